//! Progress of long work wherever it runs: a bar on a terminal; elsewhere
//! (a script, CI, a scheduler's log) a log line each time a step finishes,
//! with the count and an estimate of the time left, and one at least every
//! minute while a step runs long, so a log never falls silent.

use std::io::IsTerminal;
use std::sync::mpsc::{channel, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How long a log may go without a line while work runs.
const QUIET_AT_MOST: Duration = Duration::from_secs(60);

/// Where the log lines go (tracing's info level; a test's collector).
type Say = Arc<dyn Fn(String) + Send + Sync>;

pub struct Progress {
    bar: Option<indicatif::ProgressBar>,
    what: String,
    unit: &'static str,
    started: Instant,
    say: Say,
    /// Steps done and in all, and when a line was last given, shared with the heartbeat.
    counts: Arc<Mutex<(u64, u64, Instant)>>,
    /// Dropped to stop the heartbeat.
    stop: Option<Sender<()>>,
    heartbeat: Option<std::thread::JoinHandle<()>>,
}

impl Progress {
    /// Progress of `what` (e.g. "rendering"), counted in `unit` (e.g. "probes and paths").
    pub fn new(what: String, unit: &'static str) -> Progress {
        if std::io::stderr().is_terminal() {
            let bar = indicatif::ProgressBar::new(0).with_message(what.clone());
            let template = format!("{{msg}} {{bar:30}} {{pos}}/{{len}} {unit}, {{eta}} left");
            bar.set_style(indicatif::ProgressStyle::with_template(&template).unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()));
            let say: Say = Arc::new(|_| {});
            let counts = Arc::new(Mutex::new((0, 0, Instant::now())));
            return Progress { bar: Some(bar), what, unit, started: Instant::now(), say, counts, stop: None, heartbeat: None };
        }
        Progress::lines(what, unit, QUIET_AT_MOST, Arc::new(|line| tracing::info!("{line}")))
    }

    /// Progress as lines given to `say`, one a step and one every `every` at least.
    fn lines(what: String, unit: &'static str, every: Duration, say: Say) -> Progress {
        let started = Instant::now();
        let counts = Arc::new(Mutex::new((0, 0, started)));
        let (stop, stopped) = channel::<()>();
        let (shared, label, heartbeat_say) = (counts.clone(), what.clone(), say.clone());
        let heartbeat = std::thread::spawn(move || {
            let mut wait = every;
            while let Err(RecvTimeoutError::Timeout) = stopped.recv_timeout(wait) {
                let mut counts = shared.lock().unwrap_or_else(|e| e.into_inner());
                let quiet = counts.2.elapsed();
                // A line only where the log has been quiet for the whole interval.
                wait = if quiet >= every {
                    counts.2 = Instant::now();
                    heartbeat_say(format!("{label}: {}/{} {unit} done after {}, still at work", counts.0, counts.1, clock(started.elapsed())));
                    every
                } else {
                    every - quiet
                };
            }
        });
        Progress { bar: None, what, unit, started, say, counts, stop: Some(stop), heartbeat: Some(heartbeat) }
    }

    /// `done` of `total` steps are done.
    pub fn set(&self, done: u64, total: u64) {
        if let Some(bar) = &self.bar {
            bar.set_length(total);
            bar.set_position(done);
            return;
        }
        let mut counts = self.counts.lock().unwrap_or_else(|e| e.into_inner());
        let before = counts.0;
        (counts.0, counts.1) = (done, total);
        if done > before {
            counts.2 = Instant::now();
            let elapsed = self.started.elapsed();
            // The steps so far at their mean pace (the first ones include setting up).
            let left = elapsed.mul_f64((total - done.min(total)) as f64 / done as f64);
            (self.say)(format!("{}: {done}/{total} {} done after {}, about {} left", self.what, self.unit, clock(elapsed), clock(left)));
        }
    }
}

impl Drop for Progress {
    /// Clears the bar, or stops the heartbeat.
    fn drop(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
        drop(self.stop.take());
        if let Some(h) = self.heartbeat.take() {
            let _ = h.join();
        }
    }
}

/// A duration as people read it: "42 s", "3 min 05 s", "1 h 02 min".
fn clock(d: Duration) -> String {
    let s = d.as_secs();
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, s % 3600 / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn off_a_terminal_each_step_logs_a_line_and_a_long_step_one_at_least_every_interval() {
        let heard = Arc::new(Mutex::new(Vec::<String>::new()));
        let ear = heard.clone();
        let progress =
            Progress::lines("rendering".into(), "probes and paths", Duration::from_millis(40), Arc::new(move |l| ear.lock().unwrap().push(l)));
        progress.set(0, 3);
        progress.set(1, 3);
        std::thread::sleep(Duration::from_millis(150));
        progress.set(3, 3);
        drop(progress);
        let heard = heard.lock().unwrap();
        let steps: Vec<&String> = heard.iter().filter(|l| l.contains("left")).collect();
        assert_eq!(steps.len(), 2, "a line a finished step, none for nothing done: {heard:?}");
        assert!(steps[0].starts_with("rendering: 1/3 probes and paths done after 0 s, about 0 s left"), "{}", steps[0]);
        assert!(steps[1].starts_with("rendering: 3/3"), "{}", steps[1]);
        let beats = heard.iter().filter(|l| l.contains("1/3 probes and paths done after") && l.ends_with("still at work")).count();
        assert!(beats >= 2, "the long step is not silent: {heard:?}");
    }

    #[test]
    fn durations_read_as_seconds_minutes_or_hours() {
        assert_eq!(clock(Duration::from_millis(42_700)), "42 s");
        assert_eq!(clock(Duration::from_secs(185)), "3 min 05 s");
        assert_eq!(clock(Duration::from_secs(3720)), "1 h 02 min");
    }
}

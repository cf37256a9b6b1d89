//! The render stage: what `exploremaps render` runs on a planned bundle.
//!
//! Inputs: the bundle folder and its graph, the scene, the [`Settings`] and
//! a [`Shard`]. Steps:
//! 1. [`jobs`]: probes first, then paths, then the proxy; this shard's, less
//!    those whose files are all there (a finished file is never redone).
//! 2. One [`Renderer`] for all of them (the radiance cache is baked here).
//! 3. Each job writes its files atomically: `probe` (cube faces, tiles,
//!    panorama, thumbnail, and the depth for glides), `path` (with glides,
//!    the transition `glide` chooses; video frames, MP4, poster), `proxy` (the
//!    light 3D stand-in). A killed run loses at most the asset in progress.
//! 4. The settings and timings: graph.json's `render` entry, or a shard's
//!    manifest (`shards`, which also completes a split render).
//! 5. graph.json lists every asset whose files exist ([`list_assets`]).
//!
//! The pictures themselves come from `crate::tracer`.

pub mod glide;
mod path;
mod probe;
mod proxy;
mod shards;

pub use crate::tracer::Quality;
pub use glide::Transitions;
pub use shards::{finalize, Shard};

use crate::bundle::{write, write_graph, BundleError};
use crate::tracer::Renderer;
use exploremaps_format::record::{RenderRecord, Seconds, ShardManifest, Timings};
use exploremaps_format::Graph;
use exploremaps_scenes::Scene;
use glam::Vec3;
use probe::ProbeFiles;
use std::path::Path;
use std::time::Instant;

/// What a render makes, and how well: the tracer's settings for the quality,
/// and the render jobs' own choices.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// How each picture is traced.
    pub trace: crate::tracer::Settings,
    /// Largest cube face; smaller levels halve it down to 512.
    pub face: u32,
    /// Video frame width (height is half), a multiple of 32.
    pub video_width: u32,
    /// Denoise panoramas and thumbnails with Open Image Denoise (worth it with
    /// real bounces or few samples; the cache alone leaves little noise).
    pub denoise: bool,
    /// The light 3D stand-in written with the panoramas.
    pub proxy: crate::proxy::ProxyParams,
    /// How paths are shown: glides (with each probe's depth) or videos.
    pub transitions: Transitions,
    /// Cells a cube face edge of each probe's depth for glides.
    pub depth_cells: u32,
}

impl Settings {
    pub fn new(quality: Quality, seed: u64) -> Settings {
        let trace = crate::tracer::Settings::new(quality, seed);
        match quality {
            Quality::Preview => Settings {
                trace,
                face: 512,
                video_width: 512,
                denoise: false,
                proxy: crate::proxy::ProxyParams { bake_samples: 4, ..Default::default() },
                transitions: Transitions::Video,
                depth_cells: 32,
            },
            Quality::Final => Settings {
                trace,
                face: 2048,
                video_width: 1024,
                denoise: false,
                proxy: Default::default(),
                transitions: Transitions::Video,
                depth_cells: 128,
            },
            Quality::Tour => Settings { trace, face: 4096, ..Settings::new(Quality::Final, seed) },
        }
    }

    /// A panorama part way along a path is seen only in passing: a face half
    /// a video frame's width (twice as sharp as the frame, whose 90° are a
    /// quarter of its width).
    pub fn waypoint_face(&self) -> u32 {
        self.video_width / 2
    }

    /// How a panorama part way is traced: as the probes' panoramas, but, like
    /// video frames, without refining edges (it is seen only in passing,
    /// resampled through its depth; the refinement took a third of its time).
    pub fn waypoint_trace(&self) -> crate::tracer::TraceParams {
        crate::tracer::TraceParams { antialias: false, ..self.trace.panorama }
    }

    /// Depth cells of a panorama part way: half the probes', at least 32.
    pub fn waypoint_cells(&self) -> u32 {
        (self.depth_cells / 2).max(32)
    }

    /// Whether the render writes depth and a transition for each path.
    pub fn glides(&self) -> bool {
        self.transitions != Transitions::Video
    }

    /// Cube-face sizes from 512 (or the largest, if smaller) up to `face`.
    pub fn face_levels(&self) -> Vec<u32> {
        let mut levels = vec![self.face];
        while levels[0] > 512 && levels[0] % 2 == 0 {
            levels.insert(0, levels[0] / 2);
        }
        levels
    }
}

/// One unit of rendering, owned by one shard.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Job {
    Probe(usize),
    Path(usize),
    Proxy,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderReport {
    pub probes_rendered: usize,
    pub paths_rendered: usize,
    pub proxy_rendered: bool,
    /// Jobs of this shard whose files were all there already.
    pub skipped: usize,
    pub video_encoder: Option<String>,
    pub seconds: f64,
}

/// Every job of a bundle in order (probes, paths, the proxy), numbered as
/// shards split them: job `k` belongs to shard `k % count`.
pub fn all_jobs(graph: &Graph) -> Vec<Job> {
    let probes = (0..graph.probes.len()).map(Job::Probe);
    probes.chain((0..graph.paths.len()).map(Job::Path)).chain([Job::Proxy]).collect()
}

/// A job with its number in [`all_jobs`].
pub type Numbered = (usize, Job);

/// This shard's jobs, and those of them whose files are not all in `dir`
/// (with `glides`, probes' depth and paths' transitions are files too).
pub fn jobs(dir: &Path, graph: &Graph, levels: &[u32], glides: bool, shard: Shard) -> (Vec<Numbered>, Vec<Numbered>) {
    let exists = |name: &String| dir.join(name).exists();
    let mine: Vec<Numbered> = all_jobs(graph).into_iter().enumerate().filter(|(k, _)| k % shard.count == shard.index).collect();
    let todo = mine
        .iter()
        .copied()
        .filter(|&(_, job)| match job {
            Job::Probe(id) => !ProbeFiles::new(id, levels, glides).all().iter().all(exists),
            Job::Path(id) => !path::expected(dir, id, glides).iter().all(exists),
            Job::Proxy => proxy::listed(dir).is_none(),
        })
        .collect();
    (mine, todo)
}

/// Renders what the bundle is missing, for this shard (steps above), calling
/// `progress(done, total)` at the start and as each job ends.
pub fn render_missing(
    dir: &Path,
    scene: &Scene,
    graph: &mut Graph,
    settings: &Settings,
    shard: Shard,
    mut progress: impl FnMut(usize, usize),
) -> Result<RenderReport, BundleError> {
    let started = Instant::now();
    let abandoned = crate::files::remove_abandoned(dir);
    if abandoned > 0 {
        tracing::info!("removed {abandoned} temporary files a killed run left behind");
    }
    let levels = settings.face_levels();
    let (mine, todo) = jobs(dir, graph, &levels, settings.glides(), shard);
    let mut report = RenderReport { skipped: mine.len() - todo.len(), ..Default::default() };
    // The render also states its settings (in graph.json, or a shard's
    // manifest): a run killed after its last asset but before that file
    // leaves them to the next run.
    let split = shard.count > 1;
    let stated = if split { dir.join(shard.manifest()).exists() } else { graph.stats.render.is_some() };
    let mut timings = Timings::default();
    if !todo.is_empty() || !stated {
        let setup_started = Instant::now();
        let rays = crate::raycast::RayScene::new(&scene.positions, &scene.triangles, 0)?;
        let mut viewpoints: Vec<Vec3> = graph.probes.iter().map(|p| Vec3::from(p.position)).collect();
        viewpoints.extend(graph.paths.iter().flat_map(|p| p.camera.iter().step_by(10).map(|k| Vec3::from(k.position))));
        let renderer = Renderer::new(scene, &rays, &viewpoints, settings.trace.clone());
        let encoder = crate::video::Encoder::detect();
        report.video_encoder = Some(encoder.name());
        let seconds_setup = setup_started.elapsed().as_secs_f64();
        let run = |job: Job| -> Result<Done, BundleError> {
            Ok(match job {
                Job::Probe(id) => {
                    probe::render(dir, &renderer, settings, &graph.probes[id], id, &levels)?;
                    Done::Probe
                }
                Job::Path(id) => Done::Path(path::render(dir, &renderer, settings, &encoder, &graph.paths[id], id)?),
                Job::Proxy => {
                    proxy::render(dir, scene, graph, &renderer, &settings.proxy)?;
                    Done::Proxy
                }
            })
        };
        let jobs: Vec<Job> = todo.iter().map(|&(_, job)| job).collect();
        let done = two_at_a_time(&jobs, run, &mut progress)?;
        for (outcome, _) in &done {
            match outcome {
                Done::Probe => report.probes_rendered += 1,
                Done::Path(rendered) => report.paths_rendered += usize::from(*rendered),
                Done::Proxy => report.proxy_rendered = true,
            }
        }
        let job_seconds: Vec<f64> = done.iter().map(|d| d.1).collect();
        let record = record(settings, &renderer, &report);
        if split {
            let manifest = ShardManifest { shard: shard.index, count: shard.count, levels: levels.clone(), render: record };
            write(dir, &shard.manifest(), manifest.to_json().as_bytes())?;
        } else {
            // The renderer's set-up, which every shard repeats, and each
            // job's time by its number, for planning shards.
            let jobs: Vec<(usize, f64)> = todo.iter().map(|&(k, _)| k).zip(job_seconds).collect();
            timings.set("render", "seconds_setup", Seconds::Total(seconds_setup));
            timings.set("render", "seconds_jobs", Seconds::PerJob(jobs));
            graph.stats.render = Some(record);
        }
    }
    if !split {
        list_assets(dir, graph, &levels);
        graph.validate()?;
        write_graph(dir, graph, timings)?;
    }
    report.seconds = started.elapsed().as_secs_f64();
    Ok(report)
}

/// What a finished job did.
enum Done {
    Probe,
    /// Whether the path had anything to show.
    Path(bool),
    Proxy,
}

/// Runs the jobs, two at once (each parallel inside): one job's serial
/// stretches (encoding, writing, a path's few rays) leave the other core to
/// the other job, and two at most bound the memory (a `final` probe holds
/// about 2 GB while it renders). Results and seconds in the jobs' order; the
/// first error stops the remaining jobs. Each job writes its own files,
/// seeded by itself, so the order they finish in changes nothing written.
fn two_at_a_time<T: Send>(
    jobs: &[Job],
    run: impl Fn(Job) -> Result<T, BundleError> + Sync,
    progress: &mut (impl FnMut(usize, usize) + ?Sized),
) -> Result<Vec<(T, f64)>, BundleError> {
    let next = std::sync::atomic::AtomicUsize::new(0);
    let failed = std::sync::atomic::AtomicBool::new(false);
    let (finished, receive) = std::sync::mpsc::channel::<(usize, Result<T, BundleError>, f64)>();
    let mut results: Vec<Option<(T, f64)>> = std::iter::repeat_with(|| None).take(jobs.len()).collect();
    let mut first_error = None;
    std::thread::scope(|scope| {
        for _ in 0..2.min(jobs.len()) {
            let finished = finished.clone();
            let (next, failed, run) = (&next, &failed, &run);
            scope.spawn(move || loop {
                let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                if k >= jobs.len() || failed.load(std::sync::atomic::Ordering::Relaxed) {
                    break;
                }
                let started = Instant::now();
                let outcome = run(jobs[k]);
                failed.fetch_or(outcome.is_err(), std::sync::atomic::Ordering::Relaxed);
                if finished.send((k, outcome, started.elapsed().as_secs_f64())).is_err() {
                    break;
                }
            });
        }
        drop(finished);
        progress(0, jobs.len());
        for (count, (k, outcome, seconds)) in receive.iter().enumerate() {
            match outcome {
                Ok(t) => results[k] = Some((t, seconds)),
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
            progress(count + 1, jobs.len());
        }
    });
    match first_error {
        Some(e) => Err(e),
        None => Ok(results.into_iter().map(|r| r.expect("every job ran")).collect()),
    }
}

/// What a render was made with (a shard's manifest carries the same;
/// `finalize` checks that every shard's agree).
fn record(settings: &Settings, renderer: &Renderer, report: &RenderReport) -> RenderRecord {
    RenderRecord {
        quality: settings.trace.quality.name().to_string(),
        lighting: renderer.tracer.lighting.description.clone(),
        exposure: renderer.exposure,
        cache_cells: renderer.tracer.cache.as_ref().map(|c| c.stats.cells),
        video_encoder: report.video_encoder.clone(),
        samples_per_pixel: settings.trace.panorama.samples,
        bounces: settings.trace.panorama.bounces,
        denoised: settings.denoise,
        seed: settings.trace.seed,
        transitions: settings.glides().then(|| settings.transitions.name().to_string()),
        depth_cells: settings.glides().then_some(settings.depth_cells),
    }
}

/// Lists in graph.json every asset whose files exist.
fn list_assets(dir: &Path, graph: &mut Graph, levels: &[u32]) {
    let exists = |name: &String| dir.join(name).exists();
    for (id, probe) in graph.probes.iter_mut().enumerate() {
        let files = ProbeFiles::new(id, levels, true);
        let tiled = files.tiles.files().iter().chain([&files.tiles.preview]).all(exists);
        let ProbeFiles { cube, tiles, pano, thumb, depth, .. } = files;
        probe.assets.cube_levels = cube.into_iter().filter(|l| l.faces.iter().all(exists)).collect();
        probe.assets.tiles = tiled.then_some(tiles);
        probe.assets.equirect = exists(&pano).then_some(pano);
        probe.assets.thumbnail = exists(&thumb).then_some(thumb);
        probe.assets.depth = depth.filter(exists);
    }
    for (id, path) in graph.paths.iter_mut().enumerate() {
        let (video, poster) = path::files(id);
        path.assets.video = exists(&video).then_some(video);
        path.assets.poster = exists(&poster).then_some(poster);
        path.assets.transition = path::transition(dir, id);
    }
    graph.proxy = proxy::listed(dir);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn graph(probes: usize, paths: usize) -> Graph {
        use exploremaps_format as f;
        let scene = f::SceneInfo {
            name: "test".into(),
            source: "builtin:test".into(),
            triangles: 1,
            bounds_min: [0.0; 3],
            bounds_max: [1.0; 3],
            metres_per_unit: 1.0,
            scale_source: "file".into(),
            space: None,
            near_distance: None,
            eye_height_m: None,
            credits: Vec::new(),
        };
        let mut g = Graph::new(scene);
        g.probes = (0..probes)
            .map(|i| f::Probe {
                id: i as u32,
                position: [0.0; 3],
                cluster: None,
                preferred_directions: Vec::new(),
                user_placed: false,
                assets: f::ProbeAssets::default(),
            })
            .collect();
        g.paths = (0..paths)
            .map(|i| f::Path {
                id: i as u32,
                from: 0,
                to: 1,
                polyline: Vec::new(),
                length: 0.0,
                duration_s: 0.0,
                camera: Vec::new(),
                assets: f::PathAssets::default(),
            })
            .collect();
        g
    }

    #[test]
    fn jobs_run_two_at_a_time_give_their_results_in_order_and_stop_at_an_error() {
        let jobs: Vec<Job> = (0..40).map(Job::Probe).collect();
        let running = std::sync::atomic::AtomicUsize::new(0);
        let most = std::sync::atomic::AtomicUsize::new(0);
        let run = |job: Job| {
            let now = running.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
            most.fetch_max(now, std::sync::atomic::Ordering::SeqCst);
            std::thread::sleep(std::time::Duration::from_millis(2));
            running.fetch_sub(1, std::sync::atomic::Ordering::SeqCst);
            match job {
                Job::Probe(7) => Err(BundleError::Invalid(exploremaps_format::FormatError::Invalid("job 7".into()))),
                Job::Probe(k) => Ok(k),
                _ => unreachable!(),
            }
        };
        let mut ticks = Vec::new();
        let all = two_at_a_time(&jobs[..7], run, &mut |done, total| ticks.push((done, total))).unwrap();
        assert_eq!(all.iter().map(|r| r.0).collect::<Vec<_>>(), (0..7).collect::<Vec<_>>());
        assert_eq!(ticks, (0..=7).map(|k| (k, 7)).collect::<Vec<_>>());
        assert_eq!(most.load(std::sync::atomic::Ordering::SeqCst), 2, "two at once, never more");
        let mut count = 0;
        assert!(two_at_a_time(&jobs, run, &mut |_, _| count += 1).is_err());
        assert!(count < 1 + 40, "the jobs after the error did not all run: {count} ticks");
    }

    #[test]
    fn shards_split_the_jobs_between_them_each_job_once() {
        let g = graph(5, 7);
        let all = all_jobs(&g);
        assert_eq!(all.len(), 13);
        assert_eq!(all[4], Job::Probe(4));
        assert_eq!(all[5], Job::Path(0));
        assert_eq!(all[12], Job::Proxy);
        let dir = tempfile::tempdir().unwrap();
        let mut seen = Vec::new();
        for index in 0..3 {
            let (mine, todo) = jobs(dir.path(), &g, &[512], false, Shard { index, count: 3 });
            // Nothing is rendered yet: every job is to do.
            assert_eq!(mine, todo);
            assert!(mine.iter().all(|&(k, job)| k % 3 == index && all[k] == job));
            seen.extend(mine);
        }
        seen.sort_by_key(|&(k, _)| k);
        assert_eq!(seen.into_iter().map(|(_, job)| job).collect::<Vec<_>>(), all);
    }

    #[test]
    fn a_job_whose_files_are_all_there_is_not_redone() {
        let g = graph(2, 1);
        let dir = tempfile::tempdir().unwrap();
        let whole = Shard { index: 0, count: 1 };
        for file in ProbeFiles::new(1, &[512], false).all() {
            crate::files::write_atomic(&dir.path().join(file), b"x").unwrap();
        }
        // Only the video of path 0: its poster is missing, so it stays to do.
        crate::files::write_atomic(&dir.path().join(path::files(0).0), b"x").unwrap();
        let (mine, todo) = jobs(dir.path(), &g, &[512], false, whole);
        assert_eq!(mine.len(), 4);
        assert_eq!(todo, vec![(0, Job::Probe(0)), (2, Job::Path(0)), (3, Job::Proxy)]);
    }

    #[test]
    fn finalizing_with_a_damaged_manifest_names_it_and_writes_no_graph() {
        let mut g = graph(2, 1);
        let dir = tempfile::tempdir().unwrap();
        crate::files::write_atomic(&dir.path().join("shards/1-of-2.json"), b"{\"shard\": 1, \"count\":").unwrap();
        let e = exploremaps_format::error_chain(&shards::finalize(dir.path(), &mut g).unwrap_err());
        assert!(e.contains("1-of-2.json: not a shard manifest") && e.contains("run its shard again"), "{e}");
        assert!(!dir.path().join(exploremaps_format::GRAPH_FILE).exists());
    }
}

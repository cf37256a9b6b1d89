//! Transition videos: rendered frames to fast-start H.264 MP4 without
//! B-frames (browsers and phones decode it in hardware; the openh264 decoder
//! the native viewer uses needs frames in display order).
//!
//! Encoders: Debian's ffmpeg with libx264 when it is on the PATH (about 1.8×
//! smaller files), otherwise openh264, built in. Both write BT.601
//! limited-range YUV 4:2:0 and say so in the stream. `EXPLOREMAPS_ENCODER=
//! openh264|ffmpeg` forces one.

use image::RgbImage;
use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Stdio};

mod spherical;

/// Seconds between key frames: players seek, and play backwards, a key-frame
/// interval at a time (a path's only key frame at its start made each
/// backward step in Chromium decode up to the whole path: 163 ms a seek on a
/// 1024×512 gallery path, against 35 ms with one a second, for 7 % more bytes).
pub const KEY_FRAME_INTERVAL_S: f32 = 1.0;

/// libx264's preset. On 200 frames of a gallery path (1024 × 512, CRF 20)
/// against `medium`: `faster` encodes 2.1× as fast for 3 % more bytes and
/// 0.2 dB less PSNR, `veryfast` 2.9× for 6 % and 0.6 dB. At `medium`
/// encoding took about a seventh of a final bundle's video time.
const X264_PRESET: &str = "faster";

fn key_frame_interval(fps: f32) -> u32 {
    (fps * KEY_FRAME_INTERVAL_S).round().max(1.0) as u32
}

#[derive(Debug, thiserror::Error)]
pub enum VideoError {
    #[error("no frames to encode")]
    Empty,
    #[error("frames must all be {0}×{1}, multiples of 16 and at most 4096 wide")]
    Size(u32, u32),
    #[error("openh264: {0}")]
    OpenH264(String),
    #[error("MP4 muxing: {0}")]
    Mux(String),
    #[error("ffmpeg failed: {0}")]
    Ffmpeg(String),
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Encoder {
    /// An ffmpeg binary with libx264.
    Ffmpeg(PathBuf),
    OpenH264,
}

impl Encoder {
    /// ffmpeg with libx264 if it is on the PATH, else openh264.
    pub fn detect() -> Encoder {
        match std::env::var("EXPLOREMAPS_ENCODER").as_deref() {
            Ok("openh264") => return Encoder::OpenH264,
            Ok("ffmpeg") => return Encoder::Ffmpeg("ffmpeg".into()),
            _ => {}
        }
        let has_x264 = Command::new("ffmpeg")
            .args(["-hide_banner", "-encoders"])
            .stderr(Stdio::null())
            .output()
            .is_ok_and(|o| o.status.success() && String::from_utf8_lossy(&o.stdout).contains("libx264"));
        if has_x264 {
            Encoder::Ffmpeg("ffmpeg".into())
        } else {
            Encoder::OpenH264
        }
    }

    pub fn name(&self) -> String {
        match self {
            Encoder::Ffmpeg(_) => "ffmpeg libx264".into(),
            Encoder::OpenH264 => "openh264".into(),
        }
    }

    /// The frames as an MP4 file at `fps` frames a second.
    pub fn encode(&self, frames: &[RgbImage], fps: f32) -> Result<Vec<u8>, VideoError> {
        let mut stream = self.stream(fps);
        for frame in frames {
            stream.push(frame)?;
        }
        stream.finish()
    }

    /// An MP4 at `fps` frames a second, encoded as its frames are handed
    /// over ([`Stream::push`]).
    pub fn stream(&self, fps: f32) -> Stream {
        let kind = match self {
            Encoder::Ffmpeg(program) => Kind::Ffmpeg(program.clone(), None),
            Encoder::OpenH264 => Kind::Held(Vec::new()),
        };
        Stream { fps, size: None, kind }
    }
}

/// A video being encoded. With ffmpeg each frame goes to libx264 as it comes,
/// so a path's frames are encoded while the next ones render (in the cores'
/// idle moments; the encoding had waited for the last frame, a tenth of a
/// path's time) and are not all held at once; openh264 encodes at the end.
pub struct Stream {
    fps: f32,
    /// The frames' size, once one has been taken.
    size: Option<(u32, u32)>,
    kind: Kind,
}

enum Kind {
    /// The program, and once the first frame has come its running process.
    Ffmpeg(PathBuf, Option<Ffmpeg>),
    Held(Vec<RgbImage>),
}

/// A running ffmpeg writing into its own temporary directory.
struct Ffmpeg {
    child: std::process::Child,
    stdin: Option<std::process::ChildStdin>,
    dir: tempfile::TempDir,
}

impl Drop for Ffmpeg {
    /// An abandoned encoding (an error elsewhere) leaves no process behind.
    fn drop(&mut self) {
        drop(self.stdin.take());
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Stream {
    /// Adds the next frame; all must be the first's size, a multiple of 16
    /// and at most 4096 wide.
    pub fn push(&mut self, frame: &RgbImage) -> Result<(), VideoError> {
        let (w, h) = frame.dimensions();
        if w % 16 != 0 || h % 16 != 0 || w > 4096 || self.size.is_some_and(|s| s != (w, h)) {
            return Err(VideoError::Size(w, h));
        }
        // Set before anything can fail: a stream whose ffmpeg failed to
        // start or stopped stays failed (no second ffmpeg).
        let earlier = self.size.replace((w, h)).is_some();
        match &mut self.kind {
            Kind::Held(frames) => frames.push(frame.clone()),
            Kind::Ffmpeg(program, running) => {
                if running.is_none() {
                    if earlier {
                        return Err(stopped());
                    }
                    *running = Some(start_ffmpeg(program, (w, h), self.fps)?);
                }
                let ffmpeg = running.as_mut().expect("started");
                let stdin = ffmpeg.stdin.as_mut().expect("open until finish");
                if stdin.write_all(frame.as_raw()).is_err() {
                    // ffmpeg has stopped: its own words say why.
                    let mut ffmpeg = running.take().expect("started");
                    drop(ffmpeg.stdin.take());
                    return Err(ffmpeg_failed(&mut ffmpeg));
                }
            }
        }
        Ok(())
    }

    /// The MP4 file, marked as a mono equirectangular 360° video.
    pub fn finish(mut self) -> Result<Vec<u8>, VideoError> {
        if self.size.is_none() {
            return Err(VideoError::Empty);
        }
        let mp4 = match &mut self.kind {
            Kind::Held(frames) => openh264(frames, self.fps),
            Kind::Ffmpeg(_, running) => {
                let mut ffmpeg = running.take().ok_or_else(stopped)?;
                drop(ffmpeg.stdin.take());
                let out = ffmpeg.dir.path().join(VIDEO_FILE);
                match ffmpeg.child.wait() {
                    Ok(status) if status.success() => std::fs::read(&out).map_err(|e| VideoError::Ffmpeg(e.to_string())),
                    _ => Err(ffmpeg_failed(&mut ffmpeg)),
                }
            }
        }?;
        spherical::tag(mp4).map_err(|e| VideoError::Mux(e.to_string()))
    }
}

/// A stream whose ffmpeg failed at an earlier frame (that error said why).
fn stopped() -> VideoError {
    VideoError::Ffmpeg("ffmpeg stopped at an earlier frame".into())
}

/// ffmpeg's output file and error output in its temporary directory.
const VIDEO_FILE: &str = "video.mp4";
const LOG_FILE: &str = "ffmpeg.log";

fn openh264(frames: &[RgbImage], fps: f32) -> Result<Vec<u8>, VideoError> {
    use openh264::encoder::{EncoderConfig, FrameType, IntraFramePeriod, QpRange, RateControlMode, VuiConfig};
    use openh264::formats::{RgbSliceU8, YUVBuffer};
    let (w, h) = frames[0].dimensions();
    let err = |e: openh264::Error| VideoError::OpenH264(e.to_string());
    // Constant quality (QP 20-24 gives about 40 dB on rendered frames), every frame kept,
    // a key frame every KEY_FRAME_INTERVAL_S and none elsewhere.
    let config = EncoderConfig::new()
        .rate_control_mode(RateControlMode::Off)
        .qp(QpRange::new(20, 24))
        .skip_frames(false)
        .max_frame_rate(openh264::encoder::FrameRate::from_hz(fps))
        .intra_frame_period(IntraFramePeriod::from_num_frames(key_frame_interval(fps)))
        .scene_change_detect(false)
        .vui(VuiConfig::bt601());
    let mut encoder = openh264::encoder::Encoder::with_api_config(openh264::OpenH264API::from_source(), config).map_err(err)?;
    let mut out = Vec::new();
    let mut muxer = muxide::api::MuxerBuilder::new(&mut out)
        .video(muxide::api::VideoCodec::H264, w, h, f64::from(fps))
        .with_fast_start(true)
        .build()
        .map_err(|e| VideoError::Mux(e.to_string()))?;
    for (i, frame) in frames.iter().enumerate() {
        let yuv = YUVBuffer::from_rgb8_source(RgbSliceU8::new(frame.as_raw(), (w as usize, h as usize)));
        let stream = encoder.encode(&yuv).map_err(err)?;
        let key = matches!(stream.frame_type(), FrameType::IDR | FrameType::I);
        muxer.write_video(i as f64 / f64::from(fps), &stream.to_vec(), key).map_err(|e| VideoError::Mux(e.to_string()))?;
    }
    muxer.finish().map_err(|e| VideoError::Mux(e.to_string()))?;
    Ok(out)
}

fn start_ffmpeg(program: &PathBuf, (w, h): (u32, u32), fps: f32) -> Result<Ffmpeg, VideoError> {
    let key = key_frame_interval(fps).to_string();
    let dir = tempfile::tempdir().map_err(|e| VideoError::Ffmpeg(e.to_string()))?;
    let mut child = Command::new(program)
        .args([
            "-hide_banner",
            "-loglevel",
            "error",
            "-f",
            "rawvideo",
            "-pix_fmt",
            "rgb24",
            "-s",
            &format!("{w}x{h}"),
            "-r",
            &fps.to_string(),
            "-i",
            "-",
        ])
        .args(["-c:v", "libx264", "-preset", X264_PRESET, "-crf", "20", "-bf", "0", "-pix_fmt", "yuv420p"])
        .args(["-g", &key, "-keyint_min", &key, "-sc_threshold", "0"])
        .args(["-colorspace", "smpte170m", "-color_primaries", "smpte170m", "-color_trc", "smpte170m", "-color_range", "tv"])
        .args(["-movflags", "+faststart", "-y"])
        .arg(dir.path().join(VIDEO_FILE))
        .stdin(Stdio::piped())
        // A file, not a pipe: nothing reads it until ffmpeg has stopped.
        .stderr(std::fs::File::create(dir.path().join(LOG_FILE)).map_err(|e| VideoError::Ffmpeg(e.to_string()))?)
        .spawn()
        .map_err(|e| VideoError::Ffmpeg(format!("cannot start {}: {e}", program.display())))?;
    let stdin = child.stdin.take();
    Ok(Ffmpeg { child, stdin, dir })
}

/// Why ffmpeg failed, from what it wrote to its error output.
fn ffmpeg_failed(ffmpeg: &mut Ffmpeg) -> VideoError {
    let status = ffmpeg.child.wait().map_or_else(|e| e.to_string(), |s| s.to_string());
    let log = std::fs::read_to_string(ffmpeg.dir.path().join(LOG_FILE)).unwrap_or_default();
    VideoError::Ffmpeg(format!("{status}: {}", log.trim()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracer::{psnr, Quality, Renderer, Settings};
    use exploremaps_format::video::{decode_mp4, Mp4Decoder};
    use glam::Vec3;

    /// Frames of a walk through a lit room, as the bundle renders them.
    fn frames(count: usize) -> Vec<RgbImage> {
        let scene = crate::testing::pillar_room(0.6);
        let rays = crate::raycast::RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let eyes: Vec<Vec3> = (0..count).map(|i| Vec3::new(1.5 + 0.1 * i as f32, 1.5, 2.0)).collect();
        let renderer = Renderer::new(&scene, &rays, &eyes, Settings::new(Quality::Preview, 1));
        eyes.iter()
            .enumerate()
            .map(|(i, &e)| renderer.to_image(256, 128, &renderer.equirect(&renderer.settings.video, e, 256, i as u64).color))
            .collect()
    }

    fn round_trip(encoder: Encoder) {
        let frames = frames(12);
        // At 5 fps: a key frame every 5 frames.
        let mp4 = encoder.encode(&frames, 5.0).unwrap();
        // Fast start: the movie header comes before the media data.
        let moov = mp4.windows(4).position(|w| w == b"moov").unwrap();
        let mdat = mp4.windows(4).position(|w| w == b"mdat").unwrap();
        assert!(moov < mdat, "{}: moov at {moov}, mdat at {mdat}", encoder.name());
        let decoded: Vec<RgbImage> =
            decode_mp4(mp4.clone()).unwrap().into_iter().map(|f| RgbImage::from_raw(f.width, f.height, f.rgb).unwrap()).collect();
        assert_eq!(decoded.len(), frames.len(), "{}: every frame comes back", encoder.name());
        let mut worst = f64::INFINITY;
        for (i, (a, b)) in frames.iter().zip(&decoded).enumerate() {
            let db = psnr(a, b);
            assert!(db >= 38.0, "{}: frame {i} at {db:.1} dB", encoder.name());
            worst = worst.min(db);
        }
        eprintln!("{}: {} frames, {} bytes, worst frame {worst:.1} dB", encoder.name(), frames.len(), mp4.len());
        spherical_metadata_is_seen(encoder.name(), &mp4);
        // Key frames where asked and nowhere else; decoding from one gives the
        // same frames as decoding from the start (how players go backwards).
        let mut decoder = Mp4Decoder::new(mp4).unwrap();
        assert_eq!(decoder.key_frames(), [0, 5, 10], "{}", encoder.name());
        decoder.seek(5).unwrap();
        for (i, expected) in decoded.iter().enumerate().skip(5) {
            let f = decoder.next_frame().unwrap().unwrap();
            assert!(f.rgb == expected.as_raw().as_slice(), "{}: frame {i} after a seek differs", encoder.name());
        }
        assert!(decoder.next_frame().unwrap().is_none());
        assert!(decoder.seek(3).is_err(), "not a key frame");
    }

    /// ffprobe (where it is installed) reads the video as 360°: mono, equirectangular.
    fn spherical_metadata_is_seen(name: String, mp4: &[u8]) {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("v.mp4");
        std::fs::write(&file, mp4).unwrap();
        let Ok(probe) = Command::new("ffprobe").args(["-v", "error", "-show_streams", "-of", "json"]).arg(&file).output() else {
            return eprintln!("SKIPPED: no ffprobe on the PATH");
        };
        let report = String::from_utf8_lossy(&probe.stdout);
        assert!(probe.status.success() && report.contains("\"Spherical Mapping\"") && report.contains("\"equirectangular\""), "{name}: {report}");
        assert!(report.contains("\"Stereo 3D\"") && report.contains("\"2D\""), "{name}: mono: {report}");
        assert_eq!(spherical::tag(mp4.to_vec()).unwrap(), mp4, "{name}: tagged once");
    }

    #[test]
    fn openh264_round_trip_keeps_every_frame_above_38_db() {
        round_trip(Encoder::OpenH264);
    }

    #[test]
    fn ffmpeg_round_trip_keeps_every_frame_above_38_db() {
        match Encoder::detect() {
            Encoder::OpenH264 => eprintln!("SKIPPED: no ffmpeg with libx264 on the PATH"),
            ffmpeg => round_trip(ffmpeg),
        }
    }

    #[test]
    fn a_failing_or_missing_encoder_is_an_error() {
        let frames = vec![RgbImage::new(64, 32); 3];
        // `false` reads nothing and exits at once: the frames go nowhere, and no file comes.
        let r = Encoder::Ffmpeg("false".into()).encode(&frames, 25.0);
        assert!(matches!(&r, Err(VideoError::Ffmpeg(m)) if m.contains("exit status")), "{r:?}");
        let r = Encoder::Ffmpeg("/nonexistent/ffmpeg".into()).encode(&frames, 25.0);
        assert!(matches!(&r, Err(VideoError::Ffmpeg(m)) if m.contains("cannot start")), "{r:?}");
        // One that cannot start is not tried again at the next frame.
        let mut stream = Encoder::Ffmpeg("/nonexistent/ffmpeg".into()).stream(25.0);
        assert!(matches!(stream.push(&frames[0]), Err(VideoError::Ffmpeg(m)) if m.contains("cannot start")));
        assert!(matches!(stream.push(&frames[0]), Err(VideoError::Ffmpeg(m)) if m.contains("earlier frame")));
        // After a failure the stream stays failed: no second ffmpeg, no panic.
        let mut stream = Encoder::Ffmpeg("false".into()).stream(25.0);
        let big = RgbImage::new(1024, 512);
        let first_error = (0..8).find_map(|_| stream.push(&big).err());
        assert!(matches!(&first_error, Some(VideoError::Ffmpeg(_))), "{first_error:?}");
        assert!(matches!(stream.push(&big), Err(VideoError::Ffmpeg(m)) if m.contains("earlier frame")));
        assert!(matches!(stream.finish(), Err(VideoError::Ffmpeg(_))));
        // A frame of another size than the first is refused as it comes.
        let mut stream = Encoder::OpenH264.stream(25.0);
        stream.push(&RgbImage::new(64, 32)).unwrap();
        assert!(matches!(stream.push(&RgbImage::new(32, 32)), Err(VideoError::Size(32, 32))));
    }

    #[test]
    fn bad_frame_sizes_are_refused() {
        let odd = vec![RgbImage::new(100, 50)];
        assert!(matches!(Encoder::OpenH264.encode(&odd, 25.0), Err(VideoError::Size(100, 50))));
        assert!(matches!(Encoder::OpenH264.encode(&[], 25.0), Err(VideoError::Empty)));
        assert!(decode_mp4(b"not an mp4 at all".to_vec()).is_err());
    }
}

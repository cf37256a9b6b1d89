//! A path's job: its 360° frames along the camera keys (key frames lit in
//! full, the frames between reusing their light), encoded as an MP4, and a
//! poster (the first frame).

use super::Settings;
use crate::bundle::{write, BundleError};
use crate::files::jpeg;
use crate::tracer::Renderer;
use crate::video::Encoder;
use exploremaps_format::Path as PathInfo;
use glam::Vec3;
use std::ops::ControlFlow;
use std::path::Path;

/// The video's and the poster's file names.
pub(super) fn files(id: usize) -> (String, String) {
    (format!("paths/{id}.mp4"), format!("paths/{id}.jpg"))
}

/// Renders path `id`, encodes and writes its files. A path without camera
/// keys has nothing to show: false, and no files.
pub(super) fn render(
    dir: &Path,
    renderer: &Renderer,
    settings: &Settings,
    encoder: &Encoder,
    path: &PathInfo,
    id: usize,
) -> Result<bool, BundleError> {
    let (video, poster) = files(id);
    let w = settings.video_width;
    let eyes: Vec<Vec3> = path.camera.iter().map(|key| Vec3::from(key.position)).collect();
    // Each frame goes to the encoder as it is rendered; the first is the poster too.
    let mut stream = encoder.stream(crate::plan::smooth::FPS);
    let (mut first, mut failed) = (None, None);
    renderer.path_frames(&settings.trace.video, &eyes, w, crate::seeds::image::video(id as u32), settings.trace.video_keys, |_, frame| {
        let image = renderer.to_image(w, w / 2, &frame.color);
        failed = stream.push(&image).err();
        first.get_or_insert(image);
        // No more frames once the encoder has failed: the path errs anyway.
        if failed.is_some() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    let Some(first) = first else { return Ok(false) };
    let video_error = |e| BundleError::Video { path: dir.join(&video).display().to_string(), source: e };
    if let Some(e) = failed {
        return Err(video_error(e));
    }
    let mp4 = stream.finish().map_err(video_error)?;
    write(dir, &poster, &jpeg(&first, 85))?;
    write(dir, &video, &mp4)?;
    Ok(true)
}

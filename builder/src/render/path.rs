//! A path's job: with glides, the transition `glide` chooses, written as a
//! record (`paths/<id>.json`) once the path is done; where it is a glide in
//! legs, the panoramas part way (a cube level and a depth cube each); where
//! it is a video (and always without glides), its 360° frames along the camera keys (key frames
//! lit in full, the frames between reusing their light), encoded as an MP4,
//! and a poster (the first frame).

use super::probe::{traced_cube, write_jpegs};
use super::{glide, Settings};
use crate::bundle::{write, BundleError};
use crate::files::jpeg;
use crate::tracer::Renderer;
use crate::video::Encoder;
use exploremaps_format::{CubeLevel, Path as PathInfo, Transition, TransitionKind, Waypoint, CUBE_FACES};
use glam::Vec3;
use std::ops::ControlFlow;
use std::path::Path;

/// JPEG quality of a panorama part way: seen only in passing, as a video's
/// frames are (a probe's faces: 90).
const WAYPOINT_QUALITY: u8 = 75;

/// The video's and the poster's file names.
pub(super) fn files(id: usize) -> (String, String) {
    (format!("paths/{id}.mp4"), format!("paths/{id}.jpg"))
}

/// The record of the transition chosen for path `id`.
fn record(id: usize) -> String {
    format!("paths/{id}.json")
}

/// Path `id`'s transition, if its record is there and reads.
pub(super) fn transition(dir: &Path, id: usize) -> Option<Transition> {
    serde_json::from_slice(&std::fs::read(dir.join(record(id))).ok()?).ok()
}

/// The files a finished path `id` has: its video and poster; with glides,
/// its record, and the video and poster only where the record says video.
pub(super) fn expected(dir: &Path, id: usize, glides: bool) -> Vec<String> {
    let (video, poster) = files(id);
    if !glides {
        return vec![video, poster];
    }
    match transition(dir, id) {
        Some(t) if t.kind == TransitionKind::Video => vec![video, poster, record(id)],
        Some(t) => t.waypoints.into_iter().flat_map(|w| w.cube.faces.into_iter().chain([w.depth])).chain([record(id)]).collect(),
        None => vec![record(id)],
    }
}

/// Renders path `id`: with glides, chooses its transition and writes its
/// record last; renders its video where that is a video (always without
/// glides). A path without camera keys has nothing to show: false, and no
/// files.
pub(super) fn render(
    dir: &Path,
    renderer: &Renderer,
    settings: &Settings,
    encoder: &Encoder,
    path: &PathInfo,
    id: usize,
) -> Result<bool, BundleError> {
    if path.camera.is_empty() {
        return Ok(false);
    }
    let ends = (path.polyline.first().copied().unwrap_or_default().into(), path.polyline.last().copied().unwrap_or_default().into());
    let legs = if settings.glides() { glide::plan_legs(&renderer.tracer, path, ends, glide::MAX_WAYPOINTS) } else { glide::Legs::default() };
    let mut transition = glide::choose(settings.transitions, &legs);
    if let Some(t) = &mut transition {
        tracing::info!("path {id}: {}", t.reason);
        if t.kind == TransitionKind::Depth {
            t.waypoints = legs.waypoints.iter().map(|&key| render_waypoint(dir, renderer, settings, path, (id, key))).collect::<Result<_, _>>()?;
        }
    }
    if transition.as_ref().is_none_or(|t| t.kind == TransitionKind::Video) && !render_video(dir, renderer, settings, encoder, path, id)? {
        return Ok(false);
    }
    if let Some(t) = transition {
        write(dir, &record(id), serde_json::to_string(&t).expect("a transition serializes").as_bytes())?;
    }
    Ok(true)
}

/// Renders the panorama part way along path `id` at camera key `key`: a
/// cube as sharp as a video's frames and a depth cube.
fn render_waypoint(
    dir: &Path,
    renderer: &Renderer,
    settings: &Settings,
    path: &PathInfo,
    (id, key): (usize, usize),
) -> Result<Waypoint, BundleError> {
    let size = settings.waypoint_face();
    let position = path.camera[key].position;
    let cube = CubeLevel { size, faces: CUBE_FACES.map(|f| format!("paths/{id}/{key}_{f}.jpg")) };
    let depth = format!("paths/{id}/{key}.emdc");
    let eye = Vec3::from(position);
    write(dir, &depth, &glide::depth_cube(&renderer.tracer, eye, settings.waypoint_cells()).encode())?;
    let k = key as u32;
    let faces =
        traced_cube(dir, (renderer, &settings.waypoint_trace()), settings, (eye, size), crate::seeds::image::waypoint(id as u32, k), &cube.faces[0])?;
    let images: Vec<image::RgbImage> = faces.iter().map(|f| renderer.to_image(size, size, f)).collect();
    write_jpegs(dir, &cube.faces.iter().map(String::as_str).zip(&images).collect::<Vec<_>>(), WAYPOINT_QUALITY)?;
    Ok(Waypoint { key: k, position, cube, depth })
}

/// Renders path `id`'s video, encodes and writes it and its poster.
fn render_video(dir: &Path, renderer: &Renderer, settings: &Settings, encoder: &Encoder, path: &PathInfo, id: usize) -> Result<bool, BundleError> {
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

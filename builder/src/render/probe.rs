//! A probe's job: its cube faces at every level (512 up to the largest),
//! the tour tiles cut from them, a photo-sphere panorama resampled from the
//! largest faces, a thumbnail in its preferred direction and, with glides,
//! its depth cube.

use super::Settings;
use crate::bundle::{write, BundleError};
use crate::files::jpeg;
use crate::tracer::{denoise, downsample, equirect_from_cube, photo_sphere_jpeg, Frame, Perspective, Renderer, TraceParams};
use exploremaps_format::{CubeLevel, Probe, Tiles, CUBE_FACES};
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

/// Tour tiles are 512 pixels, as tour viewers' are; the preview strip's
/// faces 256 (or the face, if smaller).
const TILE: u32 = 512;
const TILE_PREVIEW: u32 = 256;
/// JPEG quality of faces, tiles and the panorama (thumbnails: 85).
const QUALITY: u8 = 90;

/// File names of a probe's assets.
pub(super) struct ProbeFiles {
    /// Cube faces per level.
    pub cube: Vec<CubeLevel>,
    pub tiles: Tiles,
    pub pano: String,
    pub thumb: String,
    /// With glides.
    pub depth: Option<String>,
}

impl ProbeFiles {
    pub fn new(id: usize, levels: &[u32], glides: bool) -> ProbeFiles {
        let cube = levels.iter().map(|&size| CubeLevel { size, faces: CUBE_FACES.map(|f| format!("probes/{id}/{size}_{f}.jpg")) }).collect();
        let face = levels.last().copied().unwrap_or(TILE);
        let tiles = Tiles::new(format!("probes/{id}/tiles"), face, TILE, TILE_PREVIEW.min(face));
        let depth = glides.then(|| format!("probes/{id}/depth.emdc"));
        ProbeFiles { cube, tiles, pano: format!("probes/{id}/pano.jpg"), thumb: format!("thumbs/{id}.jpg"), depth }
    }

    /// The levels written as whole faces: the smallest only, which the
    /// viewer shows first. The sharper ones are in the tiles alone (every
    /// reader of a bundle, the viewer and the tour export, takes them so):
    /// one copy of each panorama.
    pub fn face_levels(&self) -> &[CubeLevel] {
        &self.cube[..self.cube.len().min(1)]
    }

    /// Every file: the faces written, the tiles and their preview.
    pub fn all(&self) -> Vec<String> {
        let faces = self.face_levels().iter().flat_map(|l| l.faces.iter().cloned());
        let others = [self.tiles.preview.clone(), self.pano.clone(), self.thumb.clone()];
        faces.chain(self.tiles.files()).chain(others).chain(self.depth.clone()).collect()
    }
}

/// Encodes the images on every core (serially they took a tenth of a
/// probe's time, one core idle) and writes each to its file.
pub(super) fn write_jpegs(dir: &Path, images: &[(&str, &image::RgbImage)], quality: u8) -> Result<(), BundleError> {
    images.par_iter().try_for_each(|(name, image)| write(dir, name, &jpeg(image, quality)))
}

/// The frame's colours, denoised where the settings say (errors name `file`).
fn denoised(dir: &Path, settings: &Settings, mut frame: Frame, file: &str) -> Result<Vec<Vec3>, BundleError> {
    if settings.denoise {
        denoise(&mut frame).map_err(|source| BundleError::Denoise { path: dir.join(file).display().to_string(), source })?;
    }
    Ok(frame.color)
}

/// The six faces of the cube seen from `eye`, `size` pixels square, traced
/// with `params` from the stream of `image` (errors name `file`).
pub(super) fn traced_cube(
    dir: &Path,
    (renderer, params): (&Renderer, &TraceParams),
    settings: &Settings,
    (eye, size): (Vec3, u32),
    image: u64,
    file: &str,
) -> Result<Vec<Vec<Vec3>>, BundleError> {
    renderer.cube(params, eye, size, image).into_iter().map(|f| denoised(dir, settings, f, file)).collect()
}

/// Renders probe `id` and writes its files; files already there are kept.
pub(super) fn render(dir: &Path, renderer: &Renderer, settings: &Settings, probe: &Probe, id: usize, levels: &[u32]) -> Result<(), BundleError> {
    let exists = |name: &str| dir.join(name).exists();
    let eye = Vec3::from(probe.position);
    let files = ProbeFiles::new(id, levels, settings.glides());
    let written = files.face_levels().len();
    let ProbeFiles { cube, tiles, pano, thumb, depth, .. } = files;
    if let Some(depth) = depth.filter(|d| !exists(d)) {
        write(dir, &depth, &super::glide::depth_cube(&renderer.tracer, eye, settings.depth_cells).encode())?;
    }
    let denoised = |f: Frame| denoised(dir, settings, f, &pano);
    let mut faces =
        traced_cube(dir, (renderer, &settings.trace.panorama), settings, (eye, settings.face), crate::seeds::image::cube(id as u32), &pano)?;
    let full = faces.clone();
    // Levels from the largest down, each box-filtered from the one above.
    let mut images = Vec::with_capacity(cube.len());
    for level in cube.iter().rev() {
        if faces.len() == 6 && level.size < settings.face {
            faces = faces.iter().map(|f| downsample(level.size * 2, f)).collect();
        }
        let level_images: Vec<image::RgbImage> = faces.iter().map(|face| renderer.to_image(level.size, level.size, face)).collect();
        let written = cube.iter().position(|l| l.size == level.size).is_some_and(|i| i < written);
        let missing: Vec<(&str, &image::RgbImage)> =
            level.faces.iter().zip(&level_images).filter(|(name, _)| written && !exists(name)).map(|(name, image)| (name.as_str(), image)).collect();
        write_jpegs(dir, &missing, QUALITY)?;
        images.push((level.size, level_images));
    }
    let mut cut = Vec::new();
    crate::tiles::cut(&tiles, &images, |name, tile| {
        if !exists(name) {
            cut.push((name.to_string(), tile));
        }
        Ok::<(), BundleError>(())
    })?;
    write_jpegs(dir, &cut.iter().map(|(name, tile)| (name.as_str(), tile)).collect::<Vec<_>>(), QUALITY)?;
    // The photo sphere keeps the sharpest faces' detail: two faces wide.
    let pano_width = (2 * settings.face).max(1024);
    let equirect = equirect_from_cube(&full, settings.face, pano_width);
    write(dir, &pano, &photo_sphere_jpeg(&renderer.to_image(pano_width, pano_width / 2, &equirect), QUALITY))?;
    let (yaw, pitch) = probe.preferred_directions.first().map_or((0.0, 0.0), |d| (d.yaw, d.pitch));
    let view = denoised(renderer.perspective(
        &settings.trace.panorama,
        Perspective { eye, yaw, pitch, fov_y: 1.0 },
        320,
        180,
        crate::seeds::image::thumbnail(id as u32),
    ))?;
    write(dir, &thumb, &jpeg(&renderer.to_image(320, 180, &view), 85))
}

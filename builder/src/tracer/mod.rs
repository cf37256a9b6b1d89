//! The renderer: panoramas, thumbnails and video frames, path traced on
//! Embree (the render stage, `crate::render`, decides what to render).
//!
//! Inputs: the scene, its ray-casting structure, and the viewpoints (probe
//! positions and camera paths) the bundle will be seen from. Outputs: linear
//! frames ([`Frame`]) and their tone-mapped sRGB images: cube-map faces, an
//! equirectangular panorama resampled from them, perspective thumbnails.
//!
//! - `surface`: materials (textures, cut-outs, emission) and lights (scene
//!   lights, or a default sun and sky, or ceiling lights in a closed scene).
//! - `cache`: indirect light baked once per scene on hashed surface cells and
//!   solved for all bounces; every panorama and video frame reuses it.
//! - `trace`: the path tracer (packets, next-event estimation, Russian
//!   roulette, the cache after `bounces` real bounces).
//! - `lights`: the reference's light sampling (emissive triangles, sunlit
//!   points) weighed against bounces by multiple importance sampling.
//! - `gather`: `final`'s indirect light: a final gather on a grid coarser
//!   than the pixels (one real bounce, the cache at the second hit), filtered
//!   across surfaces and upsampled by geometry.
//! - `reuse`: video frames between key frames take the keys' lighting,
//!   reprojected by geometry.
//!
//! `preview` looks the cache up at the first hit (one sample through each
//! pixel centre): cheap, but its cells show as soft blotches on plain walls.
//! `final` gathers instead (no blotches; the sunroom ceiling test), antialiases
//! panoramas adaptively (one sample through each pixel centre, four more
//! where a pixel differs from a neighbour) and samples point lights exactly. A real bounce
//! at every pixel (`TraceParams::bounces`) cost 173 s for a 6×2048² cube at
//! 16 samples on the Crytek Sponza. Without a cache the tracer is a plain
//! path tracer (the furnace test and the benches' references).

mod cache;
mod denoise;
mod gather;
mod lights;
mod reuse;
mod surface;
mod trace;

pub use cache::{CacheParams, CacheStats, RadianceCache};
pub use denoise::{denoise, DenoiseError};
pub use gather::GatherParams;
pub use surface::{fibonacci_sphere, Lighting, Materials, Sky, DEFAULT_SUN, SUN_RADIUS};
use trace::Shot;
pub use trace::{Frame, TraceParams, Tracer};

use crate::colour::linear_to_srgb;
use crate::raycast::RayScene;
use exploremaps_format::{cube_direction, cube_face_of, direction};
use exploremaps_scenes::Scene;
use glam::Vec3;
use image::RgbImage;
use rayon::prelude::*;
use std::ops::ControlFlow;

/// How much work a render puts in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    /// Quick look: one sample a pixel, 512 faces, 512-wide videos.
    Preview,
    /// Deliverable: final-gathered indirect light, antialiased panoramas,
    /// 512/1024/2048 faces, 1024-wide videos.
    Final,
    /// As final with 4096 faces, the size tour sites publish (four times the
    /// render time of final's panoramas).
    Tour,
}

impl Quality {
    pub fn name(self) -> &'static str {
        match self {
            Quality::Preview => "preview",
            Quality::Final => "final",
            Quality::Tour => "tour",
        }
    }
}

/// How a quality traces its images: samples, bounces, the radiance cache,
/// and how video frames reuse lighting (what to render is the render stage's
/// `render::Settings`).
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub quality: Quality,
    /// Panoramas and thumbnails.
    pub panorama: TraceParams,
    /// Transition-video frames.
    pub video: TraceParams,
    /// Cache cell edge in metres (converted through the scene's unit scale).
    pub cell_m: f32,
    pub gather_rays: usize,
    pub max_cells: usize,
    /// Frames from one video key frame to the next; the frames between reuse
    /// the keys' lighting ([`Renderer::path_frames`]); 1 renders every frame in full.
    /// `final` takes 32, with 16 rays at every pixel of a key: on the
    /// quality bench, the frame farthest from both keys scores about the
    /// same FLIP as at 24 (Crytek Sponza 0.0777 against 0.0772) for fewer
    /// keys to gather; the trials are in docs/RENDER_QUALITY.md.
    pub video_keys: u32,
    pub seed: u64,
}

/// Shadow rays toward the sun at each first hit in `final` (stratified over
/// its disk): one left soft shadow edges speckled at two samples a pixel.
/// Test `several_sun_rays_smooth_a_soft_shadow_edge`: the penumbra's error
/// is 0.36 of its light with one ray, 0.14 with four, 0.07 with eight. A
/// panorama's time, one / four / eight: Crytek Sponza probe 20 / 20 / 24 s,
/// sunroom 8.0 / 10.7 / 13.5 s; four is the balance. Frames between video
/// keys take the keys' light, so only keys pay.
const SUN_RAYS: u32 = 4;

impl Settings {
    pub fn new(quality: Quality, seed: u64) -> Settings {
        match quality {
            Quality::Preview => Settings {
                quality,
                panorama: TraceParams { samples: 1, bounces: 0, baked_points: true, gather: None, antialias: false, sun_rays: 1, seed },
                video: TraceParams { samples: 1, bounces: 0, baked_points: true, gather: None, antialias: false, sun_rays: 1, seed },
                cell_m: 0.3,
                gather_rays: 32,
                max_cells: 300_000,
                video_keys: 1,
                seed,
            },
            Quality::Tour => Settings { quality, ..Settings::new(Quality::Final, seed) },
            Quality::Final => Settings {
                quality,
                panorama: TraceParams {
                    samples: 1,
                    bounces: 0,
                    baked_points: false,
                    gather: Some(GatherParams { rays: 32, step: 6, passes: 3, near: 8, spread: 0.25, widen: (2, 0.1), history_rays: 0 }),
                    antialias: true,
                    sun_rays: SUN_RAYS,
                    seed,
                },
                video: TraceParams {
                    samples: 1,
                    bounces: 0,
                    baked_points: true,
                    gather: Some(GatherParams { rays: 16, step: 1, passes: 2, near: 0, spread: 0.0, widen: (2, 0.1), history_rays: 9 }),
                    antialias: false,
                    sun_rays: SUN_RAYS,
                    seed,
                },
                cell_m: 0.15,
                gather_rays: 64,
                max_cells: 600_000,
                video_keys: 32,
                seed,
            },
        }
    }
}

/// A camera at `eye` looking toward (`yaw`, `pitch`), with a vertical field
/// of view of `fov_y` radians.
#[derive(Clone, Copy, Debug)]
pub struct Perspective {
    pub eye: Vec3,
    pub yaw: f32,
    pub pitch: f32,
    pub fov_y: f32,
}

/// A scene ready to render bundle assets: lights chosen, cache built,
/// exposure fixed for the whole bundle.
pub struct Renderer<'a> {
    pub tracer: Tracer<'a>,
    pub settings: Settings,
    /// Multiplies radiance before tone mapping.
    pub exposure: f32,
}

impl<'a> Renderer<'a> {
    /// Chooses the lighting, bakes the radiance cache from what `viewpoints`
    /// see, and sets one exposure for every image of the bundle.
    pub fn new(scene: &'a Scene, rays: &'a RayScene, viewpoints: &[Vec3], settings: Settings) -> Renderer<'a> {
        let lighting = Lighting::for_scene(scene, rays, viewpoints);
        tracing::info!("lighting {}: {}", scene.name, lighting.description);
        let mut tracer = Tracer { rays, materials: surface::Materials::new(scene), lighting, cache: None, guide: None };
        let metre = 1.0 / scene.metres_per_unit.max(1e-9);
        // Cells no smaller than the scene's area allows within the cell budget (both sides of every surface).
        let area = 2.0 * scene.total_area() as f32;
        let cell = (settings.cell_m * metre).max((area / settings.max_cells as f32).sqrt());
        let seeds = spread(viewpoints, 256);
        let params = CacheParams {
            cell,
            gather_rays: settings.gather_rays,
            seed_rays: 16_384,
            max_cells: settings.max_cells,
            generations: 3,
            seed: settings.seed,
        };
        let cache = RadianceCache::build(&tracer, &seeds, &params);
        tracing::info!(
            "radiance cache: {} cells of {:.3} units, {} gather rays, {} iterations, {:.2} s",
            cache.stats.cells,
            cell,
            cache.stats.gather_rays,
            cache.stats.iterations,
            cache.stats.seconds
        );
        tracer.cache = Some(cache);
        let mut renderer = Renderer { tracer, settings, exposure: 1.0 };
        renderer.exposure = renderer.auto_exposure(&spread(viewpoints, 8));
        renderer
    }

    /// The median luminance seen from the viewpoints at mid grey, unless that
    /// pushes the 98th percentile past the tone curve's shoulder (a median
    /// alone blows out sunlit floors beside deep shade).
    fn auto_exposure(&self, eyes: &[Vec3]) -> f32 {
        let quick = TraceParams { samples: 1, bounces: 0, baked_points: true, gather: None, antialias: false, sun_rays: 1, seed: self.settings.seed };
        let mut seen: Vec<f32> = eyes
            .iter()
            .enumerate()
            .flat_map(|(i, &eye)| self.equirect(&quick, eye, 128, crate::seeds::image::exposure(i as u32)).color)
            .map(luminance)
            .filter(|l| l.is_finite())
            .collect();
        if seen.is_empty() {
            return 1.0;
        }
        let n = seen.len();
        let high = *seen.select_nth_unstable_by(n * 98 / 100, f32::total_cmp).1;
        let median = *seen.select_nth_unstable_by(n / 2, f32::total_cmp).1;
        (0.18 / median.max(1e-6)).min(2.0 / high.max(1e-6)).clamp(0.05, 100.0)
    }

    /// The six cube faces seen from `eye`, `size` pixels square, in the
    /// format's face order and orientation; face f draws from image `image + f`.
    pub fn cube(&self, params: &TraceParams, eye: Vec3, size: u32, image: u64) -> Vec<Frame> {
        (0..6).map(|face| self.tracer.render(params, eye, size, size, image + face as u64, |s, t| Vec3::from(cube_direction(face, s, t)))).collect()
    }

    /// An equirectangular frame, `width` × `width`/2: column 0 looks toward
    /// −Z then turns toward +X (the bundle's yaw convention), row 0 looks up.
    pub fn equirect(&self, params: &TraceParams, eye: Vec3, width: u32, image: u64) -> Frame {
        self.tracer.render(params, eye, width, width / 2, image, equirect_direction)
    }

    /// The equirectangular frames of a path seen from `eyes`, `width` wide,
    /// handed to `each` in order; frame i uses random stream `image + i`.
    /// With one sample a pixel, only every `interval`-th frame and the last are
    /// lit in full (after the first, averaged with the key before where
    /// `GatherParams::history_rays` says); the frames between take their
    /// lighting from those two ([`reuse`]). Rows toward the poles trace
    /// fewer pixels ([`equirect_columns`]): a fifth less work a frame.
    /// `each` breaks to stop the path there (its encoder failed, say).
    pub fn path_frames(
        &self,
        params: &TraceParams,
        eyes: &[Vec3],
        width: u32,
        image: u64,
        interval: u32,
        mut each: impl FnMut(usize, Frame) -> ControlFlow<()>,
    ) {
        let n = eyes.len();
        let columns = equirect_rows(width);
        let render = |params: &TraceParams, i: usize, reuse: reuse::Reuse| {
            self.tracer.render_reusing(
                params,
                Shot { eye: eyes[i], size: (width, width / 2), image: image + i as u64, project: equirect_direction },
                reuse,
                &columns,
            )
        };
        if params.samples != 1 || interval <= 1 || n < 3 {
            for i in 0..n {
                if each(i, render(params, i, reuse::Reuse::Off).0).is_break() {
                    return;
                }
            }
            return;
        }
        let mut keys: Vec<usize> = (0..n).step_by(interval as usize).collect();
        if keys.last() != Some(&(n - 1)) {
            keys.push(n - 1);
        }
        // Keys after the first: fewer rays, averaged with the keys before.
        let later =
            params.gather.filter(|g| g.history_rays > 0).map(|g| TraceParams { gather: Some(GatherParams { rays: g.history_rays, ..g }), ..*params });
        let (first, lit) = render(params, 0, reuse::Reuse::Key { history: None });
        if each(0, first).is_break() {
            return;
        }
        let mut previous = lit.expect("key frames keep their lighting");
        for w in keys.windows(2) {
            let (a, b) = (w[0], w[1]);
            let (key, lit) = match &later {
                Some(later) => render(later, b, reuse::Reuse::Key { history: Some(&previous) }),
                None => render(params, b, reuse::Reuse::Key { history: None }),
            };
            let next = lit.expect("key frames keep their lighting");
            for i in a + 1..b {
                let between = reuse::Between { keys: [&previous, &next], t: (i - a) as f32 / (b - a) as f32 };
                if each(i, render(params, i, reuse::Reuse::Between(&between)).0).is_break() {
                    return;
                }
            }
            if each(b, key).is_break() {
                return;
            }
            previous = next;
        }
    }

    /// A perspective view of `width` × `height` pixels.
    pub fn perspective(&self, params: &TraceParams, view: Perspective, width: u32, height: u32, image: u64) -> Frame {
        let Perspective { eye, yaw, pitch, fov_y } = view;
        let forward = Vec3::from(direction(yaw, pitch));
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        let up = right.cross(forward);
        let tan = (0.5 * fov_y).tan();
        let aspect = width as f32 / height as f32;
        self.tracer.render(params, eye, width, height, image, |s, t| {
            (forward + right * ((2.0 * s - 1.0) * tan * aspect) + up * ((1.0 - 2.0 * t) * tan)).normalize()
        })
    }

    /// The mean radiance leaving the scene's surface around `p`, seen from the
    /// side `n` points to, lit as the panoramas are (direct light by shadow
    /// rays, indirect light from the cache): for baking colour onto a
    /// simplified stand-in whose point `p` lies within `reach` of the surface
    /// along `n`. Samples are spread over a disc of `radius` across `n`;
    /// `None` when none finds a surface. Random stream `image`.
    pub fn surface_radiance(&self, p: Vec3, n: Vec3, radius: f32, reach: f32, samples: u32, image: u64) -> Option<Vec3> {
        let mut rng = trace::sampler(self.settings.seed, trace::Work::Bake, image, 0);
        let (t1, t2) = n.any_orthonormal_pair();
        let (mut sum, mut found) = (Vec3::ZERO, 0);
        for k in 0..samples {
            // A Fibonacci spiral over the disc: even cover with few samples.
            let r = radius * ((k as f32 + 0.5) / samples as f32).sqrt();
            let a = k as f32 * std::f32::consts::PI * (3.0 - 5f32.sqrt());
            let q = p + (t1 * a.cos() + t2 * a.sin()) * r;
            let mut ray = crate::raycast::Ray { t_max: 2.0 * reach, ..crate::raycast::Ray::new(q + n * reach, -n) };
            let Some(hit) = self.tracer.intersect(&mut ray) else { continue };
            let s = self.tracer.materials.surface(&ray, &hit);
            let indirect = self.tracer.cache.as_ref().map_or(Vec3::ZERO, |c| c.irradiance(s.position, s.geometric, false));
            let e = self.tracer.direct(&s, surface::Which::All, &mut rng) + indirect;
            let c = s.emission + s.albedo / std::f32::consts::PI * e;
            if c.is_finite() {
                sum += c;
                found += 1;
            }
        }
        (found > 0).then(|| sum / found as f32)
    }

    /// Tone-mapped sRGB image of linear radiance.
    pub fn to_image(&self, width: u32, height: u32, radiance: &[Vec3]) -> RgbImage {
        to_image(width, height, radiance, self.exposure)
    }
}

/// Up to `n` of `points`, evenly spread through the list.
fn spread(points: &[Vec3], n: usize) -> Vec<Vec3> {
    let step = points.len().div_ceil(n).max(1);
    points.iter().step_by(step).copied().collect()
}

fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// The direction through (s, t) of an equirectangular image.
pub fn equirect_direction(s: f32, t: f32) -> Vec3 {
    let yaw = s * std::f32::consts::TAU;
    let pitch = std::f32::consts::FRAC_PI_2 - t * std::f32::consts::PI;
    Vec3::from(direction(yaw, pitch))
}

/// Every how many pixels row `y` of an equirectangular frame is traced (the
/// rest interpolated along the row): a row at latitude φ is a circle cos φ
/// the equator's length, so its pixels lie cos φ as far apart as the rows
/// do. Tracing every s-th where s cos φ ≤ 1 keeps them no farther apart
/// than the rows, the equator's density that a view shows everywhere, and
/// skips about a fifth of the pixels. Powers of two up to 16 that divide
/// `width`.
pub fn equirect_columns(width: u32, height: u32, y: u32) -> u32 {
    let latitude = (0.5 - (y as f32 + 0.5) / height as f32) * std::f32::consts::PI;
    let mut columns = 1;
    while columns < 16 && 2.0 * columns as f32 * latitude.cos() <= 1.0 && width.is_multiple_of(2 * columns) {
        columns *= 2;
    }
    columns
}

/// [`equirect_columns`] of each row of a frame `width` wide.
pub(super) fn equirect_rows(width: u32) -> Vec<u32> {
    (0..width / 2).map(|y| equirect_columns(width, width / 2, y)).collect()
}

/// Halves a square frame's radiance by 2×2 averaging (the next cube level down).
pub fn downsample(size: u32, radiance: &[Vec3]) -> Vec<Vec3> {
    let half = size / 2;
    (0..half * half)
        .map(|i| {
            let (x, y) = (2 * (i % half), 2 * (i / half));
            let at = |dx: u32, dy: u32| radiance[((y + dy) * size + x + dx) as usize];
            (at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1)) * 0.25
        })
        .collect()
}

/// Resamples cube faces (`size` square, linear radiance) to an
/// equirectangular image `width` × `width`/2, bilinearly within each face.
pub fn equirect_from_cube(faces: &[Vec<Vec3>], size: u32, width: u32) -> Vec<Vec3> {
    let height = width / 2;
    (0..width * height)
        .into_par_iter()
        .map(|i| {
            let d = equirect_direction(((i % width) as f32 + 0.5) / width as f32, ((i / width) as f32 + 0.5) / height as f32);
            let (face, s, t) = cube_face_of(d.into());
            let (x, y) = ((s * size as f32 - 0.5).clamp(0.0, size as f32 - 1.0), (t * size as f32 - 0.5).clamp(0.0, size as f32 - 1.0));
            let (x0, y0) = (x.floor() as u32, y.floor() as u32);
            let (x1, y1) = ((x0 + 1).min(size - 1), (y0 + 1).min(size - 1));
            let (fx, fy) = (x - x0 as f32, y - y0 as f32);
            let at = |xx: u32, yy: u32| faces[face][(yy * size + xx) as usize];
            (at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx) * (1.0 - fy) + (at(x0, y1) * (1.0 - fx) + at(x1, y1) * fx) * fy
        })
        .collect()
}

/// ACES filmic curve (Narkowicz's fit).
fn tone_map(x: Vec3) -> Vec3 {
    let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
    ((x * (x * a + b)) / (x * (x * c + d) + e)).clamp(Vec3::ZERO, Vec3::ONE)
}

/// Exposed, tone-mapped and sRGB-encoded radiance.
pub fn to_image(width: u32, height: u32, radiance: &[Vec3], exposure: f32) -> RgbImage {
    let mut raw = vec![0u8; 3 * (width * height) as usize];
    // Row by row on every core: a path's frames are toned one at a time.
    raw.par_chunks_mut(3 * width.max(1) as usize).zip(radiance.par_chunks(width.max(1) as usize)).for_each(|(row, colours)| {
        for (px, &c) in row.chunks_exact_mut(3).zip(colours) {
            let c = tone_map(c * exposure);
            px.copy_from_slice(&[linear_to_srgb(c.x), linear_to_srgb(c.y), linear_to_srgb(c.z)]);
        }
    });
    RgbImage::from_raw(width, height, raw).expect("three bytes a pixel")
}

/// Peak signal-to-noise ratio of two 8-bit images of the same size, in dB.
pub fn psnr(a: &RgbImage, b: &RgbImage) -> f64 {
    assert_eq!(a.dimensions(), b.dimensions());
    let se: f64 = a.as_raw().iter().zip(b.as_raw()).map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2)).sum();
    let mse = se / a.as_raw().len().max(1) as f64;
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    }
}

/// JPEG bytes of an equirectangular panorama with photo-sphere (GPano) XMP
/// metadata, so panorama viewers and photo apps show it as a sphere.
pub fn photo_sphere_jpeg(image: &RgbImage, quality: u8) -> Vec<u8> {
    let (w, h) = image.dimensions();
    let xmp = format!(
        "http://ns.adobe.com/xap/1.0/\0<?xpacket begin=\"\u{feff}\" id=\"W5M0MpCehiHzreSzNTczkc9d\"?>\
<x:xmpmeta xmlns:x=\"adobe:ns:meta/\"><rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\">\
<rdf:Description rdf:about=\"\" xmlns:GPano=\"http://ns.google.com/photos/1.0/panorama/\" \
GPano:ProjectionType=\"equirectangular\" GPano:UsePanoramaViewer=\"True\" \
GPano:FullPanoWidthPixels=\"{w}\" GPano:FullPanoHeightPixels=\"{h}\" \
GPano:CroppedAreaImageWidthPixels=\"{w}\" GPano:CroppedAreaImageHeightPixels=\"{h}\" \
GPano:CroppedAreaLeftPixels=\"0\" GPano:CroppedAreaTopPixels=\"0\"/></rdf:RDF></x:xmpmeta><?xpacket end=\"w\"?>"
    );
    crate::files::jpeg_with_app1(image, quality, Some(xmp.as_bytes()))
}

#[cfg(test)]
mod tests;

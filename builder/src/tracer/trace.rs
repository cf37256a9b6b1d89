//! The path tracer: camera rays in coherent 8-wide packets over 8×8 pixel
//! tiles, shaded with next-event estimation toward the sun and point lights,
//! diffuse bounces with Russian roulette, and the radiance cache standing in
//! for the rest of the path after `bounces` real bounces.
//!
//! Every random number comes from a generator seeded by (render seed, image,
//! pixel), and pixels are independent, so images do not depend on the thread
//! count.

use super::cache::RadianceCache;
use super::gather::{Field, GatherParams};
use super::lights::LightSampler;
use super::reuse::{Lit, Reuse, Seen, HISTORY};
use super::surface::{cosine_direction, Lighting, Materials, Surface, Which};
use crate::raycast::{FlushDenormals, Hit, Ray, RayScene};
use exploremaps_scenes::Scene;
use glam::{Vec2, Vec3, Vec4};
use rand::Rng;
use rand_pcg::Pcg32;
use rayon::prelude::*;
use std::f32::consts::PI;

pub use crate::seeds::{image, sampler, Work};

/// How rays are turned into radiance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceParams {
    /// Samples per pixel; 1 traces through pixel centres without jitter.
    pub samples: u32,
    /// Real diffuse bounces before the radiance cache takes over (with no
    /// cache: the most bounces, 0 for up to 64; Russian roulette ends most
    /// paths sooner).
    pub bounces: u32,
    /// With no real bounce, take point lights from the cache (blurred to its
    /// cells) instead of a shadow ray each: the sun stays sharp, and frames
    /// of a scene with many lamps stay cheap.
    pub baked_points: bool,
    /// With no real bounce: gather the first hits' indirect light on a coarse
    /// grid ([`super::gather`]) instead of reading it from the cache.
    pub gather: Option<GatherParams>,
    /// With one sample a pixel: four more in the pixels whose colour differs
    /// from a neighbour's ([`Tracer::antialias`]). On for `final` panoramas:
    /// against 16 jittered samples at 2048², it leaves a quarter to a third
    /// less error than 2 samples (mean FLIP, gallery 0.0044 against 0.0068,
    /// Crytek Sponza 0.0087 against 0.0119), refining 3-25 % of a face's
    /// pixels, for 16-23 % less time on the gallery and the same on the
    /// Crytek Sponza. Off for video frames: on the gallery it nearly doubles a
    /// frame's cost for 0.001 FLIP (0.007-0.010 on the Crytek Sponza).
    pub antialias: bool,
    /// Shadow rays toward each sun at a first hit, spread over its disk
    /// (stratified, each carrying its share): one leaves the half-lit band of
    /// a soft shadow edge (its penumbra) speckled at a few samples a pixel.
    pub sun_rays: u32,
    pub seed: u64,
}

/// Linear images from one render: radiance, plus the first hit's albedo and
/// normal that guide a denoiser.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub color: Vec<Vec3>,
    pub albedo: Vec<Vec3>,
    pub normal: Vec<Vec3>,
}

/// The scene ready to be rendered.
pub struct Tracer<'a> {
    pub rays: &'a RayScene,
    pub materials: Materials<'a>,
    pub lighting: Lighting,
    pub cache: Option<RadianceCache>,
    /// Light sampling toward emitters and sunlit points, for the reference
    /// path tracer; used only when there is no cache.
    pub guide: Option<LightSampler>,
}

const TILE: u32 = 8;

/// One pixel's result: its images' values and its (last) sample's hit and irradiance.
struct Pixel {
    index: usize,
    color: Vec3,
    albedo: Vec3,
    normal: Vec3,
    /// The colour without the light of rouletted lamps: what antialiasing
    /// decides on, since deciding on the roulette's draws would bias the
    /// mean (a lucky sample's pixel refined, an unlucky one's left dark).
    steady: Vec3,
    /// A key frame's: what it saw, and its gathered light's history.
    hit: Option<(Seen, Vec4)>,
}
/// Paths end here at the latest (Russian roulette ends nearly all long before).
const MAX_DEPTH: u32 = 64;

impl<'a> Tracer<'a> {
    /// The reference: a plain path tracer with no cache, sampling the lights
    /// (emitters, the sky through openings and sunlit points too) by multiple
    /// importance sampling, tuned to what `viewpoints` see.
    pub fn path_traced(scene: &'a Scene, rays: &'a RayScene, lighting: Lighting, viewpoints: &[Vec3]) -> Tracer<'a> {
        let mut tracer = Tracer { rays, materials: Materials::new(scene), lighting, cache: None, guide: None };
        tracer.guide = Some(LightSampler::new(&tracer, scene, viewpoints));
        tracer
    }

    fn guide(&self) -> Option<&LightSampler> {
        self.guide.as_ref().filter(|_| self.cache.is_none())
    }

    /// The scene being rendered.
    pub fn scene(&self) -> &'a Scene {
        self.materials.scene()
    }

    /// The closest hit that is not a hole in a cut-out; `ray.t_min` ends up past the holes.
    pub fn intersect(&self, ray: &mut Ray) -> Option<Hit> {
        let hit = self.rays.intersect(ray)?;
        self.through_holes(ray, hit)
    }

    /// Continues a ray through cut-out holes, starting from its first hit.
    fn through_holes(&self, ray: &mut Ray, mut hit: Hit) -> Option<Hit> {
        for _ in 0..64 {
            if !self.materials.is_hole(&hit) {
                return Some(hit);
            }
            ray.t_min = hit.t + offset_t(ray, hit.t);
            hit = self.rays.intersect(ray)?;
        }
        Some(hit)
    }

    /// Whether nothing opaque blocks the ray.
    pub fn visible(&self, ray: &Ray) -> bool {
        if !self.materials.has_cutouts {
            return !self.rays.occluded(ray);
        }
        let mut r = *ray;
        self.intersect(&mut r).is_none()
    }

    /// Irradiance from the directly sampled lights.
    pub fn direct(&self, s: &Surface, which: Which, rng: &mut Pcg32) -> Vec3 {
        let u = Vec2::new(rng.random(), rng.random());
        self.lighting.direct(s, u, which, |r| self.visible(r))
    }

    /// Indirect irradiance at a first hit: from the cache, or by one bounce
    /// and the path beyond it (cosine sampling: E ≈ π L).
    fn indirect(&self, params: &TraceParams, s: &Surface, at: Option<(&Field, f32, f32, f32)>, rng: &mut Pcg32) -> Vec3 {
        match (&self.cache, params.bounces) {
            (Some(cache), 0) => match at.and_then(|(field, x, y, depth)| self.indirect_from(field, x, y, s, depth, rng)) {
                Some(e) if params.baked_points => e + cache.point_irradiance(s.position, s.geometric),
                Some(e) => e,
                None => cache.irradiance(s.position, s.geometric, params.baked_points),
            },
            _ => {
                let sampled = match self.guide() {
                    Some(g) => g.irradiance(self, s, rng),
                    None => Vec3::ZERO,
                };
                let d = cosine_direction(s.normal, Vec2::new(rng.random(), rng.random()));
                if d.dot(s.geometric) <= 0.0 {
                    return sampled;
                }
                let mut ray = Ray::new(s.lifted(), d);
                let hit = self.intersect(&mut ray);
                sampled + PI * self.path(params, ray, hit, *s, rng)
            }
        }
    }

    /// Radiance arriving along a bounce ray from `from` whose hit is `hit`:
    /// next-event estimation at every vertex, the cache once `bounces` are
    /// done, Russian roulette from the third vertex on.
    fn path(&self, params: &TraceParams, mut ray: Ray, mut hit: Option<Hit>, mut from: Surface, rng: &mut Pcg32) -> Vec3 {
        let (mut sum, mut weight) = (Vec3::ZERO, Vec3::ONE);
        let guide = self.guide();
        for depth in 1..=MAX_DEPTH {
            let Some(h) = hit else {
                let w = guide.map_or(1.0, |g| g.bounce_weight_sky(&from, ray.dir));
                sum += weight * w * self.lighting.sky.radiance(ray.dir);
                break;
            };
            let s = self.materials.surface(&ray, &h);
            let brdf = s.albedo / PI;
            let (emission, direct) = match guide {
                None => (s.emission, self.direct(&s, Which::All, rng)),
                Some(g) => {
                    // Suns' light here weighed against reaching a sunlit point by connection.
                    let mut e = Vec3::ZERO;
                    let u = Vec2::new(rng.random(), rng.random());
                    self.lighting.shadow_rays(&s, u, Which::All, 1, |k, r, irradiance| {
                        if self.visible(&r) {
                            e += if k < self.lighting.suns.len() { irradiance * g.bounce_weight_sun(k, &from, &s, r.dir) } else { irradiance };
                        }
                    });
                    let emission = if s.emission == Vec3::ZERO { s.emission } else { s.emission * g.bounce_weight_emission(&from, &s, h.triangle) };
                    (emission, e + g.irradiance(self, &s, rng))
                }
            };
            sum += weight * (emission + brdf * direct);
            if depth >= params.bounces {
                match &self.cache {
                    Some(cache) => {
                        sum += weight * brdf * cache.irradiance_jittered(s.position, s.geometric, rng);
                        break;
                    }
                    None if params.bounces > 0 => break,
                    None => {}
                }
            }
            if depth >= 2 {
                let survive = s.albedo.max_element().min(0.95);
                if rng.random::<f32>() >= survive {
                    break;
                }
                weight /= survive;
            }
            // Cosine sampling: the pdf cancels the cosine and π of the BRDF.
            weight *= s.albedo;
            let d = cosine_direction(s.normal, Vec2::new(rng.random(), rng.random()));
            if d.dot(s.geometric) <= 0.0 || weight == Vec3::ZERO {
                break;
            }
            ray = Ray::new(s.lifted(), d);
            hit = self.intersect(&mut ray);
            from = s;
        }
        sum
    }

    /// Renders `width` × `height` pixels from `eye`; `project(s, t)` gives the
    /// direction through image coordinates in [0, 1]² (t down). `image`
    /// separates the random streams of different images.
    pub fn render(&self, params: &TraceParams, eye: Vec3, width: u32, height: u32, image: u64, project: impl Fn(f32, f32) -> Vec3 + Sync) -> Frame {
        self.render_reusing(params, Shot { eye, size: (width, height), image, project }, Reuse::Off, &[]).0
    }

    /// [`Tracer::render`], reusing light along a path as `reuse` says
    /// ([`super::reuse`]); a key frame also returns what its pixels saw
    /// (meaningful with one sample a pixel). With `columns` (one a row), row
    /// y traces only every `columns[y]`-th pixel from column 0 and fills the
    /// rest by interpolating along the row, wrapping around
    /// ([`super::equirect_columns`]); empty traces every pixel.
    pub(super) fn render_reusing(
        &self,
        params: &TraceParams,
        shot: Shot<impl Fn(f32, f32) -> Vec3 + Sync>,
        reuse: Reuse,
        columns: &[u32],
    ) -> (Frame, Option<Lit>) {
        let Shot { eye, size: (width, height), image, project } = shot;
        debug_assert!(columns.is_empty() || (columns.len() == height as usize && columns.iter().all(|&c| c >= 1 && width % c == 0)));
        let traced = |x: u32, y: u32| columns.get(y as usize).is_none_or(|&c| x.is_multiple_of(c));
        let keep = matches!(reuse, Reuse::Key { .. });
        let n = (width * height) as usize;
        let mut frame = Frame { width, height, color: vec![Vec3::ZERO; n], albedo: vec![Vec3::ZERO; n], normal: vec![Vec3::ZERO; n] };
        let mut lit = keep.then(|| Lit { eye, width, height, columns: columns.to_vec(), points: vec![None; n], history: vec![Vec4::ZERO; n] });
        // Frames between key frames gather nothing: the keys did.
        let field = match (&params.gather, &self.cache, params.bounces, reuse) {
            (Some(g), Some(_), 0, Reuse::Off | Reuse::Key { .. }) => {
                Some(self.gather_field(g, params.seed, &Shot { eye, size: (width, height), image, project: &project }, &traced))
            }
            _ => None,
        };
        let antialias = params.antialias && params.samples == 1;
        let mut steady = vec![Vec3::ZERO; if antialias { n } else { 0 }];
        let (mut no_points, mut no_history) = (Vec::new(), Vec::new());
        let (points, history) = match &mut lit {
            Some(lit) => (&mut lit.points, &mut lit.history),
            None => (&mut no_points, &mut no_history),
        };
        // A band of tiles a task, each writing its own rows of every output
        // (scattering all pixels afterwards on one thread took a tenth of a
        // frame between video keys).
        let rows = (width * TILE) as usize;
        let band_count = height.div_ceil(TILE) as usize;
        let bands: Vec<_> = bands(&mut frame.color, rows, band_count)
            .into_iter()
            .zip(bands(&mut frame.albedo, rows, band_count))
            .zip(bands(&mut frame.normal, rows, band_count))
            .zip(bands(&mut steady, rows, band_count))
            .zip(bands(points, rows, band_count))
            .zip(bands(history, rows, band_count))
            .enumerate()
            .collect();
        let job = FrameJob { params, eye, size: (width, height), image, project: &project, field: field.as_ref(), reuse };
        bands.into_par_iter().for_each(|(band, (((((color, albedo), normal), steady), points), history))| {
            let _mode = FlushDenormals::new();
            let y0 = band as u32 * TILE;
            for x0 in (0..width).step_by(TILE as usize) {
                // Pixels in 4×2 blocks, so each packet of 8 is a compact frustum.
                let pixels: Vec<(u32, u32)> = (0..TILE * TILE)
                    .map(|i| {
                        let block = i / 8;
                        (x0 + (block % 2) * 4 + i % 4, y0 + (block / 2) * 2 + (i % 8) / 4)
                    })
                    .filter(|&(x, y)| x < width && y < height && traced(x, y))
                    .collect();
                for p in self.render_tile(&job, &pixels, None) {
                    let i = p.index - band * rows;
                    color[i] = p.color;
                    albedo[i] = p.albedo;
                    normal[i] = p.normal;
                    if antialias {
                        steady[i] = p.steady;
                    }
                    if let Some((seen, h)) = p.hit {
                        points[i] = Some(seen);
                        history[i] = h;
                    }
                }
            }
            if !columns.is_empty() {
                let band_columns = &columns[y0 as usize..(y0 as usize + color.len() / width as usize)];
                fill_rows(color, width, band_columns, |c| c);
                fill_rows(albedo, width, band_columns, |a| a);
                fill_rows(normal, width, band_columns, Vec3::normalize_or_zero);
            }
        });
        if antialias {
            self.antialias(&job, &steady, &mut frame);
        }
        (frame, lit)
    }

    /// Adaptive antialiasing of a one-sample frame: a pixel centre alone
    /// leaves jagged silhouettes, shadow edges and shimmering texture detail,
    /// which is where a pixel's colour differs from a neighbour's. Those
    /// pixels (4 % of the sunroom, far more on checkered floors) get four more samples on a
    /// rotated grid, lit as the centre was (the same gather field, the same key
    /// frames), and keep the mean of the five; flat regions cost nothing more.
    fn antialias<P: Fn(f32, f32) -> Vec3 + Sync>(&self, job: &FrameJob<P>, steady: &[Vec3], frame: &mut Frame) {
        const GRID: [(f32, f32); 4] = [(0.375, 0.125), (0.875, 0.375), (0.625, 0.875), (0.125, 0.625)];
        let (width, height) = (frame.width, frame.height);
        let edges = contrast_edges(steady, width, height);
        // In tile order, so the packets stay coherent.
        let mut todo: Vec<(u32, u32)> = edges.iter().map(|&i| (i as u32 % width, i as u32 / width)).collect();
        todo.sort_by_key(|&(x, y)| (y / TILE, x / TILE, y, x));
        let jobs: Vec<((u32, u32), (f32, f32))> = todo.iter().flat_map(|&p| GRID.map(|g| (p, g))).collect();
        let n = (width * height) as u64;
        let more: Vec<Vec<Pixel>> = jobs
            .par_chunks(64)
            .enumerate()
            .map(|(c, chunk)| {
                let _mode = FlushDenormals::new();
                let pixels: Vec<(u32, u32)> = chunk.iter().map(|j| j.0).collect();
                let jitter: Vec<(f32, f32)> = chunk.iter().map(|j| j.1).collect();
                let single = TraceParams { samples: 1, ..*job.params };
                let job = FrameJob { params: &single, ..*job };
                self.render_tile(&job, &pixels, Some((&jitter, n + 64 * c as u64)))
            })
            .collect();
        for p in more.into_iter().flatten() {
            frame.color[p.index] += p.color;
        }
        for &i in &edges {
            frame.color[i] /= 1.0 + GRID.len() as f32;
        }
    }

    /// `jitter`: where in each pixel its one sample goes, and the random
    /// stream of the first (the rest follow), instead of pixel centres.
    fn render_tile<P: Fn(f32, f32) -> Vec3 + Sync>(
        &self,
        job: &FrameJob<P>,
        pixels: &[(u32, u32)],
        jitter: Option<(&[(f32, f32)], u64)>,
    ) -> Vec<Pixel> {
        // Antialiasing's extra samples (jittered) keep nothing.
        let keep = matches!(job.reuse, Reuse::Key { .. }) && jitter.is_none();
        let mut tile = Tile::new(self, job, pixels, jitter);
        for sample in 0..tile.spp {
            self.first_hits(job, &mut tile, sample);
            // The keys' light, four pixels at a time, in a loop of its own
            // (a lookup is a long chain of dependent arithmetic, which the
            // next pixels' can overlap here).
            if let Reuse::Between(b) = job.reuse {
                for (r, s) in tile.reused.chunks_mut(4).zip(tile.surfaces.chunks(4)) {
                    let found = b.irradiance(std::array::from_fn(|j| s.get(j).and_then(Option::as_ref)));
                    r.copy_from_slice(&found[..r.len()]);
                }
            }
            self.direct_light(job.params, &mut tile);
            self.shade(job, &mut tile, keep);
        }
        tile.finish(job.size.0)
    }

    /// A sample through every pixel of the tile, its first hit and the
    /// surface there (the sky where it hits nothing).
    fn first_hits<P: Fn(f32, f32) -> Vec3 + Sync>(&self, job: &FrameJob<P>, tile: &mut Tile, sample: u32) {
        let (width, height) = job.size;
        let (spp, streams) = (tile.spp, tile.streams);
        tile.rays.clear();
        tile.at.clear();
        for (k, &(x, y)) in tile.pixels.iter().enumerate() {
            // Stratified in rows of the pixel when there are several samples.
            let (jx, jy) = match tile.jitter {
                Some(at) => at[k],
                None if spp == 1 => (0.5, 0.5),
                None => {
                    let rng = tile.rngs[k].get_or_insert_with(|| streams.of(k));
                    (rng.random::<f32>(), (sample as f32 + rng.random::<f32>()) / spp as f32)
                }
            };
            let d = (job.project)((x as f32 + jx) / width as f32, (y as f32 + jy) / height as f32);
            tile.rays.push(Ray::new(job.eye, d));
            tile.at.push((x as f32 + jx, y as f32 + jy));
        }
        for (r8, h8) in tile.rays.chunks(8).zip(tile.hits.chunks_mut(8)) {
            self.rays.intersect8(r8, h8, true);
        }
        tile.surfaces.clear();
        for i in 0..tile.pixels.len() {
            let mut ray = tile.rays[i];
            let hit = tile.hits[i].and_then(|h| self.through_holes(&mut ray, h));
            // The field's tolerances need the distance along the ray.
            tile.hits[i] = hit;
            let s = hit.map(|h| self.materials.surface_seen(&ray, &h, tile.spread));
            match &s {
                None => {
                    let sky = self.lighting.sky.radiance(ray.dir);
                    tile.sums[i].0 += sky;
                    tile.sums[i].3 += sky;
                    tile.last_hit[i] = None;
                }
                Some(s) => {
                    tile.sums[i].1 += s.albedo;
                    tile.sums[i].2 += s.normal;
                }
            }
            tile.surfaces.push(s);
        }
    }

    /// Direct light at the first hits the keys lent none, by shadow rays
    /// sorted by light so that each packet of 8 shares one (a coherent
    /// frustum).
    fn direct_light(&self, params: &TraceParams, tile: &mut Tile) {
        let which = if params.baked_points && params.bounces == 0 && self.cache.is_some() { Which::Suns } else { Which::All };
        let lamps = self.cache.as_ref().filter(|_| which == Which::All);
        let suns = self.lighting.suns.len();
        let streams = tile.streams;
        let Tile { shadows, surfaces, reused, rngs, direct, .. } = tile;
        shadows.iter_mut().for_each(Vec::clear);
        for i in 0..surfaces.len() {
            let (Some(s), None) = (&surfaces[i], reused[i]) else { continue };
            let rng = rngs[i].get_or_insert_with(|| streams.of(i));
            let u = Vec2::new(rng.random(), rng.random());
            let seen = lamps.and_then(|c| c.lamps_seen(s.position, s.geometric));
            self.lighting.shadow_rays(s, u, which, params.sun_rays, |k, r, e| match (&seen, k.checked_sub(suns)) {
                // Russian roulette on a lamp no cache point nearby saw (most are in
                // other rooms): traced at odds UNSEEN_LAMP_ODDS, carrying its light
                // over them, so the mean stays exact wherever the cache was wrong.
                (Some(seen), Some(lamp)) if !seen.sees(lamp) => {
                    if rng.random::<f32>() < UNSEEN_LAMP_ODDS {
                        shadows[k].push((i, r, e / UNSEEN_LAMP_ODDS, true));
                    }
                }
                _ => shadows[k].push((i, r, e, false)),
            });
        }
        direct.iter_mut().for_each(|d| *d = (Vec3::ZERO, Vec3::ZERO));
        let mut add = |(i, _, e, won): &(usize, Ray, Vec3, bool)| {
            direct[*i].0 += *e;
            if *won {
                direct[*i].1 += *e;
            }
        };
        // Light by light, in each pixel's order of lights.
        if self.materials.has_cutouts {
            for c in shadows.iter().flatten() {
                if self.visible(&c.1) {
                    add(c);
                }
            }
        } else {
            let mut blocked = [false; 8];
            for chunk in shadows.iter().flat_map(|light| light.chunks(8)) {
                let r8: smallvec::SmallVec<[Ray; 8]> = chunk.iter().map(|c| c.1).collect();
                self.rays.occluded8(&r8, &mut blocked, true);
                for (c, &b) in chunk.iter().zip(&blocked) {
                    if !b {
                        add(c);
                    }
                }
            }
        }
    }

    /// Each first hit's colour: its emission and its albedo times the light
    /// reaching it (the keys' or its own direct and indirect light); a key
    /// frame keeps what it saw.
    fn shade<P: Fn(f32, f32) -> Vec3 + Sync>(&self, job: &FrameJob<P>, tile: &mut Tile, keep: bool) {
        let streams = tile.streams;
        for i in 0..tile.pixels.len() {
            let Some(s) = &tile.surfaces[i] else { continue };
            let field_at = job.field.zip(tile.hits[i]).map(|(f, h)| (f, tile.at[i].0, tile.at[i].1, h.t * tile.rays[i].dir.length()));
            let (e, history) = match tile.reused[i] {
                Some(e) => (e, Vec4::ZERO),
                None => {
                    let own = self.indirect(job.params, s, field_at, tile.rngs[i].get_or_insert_with(|| streams.of(i)));
                    // A running mean over keys (up to HISTORY) where the previous key saw this point.
                    let history = match job.reuse {
                        Reuse::Key { history: Some(before) } => before.history(s).map(|h| {
                            let keys = (h.w + 1.0).min(HISTORY);
                            (h.truncate() + (own - h.truncate()) / keys).extend(keys)
                        }),
                        _ => None,
                    };
                    let history = history.unwrap_or(own.extend(1.0));
                    (tile.direct[i].0 + history.truncate(), history)
                }
            };
            if keep {
                tile.last_hit[i] = Some((Seen { position: s.position, normal: s.normal, irradiance: e }, history));
            }
            let c = s.emission + s.albedo / PI * e;
            // A stray NaN or infinity must not poison a pixel (or a denoiser).
            if c.is_finite() {
                tile.sums[i].0 += c;
                tile.sums[i].3 += c - s.albedo / PI * tile.direct[i].1;
            }
        }
    }
}

/// A frame to trace: from `eye`, `size` pixels, image number `image` (which
/// separates the random streams of images), and `project(s, t)` the
/// direction through image coordinates in [0, 1]² (t down).
pub(super) struct Shot<P> {
    pub eye: Vec3,
    pub size: (u32, u32),
    pub image: u64,
    pub project: P,
}

/// What every tile of a frame shares: how it is traced, from where, its size
/// and random streams, its projection, the gather field and the light it
/// reuses (the per-frame context of [`Tracer::render_tile`]).
struct FrameJob<'a, P> {
    params: &'a TraceParams,
    eye: Vec3,
    size: (u32, u32),
    image: u64,
    project: &'a P,
    field: Option<&'a Field>,
    reuse: Reuse<'a>,
}

/// Where each pixel's random stream comes from: its place in the image, or
/// (antialiasing's extra samples) its place after the first.
#[derive(Clone, Copy)]
struct Streams<'p> {
    seed: u64,
    image: u64,
    width: u32,
    pixels: &'p [(u32, u32)],
    first: Option<u64>,
}

impl Streams<'_> {
    fn of(&self, k: usize) -> Pcg32 {
        match self.first {
            None => sampler(self.seed, Work::Pixels, self.image, (self.pixels[k].1 * self.width + self.pixels[k].0) as u64),
            Some(first) => sampler(self.seed, Work::Pixels, self.image, first + k as u64),
        }
    }
}

/// One tile's pixels in flight through [`Tracer::render_tile`]'s phases.
struct Tile<'p> {
    pixels: &'p [(u32, u32)],
    /// Where in each pixel its one sample goes, instead of the centre.
    jitter: Option<&'p [(f32, f32)]>,
    streams: Streams<'p>,
    spp: u32,
    /// The angle one pixel spans, for reading textures over its footprint.
    spread: f32,
    /// Each pixel's random stream, made when first drawn from (frames
    /// between video keys draw only where neither key saw the point).
    rngs: Vec<Option<Pcg32>>,
    /// Colour, albedo, normal, and the colour without rouletted lamps.
    sums: Vec<(Vec3, Vec3, Vec3, Vec3)>,
    rays: Vec<Ray>,
    /// Each sample's image position, pixels.
    at: Vec<(f32, f32)>,
    hits: Vec<Option<Hit>>,
    surfaces: Vec<Option<Surface>>,
    /// Shadow rays by light (suns first, then point lights): (pixel, ray,
    /// irradiance, whether the ray won a roulette).
    shadows: Vec<Vec<(usize, Ray, Vec3, bool)>>,
    /// Direct light, and the part of it rouletted lamps brought.
    direct: Vec<(Vec3, Vec3)>,
    /// The keys' light, between video keys.
    reused: Vec<Option<Vec3>>,
    last_hit: Vec<Option<(Seen, Vec4)>>,
}

impl<'p> Tile<'p> {
    fn new<P: Fn(f32, f32) -> Vec3 + Sync>(
        tracer: &Tracer,
        job: &FrameJob<P>,
        pixels: &'p [(u32, u32)],
        jitter: Option<(&'p [(f32, f32)], u64)>,
    ) -> Tile<'p> {
        let (width, height) = job.size;
        let spp = job.params.samples.max(1);
        // One sample through a pixel stands for all of it: its texture is
        // read over the pixel's footprint, the angle from the tile's first
        // pixel to the one below (in an equirectangular frame, the rows'
        // spacing, which its thinned rows keep; on a cube face it changes
        // by under a percent across a tile).
        let spread = match (spp, pixels.first()) {
            (1, Some(&(x, y))) if tracer.materials.has_textures() => {
                let (x, y) = (x as f32 + 0.5, y as f32 + 0.5);
                let (w, h) = (width as f32, height as f32);
                ((job.project)(x / w, (y + 1.0) / h).normalize_or_zero() - (job.project)(x / w, y / h).normalize_or_zero()).length()
            }
            _ => 0.0,
        };
        let n = pixels.len();
        Tile {
            pixels,
            jitter: jitter.map(|j| j.0),
            streams: Streams { seed: job.params.seed, image: job.image, width, pixels, first: jitter.map(|j| j.1) },
            spp,
            spread,
            rngs: vec![None; n],
            sums: vec![(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO); n],
            rays: Vec::with_capacity(n),
            at: Vec::with_capacity(n),
            hits: vec![None; n],
            surfaces: Vec::with_capacity(n),
            shadows: vec![Vec::new(); tracer.lighting.suns.len() + tracer.lighting.points.len()],
            direct: vec![(Vec3::ZERO, Vec3::ZERO); n],
            reused: vec![None; n],
            last_hit: vec![None; n],
        }
    }

    /// The pixels' means over their samples.
    fn finish(self, width: u32) -> Vec<Pixel> {
        let inv = 1.0 / self.spp as f32;
        self.pixels
            .iter()
            .zip(self.sums)
            .zip(self.last_hit)
            .map(|((&(x, y), (c, a, n, steady)), hit)| Pixel {
                index: (y * width + x) as usize,
                color: c * inv,
                albedo: a * inv,
                normal: n.normalize_or_zero(),
                steady: steady * inv,
                hit,
            })
            .collect()
    }
}

/// The odds of tracing a shadow ray to a point light that no cache point
/// near the hit saw (mostly lamps in other rooms): seven in eight of those
/// rays are skipped. A panorama (six 2048² faces) of the 24-cell maze, whose
/// 64 default ceiling lamps are one above each viewpoint, takes 21-22 s
/// instead of 31; the 9-lamp maze 11.4 s instead of 12.5; the gallery's six
/// lamps save 3-4 %. Test
/// `lamps_no_cache_point_saw_are_rouletted_and_the_light_stays_the_same`.
const UNSEEN_LAMP_ODDS: f32 = 0.125;

/// Pixels whose colour differs from a 4-neighbour's by more than a tenth of
/// the two (in any channel), ignoring differences under a twentieth of the
/// frame's mean, which no tone curve shows.
pub(super) fn contrast_edges(color: &[Vec3], width: u32, height: u32) -> Vec<usize> {
    let (w, h) = (width as usize, height as usize);
    let mean = color.iter().map(|c| c.element_sum() / 3.0).sum::<f32>() / color.len().max(1) as f32;
    let floor = 0.05 * mean;
    let differs = |a: Vec3, b: Vec3| ((a - b).abs() - (a + b + Vec3::splat(floor)) * 0.1).max_element() > 0.0;
    let mut edge = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let c = color[i];
            if x + 1 < w && differs(c, color[i + 1]) {
                edge[i] = true;
                edge[i + 1] = true;
            }
            if y + 1 < h && differs(c, color[i + w]) {
                edge[i] = true;
                edge[i + w] = true;
            }
        }
    }
    edge.iter().enumerate().filter(|e| *e.1).map(|e| e.0).collect()
}

/// `values` cut into `count` slices of `len` (the last may be shorter), or
/// `count` empty ones when there are no values.
fn bands<T>(values: &mut [T], len: usize, count: usize) -> Vec<&mut [T]> {
    if values.is_empty() {
        (0..count).map(|_| <&mut [T]>::default()).collect()
    } else {
        values.chunks_mut(len).collect()
    }
}

/// Fills the pixels a thinned row skipped (`columns[y]` apart from column
/// 0) linearly between the traced ones around them, wrapping around the
/// row, then passed through `finish`.
fn fill_rows(values: &mut [Vec3], width: u32, columns: &[u32], finish: impl Fn(Vec3) -> Vec3) {
    let w = width as usize;
    for (row, &c) in values.chunks_exact_mut(w).zip(columns) {
        let c = c as usize;
        for before in (0..w).step_by(c) {
            let (a, b) = (row[before], row[(before + c) % w]);
            for r in 1..c {
                row[before + r] = finish(a.lerp(b, r as f32 / c as f32));
            }
        }
    }
}

/// How far past a hit to restart a ray, in its own `t` units.
fn offset_t(ray: &Ray, t: f32) -> f32 {
    super::surface::offset(ray.at(t)) / ray.dir.length().max(1e-20)
}

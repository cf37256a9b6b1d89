//! Visibility for the stages that choose and aim probes: what a point sees.
//! - [`CubeView`]: the closest hit through every pixel of a cube map around a
//!   point (exploration's occluded-space sampling and relaxation,
//!   orientation's view goodness).
//! - [`Targets`]: which of a set of reachable surface samples a point sees,
//!   as a bitset (exploration's greedy set cover, cluster synthesis).
//!
//! The coverage metric does not use this module: it draws its own samples
//! and tests the final probes with its own occlusion rays, so it checks the
//! choices made here rather than repeating them. It does share with
//! [`Targets`] the definition of which surface is reachable
//! (`samples::reachability`), so the stages optimise what it measures.

use crate::plan::freespace::FreeSpace;
use crate::plan::samples::{reachability, stratified_samples, SurfaceSamples};
use crate::raycast::{Hit, Packing, Ray, RayScene};
use exploremaps_scenes::Scene;
use glam::Vec3;

/// A probe's view: one closest hit per cube-map pixel, in pixel order
/// (face, row, column).
pub struct CubeView {
    pub origin: Vec3,
    pub res: usize,
    pub dirs: Vec<Vec3>,
    pub hits: Vec<Option<Hit>>,
}

impl CubeView {
    /// Traces the cube map with coherent packets of 4×2 pixel tiles.
    pub fn trace(rays: &RayScene, origin: Vec3, res: usize) -> CubeView {
        let res = res.max(2).next_multiple_of(4);
        let (tiled, order) = Self::tiled_rays(origin, res);
        let traced = rays.intersect_batch(&tiled, Packing::Coherent8);
        let mut hits = vec![None; tiled.len()];
        let mut dirs = vec![Vec3::ZERO; tiled.len()];
        for ((&p, h), r) in order.iter().zip(traced).zip(&tiled) {
            hits[p] = h;
            dirs[p] = r.dir;
        }
        CubeView { origin, res, dirs, hits }
    }

    /// The cube map's rays in tracing order (4×2 pixel tiles, face by face; `res`
    /// a multiple of 4), with the pixel index (face, row, column) of each.
    pub fn tiled_rays(origin: Vec3, res: usize) -> (Vec<Ray>, Vec<usize>) {
        let mut rays = Vec::with_capacity(6 * res * res);
        let mut order = Vec::with_capacity(6 * res * res);
        // Faces in the bundle's order and orientation (`exploremaps_format::cube_direction`).
        for f in 0..6 {
            for ty in (0..res).step_by(2) {
                for tx in (0..res).step_by(4) {
                    for y in ty..ty + 2 {
                        for x in tx..tx + 4 {
                            let (s, t) = ((x as f32 + 0.5) / res as f32, (y as f32 + 0.5) / res as f32);
                            rays.push(Ray::new(origin, Vec3::from(exploremaps_format::cube_direction(f, s, t)).normalize()));
                            order.push((f * res + y) * res + x);
                        }
                    }
                }
            }
        }
        (rays, order)
    }

    /// Surface area a pixel covers at its hit (solid angle × t² / cos).
    pub fn pixel_area(&self, pixel: usize) -> f32 {
        let Some(h) = self.hits[pixel] else { return 0.0 };
        let d = self.dirs[pixel];
        let (x, y) = (pixel % self.res, (pixel / self.res) % self.res);
        let sx = 2.0 * (x as f32 + 0.5) / self.res as f32 - 1.0;
        let sy = 1.0 - 2.0 * (y as f32 + 0.5) / self.res as f32;
        let texel = (2.0 / self.res as f32).powi(2);
        let solid_angle = texel / (1.0 + sx * sx + sy * sy).powf(1.5);
        let cos = h.normal.dot(d).abs().max(0.05);
        solid_angle * h.t * h.t / cos
    }

    pub fn point(&self, pixel: usize) -> Option<Vec3> {
        self.hits[pixel].map(|h| self.origin + self.dirs[pixel] * h.t)
    }

    /// Pairs of neighbouring pixels (same face) where one point lies more than
    /// τ + two pixel footprints off the other's tangent plane: (near pixel, far depth).
    pub fn depth_jumps(&self, tau: f32) -> Vec<(usize, f32)> {
        let r = self.res;
        let mut jumps = Vec::new();
        let footprint = 2.0 / r as f32;
        for f in 0..6 {
            for y in 0..r {
                for x in 0..r {
                    let a = (f * r + y) * r + x;
                    for b in [(x + 1 < r).then(|| a + 1), (y + 1 < r).then(|| a + r)].into_iter().flatten() {
                        let (Some(ha), Some(hb)) = (self.hits[a], self.hits[b]) else { continue };
                        let (near, far, hn, hf) = if ha.t <= hb.t { (a, b, ha, hb) } else { (b, a, hb, ha) };
                        let (pn, pf) = (self.origin + self.dirs[near] * hn.t, self.origin + self.dirs[far] * hf.t);
                        // Either point off the other's tangent plane, beyond the slack of
                        // sampling (one test alone misses a wall that continues past an opening).
                        let off = (pf - pn).dot(hn.normal).abs().max((pn - pf).dot(hf.normal).abs());
                        if off > tau + 2.0 * footprint * hf.t {
                            jumps.push((near, hf.t));
                        }
                    }
                }
            }
        }
        jumps
    }
}

/// The reachable ones among a set of surface samples, as bit positions, for
/// the stages that choose probes by what they see (exploration's greedy cover,
/// cluster synthesis). Sampling as in [`stratified_samples`].
pub struct Targets {
    pub samples: SurfaceSamples,
    /// Side each sample is reached from (+1 front, −1 back, 0 never).
    pub side: Vec<i8>,
    /// Indices of the reachable samples: bit k stands for `samples[index[k]]`.
    pub index: Vec<usize>,
    eps: f32,
}

impl Targets {
    /// Samples the surface and keeps the reachable samples; returns the rays cast.
    pub fn new(scene: &Scene, rays: &RayScene, space: &FreeSpace, count: usize, min_per_object: usize, seed: u64) -> (Targets, usize) {
        // The per-object floor shrinks with many objects, so the extra samples stay
        // within `count` (a scene merged from 775 parts would otherwise take 200,000).
        let min_per_object = min_per_object.min(count / scene.objects.len().max(1)).max(1);
        let samples = stratified_samples(scene, count, min_per_object, seed);
        let (side, _, cast) = reachability(rays, space, &samples, 8, seed);
        let index = (0..samples.points.len()).filter(|&i| side[i] != 0).collect();
        (Targets { samples, side, index, eps: 1e-3 * space.bounds.diagonal().max(1e-6) }, cast)
    }

    pub fn len(&self) -> usize {
        self.index.len()
    }

    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// 64-bit words of a bitset over the targets.
    pub fn words(&self) -> usize {
        self.index.len().div_ceil(64)
    }

    /// The targets `eye` sees from the side they are reached from, among those
    /// set in `among` (all when `None`); returns the bitset and the rays cast.
    pub fn seen_by(&self, rays: &RayScene, eye: Vec3, among: Option<&[u64]>) -> (Vec<u64>, usize) {
        let s = &self.samples;
        let facing: Vec<usize> = (0..self.index.len())
            .filter(|&k| among.is_none_or(|m| m[k / 64] >> (k % 64) & 1 == 1))
            .filter(|&k| {
                let i = self.index[k];
                (eye - s.points[i]).dot(s.normals[i]) * self.side[i] as f32 > 0.0
            })
            .collect();
        let segments: Vec<Ray> = facing
            .iter()
            .map(|&k| {
                let i = self.index[k];
                Ray::segment(eye, s.points[i] + s.normals[i] * (self.eps * self.side[i] as f32))
            })
            .collect();
        let mut blocked = vec![false; segments.len()];
        rays.occluded_into(&segments, &mut blocked, Packing::Packets8);
        let mut bits = vec![0u64; self.words()];
        for (&k, b) in facing.iter().zip(blocked) {
            if !b {
                bits[k / 64] |= 1 << (k % 64);
            }
        }
        (bits, segments.len())
    }
}

/// Set bits of a bitset.
pub fn count_bits(bits: &[u64]) -> usize {
    bits.iter().map(|w| w.count_ones() as usize).sum()
}

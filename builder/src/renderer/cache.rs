//! The radiance cache: indirect irradiance baked once per scene on a hashed
//! grid of surface cells, so hundreds of panoramas and video frames share one
//! global-illumination solution instead of path tracing each anew.
//!
//! Cells are keyed by grid position and the dominant axis of the surface
//! normal (so the two sides of a wall, or a floor and the wall beside it,
//! never share a cell). They are created where the viewpoints see surfaces,
//! then where those cells' gather rays land, for a few generations.
//!
//! Each cell gathers once: cosine-weighted rays from points in the cell
//! record what they hit. A hit contributes a fixed part (emission, direct
//! light from the sampled lights, sky on a miss) and a part proportional to
//! the indirect irradiance of the cell it hit. The gather graph is then
//! solved by Jacobi iteration, which gives every bounce for the price of one
//! gather: E(c) = π/K · Σ_j [A_j + ρ_j/π · E(target_j)].

use super::surface::{cosine_direction, fibonacci_sphere, Surface, Which};
use super::trace::{sampler, Tracer};
use crate::raycast::Ray;
use glam::{IVec3, Vec2, Vec3};
use rand::Rng;
use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;
use std::f32::consts::PI;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheParams {
    /// Cell edge in scene units.
    pub cell: f32,
    /// Gather rays per cell.
    pub gather_rays: usize,
    /// Rays cast from each viewpoint to find the visible surfaces.
    pub seed_rays: usize,
    pub max_cells: usize,
    /// Rounds of creating cells where gather rays land.
    pub generations: usize,
    pub seed: u64,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct CacheStats {
    pub cells: usize,
    pub gather_rays: usize,
    /// Gather hits that found no cell (they use the mean irradiance).
    pub missing: usize,
    pub iterations: usize,
    pub seconds: f64,
}

pub struct RadianceCache {
    cell: f32,
    index: HashMap<u64, u32>,
    /// Indirect irradiance per cell (everything but the directly sampled lights).
    irradiance: Vec<Vec3>,
    /// Direct irradiance from point lights per cell, for renders that bake them.
    points: Vec<Vec3>,
    /// Direct irradiance from the suns per cell: with `points`, what a final
    /// gather's second hits take instead of a shadow ray each.
    suns: Vec<Vec3>,
    mean: Vec3,
    pub stats: CacheStats,
}

/// Dominant normal axis with its sign, 0..6.
fn normal_bin(n: Vec3) -> u64 {
    let a = n.abs();
    if a.x >= a.y && a.x >= a.z {
        u64::from(n.x < 0.0)
    } else if a.y >= a.z {
        2 + u64::from(n.y < 0.0)
    } else {
        4 + u64::from(n.z < 0.0)
    }
}

fn key(cell: IVec3, bin: u64) -> u64 {
    // 20 bits an axis (a million cells across) and 3 for the normal.
    let c = |v: i32| (v as u64) & 0xF_FFFF;
    (c(cell.x) << 44) | (c(cell.y) << 24) | (c(cell.z) << 4) | bin
}

/// One cell while the cache is built: the surface points its gathers start from.
struct Cell {
    points: Vec<(Vec3, Vec3)>,
}

/// What one cell's gather found: the fixed part and the links to other cells.
#[derive(Default)]
struct Gathered {
    fixed: Vec3,
    /// (position, normal, ρ/π) of hit surfaces, resolved to cells afterwards.
    hits: Vec<(Vec3, Vec3, Vec3)>,
}

const MAX_POINTS: usize = 4;

impl RadianceCache {
    fn cell_of(&self, p: Vec3) -> IVec3 {
        (p / self.cell).floor().as_ivec3()
    }

    fn find(&self, p: Vec3, n: Vec3) -> Option<u32> {
        self.index.get(&key(self.cell_of(p), normal_bin(n))).copied()
    }

    /// Builds the cache from surfaces seen from `viewpoints`.
    pub fn build(tracer: &Tracer, viewpoints: &[Vec3], params: &CacheParams) -> RadianceCache {
        let started = std::time::Instant::now();
        let mut cache = RadianceCache { cell: params.cell, index: HashMap::default(), irradiance: Vec::new(), points: Vec::new(), suns: Vec::new(), mean: Vec3::ZERO, stats: CacheStats::default() };
        let mut cells: Vec<Cell> = Vec::new();
        let add = |cache: &mut RadianceCache, cells: &mut Vec<Cell>, p: Vec3, n: Vec3, create: bool| -> Option<u32> {
            let k = key(cache.cell_of(p), normal_bin(n));
            if let Some(&i) = cache.index.get(&k) {
                let c = &mut cells[i as usize].points;
                if c.len() < MAX_POINTS {
                    c.push((p, n));
                }
                return Some(i);
            }
            if !create || cells.len() >= params.max_cells {
                return None;
            }
            let i = cells.len() as u32;
            cache.index.insert(k, i);
            cells.push(Cell { points: vec![(p, n)] });
            Some(i)
        };

        // Seeds: what the viewpoints see.
        let dirs = fibonacci_sphere(params.seed_rays);
        let seen: Vec<Vec<Surface>> = viewpoints
            .par_iter()
            .map(|&eye| {
                dirs.iter()
                    .filter_map(|&d| {
                        let mut ray = Ray::new(eye, d);
                        tracer.intersect(&mut ray).map(|h| tracer.materials.surface(&ray, &h))
                    })
                    .collect()
            })
            .collect();
        for s in seen.iter().flatten() {
            add(&mut cache, &mut cells, s.position, s.geometric, true);
        }

        // Gather, generation by generation; sequential bookkeeping keeps the
        // cell numbering independent of the thread count.
        let mut fixed = Vec::new();
        let mut links: Vec<Vec<(u32, Vec3)>> = Vec::new();
        let mut missing_weight: Vec<Vec3> = Vec::new();
        let mut start = 0;
        for generation in 0..=params.generations {
            let end = cells.len();
            if start == end {
                break;
            }
            let gathered: Vec<Gathered> = (start..end).into_par_iter().map(|c| gather(tracer, &cells[c], c as u64, params)).collect();
            for g in gathered {
                let mut row: Vec<(u32, Vec3)> = Vec::new();
                let mut lost = Vec3::ZERO;
                for (p, n, weight) in g.hits {
                    match add(&mut cache, &mut cells, p, n, generation < params.generations) {
                        Some(t) => row.push((t, weight)),
                        None => {
                            lost += weight;
                            cache.stats.missing += 1;
                        }
                    }
                }
                row.sort_by_key(|e| e.0);
                row.dedup_by(|b, a| {
                    let same = a.0 == b.0;
                    if same {
                        a.1 += b.1;
                    }
                    same
                });
                fixed.push(g.fixed);
                links.push(row);
                missing_weight.push(lost);
            }
            start = end;
        }
        let n = links.len();
        cache.stats.cells = n;
        cache.stats.gather_rays = n * params.gather_rays;

        // Solve E = π/K (A + Σ w E_target + lost · mean E) by Jacobi iteration.
        let scale = PI / params.gather_rays as f32;
        let mut e: Vec<Vec3> = fixed.iter().map(|&a| a * scale).collect();
        for iteration in 1..=500 {
            let mean = e.iter().copied().sum::<Vec3>() / n.max(1) as f32;
            let next: Vec<Vec3> = (0..n)
                .into_par_iter()
                .map(|c| (fixed[c] + links[c].iter().map(|&(t, w)| w * e[t as usize]).sum::<Vec3>() + missing_weight[c] * mean) * scale)
                .collect();
            let change = next.iter().zip(&e).map(|(a, b)| (*a - *b).abs().max_element() / (a.max_element() + 1e-6)).fold(0.0f32, f32::max);
            e = next;
            cache.stats.iterations = iteration;
            if change < 1e-5 {
                break;
            }
        }
        // Direct light per cell, averaged over its points: point lights (for
        // renders that bake them) and suns (for a final gather's second hits).
        let direct = |which: Which, stream: u64| -> Vec<Vec3> {
            cells
                .par_iter()
                .enumerate()
                .map(|(c, cell)| {
                    let mut rng = sampler(params.seed, stream, c as u64);
                    let sum: Vec3 = cell
                        .points
                        .iter()
                        .map(|&(p, n)| tracer.direct(&Surface { position: p, normal: n, geometric: n, albedo: Vec3::ZERO, emission: Vec3::ZERO }, which, &mut rng))
                        .sum();
                    sum / cell.points.len() as f32
                })
                .collect()
        };
        if !tracer.lighting.points.is_empty() {
            cache.points = direct(Which::Points, 0xD1EC7);
        }
        if !tracer.lighting.suns.is_empty() {
            cache.suns = direct(Which::Suns, 0x5A45);
        }
        cache.mean = e.iter().copied().sum::<Vec3>() / n.max(1) as f32;
        cache.irradiance = e;
        cache.index.shrink_to_fit();
        cache.stats.seconds = started.elapsed().as_secs_f64();
        cache
    }

    /// Indirect irradiance at a surface point (plus the point lights' direct
    /// irradiance with `points`), interpolated bilinearly between the centres
    /// of the cells around it that exist (noise-free).
    pub fn irradiance(&self, p: Vec3, n: Vec3, points: bool) -> Vec3 {
        let value = |i: usize| self.irradiance[i] + if points { self.points.get(i).copied().unwrap_or_default() } else { Vec3::ZERO };
        self.interpolate(p, n, value).unwrap_or_else(|| self.find(p, n).map_or(self.mean, |i| value(i as usize)))
    }

    /// The point lights' direct irradiance blurred to cells (zero without
    /// point lights), for renders that bake them.
    pub fn point_irradiance(&self, p: Vec3, n: Vec3) -> Vec3 {
        if self.points.is_empty() {
            return Vec3::ZERO;
        }
        self.interpolate(p, n, |i| self.points[i]).or_else(|| self.find(p, n).map(|i| self.points[i as usize])).unwrap_or_default()
    }

    /// Everything a surface point receives, direct light of every sampled
    /// light included (blurred to cells: right for a final gather's second
    /// hits, where the gather averages it); `None` where no cell is near.
    pub fn total_irradiance(&self, p: Vec3, n: Vec3) -> Option<Vec3> {
        let at = |v: &[Vec3], i: usize| v.get(i).copied().unwrap_or_default();
        let value = |i: usize| self.irradiance[i] + at(&self.points, i) + at(&self.suns, i);
        self.interpolate(p, n, value).or_else(|| self.find(p, n).map(|i| value(i as usize)))
    }

    /// Bilinear interpolation across the surface of a per-cell value between
    /// the centres of the cells around `p` that exist; along the normal, the
    /// cell `p` is in.
    fn interpolate(&self, p: Vec3, n: Vec3, value: impl Fn(usize) -> Vec3) -> Option<Vec3> {
        let bin = normal_bin(n);
        let axis = (bin / 2) as usize;
        let mut g = p / self.cell - 0.5;
        g[axis] = (p[axis] / self.cell).floor();
        let base = g.floor();
        let f = g - base;
        let base = base.as_ivec3();
        let (mut sum, mut weight) = (Vec3::ZERO, 0.0);
        for corner in 0..8 {
            let o = IVec3::new(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let w = (if o.x == 1 { f.x } else { 1.0 - f.x }) * (if o.y == 1 { f.y } else { 1.0 - f.y }) * (if o.z == 1 { f.z } else { 1.0 - f.z });
            if w <= 0.0 {
                continue;
            }
            if let Some(&i) = self.index.get(&key(base + o, bin)) {
                sum += value(i as usize) * w;
                weight += w;
            }
        }
        (weight > 1e-4).then(|| sum / weight)
    }

    /// One cell lookup at a point jittered by up to half a cell: cheaper than
    /// [`Self::irradiance`] and smooth once averaged over samples.
    pub fn irradiance_jittered(&self, p: Vec3, n: Vec3, rng: &mut impl Rng) -> Vec3 {
        let jitter = Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5;
        let q = p + (jitter - n * n.dot(jitter)) * self.cell;
        self.find(q, n).or_else(|| self.find(p, n)).map_or(self.mean, |i| self.irradiance[i as usize])
    }
}

/// A cell's gather: stratified cosine-weighted rays from its points.
fn gather(tracer: &Tracer, cell: &Cell, index: u64, params: &CacheParams) -> Gathered {
    let mut rng = sampler(params.seed, 0xCAC4E, index);
    let mut out = Gathered::default();
    let k = params.gather_rays;
    let side = (k as f32).sqrt().ceil() as usize;
    for j in 0..k {
        let (p, n) = cell.points[j % cell.points.len()];
        let here = Surface { position: p, normal: n, geometric: n, albedo: Vec3::ZERO, emission: Vec3::ZERO };
        let u = Vec2::new(((j % side) as f32 + rng.random::<f32>()) / side as f32, ((j / side % side) as f32 + rng.random::<f32>()) / side as f32);
        let mut ray = Ray::new(here.lifted(), cosine_direction(n, u));
        match tracer.intersect(&mut ray) {
            None => out.fixed += tracer.lighting.sky.radiance(ray.dir),
            Some(hit) => {
                let s = tracer.materials.surface(&ray, &hit);
                let direct = tracer.direct(&s, Which::All, &mut rng);
                let brdf = s.albedo / PI;
                out.fixed += s.emission + brdf * direct;
                if brdf != Vec3::ZERO {
                    out.hits.push((s.position, s.geometric, brdf));
                }
            }
        }
    }
    out
}

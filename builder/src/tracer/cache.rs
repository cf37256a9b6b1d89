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

use super::surface::{cosine_direction, fibonacci_sphere, lattice, Surface, Which};
use super::trace::{image, sampler, Tracer, Work};
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
    /// The cells at the four corners of each square between cell centres (in
    /// the plane across the normal bin's axis, keyed as the square's lowest
    /// corner cell), `u32::MAX` where none: interpolation costs one hash
    /// lookup instead of four (a final gather makes one at every ray's hit).
    corners: Squares,
    /// Indirect irradiance per cell (everything but the directly sampled lights).
    irradiance: Vec<Vec3>,
    /// Direct irradiance from point lights per cell, for renders that bake them.
    points: Vec<Vec3>,
    /// Which point lights each cell's points saw: `lamp_words` bits a cell,
    /// one a light ([`Self::lamps_seen`]).
    lamps: Vec<u64>,
    lamp_words: usize,
    /// Everything per cell: indirect, point lights and suns (direct light
    /// blurred to cells, what a final gather's second hits take instead of a
    /// shadow ray each).
    total: Vec<Vec3>,
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

/// 20 bits an axis of a key (a million cells across; coordinates wrap).
const AXIS_BITS: u64 = 0xF_FFFF;
const AXIS_SHIFTS: [u64; 3] = [44, 24, 4];

fn key(cell: IVec3, bin: u64) -> u64 {
    pack(cell.to_array().map(|v| v as u64), bin)
}

/// A key from three cell coordinates (each taken modulo 2^20) and a bin.
fn pack(c: [u64; 3], bin: u64) -> u64 {
    let c = c.map(|v| v & AXIS_BITS);
    (c[0] << AXIS_SHIFTS[0]) | (c[1] << AXIS_SHIFTS[1]) | (c[2] << AXIS_SHIFTS[2]) | bin
}

/// [`RadianceCache::corners`]' table.
type Squares = std::collections::HashMap<u64, [u32; 4], std::hash::BuildHasherDefault<Nearby>>;

/// The two axes across a normal bin's axis, in increasing order.
fn across(bin: u64) -> (usize, usize) {
    match bin / 2 {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// A hash of cell keys that keeps the cells of a 4 × 4 × 4 block (all
/// normal bins) in neighbouring buckets: a gather's rays from neighbouring
/// pixels hit near each other, so their lookups share cache lines and pages
/// instead of each missing (the table outgrows the caches).
#[derive(Default)]
struct Nearby(u64);

impl std::hash::Hasher for Nearby {
    fn write(&mut self, _: &[u8]) {
        unreachable!("cell keys are hashed as u64")
    }
    fn write_u64(&mut self, k: u64) {
        // A block's cells take buckets in a run from where its hash puts the
        // block: the offset is each axis's two low bits and the bin.
        let fine = |s: u64| (k >> s) & 3;
        let low = fine(AXIS_SHIFTS[0]) | fine(AXIS_SHIFTS[1]) << 2 | fine(AXIS_SHIFTS[2]) << 4 | (k & 7) << 6;
        let block = k & !(0x3 << AXIS_SHIFTS[0] | 0x3 << AXIS_SHIFTS[1] | 0x3 << AXIS_SHIFTS[2] | 0xF);
        let h = block.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(26);
        // The top 7 bits tell entries apart within a probed group: mix the offset in.
        self.0 = h.wrapping_add(low) ^ (low << 57);
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

/// [`RadianceCache::corners`] of an index of cells.
fn corners(index: &HashMap<u64, u32>) -> Squares {
    let mut corners = Squares::default();
    corners.reserve(2 * index.len());
    for (&k, &i) in index {
        let bin = k & 0xF;
        let (a, b) = across(bin);
        let mut c = AXIS_SHIFTS.map(|s| (k >> s) & AXIS_BITS);
        let (ca, cb) = (c[a], c[b]);
        // The cell is corner (da, db) of the square whose lowest corner is da, db below it.
        for slot in 0..4 {
            c[a] = ca.wrapping_sub(slot & 1);
            c[b] = cb.wrapping_sub(slot >> 1);
            corners.entry(pack(c, bin)).or_insert([u32::MAX; 4])[slot as usize] = i;
        }
    }
    corners
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

/// The cell grid's shift, in cells (see [`RadianceCache::grid`]): a fraction
/// no round coordinate lands on.
const GRID_OFFSET: Vec3 = Vec3::splat(0.3719);

/// The cell that holds `p`, for cells of size `cell`.
fn grid_cell(p: Vec3, cell: f32) -> IVec3 {
    (p / cell + GRID_OFFSET).floor().as_ivec3()
}

impl RadianceCache {
    /// `p` in units of cells, on a grid shifted off round coordinates: walls
    /// at whole metres (or any multiple of the cell) would otherwise lie on
    /// a boundary between two layers of cells, and which layer a hit on them
    /// reads would hang on the last bits of its coordinates (they differ
    /// between Embree's AVX2 and AVX-512 kernels).
    fn grid(&self, p: Vec3) -> Vec3 {
        p / self.cell + GRID_OFFSET
    }

    fn cell_of(&self, p: Vec3) -> IVec3 {
        grid_cell(p, self.cell)
    }

    fn find(&self, p: Vec3, n: Vec3) -> Option<u32> {
        self.index.get(&key(self.cell_of(p), normal_bin(n))).copied()
    }

    /// Builds the cache from surfaces seen from `viewpoints`.
    pub fn build(tracer: &Tracer, viewpoints: &[Vec3], params: &CacheParams) -> RadianceCache {
        let started = std::time::Instant::now();
        let mut cells = Cells { cell: params.cell, max_cells: params.max_cells, index: HashMap::default(), cells: Vec::new() };
        cells.seed(tracer, viewpoints, params.seed_rays);
        let links = cells.gather(tracer, params);
        let n = links.fixed.len();
        let (irradiance, iterations) = links.solve(PI / params.gather_rays as f32);
        let (points, lamps, lamp_words) = point_lights(tracer, &cells.cells);
        let suns = sunlight(tracer, &cells.cells, params.seed);
        let at = |v: &[Vec3], i: usize| v.get(i).copied().unwrap_or_default();
        let mut index = cells.index;
        index.shrink_to_fit();
        RadianceCache {
            cell: params.cell,
            corners: corners(&index),
            index,
            total: (0..n).map(|i| irradiance[i] + at(&points, i) + at(&suns, i)).collect(),
            mean: irradiance.iter().copied().sum::<Vec3>() / n.max(1) as f32,
            irradiance,
            points,
            lamps,
            lamp_words,
            stats: CacheStats {
                cells: n,
                gather_rays: n * params.gather_rays,
                missing: links.missing,
                iterations,
                seconds: started.elapsed().as_secs_f64(),
            },
        }
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

    /// Which point lights the cache's points around `p` saw (those of the
    /// 2 × 2 cells nearest, so a light is seen a little beyond where a
    /// point saw it); `None` where no cell is near.
    pub fn lamps_seen(&self, p: Vec3, n: Vec3) -> Option<LampsSeen<'_>> {
        if self.lamp_words == 0 {
            return None;
        }
        let (g, bin) = self.square(p, n);
        // (The square holds the cell `p` is in, so it exists wherever that cell does.)
        let cells = *self.corners.get(&key(g.floor().as_ivec3(), bin))?;
        Some(LampsSeen { cache: self, cells })
    }

    /// Marks every point light as seen, or none, from every cell (tests).
    #[cfg(test)]
    pub(super) fn see_every_lamp(&mut self, seen: bool) {
        self.lamps.fill(if seen { u64::MAX } else { 0 });
    }

    /// Everything a surface point receives, direct light of every sampled
    /// light included (blurred to cells: right for a final gather's second
    /// hits, where the gather averages it); `None` where no cell is near.
    pub fn total_irradiance(&self, p: Vec3, n: Vec3) -> Option<Vec3> {
        let value = |i: usize| self.total[i];
        self.interpolate(p, n, value).or_else(|| self.find(p, n).map(|i| value(i as usize)))
    }

    /// `p` in units of cells from the centre of the lowest cell of the
    /// square of cell centres around it (in the plane across the normal
    /// bin's axis; along it, the cell `p` is in), and the bin.
    fn square(&self, p: Vec3, n: Vec3) -> (Vec3, u64) {
        let bin = normal_bin(n);
        let axis = (bin / 2) as usize;
        let u = self.grid(p);
        let mut g = u - 0.5;
        g[axis] = u[axis].floor();
        (g, bin)
    }

    /// Bilinear interpolation across the surface of a per-cell value between
    /// the centres of the cells around `p` that exist; along the normal, the
    /// cell `p` is in.
    fn interpolate(&self, p: Vec3, n: Vec3, value: impl Fn(usize) -> Vec3) -> Option<Vec3> {
        let (g, bin) = self.square(p, n);
        let base = g.floor();
        let f = g - base;
        let cells = self.corners.get(&key(base.as_ivec3(), bin))?;
        let (a, b) = across(bin);
        let (mut sum, mut weight) = (Vec3::ZERO, 0.0);
        for (slot, &i) in cells.iter().enumerate() {
            let w = (if slot & 1 == 1 { f[a] } else { 1.0 - f[a] }) * (if slot >> 1 == 1 { f[b] } else { 1.0 - f[b] });
            if w > 0.0 && i != u32::MAX {
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

/// The point lights seen around a surface point ([`RadianceCache::lamps_seen`]).
pub struct LampsSeen<'a> {
    cache: &'a RadianceCache,
    cells: [u32; 4],
}

impl LampsSeen<'_> {
    /// Whether a point of these cells saw point light `lamp`.
    pub fn sees(&self, lamp: usize) -> bool {
        let words = self.cache.lamp_words;
        self.cells.iter().any(|&c| c != u32::MAX && self.cache.lamps[c as usize * words + lamp / 64] & 1 << (lamp % 64) != 0)
    }
}

/// One of a cell's points as a surface to light (its normal both ways).
fn cell_surface(position: Vec3, normal: Vec3) -> Surface {
    Surface { position, normal, geometric: normal, albedo: Vec3::ZERO, emission: Vec3::ZERO }
}

/// The cells as they are created: where the viewpoints see surfaces, then
/// where gather rays land.
struct Cells {
    cell: f32,
    max_cells: usize,
    index: HashMap<u64, u32>,
    cells: Vec<Cell>,
}

impl Cells {
    /// The cell of a surface point, keeping the point as one of its samples;
    /// with `create`, a new cell where there is none (up to the limit).
    fn add(&mut self, p: Vec3, n: Vec3, create: bool) -> Option<u32> {
        let k = key(grid_cell(p, self.cell), normal_bin(n));
        if let Some(&i) = self.index.get(&k) {
            let c = &mut self.cells[i as usize].points;
            if c.len() < MAX_POINTS {
                c.push((p, n));
            }
            return Some(i);
        }
        if !create || self.cells.len() >= self.max_cells {
            return None;
        }
        let i = self.cells.len() as u32;
        self.index.insert(k, i);
        self.cells.push(Cell { points: vec![(p, n)] });
        Some(i)
    }

    /// The first cells: what the viewpoints see.
    fn seed(&mut self, tracer: &Tracer, viewpoints: &[Vec3], rays: usize) {
        let dirs = fibonacci_sphere(rays);
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
            self.add(s.position, s.geometric, true);
        }
    }

    /// Gathers, generation by generation (the last creates no cells), into
    /// the links between cells; sequential bookkeeping keeps the cell
    /// numbering independent of the thread count.
    fn gather(&mut self, tracer: &Tracer, params: &CacheParams) -> Links {
        let mut links = Links::default();
        let mut start = 0;
        for generation in 0..=params.generations {
            let end = self.cells.len();
            if start == end {
                break;
            }
            let gathered: Vec<Gathered> = (start..end).into_par_iter().map(|c| gather(tracer, &self.cells[c], c as u64, params)).collect();
            for g in gathered {
                let mut row: Vec<(u32, Vec3)> = Vec::new();
                let mut lost = Vec3::ZERO;
                for (p, n, weight) in g.hits {
                    match self.add(p, n, generation < params.generations) {
                        Some(t) => row.push((t, weight)),
                        None => {
                            lost += weight;
                            links.missing += 1;
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
                links.fixed.push(g.fixed);
                links.to.push(row);
                links.lost.push(lost);
            }
            start = end;
        }
        links
    }
}

/// The gather graph, per cell: its fixed part, the cells its rays reached
/// with their weights, and the weight of rays that reached no cell.
#[derive(Default)]
struct Links {
    fixed: Vec<Vec3>,
    to: Vec<Vec<(u32, Vec3)>>,
    lost: Vec<Vec3>,
    /// Hits that reached no cell.
    missing: usize,
}

impl Links {
    /// Solves E = scale · (A + Σ w E_target + lost · mean E) by Jacobi
    /// iteration; returns E and the iterations taken.
    fn solve(&self, scale: f32) -> (Vec<Vec3>, usize) {
        let n = self.fixed.len();
        let mut e: Vec<Vec3> = self.fixed.iter().map(|&a| a * scale).collect();
        let mut iterations = 0;
        for iteration in 1..=500 {
            let mean = e.iter().copied().sum::<Vec3>() / n.max(1) as f32;
            let next: Vec<Vec3> = (0..n)
                .into_par_iter()
                .map(|c| (self.fixed[c] + self.to[c].iter().map(|&(t, w)| w * e[t as usize]).sum::<Vec3>() + self.lost[c] * mean) * scale)
                .collect();
            let change = next.iter().zip(&e).map(|(a, b)| (*a - *b).abs().max_element() / (a.max_element() + 1e-6)).fold(0.0f32, f32::max);
            e = next;
            iterations = iteration;
            if change < 1e-5 {
                break;
            }
        }
        (e, iterations)
    }
}

/// The point lights' direct light per cell, averaged over its points (for
/// renders that bake them), and which lights each cell saw (bit sets of
/// `words` words a cell): (light, bits, words); empty without point lights.
fn point_lights(tracer: &Tracer, cells: &[Cell]) -> (Vec<Vec3>, Vec<u64>, usize) {
    let lamps = tracer.lighting.points.len();
    if lamps == 0 {
        return (Vec::new(), Vec::new(), 0);
    }
    let words = lamps.div_ceil(64);
    let suns = tracer.lighting.suns.len();
    let per_cell: Vec<(Vec3, Vec<u64>)> = cells
        .par_iter()
        .map(|cell| {
            let (mut sum, mut seen) = (Vec3::ZERO, vec![0u64; words]);
            for &(p, n) in &cell.points {
                // (Point lights draw no random numbers.)
                tracer.lighting.shadow_rays(&cell_surface(p, n), Vec2::ZERO, Which::Points, 1, |k, ray, e| {
                    if tracer.visible(&ray) {
                        sum += e;
                        let lamp = k - suns;
                        seen[lamp / 64] |= 1 << (lamp % 64);
                    }
                });
            }
            (sum / cell.points.len() as f32, seen)
        })
        .collect();
    let light = per_cell.iter().map(|c| c.0).collect();
    (light, per_cell.into_iter().flat_map(|c| c.1).collect(), words)
}

/// The suns' direct light per cell, averaged over its points (for a final
/// gather's second hits); empty without suns.
fn sunlight(tracer: &Tracer, cells: &[Cell], seed: u64) -> Vec<Vec3> {
    if tracer.lighting.suns.is_empty() {
        return Vec::new();
    }
    cells
        .par_iter()
        .enumerate()
        .map(|(c, cell)| {
            let mut rng = sampler(seed, Work::CacheSun, image::NONE, c as u64);
            cell.points.iter().map(|&(p, n)| tracer.direct(&cell_surface(p, n), Which::Suns, &mut rng)).sum::<Vec3>() / cell.points.len() as f32
        })
        .collect()
}

/// A cell's gather: stratified cosine-weighted rays from its points.
fn gather(tracer: &Tracer, cell: &Cell, index: u64, params: &CacheParams) -> Gathered {
    let mut rng = sampler(params.seed, Work::CacheGather, image::NONE, index);
    let mut out = Gathered::default();
    let k = params.gather_rays;
    // A Fibonacci lattice shifted at random: even over the hemisphere for any
    // count. (A jittered square grid left its last row part empty when the
    // count was no square, 32 in preview: a whole band of directions
    // under-sampled, and the cache biased by it.)
    let shift = Vec2::new(rng.random(), rng.random());
    for j in 0..k {
        let (p, n) = cell.points[j % cell.points.len()];
        let here = cell_surface(p, n);
        let u = lattice(j, k, shift);
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

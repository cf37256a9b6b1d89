//! Light sampling for the reference path tracer (no cache): at every path
//! vertex, next-event estimation toward emissive triangles, toward the sky
//! through the scene's openings, and a connection to a sunlit point; each is
//! combined with the cosine-sampled bounce by multiple importance sampling
//! (Veach and Guibas 1995, balance heuristic), so the sum stays unbiased and
//! neither strategy's weak cases show. The bundle's renders do not use this:
//! they read the radiance cache.
//!
//! Why: in a room lit through a window most light comes off the small sunlit
//! patch on the floor and from the sky through the window, both of which
//! bounce rays find only by chance (thousands of samples a pixel).
//! - Sunlit points: a sun ray is traced in from a square outside the scene;
//!   its first hit is sunlit, with a known density per unit area, and the path
//!   vertex connects to it (a bidirectional path tracer's light vertex).
//! - Sky: a point on the scene's bounding box is chosen and the vertex looks
//!   toward it; every direction crosses the box once, so the density per
//!   solid angle is known.
//!
//! Both choose cells of a grid (on the sun's square, on the box's faces) by
//! what a pilot pass found useful: the sun's cells whose sunlit points the
//! surfaces seen from the viewpoints can see, the box's cells that bounce
//! rays from those surfaces leave through (the windows). A fifth of every
//! choice stays uniform, so no cell that carries light is ever left out.

use super::luminance;
use super::surface::{cosine_direction, fibonacci_sphere, Lighting, Surface};
use super::trace::{image, sampler, Tracer, Work};
use crate::raycast::Ray;
use exploremaps_scenes::Scene;
use glam::{Vec2, Vec3};
use rand::Rng;
use rand_pcg::Pcg32;
use rayon::prelude::*;
use std::f32::consts::PI;

/// The reference's light tables are the same whatever the run's seed, so
/// references drawn with different seeds differ only in their samples.
const TABLES_SEED: u64 = 0x5EED;

/// Where the reference's light samples come from.
pub struct LightSampler {
    /// (triangle, corners, emitted radiance) of every emissive triangle.
    emitters: Vec<Emitter>,
    /// Chooses an emitter by area × luminance.
    emitter_table: Table,
    suns: Vec<SunSquare>,
    /// The scene's bounding box, a little enlarged; `None` without a sky.
    sky: Option<SkyBox>,
}

/// A square outside the scene, facing a sun, from which its rays are traced in.
struct SunSquare {
    dir: Vec3,
    centre: Vec3,
    axes: (Vec3, Vec3),
    half: f32,
    cells: Table,
}

struct SkyBox {
    lo: Vec3,
    hi: Vec3,
    /// CELLS² cells on each of the six faces (axis-major, low side first).
    cells: Table,
}

/// Cells a side of the sun's square and of each face of the sky box.
const CELLS: usize = 32;
/// Share of every grid choice that stays uniform.
const UNIFORM: f32 = 0.2;

/// A discrete distribution.
struct Table {
    cdf: Vec<f32>,
}

impl Table {
    /// From non-negative weights, none of which need be positive (then empty).
    fn new(weights: impl IntoIterator<Item = f32>) -> Table {
        let mut total = 0.0;
        let cdf: Vec<f32> = weights
            .into_iter()
            .map(|w| {
                total += w.max(0.0);
                total
            })
            .collect();
        Table { cdf: if total > 0.0 { cdf } else { Vec::new() } }
    }

    /// Mixes `counts` (normalized) with the uniform distribution by `UNIFORM`.
    fn mixed(counts: &[f32]) -> Table {
        let total: f32 = counts.iter().sum();
        let n = counts.len() as f32;
        Table::new(counts.iter().map(|&c| if total > 0.0 { (1.0 - UNIFORM) * c / total + UNIFORM / n } else { 1.0 / n }))
    }

    fn sample(&self, u: f32) -> usize {
        let total = self.cdf.last().copied().unwrap_or(0.0);
        self.cdf.partition_point(|&c| c <= u * total).min(self.cdf.len().saturating_sub(1))
    }

    fn probability(&self, i: usize) -> f32 {
        let total = self.cdf.last().copied().unwrap_or(0.0);
        if i >= self.cdf.len() || total <= 0.0 {
            return 0.0;
        }
        (self.cdf[i] - if i == 0 { 0.0 } else { self.cdf[i - 1] }) / total
    }
}

/// Density per unit solid angle of a cosine bounce from `x` along unit `w`.
fn bounce_solid(x: &Surface, w: Vec3) -> f32 {
    if w.dot(x.geometric) <= 0.0 {
        return 0.0;
    }
    w.dot(x.normal).max(0.0) / PI
}

/// Density per unit area at `y` (geometric normal `n`) of the point a cosine
/// bounce from `x` reaches, if nothing is in between.
fn bounce_area(x: &Surface, y: Vec3, n: Vec3) -> f32 {
    let to = y - x.position;
    let d2 = to.length_squared().max(1e-12);
    let w = to / d2.sqrt();
    bounce_solid(x, w) * w.dot(n).abs() / d2
}

/// Balance heuristic weight of strategy `p` against `q`.
fn balance(p: f32, q: f32) -> f32 {
    if p + q > 0.0 {
        p / (p + q)
    } else {
        1.0
    }
}

/// An emissive triangle: its index, corners and emission.
type Emitter = (u32, [Vec3; 3], Vec3);

/// The emissive triangles and the power of each.
fn emitters(tracer: &Tracer, scene: &Scene) -> (Vec<Emitter>, Vec<f32>) {
    let mut emitters = Vec::new();
    let mut power = Vec::new();
    for (t, tri) in scene.triangles.iter().enumerate() {
        let e = tracer.materials.emission(t as u32);
        let corners = tri.map(|i| scene.positions[i as usize]);
        let area = 0.5 * (corners[1] - corners[0]).cross(corners[2] - corners[0]).length();
        let p = area * luminance(e);
        if p > 0.0 && p.is_finite() {
            emitters.push((t as u32, corners, e));
            power.push(p);
        }
    }
    (emitters, power)
}

/// The pilot: surfaces the viewpoints see, and those one bounce further.
fn pilot(tracer: &Tracer, viewpoints: &[Vec3]) -> Vec<Surface> {
    let views: Vec<Vec3> = viewpoints.iter().step_by(viewpoints.len().div_ceil(8).max(1)).copied().collect();
    let dirs = fibonacci_sphere(1024);
    (0..views.len() * dirs.len())
        .into_par_iter()
        .flat_map_iter(|i| {
            let mut rng = sampler(TABLES_SEED, Work::LightPilot, image::NONE, i as u64);
            let mut ray = Ray::new(views[i / dirs.len()], dirs[i % dirs.len()]);
            let first = tracer.intersect(&mut ray).map(|h| tracer.materials.surface(&ray, &h));
            let second = first.and_then(|s| {
                let mut ray = Ray::new(s.lifted(), cosine_direction(s.normal, Vec2::new(rng.random(), rng.random())));
                tracer.intersect(&mut ray).map(|h| tracer.materials.surface(&ray, &h))
            });
            first.into_iter().chain(second)
        })
        .collect()
}

impl SunSquare {
    /// A sun's square over the scene's box `(lo, hi)`, its cells weighed by
    /// how many pilot surfaces see the sunlit points of each.
    fn learn(tracer: &Tracer, surfaces: &[Surface], dir: Vec3, (lo, hi): (Vec3, Vec3)) -> SunSquare {
        let axes = dir.any_orthonormal_pair();
        let half = (hi - lo).length() / 2.0 * 1.01;
        let centre = (lo + hi) / 2.0 + dir * half;
        let counts: Vec<f32> = (0..CELLS * CELLS)
            .into_par_iter()
            .map(|c| {
                let mut rng = sampler(TABLES_SEED, Work::LightCells, image::NONE, c as u64);
                let mut seen = 0;
                for _ in 0..4 {
                    let (a, b) = cell_point(c, rng.random(), rng.random());
                    let mut ray = Ray::new(centre + (axes.0 * a + axes.1 * b) * half, -dir);
                    let Some(hit) = tracer.intersect(&mut ray) else { continue };
                    let y = tracer.materials.surface(&ray, &hit).lifted();
                    for _ in 0..8 {
                        if surfaces.is_empty() {
                            break;
                        }
                        let s = &surfaces[rng.random_range(0..surfaces.len())];
                        let to = y - s.lifted();
                        if to.dot(s.geometric) > 0.0 && tracer.visible(&Ray { t_max: 1.0, ..Ray::new(s.lifted(), to) }) {
                            seen += 1;
                        }
                    }
                }
                seen as f32
            })
            .collect();
        SunSquare { dir, centre, axes, half, cells: Table::mixed(&counts) }
    }
}

impl SkyBox {
    /// The sky's box `lo..hi`, its cells weighed by where bounce rays from
    /// the pilot surfaces leave it, mixed with a uniform share by area.
    fn learn(tracer: &Tracer, surfaces: &[Surface], lo: Vec3, hi: Vec3) -> SkyBox {
        let exits: Vec<usize> = surfaces
            .par_iter()
            .enumerate()
            .flat_map_iter(|(i, s)| {
                let mut rng = sampler(TABLES_SEED, Work::LightExits, image::NONE, i as u64);
                (0..64)
                    .filter_map(|_| {
                        let w = cosine_direction(s.normal, Vec2::new(rng.random(), rng.random()));
                        let mut ray = Ray::new(s.lifted(), w);
                        if w.dot(s.geometric) <= 0.0 || tracer.intersect(&mut ray).is_some() {
                            return None;
                        }
                        exit_cell(lo, hi, s.position, w).map(|(c, _)| c)
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let mut counts = vec![0.0; 6 * CELLS * CELLS];
        for c in exits {
            counts[c] += 1.0;
        }
        // Uniform by area, not by cell: scale the uniform share per face.
        let areas: Vec<f32> = (0..6).map(|f| face_area(lo, hi, f / 2)).collect();
        let total_area: f32 = areas.iter().sum();
        let seen: f32 = counts.iter().sum();
        let weights = counts.iter().enumerate().map(|(c, &n)| {
            let uniform = UNIFORM * areas[c / (CELLS * CELLS)] / total_area / (CELLS * CELLS) as f32;
            if seen > 0.0 {
                (1.0 - UNIFORM) * n / seen + uniform
            } else {
                uniform
            }
        });
        SkyBox { lo, hi, cells: Table::new(weights) }
    }
}

impl LightSampler {
    /// Lights of `tracer`'s scene, with grids learnt from what `viewpoints` see.
    pub fn new(tracer: &Tracer, scene: &Scene, viewpoints: &[Vec3]) -> LightSampler {
        let (emitters, power) = emitters(tracer, scene);
        let (lo, hi) = scene.positions.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let (lo, hi) = if lo.x <= hi.x { (lo, hi) } else { (Vec3::ZERO, Vec3::ZERO) };
        let margin = 1e-3 * (hi - lo).length() + 1e-3;
        let (lo, hi) = (lo - Vec3::splat(margin), hi + Vec3::splat(margin));
        let surfaces = pilot(tracer, viewpoints);
        let suns = tracer.lighting.suns.iter().map(|&(dir, _)| SunSquare::learn(tracer, &surfaces, dir, (lo, hi))).collect();
        let lit_sky = tracer.lighting.sky.zenith.max_element() > 0.0 || tracer.lighting.sky.horizon.max_element() > 0.0;
        let sky = lit_sky.then(|| SkyBox::learn(tracer, &surfaces, lo, hi));
        LightSampler { emitters, emitter_table: Table::new(power), suns, sky }
    }

    /// Density per unit area with which an emitter sample lands on a point of `triangle`.
    fn emitter_area(&self, triangle: u32) -> f32 {
        match self.emitters.binary_search_by_key(&triangle, |e| e.0) {
            Ok(i) => {
                let [a, b, c] = self.emitters[i].1;
                self.emitter_table.probability(i) / (0.5 * (b - a).cross(c - a).length())
            }
            Err(_) => 0.0,
        }
    }

    /// Density per unit area with which sun `k`'s rays along `d` reach `y`, of
    /// geometric normal `n` (facing the sun).
    fn sun_area(&self, k: usize, y: Vec3, n: Vec3, d: Vec3) -> f32 {
        let sq = &self.suns[k];
        let along = d.dot(sq.dir);
        if along <= 0.0 {
            return 0.0;
        }
        let on_square = y + d * ((sq.centre - y).dot(sq.dir) / along);
        let rel = on_square - sq.centre;
        let (a, b) = (rel.dot(sq.axes.0) / sq.half, rel.dot(sq.axes.1) / sq.half);
        let Some(c) = square_cell(a, b) else { return 0.0 };
        let cell_area = (2.0 * sq.half / CELLS as f32).powi(2);
        sq.cells.probability(c) / cell_area * n.dot(d).max(0.0) / along
    }

    /// Density per unit solid angle with which a sky sample from `x` looks along unit `w`.
    fn sky_solid(&self, x: Vec3, w: Vec3) -> f32 {
        let Some(sky) = &self.sky else { return 0.0 };
        match exit_cell(sky.lo, sky.hi, x, w) {
            Some((c, t)) => {
                let axis = c / (2 * CELLS * CELLS);
                let cell_area = face_area(sky.lo, sky.hi, axis) / (CELLS * CELLS) as f32;
                sky.cells.probability(c) / cell_area * t * t / w[axis].abs().max(1e-12)
            }
            None => 0.0,
        }
    }

    /// Weight of the emission a cosine bounce from `from` finds at `hit`.
    pub fn bounce_weight_emission(&self, from: &Surface, hit: &Surface, triangle: u32) -> f32 {
        balance(bounce_area(from, hit.position, hit.geometric), self.emitter_area(triangle))
    }

    /// Weight of sun `k`'s light arriving along `d` at `hit`, a point a cosine
    /// bounce from `from` found.
    pub fn bounce_weight_sun(&self, k: usize, from: &Surface, hit: &Surface, d: Vec3) -> f32 {
        balance(bounce_area(from, hit.position, hit.geometric), self.sun_area(k, hit.position, hit.geometric, d))
    }

    /// Weight of the sky a cosine bounce from `from` along unit `w` escapes to.
    pub fn bounce_weight_sky(&self, from: &Surface, w: Vec3) -> f32 {
        balance(bounce_solid(from, w), self.sky_solid(from.lifted(), w))
    }

    /// Irradiance at `s` from every strategy here: emitters, sky, sunlit points.
    pub fn irradiance(&self, tracer: &Tracer, s: &Surface, rng: &mut Pcg32) -> Vec3 {
        self.emitters(tracer, s, rng) + self.sky(tracer, s, rng) + self.sunlit(tracer, s, rng)
    }

    /// Irradiance at `s` from one point on the emitters.
    fn emitters(&self, tracer: &Tracer, s: &Surface, rng: &mut Pcg32) -> Vec3 {
        if self.emitters.is_empty() {
            return Vec3::ZERO;
        }
        let i = self.emitter_table.sample(rng.random());
        let (triangle, [a, b, c], e) = self.emitters[i];
        let (u, v) = (rng.random::<f32>().sqrt(), rng.random::<f32>());
        let z = a * (1.0 - u) + b * (u * (1.0 - v)) + c * (u * v);
        let n = (b - a).cross(c - a).normalize_or_zero();
        let from = s.lifted();
        let to = z - from;
        let d2 = to.length_squared();
        if d2 <= 1e-12 {
            return Vec3::ZERO;
        }
        let w = to / d2.sqrt();
        let (cos_x, cos_z) = (w.dot(s.normal), w.dot(n).abs());
        if cos_x <= 0.0 || w.dot(s.geometric) <= 0.0 || cos_z <= 1e-6 {
            return Vec3::ZERO;
        }
        // The sample counts only if the ray's first (non-hole) hit is that triangle.
        let mut ray = Ray { t_max: 1.0 + 1e-3, ..Ray::new(from, to) };
        match tracer.intersect(&mut ray) {
            Some(h) if h.triangle == triangle => {}
            _ => return Vec3::ZERO,
        }
        e * (cos_x * cos_z / d2) / (self.emitter_area(triangle) + bounce_area(s, z, n))
    }

    /// Irradiance at `s` from the sky, looking toward a point on the box.
    fn sky(&self, tracer: &Tracer, s: &Surface, rng: &mut Pcg32) -> Vec3 {
        let Some(sky) = &self.sky else { return Vec3::ZERO };
        let from = s.lifted();
        if from.cmplt(sky.lo).any() || from.cmpgt(sky.hi).any() {
            return Vec3::ZERO;
        }
        let c = sky.cells.sample(rng.random());
        let q = face_point(sky.lo, sky.hi, c, rng.random(), rng.random());
        let w = (q - from).normalize_or_zero();
        let cos_x = w.dot(s.normal);
        if cos_x <= 0.0 || w.dot(s.geometric) <= 0.0 || !tracer.visible(&Ray::new(from, w)) {
            return Vec3::ZERO;
        }
        tracer.lighting.sky.radiance(w) * cos_x / (self.sky_solid(from, w) + bounce_solid(s, w))
    }

    /// Irradiance at `s` from the suns' light bounced once off a sunlit point: one connection per sun.
    fn sunlit(&self, tracer: &Tracer, s: &Surface, rng: &mut Pcg32) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for (k, (sq, &(_, irradiance))) in self.suns.iter().zip(&tracer.lighting.suns).enumerate() {
            let d = Lighting::sun_direction(sq.dir, Vec2::new(rng.random(), rng.random()));
            let (a, b) = cell_point(sq.cells.sample(rng.random()), rng.random(), rng.random());
            let origin = sq.centre + (sq.axes.0 * a + sq.axes.1 * b) * sq.half;
            let mut ray = Ray::new(origin, -d);
            let Some(hit) = tracer.intersect(&mut ray) else { continue };
            let y = tracer.materials.surface(&ray, &hit);
            let cos_sun = y.normal.dot(d);
            let to = y.lifted() - s.lifted();
            let d2 = to.length_squared();
            if cos_sun <= 0.0 || y.geometric.dot(d) <= 0.0 || d2 <= 1e-12 {
                continue;
            }
            let w = to / d2.sqrt();
            let (cos_x, cos_y) = (w.dot(s.normal), -w.dot(y.geometric));
            if cos_x <= 0.0 || w.dot(s.geometric) <= 0.0 || cos_y <= 0.0 || !tracer.visible(&Ray { t_max: 1.0, ..Ray::new(s.lifted(), to) }) {
                continue;
            }
            let leaving = y.albedo / PI * irradiance * cos_sun;
            sum += leaving * (cos_x * cos_y / d2) / (self.sun_area(k, y.position, y.geometric, d) + bounce_area(s, y.position, y.geometric));
        }
        sum
    }
}

/// A point of cell `c` of the sun's square, in [-1, 1]² coordinates.
fn cell_point(c: usize, u: f32, v: f32) -> (f32, f32) {
    let size = 2.0 / CELLS as f32;
    (-1.0 + ((c % CELLS) as f32 + u) * size, -1.0 + ((c / CELLS) as f32 + v) * size)
}

/// The cell of the sun's square holding [-1, 1]² coordinates.
fn square_cell(a: f32, b: f32) -> Option<usize> {
    let (i, j) = (((a + 1.0) / 2.0 * CELLS as f32).floor(), ((b + 1.0) / 2.0 * CELLS as f32).floor());
    ((0.0..CELLS as f32).contains(&i) && (0.0..CELLS as f32).contains(&j)).then(|| j as usize * CELLS + i as usize)
}

/// The two axes spanning the faces across `axis`.
fn face_axes(axis: usize) -> (usize, usize) {
    ((axis + 1) % 3, (axis + 2) % 3)
}

fn face_area(lo: Vec3, hi: Vec3, axis: usize) -> f32 {
    let (b, c) = face_axes(axis);
    (hi[b] - lo[b]) * (hi[c] - lo[c])
}

/// A point of cell `c` of the box's faces.
fn face_point(lo: Vec3, hi: Vec3, c: usize, u: f32, v: f32) -> Vec3 {
    let face = c / (CELLS * CELLS);
    let (axis, high) = (face / 2, face % 2 == 1);
    let cell = c % (CELLS * CELLS);
    let (b, cc) = face_axes(axis);
    let mut p = lo;
    p[axis] = if high { hi[axis] } else { lo[axis] };
    p[b] = lo[b] + ((cell % CELLS) as f32 + u) / CELLS as f32 * (hi[b] - lo[b]);
    p[cc] = lo[cc] + ((cell / CELLS) as f32 + v) / CELLS as f32 * (hi[cc] - lo[cc]);
    p
}

/// Where a ray from `x` inside the box along unit `w` leaves it: (cell, distance).
fn exit_cell(lo: Vec3, hi: Vec3, x: Vec3, w: Vec3) -> Option<(usize, f32)> {
    if x.cmplt(lo).any() || x.cmpgt(hi).any() {
        return None;
    }
    let mut best: Option<(usize, bool, f32)> = None;
    for axis in 0..3 {
        if w[axis] == 0.0 {
            continue;
        }
        let high = w[axis] > 0.0;
        let t = ((if high { hi[axis] } else { lo[axis] }) - x[axis]) / w[axis];
        if best.is_none_or(|b| t < b.2) {
            best = Some((axis, high, t));
        }
    }
    let (axis, high, t) = best?;
    let p = x + w * t;
    let (b, c) = face_axes(axis);
    let cell = |k: usize| (((p[k] - lo[k]) / (hi[k] - lo[k]) * CELLS as f32).floor() as i64).clamp(0, CELLS as i64 - 1) as usize;
    Some(((2 * axis + high as usize) * CELLS * CELLS + cell(c) * CELLS + cell(b), t.max(0.0)))
}

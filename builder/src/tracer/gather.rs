//! Final gather at reduced resolution: the indirect light at a frame's first
//! hits, traced one real bounce deep, with the radiance cache answering only
//! at the second hit, where a gather averages its cells over a hemisphere.
//!
//! The cache looked up at the first hit showed its cells as soft blotches on
//! every plain wall. Gathering at every pixel would cost tens of rays a pixel,
//! but indirect light varies slowly across a surface, so it is gathered on a
//! grid `step` times coarser than the pixels (16 to 64 rays a point), smoothed
//! across surfaces by an edge-avoiding à-trous filter (Dammertz et al. 2010,
//! weights from normals and distances to the tangent plane, so it never blurs
//! across a corner or a silhouette), and brought back to every pixel sample by
//! the same geometric weights over the nearest 2 × 2 grid points, or 4 × 4
//! where those lie on other surfaces (joint bilateral upsampling). Direct
//! light stays per pixel sample, so sun shadows stay sharp; samples with no
//! similar grid point nearby (thin objects) fall back to the cache.
//!
//! Light from surfaces close to a point changes faster than that grid can
//! follow: the dark band where a curtain's hem meets the floor, a wall's
//! foot, a ledge's underside. So the gather is split at a reach of a few grid
//! footprints (a near and a far field, as in ambient occlusion): the coarse
//! grid keeps only the light from beyond it, which varies slowly; where its
//! rays found surfaces within reach, a finer grid (every `NEAR_STEP` pixels,
//! short rays) gathers the near field and the share of rays that get past
//! it, filtered the same way; a sample then receives near + open × far.
//! And a point's light spreads, in the filter and the upsampling, no farther
//! than a quarter of the harmonic mean distance of the surfaces its rays hit
//! (Ward's bound on how fast irradiance changes), so the open floor in front
//! of a curtain does not light the strip behind its hem; but at least two
//! grid cells, which a crease's points, whose R is tiny, need to be filtered.
//!
//! The grid is spaced in pixels, so on a surface close to the eye its points
//! crowd a few centimetres where the light hardly changes, and the usual
//! passes average too few independent rays: the noise they leave showed as
//! soft blotches on a pillar next to the eye. There up to two more passes run,
//! each only at the points whose filter still reaches less than a tenth of
//! their harmonic distance across the scene.
//!
//! Random numbers come from generators seeded by (render seed, image, grid
//! point), so the result does not depend on the thread count.

use super::surface::{cosine_direction, Surface, Which};
use super::trace::{sampler, Shot, Tracer, Work};
use crate::raycast::{Hit, Ray};
use glam::{Vec2, Vec3};
use rand::Rng;
use rand_pcg::Pcg32;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::ops::RangeInclusive;

/// The B3-spline taps of one à-trous pass.
const TAPS: [f32; 5] = [1.0 / 16.0, 1.0 / 4.0, 3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0];
/// Sharpness of the normal weight: cos^N.
pub(super) const NORMAL_POWER: i32 = 16;
/// The same within the filter, whose wider passes would otherwise mix a
/// curved or creased surface's sides (a Crytek Sponza panorama: 0.0555 →
/// 0.0538 mean FLIP at 64 against 16; the sunroom's flat walls unchanged).
const FILTER_NORMAL_POWER: i32 = 64;
/// Ward's bound lets a point's light spread at least this many grid cells:
/// light that changes faster than the grid's spacing is the near field's to
/// carry. Where a ceiling meets a wall, R falls to millimetres, and with no
/// floor the points along the crease were left unfiltered and stood for
/// almost no pixel sample: a row of dots and blotches on the sunroom's
/// ceiling at 1024² (2,457 pixels 10 % off their row's median, none now).
/// Crytek Sponza panorama (`FACE=256`): 0.0476 mean FLIP with no floor,
/// 0.0473 at 1 and 3 cells, 0.0472 at 2; sunroom 0.0375 → 0.0374.
const SPREAD_FLOOR: f32 = 2.0;
/// The near field's grid: pixels between points, rays a point, à-trous
/// passes. Crytek Sponza panorama (`FACE=256`): 0.0515 mean FLIP at (3, 4, 2)
/// against 0.0514 at (2, 4, 2) and 0.0513 at (2, 4, 1), a second cheaper.
const NEAR_GRID: (u32, u32, u32) = (3, 4, 2);

/// How a frame's indirect light is gathered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GatherParams {
    /// Rays a grid point (rounded up to a square for stratification).
    pub rays: u32,
    /// Pixels between grid points along each axis.
    pub step: u32,
    /// À-trous passes (each doubles the filter's reach).
    pub passes: u32,
    /// The near field's reach in grid footprints (0: no near field).
    pub near: u32,
    /// How far a point's light may spread, in units of the harmonic mean
    /// distance of the surfaces around it (0: no limit).
    pub spread: f32,
    /// Surfaces close to the eye: at most this many more passes, each only
    /// at the points whose filter still reaches less than this share of R
    /// (Ward's harmonic distance) across the scene ((0, _): none).
    pub widen: (u32, f32),
    /// Video key frames after a path's first: average their gather with the
    /// previous key's where it saw the same point ([`super::reuse`]), and
    /// gather with this many rays a point (0: each key gathers alone, with `rays`).
    pub history_rays: u32,
}

#[derive(Clone, Copy, Debug)]
struct Point {
    position: Vec3,
    normal: Vec3,
    /// Distance from the eye (sets the geometric tolerances).
    depth: f32,
    /// π / rays × the radiance of the rays that hit within the reach.
    near: Vec3,
    /// π × the mean radiance of the rays that went past it (what the point
    /// would receive were nothing near it).
    far: Vec3,
    /// The share of rays that went past it.
    open: f32,
    /// Harmonic mean distance of the surfaces the rays hit (Ward's R).
    harmonic: f32,
}

/// Gather points on a regular grid over a frame.
struct Grid {
    width: u32,
    height: u32,
    step: u32,
    /// Angle one pixel spans at the frame's centre, radians.
    pixel_angle: f32,
    /// [`GatherParams::spread`].
    spread: f32,
    points: Vec<Option<Point>>,
}

/// A blend of grid points' light.
#[derive(Clone, Copy, Debug)]
struct Blend {
    near: Vec3,
    far: Vec3,
    open: f32,
    /// Whether a point that counted had surfaces within the reach.
    crowded: bool,
}

/// Indirect irradiance over one frame: the far field on a coarse grid, the
/// near field on a finer one where surfaces are close.
pub struct Field {
    far: Grid,
    near: Option<Grid>,
    /// The near field's reach in coarse grid footprints.
    reach: f32,
}

/// How much a grid point at (p, n) stands for a surface point at (q, m) seen
/// from `depth`: normals alike and p near q's tangent plane.
/// `power` sets how fast it falls with the angle between the normals.
pub(super) fn geometric_weight(q: Vec3, m: Vec3, p: Vec3, n: Vec3, tolerance: f32, power: i32) -> f32 {
    let cos = m.dot(n);
    if cos <= 0.5 {
        return 0.0;
    }
    let plane = (p - q).dot(m).abs() / tolerance;
    cos.powi(power) * (-plane * plane).exp()
}

/// How much a point's light stands for a point `d` away: irradiance
/// changes across a distance d by about d / R, R the harmonic mean distance
/// of the surfaces around (Ward et al. 1988), so beyond `spread` × R it
/// stands for little (a floor's open part for the strip behind a curtain
/// hanging close above it). But never below [`SPREAD_FLOOR`] grid cells
/// (`footprint` each), what the grid resolves.
fn ward(d: f32, harmonic: f32, spread: f32, footprint: f32) -> f32 {
    if spread == 0.0 {
        return 1.0;
    }
    let x = d / (spread * harmonic).max(SPREAD_FLOOR * footprint);
    (-x * x).exp()
}

/// How one grid of a gather field is gathered: its random streams (`seed`,
/// `work`), `side`² rays a point, and whether the light from beyond the
/// near reach is taken (`far`).
#[derive(Clone, Copy)]
struct GridPass {
    seed: u64,
    work: Work,
    side: u32,
    far: bool,
}

impl Tracer<'_> {
    /// Gathers the indirect light seen through a `width` × `height` frame
    /// (as [`Tracer::render`] projects it) on a grid every `params.step`
    /// pixels, and its near field where that grid found surfaces close.
    pub(super) fn gather_field<P: Fn(f32, f32) -> Vec3 + Sync>(
        &self,
        params: &GatherParams,
        seed: u64,
        shot: &Shot<&P>,
        traced: &(impl Fn(u32, u32) -> bool + Sync),
    ) -> Field {
        let (project, (width, height)) = (shot.project, shot.size);
        let step = params.step.max(1);
        let centre = project(0.5, 0.5);
        let pixel_angle = centre.angle_between(project(0.5 + 1.0 / width as f32, 0.5)).max(1e-6);
        let mut far = Grid { width, height, step, pixel_angle, spread: params.spread, points: Vec::new() };
        let reach = params.near as f32;
        let unit = far.footprint(1.0);
        let reach_at = |depth: f32| reach * unit * depth;
        let side = (params.rays as f32).sqrt().ceil().max(1.0) as u32;
        // Only at pixels the frame traces.
        let pass = GridPass { seed, work: Work::Gather, side, far: true };
        far.points = self.gather_grid(&far, shot, pass, &reach_at, |x, y| traced(x as u32, y as u32));
        for pass in 0..params.passes {
            far.filter(1 << pass, false, None);
        }
        far.widen(params.passes, params.widen);
        let near = (params.near > 0 && far.points.iter().flatten().any(|p| p.open < 1.0)).then(|| {
            let (near_step, rays, passes) = NEAR_GRID;
            let mut near = Grid { step: near_step, points: Vec::new(), ..far };
            let side = (rays as f32).sqrt().ceil().max(1.0) as u32;
            // Only where a coarse point around had surfaces within reach.
            let crowded = |x: f32, y: f32| far.around(x, y, 1).any(|p| p.open < 1.0);
            let pass = GridPass { seed, work: Work::NearGather, side, far: false };
            near.points = self.gather_grid(&near, shot, pass, &reach_at, crowded);
            for pass in 0..passes {
                near.filter(1 << pass, true, None);
            }
            near
        });
        Field { far, near, reach }
    }

    /// The points of `grid` (where `wanted` at their pixel), each gathered by
    /// `pass.side`² rays split at `reach_at(depth)` (the light from beyond it
    /// only when `pass.far`).
    fn gather_grid<P: Fn(f32, f32) -> Vec3 + Sync>(
        &self,
        grid: &Grid,
        shot: &Shot<&P>,
        pass: GridPass,
        reach_at: &(impl Fn(f32) -> f32 + Sync),
        wanted: impl Fn(f32, f32) -> bool + Sync,
    ) -> Vec<Option<Point>> {
        let GridPass { seed, work, side, far } = pass;
        let (eye, image, project) = (shot.eye, shot.image, shot.project);
        let (gw, gh) = grid.size();
        let (width, height, step) = (grid.width as f32, grid.height as f32, grid.step as f32);
        (0..gw * gh)
            .into_par_iter()
            .map(|g| {
                let _mode = crate::raycast::FlushDenormals::new();
                let (gx, gy) = (g % gw, g / gw);
                let x = ((gx as f32 + 0.5) * step).min(width - 0.5);
                let y = ((gy as f32 + 0.5) * step).min(height - 0.5);
                if !wanted(x, y) {
                    return None;
                }
                let mut ray = Ray::new(eye, project(x / width, y / height));
                let hit = self.intersect(&mut ray)?;
                let s = self.materials.surface(&ray, &hit);
                let mut rng = sampler(seed, work, image, g as u64);
                let depth = hit.t * ray.dir.length();
                Some(self.gather_at(&s, depth, side, reach_at(depth), far, &mut rng))
            })
            .collect()
    }

    /// Indirect irradiance at `s` by side² stratified cosine-weighted rays,
    /// split at `reach`: only what lies within it unless `beyond`, then only
    /// what lies past it (with how open the view is, and the harmonic mean
    /// distance of all hits).
    fn gather_at(&self, s: &Surface, depth: f32, side: u32, reach: f32, beyond: bool, rng: &mut Pcg32) -> Point {
        let (mut near, mut far, mut escaped, mut inverse) = (Vec3::ZERO, Vec3::ZERO, 0u32, 0.0f32);
        let from = s.lifted();
        for j in 0..side * side {
            let u = Vec2::new(((j % side) as f32 + rng.random::<f32>()) / side as f32, ((j / side) as f32 + rng.random::<f32>()) / side as f32);
            let d = cosine_direction(s.normal, u);
            if d.dot(s.geometric) <= 0.0 {
                // Below the surface: no light, and nothing near either.
                escaped += 1;
                continue;
            }
            let mut ray = Ray { t_max: if beyond { f32::INFINITY } else { reach }, ..Ray::new(from, d) };
            match self.intersect(&mut ray) {
                None => {
                    if beyond {
                        far += self.lighting.sky.radiance(d);
                    }
                    escaped += 1;
                }
                Some(hit) if hit.t >= reach => {
                    inverse += 1.0 / hit.t.max(1e-6);
                    far += self.leaving(&ray, &hit, rng);
                    escaped += 1;
                }
                Some(hit) => {
                    inverse += 1.0 / hit.t.max(1e-6);
                    // The far grid's near light is never read (the near grid
                    // gathers it where it matters): not looked up.
                    if !beyond {
                        near += self.leaving(&ray, &hit, rng);
                    }
                }
            }
        }
        // Cosine sampling: E = π · mean radiance.
        let n = (side * side) as f32;
        Point {
            position: s.position,
            normal: s.normal,
            depth,
            near: near * (PI / n),
            far: if escaped > 0 { far * (PI / escaped as f32) } else { Vec3::ZERO },
            open: escaped as f32 / n,
            harmonic: if inverse > 0.0 { n / inverse } else { f32::INFINITY },
        }
    }

    /// Radiance leaving a gather ray's hit toward it: emission plus the
    /// cache's light (all of it: direct from every sampled light and indirect).
    fn leaving(&self, ray: &Ray, hit: &Hit, rng: &mut Pcg32) -> Vec3 {
        let cache = self.cache.as_ref().expect("a final gather needs the radiance cache");
        let h = self.materials.surface_flat(ray, hit);
        let e = match cache.total_irradiance(h.position, h.geometric) {
            Some(e) => e,
            // No cell here: direct light by shadow rays, which need the shading normal.
            None => cache.irradiance(h.position, h.geometric, false) + self.direct(&self.materials.surface(ray, hit), Which::All, rng),
        };
        h.emission + h.albedo / PI * e
    }

    /// Indirect irradiance at a pixel sample the near field's grid missed
    /// (a thin object), whose far field is `far`: one cosine ray, bringing a
    /// surface's light within `reach`, the far field past it.
    fn near_ray(&self, s: &Surface, far: Vec3, reach: f32, rng: &mut Pcg32) -> Vec3 {
        let d = cosine_direction(s.normal, Vec2::new(rng.random(), rng.random()));
        if d.dot(s.geometric) <= 0.0 {
            return far;
        }
        let mut ray = Ray { t_max: reach, ..Ray::new(s.lifted(), d) };
        match self.intersect(&mut ray) {
            None => far,
            Some(hit) => PI * self.leaving(&ray, &hit, rng),
        }
    }

    /// Indirect irradiance for a pixel sample at (x, y) (pixel units) whose
    /// surface is `s`, `depth` from the eye; `None` when no grid point is alike.
    pub(super) fn indirect_from(&self, field: &Field, x: f32, y: f32, s: &Surface, depth: f32, rng: &mut Pcg32) -> Option<Vec3> {
        let far = field.far.at(x, y, s, depth)?;
        if !far.crowded {
            return Some(far.far);
        }
        let reach = field.reach * field.far.footprint(depth);
        Some(match field.near.as_ref().and_then(|g| g.at(x, y, s, depth)) {
            Some(near) => near.near + near.open * far.far,
            None => self.near_ray(s, far.far, reach, rng),
        })
    }
}

impl Grid {
    /// The width of a grid cell `depth` from the eye (the geometric tolerances' unit).
    fn footprint(&self, depth: f32) -> f32 {
        self.pixel_angle * self.step as f32 * depth
    }

    fn size(&self) -> (u32, u32) {
        (self.width.div_ceil(self.step), self.height.div_ceil(self.step))
    }

    /// The columns and rows of the (2 radius)² grid points around grid
    /// position (u, v), within the grid.
    fn window(&self, u: f32, v: f32, radius: i64) -> (RangeInclusive<i64>, RangeInclusive<i64>) {
        let (gw, gh) = self.size();
        let (u0, v0) = (u.floor() as i64, v.floor() as i64);
        ((u0 + 1 - radius).max(0)..=(u0 + radius).min(gw as i64 - 1), (v0 + 1 - radius).max(0)..=(v0 + radius).min(gh as i64 - 1))
    }

    /// The points of the (2 radius)² around pixel (x, y).
    fn around(&self, x: f32, y: f32, radius: i64) -> impl Iterator<Item = &Point> {
        let gw = self.size().0 as i64;
        let (xs, ys) = self.window(x / self.step as f32 - 0.5, y / self.step as f32 - 0.5, radius);
        ys.flat_map(move |yy| xs.clone().filter_map(move |xx| self.points[(yy * gw + xx) as usize].as_ref()))
    }

    /// After `passes` à-trous passes of the far field, up to `more` wider ones,
    /// each only at the points whose filter still reaches less than `share`
    /// of their harmonic distance R ([`GatherParams::widen`]).
    fn widen(&mut self, passes: u32, (more, share): (u32, f32)) {
        for pass in passes..passes + more {
            // The reach so far, in grid footprints: two taps of every pass's spacing.
            let reach = 2.0 * ((1u32 << pass) - 1) as f32;
            self.filter(1 << pass, false, Some(reach / share));
        }
    }

    /// One edge-avoiding à-trous pass with taps `spacing` grid points apart:
    /// of the far field, each point weighed by its share of rays that reached
    /// it; or of the near field and that share. With `only_below` = k, only
    /// points whose harmonic distance R exceeds k grid footprints change.
    fn filter(&mut self, spacing: u32, near_field: bool, only_below: Option<f32>) {
        let (gw, gh) = self.size();
        let (gw, gh) = (gw as i64, gh as i64);
        let points = &self.points;
        let next: Vec<Option<Point>> = (0..points.len())
            .into_par_iter()
            .map(|i| {
                let mut p = points[i]?;
                if only_below.is_some_and(|k| k * self.footprint(p.depth) >= p.harmonic) {
                    return Some(p);
                }
                let (x, y) = (i as i64 % gw, i as i64 / gw);
                // A plane's points stay on its tangent plane however far
                // apart: the tolerance does not grow with the spacing (it
                // did, and a ledge's face then blended with the wall behind
                // it on the wider passes).
                let tolerance = self.footprint(p.depth);
                let (mut far, mut near, mut open, mut weight) = (Vec3::ZERO, Vec3::ZERO, 0.0f32, 0.0f32);
                for (dy, ty) in TAPS.iter().enumerate() {
                    let yy = y + (dy as i64 - 2) * spacing as i64;
                    if yy < 0 || yy >= gh {
                        continue;
                    }
                    for (dx, tx) in TAPS.iter().enumerate() {
                        let xx = x + (dx as i64 - 2) * spacing as i64;
                        if xx < 0 || xx >= gw {
                            continue;
                        }
                        let Some(q) = points[(yy * gw + xx) as usize] else {
                            continue;
                        };
                        let mut w = tx
                            * ty
                            * geometric_weight(p.position, p.normal, q.position, q.normal, tolerance, FILTER_NORMAL_POWER)
                            * ward((p.position - q.position).length(), p.harmonic.min(q.harmonic), self.spread, tolerance);
                        if !near_field {
                            // A far field seen through few rays counts for little.
                            w *= q.open;
                        }
                        far += q.far * w;
                        near += q.near * w;
                        open += q.open * w;
                        weight += w;
                    }
                }
                if weight > 0.0 {
                    if near_field {
                        (p.near, p.open) = (near / weight, open / weight);
                    } else {
                        p.far = far / weight;
                    }
                }
                Some(p)
            })
            .collect();
        self.points = next;
    }

    /// The light for a pixel sample at (x, y) (pixel units) whose surface is
    /// `s`, `depth` from the eye: the grid points of the 4 × 4 around it,
    /// weighted by distance and likeness; `None` when none is alike.
    fn at(&self, x: f32, y: f32, s: &Surface, depth: f32) -> Option<Blend> {
        let (u, v) = (x / self.step as f32 - 0.5, y / self.step as f32 - 0.5);
        let tolerance = self.footprint(depth);
        // The 2 × 2 around the sample (bilinear) almost always suffice; the
        // 4 × 4 (a tent twice as wide) where they lie on other surfaces.
        self.blend(u, v, 1, s, tolerance, 0.25).or_else(|| self.blend(u, v, 2, s, tolerance, 1e-3))
    }

    /// Grid points within `radius` of (u, v) (grid units) under a tent of
    /// that radius times likeness to `s`; `None` when their weight is below `least`.
    fn blend(&self, u: f32, v: f32, radius: i64, s: &Surface, tolerance: f32, least: f32) -> Option<Blend> {
        let gw = self.size().0 as i64;
        let (xs, ys) = self.window(u, v, radius);
        let r = radius as f32;
        let mut sum = Blend { near: Vec3::ZERO, far: Vec3::ZERO, open: 0.0, crowded: false };
        let mut weight = 0.0f32;
        for yy in ys {
            let wy = (1.0 - (v - yy as f32).abs() / r).max(0.0);
            for xx in xs.clone() {
                let wx = (1.0 - (u - xx as f32).abs() / r).max(0.0);
                let Some(q) = self.points[(yy * gw + xx) as usize] else { continue };
                if wx * wy == 0.0 {
                    continue;
                }
                let w = wx
                    * wy
                    * geometric_weight(s.position, s.normal, q.position, q.normal, tolerance, NORMAL_POWER)
                    * ward((s.position - q.position).length(), q.harmonic, self.spread, tolerance);
                sum.near += q.near * w;
                sum.far += q.far * w;
                sum.open += q.open * w;
                sum.crowded |= w > 0.0 && q.open < 1.0;
                weight += w;
            }
        }
        (weight >= least).then(|| Blend { near: sum.near / weight, far: sum.far / weight, open: sum.open / weight, crowded: sum.crowded })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wall facing the eye 10 units away with a ledge 2 grid points wide
    /// 0.15 units in front of it (three grid footprints), both facing +z:
    /// the filter smooths the wall's noise but keeps the ledge's own light
    /// on every pass, however wide its spacing.
    #[test]
    fn the_filter_smooths_a_plane_but_never_blends_a_ledge_with_the_wall_behind_it() {
        let (n, ledge) = (24u32, 11..13u32);
        let mut field = Grid { width: n, height: n, step: 1, pixel_angle: 0.005, spread: 0.0, points: Vec::new() };
        for y in 0..n {
            for x in 0..n {
                let on_ledge = ledge.contains(&x);
                // The wall's light alternates 0.9 / 1.1 (noise around 1.0).
                let light = if on_ledge {
                    0.2
                } else if (x + y) % 2 == 0 {
                    0.9
                } else {
                    1.1
                };
                let z = if on_ledge { 0.15 } else { 0.0 };
                field.points.push(Some(Point {
                    position: Vec3::new(x as f32 * 0.05, y as f32 * 0.05, z),
                    normal: Vec3::Z,
                    depth: 10.0,
                    near: Vec3::ZERO,
                    far: Vec3::splat(light),
                    open: 1.0,
                    harmonic: f32::INFINITY,
                }));
            }
        }
        for pass in 0..3 {
            field.filter(1 << pass, false, None);
        }
        let at = |x: u32, y: u32| field.points[(y * n + x) as usize].unwrap().far.x;
        for y in 0..n {
            for x in ledge.clone() {
                assert!((at(x, y) - 0.2).abs() < 0.01, "ledge point ({x}, {y}) took the wall's light: {}", at(x, y));
            }
            for x in [3, 7, 17, 20] {
                assert!((at(x, y) - 1.0).abs() < 0.03, "wall point ({x}, {y}) kept its noise: {}", at(x, y));
            }
        }
    }

    /// One plane, grid points 0.05 units apart, with a strip 10 points wide
    /// whose points have surfaces 0.4 units away (under a shelf) and get a
    /// fifth of the light: the strip keeps its own light when a point's light
    /// spreads at most a quarter of that distance, and takes the open floor's
    /// when it spreads freely.
    #[test]
    fn light_spreads_no_farther_than_the_surfaces_around_allow() {
        let n = 32u32;
        let filtered = |spread: f32| {
            let mut grid = Grid { width: n, height: n, step: 1, pixel_angle: 0.005, spread, points: Vec::new() };
            for y in 0..n {
                for x in 0..n {
                    let under = (11..21).contains(&x);
                    let (light, harmonic) = if under { (0.2, 0.4) } else { (1.0, f32::INFINITY) };
                    grid.points.push(Some(Point {
                        position: Vec3::new(x as f32 * 0.05, y as f32 * 0.05, 0.0),
                        normal: Vec3::Z,
                        depth: 10.0,
                        near: Vec3::ZERO,
                        far: Vec3::splat(light),
                        open: 1.0,
                        harmonic,
                    }));
                }
            }
            for pass in 0..3 {
                grid.filter(1 << pass, false, None);
            }
            grid.points[(5 * n + 15) as usize].unwrap().far.x
        };
        let (limited, free) = (filtered(0.25), filtered(0.0));
        assert!((limited - 0.2).abs() < 0.01, "the strip took the open floor's light: {limited}");
        assert!(free > 0.4, "a freely spreading filter should blend the strip: {free}");
    }

    /// The same noisy plane seen close (its grid points 1.25 mm apart, the
    /// surfaces around 1 unit away) and far (10 cm apart): the wider passes
    /// take the close plane's noise down to less than half of what the usual
    /// three passes leave, and leave the far plane as it was.
    #[test]
    fn a_plane_close_to_the_eye_is_filtered_wider_and_a_far_one_as_before() {
        let n = 96u32;
        let filtered = |depth: f32, widen: u32| {
            let mut grid = Grid { width: n, height: n, step: 1, pixel_angle: 0.005, spread: 0.25, points: Vec::new() };
            let spacing = grid.footprint(depth);
            let mut rng = Pcg32::new(7, 11);
            for y in 0..n {
                for x in 0..n {
                    let light = 1.0 + 0.2 * (rng.random::<f32>() - 0.5);
                    grid.points.push(Some(Point {
                        position: Vec3::new(x as f32 * spacing, y as f32 * spacing, 0.0),
                        normal: Vec3::Z,
                        depth,
                        near: Vec3::ZERO,
                        far: Vec3::splat(light),
                        open: 1.0,
                        harmonic: 1.0,
                    }));
                }
            }
            for pass in 0..3 {
                grid.filter(1 << pass, false, None);
            }
            grid.widen(3, (widen, 0.05));
            // The spread of the light over the middle (away from the borders).
            let middle: Vec<f32> =
                (24..72).flat_map(|y| (24..72).map(move |x| (x, y))).map(|(x, y)| grid.points[(y * n + x) as usize].unwrap().far.x).collect();
            let mean = middle.iter().sum::<f32>() / middle.len() as f32;
            (middle.iter().map(|v| (v - mean) * (v - mean)).sum::<f32>() / middle.len() as f32).sqrt()
        };
        let (close, close_wide) = (filtered(0.25, 0), filtered(0.25, 2));
        assert!(close_wide < 0.5 * close, "the close plane kept its noise: {close_wide} after the wider passes, {close} before");
        let (far, far_wide) = (filtered(20.0, 0), filtered(20.0, 2));
        assert_eq!(far, far_wide, "the far plane changed");
    }
}

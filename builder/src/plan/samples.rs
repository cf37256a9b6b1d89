//! Surface samples and reachability: the definition of the reachable
//! surface that the stages choosing probes (`visibility`) and the
//! independent coverage metric (`coverage`) share, so that those stages
//! optimise what the metric measures. Each draws its own samples.

use crate::plan::freespace::FreeSpace;
use crate::raycast::{Ray, RayScene};
use crate::seeds::cosine_direction;
use exploremaps_scenes::Scene;
use glam::{Vec2, Vec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;

/// Points spread uniformly over the surface.
#[derive(Clone, Debug, Default)]
pub struct SurfaceSamples {
    pub points: Vec<Vec3>,
    /// Unit front normals (by winding).
    pub normals: Vec<Vec3>,
    pub triangles: Vec<u32>,
    /// Area each sample stands for.
    pub area_each: f64,
}

/// Samples the surface uniformly by area with a seeded generator.
pub fn surface_samples(scene: &Scene, count: usize, seed: u64) -> SurfaceSamples {
    let all: Vec<u32> = (0..scene.triangles.len() as u32).collect();
    let mut rng = crate::seeds::Stream::Surface.rng(seed);
    let mut s = SurfaceSamples::default();
    let total = sample_triangles(scene, &all, count, &mut rng, &mut s);
    s.area_each = total / count.max(1) as f64;
    s
}

/// Area-uniform samples plus, for every object that got fewer than
/// `min_per_object`, extra samples on it up to that number: a small detailed
/// object in a large hall (the paper's "teapot in a stadium") then weighs in
/// the selection like a wall does. `area_each` is meaningless here: count samples.
pub fn stratified_samples(scene: &Scene, count: usize, min_per_object: usize, seed: u64) -> SurfaceSamples {
    let mut s = surface_samples(scene, count, seed);
    let mut per_object = vec![0usize; scene.objects.len()];
    for &t in &s.triangles {
        per_object[scene.triangle_object[t as usize] as usize] += 1;
    }
    let mut rng = crate::seeds::Stream::Strata.rng(seed);
    for (object, &have) in per_object.iter().enumerate() {
        if have < min_per_object {
            let triangles: Vec<u32> = (0..scene.triangles.len() as u32).filter(|&t| scene.triangle_object[t as usize] == object as u32).collect();
            sample_triangles(scene, &triangles, min_per_object - have, &mut rng, &mut s);
        }
    }
    s
}

/// Appends `count` area-uniform samples over `triangles`; returns their total area.
fn sample_triangles(scene: &Scene, triangles: &[u32], count: usize, rng: &mut Pcg64Mcg, s: &mut SurfaceSamples) -> f64 {
    let mut cumulative = Vec::with_capacity(triangles.len());
    let mut total = 0.0f64;
    for &t in triangles {
        total += scene.triangle_area(t as usize) as f64;
        cumulative.push(total);
    }
    if total <= 0.0 {
        return 0.0;
    }
    for _ in 0..count {
        let x = rng.random::<f64>() * total;
        let t = triangles[cumulative.partition_point(|&c| c <= x).min(cumulative.len() - 1)] as usize;
        let [a, b, c] = scene.triangle(t);
        let (mut u, mut v): (f32, f32) = (rng.random(), rng.random());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        s.points.push(a + (b - a) * u + (c - a) * v);
        s.normals.push((b - a).cross(c - a).normalize_or_zero());
        s.triangles.push(t as u32);
    }
    total
}

/// From where in the open space a surface sample is seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FromOpen {
    /// Not at all (inside solids, outside the box, or behind everything).
    #[default]
    No,
    /// Only from open voxels touching geometry: a crevice no viewpoint fits in.
    CreviceOnly,
    /// From an open voxel touching no occupied voxel: in the ceiling.
    Ceiling,
}

/// Open voxels at least this many voxels from every occupied voxel centre touch
/// none (a corner neighbour is √3 away): points in them see the ceiling.
const CEILING_CLEARANCE_VOXELS: f32 = 1.99;

/// Which side of each sample navigable space reaches (+1 front, −1 back, 0
/// none), and from where in the open space it is seen, with the rays cast.
pub(crate) fn reachability(rays: &RayScene, space: &FreeSpace, samples: &SurfaceSamples, dirs: usize, seed: u64) -> (Vec<i8>, Vec<FromOpen>, usize) {
    let eps = 1e-3 * space.bounds.diagonal().max(1e-6);
    let step = space.grid.voxel * 0.5;
    // Largest distance worth marching: the grid's diagonal.
    let far = space.grid.voxel * (space.grid.dims.iter().map(|&d| (d * d) as f32).sum::<f32>()).sqrt();
    let roomy = CEILING_CLEARANCE_VOXELS * space.grid.voxel;
    let reach = crate::seeds::Stream::Reach.seed(seed);
    let reached: Vec<(i8, FromOpen)> = (0..samples.points.len())
        .into_par_iter()
        .map(|i| {
            let mut rng = Pcg64Mcg::seed_from_u64(crate::seeds::substream(reach, i as u64));
            let (mut reached, mut from_open) = (0i8, FromOpen::No);
            for side in [1.0f32, -1.0] {
                let n = samples.normals[i] * side;
                let origin = samples.points[i] + n * eps;
                for _ in 0..dirs {
                    let d = cosine_direction(n, Vec2::new(rng.random(), rng.random()));
                    let t_hit = rays.intersect(&Ray::new(origin, d)).map_or(far, |h| h.t).min(far);
                    let mut t = step.min(t_hit);
                    while t < t_hit {
                        let p = origin + d * t;
                        // The grid is convex: a ray that leaves it finds nothing more.
                        let Some(free_run) = space.navigable_free_run(p) else { break };
                        if from_open != FromOpen::Ceiling && space.is_open(p) {
                            from_open = if space.clearance_at(p) >= roomy { FromOpen::Ceiling } else { FromOpen::CreviceOnly };
                        }
                        if reached == 0 && t >= space.near && space.is_navigable(p) {
                            reached = side as i8;
                        }
                        if reached != 0 && from_open == FromOpen::Ceiling {
                            return (reached, from_open);
                        }
                        // Only the navigable space is still sought: skip the steps
                        // that cannot reach it (the same points are tested as before).
                        let skip = if from_open == FromOpen::Ceiling { (free_run / step).floor().max(1.0) } else { 1.0 };
                        t += step * skip;
                    }
                }
            }
            (reached, from_open)
        })
        .collect();
    let (side, from_open) = reached.into_iter().unzip();
    (side, from_open, samples.points.len() * dirs * 2)
}

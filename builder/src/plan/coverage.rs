//! Coverage: how much of the reachable surface a set of probes sees. An
//! independent check of exploration: it samples the surface itself and tests
//! visibility from the final probes with its own occlusion rays, never with
//! the stages' `crate::plan::visibility`. Reachability (step 2) is the one
//! definition both use, so those stages optimise what this measures.
//!
//! Inputs: the scene, its ray-casting structure, the navigable [`FreeSpace`],
//! probe positions in placement order, [`CoverageParams`].
//! Output: [`CoverageReport`].
//!
//! 1. Samples: `samples` points uniform by area (seeded), each with its
//!    triangle's front normal and an equal share of the total area.
//! 2. Reachable: a sample is reachable when some point of navigable space sees
//!    its front side: of `reach_dirs` cosine-distributed rays leaving its front,
//!    one passes through a navigable voxel before it hits anything. Scenes whose
//!    winding is inconsistent have surfaces seen from their back; both sides are
//!    tried, so such a surface still counts once. When the space is walked, the
//!    navigable voxels are the band around eye height: reachable then means seen
//!    from eye height.
//!    The same rays decide whether the sample is in the *ceiling*: seen from a
//!    voxel of the open space (free, inside the scene's box, outside closed
//!    solids) that touches no occupied voxel, whatever space was chosen. Surface
//!    seen only from open voxels touching geometry lies in *crevices* (gaps of
//!    about two voxels or less: behind furniture, under plinths, between a
//!    foundation and the ground) where no viewpoint fits and which the grid
//!    cannot even tell open from closed; the report gives their area apart. It
//!    gives the ceiling's area, the share of it the navigable space sees, and the
//!    share the probes see, so the space choice's exclusions show.
//! 3. Covered: a reachable sample is covered when the segment from some probe to
//!    it is free and the probe is on the side the sample is reached from.
//!    Probes are tested in placement order, which yields the coverage-versus-
//!    probe-count curve at no extra cost.
//!
//! Defaults: 200,000 samples, 16 reach directions, seed 1.

use crate::plan::freespace::FreeSpace;
use crate::plan::samples::{reachability, surface_samples, FromOpen, SurfaceSamples};
use crate::raycast::{Packing, Ray, RayScene};
use exploremaps_scenes::Scene;
use glam::Vec3;
use std::time::Instant;

#[derive(Clone, Debug, PartialEq)]
pub struct CoverageParams {
    pub samples: usize,
    pub reach_dirs: usize,
    pub seed: u64,
}

impl Default for CoverageParams {
    fn default() -> Self {
        CoverageParams { samples: 200_000, reach_dirs: 16, seed: 1 }
    }
}

#[derive(Clone, Debug, Default)]
pub struct CoverageReport {
    pub samples: SurfaceSamples,
    /// Per sample: +1 reached from its front, −1 only from its back, 0 unreachable.
    pub reached_side: Vec<i8>,
    /// Per sample: whether the open space sees it (the ceiling, or only from crevices).
    pub from_open: Vec<FromOpen>,
    /// Per sample: index of the first probe (placement order) that sees it.
    pub first_seen_by: Vec<Option<u32>>,
    pub reachable_area: f64,
    pub covered_area: f64,
    /// (probes, covered fraction of reachable area) for 1..=probes.
    pub curve: Vec<(u32, f64)>,
    pub rays: usize,
    pub seconds: f64,
}

impl CoverageReport {
    pub fn fraction(&self) -> f64 {
        if self.reachable_area > 0.0 {
            self.covered_area / self.reachable_area
        } else {
            1.0
        }
    }

    /// (name, reachable area, covered area) per group, given each triangle's group.
    pub fn per_group(&self, triangle_group: &[u32], names: &[String]) -> Vec<(String, f64, f64)> {
        let mut sums = vec![(0.0, 0.0); names.len()];
        for (i, &t) in self.samples.triangles.iter().enumerate() {
            if self.reached_side[i] != 0 {
                let g = &mut sums[triangle_group[t as usize] as usize];
                g.0 += self.samples.area_each;
                if self.first_seen_by[i].is_some() {
                    g.1 += self.samples.area_each;
                }
            }
        }
        names.iter().cloned().zip(sums).filter(|(_, (r, _))| *r > 0.0).map(|(n, (r, c))| (n, r, c)).collect()
    }

    /// The ceiling's area, and the shares of it the navigable space and the probes see.
    pub fn ceiling(&self) -> exploremaps_format::Ceiling {
        let area = |keep: &dyn Fn(usize) -> bool| (0..self.from_open.len()).filter(|&i| keep(i)).count() as f64 * self.samples.area_each;
        let ceiling = |i: usize| self.from_open[i] == FromOpen::Ceiling;
        exploremaps_format::Ceiling {
            area: area(&ceiling),
            seen_from_space: area(&|i| ceiling(i) && self.reached_side[i] != 0),
            covered: area(&|i| ceiling(i) && self.first_seen_by[i].is_some()),
            crevices: area(&|i| self.from_open[i] == FromOpen::CreviceOnly),
        }
    }

    /// Probes needed to reach `fraction` of the reachable area, if they do.
    pub fn probes_for(&self, fraction: f64) -> Option<u32> {
        self.curve.iter().find(|&&(_, f)| f >= fraction - 1e-12).map(|&(n, _)| n)
    }
}

/// Measures coverage of `probes` (in placement order).
pub fn coverage(scene: &Scene, rays: &RayScene, space: &FreeSpace, probes: &[Vec3], params: &CoverageParams) -> CoverageReport {
    coverage_of(surface_samples(scene, params.samples, params.seed), rays, space, probes, params)
}

/// Measures coverage of `probes` over given surface samples.
pub fn coverage_of(samples: SurfaceSamples, rays: &RayScene, space: &FreeSpace, probes: &[Vec3], params: &CoverageParams) -> CoverageReport {
    let started = Instant::now();
    let (reached_side, from_open, reach_rays) = reachability(rays, space, &samples, params.reach_dirs, params.seed);
    let mut report = seen_from(samples, reached_side, from_open, rays, space, probes);
    report.rays += reach_rays;
    report.seconds = started.elapsed().as_secs_f64();
    report
}

/// Coverage of other probes over the same samples and reachability as `base`
/// (for baselines: the expensive reachability is done once).
pub fn coverage_like(base: &CoverageReport, rays: &RayScene, space: &FreeSpace, probes: &[Vec3]) -> CoverageReport {
    let started = Instant::now();
    let mut report = seen_from(base.samples.clone(), base.reached_side.clone(), base.from_open.clone(), rays, space, probes);
    report.seconds = started.elapsed().as_secs_f64();
    report
}

/// Which reachable samples the probes see, probe by probe in order.
fn seen_from(
    samples: SurfaceSamples,
    reached_side: Vec<i8>,
    from_open: Vec<FromOpen>,
    rays: &RayScene,
    space: &FreeSpace,
    probes: &[Vec3],
) -> CoverageReport {
    let mut ray_count = 0;
    let eps = 1e-3 * space.bounds.diagonal().max(1e-6);
    let mut first_seen_by: Vec<Option<u32>> = vec![None; samples.points.len()];
    let reachable: Vec<usize> = (0..samples.points.len()).filter(|&i| reached_side[i] != 0).collect();
    let reachable_area = reachable.len() as f64 * samples.area_each;
    let mut open: Vec<usize> = reachable.clone();
    let mut curve = Vec::with_capacity(probes.len());
    let mut covered = 0usize;
    for (k, &probe) in probes.iter().enumerate() {
        // Only samples facing the probe on the side they are reached from.
        let facing: Vec<usize> =
            open.iter().copied().filter(|&i| (probe - samples.points[i]).dot(samples.normals[i]) * reached_side[i] as f32 > 0.0).collect();
        let segments: Vec<Ray> = facing
            .iter()
            .map(|&i| {
                let target = samples.points[i] + samples.normals[i] * (eps * reached_side[i] as f32);
                Ray { t_max: 1.0, ..Ray::segment(probe, target) }
            })
            .collect();
        ray_count += segments.len();
        let blocked = rays.occluded_batch(&segments, Packing::Packets8);
        for (&i, b) in facing.iter().zip(blocked) {
            if !b {
                first_seen_by[i] = Some(k as u32);
                covered += 1;
            }
        }
        open.retain(|&i| first_seen_by[i].is_none());
        let fraction = if reachable.is_empty() { 1.0 } else { covered as f64 / reachable.len() as f64 };
        curve.push((k as u32 + 1, fraction));
    }
    CoverageReport {
        covered_area: covered as f64 * samples.area_each,
        samples,
        reached_side,
        from_open,
        first_seen_by,
        reachable_area,
        curve,
        rays: ray_count,
        seconds: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::freespace::{free_space, FreeSpaceParams, HeightMode, SpaceMode};
    use crate::testing::{rooms, rooms_with};
    use exploremaps_scenes::mesh::MeshBuilder;

    fn setup(scene: &Scene) -> (RayScene, FreeSpace) {
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let (space, _) =
            free_space(scene, &rays, &FreeSpaceParams { space: SpaceMode::Inside, height: HeightMode::Fly, ..Default::default() }).unwrap();
        (rays, space)
    }

    #[test]
    fn samples_are_uniform_by_area() {
        let mut m = MeshBuilder::new("two quads");
        m.quad([Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]);
        m.quad([Vec3::new(5.0, 0.0, 0.0), Vec3::new(8.0, 0.0, 0.0), Vec3::new(8.0, 1.0, 0.0), Vec3::new(5.0, 1.0, 0.0)]);
        let s = surface_samples(&m.finish(), 40_000, 3);
        let big = s.points.iter().filter(|p| p.x > 4.0).count() as f64 / 40_000.0;
        assert!((big - 0.75).abs() < 0.01, "{big}");
        assert!((s.area_each * 40_000.0 - 4.0).abs() < 1e-6);
    }

    #[test]
    fn one_probe_in_a_closed_box_covers_all_of_it() {
        let scene = rooms(1, 6.0, 3.0, 4.0, &[]);
        let (rays, space) = setup(&scene);
        let report = coverage(&scene, &rays, &space, &[Vec3::new(3.0, 1.5, 2.0)], &CoverageParams { samples: 20_000, ..Default::default() });
        // Only the inner faces are reachable: the walls are 0.2 thick, centred on the
        // room's outline, so the inside is 5.8 × 3 × 3.8.
        let inner = 2.0 * (5.8 * 3.8) + 2.0 * (5.8 * 3.0) + 2.0 * (3.8 * 3.0);
        assert!((report.reachable_area - inner).abs() < 0.01 * inner, "{} vs {inner}", report.reachable_area);
        assert!(report.fraction() > 0.999, "{}", report.fraction());
    }

    #[test]
    fn a_probe_in_one_of_two_rooms_sees_its_room_and_some_of_the_next_through_the_door() {
        let scene = rooms(2, 5.0, 3.0, 4.0, &[1]);
        let (rays, space) = setup(&scene);
        let params = CoverageParams { samples: 20_000, ..Default::default() };
        let one = coverage(&scene, &rays, &space, &[Vec3::new(2.5, 1.5, 2.0)], &params);
        let both = coverage(&scene, &rays, &space, &[Vec3::new(2.5, 1.5, 2.0), Vec3::new(7.5, 1.5, 2.0)], &params);
        assert!(one.fraction() > 0.5 && one.fraction() < 0.8, "{}", one.fraction());
        assert!(both.fraction() > 0.995, "{}", both.fraction());
        assert_eq!(both.curve.len(), 2);
        assert!((both.curve[0].1 - one.fraction()).abs() < 1e-12, "the curve's first point is the first probe alone");
        assert_eq!(both.probes_for(0.99), Some(2));
    }

    #[test]
    fn surface_seen_only_through_a_crevice_is_kept_apart_from_the_ceiling() {
        // A cabinet 2 m wide and 2 m tall stands 5 cm (about two voxels) from the
        // back wall of a closed room: the wall behind it and its back face (8 m²)
        // are seen only through the gap, from free voxels touching geometry.
        let scene = rooms_with(1, 6.0, 3.0, 4.0, &[], |m| m.cuboid(Vec3::new(2.0, 0.0, 0.15), Vec3::new(4.0, 2.0, 0.65)));
        let plain = rooms(1, 6.0, 3.0, 4.0, &[]);
        let params = CoverageParams { samples: 40_000, ..Default::default() };
        let (rays, space) = setup(&scene);
        let probes = [Vec3::new(1.0, 1.5, 3.0), Vec3::new(5.0, 1.5, 3.0), Vec3::new(3.0, 2.6, 1.2)];
        let ceiling = coverage(&scene, &rays, &space, &probes, &params).ceiling();
        assert!(ceiling.crevices > 0.5 * 8.0 && ceiling.crevices < 1.05 * 8.0, "{ceiling:?}");
        assert!(ceiling.covered > 0.97 * ceiling.area, "{ceiling:?}");
        // The plain room has no crevice, corners included.
        let (rays, space) = setup(&plain);
        let ceiling = coverage(&plain, &rays, &space, &probes, &params).ceiling();
        assert!(ceiling.crevices < 0.005 * ceiling.area, "{ceiling:?}");
    }

    #[test]
    fn no_probes_no_coverage_and_deterministic() {
        let scene = rooms(1, 6.0, 3.0, 4.0, &[]);
        let (rays, space) = setup(&scene);
        let params = CoverageParams { samples: 5_000, ..Default::default() };
        let a = coverage(&scene, &rays, &space, &[], &params);
        assert_eq!(a.covered_area, 0.0);
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let b = one.install(|| coverage(&scene, &rays, &space, &[], &params));
        assert_eq!(a.reached_side, b.reached_side);
    }
}

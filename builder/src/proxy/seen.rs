//! Point-to-go's tables: for each triangle of a proxy level, and for each
//! texel of a small depth cube around each probe, the probe that sees that
//! surface best, so the viewer turns a tap (on the proxy, or in a panorama)
//! into a destination with no ray casting on the phone beyond the proxy.
//!
//! "Best" is the probe whose panorama gives the surface the most pixels: the
//! sum over a few points of it of |cos θ| / d² (the solid angle a unit of its
//! area covers) over the points the probe sees. Visibility is tested against
//! the full scene, with slack for the proxy's distance from the true surface
//! (its simplification error), measured along the ray. Only the
//! [`CANDIDATES`] probes nearest a surface compete: one farther than all of
//! them wins only when they are all hidden or grazing, and bundles of
//! hundreds of probes stay cheap.

use super::Mesh;
use crate::raycast::{Ray, RayScene};
use exploremaps_format::{cube_direction, depthmap::DepthMap, seen::NONE};
use glam::Vec3;
use rayon::prelude::*;

pub const CANDIDATES: usize = 24;

/// The probe (index in `probes`) that sees best the surface sampled at
/// `points` with unit `normal` (zero: judged by distance alone), or NONE.
fn best_probe(rays: &RayScene, probes: &[Vec3], points: &[Vec3], normal: Vec3, slack: f32) -> u32 {
    let centre = points.iter().sum::<Vec3>() / points.len().max(1) as f32;
    let mut near: Vec<(f32, usize)> = probes.iter().enumerate().map(|(i, p)| (p.distance_squared(centre), i)).collect();
    if near.len() > CANDIDATES {
        near.select_nth_unstable_by(CANDIDATES - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        near.truncate(CANDIDATES);
    }
    near.sort_unstable_by_key(|c| c.1);
    let mut best = (NONE, 0.0f32);
    for &(_, i) in &near {
        let eye = probes[i];
        let mut score = 0.0;
        for &p in points {
            let d = p - eye;
            let dist = d.length();
            if dist <= slack {
                continue;
            }
            let cos = if normal == Vec3::ZERO { 1.0 } else { normal.dot(d).abs() / dist };
            let reach = dist - slack / cos.max(0.2);
            if reach <= 0.0 || !rays.occluded(&Ray { t_max: reach / dist, ..Ray::new(eye, d) }) {
                score += cos / (dist * dist);
            }
        }
        if score > best.1 {
            best = (i as u32, score);
        }
    }
    best.0
}

/// Per triangle of `mesh`, the index in `probes` of the probe that sees it
/// best, or [`NONE`]. `error` is the level's distance from the scene's surface.
pub fn best_probes(rays: &RayScene, mesh: &Mesh, probes: &[Vec3], error: f32) -> Vec<u32> {
    // Room for quantization and float error beyond the simplification's own.
    let slack = error + 1e-4 * mesh.diagonal();
    mesh.triangles
        .par_iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
            let centre = (a + b + c) / 3.0;
            let normal = (b - a).cross(c - a).normalize_or_zero();
            best_probe(rays, probes, &[centre, (centre + a) / 2.0, (centre + b) / 2.0, (centre + c) / 2.0], normal, slack)
        })
        .collect()
}

/// Probe `eye`'s depth cube in `map` (empty, of `map.size`² texels a face):
/// what each texel's central direction hits (distance between `map.near` and
/// `map.far`, log-coded) and the probe that sees that point best. `slack`
/// absorbs float error.
pub fn depth_map(rays: &RayScene, eye: Vec3, probes: &[Vec3], mut map: DepthMap, slack: f32) -> DepthMap {
    let n = map.size as usize;
    let texels: Vec<(Option<f32>, u32)> = (0..6 * n * n)
        .into_par_iter()
        .map(|i| {
            let (face, y, x) = (i / (n * n), (i / n) % n, i % n);
            let d = Vec3::from(cube_direction(face, (x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32)).normalize();
            match rays.intersect(&Ray::new(eye, d)) {
                Some(hit) => (Some(hit.t), best_probe(rays, probes, &[eye + d * hit.t], hit.normal, slack)),
                None => (None, NONE),
            }
        })
        .collect();
    for (distance, best) in texels {
        map.depth.push(map.code(distance));
        map.best.push(best);
    }
    map
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two rooms side by side, 4 × 3 × 4 each, a 0.2-thick wall between
    /// them and no door. Built of axis-aligned quads facing in.
    fn two_rooms() -> Mesh {
        let mut m = Mesh::default();
        let mut quad = |corners: [Vec3; 4], group: u32| {
            let base = m.positions.len() as u32;
            m.positions.extend(corners);
            m.triangles.push([base, base + 1, base + 2]);
            m.triangles.push([base, base + 2, base + 3]);
            m.groups.extend([group; 2]);
        };
        for (room, x0) in [(0u32, 0.0f32), (1, 4.2)] {
            let (x1, y1, z1) = (x0 + 4.0, 3.0, 4.0);
            let v = |x, y, z| Vec3::new(x, y, z);
            quad([v(x0, 0.0, 0.0), v(x0, 0.0, z1), v(x1, 0.0, z1), v(x1, 0.0, 0.0)], room); // floor
            quad([v(x0, y1, 0.0), v(x1, y1, 0.0), v(x1, y1, z1), v(x0, y1, z1)], room); // ceiling
            quad([v(x0, 0.0, 0.0), v(x1, 0.0, 0.0), v(x1, y1, 0.0), v(x0, y1, 0.0)], room); // back
            quad([v(x0, 0.0, z1), v(x0, y1, z1), v(x1, y1, z1), v(x1, 0.0, z1)], room); // front
            quad([v(x0, 0.0, 0.0), v(x0, y1, 0.0), v(x0, y1, z1), v(x0, 0.0, z1)], room); // left
            quad([v(x1, 0.0, 0.0), v(x1, 0.0, z1), v(x1, y1, z1), v(x1, y1, 0.0)], room);
            // right
        }
        m
    }

    /// Probes 0 and 1 in the left room (0 near its left wall), 2 in the right one.
    const PROBES: [Vec3; 3] = [Vec3::new(1.0, 1.6, 2.0), Vec3::new(3.0, 1.6, 2.0), Vec3::new(6.2, 1.6, 2.0)];

    #[test]
    fn each_room_is_seen_best_from_its_own_probe_and_the_nearer_probe_wins_within_a_room() {
        let mesh = two_rooms();
        let rays = RayScene::new(&mesh.positions, &mesh.triangles, 0).unwrap();
        let best = best_probes(&rays, &mesh, &PROBES, 0.0);
        for (t, &p) in best.iter().enumerate() {
            let room = mesh.groups[t];
            assert_ne!(p, NONE, "triangle {t}");
            assert_eq!(room == 1, p == 2, "triangle {t} of room {room} went to probe {p}");
        }
        // The left room's left wall (triangles 8 and 9): probe 0 stands a metre from it.
        assert_eq!(&best[8..10], &[0, 0]);
        // Its right wall (10, 11) is nearer probe 1.
        assert_eq!(&best[10..12], &[1, 1]);
        // With every probe in the right room, the left room is seen by none.
        let right_only = best_probes(&rays, &mesh, &PROBES[2..], 0.0);
        assert!(right_only.iter().zip(&mesh.groups).all(|(&p, &g)| (p == NONE) == (g == 0)));
    }

    #[test]
    fn a_depth_map_holds_the_distance_each_way_and_the_probe_that_sees_that_wall_best() {
        let mesh = two_rooms();
        let rays = RayScene::new(&mesh.positions, &mesh.triangles, 0).unwrap();
        let map = depth_map(&rays, PROBES[1], &PROBES, DepthMap { size: 32, near: 0.05, far: 20.0, depth: vec![], best: vec![] }, 1e-3);
        // From probe 1 at x = 3: the left wall 3 away (probe 0 sees it best), the right
        // wall 1 away (probe 1 itself), the back wall (z = 0) 2 away.
        for (dir, distance, probe) in [([-1.0, 0.0, 0.0], 3.0, 0), ([1.0, 0.0, 0.0], 1.0, 1), ([0.0, 0.0, -1.0], 2.0, 1)] {
            let (d, p) = map.look(dir).unwrap();
            assert!((d - distance).abs() / distance < 0.02, "{dir:?}: {d}");
            assert_eq!(p, probe, "{dir:?}");
        }
        // Straight up: the ceiling 1.4 above.
        let (d, _) = map.look([0.0, 1.0, 0.0]).unwrap();
        assert!((d - 1.4).abs() < 0.03, "{d}");
        // The right room is never the answer from inside the left one.
        assert!(map.best.iter().all(|&p| p != 2));
        // A few KB a probe.
        assert!(map.encode().len() < 6 * 1024, "{} bytes", map.encode().len());
    }
}

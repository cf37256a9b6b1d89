//! Point-to-go's table: for each triangle of a proxy level, the probe that
//! sees it best, so the viewer turns a tap on the proxy into a probe with no
//! ray casting on the phone beyond the proxy itself.
//!
//! "Best" is the probe whose panorama gives the triangle the most pixels: the
//! sum over a few points of the triangle of |cos θ| / d² (the solid angle a
//! unit of its area covers) over the points the probe sees. Visibility is
//! tested against the full scene, with slack for the proxy's distance from
//! the true surface (its simplification error), measured along the ray.

use super::Mesh;
use crate::raycast::{Ray, RayScene};
use exploremaps_format::seen::NONE;
use glam::Vec3;
use rayon::prelude::*;

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
            let points = [centre, (centre + a) / 2.0, (centre + b) / 2.0, (centre + c) / 2.0];
            let mut best = (NONE, 0.0f32);
            for (i, &eye) in probes.iter().enumerate() {
                let mut score = 0.0;
                for &p in &points {
                    let d = p - eye;
                    let dist = d.length();
                    if dist <= slack {
                        continue;
                    }
                    // A degenerate triangle's normal is zero: judge it by distance alone.
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
        })
        .collect()
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
            quad([v(x1, 0.0, 0.0), v(x1, 0.0, z1), v(x1, y1, z1), v(x1, y1, 0.0)], room); // right
        }
        m
    }

    #[test]
    fn each_room_is_seen_best_from_its_own_probe_and_the_nearer_probe_wins_within_a_room() {
        let mesh = two_rooms();
        let rays = RayScene::new(&mesh.positions, &mesh.triangles, 0).unwrap();
        // Probes 0 and 1 in the left room (0 near its left wall), 2 in the right one.
        let probes = [Vec3::new(1.0, 1.6, 2.0), Vec3::new(3.0, 1.6, 2.0), Vec3::new(6.2, 1.6, 2.0)];
        let best = best_probes(&rays, &mesh, &probes, 0.0);
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
        let right_only = best_probes(&rays, &mesh, &probes[2..], 0.0);
        assert!(right_only.iter().zip(&mesh.groups).all(|(&p, &g)| (p == NONE) == (g == 0)));
    }
}

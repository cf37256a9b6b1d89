//! Orient: where a probe is best looked at from (the ExploreMaps paper,
//! section 5, after Vázquez et al.'s viewpoint measures).
//!
//! Inputs: the ray-casting scene, a probe position, the near distance r, the
//! scene diagonal. Output: preferred view directions (yaw, pitch, goodness),
//! best first; the first is the arrival and thumbnail direction.
//!
//! Goodness of a direction: the pixels of a coarse cube map within a 45° cone
//! around it give a depth histogram H (16 bins over [0, diagonal/2]) and a
//! largest depth; G = α·(max depth / (diagonal/2)) + β·(1 − Σ H²), times a
//! stability factor 1 − ½·mean |H − H'| over the views from the probe moved by
//! r along ±x, ±z (views that change little when the camera moves are better,
//! so the factor is 1 for a perfectly stable view and falls as it changes),
//! times a clear-view factor min(1, central depth / max(½ · all-round depth, 8 r)):
//! the depth of the nearest 30 % within 12° of the direction against the
//! probe's median depth over the whole sphere (and eight near distances), so a pillar or a
//! wall at arm's length straight ahead makes a poor first view however deep the
//! scene around it is.
//! Directions are kept upright: pitch within ±30°, no roll. Preferred
//! directions are the modes of G over 96 candidate directions found by
//! mean-shift (kernel 30°), each snapped to the best candidate within the
//! kernel (so the view shown is one that was scored), merged within 15°.
//!
//! Defaults: α = 0.5, β = 0.5, cube faces of 24², 96 directions.

use crate::plan::visibility::CubeView;
use crate::raycast::RayScene;
use glam::Vec3;

pub const ALPHA: f32 = 0.5;
pub const BETA: f32 = 0.5;
const FACE_RES: usize = 24;
const DIRECTIONS: usize = 96;
const CONE_COS: f32 = std::f32::consts::FRAC_1_SQRT_2; // 45°
const BINS: usize = 16;
const MAX_PITCH: f32 = std::f32::consts::FRAC_PI_6; // 30°
/// A view whose central median depth is under this share of the probe's
/// all-round median depth, or under CLEAR_NEARS near distances (about 2.4 m
/// with a trusted scale), is scaled down in proportion.
const CLEAR_SHARE: f32 = 0.5;
const CLEAR_NEARS: f32 = 8.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Preferred {
    pub yaw: f32,
    pub pitch: f32,
    pub goodness: f32,
}

/// Unit direction of yaw and pitch, the bundle format's convention.
pub fn direction(yaw: f32, pitch: f32) -> Vec3 {
    Vec3::from(exploremaps_format::direction(yaw, pitch))
}

/// Yaw and pitch of a direction, the bundle format's convention.
pub fn yaw_pitch(d: Vec3) -> (f32, f32) {
    exploremaps_format::yaw_pitch(d.to_array())
}

/// Upright candidate directions: rings of yaw at a few pitches within ±30°.
fn candidates() -> Vec<Vec3> {
    let pitches = [-0.35f32, -0.12, 0.12, 0.35];
    let per_ring = DIRECTIONS / pitches.len();
    pitches
        .iter()
        .enumerate()
        .flat_map(|(r, &p)| (0..per_ring).map(move |k| direction(std::f32::consts::TAU * (k as f32 + 0.5 * (r % 2) as f32) / per_ring as f32, p)))
        .collect()
}

/// Cosine of the central cone whose depth says whether a view is blocked (12°).
const CENTRAL_COS: f32 = 0.978;
/// The central depth taken: the nearest 30 % (a view half filled by a door
/// jamb at arm's length is blocked, whatever shows through the other half).
const CENTRAL_QUANTILE: f32 = 0.3;

/// Per candidate direction: the depth histogram and largest depth of the cone
/// around it, and the depth of the nearest 30 % of its central 12°.
fn cone_histograms(view: &CubeView, dirs: &[Vec3], range: f32) -> Vec<([f32; BINS], f32, f32)> {
    // Misses (sky) count as the far end of the range.
    let depth = |pixel: usize| view.hits[pixel].map_or(range, |hit| hit.t.min(range));
    dirs.iter()
        .map(|&d| {
            let mut h = [0.0f32; BINS];
            let (mut count, mut max_depth) = (0.0f32, 0.0f32);
            let mut central = Vec::new();
            for (pixel, ray_dir) in view.dirs.iter().enumerate() {
                let cos = ray_dir.dot(d);
                if cos < CONE_COS {
                    continue;
                }
                let t = depth(pixel);
                h[((t / range * BINS as f32) as usize).min(BINS - 1)] += 1.0;
                count += 1.0;
                max_depth = max_depth.max(t);
                if cos >= CENTRAL_COS {
                    central.push(t);
                }
            }
            if count > 0.0 {
                h.iter_mut().for_each(|v| *v /= count);
            }
            (h, max_depth, quantile(&mut central, CENTRAL_QUANTILE))
        })
        .collect()
}

/// The value below which `q` of the values lie (0 for none).
fn quantile(values: &mut [f32], q: f32) -> f32 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f32::total_cmp);
    values[((values.len() - 1) as f32 * q) as usize]
}

/// Goodness of every candidate direction around `probe`: (direction, goodness, stability).
pub fn goodness(rays: &RayScene, probe: Vec3, near: f32, diagonal: f32) -> Vec<(Vec3, f32, f32)> {
    let dirs = candidates();
    let range = (0.5 * diagonal).max(f32::MIN_POSITIVE);
    let view = CubeView::trace(rays, probe, FACE_RES);
    let here = cone_histograms(&view, &dirs, range);
    // How far the probe sees, all round: a view is blocked when its centre is
    // much nearer than that (a pillar or a wall at arm's length).
    let all_round =
        quantile(&mut (0..view.hits.len()).map(|p| view.hits[p].map_or(range, |h| h.t.min(range))).collect::<Vec<_>>(), 0.5).max(f32::MIN_POSITIVE);
    let moved: Vec<Vec<([f32; BINS], f32, f32)>> = [Vec3::X, Vec3::NEG_X, Vec3::Z, Vec3::NEG_Z]
        .iter()
        .map(|&m| cone_histograms(&CubeView::trace(rays, probe + m * near, FACE_RES), &dirs, range))
        .collect();
    dirs.iter()
        .enumerate()
        .map(|(k, &d)| {
            let (h, max_depth, central) = &here[k];
            let spread = 1.0 - h.iter().map(|v| v * v).sum::<f32>();
            let change = moved.iter().map(|m| 0.5 * h.iter().zip(&m[k].0).map(|(a, b)| (a - b).abs()).sum::<f32>()).sum::<f32>() / moved.len() as f32;
            let stability = 1.0 - change;
            let clear = (central / (CLEAR_SHARE * all_round).max(CLEAR_NEARS * near)).min(1.0);
            (d, (ALPHA * max_depth / range + BETA * spread) * stability * clear, stability)
        })
        .collect()
}

/// Preferred directions of a probe, best first (at least one).
pub fn preferred_directions(rays: &RayScene, probe: Vec3, near: f32, diagonal: f32) -> Vec<Preferred> {
    let scored: Vec<(Vec3, f32)> = goodness(rays, probe, near, diagonal).into_iter().map(|(d, g, _)| (d, g)).collect();
    let kernel_cos = 0.866f32; // 30°
    let mut modes: Vec<(Vec3, f32)> = Vec::new();
    for &(start, _) in &scored {
        let mut d = start;
        for _ in 0..30 {
            let (sum, weight) = scored.iter().filter(|(c, _)| c.dot(d) > kernel_cos).fold((Vec3::ZERO, 0.0f32), |(s, w), &(c, g)| (s + c * g, w + g));
            if weight <= 0.0 {
                break;
            }
            let next = upright(sum / weight);
            let converged = next.dot(d) > 0.99999;
            d = next;
            if converged {
                break;
            }
        }
        // The mode's view is the best evaluated candidate within the kernel: the
        // mean of nearby directions may itself graze a wall nobody scored.
        let Some(&(d, g)) = scored.iter().filter(|(c, _)| c.dot(d) > kernel_cos).max_by(|a, b| a.1.total_cmp(&b.1)) else { continue };
        if !modes.iter().any(|(m, _)| m.dot(d) > 0.966) {
            modes.push((d, g));
        }
    }
    modes.sort_by(|a, b| b.1.total_cmp(&a.1));
    modes
        .into_iter()
        .map(|(d, goodness)| {
            let (yaw, pitch) = yaw_pitch(d);
            Preferred { yaw, pitch, goodness }
        })
        .collect()
}

/// Normalises and clamps the pitch to ±30°.
fn upright(d: Vec3) -> Vec3 {
    let (yaw, pitch) = yaw_pitch(d.normalize_or(Vec3::NEG_Z));
    direction(yaw, pitch.clamp(-MAX_PITCH, MAX_PITCH))
}

#[cfg(test)]
mod tests {
    use super::*;
    use exploremaps_scenes::mesh::{MeshBuilder, Wall};

    #[test]
    fn yaw_pitch_convention_round_trips() {
        for (yaw, pitch) in [(0.0, 0.0), (1.0, 0.2), (-2.0, -0.4)] {
            let (y, p) = yaw_pitch(direction(yaw, pitch));
            assert!((y - yaw).abs() < 1e-5 && (p - pitch).abs() < 1e-5);
        }
        assert!((direction(std::f32::consts::FRAC_PI_2, 0.0) - Vec3::X).length() < 1e-6);
    }

    #[test]
    fn in_a_long_corridor_the_preferred_direction_lies_along_it() {
        // A closed corridor 30 long (x), 2 wide, 3 high; the probe off-centre toward -x.
        let mut m = MeshBuilder::new("corridor");
        m.cuboid(Vec3::new(-0.2, -0.2, -0.2), Vec3::new(30.2, 0.0, 2.2));
        m.cuboid(Vec3::new(-0.2, 3.0, -0.2), Vec3::new(30.2, 3.2, 2.2));
        m.wall(Wall::along_x(0.0, 0.0, 30.0), 0.0..3.0, 0.2, &[]);
        m.wall(Wall::along_x(2.0, 0.0, 30.0), 0.0..3.0, 0.2, &[]);
        m.wall(Wall::along_z(0.0, 0.0, 2.0), 0.0..3.0, 0.2, &[]);
        m.wall(Wall::along_z(30.0, 0.0, 2.0), 0.0..3.0, 0.2, &[]);
        let scene = m.finish();
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let probe = Vec3::new(8.0, 1.5, 1.0);
        let best = preferred_directions(&rays, probe, 0.15, scene.bounds().diagonal());
        let d = direction(best[0].yaw, best[0].pitch);
        assert!(d.x.abs() > 0.9, "best direction {d} does not follow the corridor ({best:?})");
        assert!(d.x > 0.0, "the long end of the corridor is the better view ({best:?})");
        assert!(best[0].pitch.abs() <= MAX_PITCH + 1e-5);
        assert!(best.windows(2).all(|w| w[0].goodness >= w[1].goodness));
    }

    #[test]
    fn the_first_view_faces_into_the_room_not_a_pillar_at_arms_length() {
        // Gallery probes whose first view, before the clear-view factor, met a
        // pillar or a wall 1.1 to 2.4 m ahead (issue: navigable space).
        let scene = exploremaps_scenes::BuiltIn::Gallery.generate(1);
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        for probe in [Vec3::new(30.326, 1.6, 3.632), Vec3::new(37.955, 1.6, 19.494), Vec3::new(5.691, 1.6, 3.648)] {
            let best = preferred_directions(&rays, probe, 0.272, scene.bounds().diagonal());
            // How open the view is: the median depth of a 5 × 5 fan of rays within
            // 10° of its centre, cast here rather than taken from the goodness.
            let mut depths: Vec<f32> = (0..25)
                .map(|k| {
                    let (yaw, pitch) = (best[0].yaw + 0.087 * ((k % 5) as f32 - 2.0), best[0].pitch + 0.087 * ((k / 5) as f32 - 2.0));
                    rays.intersect(&crate::raycast::Ray::new(probe, direction(yaw, pitch))).map_or(f32::INFINITY, |h| h.t)
                })
                .collect();
            depths.sort_by(f32::total_cmp);
            assert!(depths[12] > 3.0, "from {probe} the first view ({best:?}) is open for a median {:.2} ahead", depths[12]);
        }
    }

    #[test]
    fn stability_rewards_views_that_change_little() {
        // Facing a wall 0.6 away (depths shift a lot as the probe moves) against
        // facing down a long empty room (depths barely shift).
        let mut m = MeshBuilder::new("room");
        m.cuboid(Vec3::new(-0.2, -0.2, -0.2), Vec3::new(20.2, 0.0, 20.2));
        m.cuboid(Vec3::new(-0.2, 3.0, -0.2), Vec3::new(20.2, 3.2, 20.2));
        for (along_x, line) in [(true, 0.0), (true, 20.0), (false, 0.0), (false, 20.0)] {
            m.wall(Wall::new(along_x, line, 0.0, 20.0), 0.0..3.0, 0.2, &[]);
        }
        let scene = m.finish();
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let scored = goodness(&rays, Vec3::new(0.7, 1.5, 10.0), 0.4, scene.bounds().diagonal());
        let toward = |v: Vec3| *scored.iter().max_by(|a, b| a.0.dot(v).total_cmp(&b.0.dot(v))).unwrap();
        let (open, wall) = (toward(Vec3::X), toward(Vec3::NEG_X));
        assert!(open.2 > wall.2 && open.2 > 0.8, "stability: open view {} vs wall {}", open.2, wall.2);
        assert!(open.1 > wall.1, "goodness: open view {} vs wall {}", open.1, wall.1);
    }
}

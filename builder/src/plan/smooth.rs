//! Smooth: mass-spring smoothing of raw paths, then camera timing.
//!
//! Inputs: a raw polyline between two probes, the ray-casting scene, the
//! navigable [`FreeSpace`]. Output: a smooth polyline with clearance ≥ r, its
//! verification, and camera keys.
//!
//! The polyline is resampled to masses about one voxel apart; each iteration
//! moves every inner mass by springs toward the midpoint of its neighbours
//! (which both evens the rest lengths, shortens the path and unbends it) plus a
//! repulsion up the clearance field, inverse-square in the clearance, within 3r
//! of surfaces. A move is taken only if the mass stays navigable (clearance
//! ≥ r) and neither segment to its neighbours stops being clear (every voxel
//! it crosses navigable, no geometry across it). Endpoints are fixed. It
//! stops when no mass moves more than a thousandth of a voxel, or after 400
//! iterations. Every final segment is then verified by a ray cast and its
//! clearance measured over every voxel it crosses.
//!
//! Timing: duration = length / walking speed (1.4 m/s through the unit
//! scale), at least 1.5 s and at most 10 s (a longer path is travelled
//! faster: a visitor waits for a transition, and where the scale is only
//! guessed, as for a scene flown through, walking pace made the Crytek
//! Sponza's transitions 46 s long on average); keys at 25 fps; position by
//! arc length with slow-in/slow-out (smoothstep); view blended with the same
//! easing from the direction of travel at departure to the arrival direction.

use crate::plan::connect::{polyline_length, segment_clear};
use crate::plan::freespace::FreeSpace;
use crate::plan::orient::yaw_pitch;
use crate::raycast::{Ray, RayScene};
use exploremaps_format::timing::{ease, ArcLength};
use glam::Vec3;

const MAX_ITERATIONS: usize = 400;
const STEP: f32 = 0.5;
pub const WALKING_SPEED_M_S: f32 = 1.4;
pub const MIN_DURATION_S: f32 = 1.5;
pub const MAX_DURATION_S: f32 = 10.0;
pub const FPS: f32 = 25.0;

#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct SmoothingStats {
    pub iterations: usize,
    /// Segments that cross geometry after smoothing (0 when verified).
    pub blocked_segments: usize,
    pub min_clearance: f32,
    pub mean_clearance: f32,
    pub length_before: f32,
    pub length_after: f32,
}

/// Turning angle per unit length, largest along the polyline (radians / unit).
pub fn max_curvature(p: &[Vec3]) -> f32 {
    p.windows(3)
        .map(|w| {
            let (a, b) = (w[1] - w[0], w[2] - w[1]);
            // atan2 of cross and dot stays accurate for small turns, where acos of
            // a dot of normalised vectors rounds to about 5e-4 rad for none.
            let turn = a.cross(b).length().atan2(a.dot(b));
            turn / (0.5 * (a.length() + b.length())).max(1e-6)
        })
        .fold(0.0, f32::max)
}

fn resample(p: &[Vec3], spacing: f32) -> Vec<Vec3> {
    let length = polyline_length(p);
    let n = (length / spacing).ceil().max(1.0) as usize;
    let mut out = Vec::with_capacity(n + 1);
    let (mut seg, mut walked) = (0usize, 0.0f32);
    for k in 0..=n {
        let target = length * k as f32 / n as f32;
        while seg + 2 < p.len() && walked + (p[seg + 1] - p[seg]).length() < target {
            walked += (p[seg + 1] - p[seg]).length();
            seg += 1;
        }
        let l = (p[seg + 1] - p[seg]).length().max(1e-12);
        out.push(p[seg] + (p[seg + 1] - p[seg]) * ((target - walked) / l).clamp(0.0, 1.0));
    }
    out
}

/// Gradient of the clearance field at `p` (central differences, one voxel).
fn clearance_gradient(space: &FreeSpace, p: Vec3) -> Vec3 {
    let h = space.grid.voxel;
    let d = |axis: Vec3| space.clearance_at(p + axis * h) - space.clearance_at(p - axis * h);
    Vec3::new(d(Vec3::X), d(Vec3::Y), d(Vec3::Z)) / (2.0 * h)
}

/// Smooths a raw path; endpoints stay put.
pub fn smooth(rays: &RayScene, space: &FreeSpace, raw: &[Vec3]) -> (Vec<Vec3>, SmoothingStats) {
    let mut stats = SmoothingStats { length_before: polyline_length(raw), ..Default::default() };
    let spacing = space.grid.voxel.max(polyline_length(raw) / 400.0);
    let mut p = resample(raw, spacing);
    let r = space.near;
    for iteration in 1..=MAX_ITERATIONS {
        stats.iterations = iteration;
        let mut largest = 0.0f32;
        for i in 1..p.len().saturating_sub(1) {
            let spring = 0.5 * (p[i - 1] + p[i + 1]) - p[i];
            let c = space.clearance_at(p[i]).max(1e-6);
            let repulsion = if c < 3.0 * r { clearance_gradient(space, p[i]).normalize_or_zero() * spacing * (r / c).powi(2) } else { Vec3::ZERO };
            let next = p[i] + (spring + repulsion * 0.25) * STEP;
            let moved = (next - p[i]).length();
            if moved == 0.0 || !space.is_navigable(next) {
                continue;
            }
            // No segment that was clear may stop being clear (one that was
            // not, where a raw route cut a corner, may stay so while it mends).
            // The same for the stretches of a path that glide where walking
            // cannot (see `connect`): they may not come to cross geometry.
            let clear = |x: Vec3, y: Vec3| segment_clear(rays, space, x, y);
            let glides = |x: Vec3, y: Vec3| space.segment_glides(x, y) && !rays.occluded(&Ray::segment(x, y));
            let keeps = |old: (Vec3, Vec3), new: (Vec3, Vec3)| {
                clear(new.0, new.1) || (!clear(old.0, old.1) && (!glides(old.0, old.1) || glides(new.0, new.1)))
            };
            if !keeps((p[i - 1], p[i]), (p[i - 1], next)) || !keeps((p[i], p[i + 1]), (next, p[i + 1])) {
                continue;
            }
            p[i] = next;
            largest = largest.max(moved);
        }
        if largest < 1e-3 * space.grid.voxel {
            break;
        }
    }
    stats.blocked_segments = p.windows(2).filter(|w| rays.occluded(&Ray::segment(w[0], w[1]))).count();
    let clearances: Vec<f32> = p.iter().map(|&q| space.clearance_at(q)).collect();
    // The least over every voxel the path crosses, not only at its masses.
    stats.min_clearance = p.windows(2).map(|w| space.segment_clearance(w[0], w[1])).fold(f32::INFINITY, f32::min);
    stats.mean_clearance = clearances.iter().sum::<f32>() / clearances.len().max(1) as f32;
    stats.length_after = polyline_length(&p);
    (p, stats)
}

/// Seconds the camera takes along `length` scene units.
pub fn duration(length: f32, metres_per_unit: f32) -> f32 {
    (length * metres_per_unit / WALKING_SPEED_M_S).clamp(MIN_DURATION_S, MAX_DURATION_S)
}

/// Camera keys at 25 fps: (time s, position, yaw, pitch), eased along the
/// path's length as the viewer moves (`exploremaps_format::timing`).
pub fn camera_keys(p: &[Vec3], duration_s: f32, arrival: Option<(f32, f32)>) -> Vec<(f32, Vec3, f32, f32)> {
    let departure = yaw_pitch(p[1.min(p.len() - 1)] - p[0]);
    let (end_yaw, end_pitch) = arrival.unwrap_or_else(|| yaw_pitch(p[p.len() - 1] - p[p.len().saturating_sub(2)]));
    let frames = (duration_s * FPS).ceil().max(1.0) as usize;
    let points: Vec<[f32; 3]> = p.iter().map(|q| q.to_array()).collect();
    let arc = ArcLength::new(&points);
    (0..=frames)
        .map(|f| {
            let t = (f as f32 / FPS).min(duration_s);
            let s = ease(t / duration_s);
            let turn = (end_yaw - departure.0 + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU) - std::f32::consts::PI;
            (t, Vec3::from(arc.at(s)), departure.0 + turn * s, departure.1 + (end_pitch - departure.1) * s)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::freespace::{free_space, FreeSpaceParams, HeightMode, SpaceMode};

    fn pillar_room() -> (RayScene, FreeSpace) {
        let scene = crate::testing::pillar_room(1.0);
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let (space, _) =
            free_space(&scene, &rays, &FreeSpaceParams { space: SpaceMode::Inside, height: HeightMode::Fly, ..Default::default() }).unwrap();
        (rays, space)
    }

    #[test]
    fn smoothing_a_detour_round_a_pillar_keeps_clearance_and_lowers_curvature() {
        let (rays, space) = pillar_room();
        // A jagged raw route round the pillar's +z side.
        let raw = vec![
            Vec3::new(2.0, 1.5, 3.0),
            Vec3::new(3.0, 1.5, 4.6),
            Vec3::new(4.0, 1.5, 4.7),
            Vec3::new(5.0, 1.5, 5.0),
            Vec3::new(6.0, 1.5, 4.7),
            Vec3::new(7.0, 1.5, 4.6),
            Vec3::new(8.0, 1.5, 3.0),
        ];
        let (p, stats) = smooth(&rays, &space, &raw);
        assert_eq!(stats.blocked_segments, 0);
        assert!(stats.min_clearance >= space.near, "{stats:?}");
        assert_eq!((p[0], *p.last().unwrap()), (raw[0], raw[6]), "endpoints are fixed");
        assert!(max_curvature(&p) <= max_curvature(&resample(&raw, space.grid.voxel)) + 1e-4, "{stats:?}");
        assert!(stats.length_after <= stats.length_before, "{stats:?}");
        assert!(p.iter().all(|q| ((q.x - 5.0).powi(2) + (q.z - 3.0).powi(2)).sqrt() > 1.0), "goes round the pillar");
    }

    #[test]
    fn a_straight_clear_path_stays_straight() {
        let (rays, space) = pillar_room();
        let raw = vec![Vec3::new(1.0, 1.5, 1.0), Vec3::new(9.0, 1.5, 1.0)];
        let (p, stats) = smooth(&rays, &space, &raw);
        assert!(max_curvature(&p) < 1e-3, "{stats:?}");
        assert!((stats.length_after - 8.0).abs() < 1e-3);
    }

    #[test]
    fn camera_timing_eases_in_and_out_and_turns_to_the_arrival() {
        let p = vec![Vec3::ZERO, Vec3::new(0.0, 0.0, -10.0)];
        let d = duration(10.0, 1.0);
        assert!((d - 10.0 / WALKING_SPEED_M_S).abs() < 1e-5);
        assert_eq!(duration(0.5, 1.0), MIN_DURATION_S);
        assert_eq!(duration(100.0, 1.0), MAX_DURATION_S);
        let keys = camera_keys(&p, d, Some((std::f32::consts::FRAC_PI_2, 0.0)));
        assert_eq!(keys.len(), (d * FPS).ceil() as usize + 1);
        let speed = |k: usize| (keys[k + 1].1 - keys[k].1).length();
        let mid = keys.len() / 2;
        assert!(speed(0) < 0.2 * speed(mid) && speed(keys.len() - 2) < 0.2 * speed(mid), "slow in, slow out");
        assert!(keys[0].2.abs() < 1e-6, "departs along the path (−Z, yaw 0)");
        assert!((keys.last().unwrap().2 - std::f32::consts::FRAC_PI_2).abs() < 1e-5, "arrives facing +X");
        assert!((keys.last().unwrap().1 - p[1]).length() < 1e-4);
    }
}

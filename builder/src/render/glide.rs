//! Glides drawn on the device: each probe's depth cube, and per path whether
//! a glide from the two ends' panoramas will do or the path needs its video.
//!
//! A glide reprojects the departure and arrival panoramas through their
//! depth to the moving camera. It is exact for what either end sees (the
//! renderer's surfaces are Lambertian: nothing changes with the view), so it
//! fails where the camera sees surface that neither end sees. `auto`
//! measures that share of the view at points along the path with the ray
//! caster and gives the path a video where it is too large.

use crate::raycast::Ray;
use crate::tracer::{fibonacci_sphere, Tracer};
use exploremaps_format::depthcube::{corner_direction, DepthCube};
use exploremaps_format::{Path as PathInfo, Transition, TransitionKind};
use glam::Vec3;
use rayon::prelude::*;

/// How paths are shown (`--transitions`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transitions {
    /// A glide where it will do, a video where [`MAX_UNSEEN`] says it fails.
    Auto,
    /// Every path a glide.
    Depth,
    /// Every path a video, and no depth: the bundle as before glides.
    Video,
}

impl Transitions {
    pub fn name(self) -> &'static str {
        match self {
            Transitions::Auto => "auto",
            Transitions::Depth => "depth",
            Transitions::Video => "video",
        }
    }
}

/// The share of the view (by solid angle) seen from neither end above which
/// `auto` renders a video: past it, the glide shows the proxy's flat colours
/// over a noticeable part of the view.
pub const MAX_UNSEEN: f32 = 0.02;
/// Rays a measured point casts, evenly over the sphere.
const RAYS: usize = 2048;
/// Where along a path the view is measured, as fractions of its camera keys.
const ALONG: [f32; 5] = [0.1, 0.3, 0.5, 0.7, 0.9];

/// The distance from `eye` to what each corner direction of a `cells`-cell
/// cube lattice hits (through cut-out holes, as the panoramas see it).
pub fn depth_cube(tracer: &Tracer, eye: Vec3, cells: u32) -> DepthCube {
    let diagonal = tracer.scene().bounds().diagonal().max(f32::MIN_POSITIVE);
    let corners = 6 * (cells as usize + 1).pow(2);
    let distances: Vec<Option<f32>> = (0..corners)
        .into_par_iter()
        .map(|i| {
            let mut ray = Ray::new(eye, Vec3::from(corner_direction(cells, i)));
            tracer.intersect(&mut ray).map(|hit| hit.t)
        })
        .collect();
    // The range spans any distance inside the scene's box to 0.02 %.
    DepthCube::new(cells, 1e-5 * diagonal, 2.0 * diagonal, &distances)
}

/// The largest share of the view, over the points measured along the path,
/// that neither `from` nor `to` sees, and the fraction of the way where it is.
pub fn unseen_along(tracer: &Tracer, path: &PathInfo, from: Vec3, to: Vec3) -> (f32, f32) {
    let directions = fibonacci_sphere(RAYS);
    let mut worst = (0.0f32, 0.5f32);
    let Some(last) = path.camera.len().checked_sub(1) else { return worst };
    for along in ALONG {
        let eye = Vec3::from(path.camera[(last as f32 * along).round() as usize].position);
        let unseen = directions.par_iter().filter(|&&d| seen_by_neither(tracer, eye, d, [from, to])).count();
        let share = unseen as f32 / RAYS as f32;
        if share > worst.0 {
            worst = (share, along);
        }
    }
    worst
}

/// Whether the surface `eye` sees along `d` is hidden from both ends (behind
/// something, or facing away from them). Sky is seen from everywhere.
fn seen_by_neither(tracer: &Tracer, eye: Vec3, d: Vec3, ends: [Vec3; 2]) -> bool {
    let mut ray = Ray::new(eye, d);
    let Some(hit) = tracer.intersect(&mut ray) else { return false };
    let point = eye + d * hit.t;
    let side = hit.normal.dot(eye - point).signum();
    !ends.iter().any(|&end| {
        // From the end toward the point, stopping just short of it.
        let toward = point - end;
        let ray = Ray { origin: end, dir: toward, t_min: 0.0, t_max: 1.0 - 1e-3 };
        hit.normal.dot(-toward).signum() == side && tracer.visible(&ray)
    })
}

/// The transition of a path with `unseen` of its view (at `along` of the
/// way) seen from neither end; None with `video` (no record: as before glides).
pub fn choose(transitions: Transitions, unseen: f32, along: f32) -> Option<Transition> {
    let percent = 100.0 * unseen;
    let at = format!("{percent:.1} % of the view {:.0} % of the way along is seen from neither end", 100.0 * along);
    let (kind, reason) = match transitions {
        Transitions::Video => return None,
        Transitions::Depth => (TransitionKind::Depth, format!("a glide, as asked (--transitions depth); {at}")),
        Transitions::Auto if unseen > MAX_UNSEEN => (TransitionKind::Video, format!("a video: {at}, more than {:.0} %", 100.0 * MAX_UNSEEN)),
        Transitions::Auto => (TransitionKind::Depth, format!("a glide: at most {at}")),
    };
    Some(Transition { kind, unseen, reason })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raycast::RayScene;
    use crate::testing::rooms;
    use crate::tracer::{Lighting, Sky};
    use exploremaps_scenes::Scene;

    fn path(from: Vec3, to: Vec3) -> PathInfo {
        let camera = (0..=20)
            .map(|i| {
                let p = from.lerp(to, i as f32 / 20.0);
                exploremaps_format::CameraKey { t_s: i as f32 / 10.0, position: p.into(), yaw: 0.0, pitch: 0.0 }
            })
            .collect();
        PathInfo {
            id: 0,
            from: 0,
            to: 1,
            polyline: vec![from.into(), to.into()],
            length: from.distance(to),
            duration_s: 2.0,
            camera,
            assets: Default::default(),
        }
    }

    fn tracer<'a>(scene: &'a Scene, rays: &'a RayScene) -> Tracer<'a> {
        Tracer::path_traced(scene, rays, Lighting { sky: Sky::NONE, ..Lighting::for_scene(scene, rays, &[]) }, &[])
    }

    #[test]
    fn a_path_within_a_room_glides_and_one_through_a_room_neither_end_sees_needs_a_video() {
        // Three rooms 4 × 4 in a row (x 0..4, 4..8, 8..12; z 0..4), 3 high,
        // doors between them at z = 2.
        let scene = rooms(3, 4.0, 3.0, 4.0, &[1, 2]);
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let tracer = tracer(&scene, &rays);
        // Within the first room, both ends see all of it.
        let (a, b) = (Vec3::new(1.0, 1.6, 1.0), Vec3::new(3.0, 1.6, 3.0));
        let (within, _) = unseen_along(&tracer, &path(a, b), a, b);
        assert!(within < MAX_UNSEEN, "{within}");
        assert_eq!(choose(Transitions::Auto, within, 0.5).unwrap().kind, TransitionKind::Depth);
        // From the first room to the third through the middle one: the ends
        // see the middle room only through its doors, not its side walls,
        // which fill much of the view from inside it.
        let (a, b) = (Vec3::new(1.0, 1.6, 2.0), Vec3::new(11.0, 1.6, 2.0));
        let (through, along) = unseen_along(&tracer, &path(a, b), a, b);
        assert!(through > 5.0 * MAX_UNSEEN && (0.3..=0.7).contains(&along), "{through} at {along}");
        let transition = choose(Transitions::Auto, through, along).unwrap();
        assert_eq!(transition.kind, TransitionKind::Video);
        assert!(transition.reason.contains("seen from neither end"), "{}", transition.reason);
        assert_eq!(choose(Transitions::Depth, through, along).unwrap().kind, TransitionKind::Depth);
        assert_eq!(choose(Transitions::Video, through, along), None);
    }

    #[test]
    fn depth_cubes_hold_the_distance_to_the_walls() {
        let scene = rooms(2, 4.0, 3.0, 4.0, &[]);
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let tracer = tracer(&scene, &rays);
        let eye = Vec3::new(2.0, 1.5, 1.0);
        let cube = depth_cube(&tracer, eye, 8);
        assert_eq!(cube.codes.len(), 6 * 81);
        for (i, &code) in cube.codes.iter().enumerate() {
            let d = Vec3::from(cube.corner_direction(i));
            let truth = rays.intersect(&Ray::new(eye, d)).map(|h| h.t).expect("a closed room");
            let got = cube.distance(code).expect("a wall");
            assert!((got - truth).abs() <= 1e-3 * truth, "corner {i}: {got} against {truth}");
        }
    }
}

//! Glides drawn on the device: each probe's depth cube, and per path whether
//! a glide from the two ends' panoramas will do or the path needs its video.
//!
//! A glide reprojects the departure and arrival panoramas through their
//! depth to the moving camera. It is exact for what either end sees (the
//! renderer's surfaces are Lambertian: nothing changes with the view), so it
//! fails where the camera sees surface that neither end sees, or sees from
//! much farther. The render measures that share of the view at points along
//! the path with the ray caster, adds panoramas part way where it is too
//! large, and under `auto` gives the path a video where a few do not do.

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

/// Panoramas part way a glide may add before a video is cheaper: at final
/// each costs about a second and 150 KB, a video some 30 s and 4 MB.
pub const MAX_WAYPOINTS: usize = 16;

/// How a glide along a path goes: in legs between its ends and the
/// panoramas part way, and what the worst leg leaves unseen.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Legs {
    /// Camera keys of the panoramas part way, in order.
    pub waypoints: Vec<usize>,
    /// The largest share of the view (by solid angle), over the points
    /// measured along each leg, that neither end of its leg sees...
    pub unseen: f32,
    /// ... and where, as a fraction of the path's camera keys.
    pub along: f32,
}

/// Splits the path into legs until no point measured along a leg leaves
/// more than [`MAX_UNSEEN`] of the view to neither of its ends, a panorama
/// part way at a time (at the worst point of the worst leg), at most
/// `max_waypoints` of them. The ends are the probes, `from` and `to`.
pub fn plan_legs(tracer: &Tracer, path: &PathInfo, (from, to): (Vec3, Vec3), max_waypoints: usize) -> Legs {
    let Some(last) = path.camera.len().checked_sub(1) else { return Legs { waypoints: Vec::new(), unseen: 0.0, along: 0.5 } };
    let directions = fibonacci_sphere(RAYS);
    let key = |k: usize| Vec3::from(path.camera[k].position);
    let stand = |k: usize| {
        if k == 0 {
            from
        } else if k == last {
            to
        } else {
            key(k)
        }
    };
    let worst_of = |a: usize, b: usize| -> (f32, usize) {
        let mut worst = (0.0f32, (a + b) / 2);
        for along in ALONG {
            let k = a + ((b - a) as f32 * along).round() as usize;
            let share = directions.par_iter().filter(|&&d| seen_by_neither(tracer, key(k), d, [stand(a), stand(b)])).count() as f32 / RAYS as f32;
            if share > worst.0 {
                worst = (share, k);
            }
        }
        worst
    };
    // stops[i]..stops[i + 1] is leg i; worst[i] its worst point.
    let mut stops = vec![0, last];
    let mut worst = vec![worst_of(0, last)];
    loop {
        let (i, &(share, k)) = worst.iter().enumerate().max_by(|a, b| a.1 .0.total_cmp(&b.1 .0)).expect("a leg");
        if share <= MAX_UNSEEN || stops.len() - 2 >= max_waypoints || k <= stops[i] || k >= stops[i + 1] {
            let along = if last > 0 { k as f32 / last as f32 } else { 0.5 };
            return Legs { waypoints: stops[1..stops.len() - 1].to_vec(), unseen: share, along };
        }
        stops.insert(i + 1, k);
        worst.splice(i..=i, [worst_of(stops[i], k), worst_of(k, stops[i + 2])]);
    }
}

/// How much coarser than the camera's an end's view of a surface may be
/// (its distance over the cosine of its incidence, against the camera's)
/// and still count as seeing it: past it, the glide magnifies the end's
/// texels and its depth lattice's cells that much (a sculpture passed
/// close by, seen from ten metres, falls apart).
pub const DETAIL: f32 = 4.0;

/// Whether the surface `eye` sees along `d` is hidden from both ends
/// (behind something, or facing away from them), or seen by them only at
/// under 1/[`DETAIL`] of the camera's detail. Sky is seen from everywhere.
fn seen_by_neither(tracer: &Tracer, eye: Vec3, d: Vec3, ends: [Vec3; 2]) -> bool {
    let mut ray = Ray::new(eye, d);
    let Some(hit) = tracer.intersect(&mut ray) else { return false };
    let point = eye + d * hit.t;
    let side = hit.normal.dot(eye - point).signum();
    // A surface's footprint in a view: distance over the incidence's cosine.
    let footprint = |distance: f32, along: Vec3| distance / (hit.normal.dot(along).abs() / along.length().max(1e-12)).max(0.05);
    let camera = footprint(hit.t * d.length(), d);
    !ends.iter().any(|&end| {
        // From the end toward the point, stopping just short of it.
        let toward = point - end;
        let ray = Ray { origin: end, dir: toward, t_min: 0.0, t_max: 1.0 - 1e-3 };
        hit.normal.dot(-toward).signum() == side && footprint(toward.length(), toward) <= DETAIL * camera && tracer.visible(&ray)
    })
}

/// The transition of a path whose glide would go in `legs`; None with
/// `video` (no record: as before glides). A glide's waypoints are listed by
/// the caller once their panoramas are made.
pub fn choose(transitions: Transitions, legs: &Legs) -> Option<Transition> {
    let percent = 100.0 * legs.unseen;
    let n = legs.waypoints.len();
    let parts = match n {
        0 => "from the two ends".to_string(),
        1 => "in 2 legs (a panorama part way)".to_string(),
        _ => format!("in {} legs ({n} panoramas part way)", n + 1),
    };
    let at = format!(
        "{percent:.1} % of the view {:.0} % of the way along is seen from neither end of its leg (or at under 1/{DETAIL} of the detail)",
        100.0 * legs.along
    );
    let (kind, reason) = match transitions {
        Transitions::Video => return None,
        Transitions::Depth => (TransitionKind::Depth, format!("a glide {parts}, as asked (--transitions depth); {at}")),
        Transitions::Auto if legs.unseen > MAX_UNSEEN => {
            (TransitionKind::Video, format!("a video: even {parts}, {at}, more than {:.0} %", 100.0 * MAX_UNSEEN))
        }
        Transitions::Auto => (TransitionKind::Depth, format!("a glide {parts}: at most {at}")),
    };
    Some(Transition { kind, unseen: legs.unseen, reason, waypoints: Vec::new() })
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
    fn a_path_within_a_room_glides_and_one_through_a_room_neither_end_sees_needs_a_panorama_there_or_a_video() {
        // Three rooms 4 × 4 in a row (x 0..4, 4..8, 8..12; z 0..4), 3 high,
        // doors between them at z = 2.
        let scene = rooms(3, 4.0, 3.0, 4.0, &[1, 2]);
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let tracer = tracer(&scene, &rays);
        // Within the first room, both ends see all of it.
        let (a, b) = (Vec3::new(1.0, 1.6, 1.0), Vec3::new(3.0, 1.6, 3.0));
        let within = plan_legs(&tracer, &path(a, b), (a, b), MAX_WAYPOINTS);
        assert!(within.unseen < MAX_UNSEEN && within.waypoints.is_empty(), "{within:?}");
        assert_eq!(choose(Transitions::Auto, &within).unwrap().kind, TransitionKind::Depth);
        // From the first room to the third through the middle one: the ends
        // see the middle room only through its doors, not its side walls,
        // which fill much of the view from inside it.
        let (a, b) = (Vec3::new(1.0, 1.6, 2.0), Vec3::new(11.0, 1.6, 2.0));
        let through = plan_legs(&tracer, &path(a, b), (a, b), 0);
        assert!(through.unseen > 5.0 * MAX_UNSEEN && (0.3..=0.7).contains(&through.along), "{through:?}");
        let transition = choose(Transitions::Auto, &through).unwrap();
        assert_eq!(transition.kind, TransitionKind::Video);
        assert!(transition.reason.contains("seen from neither end"), "{}", transition.reason);
        assert_eq!(choose(Transitions::Depth, &through).unwrap().kind, TransitionKind::Depth);
        assert_eq!(choose(Transitions::Video, &through), None);
        // A panorama part way stands in the middle room (keys 8 to 12 of 20
        // lie in it), and the legs it makes glide.
        let legs = plan_legs(&tracer, &path(a, b), (a, b), MAX_WAYPOINTS);
        assert!(legs.unseen <= MAX_UNSEEN, "{legs:?}");
        assert!(legs.waypoints.iter().any(|k| (8..=12).contains(k)), "{legs:?}");
        let transition = choose(Transitions::Auto, &legs).unwrap();
        assert_eq!(transition.kind, TransitionKind::Depth);
        assert!(transition.reason.contains("part way"), "{}", transition.reason);
    }

    #[test]
    fn a_long_path_down_a_hall_needs_a_panorama_part_way_though_both_ends_see_every_wall() {
        // One hall 16 long, 3 high, 4 wide: both ends see all of it, but
        // half way the floor and walls beside the camera are 7 m from
        // either end and seen from them at a slant.
        let scene = rooms(1, 16.0, 3.0, 4.0, &[]);
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let tracer = tracer(&scene, &rays);
        let (a, b) = (Vec3::new(1.0, 1.6, 2.0), Vec3::new(15.0, 1.6, 2.0));
        let whole = plan_legs(&tracer, &path(a, b), (a, b), 0);
        assert!(whole.unseen > MAX_UNSEEN, "{whole:?}");
        let legs = plan_legs(&tracer, &path(a, b), (a, b), MAX_WAYPOINTS);
        assert!(legs.unseen <= MAX_UNSEEN && !legs.waypoints.is_empty(), "{legs:?}");
        // A short step in the same hall glides from its ends.
        let (a, b) = (Vec3::new(7.0, 1.6, 2.0), Vec3::new(9.0, 1.6, 2.0));
        let short = plan_legs(&tracer, &path(a, b), (a, b), MAX_WAYPOINTS);
        assert!(short.unseen <= MAX_UNSEEN && short.waypoints.is_empty(), "{short:?}");
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

use super::*;
use crate::navigation::tests::graph;
use crate::panorama::Lens;
use std::f32::consts::FRAC_PI_2;

fn at(probe: u32) -> Navigator {
    Navigator::new(graph(), Some(probe), 1).unwrap()
}

#[test]
fn each_path_leaving_is_a_target_below_its_departure_and_probes_nearby_only_where_not_hidden() {
    let nav = at(0);
    let found = targets(&nav, 10.0, |_, _| false);
    let goals: Vec<Goal> = found.iter().map(|t| t.goal).collect();
    assert_eq!(goals.len(), 3, "{goals:?}");
    for c in nav.path_bar() {
        let t = found.iter().find(|t| t.goal == Goal::Path(c.path)).expect("a target a path");
        let (yaw, _) = nav.departure(c.path, c.reversed);
        let ahead = Vec3::from(direction(yaw, 0.0));
        assert!(t.direction.y < -0.2 && t.direction.dot(ahead) > 0.95, "path {}: {}", c.path, t.direction);
    }
    // Probe 4 (8.6 away from probe 3, no path): a target unless hidden or too far.
    let nav = at(3);
    assert!(targets(&nav, 10.0, |_, _| false).iter().any(|t| t.goal == Goal::Probe(4)));
    assert!(!targets(&nav, 10.0, |_, _| true).iter().any(|t| t.goal == Goal::Probe(4)));
    assert!(!targets(&nav, 8.0, |_, _| false).iter().any(|t| t.goal == Goal::Probe(4)));
}

#[test]
fn a_ray_picks_the_target_it_points_at_within_a_few_degrees() {
    let found = [Target { goal: Goal::Path(0), direction: Vec3::X }, Target { goal: Goal::Path(1), direction: Vec3::NEG_Z }];
    assert_eq!(pointed(&found, Vec3::new(1.0, 0.05, 0.0)), Some(0));
    assert_eq!(pointed(&found, Vec3::new(0.02, 0.0, -1.0)), Some(1));
    // 10° off both.
    assert_eq!(pointed(&found, Vec3::new(1.0, 0.176, 0.0)), None);
    assert_eq!(pointed(&found, Vec3::ZERO), None);
}

#[test]
fn a_gaze_picks_after_resting_a_second_and_starts_over_when_it_moves() {
    let mut gaze = Gaze::default();
    assert_eq!(gaze.update(Some(2), 0.1), None);
    assert_eq!(gaze.update(Some(2), 0.6), None);
    assert!((gaze.progress() - 0.6).abs() < 1e-6);
    assert_eq!(gaze.update(Some(1), 0.6), None, "moved to another target");
    assert_eq!(gaze.update(Some(1), 0.6), None);
    assert_eq!(gaze.update(Some(1), 0.5), Some(1));
    assert_eq!(gaze.progress(), 0.0, "picked: starts over");
    assert_eq!(gaze.update(None, 5.0), None);
}

#[test]
fn a_target_ahead_shows_in_the_middle_of_each_eye_and_one_behind_not_at_all() {
    let lens = Lens::of_view(&crate::navigation::View { yaw: FRAC_PI_2, pitch: 0.0, fov_y: 1.6 }, 1.0);
    let eye = Eye { viewport: [200.0, 0.0, 200.0, 200.0], lens };
    let ahead = [Target { goal: Goal::Path(0), direction: Vec3::X }];
    let shapes = eye_shapes(&ahead, None, 0.0, None, &eye);
    assert_eq!(shapes.len(), 2, "a disc and its shadow");
    let centre = [(shapes[1].a[0] + shapes[1].b[0]) / 2.0, shapes[1].a[1]];
    assert!((centre[0] - 100.0).abs() < 0.01 && (centre[1] - 100.0).abs() < 0.01, "{centre:?}");
    let behind = [Target { goal: Goal::Path(0), direction: Vec3::NEG_X }];
    assert!(eye_shapes(&behind, None, 0.0, None, &eye).is_empty());
}

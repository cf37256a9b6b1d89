use super::*;
use crate::navigation::tests::graph;

fn screen(width: f32, height: f32, scale: f32) -> Screen {
    Screen {
        width,
        height,
        scale,
        show_map: true,
        touring: false,
        thumbs_ready: true,
        message: false,
        proxy: false,
        dollhouse: None,
        plan: None,
        sections: std::rc::Rc::new([]),
        steering: None,
    }
}

fn centre_of(l: &Layout, action: Action) -> Option<[f32; 2]> {
    l.hits.iter().find(|h| h.action == action).map(|h| [h.x + h.w / 2.0, h.y + h.h / 2.0])
}

#[test]
fn the_path_bar_runs_left_to_right_by_departure_with_the_best_aligned_in_the_middle() {
    // At probe 0 facing −Z: path 1 leads to probe 2 straight ahead, path 0 to probe 1
    // on the right (+X), path 2 to probe 3 behind (+Z).
    let mut nav = Navigator::new(graph(), Some(0), 1).unwrap();
    nav.view.yaw = 0.0;
    let l = layout(&nav, &screen(1280.0, 720.0, 1.0));
    let xs: Vec<f32> = (0..3).map(|p| centre_of(&l, Action::TakePath(p)).unwrap()[0]).collect();
    // Markers are hits too; the path bar tiles are the last hits per path, so look them up by row.
    let bar: Vec<(f32, u32)> = l
        .hits
        .iter()
        .filter_map(|h| match h.action {
            Action::TakePath(p) if !h.round => Some((h.x + h.w / 2.0, p)),
            _ => None,
        })
        .collect();
    assert_eq!(bar.len(), 3, "{bar:?}");
    let mut sorted = bar.clone();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    assert_eq!(sorted.iter().map(|b| b.1).collect::<Vec<_>>(), vec![2, 1, 0], "behind (wrapped to the left), ahead, right");
    assert!((sorted[1].0 - 640.0).abs() < 1.0, "best aligned centred: {sorted:?}");
    assert!(xs.iter().all(|x| x.is_finite()));
}

#[test]
fn markers_show_where_visible_paths_leave_and_a_tap_on_one_takes_it() {
    let mut nav = Navigator::new(graph(), Some(0), 1).unwrap();
    nav.view.yaw = 0.0;
    let l = layout(&nav, &screen(1280.0, 720.0, 1.0));
    let markers: Vec<&Hit> = l.hits.iter().filter(|h| h.round && matches!(h.action, Action::TakePath(_))).collect();
    // Ahead (−Z) is in view; +X is at 90° (outside a 1.2 rad field of view); +Z is behind.
    assert_eq!(markers.len(), 1, "{markers:?}");
    let [x, y] = [markers[0].x + markers[0].w / 2.0, markers[0].y + markers[0].h / 2.0];
    assert!((x - 640.0).abs() < 1.0 && y > 360.0, "straight ahead, below the horizon: {x} {y}");
    assert_eq!(l.hit(x, y), Some(Action::TakePath(1)));
    // Turned toward +X, that path's marker comes into view instead.
    nav.view.yaw = PI / 2.0;
    let l = layout(&nav, &screen(1280.0, 720.0, 1.0));
    let markers: Vec<Action> = l.hits.iter().filter(|h| h.round && matches!(h.action, Action::TakePath(_))).map(|h| h.action).collect();
    assert_eq!(markers, vec![Action::TakePath(0)]);
}

#[test]
fn the_probe_bar_frames_the_current_probe_and_a_tap_goes_to_a_probe() {
    let nav = Navigator::new(graph(), Some(3), 1).unwrap();
    let l = layout(&nav, &screen(1280.0, 720.0, 1.0));
    let [x, y] = centre_of(&l, Action::GoTo(4)).unwrap();
    assert!(y > 600.0, "the probe bar is at the bottom: {y}");
    assert_eq!(l.hit(x, y), Some(Action::GoTo(4)));
    // The frame is a highlight rectangle drawn just before probe 3's thumbnail.
    let i = l.shapes.iter().position(|s| s.layer == 3.0).unwrap();
    assert_eq!(l.shapes[i - 1].colour, HIGHLIGHT);
    let j = l.shapes.iter().position(|s| s.layer == 4.0).unwrap();
    assert_ne!(l.shapes[j - 1].colour, HIGHLIGHT);
}

#[test]
fn the_map_is_a_top_view_and_its_dots_are_tappable() {
    let nav = Navigator::new(graph(), Some(0), 1).unwrap();
    let l = layout(&nav, &screen(1280.0, 720.0, 1.0));
    // The map's hits are round GoTo regions; the probe bar's are rectangles.
    let dot = |p: u32| l.hits.iter().find(|h| h.round && h.action == Action::GoTo(p)).map(|h| [h.x + h.w / 2.0, h.y + h.h / 2.0]).unwrap();
    let (p0, p1, p2) = (dot(0), dot(1), dot(2));
    assert!(p1[0] > p0[0] && (p1[1] - p0[1]).abs() < 1e-3, "+X is to the right");
    assert!(p2[1] < p0[1] && (p2[0] - p0[0]).abs() < 1e-3, "−Z is up");
    assert!(p0[0] > 640.0 && p0[1] < 360.0, "top right");
    assert_eq!(l.hit(p1[0], p1[1]), Some(Action::GoTo(1)));
    let hidden = layout(&nav, &Screen { show_map: false, ..screen(1280.0, 720.0, 1.0) });
    assert!(!hidden.hits.iter().any(|h| h.round && h.action == Action::GoTo(1)));
}

#[test]
fn over_the_floor_plan_the_map_draws_wall_outlines_in_its_frame_instead_of_a_panel() {
    let nav = Navigator::new(graph(), Some(0), 1).unwrap();
    let sections: std::rc::Rc<[[f32; 4]]> = vec![[-12.0, -12.0, 12.0, -12.0], [12.0, -12.0, 12.0, 12.0]].into();
    let s = Screen { plan: Some([-12.0, -12.0, 12.0, 12.0]), sections, ..screen(1280.0, 720.0, 1.0) };
    let l = layout(&nav, &s);
    let frame = l.map.expect("a map");
    // The plan's extent is framed: its corners fall inside the map square.
    for corner in [[-12.0, 0.0, -12.0], [12.0, 0.0, 12.0]] {
        let [x, y] = frame.to_map(corner);
        assert!(x >= frame.x0 && x <= frame.x0 + frame.size && y >= frame.y0 && y <= frame.y0 + frame.size, "{corner:?} → {x} {y}");
    }
    let dark = |sh: &&Shape| sh.colour == [0.02, 0.02, 0.03, 1.0];
    assert_eq!(l.shapes.iter().filter(dark).count(), 2, "one line a segment");
    let panel = |l: &Layout| l.shapes.iter().any(|sh| sh.width == frame.size && sh.colour == PANEL);
    assert!(!panel(&l), "the plan is the map's background");
    assert!(panel(&layout(&nav, &screen(1280.0, 720.0, 1.0))), "without a plan, the panel");
}

#[test]
fn a_phone_portrait_viewport_keeps_the_interface_on_screen() {
    // 360×740 CSS pixels at 3 device pixels each, with many probes.
    let mut g = graph();
    for i in 5..40u32 {
        let mut p = g.probes[4].clone();
        p.id = i;
        p.position = [i as f32, 0.0, -(i as f32)];
        g.probes.push(p);
    }
    let nav = Navigator::new(g, Some(30), 1).unwrap();
    let (w, h) = (1080.0, 2220.0);
    let l = layout(&nav, &screen(w, h, 3.0));
    for hit in l.hits.iter().filter(|h| !matches!(h.action, Action::TakePath(_))) {
        let on_screen = hit.x + hit.w > 0.0 && hit.x < w && hit.y >= 0.0 && hit.y + hit.h <= h;
        assert!(on_screen, "{hit:?}");
    }
    // Tiles are at least 44 CSS pixels tall (a comfortable touch target), and the current probe is shown.
    let tile = l.hits.iter().find(|h| h.action == Action::GoTo(30) && !h.round).expect("the current probe's tile is scrolled into view");
    assert!(tile.h >= 44.0 * 3.0 && tile.x >= 0.0 && tile.x + tile.w <= w, "{tile:?}");
}

#[test]
fn links_round_trip_and_name_bad_values() {
    let link = Link::parse("#probe=3&yaw=90&pitch=-10.5&fov=70&other=x").unwrap();
    assert_eq!(link, Link { probe: Some(3), yaw_deg: Some(90.0), pitch_deg: Some(-10.5), fov_deg: Some(70.0), dollhouse: false });
    assert_eq!(Link::parse(&link.to_fragment()).unwrap(), link);
    assert_eq!(Link::parse("").unwrap(), Link::default());
    assert!(Link::parse("yaw=abc").unwrap_err().contains("yaw=abc"));
    assert!(Link::parse("probe=-1").unwrap_err().contains("probe=-1"));
    let mut nav = Navigator::new(graph(), Some(0), 1).unwrap();
    link.apply_view(&mut nav);
    assert!((nav.view.yaw - PI / 2.0).abs() < 1e-5 && (nav.view.pitch + 10.5f32.to_radians()).abs() < 1e-5);
    assert!((nav.view.fov_y - 70f32.to_radians()).abs() < 1e-5);
    let back = Link::of(&nav);
    assert_eq!(back.probe, Some(0));
    assert!((back.yaw_deg.unwrap() - 90.0).abs() < 1e-3);
}

/// While the proxy refines, a bar along the top shows how much of it is in;
/// none once it is whole.
#[test]
fn a_bar_shows_the_proxy_refining() {
    let nav = Navigator::new(graph(), Some(0), 1).unwrap();
    let over =
        |loading| Screen { dollhouse: Some(DollhouseScreen { markers: Vec::new(), floors: 0, floor: None, loading }), ..screen(1000.0, 600.0, 1.0) };
    let filled = |l: &Layout| l.shapes.iter().filter(|s| s.colour == HIGHLIGHT && s.a[1] < 5.0 && s.b[1] < 5.0).map(|s| s.b[0] - s.a[0]).next();
    let half = layout(&nav, &over(Some(0.4)));
    assert!(filled(&half).is_some_and(|len| (len - 400.0).abs() < 1.0), "{:?}", filled(&half));
    assert_eq!(filled(&layout(&nav, &over(None))), None);
}

#[test]
fn while_gliding_three_buttons_steer_back_pause_and_on_the_way_under_way_lit() {
    let mut nav = Navigator::new(graph(), Some(0), 1).unwrap();
    nav.take_path(0).unwrap();
    let s = screen(1280.0, 720.0, 1.0);
    assert!(layout(&nav, &s).hits.iter().all(|h| !matches!(h.action, Action::Back | Action::Pause | Action::On)), "not without steering");
    let steered = layout(&nav, &Screen { steering: Some(1.0), ..screen(1280.0, 720.0, 1.0) });
    let at = |a: Action| steered.hits.iter().find(|h| h.action == a).copied().unwrap_or_else(|| panic!("no {a:?} button"));
    let (back, pause, on) = (at(Action::Back), at(Action::Pause), at(Action::On));
    assert!(back.x < pause.x && pause.x < on.x && (pause.x + pause.w / 2.0 - 640.0).abs() < 1.0, "left to right, centred");
    assert_eq!(steered.hit(pause.x + pause.w / 2.0, pause.y + pause.h / 2.0), Some(Action::Pause), "on top of what is under it");
    let lit = [0.2, 0.5, 0.9, 0.95];
    let disc_at = |l: &Layout, h: Hit| {
        l.shapes.iter().find(|s| s.round == 1.0 && (s.a[0] - h.x).abs() < 0.01 && (s.a[1] - (h.y + h.h / 2.0)).abs() < 0.01).map(|s| s.colour)
    };
    assert_eq!(disc_at(&steered, on), Some(lit), "going on: on lit");
    let paused = layout(&nav, &Screen { steering: Some(0.0), ..screen(1280.0, 720.0, 1.0) });
    assert_eq!(disc_at(&paused, pause), Some(lit), "paused: pause lit");
    assert_ne!(disc_at(&paused, on), Some(lit));
}

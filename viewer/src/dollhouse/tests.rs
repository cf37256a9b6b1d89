use super::*;
use crate::navigation::tests::graph;

/// Two storeys: a red floor quad at y = 0 and a blue one at y = 3, both
/// spanning x, z in [−5, 5], facing up; triangles 0-1 red, 2-3 blue.
pub(crate) fn two_storeys(seen: Vec<u32>) -> ProxyMesh {
    ProxyMesh::new(0, two_storeys_data(), seen)
}

pub(crate) fn two_storeys_data() -> MeshData {
    let mut data = MeshData::default();
    for (y, colour) in [(0.0f32, [200u8, 30, 30]), (3.0, [30, 30, 200])] {
        let base = data.positions.len() as u32;
        data.positions.extend([[-5.0, y, -5.0], [5.0, y, -5.0], [5.0, y, 5.0], [-5.0, y, 5.0]]);
        data.colours.extend([colour; 4]);
        data.triangles.extend([[base, base + 2, base + 1], [base, base + 3, base + 2]]);
    }
    data
}

#[test]
fn a_ray_through_a_projected_point_passes_through_it() {
    let orbit = Orbit::framing(Vec3::splat(-5.0), Vec3::splat(5.0), 0.7, 16.0 / 9.0);
    let camera = orbit.camera();
    for p in [Vec3::ZERO, Vec3::new(3.0, -2.0, 1.0), Vec3::new(-4.0, 4.0, -4.0)] {
        let [x, y] = camera.project(p, 640.0, 360.0).expect("in front");
        assert!((0.0..640.0).contains(&x) && (0.0..360.0).contains(&y), "framed: {x} {y}");
        let d = camera.ray(x, y, 640.0, 360.0);
        let to = (p - camera.eye).normalize();
        assert!(d.dot(to) > 0.99999, "{d} vs {to}");
    }
    // The box's corners are all in view, and it fills the view: some corner
    // reaches the margin of a tenth left spare.
    let mut fill = 0.0f32;
    for i in 0..8 {
        let c = Vec3::new(if i & 1 == 0 { -5.0 } else { 5.0 }, if i & 2 == 0 { -5.0 } else { 5.0 }, if i & 4 == 0 { -5.0 } else { 5.0 });
        let [x, y] = camera.project(c, 640.0, 360.0).unwrap();
        assert!((0.0..640.0).contains(&x) && (0.0..360.0).contains(&y), "corner {c}: {x} {y}");
        fill = fill.max((x / 320.0 - 1.0).abs()).max((y / 180.0 - 1.0).abs());
    }
    assert!((fill - 0.9).abs() < 0.01, "{fill}");
}

#[test]
fn orbit_turns_zooms_and_pans_within_bounds() {
    let mut orbit = Orbit::framing(Vec3::splat(-1.0), Vec3::splat(1.0), 0.0, 1.0);
    orbit.turn(0.0, -10.0);
    assert_eq!(orbit.pitch, MIN_PITCH, "never upside down");
    orbit.turn(0.0, 10.0);
    assert_eq!(orbit.pitch, MAX_PITCH, "always from above");
    orbit.zoom(1e-9);
    assert!((orbit.distance - 0.05 * orbit.radius).abs() < 1e-6);
    let before = orbit.target;
    orbit.pan(1e9, 0.0, 100.0);
    assert!(orbit.target.distance(before) <= 2.0 * orbit.radius * 3f32.sqrt() + 1e-4);
    // A small drag right moves the scene right: the target moves left on screen's right axis.
    let mut o = Orbit::framing(Vec3::splat(-1.0), Vec3::splat(1.0), 0.0, 1.0);
    let seen_before = o.camera().project(Vec3::ZERO, 100.0, 100.0).unwrap();
    o.pan(10.0, 0.0, 100.0);
    let seen_after = o.camera().project(Vec3::ZERO, 100.0, 100.0).unwrap();
    assert!((seen_after[0] - seen_before[0] - 10.0).abs() < 0.5, "{seen_before:?} → {seen_after:?}");
}

#[test]
fn a_tap_picks_the_nearest_triangle_below_the_cut() {
    let mesh = two_storeys(vec![]);
    let down = Vec3::NEG_Y;
    let (t, d) = mesh.pick(Vec3::new(1.0, 10.0, 2.0), down, f32::INFINITY).unwrap();
    assert!(t >= 2 && (d - 7.0).abs() < 1e-4, "the upper floor first: {t} at {d}");
    let (t, d) = mesh.pick(Vec3::new(1.0, 10.0, 2.0), down, 2.0).unwrap();
    assert!(t < 2 && (d - 10.0).abs() < 1e-4, "cut at 2: the lower floor: {t} at {d}");
    assert_eq!(mesh.pick(Vec3::new(6.0, 10.0, 0.0), down, f32::INFINITY), None, "beside the house");
    assert_eq!(mesh.pick(Vec3::new(1.0, 10.0, 2.0), Vec3::Y, f32::INFINITY), None, "behind the ray");
}

#[test]
fn a_tap_goes_to_the_tables_probe_else_to_the_probe_that_sees_the_point_best() {
    // Test graph probes at y = 0: 0 at the origin, 1 at +4 x, 2 at −4 z, 3, 4 farther.
    let g = graph();
    let table = two_storeys(vec![3, 3, NONE, 1]);
    assert_eq!(table.destination(&g, 0, Vec3::new(1.0, 0.0, 1.0)), Some(3), "the builder's choice");
    assert_eq!(table.destination(&g, 3, Vec3::new(1.0, 3.0, 1.0)), Some(1));
    // No table: probes stand on the lower floor (y = 0, in its plane) and all see the upper one;
    // the nearest facing one wins: probe 1 at (4, 0, 0) for a point above (4, 3, 0).
    let plain = two_storeys(vec![]);
    assert_eq!(plain.destination(&g, 2, Vec3::new(4.0, 3.0, 0.2)), Some(1));
    assert_eq!(table.destination(&g, 2, Vec3::new(-0.2, 3.0, -4.0)), Some(2), "a triangle no probe sees by the table falls back too");
    // A table naming a probe the graph lacks is ignored.
    let wrong = two_storeys(vec![99; 4]);
    assert_eq!(wrong.destination(&g, 2, Vec3::new(4.0, 3.0, 0.2)), Some(1));
}

#[test]
fn a_probe_the_proxy_hides_the_point_from_is_not_chosen() {
    // Point on the upper floor. Probe 1 below the lower floor is nearer and faces it squarely,
    // but the lower floor stands between them; probe 0 on the lower storey sees it obliquely.
    let mut g = graph();
    g.probes[0].position = [4.5, 1.5, 0.0];
    g.probes[1].position = [0.5, -0.5, 0.0];
    for p in &mut g.probes[2..] {
        p.position = [20.0, 1.5, 0.0];
    }
    let point = Vec3::new(0.5, 3.0, 0.0);
    let plain = two_storeys(vec![]);
    assert_eq!(plain.destination(&g, 2, point), Some(0));
    // Without the lower floor, probe 1 would win.
    let mut upper_only = two_storeys(vec![]);
    upper_only.triangles.drain(..2);
    assert_eq!(upper_only.destination(&g, 0, point), Some(1));
}

#[test]
fn without_listed_storeys_the_floors_under_standing_probes_stand_in() {
    let mut g = graph();
    // Probes at y = 0 (the test graph) and one a storey up, eye height 1.6: floors at −1.6 and 1.4.
    g.probes[4].position[1] = 3.0;
    g.scene.eye_height_m = Some(1.6);
    let floors = Floors::of(&g);
    assert_eq!(floors.heights.len(), 2);
    assert!((floors.heights[0] + 1.6).abs() < 1e-5 && (floors.heights[1] - 1.4).abs() < 1e-5, "{:?}", floors.heights);
    // Flying probes give no storeys.
    g.scene.eye_height_m = None;
    assert!(Floors::of(&g).heights.is_empty());
}

#[test]
fn floors_cut_above_head_height_and_below_the_next_storey() {
    let floors = Floors { heights: vec![0.0, 3.0, 10.0], eye: 1.6 };
    assert_eq!(floors.cut(None), f32::INFINITY);
    assert!((floors.cut(Some(0)) - 2.08).abs() < 1e-5, "head height on a tall storey");
    assert!((floors.cut(Some(2)) - 12.08).abs() < 1e-4, "the top storey");
    let low = Floors { heights: vec![0.0, 2.0], eye: 1.6 };
    assert!((low.cut(Some(0)) - 1.6).abs() < 1e-5, "below the next floor when it comes first");
    assert_eq!(floors.of_point(1.6), Some(0));
    assert_eq!(floors.of_point(4.6), Some(1));
    assert_eq!(floors.of_point(-3.0), Some(0), "below every floor: the lowest");
    assert_eq!(Floors { heights: vec![], eye: 1.6 }.of_point(1.6), None);
}

/// Draws `mesh` seen by `camera` into a `size`² target and reads it back.
pub(crate) fn draw(mesh: &ProxyMesh, camera: &Camera, cut: f32, size: u32) -> Option<Vec<u8>> {
    render_with(mesh, size, |pass, frame| pass.draw(frame, camera, cut, (mesh.lo + mesh.hi) / 2.0, mesh.diagonal()))
}

/// Clears a `size`² target to black, runs `call` on it with a pass holding
/// `mesh`, and reads it back.
fn render_with(mesh: &ProxyMesh, size: u32, call: impl FnOnce(&mut DollhousePass, &mut FrameTarget)) -> Option<Vec<u8>> {
    let (device, queue) = crate::panorama::tests::gpu()?;
    let mut pass = DollhousePass::new(&device, wgpu::TextureFormat::Rgba8UnormSrgb);
    pass.upload(&device, &queue, mesh);
    Some(crate::panorama::tests::render_target(&device, &queue, size, |encoder, view| {
        call(&mut pass, &mut FrameTarget { device: &device, queue: &queue, encoder, view, width: size, height: size })
    }))
}

#[test]
fn the_dollhouse_draws_the_proxy_in_its_colours_and_the_cut_hides_the_upper_storey() {
    let mesh = two_storeys(vec![]);
    let orbit = Orbit { pitch: -1.5, ..Orbit::framing(mesh.lo, mesh.hi, 0.0, 1.0) };
    let camera = orbit.camera();
    let at = |px: &[u8], x: u32, y: u32| {
        let i = 4 * (y * 64 + x) as usize;
        [px[i], px[i + 1], px[i + 2]]
    };
    let Some(whole) = draw(&mesh, &camera, f32::INFINITY, 64) else { return };
    assert_eq!(at(&whole, 32, 32), [30, 30, 200], "from above, the upper storey");
    let background = [0.06f32, 0.065, 0.075].map(|c| (255.0 * c.powf(1.0 / 2.2)).round() as i32);
    let corner = at(&whole, 0, 0).map(i32::from);
    assert!(corner.iter().zip(background).all(|(a, b)| (a - b).abs() <= 4), "the background around it: {corner:?}");
    let cut = draw(&mesh, &camera, 2.0, 64).unwrap();
    assert_eq!(at(&cut, 32, 32), [200, 30, 30], "cut at 2: the lower storey");
}

#[test]
fn a_section_outlines_what_crosses_the_plane() {
    // A unit box from y = 0 to 1 (12 triangles): cut at 0.5, its four sides
    // give two segments each, all on the square's outline.
    let mut data = MeshData::default();
    for i in 0..8u32 {
        data.positions.push([(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32]);
    }
    for [a, b, c, d] in [[0u32, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]] {
        data.triangles.extend([[a, b, c], [a, c, d]]);
    }
    let mesh = ProxyMesh::new(0, data, vec![]);
    let section = mesh.section(0.5);
    assert_eq!(section.len(), 8);
    let on_outline = |x: f32, z: f32| {
        (x.abs() < 1e-6 || (x - 1.0).abs() < 1e-6 || z.abs() < 1e-6 || (z - 1.0).abs() < 1e-6) && (0.0..=1.0).contains(&x) && (0.0..=1.0).contains(&z)
    };
    assert!(section.iter().all(|s| on_outline(s[0], s[1]) && on_outline(s[2], s[3])), "{section:?}");
    let length: f32 = section.iter().map(|s| ((s[2] - s[0]).powi(2) + (s[3] - s[1]).powi(2)).sqrt()).sum();
    assert!((length - 4.0).abs() < 1e-4, "the perimeter: {length}");
    assert!(mesh.section(2.0).is_empty() && mesh.section(-1.0).is_empty());
}

#[test]
fn the_floor_plan_draws_the_storey_from_above_dimmed_in_its_square_only() {
    let mesh = two_storeys(vec![]);
    // A 32-pixel square at (0, 16) of a 64² target, 2 px a unit, centred on the origin.
    let Some(px) = render_with(&mesh, 64, |pass, frame| pass.draw_plan(frame, [0.0, 16.0, 32.0], [0.0, 0.0], 2.0, 2.0, 0.0)) else {
        return;
    };
    let at = |x: u32, y: u32| {
        let i = 4 * (y * 64 + x) as usize;
        [px[i], px[i + 1], px[i + 2]]
    };
    // The red lower storey (the blue one is cut), dimmed: red 200 × 0.45 in linear light.
    let red = at(16, 32);
    assert!(red[0] > 120 && red[0] < 160 && red[1] < 40 && red[2] < 40, "{red:?}");
    // Beyond the house (±5 units = ±10 px) but inside the square: the dark background.
    let edge = at(1, 17);
    assert!(edge.iter().all(|&c| c < 60) && edge != [0, 0, 0], "{edge:?}");
    // Outside the square, untouched.
    assert_eq!(at(48, 32), [0, 0, 0]);
    // Seen from below (wound the other way), a floor is a solid's inside: dark.
    let mut flipped = two_storeys(vec![]);
    flipped.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    let Some(px) = render_with(&flipped, 64, |pass, frame| pass.draw_plan(frame, [0.0, 16.0, 32.0], [0.0, 0.0], 2.0, 2.0, 0.0)) else {
        return;
    };
    let i = 4 * (32 * 64 + 16);
    assert!(px[i..i + 3].iter().all(|&c| c < 60), "{:?}", &px[i..i + 3]);
}

#[test]
fn a_level_in_parts_is_their_meshes_one_after_the_other() {
    let whole = two_storeys_data();
    let (mut a, mut b) = (MeshData::default(), MeshData::default());
    a.positions = whole.positions[..4].to_vec();
    a.colours = whole.colours[..4].to_vec();
    a.triangles = whole.triangles[..2].to_vec();
    b.positions = whole.positions[4..].to_vec();
    b.triangles = whole.triangles[2..].iter().map(|t| t.map(|v| v - 4)).collect();
    // Part b has neither colours nor a table.
    let mesh = ProxyMesh::from_parts(0, vec![(a, vec![3, 3]), (b, vec![])]);
    assert_eq!(mesh.triangles, whole.triangles, "the second part's corners offset past the first's vertices");
    assert_eq!(mesh.seen, vec![3, 3, NONE, NONE]);
    assert_eq!(&mesh.colours[..4], &whole.colours[..4]);
    assert_eq!(&mesh.colours[4..], &[[170; 3]; 4], "grey where a part has no colours");
    assert_eq!((mesh.lo, mesh.hi), (Vec3::new(-5.0, 0.0, -5.0), Vec3::new(5.0, 3.0, 5.0)));
}

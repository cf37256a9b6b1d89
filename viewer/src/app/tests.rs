//! The application with a scripted platform: what it asks for and when.

use super::*;
use crate::navigation::tests::graph;
use exploremaps_format::{depthmap::DepthMap, CubeLevel, Graph};

/// Records requests; answers cube requests (solid grey) on the next poll,
/// except for probes listed as broken, which fail.
#[derive(Default)]
struct Script {
    requests: Vec<(u32, u32)>,
    pending: Vec<(u32, u32)>,
    broken: Vec<u32>,
    messages: Vec<String>,
    videos: Vec<(String, bool)>,
    thumbnails: Vec<u32>,
    /// Proxy levels asked for, those to answer, and whether they fail.
    proxy_requests: Vec<usize>,
    proxy_pending: Vec<(usize, usize)>,
    broken_proxy: bool,
    /// Vertex-split streams asked for (from, to, base file), their answers
    /// (one a poll), and whether their second packet is broken.
    stream_requests: Vec<(usize, usize, String)>,
    stream_pending: Vec<Loaded>,
    broken_stream: bool,
    depth_requests: Vec<u32>,
    depth_pending: Vec<u32>,
    /// Depth cubes for glides asked for, and those to answer.
    glide_requests: Vec<u32>,
    glide_pending: Vec<u32>,
    /// Tiles asked for: (probe, size, slot, x, y), and those to answer.
    tiles: Vec<(u32, u32, usize, u32, u32)>,
    tiles_pending: Vec<(u32, u32, usize, u32, u32)>,
}

/// Every probe's depth map: everything 2 units away; what lies toward −Z is
/// seen best from probe 2, the rest from the probe itself.
fn depth_map(probe: u32) -> DepthMap {
    let size = 8;
    let mut map = DepthMap { size, near: 0.1, far: 50.0, depth: Vec::new(), best: Vec::new() };
    for face in 0..6 {
        for i in 0..size * size {
            let (s, t) = (((i % size) as f32 + 0.5) / size as f32, ((i / size) as f32 + 0.5) / size as f32);
            let d = exploremaps_format::cube_direction(face, s, t);
            map.depth.push(map.code(Some(2.0)));
            map.best.push(if d[2] < -0.5 * (d[0].abs() + d[1].abs()).max(1e-3) { 2 } else { probe });
        }
    }
    map
}

impl Platform for Script {
    fn load_cube(&mut self, probe: u32, size: u32, _faces: &[String; 6]) {
        self.requests.push((probe, size));
        self.pending.push((probe, size));
    }
    fn load_tile(&mut self, probe: u32, size: u32, slot: usize, x: u32, y: u32, _file: &str) {
        self.tiles.push((probe, size, slot, x, y));
        self.tiles_pending.push((probe, size, slot, x, y));
    }
    fn load_equirect(&mut self, _probe: u32, _file: &str) {}
    fn load_thumbnail(&mut self, probe: u32, _file: &str) {
        self.thumbnails.push(probe);
    }
    fn load_depth_map(&mut self, probe: u32, _file: &str, _probes: u32) {
        self.depth_requests.push(probe);
        self.depth_pending.push(probe);
    }
    fn load_depth_cube(&mut self, probe: u32, _file: &str) {
        self.glide_requests.push(probe);
        self.glide_pending.push(probe);
    }
    fn load_proxy(&mut self, level: usize, part: usize, _mesh: &str, _seen: Option<&str>, _probes: u32) {
        self.proxy_requests.push(level);
        self.proxy_pending.push((level, part));
    }
    fn load_stream(&mut self, stream: &ProxyStream, base: &ProxyLevel, _probes: u32) {
        self.stream_requests.push((stream.from, stream.to, base.file.clone()));
        // The two-storey mesh grown by a triangle a packet.
        let grown = |extra: usize| {
            let mut m = crate::dollhouse::tests::two_storeys_data();
            m.triangles.extend_from_within(..extra);
            m
        };
        self.stream_pending.push(Loaded::Refined { level: stream.from, mesh: grown(1), seen: vec![3, 3, 1, 1, 3] });
        self.stream_pending.push(match self.broken_stream {
            true => Loaded::Failed { what: "proxy/splits-1.emvs".into(), error: "vertex-split packet checksum mismatch".into(), probe: None },
            false => Loaded::Refined { level: stream.to, mesh: grown(2), seen: vec![3, 3, 1, 1, 3, 3] },
        });
    }
    fn poll(&mut self, gpu: &Gpu, _overlay: &OverlayPass) -> Vec<Loaded> {
        let refined = (!self.stream_pending.is_empty()).then(|| self.stream_pending.remove(0));
        // Proxy levels: the two-storey mesh, its lower floor seen best from probe 3, its upper from 1.
        let broken = self.broken_proxy;
        let proxies: Vec<Loaded> = self
            .proxy_pending
            .drain(..)
            .map(|(level, part)| match broken {
                true => Loaded::Failed { what: format!("proxy/{level}.emmc"), error: "coded mesh is corrupt: checksum mismatch".into(), probe: None },
                false => Loaded::Proxy { level, part, mesh: crate::dollhouse::tests::two_storeys_data(), seen: vec![3, 3, 1, 1] },
            })
            .collect();
        let maps: Vec<Loaded> = self.depth_pending.drain(..).map(|probe| Loaded::DepthMap { probe, map: depth_map(probe) }).collect();
        // Tiles are 16 pixels, white.
        let tiles: Vec<Loaded> = std::mem::take(&mut self.tiles_pending)
            .into_iter()
            .map(|(probe, size, slot, x, y)| Loaded::Tile {
                probe,
                size,
                slot,
                x,
                y,
                pixels: crate::panorama::TilePixels::Rgba { width: 16, height: 16, rgba: vec![255; 4 * 16 * 16] },
            })
            .collect();
        // Depth cubes for glides: everything 2 units away.
        let cubes = self.glide_pending.drain(..).map(|probe| {
            let cube = exploremaps_format::depthcube::DepthCube::new(4, 0.1, 50.0, &[Some(2.0); 6 * 25]);
            Loaded::DepthCube { probe, cube }
        });
        let maps: Vec<Loaded> = maps.into_iter().chain(tiles).chain(cubes).collect();
        proxies
            .into_iter()
            .chain(refined)
            .chain(maps)
            .chain(self.pending.drain(..).map(|(probe, size)| {
                if self.broken.contains(&probe) {
                    return Loaded::Failed {
                        what: format!("probes/{probe}/{size}_px.jpg"),
                        error: "is not a readable image".into(),
                        probe: Some(probe),
                    };
                }
                let cube = Cube::new(&gpu.device, size);
                let grey = vec![128u8; (4 * size * size) as usize];
                for f in 0..6 {
                    cube.write_face(&gpu.queue, f, &grey);
                }
                Loaded::Pano { probe, pano: Pano::Cube(cube) }
            }))
            .collect()
    }
    fn play_video(&mut self, file: &str, reversed: bool) {
        self.videos.push((file.to_string(), reversed));
    }
    fn stop_video(&mut self) {}
    fn video_frame(&mut self, _gpu: &Gpu, _t: f32) -> Result<Option<&VideoTexture>, String> {
        Ok(None)
    }
    fn show_message(&mut self, text: &str) {
        self.messages.push(text.to_string());
    }
}

/// The test graph with cube levels 8, 16 and 32 for every probe and a video per path.
fn bundle_graph() -> Graph {
    let mut g = graph();
    for p in &mut g.probes {
        p.assets.thumbnail = Some(format!("probes/{}/thumbnail.jpg", p.id));
        p.assets.cube_levels = [8u32, 16, 32]
            .iter()
            .map(|&size| CubeLevel { size, faces: std::array::from_fn(|f| format!("probes/{}/{size}_{f}.jpg", p.id)) })
            .collect();
    }
    for p in &mut g.paths {
        p.assets.video = Some(format!("paths/{}.mp4", p.id));
    }
    g
}

/// `graph` with no videos and every probe's depth: its paths glide.
fn without_video_with_depth(mut graph: Graph) -> Graph {
    for p in &mut graph.paths {
        p.assets.video = None;
    }
    for p in &mut graph.probes {
        p.assets.depth = Some(format!("probes/{}/depth.emdc", p.id));
    }
    graph
}

fn app(script: &mut Script, budget: u64, height: u32) -> Option<App> {
    app_of(bundle_graph(), script, budget, height)
}

fn app_of(graph: Graph, script: &mut Script, budget: u64, height: u32) -> Option<App> {
    let (device, queue) = crate::panorama::tests::gpu()?;
    let gpu = Gpu { device, queue, format: wgpu::TextureFormat::Rgba8UnormSrgb };
    let nav = Navigator::new(graph, Some(0), 1).unwrap();
    let mut app = App::new(gpu, nav, None, Options { budget_bytes: budget, max_face: 2048, show_map: true, tour: false }, script);
    app.resize(height * 16 / 9, height, 1.0);
    Some(app)
}

#[test]
fn the_low_resolution_level_comes_first_then_the_sharp_one_and_neighbours_are_prefetched() {
    let mut script = Script::default();
    let Some(mut app) = app(&mut script, 1 << 30, 30) else { return };
    // At first only the smallest level of the current probe is asked for, and
    // nothing is drawn; the thumbnails wait for it too.
    assert_eq!(script.requests, vec![(0, 8)]);
    assert!(app.waiting_for_first_frame() && script.thumbnails.is_empty());
    app.update(0.016, &mut script);
    assert!(!app.waiting_for_first_frame());
    assert_eq!(script.thumbnails, vec![0, 1, 2, 3, 4]);
    // Once it is in: the level sharp enough for a 30-pixel-high view at fov 1.2
    // (30 / (2 tan 0.6) ≈ 22 → 32), and the neighbours' smallest levels.
    let asked: Vec<(u32, u32)> = script.requests[1..].to_vec();
    assert!(asked.contains(&(0, 32)) && !asked.contains(&(0, 16)), "{asked:?}");
    for neighbour in [1, 2, 3] {
        assert!(asked.contains(&(neighbour, 8)), "neighbour {neighbour} prefetched: {asked:?}");
    }
    assert!(!asked.iter().any(|r| r.0 == 4), "probe 4 is not a neighbour: {asked:?}");
    // Nothing is asked twice.
    app.update(0.016, &mut script);
    app.update(0.016, &mut script);
    let mut all = script.requests.clone();
    all.sort_unstable();
    all.dedup();
    assert_eq!(all.len(), script.requests.len(), "{:?}", script.requests);
}

#[test]
fn with_a_tile_pyramid_only_the_tiles_in_view_come_after_the_low_level() {
    let mut graph = bundle_graph();
    for p in &mut graph.probes {
        p.assets.tiles = Some(exploremaps_format::Tiles::new(format!("probes/{}/tiles", p.id), 32, 16, 8));
    }
    let mut script = Script::default();
    let Some(mut app) = app_of(graph, &mut script, 1 << 30, 30) else { return };
    app.update(0.016, &mut script);
    app.update(0.016, &mut script);
    // The whole lowest level, then tiles of the 32 level (2 × 2 a face):
    // not the whole 32 cube, and not the tiles behind the view (it looks
    // toward −Z: slot 4, the tour's front face, is ahead; slot 5 behind).
    assert!(script.requests.contains(&(0, 8)) && !script.requests.contains(&(0, 32)), "{:?}", script.requests);
    let asked: Vec<_> = script.tiles.iter().filter(|t| t.0 == 0).copied().collect();
    assert!(asked.iter().all(|t| t.1 == 32), "{asked:?}");
    assert!(asked.len() >= 4 && asked.len() < 24, "{} of 24 tiles: {asked:?}", asked.len());
    assert!((0..2).all(|x| (0..2).all(|y| asked.contains(&(0, 32, 4, x, y)))), "the four tiles ahead: {asked:?}");
    assert!(!asked.iter().any(|t| t.2 == 5), "none behind: {asked:?}");
    assert_eq!(asked[0].2, 4, "the tiles ahead come first");
    app.update(0.016, &mut script);
    assert_eq!(app.tile_counts(), (asked.len(), asked.len()), "each came in once");
    // Turning round asks for the tiles now in view, once each.
    app.nav.look(std::f32::consts::PI, 0.0);
    app.update(0.016, &mut script);
    app.update(0.016, &mut script);
    assert!(script.tiles.iter().any(|t| t.2 == 5), "the back face's tiles: {:?}", script.tiles);
    let mut all = script.tiles.clone();
    all.sort_unstable();
    all.dedup();
    assert_eq!(all.len(), script.tiles.len(), "no tile asked twice");
}

#[test]
fn the_texture_budget_evicts_the_least_recently_used_but_never_the_current_probe() {
    let mut script = Script::default();
    // 8² faces are 1.5 KiB a cube, 32² 24 KiB: a 30 KiB budget holds the sharp current cube and little else.
    let Some(mut app) = app(&mut script, 30 << 10, 30) else { return };
    for _ in 0..4 {
        app.update(0.016, &mut script);
    }
    let total: u64 = app.panos.values().map(|l| l.pano.bytes()).sum();
    assert!(total <= 30 << 10, "{total}");
    assert_eq!(app.panos.get(&0).map(|l| l.pano.size()), Some(32), "the current probe stays, sharp");
}

#[test]
fn taking_a_path_plays_its_video_and_a_failed_probe_gives_a_message_without_stopping() {
    let mut script = Script { broken: vec![4], ..Default::default() };
    let Some(mut app) = app(&mut script, 1 << 30, 30) else { return };
    app.update(0.016, &mut script);
    app.input(Input::Key(Key::Go), &mut script);
    app.update(0.016, &mut script);
    assert_eq!(script.videos.len(), 1, "the best-aligned path's video starts");
    for _ in 0..200 {
        app.update(0.02, &mut script);
    }
    assert!(matches!(app.nav.state, State::AtProbe { .. }) && app.nav.probe() != 0, "arrived: {:?}", app.nav.state);
    // Probe 4 is reached by a cross-fade; its panorama fails: a message names the
    // file, the fade does not wait for it forever, and the viewer arrives and goes on.
    app.nav.state = State::AtProbe { probe: 0 };
    app.nav.go_to(4).unwrap();
    for _ in 0..100 {
        app.update(0.02, &mut script);
    }
    assert!(script.messages.iter().any(|m| m.contains("probes/4/8_px.jpg")), "{:?}", script.messages);
    assert_eq!(app.nav.state, State::AtProbe { probe: 4 });
    app.input(Input::Key(Key::NextProbe), &mut script);
    for _ in 0..100 {
        app.update(0.02, &mut script);
    }
    assert_ne!(app.nav.probe(), 4, "the viewer keeps working");
}

#[test]
fn a_path_without_video_glides_once_both_ends_depth_is_in() {
    let graph = without_video_with_depth(bundle_graph());
    let mut script = Script::default();
    let Some(mut app) = app_of(graph, &mut script, 1 << 30, 30) else { return };
    app.update(0.016, &mut script);
    // At a probe, its depth and its path bar's destinations' come with the panoramas.
    let bar: Vec<u32> = app.nav.path_bar().iter().map(|c| c.to).collect();
    assert!(script.glide_requests.contains(&0) && bar.iter().all(|p| script.glide_requests.contains(p)), "{:?}", script.glide_requests);
    app.update(0.016, &mut script);
    app.input(Input::Key(Key::Go), &mut script);
    let mut glided = 0;
    for _ in 0..200 {
        app.update(0.02, &mut script);
        render_frame(&mut app, &mut script);
        glided += usize::from(app.gliding());
    }
    assert!(script.videos.is_empty(), "no video to play");
    assert!(glided > 10, "the travel was drawn as a glide ({glided} frames)");
    assert!(matches!(app.nav.state, State::AtProbe { .. }) && app.nav.probe() != 0 && !app.gliding(), "arrived: {:?}", app.nav.state);
    // A glide pauses and goes back: here, where it set out.
    let to = app.nav.probe();
    app.input(Input::Key(Key::Go), &mut script);
    assert!(matches!(app.nav.state, State::Travelling { .. }), "took the path back: {:?}", app.nav.state);
    app.update(0.5, &mut script);
    app.input(Input::Key(Key::Go), &mut script);
    let here = app.nav.camera_position();
    app.update(0.5, &mut script);
    assert_eq!(app.nav.camera_position(), here, "paused");
    app.input(Input::Key(Key::Down), &mut script);
    for _ in 0..100 {
        app.update(0.02, &mut script);
    }
    assert_eq!(app.nav.state, State::AtProbe { probe: to }, "went back to where it set out");
    assert_eq!(script.glide_requests.iter().filter(|&&p| p == 0).count(), 1, "each depth cube asked for once");
}

#[test]
fn a_glide_in_legs_goes_through_its_panoramas_part_way_asked_for_before_the_click() {
    let mut graph = crate::navigation::tests::graph_with_waypoints();
    for p in &mut graph.probes {
        p.assets.depth = Some(format!("probes/{}/depth.emdc", p.id));
        p.assets.cube_levels = vec![CubeLevel { size: 8, faces: std::array::from_fn(|f| format!("probes/{}/8_{f}.jpg", p.id)) }];
    }
    let mut script = Script::default();
    let Some(mut app) = app_of(graph, &mut script, 1 << 30, 30) else { return };
    app.update(0.016, &mut script);
    app.update(0.016, &mut script);
    // At probe 0, the first panorama part way along each path of the bar
    // comes with the destinations: source 5 toward probe 2, 6 toward 3.
    for source in [5, 6] {
        assert!(script.glide_requests.contains(&source) && script.requests.contains(&(source, 8)), "{source}: {:?}", script.requests);
    }
    assert!(!script.glide_requests.contains(&7), "the second along a path waits for the travel");
    app.nav.go_to(2).unwrap();
    let mut legs = Vec::new();
    for _ in 0..200 {
        app.update(0.02, &mut script);
        render_frame(&mut app, &mut script);
        if let Some(leg) = app.glide_leg().filter(|l| legs.last() != Some(l)) {
            legs.push(leg);
        }
    }
    assert_eq!(legs, vec![(0, 5), (5, 2)], "from probe 0 to the panorama half way, then on to probe 2");
    assert!(matches!(app.nav.state, State::AtProbe { probe: 2 }), "{:?}", app.nav.state);
}

#[test]
fn a_probe_with_only_large_levels_still_shows_and_one_with_none_gives_a_message() {
    let Some((device, queue)) = crate::panorama::tests::gpu() else { return };
    let gpu = Gpu { device, queue, format: wgpu::TextureFormat::Rgba8UnormSrgb };
    let mut g = bundle_graph();
    // Probe 0 has only a 32² level (over max_face 16); probe 1 has nothing.
    g.probes[0].assets.cube_levels.retain(|l| l.size == 32);
    g.probes[1].assets.cube_levels.clear();
    g.probes[1].assets.equirect = None;
    let mut script = Script::default();
    let nav = Navigator::new(g, Some(0), 1).unwrap();
    let mut app = App::new(gpu, nav, None, Options { budget_bytes: 1 << 30, max_face: 16, show_map: true, tour: false }, &mut script);
    app.resize(53, 30, 1.0);
    assert_eq!(script.requests, vec![(0, 32)], "the smallest level the device takes, though over max_face");
    app.update(0.016, &mut script);
    assert!(app.panos.contains_key(&0));
    app.nav.go_to(1).unwrap();
    for _ in 0..400 {
        app.update(0.02, &mut script);
    }
    assert!(script.messages.iter().any(|m| m.contains("probe 1 cannot be shown") && m.contains("exploremaps render")), "{:?}", script.messages);
    assert_eq!(app.nav.state, State::AtProbe { probe: 1 }, "arrived all the same");
}

/// The bundle graph with a two-level proxy over two storeys (floors at 0
/// and 3, eye height 1.6).
fn graph_with_proxy() -> Graph {
    let mut g = bundle_graph();
    g.scene.eye_height_m = Some(1.6);
    let level = |i: usize| exploremaps_format::ProxyLevel {
        file: format!("proxy/{i}.emmc"),
        triangles: 4,
        vertices: 8,
        error: 0.0,
        bytes: 100,
        seen: Some(format!("proxy/{i}.seen")),
        chunks: vec![],
    };
    let depth_maps = (0..g.probes.len()).map(|p| format!("proxy/depth/{p}.emdm")).collect();
    g.proxy = Some(exploremaps_format::Proxy { levels: vec![level(0), level(1)], glb: None, floors: vec![0.0, 3.0], depth_maps, stream: None });
    g
}

/// Level 0 comes as vertex splits on level 1, a packet a poll; when a
/// packet is broken, the viewer says so and loads level 0 whole instead.
#[test]
fn the_proxy_refines_by_vertex_splits_or_comes_whole_when_they_fail() {
    for broken in [false, true] {
        let mut script = Script { broken_stream: broken, ..Script::default() };
        let mut g = graph_with_proxy();
        let packet =
            |k: usize, triangles: u64| exploremaps_format::ProxyPacket { file: format!("proxy/splits-{k}.emvs"), offset: 0, triangles, bytes: 10 };
        g.proxy.as_mut().unwrap().stream = Some(ProxyStream { from: 1, to: 0, packets: vec![packet(0, 5), packet(1, 6)] });
        let Some(mut app) = app_of(g, &mut script, 1 << 30, 360) else { return };
        app.resize(640, 360, 1.0);
        let mut shown = Vec::new();
        assert_eq!(app.proxy_loading(), Some(0.0), "nothing in yet");
        for _ in 0..8 {
            app.update(0.016, &mut script);
            let now = app.proxy.as_ref().map(|m| (m.level, m.triangles.len()));
            if now.is_some() && shown.last() != Some(&now) {
                shown.push(now);
            }
        }
        assert_eq!(script.stream_requests, vec![(1, 0, "proxy/1.emmc".to_string())]);
        if broken {
            assert_eq!(script.proxy_requests, vec![1, 0], "level 0 whole after the failure");
            assert_eq!(shown, vec![Some((1, 4)), Some((1, 5)), Some((0, 4))]);
            assert!(script.messages.iter().any(|m| m.contains("proxy/splits-1.emvs") && m.contains("whole")), "{:?}", script.messages);
            assert!(!app.proxy_failed);
        } else {
            assert_eq!(script.proxy_requests, vec![1], "no level asked for whole");
            assert_eq!(shown, vec![Some((1, 4)), Some((1, 5)), Some((0, 6))], "base, a packet, the last packet");
            assert_eq!(app.proxy.as_ref().unwrap().seen, vec![3, 3, 1, 1, 3, 3]);
            assert_eq!(app.proxy_loading(), None, "no loading bar once whole");
            assert!(script.messages.is_empty(), "{:?}", script.messages);
        }
    }
}

/// Presses and releases at a pixel.
fn tap(app: &mut App, script: &mut Script, [x, y]: [f32; 2]) {
    app.input(Input::PointerDown { id: 1, x, y }, script);
    app.input(Input::PointerUp { id: 1, x, y }, script);
}

fn settle(app: &mut App, script: &mut Script) {
    for _ in 0..80 {
        app.update(0.02, script);
    }
}

#[test]
fn the_dollhouse_streams_coarse_then_fine_and_a_tap_flies_to_the_probe_that_sees_the_point_best() {
    let mut script = Script::default();
    let Some(mut app) = app_of(graph_with_proxy(), &mut script, 1 << 30, 360) else { return };
    app.resize(640, 360, 1.0);
    assert!(script.proxy_requests.is_empty(), "nothing before the first panorama");
    app.update(0.016, &mut script);
    app.update(0.016, &mut script);
    app.update(0.016, &mut script);
    assert_eq!(script.proxy_requests, vec![1, 0], "the coarse level first, then the fine one");
    assert_eq!(app.proxy.as_ref().map(|m| m.level), Some(0));
    // Into the dollhouse: a flight up from the probe, then the orbit, cut at the
    // current storey (the upper floor at y = 3 hidden).
    app.input(Input::Key(Key::Dollhouse), &mut script);
    assert_eq!(app.mode, Mode::Dollhouse);
    assert!(app.flight.is_some() && app.animating());
    settle(&mut app, &mut script);
    assert!(app.flight.is_none());
    assert_eq!(app.floor, Some(0));
    assert!((app.cut() - 2.08).abs() < 1e-4);
    // A frame draws, with probe markers (probe 4 at (9, 0, 9) too).
    render_frame(&mut app, &mut script);
    let markers = app.layout.hits.iter().filter(|h| h.round && matches!(h.action, Action::GoTo(_))).count();
    assert_eq!(markers, 5);
    // A tap on the lower floor at (1, 0, −2): the table says probe 3; the camera flies
    // there and the panorama faces the point.
    let point = Vec3::new(1.0, 0.0, -2.0);
    let pixel = app.orbit.unwrap().camera().project(point, 640.0, 360.0).unwrap();
    tap(&mut app, &mut script, pixel);
    assert!(app.flight.is_some_and(|f| f.arrive.map(|a| a.0) == Some(3)));
    settle(&mut app, &mut script);
    assert_eq!((app.mode, app.nav.state), (Mode::Panorama, State::AtProbe { probe: 3 }));
    let facing = Vec3::from(direction(app.nav.view.yaw, app.nav.view.pitch));
    let wanted = (point - Vec3::new(2.0, 0.0, 4.0)).normalize();
    assert!(facing.dot(wanted) > 0.9999, "facing {facing}, the point is toward {wanted}");
    // Back up, show the upper storey, tap the same place: the upper floor, probe 1.
    app.input(Input::Key(Key::Dollhouse), &mut script);
    settle(&mut app, &mut script);
    app.input(Input::Key(Key::Floor), &mut script);
    assert_eq!(app.floor, Some(1));
    let pixel = app.orbit.unwrap().camera().project(Vec3::new(1.0, 3.0, -2.0), 640.0, 360.0).unwrap();
    tap(&mut app, &mut script, pixel);
    settle(&mut app, &mut script);
    assert_eq!(app.nav.state, State::AtProbe { probe: 1 });
    // The dollhouse button and the markers: a tap on probe 2's marker flies there.
    app.input(Input::Key(Key::Dollhouse), &mut script);
    settle(&mut app, &mut script);
    render_frame(&mut app, &mut script);
    let marker = app.layout.hits.iter().find(|h| h.action == Action::GoTo(2) && h.round).map(|h| [h.x + h.w / 2.0, h.y + h.h / 2.0]).unwrap();
    tap(&mut app, &mut script, marker);
    settle(&mut app, &mut script);
    assert_eq!(app.nav.state, State::AtProbe { probe: 2 });
    let (yaw, _) = (app.nav.view.yaw, app.nav.view.pitch);
    assert!((yaw - std::f32::consts::FRAC_PI_2).abs() < 1e-4, "probe 2's preferred direction: {yaw}");
}

/// Renders one frame into a throwaway target the app's size.
fn render_frame(app: &mut App, script: &mut Script) {
    let gpu = app.gpu().clone();
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: None,
        size: wgpu::Extent3d { width: app.width as u32, height: app.height as u32, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: gpu.format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    });
    let commands = app.render(&texture.create_view(&Default::default()), script);
    gpu.queue.submit([commands]);
}

#[test]
fn a_corrupt_proxy_gives_a_message_and_the_panoramas_keep_working() {
    let mut script = Script { broken_proxy: true, ..Default::default() };
    let Some(mut app) = app_of(graph_with_proxy(), &mut script, 1 << 30, 90) else { return };
    app.update(0.016, &mut script);
    app.input(Input::Key(Key::Dollhouse), &mut script);
    app.update(0.016, &mut script);
    assert_eq!(app.mode, Mode::Panorama, "back to the panorama");
    assert!(script.messages.iter().any(|m| m.contains("3D overview") && m.contains("proxy/1.emmc")), "{:?}", script.messages);
    app.input(Input::Key(Key::Dollhouse), &mut script);
    assert_eq!(app.mode, Mode::Panorama, "asking again does not enter an empty dollhouse");
    render_frame(&mut app, &mut script);
    app.input(Input::Key(Key::Go), &mut script);
    for _ in 0..200 {
        app.update(0.02, &mut script);
    }
    assert_ne!(app.nav.probe(), 0, "the panorama viewer goes on");
}

#[test]
fn a_bundle_without_a_proxy_says_so_when_the_dollhouse_is_asked_for() {
    let mut script = Script::default();
    let Some(mut app) = app(&mut script, 1 << 30, 90) else { return };
    app.update(0.016, &mut script);
    app.input(Input::Key(Key::Dollhouse), &mut script);
    assert_eq!(app.mode, Mode::Panorama);
    assert!(script.proxy_requests.is_empty());
    assert!(script.messages.iter().any(|m| m.contains("no 3D overview") && m.contains("exploremaps render")), "{:?}", script.messages);
}

#[test]
fn opened_in_the_dollhouse_the_proxy_comes_before_any_panorama_and_a_landing_waits_for_its_panorama() {
    let Some((device, queue)) = crate::panorama::tests::gpu() else { return };
    let gpu = Gpu { device, queue, format: wgpu::TextureFormat::Rgba8UnormSrgb };
    let mut script = Script::default();
    let nav = Navigator::new(graph_with_proxy(), Some(0), 1).unwrap();
    let link = Link { dollhouse: true, ..Link::default() };
    let mut app = App::new(gpu, nav, Some(&link), Options { budget_bytes: 1 << 30, max_face: 2048, show_map: true, tour: false }, &mut script);
    app.resize(640, 360, 1.0);
    assert_eq!(app.mode, Mode::Dollhouse);
    assert!(app.waiting_for_first_frame(), "nothing to draw before the proxy");
    assert_eq!((script.proxy_requests.clone(), script.requests.clone()), (vec![1], vec![]), "the coarse proxy alone");
    app.update(0.016, &mut script);
    assert!(!app.waiting_for_first_frame());
    assert_eq!((script.proxy_requests.clone(), script.requests.clone()), (vec![1, 0], vec![]), "then the fine one, still no panorama");
    app.update(0.016, &mut script);
    assert_eq!(script.requests.first(), Some(&(0, 8)), "panoramas once the proxy is whole");
    // A flight to probe 3, whose panorama is not here (forgotten, as if evicted):
    // it is asked for at once, and the landing waits for it.
    let point = Vec3::new(1.0, 0.0, -2.0);
    app.update(0.016, &mut script);
    let pixel = app.orbit.unwrap().camera().project(point, 640.0, 360.0).unwrap();
    tap(&mut app, &mut script, pixel);
    app.panos.remove(&3);
    app.requested.retain(|r| r.0 != 3);
    script.pending.retain(|r| r.0 != 3);
    let before = script.requests.len();
    app.flight.as_mut().unwrap().elapsed_s = 10.0;
    app.fly(0.0);
    assert_eq!(app.mode, Mode::Dollhouse, "no panorama of probe 3 yet: still flying");
    app.update(0.0, &mut script);
    assert!(script.requests[before..].contains(&(3, 8)), "{:?}", &script.requests[before..]);
    assert_eq!(app.mode, Mode::Dollhouse, "asked, not here yet");
    app.update(0.0, &mut script);
    assert_eq!((app.mode, app.nav.state), (Mode::Panorama, State::AtProbe { probe: 3 }));
}

#[test]
fn a_tap_in_a_panorama_goes_to_the_probe_that_sees_that_point_best_facing_it() {
    let mut script = Script::default();
    let Some(mut app) = app_of(graph_with_proxy(), &mut script, 1 << 30, 360) else { return };
    app.resize(640, 360, 1.0);
    app.nav.view.yaw = 0.0;
    for _ in 0..3 {
        app.update(0.016, &mut script);
    }
    assert_eq!(script.depth_requests, vec![0], "the current probe's map, once");
    // Facing −Z at probe 0: the tapped point (0, 0, −2) is seen best from probe 2 at (0, 0, −4),
    // joined by a path; on arrival it faces back toward +Z (not its preferred +X).
    render_frame(&mut app, &mut script);
    tap(&mut app, &mut script, [320.0, 180.0]);
    assert!(matches!(app.nav.state, State::Travelling { .. }), "{:?}", app.nav.state);
    for _ in 0..200 {
        app.update(0.02, &mut script);
    }
    assert_eq!(app.nav.state, State::AtProbe { probe: 2 });
    let yaw = app.nav.view.yaw;
    assert!((yaw.abs() - std::f32::consts::PI).abs() < 1e-3, "facing the point: {yaw}");
    // Where the map says this probe sees best itself, a tap does what it did before
    // (takes the best-aligned path within 45°, here none): no move.
    app.nav.view.yaw = std::f32::consts::FRAC_PI_2;
    tap(&mut app, &mut script, [320.0, 180.0]);
    assert_eq!(app.nav.state, State::AtProbe { probe: 2 });
}

#[test]
fn going_to_a_probe_no_route_reaches_flies_over_the_dollhouse_and_one_a_route_reaches_walks() {
    let mut script = Script::default();
    let Some(mut app) = app_of(without_video_with_depth(graph_with_proxy()), &mut script, 1 << 30, 360) else { return };
    app.resize(640, 360, 1.0);
    for _ in 0..3 {
        app.update(0.016, &mut script);
    }
    assert!(app.proxy.is_some());
    // Probe 1 is joined by a path: travelled as before.
    app.go_to(1, None);
    assert!(matches!(app.nav.state, State::Travelling { .. }));
    settle(&mut app, &mut script);
    app.nav.state = State::AtProbe { probe: 0 };
    // Probe 4 (9, 0, 9) is not: a flight that leaves the panorama fading, rises over the
    // middle and lands facing probe 4's way, with no cross-fade.
    app.go_to(4, None);
    assert_eq!(app.nav.state, State::AtProbe { probe: 0 });
    let flight = app.flight.expect("a flight");
    assert!(flight.fade_out && flight.via.is_some());
    let mut highest = f32::MIN;
    for _ in 0..200 {
        if let Some(f) = &app.flight {
            highest = highest.max(f.camera().eye.y);
        }
        app.update(0.02, &mut script);
    }
    assert!(highest > 5.0, "it rose over the scene: {highest}");
    assert_eq!((app.mode, app.nav.state), (Mode::Panorama, State::AtProbe { probe: 4 }));
    // Probe 3 from probe 1 is two paths away (1 → 0 → 3): walked, not flown,
    // with probe 3's panorama and depth asked for from the start.
    app.nav.state = State::AtProbe { probe: 1 };
    app.update(0.02, &mut script);
    app.go_to(3, None);
    assert!(app.flight.is_none() && matches!(app.nav.state, State::Travelling { path: 0, reversed: true, .. }), "{:?}", app.nav.state);
    app.update(0.02, &mut script);
    assert!(script.requests.iter().any(|r| r.0 == 3) && script.glide_requests.contains(&3), "{:?}", script.requests);
    let mut legs = vec![];
    for _ in 0..400 {
        if let State::Travelling { path, .. } = app.nav.state {
            if legs.last() != Some(&path) {
                legs.push(path);
            }
        }
        assert!(app.flight.is_none());
        app.update(0.02, &mut script);
    }
    assert_eq!((legs, app.mode, app.nav.state), (vec![0, 2], Mode::Panorama, State::AtProbe { probe: 3 }));
}

#[test]
fn a_tap_on_the_floor_plan_goes_where_that_point_is_seen_best() {
    let mut script = Script::default();
    let Some(mut app) = app_of(graph_with_proxy(), &mut script, 1 << 30, 720) else { return };
    app.resize(1280, 720, 1.0);
    for _ in 0..3 {
        app.update(0.016, &mut script);
    }
    render_frame(&mut app, &mut script);
    let frame = app.layout.map.expect("the map, over the plan");
    // The lower floor at (1, 0, −2): the table says probe 3.
    let pixel = frame.to_map([1.0, 0.0, -2.0]);
    assert_eq!(app.layout.hit(pixel[0], pixel[1]), Some(Action::PlanPoint));
    let back = frame.to_world(pixel[0], pixel[1]);
    assert!((back[0] - 1.0).abs() < 1e-4 && (back[1] + 2.0).abs() < 1e-4);
    tap(&mut app, &mut script, pixel);
    assert!(matches!(app.nav.state, State::Travelling { .. }), "probe 3 is joined by a path: {:?}", app.nav.state);
    for _ in 0..200 {
        app.update(0.02, &mut script);
    }
    assert_eq!(app.nav.state, State::AtProbe { probe: 3 });
    let facing = Vec3::from(direction(app.nav.view.yaw, app.nav.view.pitch));
    let wanted = (Vec3::new(1.0, 0.0, -2.0) - Vec3::new(2.0, 0.0, 4.0)).normalize();
    assert!(facing.dot(wanted) > 0.9999, "facing the point: {facing} vs {wanted}");
}

#[test]
fn markers_the_proxy_hides_are_told_apart() {
    let mut script = Script::default();
    let Some(mut app) = app_of(graph_with_proxy(), &mut script, 1 << 30, 360) else { return };
    app.resize(640, 360, 1.0);
    for _ in 0..3 {
        app.update(0.016, &mut script);
    }
    app.input(Input::Key(Key::Dollhouse), &mut script);
    settle(&mut app, &mut script);
    // Showing the upper storey, looking straight down: its floor (y = 3, x and z in ±5)
    // hides the probes under it; probe 4 at (9, 0, 9) is beside it.
    app.orbit.as_mut().unwrap().pitch = -1.55;
    app.input(Input::Key(Key::Floor), &mut script);
    render_frame(&mut app, &mut script);
    assert_eq!(app.hidden, vec![true, true, true, true, false]);
    // The ground storey alone: nothing hides them.
    app.input(Input::Key(Key::Floor), &mut script);
    app.input(Input::Key(Key::Floor), &mut script);
    assert_eq!(app.floor, Some(0));
    render_frame(&mut app, &mut script);
    assert_eq!(app.hidden, vec![false; 5]);
}

/// Two eyes side by side on a 128 × 64 frame, each 90° wide, turned by `rotation`.
fn eyes(rotation: glam::Quat) -> Vec<Eye> {
    // 90° each way: edges at ±1 at depth 1.
    eyes_through(rotation, [-1.0, 1.0, -1.0, 1.0])
}

/// Two eyes side by side on a 128 × 64 frame, turned by `rotation`, each
/// through the frustum whose edges at depth 1 are `[left, right, bottom, top]`.
fn eyes_through(rotation: glam::Quat, edges: [f32; 4]) -> Vec<Eye> {
    let lens = Lens::of_eye(rotation, &crate::panorama::tests::gl_frustum(edges));
    vec![Eye { viewport: [0.0, 0.0, 64.0, 64.0], lens }, Eye { viewport: [64.0, 0.0, 64.0, 64.0], lens }]
}

/// A headset frame looking along `rotation`: its pixels.
fn headset_frame(app: &mut App, script: &mut Script, rotation: glam::Quat) -> Vec<u8> {
    headset_frame_through(app, script, &eyes(rotation))
}

fn headset_frame_through(app: &mut App, script: &mut Script, eyes: &[Eye]) -> Vec<u8> {
    let gpu = app.gpu().clone();
    let target = crate::offscreen::texture(&gpu.device, 128, 64);
    app.render_eyes(&target.create_view(&Default::default()), eyes, script);
    crate::offscreen::read_back(&gpu.device, &gpu.queue, &target)
}

#[test]
fn in_a_headset_a_controller_picks_a_path_both_eyes_glide_along_it_and_a_resting_gaze_picks_the_way_back() {
    let graph = without_video_with_depth(bundle_graph());
    let mut script = Script::default();
    let Some(mut app) = app_of(graph, &mut script, 1 << 30, 30) else { return };
    let level = glam::Quat::IDENTITY;
    for _ in 0..3 {
        app.look(level, std::f32::consts::FRAC_PI_2, (64, 64));
        app.point(None, Vec3::NEG_Z, 0.016);
        app.update(0.016, &mut script);
    }
    let out = app.targets().iter().find(|t| t.goal == Goal::Path(0)).copied().expect("a target on path 0 at probe 0");
    app.point(Some(Vec3::Y), Vec3::NEG_Z, 0.016);
    app.select();
    assert_eq!(app.nav.state, State::AtProbe { probe: 0 }, "pointing at nothing, a select does nothing");
    app.point(Some(out.direction), Vec3::NEG_Z, 0.016);
    app.select();
    assert!(matches!(app.nav.state, State::Travelling { path: 0, .. }), "{:?}", app.nav.state);
    let (mut glided, mut frames) = (0, 0);
    while matches!(app.nav.state, State::Travelling { .. }) && frames < 300 {
        app.update(0.02, &mut script);
        app.point(None, Vec3::NEG_Z, 0.02);
        let pixels = headset_frame(&mut app, &mut script, level);
        glided += usize::from(app.gliding());
        frames += 1;
        let centre = |x: usize| [pixels[(32 * 128 + x) * 4], pixels[(32 * 128 + x) * 4 + 1], pixels[(32 * 128 + x) * 4 + 2]];
        let left = centre(32);
        // (The script's depth, everything 2 away from every probe, leaves
        // holes part way; the glide's own tests look at what it draws.)
        assert!(app.gliding() || left.iter().all(|&c| c.abs_diff(128) <= 12), "frame {frames}: the left eye shows the grey panorama: {left:?}");
        let (l, r): (Vec<&[u8]>, Vec<&[u8]>) = pixels.chunks(4 * 128).map(|row| row.split_at(4 * 64)).unzip();
        assert_eq!(l, r, "frame {frames}: both eyes see the same");
    }
    assert!(glided > 10, "drawn as a glide in the headset ({glided} of {frames} frames)");
    assert_eq!(app.nav.state, State::AtProbe { probe: 1 });
    assert!(app.targets().is_empty() || app.targets().iter().all(|t| t.goal != Goal::Path(1)), "targets are those of probe 1");
    // No controller: the gaze rests on the way back for a second.
    app.point(None, Vec3::NEG_Z, 0.016);
    let back = app.targets().iter().find(|t| t.goal == Goal::Path(0)).copied().expect("path 0 leads back");
    let facing = glam::Quat::from_rotation_arc(Vec3::NEG_Z, back.direction);
    for _ in 0..9 {
        app.look(facing, std::f32::consts::FRAC_PI_2, (64, 64));
        app.point(None, back.direction, 0.1);
    }
    assert_eq!(app.nav.state, State::AtProbe { probe: 1 }, "not yet: 0.9 s");
    for _ in 0..3 {
        app.point(None, back.direction, 0.1);
    }
    assert!(matches!(app.nav.state, State::Travelling { path: 0, reversed: true, .. }), "{:?}", app.nav.state);
}

/// The window's frame as pixels (the app sized 128 × 64).
fn window_frame(app: &mut App, script: &mut Script) -> Vec<u8> {
    let gpu = app.gpu().clone();
    let target = crate::offscreen::texture(&gpu.device, 128, 64);
    let commands = app.render(&target.create_view(&Default::default()), script);
    gpu.queue.submit([commands]);
    crate::offscreen::read_back(&gpu.device, &gpu.queue, &target)
}

#[test]
fn where_neither_end_of_a_glide_sees_the_proxy_shows_its_colours() {
    // The script's depth (everything 2 away from every probe) leaves holes part way along path 0.
    let glide_at_half_way = |graph: Graph| {
        let graph = without_video_with_depth(graph);
        let mut script = Script::default();
        let mut app = app_of(graph, &mut script, 1 << 30, 64)?;
        app.resize(128, 64, 1.0);
        for _ in 0..20 {
            app.update(0.016, &mut script);
            render_frame(&mut app, &mut script);
        }
        app.nav.take_path(0).unwrap();
        while app.nav.progress().is_some_and(|p| p < 0.45) {
            app.update(0.02, &mut script);
        }
        let pixels = window_frame(&mut app, &mut script);
        assert!(app.gliding(), "drawn as a glide");
        // A headset's eyes, each seeing what the window sees.
        let (t, rotation) = ((0.5 * app.nav.view.fov_y).tan(), crate::navigation::rotation_of(&app.nav.view));
        let headset = eyes_through(rotation, [-2.0 * t, 2.0 * t, -t, t]);
        let eyes = headset_frame_through(&mut app, &mut script, &headset);
        // The proxy alone from there, over the background: where it has surface.
        let window = [(Lens::of_view(&app.nav.view, 2.0), [0.0, 0.0, 128.0, 64.0])];
        let headset: Vec<_> = headset.iter().map(|e| (e.lens, e.viewport)).collect();
        let proxy = [&window[..], &headset].map(|views| proxy_alone(&mut app, views));
        Some((pixels, eyes, proxy, app.proxy.is_some()))
    };
    let Some((without, eyes_without, _, _)) = glide_at_half_way(bundle_graph()) else { return };
    let (with, eyes_with, [proxy, eyes_proxy], loaded) = glide_at_half_way(graph_with_proxy()).expect("a GPU, as above");
    assert!(loaded, "the proxy came after the first panorama");
    // The window's and the eyes' background, (0.02, 0.02, 0.025) in sRGB.
    let background = |c: &[u8]| c[0].abs_diff(39) <= 2 && c[2].abs_diff(44) <= 2;
    // Holes the glide alone leaves where the proxy has surface, and how many stay with it.
    let count = |without: &[u8], with: &[u8], proxy: &[u8]| {
        let holes = without.chunks(4).zip(proxy.chunks(4)).zip(with.chunks(4)).filter(|((a, p), _)| background(a) && !background(p));
        holes.fold((0, 0), |(n, left), (_, b)| (n + 1, left + usize::from(background(b))))
    };
    let (holes, left) = count(&without, &with, &proxy);
    assert!(holes > 50, "the glide alone leaves holes where the proxy has surface: {holes} pixels");
    assert_eq!(left, 0, "the proxy fills them: {left} of {holes} left");
    // In each eye of a headset too, where the veil darkens the edges: the proxy is blue.
    let eye = |p: &[u8], k: usize| p.chunks(4 * 128).flat_map(|row| row[4 * 64 * k..4 * 64 * (k + 1)].to_vec()).collect::<Vec<u8>>();
    let blue = |p: &[u8]| p.chunks(4).filter(|c| c[2] > 40 && c[2] > c[0].saturating_add(30) && c[2] > c[1].saturating_add(30)).count();
    for k in 0..2 {
        let (none, shown, alone) = (blue(&eye(&eyes_without, k)), blue(&eye(&eyes_with, k)), blue(&eye(&eyes_proxy, k)));
        assert!(none == 0 && alone > 20, "eye {k}: no blue without the proxy ({none}), some seen from there ({alone})");
        assert!(2 * shown > alone, "eye {k}: the proxy shows through the glide's holes: {shown} of {alone} pixels");
    }
}

/// The proxy alone, through each (lens, viewport), from where the camera is,
/// on a 128 × 64 frame cleared to the window's background.
fn proxy_alone(app: &mut App, views: &[(Lens, [f32; 4])]) -> Vec<u8> {
    let gpu = app.gpu().clone();
    let target = crate::offscreen::texture(&gpu.device, 128, 64);
    let view = target.create_view(&Default::default());
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    drop(colour_pass(&mut encoder, &view, wgpu::LoadOp::Clear(wgpu::Color { r: 0.02, g: 0.02, b: 0.025, a: 1.0 }), "test"));
    let mut frame = FrameTarget { device: &gpu.device, queue: &gpu.queue, encoder: &mut encoder, view: &view, width: 128, height: 64 };
    for (lens, viewport) in views {
        app.fill_behind_glide(&mut frame, lens, *viewport);
    }
    gpu.queue.submit([encoder.finish()]);
    crate::offscreen::read_back(&gpu.device, &gpu.queue, &target)
}

#[test]
fn along_a_glide_taps_on_the_buttons_pause_go_back_and_go_on() {
    let graph = without_video_with_depth(bundle_graph());
    let mut script = Script::default();
    let Some(mut app) = app_of(graph, &mut script, 1 << 30, 360) else { return };
    for _ in 0..3 {
        app.update(0.016, &mut script);
    }
    app.input(Input::Key(Key::Go), &mut script);
    app.update(0.3, &mut script);
    render_frame(&mut app, &mut script);
    let button = |app: &App, a: Action| {
        let h = app.layout.hits.iter().find(|h| h.action == a).copied().unwrap_or_else(|| panic!("no {a:?} button while gliding"));
        [h.x + h.w / 2.0, h.y + h.h / 2.0]
    };
    let at = button(&app, Action::Pause);
    tap(&mut app, &mut script, at);
    assert_eq!(app.nav.speed, 0.0, "paused");
    render_frame(&mut app, &mut script);
    let at = button(&app, Action::Back);
    tap(&mut app, &mut script, at);
    assert_eq!(app.nav.speed, -1.0, "going back");
    render_frame(&mut app, &mut script);
    let at = button(&app, Action::On);
    tap(&mut app, &mut script, at);
    let at = button(&app, Action::On);
    tap(&mut app, &mut script, at);
    assert_eq!(app.nav.speed, 2.0, "on, then faster");
    assert!(matches!(app.nav.state, State::Travelling { .. }), "still under way: {:?}", app.nav.state);
}

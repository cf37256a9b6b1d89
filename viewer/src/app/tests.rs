//! The application with a scripted platform: what it asks for and when.

use super::*;
use crate::navigation::tests::graph;
use exploremaps_format::{CubeLevel, Graph};

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
}

impl Platform for Script {
    fn load_cube(&mut self, probe: u32, size: u32, _faces: &[String; 6]) {
        self.requests.push((probe, size));
        self.pending.push((probe, size));
    }
    fn load_equirect(&mut self, _probe: u32, _file: &str) {}
    fn load_thumbnail(&mut self, probe: u32, _file: &str) {
        self.thumbnails.push(probe);
    }
    fn poll(&mut self, gpu: &Gpu, _overlay: &OverlayPass) -> Vec<Loaded> {
        self.pending
            .drain(..)
            .map(|(probe, size)| {
                if self.broken.contains(&probe) {
                    return Loaded::Failed { what: format!("probes/{probe}/{size}_px.jpg"), error: "is not a readable image".into(), probe: Some(probe) };
                }
                let cube = Cube::new(&gpu.device, size);
                let grey = vec![128u8; (4 * size * size) as usize];
                for f in 0..6 {
                    cube.write_face(&gpu.queue, f, &grey);
                }
                Loaded::Pano { probe, pano: Pano::Cube(cube) }
            })
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
        p.assets.cube_levels = [8u32, 16, 32].iter().map(|&size| CubeLevel { size, faces: std::array::from_fn(|f| format!("probes/{}/{size}_{f}.jpg", p.id)) }).collect();
    }
    for p in &mut g.paths {
        p.assets.video = Some(format!("paths/{}.mp4", p.id));
    }
    g
}

fn app(script: &mut Script, budget: u64, height: u32) -> Option<App> {
    let (device, queue) = crate::panorama::tests::gpu()?;
    let gpu = Gpu { device, queue, format: wgpu::TextureFormat::Rgba8UnormSrgb };
    let nav = Navigator::new(bundle_graph(), Some(0), 1).unwrap();
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
    assert!(app.waiting_for_first_panorama() && script.thumbnails.is_empty());
    app.update(0.016, &mut script);
    assert!(!app.waiting_for_first_panorama());
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

//! The viewer end to end: `serve`, the web viewer in headless Chromium, the
//! native window under Xvfb. They run on a synthetic bundle whose panoramas
//! are solid colours a face, so what is on screen says where the viewer is
//! and which way it looks.
//!
//! They need Chromium, Node with playwright-core, the wasm toolchain, Xvfb and
//! xdotool, which scripts/setup.sh installs; without them they fail, unless
//! EXPLOREMAPS_SKIP_BROWSER=1 (or EXPLOREMAPS_SKIP_WINDOW=1) says so.

use super::{exploremaps, stderr};
use exploremaps_format::{CameraKey, CubeLevel, Graph, Path as GraphPath, PathAssets, Probe, ProbeAssets, SceneInfo, ViewDirection, CUBE_FACES};
use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Mutex;

/// Face colours (+X, −X, +Y, −Y, +Z, −Z) of probes 0 and 1; probe 2's +X face is corrupt.
const FACES: [[[u8; 3]; 6]; 3] = [
    [[220, 40, 40], [40, 200, 200], [235, 235, 235], [30, 30, 30], [40, 40, 220], [40, 200, 40]],
    [[230, 140, 20], [140, 40, 200], [235, 235, 235], [30, 30, 30], [220, 220, 40], [230, 110, 170]],
    [[90, 90, 90], [90, 90, 90], [90, 90, 90], [90, 90, 90], [90, 90, 90], [90, 90, 90]],
];
const VIDEO: [u8; 3] = [230, 40, 230];
/// The proxy: a ground quad at y = 0 over x in [−5, 9], z in [−5, 9], its
/// west half (x < 2) green and seen best from probe 0, its east half orange
/// and seen best from probe 1.
const WEST: [u8; 3] = [40, 180, 60];
const EAST: [u8; 3] = [230, 140, 20];

fn jpeg(img: &image::RgbImage) -> Vec<u8> {
    let mut bytes = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, 95).encode_image(img).unwrap();
    bytes
}

/// The scene of the synthetic bundles: 14 × 4 × 14 m.
pub(super) fn synthetic_scene(name: &str) -> SceneInfo {
    SceneInfo {
        name: name.into(),
        source: "test".into(),
        triangles: 12,
        bounds_min: [-5.0, -1.0, -5.0],
        bounds_max: [9.0, 3.0, 9.0],
        metres_per_unit: 1.0,
        scale_source: "file".into(),
        space: None,
        near_distance: None,
        eye_height_m: None,
        credits: vec![],
    }
}

/// Writes a file of a bundle in `dir`, making its folders.
pub(super) fn writer(dir: &Path) -> impl Fn(&str, &[u8]) + '_ {
    move |name, bytes| {
        let path = dir.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }
}

/// Path 0 from probe 0 at (0, 1.5, 0) to probe 1 at (4, 1.5, 0): 2 s facing
/// +X, its video 50 frames of [`VIDEO`].
pub(super) fn push_path(graph: &mut Graph, write: &impl Fn(&str, &[u8])) {
    let frames: Vec<image::RgbImage> = (0..50).map(|_| image::RgbImage::from_pixel(256, 128, image::Rgb(VIDEO))).collect();
    write("paths/0.mp4", &exploremaps_builder::video::Encoder::OpenH264.encode(&frames, 25.0).unwrap());
    let camera = (0..50)
        .map(|i| CameraKey { t_s: i as f32 / 25.0, position: [4.0 * i as f32 / 49.0, 1.5, 0.0], yaw: std::f32::consts::FRAC_PI_2, pitch: 0.0 })
        .collect();
    graph.paths.push(GraphPath {
        id: 0,
        from: 0,
        to: 1,
        polyline: vec![[0.0, 1.5, 0.0], [2.0, 1.5, 0.0], [4.0, 1.5, 0.0]],
        length: 4.0,
        duration_s: 2.0,
        camera,
        assets: PathAssets { video: Some("paths/0.mp4".into()), ..Default::default() },
    });
}

/// Probe 0 at the origin facing −Z, probe 1 4 m along +X (a 2 s path between
/// them; it arrives facing +Z), probe 2 unconnected with a corrupt face.
pub fn synthetic_bundle(dir: &Path) {
    let mut graph = Graph::new(synthetic_scene("synthetic"));
    let write = writer(dir);
    push_probes(&mut graph, &write);
    push_path(&mut graph, &write);
    graph.bar_order = vec![0, 1, 2];
    let (levels, stream) = proxy_levels(&write);
    let depth_maps = depth_maps(&write, graph.probes.len() as u32);
    graph.proxy = Some(exploremaps_format::Proxy { levels, glb: None, floors: vec![], depth_maps, stream });
    graph.validate().unwrap();
    write("graph.json", graph.to_json().as_bytes());
}

/// The three probes, each with two cube levels (probe 2's first face corrupt).
fn push_probes(graph: &mut Graph, write: &impl Fn(&str, &[u8])) {
    let positions = [[0.0, 1.5, 0.0], [4.0, 1.5, 0.0], [0.0, 1.5, 8.0]];
    let facing = [0.0, std::f32::consts::PI, 0.0];
    for (p, position) in positions.iter().enumerate() {
        let mut levels = Vec::new();
        for size in [32u32, 64] {
            let faces: [String; 6] = std::array::from_fn(|f| format!("probes/{p}/{size}_{}.jpg", CUBE_FACES[f]));
            for (f, name) in faces.iter().enumerate() {
                if p == 2 && f == 0 {
                    write(name, b"\xff\xd8 this is not a JPEG");
                } else {
                    write(name, &jpeg(&image::RgbImage::from_pixel(size, size, image::Rgb(FACES[p][f]))));
                }
            }
            levels.push(CubeLevel { size, faces });
        }
        let thumbnail = format!("thumbs/{p}.jpg");
        write(&thumbnail, &jpeg(&image::RgbImage::from_pixel(320, 180, image::Rgb(FACES[p][5]))));
        graph.probes.push(Probe {
            id: p as u32,
            position: *position,
            cluster: None,
            preferred_directions: vec![ViewDirection { yaw: facing[p], pitch: 0.0, goodness: 1.0 }],
            user_placed: false,
            assets: ProbeAssets { cube_levels: levels, thumbnail: Some(thumbnail), ..Default::default() },
        });
    }
}

/// The proxy's two levels (a ground of two coloured quads) and the vertex
/// split that refines the coarse one into the fine one.
fn proxy_levels(write: &impl Fn(&str, &[u8])) -> (Vec<exploremaps_format::ProxyLevel>, Option<exploremaps_format::ProxyStream>) {
    let mut ground = exploremaps_format::meshcode::MeshData::default();
    for (x0, x1, colour) in [(-5.0, 2.0, WEST), (2.0, 9.0, EAST)] {
        let base = ground.positions.len() as u32;
        ground.positions.extend([[x0, 0.0, -5.0], [x1, 0.0, -5.0], [x1, 0.0, 9.0], [x0, 0.0, 9.0]]);
        ground.colours.extend([colour; 4]);
        ground.triangles.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    }
    // Level 0 whole; level 1 the east quad's corner (9, −5) collapsed into
    // (9, 9), which a vertex split of the stream undoes.
    let best = [0, 0, 1, 1];
    let mut levels = Vec::new();
    let mut coarse = ground.clone();
    coarse.positions[5] = [9.0, 0.0, 9.0];
    coarse.positions.remove(6);
    coarse.colours.remove(6);
    coarse.triangles = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6]];
    let coarse_best = [0, 0, 1];
    let mut coded_coarse = None;
    for (level, mesh, best) in [(0, &ground, &best[..]), (1, &coarse, &coarse_best[..])] {
        let coded = exploremaps_format::meshcode::encode(mesh, 14).unwrap();
        let (file, table) = (format!("proxy/{level}.emmc"), format!("proxy/{level}.seen"));
        let seen: Vec<u32> = coded.order.triangles.iter().map(|&t| best[t as usize]).collect();
        write(&file, &coded.bytes);
        write(&table, &exploremaps_format::seen::encode(&seen));
        levels.push(exploremaps_format::ProxyLevel {
            file,
            triangles: mesh.triangles.len() as u64,
            vertices: mesh.positions.len() as u64,
            error: 0.0,
            bytes: coded.bytes.len() as u64,
            seen: Some(table),
            chunks: vec![],
        });
        coded_coarse = Some((coded, seen));
    }
    let (coded, seen) = coded_coarse.unwrap();
    let mut base = exploremaps_format::meshcode::decode(&coded.bytes).unwrap();
    base.groups = seen;
    let decoded = |input: u32| coded.order.vertices.iter().position(|&v| v == input).unwrap() as u32;
    let [e, f] = [4, 5].map(decoded);
    let g = base.positions.len() as u32;
    let moved = coded.order.triangles.iter().position(|&t| t == 2).unwrap() as u32;
    let split = exploremaps_format::splits::Refinement::Split {
        vertex: f,
        position: [9.0, 0.0, -5.0],
        new_position: [9.0, 0.0, 9.0],
        colour: EAST,
        new_colour: EAST,
        moved: vec![moved],
        added: vec![[e, f, g]],
        groups: vec![1],
    };
    let packet = exploremaps_format::splits::encode(&base, &[split], 14, 1).unwrap().remove(0);
    write("proxy/splits-0.emvs", &packet.bytes);
    let packets =
        vec![exploremaps_format::ProxyPacket { file: "proxy/splits-0.emvs".into(), offset: 0, bytes: packet.bytes.len() as u64, triangles: 4 }];
    let stream = Some(exploremaps_format::ProxyStream { from: 1, to: 0, packets });
    (levels, stream)
}

/// Depth maps: everything 3 away; from probe 0, what lies toward −Z is seen best from probe 1.
fn depth_maps(write: &impl Fn(&str, &[u8]), probes: u32) -> Vec<String> {
    let mut depth_maps = Vec::new();
    for p in 0..probes {
        let size = 16;
        let mut map = exploremaps_format::depthmap::DepthMap { size, near: 0.1, far: 40.0, depth: Vec::new(), best: Vec::new() };
        for face in 0..6 {
            for i in 0..size * size {
                let d = exploremaps_format::cube_direction(face, ((i % size) as f32 + 0.5) / size as f32, ((i / size) as f32 + 0.5) / size as f32);
                map.depth.push(map.code(Some(3.0)));
                map.best.push(if p == 0 && d[2] < 0.0 { 1 } else { p });
            }
        }
        let file = format!("proxy/depth/{p}.emdm");
        write(&file, &map.encode());
        depth_maps.push(file);
    }
    depth_maps
}

/// The synthetic bundle in a temporary folder (as `b`), changed by
/// `change`, and served.
fn served(change: impl FnOnce(&Path)) -> (tempfile::TempDir, Server) {
    let dir = tempfile::tempdir().unwrap();
    let bundle = dir.path().join("b");
    synthetic_bundle(&bundle);
    change(&bundle);
    let server = serve(&bundle);
    (dir, server)
}

/// A running `exploremaps serve`, stopped on drop.
pub(super) struct Server {
    child: Child,
    pub(super) url: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

pub(super) fn serve(bundle: &Path) -> Server {
    let mut child = Command::new(env!("CARGO_BIN_EXE_exploremaps"))
        .args(["serve", bundle.to_str().unwrap(), "--address", "127.0.0.1:0"])
        .env("RUST_LOG", "warn")
        .env("EXPLOREMAPS_WEB_DIR", web_viewer())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let url = line.split_whitespace().find(|w| w.starts_with("http://")).unwrap_or_else(|| panic!("no address in {line:?}")).to_string();
    Server { child, url }
}

pub(super) fn skip(var: &str, what: &str) -> bool {
    let skip = std::env::var(var).is_ok_and(|v| v == "1");
    if skip {
        eprintln!("SKIPPED: {var}=1 ({what})");
    }
    skip
}

/// Builds the web viewer (web/build.sh; quick when it is up to date) once.
pub(super) fn web_viewer() -> PathBuf {
    static BUILT: Mutex<Option<PathBuf>> = Mutex::new(None);
    let mut built = BUILT.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(p) = &*built {
        return p.clone();
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = Command::new(root.join("web/build.sh")).output().expect("run web/build.sh");
    assert!(out.status.success(), "web/build.sh failed (scripts/setup.sh installs the wasm target and wasm-bindgen): {}", stderr(&out));
    let dir = root.join("target/web-viewer");
    *built = Some(dir.clone());
    dir
}

/// Runs tests/browser/viewer.mjs; returns its JSON lines by step.
fn browser(mode: &str, url: &str, out: &Path) -> Vec<serde_json::Value> {
    browser_on(mode, url, out, false)
}

/// As [`browser`], on WebGPU when `webgpu`, else WebGL2.
fn browser_on(mode: &str, url: &str, out: &Path, webgpu: bool) -> Vec<serde_json::Value> {
    browser_with(mode, url, out, webgpu, &[])
}

/// As [`browser_on`], with more environment for the script.
fn browser_with(mode: &str, url: &str, out: &Path, webgpu: bool, env: &[(&str, String)]) -> Vec<serde_json::Value> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let playwright = root.join("target/node/node_modules/playwright-core/index.mjs");
    assert!(playwright.exists(), "{} is missing: run scripts/setup.sh (or set EXPLOREMAPS_SKIP_BROWSER=1)", playwright.display());
    let run = Command::new("node")
        .arg(root.join("tests/browser/viewer.mjs"))
        .args([mode, url, out.to_str().unwrap()])
        .env("PLAYWRIGHT_CORE", &playwright)
        .env("WEBGPU", if webgpu { "1" } else { "0" })
        .envs(env.iter().map(|(k, v)| (*k, v.as_str())))
        .output()
        .expect("node (scripts/setup.sh installs it)");
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&run.stdout).lines().filter_map(|l| serde_json::from_str(l).ok()).collect();
    assert!(run.status.success(), "{}\n{lines:?}", stderr(&run));
    for l in &lines {
        assert!(l["step"] != "error" && l["step"] != "pageerror", "{l}\nall: {lines:?}");
    }
    lines
}

fn step<'a>(lines: &'a [serde_json::Value], name: &str) -> &'a serde_json::Value {
    lines.iter().find(|l| l["step"] == name).unwrap_or_else(|| panic!("no step {name} in {lines:?}"))
}

/// The colour at (x, y) of a screenshot.
fn colour_at(png: &Path, x: u32, y: u32) -> [u8; 3] {
    let img = image::open(png).unwrap_or_else(|e| panic!("{}: {e}", png.display())).to_rgb8();
    img.get_pixel(x, y).0
}

fn near(a: [u8; 3], b: [u8; 3], tolerance: i32) -> bool {
    a.iter().zip(b).all(|(&x, y)| (x as i32 - y as i32).abs() <= tolerance)
}

/// Loads the synthetic bundle, drags, takes the path and back, then opens a probe with
/// a corrupt face: checks each step on screen and in the deep link.
fn tour(webgpu: bool) {
    let (dir, server) = served(|_| {});
    let lines = browser_on("tour", &server.url, dir.path(), webgpu);
    let backend = step(&lines, "start")["backend"].as_str().unwrap_or_default().to_string();
    assert_eq!(backend, if webgpu { "BrowserWebGpu" } else { "Gl" });
    let shot = |name: &str| dir.path().join(format!("{name}.png"));
    // Above the centre, clear of the path markers (which sit below the horizon).
    let (x, y) = (640, 300);
    let start = colour_at(&shot("start"), x, y);
    assert!(near(start, FACES[0][5], 24), "{backend}: probe 0 facing −Z shows its −Z face: {start:?}");
    let turned = colour_at(&shot("turned"), x, y);
    assert!(near(turned, FACES[0][0], 24), "{backend}: dragging left turns toward +X: {turned:?}");
    let yaw = link_value(step(&lines, "turned")["hash"].as_str().unwrap(), "yaw");
    assert!((yaw - 90.0).abs() < 8.0, "{backend}: the deep link follows the view: {yaw}");
    let travel = colour_at(&shot("travel"), x, y);
    assert!(near(travel, VIDEO, 40), "{backend}: the path's video plays on the way: {travel:?}");
    let arrived = step(&lines, "arrived");
    assert_eq!(arrived["probe"], 1);
    let yaw = link_value(arrived["hash"].as_str().unwrap(), "yaw");
    assert!((yaw.abs() - 180.0).abs() < 1.0, "{backend}: arrival faces probe 1's preferred direction (+Z): {yaw}");
    let there = colour_at(&shot("arrived"), x, y);
    assert!(near(there, FACES[1][4], 24), "{backend}: probe 1's +Z face: {there:?}");
    let back = colour_at(&shot("back_travel"), x, y);
    assert!(near(back, VIDEO, 40), "{backend}: the video plays backwards on the way back: {back:?}");
    assert_eq!(step(&lines, "back")["probe"], 0, "{backend}: back at probe 0");
    // The corrupt face is named in a message, and the viewer goes on to probe 0.
    let message = step(&lines, "corrupt")["message"].as_str().unwrap_or_default().to_string();
    assert!(message.contains("probes/2/") && message.contains("_px.jpg"), "{backend}: {message}");
    let recovered = colour_at(&shot("recovered"), x, y);
    assert!(near(recovered, FACES[0][5], 24), "{backend}: back at probe 0: {recovered:?}");
}

/// Path 0 without its video, and probes 0 and 1 with depth cubes (everything
/// 3 away): the path is a glide.
fn without_video_with_depth(bundle: &Path) {
    let mut graph = Graph::from_json(&std::fs::read_to_string(bundle.join("graph.json")).unwrap()).unwrap();
    graph.paths[0].assets.video = None;
    for p in 0..2 {
        let cube = exploremaps_format::depthcube::DepthCube::new(8, 0.1, 40.0, &[Some(3.0); 6 * 81]);
        let file = format!("probes/{p}/depth.emdc");
        std::fs::write(bundle.join(&file), cube.encode()).unwrap();
        graph.probes[p].assets.depth = Some(file);
    }
    std::fs::write(bundle.join("graph.json"), graph.to_json()).unwrap();
}

#[test]
fn the_web_viewer_glides_along_a_path_without_video() {
    if skip("EXPLOREMAPS_SKIP_BROWSER", "no headless Chromium on this machine") {
        return;
    }
    let (dir, server) = served(without_video_with_depth);
    let lines = browser("glide", &server.url, dir.path());
    let gliding = step(&lines, "gliding");
    assert!(gliding["glide_frames"].as_u64().unwrap() > 0, "drawn as a glide: {gliding}");
    // Under way, the view (toward +X, turning to +Z) shows the two probes'
    // panoramas: not the background, and no video.
    let shown = colour_at(&dir.path().join("glide.png"), 640, 300);
    assert!(!near(shown, [5, 5, 6], 20) && !near(shown, VIDEO, 40), "{shown:?}");
    let arrived = step(&lines, "arrived");
    assert_eq!(arrived["probe"], 1);
    assert!(arrived["glide_frames"].as_u64().unwrap() > gliding["glide_frames"].as_u64().unwrap(), "{arrived}");
}

/// Mean difference (levels of 255) between the left and right halves of a screenshot.
fn halves_differ(png: &Path) -> f64 {
    let img = image::open(png).unwrap_or_else(|e| panic!("{}: {e}", png.display())).to_rgb8();
    let half = img.width() / 2;
    let mut sum = 0u64;
    for y in 0..img.height() {
        for x in 0..half {
            let (a, b) = (img.get_pixel(x, y).0, img.get_pixel(x + half, y).0);
            sum += a.iter().zip(b).map(|(&p, q)| (p as i32 - q as i32).unsigned_abs() as u64).sum::<u64>();
        }
    }
    sum as f64 / (3 * half * img.height()) as f64
}

#[test]
fn in_an_emulated_headset_both_eyes_see_the_panorama_turning_with_the_head_a_controller_takes_a_path_and_leaving_gives_the_window_back() {
    if skip("EXPLOREMAPS_SKIP_BROWSER", "no headless Chromium on this machine") {
        return;
    }
    let iwer = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/node/node_modules/iwer/build/iwer.js");
    assert!(iwer.exists(), "{} is missing: run scripts/setup.sh", iwer.display());
    let (dir, server) = served(|_| {});
    let lines = browser_with("xr", &server.url, dir.path(), false, &[("IWER", iwer.display().to_string())]);
    let (window, xr, turned, after) = (step(&lines, "window"), step(&lines, "xr"), step(&lines, "turned_head"), step(&lines, "after"));
    assert!(xr["xr"] == true && xr["xr_frames"].as_u64().unwrap() >= 60 && xr["xr_eyes"] == 2, "{xr}");
    // The emulated Quest 3 puts the eyes side by side on the 1280 × 720 canvas.
    let shot = dir.path().join("xr.png");
    let (left, right) = (colour_at(&shot, 320, 360), colour_at(&shot, 960, 360));
    assert!(!near(left, [5, 5, 6], 20), "the left eye shows the panorama, not the background: {left:?}");
    assert!(near(left, right, 8), "a panorama at infinity looks the same to both eyes: {left:?} against {right:?}");
    let differ = halves_differ(&shot);
    assert!(differ < 4.0, "the eyes' images differ by {differ:.1} levels on average");
    // Facing where the window faced; the head turned 90° right, level.
    assert!((xr["yaw"].as_f64().unwrap() - window["yaw"].as_f64().unwrap()).abs() < 1.0, "{xr}\n{window}");
    let turn = turned["yaw"].as_f64().unwrap() - xr["yaw"].as_f64().unwrap();
    assert!(((turn + 540.0) % 360.0 - 180.0 - 90.0).abs() < 2.0, "turned by {turn}°: {turned}");
    assert!(turned["pitch"].as_f64().unwrap().abs() < 0.5, "the horizon stays level: {turned}");
    let seen = colour_at(&dir.path().join("xr_turned.png"), 320, 360);
    assert!(!near(seen, left, 20), "the view turned: {seen:?} against {left:?}");
    // The controller points at a path's target and selects: the visitor goes along it.
    let (selected, arrived) = (step(&lines, "selected"), step(&lines, "arrived"));
    assert!(selected["moving"] == true && selected["probe"] == window["probe"], "{selected}");
    assert!(arrived["probe"] == arrived["expected"] && arrived["probe"] != window["probe"], "{arrived}");
    // The session over, the window draws again at the same probe, heading as the head left it.
    assert!(after["xr"] == false && after["probe"] == arrived["probe"], "{after}");
    assert_eq!(after["canvas"], serde_json::json!([1280, 720, 1280, 720]));
    assert!((after["yaw"].as_f64().unwrap() - turned["yaw"].as_f64().unwrap()).abs() < 1.0, "{after}");
    assert!(!near(colour_at(&dir.path().join("after.png"), 640, 300), [5, 5, 6], 20));
}

#[test]
fn without_a_headset_the_web_viewer_offers_no_vr_and_says_nothing() {
    if skip("EXPLOREMAPS_SKIP_BROWSER", "no headless Chromium on this machine") {
        return;
    }
    let (dir, server) = served(|_| {});
    let lines = browser("no_xr", &server.url, dir.path());
    for name in ["no_xr", "no_webxr"] {
        let page = step(&lines, name);
        assert!(page["button"] == false && page["message"].is_null() && page["error"].is_null(), "{page}");
        assert!(page["first_panorama_ms"].is_number(), "{page}");
    }
    assert_eq!(step(&lines, "no_webxr")["has_xr"], false, "the page ran without navigator.xr");
}

#[test]
fn the_web_viewer_shows_turns_travels_and_survives_a_corrupt_asset_on_webgl2() {
    if skip("EXPLOREMAPS_SKIP_BROWSER", "no headless Chromium on this machine") {
        return;
    }
    tour(false);
}

#[test]
fn the_web_viewer_does_the_same_on_webgpu() {
    if skip("EXPLOREMAPS_SKIP_BROWSER", "no headless Chromium on this machine") {
        return;
    }
    tour(true);
}

/// A deep link's value for `key`.
fn link_value(hash: &str, key: &str) -> f32 {
    hash.trim_start_matches('#')
        .split('&')
        .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('='))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no {key} in {hash}"))
}

/// Gives probe 0 a tile pyramid of 256-pixel faces in 64-pixel tiles (4 × 4
/// a face at the top level), its colours lighter than the whole faces' so
/// a screenshot tells the two apart.
fn add_tiles(bundle: &Path) {
    use exploremaps_format::Tiles;
    let lighter = |c: [u8; 3]| c.map(|v| ((u16::from(v) + 255) / 2) as u8);
    let faces: Vec<image::RgbImage> = (0..6).map(|f| image::RgbImage::from_pixel(256, 256, image::Rgb(lighter(FACES[0][f])))).collect();
    let tiles = Tiles::new("probes/0/tiles".into(), 256, 64, 64);
    exploremaps_builder::tiles::cut(&tiles, &[(256, faces)], |name, tile| {
        let path = bundle.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, jpeg(&tile)).map_err(|_| ())
    })
    .unwrap();
    let mut graph = Graph::from_json(&std::fs::read_to_string(bundle.join("graph.json")).unwrap()).unwrap();
    graph.probes[0].assets.tiles = Some(tiles);
    std::fs::write(bundle.join("graph.json"), graph.to_json()).unwrap();
}

#[test]
fn on_a_phone_the_web_viewer_fetches_only_the_tiles_in_view() {
    if skip("EXPLOREMAPS_SKIP_BROWSER", "no headless Chromium on this machine") {
        return;
    }
    let (dir, server) = served(add_tiles);
    let lines = browser("tiles", &server.url, dir.path());
    let tiles = step(&lines, "tiles");
    let (asked, arrived) = (tiles["tiles_requested"].as_u64().unwrap(), tiles["tiles_in"].as_u64().unwrap());
    let fetched: Vec<&str> = tiles["fetched"].as_array().unwrap().iter().map(|f| f.as_str().unwrap()).collect();
    eprintln!("phone: {asked} of 96 tiles asked for, {arrived} in, {} fetched", fetched.len());
    // The screen (720 × 1480 pixels) wants more than the 32 faces: the top
    // level, 256; of its 96 tiles, only those about the view toward −Z.
    assert!((4..48).contains(&asked), "{asked} tiles: {tiles}");
    assert_eq!((arrived, fetched.len() as u64), (asked, asked), "each fetched once: {fetched:?}");
    assert!(fetched.iter().all(|f| f.contains("/probes/0/tiles/3/")), "{fetched:?}");
    assert!(fetched.iter().any(|f| f.contains("/3/f/")) && !fetched.iter().any(|f| f.contains("/3/b/")), "ahead, not behind: {fetched:?}");
    // In the middle of the screen, the tiles' lighter green, not the whole face's.
    let centre = colour_at(&dir.path().join("tiles.png"), 360, 740);
    assert!(near(centre, [147, 227, 147], 20), "{centre:?}");
}

#[test]
fn the_web_viewer_works_on_a_portrait_phone_screen_with_touch() {
    if skip("EXPLOREMAPS_SKIP_BROWSER", "no headless Chromium on this machine") {
        return;
    }
    let (dir, server) = served(|_| {});
    // The dollhouse on the phone frames the ground for a 720 × 1480 canvas facing yaw 0
    // (probe 0's way; the tap on the path bar leaves the view turned toward +X on arrival,
    // where probe 1 faces +Z: yaw π). A tap on the west half goes to probe 0.
    let camera = exploremaps_viewer::dollhouse::Orbit::framing(
        glam::Vec3::new(-5.0, 0.0, -5.0),
        glam::Vec3::new(9.0, 0.0, 9.0),
        std::f32::consts::PI,
        720.0 / 1480.0,
    )
    .camera();
    let [x, y] = camera.project(glam::Vec3::new(-3.0, 0.0, 3.0), 720.0, 1480.0).unwrap().map(|c| c / 2.0);
    let lines = browser_with("phone", &server.url, dir.path(), false, &[("DOLLHOUSE_TAP", format!("{x:.0},{y:.0}"))]);
    let centre = colour_at(&dir.path().join("phone.png"), 360, 600);
    assert!(near(centre, FACES[0][5], 24), "probe 0's −Z face on the phone: {centre:?}");
    // 240 CSS pixels = 480 device pixels of a 1480-pixel-high view at fov 68.8°: about 22°.
    let yaw = link_value(step(&lines, "swiped")["hash"].as_str().unwrap(), "yaw");
    assert!((yaw - 22.3).abs() < 4.0, "a swipe turns the view: {yaw}");
    let fov = link_value(step(&lines, "pinched")["hash"].as_str().unwrap(), "fov");
    assert!(fov < 60.0, "spreading two fingers zooms in: {fov}");
    let tapped = step(&lines, "tapped");
    assert_eq!(tapped["probe"], 1, "a tap on the path bar goes along the path");
    assert_eq!(step(&lines, "phone_dollhouse")["dollhouse"], true, "the dollhouse button");
    let shot = dir.path().join("phone_dollhouse.png");
    let ground = colour_at(&shot, (2.0 * x) as u32, (2.0 * y) as u32);
    assert!(near(ground, WEST, 8), "the west half under the finger: {ground:?}");
    assert_eq!(step(&lines, "phone_landed")["probe"], 0, "a tap on the west half lands at probe 0");
}

#[test]
fn the_web_viewer_shows_the_dollhouse_and_a_click_on_it_flies_to_the_probe_that_sees_that_point_best() {
    use exploremaps_viewer::dollhouse::Orbit;
    use glam::Vec3;
    if skip("EXPLOREMAPS_SKIP_BROWSER", "no headless Chromium on this machine") {
        return;
    }
    let (dir, server) = served(|_| {});
    // Where the viewer frames the ground: probe 0 faces yaw 0 on a 1280 × 720 page.
    let camera = Orbit::framing(Vec3::new(-5.0, 0.0, -5.0), Vec3::new(9.0, 0.0, 9.0), 0.0, 1280.0 / 720.0).camera();
    let pixel = |p: Vec3| camera.project(p, 1280.0, 720.0).unwrap().map(|c| c.round() as u32);
    let east_point = Vec3::new(7.0, 0.0, 2.0);
    let [tx, ty] = pixel(east_point);
    let lines = browser_with("dollhouse", &server.url, dir.path(), false, &[("TAP_X", tx.to_string()), ("TAP_Y", ty.to_string())]);
    let opened = step(&lines, "dollhouse");
    assert_eq!(opened["dollhouse"], true);
    assert!(opened["t_dollhouse_full"].as_f64().is_some(), "{opened}");
    let shot = dir.path().join("dollhouse.png");
    let [wx, wy] = pixel(Vec3::new(-3.0, 0.0, 3.0));
    assert!(near(colour_at(&shot, wx, wy), WEST, 6), "the west half in its colour: {:?}", colour_at(&shot, wx, wy));
    assert!(near(colour_at(&shot, tx, ty), EAST, 6), "the east half: {:?}", colour_at(&shot, tx, ty));
    // The click on the east half lands at probe 1, facing the clicked point.
    let landed = step(&lines, "landed");
    assert_eq!(landed["probe"], 1, "{landed}");
    let hash = landed["hash"].as_str().unwrap();
    let d = east_point - Vec3::new(4.0, 1.5, 0.0);
    let (yaw, pitch) = (d.x.atan2(-d.z).to_degrees(), (d.y / d.length()).asin().to_degrees());
    assert!(
        (link_value(hash, "yaw") - yaw).abs() < 1.5 && (link_value(hash, "pitch") - pitch).abs() < 1.5,
        "{hash}: wanted yaw {yaw}, pitch {pitch}"
    );
    assert_eq!(step(&lines, "floor")["dollhouse"], true, "back in the dollhouse");
}

#[test]
fn a_click_on_a_panorama_goes_to_the_probe_that_sees_that_point_best_facing_it() {
    if skip("EXPLOREMAPS_SKIP_BROWSER", "no headless Chromium on this machine") {
        return;
    }
    let (dir, server) = served(|_| {});
    let lines = browser("panorama_tap", &server.url, dir.path());
    // At probe 0 facing −Z, the click at the centre hits (0, 1.5, −3), which probe 1 sees
    // best: the viewer travels the path there and faces the point, not probe 1's +Z.
    let arrived = step(&lines, "arrived");
    assert_eq!(arrived["probe"], 1, "{arrived}");
    let yaw = link_value(arrived["hash"].as_str().unwrap(), "yaw");
    assert!((yaw - (-4f32).atan2(3.0).to_degrees()).abs() < 1.5, "{yaw}");
}

#[test]
fn the_web_viewer_says_when_the_proxy_is_corrupt_and_the_panoramas_go_on() {
    if skip("EXPLOREMAPS_SKIP_BROWSER", "no headless Chromium on this machine") {
        return;
    }
    let (dir, server) = served(|bundle| {
        let coarse = bundle.join("proxy/1.emmc");
        let mut bytes = std::fs::read(&coarse).unwrap();
        bytes[12] ^= 0x55;
        std::fs::write(&coarse, bytes).unwrap();
    });
    let lines = browser("dollhouse_broken", &server.url, dir.path());
    let broken = step(&lines, "broken");
    let message = broken["message"].as_str().unwrap_or_default();
    assert!(message.contains("3D overview") && message.contains("proxy/1.emmc"), "{message}");
    assert_eq!(broken["dollhouse"], false, "back to the panorama");
    let centre = colour_at(&dir.path().join("broken.png"), 640, 300);
    assert!(near(centre, FACES[0][5], 24), "probe 0's −Z face: {centre:?}");
}

fn other_version(dir: &Path) -> PathBuf {
    let bundle = dir.join("old");
    synthetic_bundle(&bundle);
    let text = std::fs::read_to_string(bundle.join("graph.json")).unwrap();
    std::fs::write(bundle.join("graph.json"), text.replacen("\"format_version\": 1", "\"format_version\": 99", 1)).unwrap();
    bundle
}

#[test]
fn the_web_viewer_refuses_another_format_version_with_a_message() {
    if skip("EXPLOREMAPS_SKIP_BROWSER", "no headless Chromium on this machine") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let server = serve(&other_version(dir.path()));
    let lines = browser("message", &server.url, dir.path());
    let message = step(&lines, "message")["message"].as_str().unwrap_or_default().to_string();
    assert!(message.contains("graph.json") && message.contains("format version 99"), "{message}");
}

#[test]
fn the_native_viewer_refuses_bad_bundles_and_links_before_opening_a_window() {
    let dir = tempfile::tempdir().unwrap();
    let old = other_version(dir.path());
    let out = exploremaps(&["view", old.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("format version 99") && stderr(&out).contains("graph.json"), "{}", stderr(&out));
    let missing = dir.path().join("nothing");
    for args in [vec!["view", missing.to_str().unwrap()], vec!["serve", missing.to_str().unwrap()]] {
        let out = exploremaps(&args);
        assert_ne!(out.status.code(), Some(0), "{args:?}");
        assert!(stderr(&out).contains("nothing"), "{args:?}: {}", stderr(&out));
    }
    let good = dir.path().join("good");
    synthetic_bundle(&good);
    let out = exploremaps(&["view", good.to_str().unwrap(), "--probe", "7"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("probe 7"), "{}", stderr(&out));
    let out = exploremaps(&["view", good.to_str().unwrap(), "--link", "yaw=left"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("yaw=left"), "{}", stderr(&out));
}

/// One raw HTTP/1.1 request; the status code and body.
fn get(url: &str, path: &str, range: Option<&str>) -> (u16, Vec<u8>) {
    let host = url.trim_start_matches("http://").trim_end_matches('/');
    let mut stream = std::net::TcpStream::connect(host).unwrap();
    let range = range.map(|r| format!("Range: {r}\r\n")).unwrap_or_default();
    write!(stream, "GET {path} HTTP/1.1\r\nHost: {host}\r\n{range}Connection: close\r\n\r\n").unwrap();
    let mut response = Vec::new();
    stream.read_to_end(&mut response).unwrap();
    let split = response.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8_lossy(&response[..split]).to_string();
    let status = head.split_whitespace().nth(1).unwrap().parse().unwrap();
    (status, response[split + 4..].to_vec())
}

#[test]
fn serve_serves_the_bundle_and_viewer_and_nothing_outside() {
    if skip("EXPLOREMAPS_SKIP_BROWSER", "no wasm toolchain for the web viewer") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let bundle = dir.path().join("b");
    synthetic_bundle(&bundle);
    std::fs::write(dir.path().join("secret.txt"), "TOP-SECRET").unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(dir.path().join("secret.txt"), bundle.join("link.txt")).unwrap();
    let server = serve(&bundle);
    let (status, body) = get(&server.url, "/", None);
    assert_eq!(status, 200);
    assert!(String::from_utf8_lossy(&body).contains("exploremaps.js"), "the viewer's page");
    assert_eq!(get(&server.url, "/viewer/exploremaps_bg.wasm", None).0, 200);
    let (status, body) = get(&server.url, "/graph.json", None);
    assert_eq!(status, 200);
    assert!(Graph::from_json(&String::from_utf8_lossy(&body)).is_ok());
    let whole = std::fs::read(bundle.join("paths/0.mp4")).unwrap();
    let (status, body) = get(&server.url, "/paths/0.mp4", Some("bytes=10-29"));
    assert_eq!((status, body.as_slice()), (206, &whole[10..30]));
    for bad in ["/../secret.txt", "/%2e%2e/secret.txt", "/probes/..%2f..%2fsecret.txt", "/link.txt"] {
        let (status, body) = get(&server.url, bad, None);
        assert!(status == 403 || status == 404, "{bad}: {status}");
        assert!(!String::from_utf8_lossy(&body).contains("TOP-SECRET"), "{bad}");
    }
    assert_eq!(get(&server.url, "/missing.jpg", None).0, 404);
}

#[test]
fn the_native_window_turns_with_keys_under_xvfb() {
    if skip("EXPLOREMAPS_SKIP_WINDOW", "no X virtual framebuffer on this machine") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let bundle = dir.path().join("b");
    synthetic_bundle(&bundle);
    let (before, after, log) = (dir.path().join("before.png"), dir.path().join("after.png"), dir.path().join("view.log"));
    // Open the window, look, press Right 20 times (20 × 0.08 rad ≈ 92°), look again.
    // On a loaded CI machine the viewer once found no X server although
    // xvfb-run had started one (a screenshot taken later worked): so wait until
    // the display answers, and start the viewer again if it exits without a window.
    let script = format!(
        "for i in $(seq 100); do xdotool getdisplaygeometry >/dev/null 2>&1 && break; sleep 0.1; done\n\
         for try in 1 2 3; do\n\
           {exe} view {b} > {log} 2>&1 & pid=$!; wid=\n\
           for i in $(seq 150); do wid=$(xdotool search --name ExploreMaps 2>/dev/null | head -1); [ -n \"$wid\" ] && break; kill -0 $pid 2>/dev/null || break; sleep 0.1; done\n\
           [ -n \"$wid\" ] && break; echo \"attempt $try opened no window\" >&2; kill $pid 2>/dev/null; wait $pid; sleep 1\n\
         done\n\
         sleep 2; import -window root {before}\n\
         xdotool windowfocus --sync $wid; xdotool key --delay 30 {keys}\n\
         sleep 1; import -window root {after}\n\
         kill $pid; wait $pid",
        exe = env!("CARGO_BIN_EXE_exploremaps"),
        b = bundle.display(),
        log = log.display(),
        before = before.display(),
        after = after.display(),
        keys = vec!["Right"; 20].join(" ")
    );
    let run = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1280x720x24", "bash", "-c", &script])
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .env("RUST_LOG", "info")
        .output()
        .expect("xvfb-run (scripts/setup.sh installs xvfb, xdotool and imagemagick; or set EXPLOREMAPS_SKIP_WINDOW=1)");
    let log = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(after.exists(), "no screenshot: {}\n{log}", stderr(&run));
    let (x, y) = (640, 300);
    assert!(near(colour_at(&before, x, y), FACES[0][5], 24), "probe 0's −Z face at first: {:?}\n{log}", colour_at(&before, x, y));
    assert!(near(colour_at(&after, x, y), FACES[0][0], 24), "its +X face after turning right: {:?}\n{log}", colour_at(&after, x, y));
    // Each key press turns by 0.08 rad and logs the new view.
    let views: Vec<&str> = log.lines().filter_map(|l| l.split("view: ").nth(1)).collect();
    let last = views.last().unwrap_or_else(|| panic!("no view lines in {log}"));
    assert!(views.len() >= 20 && (link_value(last, "yaw") - views.len() as f32 * 0.08f32.to_degrees()).abs() < 0.5, "{views:?}");
}

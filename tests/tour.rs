//! `exploremaps export`: the tour in Pannellum, Marzipano and Photo Sphere
//! Viewer (installed from npm by scripts/setup.sh), in headless Chromium.
//! The bundle is synthetic: each probe's panorama colours every direction
//! by its coordinates, so a screenshot compared with the view rendered here
//! from the cube says whether the viewer shows the right part of the right
//! face the right way round. Needs what tests/viewer.rs needs, unless
//! EXPLOREMAPS_SKIP_BROWSER=1.

use super::viewer::{push_path, serve, skip, synthetic_scene, writer};
use super::{exploremaps, stderr};
use exploremaps_format::{cube_direction, direction, CubeLevel, Graph, Probe, ProbeAssets, Tiles, ViewDirection, CUBE_FACES};
use std::path::Path;
use std::process::Command;

const FACE: u32 = 1024;

/// Probe `p`'s colour of direction `d`: smooth in the direction, with a
/// finer ripple, and the channels permuted from one probe to the next.
fn colour(p: usize, d: [f32; 3]) -> [f32; 3] {
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let [x, y, z] = d.map(|c| c / n);
    let ripple = 25.0 * (9.0 * x).sin() * (9.0 * y).sin();
    let c = [128.0 + 95.0 * x + ripple, 128.0 + 95.0 * y - ripple, 128.0 + 95.0 * z];
    if p == 0 {
        c
    } else {
        [c[2], c[0], c[1]]
    }
}

fn jpeg(img: &image::RgbImage) -> Vec<u8> {
    let mut bytes = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, 95).encode_image(img).unwrap();
    bytes
}

fn faces(p: usize) -> Vec<image::RgbImage> {
    (0..6)
        .map(|f| {
            image::RgbImage::from_fn(FACE, FACE, |x, y| {
                let d = cube_direction(f, (x as f32 + 0.5) / FACE as f32, (y as f32 + 0.5) / FACE as f32);
                image::Rgb(colour(p, d).map(|c| c.round().clamp(0.0, 255.0) as u8))
            })
        })
        .collect()
}

/// Two probes 4 m apart joined by a path; probe 0's tiles are in the bundle
/// (as `render` writes them), probe 1 has only whole faces (an older bundle:
/// the export cuts them).
fn bundle(dir: &Path) {
    let mut graph = Graph::new(synthetic_scene("tour test"));
    let write = writer(dir);
    let positions = [[0.0, 1.5, 0.0], [4.0, 1.5, 0.0]];
    for (p, position) in positions.iter().enumerate() {
        let images = faces(p);
        let names: [String; 6] = std::array::from_fn(|f| format!("probes/{p}/{FACE}_{}.jpg", CUBE_FACES[f]));
        for (image, name) in images.iter().zip(&names) {
            write(name, &jpeg(image));
        }
        let tiles = (p == 0).then(|| {
            let tiles = Tiles::new(format!("probes/{p}/tiles"), FACE, 512, 256);
            exploremaps_builder::tiles::cut(&tiles, &[(FACE, images)], |name, tile| {
                write(name, &jpeg(&tile));
                Ok::<_, ()>(())
            })
            .unwrap();
            tiles
        });
        let thumbnail = format!("thumbs/{p}.jpg");
        write(&thumbnail, &jpeg(&image::RgbImage::from_pixel(320, 180, image::Rgb([90, 90, 90]))));
        graph.probes.push(Probe {
            id: p as u32,
            position: *position,
            cluster: None,
            preferred_directions: vec![ViewDirection { yaw: [-0.5, 2.5][p], pitch: [0.0, 0.15][p], goodness: 1.0 }],
            user_placed: false,
            assets: ProbeAssets {
                cube_levels: vec![CubeLevel { size: FACE, faces: names }],
                thumbnail: Some(thumbnail),
                tiles,
                ..Default::default()
            },
        });
    }
    push_path(&mut graph, &write);
    graph.bar_order = vec![0, 1];
    write("graph.json", graph.to_json().as_bytes());
}

/// Path 0 as a glide, without its video, through a panorama half way: the
/// probes' depth and its, everything 3 away.
fn as_glide(dir: &Path) {
    use exploremaps_format::{depthcube::DepthCube, Transition, TransitionKind, Waypoint};
    let write = writer(dir);
    let mut graph = Graph::from_json(&std::fs::read_to_string(dir.join("graph.json")).unwrap()).unwrap();
    let depth = DepthCube::new(8, 0.1, 40.0, &[Some(3.0); 6 * 81]).encode();
    for p in 0..2 {
        let file = format!("probes/{p}/depth.emdc");
        write(&file, &depth);
        graph.probes[p].assets.depth = Some(file);
    }
    let path = &mut graph.paths[0];
    let key = path.camera.len() as u32 / 2;
    let faces: [String; 6] = std::array::from_fn(|f| format!("paths/0/{key}_{}.jpg", CUBE_FACES[f]));
    for (f, name) in faces.iter().enumerate() {
        let image = image::RgbImage::from_fn(64, 64, |x, y| {
            image::Rgb(colour(0, cube_direction(f, (x as f32 + 0.5) / 64.0, (y as f32 + 0.5) / 64.0)).map(|c| c.round().clamp(0.0, 255.0) as u8))
        });
        write(name, &jpeg(&image));
    }
    write(&format!("paths/0/{key}.emdc"), &depth);
    let waypoint =
        Waypoint { key, position: path.camera[key as usize].position, cube: CubeLevel { size: 64, faces }, depth: format!("paths/0/{key}.emdc") };
    path.assets.video = None;
    path.assets.transition = Some(Transition { kind: TransitionKind::Depth, unseen: 0.0, reason: "a glide".into(), waypoints: vec![waypoint] });
    graph.validate().unwrap();
    write("graph.json", graph.to_json().as_bytes());
}

/// Probe `p`'s view (yaw, pitch, vertical fov) at `width` × `height`, as a
/// perfect viewer shows it: each pixel's direction's colour (the faces are
/// that function, sampled).
fn reference(p: usize, view: &serde_json::Value, width: u32, height: u32) -> image::RgbImage {
    let (yaw, pitch, fov) = (view["yaw"].as_f64().unwrap() as f32, view["pitch"].as_f64().unwrap() as f32, view["fov"].as_f64().unwrap() as f32);
    let forward = glam::Vec3::from(direction(yaw, pitch));
    let right = glam::Vec3::new(yaw.cos(), 0.0, yaw.sin());
    let up = right.cross(forward);
    let half = (fov / 2.0).tan();
    let aspect = width as f32 / height as f32;
    image::RgbImage::from_fn(width, height, |x, y| {
        let a = (2.0 * (x as f32 + 0.5) / width as f32 - 1.0) * half * aspect;
        let b = (1.0 - 2.0 * (y as f32 + 0.5) / height as f32) * half;
        let c = colour(p, (forward + a * right + b * up).to_array());
        image::Rgb(c.map(|c| c.round().clamp(0.0, 255.0) as u8))
    })
}

/// The median absolute difference over the middle of the picture, in 8-bit
/// levels: margins hold the viewers' controls, and a link's marker can be
/// anywhere (the median passes over it).
fn difference(a: &image::RgbImage, b: &image::RgbImage) -> f64 {
    let (w, h) = a.dimensions();
    let mut errors = Vec::new();
    for y in h / 6..h - h / 6 {
        for x in w / 6..w - w / 6 {
            let (p, q) = (a.get_pixel(x, y), b.get_pixel(x, y));
            errors.push((0..3).map(|c| f64::from(p[c].abs_diff(q[c]))).sum::<f64>() / 3.0);
        }
    }
    errors.sort_by(f64::total_cmp);
    errors[errors.len() / 2]
}

/// The screenshot against the reference at the view the viewer reports,
/// and against views a little off (turned, tilted, another probe), which
/// must all be clearly worse.
fn check_view(viewer: &str, shot: &Path, probe: usize, view: &serde_json::Value) -> f64 {
    let img = image::open(shot).unwrap_or_else(|e| panic!("{}: {e}", shot.display())).to_rgb8();
    let (w, h) = img.dimensions();
    let right = difference(&img, &reference(probe, view, w, h));
    let off = |dyaw: f64, dpitch: f64, other: usize| {
        let mut v = view.clone();
        v["yaw"] = (v["yaw"].as_f64().unwrap() + dyaw).into();
        v["pitch"] = (v["pitch"].as_f64().unwrap() + dpitch).into();
        difference(&img, &reference(other, &v, w, h))
    };
    let wrong = [off(0.12, 0.0, probe), off(0.0, 0.12, probe), off(0.0, 0.0, 1 - probe)];
    eprintln!("{viewer} probe {probe}: {right:.1} levels from the reference; views a little off: {wrong:.1?}");
    assert!(right < 2.0, "{viewer} shows probe {probe} {right:.1} levels off the reference at {view} ({})", shot.display());
    for w in wrong {
        assert!(w > 3.0 * right, "{viewer}: a wrong view is as close ({w:.1}) as the right one ({right:.1})");
    }
    right
}

/// Views of the first probe (yaw, pitch, vertical fov): the side faces, then
/// through the top face and the bottom one, whose orientations viewers
/// disagree on most.
const VIEWS: [(f64, f64, f64); 3] = [(-1.0, 0.35, 1.0), (2.0, 1.1, 1.2), (0.7, -1.1, 1.2)];

/// Exports the bundle's tour into `out` for all three viewers, checking the
/// files and the refusals (an unknown viewer; a folder export did not write).
fn export_tours(bundle_dir: &Path, out: &Path, library: &Path) {
    let bad = exploremaps(&["export", bundle_dir.to_str().unwrap(), out.to_str().unwrap(), "--to", "pannellum,krpano"]);
    assert_eq!(bad.status.code(), Some(2), "{}", stderr(&bad));
    assert!(stderr(&bad).contains("krpano: not a tour viewer") && !out.exists(), "{}", stderr(&bad));
    let mixed = exploremaps(&["export", bundle_dir.to_str().unwrap(), out.to_str().unwrap(), "--to", "matterport3d,psv"]);
    assert!(mixed.status.code() == Some(2) && !out.exists(), "{}", stderr(&mixed));
    // The simulator's scan (its layout and arithmetic: builder/src/export/matterport/tests.rs).
    let scan = out.with_file_name("scan");
    let run = exploremaps(&["export", bundle_dir.to_str().unwrap(), scan.to_str().unwrap(), "--to", "matterport3d"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let scans = std::fs::read_to_string(scan.join("connectivity/scans.txt")).unwrap();
    let name = scans.trim();
    assert!(scan.join(format!("connectivity/{name}_connectivity.json")).exists(), "{scans}");
    assert!(scan.join(format!("data/v1/scans/{name}/matterport_skybox_images/{:032x}_skybox_small.jpg", 1)).exists());
    let run = exploremaps(&["export", bundle_dir.to_str().unwrap(), out.to_str().unwrap(), "--library", library.to_str().unwrap()]);
    assert!(run.status.success(), "{}", stderr(&run));
    // Probe 0's tiles were copied, probe 1's cut from its faces: the same
    // pyramid either way.
    for p in 0..2 {
        let tiles = Tiles::new(format!("tiles/{p}"), FACE, 512, 256);
        assert_eq!((tiles.levels, tiles.tile), (2, 512));
        for file in tiles.files().iter().chain([&tiles.preview]) {
            assert!(out.join(file).exists(), "{file} is missing");
        }
    }
    let pannellum: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("pannellum/tour.json")).unwrap()).unwrap();
    let spot = &pannellum["scenes"]["0"]["hotSpots"][0];
    assert_eq!((spot["type"].as_str(), spot["sceneId"].as_str()), (Some("scene"), Some("1")));
    assert!((spot["yaw"].as_f64().unwrap() - 90.0).abs() < 0.1 && (spot["targetYaw"].as_f64().unwrap() - 2.5f64.to_degrees()).abs() < 0.1, "{spot}");
    assert_eq!(pannellum["scenes"]["1"]["multiRes"]["maxLevel"], 2);
    let marzipano = std::fs::read_to_string(out.join("marzipano/data.js")).unwrap();
    assert!(marzipano.starts_with("var APP_DATA = ") && marzipano.contains("\"linkHotspots\"") && marzipano.contains("\"faceSize\": 1024"));
    // A second export replaces the first; a folder it did not write is refused.
    let again = exploremaps(&["export", bundle_dir.to_str().unwrap(), out.to_str().unwrap(), "--to", "psv", "--library", library.to_str().unwrap()]);
    assert!(again.status.success() && !out.join("pannellum").exists(), "{}", stderr(&again));
    let refused = exploremaps(&["export", bundle_dir.to_str().unwrap(), bundle_dir.to_str().unwrap()]);
    assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
    assert!(stderr(&refused).contains("is not a tour this command wrote"), "{}", stderr(&refused));
    let run = exploremaps(&["export", bundle_dir.to_str().unwrap(), out.to_str().unwrap(), "--library", library.to_str().unwrap()]);
    assert!(run.status.success(), "{}", stderr(&run));
}

#[test]
fn exported_tours_open_in_pannellum_marzipano_and_photo_sphere_viewer() {
    let dir = tempfile::tempdir().unwrap();
    let bundle_dir = dir.path().join("b");
    bundle(&bundle_dir);
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let library = root.join("target/node/node_modules");
    let out = dir.path().join("tour");
    export_tours(&bundle_dir, &out, &library);
    if skip("EXPLOREMAPS_SKIP_BROWSER", "the exported tours in Chromium") {
        return;
    }
    let server = serve(&out);
    let playwright = library.join("playwright-core/index.mjs");
    assert!(playwright.exists(), "{} is missing: run scripts/setup.sh (or set EXPLOREMAPS_SKIP_BROWSER=1)", playwright.display());
    let shots = dir.path().join("shots");
    std::fs::create_dir_all(&shots).unwrap();
    let viewers = ["pannellum", "marzipano", "psv"];
    let drive = |views: &str, under_way: &str| {
        let run = Command::new("node")
            .arg(root.join("tests/browser/tour.mjs"))
            .arg(&server.url)
            .arg(&shots)
            .args(viewers)
            .env("PLAYWRIGHT_CORE", &playwright)
            .envs([("VIEWS", views), ("FOLLOW", "1"), ("TO", "1"), ("UNDER_WAY", under_way)])
            .output()
            .expect("node (scripts/setup.sh installs it)");
        let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&run.stdout).lines().filter_map(|l| serde_json::from_str(l).ok()).collect();
        assert!(run.status.success(), "{}\n{lines:?}", stderr(&run));
        for l in &lines {
            // The missing video's request may be dropped: that is the fallback.
            let dropped_video =
                l["step"] == "requestfailed" && l["url"].as_str().is_some_and(|u| u.ends_with("/videos/0.mp4")) && !out.join("videos/0.mp4").exists();
            assert!(l["step"] != "error" && l["step"] != "pageerror" && (l["step"] != "requestfailed" || dropped_video), "{l}\nall: {lines:?}");
        }
        lines
    };
    let lines = drive(&VIEWS.map(|(y, p, f)| format!("{y},{p},{f}")).join(";"), "0");
    let step = |name: &str, viewer: &str| {
        lines.iter().find(|l| l["step"] == name && l["viewer"] == viewer).unwrap_or_else(|| panic!("no {name} for {viewer}: {lines:?}")).clone()
    };
    if let Ok(keep) = std::env::var("EXPLOREMAPS_KEEP_SHOTS") {
        for e in std::fs::read_dir(&shots).unwrap().flatten() {
            std::fs::create_dir_all(&keep).unwrap();
            std::fs::copy(e.path(), Path::new(&keep).join(e.file_name())).unwrap();
        }
    }
    for viewer in viewers {
        for (k, (yaw, pitch, _)) in VIEWS.into_iter().enumerate() {
            let first = lines
                .iter()
                .find(|l| l["step"] == "first" && l["viewer"] == viewer && l["k"] == k)
                .unwrap_or_else(|| panic!("no view {k} for {viewer}: {lines:?}"));
            let view = &first["view"];
            assert_eq!(view["scene"], "0", "{viewer} starts at the first probe of the bar");
            assert!((view["yaw"].as_f64().unwrap() - yaw).abs() < 0.01 && (view["pitch"].as_f64().unwrap() - pitch).abs() < 0.01, "{viewer}: {view}");
            check_view(viewer, &shots.join(format!("{viewer}-0-{k}.png")), 0, view);
        }
        let followed = step("followed", viewer);
        let (view, transition) = (&followed["view"], &followed["transition"]);
        assert_eq!(view["scene"], "1", "{viewer} follows the link: {followed}");
        assert_eq!(transition["kind"], "video", "{viewer} plays the path's video: {followed}");
        assert!(transition["frames"].as_u64().unwrap() >= 2, "{viewer} drew the video (frames come slowly on a busy CPU renderer): {followed}");
        assert!(
            (view["yaw"].as_f64().unwrap() - 2.5).abs() < 0.02 && (view["pitch"].as_f64().unwrap() - 0.15).abs() < 0.02,
            "{viewer} arrives facing the arrival direction: {view}"
        );
        check_view(viewer, &shots.join(format!("{viewer}-1.png")), 1, view);
    }
    // Without the video, each link falls back to the viewer's own change of
    // scene and still arrives facing the arrival direction.
    std::fs::remove_file(out.join("videos/0.mp4")).unwrap();
    let lines = drive("0,0,1", "0");
    for viewer in viewers {
        let followed =
            lines.iter().find(|l| l["step"] == "followed" && l["viewer"] == viewer).unwrap_or_else(|| panic!("no follow for {viewer}: {lines:?}"));
        let view = &followed["view"];
        assert_eq!((view["scene"].as_str(), followed["transition"]["kind"].as_str()), (Some("1"), Some("fade")), "{viewer}: {followed}");
        assert!(
            (view["yaw"].as_f64().unwrap() - 2.5).abs() < 0.02 && (view["pitch"].as_f64().unwrap() - 0.15).abs() < 0.02,
            "{viewer} arrives facing the arrival direction: {view}"
        );
    }
    // A path without video drawn as a glide: the two probes and the
    // panorama half way, in WebGL 2, in each viewer.
    as_glide(&bundle_dir);
    let run = exploremaps(&["export", bundle_dir.to_str().unwrap(), out.to_str().unwrap(), "--library", library.to_str().unwrap()]);
    assert!(run.status.success(), "{}", stderr(&run));
    for file in ["glide/p0.depth", "glide/p1.depth", "glide/w0-0.depth", "glide/w0-0/px.jpg", "glide/p1/nz.jpg"] {
        assert!(out.join(file).exists(), "{file} is missing");
    }
    let lines = drive("0,0,1", "1");
    for viewer in viewers {
        let followed =
            lines.iter().find(|l| l["step"] == "followed" && l["viewer"] == viewer).unwrap_or_else(|| panic!("no follow for {viewer}: {lines:?}"));
        let (view, transition) = (&followed["view"], &followed["transition"]);
        assert_eq!((view["scene"].as_str(), transition["kind"].as_str()), (Some("1"), Some("glide")), "{viewer}: {followed}");
        assert!(transition["frames"].as_u64().unwrap() >= 2, "{viewer} drew the glide: {followed}");
        // Under way the panoramas show: the colours of probe 0's or 1's
        // directions (each channel 33 to 223 before the ripple), not black.
        let shot = image::open(shots.join(format!("{viewer}-under-way.png"))).unwrap().to_rgb8();
        let (w, h) = shot.dimensions();
        let centre = shot.get_pixel(w / 2, h / 2);
        assert!(centre.0.iter().all(|&c| c > 8) && centre.0.iter().any(|&c| c > 60), "{viewer}: under way the centre is {centre:?}");
    }
}

//! End-to-end tests of the `exploremaps` command line.

use exploremaps_builder::plan::smooth::{MAX_DURATION_S, MIN_DURATION_S};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod tour;
mod viewer;

/// The binary under test. Bundles it renders copy the built web viewer, so
/// that is built first (once a run; see `viewer::web_viewer`): a rebuild of
/// an out-of-date viewer by the viewer tests could otherwise land between
/// two bundles that a test compares byte for byte.
fn exe() -> &'static str {
    viewer::web_viewer();
    env!("CARGO_BIN_EXE_exploremaps")
}

fn exploremaps(args: &[&str]) -> Output {
    Command::new(exe()).args(args).env("RUST_LOG", "warn").output().expect("run exploremaps")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The `triangles` count from `exploremaps info`.
fn info_triangles(scene: &str) -> usize {
    let out = exploremaps(&["info", scene]);
    assert!(out.status.success(), "info {scene} failed: {}", stderr(&out));
    let text = stdout(&out);
    let line = text.lines().find(|l| l.starts_with("triangles")).unwrap_or_else(|| panic!("no triangles line in {text}"));
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

fn shared_scenes() -> Option<PathBuf> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes");
    if path.exists() {
        Some(path)
    } else {
        eprintln!("SKIPPED: {} is absent (the shared test scenes are not next to this checkout)", path.display());
        None
    }
}

#[test]
fn info_works_on_every_builtin_scene() {
    assert!((50_000..=300_000).contains(&info_triangles("gallery")));
    assert!(info_triangles("maze:5") > 100);
    assert!(info_triangles("pillars") > 1_000);
    assert!(info_triangles("big:600000") >= 600_000);
    // The default scene is the gallery.
    let out = exploremaps(&["info"]);
    assert!(stdout(&out).contains("scene       gallery"));
}

#[test]
fn info_works_on_every_shared_scene() {
    let Some(dir) = shared_scenes() else { return };
    for (file, triangles) in [
        ("cornell_box/CornellBox-Original.obj", 36),
        ("stanford_bunny/bun_zipper.ply", 69_451),
        ("sponza_dabrovic/sponza.obj", 66_450),
        ("sponza_crytek/sponza_crytek.obj", 236_809),
    ] {
        let n = info_triangles(dir.join(file).to_str().unwrap());
        assert!(n <= triangles && n * 100 >= triangles * 99, "{file}: {n} of {triangles}");
    }
}

#[test]
fn scenes_lists_and_exports_builtins_that_load_back() {
    let out = exploremaps(&["scenes"]);
    for name in ["gallery", "maze", "pillars", "big"] {
        assert!(stdout(&out).contains(name), "{name} not listed");
    }
    let dir = tempfile::tempdir().unwrap();
    for file in ["maze.obj", "maze.glb"] {
        let path = dir.path().join(file);
        let out = exploremaps(&["scenes", "maze:4", "-o", path.to_str().unwrap()]);
        assert!(out.status.success(), "{}", stderr(&out));
        assert_eq!(info_triangles(path.to_str().unwrap()), info_triangles("maze:4"));
    }
    // A name of no format is the user's to fix (2); a folder that cannot be
    // written is a failure of the disk, not of the input (1).
    let unknown = exploremaps(&["scenes", "maze:4", "-o", dir.path().join("maze.txt").to_str().unwrap()]);
    assert_eq!(unknown.status.code(), Some(2), "{}", stderr(&unknown));
    std::fs::write(dir.path().join("a-file"), b"").unwrap();
    let unwritable = exploremaps(&["scenes", "maze:4", "-o", dir.path().join("a-file/maze.obj").to_str().unwrap()]);
    assert_eq!(unwritable.status.code(), Some(1), "{}", stderr(&unwritable));
    assert!(stderr(&unwritable).contains("a-file/maze"), "{}", stderr(&unwritable));
}

#[test]
fn bad_input_exits_2_with_a_message_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let cut = dir.path().join("cut.ply");
    std::fs::write(&cut, "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n")
        .unwrap();
    let binary = dir.path().join("noise.obj");
    std::fs::write(&binary, [0u8, 1, 2, 3, 255, 0, 7]).unwrap();
    let missing = dir.path().join("missing.glb");
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path.to_str().unwrap().to_string()
    };
    let cut_obj = write("cut.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 1.");
    let range_obj = write("range.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
    let empty_obj = write("empty.obj", b"# just a comment\n");
    let cut_glb = write("cut.glb", b"glTF\x02\x00\x00\x00\xff\xff\x00\x00\x10\x00\x00\x00JSON{\"asset\"");
    let unknown = dir.path().join("scene.blend");
    std::fs::write(&unknown, "x").unwrap();
    for (scene, needle) in [
        (missing.to_str().unwrap(), "missing.glb"),
        (unknown.to_str().unwrap(), "unknown scene format"),
        (cut.to_str().unwrap(), "cut.ply"),
        (binary.to_str().unwrap(), "binary data"),
        ("castle", "not a built-in scene"),
        (cut_obj.as_str(), "cut.obj"),
        (range_obj.as_str(), "out of bounds"),
        (empty_obj.as_str(), "no usable triangles"),
        (cut_glb.as_str(), "cut.glb"),
    ] {
        let out = exploremaps(&["info", scene]);
        assert_eq!(out.status.code(), Some(2), "{scene}: {}", stderr(&out));
        assert!(stderr(&out).contains(needle), "{scene}: {}", stderr(&out));
        assert!(!stderr(&out).contains("panicked"));
    }
    let out = exploremaps(&["info", "gallery", "--up", "sideways"]);
    assert_eq!(out.status.code(), Some(2));
    let out = exploremaps(&["info", "gallery", "--metres-per-unit", "-1"]);
    assert_eq!(out.status.code(), Some(2));
    let out = exploremaps(&["info", "--no-such-flag"]);
    assert_eq!(out.status.code(), Some(2), "clap reports usage errors with 2");
}

#[test]
fn recoverable_problems_are_warnings_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.png"), b"not an image").unwrap();
    std::fs::write(dir.path().join("m.mtl"), b"newmtl red\nKd 1 0 0\nmap_Kd bad.png\n").unwrap();
    let obj = dir.path().join("warn.obj");
    std::fs::write(&obj, b"mtllib m.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nf 1 2 3\nf 1 2 4\n").unwrap();
    let out = exploremaps(&["info", obj.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("bad.png") && err.contains("cannot be decoded"), "{err}");
    assert!(err.contains("warn.obj") && err.contains("1 non-finite"), "{err}");
    assert!(stdout(&out).contains("triangles   1 "));
}

/// Probe positions of a bundle, via the format crate (which validates it).
fn bundle_probes(dir: &Path) -> Vec<[f32; 3]> {
    let text = std::fs::read_to_string(dir.join("graph.json")).unwrap();
    let graph = exploremaps_format::Graph::from_json(&text).unwrap();
    graph.probes.iter().map(|p| p.position).collect()
}

#[test]
fn plan_writes_a_valid_bundle_with_coverage_and_pictures() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("maze");
    let o = out.to_str().unwrap();
    let run = exploremaps(&["plan", "maze:4", "-o", o, "--samples", "20000"]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(stdout(&run).contains("coverage"), "{}", stdout(&run));
    let probes = bundle_probes(&out);
    assert!(!probes.is_empty());
    let graph = exploremaps_format::Graph::from_json(&std::fs::read_to_string(out.join("graph.json")).unwrap()).unwrap();
    assert_eq!(graph.bar_order.len(), probes.len(), "every probe is in the thumbnail bar");
    assert!(graph.probes.iter().all(|p| !p.preferred_directions.is_empty()), "every probe has a preferred direction");
    if graph.probes.len() > 1 {
        assert!(!graph.paths.is_empty(), "probes are joined by paths");
        assert_eq!(graph.stats.stages["connect"]["components"], 1, "the maze is one connected space");
        assert_eq!(graph.stats.stages["smooth"]["blocked_segments"], 0);
        assert!(graph.paths.iter().all(|p| (MIN_DURATION_S..=MAX_DURATION_S).contains(&p.duration_s) && !p.camera.is_empty()));
    }
    let order = &graph.stats.stages["order"];
    assert!(order["cost"].as_f64().unwrap() <= order["random_cost"].as_f64().unwrap(), "{order}");
    let coverage: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("coverage.json")).unwrap()).unwrap();
    assert!(coverage["fraction"].as_f64().unwrap() > 0.98, "{coverage}");
    assert_eq!(coverage["baselines"].as_array().unwrap().len(), 2);
    // SCHEMA.md describes every field of coverage.json.
    let schema = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("format/SCHEMA.md")).unwrap();
    let section = schema.split("## `coverage.json`").nth(1).expect("SCHEMA.md has a coverage.json section");
    for field in coverage.as_object().unwrap().keys() {
        assert!(section.contains(&format!("`{field}`")), "SCHEMA.md's coverage.json section lacks `{field}`");
    }
    for picture in ["coverage_curve.png", "coverage_top.png", "coverage_view_0.png"] {
        let img = image::open(out.join(picture)).unwrap_or_else(|e| panic!("{picture}: {e}"));
        assert!(img.width() >= 200, "{picture}");
    }
    // No temporary files are left behind.
    assert!(std::fs::read_dir(&out).unwrap().all(|e| !e.unwrap().file_name().to_string_lossy().ends_with(".tmp")));

    // Same seed, one thread: the same probes.
    let again = dir.path().join("again");
    let run = exploremaps(&["--threads", "1", "plan", "maze:4", "-o", again.to_str().unwrap(), "--samples", "20000"]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert_eq!(bundle_probes(&again), probes);

    // `coverage` measures the bundle again, with more samples.
    let run = exploremaps(&["coverage", o, "--samples", "40000"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let coverage: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("coverage.json")).unwrap()).unwrap();
    assert_eq!(coverage["samples"].as_u64(), Some(40_000));
    assert_eq!(bundle_probes(&out), probes, "re-measuring keeps the probes");
}

#[test]
fn plan_user_probes_and_bad_planning_arguments() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p");
    let o = out.to_str().unwrap();
    let run = exploremaps(&["plan", "maze:3", "-o", o, "--samples", "5000", "--probe", "1,1.5,1", "--strategy", "occluded"]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert_eq!(bundle_probes(&out)[0], [1.0, 1.5, 1.0]);
    // Walk mode: every probe at eye height above the maze floor (y = 0).
    let walk = dir.path().join("walk");
    let run = exploremaps(&["plan", "maze:3", "-o", walk.to_str().unwrap(), "--samples", "5000", "--walk", "--eye-height-m", "1.5"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let probes = bundle_probes(&walk);
    assert!(!probes.is_empty() && probes.iter().all(|p| (p[1] - 1.5).abs() < 1e-3), "{probes:?}");
    for (args, needle) in [
        (vec!["--start", "1000,0,0"], "outside the scene's bounds"),
        (vec!["--start", "1,2"], "x,y,z"),
        (vec!["--coverage", "1.5"], "fraction"),
        (vec!["--max-cells", "3"], "max-cells"),
        (vec!["--space", "sideways"], "sideways"),
        (vec!["--walk", "--fly"], "--fly"),
        (vec!["--eye-height-m", "0"], "eye-height"),
    ] {
        let bad = dir.path().join("bad");
        let mut all = vec!["plan", "maze:3", "-o", bad.to_str().unwrap(), "--samples", "5000"];
        all.extend(args.iter());
        let run = exploremaps(&all);
        assert_eq!(run.status.code(), Some(2), "{args:?}: {}", stderr(&run));
        assert!(stderr(&run).contains(needle), "{args:?}: {}", stderr(&run));
        assert!(!bad.join("graph.json").exists());
    }
    let run = exploremaps(&["coverage", dir.path().join("nowhere").to_str().unwrap()]);
    assert_eq!(run.status.code(), Some(2));
    assert!(stderr(&run).contains("graph.json"));
    // A bundle of another format version, or a corrupt one, is refused with a clear message.
    let text = std::fs::read_to_string(out.join("graph.json")).unwrap();
    std::fs::write(out.join("graph.json"), text.replacen("\"format_version\": 1", "\"format_version\": 99", 1)).unwrap();
    for command in ["coverage", "render"] {
        let run = exploremaps(&[command, o]);
        assert_eq!(run.status.code(), Some(2), "{command}");
        assert!(stderr(&run).contains("version 99"), "{command}: {}", stderr(&run));
    }
    std::fs::write(out.join("graph.json"), &text[..text.len() / 2]).unwrap();
    let run = exploremaps(&["render", o]);
    assert_eq!(run.status.code(), Some(2));
    assert!(stderr(&run).contains("graph.json"), "{}", stderr(&run));
    // A probe moved into the floor slab: a bad bundle (exit 2), not a failure of the program.
    let mut graph = exploremaps_format::Graph::from_json(&text).unwrap();
    graph.probes[0].position[1] = graph.scene.bounds_min[1] + 0.01;
    std::fs::write(out.join("graph.json"), graph.to_json()).unwrap();
    let run = exploremaps(&["coverage", o]);
    assert_eq!(run.status.code(), Some(2), "{}", stderr(&run));
    assert!(stderr(&run).contains("graph.json") && stderr(&run).contains("start point"), "{}", stderr(&run));
}

/// Every probe's panorama, thumbnail and faces and every path's video and
/// poster are there at the sizes asked (`--face 64 --video-width 128`).
fn assert_assets_decode(one: &std::path::Path, graph: &exploremaps_format::Graph) {
    for p in &graph.probes {
        let pano = p.assets.equirect.as_ref().expect("graph.json lists the panorama");
        let img = image::open(one.join(pano)).unwrap();
        assert_eq!((img.width(), img.height()), (1024, 512));
        assert!(one.join(p.assets.thumbnail.as_ref().unwrap()).exists());
        let [level] = &p.assets.cube_levels[..] else { panic!("one cube level at --face 64: {:?}", p.assets.cube_levels) };
        for face in &level.faces {
            assert_eq!(image::open(one.join(face)).unwrap().width(), 64, "{face}");
        }
    }
    for p in &graph.paths {
        let video = std::fs::read(one.join(p.assets.video.as_ref().expect("graph.json lists the video"))).unwrap();
        let frames = exploremaps_format::video::decode_mp4(video).unwrap();
        assert_eq!(frames.len(), p.camera.len(), "a frame per camera key");
        assert_eq!((frames[0].width, frames[0].height), (128, 64));
        assert!(one.join(p.assets.poster.as_ref().unwrap()).exists());
    }
}

/// The 3D proxy: coded levels with a colour per vertex, vertex splits that
/// rebuild the finest level from the coarsest, and a GLB another parser reads.
fn assert_proxy_rebuilds(one: &std::path::Path, graph: &exploremaps_format::Graph) {
    // The 3D proxy: coded levels with a colour per vertex, and a GLB another parser reads.
    let proxy = graph.proxy.as_ref().expect("graph.json lists the proxy");
    assert!(!proxy.levels.is_empty());
    for level in &proxy.levels {
        let bytes = std::fs::read(one.join(&level.file)).unwrap();
        assert_eq!(bytes.len() as u64, level.bytes, "{}", level.file);
        let mesh = exploremaps_format::meshcode::decode(&bytes).unwrap();
        assert_eq!((mesh.triangles.len() as u64, mesh.colours.len()), (level.triangles, mesh.positions.len()), "{}", level.file);
    }
    // Its vertex splits rebuild the finest level from the coarsest, each
    // triangle with its point-to-go entry (a probe, or the probe count for none).
    let stream = proxy.stream.as_ref().expect("a 10-triangle level refined to 100 by vertex splits");
    let coarse = &proxy.levels[stream.from];
    let mut base = exploremaps_format::meshcode::decode(&std::fs::read(one.join(&coarse.file)).unwrap()).unwrap();
    let probes = graph.probes.len() as u32;
    let seen =
        exploremaps_format::seen::decode(&std::fs::read(one.join(coarse.seen.as_ref().unwrap())).unwrap(), base.triangles.len(), probes).unwrap();
    base.groups = seen.iter().map(|&p| p.min(probes)).collect();
    let mut refiner = exploremaps_format::splits::Refiner::new(base).unwrap();
    for (file, packets) in stream.files() {
        let bytes = std::fs::read(one.join(&file)).unwrap();
        assert_eq!(exploremaps_format::splits::packets(&bytes).unwrap().len(), packets.len(), "{file}");
        for k in packets {
            refiner.apply_packet(stream.packets[k].slice(&bytes).unwrap()).unwrap();
            assert_eq!(refiner.mesh.triangles.len() as u64, stream.packets[k].triangles);
        }
    }
    assert_eq!(refiner.mesh.triangles.len() as u64, proxy.levels[stream.to].triangles);
    assert!(refiner.mesh.groups.iter().all(|&p| p <= probes) && refiner.mesh.groups.iter().any(|&p| p < probes));
    let (document, buffers, _) = gltf::import(one.join(proxy.glb.as_ref().expect("a GLB"))).unwrap();
    let primitive = document.meshes().next().unwrap().primitives().next().unwrap();
    let reader = primitive.reader(|b| Some(&buffers[b.index()]));
    assert_eq!(reader.read_indices().unwrap().into_u32().count() as u64, 3 * proxy.levels[0].triangles);
    assert_eq!(reader.read_colors(0).expect("vertex colours").into_rgb_f32().count(), reader.read_positions().unwrap().count());
}

#[test]
fn render_fills_in_assets_resumably_and_in_shards() {
    let dir = tempfile::tempdir().unwrap();
    let one = dir.path().join("one");
    let run = exploremaps(&["plan", "maze:3", "-o", one.to_str().unwrap(), "--samples", "5000"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let sharded = dir.path().join("sharded");
    std::fs::create_dir_all(&sharded).unwrap();
    for entry in std::fs::read_dir(&one).unwrap().flatten() {
        std::fs::copy(entry.path(), sharded.join(entry.file_name())).unwrap();
    }
    // Videos (the glides have their own test below).
    let small = ["--quality", "preview", "--face", "64", "--video-width", "128", "--proxy-triangles", "100", "--transitions", "video"];
    let render = |bundle: &std::path::Path, extra: &[&str]| {
        let mut args = vec!["render", bundle.to_str().unwrap()];
        args.extend(small);
        args.extend(extra);
        exploremaps(&args)
    };
    let run = render(&one, &[]);
    assert!(run.status.success(), "{}", stderr(&run));
    let graph = exploremaps_format::Graph::from_json(&std::fs::read_to_string(one.join("graph.json")).unwrap()).unwrap();
    assert!(!graph.paths.is_empty());
    assert_assets_decode(&one, &graph);
    assert_proxy_rebuilds(&one, &graph);
    // Resuming renders nothing new and leaves the files untouched.
    let before = std::fs::metadata(one.join("probes/0/pano.jpg")).unwrap().modified().unwrap();
    let run = render(&one, &[]);
    assert!(stdout(&run).contains("rendered 0 probes and 0 paths,"), "{}", stdout(&run));
    assert_eq!(std::fs::metadata(one.join("probes/0/pano.jpg")).unwrap().modified().unwrap(), before);
    // After a kill mid-way (simulated: assets deleted, a stray temporary file left), only the missing ones are redone.
    std::fs::remove_file(one.join("probes/1/64_pz.jpg")).unwrap();
    std::fs::remove_file(one.join("paths/0.mp4")).unwrap();
    std::fs::write(one.join("paths/.0.mp4.tmp"), b"half a video").unwrap();
    let run = render(&one, &[]);
    assert!(stdout(&run).contains("rendered 1 probes and 1 paths"), "{}", stdout(&run));
    assert!(one.join("probes/1/64_pz.jpg").exists() && one.join("paths/0.mp4").exists());
    // Two shards produce the same files as one run; they leave graph.json to
    // --finalize, which refuses until every shard is done and every file decodes.
    let planned = std::fs::read(sharded.join("graph.json")).unwrap();
    let finalize = || exploremaps(&["render", sharded.to_str().unwrap(), "--finalize"]);
    let run = render(&sharded, &["--shard", "0/2"]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert_eq!(std::fs::read(sharded.join("graph.json")).unwrap(), planned, "a shard does not touch graph.json");
    let run = finalize();
    assert_eq!(run.status.code(), Some(1));
    assert!(
        stderr(&run).contains("shard 1/2 has not finished") && stderr(&run).contains("probes/1/pano.jpg (shard 1/2): missing"),
        "{}",
        stderr(&run)
    );
    let run = render(&sharded, &["--shard", "1/2"]);
    assert!(run.status.success(), "{}", stderr(&run));
    std::fs::write(sharded.join("probes/2/64_px.jpg"), b"\xff\xd8 torn").unwrap();
    let run = finalize();
    assert!(stderr(&run).contains("probes/2/64_px.jpg (shard 0/2): does not decode") && stderr(&run).contains("removed"), "{}", stderr(&run));
    assert_eq!(std::fs::read(sharded.join("graph.json")).unwrap(), planned);
    let run = render(&sharded, &["--shard", "0/2"]);
    assert!(stdout(&run).contains("rendered 1 probes and 0 paths"), "{}", stdout(&run));
    let run = finalize();
    assert!(run.status.success(), "{}", stderr(&run));
    assert_eq!(
        std::fs::read(sharded.join("graph.json")).unwrap(),
        std::fs::read(one.join("graph.json")).unwrap(),
        "finalize writes the graph one run writes"
    );
    for (name, bytes) in bundle_files(&one).into_iter().filter(|(n, _)| !n.to_string_lossy().ends_with(".tmp")) {
        assert!(std::fs::read(sharded.join(&name)).is_ok_and(|b| b == bytes), "{} differs", name.display());
    }
    // `build` is plan plus render.
    let built = dir.path().join("built");
    let mut args = vec!["build", "maze:3", "-o", built.to_str().unwrap(), "--samples", "5000"];
    args.extend(small);
    // Off a terminal (stderr is a pipe here) the render logs a line a finished asset.
    let run = Command::new(exe()).args(&args).env("RUST_LOG", "info").output().expect("run exploremaps");
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(built.join("probes/0/pano.jpg").exists() && built.join("paths/0.mp4").exists() && built.join("graph.json").exists());
    let graph = exploremaps_format::Graph::from_json(&std::fs::read_to_string(built.join("graph.json")).unwrap()).unwrap();
    // The probes, the paths and the proxy.
    let assets = graph.probes.len() + graph.paths.len() + 1;
    let log = stderr(&run);
    let lines: Vec<&str> = log.lines().filter(|l| l.contains("assets done after") && l.contains("left")).collect();
    assert_eq!(lines.len(), assets, "a line an asset:\n{log}");
    assert!(lines.last().unwrap().contains(&format!("rendering (preview quality): {assets}/{assets} assets")), "{log}");
    // Path traced with a real bounce and denoised.
    let denoised = dir.path().join("denoised");
    std::fs::create_dir_all(&denoised).unwrap();
    std::fs::copy(one.join("graph.json"), denoised.join("graph.json")).unwrap();
    let run = render(&denoised, &["--bounces", "1", "--spp", "4", "--denoise"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let g = exploremaps_format::Graph::from_json(&std::fs::read_to_string(denoised.join("graph.json")).unwrap()).unwrap();
    assert!(g.stats.render.as_ref().unwrap().denoised);
    assert!(g.probes.iter().all(|p| p.assets.equirect.is_some()));
    for bad in [
        vec!["--face", "7"],
        vec!["--video-width", "100"],
        vec!["--proxy-triangles", "5"],
        vec!["--spp", "0"],
        vec!["--bounces", "99"],
        vec!["--shard", "2/2"],
        vec!["--quality", "best"],
        vec!["--threads", "100000"],
    ] {
        let mut args = vec!["render", one.to_str().unwrap()];
        args.extend(bad.iter());
        let run = exploremaps(&args);
        assert_eq!(run.status.code(), Some(2), "{bad:?}");
        assert!(stderr(&run).contains(bad[0]), "{bad:?}: {}", stderr(&run));
    }
}

#[test]
fn transitions_give_each_path_a_glide_or_a_video_and_say_why() {
    let dir = tempfile::tempdir().unwrap();
    let planned = dir.path().join("planned");
    let run = exploremaps(&["plan", "maze:3", "-o", planned.to_str().unwrap(), "--samples", "5000"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let copy = |name: &str| {
        let to = dir.path().join(name);
        assert!(Command::new("cp").arg("-r").arg(&planned).arg(&to).status().unwrap().success());
        to
    };
    let small = ["--quality", "preview", "--face", "64", "--video-width", "128", "--proxy-triangles", "100"];
    let render = |bundle: &Path, extra: &[&str]| {
        let mut args = vec!["render", bundle.to_str().unwrap()];
        args.extend(small);
        args.extend(extra);
        exploremaps(&args)
    };
    for mode in ["depth", "auto"] {
        let b = copy(mode);
        let run = render(&b, &["--transitions", mode]);
        assert!(run.status.success(), "{}", stderr(&run));
        let graph = exploremaps_format::Graph::from_json(&std::fs::read_to_string(b.join("graph.json")).unwrap()).unwrap();
        assert_eq!(graph.stats.render.as_ref().unwrap().transitions.as_deref(), Some(mode));
        // Every probe's depth: a 32-cell lattice (preview), something hit in most directions.
        for p in &graph.probes {
            let cube = exploremaps_format::depthcube::DepthCube::decode(&std::fs::read(b.join(p.assets.depth.as_ref().unwrap())).unwrap()).unwrap();
            assert_eq!((cube.size, cube.codes.len()), (32, 6 * 33 * 33));
            assert!(cube.codes.iter().filter(|&&c| c > 0).count() > cube.codes.len() / 2);
        }
        // Every path: a transition with its reason; a video exactly where it says video.
        let (mut kinds, mut waypoints) = (Vec::new(), 0);
        for (id, p) in graph.paths.iter().enumerate() {
            let t = p.assets.transition.as_ref().expect("a transition");
            assert!(t.reason.contains("seen from neither end"), "{}", t.reason);
            let video = t.kind == exploremaps_format::TransitionKind::Video;
            assert_eq!(p.assets.video.is_some(), video, "path {id}: {}", t.reason);
            assert_eq!(b.join(format!("paths/{id}.mp4")).exists(), video, "path {id}");
            assert!(mode == "auto" || !video, "depth: no videos");
            // Panoramas part way: a cube half a video frame wide (128 / 2) and depth, each file there.
            for w in &t.waypoints {
                assert!(t.reason.contains("legs"), "{}", t.reason);
                assert_eq!(image::image_dimensions(b.join(&w.cube.faces[0])).unwrap(), (64, 64));
                exploremaps_format::depthcube::DepthCube::decode(&std::fs::read(b.join(&w.depth)).unwrap()).unwrap();
            }
            waypoints += t.waypoints.len();
            kinds.push(t.kind);
        }
        // Resuming does nothing more.
        let run = render(&b, &["--transitions", mode]);
        assert!(stdout(&run).contains("rendered 0 probes and 0 paths"), "{}", stdout(&run));
        if mode == "auto" {
            // Shards and finalize give the same bundle as one process.
            let sharded = copy("sharded");
            for shard in ["0/2", "1/2"] {
                let run = render(&sharded, &["--transitions", mode, "--shard", shard]);
                assert!(run.status.success(), "{}", stderr(&run));
            }
            let run = exploremaps(&["render", sharded.to_str().unwrap(), "--finalize"]);
            assert!(run.status.success(), "{}", stderr(&run));
            assert_eq!(std::fs::read(sharded.join("graph.json")).unwrap(), std::fs::read(b.join("graph.json")).unwrap());
            // A damaged depth cube is named, removed and redone by its shard.
            let depth = graph.probes[1].assets.depth.clone().unwrap();
            std::fs::write(sharded.join(&depth), b"EMDC torn").unwrap();
            let run = exploremaps(&["render", sharded.to_str().unwrap(), "--finalize"]);
            assert!(!run.status.success() && stderr(&run).contains(&format!("{depth} (shard 1/2): does not decode")), "{}", stderr(&run));
            println!("auto chose {kinds:?} with {waypoints} panoramas part way");
            assert!(waypoints >= 1, "a maze's corridor hides walls from both ends: a panorama part way");
        }
    }
}

#[test]
fn a_bundle_is_byte_identical_at_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    let build = |threads: &str| {
        let out = dir.path().join(format!("t{threads}"));
        let args = [
            "build",
            "maze:3",
            "-o",
            out.to_str().unwrap(),
            "--samples",
            "5000",
            "--quality",
            "preview",
            "--face",
            "64",
            "--video-width",
            "128",
            "--threads",
            threads,
        ];
        let run = exploremaps(&args);
        assert!(run.status.success(), "{}", stderr(&run));
        out
    };
    let (one, two) = (build("1"), build("2"));
    let (a, b) = (bundle_files(&one), bundle_files(&two));
    let names = |f: &[(PathBuf, Vec<u8>)]| f.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&a), names(&b), "the same files");
    // (The default, auto: glides, each path's record and each probe's depth.)
    for name in ["graph.json", "coverage.json", "proxy/0.emmc", "paths/0.json", "probes/0/pano.jpg", "probes/0/depth.emdc"] {
        assert!(names(&a).contains(&PathBuf::from(name)), "{name} is written");
    }
    assert!(one.join("timings.json").exists() && two.join("timings.json").exists());
    // The photo sphere: two faces wide (here the floor, 1024), tagged as one.
    let pano = one.join("probes/0/pano.jpg");
    assert_eq!(image::image_dimensions(&pano).unwrap(), (1024, 512));
    let tag = b"GPano:FullPanoWidthPixels=\"1024\"";
    assert!(std::fs::read(&pano).unwrap().windows(tag.len()).any(|w| w == tag), "GPano-tagged");
    let text = std::fs::read_to_string(one.join("graph.json")).unwrap();
    assert!(!text.contains("\"seconds"), "graph.json holds no timings");
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{} differs between 1 and 2 threads", name.display());
    }
}

/// Every file of a bundle but timings.json (which varies by design), with
/// its bytes, by path.
fn bundle_files(root: &std::path::Path) -> Vec<(PathBuf, Vec<u8>)> {
    bundle_names(root)
        .into_iter()
        .map(|name| {
            let bytes = std::fs::read(root.join(&name)).unwrap();
            (name, bytes)
        })
        .collect()
}

/// The paths of a bundle's files but timings.json, sorted. Safe to call while
/// a render writes into the bundle (entries that vanish are skipped).
fn bundle_names(root: &std::path::Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            let path = entry.path();
            if entry.file_type().is_ok_and(|t| t.is_dir()) {
                stack.push(path);
            } else if path.file_name().unwrap() != "timings.json" {
                out.push(path.strip_prefix(root).unwrap().to_path_buf());
            }
        }
    }
    out.sort();
    out
}

#[test]
fn renders_killed_at_random_moments_resume_to_the_same_bytes() {
    use rand::{Rng, SeedableRng};
    let dir = tempfile::tempdir().unwrap();
    let planned = dir.path().join("planned");
    let run = exploremaps(&["plan", "maze:3", "-o", planned.to_str().unwrap(), "--samples", "5000"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let render_args = |b: &std::path::Path| -> Vec<String> {
        ["render", b.to_str().unwrap(), "--quality", "preview", "--face", "64", "--video-width", "128", "--transitions", "video"]
            .map(str::to_string)
            .to_vec()
    };
    let copy = |to: &std::path::Path| {
        std::fs::create_dir_all(to).unwrap();
        for name in ["graph.json", "coverage.json"] {
            std::fs::copy(planned.join(name), to.join(name)).unwrap();
        }
    };
    // The uninterrupted run, timed.
    let whole = dir.path().join("whole");
    copy(&whole);
    let started = std::time::Instant::now();
    let run = exploremaps(&render_args(&whole).iter().map(String::as_str).collect::<Vec<_>>());
    assert!(run.status.success(), "{}", stderr(&run));
    let duration = started.elapsed();
    let reference = bundle_files(&whole);
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(19);
    let (mut interrupted, mut unfinished, mut temporaries) = (0, 0, 0);
    for kill in 0..20 {
        let b = dir.path().join(format!("k{kill}"));
        copy(&b);
        // Kill once a seeded number of the files is out, plus a seeded part
        // of one file's time: mid-render whatever the machine's load.
        // (Files come in bursts and the last burst ends the run, so the
        // count is drawn from the first two thirds.)
        let files = rng.random_range(2..reference.len() * 2 / 3);
        let extra = duration.mul_f64(rng.random_range(0.0..0.5) / reference.len() as f64);
        let mut child = Command::new(exe()).args(render_args(&b)).env("RUST_LOG", "error").stdout(std::process::Stdio::null()).spawn().unwrap();
        let started = std::time::Instant::now();
        while bundle_names(&b).iter().filter(|n| !n.to_string_lossy().ends_with(".tmp")).count() < files && child.try_wait().unwrap().is_none() {
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        std::thread::sleep(extra);
        let at = started.elapsed();
        interrupted += usize::from(child.try_wait().unwrap().is_none());
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        let before = bundle_files(&b);
        unfinished += usize::from(before.len() < reference.len());
        temporaries += before.iter().filter(|(n, _)| n.file_name().unwrap().to_string_lossy().ends_with(".tmp")).count();
        let run = exploremaps(&render_args(&b).iter().map(String::as_str).collect::<Vec<_>>());
        assert!(run.status.success(), "kill {kill} at {at:?}: {}", stderr(&run));
        let got = bundle_files(&b);
        let names = |f: &[(PathBuf, Vec<u8>)]| f.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
        assert_eq!(names(&got), names(&reference), "kill {kill} at {at:?}: the same files, no temporaries left");
        for ((name, a), (_, b)) in got.iter().zip(&reference) {
            assert!(a == b, "kill {kill} at {at:?}: {} differs from the uninterrupted run's", name.display());
        }
        std::fs::remove_dir_all(&b).unwrap();
    }
    println!("{interrupted} of 20 kills interrupted the render, {unfinished} before its last file, leaving {temporaries} temporary files in all");
    assert!(interrupted >= 15, "the kills must land mid-render: {interrupted} of 20 did");
}

#[test]
fn a_killed_render_leaves_only_whole_files_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let b = dir.path().join("b");
    let run = exploremaps(&["plan", "maze:3", "-o", b.to_str().unwrap(), "--samples", "5000"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let args = ["render", b.to_str().unwrap(), "--quality", "preview", "--face", "256", "--video-width", "256", "--transitions", "video"];
    let mut child = Command::new(exe()).args(args).env("RUST_LOG", "warn").stdout(std::process::Stdio::null()).spawn().unwrap();
    let started = std::time::Instant::now();
    while !b.join("probes/1/pano.jpg").exists() && started.elapsed().as_secs() < 120 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    // Whatever is there under its own name is whole.
    let mut whole = 0;
    let mut folders: Vec<PathBuf> = ["probes/0", "probes/1", "probes/2", "thumbs", "paths"].iter().map(|s| b.join(s)).collect();
    while let Some(folder) = folders.pop() {
        for entry in std::fs::read_dir(folder).into_iter().flatten().flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if entry.file_type().unwrap().is_dir() {
                // A probe's tiles.
                folders.push(entry.path());
                continue;
            }
            if name.starts_with('.') {
                continue;
            }
            if name.ends_with(".jpg") {
                image::open(entry.path()).unwrap_or_else(|e| panic!("{name}: {e}"));
            } else {
                exploremaps_format::video::decode_mp4(std::fs::read(entry.path()).unwrap()).unwrap();
            }
            whole += 1;
        }
    }
    assert!(whole >= 7, "the first probe's files were done before the kill: {whole}");
    let run = exploremaps(&args);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(!stdout(&run).contains(" 0 already there"), "finished probes are not redone: {}", stdout(&run));
    let graph = exploremaps_format::Graph::from_json(&std::fs::read_to_string(b.join("graph.json")).unwrap()).unwrap();
    assert!(graph.probes.iter().all(|p| p.assets.equirect.is_some()
        && p.assets.cube_levels.len() == 1
        && p.assets.tiles.as_ref().is_some_and(|t| (t.size, t.levels) == (256, 1))));
    assert!(graph.paths.iter().all(|p| p.assets.video.is_some()));
}

#[test]
fn a_slurm_job_array_renders_what_one_process_does_and_finalize_names_what_is_missing() {
    // scripts/slurm-test.sh starts a one-node cluster on localhost (it says
    // SKIPPED where Slurm or root is missing).
    let run = Command::new("scripts/slurm-test.sh").arg(exe()).output().unwrap();
    println!("{}", stdout(&run));
    assert!(run.status.success(), "{}{}", stdout(&run), stderr(&run));
    assert!(stdout(&run).contains("slurm-test: passed") || stdout(&run).contains("SKIPPED"), "{}", stdout(&run));
}

#[test]
fn the_kubernetes_job_manifests_match_the_job_schema() {
    let validator = std::path::Path::new("target/k8s-validate");
    if !validator.join("kubernetes_validate").exists() {
        println!("SKIPPED: target/k8s-validate is missing (scripts/setup.sh installs it)");
        return;
    }
    let validate = |files: &[&std::path::Path]| {
        let mut command = Command::new("python3");
        command.env("PYTHONPATH", validator).args(["-m", "kubernetes_validate", "-k", "1.30.0", "--strict"]).args(files);
        command.output().unwrap()
    };
    let (render, finalize) = (std::path::Path::new("deploy/kubernetes/render.yaml"), std::path::Path::new("deploy/kubernetes/finalize.yaml"));
    let run = validate(&[render, finalize]);
    assert!(run.status.success(), "{}{}", stdout(&run), stderr(&run));
    // The shard count is given once and must be the Job's completions.
    let text = std::fs::read_to_string(render).unwrap();
    assert!(text.contains("completions: 8") && text.contains("parallelism: 8") && text.contains("\"auto/8\""));
    // The check can fail: a completion count that is not a number.
    let dir = tempfile::tempdir().unwrap();
    let broken = dir.path().join("broken.yaml");
    std::fs::write(&broken, text.replace("completions: 8", "completions: eight")).unwrap();
    assert!(!validate(&[&broken]).status.success());
}

//! Render quality against a converged reference (issue: render quality; the
//! protocol is in docs/RENDER_QUALITY.md). For the `sunroom`, the gallery and
//! the Crytek Sponza (when present), from the first probe of a default plan:
//! - the reference: the project's path tracer with no cache, sampling the
//!   lights by multiple importance sampling (`Tracer::path_traced`),
//!   accumulated in batches until REF_SPP samples (default 1024) and kept in
//!   target/bench-quality (a rerun reuses it and a larger REF_SPP continues
//!   it). Every row is scored against it and against its image at half the
//!   samples: the reference is converged for that row when the score moves by
//!   less than 0.005 ("doubling" column). The FLIP between the two reference
//!   images themselves is printed too (a far stricter figure: noise against noise);
//! - `final` panoramas (cube faces rendered at 2048², compared at 1024² as the
//!   viewer's 1024 level), `final` video frames (1024 × 512 equirectangular,
//!   resampled to 256² faces, their resolution), the frame farthest from both
//!   key frames on a walk four keys long (back and forth through the eye, so
//!   keys carry the history of the keys before), and the cache read at the
//!   first hit (the renderer before the final gather) for comparison;
//! - mean FLIP (NVIDIA's flip-evaluator, LDR, 67 pixels a degree) over the six
//!   faces, PSNR beside it, and seconds. Goals: panoramas ≤ 0.05, video ≤ 0.08.
//!
//! - Blender's Cycles (the `bpy` wheel, `blender_cycles.py`) on the same views
//!   and lights: its own reference (no denoiser, CYCLES_REF_SPP, default 1024,
//!   at FACE) against ours, and a sweep of its samples with OIDN (CYCLES_SPP,
//!   default 1,4,16,64, at CYCLES_FACE, default 2048, the bundle's faces; 0
//!   turns Cycles off) beside our panorama at the same size; it prints how long
//!   Cycles needs to reach our panorama's FLIP (goal: ≥ 5× ours, our share of
//!   the bake counted).
//!
//! Needs `scripts/bench-env.sh` once (FLIP and bpy); without it the table
//! shows PSNR only. `cargo bench -p exploremaps-builder --bench quality`;
//! SCENES=sunroom,gallery,crytek narrows it (or names other built-in scenes: maze, house, ...;
//! or the shared scenes staircase, livingroom, apartment), FACE sets the compared face size,
//! REF_SPP the reference's samples, FACES=2 compares only the faces named (90° views: 0-5 are
//! +x -x +y -y +z -z), LIGHTS=sun,sky,points,emitters keeps only
//! those lights and NO_TEXTURES=1 drops textures (to check each against Cycles); VIDEO_GATHER and
//! PANORAMA_GATHER=rays,step[,passes[,near]], VIDEO_SPREAD / PANORAMA_SPREAD=x, VIDEO_WIDEN / PANORAMA_WIDEN=passes,x, VIDEO_KEYS=n, VIDEO_HISTORY=rays (0: keys gather alone), VIDEO_ANTIALIAS=0, SUN_RAYS=n and CACHE_GATHER=n (gather rays a cache cell) try
//! other settings. REF_BOUNCES=n (1 or more) caps the reference's bounces and Cycles' at n
//! (to see at which bounce the two part), CYCLES_LIGHT_THRESHOLD sets Cycles'
//! light threshold (0.01 by default, 0 off), CYCLES_GUIDING=1 turns Cycles' path
//! guiding on, DROP_OBJECTS=a,b leaves out the objects whose names start so.

use exploremaps_builder::colour::srgb_to_linear;
use exploremaps_builder::plan::{plan, PlanParams};
use exploremaps_builder::raycast::RayScene;
use exploremaps_builder::scene_io::{load, LoadOptions};
use exploremaps_builder::tracer::{downsample, psnr, to_image, Quality, Renderer, Settings, TraceParams, Tracer};
use exploremaps_format::cube_direction;
use exploremaps_scenes::{BuiltIn, Scene};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What the bench compares and how, from the environment (see the header).
struct Options {
    out: PathBuf,
    python: PathBuf,
    has_flip: bool,
    scenes: Vec<String>,
    face: u32,
    ref_spp: u32,
    /// The compared cube faces (0-5: +x -x +y -y +z -z), as 90° views.
    views: Vec<usize>,
    /// The face size both renderers render at for the Cycles comparison (0: none).
    cycles_face: u32,
    cycles_ref: u32,
    cycles_spp: Vec<u32>,
    lights: Option<String>,
    untextured: bool,
    drop: Option<String>,
    ref_bounces: Option<u32>,
}

fn var<T: std::str::FromStr>(name: &str) -> Option<T> {
    std::env::var(name).ok().and_then(|s| s.parse().ok())
}

impl Options {
    fn from_env(root: &Path) -> Options {
        let out = root.join("target/bench-quality");
        std::fs::create_dir_all(&out).unwrap();
        let python = root.join("target/bench-py/bin/python");
        let imports =
            |module: &str| std::process::Command::new(&python).args(["-c", &format!("import {module}")]).output().is_ok_and(|o| o.status.success());
        let has_flip = imports("flip_evaluator");
        if !has_flip {
            println!("no FLIP package: run scripts/bench-env.sh once; PSNR only");
        }
        // FACES=2,4: a reference at 1024² costs hours for six faces here.
        let views: Vec<usize> =
            std::env::var("FACES").map_or((0..6).collect(), |v| v.split(',').filter_map(|f| f.trim().parse().ok()).filter(|&f| f < 6).collect());
        assert!(!views.is_empty(), "FACES names no face of 0-5");
        let list = |v: String| v.split(',').map(|s| s.trim().to_string()).collect::<Vec<_>>();
        Options {
            out,
            has_flip,
            scenes: std::env::var("SCENES").map_or(vec!["sunroom".into(), "gallery".into(), "crytek".into()], list),
            face: var("FACE").unwrap_or(1024),
            ref_spp: var("REF_SPP").unwrap_or(1024),
            views,
            cycles_face: var("CYCLES_FACE").unwrap_or(if imports("bpy") { 2048 } else { 0 }),
            cycles_ref: var("CYCLES_REF_SPP").unwrap_or(1024),
            cycles_spp: list(std::env::var("CYCLES_SPP").unwrap_or("1,4,16,64".into())).iter().filter_map(|n| n.parse().ok()).collect(),
            lights: std::env::var("LIGHTS").ok(),
            untextured: std::env::var("NO_TEXTURES").is_ok_and(|v| v == "1"),
            drop: std::env::var("DROP_OBJECTS").ok(),
            ref_bounces: var::<u32>("REF_BOUNCES").filter(|&n| n > 0),
            python,
        }
    }

    /// Whether LIGHTS keeps this kind of light (sun, sky, points, emitters).
    fn keep(&self, kind: &str) -> bool {
        self.lights.as_ref().is_none_or(|l| l.split(',').any(|k| k == kind))
    }

    /// What the options change, for the cached files' names.
    fn tag(&self) -> String {
        self.lights.as_ref().map_or(String::new(), |l| format!("-{}", l.replace(',', "+")))
            + if self.untextured { "-untextured" } else { "" }
            + &self.drop.as_ref().map_or(String::new(), |d| format!("-without-{}", d.replace(',', "+")))
            + &self.ref_bounces.map_or(String::new(), |n| format!("-b{n}"))
    }
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let options = Options::from_env(&root);
    let mut report = Report::default();
    for (name, mut scene) in load_scenes(&root, &options) {
        restrict(&mut scene, &options);
        compare_scene(&options, &name, &scene, &mut report);
    }
    report.print(&options.out);
}

/// The scenes SCENES names: built-in ones by name, shared ones by short name.
fn load_scenes(root: &Path, options: &Options) -> Vec<(String, Scene)> {
    // (file, metres a unit when the file does not say).
    let shared = |name: &str| match name {
        "crytek" => Some(("sponza_crytek/sponza_crytek.obj", Some(0.2))),
        "staircase" => Some(("wooden_staircase/wooden_staircase.obj", Some(1.0))),
        "livingroom" => Some(("grey_white_room/grey_white_room.obj", Some(1.0))),
        "apartment" => Some(("dream_apartment/dream_apartment.glb", None)),
        _ => None,
    };
    let mut scenes = Vec::new();
    for name in &options.scenes {
        if let Some((file, metres_per_unit)) = shared(name) {
            match load(&root.join("../shared/scenes").join(file), &LoadOptions { metres_per_unit, ..Default::default() }) {
                Ok(s) => scenes.push((name.clone(), s)),
                Err(e) => println!("SKIPPED {name}: {e}"),
            }
        } else {
            match BuiltIn::parse(name) {
                Some(b) => scenes.push((name.clone(), b.generate(1))),
                None => println!("SKIPPED {name}: not a built-in scene"),
            }
        }
    }
    scenes
}

/// LIGHTS, NO_TEXTURES and DROP_OBJECTS: leaves out lights, textures and
/// objects (to find which part of a scene two renderers disagree on).
fn restrict(scene: &mut Scene, options: &Options) {
    scene.lights.retain(|l| match l {
        exploremaps_scenes::Light::Sun { .. } => options.keep("sun"),
        exploremaps_scenes::Light::Point { .. } => options.keep("points"),
    });
    for m in &mut scene.materials {
        if !options.keep("emitters") {
            m.emissive = Vec3::ZERO;
        }
        if options.untextured {
            m.base_color_texture = None;
        }
    }
    if let Some(prefixes) = &options.drop {
        let gone: Vec<bool> = scene.objects.iter().map(|o| prefixes.split(',').any(|p| o.starts_with(p))).collect();
        let keep: Vec<usize> = (0..scene.triangles.len()).filter(|&t| !scene.triangle_object.get(t).is_some_and(|&o| gone[o as usize])).collect();
        scene.triangles = keep.iter().map(|&t| scene.triangles[t]).collect();
        scene.triangle_material = keep.iter().filter_map(|&t| scene.triangle_material.get(t).copied()).collect();
        scene.triangle_object = keep.iter().filter_map(|&t| scene.triangle_object.get(t).copied()).collect();
    }
}

/// `final` settings with the environment's overrides (VIDEO_KEYS,
/// VIDEO_ANTIALIAS, SUN_RAYS, CACHE_GATHER, *_GATHER, *_WIDEN, VIDEO_HISTORY, *_SPREAD).
fn tuned_settings() -> Settings {
    let mut settings = Settings::new(Quality::Final, 1);
    if let Some(n) = var("VIDEO_KEYS") {
        settings.video_keys = n;
    }
    settings.video.antialias &= std::env::var("VIDEO_ANTIALIAS").map_or(true, |v| v != "0");
    if let Some(n) = var("SUN_RAYS") {
        (settings.panorama.sun_rays, settings.video.sun_rays) = (n, n);
    }
    if let Some(n) = var("CACHE_GATHER") {
        settings.gather_rays = n;
    }
    for (prefix, params) in [("VIDEO", &mut settings.video), ("PANORAMA", &mut settings.panorama)] {
        let Some(g) = params.gather.as_mut() else { continue };
        // rays,step[,passes[,near]]
        let n: Vec<u32> = std::env::var(format!("{prefix}_GATHER")).unwrap_or_default().split(',').filter_map(|x| x.parse().ok()).collect();
        if let &[rays, step, ..] = &n[..] {
            (g.rays, g.step, g.passes, g.near) = (rays, step, n.get(2).copied().unwrap_or(g.passes), n.get(3).copied().unwrap_or(g.near));
        }
        // passes,x: at most that many more passes where the filter reaches less than x R.
        let widen =
            std::env::var(format!("{prefix}_WIDEN")).ok().and_then(|v| v.split_once(',').and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?))));
        if let Some(widen) = widen {
            g.widen = widen;
        }
        if let Some(x) = var(&format!("{prefix}_SPREAD")) {
            g.spread = x;
        }
    }
    // Rays of video keys that average with the key before (0: keys gather alone).
    if let (Some(g), Some(n)) = (settings.video.gather.as_mut(), var("VIDEO_HISTORY")) {
        g.history_rays = n;
    }
    settings
}

/// One scene under comparison: its renderer (cache baked) and the eye, the
/// first probe of a default plan.
struct Subject<'a> {
    name: &'a str,
    scene: &'a Scene,
    options: &'a Options,
    renderer: Renderer<'a>,
    eye: Vec3,
    /// Seconds the cache took to bake, and how many probes share it.
    bake: f64,
    probes: usize,
    video_width: u32,
}

impl<'a> Subject<'a> {
    fn new(options: &'a Options, name: &'a str, scene: &'a Scene, rays: &'a RayScene) -> Subject<'a> {
        let planned = plan(scene, name, &PlanParams::default()).expect("plan");
        let graph = &planned.graph;
        let mut viewpoints: Vec<Vec3> = graph.probes.iter().map(|p| Vec3::from(p.position)).collect();
        viewpoints.extend(graph.paths.iter().flat_map(|p| p.camera.iter().step_by(10).map(|k| Vec3::from(k.position))));
        let t = Instant::now();
        let mut renderer = Renderer::new(scene, rays, &viewpoints, tuned_settings());
        if !options.keep("sky") {
            renderer.tracer.lighting.sky = exploremaps_builder::tracer::Sky::NONE;
        }
        let bake = t.elapsed().as_secs_f64();
        let video_width = exploremaps_builder::render::Settings::new(Quality::Final, 1).video_width;
        Subject { name, scene, options, renderer, eye: viewpoints[0], bake, probes: graph.probes.len().max(1), video_width }
    }

    /// Saves the compared faces (`views`, in that order) as images.
    fn save(&self, tag: &str, size: u32, faces: &[Vec<Vec3>]) -> Vec<PathBuf> {
        faces
            .iter()
            .zip(&self.options.views)
            .map(|(c, f)| {
                let path = self.options.out.join(format!("{}-{tag}-{f}.png", self.name));
                to_image(size, size, c, self.renderer.exposure).save(&path).unwrap();
                path
            })
            .collect()
    }

    /// The compared faces of a cube from `faces` (all six), box-filtered to FACE.
    fn views_of(&self, faces: &[exploremaps_builder::tracer::Frame], size: u32) -> Vec<Vec<Vec3>> {
        self.options.views.iter().map(|&f| shrink(&faces[f].color, size, self.options.face)).collect()
    }

    /// The compared faces of an equirectangular frame, at `size`.
    fn views_of_frame(&self, frame: &[Vec3], size: u32) -> Vec<Vec<Vec3>> {
        self.options.views.iter().map(|&f| cube_from_equirect(frame, self.video_width, f, size)).collect()
    }
}

/// One method's images beside the reference's (and the reference's at half its samples).
struct Row {
    method: String,
    seconds: f64,
    images: Vec<PathBuf>,
    reference: Vec<PathBuf>,
    half: Option<Vec<PathBuf>>,
}

/// The converged reference's images: at FACE, and at the video frames' size
/// (`small`), each also at half the samples.
struct References {
    full: Vec<Vec<Vec3>>,
    paths: Vec<PathBuf>,
    half_paths: Vec<PathBuf>,
    small: u32,
    small_paths: Vec<PathBuf>,
    small_half_paths: Vec<PathBuf>,
    seconds: f64,
}

impl References {
    fn new(subject: &Subject, pure: &Tracer) -> References {
        let o = subject.options;
        let key = format!("{}{}-{:08x}", subject.name, o.tag(), fingerprint(subject.scene));
        let (half, full, seconds) = reference(pure, o, &key, subject.eye);
        // Video frames are compared at about their own resolution (or FACE, when smaller).
        let small = o.face.min(256);
        let small_of = |img: &[Vec<Vec3>]| -> Vec<Vec<Vec3>> { img.iter().map(|f| shrink(f, o.face, small)).collect() };
        References {
            paths: subject.save("reference", o.face, &full),
            half_paths: subject.save(&format!("reference-{}spp", o.ref_spp / 2), o.face, &half),
            small_paths: subject.save("reference-small", small, &small_of(&full)),
            small_half_paths: subject.save("reference-small-half", small, &small_of(&half)),
            full,
            small,
            seconds,
        }
    }

    /// A row scored against the reference at FACE.
    fn row(&self, method: String, seconds: f64, images: Vec<PathBuf>) -> Row {
        Row { method, seconds, images, reference: self.paths.clone(), half: Some(self.half_paths.clone()) }
    }

    /// A row scored against the reference at the video frames' size.
    fn small_row(&self, method: String, seconds: f64, images: Vec<PathBuf>) -> Row {
        Row { method, seconds, images, reference: self.small_paths.clone(), half: Some(self.small_half_paths.clone()) }
    }
}

/// The tables printed at the end, over all scenes.
#[derive(Default)]
struct Report {
    table: Vec<String>,
    summary: Vec<String>,
}

impl Report {
    fn print(&self, out: &Path) {
        println!("\nscene    method                                  FLIP  doubling  PSNR  seconds");
        println!(
            "(goals: panorama ≤ 0.05, video ≤ 0.08; the reference is converged for a row when doubling its samples moves the row's FLIP by < 0.005)"
        );
        for line in self.table.iter().chain(&self.summary) {
            println!("{line}");
        }
        println!("images in {}", out.display());
    }
}

fn compare_scene(options: &Options, name: &str, scene: &Scene, report: &mut Report) {
    let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
    let subject = Subject::new(options, name, scene, &rays);
    let pure = Tracer::path_traced(scene, &rays, subject.renderer.tracer.lighting.clone(), &[subject.eye]);
    // ALBEDO=1: compare only the two renderers' first-hit albedo, what
    // each takes every surface's reflectance to be.
    if albedo_only() {
        compare_albedo(&subject, &pure);
        return;
    }
    let refs = References::new(&subject, &pure);
    let (o, settings) = (options, &subject.renderer.settings);
    let mut rows = vec![Row {
        method: format!("reference at {} spp vs {}", o.ref_spp / 2, o.ref_spp),
        seconds: refs.seconds,
        images: refs.half_paths.clone(),
        reference: refs.paths.clone(),
        half: None,
    }];
    let before = TraceParams { gather: None, ..settings.panorama };
    for (tag, params) in [("cache at first hit (before)", before), ("final panorama", settings.panorama)] {
        rows.push(panorama_row(&subject, &refs, tag, &params, 2048));
    }
    for (tag, params) in [
        ("video, cache at first hit (before)", TraceParams { gather: None, ..settings.video }),
        ("video, centres only (no antialiasing)", TraceParams { antialias: false, ..settings.video }),
        ("final video frame", settings.video),
    ] {
        let t = Instant::now();
        let frame = subject.renderer.equirect(&params, subject.eye, subject.video_width, 0);
        let seconds = t.elapsed().as_secs_f64();
        let faces = subject.views_of_frame(&frame.color, refs.small);
        rows.push(refs.small_row(tag.to_string(), seconds, subject.save(&tag.replace([' ', ','], "_"), refs.small, &faces)));
    }
    rows.push(walk_row(&subject, &refs));
    let cycles_rows = if o.cycles_face > 0 { compare_cycles(&subject, &refs, &mut rows) } else { Vec::new() };
    let flips = score(o, &rows);
    print_rows(&subject, &rows, &flips, report);
    if let Some(line) = cycles_speed(&subject, &rows, &cycles_rows, &flips) {
        println!("{line}");
        report.summary.push(line);
    }
}

/// A panorama rendered with `params` at `size`² faces, scored at FACE.
fn panorama_row(subject: &Subject, refs: &References, tag: &str, params: &TraceParams, size: u32) -> Row {
    let t = Instant::now();
    let faces = subject.renderer.cube(params, subject.eye, size, 0);
    let seconds = t.elapsed().as_secs_f64();
    let faces = subject.views_of(&faces, size);
    refs.row(tag.to_string(), seconds, subject.save(&tag.replace([' ', ',', '²'], "_"), subject.options.face, &faces))
}

/// A walk back and forth through the eye at 1.4 m/s, 25 frames a second,
/// four key frames long (so keys carry the history of the keys before, as
/// along a real path): the frame at the eye in the last stretch is the one
/// farthest from both key frames.
fn walk_row(subject: &Subject, refs: &References) -> Row {
    let settings = &subject.renderer.settings;
    let interval = settings.video_keys as usize;
    let walk = Vec3::X * (1.4 / 25.0 / subject.scene.metres_per_unit);
    let along = |i: usize| {
        let p = i % (2 * interval);
        (if p <= interval { p } else { 2 * interval - p }) as f32 - (interval / 2) as f32
    };
    let eyes: Vec<Vec3> = (0..=3 * interval).map(|i| subject.eye + walk * along(i)).collect();
    let t = Instant::now();
    let mut middle = None;
    let mut done = vec![];
    subject.renderer.path_frames(&settings.video, &eyes, subject.video_width, 0, settings.video_keys, |i, frame| {
        done.push(t.elapsed().as_secs_f64());
        if i == 2 * interval + interval / 2 {
            middle = Some(frame);
        }
        std::ops::ControlFlow::Continue(())
    });
    let seconds = t.elapsed().as_secs_f64() / eyes.len() as f64;
    // Frames between keys are handed over as each is rendered: the median gap is one's cost.
    let mut gaps: Vec<f64> = done.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort_by(f64::total_cmp);
    let between = gaps[gaps.len() / 2];
    let faces = subject.views_of_frame(&middle.expect("the middle frame").color, refs.small);
    let tag = format!("final video, between keys ({between:.3} s; mean of {})", eyes.len());
    refs.small_row(tag, seconds, subject.save("final_video_between_keys", refs.small, &faces))
}

/// ALBEDO=1: the first-hit albedo of both renderers, and Cycles' over ours per face.
fn compare_albedo(subject: &Subject, pure: &Tracer) {
    let (o, eye, name) = (subject.options, subject.eye, subject.name);
    let params = TraceParams { samples: 64, bounces: 1, baked_points: false, gather: None, antialias: false, sun_rays: 1, seed: 7 };
    let ours: Vec<Vec<Vec3>> =
        o.views.iter().map(|&f| pure.render(&params, eye, o.face, o.face, f as u64, |a, b| Vec3::from(cube_direction(f, a, b))).albedo).collect();
    subject.save("albedo", o.face, &ours);
    match cycles(subject, &[("albedo".into(), 64, false, o.face)], 0, &o.out.join(format!("cycles-albedo-{name}"))) {
        Err(e) => println!("Cycles albedo comparison failed: {e}"),
        Ok(done) => {
            let theirs: Vec<Vec<Vec3>> = o.views.iter().map(|&f| done[0].3[f].clone()).collect();
            subject.save("cycles_albedo", o.face, &theirs);
            let mean = |f: &[Vec3]| f.iter().copied().sum::<Vec3>() / f.len() as f32;
            let ratios: Vec<String> = theirs.iter().zip(&ours).map(|(c, o)| format!("{:.3}", mean(c) / mean(o))).collect();
            println!("{name}: Cycles' first-hit albedo over ours, per face (r, g, b): {}", ratios.join(" "));
        }
    }
}

/// Cycles: its converged reference against ours, then its samples with OIDN.
/// Adds their rows (and ours at CYCLES_FACE when that is not the bundle's
/// 2048); returns (row, samples, seconds) of ours and then each Cycles row.
fn compare_cycles(subject: &Subject, refs: &References, rows: &mut Vec<Row>) -> Vec<(usize, u32, f64)> {
    let (o, name) = (subject.options, subject.name);
    let dir = o.out.join(format!("cycles-{name}{}", o.tag()));
    // The sweep at the compared renders' size; Cycles' own reference at the scored size.
    let runs: Vec<(String, u32, bool, u32)> = o
        .cycles_spp
        .iter()
        .map(|&n| (format!("{n}-oidn-{}", o.cycles_face), n, true, o.cycles_face))
        .chain([(format!("{}-reference-{}", o.cycles_ref, o.face), o.cycles_ref, false, o.face)])
        .collect();
    let done = match cycles(subject, &runs, o.ref_bounces.unwrap_or(64), &dir) {
        Err(e) => {
            println!("Cycles comparison failed: {e}");
            return Vec::new();
        }
        Ok(done) => done,
    };
    let mut cycles_rows = Vec::new();
    if o.cycles_face != 2048 {
        let tag = format!("final panorama, {}² faces", o.cycles_face);
        let row = panorama_row(subject, refs, &tag, &subject.renderer.settings.panorama, o.cycles_face);
        cycles_rows.push((rows.len(), 0, row.seconds));
        rows.push(row);
    } else {
        cycles_rows.push((2, 0, rows[2].seconds));
    }
    for (tag, samples, size, faces, seconds) in done {
        let faces: Vec<Vec<Vec3>> = o.views.iter().map(|&f| faces[f].clone()).collect();
        if tag.contains("reference") {
            // Noise aside, do the two renderers compute the same light? Mean radiance per face.
            let mean = |f: &[Vec3]| f.iter().map(|c| c.dot(Vec3::ONE)).sum::<f32>() / f.len() as f32;
            let ratios: Vec<String> = faces.iter().zip(&refs.full).map(|(c, o)| format!("{:.3}", mean(c) / mean(o))).collect();
            println!("{name}: Cycles' {samples}-sample mean radiance over the reference's, per face: {}", ratios.join(" "));
        }
        let faces: Vec<Vec<Vec3>> = faces.iter().map(|f| shrink(f, size, o.face)).collect();
        cycles_rows.push((rows.len(), samples, seconds));
        let tag = if tag.contains("reference") {
            format!("Cycles {samples} spp, no denoiser, {size}²")
        } else {
            format!("Cycles {samples} spp + OIDN, {size}² faces")
        };
        let images = subject.save(&tag.replace([' ', ',', '²', '+'], "_"), o.face, &faces);
        rows.push(refs.row(tag, seconds, images));
    }
    cycles_rows
}

/// Mean FLIP of each row against the reference, and against the reference at
/// half its samples (None without FLIP or when it failed).
fn score(options: &Options, rows: &[Row]) -> Vec<Option<(f64, Option<f64>)>> {
    if !options.has_flip {
        return vec![None; rows.len()];
    }
    let args: Vec<&PathBuf> = rows
        .iter()
        .flat_map(|r| {
            let full = r.reference.iter().zip(&r.images).flat_map(|(a, b)| [a, b]);
            let half = r.half.iter().flat_map(|h| h.iter().zip(&r.images).flat_map(|(a, b)| [a, b]));
            full.chain(half)
        })
        .collect();
    let flip_script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/flip.py");
    let run = std::process::Command::new(&options.python).arg(&flip_script).args(&args).output().expect("python");
    let values: Vec<f64> = String::from_utf8_lossy(&run.stdout).lines().filter_map(|l| l.trim().parse().ok()).collect();
    let complete = values.len() == args.len() / 2;
    if !complete {
        println!("FLIP failed: {}", String::from_utf8_lossy(&run.stderr));
    }
    let mut next = values.chunks(options.views.len()).map(|v| v.iter().sum::<f64>() / v.len() as f64);
    rows.iter()
        .map(|r| {
            let full = next.next();
            let half = if r.half.is_some() { next.next() } else { None };
            complete.then(|| (full.unwrap_or(f64::NAN), half))
        })
        .collect()
}

/// Prints a scene's rows and adds them to the final table.
fn print_rows(subject: &Subject, rows: &[Row], flips: &[Option<(f64, Option<f64>)>], report: &mut Report) {
    let name = subject.name;
    println!(
        "\n{name}: eye {:.2}, {} triangles, cache bake {:.1} s ({}), exposure {:.2}",
        subject.eye,
        subject.scene.triangles.len(),
        subject.bake,
        subject.renderer.tracer.lighting.description,
        subject.renderer.exposure
    );
    for (row, flip) in rows.iter().zip(flips) {
        let db: f64 = row
            .images
            .iter()
            .zip(&row.reference)
            .map(|(a, b)| psnr(&image::open(a).unwrap().to_rgb8(), &image::open(b).unwrap().to_rgb8()))
            .sum::<f64>()
            / subject.options.views.len() as f64;
        // How much the score moves when the reference's samples double.
        let change = match flip {
            Some((f, Some(h))) => format!("{:+.4}", f - h),
            _ => "-".to_string(),
        };
        let flip = flip.map_or("-".to_string(), |f| format!("{:.4}", f.0));
        let (tag, seconds) = (&row.method, row.seconds);
        println!("  {tag:<38} FLIP {flip:>7} ({change:>7} on doubling the reference)   PSNR {db:>5.1} dB   {seconds:>7.2} s");
        report.table.push(format!("{name:<8} {tag:<38} {flip:>7} {change:>8} {db:>5.1} {seconds:>7.2}"));
    }
}

/// Seconds Cycles (with OIDN) needs to reach our panorama's FLIP, interpolated
/// between its sample counts on log time; our side carries its share of the bake.
fn cycles_speed(subject: &Subject, rows: &[Row], cycles_rows: &[(usize, u32, f64)], flips: &[Option<(f64, Option<f64>)>]) -> Option<String> {
    let name = subject.name;
    let &(ours_row, _, ours_s) = cycles_rows.first()?;
    let flip_of = |row: usize| flips[row].map(|f| f.0);
    let (probes, share) = (subject.probes, subject.bake / subject.probes as f64);
    let ours = ours_s + share;
    let denoised: Vec<(f64, f64)> =
        cycles_rows[1..].iter().filter(|r| !rows[r.0].method.contains("no denoiser")).filter_map(|r| flip_of(r.0).map(|f| (r.2, f))).collect();
    let target = flip_of(ours_row)?;
    let reach = denoised.windows(2).find_map(|w| {
        let ((t0, f0), (t1, f1)) = (w[0], w[1]);
        (f1 <= target && f0 > target).then(|| (t0.ln() + (t1.ln() - t0.ln()) * (f0 - target) / (f0 - f1)).exp())
    });
    let first = denoised.first().filter(|d| d.1 <= target);
    Some(match (reach, first) {
        (None, Some(&(t, f))) => format!("{name}: Cycles + OIDN's fewest samples already reach our panorama's FLIP {target:.4} ({f:.4}) in {t:.1} s: at most {:.1}x against our {ours:.1} s", t / ours),
        (Some(t), _) => format!("{name}: Cycles + OIDN reaches our panorama's FLIP {target:.4} in {t:.1} s; ours {ours:.1} s ({ours_s:.1} s + the bake's {share:.1} s shared by {probes} probes): {:.1}x (goal ≥ 5x)", t / ours),
        (None, None) => format!("{name}: Cycles + OIDN did not reach our panorama's FLIP {target:.4} within its sweep: more than {:.1}x", denoised.last().map_or(0.0, |d| d.0) / ours),
    })
}

/// A checksum of what a reference image depends on in the scene (geometry,
/// materials, textures, lights), so that a cached reference is not reused
/// once a scene's generator or loader changes.
fn fingerprint(scene: &exploremaps_scenes::Scene) -> u32 {
    let mut h = crc32fast::Hasher::new();
    for p in scene.positions.iter().chain(&scene.normals) {
        p.to_array().iter().for_each(|x| h.update(&x.to_le_bytes()));
    }
    for t in &scene.triangles {
        t.iter().for_each(|i| h.update(&i.to_le_bytes()));
    }
    scene.uvs.iter().for_each(|uv| uv.to_array().iter().for_each(|x| h.update(&x.to_le_bytes())));
    scene.triangle_material.iter().for_each(|m| h.update(&m.to_le_bytes()));
    h.update(format!("{:?}{:?}", scene.materials, scene.lights).as_bytes());
    scene.textures.iter().for_each(|t| h.update(t.image.as_raw()));
    h.finalize()
}

/// The faces `views` (all six by default) at FACE² by plain path tracing, accumulated in batches of
/// 32 samples; the images at half and at all the samples are kept on disk and
/// reused: (at half the samples, at all, seconds spent now).
fn reference(pure: &Tracer, options: &Options, name: &str, eye: Vec3) -> (Vec<Vec<Vec3>>, Vec<Vec<Vec3>>, f64) {
    let (out, face, spp, views) = (&options.out, options.face, options.ref_spp, &options.views);
    let bounces = options.ref_bounces.unwrap_or(0);
    const BATCH: u32 = 32;
    assert!(spp.is_multiple_of(2 * BATCH), "REF_SPP must be a multiple of {}", 2 * BATCH);
    let n = (face * face) as usize;
    let some = if views.len() < 6 { format!("-faces{}", views.iter().map(usize::to_string).collect::<String>()) } else { String::new() };
    let key = format!("{name}-{face}-{:.3}_{:.3}_{:.3}{some}", eye.x, eye.y, eye.z);
    let file = |samples: u32| out.join(format!("ref-{key}-{samples}.bin"));
    let load = |samples: u32| -> Option<Vec<Vec<Vec3>>> {
        let bytes = std::fs::read(file(samples)).ok().filter(|b| b.len() == views.len() * 12 * n)?;
        Some(
            bytes
                .chunks_exact(12 * n)
                .map(|f| {
                    f.chunks_exact(12)
                        .map(|c| Vec3::from_array(std::array::from_fn(|k| f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap()))))
                        .collect()
                })
                .collect(),
        )
    };
    let save = |samples: u32, img: &[Vec<Vec3>]| {
        let bytes: Vec<u8> = img.iter().flatten().flat_map(|v| v.to_array()).flat_map(f32::to_le_bytes).collect();
        std::fs::write(file(samples), bytes).unwrap();
    };
    let started = Instant::now();
    let half = load(spp / 2);
    if let (Some(half), Some(full)) = (&half, load(spp)) {
        return (half.clone(), full, 0.0);
    }
    // Sums of radiance over the samples so far.
    let (mut sum, mut done) = match &half {
        Some(h) => (h.iter().map(|f| f.iter().map(|c| *c * (spp / 2) as f32).collect()).collect(), spp / 2),
        None => (vec![vec![Vec3::ZERO; n]; views.len()], 0),
    };
    let mean = |sum: &Vec<Vec<Vec3>>, k: u32| -> Vec<Vec<Vec3>> { sum.iter().map(|f| f.iter().map(|c| *c / k as f32).collect()).collect() };
    while done < spp {
        let params =
            TraceParams { samples: BATCH, bounces, baked_points: false, gather: None, antialias: false, sun_rays: 1, seed: 0xF00D + done as u64 };
        for (&f, s) in views.iter().zip(sum.iter_mut()) {
            let frame = pure.render(&params, eye, face, face, f as u64, |a, b| Vec3::from(cube_direction(f, a, b)));
            s.iter_mut().zip(&frame.color).for_each(|(a, c)| *a += *c * BATCH as f32);
        }
        done += BATCH;
        if done == spp / 2 {
            save(done, &mean(&sum, done));
        }
        eprint!("\r{name}: reference {done}/{spp} samples ");
    }
    eprintln!();
    let full = mean(&sum, spp);
    save(spp, &full);
    (load(spp / 2).expect("the half-way reference"), full, started.elapsed().as_secs_f64())
}

/// `ALBEDO=1`: both renderers give first-hit albedo only (read by the bench's
/// loop and by the spec it writes for Cycles).
fn albedo_only() -> bool {
    std::env::var("ALBEDO").is_ok_and(|v| v == "1")
}

/// Box-filters a square image from `from` to `to` pixels a side (powers of two).
fn shrink(img: &[Vec3], from: u32, to: u32) -> Vec<Vec3> {
    let mut img = img.to_vec();
    let mut size = from;
    while size > to {
        img = downsample(size, &img);
        size /= 2;
    }
    img
}

/// One cube face, `size`² pixels, from an equirectangular image: each pixel
/// the mean of s × s bilinear samples over its square, s enough that they lie
/// no farther apart than the image's pixels at the equator (a face spans a
/// quarter of its width). Panoramas are box-filtered down to the scored size
/// ([`shrink`]); one sample a pixel here would alias a frame against its
/// reference wherever the face is smaller than the frame (four frame pixels
/// a face pixel at 64² faces from 1,024-wide frames), and score that, not
/// the render.
fn cube_from_equirect(eq: &[Vec3], width: u32, face: usize, size: u32) -> Vec<Vec3> {
    let height = width / 2;
    let s = (width / 4).div_ceil(size).max(1);
    let bilinear = |u: f32, v: f32| {
        let d = Vec3::from(cube_direction(face, u, v));
        let (yaw, pitch) = exploremaps_format::yaw_pitch(d.into());
        let x = (yaw / std::f32::consts::TAU).rem_euclid(1.0) * width as f32 - 0.5;
        let y = (0.5 - pitch / std::f32::consts::PI) * height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor().clamp(0.0, height as f32 - 1.0));
        let (fx, fy) = (x - x0, (y - y0).clamp(0.0, 1.0));
        let at = |xx: f32, yy: f32| eq[(yy.min(height as f32 - 1.0) as u32 * width + (xx as i64).rem_euclid(width as i64) as u32) as usize];
        (at(x0, y0) * (1.0 - fx) + at(x0 + 1.0, y0) * fx) * (1.0 - fy) + (at(x0, y0 + 1.0) * (1.0 - fx) + at(x0 + 1.0, y0 + 1.0) * fx) * fy
    };
    (0..size * size)
        .map(|i| {
            let (px, py) = ((i % size) as f32, (i / size) as f32);
            let sub = |k: u32| (k as f32 + 0.5) / s as f32;
            (0..s * s).map(|k| bilinear((px + sub(k % s)) / size as f32, (py + sub(k / s)) / size as f32)).sum::<Vec3>() / (s * s) as f32
        })
        .collect()
}

/// Renders the six faces from `eye` with Blender's Cycles (builder/benches/blender_cycles.py,
/// the `bpy` wheel) for each run (tag, samples, denoise): the scene is written to
/// `dir` in Blender's axes with the renderer's lights. Returns (tag, samples,
/// linear faces, seconds of the six renders).
#[allow(clippy::type_complexity)]
fn cycles(
    subject: &Subject,
    runs: &[(String, u32, bool, u32)],
    bounces: u32,
    dir: &Path,
) -> Result<Vec<(String, u32, u32, Vec<Vec<Vec3>>, f64)>, String> {
    std::fs::create_dir_all(dir).map_err(|e| e.to_string())?;
    write_mesh(subject.scene, dir)?;
    let materials = write_materials(subject.scene, dir)?;
    let spec = cycles_spec(subject, materials, runs, bounces);
    std::fs::write(dir.join("scene.json"), serde_json::to_string_pretty(&spec).unwrap()).map_err(|e| e.to_string())?;
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/blender_cycles.py");
    eprintln!("Cycles: {} runs of six faces...", runs.len());
    let run = std::process::Command::new(&subject.options.python).arg(&script).arg(dir).output().map_err(|e| e.to_string())?;
    if !run.status.success() {
        return Err(String::from_utf8_lossy(&run.stderr).lines().rev().take(8).collect::<Vec<_>>().join(" | "));
    }
    read_cycles_runs(&String::from_utf8_lossy(&run.stdout), dir)
}

/// ExploreMaps is Y up, Blender Z up: (x, y, z) -> (x, -z, y).
fn z_up(v: Vec3) -> [f32; 3] {
    [v.x, -v.z, v.y]
}

/// The scene's mesh for blender_cycles.py: positions, triangles, materials, uvs, normals.
fn write_mesh(scene: &Scene, dir: &Path) -> Result<(), String> {
    let mut mesh: Vec<u8> = Vec::new();
    mesh.extend(scene.positions.iter().flat_map(|&p| z_up(p)).flat_map(f32::to_le_bytes));
    mesh.extend(scene.triangles.iter().flatten().flat_map(|i| i.to_le_bytes()));
    mesh.extend(
        (0..scene.triangles.len())
            .flat_map(|t| scene.triangle_material.get(t).copied().unwrap_or(u32::MAX).min(scene.materials.len() as u32).to_le_bytes()),
    );
    // Blender's texture rows run bottom to top.
    mesh.extend(scene.uvs.iter().flat_map(|uv| [uv.x, 1.0 - uv.y]).flat_map(f32::to_le_bytes));
    // Shading normals, if the scene has them (the script shades flat otherwise, as
    // this renderer does; Blender's default, smooth, lit the Crytek Sponza's creases).
    mesh.extend(scene.normals.iter().flat_map(|&n| z_up(n)).flat_map(f32::to_le_bytes));
    std::fs::write(dir.join("mesh.bin"), mesh).map_err(|e| e.to_string())
}

/// The materials for blender_cycles.py, their textures written beside them.
fn write_materials(scene: &Scene, dir: &Path) -> Result<Vec<serde_json::Value>, String> {
    use serde_json::json;
    // Textures as linear floats (rows bottom to top), so Cycles filters linear values as this
    // renderer does; given the sRGB bytes, it interpolates before decoding (measured 8-15 %
    // darker on the gallery's textured walls).
    let mut textures = Vec::new();
    for (i, t) in scene.textures.iter().enumerate() {
        let path = dir.join(format!("texture-{i}.bin"));
        let (w, h) = t.image.dimensions();
        let texels: Vec<u8> = (0..h)
            .rev()
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .flat_map(|(x, y)| {
                let p = t.image.get_pixel(x, y).0;
                [srgb_to_linear(p[0]), srgb_to_linear(p[1]), srgb_to_linear(p[2]), p[3] as f32 / 255.0]
            })
            .flat_map(f32::to_le_bytes)
            .collect();
        std::fs::write(&path, texels).map_err(|e| e.to_string())?;
        textures.push(json!({"path": path, "width": w, "height": h}));
    }
    let mut materials: Vec<serde_json::Value> = scene
        .materials
        .iter()
        .map(|m| {
            let cutoff = match m.alpha_mode {
                exploremaps_scenes::AlphaMode::Opaque => None,
                exploremaps_scenes::AlphaMode::Mask { cutoff } => Some(cutoff),
                exploremaps_scenes::AlphaMode::Blend => Some(0.5),
            };
            json!({"albedo": &m.base_color[..3], "alpha": m.base_color[3], "texture": m.base_color_texture.map(|t| &textures[t]), "cutoff": cutoff.filter(|_| m.base_color_texture.is_some()), "emission": m.emissive.to_array()})
        })
        .collect();
    // Triangles without a material: the renderer's default grey.
    materials.push(json!({"albedo": [0.7, 0.7, 0.7], "alpha": 1.0, "texture": null, "cutoff": null, "emission": [0.0, 0.0, 0.0]}));
    Ok(materials)
}

/// What blender_cycles.py renders: the scene, our lights, the eye's six faces and the runs.
fn cycles_spec(subject: &Subject, materials: Vec<serde_json::Value>, runs: &[(String, u32, bool, u32)], bounces: u32) -> serde_json::Value {
    use serde_json::json;
    let (scene, eye) = (subject.scene, subject.eye);
    let lighting = &subject.renderer.tracer.lighting;
    let sky = lighting.sky;
    let sky_rows: Vec<[f32; 3]> = (0..512)
        .map(|j| {
            {
                let e = ((j as f32 + 0.5) / 512.0 - 0.5) * std::f32::consts::PI;
                sky.radiance(Vec3::new(0.0, e.sin(), e.cos()))
            }
            .to_array()
        })
        .collect();
    let faces: Vec<serde_json::Value> = (0..6)
        .map(|f| {
            let at = |a: f32, b: f32| Vec3::from(cube_direction(f, a, b));
            let forward = at(0.5, 0.5).normalize();
            let right = (at(1.0, 0.5) - at(0.5, 0.5)).normalize();
            let up = (at(0.5, 0.0) - at(0.5, 0.5)).normalize();
            json!({"forward": z_up(forward), "right": z_up(right), "up": z_up(up)})
        })
        .collect();
    json!({
        "name": scene.name,
        "vertices": scene.positions.len(),
        "triangles": scene.triangles.len(),
        "uvs": !scene.uvs.is_empty(),
        "normals": !scene.normals.is_empty(),
        "materials": materials,
        "suns": lighting.suns.iter().map(|&(d, e)| json!({"direction": z_up(d), "irradiance": e.to_array(), "angle": 2.0 * exploremaps_builder::tracer::SUN_RADIUS})).collect::<Vec<_>>(),
        "points": lighting.points.iter().map(|&(p, i)| json!({"position": z_up(p), "intensity": i.to_array()})).collect::<Vec<_>>(),
        "sky_rows": if sky.zenith == Vec3::ZERO && sky.horizon == Vec3::ZERO && sky.ground == Vec3::ZERO { serde_json::Value::Null } else { json!(sky_rows) },
        "eye": z_up(eye),
        "faces": faces,
        "threads": rayon::current_num_threads(),
        "guiding": std::env::var("CYCLES_GUIDING").is_ok_and(|v| v == "1"),
        "light_threshold": std::env::var("CYCLES_LIGHT_THRESHOLD").ok().and_then(|v| v.parse::<f32>().ok()).unwrap_or(0.01),
        "bounces": bounces,
        "albedo_only": albedo_only(),
        "runs": runs.iter().map(|(tag, samples, denoise, size)| json!({"tag": tag, "samples": samples, "denoise": denoise, "size": size})).collect::<Vec<_>>(),
    })
}

/// Reads what blender_cycles.py printed and wrote: (tag, samples, size, linear faces, seconds) a run.
#[allow(clippy::type_complexity)]
fn read_cycles_runs(log: &str, dir: &Path) -> Result<Vec<(String, u32, u32, Vec<Vec<Vec3>>, f64)>, String> {
    let mut done = Vec::new();
    for line in log.lines().filter(|l| l.starts_with('{')) {
        let v: serde_json::Value = serde_json::from_str(line).map_err(|e| e.to_string())?;
        if let Some(c) = v.get("calibration") {
            println!("Cycles light units against ours (multipliers): {c}");
        }
        if let Some(o) = v.get("overhead") {
            println!("Cycles: a 1-sample 64² render of one face takes {o} s (scene sync and BVH build, paid by each of the six renders)");
        }
        let Some(tag) = v.get("tag").and_then(|t| t.as_str()) else { continue };
        let faces = (0..6)
            .map(|f| {
                let bytes = std::fs::read(dir.join(format!("cycles-{tag}-{f}.bin"))).map_err(|e| e.to_string())?;
                Ok(bytes
                    .chunks_exact(12)
                    .map(|c| Vec3::from_array(std::array::from_fn(|k| f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap()))))
                    .collect())
            })
            .collect::<Result<Vec<Vec<Vec3>>, String>>()?;
        done.push((
            tag.to_string(),
            v["samples"].as_u64().unwrap_or(0) as u32,
            v["size"].as_u64().unwrap_or(0) as u32,
            faces,
            v["seconds"].as_f64().unwrap_or(0.0),
        ));
    }
    Ok(done)
}

//! Glide quality (issue 69): the frames the viewer's glide pass draws along
//! each path from its ends' panoramas and depth (leg by leg, with the
//! panoramas part way the render adds), against frames the renderer traces
//! at the same camera positions, converged: the panoramas' lighting (the
//! same radiance cache and gather) at REF_SAMPLES jittered samples a pixel
//! (default 16; 1 gives the panoramas' own single trace), in traces of two
//! samples averaged (a trace's gather noise is shared by its samples), so
//! that what is scored is the glide, not the reference's noise and
//! aliasing. Each view is also scored against the reference at half its
//! traces: the "halved" figure says how far from converged it still is. Metric: mean
//! FLIP (the quality bench's: NVIDIA's flip-evaluator, LDR, 67 pixels a
//! degree; PSNR beside it). Per scene: plans it, renders it
//! with `--transitions depth` (every path measured, every probe's depth),
//! then for every path at 0 (a check: the glide there is the panorama), a
//! quarter and half of its camera keys, four views 90° wide around the
//! direction of travel. Prints a row a path (what `auto` would choose and
//! why) and the means over the paths `auto` gives a glide. Goals: ≤ 0.07 at
//! a quarter, ≤ 0.10 half way. Beside the render's own `unseen` figure, an
//! independent count: the share of each view the glide left empty (neither
//! end drew there) where the traced frame shows something; it leaves out
//! what the render also counts, surface seen but 4× too coarse, and sees
//! only the points compared, where `unseen` is the worst along the path.
//!
//! `cargo bench --bench glide`; SCENES=gallery,house,crytek (built-in
//! scenes, or the shared ones by the map bench's names: crytek, dabrovic,
//! staircase, apartment, grey_room),
//! QUALITY=preview|final (default preview), SIZE=256 (view pixels, a
//! multiple of 64), REF_SAMPLES=16 (even, or 1). Needs `scripts/bench-env.sh` once for FLIP (PSNR only
//! without it) and a GPU adapter (lavapipe or llvmpipe here). Images in
//! target/bench-glide.

use exploremaps_builder::plan::{plan, PlanParams};
use exploremaps_builder::raycast::RayScene;
use exploremaps_builder::render::glide::MAX_UNSEEN;
use exploremaps_builder::render::{render_missing, Settings, Shard, Transitions};
use exploremaps_builder::scene_io::{load, LoadOptions};
use exploremaps_builder::tracer::{psnr, Perspective, Quality, Renderer, TraceParams};
use exploremaps_format::depthcube::DepthCube;
use exploremaps_format::{CubeLevel, Graph};
use exploremaps_scenes::{BuiltIn, Scene};
use exploremaps_viewer::dollhouse::FrameTarget;
use exploremaps_viewer::glide::{toward, End, GlideFrame, GlideMesh, GlidePass};
use exploremaps_viewer::navigation::View;
use exploremaps_viewer::offscreen::render_target;
use exploremaps_viewer::panorama::{Cube, Lens};
use glam::Vec3;
use std::path::{Path, PathBuf};

const FOV: f32 = std::f32::consts::FRAC_PI_2;
/// Where along a path frames are compared, as fractions of its camera keys.
const ALONG: [f32; 3] = [0.0, 0.25, 0.5];

/// The reference's samples a pixel (REF_SAMPLES: even, or 1).
fn ref_samples() -> u32 {
    std::env::var("REF_SAMPLES").ok().and_then(|s| s.parse().ok()).filter(|&n: &u32| n == 1 || (n >= 2 && n % 2 == 0)).unwrap_or(16)
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = root.join("target/bench-glide");
    std::fs::create_dir_all(&out).unwrap();
    let python = root.join("target/bench-py/bin/python");
    let names = std::env::var("SCENES").unwrap_or("gallery".into());
    let quality = if std::env::var("QUALITY").is_ok_and(|q| q == "final") { Quality::Final } else { Quality::Preview };
    let size: u32 = std::env::var("SIZE").ok().and_then(|s| s.parse().ok()).filter(|s| s % 64 == 0).unwrap_or(256);
    let Some((device, queue)) = gpu() else { return };
    let mut summary = Vec::new();
    for name in names.split(',') {
        let scene = match load_scene(name) {
            Ok(scene) => scene,
            Err(why) => {
                println!("SKIPPED {name}: {why}");
                continue;
            }
        };
        let bundle = tempfile::tempdir().unwrap();
        let (graph, settings) = render_with_depth(&scene, name, bundle.path(), quality);
        let subject = Subject { scene: &scene, graph: &graph, dir: bundle.path(), out: &out, size, name };
        let rows = subject.compare_paths(&device, &queue, &settings);
        let scores = score(&python, &rows);
        summary.push(subject.print(&rows, &scores));
    }
    println!("\n{}", summary.join("\n"));
    println!("(goals on the paths auto glides: FLIP ≤ 0.07 a quarter of the way, ≤ 0.10 half way; images in {})", out.display());
}

/// A built-in scene, or a shared one (in `../shared/scenes`) by its short name.
fn load_scene(name: &str) -> Result<Scene, String> {
    const SHARED: [(&str, &str); 5] = [
        ("crytek", "sponza_crytek/sponza_crytek.obj"),
        ("dabrovic", "sponza_dabrovic/sponza.obj"),
        ("staircase", "wooden_staircase/wooden_staircase.obj"),
        ("apartment", "dream_apartment/dream_apartment.glb"),
        ("grey_room", "grey_white_room/grey_white_room.obj"),
    ];
    if let Some(builtin) = BuiltIn::parse(name) {
        return Ok(builtin.generate(1));
    }
    let (_, file) = SHARED.iter().find(|(n, _)| *n == name).ok_or("neither a built-in nor a shared scene")?;
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes");
    load(&shared.join(file), &LoadOptions::default()).map_err(|e| e.to_string())
}

/// Plans the scene and renders it with every path a glide; the graph and the settings used.
fn render_with_depth(scene: &Scene, name: &str, dir: &Path, quality: Quality) -> (Graph, Settings) {
    let planned = plan(scene, name, &PlanParams::default()).expect("plan");
    exploremaps_builder::bundle::write_plan(dir, &planned).unwrap();
    let mut graph = planned.graph.clone();
    let settings = Settings { transitions: Transitions::Depth, ..Settings::new(quality, 1) };
    render_missing(dir, scene, &mut graph, &settings, Shard { index: 0, count: 1 }, |_, _| {}).expect("render");
    (graph, settings)
}

/// A frame compared: the path, where along it, the view's images (glide,
/// the converged reference, the reference at half its samples).
struct Row {
    path: usize,
    along: f32,
    images: Vec<(PathBuf, PathBuf, PathBuf)>,
    /// The share of the views' pixels the glide left empty (neither end's
    /// mesh drew there) where the traced frame shows something.
    holes: f64,
}

/// The share of `glide`'s pixels (RGBA8) left black where `traced` is not.
fn holes(glide: &[u8], traced: &image::RgbImage) -> f64 {
    let empty = glide.chunks(4).zip(traced.pixels()).filter(|(g, t)| g[..3] == [0, 0, 0] && t.0.iter().any(|&c| c > 10)).count();
    empty as f64 / traced.pixels().len().max(1) as f64
}

struct Subject<'a> {
    scene: &'a Scene,
    graph: &'a Graph,
    dir: &'a Path,
    out: &'a Path,
    size: u32,
    name: &'a str,
}

impl Subject<'_> {
    /// Every path at every point of [`ALONG`]: the glide's and the tracer's images.
    fn compare_paths(&self, device: &wgpu::Device, queue: &wgpu::Queue, settings: &Settings) -> Vec<Row> {
        let rays = RayScene::new(&self.scene.positions, &self.scene.triangles, 0).unwrap();
        let mut viewpoints: Vec<Vec3> = self.graph.probes.iter().map(|p| Vec3::from(p.position)).collect();
        viewpoints.extend(self.graph.paths.iter().flat_map(|p| p.camera.iter().step_by(10).map(|k| Vec3::from(k.position))));
        let mut renderer = Renderer::new(self.scene, &rays, &viewpoints, settings.trace.clone());
        renderer.exposure = self.graph.stats.render.as_ref().expect("rendered").exposure;
        let probes: Vec<(Cube, GlideMesh)> = self
            .graph
            .probes
            .iter()
            .map(|p| self.load_source(device, queue, (self.level(&p.assets.cube_levels), p.assets.depth.as_ref().expect("depth")), p.position))
            .collect();
        let mut pass = GlidePass::new(device, wgpu::TextureFormat::Rgba8UnormSrgb);
        let mut rows = Vec::new();
        for (id, path) in self.graph.paths.iter().enumerate() {
            // The legs' sources: the ends and the panoramas part way, by camera key.
            let waypoints = path.assets.transition.iter().flat_map(|t| &t.waypoints);
            let inner: Vec<(usize, (Cube, GlideMesh))> =
                waypoints.map(|w| (w.key as usize, self.load_source(device, queue, (&w.cube, &w.depth), w.position))).collect();
            let last = path.camera.len() - 1;
            let mut sources: Vec<(usize, &(Cube, GlideMesh))> = vec![(0, &probes[path.from as usize])];
            sources.extend(inner.iter().map(|(k, s)| (*k, s)));
            sources.push((last, &probes[path.to as usize]));
            for along in ALONG {
                let at = (last as f32 * along).round() as usize;
                let leg = sources.windows(2).find(|w| at < w[1].0).unwrap_or(&sources[sources.len() - 2..]);
                let (a, b) = (leg[0].1, leg[1].1);
                let key = &path.camera[at];
                let eye = Vec3::from(key.position);
                let (mut images, mut empty) = (Vec::new(), 0.0);
                for k in 0..4 {
                    let yaw = key.yaw + k as f32 * std::f32::consts::FRAC_PI_2;
                    let stem = self.out.join(format!("{}-{id}-{:.0}-{k}", self.name, 100.0 * along));
                    let frame = GlideFrame {
                        eye,
                        lens: Lens::of_view(&View { yaw, pitch: 0.0, fov_y: FOV }, 1.0),
                        from: End { mesh: &a.1, cube: &a.0, tiles: None },
                        to: End { mesh: &b.1, cube: &b.0, tiles: None },
                        t: toward(eye, a.1.probe, b.1.probe),
                    };
                    let glide = draw(device, queue, &mut pass, &frame, self.size);
                    let view = Perspective { eye, yaw, pitch: 0.0, fov_y: FOV };
                    let (traced, half) = self.reference(&renderer, settings, view, k);
                    let (g, t, h) = (stem.with_extension("glide.png"), stem.with_extension("traced.png"), stem.with_extension("half.png"));
                    empty += holes(&glide, &traced) / 4.0;
                    image::RgbaImage::from_raw(self.size, self.size, glide).unwrap().save(&g).unwrap();
                    traced.save(&t).unwrap();
                    half.save(&h).unwrap();
                    images.push((g, t, h));
                }
                rows.push(Row { path: id, along, images, holes: empty });
            }
        }
        rows
    }

    /// The reference view, converged ([`ref_samples`] jittered samples a
    /// pixel, the panoramas' lighting), and the same at half the samples.
    fn reference(&self, renderer: &Renderer, settings: &Settings, view: Perspective, k: u64) -> (image::RgbImage, image::RgbImage) {
        let samples = ref_samples();
        let image = |colour: &[Vec3]| renderer.to_image(self.size, self.size, colour);
        if samples == 1 {
            let traced = image(&renderer.perspective(&settings.trace.panorama, view, self.size, self.size, k).color);
            return (traced.clone(), traced);
        }
        // Traces of two samples each, averaged: a trace's final gather is one
        // coarse grid whose noise all its samples share, so only more traces
        // reduce it.
        let traces: Vec<Vec<Vec3>> = (0..samples / 2)
            .map(|i| {
                let params = TraceParams { samples: 2, antialias: false, seed: 0x5EED_0000 + u64::from(i), ..settings.trace.panorama };
                renderer.perspective(&params, view, self.size, self.size, k).color
            })
            .collect();
        let mean = |traces: &[Vec<Vec3>]| -> Vec<Vec3> {
            (0..traces[0].len()).map(|p| traces.iter().map(|t| t[p]).sum::<Vec3>() / traces.len() as f32).collect()
        };
        let half = traces.len().div_ceil(2);
        (image(&mean(&traces)), image(&mean(&traces[..half])))
    }

    /// The level the viewer would show on a view of this size (its 90° as
    /// wide as a face): the smallest at least as sharp as the screen, as
    /// sampling a sharper one unfiltered aliases.
    fn level<'l>(&self, levels: &'l [CubeLevel]) -> &'l CubeLevel {
        levels.iter().find(|l| l.size >= self.size).or(levels.last()).expect("rendered faces")
    }

    /// A cube level and a depth mesh (a probe's or a waypoint's), from the bundle.
    fn load_source(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        (level, depth): (&CubeLevel, &String),
        position: [f32; 3],
    ) -> (Cube, GlideMesh) {
        let cube = Cube::new(device, level.size);
        for (f, face) in level.faces.iter().enumerate() {
            cube.write_face(queue, f, &image::open(self.dir.join(face)).unwrap().to_rgba8());
        }
        let depth = DepthCube::decode(&std::fs::read(self.dir.join(depth)).unwrap()).unwrap();
        (cube, GlideMesh::new(device, &depth, position))
    }

    /// Prints a row a path; returns the summary line over the paths auto glides.
    fn print(&self, rows: &[Row], scores: &[Score]) -> String {
        println!(
            "\n{}: path, unseen (the render's figure), auto, panoramas part way, the glide's empty pixels at ¼ and ½ (most), then FLIP (PSNR dB) at {ALONG:?} of the way",
            self.name
        );
        let (mut quarter, mut half, mut glides, mut waypoints, mut empty) = (Vec::new(), Vec::new(), 0, 0, Vec::new());
        let (mut quarter_halved, mut half_halved, mut floor) = (Vec::new(), Vec::new(), Vec::new());
        for (id, path) in self.graph.paths.iter().enumerate() {
            let unseen = path.assets.transition.as_ref().map_or(0.0, |t| t.unseen);
            let glide = unseen <= MAX_UNSEEN;
            let parts = path.assets.transition.as_ref().map_or(0, |t| t.waypoints.len());
            glides += usize::from(glide);
            waypoints += if glide { parts } else { 0 };
            let mut cells = Vec::new();
            for (row, score) in rows.iter().zip(scores).filter(|(r, _)| r.path == id) {
                cells.push(format!("{} ({:.1})", score.flip.map_or("-".into(), |f| format!("{f:.3}")), score.db));
                let (Some(f), Some(h)) = (score.flip, score.flip_halved) else { continue };
                let (converged, halved) = match (glide, row.along) {
                    (true, 0.0) => (&mut floor, None),
                    (true, 0.25) => (&mut quarter, Some(&mut quarter_halved)),
                    (true, 0.5) => (&mut half, Some(&mut half_halved)),
                    _ => continue,
                };
                converged.push(f);
                halved.into_iter().for_each(|v| v.push(h));
            }
            let auto = if glide { "glide" } else { "video" };
            let holes = rows.iter().filter(|r| r.path == id && r.along > 0.0).map(|r| r.holes).fold(0.0, f64::max);
            if glide {
                empty.push(holes);
            }
            println!("  path {id:>3}  {:>5.1} %  {auto:<5}  {parts:>2}  {:>5.2} %  {}", 100.0 * unseen, 100.0 * holes, cells.join("  "));
        }
        let mean = |v: &[f64]| if v.is_empty() { "-".to_string() } else { format!("{:.3}", v.iter().sum::<f64>() / v.len() as f64) };
        let paths = self.graph.paths.len();
        let most = empty.iter().copied().fold(0.0, f64::max);
        format!(
            "{}: {glides} of {paths} paths glide ({:.0} % get a video), with {waypoints} panoramas part way; on them mean FLIP {} a quarter of the way, {} half way \
             (the panorama itself at the path's start: {}; against the reference at half its {} samples: {} and {}); \
             the glides left {:.2} % of the views empty on average, {:.2} % at most (the render allows 2 % unseen or seen 4× coarser)",
            self.name,
            100.0 * (paths - glides) as f64 / paths.max(1) as f64,
            mean(&quarter),
            mean(&half),
            mean(&floor),
            ref_samples(),
            mean(&quarter_halved),
            mean(&half_halved),
            100.0 * empty.iter().sum::<f64>() / empty.len().max(1) as f64,
            100.0 * most
        )
    }
}

/// A row's mean scores over its views: FLIP against the converged reference
/// and against it at half its samples (None without the FLIP package), and
/// PSNR against the converged one.
struct Score {
    flip: Option<f64>,
    flip_halved: Option<f64>,
    db: f64,
}

fn score(python: &Path, rows: &[Row]) -> Vec<Score> {
    let pairs: Vec<&PathBuf> = rows.iter().flat_map(|r| r.images.iter().flat_map(|(g, t, h)| [t, g, h, g])).collect();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("builder/benches/flip.py");
    let flips: Vec<f64> = std::process::Command::new(python)
        .arg(script)
        .args(&pairs)
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).lines().filter_map(|l| l.trim().parse().ok()).collect())
        .unwrap_or_default();
    if flips.len() != pairs.len() / 2 {
        println!("no FLIP (run scripts/bench-env.sh once): PSNR only");
    }
    rows.iter()
        .enumerate()
        .map(|(i, r)| {
            let n = r.images.len();
            let mean = |which: usize| {
                (flips.len() == pairs.len() / 2).then(|| flips[2 * i * n..2 * (i + 1) * n].iter().skip(which).step_by(2).sum::<f64>() / n as f64)
            };
            let db =
                r.images.iter().map(|(g, t, _)| psnr(&image::open(t).unwrap().to_rgb8(), &image::open(g).unwrap().to_rgb8())).sum::<f64>() / n as f64;
            Score { flip: mean(0), flip_halved: mean(1), db }
        })
        .collect()
}

/// Draws a glide frame into a `size`² sRGB target and reads it back (RGBA8).
fn draw(device: &wgpu::Device, queue: &wgpu::Queue, pass: &mut GlidePass, frame: &GlideFrame, size: u32) -> Vec<u8> {
    render_target(device, queue, size, |encoder, view| {
        pass.draw(&mut FrameTarget { device, queue, encoder, view, width: size, height: size }, frame);
    })
}

/// A headless GPU device (lavapipe or llvmpipe here), or None, saying why.
fn gpu() -> Option<(wgpu::Device, wgpu::Queue)> {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        // SAFETY: set before any other thread starts.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir()) };
    }
    pollster::block_on(async {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = match instance.request_adapter(&wgpu::RequestAdapterOptions::default()).await {
            Ok(a) => a,
            Err(e) => {
                println!("SKIPPED: no GPU adapter ({e}); install mesa-vulkan-drivers");
                return None;
            }
        };
        let limits = wgpu::Limits::downlevel_webgl2_defaults().using_resolution(adapter.limits());
        let desc = wgpu::DeviceDescriptor { label: None, required_limits: limits, ..Default::default() };
        Some(adapter.request_device(&desc).await.expect("a device on the adapter"))
    })
}

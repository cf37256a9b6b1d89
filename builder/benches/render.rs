//! Rendering figures: radiance-cache bake, panoramas and video frames at both
//! qualities, ray throughput against Embree's own packet limit on the same
//! rays, and (with `BENCH_BUNDLE=1`) a whole final-quality bundle.
//! `cargo bench -p exploremaps-builder --bench render`. The comparison with
//! Cycles is in the quality bench (`CYCLES=1`), against a common reference.
//! Goal (issue 14): the whole Crytek Sponza bundle at `final` within 15 min on 2 cores.

use exploremaps_builder::plan::coverage::CoverageParams;
use exploremaps_builder::plan::{plan, PlanParams};
use exploremaps_builder::raycast::{Packing, Ray, RayScene};
use exploremaps_builder::render::Settings;
use exploremaps_builder::scene_io::{load, LoadOptions};
use exploremaps_builder::tracer::{equirect_direction, Quality, Renderer};
use exploremaps_scenes::{BuiltIn, Scene};
use glam::Vec3;
use std::path::Path;
use std::time::Instant;

/// The scene under test, its plan, and where its cache is baked for.
struct Subject {
    name: &'static str,
    scene: Scene,
    planned: exploremaps_builder::plan::Plan,
    rays: RayScene,
    viewpoints: Vec<Vec3>,
    /// Video frames over all paths.
    frames: usize,
}

fn main() {
    let s = subject();
    let (w, h) = (1024u32, 512u32);
    let limit = embree_limit(&s, w, h);
    for quality in [Quality::Preview, Quality::Final] {
        time_quality(&s, quality);
    }
    // Preview video frames trace one primary and one sun shadow ray a sample (point lights baked).
    let settings = Settings::new(Quality::Preview, 1);
    let renderer = Renderer::new(&s.scene, &s.rays, &s.viewpoints, settings.trace.clone());
    let t = Instant::now();
    for f in 0..5 {
        renderer.equirect(&settings.trace.video, s.viewpoints[0], w, f);
    }
    let whole = 5.0 * (w * h) as f64 / t.elapsed().as_secs_f64() / 1e6;
    println!("\nrays: Embree's 8-wide coherent packets alone {limit:.1} Mrays/s on a {w}x{h} equirect's primary rays; whole preview frames (primary + sun shadow + cache) {whole:.1} M pixels/s, {:.1} Mrays/s", whole * 2.0);
    if std::env::var("BENCH_BUNDLE").is_ok_and(|v| v == "1") {
        time_bundle(&s);
    }
}

/// The Crytek Sponza (the gallery without it), planned.
fn subject() -> Subject {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes/sponza_crytek/sponza_crytek.obj");
    let (name, scene): (&str, Scene) = match load(&shared, &LoadOptions { metres_per_unit: Some(0.2), ..Default::default() }) {
        Ok(s) => ("sponza_crytek", s),
        Err(e) => {
            println!("SKIPPED the Crytek Sponza ({e}); using the gallery");
            ("gallery", BuiltIn::parse("gallery").unwrap().generate(1))
        }
    };
    let params =
        PlanParams { coverage: CoverageParams { samples: 10_000, ..Default::default() }, synthesis: Some(Default::default()), ..Default::default() };
    let planned = plan(&scene, name, &params).expect("plan");
    let graph = &planned.graph;
    let frames: usize = graph.paths.iter().map(|p| p.camera.len()).sum();
    println!("{name}: {} triangles, {} probes, {} paths, {frames} video frames", scene.triangles.len(), graph.probes.len(), graph.paths.len());
    let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
    let mut viewpoints: Vec<Vec3> = graph.probes.iter().map(|p| Vec3::from(p.position)).collect();
    viewpoints.extend(graph.paths.iter().flat_map(|p| p.camera.iter().step_by(10).map(|k| Vec3::from(k.position))));
    Subject { name, scene, planned, rays, viewpoints, frames }
}

/// Embree alone on one w × h equirect's primary rays from the first probe: M rays a second.
fn embree_limit(s: &Subject, w: u32, h: u32) -> f64 {
    let eye = s.viewpoints[0];
    let primary: Vec<Ray> = (0..w * h)
        .map(|i| {
            // 4×2 pixel blocks, as the tracer packs them.
            let (bx, by) = ((i / 8) % (w / 4), (i / 8) / (w / 4));
            let (x, y) = (bx * 4 + i % 4, by * 2 + (i % 8) / 4);
            Ray::new(eye, equirect_direction((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32))
        })
        .collect();
    let mut hits = vec![None; primary.len()];
    let t = Instant::now();
    for _ in 0..5 {
        s.rays.intersect_into(&primary, &mut hits, Packing::Coherent8);
    }
    5.0 * primary.len() as f64 / t.elapsed().as_secs_f64() / 1e6
}

/// At one quality: the cache bake, video frames lit alone and along a path, and a cube.
fn time_quality(s: &Subject, quality: Quality) {
    let (graph, eye, frames) = (&s.planned.graph, s.viewpoints[0], s.frames);
    let settings = Settings::new(quality, 1);
    let t = Instant::now();
    let renderer = Renderer::new(&s.scene, &s.rays, &s.viewpoints, settings.trace.clone());
    let cache = renderer.tracer.cache.as_ref().unwrap().stats.clone();
    println!(
        "\n{}: lighting: {}; cache {} cells, {} gather rays, {} iterations, {:.2} s (renderer ready in {:.2} s, exposure {:.2})",
        quality.name(),
        renderer.tracer.lighting.description,
        cache.cells,
        cache.gather_rays,
        cache.iterations,
        cache.seconds,
        t.elapsed().as_secs_f64(),
        renderer.exposure
    );
    let (trace, vw) = (&settings.trace, settings.video_width);
    let t = Instant::now();
    let n = 10;
    for f in 0..n {
        renderer.equirect(&trace.video, eye + Vec3::X * f as f32 * 0.1, vw, f);
    }
    let lit_alone = t.elapsed().as_secs_f64() / n as f64;
    // As bundles render them: along a path, a key frame every
    // `video_keys` frames and the frames between reusing the keys' light.
    let eyes: Vec<Vec3> = graph
        .paths
        .first()
        .map(|p| p.camera.iter().take(2 * trace.video_keys as usize + 1).map(|k| Vec3::from(k.position)).collect())
        .unwrap_or_default();
    let t = Instant::now();
    renderer.path_frames(&trace.video, &eyes, vw, 0, trace.video_keys, |_, _| std::ops::ControlFlow::Continue(()));
    let per_frame = t.elapsed().as_secs_f64() / eyes.len().max(1) as f64;
    let px = (vw * vw / 2) as f64 * trace.video.samples as f64;
    println!(
        "  video frame {vw}x{} at {} spp: lit alone {:.1} ms ({:.1} M samples/s); along a path (a key every {} frames) {:.1} ms a frame over {} frames; all {frames} frames: {:.0} s",
        vw / 2,
        trace.video.samples,
        lit_alone * 1e3,
        px / lit_alone / 1e6,
        trace.video_keys,
        per_frame * 1e3,
        eyes.len(),
        per_frame * frames as f64
    );
    let t = Instant::now();
    let faces = renderer.cube(&trace.panorama, eye, settings.face, 0);
    let cube_s = t.elapsed().as_secs_f64();
    let samples = 6.0 * (settings.face * settings.face) as f64 * trace.panorama.samples as f64;
    println!(
        "  cube {}² x 6 at {} spp, {} bounce(s): {:.1} s ({:.2} M samples/s); all {} probes: {:.0} s",
        settings.face,
        trace.panorama.samples,
        trace.panorama.bounces,
        cube_s,
        samples / cube_s / 1e6,
        graph.probes.len(),
        cube_s * graph.probes.len() as f64
    );
    drop(faces);
}

/// BENCH_BUNDLE=1: the whole bundle at `final`.
fn time_bundle(s: &Subject) {
    let dir = tempfile::tempdir().unwrap();
    exploremaps_builder::bundle::write_plan(dir.path(), &s.planned).unwrap();
    let mut g = s.planned.graph.clone();
    let t = Instant::now();
    let report = exploremaps_builder::render::render_missing(
        dir.path(),
        &s.scene,
        &mut g,
        &Settings::new(Quality::Final, 1),
        exploremaps_builder::render::Shard { index: 0, count: 1 },
        |_, _| {},
    )
    .unwrap();
    println!(
        "\nwhole bundle of {} at final quality: {} probes, {} paths in {:.0} s ({:.1} min; goal 15 min), videos by {}",
        s.name,
        report.probes_rendered,
        report.paths_rendered,
        t.elapsed().as_secs_f64(),
        t.elapsed().as_secs_f64() / 60.0,
        report.video_encoder.unwrap_or_default()
    );
}

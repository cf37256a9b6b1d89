//! Rendering figures: radiance-cache bake, panoramas and video frames at both
//! qualities, ray throughput against Embree's own packet limit on the same
//! rays, one panorama against Blender Cycles (when `blender` is installed),
//! and (with `BENCH_BUNDLE=1`) a whole final-quality bundle.
//! `cargo bench -p exploremaps-builder --bench render`.
//! Goals (issue: render): at least 5× faster than Cycles at equal quality; the
//! whole Sponza bundle at `final` within 20 min on 2 cores.

use exploremaps_builder::coverage::CoverageParams;
use exploremaps_builder::load::{load, LoadOptions};
use exploremaps_builder::pipeline::{plan, PlanParams};
use exploremaps_builder::raycast::{Packing, Ray, RayScene};
use exploremaps_builder::render::{equirect_direction, Quality, Renderer, Settings};
use exploremaps_scenes::{BuiltIn, Scene};
use glam::Vec3;
use std::path::Path;
use std::time::Instant;

fn main() {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes/sponza_crytek/sponza_crytek.obj");
    let (name, scene): (&str, Scene) = match load(&shared, &LoadOptions { metres_per_unit: Some(0.2), ..Default::default() }) {
        Ok(s) => ("sponza_crytek", s),
        Err(e) => {
            println!("SKIPPED the Crytek Sponza ({e}); using the gallery");
            ("gallery", BuiltIn::parse("gallery").unwrap().generate(1))
        }
    };
    let planned = plan(&scene, name, &PlanParams { coverage: CoverageParams { samples: 10_000, ..Default::default() }, synthesis: Some(Default::default()), ..Default::default() }).expect("plan");
    let graph = &planned.graph;
    let frames: usize = graph.paths.iter().map(|p| p.camera.len()).sum();
    println!("{name}: {} triangles, {} probes, {} paths, {frames} video frames", scene.triangles.len(), graph.probes.len(), graph.paths.len());
    let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
    let mut viewpoints: Vec<Vec3> = graph.probes.iter().map(|p| Vec3::from(p.position)).collect();
    viewpoints.extend(graph.paths.iter().flat_map(|p| p.camera.iter().step_by(10).map(|k| Vec3::from(k.position))));
    let eye = viewpoints[0];

    // Ray throughput: Embree alone on one equirect's primary rays, then whole preview frames.
    let (w, h) = (1024u32, 512u32);
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
        rays.intersect_into(&primary, &mut hits, Packing::Coherent8);
    }
    let limit = 5.0 * primary.len() as f64 / t.elapsed().as_secs_f64() / 1e6;

    for quality in [Quality::Preview, Quality::Final] {
        let settings = Settings::new(quality, 1);
        let t = Instant::now();
        let renderer = Renderer::new(&scene, &rays, &viewpoints, settings.clone());
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
        let vw = settings.video_width;
        let t = Instant::now();
        let n = 10;
        for f in 0..n {
            renderer.equirect(&settings.video, eye + Vec3::X * f as f32 * 0.1, vw, f);
        }
        let per_frame = t.elapsed().as_secs_f64() / n as f64;
        let px = (vw * vw / 2) as f64 * settings.video.samples as f64;
        println!(
            "  video frame {vw}x{} at {} spp: {:.1} ms ({:.1} M samples/s); all {frames} frames: {:.0} s",
            vw / 2,
            settings.video.samples,
            per_frame * 1e3,
            px / per_frame / 1e6,
            per_frame * frames as f64
        );
        let t = Instant::now();
        let faces = renderer.cube(&settings.panorama, eye, settings.face, 0);
        let cube_s = t.elapsed().as_secs_f64();
        let samples = 6.0 * (settings.face * settings.face) as f64 * settings.panorama.samples as f64;
        println!(
            "  cube {}² x 6 at {} spp, {} bounce(s): {:.1} s ({:.2} M samples/s); all {} probes: {:.0} s",
            settings.face,
            settings.panorama.samples,
            settings.panorama.bounces,
            cube_s,
            samples / cube_s / 1e6,
            graph.probes.len(),
            cube_s * graph.probes.len() as f64
        );
        drop(faces);
    }
    // Preview video frames trace one primary and one sun shadow ray a sample (point lights baked).
    let settings = Settings::new(Quality::Preview, 1);
    let renderer = Renderer::new(&scene, &rays, &viewpoints, settings.clone());
    let t = Instant::now();
    for f in 0..5 {
        renderer.equirect(&settings.video, eye, w, f);
    }
    let whole = 5.0 * (w * h) as f64 / t.elapsed().as_secs_f64() / 1e6;
    println!("\nrays: Embree's 8-wide coherent packets alone {limit:.1} Mrays/s on a {w}x{h} equirect's primary rays; whole preview frames (primary + sun shadow + cache) {whole:.1} M pixels/s, {:.1} Mrays/s", whole * 2.0);

    cycles(&scene, &shared, &rays, &viewpoints, name);

    if std::env::var("BENCH_BUNDLE").is_ok_and(|v| v == "1") {
        let dir = tempfile::tempdir().unwrap();
        exploremaps_builder::bundle::write_plan(dir.path(), &planned).unwrap();
        let mut g = planned.graph.clone();
        let t = Instant::now();
        let report = exploremaps_builder::bundle::render_missing(dir.path(), &scene, &mut g, &Settings::new(Quality::Final, 1), exploremaps_builder::bundle::Shard { index: 0, count: 1 }, |_, _| {}).unwrap();
        println!(
            "\nwhole bundle at final quality: {} probes, {} paths in {:.0} s ({:.1} min; goal 20 min), videos by {}",
            report.probes_rendered,
            report.paths_rendered,
            t.elapsed().as_secs_f64(),
            t.elapsed().as_secs_f64() / 60.0,
            report.video_encoder.unwrap_or_default()
        );
    }
}

/// 2×2 box downsampling of an 8-bit image.
fn half(img: &image::RgbImage) -> image::RgbImage {
    image::RgbImage::from_fn(img.width() / 2, img.height() / 2, |x, y| {
        let p = |dx, dy| img.get_pixel(2 * x + dx, 2 * y + dy).0;
        let (a, b, c, d) = (p(0, 0), p(1, 0), p(0, 1), p(1, 1));
        image::Rgb(std::array::from_fn(|i| ((a[i] as u32 + b[i] as u32 + c[i] as u32 + d[i] as u32 + 2) / 4) as u8))
    })
}

/// Runs the Cycles script; returns the image and Cycles' own render seconds.
fn blender(obj: &Path, out: &Path, eye: Vec3, renderer: &Renderer, spp: u32, width: u32, mpu: f32) -> Option<(image::RgbImage, f64)> {
    let (sun, e) = renderer.tracer.lighting.suns[0];
    let sky = renderer.tracer.lighting.sky.radiance(Vec3::new(0.0, 0.5, 0.87));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/cycles.py");
    let v = |x: f32| x.to_string();
    let args: Vec<String> = [obj.display().to_string(), out.display().to_string()]
        .into_iter()
        .chain([eye.x, eye.y, eye.z, sun.x, sun.y, sun.z, e.x, sky.x, sky.y, sky.z].map(v))
        .chain([spp.to_string(), width.to_string(), v(renderer.exposure), v(mpu)])
        .collect();
    let run = std::process::Command::new("blender").args(["-b", "--factory-startup", "--python"]).arg(&script).arg("--").args(&args).output().ok()?;
    let log = String::from_utf8_lossy(&run.stdout);
    let Some(line) = log.lines().find(|l| l.starts_with("CYCLES")) else {
        println!("Cycles failed: {}", String::from_utf8_lossy(&run.stderr).lines().rev().take(5).collect::<Vec<_>>().join(" | "));
        return None;
    };
    let seconds = line.split("render_s=").nth(1)?.split_whitespace().next()?.parse().ok()?;
    Some((image::open(out).ok()?.to_rgb8(), seconds))
}

/// (a) One 2048x1024 panorama against Cycles at equal quality: each renderer
/// is measured against its own converged image (PSNR at 1024x512).
fn cycles(scene: &Scene, obj: &Path, rays: &RayScene, viewpoints: &[Vec3], name: &str) {
    use exploremaps_builder::render::{equirect_from_cube, psnr, TraceParams, Tracer};
    if name != "sponza_crytek" || std::process::Command::new("blender").arg("--version").output().is_err() {
        println!("
(a) SKIPPED the Cycles comparison: needs the Crytek Sponza and `blender` (apt-get install blender)");
        return;
    }
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/bench-render");
    std::fs::create_dir_all(&out).unwrap();
    let eye = viewpoints[0];
    let settings = Settings::new(Quality::Final, 1);
    let t = Instant::now();
    let renderer = Renderer::new(scene, rays, viewpoints, settings.clone());
    let cache_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let faces: Vec<Vec<Vec3>> = renderer.cube(&settings.panorama, eye, 2048, 0).into_iter().map(|f| f.color).collect();
    let ours = renderer.to_image(2048, 1024, &equirect_from_cube(&faces, 2048, 2048));
    let ours_s = t.elapsed().as_secs_f64();
    let ref_spp = 256;
    let t = Instant::now();
    let pure = Tracer::path_traced(scene, rays, renderer.tracer.lighting.clone(), &[eye]);
    let reference = pure.render(&TraceParams { samples: ref_spp, bounces: 0, baked_points: false, gather: None, seed: 9 }, eye, 1024, 512, 1, equirect_direction);
    let ours_ref = renderer.to_image(1024, 512, &reference.color);
    let ours_ref_s = t.elapsed().as_secs_f64();
    ours.save(out.join("ours.png")).unwrap();
    ours_ref.save(out.join("ours_reference.png")).unwrap();
    let ours_db = psnr(&half(&ours), &ours_ref);
    // Quality against time for other sample counts (antialiasing and sun-disk noise; the cache's bias stays).
    for spp in [1, 4, 8] {
        let t = Instant::now();
        let params = exploremaps_builder::render::TraceParams { samples: spp, ..settings.panorama };
        let faces: Vec<Vec<Vec3>> = renderer.cube(&params, eye, 2048, 0).into_iter().map(|f| f.color).collect();
        let img = renderer.to_image(2048, 1024, &equirect_from_cube(&faces, 2048, 2048));
        println!("    ExploreMaps at {spp} spp: {:.1} s, {:.1} dB", t.elapsed().as_secs_f64(), psnr(&half(&img), &ours_ref));
    }
    let mpu = scene.metres_per_unit;
    let Some((cy, cy_s)) = blender(obj, &out.join("cycles.png"), eye, &renderer, 16, 2048, mpu) else { return };
    let Some((cy_ref, cy_ref_s)) = blender(obj, &out.join("cycles_reference.png"), eye, &renderer, ref_spp, 1024, mpu) else { return };
    let cy_db = psnr(&half(&cy), &cy_ref);
    println!("\n(a) one 2048x1024 panorama of {name}, PSNR at 1024x512 against each renderer's own {ref_spp}-sample path-traced image:");
    println!("    ExploreMaps final (cube 2048 at {} spp, cache):  {:>6.1} s + {:.1} s cache bake  {:>5.1} dB   (reference took {:.0} s)", settings.panorama.samples, ours_s, cache_s, ours_db, ours_ref_s);
    println!("    Cycles 16 spp, 4 bounces, no denoiser:          {:>6.1} s                    {:>5.1} dB   (reference took {:.0} s)", cy_s, cy_db, cy_ref_s);
    println!("    speed-up {:.1}x (with the bake {:.1}x; goal 5x at equal or better PSNR); images in {}", cy_s / ours_s, cy_s / (ours_s + cache_s), out.display());
}

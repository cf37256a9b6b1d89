//! Navigable space and human scale on every kind of scene (issue: navigable
//! space). For each shared and built-in scene, plans it in free flight and,
//! where it has floors and a scale, walking, and prints:
//! - the space `auto` chose and why;
//! - the ceiling (surface seen from the free space inside the scene's box where
//!   a viewpoint fits; crevices apart), the
//!   share of it the navigable space sees, and the share the probes see (goal in
//!   free flight: ≥ 95 %);
//! - the same probe count placed by greedy set cover over 3,000 random candidates
//!   of the same space, measured on the same samples (goal: within 1 point);
//! - the plan's reported coverage against an independent recomputation with
//!   another seed and sample set (goal: within 1 point);
//! - walking: the largest distance of a probe from eye height above the floor
//!   under it (goal: ≤ 5 cm), floor levels with a probe, and planning time
//!   (goal ≤ 10 s on the Sponzas and the new scenes).
//!
//! `cargo bench -p exploremaps-builder --bench space`; SCENES (comma list of
//! names below) narrows the run.

use exploremaps_builder::plan::coverage::{coverage, coverage_like, CoverageParams};
use exploremaps_builder::plan::explore::{explore, ExploreParams};
use exploremaps_builder::plan::freespace::{free_space, FreeSpaceParams, HeightMode};
use exploremaps_builder::plan::walk::{WalkStats, SLOPE_COS};
use exploremaps_builder::plan::{plan, PlanParams};
use exploremaps_builder::raycast::{Ray, RayScene};
use exploremaps_builder::scene_io::{load, LoadOptions};
use exploremaps_scenes::{BuiltIn, Scene};
use glam::Vec3;
use std::path::Path;

fn main() {
    let only: Option<Vec<String>> = std::env::var("SCENES").ok().map(|s| s.split(',').map(str::to_string).collect());
    let scenes = load_scenes(only.as_deref());
    #[rustfmt::skip]
    println!(
        "{:<10} {:<5} {:<7} {:>6} {:>7} {:>7} {:>8} {:>7} {:>7} {:>6} {:>8} {:>7} {:>7} {:>8} {:>9} {:>7}",
        "scene", "mode", "space", "probes", "plan s", "total s", "reported", "again", "ceil", "crev%", "space%", "probe%", "again%", "greedy%", "eye err", "levels"
    );
    for (name, scene) in &scenes {
        for height in [HeightMode::Fly, HeightMode::Walk] {
            bench_plan(name, scene, height);
        }
    }
    println!("columns: plan s = free space to bar order; total s adds the coverage metric and its random and grid baselines;");
    println!("reported = coverage of what the navigable space sees, as the plan reports it; again = the same metric, another seed");
    println!("and sample set; ceil = the ceiling's area in m² (surface seen from the free space in the box where a viewpoint fits);");
    println!("crev% = surface seen only through crevices (from free voxels touching geometry), in % of it and the ceiling; space% / probe% = its");
    println!("share seen from the navigable space / by the probes; again% = the probes' share recomputed with another seed and");
    println!("sample set; greedy% = by greedy set cover over 3,000 random candidates with");
    println!("as many probes; eye err = the largest distance of a probe from eye height above the floor under it; levels = floor");
    println!("levels with a probe at eye height above them.");
}

/// The shared and built-in scenes SCENES names (all by default).
fn load_scenes(only: Option<&[String]>) -> Vec<(String, Scene)> {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes");
    let wanted = |name: &str| only.is_none_or(|o| o.iter().any(|w| w == name));
    let mut scenes: Vec<(String, Scene)> = Vec::new();
    // (name, file, metres per unit when the file's own guess is wrong).
    for (name, file, scale) in [
        ("crytek", "sponza_crytek/sponza_crytek.obj", Some(0.2)),
        ("dabrovic", "sponza_dabrovic/sponza.obj", None),
        ("cornell", "cornell_box/CornellBox-Original.obj", None),
        ("bunny", "stanford_bunny/bun_zipper.ply", None),
        ("staircase", "wooden_staircase/wooden_staircase.obj", None),
        ("grey_room", "grey_white_room/grey_white_room.obj", None),
        ("apartment", "dream_apartment/dream_apartment.glb", None),
    ] {
        if !wanted(name) {
            continue;
        }
        match load(&shared.join(file), &LoadOptions { metres_per_unit: scale, ..Default::default() }) {
            Ok(scene) => scenes.push((name.to_string(), scene)),
            Err(e) => println!("SKIPPED {name}: {e}"),
        }
    }
    for name in ["gallery", "maze", "pillars", "island", "house", "cathedral"] {
        if wanted(name) {
            scenes.push((name.to_string(), BuiltIn::parse(name).unwrap().generate(1)));
        }
    }
    scenes
}

/// Plans a scene with one height mode and prints its row and the space's reasons.
fn bench_plan(name: &str, scene: &Scene, height: HeightMode) {
    let free = FreeSpaceParams { height, ..Default::default() };
    let params = PlanParams { free_space: free.clone(), synthesis: Some(Default::default()), ..Default::default() };
    let result = match plan(scene, name, &params) {
        Ok(r) => r,
        Err(e) => {
            println!("{name:<10} {:<5} no plan: {e}", mode(height));
            return;
        }
    };
    let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
    let (space, _) = free_space(scene, &rays, &free).unwrap();
    let probes: Vec<Vec3> = result.graph.probes.iter().map(|p| Vec3::from(p.position)).collect();
    let report = &result.coverage;
    let ceiling = report.ceiling();
    // Greedy set cover over 3,000 random candidates of the same space, as
    // many probes, measured on the same samples.
    let greedy = ExploreParams { candidates: 3000, max_probes: probes.len(), coverage_target: 1.0, seed: 7, ..Default::default() };
    let (chosen, _) = explore(scene, &rays, &space, &greedy);
    let chosen: Vec<Vec3> = chosen.iter().map(|c| c.position).collect();
    let greedy_ceiling = coverage_like(report, &rays, &space, &chosen).ceiling();
    // The same metric with another seed and sample set.
    let again = coverage(scene, &rays, &space, &probes, &CoverageParams { seed: 0x5eed, ..Default::default() });
    let again_ceiling = again.ceiling();
    let baselines: f64 = result.baselines.iter().map(|b| b.report.seconds).sum();
    let planning = result.seconds - report.seconds - baselines;
    let (eye_err, levels) = match (&space.walk, &result.stats.free_space.walk) {
        (Some(w), Some(stats)) => eye_height_check(scene, &rays, &probes, w.eye, stats),
        _ => ("-".into(), "-".into()),
    };
    let pct = |x: f64| if ceiling.area > 0.0 { format!("{:.1}", 100.0 * x / ceiling.area) } else { "-".into() };
    println!(
        "{name:<10} {:<5} {:<7} {:>6} {planning:>7.2} {:>7.2} {:>8.2} {:>7.2} {:>7} {:>6.1} {:>8} {:>7} {:>7} {:>8} {eye_err:>9} {levels:>7}",
        mode(height),
        result.stats.free_space.space,
        probes.len(),
        result.seconds,
        100.0 * report.fraction(),
        100.0 * again.fraction(),
        human_area(ceiling.area * (scene.metres_per_unit as f64).powi(2)),
        100.0 * ceiling.crevices / (ceiling.area + ceiling.crevices).max(f64::MIN_POSITIVE),
        pct(ceiling.seen_from_space),
        pct(ceiling.covered),
        format!("{:.1}", 100.0 * again_ceiling.covered / again_ceiling.area.max(f64::MIN_POSITIVE)),
        pct(greedy_ceiling.covered),
    );
    println!("{:<10} {}; {}", "", result.stats.free_space.space_reason, result.stats.free_space.height_reason);
}

/// Walking: the largest distance of a probe from eye height above the floor
/// under it, and the floor levels with a probe at eye height ("1.2 cm", "2/3").
fn eye_height_check(scene: &Scene, rays: &RayScene, probes: &[Vec3], eye: f32, stats: &WalkStats) -> (String, String) {
    let err = probes
        .iter()
        .map(|&p| match rays.intersect(&Ray::new(p, Vec3::NEG_Y)) {
            Some(h) if h.normal.y.abs() >= SLOPE_COS => (h.t - eye).abs() * scene.metres_per_unit,
            _ => f32::INFINITY,
        })
        .fold(0.0f32, f32::max);
    let with_probe = stats.levels.iter().filter(|l| probes.iter().any(|p| (p.y - l.height - eye).abs() < 0.3 / scene.metres_per_unit)).count();
    (format!("{:.1} cm", 100.0 * err), format!("{with_probe}/{}", stats.levels.len()))
}

fn mode(height: HeightMode) -> &'static str {
    match height {
        HeightMode::Fly => "fly",
        HeightMode::Walk => "walk",
        HeightMode::Auto => "auto",
    }
}

fn human_area(m2: f64) -> String {
    if m2 >= 1e4 {
        format!("{:.0}k", m2 / 1e3)
    } else if m2 < 10.0 {
        format!("{m2:.3}")
    } else {
        format!("{m2:.0}")
    }
}

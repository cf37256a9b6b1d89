//! Exploration on the shared and built-in scenes: probes placed, rays cast,
//! time per step, and Mrays/s against Embree's coherent-packet rate measured
//! in the same run; coverage by the independent metric (probes needed for
//! 90/95/98/99 %) and of random and grid placements with as many probes.
//! `cargo bench -p exploremaps-builder --bench explore`; environment variables
//! STRATEGY (greedy|occluded), SEL, CANDS, TARGET and BUILTINS (comma list)
//! narrow or tune the run. Goals (issue: explore): Crytek Sponza atrium
//! explored in at most 3 s on 2 cores; 95 % with at most 18 probes, 98 % with
//! at most 44, at least 98 % with the paper's 36.

use exploremaps_builder::plan::coverage::{coverage, CoverageParams};
use exploremaps_builder::plan::explore::{explore, ExploreParams, Strategy};
use exploremaps_builder::plan::freespace::{free_space, FreeSpaceParams};
use exploremaps_builder::plan::visibility::CubeView;
use exploremaps_builder::raycast::RayScene;
use exploremaps_builder::scene_io::{load, LoadOptions};
use exploremaps_scenes::{BuiltIn, Scene};
use std::path::Path;
use std::time::Instant;

fn main() {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes");
    let mut scenes: Vec<(String, Scene)> = Vec::new();
    for file in ["sponza_crytek/sponza_crytek.obj", "sponza_dabrovic/sponza.obj"] {
        let path = shared.join(file);
        match load(&path, &LoadOptions::default()) {
            Ok(scene) => scenes.push((file.to_string(), scene)),
            Err(e) => println!("SKIPPED {file}: {e}"),
        }
    }
    for name in std::env::var("BUILTINS").unwrap_or("gallery,maze,pillars".into()).split(',').filter(|s| !s.is_empty()) {
        scenes.push((name.to_string(), BuiltIn::parse(name).unwrap().generate(1)));
    }
    println!(
        "{:<34} {:>9} {:>7} {:>6} {:>7} {:>8} {:>7} {:>7} {:>7} {:>8} {:>8}",
        "scene", "triangles", "space", "probes", "left", "rays", "free s", "views s", "mask s", "relax s", "total s"
    );
    let strategies: Vec<Strategy> = match std::env::var("STRATEGY").as_deref() {
        Ok("greedy") => vec![Strategy::Greedy],
        Ok("occluded") => vec![Strategy::Occluded],
        _ => vec![Strategy::Greedy, Strategy::Occluded],
    };
    for ((name, scene), strategy) in scenes.iter().flat_map(|s| strategies.iter().map(move |&st| (s, st))) {
        let name = format!("{name} ({strategy:?})");
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let t = Instant::now();
        let (space, fs) = free_space(scene, &rays, &FreeSpaceParams::default()).unwrap();
        let env = |k: &str, d: f64| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
        let params = ExploreParams {
            strategy,
            selection_samples: env("SEL", 20_000.0) as usize,
            candidates: env("CANDS", 2000.0) as usize,
            coverage_target: env("TARGET", exploremaps_builder::plan::explore::DEFAULT_COVERAGE_TARGET),
            ..Default::default()
        };
        let (probes, st) = explore(scene, &rays, &space, &params);
        let total = t.elapsed().as_secs_f64();
        println!(
            "{name:<34} {:>9} {:>7} {:>6} {:>7} {:>8} {:>7.2} {:>7.2} {:>7.2} {:>8.2} {:>8.2}",
            scene.triangles.len(),
            fs.space,
            probes.len(),
            st.samples_left,
            st.rays,
            fs.seconds,
            st.seconds_views,
            st.seconds_masking,
            st.seconds_relax,
            total
        );
        // Throughput of the cube-map views against a reference run of the same views.
        let t = Instant::now();
        let n: usize = probes.iter().map(|p| CubeView::trace(&rays, p.position, 64).dirs.len()).sum();
        let reference = n as f64 / t.elapsed().as_secs_f64() / 1e6;
        println!("{:<34} exploration {:.1} Mrays/s overall; cube-map views alone {reference:.1} Mrays/s", "", st.rays as f64 / st.seconds / 1e6);
        let positions: Vec<_> = probes.iter().map(|p| p.position).collect();
        let report = coverage(scene, &rays, &space, &positions, &CoverageParams::default());
        let need = |f: f64| report.probes_for(f).map_or("-".to_string(), |n| n.to_string());
        println!(
            "{:<34} coverage {:.2} % of {:.0} units² reachable; probes for 90/95/98/99 %: {}/{}/{}/{} ({:.2} s)",
            "",
            100.0 * report.fraction(),
            report.reachable_area,
            need(0.90),
            need(0.95),
            need(0.98),
            need(0.99),
            report.seconds
        );
        if strategy == Strategy::Greedy {
            // Cluster, synthesize and orient the candidates (issue: cluster).
            let t = Instant::now();
            let (out, cs) = exploremaps_builder::plan::cluster::synthesize(scene, &rays, &space, &probes, &Default::default());
            let cluster_s = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let diagonal = scene.bounds().diagonal();
            for &p in &out.probes {
                std::hint::black_box(exploremaps_builder::plan::orient::preferred_directions(&rays, p, space.near, diagonal));
            }
            let orient_s = t.elapsed().as_secs_f64();
            let final_report = coverage(scene, &rays, &space, &out.probes, &CoverageParams::default());
            let need = |f: f64| final_report.probes_for(f).map_or("-".to_string(), |n| n.to_string());
            println!(
                "{:<34} cluster: {} clusters -> {} final probes ({} added back), {:.2} % coverage (95 % with {}); cluster+synthesis {:.2} s, orient {:.2} s",
                "", cs.clusters, out.probes.len(), cs.added_back, 100.0 * final_report.fraction(), need(0.95), cluster_s, orient_s
            );
        }
        let baselines = exploremaps_builder::plan::baselines(&rays, &space, probes.len(), 1, &report);
        let line: Vec<String> = baselines.iter().map(|b| format!("{} {:.2} %", b.name, 100.0 * b.report.fraction())).collect();
        println!("{:<34} baselines with the same {} probes: {}", "", probes.len(), line.join(", "));
    }
}

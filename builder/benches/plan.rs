//! The whole planning pipeline, stage by stage, next to the timings the
//! ExploreMaps paper reports (Di Benedetto et al., Eurographics 2014). `cargo bench -p exploremaps-builder --bench plan`.
//! Goals (issue: paths): paths plus smoothing within 1 s on the Crytek Sponza,
//! at most 10 ms a path; a full plan (load to order) within 6 s.

use exploremaps_builder::plan::coverage::CoverageParams;
use exploremaps_builder::plan::{plan, PlanParams};
use exploremaps_builder::scene_io::{load, LoadOptions};
use exploremaps_scenes::{BuiltIn, Scene};
use std::path::Path;
use std::time::Instant;

fn main() {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes");
    let mut scenes: Vec<(String, Scene, f64)> = Vec::new();
    for file in ["sponza_crytek/sponza_crytek.obj", "sponza_dabrovic/sponza.obj"] {
        let t = Instant::now();
        match load(&shared.join(file), &LoadOptions::default()) {
            Ok(scene) => scenes.push((file.split('/').next().unwrap().to_string(), scene, t.elapsed().as_secs_f64())),
            Err(e) => println!("SKIPPED {file}: {e}"),
        }
    }
    for name in ["gallery", "maze", "pillars"] {
        let t = Instant::now();
        let scene = BuiltIn::parse(name).unwrap().generate(1);
        scenes.push((name.to_string(), scene, t.elapsed().as_secs_f64()));
    }
    println!(
        "{:<16} {:>9} {:>6} {:>6} {:>8} {:>5} | {:>6} {:>6} {:>7} {:>7} {:>6} {:>7} {:>7} {:>6} | {:>8} {:>7}",
        "scene",
        "triangles",
        "cands",
        "probes",
        "clusters",
        "paths",
        "load",
        "free",
        "explore",
        "cluster",
        "orient",
        "connect",
        "smooth",
        "order",
        "planning",
        "ms/path"
    );
    let params =
        PlanParams { coverage: CoverageParams { samples: 10_000, ..Default::default() }, synthesis: Some(Default::default()), ..Default::default() };
    for (name, scene, load_s) in &scenes {
        let p = plan(scene, name, &params).expect("plan");
        let s = &p.stats;
        let cluster = s.cluster.as_ref().map_or(0.0, |c| c.seconds);
        let stages = [s.free_space.seconds, s.explore.seconds, cluster, s.orient.seconds, s.connect.seconds, s.smooth.seconds, s.order.seconds];
        let planning = load_s + stages.iter().sum::<f64>();
        println!(
            "{:<16} {:>9} {:>6} {:>6} {:>8} {:>5} | {:>6.2} {:>6.2} {:>7.2} {:>7.2} {:>6.2} {:>7.2} {:>7.3} {:>6.3} | {:>8.2} {:>7.2}",
            name,
            scene.triangles.len(),
            s.explore.probes,
            p.graph.probes.len(),
            p.graph.clusters.len(),
            p.graph.paths.len(),
            load_s,
            stages[0],
            stages[1],
            stages[2],
            stages[3],
            stages[4],
            stages[5],
            stages[6],
            planning,
            1000.0 * s.smooth.seconds_per_path,
        );
    }
    println!("paper, Sponza      262267     -     36       10    29 |   exploration 23 s, smoothing 122 s, total planning 189 s (i7 + GTX 670)");
    println!("paper, Sibenik      69853     -     92       21    58 |   exploration 63 s, smoothing 81 s, total planning 659 s");
}

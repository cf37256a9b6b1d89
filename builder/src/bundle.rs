//! Writes a bundle folder: `graph.json` (the format crate's schema),
//! `coverage.json` and the report pictures. Every file is written under a
//! temporary name and renamed, and graph.json last, so a bundle with a
//! graph.json is complete. The stages' timings go to `timings.json`, not
//! graph.json: the same seed gives byte-identical bundles at any thread
//! count, timings apart.

use crate::files::write_atomic;
use crate::plan::Plan;
use exploremaps_format::{record::Timings, GRAPH_FILE};
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum BundleError {
    #[error("cannot write {path} (check that the folder is writable and the disk has room)")]
    Io { path: String, source: std::io::Error },
    #[error("the planned graph is inconsistent (a bug: please report it)")]
    Invalid(#[from] exploremaps_format::FormatError),
    #[error("cannot denoise {path}")]
    Denoise { path: String, source: crate::tracer::DenoiseError },
    #[error("cannot encode the transition video {path}")]
    Video { path: String, source: crate::video::VideoError },
    #[error("cannot code the proxy mesh {path} (a bug: please report it)")]
    Proxy { path: String, source: exploremaps_format::edgebreaker::CodingError },
    #[error(transparent)]
    Raycast(#[from] crate::raycast::RaycastError),
    #[error("{dir} is not complete; {} problems:\n  {}\nrun the shards named again (`exploremaps render {dir} --shard i/n`), then --finalize", problems.len(), list_some(problems))]
    Incomplete { dir: String, problems: Vec<String> },
}

/// The first 20 lines of a list, and how many more there are.
fn list_some(lines: &[String]) -> String {
    let mut shown = lines.iter().take(20).cloned().collect::<Vec<_>>().join("\n  ");
    if lines.len() > 20 {
        shown.push_str(&format!("\n  … and {} more", lines.len() - 20));
    }
    shown
}

pub(crate) fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<(), BundleError> {
    let path = dir.join(name);
    write_atomic(&path, bytes).map_err(|source| BundleError::Io { path: path.display().to_string(), source })
}

/// The web viewer's files (`index.html`, `viewer/…`), relative to its folder.
pub const WEB_VIEWER_FILES: [&str; 3] = ["index.html", "viewer/exploremaps.js", "viewer/exploremaps_bg.wasm"];

/// Copies the built web viewer (web/build.sh writes it to target/web-viewer) into a
/// bundle, so the folder can be hosted anywhere as static files. Files that
/// are already identical are left alone. Returns how many were written.
pub fn install_web_viewer(dir: &Path, web: &Path) -> Result<usize, BundleError> {
    let mut written = 0;
    for name in WEB_VIEWER_FILES {
        let from = web.join(name);
        let bytes = std::fs::read(&from).map_err(|source| BundleError::Io { path: from.display().to_string(), source })?;
        let to = dir.join(name);
        if std::fs::read(&to).is_ok_and(|old| old == bytes) {
            continue;
        }
        if let Some(parent) = to.parent() {
            std::fs::create_dir_all(parent).map_err(|source| BundleError::Io { path: parent.display().to_string(), source })?;
        }
        write(dir, name, &bytes)?;
        written += 1;
    }
    Ok(written)
}

/// The coverage report as JSON: overall, per material and object, the curve,
/// and the baselines at the same probe count.
pub fn coverage_json(plan: &Plan) -> serde_json::Value {
    let groups = |g: &[(String, f64, f64)]| -> Vec<serde_json::Value> {
        g.iter()
            .map(|(name, r, c)| serde_json::json!({ "name": name, "reachable_area": r, "covered_area": c, "fraction": if *r > 0.0 { c / r } else { 1.0 } }))
            .collect()
    };
    let c = &plan.coverage;
    let ceiling = c.ceiling();
    serde_json::json!({
        "probes": plan.graph.probes.len(),
        "samples": c.samples.points.len(),
        "reachable_area": c.reachable_area,
        "covered_area": c.covered_area,
        "fraction": c.fraction(),
        "measured_from": match &plan.stats.free_space.walk {
            Some(w) => format!("eye height ({} m) above the walkable floors: surface seen only from higher up or lower down is not counted here, but is in the ceiling", w.eye_height_m),
            None => "anywhere in the navigable space".to_string(),
        },
        "ceiling": {
            "what": "surface seen from the free space inside the scene's bounding box (outside closed solids) where a viewpoint fits (touching no occupied voxel), whatever space was chosen: the most any placement could see; crevices_area is surface seen only from narrower gaps, left out",
            "area": ceiling.area,
            "crevices_area": ceiling.crevices,
            "seen_from_space": ceiling.seen_from_space,
            "covered": ceiling.covered,
            "space_fraction": if ceiling.area > 0.0 { ceiling.seen_from_space / ceiling.area } else { 1.0 },
            "covered_fraction": if ceiling.area > 0.0 { ceiling.covered / ceiling.area } else { 1.0 },
        },
        "probes_for": { "0.90": c.probes_for(0.90), "0.95": c.probes_for(0.95), "0.98": c.probes_for(0.98), "0.99": c.probes_for(0.99) },
        "curve": c.curve,
        "per_material": groups(&plan.per_material),
        "per_object": groups(&plan.per_object),
        "baselines": plan.baselines.iter().map(|b| serde_json::json!({
            "name": b.name,
            "probes": b.probes.len(),
            "fraction": b.report.fraction(),
            "curve": b.report.curve,
        })).collect::<Vec<_>>(),
        "chart": "coverage_curve.png: explored probes green, random baseline orange, grid baseline blue; gridlines every 10 % of the y range and every 10 probes",
        "top_view": "coverage_top.png: a cutaway from the top of the navigable space; grey seen by a probe, magenta reachable but unseen, dim unreachable, amber free space the chosen space leaves out, green dots probes",
    })
}

/// Writes the planned bundle into `dir` (created if missing).
pub fn write_plan(dir: &Path, plan: &Plan) -> Result<(), BundleError> {
    plan.graph.validate()?;
    for (name, image) in &plan.images {
        write(dir, name, &crate::files::png(image))?;
    }
    let coverage = serde_json::to_string_pretty(&coverage_json(plan)).expect("JSON of plain values");
    write(dir, "coverage.json", coverage.as_bytes())?;
    write_graph(dir, &plan.graph, plan.timings.clone())
}

/// What varies from run to run, kept out of graph.json.
pub const TIMINGS_FILE: &str = "timings.json";

/// Writes graph.json, after merging this run's `timings` into timings.json
/// (a plan's times stay when the render adds its own).
pub(crate) fn write_graph(dir: &Path, graph: &exploremaps_format::Graph, timings: Timings) -> Result<(), BundleError> {
    if !timings.0.is_empty() {
        let path = dir.join(TIMINGS_FILE);
        let earlier = match std::fs::read_to_string(&path) {
            Ok(text) => serde_json::from_str(&text).unwrap_or_else(|e| {
                tracing::warn!("{}: not timings ({e}); written anew", path.display());
                Timings::default()
            }),
            Err(_) => Timings::default(),
        };
        let all = timings.merged_over(earlier);
        write(dir, TIMINGS_FILE, serde_json::to_string_pretty(&all).expect("JSON of plain values").as_bytes())?;
    }
    write(dir, GRAPH_FILE, graph.to_json().as_bytes())
}

//! Writes a bundle folder: `graph.json` (the format crate's schema),
//! `coverage.json` and the report pictures. Every file is written under a
//! temporary name and renamed, and graph.json last, so a bundle with a
//! graph.json is complete.

use crate::files::write_atomic;
use crate::pipeline::Plan;
use exploremaps_format::GRAPH_FILE;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum BundleError {
    #[error("cannot write {path}: {source}; check that the folder is writable and the disk has room")]
    Io { path: String, source: std::io::Error },
    #[error("the planned graph is inconsistent ({0}); this is a bug, please report it")]
    Invalid(#[from] exploremaps_format::FormatError),
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<(), BundleError> {
    let path = dir.join(name);
    write_atomic(&path, bytes).map_err(|source| BundleError::Io { path: path.display().to_string(), source })
}

fn png(image: &image::RgbImage) -> Vec<u8> {
    let mut bytes = Vec::new();
    image.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).expect("PNG encoding to memory");
    bytes
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
    serde_json::json!({
        "probes": plan.graph.probes.len(),
        "samples": c.samples.points.len(),
        "reachable_area": c.reachable_area,
        "covered_area": c.covered_area,
        "fraction": c.fraction(),
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
    })
}

/// Writes the planned bundle into `dir` (created if missing).
pub fn write_plan(dir: &Path, plan: &Plan) -> Result<(), BundleError> {
    plan.graph.validate()?;
    for (name, image) in &plan.images {
        write(dir, name, &png(image))?;
    }
    let coverage = serde_json::to_string_pretty(&coverage_json(plan)).expect("JSON of plain values");
    write(dir, "coverage.json", coverage.as_bytes())?;
    write(dir, GRAPH_FILE, plan.graph.to_json().as_bytes())
}

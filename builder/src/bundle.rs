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
    #[error(transparent)]
    Raycast(#[from] crate::raycast::RaycastError),
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

/// Which probes a shard renders: probe `id` belongs to shard `id % count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderReport {
    pub rendered: usize,
    pub skipped: usize,
    pub seconds: f64,
}

/// Renders what the bundle is missing: a photo-sphere JPEG panorama
/// (`probes/<id>.jpg`, `width` × `width`/2) and a thumbnail (`thumbs/<id>.jpg`)
/// per probe of this shard. A finished file is never redone and every file is
/// written atomically, so a killed run loses at most the probe in progress.
/// graph.json then lists the assets of every probe whose files exist.
pub fn render_missing(
    dir: &Path,
    scene: &exploremaps_scenes::Scene,
    graph: &mut exploremaps_format::Graph,
    width: u32,
    shard: Shard,
    mut progress: impl FnMut(usize, usize),
) -> Result<RenderReport, BundleError> {
    use crate::render::{equirect, perspective, photo_sphere_jpeg, Shader};
    let started = std::time::Instant::now();
    let rays = crate::raycast::RayScene::new(&scene.positions, &scene.triangles, 0)?;
    let shader = Shader::new(scene, &rays);
    let mut report = RenderReport::default();
    let mine: Vec<usize> = (0..graph.probes.len()).filter(|id| id % shard.count == shard.index).collect();
    for (done, &id) in mine.iter().enumerate() {
        progress(done, mine.len());
        let (pano, thumb) = (format!("probes/{id}.jpg"), format!("thumbs/{id}.jpg"));
        if dir.join(&pano).exists() && dir.join(&thumb).exists() {
            report.skipped += 1;
            continue;
        }
        let probe = &graph.probes[id];
        let eye = glam::Vec3::from(probe.position);
        let (yaw, pitch) = probe.preferred_directions.first().map_or((0.0, 0.0), |d| (d.yaw, d.pitch));
        write(dir, &pano, &photo_sphere_jpeg(&equirect(&shader, eye, width), 90))?;
        let mut jpeg = Vec::new();
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 85)
            .encode_image(&perspective(&shader, eye, yaw, pitch, 1.0, 320, 180))
            .expect("JPEG encoding to memory");
        write(dir, &thumb, &jpeg)?;
        report.rendered += 1;
    }
    progress(mine.len(), mine.len());
    for (id, probe) in graph.probes.iter_mut().enumerate() {
        let (pano, thumb) = (format!("probes/{id}.jpg"), format!("thumbs/{id}.jpg"));
        probe.assets.equirect = dir.join(&pano).exists().then_some(pano);
        probe.assets.thumbnail = dir.join(&thumb).exists().then_some(thumb);
    }
    graph.validate()?;
    write(dir, GRAPH_FILE, graph.to_json().as_bytes())?;
    report.seconds = started.elapsed().as_secs_f64();
    Ok(report)
}

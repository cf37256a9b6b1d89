//! The pipeline, step by step: what `exploremaps plan` runs. Each step is one
//! stage module; this file only wires their results together.
//!
//! Planning today: ray casting → free space → explore (candidate probes) →
//! cluster and synthesize (final probes) → orient (preferred view directions)
//! → connect and smooth (paths) → order (thumbnail bar) → coverage (with random and grid baselines of the same probe count) →
//! pictures → graph. Clustering,
//! orientation, paths, ordering and rendering join here as they land.

use crate::cluster::{self, SynthesisParams};
use crate::connect::{self, ConnectParams};
use crate::smooth;
use crate::coverage::{coverage, coverage_like, CoverageParams, CoverageReport};
use crate::explore::{explore, ExploreParams, ExploreStats};
use crate::freespace::{free_space, FreeSpace, FreeSpaceError, FreeSpaceParams, FreeSpaceStats};
use crate::raycast::{RayScene, RaycastError};
use crate::order;
use crate::orient;
use rayon::prelude::*;
use crate::report;
use exploremaps_format as format;
use exploremaps_scenes::{ScaleSource, Scene};
use glam::Vec3;
use image::{Rgb, RgbImage};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::time::Instant;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlanParams {
    pub free_space: FreeSpaceParams,
    pub explore: ExploreParams,
    /// `None` keeps the explored candidates as the final probes.
    pub synthesis: Option<SynthesisParams>,
    pub coverage: CoverageParams,
}

#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    #[error(transparent)]
    Raycast(#[from] RaycastError),
    #[error(transparent)]
    FreeSpace(#[from] FreeSpaceError),
}

/// Coverage of a baseline placement with the same number of probes.
pub struct Baseline {
    pub name: &'static str,
    pub probes: Vec<Vec3>,
    pub report: CoverageReport,
}

pub struct Plan {
    pub graph: format::Graph,
    pub coverage: CoverageReport,
    pub baselines: Vec<Baseline>,
    pub free_space: FreeSpaceStats,
    pub explore: ExploreStats,
    /// (file name, picture) to write into the bundle.
    pub images: Vec<(String, RgbImage)>,
    /// Per material and per object: (name, reachable area, covered area).
    pub per_material: Vec<(String, f64, f64)>,
    pub per_object: Vec<(String, f64, f64)>,
    pub seconds: f64,
}

const EXPLORED: Rgb<u8> = Rgb([20, 150, 40]);
const RANDOM: Rgb<u8> = Rgb([230, 120, 20]);
const GRID: Rgb<u8> = Rgb([40, 90, 220]);

/// Plans a scene: every step from ray casting to the graph.
pub fn plan(scene: &Scene, source: &str, params: &PlanParams) -> Result<Plan, PlanError> {
    let started = Instant::now();
    let (rays, space, free_stats) = prepare(scene, &params.free_space)?;
    let (candidates, explore_stats) = {
        let _span = tracing::info_span!("explore").entered();
        explore(scene, &rays, &space, &params.explore)
    };
    tracing::info!("explore: {} candidate probes in {:.2} s", candidates.len(), explore_stats.seconds);
    let synthesized = match &params.synthesis {
        Some(synthesis) => {
            let _span = tracing::info_span!("cluster").entered();
            let (out, stats) = cluster::synthesize(scene, &rays, &space, &candidates, synthesis);
            tracing::info!("{} candidates -> {} clusters -> {} probes ({} added back) in {:.2} s", stats.candidates, stats.clusters, stats.final_probes, stats.added_back, stats.seconds);
            Some((out, stats))
        }
        None => None,
    };
    let mut graph = match &synthesized {
        Some((out, _)) => new_graph(scene, source, &space, &out.probes, &out.user_placed, Some(out)),
        None => {
            let positions: Vec<Vec3> = candidates.iter().map(|c| c.position).collect();
            let user: Vec<bool> = candidates.iter().map(|c| c.user_placed).collect();
            new_graph(scene, source, &space, &positions, &user, None)
        }
    };
    if let Some((_, stats)) = &synthesized {
        graph.stats.insert("cluster".into(), serde_json::to_value(stats).unwrap_or_default());
    }
    let oriented = Instant::now();
    let diagonal = scene.bounds().diagonal();
    let directions: Vec<Vec<orient::Preferred>> =
        graph.probes.par_iter().map(|p| orient::preferred_directions(&rays, Vec3::from(p.position), space.near, diagonal)).collect();
    for (probe, preferred) in graph.probes.iter_mut().zip(directions) {
        probe.preferred_directions = preferred
            .into_iter()
            .take(3)
            .map(|p| format::ViewDirection { yaw: p.yaw, pitch: p.pitch, goodness: p.goodness })
            .collect();
    }
    graph.stats.insert("orient".into(), serde_json::json!({ "seconds": oriented.elapsed().as_secs_f64() }));
    route(scene, &rays, &space, &mut graph, params.explore.seed);
    // The bar order weighs probe pairs by 1 / path length, or by 1 / Euclidean
    // distance when no path joins any probes.
    let points: Vec<[f32; 3]> = graph.probes.iter().map(|p| p.position).collect();
    let edges = if graph.paths.is_empty() {
        order::euclidean_edges(&points)
    } else {
        graph.paths.iter().map(|p| (p.from as usize, p.to as usize, 1.0 / (p.length as f64).max(1e-9))).collect()
    };
    let ordered = Instant::now();
    let (bar_order, order_stats) = order::order(points.len(), &edges, params.explore.seed);
    graph.bar_order = bar_order;
    let order_s = ordered.elapsed().as_secs_f64();
    graph.stats.insert("free_space".into(), serde_json::to_value(&free_stats).unwrap_or_default());
    graph.stats.insert("explore".into(), serde_json::to_value(&explore_stats).unwrap_or_default());
    let mut order_json = serde_json::to_value(&order_stats).unwrap_or_default();
    order_json["seconds"] = serde_json::json!(order_s);
    graph.stats.insert("order".into(), order_json);
    Ok(measure(scene, &rays, &space, graph, free_stats, explore_stats, params, started))
}

/// Connects the graph's probes, smooths and times the paths, and writes them
/// into the graph with their stats.
fn route(scene: &Scene, rays: &RayScene, space: &FreeSpace, graph: &mut format::Graph, seed: u64) {
    let _span = tracing::info_span!("connect").entered();
    let probes: Vec<Vec3> = graph.probes.iter().map(|p| Vec3::from(p.position)).collect();
    let (raw, connect_stats) = connect::connect(rays, space, &probes, &ConnectParams { seed, ..Default::default() });
    let started = Instant::now();
    let smoothed: Vec<(Vec<Vec3>, smooth::SmoothingStats)> = raw.par_iter().map(|r| smooth::smooth(rays, space, &r.polyline)).collect();
    let smoothing_s = started.elapsed().as_secs_f64();
    graph.paths = raw
        .iter()
        .zip(&smoothed)
        .enumerate()
        .map(|(id, (r, (polyline, _)))| {
            let length = connect::polyline_length(polyline);
            let duration_s = smooth::duration(length, scene.metres_per_unit);
            let arrival = graph.probes[r.to].preferred_directions.first().map(|d| (d.yaw, d.pitch));
            format::Path {
                id: id as u32,
                from: r.from as u32,
                to: r.to as u32,
                polyline: polyline.iter().map(|p| p.to_array()).collect(),
                length,
                duration_s,
                camera: smooth::camera_keys(polyline, duration_s, arrival)
                    .into_iter()
                    .map(|(t_s, position, yaw, pitch)| format::CameraKey { t_s, position: position.to_array(), yaw, pitch })
                    .collect(),
                assets: format::PathAssets::default(),
            }
        })
        .collect();
    tracing::info!("{} paths, {} components, smoothed in {:.3} s", connect_stats.paths, connect_stats.components, smoothing_s);
    let n = smoothed.len().max(1) as f64;
    graph.stats.insert("connect".into(), serde_json::to_value(&connect_stats).unwrap_or_default());
    graph.stats.insert(
        "smooth".into(),
        serde_json::json!({
            "paths": smoothed.len(),
            "seconds": smoothing_s,
            "seconds_per_path": smoothing_s / n,
            "iterations_max": smoothed.iter().map(|s| s.1.iterations).max().unwrap_or(0),
            "blocked_segments": smoothed.iter().map(|s| s.1.blocked_segments).sum::<usize>(),
            "min_clearance": smoothed.iter().map(|s| s.1.min_clearance).fold(f32::INFINITY, f32::min),
            "mean_clearance": smoothed.iter().map(|s| s.1.mean_clearance as f64).sum::<f64>() / n,
            "near_distance": space.near,
        }),
    );
}

/// Measures the coverage of a planned graph's probes again (e.g. with more
/// samples). The navigable component is the one holding the first probe.
pub fn remeasure(scene: &Scene, graph: format::Graph, params: &PlanParams) -> Result<Plan, PlanError> {
    let started = Instant::now();
    let mut free_params = params.free_space.clone();
    free_params.start = graph.probes.first().map(|p| Vec3::from(p.position));
    let (rays, space, free_stats) = prepare(scene, &free_params)?;
    Ok(measure(scene, &rays, &space, graph, free_stats, ExploreStats::default(), params, started))
}

fn prepare(scene: &Scene, params: &FreeSpaceParams) -> Result<(RayScene, FreeSpace, FreeSpaceStats), PlanError> {
    let rays = {
        let _span = tracing::info_span!("raycast").entered();
        RayScene::new(&scene.positions, &scene.triangles, 0)?
    };
    let (space, stats) = {
        let _span = tracing::info_span!("free space").entered();
        free_space(scene, &rays, params)?
    };
    tracing::info!("space: {} ({}); {} ({})", stats.space, stats.space_reason, stats.height, stats.height_reason);
    tracing::info!("free space: {} navigable voxels of {:.3} units, near distance {:.3}; open space {} voxels, {} inside closed solids", stats.navigable, stats.voxel, stats.near, stats.open, stats.solid);
    Ok((rays, space, stats))
}

/// Coverage, baselines and pictures for the graph's probes.
#[allow(clippy::too_many_arguments)]
fn measure(
    scene: &Scene,
    rays: &RayScene,
    space: &FreeSpace,
    mut graph: format::Graph,
    free_space: FreeSpaceStats,
    explore: ExploreStats,
    params: &PlanParams,
    started: Instant,
) -> Plan {
    let probes: Vec<Vec3> = graph.probes.iter().map(|p| Vec3::from(p.position)).collect();
    let report = {
        let _span = tracing::info_span!("coverage").entered();
        coverage(scene, rays, space, &probes, &params.coverage)
    };
    let baselines = baselines(rays, space, probes.len(), params.explore.seed, &report);
    let floor = ([&report].into_iter().chain(baselines.iter().map(|b| &b.report)))
        .filter_map(|r| r.curve.first().map(|c| c.1))
        .fold(1.0f64, f64::min);
    let mut curves: Vec<report::Curve> = vec![(&report.curve, EXPLORED)];
    for b in &baselines {
        curves.push((&b.report.curve, if b.name == "random" { RANDOM } else { GRID }));
    }
    let mut images = vec![
        ("coverage_curve.png".to_string(), report::coverage_chart(&curves, (floor - 0.05).clamp(0.0, 0.9), 640, 400)),
        ("coverage_top.png".to_string(), report::top_view(scene, rays, space, &report, &probes, 800)),
    ];
    if let Some(eye) = space.most_open_point() {
        let e = scene.bounds().extent();
        let long = if e.x >= e.z { Vec3::X } else { Vec3::Z };
        for (k, forward) in [long, -long].into_iter().enumerate() {
            images.push((format!("coverage_view_{k}.png"), report::perspective_view(scene, rays, &report, &probes, eye, forward, 640)));
        }
    }
    let per_material = report.per_group(&scene.triangle_material, &scene.materials.iter().map(|m| m.name.clone()).collect::<Vec<_>>());
    let per_object = report.per_group(&scene.triangle_object, &scene.objects);
    graph.coverage = Some(format::Coverage {
        samples: report.samples.points.len() as u32,
        reachable_area: report.reachable_area,
        covered_area: report.covered_area,
        ceiling: Some(report.ceiling()),
        per_group: per_material.iter().map(|(name, r, c)| format::GroupCoverage { name: name.clone(), reachable_area: *r, covered_area: *c }).collect(),
        curve: report.curve.clone(),
    });
    graph.stats.insert(
        "coverage".into(),
        serde_json::json!({ "seconds": report.seconds, "rays": report.rays, "fraction": report.fraction() }),
    );
    Plan {
        graph,
        coverage: report,
        baselines,
        free_space,
        explore,
        images,
        per_material,
        per_object,
        seconds: started.elapsed().as_secs_f64(),
    }
}

/// Random navigable points and a regular lattice of navigable points, `count`
/// of each, measured with the same metric on the same samples as `base`.
pub fn baselines(rays: &RayScene, space: &FreeSpace, count: usize, seed: u64, base: &CoverageReport) -> Vec<Baseline> {
    let navigable = space.navigable_points();
    if navigable.is_empty() || count == 0 {
        return Vec::new();
    }
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x7261_6e64);
    let random: Vec<Vec3> = (0..count).map(|_| navigable[rng.random_range(0..navigable.len())]).collect();
    // The coarsest lattice (in voxels) with at least `count` navigable nodes, thinned evenly.
    let mut lattice = Vec::new();
    for step in (1..=64usize).rev() {
        lattice = (0..space.grid.len())
            .filter(|&i| space.navigable[i] && space.grid.coords(i).iter().all(|&c| c % step == step / 2))
            .map(|i| space.grid.center(space.grid.coords(i)))
            .collect();
        if lattice.len() >= count {
            break;
        }
    }
    let stride = lattice.len() as f64 / count as f64;
    let grid: Vec<Vec3> = (0..count.min(lattice.len())).map(|k| lattice[(k as f64 * stride) as usize]).collect();
    [("random", random), ("grid", grid)]
        .into_iter()
        .map(|(name, probes)| {
            let report = coverage_like(base, rays, space, &probes);
            Baseline { name, probes, report }
        })
        .collect()
}

/// A graph holding the scene's description and the final probes (with their
/// clusters when synthesis ran).
fn new_graph(scene: &Scene, source: &str, space: &FreeSpace, probes: &[Vec3], user_placed: &[bool], clusters: Option<&cluster::Synthesized>) -> format::Graph {
    let b = scene.bounds();
    let mut graph = format::Graph::new(format::SceneInfo {
        name: scene.name.clone(),
        source: source.to_string(),
        triangles: scene.triangles.len() as u64,
        bounds_min: b.min.to_array(),
        bounds_max: b.max.to_array(),
        metres_per_unit: scene.metres_per_unit,
        scale_source: match scene.scale_source {
            ScaleSource::File => "file",
            ScaleSource::User => "user",
            ScaleSource::Guessed => "guessed",
        }
        .to_string(),
        space: Some(space.space.name().to_string()),
        near_distance: Some(space.near),
        eye_height_m: space.walk.as_ref().map(|w| w.eye * scene.metres_per_unit),
        credits: Vec::new(),
    });
    graph.probes = probes
        .iter()
        .enumerate()
        .map(|(i, p)| format::Probe {
            id: i as u32,
            position: p.to_array(),
            cluster: clusters.map(|c| c.cluster_of[i]),
            preferred_directions: Vec::new(),
            user_placed: user_placed[i],
            assets: format::ProbeAssets::default(),
        })
        .collect();
    if let Some(c) = clusters {
        graph.clusters = c.clusters.iter().enumerate().map(|(i, &(probe, merged))| format::Cluster { id: i as u32, probe: probe as u32, candidates: merged as u32 }).collect();
    }
    graph
}

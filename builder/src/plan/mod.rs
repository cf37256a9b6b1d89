//! The planning pipeline: what `exploremaps plan` runs. Each line of [`plan`]
//! is one stage module over the previous stages' typed results; the graph
//! is assembled once, at the end.
//!
//! raycast (Embree) → freespace (navigable space, human scale) → explore
//! (candidate probes) → cluster (final probes) → orient (preferred view
//! directions) → connect and smooth (paths) → order (thumbnail bar) →
//! coverage (with random and grid baselines of the same probe count, and
//! pictures) → graph. `crate::render` then renders a planned bundle.

pub mod cluster;
pub mod connect;
pub mod coverage;
pub mod explore;
pub mod freespace;
pub mod order;
pub mod orient;
pub mod report;
pub mod samples;
pub mod scale;
pub mod smooth;
pub mod visibility;
pub mod walk;

use crate::raycast::{RayScene, RaycastError};
use cluster::{SynthesisParams, SynthesisStats, Synthesized};
use connect::{ConnectParams, ConnectStats};
use coverage::{coverage, coverage_like, CoverageParams, CoverageReport};
use explore::{explore, Candidate, ExploreParams, ExploreStats};
use exploremaps_format as format;
use exploremaps_scenes::{ScaleSource, Scene};
use format::record::Timings;
use freespace::{free_space, FreeSpace, FreeSpaceError, FreeSpaceParams, FreeSpaceStats, SpaceMode};
use glam::Vec3;
use image::{Rgb, RgbImage};
use order::OrderStats;
use rand::Rng;
use rayon::prelude::*;
use scale::ScaleGuess;
use std::borrow::Cow;
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
    /// The bundle's graph, assembled from the stages' results at the end.
    pub graph: format::Graph,
    pub stats: PlanStats,
    pub coverage: CoverageReport,
    pub baselines: Vec<Baseline>,
    /// (file name, picture) to write into the bundle.
    pub images: Vec<(String, RgbImage)>,
    /// Per material and per object: (name, reachable area, covered area).
    pub per_material: Vec<(String, f64, f64)>,
    pub per_object: Vec<(String, f64, f64)>,
    /// The whole plan, and of it the report (coverage, baselines, pictures).
    pub seconds: f64,
    pub report_seconds: f64,
    /// The stages' times, for timings.json.
    pub timings: Timings,
}

/// What the planning stages report, one entry each in graph.json's `stats`
/// (their `seconds` go to timings.json, by [`PlanStats::timings`]).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct PlanStats {
    pub scale: ScaleStats,
    pub free_space: FreeSpaceStats,
    pub explore: ExploreStats,
    /// None when the candidates are kept as the final probes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cluster: Option<SynthesisStats>,
    pub orient: Seconds,
    pub connect: ConnectStats,
    pub smooth: SmoothStats,
    pub order: OrderSummary,
    pub coverage: CoverageStats,
}

impl PlanStats {
    /// Each stage's time.
    fn timings(&self) -> Timings {
        let mut timings = Timings::default();
        let mut set = |stage: &str, step: &str, seconds: f64| timings.set(stage, step, format::record::Seconds::Total(seconds));
        set("scale", "seconds", self.scale.seconds);
        set("free_space", "seconds", self.free_space.seconds);
        let e = &self.explore;
        for (step, seconds) in
            [("seconds", e.seconds), ("seconds_views", e.seconds_views), ("seconds_masking", e.seconds_masking), ("seconds_relax", e.seconds_relax)]
        {
            set("explore", step, seconds);
        }
        if let Some(cluster) = &self.cluster {
            set("cluster", "seconds", cluster.seconds);
        }
        set("orient", "seconds", self.orient.seconds);
        set("connect", "seconds", self.connect.seconds);
        set("smooth", "seconds", self.smooth.seconds);
        set("smooth", "seconds_per_path", self.smooth.seconds_per_path);
        set("order", "seconds", self.order.seconds);
        set("coverage", "seconds", self.coverage.seconds);
        timings
    }
}

/// The scale planning used, and where it came from.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ScaleStats {
    pub metres_per_unit: f32,
    /// "file", "user", "measured" or "guessed".
    pub source: &'static str,
    /// What decided it, in one line.
    pub reason: String,
    /// What the scene's heights said, when the file did not state a scale.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured: Option<ScaleGuess>,
    #[serde(skip)]
    pub seconds: f64,
}

#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Seconds {
    #[serde(skip)]
    pub seconds: f64,
}

/// The paths' smoothing, over all of them.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SmoothStats {
    pub paths: usize,
    #[serde(skip)]
    pub seconds: f64,
    #[serde(skip)]
    pub seconds_per_path: f64,
    pub iterations_max: usize,
    pub blocked_segments: usize,
    pub min_clearance: f32,
    pub mean_clearance: f64,
    /// The clearance asked for: the free space's near distance.
    pub near_distance: f32,
}

#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct OrderSummary {
    #[serde(flatten)]
    pub stats: OrderStats,
    #[serde(skip)]
    pub seconds: f64,
}

#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct CoverageStats {
    #[serde(skip)]
    pub seconds: f64,
    pub rays: usize,
    pub fraction: f64,
}

const EXPLORED: Rgb<u8> = Rgb([20, 150, 40]);
const RANDOM: Rgb<u8> = Rgb([230, 120, 20]);
const GRID: Rgb<u8> = Rgb([40, 90, 220]);

/// Plans a scene: every stage from ray casting to the graph.
pub fn plan(scene: &Scene, source: &str, params: &PlanParams) -> Result<Plan, PlanError> {
    let started = Instant::now();
    let seed = params.explore.seed;
    let rays = ray_scene(scene)?;
    let (scene, scale) = scale_stage(scene, &rays, &params.free_space);
    let scene = scene.as_ref();
    let (space, free_space) = space_stage(scene, &rays, &params.free_space)?;
    let (candidates, explore) = explore_stage(scene, &rays, &space, &params.explore);
    let (probes, cluster) = synthesize(scene, &rays, &space, &candidates, params.synthesis.as_ref());
    let (directions, orient) = orient_stage(scene, &rays, &space, &probes.probes);
    let (paths, connect, smooth) = route(scene, &rays, &space, &probes.probes, &directions, seed);
    let (bar_order, order) = order_stage(&probes.probes, &paths, seed);
    let measured = measure(scene, &rays, &space, &probes.probes, params);
    let stats = PlanStats { scale, free_space, explore, cluster, orient, connect, smooth, order, coverage: measured.stats() };
    let map = Map { probes, directions, paths, bar_order };
    let graph = assemble(scene, source, &space, map, &measured, &stats);
    let timings = stats.timings();
    let mut plan = measured.into_plan(graph, stats, timings, started);
    plan.timings.set("plan", "seconds", format::record::Seconds::Total(plan.seconds));
    Ok(plan)
}

/// Greedy exploration: candidate probes until the coverage target.
fn explore_stage(scene: &Scene, rays: &RayScene, space: &FreeSpace, params: &ExploreParams) -> (Vec<Candidate>, ExploreStats) {
    let _span = tracing::info_span!("explore").entered();
    let (candidates, stats) = explore(scene, rays, space, params);
    tracing::info!("explore: {} candidate probes in {:.2} s", candidates.len(), stats.seconds);
    if stats.capped {
        let seen = 100.0 * (1.0 - stats.samples_left as f64 / stats.samples_created.max(1) as f64);
        tracing::warn!("explore stopped at the limit of {} probes with {seen:.1} % of its samples seen (target {:.1} %): the scene needs more; raise --max-probes", params.max_probes, 100.0 * params.coverage_target);
    }
    (candidates, stats)
}

/// The final probes: clustered and synthesized from the candidates, or the
/// candidates themselves (and no clusters) when synthesis is off.
fn synthesize(
    scene: &Scene,
    rays: &RayScene,
    space: &FreeSpace,
    candidates: &[Candidate],
    params: Option<&SynthesisParams>,
) -> (Synthesized, Option<SynthesisStats>) {
    let Some(params) = params else {
        let probes = candidates.iter().map(|c| c.position).collect();
        let user_placed = candidates.iter().map(|c| c.user_placed).collect();
        return (Synthesized { probes, user_placed, cluster_of: Vec::new(), clusters: Vec::new() }, None);
    };
    let _span = tracing::info_span!("cluster").entered();
    let (out, stats) = cluster::synthesize(scene, rays, space, candidates, params);
    tracing::info!(
        "{} candidates -> {} clusters -> {} probes ({} added back, {} dropped as seen by the rest) in {:.2} s",
        stats.candidates,
        stats.clusters,
        stats.final_probes,
        stats.added_back,
        stats.pruned,
        stats.seconds
    );
    (out, Some(stats))
}

/// Each probe's preferred view directions, best first (at most three kept).
fn orient_stage(scene: &Scene, rays: &RayScene, space: &FreeSpace, probes: &[Vec3]) -> (Vec<Vec<format::ViewDirection>>, Seconds) {
    let started = Instant::now();
    let diagonal = scene.bounds().diagonal();
    let directions = probes
        .par_iter()
        .map(|&p| {
            let preferred = orient::preferred_directions(rays, p, space.near, diagonal);
            preferred.into_iter().take(3).map(|p| format::ViewDirection { yaw: p.yaw, pitch: p.pitch, goodness: p.goodness }).collect()
        })
        .collect();
    (directions, Seconds { seconds: started.elapsed().as_secs_f64() })
}

/// Connects the probes, smooths and times the paths (arriving facing the
/// destination's preferred direction).
fn route(
    scene: &Scene,
    rays: &RayScene,
    space: &FreeSpace,
    probes: &[Vec3],
    directions: &[Vec<format::ViewDirection>],
    seed: u64,
) -> (Vec<format::Path>, ConnectStats, SmoothStats) {
    let _span = tracing::info_span!("connect").entered();
    let (raw, connect_stats) = connect::connect(rays, space, probes, &ConnectParams { seed, ..Default::default() });
    let started = Instant::now();
    let smoothed: Vec<(Vec<Vec3>, smooth::SmoothingStats)> = raw.par_iter().map(|r| smooth::smooth(rays, space, &r.polyline)).collect();
    let smoothing_s = started.elapsed().as_secs_f64();
    let paths = raw
        .iter()
        .zip(&smoothed)
        .enumerate()
        .map(|(id, (r, (polyline, _)))| {
            let length = connect::polyline_length(polyline);
            let duration_s = smooth::duration(length, scene.metres_per_unit);
            let arrival = directions[r.to].first().map(|d| (d.yaw, d.pitch));
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
    if connect_stats.islands.len() > 1 {
        let named: Vec<String> = connect_stats.islands.iter().map(|group| format!("{:?}", group)).collect();
        tracing::warn!("the probes form {} groups no path joins (no free way between them, walking or gliding, keeps the near distance: a sealed room, a narrow gap): {}; the viewer jumps between them", named.len(), named.join(", "));
    }
    let n = smoothed.len().max(1) as f64;
    let smooth_stats = SmoothStats {
        paths: smoothed.len(),
        seconds: smoothing_s,
        seconds_per_path: smoothing_s / n,
        iterations_max: smoothed.iter().map(|s| s.1.iterations).max().unwrap_or(0),
        blocked_segments: smoothed.iter().map(|s| s.1.blocked_segments).sum::<usize>(),
        min_clearance: smoothed.iter().map(|s| s.1.min_clearance).fold(f32::INFINITY, f32::min),
        mean_clearance: smoothed.iter().map(|s| s.1.mean_clearance as f64).sum::<f64>() / n,
        near_distance: space.near,
    };
    (paths, connect_stats, smooth_stats)
}

/// The thumbnail bar's order: probe pairs weighed by 1 / path length, or by
/// 1 / Euclidean distance when no path joins any probes.
fn order_stage(probes: &[Vec3], paths: &[format::Path], seed: u64) -> (Vec<u32>, OrderSummary) {
    let points: Vec<[f32; 3]> = probes.iter().map(|p| p.to_array()).collect();
    let edges = if paths.is_empty() {
        order::euclidean_edges(&points)
    } else {
        paths.iter().map(|p| (p.from as usize, p.to as usize, 1.0 / (p.length as f64).max(1e-9))).collect()
    };
    let started = Instant::now();
    let (bar_order, stats) = order::order(points.len(), &edges, seed);
    (bar_order, OrderSummary { stats, seconds: started.elapsed().as_secs_f64() })
}

/// Measures the coverage of a planned graph's probes again (e.g. with more
/// samples). The navigable component is the one holding the first probe.
/// The graph keeps its other stages' stats.
pub fn remeasure(scene: &Scene, mut graph: format::Graph, params: &PlanParams) -> Result<Plan, PlanError> {
    let started = Instant::now();
    let mut free_params = params.free_space.clone();
    free_params.start = graph.probes.first().map(|p| Vec3::from(p.position));
    let rays = ray_scene(scene)?;
    let (space, free_space) = space_stage(scene, &rays, &free_params)?;
    let probes: Vec<Vec3> = graph.probes.iter().map(|p| Vec3::from(p.position)).collect();
    let measured = measure(scene, &rays, &space, &probes, params);
    let stats = PlanStats { free_space, coverage: measured.stats(), ..Default::default() };
    graph.coverage = Some(measured.entry());
    graph.stats.stages.insert("coverage".into(), serde_json::to_value(&stats.coverage).expect("JSON of plain values"));
    let mut timings = Timings::default();
    for (stage, seconds) in [("free_space", stats.free_space.seconds), ("coverage", stats.coverage.seconds)] {
        timings.set(stage, "seconds", format::record::Seconds::Total(seconds));
    }
    Ok(measured.into_plan(graph, stats, timings, started))
}

fn ray_scene(scene: &Scene) -> Result<RayScene, PlanError> {
    let _span = tracing::info_span!("raycast").entered();
    Ok(RayScene::new(&scene.positions, &scene.triangles, 0)?)
}

/// The scene at the scale planning uses: as stated or given; else measured
/// from its own heights ([`crate::plan::scale`]), trusted when sure, used untrusted
/// when unsure but a common unit; else the guess from its size, untrusted
/// (free space then decides whether to walk from its rooms' heights).
fn scale_stage<'a>(scene: &'a Scene, rays: &RayScene, params: &FreeSpaceParams) -> (Cow<'a, Scene>, ScaleStats) {
    let started = Instant::now();
    let source = |s: ScaleSource| match s {
        ScaleSource::File => "file",
        ScaleSource::User => "user",
        ScaleSource::Guessed => "guessed",
        ScaleSource::Measured => "measured",
    };
    if scene.scale_source != ScaleSource::Guessed {
        let reason =
            format!("{} m a unit, {}", scene.metres_per_unit, if scene.scale_source == ScaleSource::User { "given" } else { "stated by the scene" });
        let stats = ScaleStats { metres_per_unit: scene.metres_per_unit, source: source(scene.scale_source), reason, measured: None, seconds: 0.0 };
        return (Cow::Borrowed(scene), stats);
    }
    let _span = tracing::info_span!("scale").entered();
    // An object's heights are not a building's: its scale only sizes the
    // free flight around it, and the size tells that well enough.
    let object = match params.space {
        SpaceMode::Outside => true,
        SpaceMode::Inside => false,
        SpaceMode::Auto => crate::plan::freespace::facing_out(scene, rays, &scene.bounds(), params.seed) > crate::plan::freespace::FACING_OUT_OBJECT,
    };
    if object {
        let reason = format!("{} m a unit, guessed from the size alone: an object, whose heights are not a building's", scene.metres_per_unit);
        return (
            Cow::Borrowed(scene),
            ScaleStats {
                metres_per_unit: scene.metres_per_unit,
                source: "guessed",
                reason,
                measured: None,
                seconds: started.elapsed().as_secs_f64(),
            },
        );
    }
    let measured = scale::guess(scene, rays);
    let (m, scale_source, reason) = match &measured {
        Some(g) if g.sure => (g.metres_per_unit, ScaleSource::Measured, format!("measured: {}", g.describe())),
        // Unsure, the evidence is believed only where it lands on a unit
        // people model in; else the size's guess stands.
        Some(g) if g.unit.is_some() => (g.metres_per_unit, ScaleSource::Guessed, format!("not sure: {}; pass --metres-per-unit", g.describe())),
        Some(g) => (
            scene.metres_per_unit,
            ScaleSource::Guessed,
            format!("not sure: {}; kept {} m a unit from the size; pass --metres-per-unit", g.describe(), scene.metres_per_unit),
        ),
        None => (
            scene.metres_per_unit,
            ScaleSource::Guessed,
            format!("{} m a unit, guessed from the size alone: no floors under ceilings to measure", scene.metres_per_unit),
        ),
    };
    tracing::info!("scale: {reason}");
    let stats =
        ScaleStats { metres_per_unit: m, source: source(scale_source), reason, measured: measured.clone(), seconds: started.elapsed().as_secs_f64() };
    if m == scene.metres_per_unit && scale_source == scene.scale_source {
        return (Cow::Borrowed(scene), stats);
    }
    let mut settled = scene.clone();
    settled.metres_per_unit = m;
    settled.scale_source = scale_source;
    (Cow::Owned(settled), stats)
}

fn space_stage(scene: &Scene, rays: &RayScene, params: &FreeSpaceParams) -> Result<(FreeSpace, FreeSpaceStats), PlanError> {
    let (space, stats) = {
        let _span = tracing::info_span!("free space").entered();
        free_space(scene, rays, params)?
    };
    tracing::info!("space: {} ({}); {} ({})", stats.space, stats.space_reason, stats.height, stats.height_reason);
    tracing::info!(
        "free space: {} navigable voxels of {:.3} units, near distance {:.3}; open space {} voxels, {} inside closed solids",
        stats.navigable,
        stats.voxel,
        stats.near,
        stats.open,
        stats.solid
    );
    Ok((space, stats))
}

/// The coverage stage's results: the metric, its baselines and pictures.
struct Measured {
    report: CoverageReport,
    baselines: Vec<Baseline>,
    images: Vec<(String, RgbImage)>,
    per_material: Vec<(String, f64, f64)>,
    per_object: Vec<(String, f64, f64)>,
    seconds: f64,
}

impl Measured {
    fn stats(&self) -> CoverageStats {
        CoverageStats { seconds: self.report.seconds, rays: self.report.rays, fraction: self.report.fraction() }
    }

    /// graph.json's coverage entry.
    fn entry(&self) -> format::Coverage {
        let report = &self.report;
        format::Coverage {
            samples: report.samples.points.len() as u32,
            reachable_area: report.reachable_area,
            covered_area: report.covered_area,
            ceiling: Some(report.ceiling()),
            per_group: self
                .per_material
                .iter()
                .map(|(name, r, c)| format::GroupCoverage { name: name.clone(), reachable_area: *r, covered_area: *c })
                .collect(),
            curve: report.curve.clone(),
        }
    }

    fn into_plan(self, graph: format::Graph, stats: PlanStats, timings: Timings, started: Instant) -> Plan {
        let Measured { report, baselines, images, per_material, per_object, seconds } = self;
        Plan {
            graph,
            stats,
            coverage: report,
            baselines,
            images,
            per_material,
            per_object,
            seconds: started.elapsed().as_secs_f64(),
            report_seconds: seconds,
            timings,
        }
    }
}

/// Coverage, baselines and pictures for the probes.
fn measure(scene: &Scene, rays: &RayScene, space: &FreeSpace, probes: &[Vec3], params: &PlanParams) -> Measured {
    let started = Instant::now();
    let report = {
        let _span = tracing::info_span!("coverage").entered();
        coverage(scene, rays, space, probes, &params.coverage)
    };
    let baselines = baselines(rays, space, probes.len(), params.explore.seed, &report);
    let floor =
        ([&report].into_iter().chain(baselines.iter().map(|b| &b.report))).filter_map(|r| r.curve.first().map(|c| c.1)).fold(1.0f64, f64::min);
    let mut curves: Vec<report::Curve> = vec![(&report.curve, EXPLORED)];
    for b in &baselines {
        curves.push((&b.report.curve, if b.name == "random" { RANDOM } else { GRID }));
    }
    let subject = report::Subject { scene, rays, report: &report, probes };
    let mut images = vec![
        ("coverage_curve.png".to_string(), report::coverage_chart(&curves, (floor - 0.05).clamp(0.0, 0.9), 640, 400)),
        ("coverage_top.png".to_string(), report::top_view(&subject, space, 800)),
    ];
    if let Some(eye) = space.most_open_point() {
        let e = scene.bounds().extent();
        let long = if e.x >= e.z { Vec3::X } else { Vec3::Z };
        for (k, forward) in [long, -long].into_iter().enumerate() {
            images.push((format!("coverage_view_{k}.png"), report::perspective_view(&subject, eye, forward, 640)));
        }
    }
    let per_material = report.per_group(&scene.triangle_material, &scene.materials.iter().map(|m| m.name.clone()).collect::<Vec<_>>());
    let per_object = report.per_group(&scene.triangle_object, &scene.objects);
    Measured { report, baselines, images, per_material, per_object, seconds: started.elapsed().as_secs_f64() }
}

/// Random navigable points and a regular lattice of navigable points, `count`
/// of each, measured with the same metric on the same samples as `base`.
pub fn baselines(rays: &RayScene, space: &FreeSpace, count: usize, seed: u64, base: &CoverageReport) -> Vec<Baseline> {
    let navigable = space.navigable_points();
    if navigable.is_empty() || count == 0 {
        return Vec::new();
    }
    let mut rng = crate::seeds::Stream::Baseline.rng(seed);
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

/// The bundle's graph: the scene, the probes with their directions and
/// clusters, the paths in bar order, the coverage and the stages' figures.
fn assemble(scene: &Scene, source: &str, space: &FreeSpace, map: Map, measured: &Measured, stats: &PlanStats) -> format::Graph {
    let Map { probes, directions, paths, bar_order } = map;
    let b = scene.bounds();
    let mut graph = format::Graph::new(format::SceneInfo {
        name: scene.name.clone(),
        source: source.to_string(),
        triangles: scene.triangles.len() as u64,
        bounds_min: b.min.to_array(),
        bounds_max: b.max.to_array(),
        metres_per_unit: scene.metres_per_unit,
        scale_source: stats.scale.source.to_string(),
        space: Some(space.space.name().to_string()),
        near_distance: Some(space.near),
        eye_height_m: space.walk.as_ref().map(|w| w.eye * scene.metres_per_unit),
        credits: Vec::new(),
    });
    graph.probes = probes
        .probes
        .iter()
        .zip(directions)
        .enumerate()
        .map(|(i, (p, preferred_directions))| format::Probe {
            id: i as u32,
            position: p.to_array(),
            cluster: probes.cluster_of.get(i).copied(),
            preferred_directions,
            user_placed: probes.user_placed[i],
            assets: format::ProbeAssets::default(),
        })
        .collect();
    graph.clusters = probes
        .clusters
        .iter()
        .enumerate()
        .map(|(i, &(probe, merged))| format::Cluster { id: i as u32, probe: probe as u32, candidates: merged as u32 })
        .collect();
    graph.paths = paths;
    graph.bar_order = bar_order;
    graph.coverage = Some(measured.entry());
    if let serde_json::Value::Object(entries) = serde_json::to_value(stats).expect("JSON of plain values") {
        graph.stats.stages.extend(entries);
    }
    graph
}

/// The map the stages made: the probes, each one's preferred directions,
/// the paths, and the thumbnail bar's order.
struct Map {
    probes: Synthesized,
    directions: Vec<Vec<format::ViewDirection>>,
    paths: Vec<format::Path>,
    bar_order: Vec<u32>,
}

#[cfg(test)]
mod tests {
    //! One walkable map on each awkward kind of scene, planned as a new user
    //! would (no scale given, every choice `auto`).
    use super::*;
    use crate::raycast::Ray;
    use exploremaps_scenes::awkward::awkward;

    fn planned(name: &str) -> (Scene, f32, Plan) {
        let (scene, truth) = awkward(name).unwrap();
        let params = PlanParams {
            synthesis: Some(Default::default()),
            coverage: CoverageParams { samples: 4000, ..Default::default() },
            ..Default::default()
        };
        let plan = plan(&scene, name, &params).unwrap_or_else(|e| panic!("{name}: {e}"));
        (scene, truth, plan)
    }

    fn walking(plan: &Plan) -> bool {
        plan.graph.scene.eye_height_m.is_some()
    }

    #[test]
    fn a_suite_joined_only_by_doors_is_one_walking_map_with_probes_in_the_open() {
        let (scene, truth, plan) = planned("suite");
        let g = &plan.graph;
        assert!((g.scene.metres_per_unit / truth - 1.0).abs() < 0.25, "scale {}: {}", g.scene.metres_per_unit, plan.stats.scale.reason);
        assert!(walking(&plan), "{}", plan.stats.free_space.height_reason);
        assert!(g.probes.len() >= 3, "{} probes in six rooms", g.probes.len());
        assert_eq!(plan.stats.connect.components, 1, "{:?}", plan.stats.connect);
        // Every probe at least 0.9 m from the walls at eye height (the rooms are 4 m deep and more).
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let metre = 1.0 / g.scene.metres_per_unit;
        for p in &g.probes {
            let eye = Vec3::from(p.position);
            for k in 0..32 {
                let a = k as f32 * std::f32::consts::TAU / 32.0;
                let hit = rays.intersect(&Ray::new(eye, Vec3::new(a.cos(), 0.0, a.sin())));
                assert!(hit.is_none_or(|h| h.t >= 0.9 * metre), "probe {} is {:.2} m from a wall", p.id, hit.unwrap().t / metre);
            }
        }
    }

    #[test]
    fn terraces_a_metre_apart_are_joined_by_gliding() {
        let (_, _, plan) = planned("blocks");
        assert!(walking(&plan), "{}", plan.stats.free_space.height_reason);
        let levels: Vec<i32> = plan.graph.probes.iter().map(|p| (p.position[1] - 1.6).round() as i32).collect();
        assert!(levels.iter().any(|&l| l != levels[0]), "probes stand on one terrace only: {levels:?}");
        assert_eq!(plan.stats.connect.components, 1, "{:?}", plan.stats.connect);
        assert!(plan.stats.connect.glided >= 1, "{:?}", plan.stats.connect);
        assert_eq!(plan.stats.smooth.blocked_segments, 0);
    }

    #[test]
    fn a_block_city_is_one_walking_map_over_its_terraces_and_none_in_its_sealed_house() {
        let (_, truth, plan) = planned("block_city");
        let g = &plan.graph;
        assert!((g.scene.metres_per_unit / truth - 1.0).abs() < 0.25, "{}", plan.stats.scale.reason);
        assert!(walking(&plan), "{}", plan.stats.free_space.height_reason);
        assert_eq!(plan.stats.connect.components, 1, "{:?}", plan.stats.connect);
        // The street is at 1, the hill's lots at 2 to 4 (1 m ledges between).
        let mut levels: Vec<i32> = g.probes.iter().map(|p| (p.position[1] - 1.6).round() as i32).collect();
        levels.sort();
        levels.dedup();
        assert!([1, 2, 3, 4].iter().all(|l| levels.contains(l)), "probes stand at levels {levels:?}");
        // Houses stand 5 blocks into each lot of 16, 8 to 10 blocks a side.
        let in_a_house = |p: &[f32; 3]| {
            let (x, z) = (p[0].rem_euclid(16.0), p[2].rem_euclid(16.0));
            (5.0..15.0).contains(&x) && (5.0..15.0).contains(&z)
        };
        assert!(g.probes.iter().any(|p| p.position[1] > 3.0 && !in_a_house(&p.position)), "no probe on the hill's open terraces");
        // The sealed house: blocks x 37..45, z 21..29.
        let sealed = |p: &[f32; 3]| (37.0..45.0).contains(&p[0]) && (21.0..29.0).contains(&p[2]);
        assert!(!g.probes.iter().any(|p| sealed(&p.position)), "a probe in the sealed house");
        // ... and the report names it as left out, and why.
        let named = plan.stats.free_space.left_out.iter().any(|p| sealed(&p.centre) && p.why.starts_with("sealed off"));
        assert!(named, "{:?}", plan.stats.free_space.left_out);
    }

    #[test]
    fn a_conference_room_in_feet_walks_at_its_floor_never_on_the_table() {
        let (_, truth, plan) = planned("conference");
        let g = &plan.graph;
        assert_eq!(g.scene.scale_source, "measured", "{}", plan.stats.scale.reason);
        assert!((g.scene.metres_per_unit / truth - 1.0).abs() < 0.25);
        assert!(walking(&plan));
        // The floor is at 0; the table top at 0.75 m: every eye is 1.6 m above the floor.
        for p in &g.probes {
            let eye_m = p.position[1] * g.scene.metres_per_unit;
            assert!((eye_m - 1.6).abs() < 0.1, "probe {} has its eye {eye_m:.2} m above the floor", p.id);
        }
        assert_eq!(plan.stats.connect.components, 1);
    }

    #[test]
    fn a_car_is_an_object_seen_from_around_it_not_scaled_up_into_a_room() {
        // Its cabin's heights would make a room of it at 6 m a unit; unsure
        // and no common unit, the size's guess stands. Its cabin is a small
        // share of its box and it shows no ground: the space around it is
        // the map, one piece, and the sealed cabin is left out.
        let (_, truth, plan) = planned("car");
        assert_eq!(plan.graph.scene.metres_per_unit, truth, "{}", plan.stats.scale.reason);
        assert_ne!(plan.graph.scene.scale_source, "measured");
        assert_eq!(plan.stats.free_space.space, "outside", "{}", plan.stats.free_space.space_reason);
        assert!(!walking(&plan), "{}", plan.stats.free_space.height_reason);
        assert_eq!(plan.stats.connect.components, 1);
        // The cabin (awkward.rs): x 1.2–3.6, y 0.4–1.38, z 0.04–1.76.
        let in_cabin = |p: [f32; 3]| p[0] > 1.2 && p[0] < 3.6 && p[1] > 0.4 && p[1] < 1.38 && p[2] > 0.04 && p[2] < 1.76;
        assert!(plan.graph.probes.iter().all(|p| !in_cabin(p.position)));
    }
}

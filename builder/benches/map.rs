//! One walkable map on any scene (issue 67): for each shared, built-in and
//! awkward scene, as a new user would plan it (no scale given; the shared
//! scenes as shipped), prints per plan (auto, then free flight):
//! - the guessed scale against the true one (goal: within a factor 1.25), and
//!   whether it walks by default (goal: every piece of architecture);
//! - connected components of the graph, counted here from its paths (goal: 1);
//! - standpoints, measured here with their own rays (walking plans): probes
//!   nearer than 1 m to a wall where the space is 2 m wide or more, or off the
//!   middle line of a narrower one; probes in a door frame; on furniture; and
//!   the largest share of a probe's view within 1 m (goal: under 5 %);
//! - planning time, without the report (coverage, baselines and pictures;
//!   printed after it) (goals: ≤ 30 s under 1 M triangles, ≤ 10 s on the Sponzas);
//! - coverage against a plain greedy cover over 3,000 random standpoints of
//!   the same space at the same probe count (goal: within 2 points).
//!
//! `cargo bench -p exploremaps-builder --bench map`; SCENES (comma list)
//! narrows the run, MODES=auto or fly keeps one mode, DETAIL=1 lists the
//! flagged probes; SCALE_ONLY=1 prints the scale alone (=peaks: the
//! posterior's peaks; =gaps: the measured gaps at the true scale), KIND=1
//! the kind's evidence.

use exploremaps_builder::plan::coverage::coverage_like;
use exploremaps_builder::plan::explore::{explore, ExploreParams};
use exploremaps_builder::plan::freespace::{free_space, FreeSpaceParams, HeightMode};
use exploremaps_builder::plan::{plan, PlanParams};
use exploremaps_builder::raycast::{Packing, Ray, RayScene};
use exploremaps_builder::scene_io::{load, LoadOptions};
use exploremaps_scenes::awkward::{awkward, AWKWARD};
use exploremaps_scenes::{BuiltIn, Scene};
use glam::Vec3;
use petgraph::unionfind::UnionFind;
use std::path::Path;

/// A scene to plan: its name, the scene, its true metres a unit when known,
/// and whether it is architecture (should walk by default).
struct Case {
    name: String,
    scene: Scene,
    truth: Option<f32>,
    architecture: bool,
}

fn main() {
    let only: Option<Vec<String>> = std::env::var("SCENES").ok().map(|s| s.split(',').map(str::to_string).collect());
    let cases = load_cases(only.as_deref());
    if std::env::var("KIND").is_ok() {
        cases.iter().for_each(print_kind);
        return;
    }
    if let Ok(detail) = std::env::var("SCALE_ONLY") {
        cases.iter().for_each(|case| print_scale(case, &detail));
        return;
    }
    #[rustfmt::skip]
    println!(
        "{:<10} {:<4} {:>8} {:>9} {:>6} {:>5} {:<5} {:<7} {:>6} {:>5} {:>6} {:>5} {:>5} {:>5} {:>6} {:>7} {:>6} {:>7}",
        "scene", "mode", "tris", "scale", "truth", "ratio", "walk", "space", "probes", "comps", "plan s", "wall", "door", "furn", "near%", "inside", "cover%", "greedy%"
    );
    let modes = std::env::var("MODES").unwrap_or_else(|_| "auto,fly".into());
    for case in &cases {
        for mode in modes.split(',') {
            bench_plan(case, mode);
        }
    }
    print_legend();
}

/// The shared scenes, the awkward ones and the built-ins that SCENES names (all by default).
fn load_cases(only: Option<&[String]>) -> Vec<Case> {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes");
    let wanted = |name: &str| only.is_none_or(|o| o.iter().any(|w| w == name));
    let case = |name: &str, scene, truth, architecture| Case { name: name.to_string(), scene, truth, architecture };
    let mut cases = Vec::new();
    for (name, file, truth, architecture) in [
        ("crytek", "sponza_crytek/sponza_crytek.obj", Some(0.2), true),
        ("dabrovic", "sponza_dabrovic/sponza.obj", Some(1.0), true),
        ("cornell", "cornell_box/CornellBox-Original.obj", None, false),
        ("bunny", "stanford_bunny/bun_zipper.ply", Some(1.0), false),
        ("staircase", "wooden_staircase/wooden_staircase.obj", Some(1.0), true),
        ("grey_room", "grey_white_room/grey_white_room.obj", Some(1.0), true),
        ("apartment", "dream_apartment/dream_apartment.glb", Some(1.0), true),
    ] {
        let canonical = name == "crytek" && wanted("crytek_cm");
        if !(wanted(name) || canonical) {
            continue;
        }
        match load(&shared.join(file), &LoadOptions::default()) {
            Ok(scene) => {
                if canonical {
                    // The canonical Crytek Sponza's own units (centimetres): the shared copy is scaled by 1/20.
                    let mut canonical = scene.clone();
                    canonical.positions.iter_mut().for_each(|p| *p *= 20.0);
                    cases.push(case("crytek_cm", canonical, Some(0.01), true));
                }
                if wanted(name) {
                    cases.push(case(name, scene, truth, architecture))
                }
            }
            Err(e) => println!("SKIPPED {name}: {e}"),
        }
    }
    for name in AWKWARD.into_iter().filter(|n| wanted(n)) {
        let (scene, unit) = awkward(name).expect("listed");
        cases.push(case(name, scene, Some(unit), name != "car"));
    }
    // The built-ins, and any other built-in named (big:5000000, maze:40).
    let named = only.into_iter().flatten().filter(|n| n.contains(':')).map(String::as_str);
    for name in ["gallery", "maze", "pillars", "island", "house", "cathedral"].into_iter().chain(named) {
        if let Some(b) = BuiltIn::parse(name).filter(|_| wanted(name)) {
            let scene = b.generate(1);
            let m = scene.metres_per_unit;
            cases.push(case(name, scene, Some(m), true));
        }
    }
    cases
}

/// KIND=1: the evidence the kind of scene is decided on.
fn print_kind(case: &Case) {
    let (scene, architecture) = (&case.scene, case.architecture);
    let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
    let b = scene.bounds();
    let facing = exploremaps_builder::plan::freespace::facing_out(scene, &rays, &b, 1);
    let (enclosed, ground) = exploremaps_builder::plan::freespace::kind_evidence(&rays, &b, 1);
    println!(
        "{:<10} architecture {architecture:<5} facing out {facing:.2} enclosed {enclosed:.2} ground {ground:.2} height {:.2} m",
        case.name,
        b.extent().y * scene.metres_per_unit
    );
}

/// SCALE_ONLY=1: the guessed scale; =peaks adds the posterior's peaks, =gaps the measured gaps.
fn print_scale(case: &Case, detail: &str) {
    use exploremaps_builder::plan::scale;
    let (scene, truth) = (&case.scene, case.truth);
    let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
    let t = std::time::Instant::now();
    let said = scale::guess(scene, &rays).as_ref().map_or("no evidence".to_string(), |g| g.describe());
    let truth_said = truth.map_or("-".into(), |t| t.to_string());
    println!("{:<10} truth {truth_said:>7} ({:?}): {said} [{:.2} s]", case.name, scene.scale_source, t.elapsed().as_secs_f64());
    if detail == "peaks" {
        // The posterior's local peaks, best first.
        let post = scale::posterior(&scale::evidence(scene, &rays));
        let mut peaks: Vec<(f64, f64)> =
            (1..post.len() - 1).filter(|&k| post[k].1 >= post[k - 1].1 && post[k].1 > post[k + 1].1).map(|k| post[k]).collect();
        peaks.sort_by(|a, b| b.1.total_cmp(&a.1));
        let top = peaks.first().map_or(0.0, |p| p.1);
        let shown: Vec<String> = peaks.iter().take(6).map(|(s, l)| format!("{:.4} ({:+.1})", s.exp(), l - top)).collect();
        println!("{:<10} peaks: {}", "", shown.join(", "));
    }
    if detail == "gaps" {
        // Gaps at the true scale, metres, in bins of a fifth of a decade.
        let t = truth.unwrap_or(1.0);
        let evidence = scale::evidence(scene, &rays);
        for (what, heights) in [("gaps", &evidence.gaps), ("parapets", &evidence.parapets)] {
            let mut bins = [0usize; 25];
            for g in heights {
                let b = ((g * t).log10() * 5.0 + 15.0).floor();
                if (0.0..25.0).contains(&b) {
                    bins[b as usize] += 1;
                }
            }
            let shown: Vec<String> =
                bins.iter().enumerate().filter(|b| *b.1 > 0).map(|(k, n)| format!("{:.2}:{n}", 10f32.powf((k as f32 - 15.0) / 5.0))).collect();
            println!("{:<10} {what} (m from): {}", "", shown.join(" "));
        }
    }
}

/// Plans a scene in one mode (auto or fly) and prints its row, the plan's
/// reasons and stage times, and the groups when the graph is in pieces.
fn bench_plan(case: &Case, mode: &str) {
    let (name, scene) = (&case.name, &case.scene);
    let height = if mode == "fly" { HeightMode::Fly } else { HeightMode::Auto };
    let params =
        PlanParams { free_space: FreeSpaceParams { height, ..Default::default() }, synthesis: Some(Default::default()), ..Default::default() };
    let result = match plan(scene, name, &params) {
        Ok(r) => r,
        Err(e) => {
            println!("{name:<10} {mode:<4} no plan: {e}");
            return;
        }
    };
    let g = &result.graph;
    let m = g.scene.metres_per_unit;
    let probes: Vec<Vec3> = g.probes.iter().map(|p| Vec3::from(p.position)).collect();
    let mut groups = UnionFind::new(probes.len());
    for p in &g.paths {
        groups.union(p.from as usize, p.to as usize);
    }
    let comps = (0..probes.len()).filter(|&k| groups.find_mut(k) == k).count();
    let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
    let walking = g.scene.eye_height_m.is_some();
    let stands: Vec<Standpoint> = probes.iter().map(|&p| standpoint(&rays, p, 1.0 / m)).collect();
    let count = |flag: fn(&Standpoint) -> bool| if walking { stands.iter().filter(|s| flag(s)).count().to_string() } else { "-".into() };
    let near = stands.iter().map(|s| s.near_share).fold(0.0f32, f32::max);
    if std::env::var("DETAIL").is_ok() {
        print_flagged(&stands, &probes, m);
    }
    let greedy = greedy_coverage(case, &result, &rays, height).map_or("-".into(), |c| format!("{:.1}", 100.0 * c));
    let ratio = case.truth.map_or("-".into(), |t| format!("{:.2}", (m / t).max(t / m)));
    let walk_goal = match (walking, case.architecture && mode == "auto") {
        (true, _) => "yes",
        (false, true) => "NO",
        (false, false) => "no",
    };
    println!(
        "{name:<10} {mode:<4} {:>8} {m:>9.4} {:>6} {ratio:>5} {walk_goal:<5} {:<7} {:>6} {comps:>5} {:>6.1} {:>5} {:>5} {:>5} {:>6.1} {:>7} {:>6.1} {greedy:>7}",
        scene.triangles.len(),
        case.truth.map_or("-".into(), |t| format!("{t}")),
        g.scene.space.as_deref().unwrap_or("-"),
        probes.len(),
        result.seconds - result.report_seconds,
        count(|s| s.too_near_wall),
        count(|s| s.door_frame),
        count(|s| s.on_furniture),
        100.0 * near,
        stands.iter().filter(|s| s.inside).count(),
        100.0 * result.coverage.fraction(),
    );
    print_reasons(&result.stats);
    if comps > 1 {
        let mut by_root: std::collections::BTreeMap<usize, Vec<String>> = Default::default();
        for (k, p) in probes.iter().enumerate() {
            by_root.entry(groups.find_mut(k)).or_default().push(format!("{k}@({:.1},{:.1},{:.1})m", p.x * m, p.y * m, p.z * m));
        }
        for group in by_root.values() {
            println!("{:<10} group: {}", "", group.join(" "));
        }
    }
}

/// DETAIL=1: each flagged probe, where it is and what the checks found.
fn print_flagged(stands: &[Standpoint], probes: &[Vec3], m: f32) {
    let flagged = |s: &Standpoint| s.too_near_wall || s.door_frame || s.on_furniture || s.near_share > 0.05 || s.inside;
    for (k, (s, p)) in stands.iter().zip(probes).enumerate().filter(|(_, (s, _))| flagged(s)) {
        println!(
            "  probe {k} at {:.2?}: wall {} door {} furniture {} near {:.1} % inside {} (nearest wall {:.2} m, across {:.2} m)",
            p.to_array(),
            s.too_near_wall,
            s.door_frame,
            s.on_furniture,
            100.0 * s.near_share,
            s.inside,
            s.nearest * m,
            s.across * m
        );
    }
}

/// Coverage of a plain greedy cover over 3,000 random standpoints of the
/// same space (eye height when walking), as many probes as the plan has;
/// None when the space cannot be built at the plan's scale.
fn greedy_coverage(case: &Case, result: &exploremaps_builder::plan::Plan, rays: &RayScene, height: HeightMode) -> Option<f64> {
    let g = &result.graph;
    let mut at_scale = case.scene.clone();
    at_scale.metres_per_unit = g.scene.metres_per_unit;
    if g.scene.scale_source == "measured" {
        at_scale.scale_source = exploremaps_scenes::ScaleSource::Measured;
    }
    let (space, _) = free_space(&at_scale, rays, &FreeSpaceParams { height, ..Default::default() }).ok()?;
    let params =
        ExploreParams { candidates: 3000, max_probes: g.probes.len(), coverage_target: 1.0, prefer_open: false, seed: 7, ..Default::default() };
    let (chosen, _) = explore(&case.scene, rays, &space, &params);
    let chosen: Vec<Vec3> = chosen.iter().map(|c| c.position).collect();
    Some(coverage_like(&result.coverage, rays, &space, &chosen).fraction())
}

/// The plan's reasons for its scale and space, and its stages' seconds.
fn print_reasons(st: &exploremaps_builder::plan::PlanStats) {
    let fs = &st.free_space;
    println!("{:<10} scale: {}", "", st.scale.reason);
    println!("{:<10} {}; {}", "", fs.space_reason, fs.height_reason);
    let cluster = st.cluster.as_ref().map_or(0.0, |c| c.seconds);
    println!(
        "{:<10} open candidates {}, probes explored off the open {}; parts kept {} of {}; seconds: scale {:.1}, free space {:.1}, explore {:.1}, cluster {:.1}, orient {:.1}, connect {:.1}, smooth {:.1}",
        "", st.explore.open_candidates, st.explore.probes_not_in_the_open, fs.components_kept, fs.components, st.scale.seconds, fs.seconds, st.explore.seconds, cluster, st.orient.seconds, st.connect.seconds, st.smooth.seconds
    );
}

fn print_legend() {
    println!("columns: scale = metres a unit the plan used; ratio = the larger of scale/truth and truth/scale (goal ≤ 1.25);");
    println!("walk = walking plan (NO: architecture planned in flight by default); comps = connected components of the");
    println!("graph's paths (goal 1); wall = probes nearer than 1 m to a wall where the space is 2 m wide or more, or more than");
    println!("0.25 m off the middle of a narrower one; door = probes in a door frame; furn = probes over furniture (the");
    println!("floor 0.5 m around falls by more than 0.3 m); near% = the largest share of a probe's view within 1 m (goal < 5);");
    println!("inside = probes whose rays mostly meet back faces (inside geometry, where the scene's faces are oriented);");
    println!("cover% = the plan's coverage (of the surface its navigable space sees); greedy% = a plain greedy cover over 3,000");
    println!("random standpoints of the same space (eye height when walking), as many probes, same samples (goal: cover% within 2).");
}

struct Standpoint {
    too_near_wall: bool,
    door_frame: bool,
    on_furniture: bool,
    near_share: f32,
    inside: bool,
    /// The nearest wall at eye level, and the width across there.
    nearest: f32,
    across: f32,
}

/// A probe's standpoint, from its own rays; `metre` is a metre in scene units.
fn standpoint(rays: &RayScene, p: Vec3, metre: f32) -> Standpoint {
    const AROUND: usize = 64;
    let level: Vec<Ray> = (0..AROUND)
        .map(|k| {
            let a = k as f32 * std::f32::consts::TAU / AROUND as f32;
            Ray::new(p, Vec3::new(a.cos(), 0.0, a.sin()))
        })
        .collect();
    let far = 100.0 * metre;
    let dist: Vec<f32> = rays.intersect_batch(&level, Packing::Single).iter().map(|h| h.map_or(far, |h| h.t)).collect();
    let width = |k: usize| dist[k] + dist[(k + AROUND / 2) % AROUND];
    let nearest = (0..AROUND).min_by(|&a, &b| dist[a].total_cmp(&dist[b])).unwrap_or(0);
    let too_near_wall =
        if width(nearest) >= 2.0 * metre { dist[nearest] < metre } else { (dist[nearest] - 0.5 * width(nearest)).abs() > 0.25 * metre };
    // A door frame: narrower than 1.5 m across one way, with room 0.6 m ahead and behind.
    let door_frame = (0..AROUND / 2).any(|k| {
        let across = (k + AROUND / 4) % AROUND;
        if width(across) >= 1.5 * metre || dist[k] < 0.6 * metre || dist[k + AROUND / 2] < 0.6 * metre {
            return false;
        }
        let d = level[k].dir;
        let side = level[across].dir;
        let open = |q: Vec3| {
            let hits = rays.intersect_batch(&[Ray::new(q, side), Ray::new(q, -side)], Packing::Single);
            hits.iter().map(|h| h.map_or(far, |h| h.t)).sum::<f32>() > 2.0 * metre
        };
        open(p + d * 0.6 * metre) && open(p - d * 0.6 * metre)
    });
    // Furniture: the floor under the probe stands above the floor around it.
    let down = |q: Vec3| rays.intersect(&Ray::new(q, Vec3::NEG_Y)).map_or(f32::INFINITY, |h| h.t);
    let here = down(p);
    let falls = (0..8)
        .filter(|&k| {
            let a = k as f32 * std::f32::consts::TAU / 8.0;
            down(p + Vec3::new(a.cos(), 0.0, a.sin()) * 0.5 * metre) > here + 0.3 * metre
        })
        .count();
    let on_furniture = here.is_finite() && falls >= 3;
    // The whole view: Fibonacci sphere directions.
    const SPHERE: usize = 1024;
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let sphere: Vec<Ray> = (0..SPHERE)
        .map(|k| {
            let y = 1.0 - 2.0 * (k as f32 + 0.5) / SPHERE as f32;
            let r = (1.0 - y * y).sqrt();
            let a = golden * k as f32;
            Ray::new(p, Vec3::new(r * a.cos(), y, r * a.sin()))
        })
        .collect();
    let hits = rays.intersect_batch(&sphere, Packing::Single);
    let near_share = hits.iter().filter(|h| h.is_some_and(|h| h.t < metre)).count() as f32 / SPHERE as f32;
    let back = sphere.iter().zip(&hits).filter(|(r, h)| h.is_some_and(|h| h.normal.dot(r.dir) > 0.0)).count();
    let inside = back as f32 > 0.5 * SPHERE as f32;
    Standpoint { too_near_wall, door_frame, on_furniture, near_share, inside, nearest: dist[nearest], across: width(nearest) }
}

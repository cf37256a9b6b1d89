//! `exploremaps`: the command-line front end. Glue only: parse arguments, set
//! up logging and threads, call the builder, map errors to exit codes in one
//! place ([`exit_code`]; 1: failure, 2: bad input).

mod cli;
mod progress;
mod serve;

use anyhow::{bail, Context, Result};
use clap::Parser;
use cli::{Cli, Command, PlanArgs, PlanJob, QualityArg, RenderArgs, SceneArgs, ShardArg};
use exploremaps_builder::plan::cluster::SynthesisParams;
use exploremaps_builder::plan::coverage::CoverageParams;
use exploremaps_builder::plan::explore::{ExploreParams, Strategy};
use exploremaps_builder::plan::freespace::{FreeSpaceParams, HeightMode, SpaceMode};
use exploremaps_builder::plan::{self, PlanParams};
use exploremaps_builder::render::{Quality, Settings, Transitions};
use exploremaps_builder::scene_io::{self, LoadError, LoadOptions};
use exploremaps_builder::scenes::{BuiltIn, Light, ScaleSource, Scene, CATALOGUE};
use exploremaps_format::record::PlanRecord;
use exploremaps_format::{Graph, GRAPH_FILE};
use glam::Vec3;
use progress::Progress;
use std::path::Path;
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// A command-line option or name that cannot be used (exit code 2); the
/// crates' own errors are mapped by [`exit_code`].
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
struct BadInput(String);

/// When the program started (the viewer's time to first panorama counts from here).
static STARTED: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();

fn main() -> ExitCode {
    STARTED.get_or_init(Instant::now);
    let cli = Cli::parse();
    init_logging(cli.verbose, cli.quiet);
    if let Err(e) = rayon::ThreadPoolBuilder::new().num_threads(cli.threads.into()).build_global() {
        tracing::warn!("could not set up {} worker threads: {e}", cli.threads);
    }
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(exit_code(&e))
        }
    }
}

/// 2 when what the user gave is at fault (options, scene files, bundles,
/// start points and probes outside the free space, tour and link names), 1
/// for everything else (the program, the disk, the GPU).
fn exit_code(e: &anyhow::Error) -> u8 {
    use exploremaps_builder::{export::TourError, scene_io::write::ExportError};
    use exploremaps_viewer::native::ViewError;
    let bad_input = e.chain().any(|cause| {
        cause.is::<BadInput>()
            || cause.is::<LoadError>()
            || matches!(cause.downcast_ref(), Some(plan::PlanError::FreeSpace(_)))
            || matches!(cause.downcast_ref(), Some(ExportError::Format(_)))
            || matches!(
                cause.downcast_ref(),
                Some(TourError::Image { .. } | TourError::NotRendered(_) | TourError::Occupied(_) | TourError::Library { .. })
            )
            || matches!(cause.downcast_ref(), Some(ViewError::Read { .. } | ViewError::Format { .. } | ViewError::Link(_) | ViewError::Empty))
    });
    if bad_input {
        2
    } else {
        1
    }
}

fn init_logging(verbose: u8, quiet: u8) {
    let level = match (verbose, quiet) {
        (0, 0) => "info",
        (1, _) => "debug",
        (v, _) if v >= 2 => "trace",
        (_, 1) => "warn",
        _ => "error",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level));
    tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).with_target(false).without_time().init();
}

fn run(cli: &Cli) -> Result<()> {
    match &cli.command {
        Command::Info { scene } => info(&load_scene(scene, cli.seed)?.0),
        Command::Plan { job } => plan(job, cli.seed).map(drop),
        Command::Coverage { bundle, samples } => remeasure(bundle, *samples),
        Command::Scenes { name: None, .. } => {
            println!("Built-in scenes (use as SCENE, e.g. `exploremaps info maze:12`):");
            for (name, parameter, about) in CATALOGUE {
                let parameter = if parameter.is_empty() { String::new() } else { format!(" [:{parameter}]") };
                println!("  {:<34} {about}", format!("{name}{parameter}"));
            }
            Ok(())
        }
        Command::Scenes { name: Some(name), output } => {
            let builtin = BuiltIn::parse(name).ok_or_else(|| BadInput(format!("{name} is not a built-in scene; `exploremaps scenes` lists them")))?;
            let scene = builtin.generate(cli.seed);
            match output {
                Some(path) => {
                    exploremaps_builder::scene_io::write::export(&scene, path)?;
                    println!("wrote {} ({} triangles)", path.display(), scene.triangles.len());
                    Ok(())
                }
                None => info(&scene),
            }
        }
        Command::Build { job, render: args } => {
            let settings = render_settings(args, cli.seed)?;
            // The planned graph and the loaded scene go straight on to rendering.
            let planned = plan(job, cli.seed)?;
            render(&job.output, &settings, None, planned)
        }
        Command::Render { bundle, finalize: true, .. } => finalize(bundle),
        Command::Render { bundle, render: args, shard, .. } => {
            let shard = match shard {
                None => None,
                Some(ShardArg::Given(i, n)) => Some((*i, *n)),
                Some(ShardArg::Auto(count)) => {
                    let (i, n, from) = cli::shard_from_env(*count, |name| std::env::var(name).ok()).map_err(BadInput)?;
                    tracing::info!("shard {i}/{n}, from the {from}'s environment");
                    Some((i, n))
                }
            };
            let settings = render_settings(args, cli.seed)?;
            let (graph, scene, _) = open_bundle(bundle)?;
            render(bundle, &settings, shard, (graph, scene))
        }
        Command::View { bundle, probe, yaw, pitch, fov, link, tour, benchmark } => {
            use exploremaps_viewer::{native, ui::Link};
            let link = match link {
                Some(text) => Link::parse(text).map_err(|e| BadInput(format!("--link: {e}")))?,
                None => Link { probe: *probe, yaw_deg: *yaw, pitch_deg: *pitch, fov_deg: *fov, dollhouse: false },
            };
            let options = native::ViewOptions { link, tour: *tour, benchmark: *benchmark, started: *STARTED.get_or_init(Instant::now) };
            Ok(native::run(bundle, options)?)
        }
        Command::Export { bundle, output, to, library } => export_tour(bundle, output.as_deref(), to, library.as_deref()),
        Command::Serve { bundle, address } => serve::serve(bundle, address, web_dir().as_deref()),
    }
}

fn export_tour(bundle: &Path, output: Option<&Path>, to: &[String], library: Option<&Path>) -> Result<()> {
    use exploremaps_builder::export::{self, Viewer};
    if to.iter().any(|t| t == SIMULATOR) {
        if to.len() > 1 {
            bail!(BadInput(format!("--to {SIMULATOR} writes a simulator scan on its own; export the tours in another run")));
        }
        return export_scan(bundle, output);
    }
    let mut viewers = Vec::new();
    for name in to {
        let chosen: Vec<Viewer> = if name == "all" { Viewer::ALL.to_vec() } else { vec![name.parse().map_err(|e| BadInput(format!("--to {e}")))?] };
        for v in chosen {
            if !viewers.contains(&v) {
                viewers.push(v);
            }
        }
    }
    let graph = read_graph(bundle)?;
    let out = output.map_or_else(|| export::default_folder(bundle), Path::to_path_buf);
    let progress = Progress::new("exporting".into(), "probes");
    let started = Instant::now();
    let report = export::export(bundle, &graph, &viewers, &out, library, |done, total| progress.set(done as u64, total as u64))?;
    drop(progress);
    let names: Vec<&str> = viewers.iter().map(|v| v.folder()).collect();
    println!(
        "wrote {}: {} views, {} links, {} tiles, {:.1} MB, for {} in {:.1} s; serve the folder and open index.html",
        out.display(),
        report.probes,
        report.links,
        report.tiles,
        report.bytes as f64 / 1e6,
        names.join(", "),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The name `export --to` takes for the Matterport3D Simulator's layout.
const SIMULATOR: &str = "matterport3d";

/// `export --to matterport3d`: the bundle as a scan of the Matterport3D Simulator.
fn export_scan(bundle: &Path, output: Option<&Path>) -> Result<()> {
    let graph = read_graph(bundle)?;
    let name = bundle.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "bundle".into());
    let out = output.map_or_else(|| bundle.with_file_name(format!("{name}-{SIMULATOR}")), Path::to_path_buf);
    let progress = Progress::new("exporting".into(), "probes");
    let report = exploremaps_builder::export::matterport::export(bundle, &graph, &out, |done, total| progress.set(done as u64, total as u64))?;
    drop(progress);
    println!(
        "wrote {}: scan {} with {} viewpoints ({} with depth) as the Matterport3D Simulator reads it: \
         point its navigation graph at {}/connectivity and its dataset at {}/data/v1/scans",
        out.display(),
        report.scan,
        report.viewpoints,
        report.with_depth,
        out.display(),
        out.display()
    );
    Ok(())
}

/// A file if one exists at that path, else a built-in scene by name; with the
/// source to record in the bundle (an absolute path, or `builtin:<spec>`).
fn load_scene(args: &SceneArgs, seed: u64) -> Result<(Scene, String)> {
    let up =
        scene_io::parse_up_axis(&args.up).ok_or_else(|| BadInput(format!("--up {}: expected x, y or z, optionally signed (e.g. -z)", args.up)))?;
    if let Some(m) = args.metres_per_unit {
        if !(m.is_finite() && m > 0.0) {
            bail!(BadInput(format!("--metres-per-unit {m}: must be a positive number")));
        }
    }
    let path = std::path::Path::new(&args.scene);
    let builtin_name = args.scene.strip_prefix("builtin:");
    if builtin_name.is_none() && (path.exists() || path.extension().is_some()) {
        let spinner = spinner(format!("loading {}", path.display()));
        let started = Instant::now();
        let scene = scene_io::load(path, &LoadOptions { up, metres_per_unit: args.metres_per_unit, max_triangles: args.max_triangles })?;
        spinner.finish_and_clear();
        tracing::info!("loaded {} in {:.2} s", path.display(), started.elapsed().as_secs_f64());
        let source = std::fs::canonicalize(path).unwrap_or(path.to_path_buf()).display().to_string();
        return Ok((scene, source));
    }
    let name = builtin_name.unwrap_or(&args.scene);
    let builtin =
        BuiltIn::parse(name).ok_or_else(|| BadInput(format!("{name}: no such file, and not a built-in scene (`exploremaps scenes` lists them)")))?;
    let mut scene = builtin.generate(seed);
    if let Some(m) = args.metres_per_unit {
        scene.metres_per_unit = m;
        scene.scale_source = ScaleSource::User;
    }
    Ok((scene, format!("builtin:{name}")))
}

/// Rejects planning options no scene could make sense of.
fn check_planning(planning: &PlanArgs) -> Result<()> {
    if !(planning.coverage > 0.0 && planning.coverage <= 1.0) {
        bail!(BadInput(format!("--coverage {}: must be a fraction in (0, 1]", planning.coverage)));
    }
    if planning.near_m.is_some_and(|m| !(m.is_finite() && m > 0.0)) {
        bail!(BadInput("--near-m: must be a positive number of metres".into()));
    }
    if !(planning.eye_height_m.is_finite() && planning.eye_height_m > 0.0) {
        bail!(BadInput("--eye-height-m: must be a positive number of metres".into()));
    }
    Ok(())
}

/// The pipeline's parameters from checked options and the loaded scene's scale.
fn plan_params(planning: &PlanArgs, seed: u64) -> PlanParams {
    PlanParams {
        free_space: FreeSpaceParams {
            space: match planning.space {
                cli::Space::Auto => SpaceMode::Auto,
                cli::Space::Inside => SpaceMode::Inside,
                cli::Space::Outside => SpaceMode::Outside,
            },
            height: match (planning.walk, planning.fly) {
                (true, _) => HeightMode::Walk,
                (_, true) => HeightMode::Fly,
                _ => HeightMode::Auto,
            },
            eye_height_m: planning.eye_height_m,
            max_cells: planning.max_cells,
            near_m: planning.near_m,
            start: planning.start.map(Vec3::from),
            seed,
            ..Default::default()
        },
        explore: ExploreParams {
            strategy: match planning.strategy {
                cli::Strategy::Greedy => Strategy::Greedy,
                cli::Strategy::Occluded => Strategy::Occluded,
            },
            coverage_target: planning.coverage,
            max_probes: planning.max_probes as usize,
            user_probes: planning.probes.iter().map(|&p| Vec3::from(p)).collect(),
            seed,
            ..Default::default()
        },
        synthesis: (!planning.no_cluster).then(|| SynthesisParams { seed, ..Default::default() }),
        coverage: CoverageParams { samples: planning.samples.clamp(1, 10_000_000), seed, ..Default::default() },
    }
}

/// `exploremaps plan`: explore, measure, write the bundle; returns the graph
/// as written and the scene.
fn plan(job: &PlanJob, seed: u64) -> Result<(Graph, Scene)> {
    let (scene_args, output, planning) = (&job.scene, job.output.as_path(), &job.planning);
    check_planning(planning)?;
    let (scene, source) = load_scene(scene_args, seed)?;
    let params = plan_params(planning, seed);
    let spinner = spinner(format!("planning {} ({} triangles)", scene.name, scene.triangles.len()));
    let result = plan::plan(&scene, &source, &params);
    spinner.finish_and_clear();
    let mut plan = result?;
    // What `exploremaps coverage` and `render` need to load the scene again.
    plan.graph.stats.plan = Some(cli::plan_record(scene_args, planning, seed));
    exploremaps_builder::bundle::write_plan(output, &plan)?;
    print_plan(&scene, output, &plan);
    Ok((plan.graph, scene))
}

/// A bundle's graph.json, read and validated; errors are the user's (exit 2).
fn read_graph(bundle: &Path) -> Result<Graph> {
    let graph_path = bundle.join(GRAPH_FILE);
    let text = std::fs::read_to_string(&graph_path).map_err(|e| {
        BadInput(format!("cannot read {}: {e}; is {} a bundle written by `exploremaps plan`?", graph_path.display(), bundle.display()))
    })?;
    Ok(Graph::from_json(&text).map_err(|e| BadInput(format!("{}: {e}", graph_path.display())))?)
}

/// A planned bundle's graph and its scene, loaded as `plan` loaded it.
fn open_bundle(bundle: &Path) -> Result<(Graph, Scene, PlanRecord)> {
    let graph = read_graph(bundle)?;
    let recorded = graph.stats.plan.clone().unwrap_or_default();
    let (mut scene, _) = load_scene(&cli::recorded_scene(&recorded, &graph.scene.source), recorded.seed)
        .with_context(|| format!("the bundle's scene {}", graph.scene.source))?;
    // A scale the plan measured from the scene's heights is the bundle's.
    if scene.scale_source == ScaleSource::Guessed && graph.scene.scale_source == "measured" {
        scene.metres_per_unit = graph.scene.metres_per_unit;
        scene.scale_source = ScaleSource::Measured;
    }
    Ok((graph, scene, recorded))
}

/// Render settings from the command line, checked before any work starts.
fn render_settings(args: &RenderArgs, seed: u64) -> Result<Settings> {
    let quality = match args.quality {
        QualityArg::Preview => Quality::Preview,
        QualityArg::Final => Quality::Final,
        QualityArg::Tour => Quality::Tour,
    };
    let mut settings = Settings::new(quality, seed);
    if let Some(face) = args.face {
        if !(16..=4096).contains(&face) || !face.is_multiple_of(16) {
            bail!(BadInput(format!("--face {face}: use a multiple of 16 from 16 to 4096 (4096 is the safe texture limit on phones)")));
        }
        settings.face = face;
    }
    if let Some(width) = args.video_width {
        if !(64..=4096).contains(&width) || !width.is_multiple_of(32) {
            bail!(BadInput(format!(
                "--video-width {width}: use a multiple of 32 from 64 to 4096 (video frames are width x width/2, both multiples of 16)"
            )));
        }
        settings.video_width = width;
    }
    if !(100..=2_000_000).contains(&args.proxy_triangles) {
        bail!(BadInput(format!("--proxy-triangles {}: use 100 to 2000000 (phones show about 25000 well)", args.proxy_triangles)));
    }
    settings.proxy.detail_triangles = args.proxy_triangles;
    settings.proxy.base_triangles = args.proxy_triangles / 10;
    if let Some(spp) = args.spp {
        if !(1..=65536).contains(&spp) {
            bail!(BadInput(format!("--spp {spp}: use 1 to 65536 samples a pixel")));
        }
        settings.trace.panorama.samples = spp;
    }
    if args.bounces > 16 {
        bail!(BadInput(format!("--bounces {}: use 0 to 16", args.bounces)));
    }
    settings.trace.panorama.bounces = args.bounces;
    settings.denoise = args.denoise;
    settings.transitions = match args.transitions {
        cli::TransitionsArg::Auto => Transitions::Auto,
        cli::TransitionsArg::Depth => Transitions::Depth,
        cli::TransitionsArg::Video => Transitions::Video,
    };
    Ok(settings)
}

/// `exploremaps render`: the assets the bundle lacks, given its graph and scene.
fn render(bundle: &Path, settings: &Settings, shard: Option<(usize, usize)>, (mut graph, scene): (Graph, Scene)) -> Result<()> {
    let (index, count) = shard.unwrap_or((0, 1));
    let progress = Progress::new(format!("rendering ({} quality)", settings.trace.quality.name()), "assets");
    let report = exploremaps_builder::render::render_missing(
        bundle,
        &scene,
        &mut graph,
        settings,
        exploremaps_builder::render::Shard { index, count },
        |done, total| progress.set(done as u64, total as u64),
    )?;
    drop(progress);
    if let Some(proxy) = &graph.proxy {
        let levels: Vec<String> = proxy
            .levels
            .iter()
            .map(|l| {
                let files = if l.chunks.is_empty() { l.file.clone() } else { format!("{} chunks, {} …", l.chunks.len(), l.file) };
                format!("{} triangles in {:.0} KB ({files})", l.triangles, l.bytes as f64 / 1024.0)
            })
            .collect();
        println!("  proxy       {}; {}", levels.join(", "), proxy.glb.as_deref().unwrap_or("no GLB"));
        if let Some(s) = &proxy.stream {
            let bytes: u64 = s.packets.iter().map(|p| p.bytes).sum();
            let (from, to) = (proxy.levels.get(s.from).map_or(0, |l| l.triangles), proxy.levels.get(s.to).map_or(0, |l| l.triangles));
            println!(
                "  streamed    {from} -> {to} triangles by vertex splits in {:.0} KB ({} packets, proxy/splits-0.emvs …)",
                bytes as f64 / 1024.0,
                s.packets.len()
            );
        }
    }
    match web_dir() {
        Some(web) => {
            exploremaps_builder::bundle::install_web_viewer(bundle, &web)?;
        }
        None => tracing::warn!(
            "the web viewer is not built, so the bundle has none; run web/build.sh, then `exploremaps render` again (it only adds what is missing)"
        ),
    }
    println!(
        "{}: rendered {} probes and {} paths{}, {} already there ({:.1} s{})",
        bundle.display(),
        report.probes_rendered,
        report.paths_rendered,
        if report.proxy_rendered { " and the 3D proxy" } else { "" },
        report.skipped,
        report.seconds,
        report.video_encoder.map(|e| format!(", videos by {e}")).unwrap_or_default()
    );
    if count > 1 {
        println!("shard {index}/{count} done; when every shard is, `exploremaps render {} --finalize` writes graph.json", bundle.display());
    }
    Ok(())
}

/// `render --finalize`: completes a split render (see `render::finalize`).
fn finalize(bundle: &Path) -> Result<()> {
    let mut graph = read_graph(bundle)?;
    let checked = exploremaps_builder::render::finalize(bundle, &mut graph)?;
    println!("{}: complete, {checked} files checked; graph.json written", bundle.display());
    Ok(())
}

/// The built web viewer (web/build.sh): EXPLOREMAPS_WEB_DIR, else `web-viewer` in
/// the build's target folder (beside `debug` or `release`, where this program is).
fn web_dir() -> Option<std::path::PathBuf> {
    let complete = |d: &Path| exploremaps_builder::bundle::WEB_VIEWER_FILES.iter().all(|f| d.join(f).is_file());
    if let Some(d) = std::env::var_os("EXPLOREMAPS_WEB_DIR") {
        return Some(d.into()).filter(|d: &std::path::PathBuf| complete(d));
    }
    let exe = std::env::current_exe().ok()?;
    exe.ancestors().skip(1).take(3).map(|d| d.join("web-viewer")).find(|d| complete(d))
}

/// `exploremaps coverage`: measure a planned bundle's probes again.
fn remeasure(bundle: &Path, samples: usize) -> Result<()> {
    let (graph, scene, recorded) = open_bundle(bundle)?;
    let seed = recorded.seed;
    let space = match graph.scene.space.as_deref() {
        Some("outside") => SpaceMode::Outside,
        _ => SpaceMode::Inside,
    };
    let near_m = graph.scene.near_distance.map(|r| r * scene.metres_per_unit);
    let max_cells = recorded.max_cells;
    let height = match graph.scene.eye_height_m {
        Some(_) => HeightMode::Walk,
        None => HeightMode::Fly,
    };
    let eye_height_m = graph.scene.eye_height_m.unwrap_or(1.6);
    let params = PlanParams {
        free_space: FreeSpaceParams { space, height, eye_height_m, near_m, max_cells, seed, ..Default::default() },
        explore: ExploreParams { seed, ..Default::default() },
        synthesis: None,
        coverage: CoverageParams { samples: samples.clamp(1, 10_000_000), seed, ..Default::default() },
    };
    let spinner = spinner(format!("measuring coverage of {} probes", graph.probes.len()));
    let result = plan::remeasure(&scene, graph, &params);
    spinner.finish_and_clear();
    let plan = result.with_context(|| format!("{} (its probes)", bundle.join(GRAPH_FILE).display()))?;
    exploremaps_builder::bundle::write_plan(bundle, &plan)?;
    print_plan(&scene, bundle, &plan);
    Ok(())
}

/// Three significant digits at any scale (scenes run from millimetres to kilometres).
fn num(x: f64) -> String {
    if x == 0.0 || (0.01..1e6).contains(&x.abs()) {
        format!("{:.3}", x).trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{x:.2e}")
    }
}

fn print_plan(scene: &Scene, output: &Path, plan: &plan::Plan) {
    println!("{} ({} triangles) -> {}", scene.name, scene.triangles.len(), output.display());
    print_space(&plan.stats.free_space);
    print_stages(&plan.stats);
    print_coverage(plan);
    let files: Vec<&str> = plan.images.iter().map(|(n, _)| n.as_str()).chain(["coverage.json", GRAPH_FILE]).collect();
    println!(
        "  wrote       {} ({:.2} s in all: planning {:.2} s, the report {:.2} s)",
        files.join(", "),
        plan.seconds,
        plan.seconds - plan.report_seconds,
        plan.report_seconds
    );
}

/// The free space: its kind, grid, the parts left out, where one walks.
fn print_space(f: &plan::freespace::FreeSpaceStats) {
    println!("  space       {} ({}); {} ({})", f.space, f.space_reason, f.height, f.height_reason);
    println!(
        "  free space  voxel {}, near {} units, {} navigable voxels of {} open ({:.2} s)",
        num(f.voxel as f64),
        num(f.near as f64),
        f.navigable,
        f.open,
        f.seconds
    );
    if !f.left_out.is_empty() {
        let largest: Vec<String> = f
            .left_out
            .iter()
            .take(3)
            .map(|p| {
                format!(
                    "{:.0} m³ around ({}, {}, {}), {}",
                    p.volume_m3,
                    num(p.centre[0] as f64),
                    num(p.centre[1] as f64),
                    num(p.centre[2] as f64),
                    p.why
                )
            })
            .collect();
        println!("  left out    {} part(s) of the open space, the largest: {}", f.left_out.len(), largest.join("; "));
    }
    if let Some(w) = &f.walk {
        let levels: Vec<String> = w.levels.iter().map(|l| format!("{} ({:.0} %)", num(l.height as f64), 100.0 * l.share)).collect();
        println!(
            "  walk        eye {} m above {} m² of floor in {} region(s) ({} roof(s) left out); floor levels at {}",
            num(w.eye_height_m as f64),
            num(w.floor_area_m2),
            w.regions_kept,
            w.roofs,
            if levels.is_empty() { "no single height (rolling ground)".to_string() } else { levels.join(", ") }
        );
    }
}

/// Exploration, clustering and paths.
fn print_stages(stats: &plan::PlanStats) {
    let e = &stats.explore;
    if e.probes > 0 {
        let capped = if e.capped { ", stopped at --max-probes short of --coverage" } else { "" };
        println!("  explore     {} candidate probes{capped}, {:.1} M rays ({:.2} s)", e.probes, e.rays as f64 / 1e6, e.seconds);
    }
    if let Some(c) = &stats.cluster {
        println!(
            "  cluster     {} clusters -> {} probes ({} added back to keep coverage) ({:.2} s)",
            c.clusters, c.final_probes, c.added_back, c.seconds
        );
    }
    let (paths, m) = (&stats.connect, &stats.smooth);
    if e.probes > 0 {
        println!(
            "  paths       {} paths ({} pairs share a view, {} pruned), {} component(s); smoothed at {:.1} ms a path, clearance ≥ {} (r = {}) ({:.2} s)",
            paths.paths,
            paths.pairs_sharing_view,
            paths.pruned,
            paths.components,
            1000.0 * m.seconds_per_path,
            num(m.min_clearance as f64),
            num(m.near_distance as f64),
            paths.seconds + m.seconds
        );
    }
}

/// The coverage, the most any placement could see, and the baselines.
fn print_coverage(plan: &plan::Plan) {
    let c = &plan.coverage;
    let need = |x: f64| c.probes_for(x).map_or("-".to_string(), |n| n.to_string());
    println!(
        "  coverage    {:.2} % of {} units² reachable, {} samples; probes for 90/95/98/99 %: {}/{}/{}/{} ({:.2} s)",
        100.0 * c.fraction(),
        num(c.reachable_area),
        c.samples.points.len(),
        need(0.90),
        need(0.95),
        need(0.98),
        need(0.99),
        c.seconds
    );
    let ceiling = c.ceiling();
    if ceiling.area > 0.0 {
        println!(
            "  ceiling     {} units² seen from the free space in the box: {:.1} % seen from the {} space, {:.1} % by the probes; {} units² more seen only through crevices no viewpoint fits in",
            num(ceiling.area),
            100.0 * ceiling.seen_from_space / ceiling.area,
            if plan.stats.free_space.height == "walk" { "walk (eye-height)" } else { "navigable" },
            100.0 * ceiling.covered / ceiling.area,
            num(ceiling.crevices)
        );
    }
    for b in &plan.baselines {
        println!("  baseline    {} placement, same {} probes: {:.2} %", b.name, b.probes.len(), 100.0 * b.report.fraction());
    }
}

/// A spinner on stderr while a long step runs; hidden when stderr is not a terminal.
fn spinner(message: String) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new_spinner().with_message(message);
    bar.enable_steady_tick(Duration::from_millis(120));
    bar
}

fn info(scene: &Scene) -> Result<()> {
    let b = scene.bounds();
    let e = b.extent();
    let textured = scene.materials.iter().filter(|m| m.base_color_texture.is_some()).count();
    let emissive = scene.materials.iter().filter(|m| m.emissive.max_element() > 0.0).count();
    let cutout = scene.materials.iter().filter(|m| !matches!(m.alpha_mode, exploremaps_builder::scenes::AlphaMode::Opaque)).count();
    let points = scene.lights.iter().filter(|l| matches!(l, Light::Point { .. })).count();
    let suns = scene.lights.len() - points;
    let scale = match scene.scale_source {
        ScaleSource::File => "stated by the scene",
        ScaleSource::User => "given with --metres-per-unit",
        ScaleSource::Guessed => "guessed from the size; override with --metres-per-unit",
        ScaleSource::Measured => "measured from the scene's heights",
    };
    let m = scene.metres_per_unit;
    println!("scene       {}", scene.name);
    println!(
        "triangles   {} ({} vertices; dropped {} degenerate, {} non-finite)",
        scene.triangles.len(),
        scene.positions.len(),
        scene.stats.dropped_degenerate,
        scene.stats.dropped_non_finite
    );
    println!("objects     {}", scene.objects.len());
    println!("materials   {} ({textured} textured, {emissive} emissive, {cutout} with alpha)", scene.materials.len());
    println!("textures    {} ({} could not be loaded)", scene.textures.len(), scene.stats.missing_textures);
    println!("lights      {points} point, {suns} sun");
    println!("normals     {}", if scene.normals.is_empty() { "none (geometric normals will be used)" } else { "per vertex" });
    println!("colours     {}", if scene.colours.is_empty() { "materials and textures" } else { "per vertex, times materials and textures" });
    println!("bounds      min ({:.3}, {:.3}, {:.3})  max ({:.3}, {:.3}, {:.3})", b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z);
    println!("extent      {:.3} x {:.3} x {:.3} units, diagonal {:.3}", e.x, e.y, e.z, b.diagonal());
    println!("scale       1 unit = {m} m ({scale}): {:.2} x {:.2} x {:.2} m", e.x * m, e.y * m, e.z * m);
    println!("surface     {:.1} units²", scene.total_area());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_input_exits_2_wherever_it_is_wrapped_and_the_program_s_failures_1() {
        let free_space = plan::PlanError::FreeSpace(exploremaps_builder::plan::freespace::FreeSpaceError::StartInGeometry(Vec3::ZERO));
        let wrapped = anyhow::Error::new(free_space).context("graph.json (its probes)");
        assert_eq!(exit_code(&wrapped), 2);
        assert_eq!(exit_code(&anyhow::Error::new(BadInput("--face 3".into()))), 2);
        let disk = exploremaps_builder::bundle::BundleError::Io { path: "b/graph.json".into(), source: std::io::Error::other("disk full") };
        assert_eq!(exit_code(&anyhow::Error::new(disk)), 1);
    }

    #[test]
    fn an_error_message_says_each_cause_once() {
        use exploremaps_builder::{bundle::BundleError, export::TourError, scene_io::write::ExportError};
        let io = || std::io::Error::other("disk full");
        let disk = BundleError::Io { path: "b/graph.json".into(), source: io() };
        let text = format!("{:#}", anyhow::Error::new(disk).context("rendering b"));
        assert!(text.starts_with("rendering b: cannot write b/graph.json"), "{text}");
        assert!(text.ends_with(": disk full"), "{text}");
        // No error repeats its source in its own text.
        let json = exploremaps_format::Graph::from_json("{").unwrap_err();
        let errors: Vec<(anyhow::Error, String)> = vec![
            (BundleError::Io { path: "b".into(), source: io() }.into(), "disk full".into()),
            (LoadError::Io { path: "s.obj".into(), source: io() }.into(), "disk full".into()),
            (ExportError::Io { path: "o".into(), source: io() }.into(), "disk full".into()),
            (TourError::Io { path: "t".into(), source: io() }.into(), "disk full".into()),
            (exploremaps_viewer::native::ViewError::Read { path: "g".into(), source: io() }.into(), "disk full".into()),
            (BundleError::Invalid(exploremaps_format::FormatError::Invalid("probe 3".into())).into(), "probe 3".into()),
            (json.into(), "EOF".into()),
        ];
        for (error, cause) in errors {
            let text = format!("{error:#}");
            assert_eq!(text.matches(&cause).count(), 1, "{text}");
        }
    }
}

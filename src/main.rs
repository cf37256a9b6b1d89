//! `exploremaps`: the command-line front end. Glue only: parse arguments, set
//! up logging and threads, call the builder, map errors to exit codes
//! (1: failure, 2: bad input, 3: stage not built yet).

mod cli;

use anyhow::{bail, Result};
use clap::Parser;
use cli::{Cli, Command, SceneArgs};
use exploremaps_builder::load::{self, LoadError, LoadOptions};
use exploremaps_builder::scenes::{BuiltIn, Light, ScaleSource, Scene, CATALOGUE};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// An error caused by what the user gave us, not by the program: exit code 2.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
struct BadInput(String);

/// A subcommand whose pipeline stage does not exist yet: exit code 3.
#[derive(Debug, thiserror::Error)]
#[error("`exploremaps {0}` is not available yet: its pipeline stage has not been built. Nothing was written.")]
struct NotBuiltYet(&'static str);

fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging(cli.verbose, cli.quiet);
    if let Err(e) = rayon::ThreadPoolBuilder::new().num_threads(cli.threads).build_global() {
        tracing::warn!("could not set up {} worker threads: {e}", cli.threads);
    }
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            if e.downcast_ref::<NotBuiltYet>().is_some() {
                ExitCode::from(3)
            } else if e.downcast_ref::<BadInput>().is_some() || e.downcast_ref::<LoadError>().is_some() {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
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
        Command::Info { scene } => info(&load_scene(scene, cli.seed)?),
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
                    exploremaps_builder::export::export(&scene, path).map_err(|e| BadInput(e.to_string()))?;
                    println!("wrote {} ({} triangles)", path.display(), scene.triangles.len());
                    Ok(())
                }
                None => info(&scene),
            }
        }
        Command::Build { .. } => Err(NotBuiltYet("build").into()),
        Command::Plan { .. } => Err(NotBuiltYet("plan").into()),
        Command::Render { .. } => Err(NotBuiltYet("render").into()),
        Command::Coverage { .. } => Err(NotBuiltYet("coverage").into()),
        Command::View { .. } => Err(NotBuiltYet("view").into()),
        Command::Serve { .. } => Err(NotBuiltYet("serve").into()),
    }
}

/// A file if one exists at that path, else a built-in scene by name.
fn load_scene(args: &SceneArgs, seed: u64) -> Result<Scene> {
    let up = load::parse_up_axis(&args.up).ok_or_else(|| BadInput(format!("--up {}: expected x, y or z, optionally signed (e.g. -z)", args.up)))?;
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
        let scene = load::load(path, &LoadOptions { up, metres_per_unit: args.metres_per_unit })?;
        spinner.finish_and_clear();
        tracing::info!("loaded {} in {:.2} s", path.display(), started.elapsed().as_secs_f64());
        return Ok(scene);
    }
    let name = builtin_name.unwrap_or(&args.scene);
    let builtin = BuiltIn::parse(name)
        .ok_or_else(|| BadInput(format!("{name}: no such file, and not a built-in scene (`exploremaps scenes` lists them)")))?;
    let mut scene = builtin.generate(seed);
    if let Some(m) = args.metres_per_unit {
        scene.metres_per_unit = m;
        scene.scale_source = ScaleSource::User;
    }
    Ok(scene)
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
    };
    let m = scene.metres_per_unit;
    println!("scene       {}", scene.name);
    println!("triangles   {} ({} vertices; dropped {} degenerate, {} non-finite)", scene.triangles.len(), scene.positions.len(), scene.stats.dropped_degenerate, scene.stats.dropped_non_finite);
    println!("objects     {}", scene.objects.len());
    println!("materials   {} ({textured} textured, {emissive} emissive, {cutout} with alpha)", scene.materials.len());
    println!("textures    {} ({} could not be loaded)", scene.textures.len(), scene.stats.missing_textures);
    println!("lights      {points} point, {suns} sun");
    println!("normals     {}", if scene.normals.is_empty() { "none (geometric normals will be used)" } else { "per vertex" });
    println!("bounds      min ({:.3}, {:.3}, {:.3})  max ({:.3}, {:.3}, {:.3})", b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z);
    println!("extent      {:.3} x {:.3} x {:.3} units, diagonal {:.3}", e.x, e.y, e.z, b.diagonal());
    println!("scale       1 unit = {m} m ({scale}): {:.2} x {:.2} x {:.2} m", e.x * m, e.y * m, e.z * m);
    println!("surface     {:.1} units²", scene.total_area());
    Ok(())
}

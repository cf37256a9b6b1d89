//! The command line: every subcommand and flag, with the help text users see.

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "exploremaps", version, about = "Turns a 3D scene into an explorable map of 360° panoramas", long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// Seed of every random choice: the same seed gives the same output at any thread count.
    #[arg(long, global = true, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads (0: one per core).
    #[arg(long, global = true, default_value_t = 0)]
    pub threads: usize,
    /// More log output (-v: debug, -vv: trace).
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Less log output (-q: warnings and errors only, -qq: errors only).
    #[arg(short, long, global = true, action = clap::ArgAction::Count, conflicts_with = "verbose")]
    pub quiet: u8,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Plan and render: scene in, finished bundle out.
    Build {
        #[command(flatten)]
        scene: SceneArgs,
        /// Bundle folder to write.
        #[arg(short, long, default_value = "bundle")]
        output: PathBuf,
    },
    /// Place probes, cluster them, find paths: writes graph.json without rendering.
    Plan {
        #[command(flatten)]
        scene: SceneArgs,
        /// Bundle folder to write.
        #[arg(short, long, default_value = "bundle")]
        output: PathBuf,
    },
    /// Render what a planned bundle is missing (resumable).
    Render {
        /// Bundle folder written by `plan`.
        bundle: PathBuf,
    },
    /// Measure how much reachable surface a bundle's probes see.
    Coverage {
        /// Bundle folder written by `plan`.
        bundle: PathBuf,
    },
    /// Open a bundle in the native viewer.
    View {
        bundle: PathBuf,
    },
    /// Serve a bundle and the web viewer over HTTP on this machine.
    Serve {
        bundle: PathBuf,
        /// Address to listen on.
        #[arg(long, default_value = "127.0.0.1:8080")]
        address: String,
    },
    /// List the built-in scenes, or write one out as OBJ or GLB.
    Scenes {
        /// A built-in scene to write, e.g. `gallery` or `maze:12`.
        name: Option<String>,
        /// File to write (.obj with .mtl and textures beside it, or .glb).
        #[arg(short, long, requires = "name")]
        output: Option<PathBuf>,
    },
    /// Load a scene and print a summary: triangles, materials, textures, bounds, scale.
    Info {
        #[command(flatten)]
        scene: SceneArgs,
    },
}

/// Which scene, and what the file does not say about it.
#[derive(Args, Debug, Clone)]
pub struct SceneArgs {
    /// A scene file (.obj, .gltf, .glb, .ply) or a built-in scene (`gallery`, `maze:12`, …;
    /// `exploremaps scenes` lists them).
    #[arg(default_value = exploremaps_scenes::DEFAULT_SCENE)]
    pub scene: String,
    /// The file's up axis (x, y, z, optionally signed: -z); it is rotated to +Y.
    #[arg(long, default_value = "y")]
    pub up: String,
    /// Metres per scene unit, when the file does not say (OBJ and PLY never do; it is guessed otherwise).
    #[arg(long)]
    pub metres_per_unit: Option<f32>,
}

//! The command line: every subcommand and flag, with the help text users see.

use clap::{Args, Parser, Subcommand};
use exploremaps_format::record::PlanRecord;
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "exploremaps", version, about = "Turns a 3D scene into an explorable map of 360° panoramas", long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// Seed of every random choice: the same seed gives the same output at any thread count.
    #[arg(long, global = true, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads (0: one per core; at most 1024).
    #[arg(long, global = true, default_value_t = 0, value_parser = clap::value_parser!(u16).range(0..=1024))]
    pub threads: u16,
    /// More log output (-v: debug, -vv: trace).
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Less log output (-q: warnings and errors only, -qq: errors only).
    #[arg(short, long, global = true, action = clap::ArgAction::Count, conflicts_with = "verbose")]
    pub quiet: u8,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Plan and render: scene in, bundle out (panoramas, thumbnails, transition videos).
    Build {
        #[command(flatten)]
        job: PlanJob,
        #[command(flatten)]
        render: RenderArgs,
    },
    /// Place probes and measure their coverage: writes graph.json, coverage.json and
    /// pictures of what is not covered, without rendering.
    Plan {
        #[command(flatten)]
        job: PlanJob,
    },
    /// Render what a planned bundle is missing (resumable): cube maps, photo-sphere
    /// panoramas and thumbnails of probes, 360° MP4 videos of paths.
    Render {
        /// Bundle folder written by `plan`.
        bundle: PathBuf,
        #[command(flatten)]
        render: RenderArgs,
        /// Render only shard i of n (i/n, 0-based) of the probes, paths and proxy;
        /// shards share the folder and need no other coordination, and leave
        /// graph.json to --finalize. `auto` reads i and n from Slurm's job-array
        /// variables or a Kubernetes indexed Job's (`auto/N`: n is N, and a Slurm task id is the shard).
        #[arg(long, value_parser = parse_shard)]
        shard: Option<ShardArg>,
        /// After the shards of a split render: check that every asset exists and
        /// decodes, then write graph.json; exits 1 listing what is missing otherwise.
        #[arg(long, conflicts_with = "shard")]
        finalize: bool,
    },
    /// Measure again how much reachable surface a bundle's probes see; rewrites
    /// coverage.json and the coverage pictures. Its random choices (the free
    /// space, the samples) take the seed recorded in the bundle, not --seed,
    /// so that it measures the space the probes were placed in.
    Coverage {
        /// Bundle folder written by `plan`.
        bundle: PathBuf,
        /// Area-uniform surface samples.
        #[arg(long, default_value_t = 200_000)]
        samples: usize,
    },
    /// Open a bundle in the native viewer. Drag or arrow keys to look, wheel
    /// or +/- to zoom, Enter or a tap to go along the best-aligned path, the
    /// bars and the map to jump; N/P next/previous probe, M map, T tour, Esc quits.
    View {
        bundle: PathBuf,
        /// Start at this probe (default: the first in the probe bar).
        #[arg(long)]
        probe: Option<u32>,
        /// Start looking this way, degrees (0 toward -Z, 90 toward +X).
        #[arg(long, allow_negative_numbers = true)]
        yaw: Option<f32>,
        /// Degrees above the horizon.
        #[arg(long, allow_negative_numbers = true)]
        pitch: Option<f32>,
        /// Vertical field of view, degrees.
        #[arg(long)]
        fov: Option<f32>,
        /// A deep link as the web viewer writes it after `#`, e.g. "probe=3&yaw=90".
        #[arg(long, conflicts_with_all = ["probe", "yaw", "pitch", "fov"])]
        link: Option<String>,
        /// Start the automatic tour (a random walk along the paths).
        #[arg(long)]
        tour: bool,
        /// Print the time to the first panorama and frame times in a probe and
        /// along a path, then close.
        #[arg(long)]
        benchmark: bool,
    },
    /// Serve a bundle and the web viewer over HTTP on this machine.
    Serve {
        bundle: PathBuf,
        /// Address to listen on.
        #[arg(long, default_value = "127.0.0.1:8080")]
        address: String,
    },
    /// Export a rendered bundle as a tour for Pannellum, Marzipano and Photo Sphere
    /// Viewer (one set of 512-pixel tiles, links along the paths playing their
    /// transition videos): a folder for any static host.
    Export {
        bundle: PathBuf,
        /// Folder to write (default: <BUNDLE>-tour beside the bundle); replaced if
        /// an earlier export wrote it.
        output: Option<PathBuf>,
        /// Viewers, comma-separated: pannellum, marzipano, psv, or all; or
        /// matterport3d alone (a scan of the Matterport3D Simulator).
        #[arg(long, default_value = "all", value_delimiter = ',')]
        to: Vec<String>,
        /// A node_modules folder with the viewers' npm packages to copy into the
        /// tour; without it, pages load them from the jsDelivr CDN.
        #[arg(long)]
        library: Option<PathBuf>,
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

/// What `plan` and `build` share: the scene, the bundle folder, the planning options.
#[derive(Args, Debug, Clone)]
pub struct PlanJob {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Bundle folder to write.
    #[arg(short, long, default_value = "bundle")]
    pub output: PathBuf,
    #[command(flatten)]
    pub planning: PlanArgs,
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
    /// Metres per scene unit, when the file does not say (OBJ and PLY never do; `plan` measures it otherwise from the scene's heights, or guesses it from the size).
    #[arg(long)]
    pub metres_per_unit: Option<f32>,
    /// The most triangles a scene file may hold, checked before its data is read.
    #[arg(long, default_value_t = exploremaps_builder::scene_io::MAX_TRIANGLES)]
    pub max_triangles: u64,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Space {
    /// Decide from which way the scene's surface faces, and say which was chosen.
    Auto,
    /// Scenes one is in (interiors, architecture, landscapes): the open space inside
    /// the scene's bounding box, never inside closed solids or under the ground.
    Inside,
    /// Objects: the space around the scene.
    Outside,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// Greedy set cover over random navigable candidates: fewest probes.
    Greedy,
    /// The ExploreMaps paper's: probes behind depth discontinuities, relaxed.
    Occluded,
}

/// How probes are placed.
#[derive(Args, Debug, Clone)]
pub struct PlanArgs {
    /// Which free space is navigable.
    #[arg(long, value_enum, default_value = "auto")]
    pub space: Space,
    /// A point in the navigable space to use (x,y,z in scene units); picks that part of it.
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    pub start: Option<[f32; 3]>,
    /// A probe to place first and keep (x,y,z in scene units; repeatable).
    #[arg(long = "probe", value_parser = parse_point, allow_hyphen_values = true)]
    pub probes: Vec<[f32; 3]>,
    /// Stop placing probes once this fraction of the reachable surface is seen. The
    /// default leaves out only nooks seen through narrow gaps, each of which would
    /// cost a probe; 1 places probes until none adds anything.
    #[arg(long, default_value_t = exploremaps_builder::plan::explore::DEFAULT_COVERAGE_TARGET)]
    pub coverage: f64,
    /// The most probes to place before clustering, even short of --coverage (a warning
    /// says when a scene needs more). More take longer to plan and render.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=20_000))]
    pub max_probes: u32,
    /// Near distance r in metres: the least clearance of probes and paths (default 0.5 %
    /// of the scene's bounding-box diagonal, at most 0.3 m when walking or when the
    /// scale is stated or plausibly guessed, so probes pass any door a visitor passes).
    #[arg(long)]
    pub near_m: Option<f32>,
    /// How probes are placed.
    #[arg(long, value_enum, default_value = "greedy")]
    pub strategy: Strategy,
    /// Keep every explored probe instead of merging probes that see the same
    /// surface into one synthesized probe per cluster.
    #[arg(long)]
    pub no_cluster: bool,
    /// Walk: probes stand at eye height above walkable floors (slopes, steps and head
    /// room as people move; stairs join floors), as a visitor sees the place. The
    /// default for scenes with floors whose scale is stated or plausibly guessed.
    #[arg(long, conflicts_with = "fly")]
    pub walk: bool,
    /// Fly: probes anywhere in the navigable space (objects, coverage research).
    #[arg(long)]
    pub fly: bool,
    /// Eye height above the floor in metres when walking.
    #[arg(long, default_value_t = 1.6)]
    pub eye_height_m: f32,
    /// Voxels on the longest side of the free-space grid; walking refines them to at
    /// most 0.4 m so doors stay open. Memory stays at most about 0.5 GiB for any
    /// scene: the grid never exceeds 40 million cells of 13 bytes.
    #[arg(long, default_value_t = 256)]
    pub max_cells: usize,
    /// Area-uniform surface samples of the coverage metric.
    #[arg(long, default_value_t = 200_000)]
    pub samples: usize,
}

/// `x,y,z` as three finite numbers.
fn parse_point(text: &str) -> Result<[f32; 3], String> {
    let parts: Vec<f32> =
        text.split(',').map(|p| p.trim().parse::<f32>()).collect::<Result<_, _>>().map_err(|e| format!("{text}: {e}; expected x,y,z"))?;
    match parts.as_slice() {
        [x, y, z] if parts.iter().all(|v| v.is_finite()) => Ok([*x, *y, *z]),
        _ => Err(format!("{text}: expected three finite numbers x,y,z")),
    }
}

/// How a bundle is rendered.
#[derive(clap::Args, Debug, Clone)]
pub struct RenderArgs {
    /// final: one sample through each pixel centre and four more where a pixel
    /// differs from a neighbour, every light sampled (4 shadow rays over the sun's
    /// disk), global illumination gathered one bounce deep over the baked radiance
    /// cache, cube faces 512/1024/2048 and 1024-wide videos (about 20 s a probe and
    /// 0.2 s a video frame on the Crytek Sponza, 2 cores); preview: one sample
    /// through each pixel centre, 512 faces, 512-wide videos (a few times faster);
    /// tour: final with 4096 faces (512-pixel tiles up to 8 × 8 a face), the size
    /// tour sites publish, at about four times final's time a probe.
    #[arg(long, value_enum, default_value_t = QualityArg::Final)]
    pub quality: QualityArg,
    /// Largest cube face in pixels (levels halve down to 512); default by quality.
    #[arg(long)]
    pub face: Option<u32>,
    /// Video frame width (height is half), a multiple of 32; default by quality.
    #[arg(long)]
    pub video_width: Option<u32>,
    /// Triangles of the 3D proxy's finest level (its coarse level, which the
    /// viewer shows first and refines by vertex splits, has a tenth).
    #[arg(long, default_value_t = 25_000)]
    pub proxy_triangles: usize,
    /// Samples a pixel for panoramas; default by quality.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Real diffuse bounces at every pixel before the radiance cache, for
    /// panoramas (0: the cache at the first hit in preview, the final gather in
    /// final; 1 traces a bounce per sample, at many times the cost).
    #[arg(long, default_value_t = 0)]
    pub bounces: u32,
    /// Denoise panoramas and thumbnails with Intel Open Image Denoise, guided by
    /// albedo and normal (for few samples or real bounces).
    #[arg(long)]
    pub denoise: bool,
    /// How paths are shown. auto: a glide the viewer draws from panoramas and
    /// their depth (written per probe), in legs between up to 16 panoramas
    /// part way where the ends alone do not see what the path sees (at most
    /// 2 % of the view unseen, or seen 4× coarser), a video where they do
    /// not do; depth: every path a glide; video: a 360° video each (the
    /// bundle as before glides). graph.json records each path's choice and why.
    #[arg(long, value_enum, default_value_t = TransitionsArg::Auto)]
    pub transitions: TransitionsArg,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransitionsArg {
    Auto,
    Depth,
    Video,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum QualityArg {
    Preview,
    Final,
    Tour,
}

/// `--shard`: given, or to be read from the scheduler's environment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShardArg {
    Given(usize, usize),
    Auto(Option<usize>),
}

fn parse_shard(text: &str) -> Result<ShardArg, String> {
    if let Some(rest) = text.strip_prefix("auto") {
        return match rest.strip_prefix('/') {
            None if rest.is_empty() => Ok(ShardArg::Auto(None)),
            Some(n) => match n.trim().parse::<usize>() {
                Ok(n) if n > 0 => Ok(ShardArg::Auto(Some(n))),
                _ => Err(format!("{text}: expected auto or auto/N with N >= 1")),
            },
            None => Err(format!("{text}: expected auto or auto/N")),
        };
    }
    let (i, n) = parse_fraction(text)?;
    Ok(ShardArg::Given(i, n))
}

/// The shard a scheduler gave this process, from its environment (`var`
/// looks a variable up): Slurm job arrays (`SLURM_ARRAY_TASK_ID` with
/// `SLURM_ARRAY_TASK_COUNT`, or with `_MIN` and `_MAX`; with the count given
/// as `auto/N`, the task id itself), then Kubernetes indexed Jobs
/// (`JOB_COMPLETION_INDEX`, the count given as `auto/N`).
/// Returns the index, the count and where they came from.
pub fn shard_from_env(count: Option<usize>, var: impl Fn(&str) -> Option<String>) -> Result<(usize, usize, &'static str), String> {
    let number = |name: &str| -> Result<Option<usize>, String> {
        var(name).map(|v| v.trim().parse::<usize>().map_err(|_| format!("{name}={v} is not a number"))).transpose()
    };
    let checked =
        |i: usize, n: usize, from: &'static str| if i < n { Ok((i, n, from)) } else { Err(format!("{from}: shard {i} of {n} is out of range")) };
    if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
        // With the count given, the task id is the shard (so `--array=2`
        // redoes shard 2 alone); else the array's own numbering is used.
        if let Some(n) = count {
            return checked(id, n, "Slurm job array");
        }
        let (min, max) = (number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0), number("SLURM_ARRAY_TASK_MAX")?);
        let n = number("SLURM_ARRAY_TASK_COUNT")?.or(max.and_then(|m| (m + 1).checked_sub(min)));
        let n = n.ok_or("SLURM_ARRAY_TASK_ID is set but not SLURM_ARRAY_TASK_COUNT nor _MAX; give the count as --shard auto/N")?;
        return checked(id.checked_sub(min).ok_or(format!("SLURM_ARRAY_TASK_ID {id} is below SLURM_ARRAY_TASK_MIN {min}"))?, n, "Slurm job array");
    }
    if let Some(index) = number("JOB_COMPLETION_INDEX")? {
        let n = count.ok_or("JOB_COMPLETION_INDEX is set (a Kubernetes indexed Job); give the Job's completions as --shard auto/N")?;
        return checked(index, n, "Kubernetes indexed Job");
    }
    Err("--shard auto: neither SLURM_ARRAY_TASK_ID (a Slurm job array) nor JOB_COMPLETION_INDEX (a Kubernetes indexed Job) is set; give the shard as i/n".into())
}

fn parse_fraction(text: &str) -> Result<(usize, usize), String> {
    let (i, n) = text.split_once('/').ok_or_else(|| format!("{text}: expected i/n, e.g. 0/4"))?;
    let (i, n): (usize, usize) = (i.trim().parse().map_err(|e| format!("{text}: {e}"))?, n.trim().parse().map_err(|e| format!("{text}: {e}"))?);
    if n == 0 || i >= n {
        return Err(format!("{text}: need 0 <= i < n"));
    }
    Ok((i, n))
}

/// What `plan` records in graph.json (`stats.plan`), so that `render` and
/// `coverage` load the scene and measure as it did.
pub fn plan_record(scene: &SceneArgs, planning: &PlanArgs, seed: u64) -> PlanRecord {
    PlanRecord {
        seed,
        up: scene.up.clone(),
        metres_per_unit: scene.metres_per_unit,
        max_triangles: scene.max_triangles,
        space: format!("{:?}", planning.space).to_lowercase(),
        strategy: format!("{:?}", planning.strategy).to_lowercase(),
        coverage_target: planning.coverage,
        near_m: planning.near_m,
        max_cells: planning.max_cells,
        cluster: !planning.no_cluster,
        height: (if planning.walk {
            "walk"
        } else if planning.fly {
            "fly"
        } else {
            "auto"
        })
        .into(),
        eye_height_m: planning.eye_height_m,
    }
}

/// The scene as `plan` loaded it.
pub fn recorded_scene(record: &PlanRecord, source: &str) -> SceneArgs {
    SceneArgs { scene: source.to_string(), up: record.up.clone(), metres_per_unit: record.metres_per_unit, max_triangles: record.max_triangles }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| vars.iter().find(|(n, _)| *n == name).map(|(_, v)| v.to_string())
    }

    #[test]
    fn a_bundle_that_does_not_record_its_plan_is_taken_as_planned_with_the_defaults() {
        let cli = Cli::try_parse_from(["exploremaps", "plan", "gallery"]).unwrap();
        let Command::Plan { job } = cli.command else { panic!("not a plan") };
        assert_eq!(plan_record(&job.scene, &job.planning, cli.seed), PlanRecord::default());
    }

    #[test]
    fn shards_come_from_slurm_arrays_and_kubernetes_indexed_jobs() {
        assert_eq!(parse_shard("auto"), Ok(ShardArg::Auto(None)));
        assert_eq!(parse_shard("auto/8"), Ok(ShardArg::Auto(Some(8))));
        assert_eq!(parse_shard("1/4"), Ok(ShardArg::Given(1, 4)));
        assert!(parse_shard("auto/0").is_err() && parse_shard("autox").is_err() && parse_shard("4/4").is_err());
        let slurm = [("SLURM_ARRAY_TASK_ID", "2"), ("SLURM_ARRAY_TASK_COUNT", "4")];
        assert_eq!(shard_from_env(None, env(&slurm)), Ok((2, 4, "Slurm job array")));
        // `--array=1-4`: ids from 1, shards from 0.
        let from_one = [("SLURM_ARRAY_TASK_ID", "4"), ("SLURM_ARRAY_TASK_MIN", "1"), ("SLURM_ARRAY_TASK_MAX", "4")];
        assert_eq!(shard_from_env(None, env(&from_one)), Ok((3, 4, "Slurm job array")));
        // One task resubmitted alone (`--array=2`) keeps its shard when the count is given.
        let alone = [("SLURM_ARRAY_TASK_ID", "2"), ("SLURM_ARRAY_TASK_MIN", "2"), ("SLURM_ARRAY_TASK_MAX", "2"), ("SLURM_ARRAY_TASK_COUNT", "1")];
        assert_eq!(shard_from_env(Some(4), env(&alone)), Ok((2, 4, "Slurm job array")));
        let kubernetes = [("JOB_COMPLETION_INDEX", "5")];
        assert_eq!(shard_from_env(Some(8), env(&kubernetes)), Ok((5, 8, "Kubernetes indexed Job")));
        assert!(shard_from_env(None, env(&kubernetes)).unwrap_err().contains("auto/N"));
        assert!(shard_from_env(Some(4), env(&[("JOB_COMPLETION_INDEX", "4")])).unwrap_err().contains("out of range"));
        assert!(shard_from_env(None, env(&[("SLURM_ARRAY_TASK_ID", "x")])).unwrap_err().contains("not a number"));
        assert!(shard_from_env(None, env(&[])).unwrap_err().contains("neither"));
    }
}

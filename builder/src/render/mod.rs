//! The render stage: what `exploremaps render` runs on a planned bundle.
//!
//! Inputs: the bundle folder and its graph, the scene, the [`Settings`] and
//! a [`Shard`]. Steps:
//! 1. [`jobs`]: probes first, then paths, then the proxy; this shard's, less
//!    those whose files are all there (a finished file is never redone).
//! 2. One [`Renderer`] for all of them (the radiance cache is baked here).
//! 3. Each job writes its files atomically: `probe` (cube faces, tiles,
//!    panorama, thumbnail, and the depth for glides), `path` (with glides,
//!    the transition `glide` chooses; video frames, MP4, poster), `proxy` (the
//!    light 3D stand-in). A killed run loses at most the asset in progress.
//! 4. The settings and timings: graph.json's `render` entry, or a shard's
//!    manifest (`shards`, which also completes a split render).
//! 5. graph.json lists every asset whose files exist ([`list_assets`]).
//!
//! The pictures themselves come from `crate::tracer`.

pub mod glide;
mod path;
mod probe;
mod proxy;
mod shards;

pub use crate::tracer::Quality;
pub use glide::Transitions;
pub use shards::{finalize, Shard};

use crate::bundle::{write, write_graph, BundleError};
use crate::tracer::Renderer;
use exploremaps_format::record::{RenderRecord, Seconds, ShardManifest, Timings};
use exploremaps_format::Graph;
use exploremaps_scenes::Scene;
use glam::Vec3;
use probe::ProbeFiles;
use std::path::Path;
use std::time::Instant;

/// What a render makes, and how well: the tracer's settings for the quality,
/// and the render jobs' own choices.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// How each picture is traced.
    pub trace: crate::tracer::Settings,
    /// Largest cube face; smaller levels halve it down to 512.
    pub face: u32,
    /// Video frame width (height is half), a multiple of 32.
    pub video_width: u32,
    /// Denoise panoramas and thumbnails with Open Image Denoise (worth it with
    /// real bounces or few samples; the cache alone leaves little noise).
    pub denoise: bool,
    /// The light 3D stand-in written with the panoramas.
    pub proxy: crate::proxy::ProxyParams,
    /// How paths are shown: glides (with each probe's depth) or videos.
    pub transitions: Transitions,
    /// Cells a cube face edge of each probe's depth for glides.
    pub depth_cells: u32,
}

impl Settings {
    pub fn new(quality: Quality, seed: u64) -> Settings {
        let trace = crate::tracer::Settings::new(quality, seed);
        match quality {
            Quality::Preview => Settings {
                trace,
                face: 512,
                video_width: 512,
                denoise: false,
                proxy: crate::proxy::ProxyParams { bake_samples: 4, ..Default::default() },
                transitions: Transitions::Video,
                depth_cells: 32,
            },
            Quality::Final => Settings {
                trace,
                face: 2048,
                video_width: 1024,
                denoise: false,
                proxy: Default::default(),
                transitions: Transitions::Video,
                depth_cells: 128,
            },
            Quality::Tour => Settings { trace, face: 4096, ..Settings::new(Quality::Final, seed) },
        }
    }

    /// A panorama part way along a path is seen only in passing: a face half
    /// a video frame's width (twice as sharp as the frame, whose 90° are a
    /// quarter of its width).
    pub fn waypoint_face(&self) -> u32 {
        self.video_width / 2
    }

    /// How a panorama part way is traced: as the probes' panoramas, but, like
    /// video frames, without refining edges (it is seen only in passing,
    /// resampled through its depth; the refinement took a third of its time).
    pub fn waypoint_trace(&self) -> crate::tracer::TraceParams {
        crate::tracer::TraceParams { antialias: false, ..self.trace.panorama }
    }

    /// Depth cells of a panorama part way: half the probes', at least 32.
    pub fn waypoint_cells(&self) -> u32 {
        (self.depth_cells / 2).max(32)
    }

    /// Whether the render writes depth and a transition for each path.
    pub fn glides(&self) -> bool {
        self.transitions != Transitions::Video
    }

    /// Cube-face sizes from 512 (or the largest, if smaller) up to `face`.
    pub fn face_levels(&self) -> Vec<u32> {
        let mut levels = vec![self.face];
        while levels[0] > 512 && levels[0] % 2 == 0 {
            levels.insert(0, levels[0] / 2);
        }
        levels
    }
}

/// One unit of rendering, owned by one shard.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Job {
    Probe(usize),
    Path(usize),
    Proxy,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderReport {
    pub probes_rendered: usize,
    pub paths_rendered: usize,
    pub proxy_rendered: bool,
    /// Jobs of this shard whose files were all there already.
    pub skipped: usize,
    pub video_encoder: Option<String>,
    pub seconds: f64,
}

/// Every job of a bundle in order (probes, paths, the proxy), numbered as
/// shards split them: job `k` belongs to shard `k % count`.
pub fn all_jobs(graph: &Graph) -> Vec<Job> {
    let probes = (0..graph.probes.len()).map(Job::Probe);
    probes.chain((0..graph.paths.len()).map(Job::Path)).chain([Job::Proxy]).collect()
}

/// A job with its number in [`all_jobs`].
pub type Numbered = (usize, Job);

/// This shard's jobs, and those of them whose files are not all in `dir`
/// (with `glides`, probes' depth and paths' transitions are files too).
pub fn jobs(dir: &Path, graph: &Graph, levels: &[u32], glides: bool, shard: Shard) -> (Vec<Numbered>, Vec<Numbered>) {
    let exists = |name: &String| dir.join(name).exists();
    let mine: Vec<Numbered> = all_jobs(graph).into_iter().enumerate().filter(|(k, _)| k % shard.count == shard.index).collect();
    let todo = mine
        .iter()
        .copied()
        .filter(|&(_, job)| match job {
            Job::Probe(id) => !ProbeFiles::new(id, levels, glides).all().iter().all(exists),
            Job::Path(id) => !path::expected(dir, id, glides).iter().all(exists),
            Job::Proxy => proxy::listed(dir).is_none(),
        })
        .collect();
    (mine, todo)
}

/// Renders what the bundle is missing, for this shard (steps above), calling
/// `progress(done, total)` before each job and at the end.
pub fn render_missing(
    dir: &Path,
    scene: &Scene,
    graph: &mut Graph,
    settings: &Settings,
    shard: Shard,
    mut progress: impl FnMut(usize, usize),
) -> Result<RenderReport, BundleError> {
    let started = Instant::now();
    let abandoned = crate::files::remove_abandoned(dir);
    if abandoned > 0 {
        tracing::info!("removed {abandoned} temporary files a killed run left behind");
    }
    let levels = settings.face_levels();
    let (mine, todo) = jobs(dir, graph, &levels, settings.glides(), shard);
    let mut report = RenderReport { skipped: mine.len() - todo.len(), ..Default::default() };
    // The render also states its settings (in graph.json, or a shard's
    // manifest): a run killed after its last asset but before that file
    // leaves them to the next run.
    let split = shard.count > 1;
    let stated = if split { dir.join(shard.manifest()).exists() } else { graph.stats.render.is_some() };
    let mut timings = Timings::default();
    if !todo.is_empty() || !stated {
        let setup_started = Instant::now();
        let rays = crate::raycast::RayScene::new(&scene.positions, &scene.triangles, 0)?;
        let mut viewpoints: Vec<Vec3> = graph.probes.iter().map(|p| Vec3::from(p.position)).collect();
        viewpoints.extend(graph.paths.iter().flat_map(|p| p.camera.iter().step_by(10).map(|k| Vec3::from(k.position))));
        let renderer = Renderer::new(scene, &rays, &viewpoints, settings.trace.clone());
        let encoder = crate::video::Encoder::detect();
        report.video_encoder = Some(encoder.name());
        let seconds_setup = setup_started.elapsed().as_secs_f64();
        let mut job_seconds = Vec::with_capacity(todo.len());
        for (done, &(_, job)) in todo.iter().enumerate() {
            let job_started = Instant::now();
            progress(done, todo.len());
            match job {
                Job::Probe(id) => {
                    probe::render(dir, &renderer, settings, &graph.probes[id], id, &levels)?;
                    report.probes_rendered += 1;
                }
                Job::Path(id) => {
                    if path::render(dir, &renderer, settings, &encoder, &graph.paths[id], id)? {
                        report.paths_rendered += 1;
                    }
                }
                Job::Proxy => {
                    proxy::render(dir, scene, graph, &renderer, &settings.proxy)?;
                    report.proxy_rendered = true;
                }
            }
            job_seconds.push(job_started.elapsed().as_secs_f64());
        }
        progress(todo.len(), todo.len());
        let record = record(settings, &renderer, &report);
        if split {
            let manifest = ShardManifest { shard: shard.index, count: shard.count, levels: levels.clone(), render: record };
            write(dir, &shard.manifest(), manifest.to_json().as_bytes())?;
        } else {
            // The renderer's set-up, which every shard repeats, and each
            // job's time by its number, for planning shards.
            let jobs: Vec<(usize, f64)> = todo.iter().map(|&(k, _)| k).zip(job_seconds).collect();
            timings.set("render", "seconds_setup", Seconds::Total(seconds_setup));
            timings.set("render", "seconds_jobs", Seconds::PerJob(jobs));
            graph.stats.render = Some(record);
        }
    }
    if !split {
        list_assets(dir, graph, &levels);
        graph.validate()?;
        write_graph(dir, graph, timings)?;
    }
    report.seconds = started.elapsed().as_secs_f64();
    Ok(report)
}

/// What a render was made with (a shard's manifest carries the same;
/// `finalize` checks that every shard's agree).
fn record(settings: &Settings, renderer: &Renderer, report: &RenderReport) -> RenderRecord {
    RenderRecord {
        quality: settings.trace.quality.name().to_string(),
        lighting: renderer.tracer.lighting.description.clone(),
        exposure: renderer.exposure,
        cache_cells: renderer.tracer.cache.as_ref().map(|c| c.stats.cells),
        video_encoder: report.video_encoder.clone(),
        samples_per_pixel: settings.trace.panorama.samples,
        bounces: settings.trace.panorama.bounces,
        denoised: settings.denoise,
        seed: settings.trace.seed,
        transitions: settings.glides().then(|| settings.transitions.name().to_string()),
        depth_cells: settings.glides().then_some(settings.depth_cells),
    }
}

/// Lists in graph.json every asset whose files exist.
fn list_assets(dir: &Path, graph: &mut Graph, levels: &[u32]) {
    let exists = |name: &String| dir.join(name).exists();
    for (id, probe) in graph.probes.iter_mut().enumerate() {
        let files = ProbeFiles::new(id, levels, true);
        let tiled = files.tiles.files().iter().chain([&files.tiles.preview]).all(exists);
        let ProbeFiles { cube, tiles, pano, thumb, depth, .. } = files;
        probe.assets.cube_levels = cube.into_iter().filter(|l| l.faces.iter().all(exists)).collect();
        probe.assets.tiles = tiled.then_some(tiles);
        probe.assets.equirect = exists(&pano).then_some(pano);
        probe.assets.thumbnail = exists(&thumb).then_some(thumb);
        probe.assets.depth = depth.filter(exists);
    }
    for (id, path) in graph.paths.iter_mut().enumerate() {
        let (video, poster) = path::files(id);
        path.assets.video = exists(&video).then_some(video);
        path.assets.poster = exists(&poster).then_some(poster);
        path.assets.transition = path::transition(dir, id);
    }
    graph.proxy = proxy::listed(dir);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn graph(probes: usize, paths: usize) -> Graph {
        use exploremaps_format as f;
        let scene = f::SceneInfo {
            name: "test".into(),
            source: "builtin:test".into(),
            triangles: 1,
            bounds_min: [0.0; 3],
            bounds_max: [1.0; 3],
            metres_per_unit: 1.0,
            scale_source: "file".into(),
            space: None,
            near_distance: None,
            eye_height_m: None,
            credits: Vec::new(),
        };
        let mut g = Graph::new(scene);
        g.probes = (0..probes)
            .map(|i| f::Probe {
                id: i as u32,
                position: [0.0; 3],
                cluster: None,
                preferred_directions: Vec::new(),
                user_placed: false,
                assets: f::ProbeAssets::default(),
            })
            .collect();
        g.paths = (0..paths)
            .map(|i| f::Path {
                id: i as u32,
                from: 0,
                to: 1,
                polyline: Vec::new(),
                length: 0.0,
                duration_s: 0.0,
                camera: Vec::new(),
                assets: f::PathAssets::default(),
            })
            .collect();
        g
    }

    #[test]
    fn shards_split_the_jobs_between_them_each_job_once() {
        let g = graph(5, 7);
        let all = all_jobs(&g);
        assert_eq!(all.len(), 13);
        assert_eq!(all[4], Job::Probe(4));
        assert_eq!(all[5], Job::Path(0));
        assert_eq!(all[12], Job::Proxy);
        let dir = tempfile::tempdir().unwrap();
        let mut seen = Vec::new();
        for index in 0..3 {
            let (mine, todo) = jobs(dir.path(), &g, &[512], false, Shard { index, count: 3 });
            // Nothing is rendered yet: every job is to do.
            assert_eq!(mine, todo);
            assert!(mine.iter().all(|&(k, job)| k % 3 == index && all[k] == job));
            seen.extend(mine);
        }
        seen.sort_by_key(|&(k, _)| k);
        assert_eq!(seen.into_iter().map(|(_, job)| job).collect::<Vec<_>>(), all);
    }

    #[test]
    fn a_job_whose_files_are_all_there_is_not_redone() {
        let g = graph(2, 1);
        let dir = tempfile::tempdir().unwrap();
        let whole = Shard { index: 0, count: 1 };
        for file in ProbeFiles::new(1, &[512], false).all() {
            crate::files::write_atomic(&dir.path().join(file), b"x").unwrap();
        }
        // Only the video of path 0: its poster is missing, so it stays to do.
        crate::files::write_atomic(&dir.path().join(path::files(0).0), b"x").unwrap();
        let (mine, todo) = jobs(dir.path(), &g, &[512], false, whole);
        assert_eq!(mine.len(), 4);
        assert_eq!(todo, vec![(0, Job::Probe(0)), (2, Job::Path(0)), (3, Job::Proxy)]);
    }

    #[test]
    fn finalizing_with_a_damaged_manifest_names_it_and_writes_no_graph() {
        let mut g = graph(2, 1);
        let dir = tempfile::tempdir().unwrap();
        crate::files::write_atomic(&dir.path().join("shards/1-of-2.json"), b"{\"shard\": 1, \"count\":").unwrap();
        let e = exploremaps_format::error_chain(&shards::finalize(dir.path(), &mut g).unwrap_err());
        assert!(e.contains("1-of-2.json: not a shard manifest") && e.contains("run its shard again"), "{e}");
        assert!(!dir.path().join(exploremaps_format::GRAPH_FILE).exists());
    }
}

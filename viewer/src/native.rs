//! The native viewer: a winit window, files read and decoded on worker
//! threads, videos decoded with openh264 on a thread of their own.

use crate::app::{App, Gpu, Input, Key, Loaded, Options, Pano, Platform};
use crate::navigation::Navigator;
use crate::overlay::{OverlayPass, THUMB_H, THUMB_W};
use crate::panorama::{Cube, VideoTexture};
use crate::ui::Link;
use exploremaps_format::{FormatError, Graph, GRAPH_FILE};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{channel, sync_channel, Receiver, Sender, TryRecvError};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, TouchPhase, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    #[error("{path}: cannot read the bundle's graph (is this a bundle folder written by `exploremaps build`?)")]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{path}")]
    Format { path: PathBuf, source: FormatError },
    #[error("{0}")]
    Link(String),
    #[error("the bundle has no probes to show")]
    Empty,
    #[error("no window could be opened: {0}")]
    Window(String),
    #[error("no GPU adapter for the window: {0}; install Mesa's drivers (mesa-vulkan-drivers) or run with WGPU_BACKEND=gl")]
    Gpu(String),
}

/// Reads and checks a bundle's graph.json (format version first).
pub fn read_graph(bundle: &Path) -> Result<Graph, ViewError> {
    let path = bundle.join(GRAPH_FILE);
    let text = std::fs::read_to_string(&path).map_err(|source| ViewError::Read { path: path.clone(), source })?;
    let graph = Graph::from_json(&text).map_err(|source| ViewError::Format { path, source })?;
    if graph.probes.is_empty() {
        return Err(ViewError::Empty);
    }
    Ok(graph)
}

/// How to run the viewer.
pub struct ViewOptions {
    pub link: Link,
    pub tour: bool,
    /// Measure and print: time to first panorama, frame times in a probe and
    /// during a transition; then close.
    pub benchmark: bool,
    /// When the program started, for the time to first panorama.
    pub started: Instant,
}

enum Job {
    Cube { probe: u32, size: u32, files: [String; 6] },
    Tile { probe: u32, size: u32, slot: usize, x: u32, y: u32, file: String },
    Equirect { probe: u32, file: String },
    Thumbnail { probe: u32, file: String },
    Proxy { level: usize, part: usize, mesh: String, seen: Option<String>, probes: u32 },
    DepthMap { probe: u32, file: String, probes: u32 },
    DepthCube { probe: u32, file: String },
    Stream { stream: exploremaps_format::ProxyStream, base: exploremaps_format::ProxyLevel, probes: u32 },
}

enum Decoded {
    Cube { probe: u32, size: u32, faces: Vec<Vec<u8>> },
    Tile { probe: u32, size: u32, slot: usize, x: u32, y: u32, image: image::RgbaImage },
    Equirect { probe: u32, width: u32, height: u32, rgba: Vec<u8> },
    Thumbnail { probe: u32, rgba: Vec<u8> },
    Proxy { level: usize, part: usize, mesh: exploremaps_format::meshcode::MeshData, seen: Vec<u32> },
    Refined { level: usize, mesh: exploremaps_format::meshcode::MeshData, seen: Vec<u32> },
    DepthMap { probe: u32, map: exploremaps_format::depthmap::DepthMap },
    DepthCube { probe: u32, cube: exploremaps_format::depthcube::DepthCube },
    Failed { what: String, error: String, probe: Option<u32> },
}

fn decode(root: &Path, file: &str) -> Result<image::RgbaImage, String> {
    let bytes = std::fs::read(root.join(file)).map_err(|e| format!("cannot be read ({e})"))?;
    Ok(image::load_from_memory(&bytes).map_err(|e| format!("is not a readable image ({e})"))?.to_rgba8())
}

/// A cube level's six faces, each the size graph.json says.
fn cube(root: &Path, probe: u32, size: u32, files: &[String; 6]) -> Decoded {
    let mut faces = Vec::with_capacity(6);
    for f in files {
        match decode(root, f) {
            Ok(img) if img.dimensions() == (size, size) => faces.push(img.into_raw()),
            Ok(img) => {
                return Decoded::Failed {
                    what: f.clone(),
                    error: format!("is {}×{}, but graph.json says {size}×{size}", img.width(), img.height()),
                    probe: Some(probe),
                }
            }
            Err(e) => return Decoded::Failed { what: f.clone(), error: e, probe: Some(probe) },
        }
    }
    Decoded::Cube { probe, size, faces }
}

/// Does a job and sends what came of it; false once the viewer has gone.
fn work(root: &Path, job: Job, results: &Sender<Decoded>) -> bool {
    let failed = |what: &str, error: String, probe| Decoded::Failed { what: what.to_string(), error, probe };
    let decoded = match job {
        Job::Cube { probe, size, files } => cube(root, probe, size, &files),
        Job::Tile { probe, size, slot, x, y, file } => match decode(root, &file) {
            Ok(image) => Decoded::Tile { probe, size, slot, x, y, image },
            Err(e) => failed(&file, e, None),
        },
        Job::Equirect { probe, file } => match decode(root, &file) {
            Ok(img) => {
                // Within every GPU's texture limit.
                let img = if img.width() > 4096 { image::imageops::resize(&img, 4096, 2048, image::imageops::FilterType::Triangle) } else { img };
                Decoded::Equirect { probe, width: img.width(), height: img.height(), rgba: img.into_raw() }
            }
            Err(e) => failed(&file, e, Some(probe)),
        },
        Job::Proxy { level, part, mesh, seen, probes } => {
            let read = |f: &str| std::fs::read(root.join(f)).map_err(|e| (f.to_string(), format!("cannot be read ({e})")));
            let decoded = read(&mesh).and_then(|m| {
                let s = seen.as_deref().map(|f| read(f).map(|b| (f, b))).transpose()?;
                crate::dollhouse::decode_level(&mesh, &m, s.as_ref().map(|(f, b)| (*f, b.as_slice())), probes)
            });
            match decoded {
                Ok((mesh, seen)) => Decoded::Proxy { level, part, mesh, seen },
                Err((what, error)) => failed(&what, error, None),
            }
        }
        Job::Stream { stream, base, probes } => return refine(root, &stream, &base, probes, results),
        Job::DepthMap { probe, file, probes } => match std::fs::read(root.join(&file)) {
            Ok(bytes) => match exploremaps_format::depthmap::DepthMap::decode(&bytes, probes) {
                Ok(map) => Decoded::DepthMap { probe, map },
                Err(e) => failed(&file, e.to_string(), None),
            },
            Err(e) => failed(&file, format!("cannot be read ({e})"), None),
        },
        Job::DepthCube { probe, file } => match std::fs::read(root.join(&file)) {
            Ok(bytes) => match exploremaps_format::depthcube::DepthCube::decode(&bytes) {
                Ok(cube) => Decoded::DepthCube { probe, cube },
                Err(e) => failed(&file, e.to_string(), None),
            },
            Err(e) => failed(&file, format!("cannot be read ({e})"), None),
        },
        Job::Thumbnail { probe, file } => match decode(root, &file) {
            Ok(img) => {
                Decoded::Thumbnail { probe, rgba: image::imageops::resize(&img, THUMB_W, THUMB_H, image::imageops::FilterType::Triangle).into_raw() }
            }
            Err(e) => failed(&file, e, None),
        },
    };
    results.send(decoded).is_ok()
}

/// Refines a proxy level by its vertex splits in this worker, sending the
/// mesh after each packet; false once the viewer has gone.
fn refine(
    root: &Path,
    stream: &exploremaps_format::ProxyStream,
    base: &exploremaps_format::ProxyLevel,
    probes: u32,
    results: &Sender<Decoded>,
) -> bool {
    let read = |f: &str| std::fs::read(root.join(f)).map_err(|e| (f.to_string(), format!("cannot be read ({e})")));
    let started = read(&base.file).and_then(|b| {
        let seen = base.seen.as_deref().map(|f| read(f).map(|bytes| (f, bytes))).transpose()?;
        crate::dollhouse::Refining::new(&base.file, &b, seen.as_ref().map(|(f, bytes)| (*f, bytes.as_slice())), probes)
    });
    let mut refining = match started {
        Ok(r) => r,
        Err((what, error)) => return results.send(Decoded::Failed { what, error, probe: None }).is_ok(),
    };
    for (file, packets) in stream.files() {
        let bytes = match read(&file) {
            Ok(b) => b,
            Err((what, error)) => return results.send(Decoded::Failed { what, error, probe: None }).is_ok(),
        };
        for k in packets {
            let applied = stream.packets[k].slice(&bytes).map_err(|e| (file.clone(), e)).and_then(|p| refining.apply(&file, p));
            let sent = match applied {
                Ok(()) => {
                    let (mesh, seen) = refining.snapshot();
                    results.send(Decoded::Refined { level: stream.level_after(k), mesh, seen })
                }
                Err((what, error)) => return results.send(Decoded::Failed { what, error, probe: None }).is_ok(),
            };
            if sent.is_err() {
                return false;
            }
        }
    }
    true
}

/// A decoded video frame: its place in travel order, RGBA pixels, size.
type VideoFrame = (u32, Vec<u8>, u32, u32);

/// A path's video being decoded: frames in travel order.
struct Playback {
    frames: Receiver<Result<VideoFrame, String>>,
    count: Arc<Mutex<Option<u32>>>,
    texture: Option<VideoTexture>,
    next: u32,
}

fn rgba(rgb: &[u8]) -> Vec<u8> {
    rgb.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect()
}

/// Decodes a video on its own thread. Reversed playback decodes a key-frame
/// interval at a time, last first (H.264 only decodes forward), so at most
/// one interval of frames is held.
fn start_playback(path: PathBuf, reversed: bool) -> Playback {
    let (tx, rx) = sync_channel(3);
    let count = Arc::new(Mutex::new(None));
    let counted = count.clone();
    std::thread::spawn(move || {
        let run = || -> Result<(), String> {
            let failed = |e: exploremaps_format::video::DecodeError| format!("{}: {e}", path.display());
            let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            let mut decoder = exploremaps_format::video::Mp4Decoder::new(bytes).map_err(failed)?;
            let n = decoder.frame_count();
            *counted.lock().expect("count lock") = Some(n);
            let mut sent = 0;
            let mut send = |px: Vec<u8>, w: u32, h: u32| {
                sent += 1;
                tx.send(Ok((sent - 1, px, w, h))).is_ok()
            };
            if !reversed {
                while let Some(f) = decoder.next_frame().map_err(failed)? {
                    if !send(rgba(&f.rgb), f.width, f.height) {
                        return Ok(());
                    }
                }
                return Ok(());
            }
            let starts: Vec<u32> = decoder.key_frames().to_vec();
            let mut end = n;
            for &start in starts.iter().rev() {
                decoder.seek(start).map_err(failed)?;
                let mut interval = Vec::new();
                for _ in start..end {
                    let Some(f) = decoder.next_frame().map_err(failed)? else { break };
                    interval.push((rgba(&f.rgb), f.width, f.height));
                }
                for (px, w, h) in interval.into_iter().rev() {
                    if !send(px, w, h) {
                        return Ok(());
                    }
                }
                end = start;
            }
            Ok(())
        };
        if let Err(e) = run() {
            let _ = tx.send(Err(e));
        }
    });
    Playback { frames: rx, count, texture: None, next: 0 }
}

pub struct NativePlatform {
    root: PathBuf,
    jobs: Sender<Job>,
    done: Receiver<Decoded>,
    playback: Option<Playback>,
    /// The last message, for the window title.
    pub message: Option<String>,
    pub link: Option<Link>,
}

impl NativePlatform {
    pub fn new(root: PathBuf) -> NativePlatform {
        let (jobs, queue) = channel::<Job>();
        let (results, done) = channel();
        let queue = Arc::new(Mutex::new(queue));
        let workers = std::thread::available_parallelism().map_or(2, |n| n.get()).clamp(1, 4);
        for _ in 0..workers {
            let (queue, results, root) = (queue.clone(), results.clone(), root.clone());
            std::thread::spawn(move || loop {
                let job = match queue.lock().expect("job queue").recv() {
                    Ok(job) => job,
                    Err(_) => return,
                };
                if !work(&root, job, &results) {
                    return;
                }
            });
        }
        NativePlatform { root, jobs, done, playback: None, message: None, link: None }
    }
}

impl Platform for NativePlatform {
    fn load_cube(&mut self, probe: u32, size: u32, faces: &[String; 6]) {
        let _ = self.jobs.send(Job::Cube { probe, size, files: faces.clone() });
    }

    fn load_tile(&mut self, probe: u32, size: u32, slot: usize, x: u32, y: u32, file: &str) {
        let _ = self.jobs.send(Job::Tile { probe, size, slot, x, y, file: file.to_string() });
    }

    fn load_equirect(&mut self, probe: u32, file: &str) {
        let _ = self.jobs.send(Job::Equirect { probe, file: file.to_string() });
    }

    fn load_thumbnail(&mut self, probe: u32, file: &str) {
        let _ = self.jobs.send(Job::Thumbnail { probe, file: file.to_string() });
    }

    fn load_proxy(&mut self, level: usize, part: usize, mesh: &str, seen: Option<&str>, probes: u32) {
        let _ = self.jobs.send(Job::Proxy { level, part, mesh: mesh.to_string(), seen: seen.map(str::to_string), probes });
    }

    fn load_stream(&mut self, stream: &exploremaps_format::ProxyStream, base: &exploremaps_format::ProxyLevel, probes: u32) {
        let _ = self.jobs.send(Job::Stream { stream: stream.clone(), base: base.clone(), probes });
    }

    fn load_depth_map(&mut self, probe: u32, file: &str, probes: u32) {
        let _ = self.jobs.send(Job::DepthMap { probe, file: file.to_string(), probes });
    }

    fn load_depth_cube(&mut self, probe: u32, file: &str) {
        let _ = self.jobs.send(Job::DepthCube { probe, file: file.to_string() });
    }

    fn poll(&mut self, gpu: &Gpu, overlay: &OverlayPass) -> Vec<Loaded> {
        let mut out = Vec::new();
        while let Ok(d) = self.done.try_recv() {
            out.push(match d {
                Decoded::Cube { probe, size, faces } => {
                    let cube = Cube::new(&gpu.device, size);
                    for (f, px) in faces.iter().enumerate() {
                        cube.write_face(&gpu.queue, f, px);
                    }
                    Loaded::Pano { probe, pano: Pano::Cube(cube) }
                }
                Decoded::Tile { probe, size, slot, x, y, image } => {
                    let pixels = crate::panorama::TilePixels::Rgba { width: image.width(), height: image.height(), rgba: image.into_raw() };
                    Loaded::Tile { probe, size, slot, x, y, pixels }
                }
                Decoded::Equirect { probe, width, height, rgba } => {
                    let t = VideoTexture::new(&gpu.device, width, height);
                    t.write(&gpu.queue, &rgba);
                    Loaded::Pano { probe, pano: Pano::Equirect(t) }
                }
                Decoded::Thumbnail { probe, rgba } => {
                    overlay.write_thumbnail(&gpu.queue, probe, &rgba);
                    Loaded::Thumbnail { probe }
                }
                Decoded::Proxy { level, part, mesh, seen } => Loaded::Proxy { level, part, mesh, seen },
                Decoded::Refined { level, mesh, seen } => Loaded::Refined { level, mesh, seen },
                Decoded::DepthMap { probe, map } => Loaded::DepthMap { probe, map },
                Decoded::DepthCube { probe, cube } => Loaded::DepthCube { probe, cube },
                Decoded::Failed { what, error, probe } => Loaded::Failed { what, error, probe },
            });
        }
        // One refined proxy a poll: the latest holds the others.
        let latest = out.iter().rposition(|l| matches!(l, Loaded::Refined { .. }));
        out.into_iter().enumerate().filter(|(i, l)| Some(*i) == latest || !matches!(l, Loaded::Refined { .. })).map(|(_, l)| l).collect()
    }

    fn play_video(&mut self, file: &str, reversed: bool) {
        self.playback = Some(start_playback(self.root.join(file), reversed));
    }

    fn stop_video(&mut self) {
        self.playback = None;
    }

    fn video_frame(&mut self, gpu: &Gpu, t: f32) -> Result<Option<&VideoTexture>, String> {
        let Some(p) = &mut self.playback else { return Ok(None) };
        let count = p.count.lock().expect("count lock").unwrap_or(1);
        let wanted = (t.clamp(0.0, 1.0) * (count.max(1) - 1) as f32).round() as u32;
        let mut latest = None;
        let mut error = None;
        while p.next <= wanted {
            match p.frames.try_recv() {
                Ok(Ok(frame)) => {
                    p.next = frame.0 + 1;
                    latest = Some(frame);
                }
                Ok(Err(e)) => {
                    error = Some(e);
                    break;
                }
                Err(TryRecvError::Empty | TryRecvError::Disconnected) => break,
            }
        }
        if let Some(e) = error {
            self.playback = None;
            return Err(e);
        }
        let Some(p) = &mut self.playback else { return Ok(None) };
        if let Some((_, px, w, h)) = latest {
            if p.texture.as_ref().is_none_or(|t| (t.width, t.height) != (w, h)) {
                p.texture = Some(VideoTexture::new(&gpu.device, w, h));
            }
            p.texture.as_ref().expect("made above").write(&gpu.queue, &px);
        }
        Ok(p.texture.as_ref())
    }

    fn show_message(&mut self, text: &str) {
        tracing::warn!("{text}");
        self.message = Some(text.to_string());
    }

    fn link_changed(&mut self, link: &Link) {
        tracing::info!("view: {}", link.to_fragment());
        self.link = Some(*link);
    }
}

/// Benchmark phases: wait for the first panorama, time frames in a probe,
/// along the best path until arrival and back, then orbiting the dollhouse.
#[derive(Default)]
struct Bench {
    phase: u8,
    frames: Vec<f64>,
    /// The path travelled forward, to travel back.
    path: Option<u32>,
}

struct Running {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    view_format: wgpu::TextureFormat,
    app: App,
    platform: NativePlatform,
    last: Instant,
    title: String,
}

struct Runner {
    bundle: PathBuf,
    graph: Option<Graph>,
    options: ViewOptions,
    running: Option<Running>,
    error: Option<ViewError>,
    cursor: (f32, f32),
    bench: Bench,
}

/// Tab also steps to the next probe here (a web page keeps it for focus).
fn key(code: KeyCode) -> Option<Key> {
    if code == KeyCode::Tab {
        return Some(Key::NextProbe);
    }
    Key::from_code(&format!("{code:?}"))
}

impl Runner {
    fn start(&mut self, event_loop: &ActiveEventLoop) -> Result<Running, ViewError> {
        let graph = self.graph.take().ok_or(ViewError::Empty)?;
        let title = format!("ExploreMaps: {}", graph.scene.name);
        let attributes = Window::default_attributes().with_title(&title).with_inner_size(winit::dpi::PhysicalSize::new(1280, 720));
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| ViewError::Window(e.to_string()))?);
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let surface = instance.create_surface(window.clone()).map_err(|e| ViewError::Window(e.to_string()))?;
        let size = window.inner_size();
        let (adapter, gpu, config) = pollster::block_on(async {
            let adapter = instance
                .request_adapter(&wgpu::RequestAdapterOptions { compatible_surface: Some(&surface), ..Default::default() })
                .await
                .map_err(|e| ViewError::Gpu(e.to_string()))?;
            let (gpu, config) = Gpu::open(&adapter, &surface, size.width, size.height).await.map_err(ViewError::Gpu)?;
            Ok::<_, ViewError>((adapter, gpu, config))
        })?;
        let view_format = gpu.format;
        tracing::info!("viewer on {} ({:?})", adapter.get_info().name, adapter.get_info().backend);
        let mut platform = NativePlatform::new(self.bundle.clone());
        let nav = Navigator::new(graph, self.options.link.probe, 1).map_err(|e| ViewError::Link(format!("--probe: {e}")))?;
        let options = Options { budget_bytes: 768 << 20, max_face: 2048, show_map: true, tour: self.options.tour };
        let mut app = App::new(gpu, nav, Some(&self.options.link), options, &mut platform);
        app.resize(config.width, config.height, window.scale_factor() as f32);
        Ok(Running { window, surface, config, view_format, app, platform, last: Instant::now(), title })
    }

    fn frame(&mut self, event_loop: &ActiveEventLoop) {
        let Some(r) = &mut self.running else { return };
        let now = Instant::now();
        let dt = (now - r.last).as_secs_f32().min(0.1);
        r.last = now;
        r.app.update(dt, &mut r.platform);
        let frame = match r.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f) | wgpu::CurrentSurfaceTexture::Suboptimal(f) => f,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                r.surface.configure(&r.app_device(), &r.config);
                r.window.request_redraw();
                return;
            }
            _ => {
                r.window.request_redraw();
                return;
            }
        };
        let view = frame.texture.create_view(&wgpu::TextureViewDescriptor { format: Some(r.view_format), ..Default::default() });
        let commands = r.app.render(&view, &mut r.platform);
        r.app_queue().submit([commands]);
        r.window.pre_present_notify();
        r.app_queue().present(frame);
        let title = match &r.platform.message {
            Some(m) => format!("{}: {m}", r.title),
            None => r.title.clone(),
        };
        r.window.set_title(&title);
        if self.options.benchmark {
            self.benchmark(now, event_loop);
        }
        let Some(r) = &mut self.running else { return };
        if r.app.animating() || self.options.benchmark {
            r.window.request_redraw();
        }
    }

    fn benchmark(&mut self, frame_start: Instant, event_loop: &ActiveEventLoop) {
        let Some(r) = &mut self.running else { return };
        // Wait for the GPU so frame times are real, not queue depth.
        let _ = r.app_device().poll(wgpu::PollType::wait_indefinitely());
        let ms = frame_start.elapsed().as_secs_f64() * 1e3;
        let b = &mut self.bench;
        match b.phase {
            0 if r.app.shown_panorama => {
                println!("first panorama: {:.0} ms after start", self.options.started.elapsed().as_secs_f64() * 1e3);
                b.phase = 1;
            }
            1 => {
                b.frames.push(ms);
                r.app.nav.look(0.08, 0.0);
                if b.frames.len() == 120 {
                    print_frames("in a probe", &b.frames, r.config.width, r.config.height);
                    b.frames.clear();
                    r.app.input(Input::Key(Key::Go), &mut r.platform);
                    b.phase = 2;
                }
            }
            2 => {
                b.frames.push(ms);
                if let crate::navigation::State::Travelling { path, .. } = r.app.nav.state {
                    b.path = Some(path);
                }
                if r.app.nav.progress().is_none() {
                    print_frames("during a transition", &b.frames, r.config.width, r.config.height);
                    b.frames.clear();
                    // The same path back: its video decoded backwards.
                    match b.path.map(|p| r.app.nav.take_path(p)) {
                        Some(Ok(())) => b.phase = 3,
                        _ => event_loop.exit(),
                    }
                }
            }
            3 => {
                b.frames.push(ms);
                if r.app.nav.progress().is_none() {
                    print_frames("travelling the path backwards", &b.frames, r.config.width, r.config.height);
                    b.frames.clear();
                    if r.app.nav.graph().proxy.is_none() {
                        return event_loop.exit();
                    }
                    r.app.input(Input::Key(Key::Dollhouse), &mut r.platform);
                    b.phase = 4;
                }
            }
            // Orbiting the dollhouse, once its finest level is in and the flight is over.
            4 if !r.app.flying() && r.app.proxy.as_ref().is_some_and(|m| m.level == 0) => {
                b.frames.push(ms);
                r.app.input(Input::Key(Key::Right), &mut r.platform);
                if b.frames.len() == 120 {
                    print_frames("orbiting the dollhouse", &b.frames, r.config.width, r.config.height);
                    event_loop.exit();
                }
            }
            _ => {}
        }
    }
}

impl Running {
    fn app_device(&self) -> wgpu::Device {
        self.app.gpu().device.clone()
    }

    fn app_queue(&self) -> wgpu::Queue {
        self.app.gpu().queue.clone()
    }
}

fn print_frames(what: &str, ms: &[f64], w: u32, h: u32) {
    let mut sorted = ms.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mean = ms.iter().sum::<f64>() / ms.len().max(1) as f64;
    let p95 = sorted.get((sorted.len() * 95 / 100).min(sorted.len().saturating_sub(1))).copied().unwrap_or(0.0);
    println!("frame time {what} at {w}x{h}: mean {mean:.1} ms, p95 {p95:.1} ms over {} frames", ms.len());
}

impl ApplicationHandler for Runner {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match self.start(event_loop) {
            Ok(r) => {
                r.window.request_redraw();
                self.running = Some(r);
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        if matches!(event, WindowEvent::RedrawRequested) {
            return self.frame(event_loop);
        }
        let Some(r) = &mut self.running else { return };
        let input = match event {
            WindowEvent::CloseRequested => return event_loop.exit(),
            WindowEvent::Resized(size) => {
                r.config.width = size.width.max(1);
                r.config.height = size.height.max(1);
                r.surface.configure(&r.app_device(), &r.config);
                r.app.resize(r.config.width, r.config.height, r.window.scale_factor() as f32);
                None
            }
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => match event.physical_key {
                PhysicalKey::Code(KeyCode::Escape) => return event_loop.exit(),
                PhysicalKey::Code(code) => key(code).map(Input::Key),
                _ => None,
            },
            WindowEvent::CursorMoved { position, .. } => {
                self.cursor = (position.x as f32, position.y as f32);
                Some(Input::PointerMove { id: 0, x: self.cursor.0, y: self.cursor.1 })
            }
            WindowEvent::MouseInput { state, button: MouseButton::Left, .. } => {
                let (x, y) = self.cursor;
                Some(if state == ElementState::Pressed { Input::PointerDown { id: 0, x, y } } else { Input::PointerUp { id: 0, x, y } })
            }
            WindowEvent::MouseWheel { delta, .. } => Some(Input::Wheel(match delta {
                MouseScrollDelta::LineDelta(_, y) => y,
                MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
            })),
            WindowEvent::Touch(t) => {
                let (id, x, y) = (t.id + 1, t.location.x as f32, t.location.y as f32);
                Some(match t.phase {
                    TouchPhase::Started => Input::PointerDown { id, x, y },
                    TouchPhase::Moved => Input::PointerMove { id, x, y },
                    TouchPhase::Ended | TouchPhase::Cancelled => Input::PointerUp { id, x, y },
                })
            }
            _ => None,
        };
        if let Some(input) = input {
            r.app.input(input, &mut r.platform);
            r.window.request_redraw();
        }
    }
}

/// Opens a window on a bundle and runs until it is closed.
pub fn run(bundle: &Path, options: ViewOptions) -> Result<(), ViewError> {
    let graph = read_graph(bundle)?;
    if let Some(p) = options.link.probe {
        if p as usize >= graph.probes.len() {
            return Err(ViewError::Link(format!("probe {p} does not exist; the bundle has probes 0 to {}", graph.probes.len() - 1)));
        }
    }
    let event_loop = EventLoop::new().map_err(|e| ViewError::Window(format!("{e}; is a display available (DISPLAY or WAYLAND_DISPLAY)?")))?;
    event_loop.set_control_flow(ControlFlow::Wait);
    let mut runner =
        Runner { bundle: bundle.to_path_buf(), graph: Some(graph), options, running: None, error: None, cursor: (0.0, 0.0), bench: Bench::default() };
    event_loop.run_app(&mut runner).map_err(|e| ViewError::Window(e.to_string()))?;
    match runner.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every frame of a playback, in the order it arrives.
    fn all_frames(path: &Path, reversed: bool) -> Vec<Vec<u8>> {
        let playback = start_playback(path.to_path_buf(), reversed);
        let numbered = |(k, f): (usize, Result<VideoFrame, String>)| {
            let (i, px, _, _) = f.expect("a frame");
            assert_eq!(i as usize, k, "frames arrive numbered in travel order");
            px
        };
        playback.frames.iter().enumerate().map(numbered).collect()
    }

    #[test]
    fn reversed_playback_gives_every_frame_backwards_a_key_frame_interval_at_a_time() {
        // 12 numbered frames with a key frame every 5, no B-frames (as the builder writes).
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("clip.mp4");
        let made = std::process::Command::new("ffmpeg")
            .args(["-v", "error", "-f", "lavfi", "-i", "testsrc=size=64x32:rate=5", "-frames:v", "12"])
            .args(["-c:v", "libx264", "-bf", "0", "-g", "5", "-keyint_min", "5", "-sc_threshold", "0", "-pix_fmt", "yuv420p"])
            .arg(&path)
            .status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("SKIPPED: no ffmpeg with libx264 to make a clip");
            return;
        }
        let forward = all_frames(&path, false);
        assert_eq!(forward.len(), 12);
        let mut backward = all_frames(&path, true);
        backward.reverse();
        assert!(backward == forward, "reversed playback shows the same frames in the opposite order");
    }
}

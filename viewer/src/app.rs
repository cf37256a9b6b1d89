//! The viewer application, the same natively and in the browser: it turns
//! input into navigation, asks its platform for the panoramas, thumbnails
//! and videos it needs (low resolution first, neighbours prefetched, a
//! memory budget for textures) and draws a frame. Platforms (`native`,
//! `web`) own the window, files and decoding.

use crate::dollhouse::{facing, Camera, DollhousePass, Floors, FrameTarget, Orbit, ProxyMesh};
use crate::glide::{GlideMesh, GlidePass};
use crate::headset::{Gaze, Goal, Headset, Target};
use crate::navigation::{direction, NavError, Navigator, State};
use crate::overlay::{OverlayPass, Shape};
use crate::panorama::{visible_tiles, Cube, Lens, PanoramaPass, Shown, Source, TilePixels, Tiled, VideoTexture, TILE_SLOTS};
use crate::ui::{self, Action, DollhouseScreen, Link, Screen};
use exploremaps_format::timing::ease;
use exploremaps_format::{depthcube::DepthCube, depthmap::DepthMap, meshcode::MeshData, seen::NONE, ProxyLevel, ProxyStream};
use glam::Vec3;
use std::collections::{HashMap, HashSet};

/// The device, its queue and the colour format frames are drawn in.
#[derive(Clone)]
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub format: wgpu::TextureFormat,
}

impl Gpu {
    /// Opens the device and configures `surface` (`width` × `height`) as
    /// both front ends do: WebGL2-level limits raised to the adapter's
    /// texture sizes, and an sRGB view of whatever format the surface offers
    /// (WebGPU canvases offer only non-sRGB ones). Returns the configuration
    /// (its view format is the `Gpu`'s), or what failed.
    pub async fn open(
        adapter: &wgpu::Adapter,
        surface: &wgpu::Surface<'_>,
        width: u32,
        height: u32,
    ) -> Result<(Gpu, wgpu::SurfaceConfiguration), String> {
        let limits = wgpu::Limits::downlevel_webgl2_defaults().using_resolution(adapter.limits());
        let desc = wgpu::DeviceDescriptor { label: Some("viewer"), required_limits: limits, ..Default::default() };
        let (device, queue) = adapter.request_device(&desc).await.map_err(|e| format!("no GPU device: {e}"))?;
        let mut config = surface.get_default_config(adapter, width.max(1), height.max(1)).ok_or("the adapter cannot draw to this surface")?;
        let format = config.format.add_srgb_suffix();
        config.view_formats = vec![format];
        config.present_mode = wgpu::PresentMode::AutoVsync;
        surface.configure(&device, &config);
        Ok((Gpu { device, queue, format }, config))
    }
}

/// One eye of a headset: where it draws in the frame (pixels, x and y from
/// the top left, width, height) and how it sees.
#[derive(Clone, Copy, Debug)]
pub struct Eye {
    pub viewport: [f32; 4],
    pub lens: Lens,
}

/// A probe's panorama as loaded: a cube level, or the equirectangular image
/// when a bundle has no cube maps.
pub enum Pano {
    Cube(Cube),
    Equirect(VideoTexture),
}

impl Pano {
    fn size(&self) -> u32 {
        match self {
            Pano::Cube(c) => c.size,
            // Sort an equirect as the cube face of equal sharpness.
            Pano::Equirect(t) => t.width / 4,
        }
    }

    fn bytes(&self) -> u64 {
        match self {
            Pano::Cube(c) => c.bytes(),
            Pano::Equirect(t) => 4 * u64::from(t.width) * u64::from(t.height),
        }
    }

    /// Drawn with the tiles of a sharper level that have arrived, if any.
    fn source<'a>(&'a self, tiles: Option<&'a Tiled>) -> Source<'a> {
        match self {
            Pano::Cube(c) => Source::Cube(c, tiles),
            Pano::Equirect(t) => Source::Video(t),
        }
    }
}

/// What a platform hands back from loading.
pub enum Loaded {
    Pano {
        probe: u32,
        pano: Pano,
    },
    /// A tile of the level of face `size` of a probe's tile pyramid, for
    /// cube slot `slot` ([`TILE_SLOTS`]) at (x, y).
    Tile {
        probe: u32,
        size: u32,
        slot: usize,
        x: u32,
        y: u32,
        pixels: TilePixels,
    },
    /// The thumbnail is in the overlay's layer `probe`.
    Thumbnail {
        probe: u32,
    },
    /// A part (chunk) of a proxy level decoded, with its point-to-go table
    /// (empty without one).
    Proxy {
        level: usize,
        part: usize,
        mesh: MeshData,
        seen: Vec<u32>,
    },
    /// The proxy as refined by the vertex splits so far: `level` is the
    /// stream's coarse level until its last packet, then its fine one.
    Refined {
        level: usize,
        mesh: MeshData,
        seen: Vec<u32>,
    },
    /// A probe's point-to-go depth cube.
    DepthMap {
        probe: u32,
        map: DepthMap,
    },
    /// A probe's depth for glides.
    DepthCube {
        probe: u32,
        cube: DepthCube,
    },
    /// `what` names the asset (its file), `error` what went wrong.
    Failed {
        what: String,
        error: String,
        probe: Option<u32>,
    },
}

/// Loading and playback, done by the platform (files and threads natively,
/// fetch and the browser's decoders on the web). Requests are answered later
/// through `poll`.
pub trait Platform {
    fn load_cube(&mut self, probe: u32, size: u32, faces: &[String; 6]);
    /// Loads one tile (a failure names no probe: the whole cube stays).
    fn load_tile(&mut self, probe: u32, size: u32, slot: usize, x: u32, y: u32, file: &str);
    fn load_equirect(&mut self, probe: u32, file: &str);
    fn load_thumbnail(&mut self, probe: u32, file: &str);
    /// Loads and decodes a part of a proxy level (off the main thread where
    /// the platform can, else one part between two frames) and its
    /// point-to-go table, checked against `probes`.
    fn load_proxy(&mut self, level: usize, part: usize, mesh: &str, seen: Option<&str>, probes: u32);
    /// Loads the vertex splits that refine the proxy level `base` (its file,
    /// decoded again) and applies their packets in order, off the main
    /// thread where the platform can, else one packet between two frames;
    /// answers with the mesh as refined so far ([`Loaded::Refined`]), at
    /// most once a poll (each is a whole mesh to upload).
    fn load_stream(&mut self, stream: &ProxyStream, base: &ProxyLevel, probes: u32);
    /// Loads and decodes a probe's depth map, checked against `probes`.
    fn load_depth_map(&mut self, probe: u32, file: &str, probes: u32);
    /// Loads and decodes a probe's depth cube for glides.
    fn load_depth_cube(&mut self, probe: u32, file: &str);
    fn poll(&mut self, gpu: &Gpu, overlay: &OverlayPass) -> Vec<Loaded>;
    /// Starts a path's video; `reversed` plays it end to start.
    fn play_video(&mut self, file: &str, reversed: bool);
    fn stop_video(&mut self);
    /// The frame for fraction `t` of the travel, once one has arrived; an
    /// error once if the video cannot be played.
    fn video_frame(&mut self, gpu: &Gpu, t: f32) -> Result<Option<&VideoTexture>, String>;
    /// Shows a message to the user (the interface shows a red bar meanwhile).
    fn show_message(&mut self, text: &str);
    /// The deep link to the current place, when it changes.
    fn link_changed(&mut self, _link: &Link) {}
}

/// Input, in physical pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Input {
    PointerDown {
        id: u64,
        x: f32,
        y: f32,
    },
    PointerMove {
        id: u64,
        x: f32,
        y: f32,
    },
    PointerUp {
        id: u64,
        x: f32,
        y: f32,
    },
    /// Wheel steps, positive away from the user (zoom in).
    Wheel(f32),
    Key(Key),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Key {
    Left,
    Right,
    Up,
    Down,
    ZoomIn,
    ZoomOut,
    /// Take the best-aligned path.
    Go,
    NextProbe,
    PreviousProbe,
    Map,
    Tour,
    Dollhouse,
    /// The next storey in the dollhouse (then the whole scene).
    Floor,
}

impl Key {
    /// The key for a key code as the web names them (`KeyboardEvent.code`,
    /// which winit's `KeyCode` variants are named after): arrows or WASD
    /// turn, +/- zoom, Enter or Space go, N/P next or previous probe, M map,
    /// T tour, O dollhouse, F floor.
    pub fn from_code(code: &str) -> Option<Key> {
        Some(match code {
            "ArrowLeft" | "KeyA" => Key::Left,
            "ArrowRight" | "KeyD" => Key::Right,
            "ArrowUp" | "KeyW" => Key::Up,
            "ArrowDown" | "KeyS" => Key::Down,
            "Equal" | "NumpadAdd" | "PageUp" => Key::ZoomIn,
            "Minus" | "NumpadSubtract" | "PageDown" => Key::ZoomOut,
            "Enter" | "Space" => Key::Go,
            "KeyN" => Key::NextProbe,
            "KeyP" => Key::PreviousProbe,
            "KeyM" => Key::Map,
            "KeyT" => Key::Tour,
            "KeyO" => Key::Dollhouse,
            "KeyF" => Key::Floor,
            _ => return None,
        })
    }
}

/// Seconds the tour stays at a probe before moving on.
const TOUR_DWELL_S: f32 = 2.0;
/// A press that moves less than this many logical pixels is a tap.
const TAP_SLOP: f32 = 8.0;
const MESSAGE_S: f32 = 6.0;
const KEY_TURN: f32 = 0.08;
/// Seconds of a flight between the dollhouse and a probe, and of the
/// panorama's fade over the proxy at either end of it.
const FLIGHT_S: f32 = 1.0;
/// The longest route (at its glides' pace) taken to a probe no path joins;
/// farther ones fly over the dollhouse.
const MAX_ROUTE_S: f32 = 10.0;
/// Probes whose markers are tested against the proxy each frame.
const MARKER_TESTS: usize = 8;
/// Seconds of a flight over the dollhouse between probes no path joins.
const OVER_S: f32 = 1.8;
const FADE_S: f32 = 0.35;
/// Probes within this many metres are a headset's targets (beside the paths).
const NEAR_TARGET_M: f32 = 12.0;

/// A proxy level and a height.
type SectionKey = (usize, f32);
/// Segments (x, z, x, z) of a section, shared with the interface.
type Segments = std::rc::Rc<[[f32; 4]]>;

/// What pointer input amounts to.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Gesture {
    /// One finger moved by (dx, dy) pixels.
    Drag(f32, f32),
    /// Two fingers: their spread's ratio (before / after) and the pan of their midpoint.
    Pinch {
        spread: f32,
        pan: (f32, f32),
    },
    Tap(f32, f32),
    /// The end of a drag or pinch.
    Release,
}

/// What fills the screen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Panorama,
    Dollhouse,
}

/// A camera move over the proxy: up out of a probe into the dollhouse, down
/// into a probe (`arrive`: the probe and the direction to face), or from a
/// probe over the dollhouse to another (through `via`, a Bézier arc).
#[derive(Clone, Copy, Debug)]
struct Flight {
    from: Camera,
    via: Option<Camera>,
    to: Camera,
    elapsed_s: f32,
    duration_s: f32,
    arrive: Option<(u32, f32, f32)>,
    /// It leaves a panorama, which fades out as it starts.
    fade_out: bool,
}

impl Flight {
    fn new(from: Camera, to: Camera, arrive: Option<(u32, f32, f32)>, fade_out: bool) -> Flight {
        Flight { from, via: None, to, elapsed_s: 0.0, duration_s: FLIGHT_S, arrive, fade_out }
    }
    fn t(&self) -> f32 {
        (self.elapsed_s / self.duration_s).min(1.0)
    }
    fn camera(&self) -> Camera {
        let s = ease(self.t());
        match &self.via {
            None => self.from.lerp(&self.to, s),
            Some(v) => {
                let (a, b, c) = ((1.0 - s) * (1.0 - s), 2.0 * (1.0 - s) * s, s * s);
                let forward = (self.from.forward * a + v.forward * b + self.to.forward * c).try_normalize().unwrap_or(self.to.forward);
                Camera { eye: self.from.eye * a + v.eye * b + self.to.eye * c, forward, fov_y: self.from.fov_y * a + v.fov_y * b + self.to.fov_y * c }
            }
        }
    }
}

struct Resident {
    pano: Pano,
    last_used: u64,
}

pub struct App {
    pub nav: Navigator,
    gpu: Gpu,
    panorama: PanoramaPass,
    overlay: OverlayPass,
    panos: HashMap<u32, Resident>,
    /// Probes a load failed for (a cross-fade to them does not wait).
    failed: HashSet<u32>,
    requested: HashSet<(u32, u32)>,
    /// The current probe's sharper level, tile by tile, and the tiles asked
    /// for (probe, size, slot, x, y).
    tiled: HashMap<u32, Tiled>,
    tile_requests: HashSet<(u32, u32, usize, u32, u32)>,
    /// Bytes of panorama textures kept at most (current and target excepted).
    budget: u64,
    /// The largest cube face used by choice (memory), and the largest the device takes.
    max_face: u32,
    device_face: u32,
    width: f32,
    height: f32,
    scale: f32,
    show_map: bool,
    touring: bool,
    dwell_s: f32,
    came_by: Option<u32>,
    pointers: Vec<(u64, f32, f32)>,
    press: Option<(f32, f32, bool)>,
    message_s: f32,
    thumbs: u32,
    thumbs_requested: bool,
    frame: u64,
    last_state: State,
    video_failed: bool,
    /// Set once a sharp-enough or low-resolution panorama has been drawn.
    pub shown_panorama: bool,
    layout: ui::Layout,
    pub mode: Mode,
    dollhouse: DollhousePass,
    /// The finest proxy level decoded so far.
    pub proxy: Option<ProxyMesh>,
    /// Levels asked for (coarsest first), and whether one failed.
    proxy_requested: usize,
    proxy_failed: bool,
    /// The vertex-split stream failed: its level comes whole instead.
    stream_failed: bool,
    /// Parts of a level decoded while the others are on their way.
    proxy_parts: Vec<(usize, usize, MeshData, Vec<u32>)>,
    orbit: Option<Orbit>,
    flight: Option<Flight>,
    /// Seconds left of the panorama fading in over the proxy after a flight.
    fade_in_s: f32,
    /// The deep link changed outside input handling (a flight ended).
    link_dirty: bool,
    floors: Floors,
    floor: Option<usize>,
    /// The floor plan's wall outlines, for (proxy triangles, section height).
    sections: Option<(SectionKey, Segments)>,
    /// Per probe, whether the proxy hides it from the dollhouse camera; the
    /// next probe to test.
    hidden: Vec<bool>,
    marker_cursor: usize,
    /// What `hidden` was last tested for, and how many tests since.
    hidden_key: Option<(Camera, f32, usize)>,
    hidden_tested: usize,
    /// Point-to-go depth maps of probes, and those asked for.
    depth_maps: HashMap<u32, DepthMap>,
    depth_requested: HashSet<u32>,
    /// Glides: the pass, probes' depth meshes, and the probes asked for.
    glide: GlidePass,
    /// In a headset: its targets, what points at them, the veil.
    headset: Option<Headset>,
    glide_meshes: HashMap<u32, GlideMesh>,
    glide_requested: HashSet<u32>,
    /// The sources of the last frame's glide, if it was one.
    glided: Option<(u32, u32)>,
    /// The travel's speed before it was paused.
    resume_speed: f32,
}

/// Options a platform chooses.
pub struct Options {
    pub budget_bytes: u64,
    pub max_face: u32,
    pub show_map: bool,
    pub tour: bool,
}

impl App {
    pub fn new(gpu: Gpu, mut nav: Navigator, link: Option<&Link>, options: Options, platform: &mut dyn Platform) -> App {
        if let Some(link) = link {
            link.apply_view(&mut nav);
        }
        let probes = nav.graph().probes.len() as u32;
        let panorama = PanoramaPass::new(&gpu.device, gpu.format);
        let overlay = OverlayPass::new(&gpu.device, gpu.format, probes);
        let device_face = gpu.device.limits().max_texture_dimension_2d;
        let last_state = nav.state;
        let dollhouse = DollhousePass::new(&gpu.device, gpu.format);
        let glide = GlidePass::new(&gpu.device, gpu.format);
        let floors = Floors::of(nav.graph());
        let mut app = App {
            nav,
            gpu,
            panorama,
            overlay,
            panos: HashMap::new(),
            failed: HashSet::new(),
            requested: HashSet::new(),
            tiled: HashMap::new(),
            tile_requests: HashSet::new(),
            budget: options.budget_bytes,
            max_face: options.max_face.min(device_face),
            device_face,
            width: 1.0,
            height: 1.0,
            scale: 1.0,
            show_map: options.show_map,
            touring: options.tour,
            dwell_s: 0.0,
            came_by: None,
            pointers: Vec::new(),
            press: None,
            message_s: 0.0,
            thumbs: 0,
            thumbs_requested: false,
            frame: 0,
            last_state,
            video_failed: false,
            shown_panorama: false,
            layout: ui::Layout::default(),
            mode: Mode::Panorama,
            dollhouse,
            proxy: None,
            proxy_requested: 0,
            proxy_failed: false,
            stream_failed: false,
            proxy_parts: Vec::new(),
            orbit: None,
            flight: None,
            fade_in_s: 0.0,
            link_dirty: false,
            floors,
            floor: None,
            sections: None,
            hidden: Vec::new(),
            marker_cursor: 0,
            hidden_key: None,
            hidden_tested: 0,
            depth_maps: HashMap::new(),
            depth_requested: HashSet::new(),
            glide,
            headset: None,
            glide_meshes: HashMap::new(),
            glide_requested: HashSet::new(),
            glided: None,
            resume_speed: 1.0,
        };
        if link.is_some_and(|l| l.dollhouse) {
            app.toggle_dollhouse(platform);
        }
        app.request_assets(platform);
        app
    }

    /// The deep link to where the viewer is.
    fn link(&self) -> Link {
        Link { dollhouse: self.mode == Mode::Dollhouse, ..Link::of(&self.nav) }
    }

    /// Whether a tap on the panorama can go somewhere: this probe's depth map is in.
    pub fn point_to_go_ready(&self) -> bool {
        self.depth_maps.contains_key(&self.nav.probe())
    }

    /// Whether the last frame drawn was a glide (a path without video, drawn
    /// from its ends' panoramas and depth).
    pub fn gliding(&self) -> bool {
        self.glided.is_some()
    }

    /// The leg the last frame glided along: its two sources (probes, or
    /// panoramas part way: [`Navigator::waypoint`]).
    pub fn glide_leg(&self) -> Option<(u32, u32)> {
        self.glided
    }

    /// Whether a flight over the dollhouse is under way.
    pub fn flying(&self) -> bool {
        self.flight.is_some()
    }

    /// True until there is something to draw (the first panorama, or in
    /// the dollhouse the first proxy level): platforms skip drawing frames
    /// until then, leaving the CPU or GPU to the loading.
    pub fn waiting_for_first_frame(&self) -> bool {
        match self.mode {
            Mode::Dollhouse => self.proxy.is_none() && !self.proxy_failed,
            Mode::Panorama => !self.panorama_ready(),
        }
    }

    /// Whether the current probe's panorama has been shown, is here, or failed.
    fn panorama_ready(&self) -> bool {
        let p = self.nav.probe();
        self.shown_panorama || self.panos.contains_key(&p) || self.failed.contains(&p)
    }

    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    pub fn resize(&mut self, width: u32, height: u32, scale: f32) {
        self.width = width.max(1) as f32;
        self.height = height.max(1) as f32;
        self.scale = if scale.is_finite() && scale > 0.0 { scale } else { 1.0 };
    }

    /// In a headset the head looks: `rotation` from looking down −Z, with
    /// the eyes' vertical field of view and pixels choosing tiles and levels
    /// as a window of that size would.
    pub fn look(&mut self, rotation: glam::Quat, fov_y: f32, (width, height): (u32, u32)) {
        let forward = rotation * glam::Vec3::NEG_Z;
        (self.nav.view.yaw, self.nav.view.pitch) = crate::navigation::yaw_pitch(forward.into());
        self.nav.view.fov_y = fov_y;
        self.resize(width, height, 1.0);
    }

    /// Cube sizes of a probe usable here, smallest first: those within
    /// `max_face`, else the smallest the device can take (better a large
    /// texture than no panorama).
    fn levels(&self, probe: u32) -> Vec<u32> {
        let mut sizes: Vec<u32> =
            self.nav.graph().probes[probe as usize].assets.cube_levels.iter().map(|l| l.size).filter(|&s| s <= self.device_face).collect();
        sizes.sort_unstable();
        let fitting = sizes.iter().take_while(|&&s| s <= self.max_face).count();
        sizes.truncate(fitting.max(1));
        sizes
    }

    /// Asks for a probe's panorama at `size` (a cube level), unless it or a
    /// sharper one is here or on its way.
    fn request(&mut self, probe: u32, size: u32, platform: &mut dyn Platform) {
        let have = self.panos.get(&probe).is_some_and(|l| l.pano.size() >= size);
        if have || !self.requested.insert((probe, size)) {
            return;
        }
        let assets = &self.nav.graph().probes[probe as usize].assets;
        if let Some(level) = assets.cube_levels.iter().find(|l| l.size == size) {
            return platform.load_cube(probe, size, &level.faces);
        }
        if let Some(e) = &assets.equirect {
            return platform.load_equirect(probe, e);
        }
        let why = match assets.cube_levels.iter().map(|l| l.size).min() {
            Some(smallest) => format!("its smallest cube face ({smallest} px) is over this device's limit ({} px)", self.device_face),
            None => "the bundle has no panorama for it (run exploremaps render on the bundle)".to_string(),
        };
        self.failed.insert(probe);
        self.message(&format!("probe {probe} cannot be shown: {why}"), platform);
    }

    /// The current probe's tiles the view needs, nearest its centre first,
    /// from the level the screen wants, once the probe's whole lowest level
    /// is in and when the bundle has a tile pyramid sharper than it. The
    /// level stays within the memory budget: its cube at most 3/5 of it.
    fn request_tiles(&mut self, platform: &mut dyn Platform) {
        if self.mode == Mode::Dollhouse || !matches!(self.nav.state, State::AtProbe { .. }) {
            return;
        }
        let p = self.nav.probe();
        let Some(base) = self.panos.get(&p).map(|l| l.pano.size()) else { return };
        let Some(tiles) = self.nav.graph().probes[p as usize].assets.tiles.clone() else { return };
        let fits = |s: u32| s <= self.max_face && 24 * u64::from(s) * u64::from(s) <= self.budget / 5 * 3;
        let sizes: Vec<u32> = (1..=tiles.levels).map(|l| tiles.level_size(l)).filter(|&s| fits(s)).collect();
        let wanted = self.wanted_face();
        let Some(&size) = sizes.iter().find(|&&s| s as f32 >= wanted).or(sizes.last()) else { return };
        if size <= base {
            return;
        }
        if self.tiled.get(&p).is_none_or(|t| t.cube.size < size) {
            self.tiled.insert(p, Tiled::new(&self.gpu.device, size, tiles.tile));
            self.tile_requests.retain(|r| r.0 != p);
        }
        let t = &self.tiled[&p];
        let Some(level) = (1..=tiles.levels).find(|&l| tiles.level_size(l) == t.cube.size) else { return };
        for (slot, x, y) in visible_tiles(&self.nav.view, self.width / self.height, t.cube.size, t.tile) {
            if !t.has(slot, x, y) && self.tile_requests.insert((p, t.cube.size, slot, x, y)) {
                platform.load_tile(p, t.cube.size, slot, x, y, &tiles.file(level, TILE_SLOTS[slot], x, y));
            }
        }
    }

    /// Tiles asked for and tiles in, for the benchmark and tests.
    pub fn tile_counts(&self) -> (usize, usize) {
        (self.tile_requests.len(), self.tiled.values().map(Tiled::count).sum())
    }

    /// The face size that shows a pixel per screen pixel at the current zoom.
    fn wanted_face(&self) -> f32 {
        self.height / (2.0 * (0.5 * self.nav.view.fov_y).tan())
    }

    /// Current probe: the smallest level first, then the sharpest needed; the
    /// target of a move; the neighbours' smallest levels (prefetch).
    fn request_assets(&mut self, platform: &mut dyn Platform) {
        // In the dollhouse, its proxy comes first: panoramas wait until its finest level is in.
        self.request_proxy(platform);
        if self.mode == Mode::Dollhouse && self.flight.is_none() && !self.proxy_failed && self.proxy.as_ref().is_none_or(|m| m.level > 0) {
            return;
        }
        let mut sharp = vec![self.nav.probe()];
        sharp.extend(self.flight.and_then(|f| f.arrive).map(|a| a.0));
        match self.nav.state {
            State::CrossFading { to, .. } => sharp.push(to),
            State::Travelling { .. } => sharp.extend(self.nav.destination().into_iter().chain(self.nav.stops_ahead())),
            State::AtProbe { .. } => {}
        }
        let wanted = self.wanted_face();
        for &p in &sharp {
            let levels = self.levels(p);
            // With a tile pyramid, sharper levels come as the view's tiles.
            let tiled = self.nav.graph().probes[p as usize].assets.tiles.is_some();
            match (levels.first(), levels.iter().find(|&&s| s as f32 >= wanted).or(levels.last())) {
                (Some(&low), Some(&high)) => {
                    self.request(p, low, platform);
                    if self.panos.contains_key(&p) && !tiled {
                        self.request(p, high, platform);
                    }
                }
                _ => self.request(p, 0, platform),
            }
        }
        self.request_tiles(platform);
        self.request_glides(&sharp, platform);
        // Thumbnails and neighbours once the first panorama is in, so they do not delay it.
        // (In the dollhouse, once its proxy is whole: it shows the probe bar too.)
        let proxy_whole = self.mode == Mode::Dollhouse && self.proxy.as_ref().is_some_and(|m| m.level == 0);
        if !self.thumbs_requested && (self.panorama_ready() || proxy_whole) {
            self.thumbs_requested = true;
            for p in &self.nav.graph().probes {
                if let Some(t) = &p.assets.thumbnail {
                    platform.load_thumbnail(p.id, t);
                }
            }
        }
        if matches!(self.nav.state, State::AtProbe { .. }) && self.panos.contains_key(&self.nav.probe()) {
            let p = self.nav.probe();
            let file = self.nav.graph().proxy.as_ref().and_then(|x| x.depth_maps.get(p as usize)).cloned();
            if let Some(file) = file.filter(|_| self.depth_requested.insert(p)) {
                platform.load_depth_map(p, &file, self.nav.graph().probes.len() as u32);
            }
            for c in self.nav.path_bar() {
                let low = self.levels(c.to).first().copied().unwrap_or(0);
                self.request(c.to, low, platform);
            }
        }
    }

    /// Depth for glides: of the probes shown sharp, and at a probe, of the
    /// path bar's destinations (so a glide can start at once); the
    /// panoramas part way along the path travelled, and at a probe the first
    /// along each path of the bar.
    fn request_glides(&mut self, sharp: &[u32], platform: &mut dyn Platform) {
        let mut wanted = sharp.to_vec();
        let mut waypoints = self.nav.glide_sources().map(|(s, _)| s.iter().map(|w| w.0).collect::<Vec<_>>()).unwrap_or_default();
        for &(path, reversed) in self.nav.route_ahead() {
            waypoints.extend(self.nav.sources_along(path, reversed).iter().map(|w| w.0).filter(|&w| self.nav.waypoint(w).is_some()));
        }
        if matches!(self.nav.state, State::AtProbe { .. }) {
            for c in self.nav.path_bar() {
                wanted.push(c.to);
                waypoints.extend(self.nav.sources_along(c.path, c.reversed).get(1).map(|w| w.0));
            }
        }
        for p in wanted {
            let file = self.nav.graph().probes[p as usize].assets.depth.clone();
            if let Some(file) = file.filter(|_| self.glide_requested.insert(p)) {
                platform.load_depth_cube(p, &file);
            }
        }
        for source in waypoints {
            let Some(w) = self.nav.waypoint(source).cloned() else { continue };
            if !self.panos.contains_key(&source) && self.requested.insert((source, w.cube.size)) {
                platform.load_cube(source, w.cube.size, &w.cube.faces);
            }
            if self.glide_requested.insert(source) {
                platform.load_depth_cube(source, &w.depth);
            }
        }
    }

    /// The proxy, coarsest level first, each once the one before it is in:
    /// after the first panorama, or at once when the dollhouse is asked for.
    fn request_proxy(&mut self, platform: &mut dyn Platform) {
        let Some(proxy) = &self.nav.graph().proxy else { return };
        let levels = proxy.levels.len();
        let wanted = self.mode == Mode::Dollhouse || self.panorama_ready();
        let ready = self.proxy.as_ref().map_or(levels, |m| m.level);
        // Level i is asked for once every coarser one has arrived (or failed).
        let next = levels - self.proxy_requested;
        if !wanted || self.proxy_requested == levels || (self.proxy_requested > 0 && ready > next && !self.proxy_failed) {
            return;
        }
        self.proxy_requested += 1;
        let probes = self.nav.graph().probes.len() as u32;
        // A level the stream refines from the one just in comes as vertex splits.
        if let Some(stream) = proxy.stream.as_ref().filter(|s| s.to + 1 == next && s.from == next && !self.stream_failed) {
            return platform.load_stream(stream, &proxy.levels[stream.from], probes);
        }
        let parts = proxy.levels[next - 1].parts();
        for (part, chunk) in parts.iter().enumerate() {
            platform.load_proxy(next - 1, part, &chunk.file, chunk.seen.as_deref(), probes);
        }
    }

    /// Takes in a decoded part of a proxy level; once the level's parts are
    /// all in, it replaces a coarser level in the dollhouse.
    fn proxy_part(&mut self, level: usize, part: usize, mesh: MeshData, seen: Vec<u32>) {
        let Some(parts) = self.nav.graph().proxy.as_ref().and_then(|p| p.levels.get(level)).map(|l| l.part_count()) else { return };
        if self.proxy.as_ref().is_some_and(|m| m.level <= level) {
            return;
        }
        self.proxy_parts.push((level, part, mesh, seen));
        if self.proxy_parts.iter().filter(|p| p.0 == level).count() < parts {
            return;
        }
        let (mut all, rest): (Vec<_>, Vec<_>) = std::mem::take(&mut self.proxy_parts).into_iter().partition(|p| p.0 == level);
        self.proxy_parts = rest;
        all.sort_by_key(|p| p.1);
        self.show_proxy(ProxyMesh::from_parts(level, all.into_iter().map(|(_, _, m, s)| (m, s)).collect()));
    }

    /// Takes in the proxy as the vertex splits so far made it, unless a
    /// finer one is shown already.
    fn proxy_refined(&mut self, level: usize, mesh: MeshData, seen: Vec<u32>) {
        if self.proxy.as_ref().is_some_and(|m| m.level < level || (m.level == level && m.triangles.len() >= mesh.triangles.len())) {
            return;
        }
        self.show_proxy(ProxyMesh::new(level, mesh, seen));
    }

    fn show_proxy(&mut self, mesh: ProxyMesh) {
        self.dollhouse.upload(&self.gpu.device, &self.gpu.queue, &mesh);
        if self.orbit.is_none() {
            self.orbit = Some(self.framing(&mesh));
        }
        self.sections = None;
        self.proxy = Some(mesh);
    }

    fn evict(&mut self, keep: &[u32]) {
        // Tiles of probes left behind go first.
        self.tiled.retain(|p, _| keep.contains(p));
        self.tile_requests.retain(|r| keep.contains(&r.0));
        loop {
            let total: u64 = self.panos.values().map(|l| l.pano.bytes()).chain(self.tiled.values().map(Tiled::bytes)).sum();
            if total <= self.budget {
                return;
            }
            let victim = self.panos.iter().filter(|(p, _)| !keep.contains(p)).min_by_key(|(_, l)| l.last_used).map(|(&p, _)| p);
            let Some(victim) = victim else { return };
            self.panos.remove(&victim);
            self.requested.retain(|&(p, _)| p != victim);
        }
    }

    fn message(&mut self, text: &str, platform: &mut dyn Platform) {
        self.message_s = MESSAGE_S;
        platform.show_message(text);
    }

    /// Advances time by `dt_s` seconds: takes in loads, moves, tours.
    pub fn update(&mut self, dt_s: f32, platform: &mut dyn Platform) {
        self.frame += 1;
        for loaded in platform.poll(&self.gpu, &self.overlay) {
            match loaded {
                Loaded::Pano { probe, pano } => {
                    if self.panos.get(&probe).is_none_or(|l| l.pano.size() < pano.size()) {
                        self.panos.insert(probe, Resident { pano, last_used: self.frame });
                    }
                }
                Loaded::Tile { probe, size, slot, x, y, pixels } => {
                    let gpu = self.gpu.clone();
                    if let Some(t) = self.tiled.get_mut(&probe).filter(|t| t.cube.size == size) {
                        if let Err(e) = t.put(&gpu, slot, x, y, pixels) {
                            self.message(&format!("a tile of probe {probe} ({} {x},{y} at {size}): {e}", TILE_SLOTS[slot]), platform);
                        }
                    }
                }
                Loaded::Thumbnail { .. } => self.thumbs += 1,
                Loaded::Proxy { level, part, mesh, seen } => self.proxy_part(level, part, mesh, seen),
                Loaded::Refined { level, mesh, seen } => self.proxy_refined(level, mesh, seen),
                Loaded::DepthMap { probe, map } => {
                    self.depth_maps.insert(probe, map);
                }
                Loaded::DepthCube { probe, cube } => {
                    if let Some(position) = self.nav.source_position(probe) {
                        self.glide_meshes.insert(probe, GlideMesh::new(&self.gpu.device, &cube, position));
                    }
                }
                Loaded::Failed { what, error, probe } => {
                    self.failed.extend(probe);
                    if what.starts_with("proxy/splits") && !self.stream_failed {
                        // The level the splits refine to comes whole instead.
                        self.stream_failed = true;
                        self.proxy_requested -= 1;
                        self.message(&format!("{what}: {error} (loading the 3D overview whole instead)"), platform);
                    } else if what.starts_with("proxy/") {
                        self.proxy_failed = true;
                        if self.proxy.is_none() && self.mode == Mode::Dollhouse {
                            self.leave_dollhouse_at_once();
                        }
                        self.message(&format!("the 3D overview cannot be shown: {what}: {error}"), platform);
                    } else {
                        self.message(&format!("{what}: {error}"), platform);
                    }
                }
            }
        }
        self.message_s = (self.message_s - dt_s).max(0.0);
        self.fly(dt_s);
        if std::mem::take(&mut self.link_dirty) {
            platform.link_changed(&self.link());
        }

        // A cross-fade waits for its target; a travel plays on regardless.
        let waiting = matches!(self.nav.state, State::CrossFading { to, .. } if !self.panos.contains_key(&to) && !self.failed.contains(&to));
        self.nav.update(if waiting { 0.0 } else { dt_s });

        let state = self.nav.state;
        let next_leg = |s: State| match s {
            State::Travelling { path, reversed, .. } => Some((path, reversed)),
            _ => None,
        };
        if std::mem::discriminant(&state) != std::mem::discriminant(&self.last_state) || next_leg(state) != next_leg(self.last_state) {
            match state {
                State::Travelling { path, reversed, .. } => {
                    if matches!(self.last_state, State::Travelling { .. }) {
                        platform.stop_video();
                    }
                    self.came_by = Some(path);
                    self.video_failed = false;
                    match &self.nav.graph().paths[path as usize].assets.video {
                        Some(v) => platform.play_video(&v.clone(), reversed),
                        None => self.video_failed = true,
                    }
                }
                State::AtProbe { .. } => {
                    platform.stop_video();
                    self.dwell_s = 0.0;
                    platform.link_changed(&self.link());
                }
                State::CrossFading { .. } => self.came_by = None,
            }
            self.last_state = state;
        }
        if self.touring && matches!(state, State::AtProbe { .. }) {
            self.dwell_s += dt_s;
            if self.dwell_s >= TOUR_DWELL_S && self.panos.contains_key(&self.nav.probe()) {
                self.nav.random_walk_step(self.came_by);
            }
        }
        self.request_assets(platform);
        let mut keep = vec![self.nav.probe()];
        keep.extend(self.nav.destination());
        keep.extend(self.nav.stops_ahead());
        keep.extend(self.nav.glide_sources().into_iter().flat_map(|(s, _)| s.into_iter().map(|w| w.0)));
        for p in &keep {
            if let Some(l) = self.panos.get_mut(p) {
                l.last_used = self.frame;
            }
        }
        self.evict(&keep);
    }

    /// Advances a flight; at its end arrives at the probe (the panorama then
    /// fades in over the proxy) or settles in the dollhouse.
    fn fly(&mut self, dt_s: f32) {
        self.fade_in_s = (self.fade_in_s - dt_s).max(0.0);
        let Some(flight) = &mut self.flight else { return };
        flight.elapsed_s += dt_s.max(0.0);
        if flight.t() < 1.0 {
            return;
        }
        if let Some((probe, yaw, pitch)) = flight.arrive {
            // Landing waits for the probe's panorama (or its failure), as a cross-fade does.
            if !self.panos.contains_key(&probe) && !self.failed.contains(&probe) {
                return;
            }
            log_refusal(self.nav.arrive(probe, yaw, pitch));
            self.mode = Mode::Panorama;
            self.fade_in_s = FADE_S;
        }
        self.flight = None;
        self.link_dirty = true;
    }

    /// Goes to a probe from the panorama, facing `point` on arrival if given
    /// (else the probe's preferred direction): along a path when one joins
    /// them, else along a route of paths if it takes at most
    /// [`MAX_ROUTE_S`], else flying over the dollhouse when the proxy is
    /// here, else along any route, else by a cross-fade.
    fn go_to(&mut self, probe: u32, point: Option<Vec3>) {
        let Some(p) = self.nav.graph().probes.get(probe as usize) else { return };
        if !matches!(self.nav.state, State::AtProbe { .. }) || probe == self.nav.probe() {
            return;
        }
        let target = Vec3::from(p.position);
        let facing = point.map(|q| facing(target, q));
        let walk = self.nav.route(probe).is_some_and(|r| r.legs.len() == 1 || r.duration_s / r.pace() <= MAX_ROUTE_S);
        if walk || self.proxy.is_none() {
            log_refusal(match facing {
                Some(f) => self.nav.go_to_facing(probe, f),
                None => self.nav.go_to(probe),
            });
            return;
        }
        let (yaw, pitch) = facing.or_else(|| p.preferred_directions.first().map(|d| (d.yaw, d.pitch))).unwrap_or((self.nav.view.yaw, 0.0));
        let from = self.panorama_camera();
        let to = Camera { eye: target, forward: Vec3::from(direction(yaw, pitch)), fov_y: self.nav.view.fov_y };
        // Over the middle, high enough to see both ends, looking toward the destination.
        let span = from.eye.distance(target);
        let rise = (0.6 * span).max(3.0 * self.floors.eye).max(0.05 * self.proxy.as_ref().map_or(1.0, |m| m.diagonal()));
        let ahead = Vec3::new(target.x - from.eye.x, 0.0, target.z - from.eye.z);
        let forward = (ahead.normalize_or_zero() - Vec3::Y).try_normalize().unwrap_or(Vec3::NEG_Y);
        // The arc's control point twice as high: the camera peaks at `rise`.
        let via = Camera { eye: (from.eye + target) / 2.0 + Vec3::Y * (2.0 * rise), forward, fov_y: from.fov_y.max(1.0) };
        self.floor = self.floors.of_point(from.eye.y);
        self.flight = Some(Flight { via: Some(via), duration_s: OVER_S, ..Flight::new(from, to, Some((probe, yaw, pitch)), true) });
    }

    /// A tap on the panorama: the point it shows (the probe's depth map) and
    /// the probe that sees that point best; goes there facing it. False when
    /// there is no map, nothing there, or the best view is this probe's.
    fn point_to_go(&mut self, x: f32, y: f32) -> bool {
        let here = self.nav.probe();
        let Some(map) = self.depth_maps.get(&here).filter(|_| matches!(self.nav.state, State::AtProbe { .. })) else { return false };
        let d = crate::panorama::unproject(&self.nav.view, x, y, self.width, self.height);
        let Some((distance, best)) = map.look(d) else { return false };
        if best == NONE || best == here || best as usize >= self.nav.graph().probes.len() {
            return false;
        }
        let point = Vec3::from(self.nav.graph().probes[here as usize].position) + Vec3::from(d) * distance;
        self.go_to(best, Some(point));
        true
    }

    /// A tap on the floor plan: the proxy point seen from above there (below
    /// the plan's cut), and the probe that sees it best.
    fn plan_to_go(&mut self, x: f32, y: f32) {
        let (Some(frame), Some(mesh)) = (self.layout.map, &self.proxy) else { return };
        let [wx, wz] = frame.to_world(x, y);
        let cut = self.plan_cut();
        let top = Vec3::new(wx, cut.min(mesh.hi.y) + 1e-3 * mesh.diagonal(), wz);
        let Some((triangle, t)) = mesh.pick(top, Vec3::NEG_Y, cut) else { return };
        let point = top + Vec3::NEG_Y * t;
        if let Some(probe) = mesh.destination(self.nav.graph(), triangle, point) {
            self.go_to(probe, Some(point));
        }
    }

    /// The camera the panorama view is seen from.
    fn panorama_camera(&self) -> Camera {
        Camera {
            eye: Vec3::from(self.nav.camera_position()),
            forward: Vec3::from(direction(self.nav.view.yaw, self.nav.view.pitch)),
            fov_y: self.nav.view.fov_y,
        }
    }

    /// Into the dollhouse, rising out of the probe; or, from it, down into
    /// the current probe.
    fn toggle_dollhouse(&mut self, platform: &mut dyn Platform) {
        if self.mode == Mode::Dollhouse {
            let p = self.nav.probe();
            return self.fly_to(p, None);
        }
        if self.nav.graph().proxy.is_none() {
            return self.message("this bundle has no 3D overview; run exploremaps render on it to make one", platform);
        }
        if self.proxy_failed && self.proxy.is_none() {
            return self.message("the 3D overview of this bundle cannot be read (see the message before)", platform);
        }
        self.mode = Mode::Dollhouse;
        self.touring = false;
        self.link_dirty = true;
        self.floor = self.floors.of_point(self.nav.camera_position()[1]);
        self.request_proxy(platform);
        if let Some(mesh) = &self.proxy {
            let orbit = self.framing(mesh);
            self.flight = Some(Flight::new(self.panorama_camera(), orbit.camera(), None, true));
            self.orbit = Some(orbit);
        }
    }

    /// The orbit showing the whole proxy below the cut, facing the way the
    /// visitor looks.
    fn framing(&self, mesh: &ProxyMesh) -> Orbit {
        let hi = Vec3::new(mesh.hi.x, mesh.hi.y.min(self.cut()).max(mesh.lo.y), mesh.hi.z);
        Orbit { radius: 0.5 * mesh.diagonal().max(1e-3), ..Orbit::framing(mesh.lo, hi, self.nav.view.yaw, self.width / self.height) }
    }

    fn leave_dollhouse_at_once(&mut self) {
        self.mode = Mode::Panorama;
        self.flight = None;
    }

    /// Flies from the dollhouse down into `probe`, facing `toward` (a point),
    /// else the probe's preferred direction, else the current yaw.
    fn fly_to(&mut self, probe: u32, toward: Option<Vec3>) {
        let Some(p) = self.nav.graph().probes.get(probe as usize) else { return };
        let eye = Vec3::from(p.position);
        let (yaw, pitch) = match (toward, p.preferred_directions.first()) {
            (Some(t), _) => facing(eye, t),
            (None, Some(d)) if probe != self.nav.probe() => (d.yaw, d.pitch),
            _ => (self.nav.view.yaw, self.nav.view.pitch),
        };
        let to = Camera { eye, forward: Vec3::from(direction(yaw, pitch)), fov_y: self.nav.view.fov_y };
        let from = match (&self.flight, &self.orbit) {
            (Some(f), _) => f.camera(),
            (None, Some(o)) => o.camera(),
            (None, None) => to,
        };
        let mut flight = Flight::new(from, to, Some((probe, yaw, pitch)), false);
        if self.proxy.is_none() {
            flight.elapsed_s = flight.duration_s;
        }
        self.flight = Some(flight);
    }

    /// The height above which the dollhouse hides the scene.
    fn cut(&self) -> f32 {
        self.floors.cut(self.floor)
    }

    /// The floor plan's cut: the current storey's, or where no storeys are
    /// known (probes that fly), the camera's height.
    fn plan_cut(&self) -> f32 {
        let y = self.nav.camera_position()[1];
        match self.floors.of_point(y) {
            Some(k) => self.floors.cut(Some(k)),
            None => y,
        }
    }

    /// The plan's wall outlines: the proxy's section at 0.75 eye heights
    /// above the current storey's floor (1.2 m, under door heads), or at the
    /// camera where no storeys are known. Kept until the level or height changes.
    fn plan_sections(&mut self) -> Segments {
        let Some(mesh) = &self.proxy else { return std::rc::Rc::new([]) };
        let y = self.nav.camera_position()[1];
        let height = match self.floors.of_point(y) {
            Some(k) => self.floors.heights[k] + 0.75 * self.floors.eye,
            None => y,
        };
        let key = (mesh.triangles.len(), height);
        match &self.sections {
            Some((k, s)) if *k == key => s.clone(),
            _ => {
                let s: Segments = mesh.section(height).into();
                self.sections = Some((key, s.clone()));
                s
            }
        }
    }

    /// Pointer input as a gesture: one finger (or the mouse) drags or taps,
    /// two pinch (and pan by their midpoint); the release of a drag or pinch.
    fn gesture(&mut self, input: Input) -> Option<Gesture> {
        match input {
            Input::PointerDown { id, x, y } => {
                self.pointers.retain(|p| p.0 != id);
                self.pointers.push((id, x, y));
                self.press = (self.pointers.len() == 1).then_some((x, y, false));
                None
            }
            Input::PointerMove { id, x, y } => {
                let i = self.pointers.iter().position(|p| p.0 == id)?;
                let (_, ox, oy) = self.pointers[i];
                let gesture = if self.pointers.len() >= 2 {
                    let other = self.pointers[1 - i.min(1)];
                    let before = ((ox - other.1).powi(2) + (oy - other.2).powi(2)).sqrt();
                    let after = ((x - other.1).powi(2) + (y - other.2).powi(2)).sqrt();
                    self.press = None;
                    // The midpoint moves half as far as this finger.
                    Gesture::Pinch { spread: if before > 1.0 && after > 1.0 { before / after } else { 1.0 }, pan: ((x - ox) / 2.0, (y - oy) / 2.0) }
                } else {
                    let slop = TAP_SLOP * self.scale;
                    if let Some((px, py, moved)) = &mut self.press {
                        *moved |= (x - *px).abs() + (y - *py).abs() > slop;
                    }
                    Gesture::Drag(x - ox, y - oy)
                };
                self.pointers[i] = (id, x, y);
                Some(gesture)
            }
            Input::PointerUp { id, x, y } => {
                self.pointers.retain(|p| p.0 != id);
                Some(if let Some((_, _, false)) = self.press.take() { Gesture::Tap(x, y) } else { Gesture::Release })
            }
            _ => None,
        }
    }

    /// Input while the dollhouse is shown: drags orbit, two fingers pinch
    /// and pan, taps on a probe or on the proxy fly there.
    fn dollhouse_input(&mut self, input: Input, platform: &mut dyn Platform) {
        let height = self.height;
        if self.orbit.is_none() {
            if let Input::Key(Key::Dollhouse) = input {
                self.leave_dollhouse_at_once();
            }
            return;
        }
        match input {
            Input::PointerDown { .. } | Input::PointerMove { .. } | Input::PointerUp { .. } => match self.gesture(input) {
                Some(Gesture::Drag(dx, dy)) => self.orbit.iter_mut().for_each(|o| o.turn(-dx * 4.0 / height, dy * 2.0 / height)),
                Some(Gesture::Pinch { spread, pan }) => {
                    if let Some(o) = &mut self.orbit {
                        o.zoom(spread);
                        o.pan(pan.0, pan.1, height);
                    }
                }
                Some(Gesture::Tap(x, y)) => self.dollhouse_tap(x, y, platform),
                Some(Gesture::Release) | None => {}
            },
            Input::Wheel(steps) => self.orbit.iter_mut().for_each(|o| o.zoom(0.9f32.powf(steps))),
            Input::Key(key) => match key {
                Key::Left | Key::Right | Key::Up | Key::Down | Key::ZoomIn | Key::ZoomOut => {
                    if let Some(o) = &mut self.orbit {
                        match key {
                            Key::Left => o.turn(-KEY_TURN, 0.0),
                            Key::Right => o.turn(KEY_TURN, 0.0),
                            Key::Up => o.turn(0.0, KEY_TURN),
                            Key::Down => o.turn(0.0, -KEY_TURN),
                            Key::ZoomIn => o.zoom(0.9),
                            _ => o.zoom(1.0 / 0.9),
                        }
                    }
                }
                Key::Dollhouse | Key::Go => self.toggle_dollhouse(platform),
                Key::Floor => self.next_floor(),
                Key::Map => self.show_map = !self.show_map,
                Key::NextProbe | Key::PreviousProbe | Key::Tour => {}
            },
        }
    }

    fn next_floor(&mut self) {
        let n = self.floors.heights.len();
        self.floor = match self.floor {
            _ if n == 0 => None,
            None => Some(0),
            Some(f) if f + 1 < n => Some(f + 1),
            Some(_) => None,
        };
    }

    /// A tap over the dollhouse: the interface, else the proxy point under
    /// the finger, whose best probe the camera flies down to, facing it.
    fn dollhouse_tap(&mut self, x: f32, y: f32, platform: &mut dyn Platform) {
        match self.layout.hit(x, y) {
            Some(Action::GoTo(p)) => return self.fly_to(p, None),
            Some(Action::ToggleDollhouse) => return self.toggle_dollhouse(platform),
            Some(Action::NextFloor) => return self.next_floor(),
            Some(Action::ToggleMap) => {
                self.show_map = !self.show_map;
                return;
            }
            Some(Action::ToggleTour | Action::TakePath(_) | Action::PlanPoint | Action::Back | Action::Pause | Action::On) => return,
            None => {}
        }
        let (Some(mesh), Some(orbit)) = (&self.proxy, &self.orbit) else { return };
        let camera = orbit.camera();
        let dir = camera.ray(x, y, self.width, self.height);
        let Some((triangle, t)) = mesh.pick(camera.eye, dir, self.cut()) else { return };
        let point = camera.eye + dir * t;
        if let Some(probe) = mesh.destination(self.nav.graph(), triangle, point) {
            self.fly_to(probe, Some(point));
        }
    }

    pub fn input(&mut self, input: Input, platform: &mut dyn Platform) {
        if self.flight.is_some() {
            // A flight ends as it started; input waits for it.
            return;
        }
        if self.mode == Mode::Dollhouse {
            return self.dollhouse_input(input, platform);
        }
        match input {
            Input::PointerDown { .. } | Input::PointerMove { .. } | Input::PointerUp { .. } => match self.gesture(input) {
                // Drag: the scene follows the finger.
                Some(Gesture::Drag(dx, dy)) => {
                    let per_px = self.nav.view.fov_y / self.height;
                    self.nav.look(-dx * per_px, dy * per_px);
                }
                // Pinch: the field of view follows the change of finger spread.
                Some(Gesture::Pinch { spread, .. }) => self.nav.zoom(spread),
                Some(Gesture::Tap(x, y)) => self.tap(x, y, platform),
                Some(Gesture::Release) => platform.link_changed(&self.link()),
                None => {}
            },
            Input::Wheel(steps) => self.nav.zoom(0.9f32.powf(steps)),
            Input::Key(key) => {
                if self.steering(key) {
                    return;
                }
                match key {
                    Key::Left => self.nav.look(-KEY_TURN, 0.0),
                    Key::Right => self.nav.look(KEY_TURN, 0.0),
                    Key::Up => self.nav.look(0.0, KEY_TURN),
                    Key::Down => self.nav.look(0.0, -KEY_TURN),
                    Key::ZoomIn => self.nav.zoom(0.9),
                    Key::ZoomOut => self.nav.zoom(1.0 / 0.9),
                    Key::Go => {
                        if let Some(best) = self.nav.path_bar().first() {
                            log_refusal(self.nav.take_path(best.path));
                        }
                    }
                    Key::NextProbe | Key::PreviousProbe => {
                        let g = self.nav.graph();
                        let order: Vec<u32> = if g.bar_order.is_empty() { (0..g.probes.len() as u32).collect() } else { g.bar_order.clone() };
                        let at = order.iter().position(|&p| p == self.nav.probe()).unwrap_or(0);
                        let step = if key == Key::NextProbe { 1 } else { order.len() - 1 };
                        self.go_to(order[(at + step) % order.len()], None);
                    }
                    Key::Map => self.show_map = !self.show_map,
                    Key::Tour => self.touring = !self.touring,
                    Key::Dollhouse => self.toggle_dollhouse(platform),
                    Key::Floor => {}
                }
                platform.link_changed(&self.link());
            }
        }
    }

    /// A tap: on the interface it acts; on the view it takes the path whose
    /// marker is nearest, or the best-aligned one if it is within 45°.
    /// Along a path drawn as a glide (no video keeps its own clock), the
    /// keys steer the travel: Enter or Space pauses and resumes, down goes
    /// back (again: faster), up goes on (again: faster, up to 4×). Whether
    /// `key` did.
    fn steering(&mut self, key: Key) -> bool {
        if !(matches!(self.nav.state, State::Travelling { .. }) && self.video_failed) {
            return false;
        }
        let speed = self.nav.speed;
        self.nav.speed = match key {
            Key::Go if speed == 0.0 => self.resume_speed,
            Key::Go => {
                self.resume_speed = speed;
                0.0
            }
            Key::Up if speed > 0.0 => (2.0 * speed).min(4.0),
            Key::Up => 1.0,
            Key::Down if speed < 0.0 => (2.0 * speed).max(-4.0),
            Key::Down => -1.0,
            _ => return false,
        };
        true
    }

    fn tap(&mut self, x: f32, y: f32, platform: &mut dyn Platform) {
        let result = match self.layout.hit(x, y) {
            Some(Action::GoTo(p)) => {
                self.go_to(p, None);
                Ok(())
            }
            Some(Action::TakePath(p)) => self.nav.take_path(p),
            Some(Action::ToggleMap) => {
                self.show_map = !self.show_map;
                Ok(())
            }
            Some(Action::ToggleTour) => {
                self.touring = !self.touring;
                Ok(())
            }
            Some(Action::ToggleDollhouse) => {
                self.toggle_dollhouse(platform);
                Ok(())
            }
            Some(Action::NextFloor) => Ok(()),
            Some(action @ (Action::Back | Action::Pause | Action::On)) => {
                let key = match action {
                    Action::Back => Key::Down,
                    Action::On => Key::Up,
                    _ => Key::Go,
                };
                self.steering(key);
                Ok(())
            }
            Some(Action::PlanPoint) => {
                self.plan_to_go(x, y);
                Ok(())
            }
            None if self.point_to_go(x, y) => Ok(()),
            None => match self.nav.path_bar().first() {
                Some(best) if best.angle < std::f32::consts::FRAC_PI_4 => self.nav.take_path(best.path),
                _ => Ok(()),
            },
        };
        log_refusal(result);
    }

    /// Which probes the proxy hides from the dollhouse camera, a few a frame
    /// in turn ([`MARKER_TESTS`]), so a frame's cost does not grow with the
    /// probes; while the camera moves the answers lag by a few frames.
    fn update_hidden(&mut self, camera: &Camera, cut: f32) {
        let Some(mesh) = &self.proxy else { return };
        let probes = &self.nav.graph().probes;
        // Nothing to redo while the camera, the cut and the mesh stay as they were.
        let key = (*camera, cut, mesh.triangles.len());
        if self.hidden_key != Some(key) {
            (self.hidden_key, self.hidden_tested) = (Some(key), 0);
        }
        if self.hidden_tested >= probes.len() {
            return;
        }
        self.hidden_tested += MARKER_TESTS;
        self.hidden.resize(probes.len(), false);
        let slack = 1e-3 * mesh.diagonal();
        for _ in 0..MARKER_TESTS.min(probes.len()) {
            let i = self.marker_cursor % probes.len();
            self.marker_cursor = i + 1;
            let d = Vec3::from(probes[i].position) - camera.eye;
            let dist = d.length();
            self.hidden[i] = dist > slack && mesh.pick(camera.eye, d / dist, cut).is_some_and(|(_, t)| t < dist - slack);
        }
    }

    /// While the finest proxy level is not yet on screen (and has not
    /// failed): the fraction of its triangles that are.
    fn proxy_loading(&self) -> Option<f32> {
        let finest = self.nav.graph().proxy.as_ref()?.levels.first()?.triangles.max(1) as f32;
        let shown = self.proxy.as_ref().map_or(Some(0), |m| (m.level > 0).then_some(m.triangles.len()))?;
        (!self.proxy_failed).then(|| (shown as f32 / finest).min(1.0))
    }

    /// The interface shapes for the current frame (also kept for taps).
    fn shapes(&mut self, camera: Option<&Camera>) -> Vec<Shape> {
        let cut = self.cut();
        // Over the dollhouse and during flights (markers only when still).
        let dollhouse_shown = self.mode == Mode::Dollhouse || self.flight.is_some();
        if let (Some(c), true, None) = (camera, dollhouse_shown, self.flight) {
            self.update_hidden(c, cut);
        }
        let dollhouse = camera.filter(|_| dollhouse_shown).map(|c| DollhouseScreen {
            markers: match self.flight {
                Some(_) => Vec::new(),
                None => self
                    .nav
                    .graph()
                    .probes
                    .iter()
                    .filter(|p| p.position[1] - 0.5 * self.floors.eye <= cut)
                    .filter_map(|p| {
                        Some((
                            p.id,
                            c.project(Vec3::from(p.position), self.width, self.height)?,
                            self.hidden.get(p.id as usize).copied().unwrap_or(false),
                        ))
                    })
                    .collect(),
            },
            floors: self.floors.heights.len(),
            floor: self.floor,
            loading: self.proxy_loading(),
        });
        let screen = Screen {
            width: self.width,
            height: self.height,
            scale: self.scale,
            show_map: self.show_map,
            touring: self.touring,
            thumbs_ready: self.thumbs > 0,
            message: self.message_s > 0.0,
            proxy: self.nav.graph().proxy.is_some(),
            plan: self.proxy.as_ref().filter(|_| camera.is_none()).map(|m| [m.lo.x, m.lo.z, m.hi.x, m.hi.z]),
            sections: if camera.is_none() && self.show_map { self.plan_sections() } else { std::rc::Rc::new([]) },
            steering: (matches!(self.nav.state, State::Travelling { .. }) && self.video_failed).then_some(self.nav.speed),
            dollhouse,
        };
        self.layout = ui::layout(&self.nav, &screen);
        self.layout.shapes.clone()
    }

    /// The camera over the proxy when it is drawn: in the dollhouse, during
    /// a flight, and while a panorama fades in over it.
    fn dollhouse_camera(&self) -> Option<Camera> {
        if let Some(f) = &self.flight {
            return Some(f.camera());
        }
        match self.mode {
            Mode::Dollhouse => Some(self.orbit.map_or_else(|| self.panorama_camera(), |o| o.camera())),
            Mode::Panorama if self.fade_in_s > 0.0 => Some(self.panorama_camera()),
            Mode::Panorama => None,
        }
    }

    /// How much of the panorama shows over the proxy: fading out as a flight
    /// rises, in after one lands.
    fn panorama_opacity(&self) -> f32 {
        match (&self.flight, self.mode) {
            (Some(f), _) if f.fade_out => 1.0 - f.elapsed_s / FADE_S,
            (Some(_), _) | (None, Mode::Dollhouse) => 0.0,
            (None, Mode::Panorama) => 1.0 - self.fade_in_s / FADE_S,
        }
    }

    /// Draws a frame into `target` (the size given to `resize`).
    pub fn render(&mut self, target: &wgpu::TextureView, platform: &mut dyn Platform) -> wgpu::CommandBuffer {
        let camera = self.dollhouse_camera();
        let opacity = self.panorama_opacity();
        let shapes = self.shapes(camera.as_ref());
        let gpu = self.gpu.clone();
        let progress = self.nav.progress().unwrap_or(0.0);
        let travelling = matches!(self.nav.state, State::Travelling { .. }) && !self.video_failed;
        let (video, video_error) = match travelling.then(|| platform.video_frame(&gpu, progress)) {
            Some(Ok(v)) => (v, None),
            Some(Err(e)) => (None, Some(e)),
            None => (None, None),
        };
        let source = Self::panorama_source(&self.nav, (&self.panos, &self.tiled), video);
        let glide = self.glide_ends(video.is_some()).filter(|_| camera.is_none() && opacity >= 1.0);
        self.glided = glide;
        self.shown_panorama |= source.is_some() && opacity > 0.0;
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        if let Some(c) = &camera {
            let (centre, extent) = self.proxy.as_ref().map_or((c.eye, 1.0), |m| ((m.lo + m.hi) / 2.0, m.diagonal().max(1e-3)));
            let mut frame = self.frame_target(&gpu, &mut encoder, target);
            self.dollhouse.draw(&mut frame, c, self.cut(), centre, extent);
        }
        {
            let load = if camera.is_some() { wgpu::LoadOp::Load } else { wgpu::LoadOp::Clear(wgpu::Color { r: 0.02, g: 0.02, b: 0.025, a: 1.0 }) };
            let mut pass = colour_pass(&mut encoder, target, load, "frame");
            if let Some(source) = source.filter(|_| opacity > 0.0 && glide.is_none()) {
                self.panorama.draw(
                    &gpu.device,
                    &gpu.queue,
                    &mut pass,
                    &Lens::of_view(&self.nav.view, self.width / self.height),
                    Shown { source, opacity },
                );
            }
        }
        if let Some(ends) = glide {
            let lens = Lens::of_view(&self.nav.view, self.width / self.height);
            let mut frame = self.frame_target(&gpu, &mut encoder, target);
            self.fill_behind_glide(&mut frame, &lens, [0.0, 0.0, self.width, self.height]);
            self.draw_glide(&mut frame, ends, lens, [0.0, 0.0]);
        }
        if let (Some(frame), Some(mesh), None) = (self.layout.map, &self.proxy, &camera) {
            let rect = [frame.x0, frame.y0, frame.size];
            let mut target = self.frame_target(&gpu, &mut encoder, target);
            self.dollhouse.draw_plan(&mut target, rect, frame.centre, frame.scale, self.plan_cut(), mesh.lo.y);
        }
        {
            let mut pass = colour_pass(&mut encoder, target, wgpu::LoadOp::Load, "interface");
            self.overlay.draw(&gpu.device, &gpu.queue, &mut pass, &shapes, self.width, self.height);
        }
        if let Some(e) = video_error {
            self.video_failed = true;
            self.message(&format!("the path's video cannot be played ({e}); showing the panoramas instead"), platform);
        }
        encoder.finish()
    }

    /// What the panorama pass shows: the video's frame while travelling with
    /// one, the cross-fade's two cubes, else the nearer probe's panorama.
    /// (Of the fields it reads, so the caller may change others meanwhile.)
    fn panorama_source<'a>(
        nav: &Navigator,
        (panos, tiled): (&'a HashMap<u32, Resident>, &'a HashMap<u32, Tiled>),
        video: Option<&'a VideoTexture>,
    ) -> Option<Source<'a>> {
        let progress = nav.progress().unwrap_or(0.0);
        let source_of = |p: u32| panos.get(&p).map(|l| l.pano.source(tiled.get(&p)));
        let here = source_of(nav.probe());
        match (nav.state, video) {
            (State::Travelling { .. }, Some(v)) => Some(Source::Video(v)),
            (State::CrossFading { from, to, .. }, _) => match (source_of(from), source_of(to)) {
                (Some(Source::Cube(a, ta)), Some(Source::Cube(b, tb))) => Some(Source::Fade((a, ta), (b, tb), ease(progress))),
                (_, Some(b)) if progress >= 0.5 => Some(b),
                (a, _) => a,
            },
            (State::Travelling { .. }, None) => {
                let there = nav.destination().and_then(source_of);
                if progress >= 0.5 {
                    there.or(here)
                } else {
                    here
                }
            }
            (State::AtProbe { .. }, _) => here,
        }
    }

    /// Draws a headset's frame into `target`: in each eye's viewport the
    /// panorama (or the glide along a path without video), the targets and
    /// the pointer, and while moving the veil. One submission an eye, since
    /// the passes rewrite their uniforms for each draw.
    pub fn render_eyes(&mut self, target: &wgpu::TextureView, eyes: &[Eye], platform: &mut dyn Platform) {
        let gpu = self.gpu.clone();
        let travelling = matches!(self.nav.state, State::Travelling { .. }) && !self.video_failed;
        let progress = self.nav.progress().unwrap_or(0.0);
        let video = match travelling.then(|| platform.video_frame(&gpu, progress)) {
            Some(Ok(v)) => v,
            _ => None,
        };
        let glide = self.glide_ends(video.is_some());
        self.glided = glide;
        let headset = self.headset.get_or_insert_with(|| Headset::new(&gpu.device, gpu.format));
        // The veil comes in over the first and goes over the last tenth of a move.
        let moving = self.nav.progress().map_or(0.0, |p| (10.0 * p.min(1.0 - p)).clamp(0.0, 1.0));
        headset.veil.set(&gpu.queue, 0.85 * moving);
        // The eyes' viewports tile the layer's framebuffer.
        let (width, height) =
            eyes.iter().fold((0.0f32, 0.0f32), |(a, b), e| (a.max(e.viewport[0] + e.viewport[2]), b.max(e.viewport[1] + e.viewport[3])));
        for (i, eye) in eyes.iter().enumerate() {
            let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("eye") });
            let [x, y, w, h] = eye.viewport;
            {
                let clear = wgpu::LoadOp::Clear(wgpu::Color { r: 0.02, g: 0.02, b: 0.025, a: 1.0 });
                let mut pass = colour_pass(&mut encoder, target, if i == 0 { clear } else { wgpu::LoadOp::Load }, "eye");
                pass.set_viewport(x, y, w, h, 0.0, 1.0);
                let source = Self::panorama_source(&self.nav, (&self.panos, &self.tiled), video).filter(|_| glide.is_none());
                if let Some(source) = source {
                    self.panorama.draw(&gpu.device, &gpu.queue, &mut pass, &eye.lens, Shown { source, opacity: 1.0 });
                    self.shown_panorama = true;
                }
            }
            if let Some(ends) = glide {
                let mut frame = FrameTarget {
                    device: &gpu.device,
                    queue: &gpu.queue,
                    encoder: &mut encoder,
                    view: target,
                    width: width as u32,
                    height: height as u32,
                };
                self.fill_behind_glide(&mut frame, &eye.lens, eye.viewport);
                let mut frame = FrameTarget { width: w as u32, height: h as u32, ..frame };
                self.draw_glide(&mut frame, ends, eye.lens, [x, y]);
            }
            {
                let mut pass = colour_pass(&mut encoder, target, wgpu::LoadOp::Load, "eye interface");
                pass.set_viewport(x, y, w, h, 0.0, 1.0);
                let headset = self.headset.as_ref().expect("made above");
                if moving > 0.0 {
                    headset.veil.draw(&mut pass);
                }
                let shapes = crate::headset::eye_shapes(&headset.targets, headset.pointed, headset.gaze.progress(), headset.ray, eye);
                self.overlay.draw(&gpu.device, &gpu.queue, &mut pass, &shapes, w, h);
            }
            gpu.queue.submit([encoder.finish()]);
        }
    }

    /// In a headset, what points: a controller's ray (`controller`, world
    /// directions), else the gaze (`head`), which picks a target by resting
    /// on it. The targets are found again at each probe (and as the proxy,
    /// which hides the probes behind walls, sharpens). Each frame, after [`App::look`].
    pub fn point(&mut self, controller: Option<Vec3>, head: Vec3, dt_s: f32) {
        let gpu = self.gpu.clone();
        let headset = self.headset.get_or_insert_with(|| Headset::new(&gpu.device, gpu.format));
        let still = matches!(self.nav.state, State::AtProbe { .. }) && self.flight.is_none();
        let key = still.then(|| (self.nav.probe(), self.proxy.as_ref().map_or(0, |m| m.triangles.len())));
        if key != headset.key {
            let near = NEAR_TARGET_M / self.nav.graph().scene.metres_per_unit;
            let proxy = &self.proxy;
            headset.targets = if still { crate::headset::targets(&self.nav, near, |a, b| hidden_by(proxy.as_ref(), a, b)) } else { Vec::new() };
            (headset.key, headset.gaze) = (key, Gaze::default());
        }
        let ray = controller.unwrap_or(head);
        headset.ray = Some(ray);
        headset.pointed = crate::headset::pointed(&headset.targets, ray);
        let picked = if controller.is_none() { headset.gaze.update(headset.pointed, dt_s) } else { None };
        if let Some(i) = picked {
            self.take_target(i);
        }
    }

    /// A controller's select: goes where it points, if at a target.
    pub fn select(&mut self) {
        if let Some(i) = self.headset.as_ref().and_then(|h| h.pointed) {
            self.take_target(i);
        }
    }

    /// The headset's targets (world directions), for tests and the page's status.
    pub fn targets(&self) -> &[Target] {
        self.headset.as_ref().map_or(&[], |h| &h.targets)
    }

    fn take_target(&mut self, i: usize) {
        let Some(t) = self.headset.as_ref().and_then(|h| h.targets.get(i).copied()) else { return };
        match t.goal {
            Goal::Path(p) => log_refusal(self.nav.take_path(p)),
            Goal::Probe(p) => self.go_to(p, None),
        }
    }

    /// The leg of the path being travelled that a glide draws, when it shows
    /// no video: the sources (probes or panoramas part way) on either side
    /// of the camera whose depth and panoramas (cubes) are in, the nearest
    /// ready on each side (a leg whose end is still loading glides to the
    /// one beyond).
    fn glide_ends(&self, video_shown: bool) -> Option<(u32, u32)> {
        if video_shown {
            return None;
        }
        let (sources, s) = self.nav.glide_sources()?;
        let ready = |p: &&(u32, f32)| self.glide_meshes.contains_key(&p.0) && matches!(self.panos.get(&p.0).map(|l| &l.pano), Some(Pano::Cube(_)));
        let from = sources.iter().filter(|w| w.1 <= s).rfind(ready)?;
        let to = sources.iter().filter(|w| w.1 > s).find(ready).or(sources.last().filter(ready))?;
        (from.0 != to.0).then_some((from.0, to.0))
    }

    /// The proxy's baked colours, where it is in, seen from the camera through
    /// `lens` into `viewport` of `frame`: behind a glide, where neither end saw.
    fn fill_behind_glide(&mut self, frame: &mut FrameTarget, lens: &Lens, viewport: [f32; 4]) {
        if let Some(mesh) = &self.proxy {
            let (centre, extent) = ((mesh.lo + mesh.hi) / 2.0, mesh.diagonal().max(1e-3));
            let eye = Vec3::from(self.nav.camera_position());
            self.dollhouse.draw_through(frame, (eye, lens), viewport, centre, extent);
        }
    }

    /// Draws the glide between two sources (both ready: [`App::glide_ends`])
    /// from where the camera is on the path, blended by its distance to
    /// each, through `lens` into the viewport at `origin` of `frame`.
    fn draw_glide(&mut self, frame: &mut FrameTarget, (from, to): (u32, u32), lens: Lens, origin: [f32; 2]) {
        let end = |p: u32| {
            let Some(Pano::Cube(cube)) = self.panos.get(&p).map(|l| &l.pano) else { return None };
            Some(crate::glide::End { mesh: self.glide_meshes.get(&p)?, cube, tiles: self.tiled.get(&p) })
        };
        let (Some(a), Some(b)) = (end(from), end(to)) else { return };
        let eye = Vec3::from(self.nav.camera_position());
        let t = crate::glide::toward(eye, a.mesh.probe, b.mesh.probe);
        self.glide.draw_in(frame, &crate::glide::GlideFrame { eye, lens, from: a, to: b, t }, origin);
    }

    /// The frame's target, the size of the window.
    fn frame_target<'a>(&self, gpu: &'a Gpu, encoder: &'a mut wgpu::CommandEncoder, view: &'a wgpu::TextureView) -> FrameTarget<'a> {
        FrameTarget { device: &gpu.device, queue: &gpu.queue, encoder, view, width: self.width as u32, height: self.height as u32 }
    }

    /// Whether anything moves or loads, so the platform keeps drawing frames.
    pub fn animating(&self) -> bool {
        let loading_proxy = self.mode == Mode::Dollhouse && self.proxy.is_none() && !self.proxy_failed;
        !matches!(self.nav.state, State::AtProbe { .. })
            || self.touring
            || self.message_s > 0.0
            || !self.panos.contains_key(&self.nav.probe())
            || self.flight.is_some()
            || self.fade_in_s > 0.0
            || loading_proxy
    }
}

#[cfg(test)]
mod tests;

/// A move the navigator refused: a press while on the way is expected and
/// ignored; a path or probe the bundle lacks is a fault, logged.
/// A render pass drawing colour into `target`, nothing else attached.
fn colour_pass<'a>(
    encoder: &'a mut wgpu::CommandEncoder,
    target: &'a wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
    label: &str,
) -> wgpu::RenderPass<'a> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: target,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// Whether the proxy hides `to` from `from` (without a proxy, nothing can be
/// told, and a probe counts as hidden).
fn hidden_by(proxy: Option<&ProxyMesh>, from: Vec3, to: Vec3) -> bool {
    let Some(mesh) = proxy else { return true };
    let d = to - from;
    let dist = d.length();
    let slack = 1e-3 * mesh.diagonal();
    mesh.pick(from, d / dist.max(1e-9), f32::INFINITY).is_some_and(|(_, t)| t < dist - slack)
}

fn log_refusal(result: Result<(), NavError>) {
    let text = match result {
        Ok(()) | Err(NavError::Busy) => return,
        Err(e) => format!("move refused: {e}"),
    };
    #[cfg(not(target_arch = "wasm32"))]
    tracing::warn!("{text}");
    #[cfg(target_arch = "wasm32")]
    web_sys::console::warn_1(&text.into());
}

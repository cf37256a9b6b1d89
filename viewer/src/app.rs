//! The viewer application, the same natively and in the browser: it turns
//! input into navigation, asks its platform for the panoramas, thumbnails
//! and videos it needs (low resolution first, neighbours prefetched, a
//! memory budget for textures) and draws a frame. Platforms (`native`,
//! `web`) own the window, files and decoding.

use crate::navigation::{Navigator, State};
use crate::overlay::{OverlayPass, Shape};
use crate::panorama::{Cube, PanoramaPass, Source, VideoTexture};
use crate::ui::{self, Action, Link, Screen};
use std::collections::{HashMap, HashSet};

/// The device, its queue and the colour format frames are drawn in.
#[derive(Clone)]
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub format: wgpu::TextureFormat,
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

    fn source(&self) -> Source<'_> {
        match self {
            Pano::Cube(c) => Source::Cube(c),
            Pano::Equirect(t) => Source::Video(t),
        }
    }
}

/// What a platform hands back from loading.
pub enum Loaded {
    Pano { probe: u32, pano: Pano },
    /// The thumbnail is in the overlay's layer `probe`.
    Thumbnail { probe: u32 },
    /// `what` names the asset (its file), `error` what went wrong.
    Failed { what: String, error: String, probe: Option<u32> },
}

/// Loading and playback, done by the platform (files and threads natively,
/// fetch and the browser's decoders on the web). Requests are answered later
/// through `poll`.
pub trait Platform {
    fn load_cube(&mut self, probe: u32, size: u32, faces: &[String; 6]);
    fn load_equirect(&mut self, probe: u32, file: &str);
    fn load_thumbnail(&mut self, probe: u32, file: &str);
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
    PointerDown { id: u64, x: f32, y: f32 },
    PointerMove { id: u64, x: f32, y: f32 },
    PointerUp { id: u64, x: f32, y: f32 },
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
}

/// Seconds the tour stays at a probe before moving on.
const TOUR_DWELL_S: f32 = 2.0;
/// A press that moves less than this many logical pixels is a tap.
const TAP_SLOP: f32 = 8.0;
const MESSAGE_S: f32 = 6.0;
const KEY_TURN: f32 = 0.08;

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
        let mut app = App {
            nav,
            gpu,
            panorama,
            overlay,
            panos: HashMap::new(),
            failed: HashSet::new(),
            requested: HashSet::new(),
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
        };
        app.request_assets(platform);
        app
    }

    /// True until the first panorama can be drawn: platforms skip drawing
    /// frames until then, leaving the CPU or GPU to the loading.
    pub fn waiting_for_first_panorama(&self) -> bool {
        let p = self.nav.probe();
        !self.shown_panorama && !self.panos.contains_key(&p) && !self.failed.contains(&p)
    }

    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    pub fn resize(&mut self, width: u32, height: u32, scale: f32) {
        self.width = width.max(1) as f32;
        self.height = height.max(1) as f32;
        self.scale = if scale.is_finite() && scale > 0.0 { scale } else { 1.0 };
    }

    /// Cube sizes of a probe usable here, smallest first: those within
    /// `max_face`, else the smallest the device can take (better a large
    /// texture than no panorama).
    fn levels(&self, probe: u32) -> Vec<u32> {
        let mut sizes: Vec<u32> = self.nav.graph().probes[probe as usize].assets.cube_levels.iter().map(|l| l.size).filter(|&s| s <= self.device_face).collect();
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

    /// The face size that shows a pixel per screen pixel at the current zoom.
    fn wanted_face(&self) -> f32 {
        self.height / (2.0 * (0.5 * self.nav.view.fov_y).tan())
    }

    /// Current probe: the smallest level first, then the sharpest needed; the
    /// target of a move; the neighbours' smallest levels (prefetch).
    fn request_assets(&mut self, platform: &mut dyn Platform) {
        let mut sharp = vec![self.nav.probe()];
        match self.nav.state {
            State::CrossFading { to, .. } => sharp.push(to),
            State::Travelling { .. } => sharp.extend(self.nav.destination()),
            State::AtProbe { .. } => {}
        }
        let wanted = self.wanted_face();
        for &p in &sharp {
            let levels = self.levels(p);
            match (levels.first(), levels.iter().find(|&&s| s as f32 >= wanted).or(levels.last())) {
                (Some(&low), Some(&high)) => {
                    self.request(p, low, platform);
                    if self.panos.contains_key(&p) {
                        self.request(p, high, platform);
                    }
                }
                _ => self.request(p, 0, platform),
            }
        }
        // Thumbnails and neighbours once the first panorama is in, so they do not delay it.
        if !self.thumbs_requested && !self.waiting_for_first_panorama() {
            self.thumbs_requested = true;
            for p in &self.nav.graph().probes {
                if let Some(t) = &p.assets.thumbnail {
                    platform.load_thumbnail(p.id, t);
                }
            }
        }
        if matches!(self.nav.state, State::AtProbe { .. }) && self.panos.contains_key(&self.nav.probe()) {
            for c in self.nav.path_bar() {
                let low = self.levels(c.to).first().copied().unwrap_or(0);
                self.request(c.to, low, platform);
            }
        }
    }

    fn evict(&mut self, keep: &[u32]) {
        loop {
            let total: u64 = self.panos.values().map(|l| l.pano.bytes()).sum();
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
                Loaded::Thumbnail { .. } => self.thumbs += 1,
                Loaded::Failed { what, error, probe } => {
                    self.failed.extend(probe);
                    self.message(&format!("{what}: {error}"), platform);
                }
            }
        }
        self.message_s = (self.message_s - dt_s).max(0.0);

        // A cross-fade waits for its target; a travel plays on regardless.
        let waiting = matches!(self.nav.state, State::CrossFading { to, .. } if !self.panos.contains_key(&to) && !self.failed.contains(&to));
        self.nav.update(if waiting { 0.0 } else { dt_s });

        let state = self.nav.state;
        if std::mem::discriminant(&state) != std::mem::discriminant(&self.last_state) {
            match state {
                State::Travelling { path, reversed, .. } => {
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
                    platform.link_changed(&Link::of(&self.nav));
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
        for p in &keep {
            if let Some(l) = self.panos.get_mut(p) {
                l.last_used = self.frame;
            }
        }
        self.evict(&keep);
    }

    pub fn input(&mut self, input: Input, platform: &mut dyn Platform) {
        let k = self.scale;
        match input {
            Input::PointerDown { id, x, y } => {
                self.pointers.retain(|p| p.0 != id);
                self.pointers.push((id, x, y));
                self.press = (self.pointers.len() == 1).then_some((x, y, false));
            }
            Input::PointerMove { id, x, y } => {
                let Some(i) = self.pointers.iter().position(|p| p.0 == id) else { return };
                let (_, ox, oy) = self.pointers[i];
                if self.pointers.len() >= 2 {
                    // Pinch: the field of view follows the change of finger spread.
                    let other = self.pointers[1 - i.min(1)];
                    let before = ((ox - other.1).powi(2) + (oy - other.2).powi(2)).sqrt();
                    let after = ((x - other.1).powi(2) + (y - other.2).powi(2)).sqrt();
                    if before > 1.0 && after > 1.0 {
                        self.nav.zoom(before / after);
                    }
                    self.press = None;
                } else {
                    // Drag: the scene follows the finger.
                    let per_px = self.nav.view.fov_y / self.height;
                    self.nav.look(-(x - ox) * per_px, (y - oy) * per_px);
                    if let Some((px, py, moved)) = &mut self.press {
                        *moved |= (x - *px).abs() + (y - *py).abs() > TAP_SLOP * k;
                    }
                }
                self.pointers[i] = (id, x, y);
            }
            Input::PointerUp { id, x, y } => {
                self.pointers.retain(|p| p.0 != id);
                if let Some((_, _, false)) = self.press.take() {
                    self.tap(x, y, platform);
                } else {
                    platform.link_changed(&Link::of(&self.nav));
                }
            }
            Input::Wheel(steps) => self.nav.zoom(0.9f32.powf(steps)),
            Input::Key(key) => {
                match key {
                    Key::Left => self.nav.look(-KEY_TURN, 0.0),
                    Key::Right => self.nav.look(KEY_TURN, 0.0),
                    Key::Up => self.nav.look(0.0, KEY_TURN),
                    Key::Down => self.nav.look(0.0, -KEY_TURN),
                    Key::ZoomIn => self.nav.zoom(0.9),
                    Key::ZoomOut => self.nav.zoom(1.0 / 0.9),
                    Key::Go => {
                        if let Some(best) = self.nav.path_bar().first() {
                            let _ = self.nav.take_path(best.path);
                        }
                    }
                    Key::NextProbe | Key::PreviousProbe => {
                        let g = self.nav.graph();
                        let order: Vec<u32> = if g.bar_order.is_empty() { (0..g.probes.len() as u32).collect() } else { g.bar_order.clone() };
                        let at = order.iter().position(|&p| p == self.nav.probe()).unwrap_or(0);
                        let step = if key == Key::NextProbe { 1 } else { order.len() - 1 };
                        let _ = self.nav.go_to(order[(at + step) % order.len()]);
                    }
                    Key::Map => self.show_map = !self.show_map,
                    Key::Tour => self.touring = !self.touring,
                }
                platform.link_changed(&Link::of(&self.nav));
            }
        }
    }

    /// A tap: on the interface it acts; on the view it takes the path whose
    /// marker is nearest, or the best-aligned one if it is within 45°.
    fn tap(&mut self, x: f32, y: f32, _platform: &mut dyn Platform) {
        let _ = match self.layout.hit(x, y) {
            Some(Action::GoTo(p)) => self.nav.go_to(p),
            Some(Action::TakePath(p)) => self.nav.take_path(p),
            Some(Action::ToggleMap) => {
                self.show_map = !self.show_map;
                Ok(())
            }
            Some(Action::ToggleTour) => {
                self.touring = !self.touring;
                Ok(())
            }
            None => match self.nav.path_bar().first() {
                Some(best) if best.angle < std::f32::consts::FRAC_PI_4 => self.nav.take_path(best.path),
                _ => Ok(()),
            },
        };
    }

    /// The interface shapes for the current frame (also kept for taps).
    fn shapes(&mut self) -> Vec<Shape> {
        let screen = Screen {
            width: self.width,
            height: self.height,
            scale: self.scale,
            show_map: self.show_map,
            touring: self.touring,
            thumbs_ready: self.thumbs > 0,
            message: self.message_s > 0.0,
        };
        self.layout = ui::layout(&self.nav, &screen);
        self.layout.shapes.clone()
    }

    /// Draws a frame into `target` (the size given to `resize`).
    pub fn render(&mut self, target: &wgpu::TextureView, platform: &mut dyn Platform) -> wgpu::CommandBuffer {
        let shapes = self.shapes();
        let gpu = self.gpu.clone();
        let progress = self.nav.progress().unwrap_or(0.0);
        let travelling = matches!(self.nav.state, State::Travelling { .. }) && !self.video_failed;
        let (video, video_error) = match travelling.then(|| platform.video_frame(&gpu, progress)) {
            Some(Ok(v)) => (v, None),
            Some(Err(e)) => (None, Some(e)),
            None => (None, None),
        };
        let here = self.panos.get(&self.nav.probe()).map(|l| &l.pano);
        let source = match (self.nav.state, video) {
            (State::Travelling { .. }, Some(v)) => Some(Source::Video(v)),
            (State::CrossFading { from, to, .. }, _) => match (self.panos.get(&from).map(|l| &l.pano), self.panos.get(&to).map(|l| &l.pano)) {
                (Some(Pano::Cube(a)), Some(Pano::Cube(b))) => Some(Source::Fade(a, b, crate::navigation::smoothstep(progress))),
                (_, Some(b)) if progress >= 0.5 => Some(b.source()),
                (a, _) => a.map(Pano::source),
            },
            (State::Travelling { .. }, None) => {
                let there = self.nav.destination().and_then(|p| self.panos.get(&p)).map(|l| &l.pano);
                if progress >= 0.5 { there.or(here) } else { here }.map(Pano::source)
            }
            (State::AtProbe { .. }, _) => here.map(Pano::source),
        };
        self.shown_panorama |= source.is_some();
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("frame"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color { r: 0.02, g: 0.02, b: 0.025, a: 1.0 }), store: wgpu::StoreOp::Store },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if let Some(source) = source {
                self.panorama.draw(&gpu.device, &gpu.queue, &mut pass, &self.nav.view, self.width / self.height, source);
            }
            self.overlay.draw(&gpu.device, &gpu.queue, &mut pass, &shapes, self.width, self.height);
        }
        if let Some(e) = video_error {
            self.video_failed = true;
            self.message(&format!("the path's video cannot be played ({e}); showing the panoramas instead"), platform);
        }
        encoder.finish()
    }

    /// Whether anything moves or loads, so the platform keeps drawing frames.
    pub fn animating(&self) -> bool {
        !matches!(self.nav.state, State::AtProbe { .. }) || self.touring || self.message_s > 0.0 || !self.panos.contains_key(&self.nav.probe())
    }
}

#[cfg(test)]
mod tests;

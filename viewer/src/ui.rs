//! The interface as pure layout: from the navigator and the window size, the
//! shapes to draw and the places a tap acts on. No GPU, so it is unit-tested.
//!
//! Bottom: the probe bar (every thumbnail in bar order, the current one
//! framed, scrolled to keep it in view). Above it: the path bar (the probes
//! the current one leads to, left to right by the direction the path leaves
//! in, the best aligned in the middle, framed). In the view: a marker where
//! each path leaves. Top right: the overhead map. Top left: the tour, map
//! and dollhouse buttons. Over the dollhouse: a marker per probe, the floor
//! button, no path bar or map.

use crate::navigation::{direction, Navigator, PathChoice, State, View};
use crate::overlay::{Shape, MAX_THUMBS};
use crate::panorama::project;
use exploremaps_format::Graph;
use std::f32::consts::PI;

/// What a tap on a part of the interface does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Action {
    GoTo(u32),
    TakePath(u32),
    ToggleMap,
    ToggleTour,
    ToggleDollhouse,
    NextFloor,
    /// A point of the floor plan (not a probe's dot): go where it is seen best.
    PlanPoint,
    /// Steering a glide: back (again: faster), pause or resume, on (again: faster).
    Back,
    Pause,
    On,
}

/// A tappable region: a rectangle, or a disc when `round`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub x: f32,
    pub y: f32,
    pub w: f32,
    pub h: f32,
    pub round: bool,
    pub action: Action,
}

impl Hit {
    fn contains(&self, px: f32, py: f32) -> bool {
        if self.round {
            let (cx, cy, r) = (self.x + self.w / 2.0, self.y + self.h / 2.0, self.w / 2.0);
            (px - cx).powi(2) + (py - cy).powi(2) <= r * r
        } else {
            px >= self.x && px <= self.x + self.w && py >= self.y && py <= self.y + self.h
        }
    }
}

/// Shapes in drawing order and tappable regions, last drawn on top.
#[derive(Default, Debug)]
pub struct Layout {
    pub shapes: Vec<Shape>,
    pub hits: Vec<Hit>,
    /// The overhead map's frame, when it is shown.
    pub map: Option<MapFrame>,
}

impl Layout {
    /// The action at a point: the topmost region holding it.
    pub fn hit(&self, x: f32, y: f32) -> Option<Action> {
        self.hits.iter().rev().find(|h| h.contains(x, y)).map(|h| h.action)
    }

    /// A thumbnail tile at `[x, y, w, h]`, framed in `frame` if given.
    fn tile(&mut self, [x, y, w, h]: [f32; 4], probe: u32, frame: Option<[f32; 4]>, thumbs_ready: bool, action: Action) {
        if let Some(c) = frame {
            let b = (h * 0.06).max(2.0);
            self.shapes.push(Shape::rect(x - b, y - b, w + 2.0 * b, h + 2.0 * b, c));
        }
        if thumbs_ready && probe < MAX_THUMBS {
            self.shapes.push(Shape::thumbnail(x, y, w, h, probe));
        } else {
            self.shapes.push(Shape::rect(x, y, w, h, [0.25, 0.25, 0.28, 0.9]));
        }
        self.hits.push(Hit { x, y, w, h, round: false, action });
    }
}

pub const HIGHLIGHT: [f32; 4] = [1.0, 0.78, 0.2, 1.0];
const WHITE: [f32; 4] = [1.0, 1.0, 1.0, 0.9];
const PANEL: [f32; 4] = [0.05, 0.05, 0.07, 0.6];

/// What the layout depends on besides the navigator.
pub struct Screen {
    pub width: f32,
    pub height: f32,
    /// Physical pixels per logical pixel.
    pub scale: f32,
    pub show_map: bool,
    pub touring: bool,
    /// Whether thumbnails have arrived (else plain tiles).
    pub thumbs_ready: bool,
    pub message: bool,
    /// The bundle has a proxy (the dollhouse button shows).
    pub proxy: bool,
    /// Set while the dollhouse is shown.
    pub dollhouse: Option<DollhouseScreen>,
    /// The floor plan's extent (x and z, low then high), when the proxy is
    /// here to be drawn under the map.
    pub plan: Option<[f32; 4]>,
    /// The plan's wall outlines: segments (x, z, x, z) where the proxy
    /// crosses the section height.
    pub sections: std::rc::Rc<[[f32; 4]]>,
    /// While a glide can be steered: its speed (0 paused, negative back).
    pub steering: Option<f32>,
}

/// Where the overhead map is and how it shows the world: a top view, +X to
/// the right and −Z up (yaw 0 points up the map).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapFrame {
    /// The map's square: left, top, side (pixels).
    pub x0: f32,
    pub y0: f32,
    pub size: f32,
    /// The world point (x, z) at its centre, and pixels a scene unit.
    pub centre: [f32; 2],
    pub scale: f32,
}

impl MapFrame {
    pub fn to_map(&self, p: [f32; 3]) -> [f32; 2] {
        [self.x0 + self.size / 2.0 + (p[0] - self.centre[0]) * self.scale, self.y0 + self.size / 2.0 + (p[2] - self.centre[1]) * self.scale]
    }

    /// The world (x, z) under a point of the map.
    pub fn to_world(&self, x: f32, y: f32) -> [f32; 2] {
        [self.centre[0] + (x - self.x0 - self.size / 2.0) / self.scale, self.centre[1] + (y - self.y0 - self.size / 2.0) / self.scale]
    }
}

/// The map's frame: the probes and paths (and the floor plan) fitted in the
/// top-right square; None when there is nothing to show.
pub fn map_frame(graph: &Graph, s: &Screen) -> Option<MapFrame> {
    let k = s.scale;
    let size = (s.width.min(s.height) * 0.32).clamp(110.0 * k, 280.0 * k);
    let margin = 8.0 * k;
    let points = graph.probes.iter().map(|p| p.position).chain(graph.paths.iter().flat_map(|p| p.polyline.iter().copied()));
    let plan = s.plan.iter().flat_map(|b| [[b[0], 0.0, b[1]], [b[2], 0.0, b[3]]]);
    let (mut lo, mut hi) = ([f32::MAX; 2], [f32::MIN; 2]);
    for p in points.chain(plan) {
        lo = [lo[0].min(p[0]), lo[1].min(p[2])];
        hi = [hi[0].max(p[0]), hi[1].max(p[2])];
    }
    if lo[0] > hi[0] {
        return None;
    }
    let inner = size - if s.plan.is_some() { 2.0 } else { 4.0 } * margin;
    let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-6);
    Some(MapFrame { x0: s.width - size - margin, y0: margin, size, centre: [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0], scale: inner / span })
}

/// What the interface shows over the dollhouse.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DollhouseScreen {
    /// Probes in view: id, pixel, and whether the proxy hides it.
    pub markers: Vec<(u32, [f32; 2], bool)>,
    /// Storeys, and the one shown (None: the whole scene, uncut).
    pub floors: usize,
    pub floor: Option<usize>,
    /// While the proxy is still coming: how much of its finest level is on
    /// screen (0 to 1), drawn as a thin bar along the top.
    pub loading: Option<f32>,
}

/// Signed yaw of the path's departure relative to the view, (−π, π].
fn relative_yaw(view: &View, departure: (f32, f32)) -> f32 {
    let d = departure.0 - view.yaw;
    (d + PI).rem_euclid(2.0 * PI) - PI
}

pub fn layout(nav: &Navigator, s: &Screen) -> Layout {
    let mut out = Layout::default();
    let at_probe = matches!(nav.state, State::AtProbe { .. });
    // The paths that leave from here, the best aligned first (not over the dollhouse).
    let choices = if at_probe && s.dollhouse.is_none() { nav.path_bar() } else { Vec::new() };
    departure_markers(&mut out, nav, s, &choices);
    if let Some(f) = s.dollhouse.as_ref().and_then(|d| d.loading) {
        // The proxy still refining: a bar along the top.
        let bar = 4.0 * s.scale;
        out.shapes.push(Shape::rect(0.0, 0.0, s.width, bar, PANEL));
        out.shapes.push(Shape::rect(0.0, 0.0, s.width * f.clamp(0.0, 1.0), bar, HIGHLIGHT));
    }
    dollhouse_markers(&mut out, nav.probe(), s);
    let bar = probe_bar(&mut out, nav, s);
    path_bar(&mut out, nav, s, &choices, bar);
    if let Some(speed) = s.steering {
        steering(&mut out, s, speed, bar.0);
    }
    if s.show_map && s.dollhouse.is_none() {
        map(&mut out, nav, nav.graph(), s);
    }
    buttons(&mut out, s);
    out
}

/// Over the probe bar (its top at `bar_y`) while gliding: back, pause or
/// resume, on; the direction under way lit.
fn steering(out: &mut Layout, s: &Screen, speed: f32, bar_y: f32) {
    let k = s.scale;
    let (r, gap) = (20.0 * k, 6.0 * k);
    let y = bar_y - 2.0 * gap - r;
    let lit = |on: bool| if on { [0.2, 0.5, 0.9, 0.95] } else { [0.1, 0.1, 0.1, 0.7] };
    for (i, action) in [Action::Back, Action::Pause, Action::On].into_iter().enumerate() {
        let x = s.width / 2.0 + (i as f32 - 1.0) * (2.0 * r + 2.0 * gap);
        let on = match action {
            Action::Back => speed < 0.0,
            Action::On => speed > 0.0,
            _ => speed == 0.0,
        };
        out.shapes.push(Shape::disc(x, y, r, lit(on)));
        let line = |a: [f32; 2], b: [f32; 2]| Shape::line([x + a[0] * r, y + a[1] * r], [x + b[0] * r, y + b[1] * r], 3.0 * k, WHITE);
        match action {
            // Chevrons pointing back or on; two bars to pause, or one chevron to resume.
            Action::Back | Action::On => {
                let d = if action == Action::On { 1.0 } else { -1.0 };
                for off in [-0.25, 0.2] {
                    out.shapes.push(line([d * (off - 0.15), -0.4], [d * (off + 0.2), 0.0]));
                    out.shapes.push(line([d * (off + 0.2), 0.0], [d * (off - 0.15), 0.4]));
                }
            }
            _ if speed == 0.0 => {
                out.shapes.push(line([-0.2, -0.45], [0.35, 0.0]));
                out.shapes.push(line([0.35, 0.0], [-0.2, 0.45]));
            }
            _ => {
                out.shapes.push(line([-0.2, -0.4], [-0.2, 0.4]));
                out.shapes.push(line([0.2, -0.4], [0.2, 0.4]));
            }
        }
        out.hits.push(Hit { x: x - r, y: y - r, w: 2.0 * r, h: 2.0 * r, round: true, action });
    }
}

/// Markers where paths leave, in the view.
fn departure_markers(out: &mut Layout, nav: &Navigator, s: &Screen, choices: &[PathChoice]) {
    let k = s.scale;
    for (i, c) in choices.iter().enumerate() {
        let (yaw, pitch) = nav.departure(c.path, c.reversed);
        // Markers sit a little below the horizon of the departure, like a floor arrow.
        if let Some([x, y]) = project(&nav.view, direction(yaw, pitch - 0.25), s.width, s.height) {
            let r = 16.0 * k;
            let colour = if i == 0 { HIGHLIGHT } else { WHITE };
            out.shapes.push(Shape::disc(x, y, r + 2.0 * k, [0.0, 0.0, 0.0, 0.5]));
            out.shapes.push(Shape::disc(x, y, r, colour));
            out.hits.push(Hit { x: x - r, y: y - r, w: 2.0 * r, h: 2.0 * r, round: true, action: Action::TakePath(c.path) });
        }
    }
}

/// Probes over the dollhouse.
fn dollhouse_markers(out: &mut Layout, current: u32, s: &Screen) {
    let k = s.scale;
    for &(p, [x, y], hidden) in s.dollhouse.iter().flat_map(|d| &d.markers) {
        // A probe behind a wall: smaller and faint, still tappable.
        let (r, alpha) = if hidden { (6.0 * k, 0.45) } else { (9.0 * k, 1.0) };
        let [cr, cg, cb, ca] = if p == current { HIGHLIGHT } else { WHITE };
        out.shapes.push(Shape::disc(x, y, r + 2.0 * k, [0.0, 0.0, 0.0, 0.6 * alpha]));
        out.shapes.push(Shape::disc(x, y, r, [cr, cg, cb, ca * alpha]));
        let hr = 16.0 * k;
        out.hits.push(Hit { x: x - hr, y: y - hr, w: 2.0 * hr, h: 2.0 * hr, round: true, action: Action::GoTo(p) });
    }
}

/// The probe bar along the bottom, scrolled to the current probe; returns
/// its top and tile height (the path bar sits above it).
fn probe_bar(out: &mut Layout, nav: &Navigator, s: &Screen) -> (f32, f32) {
    let (w, h, k) = (s.width, s.height, s.scale);
    let (graph, current) = (nav.graph(), nav.probe());
    let bar_h = (w.min(h) * 0.12).clamp(44.0 * k, 90.0 * k);
    let tile_w = bar_h * 16.0 / 9.0;
    let gap = 6.0 * k;
    let y = h - bar_h - gap;
    out.shapes.push(Shape::rect(0.0, y - gap, w, bar_h + 2.0 * gap, PANEL));
    let order: Vec<u32> = if graph.bar_order.is_empty() { (0..graph.probes.len() as u32).collect() } else { graph.bar_order.clone() };
    let total = order.len() as f32 * (tile_w + gap) + gap;
    let at = order.iter().position(|&p| p == current).unwrap_or(0) as f32;
    // Scroll so the current probe is centred, without empty space at the ends.
    let scroll = if total <= w { (w - total) / 2.0 } else { (w / 2.0 - (gap + at * (tile_w + gap) + tile_w / 2.0)).clamp(w - total, 0.0) };
    for (i, &p) in order.iter().enumerate() {
        let x = scroll + gap + i as f32 * (tile_w + gap);
        if x + tile_w < 0.0 || x > w {
            continue;
        }
        out.tile([x, y, tile_w, bar_h], p, (p == current).then_some(HIGHLIGHT), s.thumbs_ready, Action::GoTo(p));
    }
    (y, bar_h)
}

/// The path bar above the probe bar (`(top, height)`): left to right by
/// relative yaw, the best aligned centred.
fn path_bar(out: &mut Layout, nav: &Navigator, s: &Screen, choices: &[PathChoice], (y, bar_h): (f32, f32)) {
    if choices.is_empty() {
        return;
    }
    let (w, gap) = (s.width, 6.0 * s.scale);
    let ph = bar_h * 0.8;
    let pw = ph * 16.0 / 9.0;
    let mut by_yaw: Vec<(f32, &PathChoice)> = choices.iter().map(|c| (relative_yaw(&nav.view, nav.departure(c.path, c.reversed)), c)).collect();
    by_yaw.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.path.cmp(&b.1.path)));
    let best = by_yaw.iter().position(|(_, c)| c.path == choices[0].path).unwrap_or(0) as f32;
    let py = y - 2.0 * gap - ph;
    for (i, (_, c)) in by_yaw.iter().enumerate() {
        let x = w / 2.0 - pw / 2.0 + (i as f32 - best) * (pw + gap);
        if x + pw < 0.0 || x > w {
            continue;
        }
        let frame = if c.path == choices[0].path { HIGHLIGHT } else { WHITE };
        out.tile([x, py, pw, ph], c.to, Some(frame), s.thumbs_ready, Action::TakePath(c.path));
    }
}

/// The buttons along the top: tour (a disc, green while touring), map,
/// dollhouse and its floors; then the message bar, if any.
fn buttons(out: &mut Layout, s: &Screen) {
    let (w, k) = (s.width, s.scale);
    let gap = 6.0 * k;
    let r = 16.0 * k;
    let (bx, by) = (gap + r, gap + r);
    out.shapes.push(Shape::disc(bx, by, r, if s.touring { [0.2, 0.8, 0.3, 0.95] } else { [0.1, 0.1, 0.1, 0.7] }));
    out.shapes.push(Shape::line([bx - 0.35 * r, by - 0.5 * r], [bx - 0.35 * r, by + 0.5 * r], 3.0 * k, WHITE));
    out.shapes.push(Shape::line([bx - 0.35 * r, by], [bx + 0.55 * r, by], 3.0 * k, WHITE));
    out.hits.push(Hit { x: bx - r, y: by - r, w: 2.0 * r, h: 2.0 * r, round: true, action: Action::ToggleTour });
    let mx = bx + 2.0 * r + gap;
    out.shapes.push(Shape::disc(mx, by, r, if s.show_map { [0.2, 0.5, 0.9, 0.95] } else { [0.1, 0.1, 0.1, 0.7] }));
    out.shapes.push(Shape::rect(mx - 0.45 * r, by - 0.45 * r, 0.9 * r, 0.9 * r, WHITE));
    out.hits.push(Hit { x: mx - r, y: by - r, w: 2.0 * r, h: 2.0 * r, round: true, action: Action::ToggleMap });
    let mut last = mx;
    if s.proxy {
        // The dollhouse: a house, a roof over a wall.
        let hx = last + 2.0 * r + gap;
        last = hx;
        out.shapes.push(Shape::disc(hx, by, r, if s.dollhouse.is_some() { [0.2, 0.5, 0.9, 0.95] } else { [0.1, 0.1, 0.1, 0.7] }));
        out.shapes.push(Shape::line([hx - 0.6 * r, by], [hx, by - 0.55 * r], 3.0 * k, WHITE));
        out.shapes.push(Shape::line([hx, by - 0.55 * r], [hx + 0.6 * r, by], 3.0 * k, WHITE));
        out.shapes.push(Shape::rect(hx - 0.4 * r, by, 0.8 * r, 0.5 * r, WHITE));
        out.hits.push(Hit { x: hx - r, y: by - r, w: 2.0 * r, h: 2.0 * r, round: true, action: Action::ToggleDollhouse });
    }
    if let Some(d) = s.dollhouse.as_ref().filter(|d| d.floors > 0) {
        // Floors: a bar per storey, lowest at the bottom; the shown one lit, all lit when uncut.
        let fx = last + 2.0 * r + gap;
        last = fx;
        out.shapes.push(Shape::disc(fx, by, r, [0.1, 0.1, 0.1, 0.7]));
        let n = d.floors.min(6);
        let step = 1.2 * r / n as f32;
        for i in 0..n {
            let lit = d.floor.is_none_or(|f| f.min(n - 1) == i);
            let y = by + 0.6 * r - step * (i as f32 + 0.5);
            out.shapes.push(Shape::rect(fx - 0.5 * r, y - 0.3 * step, r, 0.6 * step, if lit { HIGHLIGHT } else { [0.6, 0.6, 0.6, 0.9] }));
        }
        out.hits.push(Hit { x: fx - r, y: by - r, w: 2.0 * r, h: 2.0 * r, round: true, action: Action::NextFloor });
    }
    if s.message {
        out.shapes.push(Shape::rect(last + r + gap, by - 3.0 * k, (w - last - r - 2.0 * gap).max(0.0), 6.0 * k, [0.9, 0.15, 0.1, 0.95]));
    }
}

/// The overhead map (over the floor plan when the proxy is here): paths as
/// lines, probes as dots, the camera and its view.
fn map(out: &mut Layout, nav: &Navigator, graph: &Graph, s: &Screen) {
    let k = s.scale;
    let Some(frame) = map_frame(graph, s) else { return };
    if s.plan.is_none() {
        out.shapes.push(Shape::rect(frame.x0, frame.y0, frame.size, frame.size, PANEL));
    }
    out.map = Some(frame);
    // The square itself: a tap beside the dots is on the plan (and does
    // nothing without one), never on the panorama underneath.
    out.hits.push(Hit { x: frame.x0, y: frame.y0, w: frame.size, h: frame.size, round: false, action: Action::PlanPoint });
    let to_map = |p: [f32; 3]| frame.to_map(p);
    for s in s.sections.iter() {
        out.shapes.push(Shape::line(to_map([s[0], 0.0, s[1]]), to_map([s[2], 0.0, s[3]]), 1.5 * k, [0.02, 0.02, 0.03, 1.0]));
    }
    for path in &graph.paths {
        for seg in path.polyline.windows(2) {
            out.shapes.push(Shape::line(to_map(seg[0]), to_map(seg[1]), 2.0 * k, [0.8, 0.8, 0.85, 0.7]));
        }
    }
    let current = nav.probe();
    for p in &graph.probes {
        let [x, y] = to_map(p.position);
        let r = 5.0 * k;
        out.shapes.push(Shape::disc(x, y, r, if p.id == current { HIGHLIGHT } else { WHITE }));
        let hr = 11.0 * k;
        out.hits.push(Hit { x: x - hr, y: y - hr, w: 2.0 * hr, h: 2.0 * hr, round: true, action: Action::GoTo(p.id) });
    }
    let [x, y] = to_map(nav.camera_position());
    let d = direction(nav.view.yaw, 0.0);
    let l = 18.0 * k;
    out.shapes.push(Shape::line([x, y], [x + d[0] * l, y + d[2] * l], 3.0 * k, [0.95, 0.25, 0.2, 1.0]));
    out.shapes.push(Shape::disc(x, y, 4.0 * k, [0.95, 0.25, 0.2, 1.0]));
}

/// A deep link: where to start and how to look (degrees in the link).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Link {
    pub probe: Option<u32>,
    pub yaw_deg: Option<f32>,
    pub pitch_deg: Option<f32>,
    pub fov_deg: Option<f32>,
    /// Open in the dollhouse.
    pub dollhouse: bool,
}

impl Link {
    /// Parses `probe=3&yaw=90&pitch=-10&fov=70&dollhouse=1` (a leading `#` is allowed);
    /// unknown keys are ignored, bad values are an error naming them.
    pub fn parse(text: &str) -> Result<Link, String> {
        let mut link = Link::default();
        for part in text.trim_start_matches('#').split('&').filter(|p| !p.is_empty()) {
            let (key, value) = part.split_once('=').unwrap_or((part, ""));
            let number = || value.parse::<f32>().ok().filter(|v| v.is_finite()).ok_or_else(|| format!("{key}={value} is not a number"));
            match key {
                "probe" => link.probe = Some(value.parse().map_err(|_| format!("probe={value} is not a probe number"))?),
                "yaw" => link.yaw_deg = Some(number()?),
                "pitch" => link.pitch_deg = Some(number()?),
                "fov" => link.fov_deg = Some(number()?),
                "dollhouse" => link.dollhouse = value != "0",
                _ => {}
            }
        }
        Ok(link)
    }

    /// The link to where the navigator is now.
    pub fn of(nav: &Navigator) -> Link {
        Link {
            probe: Some(nav.probe()),
            yaw_deg: Some(nav.view.yaw.to_degrees()),
            pitch_deg: Some(nav.view.pitch.to_degrees()),
            fov_deg: Some(nav.view.fov_y.to_degrees()),
            dollhouse: false,
        }
    }

    pub fn to_fragment(&self) -> String {
        let mut parts = Vec::new();
        if let Some(p) = self.probe {
            parts.push(format!("probe={p}"));
        }
        for (key, v) in [("yaw", self.yaw_deg), ("pitch", self.pitch_deg), ("fov", self.fov_deg)] {
            if let Some(v) = v {
                parts.push(format!("{key}={v:.1}"));
            }
        }
        if self.dollhouse {
            parts.push("dollhouse=1".into());
        }
        parts.join("&")
    }

    /// Applies the view part to a navigator (the probe is chosen at its creation).
    pub fn apply_view(&self, nav: &mut Navigator) {
        if let Some(y) = self.yaw_deg {
            nav.view.yaw = 0.0;
            nav.look(y.to_radians(), 0.0);
        }
        if let Some(p) = self.pitch_deg {
            nav.view.pitch = 0.0;
            nav.look(0.0, p.to_radians());
        }
        if let Some(f) = self.fov_deg {
            nav.zoom(f.to_radians() / nav.view.fov_y);
        }
    }
}

#[cfg(test)]
mod tests;

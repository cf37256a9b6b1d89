//! Navigation: where the viewer is, where it looks and where it can go, as pure
//! logic on the bundle graph, unit-tested without a GPU (the ExploreMaps paper's browsing: look around,
//! follow a path's video, jump anywhere).
//!
//! States: at a probe (look around); travelling along a path (its 360° video
//! plays while the view blends from the user's direction to the arrival
//! direction), or along a route of paths to a probe no single path reaches
//! (passing through the probes between without stopping where the paths
//! glide); cross-fading to a probe that no route reaches. Paths can be
//! travelled either way. Angles: yaw 0 looks toward −Z and π/2 toward +X;
//! pitch is positive upward.

use exploremaps_format::{GlideSource, Graph, Waypoint};
use std::f32::consts::{PI, TAU};

/// Seconds a jump between unconnected probes takes.
pub const CROSS_FADE_S: f32 = 0.8;
/// A route's glides go faster, up to [`MAX_PACE`] times, so that it takes
/// about this long (videos keep their own clock).
pub const ROUTE_S: f32 = 6.0;
pub const MAX_PACE: f32 = 4.0;
const MIN_FOV_Y: f32 = 0.35;
const MAX_FOV_Y: f32 = 2.0;
const MAX_PITCH: f32 = 1.45;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    pub yaw: f32,
    pub pitch: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
}

use exploremaps_format::timing::{ease, ArcLength};
pub use exploremaps_format::{direction, yaw_pitch};

/// The rotation that turns a camera looking down −Z with +Y up (WebXR's
/// convention) to look along `view`, the horizon level.
pub fn rotation_of(view: &View) -> glam::Quat {
    glam::Quat::from_rotation_y(-view.yaw) * glam::Quat::from_rotation_x(view.pitch)
}

/// Angle between two view directions, radians.
fn angle_between(a: (f32, f32), b: (f32, f32)) -> f32 {
    let (u, v) = (direction(a.0, a.1), direction(b.0, b.1));
    (u[0] * v[0] + u[1] * v[1] + u[2] * v[2]).clamp(-1.0, 1.0).acos()
}

/// Wraps an angle into (−π, π].
fn wrap(a: f32) -> f32 {
    let w = (a + PI).rem_euclid(TAU) - PI;
    if w <= -PI {
        w + TAU
    } else {
        w
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum State {
    AtProbe { probe: u32 },
    Travelling { path: u32, reversed: bool, elapsed_s: f32, start: View },
    CrossFading { from: u32, to: u32, elapsed_s: f32 },
}

/// One entry of the path bar: a path leaving the current probe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathChoice {
    pub path: u32,
    pub to: u32,
    pub reversed: bool,
    /// Angle between the view and the path's departure direction, radians.
    pub angle: f32,
}

#[derive(Debug, PartialEq, Eq, thiserror::Error)]
pub enum NavError {
    #[error("path {path} does not leave probe {probe}")]
    NotFromHere { path: u32, probe: u32 },
    #[error("no probe {0} in this bundle")]
    NoSuchProbe(u32),
    #[error("already on the way; wait until arrival")]
    Busy,
}

pub struct Navigator {
    graph: Graph,
    pub state: State,
    pub view: View,
    rng: u64,
    /// The direction to face on arriving, when a move was asked to end
    /// facing something (point-to-go); else the probe's preferred one.
    facing: Option<(f32, f32)>,
    /// Glides draw from sources: the probes by id, then the panoramas part
    /// way along the paths, numbered on from the last probe path by path:
    /// per path, its first one's number.
    waypoint_sources: Vec<u32>,
    /// How fast a travel goes, in multiples of its timing: 0 paused,
    /// negative back toward its start (glides only: a video keeps its own clock).
    pub speed: f32,
    /// The legs of the route still to go after the current one, and its
    /// glides' pace.
    route: Vec<(u32, bool)>,
    pace: f32,
    /// Whether the current travel passes through its start and its end
    /// (inner probes of a route, between glides) rather than stopping there.
    through: (bool, bool),
}

/// A way to a probe along paths: its legs (path, reversed), in order.
#[derive(Clone, Debug, PartialEq)]
pub struct Route {
    pub legs: Vec<(u32, bool)>,
    /// Seconds at the paths' own timing.
    pub duration_s: f32,
}

impl Route {
    /// How much faster than their timing the route's glides go.
    pub fn pace(&self) -> f32 {
        (self.duration_s / ROUTE_S).clamp(1.0, MAX_PACE)
    }
}

/// The fraction of a path's length reached at fraction `t` of its duration:
/// slow in and out ([`ease`]), except at an end passed through, where the
/// camera keeps the path's mean speed (2t² − t³ leaves rest and arrives at
/// speed 1; its mirror does the opposite).
fn pace_along(t: f32, (through_start, through_end): (bool, bool)) -> f32 {
    let t = t.clamp(0.0, 1.0);
    match (through_start, through_end) {
        (false, false) => ease(t),
        (false, true) => t * t * (2.0 - t),
        (true, false) => 1.0 - (1.0 - t) * (1.0 - t) * (1.0 + t),
        (true, true) => t,
    }
}

impl Navigator {
    /// Starts at `probe` (default: first in the bar order) facing its preferred direction.
    pub fn new(graph: Graph, probe: Option<u32>, seed: u64) -> Result<Navigator, NavError> {
        let probe = probe.or_else(|| graph.bar_order.first().copied()).unwrap_or(0);
        if probe as usize >= graph.probes.len() {
            return Err(NavError::NoSuchProbe(probe));
        }
        let waypoint_sources = graph
            .paths
            .iter()
            .scan(graph.probes.len() as u32, |next, p| {
                let first = *next;
                *next += p.assets.transition.as_ref().map_or(0, |t| t.waypoints.len() as u32);
                Some(first)
            })
            .collect();
        let mut nav = Navigator {
            waypoint_sources,
            graph,
            state: State::AtProbe { probe },
            view: View { yaw: 0.0, pitch: 0.0, fov_y: 1.2 },
            rng: seed | 1,
            facing: None,
            speed: 1.0,
            route: Vec::new(),
            pace: 1.0,
            through: (false, false),
        };
        (nav.view.yaw, nav.view.pitch) = nav.arrival_direction(probe, None);
        Ok(nav)
    }

    pub fn graph(&self) -> &Graph {
        &self.graph
    }

    /// The probe the viewer is at, or is leaving.
    pub fn probe(&self) -> u32 {
        match self.state {
            State::AtProbe { probe } => probe,
            State::Travelling { path, reversed, .. } => self.endpoints(path, reversed).0,
            State::CrossFading { from, .. } => from,
        }
    }

    fn endpoints(&self, path: u32, reversed: bool) -> (u32, u32) {
        let p = &self.graph.paths[path as usize];
        if reversed {
            (p.to, p.from)
        } else {
            (p.from, p.to)
        }
    }

    /// The direction to face on arriving at `probe`: its best preferred direction,
    /// else the direction of travel.
    fn arrival_direction(&self, probe: u32, via: Option<(u32, bool)>) -> (f32, f32) {
        if let Some(f) = self.facing.filter(|_| self.route.is_empty()) {
            return f;
        }
        match via {
            Some((path, reversed)) => self.graph.arrival_direction(&self.graph.paths[path as usize], reversed),
            None => self.graph.probes[probe as usize].preferred_directions.first().map_or((self.view.yaw, self.view.pitch), |d| (d.yaw, d.pitch)),
        }
    }

    /// Where the current move ends, if moving.
    pub fn destination(&self) -> Option<u32> {
        match self.state {
            State::AtProbe { .. } => None,
            State::Travelling { path, reversed, .. } => Some(self.endpoints(path, reversed).1),
            State::CrossFading { to, .. } => Some(to),
        }
    }

    /// The direction a path leaves its start in (travelled either way).
    pub fn departure(&self, path: u32, reversed: bool) -> (f32, f32) {
        self.graph.paths[path as usize].travel_direction(reversed, false)
    }

    /// Paths leaving the current probe, best aligned with the view first.
    pub fn path_bar(&self) -> Vec<PathChoice> {
        let here = self.probe();
        let mut choices: Vec<PathChoice> = self
            .graph
            .paths
            .iter()
            .filter(|p| p.from == here || p.to == here)
            .map(|p| {
                let reversed = p.to == here;
                let departure = p.travel_direction(reversed, false);
                PathChoice {
                    path: p.id,
                    to: if reversed { p.from } else { p.to },
                    reversed,
                    angle: angle_between((self.view.yaw, self.view.pitch), departure),
                }
            })
            .collect();
        choices.sort_by(|a, b| a.angle.total_cmp(&b.angle).then(a.path.cmp(&b.path)));
        choices
    }

    pub fn take_path(&mut self, path: u32) -> Result<(), NavError> {
        let State::AtProbe { probe } = self.state else { return Err(NavError::Busy) };
        let p = self.graph.paths.get(path as usize).ok_or(NavError::NotFromHere { path, probe })?;
        if p.from != probe && p.to != probe {
            return Err(NavError::NotFromHere { path, probe });
        }
        self.route.clear();
        self.start_leg(path, p.to == probe, false, 0.0);
        self.facing = None;
        Ok(())
    }

    /// Starts along `path` (the next leg of a route when `on_route`): it
    /// passes through its start when the leg before glided too, through its
    /// end when the next one glides, and glides at the route's pace.
    /// `elapsed_s` is the time already gone past the leg before.
    fn start_leg(&mut self, path: u32, reversed: bool, on_route: bool, elapsed_s: f32) {
        let glides = |p: u32| self.graph.paths[p as usize].assets.video.is_none();
        let start = on_route && self.through.1;
        let end = glides(path) && self.route.first().is_some_and(|&(next, _)| glides(next));
        self.through = (start, end);
        self.speed = if glides(path) { self.pace } else { 1.0 };
        self.state = State::Travelling { path, reversed, elapsed_s, start: self.view };
    }

    /// The quickest way from the current probe to `target` along paths (by
    /// their durations), if any: Dijkstra over the graph (a few hundred
    /// probes at most; a graph library would weigh on the web viewer).
    pub fn route(&self, target: u32) -> Option<Route> {
        let (n, from) = (self.graph.probes.len(), self.probe());
        if target as usize >= n || target == from {
            return None;
        }
        // Per probe: its best time, and the leg that reached it.
        let mut best: Vec<(f32, Option<(u32, bool)>)> = vec![(f32::INFINITY, None); n];
        let mut done = vec![false; n];
        best[from as usize].0 = 0.0;
        while let Some(here) = (0..n).filter(|&i| !done[i] && best[i].0.is_finite()).min_by(|&a, &b| best[a].0.total_cmp(&best[b].0)) {
            if here == target as usize {
                break;
            }
            done[here] = true;
            for p in self.graph.paths.iter().filter(|p| p.from as usize == here || p.to as usize == here) {
                let (next, reversed) = if p.from as usize == here { (p.to as usize, false) } else { (p.from as usize, true) };
                let time = best[here].0 + p.duration_s.max(0.0);
                if next < n && time < best[next].0 {
                    best[next] = (time, Some((p.id, reversed)));
                }
            }
        }
        let duration_s = best[target as usize].0;
        let mut legs = Vec::new();
        let mut at = target;
        while at != from {
            let (path, reversed) = best[at as usize].1?;
            legs.push((path, reversed));
            let p = &self.graph.paths[path as usize];
            at = if reversed { p.to } else { p.from };
        }
        legs.reverse();
        Some(Route { legs, duration_s })
    }

    /// Goes to any probe: along a path when one joins them, else along the
    /// quickest route of paths, else by cross-fading.
    pub fn go_to(&mut self, target: u32) -> Result<(), NavError> {
        let State::AtProbe { probe } = self.state else { return Err(NavError::Busy) };
        if target as usize >= self.graph.probes.len() {
            return Err(NavError::NoSuchProbe(target));
        }
        if target == probe {
            return Ok(());
        }
        if let Some(c) = self.path_bar().iter().find(|c| c.to == target) {
            return self.take_path(c.path);
        }
        self.facing = None;
        match self.route(target) {
            Some(route) => {
                self.pace = route.pace();
                self.route = route.legs;
                let (path, reversed) = self.route.remove(0);
                self.through = (false, false);
                self.start_leg(path, reversed, true, 0.0);
            }
            None => self.state = State::CrossFading { from: probe, to: target, elapsed_s: 0.0 },
        }
        Ok(())
    }

    /// The legs of the route still ahead after the current travel (path, reversed).
    pub fn route_ahead(&self) -> &[(u32, bool)] {
        &self.route
    }

    /// The probes the route still reaches after the current travel's end.
    pub fn stops_ahead(&self) -> impl Iterator<Item = u32> + '_ {
        self.route.iter().map(|&(path, reversed)| self.endpoints(path, reversed).1)
    }

    /// As [`Navigator::go_to`], arriving facing (yaw, pitch).
    pub fn go_to_facing(&mut self, target: u32, facing: (f32, f32)) -> Result<(), NavError> {
        self.go_to(target)?;
        if self.state != (State::AtProbe { probe: target }) {
            self.facing = Some(facing);
        }
        Ok(())
    }

    /// Arrives at a probe at once, facing (yaw, pitch): the end of a flight
    /// over the dollhouse. Cancels any move.
    pub fn arrive(&mut self, probe: u32, yaw: f32, pitch: f32) -> Result<(), NavError> {
        if probe as usize >= self.graph.probes.len() {
            return Err(NavError::NoSuchProbe(probe));
        }
        self.state = State::AtProbe { probe };
        self.facing = None;
        (self.route, self.pace, self.through) = (Vec::new(), 1.0, (false, false));
        (self.view.yaw, self.view.pitch) = (0.0, 0.0);
        self.look(yaw, pitch);
        Ok(())
    }

    /// Fraction of the current travel or cross-fade done, if moving.
    pub fn progress(&self) -> Option<f32> {
        match self.state {
            State::AtProbe { .. } => None,
            State::Travelling { path, elapsed_s, .. } => Some((elapsed_s / self.graph.paths[path as usize].duration_s.max(1e-3)).min(1.0)),
            State::CrossFading { elapsed_s, .. } => Some((elapsed_s / CROSS_FADE_S).min(1.0)),
        }
    }

    /// Advances time: moves along the path (at [`Navigator::speed`]), blends
    /// the view, arrives (back at the start when going back).
    pub fn update(&mut self, dt_s: f32) {
        let speed = self.speed;
        match &mut self.state {
            State::AtProbe { .. } => return,
            State::Travelling { elapsed_s, .. } => *elapsed_s = (*elapsed_s + dt_s.max(0.0) * speed).max(0.0),
            State::CrossFading { elapsed_s, .. } => *elapsed_s += dt_s.max(0.0),
        }
        let t = self.progress().unwrap_or(1.0);
        match self.state {
            State::Travelling { path, reversed, start, elapsed_s } => {
                let (from, to) = self.endpoints(path, reversed);
                let (yaw, pitch) = self.arrival_direction(to, Some((path, reversed)));
                let s = self.travelled().unwrap_or(1.0);
                self.view.yaw = wrap(start.yaw + wrap(yaw - start.yaw) * s);
                self.view.pitch = start.pitch + (pitch - start.pitch) * s;
                if t >= 1.0 && !self.route.is_empty() {
                    let over_s = elapsed_s - self.graph.paths[path as usize].duration_s;
                    let (path, reversed) = self.route.remove(0);
                    self.start_leg(path, reversed, true, over_s.max(0.0));
                } else if t >= 1.0 || (speed < 0.0 && elapsed_s <= 0.0) {
                    self.state = State::AtProbe { probe: if t >= 1.0 { to } else { from } };
                    self.facing = None;
                    self.speed = 1.0;
                    (self.route, self.pace, self.through) = (Vec::new(), 1.0, (false, false));
                }
            }
            State::CrossFading { to, .. } if t >= 1.0 => {
                (self.view.yaw, self.view.pitch) = self.arrival_direction(to, None);
                self.state = State::AtProbe { probe: to };
                self.facing = None;
            }
            _ => {}
        }
    }

    /// The fraction of the path's length travelled, if travelling: slow in
    /// and out, except through a route's inner probes ([`pace_along`]).
    pub fn travelled(&self) -> Option<f32> {
        let State::Travelling { .. } = self.state else { return None };
        Some(pace_along(self.progress().unwrap_or(0.0), self.through))
    }

    /// Where the camera is: the probe, or the point along the path reached
    /// ([`Navigator::travelled`], by arc length of the polyline).
    pub fn camera_position(&self) -> [f32; 3] {
        let State::Travelling { path, reversed, .. } = self.state else {
            return self.graph.probes[self.probe() as usize].position;
        };
        let s = self.travelled().unwrap_or(0.0);
        let s = if reversed { 1.0 - s } else { s };
        ArcLength::new(&self.graph.paths[path as usize].polyline).at(s)
    }

    /// The panoramas part way along `path` (a glide in legs), in its order.
    pub fn waypoints(&self, path: u32) -> &[Waypoint] {
        self.graph.paths.get(path as usize).and_then(|p| p.assets.transition.as_ref()).map_or(&[], |t| &t.waypoints)
    }

    fn first_waypoint_source(&self, path: u32) -> u32 {
        self.waypoint_sources[path as usize]
    }

    /// The panorama part way that source `source` is, if it is one.
    pub fn waypoint(&self, source: u32) -> Option<&Waypoint> {
        // The last path whose first source is at most `source`.
        let path = self.waypoint_sources.partition_point(|&first| first <= source).checked_sub(1)?;
        self.waypoints(path as u32).get((source - self.waypoint_sources[path]) as usize)
    }

    /// Where source `source` (a probe or a panorama part way) stands.
    pub fn source_position(&self, source: u32) -> Option<[f32; 3]> {
        match self.graph.probes.get(source as usize) {
            Some(p) => Some(p.position),
            None => self.waypoint(source).map(|w| w.position),
        }
    }

    /// A glide's sources along `path` travelled one way
    /// ([`exploremaps_format::Path::glide_sources`]), as source ids.
    pub fn sources_along(&self, path: u32, reversed: bool) -> Vec<(u32, f32)> {
        let first = self.first_waypoint_source(path);
        let id = |source| match source {
            GlideSource::Probe(p) => p,
            GlideSource::Waypoint(i) => first + i as u32,
        };
        self.graph.paths[path as usize].glide_sources(reversed).into_iter().map(|(source, s)| (id(source), s)).collect()
    }

    /// The sources along the path being travelled ([`Navigator::sources_along`])
    /// and the fraction of the way the camera has come.
    pub fn glide_sources(&self) -> Option<(Vec<(u32, f32)>, f32)> {
        let State::Travelling { path, reversed, .. } = self.state else { return None };
        Some((self.sources_along(path, reversed), self.travelled().unwrap_or(0.0)))
    }

    /// Turns the view (drag, keys); pitch is clamped short of straight up/down.
    pub fn look(&mut self, d_yaw: f32, d_pitch: f32) {
        self.view.yaw = wrap(self.view.yaw + d_yaw);
        self.view.pitch = (self.view.pitch + d_pitch).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Zooms (pinch, wheel): factor < 1 narrows the field of view.
    pub fn zoom(&mut self, factor: f32) {
        if factor.is_finite() && factor > 0.0 {
            self.view.fov_y = (self.view.fov_y * factor).clamp(MIN_FOV_Y, MAX_FOV_Y);
        }
    }

    /// One step of the automatic tour: a seeded random path from here, avoiding
    /// going straight back when there is another way. Returns the path taken.
    pub fn random_walk_step(&mut self, came_by: Option<u32>) -> Option<u32> {
        if !matches!(self.state, State::AtProbe { .. }) {
            return None;
        }
        let mut choices: Vec<u32> = self.path_bar().iter().map(|c| c.path).collect();
        choices.sort_unstable();
        if choices.len() > 1 {
            choices.retain(|&p| Some(p) != came_by);
        }
        if choices.is_empty() {
            return None;
        }
        // xorshift64: tiny, seeded, identical on every platform (native and wasm).
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        let path = choices[(self.rng % choices.len() as u64) as usize];
        self.take_path(path).ok()?;
        Some(path)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use exploremaps_format::{CubeLevel, Path, PathAssets, Probe, SceneInfo, ViewDirection};

    /// Probe 0 at the origin with paths to probes 1 (+X), 2 (−Z) and 3 (+Z, bent);
    /// probe 4 unconnected. Probe 2 prefers to look toward +X.
    pub(crate) fn graph() -> Graph {
        let mut g = Graph::new(SceneInfo {
            name: "t".into(),
            source: "test".into(),
            triangles: 1,
            bounds_min: [-10.0; 3],
            bounds_max: [10.0; 3],
            metres_per_unit: 1.0,
            scale_source: "file".into(),
            space: None,
            near_distance: None,
            eye_height_m: None,
            credits: vec![],
        });
        let positions = [[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 0.0, -4.0], [2.0, 0.0, 4.0], [9.0, 0.0, 9.0]];
        for (i, p) in positions.iter().enumerate() {
            let preferred = if i == 2 { vec![ViewDirection { yaw: PI / 2.0, pitch: 0.0, goodness: 1.0 }] } else { vec![] };
            g.probes.push(Probe {
                id: i as u32,
                position: *p,
                cluster: None,
                preferred_directions: preferred,
                user_placed: false,
                assets: Default::default(),
            });
        }
        let mut add = |from: u32, to: u32, polyline: Vec<[f32; 3]>| {
            let length = polyline.windows(2).map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][2] - w[0][2]).powi(2)).sqrt()).sum();
            let id = g.paths.len() as u32;
            g.paths.push(Path { id, from, to, polyline, length, duration_s: 2.0, camera: vec![], assets: PathAssets::default() });
        };
        add(0, 1, vec![[0.0, 0.0, 0.0], [4.0, 0.0, 0.0]]);
        add(2, 0, vec![[0.0, 0.0, -4.0], [0.0, 0.0, 0.0]]);
        add(0, 3, vec![[0.0, 0.0, 0.0], [0.0, 0.0, 4.0], [2.0, 0.0, 4.0]]);
        g.validate().unwrap();
        g
    }

    /// The test graph with panoramas part way: one on path 1 (probe 2 to
    /// 0) half way, two on path 2; the paths' camera keys 21 at 0.1 s.
    pub(crate) fn graph_with_waypoints() -> Graph {
        let mut g = graph();
        for p in &mut g.paths {
            let arc = ArcLength::new(&p.polyline);
            p.camera = (0..=20)
                .map(|i| {
                    let t_s = i as f32 * 0.1;
                    exploremaps_format::CameraKey { t_s, position: arc.at(ease(t_s / p.duration_s)), yaw: 0.0, pitch: 0.0 }
                })
                .collect();
            let keys: &[u32] = match p.id {
                1 => &[10],
                2 => &[5, 15],
                _ => &[],
            };
            let waypoints = keys
                .iter()
                .map(|&key| Waypoint {
                    key,
                    position: p.camera[key as usize].position,
                    cube: CubeLevel { size: 8, faces: std::array::from_fn(|f| format!("paths/{}/{key}_{f}.jpg", p.id)) },
                    depth: format!("paths/{}/{key}.emdc", p.id),
                })
                .collect();
            let kind = exploremaps_format::TransitionKind::Depth;
            p.assets.transition = Some(exploremaps_format::Transition { kind, unseen: 0.0, reason: "a glide".into(), waypoints });
        }
        g.validate().unwrap();
        g
    }

    #[test]
    fn panoramas_part_way_are_sources_numbered_after_the_probes_in_the_order_travelled() {
        let nav = Navigator::new(graph_with_waypoints(), Some(0), 1).unwrap();
        // Path 1 runs from probe 2 to 0; travelled from 0 it is reversed.
        let along = nav.sources_along(1, true);
        assert_eq!(along.iter().map(|s| s.0).collect::<Vec<_>>(), vec![0, 5, 2]);
        assert!((along[1].1 - 0.5).abs() < 1e-6 && along[0].1 == 0.0 && along[2].1 == 1.0, "{along:?}");
        let forward = nav.sources_along(2, false);
        assert_eq!(forward.iter().map(|s| s.0).collect::<Vec<_>>(), vec![0, 6, 7, 3]);
        assert!(forward.windows(2).all(|w| w[0].1 < w[1].1), "{forward:?}");
        assert_eq!(nav.source_position(5), Some([0.0, 0.0, -2.0]));
        assert_eq!(nav.waypoint(7).map(|w| w.key), Some(15));
        assert_eq!((nav.waypoint(8), nav.waypoint(4).is_some(), nav.source_position(8)), (None, false, None));
    }

    #[test]
    fn directions_round_trip() {
        for (yaw, pitch) in [(0.0, 0.0), (1.0, 0.3), (-2.5, -1.0), (PI / 2.0, 0.0)] {
            let (y, p) = yaw_pitch(direction(yaw, pitch));
            assert!((wrap(y - yaw)).abs() < 1e-5 && (p - pitch).abs() < 1e-5);
        }
        let d = direction(PI / 2.0, 0.0);
        assert!((d[0] - 1.0).abs() < 1e-6, "yaw π/2 looks toward +X");
        let d = direction(0.0, 0.0);
        assert!((d[2] + 1.0).abs() < 1e-6, "yaw 0 looks toward −Z");
    }

    #[test]
    fn path_bar_is_sorted_by_angle_to_the_view() {
        let g = graph();
        let mut nav = Navigator::new(g.clone(), Some(0), 1).unwrap();
        nav.view.yaw = 0.0; // toward −Z: the path to probe 2 (travelled in reverse) comes first
        let bar = nav.path_bar();
        assert_eq!(bar.iter().map(|c| c.to).collect::<Vec<_>>(), vec![2, 1, 3]);
        assert!(bar[0].reversed && bar[0].angle < 1e-5);
        assert!((bar[1].angle - PI / 2.0).abs() < 1e-4);
        nav.look(PI / 2.0, 0.0); // toward +X
        assert_eq!(nav.path_bar()[0].to, 1);
    }

    #[test]
    fn a_travel_pauses_goes_back_to_its_start_and_on_at_any_speed() {
        let mut nav = Navigator::new(graph(), Some(0), 1).unwrap();
        nav.go_to(1).unwrap();
        nav.update(0.5);
        let here = nav.camera_position();
        nav.speed = 0.0;
        nav.update(0.5);
        assert_eq!(nav.camera_position(), here, "paused");
        nav.speed = -2.0;
        nav.update(0.2);
        assert!(nav.camera_position()[0] < here[0], "back toward probe 0: {:?}", nav.camera_position());
        nav.update(0.2);
        assert_eq!((nav.state, nav.speed), (State::AtProbe { probe: 0 }, 1.0), "back at the start, at the usual speed");
        nav.go_to(1).unwrap();
        nav.speed = 4.0;
        nav.update(0.5);
        assert_eq!(nav.state, State::AtProbe { probe: 1 }, "four times as fast: 2 s in 0.5 s");
    }

    #[test]
    fn travelling_arrives_facing_the_arrival_direction() {
        let g = graph();
        let mut nav = Navigator::new(g.clone(), Some(0), 1).unwrap();
        nav.view.yaw = 3.0;
        nav.go_to(2).unwrap();
        assert!(matches!(nav.state, State::Travelling { path: 1, reversed: true, .. }));
        assert_eq!(nav.go_to(1), Err(NavError::Busy));
        nav.update(1.0);
        let mid = nav.camera_position();
        assert!((mid[2] + 2.0).abs() < 1e-4 && mid[0].abs() < 1e-6, "half-way in time is half-way in space: {mid:?}");
        assert!(nav.view.yaw != 3.0, "the view blends during travel");
        nav.update(1.5);
        assert_eq!(nav.state, State::AtProbe { probe: 2 });
        assert!((nav.view.yaw - PI / 2.0).abs() < 1e-5, "faces probe 2's preferred direction");
        assert_eq!(nav.camera_position(), [0.0, 0.0, -4.0]);
    }

    #[test]
    fn without_a_preferred_direction_arrival_faces_the_direction_of_travel() {
        let g = graph();
        let mut nav = Navigator::new(g.clone(), Some(0), 1).unwrap();
        nav.go_to(3).unwrap();
        nav.update(10.0);
        assert_eq!(nav.state, State::AtProbe { probe: 3 });
        assert!((nav.view.yaw - PI / 2.0).abs() < 1e-4, "the bent path ends heading +X: {}", nav.view.yaw);
    }

    #[test]
    fn unconnected_probes_cross_fade() {
        let g = graph();
        let mut nav = Navigator::new(g.clone(), Some(0), 1).unwrap();
        nav.go_to(4).unwrap();
        assert!(matches!(nav.state, State::CrossFading { from: 0, to: 4, .. }));
        nav.update(CROSS_FADE_S * 0.5);
        assert!((nav.progress().unwrap() - 0.5).abs() < 1e-5);
        nav.update(CROSS_FADE_S);
        assert_eq!(nav.state, State::AtProbe { probe: 4 });
        assert_eq!(nav.go_to(9), Err(NavError::NoSuchProbe(9)));
        assert_eq!(nav.take_path(0), Err(NavError::NotFromHere { path: 0, probe: 4 }));
    }

    #[test]
    fn a_probe_no_path_joins_is_reached_along_the_quickest_route_without_stopping_between() {
        let mut g = graph();
        // A slow detour from probe 1 to probe 3: the route avoids it.
        let detour = Path { id: 3, from: 1, to: 3, duration_s: 9.0, ..g.paths[0].clone() };
        g.paths.push(Path { polyline: vec![[4.0, 0.0, 0.0], [2.0, 0.0, 4.0]], ..detour });
        g.paths[2].duration_s = 3.0; // 6 m at 2 m/s, as path 1's 4 m in 2 s
        g.paths[3].duration_s = 6.0;
        let mut nav = Navigator::new(g, Some(2), 1).unwrap();
        let route = nav.route(3).unwrap();
        assert_eq!(route.legs, vec![(1, false), (2, false)], "2 → 0 → 3 in 5 s, not 2 → 0 → 1 → 3 in 10 s");
        assert_eq!((route.duration_s, route.pace()), (5.0, 1.0));
        assert_eq!((nav.route(4), nav.route(2)), (None, None), "probe 4 has no path; probe 2 is here");
        nav.go_to_facing(3, (-1.0, 0.2)).unwrap();
        assert_eq!(nav.stops_ahead().collect::<Vec<_>>(), vec![3]);
        // Through probe 0 at the paths' mean speed (2 m/s), with no stop.
        let mut positions = Vec::new();
        for _ in 0..51 {
            nav.update(0.1);
            positions.push(nav.camera_position());
        }
        let steps: Vec<f32> = positions.windows(2).map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][2] - w[0][2]).powi(2)).sqrt()).collect();
        let through = 19; // from 1.9 s to 2.0 s, the step that reaches probe 0
        assert!(positions[through][2].abs() < 1e-4 && positions[through][0].abs() < 1e-4, "{:?}", positions[through]);
        assert!(steps[through - 1..=through + 1].iter().all(|&d| (d - 0.2).abs() < 0.02), "steady through probe 0: {:?}", &steps[15..24]);
        assert_eq!(nav.state, State::AtProbe { probe: 3 });
        assert!((nav.view.yaw + 1.0).abs() < 1e-4 && (nav.view.pitch - 0.2).abs() < 1e-4, "faces what was asked, at the end only");
    }

    #[test]
    fn going_back_on_a_route_stops_at_the_leg_s_start() {
        let mut nav = Navigator::new(graph(), Some(1), 1).unwrap();
        nav.go_to(2).unwrap();
        assert!(matches!(nav.state, State::Travelling { path: 0, reversed: true, .. }));
        nav.update(2.5);
        assert!(matches!(nav.state, State::Travelling { path: 1, reversed: true, .. }), "on the second leg: {:?}", nav.state);
        nav.speed = -1.0;
        nav.update(1.0);
        assert_eq!((nav.state, nav.stops_ahead().count()), (State::AtProbe { probe: 0 }, 0));
    }

    #[test]
    fn the_pace_through_a_route_s_inner_probes_is_continuous() {
        let speed = |f: &dyn Fn(f32) -> f32, t: f32| (f(t + 1e-3) - f(t - 1e-3)) / 2e-3;
        for through in [(false, false), (false, true), (true, false), (true, true)] {
            let f = |t: f32| pace_along(t, through);
            assert!(f(0.0) == 0.0 && f(1.0) == 1.0, "{through:?}");
            assert!((0..=100).all(|i| speed(&f, 0.01 * i as f32 + 1e-3) >= -1e-3), "never backwards: {through:?}");
            let ends = (speed(&f, 1e-3), speed(&f, 1.0 - 1e-3));
            let expected = (if through.0 { 1.0 } else { 0.0 }, if through.1 { 1.0 } else { 0.0 });
            assert!((ends.0 - expected.0).abs() < 0.01 && (ends.1 - expected.1).abs() < 0.01, "{through:?}: {ends:?}");
        }
    }

    #[test]
    fn look_and_zoom_are_clamped() {
        let g = graph();
        let mut nav = Navigator::new(g.clone(), None, 1).unwrap();
        nav.look(10.0 * TAU + 0.5, 5.0);
        assert!((nav.view.yaw - 0.5).abs() < 1e-3 && nav.view.pitch == MAX_PITCH);
        nav.zoom(0.01);
        assert_eq!(nav.view.fov_y, MIN_FOV_Y);
        nav.zoom(f32::NAN);
        assert_eq!(nav.view.fov_y, MIN_FOV_Y);
    }

    #[test]
    fn random_walk_is_seeded_and_follows_paths() {
        let g = graph();
        let walk = |seed| {
            let mut nav = Navigator::new(g.clone(), Some(0), seed).unwrap();
            let mut visited = vec![];
            let mut came_by = None;
            for _ in 0..20 {
                came_by = nav.random_walk_step(came_by);
                nav.update(10.0);
                visited.push(nav.probe());
            }
            visited
        };
        assert_eq!(walk(7), walk(7));
        assert!(walk(7).iter().all(|&p| p != 4), "never reaches the unconnected probe");
        assert!((1..=3).all(|p| walk(7).contains(&p)), "visits every connected probe: {:?}", walk(7));
    }
}

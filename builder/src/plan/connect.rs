//! Connect: which probes get a path between them, and the raw path
//! (the ExploreMaps paper, section 6).
//!
//! Inputs: the ray-casting scene, the navigable [`FreeSpace`], final probes.
//! Output: raw polylines between connected probe pairs, and [`ConnectStats`].
//!
//! Two probes are connected when some point of navigable space is visible from
//! both (not only when they see each other: a probe in a room and one outside
//! its window connect). Each probe sees a set of seeded random navigable points
//! (4,000, or 16 a probe when there are more than 250 probes; occlusion rays);
//! shared points make a pair. The route: the straight segment
//! if it keeps clearance r; else through the shared point minimising the
//! detour, if both legs keep clearance; else A* over navigable voxels
//! (26-neighbours, each step's cost its length times 1 + r / clearance, so
//! routes keep to open space; heuristic 1.5 × distance), run nearest pairs
//! first and skipped where a two-arc detour already makes the arc redundant.
//! Pairs with no route are rejected. Groups of probes left apart (no view
//! shared across them) but in one part of the navigable space are then joined
//! along the shortest walk between them; groups walking cannot join (a
//! ledge, terraces a metre apart) by a path that glides through the fly
//! space of the visitor's parts, off walking height only where it must
//! (each such step costs four walking ones). Groups still apart are islands,
//! named in the stats. Arcs whose length exceeds 1.25 times a
//! two-arc detour through a third probe are pruned (longest first, never
//! disconnecting the graph), so the graph stays readable.

use crate::plan::freespace::FreeSpace;
use crate::raycast::{Packing, Ray, RayScene};
use glam::Vec3;
use petgraph::unionfind::UnionFind;
use rand::Rng;
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};
use std::time::Instant;

/// Witness points at least this many times the probes (the default 4,000
/// serve up to 250 probes).
const WITNESSES_PER_PROBE: usize = 16;
/// A step gliding off walking height costs this many walking steps: a join
/// walks wherever it can.
const GLIDE_COST: f32 = 4.0;
/// A* searches run this many at a time (a fixed number, so that the paths
/// do not depend on the thread count).
const SEARCH_BATCH: usize = 8;

#[derive(Clone, Debug, PartialEq)]
pub struct ConnectParams {
    /// Random navigable points tested for shared visibility.
    pub witness_points: usize,
    /// An arc is pruned when a detour through another probe is at most this much longer.
    pub prune_ratio: f32,
    pub seed: u64,
}

impl Default for ConnectParams {
    fn default() -> Self {
        ConnectParams { witness_points: 4000, prune_ratio: 1.25, seed: 1 }
    }
}

#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ConnectStats {
    pub pairs_tested: usize,
    pub pairs_sharing_view: usize,
    pub straight: usize,
    pub via_witness: usize,
    pub a_star: usize,
    /// Paths joining groups of probes that share no view with each other
    /// (the shortest walk between the groups).
    pub joined: usize,
    /// Paths gliding off walking height to join groups walking cannot.
    pub glided: usize,
    pub unroutable: usize,
    pub pruned: usize,
    pub paths: usize,
    /// Connected components of the final graph (1 when every probe is reachable).
    pub components: usize,
    /// The probes of each component, largest first, when there are several:
    /// parts of the space no path can join (a sealed room); the viewer's
    /// probe bar and map still jump there.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub islands: Vec<Vec<usize>>,
    #[serde(skip)]
    pub seconds: f64,
}

/// A raw path between probes `from` and `to` (indices), as a polyline.
#[derive(Clone, Debug, PartialEq)]
pub struct RawPath {
    pub from: usize,
    pub to: usize,
    pub polyline: Vec<Vec3>,
}

pub fn polyline_length(p: &[Vec3]) -> f32 {
    p.windows(2).map(|w| (w[1] - w[0]).length()).sum()
}

/// Whether the segment stays in navigable space (every voxel it crosses) and
/// crosses no geometry.
pub fn segment_clear(rays: &RayScene, space: &FreeSpace, a: Vec3, b: Vec3) -> bool {
    space.segment_navigable(a, b) && !rays.occluded(&Ray::segment(a, b))
}

/// Connects probes: raw routes between every pair that shares a view, pruned.
pub fn connect(rays: &RayScene, space: &FreeSpace, probes: &[Vec3], params: &ConnectParams) -> (Vec<RawPath>, ConnectStats) {
    let started = Instant::now();
    let mut stats = ConnectStats::default();
    let witnesses = Witnesses::new(rays, space, probes, params);
    let pairs: Vec<(usize, usize)> = (0..probes.len()).flat_map(|i| (i + 1..probes.len()).map(move |j| (i, j))).collect();
    stats.pairs_tested = pairs.len();
    let (mut paths, searches) = direct_routes(rays, space, probes, &witnesses, &pairs, &mut stats);
    // A* between parts of the navigable space that never touch would search
    // all of one part before giving up: such pairs are refused at once.
    let part = if searches.is_empty() && components(probes.len(), &paths) == 1 {
        Vec::new()
    } else {
        crate::plan::freespace::components_26(&space.grid, &space.navigable).0
    };
    let routing = Routing { rays, space, probes, part };
    routing.search(searches, params.prune_ratio, &mut paths, &mut stats);
    routing.join_groups(&mut paths, &mut stats);
    let before = paths.len();
    let paths = prune(probes.len(), paths, params.prune_ratio);
    stats.pruned += before - paths.len();
    stats.paths = paths.len();
    stats.components = components(probes.len(), &paths);
    stats.islands = islands(probes.len(), &paths);
    stats.seconds = started.elapsed().as_secs_f64();
    (paths, stats)
}

/// Random navigable points, and which of them each probe sees: two probes
/// that see a point in common share a view.
struct Witnesses {
    points: Vec<Vec3>,
    seen: Vec<Vec<bool>>,
}

impl Witnesses {
    fn new(rays: &RayScene, space: &FreeSpace, probes: &[Vec3], params: &ConnectParams) -> Witnesses {
        let navigable = space.navigable_points();
        let mut rng = crate::seeds::Stream::Connect.rng(params.seed);
        // Enough witnesses for each probe to share some with its neighbours however many probes there are.
        let count = params.witness_points.max(WITNESSES_PER_PROBE * probes.len());
        let points: Vec<Vec3> =
            if navigable.is_empty() { Vec::new() } else { (0..count).map(|_| navigable[rng.random_range(0..navigable.len())]).collect() };
        let seen = probes
            .par_iter()
            .map(|&p| {
                let segments: Vec<Ray> = points.iter().map(|&w| Ray::segment(p, w)).collect();
                rays.occluded_batch(&segments, Packing::Packets8).into_iter().map(|b| !b).collect()
            })
            .collect();
        Witnesses { points, seen }
    }

    /// The points probes `i` and `j` both see.
    fn shared(&self, i: usize, j: usize) -> impl Iterator<Item = Vec3> + '_ {
        (0..self.points.len()).filter(move |&k| self.seen[i][k] && self.seen[j][k]).map(|k| self.points[k])
    }
}

/// Phase 1, in parallel: the straight segment, or two legs through a shared
/// point; returns those routes, and the pairs that share a view but got
/// neither (to search).
fn direct_routes(
    rays: &RayScene,
    space: &FreeSpace,
    probes: &[Vec3],
    witnesses: &Witnesses,
    pairs: &[(usize, usize)],
    stats: &mut ConnectStats,
) -> (Vec<RawPath>, Vec<(usize, usize)>) {
    let cheap: Vec<Option<RawPath>> = pairs
        .par_iter()
        .map(|&(i, j)| {
            let (a, b) = (probes[i], probes[j]);
            if segment_clear(rays, space, a, b) {
                return Some(RawPath { from: i, to: j, polyline: vec![a, b] });
            }
            let mut shared: Vec<Vec3> = witnesses.shared(i, j).collect();
            shared.sort_by(|x, y| ((*x - a).length() + (*x - b).length()).total_cmp(&((*y - a).length() + (*y - b).length())));
            shared.into_iter().take(8).find(|&w| segment_clear(rays, space, a, w) && segment_clear(rays, space, w, b)).map(|w| RawPath {
                from: i,
                to: j,
                polyline: vec![a, w, b],
            })
        })
        .collect();
    let mut paths = Vec::new();
    let mut searches = Vec::new();
    for (&(i, j), route) in pairs.iter().zip(cheap) {
        let share = witnesses.shared(i, j).next().is_some();
        stats.pairs_sharing_view += share as usize;
        match route {
            Some(path) => {
                if path.polyline.len() == 2 {
                    stats.straight += 1
                } else {
                    stats.via_witness += 1
                }
                paths.push(path);
            }
            None if share => searches.push((i, j)),
            None => {}
        }
    }
    (paths, searches)
}

/// What the later phases route with: `part` gives each navigable voxel its
/// 26-connected part (empty when no phase needs it).
struct Routing<'a> {
    rays: &'a RayScene,
    space: &'a FreeSpace,
    probes: &'a [Vec3],
    part: Vec<u32>,
}

impl Routing<'_> {
    fn part_of(&self, p: Vec3) -> Option<u32> {
        self.space.grid.cell(p).map(|c| self.part[self.space.grid.index(c)])
    }

    /// Phase 2, nearest pairs first: A* only where no two-arc detour
    /// already beats the pruning bound (an A* route is never shorter than
    /// the straight line). In batches of a fixed size, whatever the thread
    /// count: a batch's pairs are checked for detours against the paths
    /// found before it, then searched in parallel.
    fn search(&self, mut searches: Vec<(usize, usize)>, prune_ratio: f32, paths: &mut Vec<RawPath>, stats: &mut ConnectStats) {
        let probes = self.probes;
        searches.sort_by(|x, y| (probes[x.0] - probes[x.1]).length().total_cmp(&(probes[y.0] - probes[y.1]).length()).then(x.cmp(y)));
        for batch in searches.chunks(SEARCH_BATCH) {
            let mut wanted = Vec::with_capacity(batch.len());
            for &(i, j) in batch {
                if self.part_of(probes[i]) != self.part_of(probes[j]) {
                    stats.unroutable += 1;
                    continue;
                }
                let bound = prune_ratio * (probes[i] - probes[j]).length();
                let arc = |x: usize, y: usize| {
                    paths.iter().find(|p: &&RawPath| (p.from, p.to) == (x.min(y), x.max(y))).map(|p| polyline_length(&p.polyline))
                };
                let detour =
                    (0..probes.len()).filter(|&m| m != i && m != j).any(|m| matches!((arc(i, m), arc(m, j)), (Some(a), Some(b)) if a + b <= bound));
                if detour {
                    stats.pruned += 1;
                } else {
                    wanted.push((i, j));
                }
            }
            let routes: Vec<Option<Vec<Vec3>>> = wanted.par_iter().map(|&(i, j)| a_star(self.space, probes[i], probes[j])).collect();
            for (&(i, j), route) in wanted.iter().zip(routes) {
                match route {
                    Some(polyline) => {
                        stats.a_star += 1;
                        paths.push(RawPath { from: i, to: j, polyline });
                    }
                    None => stats.unroutable += 1,
                }
            }
        }
    }

    /// Phases 3 and 4: groups of probes that share no view with each other
    /// but stand in one part of the navigable space (hundreds of probes in a
    /// labyrinth left 80 groups) are joined where the walk between them is
    /// shortest. (Nearest in a straight line was tried first: probes 2 m
    /// apart through a wall got routes of up to 1.7 km.) Where walking
    /// cannot join groups (a ledge, terraces a metre apart, a room reached
    /// over a sill), a path glides through the fly space between them,
    /// straightened.
    fn join_groups(&self, paths: &mut Vec<RawPath>, stats: &mut ConnectStats) {
        let (space, probes) = (self.space, self.probes);
        if components(probes.len(), paths) > 1 {
            let parts: Vec<Option<u32>> = probes.iter().map(|&p| self.part_of(p)).collect();
            for (i, j, polyline) in walks_between_groups(space, &space.navigable, probes, &parts, paths) {
                stats.joined += 1;
                paths.push(RawPath { from: i, to: j, polyline });
            }
        }
        if !space.glide.is_empty() && components(probes.len(), paths) > 1 {
            let (glide_part, _) = crate::plan::freespace::components_26(&space.grid, &space.glide);
            let parts: Vec<Option<u32>> =
                probes.iter().map(|&p| space.grid.cell(p).map(|c| glide_part[space.grid.index(c)]).filter(|&l| l != u32::MAX)).collect();
            for (i, j, polyline) in walks_between_groups(space, &space.glide, probes, &parts, paths) {
                stats.glided += 1;
                paths.push(RawPath { from: i, to: j, polyline: straighten(self.rays, space, &polyline) });
            }
        }
    }
}

/// The probes of each connected group, largest first, when there are several.
fn islands(n: usize, paths: &[RawPath]) -> Vec<Vec<usize>> {
    let mut groups = groups(n, paths);
    let mut by_root: HashMap<usize, Vec<usize>> = HashMap::new();
    for k in 0..n {
        by_root.entry(groups.find_mut(k)).or_default().push(k);
    }
    if by_root.len() < 2 {
        return Vec::new();
    }
    let mut out: Vec<Vec<usize>> = by_root.into_values().collect();
    out.sort_by(|a, b| b.len().cmp(&a.len()).then(a[0].cmp(&b[0])));
    out
}

/// A route through voxel centres pulled straight: from each kept point, the
/// farthest later point the path can glide to in a straight line.
fn straighten(rays: &RayScene, space: &FreeSpace, route: &[Vec3]) -> Vec<Vec3> {
    let clear = |a: Vec3, b: Vec3| space.segment_glides(a, b) && !rays.occluded(&Ray::segment(a, b));
    let mut out = vec![route[0]];
    let mut at = 0;
    while at + 1 < route.len() {
        let next = (at + 2..route.len()).rev().find(|&k| clear(route[at], route[k])).unwrap_or(at + 1);
        out.push(route[next]);
        at = next;
    }
    out
}

/// Removes arcs with a short enough two-arc detour, longest first, keeping the
/// detour's arcs and never disconnecting the graph.
fn prune(n: usize, mut paths: Vec<RawPath>, ratio: f32) -> Vec<RawPath> {
    paths.sort_by(|a, b| polyline_length(&b.polyline).total_cmp(&polyline_length(&a.polyline)).then((a.from, a.to).cmp(&(b.from, b.to))));
    let mut k = 0;
    while k < paths.len() {
        let length = |p: &RawPath| polyline_length(&p.polyline);
        let arc = |x: usize, y: usize, paths: &[RawPath], skip: usize| {
            paths.iter().enumerate().filter(|&(m, _)| m != skip).find(|(_, p)| (p.from, p.to) == (x.min(y), x.max(y))).map(|(_, p)| length(p))
        };
        let (i, j, l) = (paths[k].from, paths[k].to, length(&paths[k]));
        let detour = (0..n).filter(|&m| m != i && m != j).any(|m| match (arc(i, m, &paths, k), arc(m, j, &paths, k)) {
            (Some(a), Some(b)) => a + b <= ratio * l,
            _ => false,
        });
        if detour {
            let mut without = paths.clone();
            without.remove(k);
            if components(n, &without) == components(n, &paths) {
                paths = without;
                continue;
            }
        }
        k += 1;
    }
    paths.sort_by_key(|p| (p.from, p.to));
    paths
}

/// Groups of probes joined by paths.
fn groups(n: usize, paths: &[RawPath]) -> UnionFind<usize> {
    let mut groups = UnionFind::new(n);
    for p in paths {
        groups.union(p.from, p.to);
    }
    groups
}

/// Connected components of probes joined by paths.
pub fn components(n: usize, paths: &[RawPath]) -> usize {
    let mut groups = groups(n, paths);
    (0..n).filter(|&x| groups.find_mut(x) == x).count()
}

/// The navigable 26-neighbours of voxel `i` and the cost of the step to each:
/// its length times 1 + r / clearance, so that routes keep to open space. A
/// diagonal step is taken only where the voxels it passes between are
/// navigable too (no cutting a wall's corner).
fn steps(space: &FreeSpace, i: usize) -> impl Iterator<Item = (usize, f32)> + '_ {
    steps_in(space, &space.navigable, i)
}

/// [`steps`] through the voxels of `mask`; a step onto a voxel that is not
/// navigable (gliding off walking height) costs [`GLIDE_COST`] times more.
fn steps_in<'a>(space: &'a FreeSpace, mask: &'a [bool], i: usize) -> impl Iterator<Item = (usize, f32)> + 'a {
    let g = &space.grid;
    let c = g.coords(i);
    // The voxel `c + d` with only the axes in `mask` moved, if in the grid.
    let at = move |d: [i64; 3], mask: usize| -> Option<usize> {
        let n: [usize; 3] = std::array::from_fn(|a| if mask >> a & 1 == 1 { c[a] as i64 + d[a] } else { c[a] as i64 } as usize);
        // (A step below 0 wraps to a huge index.)
        n.iter().zip(g.dims).all(|(&v, dim)| v < dim).then(|| g.index(n))
    };
    (0..27).filter(|&k| k != 13).filter_map(move |k| {
        let d = [k % 3, k / 3 % 3, k / 9].map(|x| x as i64 - 1);
        let moved = (0..3).filter(|&a| d[a] != 0).fold(0, |m, a| m | 1 << a);
        let j = at(d, moved).filter(|&j| mask[j])?;
        // Every voxel moved along fewer of the step's axes (none for a face step).
        let corners = (1..moved).filter(|&m| m & moved == m).all(|m| at(d, m).is_some_and(|v| mask[v]));
        let length = ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) as f32).sqrt() * g.voxel;
        let glide = if space.navigable[j] { 1.0 } else { GLIDE_COST };
        corners.then(|| (j, glide * length * (1.0 + space.near / space.clearance[j].max(1e-6))))
    })
}

/// Routes joining the groups of probes that `paths` leave apart, one per pair
/// of groups that must be joined, each the cheapest walk between any probe
/// of one and any of the other: a flood over navigable voxels from every
/// probe at once (Dijkstra, step costs as A*'s) gives each voxel its nearest
/// probe by walk; where two voxels of probes in different groups touch, a
/// route runs through them; the cheapest join groups first (Kruskal). Only
/// parts of the space (`parts`, per probe) holding probes of two groups or
/// more are flooded: the Crytek Sponza's 22 parts took 5 s, for no join.
/// Returns (probe, probe, polyline), the lower index first.
fn walks_between_groups(
    space: &FreeSpace,
    mask: &[bool],
    probes: &[Vec3],
    parts: &[Option<u32>],
    paths: &[RawPath],
) -> Vec<(usize, usize, Vec<Vec3>)> {
    let mut groups = groups(probes.len(), paths);
    let mut first_group: HashMap<u32, usize> = HashMap::new();
    let mut contested: Vec<u32> = Vec::new();
    for (k, part) in parts.iter().enumerate() {
        let Some(part) = *part else { continue };
        let group = groups.find_mut(k);
        if *first_group.entry(part).or_insert(group) != group && !contested.contains(&part) {
            contested.push(part);
        }
    }
    if contested.is_empty() {
        return Vec::new();
    }
    let g = &space.grid;
    let cells = g.dims.iter().product::<usize>();
    // Per voxel: cost from its nearest probe, that probe, the voxel before.
    let (mut cost, mut owner, mut parent) = (vec![f32::INFINITY; cells], vec![u32::MAX; cells], vec![u32::MAX; cells]);
    let mut open = BinaryHeap::new();
    for (k, &p) in probes.iter().enumerate().filter(|&(k, _)| parts[k].is_some_and(|part| contested.contains(&part))) {
        if let Some(i) = g.cell(p).map(|c| g.index(c)).filter(|&i| mask[i] && owner[i] == u32::MAX) {
            (cost[i], owner[i], parent[i]) = (0.0, k as u32, i as u32);
            open.push((Reverse(ordered(0.0)), i));
        }
    }
    while let Some((Reverse(key), i)) = open.pop() {
        if key > ordered(cost[i]) {
            continue; // a stale entry
        }
        for (j, step) in steps_in(space, mask, i) {
            if cost[i] + step < cost[j] {
                (cost[j], owner[j], parent[j]) = (cost[i] + step, owner[i], i as u32);
                open.push((Reverse(ordered(cost[j])), j));
            }
        }
    }
    // Where the floods of two groups meet: the cheapest crossing per pair of probes.
    let mut crossings: HashMap<(u32, u32), (f32, u32, u32)> = HashMap::new();
    for i in (0..cells).filter(|&i| owner[i] != u32::MAX) {
        for (j, step) in steps_in(space, mask, i) {
            let (a, b) = (owner[i], owner[j]);
            if a < b && groups.find_mut(a as usize) != groups.find_mut(b as usize) {
                let total = cost[i] + step + cost[j];
                let best = crossings.entry((a, b)).or_insert((f32::INFINITY, 0, 0));
                if total < best.0 {
                    *best = (total, i as u32, j as u32);
                }
            }
        }
    }
    let mut crossings: Vec<_> = crossings.into_iter().collect();
    crossings.sort_by(|x, y| x.1 .0.total_cmp(&y.1 .0).then(x.0.cmp(&y.0)));
    let back = |mut i: usize| {
        let mut chain = vec![i];
        while parent[i] as usize != i {
            i = parent[i] as usize;
            chain.push(i);
        }
        chain
    };
    let mut joins = Vec::new();
    for ((a, b), (_, i, j)) in crossings {
        let (a, b) = (a as usize, b as usize);
        if groups.find_mut(a) == groups.find_mut(b) {
            continue;
        }
        groups.union(a, b);
        // a's probe, the voxels from its own (left out: the probe stands
        // there) to i, from j to b's (left out), b's probe.
        let (mut from_a, from_b) = (back(i as usize), back(j as usize));
        from_a.reverse();
        let inner = from_a.iter().skip(1).chain(from_b.iter().take(from_b.len() - 1));
        let polyline = std::iter::once(probes[a]).chain(inner.map(|&c| g.center(g.coords(c)))).chain(std::iter::once(probes[b])).collect();
        joins.push((a, b, polyline));
    }
    joins
}

/// A* over navigable voxels from the voxel of `a` to that of `b`; the polyline
/// runs a → voxel centres → b. Step cost: length × (1 + r / clearance).
fn a_star(space: &FreeSpace, a: Vec3, b: Vec3) -> Option<Vec<Vec3>> {
    let g = &space.grid;
    let (start, goal) = (g.index(g.cell(a)?), g.index(g.cell(b)?));
    if !space.navigable[start] || !space.navigable[goal] {
        return None;
    }
    // The heuristic is inflated by half: a slightly longer route (smoothing
    // straightens it) for a search that goes to the goal instead of flooding rooms.
    let h = |i: usize| 1.5 * (g.center(g.coords(i)) - b).length();
    // Per visited voxel: cost so far, parent, expanded. A map, not grid-sized
    // arrays: a search visits a sliver of a fine grid (tens of millions of cells).
    let mut state: FxHashMap<usize, (f32, u32, bool)> = FxHashMap::default();
    state.insert(start, (0.0, start as u32, false));
    let mut open = BinaryHeap::from([(Reverse(ordered(h(start))), start)]);
    while let Some((Reverse(key), i)) = open.pop() {
        let here = state.get_mut(&i).expect("queued voxels have a state");
        if here.2 || key > ordered(here.0 + h(i)) {
            continue; // expanded already, or a stale entry
        }
        here.2 = true;
        let cost_i = here.0;
        if i == goal {
            let mut cells = vec![goal];
            loop {
                let last = *cells.last().unwrap();
                let up = state[&last].1 as usize;
                if up == last {
                    break;
                }
                cells.push(up);
            }
            cells.reverse();
            let mut polyline = vec![a];
            polyline.extend(cells.iter().skip(1).take(cells.len().saturating_sub(2)).map(|&c| g.center(g.coords(c))));
            polyline.push(b);
            return Some(polyline);
        }
        for (j, step) in steps(space, i) {
            let through = cost_i + step;
            let there = state.entry(j).or_insert((f32::INFINITY, u32::MAX, false));
            if !there.2 && through < there.0 {
                *there = (through, i as u32, false);
                open.push((Reverse(ordered(through + h(j))), j));
            }
        }
    }
    None
}

/// f32 as a totally ordered integer key (costs are non-negative).
fn ordered(x: f32) -> u32 {
    x.max(0.0).to_bits()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::freespace::{free_space, FreeSpaceParams, HeightMode, SpaceMode};
    use crate::testing::rooms;

    fn setup(scene: &exploremaps_scenes::Scene) -> (RayScene, FreeSpace) {
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let (space, _) =
            free_space(scene, &rays, &FreeSpaceParams { space: SpaceMode::Inside, height: HeightMode::Fly, ..Default::default() }).unwrap();
        (rays, space)
    }

    #[test]
    fn two_rooms_with_a_door_connect_through_the_door() {
        let scene = rooms(2, 6.0, 3.0, 6.0, &[1]);
        let (rays, space) = setup(&scene);
        // Probes off the door's line: no straight path.
        let probes = [Vec3::new(2.0, 1.5, 1.0), Vec3::new(10.0, 1.5, 5.0)];
        let (paths, stats) = connect(&rays, &space, &probes, &ConnectParams::default());
        assert_eq!(paths.len(), 1, "{stats:?}");
        let p = &paths[0].polyline;
        // The path crosses the wall at x = 6 inside the door (z ∈ [2.4, 3.6], y < 2.2).
        let crossing = p.windows(2).find(|w| (w[0].x - 6.0) * (w[1].x - 6.0) <= 0.0).expect("crosses x = 6");
        let t = (6.0 - crossing[0].x) / (crossing[1].x - crossing[0].x);
        let at = crossing[0] + (crossing[1] - crossing[0]) * t;
        assert!(at.z > 2.4 && at.z < 3.6 && at.y < 2.2, "crosses the wall at {at}, not through the door");
        for w in p.windows(2) {
            assert!(segment_clear(&rays, &space, w[0], w[1]), "segment {w:?} is not clear");
        }
        assert_eq!(stats.components, 1);
    }

    #[test]
    fn sealed_rooms_stay_unconnected_and_are_reported() {
        let scene = rooms(2, 6.0, 3.0, 6.0, &[]);
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        // Both rooms navigable: take one, then the other, by start point, and pool them.
        let (a, _) =
            free_space(&scene, &rays, &FreeSpaceParams { space: SpaceMode::Inside, start: Some(Vec3::new(3.0, 1.5, 3.0)), ..Default::default() })
                .unwrap();
        let (paths, stats) = connect(&rays, &a, &[Vec3::new(2.0, 1.5, 3.0), Vec3::new(10.0, 1.5, 3.0)], &ConnectParams::default());
        assert!(paths.is_empty());
        assert_eq!(stats.components, 2);
    }

    #[test]
    fn a_star_goes_around_a_pillar_with_clearance() {
        let scene = crate::testing::pillar_room(1.0);
        let (rays, space) = setup(&scene);
        let path = a_star(&space, Vec3::new(2.0, 1.5, 3.0), Vec3::new(8.0, 1.5, 3.0)).expect("a route around the pillar");
        assert!(path.iter().all(|p| ((p.x - 5.0).powi(2) + (p.z - 3.0).powi(2)).sqrt() > 1.0 + space.near * 0.9), "too close to the pillar");
        assert!(path.windows(2).all(|w| !rays.occluded(&Ray::segment(w[0], w[1]))));
    }

    #[test]
    fn maze_paths_exist_stay_in_the_corridors_and_are_deterministic() {
        use crate::plan::explore::{explore, ExploreParams};
        use crate::plan::smooth::smooth;
        let scene = exploremaps_scenes::BuiltIn::Maze(5).generate(3);
        let (rays, space) = setup(&scene);
        let (candidates, _) = explore(&scene, &rays, &space, &ExploreParams::default());
        let probes: Vec<Vec3> = candidates.iter().map(|c| c.position).collect();
        let (paths, stats) = connect(&rays, &space, &probes, &ConnectParams::default());
        assert!(probes.len() >= 3 && !paths.is_empty(), "{stats:?}");
        assert_eq!(stats.components, 1, "the maze is one corridor system: {stats:?}");
        for p in &paths {
            let (smoothed, s) = smooth(&rays, &space, &p.polyline);
            assert_eq!(s.blocked_segments, 0);
            assert!(s.min_clearance >= space.near, "{s:?}");
            for w in smoothed.windows(2) {
                assert!(segment_clear(&rays, &space, w[0], w[1]), "a smoothed segment leaves the corridors");
            }
        }
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let (again, _) = one.install(|| connect(&rays, &space, &probes, &ConnectParams::default()));
        assert_eq!(again, paths);
    }

    #[test]
    fn witnesses_grow_with_the_probes() {
        // The maze's probes with one witness asked for: the floor of 16 a probe still joins them.
        let scene = exploremaps_scenes::BuiltIn::Maze(5).generate(3);
        let (rays, space) = setup(&scene);
        let (candidates, _) = crate::plan::explore::explore(&scene, &rays, &space, &crate::plan::explore::ExploreParams::default());
        let probes: Vec<Vec3> = candidates.iter().map(|c| c.position).collect();
        let (_, stats) = connect(&rays, &space, &probes, &ConnectParams { witness_points: 1, ..Default::default() });
        assert_eq!(stats.components, 1, "{} probes: {stats:?}", probes.len());
    }

    #[test]
    fn probes_that_share_no_view_are_joined_through_the_corridors() {
        // The maze's two navigable points farthest apart see no witness in
        // common (corridors turn between them); A* joins them all the same.
        let scene = exploremaps_scenes::BuiltIn::Maze(5).generate(3);
        let (rays, space) = setup(&scene);
        let points = space.navigable_points();
        let far = |from: Vec3| *points.iter().max_by(|a, b| (**a - from).length().total_cmp(&(**b - from).length())).unwrap();
        let a = far(points[0]);
        let probes = [a, far(a)];
        let (paths, stats) = connect(&rays, &space, &probes, &ConnectParams::default());
        assert_eq!((stats.pairs_sharing_view, stats.joined, stats.components), (0, 1, 1), "{stats:?}");
        let p = &paths[0].polyline;
        assert!(polyline_length(p) > 1.5 * (probes[1] - probes[0]).length(), "the route winds through the corridors");
        for w in p.windows(2) {
            assert!(segment_clear(&rays, &space, w[0], w[1]), "a joining segment leaves the corridors");
        }
    }

    #[test]
    fn a_clear_segment_clips_no_corner_of_the_walls() {
        // Segments between random navigable points of the maze: where one is
        // called clear, points a fiftieth of a voxel apart along it are all navigable.
        use rand::{Rng, SeedableRng};
        let scene = exploremaps_scenes::BuiltIn::Maze(5).generate(3);
        let (rays, space) = setup(&scene);
        let points = space.navigable_points();
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut clear = 0;
        for _ in 0..3000 {
            let a = points[rng.random_range(0..points.len())];
            let b = a + (points[rng.random_range(0..points.len())] - a).clamp_length_max(2.0);
            if !segment_clear(&rays, &space, a, b) {
                continue;
            }
            clear += 1;
            let n = ((b - a).length() / space.grid.voxel * 50.0).ceil() as usize;
            for k in 0..=n {
                let p = a + (b - a) * (k as f32 / n as f32);
                assert!(space.is_navigable(p), "{a} -> {b} is called clear but leaves navigable space at {p}");
            }
        }
        assert!(clear > 300, "{clear} clear segments");
    }

    #[test]
    fn route_steps_cut_no_corner() {
        // Every step A* and the joining flood may take, from every tenth
        // navigable voxel of the maze, runs through navigable voxels only.
        let scene = exploremaps_scenes::BuiltIn::Maze(5).generate(3);
        let (_, space) = setup(&scene);
        let g = &space.grid;
        let mut diagonal = 0;
        for i in (0..g.len()).filter(|&i| space.navigable[i]).step_by(10) {
            for (j, _) in steps(&space, i) {
                let (a, b) = (g.center(g.coords(i)), g.center(g.coords(j)));
                assert!(space.segment_navigable(a, b), "the step {a} -> {b} cuts a corner");
                diagonal += usize::from((a - b).length() > 1.5 * g.voxel);
            }
        }
        assert!(diagonal > 1000, "{diagonal} diagonal steps");
    }

    #[test]
    fn redundant_arcs_are_pruned_without_disconnecting() {
        // Three probes in a row: the long arc 0-2 has a detour via 1 of the same length.
        let line = |a: f32, b: f32, from, to| RawPath { from, to, polyline: vec![Vec3::new(a, 0.0, 0.0), Vec3::new(b, 0.0, 0.0)] };
        let paths = vec![line(0.0, 1.0, 0, 1), line(1.0, 2.0, 1, 2), line(0.0, 2.0, 0, 2)];
        let kept = prune(3, paths, 1.25);
        assert_eq!(kept.iter().map(|p| (p.from, p.to)).collect::<Vec<_>>(), vec![(0, 1), (1, 2)]);
        assert_eq!(components(3, &kept), 1);
    }
}

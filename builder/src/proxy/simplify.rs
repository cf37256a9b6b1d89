//! Simplify: edge collapses ordered by the quadric error metric (Garland and
//! Heckbert, "Surface Simplification Using Quadric Error Metrics", SIGGRAPH 1997).
//!
//! Each vertex carries the sum of the squared-distance quadrics of its
//! triangles' planes, weighted by the square root of their area (by area, one
//! large wall outweighed a small feature's planes so much that flattening it
//! looked free; the bench measured twice the Hausdorff error on the Dabrovic
//! Sponza at half its triangles). Along boundary edges, and along edges
//! where two groups (materials) meet, a plane perpendicular to the triangle
//! through the edge is added with a large weight, so outlines and material
//! borders stay where they are. An edge collapses to the point minimising the
//! sum of its ends' quadrics (a 3 × 3 solve), or, when that system is
//! singular (a flat or straight neighbourhood), to the best of its ends and
//! its midpoint. Collapses go cheapest first by the error as a distance: the
//! square root of the two ends' summed quadric over the weight it was built
//! from, a mean squared distance to the planes the new vertex stands for.
//! (The larger of the two ends' own errors was used before: it held back
//! collapses into vertices that had already moved, and left the Dabrovic
//! Sponza's arcades as pointed spans at 2 % of the triangles.)
//!
//! Colour (optional, one RGB value a vertex) counts too, as in Garland and
//! Heckbert's 1998 extension for attributes in Hoppe's compact form ("New
//! quadric metric for simplifying meshes with appearance attributes", 1999):
//! each triangle's colour, as a linear function over its plane, adds the
//! squared difference between that function and the vertex's colour
//! (weighted, so a unit of colour counts as a given distance). The colour of
//! the new vertex is the one minimising it, which leaves a 3 × 3 quadric in
//! position, so placement is solved as before, and a collapse costs that
//! quadric's error at the placement. (Each end's own quadric with its own
//! best colour was summed before: it undercounted a colour change across the
//! edge, and cost a second evaluation and 88 bytes a vertex.) The error
//! reported stays geometric.
//!
//! A collapse is refused when it would flip or nearly flatten a triangle
//! around it (or turn it past 90° from its input normal), when the edge's
//! ends share neighbours other than the third corners of the triangles on
//! the edge (the link condition: collapsing would pinch the surface into a
//! non-manifold fan), or when a triangle would land on another. Non-manifold
//! input (an edge on three or more triangles, such as a wall meeting a floor
//! that runs on under it) keeps its shape: its edges get boundary planes, so
//! the crease stays where it is, but an edge along it collapses like any
//! other, deleting every triangle on it (the Dabrovic Sponza has 472 such
//! vertices; held fixed, they kept a fifth of its 2 % level's vertices in
//! place and doubled its distance to the input). Connected parts whose bounding
//! box diagonal is under the current error are removed whole when their turn
//! comes, since collapsing them would leave slivers. Every collapse is
//! recorded ([`Collapse`]) so [`super::progressive`] can undo them in order.

use super::Mesh;
use dary_heap::OctonaryHeap as BinaryHeap;
use glam::{DMat3, DVec3, Vec3, Vec4};
use rayon::prelude::*;
use smallvec::SmallVec;
use std::cmp::Reverse;

/// A vertex's neighbours or triangles: a handful, kept off the allocator on
/// the hot path.
type Few = SmallVec<[u32; 32]>;

/// Weight of boundary and group-border planes, relative to the triangles'
/// (times the edge's length, as theirs are the square root of an area).
const BORDER_WEIGHT: f64 = 10.0;
/// Smallest cosine between a triangle's normal before and after a collapse.
const MIN_NORMAL_COSINE: f32 = 0.2;
/// A collapse costs at least this share of how far it moves off the plane
/// of a face around it. All of it made the greedy order too timid (the
/// bunny's 50 % level and the Dabrovic Sponza's 1 % level farther from their
/// input than meshoptimizer's, and 1.7 times the time); half keeps every
/// level of the proxy bench's four scenes within 3 % of meshoptimizer's
/// distances or closer (docs/2026-12-06-measurement-history.md, proxy figures).
const FARTHEST_PLANE_SHARE: f32 = 0.5;
/// Most triangles on an edge that collapses (a split record brings back at
/// most 255; real non-manifold edges carry three or four).
const MAX_EDGE_TRIANGLES: usize = 16;
/// Passes over all edges at most (the first does nearly all the work).
const ROUNDS: usize = 8;
/// The stamp of a vertex collapsed away.
const DEAD: u32 = u32::MAX;

/// When simplification stops: at `target_triangles`, or before the first
/// collapse whose error exceeds `max_error` (scene units, colour's share
/// included when colour counts), whichever is first.
#[derive(Clone, Copy, Debug)]
pub struct SimplifyParams {
    pub target_triangles: usize,
    pub max_error: f32,
}

/// One collapse: `removed` merged into `kept`, which moved from `kept_was` to
/// its new position. `moved` triangles had `removed` as a corner and now have
/// `kept`; `deleted` triangles (with their corners as they were) vanished.
#[derive(Clone, Debug, PartialEq)]
pub struct Collapse {
    pub kept: u32,
    pub removed: u32,
    pub kept_was: Vec3,
    pub kept_now: Vec3,
    pub moved: Vec<u32>,
    pub deleted: Vec<(u32, [u32; 3])>,
}

/// One step of simplification, in the order taken.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    Collapse(Collapse),
    /// A connected part removed whole: its triangles and their corners.
    Prune(Vec<(u32, [u32; 3])>),
}

/// Per-vertex colours for a colour-aware simplification: `weight` is the
/// distance (scene units) a colour difference of 1 counts as.
#[derive(Clone, Copy, Debug)]
pub struct Colours<'a> {
    pub values: &'a [Vec3],
    pub weight: f32,
}

/// The result: the simplified mesh (its triangles keep their input order; its
/// vertices are the input's, unused ones left in place), the collapses that
/// made it, and the largest error of any collapse taken.
pub struct Simplified {
    pub mesh: Mesh,
    /// Per input triangle: still there.
    pub alive: Vec<bool>,
    pub steps: Vec<Step>,
    pub error: f32,
    /// Per vertex of `mesh`, with [`simplify_with_colours`]: its colour now.
    pub colours: Vec<Vec3>,
}

impl Simplified {
    /// The surviving triangles, in input order.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        self.mesh.triangles.iter().zip(&self.alive).filter(|(_, &a)| a).map(|(t, _)| *t).collect()
    }

    /// The simplified mesh compacted: used vertices only, surviving triangles.
    pub fn compact(&self) -> Mesh {
        self.compact_with_colours().0
    }

    /// [`Self::compact`] and its vertices' colours (empty without colours).
    pub fn compact_with_colours(&self) -> (Mesh, Vec<Vec3>) {
        let alive: Vec<usize> = (0..self.mesh.triangles.len()).filter(|&t| self.alive[t]).collect();
        let (mesh, was) = self.mesh.subset(&alive);
        let colours = if self.colours.is_empty() { Vec::new() } else { was.iter().map(|&v| self.colours[v as usize]).collect() };
        (mesh, colours)
    }
}

/// A symmetric 4 × 4 quadric: error(p) = pᵀAp + 2b·p + c, and the weight it sums.
#[derive(Clone, Copy, Debug, Default)]
struct Quadric {
    a: [f64; 6],
    b: DVec3,
    c: f64,
    weight: f64,
}

impl Quadric {
    /// The plane n·p + d = 0 (n unit), weighted.
    fn plane(n: DVec3, d: f64, w: f64) -> Quadric {
        Quadric {
            a: [n.x * n.x * w, n.x * n.y * w, n.x * n.z * w, n.y * n.y * w, n.y * n.z * w, n.z * n.z * w],
            b: n * d * w,
            c: d * d * w,
            weight: w,
        }
    }

    fn add(&mut self, o: &Quadric) {
        for (x, y) in self.a.iter_mut().zip(o.a) {
            *x += y;
        }
        self.b += o.b;
        self.c += o.c;
        self.weight += o.weight;
    }

    fn error(&self, p: DVec3) -> f64 {
        let a = &self.a;
        let ap = DVec3::new(a[0] * p.x + a[1] * p.y + a[2] * p.z, a[1] * p.x + a[3] * p.y + a[4] * p.z, a[2] * p.x + a[4] * p.y + a[5] * p.z);
        (p.dot(ap + 2.0 * self.b) + self.c).max(0.0)
    }

    /// The error at p as a distance: the root mean square distance to the
    /// planes summed, by their weight (a colour part adds none).
    fn distance(&self, p: DVec3) -> f32 {
        (self.error(p) / self.weight.max(1e-30)).sqrt() as f32
    }

    /// The minimising point, if the system is well conditioned.
    fn optimum(&self) -> Option<DVec3> {
        // Cramer's rule on the symmetric matrix (its cofactors, once).
        let a = &self.a;
        let c = DVec3::new(a[3] * a[5] - a[4] * a[4], a[2] * a[4] - a[1] * a[5], a[1] * a[4] - a[2] * a[3]);
        let det = a[0] * c.x + a[1] * c.y + a[2] * c.z;
        // Relative to the scale of the entries: a flat or straight neighbourhood is singular.
        let scale = a[0] + a[3] + a[5];
        if scale <= 0.0 || det.abs() <= 1e-9 * scale * scale * scale {
            return None;
        }
        let adjugate = DMat3::from_cols(
            c,
            DVec3::new(c.y, a[0] * a[5] - a[2] * a[2], a[1] * a[2] - a[0] * a[4]),
            DVec3::new(c.z, a[1] * a[2] - a[0] * a[4], a[0] * a[3] - a[1] * a[1]),
        );
        let p = adjugate * -self.b / det;
        p.is_finite().then_some(p)
    }
}

/// The colour part of a vertex's quadric over (position p, colour s):
/// Σ w (gⱼ·p + dⱼ − sⱼ)² over its triangles and the channels j, kept as its
/// position-only terms, the cross terms hⱼ = −Σ w gⱼ, the
/// colour's linear terms `bs` = −Σ w dⱼ, and `w` = Σ w (each channel's
/// squared term).
#[derive(Clone, Copy, Debug, Default)]
struct ColourQuadric {
    /// Its terms in position alone (of no weight: the geometry's weighs).
    position: Quadric,
    h: [DVec3; 3],
    bs: DVec3,
    w: f64,
}

impl ColourQuadric {
    /// A triangle's: corners `p`, their colours `s` (already weighted),
    /// plane normal `n` (unit), weight `w`. None for a degenerate triangle.
    fn triangle(p: [DVec3; 3], s: [DVec3; 3], n: DVec3, w: f64) -> Option<ColourQuadric> {
        // Per channel the gradient g in the plane with g·(pᵢ − p₀) = sᵢ − s₀.
        let rows = DMat3::from_cols(p[1] - p[0], p[2] - p[0], n).transpose();
        if rows.determinant().abs() <= 1e-30 {
            return None;
        }
        let inverse = rows.inverse();
        // Per channel: the gradient g and offset d, colour = g·p + d.
        let channels: [(DVec3, f64); 3] = std::array::from_fn(|j| {
            let g = inverse * DVec3::new(s[1][j] - s[0][j], s[2][j] - s[0][j], 0.0);
            (g, s[0][j] - g.dot(p[0]))
        });
        let mut q = ColourQuadric { h: channels.map(|(g, _)| -w * g), bs: DVec3::from(channels.map(|(_, d)| -w * d)), w, ..Default::default() };
        for (g, d) in channels {
            q.position.add(&Quadric { weight: 0.0, ..Quadric::plane(g, d, w) });
        }
        Some(q)
    }

    fn add(&mut self, o: &ColourQuadric) {
        self.position.add(&o.position);
        for j in 0..3 {
            self.h[j] += o.h[j];
        }
        self.bs += o.bs;
        self.w += o.w;
    }

    /// The best colour at position p.
    fn colour(&self, p: DVec3) -> DVec3 {
        if self.w <= 0.0 {
            return DVec3::ZERO;
        }
        -DVec3::new(self.h[0].dot(p) + self.bs.x, self.h[1].dot(p) + self.bs.y, self.h[2].dot(p) + self.bs.z) / self.w
    }

    /// The error with the best colour at each position, as a position-only
    /// quadric of no weight (the Schur complement of the colour block).
    fn reduced(&self) -> Quadric {
        let mut q = self.position;
        if self.w > 0.0 {
            // One division, not thirty: this runs at every cost.
            let inverse = 1.0 / self.w;
            for j in 0..3 {
                let (h, bs) = (self.h[j], self.bs[j]);
                let hw = h * inverse;
                let outer = [hw.x * h.x, hw.x * h.y, hw.x * h.z, hw.y * h.y, hw.y * h.z, hw.z * h.z];
                for (x, y) in q.a.iter_mut().zip(outer) {
                    *x -= y;
                }
                q.b -= hw * bs;
                q.c -= bs * bs * inverse;
            }
        }
        q
    }
}

fn normal(p: [Vec3; 3]) -> Vec3 {
    (p[1] - p[0]).cross(p[2] - p[0])
}

/// A triangle's plane: unit normal and offset (zero if it has no area).
fn plane_of(p: [Vec3; 3]) -> Vec4 {
    let n = normal(p).normalize_or_zero();
    n.extend(-n.dot(p[0]))
}

#[derive(Clone)]
struct State<'a> {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    groups: &'a [u32],
    alive: Vec<bool>,
    /// Per vertex: its triangles (some may be dead), held inline for most
    /// vertices: one cache miss less a vertex on the hot path (the loop
    /// took a tenth less time on the Crytek Sponza).
    around: Vec<SmallVec<[u32; 8]>>,
    quadrics: Vec<Quadric>,
    /// Per vertex, with colours: the colour part of its quadric, and its colour
    /// (weighted, as the quadric sees it).
    colour_quadrics: Vec<ColourQuadric>,
    colours: Vec<DVec3>,
    /// Bumped whenever a vertex's neighbourhood changes; queue entries carry
    /// it. [`DEAD`] once the vertex is collapsed away (one array to read
    /// for both: checking popped entries is on the hot path).
    stamp: Vec<u32>,
    /// Per vertex: its part (connected component), for pruning.
    part: Vec<u32>,
    /// Per triangle: its input normal (no collapse may turn it past 90°,
    /// however small each step).
    input_normals: Vec<Vec3>,
    /// Per triangle: its plane now (unit normal, offset; zero if degenerate).
    planes: Vec<Vec4>,
}

enum Job {
    /// An edge (a, b) with the sum of both stamps when its cost was found
    /// (stamps only grow, so an equal sum means neither changed).
    Edge(u32, u32, u32),
    Part(u32),
}

/// A queue entry packed in 16 bytes, smallest cost first: the queue holds
/// millions of entries and popping them dominated the run at 32 bytes each
/// in a binary heap (hence also an 8-ary heap: half as many cache misses).
#[derive(PartialEq, Eq, PartialOrd, Ord, Default)]
struct Entry(u128);

impl Entry {
    /// Costs are non-negative, so their bits order like their values.
    fn new(cost: f32, job: Job) -> Reverse<Entry> {
        let (a, b, c) = match job {
            Job::Edge(a, b, stamps) => (a, b, stamps),
            Job::Part(i) => (i, u32::MAX, 0),
        };
        Reverse(Entry((cost.to_bits() as u128) << 96 | (a as u128) << 64 | (b as u128) << 32 | c as u128))
    }
    fn cost(&self) -> f32 {
        f32::from_bits((self.0 >> 96) as u32)
    }
    fn job(&self) -> Job {
        let (a, b, c) = ((self.0 >> 64) as u32, (self.0 >> 32) as u32, self.0 as u32);
        if b == u32::MAX {
            Job::Part(a)
        } else {
            Job::Edge(a, b, c)
        }
    }
}

/// The queue of collapses: a small heap of the entries up to a threshold,
/// and the rest unsorted. Each collapse outdates the entries of a dozen
/// edges; in one heap of every entry, popping those dominated the run. Here
/// they are mostly dropped in bulk, in the sequential scan that refills the
/// heap from the rest, and the heap stays small enough for the cache. Pops
/// come out in exactly the order one heap would give.
#[derive(Default)]
struct Queue {
    heap: BinaryHeap<Reverse<Entry>>,
    /// Entries above `threshold` (any order).
    rest: Vec<Reverse<Entry>>,
    /// Every entry in `heap` is at most this, every entry in `rest` above it.
    threshold: Entry,
}

/// Entries a refill moves into the heap, at least (and a quarter of the rest).
const REFILL: usize = 4096;

impl Queue {
    fn push(&mut self, entry: Reverse<Entry>) {
        if entry.0 <= self.threshold {
            self.heap.push(entry);
        } else {
            self.rest.push(entry);
        }
    }

    /// The cheapest entry, if it costs at most `limit` (else it stays);
    /// `valid` says which entries of the rest are still worth keeping when
    /// the heap runs dry.
    fn pop_up_to(&mut self, limit: f32, valid: impl Fn(&Entry) -> bool) -> Option<Entry> {
        if self.heap.is_empty() {
            self.refill(valid);
        }
        if self.heap.peek()?.0.cost() > limit {
            return None;
        }
        self.heap.pop().map(|Reverse(e)| e)
    }

    fn is_empty(&self) -> bool {
        self.heap.is_empty() && self.rest.is_empty()
    }

    /// Drops the invalid entries of the rest and moves its cheapest into the heap.
    fn refill(&mut self, valid: impl Fn(&Entry) -> bool) {
        self.rest.retain(|Reverse(e)| valid(e));
        if self.rest.is_empty() {
            return;
        }
        let take = (self.rest.len() / 4).max(REFILL).min(self.rest.len());
        if take < self.rest.len() {
            // Reverse(e) orders largest first: the `take` smallest go last.
            let at = self.rest.len() - take;
            self.rest.select_nth_unstable(at);
        }
        let moved = self.rest.split_off(self.rest.len() - take);
        self.threshold = Entry(moved.iter().map(|Reverse(e)| e.0).max().expect("not empty"));
        let mut all = std::mem::take(&mut self.heap).into_vec();
        all.extend(moved);
        self.heap = BinaryHeap::from(all);
    }

    /// Adds many entries at once (then the heap is made anew).
    fn extend(&mut self, entries: Vec<Reverse<Entry>>) {
        let heap = std::mem::take(&mut self.heap).into_vec();
        self.rest.extend(heap);
        self.rest.extend(entries);
        self.refill(|_| true);
    }
}

/// Simplifies `mesh` (welded: neighbouring triangles share vertex indices).
pub fn simplify(mesh: &Mesh, params: &SimplifyParams) -> Simplified {
    simplify_with_colours(mesh, None, params)
}

/// Meshes at least this large are first simplified as two halves at once
/// (see [`halves`]); below it the second core would not pay for itself.
const HALVES_ABOVE: usize = 20_000;
/// ... and at most this large: each half has its own copy of the state,
/// about 450 bytes a vertex with colour (1 GB more at 4 M triangles).
const HALVES_UP_TO: usize = 4_000_000;

/// [`simplify`], keeping colour too when `colours` are given (one a vertex).
pub fn simplify_with_colours(mesh: &Mesh, colours: Option<Colours>, params: &SimplifyParams) -> Simplified {
    simplify_halves_above(mesh, colours, params, HALVES_ABOVE)
}

/// [`simplify_with_colours`], in halves first when the mesh has at least
/// `halves_above` triangles (tests set it low).
fn simplify_halves_above(mesh: &Mesh, colours: Option<Colours>, params: &SimplifyParams, halves_above: usize) -> Simplified {
    let n = mesh.positions.len();
    let colours = colours.filter(|c| c.values.len() == n && c.weight > 0.0);
    let mut s = State::new(mesh, colours);
    let parts = s.label_parts();
    let mut done = Done { live: mesh.triangles.len(), steps: Vec::new(), error: 0.0 };
    let greedy = Greedy {
        parts: &parts,
        // The largest part is never pruned: a mesh does not vanish.
        largest: (0..parts.len()).max_by(|&a, &b| parts[a].0.total_cmp(&parts[b].0)),
        frozen: Vec::new(),
    };
    if (halves_above..=HALVES_UP_TO).contains(&mesh.triangles.len()) {
        s = halves(s, &greedy, params, &mut done);
    }
    // A refused collapse may become possible once its neighbours change: a
    // few more rounds over every edge pick those up.
    for _ in 0..ROUNDS {
        let before = done.live;
        let mut queue = Queue::default();
        queue.extend(greedy.entries(&s));
        if greedy.run(&mut s, &mut queue, params.max_error, params.target_triangles, &mut done) == Stop::Limit {
            break;
        }
        if done.live <= params.target_triangles || done.live == before {
            break;
        }
    }
    let colours = colours.map(|c| s.colours.iter().map(|v| (*v / c.weight as f64).as_vec3()).collect()).unwrap_or_default();
    Simplified {
        mesh: Mesh { positions: s.positions, triangles: s.triangles, groups: mesh.groups.clone() },
        alive: s.alive,
        steps: done.steps,
        error: done.error,
        colours,
    }
}

/// What the collapses so far did: live triangles, the steps and the
/// largest geometric error.
struct Done {
    live: usize,
    steps: Vec<Step>,
    error: f32,
}

/// Why [`Greedy::run`] stopped.
#[derive(PartialEq, Debug)]
enum Stop {
    /// The floor of live triangles was reached.
    Floor,
    /// The cheapest entry left costs more than the limit (it stays queued).
    Limit,
    /// Nothing is left to try.
    Empty,
}

/// The greedy collapse loop and what it needs besides the state.
struct Greedy<'p> {
    /// Connected parts (diagonal, triangles), for pruning.
    parts: &'p [(f32, Vec<u32>)],
    largest: Option<usize>,
    /// Per vertex: not to be moved (none when empty).
    frozen: Vec<bool>,
}

impl Greedy<'_> {
    fn frozen(&self, v: u32) -> bool {
        self.frozen.get(v as usize).copied().unwrap_or(false)
    }

    /// Every live edge's cost (in parallel, in edge order) and the parts,
    /// but for edges and parts with a frozen vertex.
    fn entries(&self, s: &State) -> Vec<Reverse<Entry>> {
        let free = |v: &u32| !self.frozen(*v);
        // Removing a part moves its surface by up to half its diagonal.
        let parts = self.parts.iter().enumerate().filter(|(_, (_, tris))| tris.iter().all(|&t| s.triangles[t as usize].iter().all(free)));
        let mut entries: Vec<Reverse<Entry>> = parts.map(|(i, (diagonal, _))| Entry::new(0.5 * diagonal, Job::Part(i as u32))).collect();
        entries.par_extend(
            s.edges()
                .par_iter()
                .filter(|(a, b)| free(a) && free(b))
                .filter_map(|&(a, b)| Some(Entry::new(s.cost(a, b)?, Job::Edge(a, b, s.stamps(a, b))))),
        );
        entries
    }

    /// Takes the cheapest collapses from `queue` until `done.live` reaches
    /// `floor` or the cheapest left costs more than `limit`.
    fn run(&self, s: &mut State, queue: &mut Queue, limit: f32, floor: usize, done: &mut Done) -> Stop {
        while done.live > floor {
            // Entries whose edge lost an end or changed since are dropped.
            let valid = |e: &Entry| match e.job() {
                Job::Edge(a, b, stamped) => s.unchanged(a, b, stamped),
                Job::Part(_) => true,
            };
            let Some(entry) = queue.pop_up_to(limit, valid) else {
                return if queue.is_empty() { Stop::Empty } else { Stop::Limit };
            };
            let (cost, job) = (entry.cost(), entry.job());
            match job {
                Job::Edge(a, b, stamped) => {
                    if !s.unchanged(a, b, stamped) {
                        continue;
                    }
                    let Some((target, _)) = s.placement(a, b) else { continue };
                    let (kept, removed) = (a, b);
                    // The quadric's error is a mean over the planes both
                    // ends stand for, so a small face (a slab's end) weighs
                    // little in it and moving far off it can look cheap.
                    // The farthest plane of the faces around the edge is how
                    // far this step moves off the surface: an entry whose
                    // cost is below its share of that goes back at that
                    // cost (popped again with nothing changed, it is taken).
                    let off = FARTHEST_PLANE_SHARE * s.farthest_plane(kept, removed, target);
                    if off > cost {
                        queue.push(Entry::new(off, Job::Edge(a, b, stamped)));
                        continue;
                    }
                    if !s.can_collapse(kept, removed, target) {
                        continue;
                    }
                    // The error reported is geometric (cost may include colour).
                    done.error = done.error.max(if s.colour_quadrics.is_empty() { cost } else { s.geometric_error(kept, removed, target) });
                    let c = s.collapse(kept, removed, target);
                    done.live -= c.deleted.len();
                    done.steps.push(Step::Collapse(c));
                    for w in s.neighbours(kept) {
                        if self.frozen(w) {
                            continue;
                        }
                        if let Some(cost) = s.cost(kept, w) {
                            let (x, y) = (kept.min(w), kept.max(w));
                            queue.push(Entry::new(cost, Job::Edge(x, y, s.stamps(x, y))));
                        }
                    }
                }
                Job::Part(i) if Some(i as usize) != self.largest => {
                    let mut pruned = Vec::new();
                    for &t in &self.parts[i as usize].1 {
                        if s.alive[t as usize] {
                            s.alive[t as usize] = false;
                            pruned.push((t, s.triangles[t as usize]));
                        }
                    }
                    if !pruned.is_empty() {
                        done.live -= pruned.len();
                        done.steps.push(Step::Prune(pruned));
                        done.error = done.error.max(cost);
                    }
                }
                Job::Part(_) => {}
            }
        }
        Stop::Floor
    }
}

/// First cost threshold of [`halves`], in diagonals, and its growth a round.
const FIRST_THRESHOLD: f32 = 1e-7;
const THRESHOLD_GROWTH: f32 = 1.1;

/// Most of the collapses on two cores: the mesh is cut in two at the median
/// vertex along its longest side, the vertices of triangles that straddle
/// the cut are frozen, and each half runs the greedy loop on its own copy of
/// the state. Collapses of one half touch only that half's vertices and
/// triangles, so the two runs are independent: together they take the
/// collapses one loop over both would take with the cut frozen. They go in
/// rounds of a rising cost threshold, so that neither half runs ahead of the
/// other's error; they stop short of the target by a tenth of it plus the
/// frozen triangles, and the caller's loop over the whole mesh (cut
/// included) does the rest in the single loop's order. The result depends on
/// the mesh alone, never on the number of threads. On the Crytek Sponza to
/// 10 % with colour: 0.43-0.47 s against 0.66-0.73 s in one loop.
fn halves<'a>(s: State<'a>, greedy: &Greedy, params: &SimplifyParams, done: &mut Done) -> State<'a> {
    let used: Vec<u32> = (0..s.positions.len() as u32).filter(|&v| !s.around[v as usize].is_empty()).collect();
    let (lo, hi) =
        used.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &v| (lo.min(s.positions[v as usize]), hi.max(s.positions[v as usize])));
    let axis = (hi - lo).max_position();
    let mut along: Vec<f32> = used.iter().map(|&v| s.positions[v as usize][axis]).collect();
    let middle = along.len() / 2;
    let cut = *along.select_nth_unstable_by(middle, f32::total_cmp).1;
    let side: Vec<bool> = s.positions.iter().map(|p| p[axis] > cut).collect();
    let mut frozen = vec![false; s.positions.len()];
    let mut seam = 0;
    for tri in &s.triangles {
        if tri.iter().any(|&v| side[v as usize] != side[tri[0] as usize]) {
            tri.iter().for_each(|&v| frozen[v as usize] = true);
        }
    }
    for tri in &s.triangles {
        seam += usize::from(tri.iter().any(|&v| frozen[v as usize]));
    }
    let stop_at = params.target_triangles + params.target_triangles / 10 + seam;
    if done.live <= stop_at {
        return s;
    }
    let greedy = Greedy { frozen, ..*greedy };
    // Per half: its triangles (all corners on its side; the others are frozen for both).
    let owned = |which: bool| s.triangles.iter().filter(|t| t.iter().all(|&v| side[v as usize] == which)).count();
    let owned = [owned(false), owned(true)];
    // (The copy is made while the other core costs the edges.)
    let (copy, entries) = rayon::join(|| s.clone(), || greedy.entries(&s));
    let mut halves = [(copy, false, owned[0]), (s, true, owned[1])];
    // A part or edge with no frozen vertex lies on one side: its first vertex's.
    let (b, a): (Vec<_>, Vec<_>) = entries.into_iter().partition(|Reverse(e)| match e.job() {
        Job::Edge(v, _, _) => side[v as usize],
        Job::Part(i) => side[halves[0].0.triangles[greedy.parts[i as usize].1[0] as usize][0] as usize],
    });
    let mut queues = [a, b].map(|entries| {
        let mut queue = Queue::default();
        queue.extend(entries);
        queue
    });
    let diagonal = (hi - lo).length();
    let mut threshold = 0.0;
    loop {
        let live: usize = halves.iter().map(|h| h.2).sum();
        let excess = done.live.saturating_sub(stop_at);
        if excess == 0 || threshold > params.max_error || queues.iter().all(Queue::is_empty) {
            break;
        }
        // Each half may take its share of the excess (by its live triangles).
        let limit = threshold.min(params.max_error);
        let [(a, _, la), (b, _, lb)] = &mut halves;
        let [qa, qb] = &mut queues;
        let floor = |l: usize| l - (excess * l).div_ceil(live.max(1)).min(l);
        let mut ran = [Done { live: *la, steps: Vec::new(), error: 0.0 }, Done { live: *lb, steps: Vec::new(), error: 0.0 }];
        let [ra, rb] = &mut ran;
        let (fa, fb) = (floor(*la), floor(*lb));
        rayon::join(|| greedy.run(a, qa, limit, fa, ra), || greedy.run(b, qb, limit, fb, rb));
        for (h, r) in halves.iter_mut().zip(ran) {
            done.live -= h.2 - r.live;
            h.2 = r.live;
            done.error = done.error.max(r.error);
            done.steps.extend(r.steps);
        }
        threshold = if threshold == 0.0 { FIRST_THRESHOLD * diagonal } else { threshold * THRESHOLD_GROWTH };
    }
    // The second half's vertices and triangles join the first half's state.
    let [(mut s, _, _), (mut b, _, _)] = halves;
    for v in (0..s.positions.len()).filter(|&v| side[v]) {
        s.positions[v] = b.positions[v];
        s.around[v] = std::mem::take(&mut b.around[v]);
        s.quadrics[v] = b.quadrics[v];
        s.stamp[v] = b.stamp[v];
        if !s.colours.is_empty() {
            s.colour_quadrics[v] = b.colour_quadrics[v];
            s.colours[v] = b.colours[v];
        }
    }
    for t in 0..s.triangles.len() {
        if b.triangles[t].iter().all(|&v| side[v as usize]) {
            s.triangles[t] = b.triangles[t];
            s.alive[t] = b.alive[t];
            s.planes[t] = b.planes[t];
        }
    }
    s
}

impl<'a> State<'a> {
    /// The mesh with its quadrics and boundary planes.
    fn new(mesh: &'a Mesh, colours: Option<Colours>) -> State<'a> {
        let n = mesh.positions.len();
        let mut around = vec![SmallVec::new(); n];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for &v in tri {
                around[v as usize].push(t as u32);
            }
        }
        let colours: Vec<DVec3> = colours.map(|c| c.values.par_iter().map(|v| v.as_dvec3() * c.weight as f64).collect()).unwrap_or_default();
        // A triangle's corners, unit normal and weight (the square root of
        // its area), if it has an area.
        let plane = |t: u32| {
            let p = mesh.triangles[t as usize].map(|v| mesh.positions[v as usize]);
            let nrm = normal(p);
            let area = 0.5 * nrm.length() as f64;
            (area > 0.0).then(|| (p, nrm.normalize().as_dvec3(), area.sqrt()))
        };
        // Each vertex's sum over its triangles in their order, each
        // triangle's quadrics found anew at each of its corners: on every
        // core, and without a list of every triangle's quadrics (300 bytes
        // each; faulting in its pages cost more than the sums).
        let quadrics = around
            .par_iter()
            .map(|ts: &SmallVec<[u32; 8]>| {
                let mut q = Quadric::default();
                for (p, u, w) in ts.iter().filter_map(|&t| plane(t)) {
                    q.add(&Quadric::plane(u, -u.dot(p[0].as_dvec3()), w));
                }
                q
            })
            .collect();
        let colour_quadrics = if colours.is_empty() {
            Vec::new()
        } else {
            around
                .par_iter()
                .map(|ts: &SmallVec<[u32; 8]>| {
                    let mut q = ColourQuadric::default();
                    for &t in ts {
                        let Some((p, u, w)) = plane(t) else { continue };
                        if let Some(c) = ColourQuadric::triangle(p.map(Vec3::as_dvec3), mesh.triangles[t as usize].map(|v| colours[v as usize]), u, w)
                        {
                            q.add(&c);
                        }
                    }
                    q
                })
                .collect()
        };
        let mut s = State {
            positions: mesh.positions.clone(),
            triangles: mesh.triangles.clone(),
            groups: &mesh.groups,
            alive: vec![true; mesh.triangles.len()],
            around,
            quadrics,
            colour_quadrics,
            colours,
            stamp: vec![0; n],
            part: vec![u32::MAX; n],
            input_normals: mesh.triangles.par_iter().map(|t| normal(t.map(|v| mesh.positions[v as usize]))).collect(),
            planes: mesh.triangles.par_iter().map(|t| plane_of(t.map(|v| mesh.positions[v as usize]))).collect(),
        };
        s.add_border_planes();
        s
    }
}

impl State<'_> {
    /// An edge's stamp: the sum of its ends' (see [`Job::Edge`]).
    fn stamps(&self, a: u32, b: u32) -> u32 {
        self.stamp[a as usize].wrapping_add(self.stamp[b as usize])
    }

    /// Whether edge (a, b) still has both ends and neither changed since its
    /// stamps were `stamped`.
    fn unchanged(&self, a: u32, b: u32, stamped: u32) -> bool {
        let (x, y) = (self.stamp[a as usize], self.stamp[b as usize]);
        x != DEAD && y != DEAD && x.wrapping_add(y) == stamped
    }

    fn live_around(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        self.around[v as usize].iter().copied().filter(|&t| self.alive[t as usize])
    }

    /// Every edge of a live triangle, once, as (low, high), in order: per
    /// vertex from its own triangles (no sort of the whole mesh's edges).
    fn edges(&self) -> Vec<(u32, u32)> {
        (0..self.positions.len() as u32)
            .into_par_iter()
            .flat_map_iter(|v| self.neighbours(v).into_iter().filter(move |&w| w > v).map(move |w| (v, w)))
            .collect()
    }

    fn neighbours(&self, v: u32) -> Few {
        let mut out: Few = self.live_around(v).flat_map(|t| self.triangles[t as usize]).filter(|&w| w != v).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Boundary planes along edges with one triangle, or more than two, or
    /// two of different groups.
    fn add_border_planes(&mut self) {
        // Per triangle, a bit per edge glued to exactly one other triangle of
        // its group (found among the triangles around the edge's first end).
        let interior: Vec<u8> = self
            .triangles
            .par_iter()
            .enumerate()
            .map(|(t, tri)| {
                (0..3)
                    .filter(|&k| {
                        let (a, b) = (tri[k], tri[(k + 1) % 3]);
                        let mut others = self.around[a as usize].iter().filter(|&&u| u as usize != t && self.triangles[u as usize].contains(&b));
                        matches!((others.next(), others.next()), (Some(&u), None) if self.groups[u as usize] == self.groups[t])
                    })
                    .fold(0u8, |bits, k| bits | 1 << k)
            })
            .collect();
        for (t, tri) in self.triangles.iter().enumerate() {
            if interior[t] == 0b111 {
                continue;
            }
            let p = tri.map(|v| self.positions[v as usize]);
            let n = normal(p);
            if n.length_squared() == 0.0 {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                if interior[t] & (1 << k) != 0 {
                    continue;
                }
                let (pa, pb) = (p[k].as_dvec3(), p[(k + 1) % 3].as_dvec3());
                let along = pb - pa;
                let side = along.cross(n.as_dvec3()).normalize_or_zero();
                if side == DVec3::ZERO {
                    continue;
                }
                let q = Quadric::plane(side, -side.dot(pa), BORDER_WEIGHT * along.length());
                self.quadrics[a as usize].add(&q);
                self.quadrics[b as usize].add(&q);
            }
        }
    }

    /// Connected parts: (bounding box diagonal, triangles), and each vertex's part.
    fn label_parts(&mut self) -> Vec<(f32, Vec<u32>)> {
        let mut parts = Vec::new();
        for start in 0..self.positions.len() {
            if self.part[start] != u32::MAX || self.around[start].is_empty() {
                continue;
            }
            let id = parts.len() as u32;
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            let mut tris = Vec::new();
            let mut stack = vec![start as u32];
            self.part[start] = id;
            while let Some(v) = stack.pop() {
                lo = lo.min(self.positions[v as usize]);
                hi = hi.max(self.positions[v as usize]);
                for &t in &self.around[v as usize] {
                    for &w in &self.triangles[t as usize] {
                        if self.part[w as usize] == u32::MAX {
                            self.part[w as usize] = id;
                            stack.push(w);
                        }
                    }
                    if self.triangles[t as usize][0] == v {
                        tris.push(t);
                    }
                }
            }
            parts.push(((hi - lo).length(), tris));
        }
        parts
    }

    /// Where edge (a, b) collapses to, and the error there as a distance
    /// (colour included): the root mean square distance to the planes both
    /// ends stand for, with the one colour best there.
    fn placement(&self, a: u32, b: u32) -> Option<(DVec3, f32)> {
        let mut q = self.quadrics[a as usize];
        q.add(&self.quadrics[b as usize]);
        if !self.colour_quadrics.is_empty() {
            let mut c = self.colour_quadrics[a as usize];
            c.add(&self.colour_quadrics[b as usize]);
            q.add(&c.reduced());
        }
        let (pa, pb) = (self.positions[a as usize].as_dvec3(), self.positions[b as usize].as_dvec3());
        // The optimum if it stays near the edge (a nearly singular system can
        // put it far away); it minimises the error, so the candidates need no
        // trying then.
        let p = match q.optimum() {
            Some(p) if p.distance(0.5 * (pa + pb)) <= 2.0 * pa.distance(pb) => p,
            _ => [pa, pb, 0.5 * (pa + pb)].into_iter().map(|p| (p, q.error(p))).min_by(|x, y| x.1.total_cmp(&y.1))?.0,
        };
        Some((p, q.distance(p)))
    }

    /// The collapse's error as a distance (colour included).
    fn cost(&self, a: u32, b: u32) -> Option<f32> {
        Some(self.placement(a, b)?.1)
    }

    /// The geometric error of moving a and b to p, as [`Self::placement`]'s.
    fn geometric_error(&self, a: u32, b: u32, p: DVec3) -> f32 {
        let mut q = self.quadrics[a as usize];
        q.add(&self.quadrics[b as usize]);
        q.distance(p)
    }

    /// The largest distance from `target` to the plane of a live face
    /// around `a` or `b` (degenerate faces left out).
    fn farthest_plane(&self, a: u32, b: u32, target: DVec3) -> f32 {
        let p = target.as_vec3().extend(1.0);
        let mut far = 0f32;
        for v in [a, b] {
            for t in self.live_around(v) {
                far = far.max(self.planes[t as usize].dot(p).abs());
            }
        }
        far
    }

    fn can_collapse(&self, kept: u32, removed: u32, target: DVec3) -> bool {
        // Link condition: shared neighbours are exactly the edge's triangles' third corners.
        let shared_triangles: Few = self.live_around(kept).filter(|&t| self.triangles[t as usize].contains(&removed)).collect();
        if shared_triangles.is_empty() {
            return false;
        }
        let (nk, nr) = (self.neighbours(kept), self.neighbours(removed));
        let common = nk.iter().filter(|w| nr.binary_search(w).is_ok()).count();
        if common != shared_triangles.len() || shared_triangles.len() > MAX_EDGE_TRIANGLES {
            return false;
        }
        // No triangle may land on another: (removed, x, y) becoming a
        // triangle (kept, x, y) that already exists. Then x and y are common
        // neighbours, so (by the link condition) third corners of the edge's
        // triangles: only triangles with two such corners need the search.
        if shared_triangles.len() >= 2 {
            let third = |w: u32| w != removed && shared_triangles.iter().any(|&t| self.triangles[t as usize].contains(&w) && w != kept);
            for t in self.live_around(removed) {
                let tri = self.triangles[t as usize];
                if !shared_triangles.contains(&t)
                    && tri.iter().all(|&w| w == removed || third(w))
                    && self
                        .live_around(kept)
                        .any(|u| !shared_triangles.contains(&u) && tri.iter().all(|&w| w == removed || self.triangles[u as usize].contains(&w)))
                {
                    return false;
                }
            }
        }
        // No vertex may lose its last triangle (a part collapsing to nothing
        // would leave loose vertices; small parts are pruned whole instead).
        let survivors = |v: u32| self.live_around(v).filter(|t| !shared_triangles.contains(t)).count();
        if survivors(kept) + survivors(removed) == 0 {
            return false;
        }
        for &t in &shared_triangles {
            for w in self.triangles[t as usize] {
                if w != kept && w != removed && survivors(w) == 0 {
                    return false;
                }
            }
        }
        let p = target.as_vec3();
        for v in [kept, removed] {
            for t in self.live_around(v) {
                let tri = self.triangles[t as usize];
                if tri.contains(&kept) && tri.contains(&removed) {
                    continue;
                }
                let after = tri.map(|w| if w == kept || w == removed { p } else { self.positions[w as usize] });
                // The face's unit normal before is its kept plane's (zero if it had no area).
                let (n0, n1) = (self.planes[t as usize].truncate(), normal(after));
                let l1 = n1.length();
                if l1 <= 1e-12 || (n0 != Vec3::ZERO && n0.dot(n1) < MIN_NORMAL_COSINE * l1) || n1.dot(self.input_normals[t as usize]) <= 0.0 {
                    return false;
                }
            }
        }
        true
    }

    fn collapse(&mut self, kept: u32, removed: u32, target: DVec3) -> Collapse {
        let mut c =
            Collapse { kept, removed, kept_was: self.positions[kept as usize], kept_now: target.as_vec3(), moved: Vec::new(), deleted: Vec::new() };
        let tris: Few = self.live_around(removed).collect();
        for t in tris {
            let tri = &mut self.triangles[t as usize];
            if tri.contains(&kept) {
                c.deleted.push((t, *tri));
                self.alive[t as usize] = false;
            } else {
                for w in tri.iter_mut() {
                    if *w == removed {
                        *w = kept;
                    }
                }
                c.moved.push(t);
                self.around[kept as usize].push(t);
            }
        }
        self.around[kept as usize].retain(|t| self.alive[*t as usize]);
        self.around[removed as usize].clear();
        self.positions[kept as usize] = c.kept_now;
        for &t in &self.around[kept as usize] {
            self.planes[t as usize] = plane_of(self.triangles[t as usize].map(|w| self.positions[w as usize]));
        }
        let q = self.quadrics[removed as usize];
        self.quadrics[kept as usize].add(&q);
        if !self.colour_quadrics.is_empty() {
            let c = self.colour_quadrics[removed as usize];
            self.colour_quadrics[kept as usize].add(&c);
            self.colours[kept as usize] = self.colour_quadrics[kept as usize].colour(target);
        }
        self.stamp[removed as usize] = DEAD;
        // Only edges at `kept` change cost (their validity is checked when taken).
        self.stamp[kept as usize] += 1;
        c
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// An n × n grid of unit squares in the z = 0 plane, two triangles each.
    pub fn plane(n: u32) -> Mesh {
        let mut m = Mesh::default();
        for y in 0..=n {
            for x in 0..=n {
                m.positions.push(Vec3::new(x as f32, y as f32, 0.0));
            }
        }
        for y in 0..n {
            for x in 0..n {
                let i = y * (n + 1) + x;
                m.triangles.push([i, i + 1, i + n + 2]);
                m.triangles.push([i, i + n + 2, i + n + 1]);
            }
        }
        m.groups = vec![0; m.triangles.len()];
        m
    }

    fn normals_agree(before: &Mesh, after: &Simplified) -> bool {
        after.alive.iter().enumerate().filter(|(_, &a)| a).all(|(t, _)| {
            let n0 = normal(before.triangles[t].map(|v| before.positions[v as usize]));
            let n1 = normal(after.mesh.triangles[t].map(|v| after.mesh.positions[v as usize]));
            n0.dot(n1) > 0.0
        })
    }

    #[test]
    fn the_queue_pops_in_the_order_of_one_heap_and_drops_what_became_invalid() {
        // Entries pushed in bulk and one by one, and entries becoming invalid
        // as the steps go (once invalid, for good, as in the simplifier):
        // each step takes the cheapest valid entry, which must be the one a
        // plain heap of everything gives.
        let mut rng = 12345u64;
        let mut next = || {
            rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (rng >> 33) as u32
        };
        let first: Vec<Reverse<Entry>> = (0..20_000).map(|i| Entry::new((next() % 1000) as f32, Job::Edge(i, i + 1, 0))).collect();
        let mut queue = Queue::default();
        queue.extend(first.iter().map(|e| Reverse(Entry(e.0 .0))).collect());
        let mut plain: BinaryHeap<Reverse<Entry>> = first.into_iter().collect();
        for step in 0..25_000u32 {
            // Odd edges below 4 × step are gone.
            let valid = |e: &Entry| !matches!(e.job(), Job::Edge(a, _, _) if a % 2 == 1 && a < 4 * step);
            if step % 3 == 0 {
                let e = Entry::new((next() % 1000) as f32, Job::Edge(100_000 + step, 0, 0));
                plain.push(Reverse(Entry(e.0 .0)));
                queue.push(e);
            }
            let ours = std::iter::from_fn(|| queue.pop_up_to(f32::INFINITY, valid)).find(&valid).map(|e| e.0);
            let theirs = std::iter::from_fn(|| plain.pop()).find(|Reverse(e)| valid(e)).map(|Reverse(e)| e.0);
            assert_eq!(ours, theirs, "step {step}");
            if ours.is_none() {
                assert!(step > 15_000, "ran dry at step {step}");
                return;
            }
        }
        panic!("never ran dry");
    }

    #[test]
    fn a_subdivided_plane_collapses_to_two_triangles_with_no_error() {
        let m = plane(8);
        let s = simplify(&m, &SimplifyParams { target_triangles: 2, max_error: f32::INFINITY });
        let out = s.compact();
        assert_eq!(out.triangles.len(), 2);
        assert!(s.error < 1e-4, "error {}", s.error);
        // The outline is kept: the four corners remain.
        let mut corners: Vec<[i32; 2]> = out.positions.iter().map(|p| [p.x.round() as i32, p.y.round() as i32]).collect();
        corners.sort();
        assert_eq!(corners, vec![[0, 0], [0, 8], [8, 0], [8, 8]]);
        assert!(out.positions.iter().all(|p| p.z.abs() < 1e-5));
        assert!(normals_agree(&m, &s));
    }

    #[test]
    fn a_cube_keeps_its_corners() {
        // A closed cube of 6 × 4 × 4 × 2 = 192 triangles (each face a 4 × 4 grid).
        let mut scene = exploremaps_scenes::mesh::MeshBuilder::new("cube");
        scene.add_material(exploremaps_scenes::Material::diffuse("grey", [0.5; 3]));
        scene.cuboid(Vec3::ZERO, Vec3::ONE);
        let scene = scene.finish();
        let (flat, _) = super::super::weld::weld_scene(&scene, 1e-5);
        let m = subdivide(&subdivide(&flat));
        let s = simplify(&m, &SimplifyParams { target_triangles: 12, max_error: f32::INFINITY });
        let out = s.compact();
        assert_eq!(out.triangles.len(), 12, "{} triangles", out.triangles.len());
        assert!(s.error < 1e-4, "error {}", s.error);
        for corner in 0..8 {
            let c = Vec3::new((corner & 1) as f32, ((corner >> 1) & 1) as f32, ((corner >> 2) & 1) as f32);
            assert!(out.positions.iter().any(|p| p.distance(c) < 1e-4), "corner {c} kept");
        }
        assert!(normals_agree(&m, &s));
    }

    #[test]
    fn a_tetrahedron_cannot_lose_a_face_without_pinching_and_stays_whole() {
        let m = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
            groups: vec![0; 4],
        };
        // Any collapse of a tetrahedron folds two faces onto two others: refused.
        let s = simplify(&m, &SimplifyParams { target_triangles: 2, max_error: 0.1 });
        assert_eq!(s.triangles().len(), 4);
        assert!(s.steps.is_empty());
    }

    /// Distance from `p` to the triangle `t`.
    fn to_triangle(p: Vec3, t: [Vec3; 3]) -> f32 {
        let n = normal(t).normalize_or_zero();
        let q = p - n * n.dot(p - t[0]);
        // Inside when q is on the inner side of all three edges.
        if (0..3).all(|k| (t[(k + 1) % 3] - t[k]).cross(q - t[k]).dot(n) >= 0.0) {
            return p.distance(q);
        }
        let segment = |a: Vec3, b: Vec3| p.distance(a + (b - a) * ((p - a).dot(b - a) / (b - a).length_squared().max(1e-30)).clamp(0.0, 1.0));
        segment(t[0], t[1]).min(segment(t[1], t[2])).min(segment(t[2], t[0]))
    }

    #[test]
    fn the_ends_of_a_thin_slab_do_not_slide_along_it() {
        // The gallery's roof strips over its walls are 0.3 units square and
        // 40 long. At 2 % of its triangles the quadric's mean over a corner's
        // planes, the strip's long faces weighing far more than its end, let
        // an end slide 0.3 units along the strip (0.55 % of the diagonal,
        // where meshoptimizer's level stays within 0.15 %).
        let scene = exploremaps_scenes::BuiltIn::Gallery.generate(1);
        let (m, _) = super::super::weld::weld_scene(&scene, 1e-5 * scene.bounds().diagonal());
        let out = simplify(&m, &SimplifyParams { target_triangles: m.triangles.len() / 50, max_error: f32::INFINITY }).compact();
        let triangles: Vec<([Vec3; 3], Vec3, f32)> = out
            .triangles
            .iter()
            .map(|t| {
                let p = t.map(|v| out.positions[v as usize]);
                let centre = (p[0] + p[1] + p[2]) / 3.0;
                (p, centre, p.iter().map(|q| q.distance(centre)).fold(0.0, f32::max))
            })
            .collect();
        // Every input vertex's distance to the simplified surface (a
        // triangle is skipped when its bounding sphere is farther than the
        // nearest found so far).
        let farthest = m
            .positions
            .iter()
            .map(|&p| {
                triangles.iter().fold(
                    f32::INFINITY,
                    |best, &(t, centre, radius)| if p.distance(centre) - radius >= best { best } else { best.min(to_triangle(p, t)) },
                )
            })
            .fold(0.0, f32::max);
        assert!(farthest < 0.1, "an input vertex {farthest} units from the 2 % level");
    }

    #[test]
    fn a_small_separate_part_is_pruned_before_the_large_part_loses_shape() {
        // A bumpy 8 × 8 plane and a tiny loose triangle.
        let mut m = plane(8);
        for (i, p) in m.positions.iter_mut().enumerate() {
            p.z = 0.3 * ((i * 7919) % 13) as f32 / 13.0;
        }
        let base = m.positions.len() as u32;
        m.positions.extend([Vec3::new(20.0, 0.0, 0.0), Vec3::new(20.01, 0.0, 0.0), Vec3::new(20.0, 0.01, 0.0)]);
        m.triangles.push([base, base + 1, base + 2]);
        m.groups.push(0);
        let s = simplify(&m, &SimplifyParams { target_triangles: 10, max_error: 0.05 });
        assert!(
            !s.alive[m.triangles.len() - 1],
            "the loose triangle is pruned: {} left, error {}, {} steps",
            s.triangles().len(),
            s.error,
            s.steps.len()
        );
        assert_eq!(s.steps.iter().filter(|s| matches!(s, Step::Prune(_))).count(), 1);
    }

    #[test]
    fn colour_keeps_the_vertices_where_colour_changes_and_geometry_alone_does_not() {
        // A flat 16 × 16 plane, black up to x = 7 and white from x = 8: three
        // strips represent it exactly, with no geometric error at all.
        let m = plane(16);
        let colours: Vec<Vec3> = m.positions.iter().map(|p| Vec3::splat(if p.x >= 8.0 { 1.0 } else { 0.0 })).collect();
        // Colour at each input vertex as the simplified plane interpolates it.
        let colour_error = |s: &Simplified| {
            let (out, c) = s.compact_with_colours();
            let mut sum = 0.0;
            for (p, want) in m.positions.iter().zip(&colours) {
                let found = out.triangles.iter().find_map(|t| {
                    let [a, b, d] = t.map(|v| out.positions[v as usize].truncate());
                    let area = (b - a).perp_dot(d - a);
                    let (u, v) = ((p.truncate() - a).perp_dot(d - a) / area, (b - a).perp_dot(p.truncate() - a) / area);
                    (u >= -1e-4 && v >= -1e-4 && u + v <= 1.0 + 1e-4)
                        .then(|| c[t[0] as usize] * (1.0 - u - v) + c[t[1] as usize] * u + c[t[2] as usize] * v)
                });
                sum += (found.expect("the plane still covers every input vertex") - *want).length_squared();
            }
            (sum / m.positions.len() as f32).sqrt()
        };
        let params = SimplifyParams { target_triangles: 6, max_error: f32::INFINITY };
        let with = simplify_with_colours(&m, Some(Colours { values: &colours, weight: 1.0 }), &params);
        assert_eq!(with.triangles().len(), 6);
        assert!(with.error < 1e-4, "geometric error {}", with.error);
        assert!(colour_error(&with) < 1e-3, "with colour: RMS colour error {}", colour_error(&with));
        // Geometry alone has no reason to keep the step: two triangles, grey blur.
        let s = simplify(&m, &SimplifyParams { target_triangles: 2, ..params });
        let without = Simplified { colours: colours.clone(), ..s };
        assert!(colour_error(&without) > 0.2, "without colour: RMS colour error {}", colour_error(&without));
    }

    #[test]
    fn group_borders_stay_put() {
        // Left half group 0, right half group 1: the border line x = 4 survives.
        let mut m = plane(8);
        for (t, tri) in m.triangles.iter().enumerate() {
            m.groups[t] = u32::from(m.positions[tri[0] as usize].x >= 4.0);
        }
        let s = simplify(&m, &SimplifyParams { target_triangles: 4, max_error: f32::INFINITY });
        let out = s.compact();
        assert!(out.triangles.len() <= 8, "{}", out.triangles.len());
        for (t, tri) in out.triangles.iter().enumerate() {
            let xs = tri.map(|v| out.positions[v as usize].x);
            if out.groups[t] == 0 {
                assert!(xs.iter().all(|&x| x <= 4.0 + 1e-4), "{xs:?}");
            } else {
                assert!(xs.iter().all(|&x| x >= 4.0 - 1e-4), "{xs:?}");
            }
        }
    }

    /// Three flat 8 × 4 sheets meeting at 120° along the x axis (a fin: the
    /// axis edges are each on three triangles).
    pub fn fin() -> Mesh {
        let mut m = Mesh::default();
        m.positions.extend((0..=8).map(|x| Vec3::new(x as f32, 0.0, 0.0)));
        let axis: Vec<u32> = (0..=8).collect();
        for sheet in 0..3 {
            let angle = (90.0 + 120.0 * sheet as f32).to_radians();
            let out = Vec3::new(0.0, angle.sin(), angle.cos());
            let mut row = axis.clone();
            for r in 1..=4 {
                let next: Vec<u32> = (0..=8)
                    .map(|x| {
                        m.positions.push(Vec3::new(x as f32, 0.0, 0.0) + out * r as f32);
                        m.positions.len() as u32 - 1
                    })
                    .collect();
                for x in 0..8 {
                    m.triangles.push([row[x], row[x + 1], next[x + 1]]);
                    m.triangles.push([row[x], next[x + 1], next[x]]);
                }
                row = next;
            }
        }
        m.groups = vec![0; m.triangles.len()];
        m
    }

    #[test]
    fn a_fin_simplifies_along_its_non_manifold_edge_with_no_error() {
        let m = fin();
        let s = simplify(&m, &SimplifyParams { target_triangles: 6, max_error: f32::INFINITY });
        let out = s.compact();
        assert_eq!(out.triangles.len(), 6, "{} triangles, error {}", out.triangles.len(), s.error);
        assert!(s.error < 1e-4, "error {}", s.error);
        assert!(normals_agree(&m, &s));
        // The shared edge keeps its two ends and nothing between; every
        // sheet keeps its far corners.
        let on_axis: Vec<f32> = out.positions.iter().filter(|p| p.y.abs() < 1e-5 && p.z.abs() < 1e-5).map(|p| p.x).collect();
        assert_eq!(on_axis.len(), 2, "{on_axis:?}");
        assert!(on_axis.iter().all(|&x| x.abs() < 1e-5 || (x - 8.0).abs() < 1e-5), "{on_axis:?}");
        // Each collapse along the axis took one triangle of each sheet.
        assert!(s.steps.iter().any(|step| matches!(step, Step::Collapse(c) if c.deleted.len() == 3)));
    }

    /// A bumpy subdivided plane of 4,608 triangles in three groups.
    pub fn bumpy() -> Mesh {
        let mut m = subdivide(&plane(24));
        for (i, p) in m.positions.iter_mut().enumerate() {
            p.z = 0.3 * ((i * 7919) % 13) as f32 / 13.0 + 0.05 * p.x;
        }
        for (t, g) in m.groups.iter_mut().enumerate() {
            *g = (t / 700) as u32 % 3;
        }
        m
    }

    /// [`simplify`] in halves first, whatever the mesh's size.
    pub fn in_halves(m: &Mesh, target: usize) -> Simplified {
        simplify_halves_above(m, None, &SimplifyParams { target_triangles: target, max_error: f32::INFINITY }, 0)
    }

    #[test]
    fn halves_give_the_same_mesh_at_any_thread_count_and_lose_little() {
        let m = bumpy();
        let target = 460;
        let on = |threads: usize| rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| in_halves(&m, target));
        let (one, two) = (on(1), on(2));
        assert_eq!(one.steps, two.steps);
        assert_eq!((&one.mesh.positions, one.error), (&two.mesh.positions, two.error));
        // A collapse takes one or two triangles: the last may pass the target by one.
        assert!((target - 1..=target).contains(&two.triangles().len()), "{}", two.triangles().len());
        assert!(normals_agree(&m, &two));
        // Both halves did most of the work: each lost most of its triangles.
        let halves = two.steps.iter().filter_map(|s| match s {
            Step::Collapse(c) => Some(m.positions[c.removed as usize].x > 12.0),
            Step::Prune(_) => None,
        });
        let right = halves.clone().filter(|&r| r).count();
        assert!(right > 800 && halves.count() - right > 800, "{right} collapses on the right");
        let whole = simplify(&m, &SimplifyParams { target_triangles: target, max_error: f32::INFINITY });
        assert_ne!(whole.steps, two.steps, "a different order");
        assert!(two.error <= 1.1 * whole.error, "in halves {}, in one loop {}", two.error, whole.error);
    }

    #[test]
    #[ignore]
    fn no_triangle_of_a_shared_scene_flips() {
        // Slow: the shared third-party scenes (`cargo test -- --ignored`).
        for file in
            ["stanford_bunny/bun_zipper.ply", "sponza_crytek/sponza_crytek.obj", "sponza_dabrovic/sponza.obj", "grey_white_room/grey_white_room.obj"]
        {
            let Some(path) = crate::testing::shared_scene(file) else { continue };
            let scene = crate::scene_io::load(&path, &crate::scene_io::LoadOptions::default()).unwrap();
            let (m, _) = super::super::weld::weld_scene(&scene, 1e-5 * scene.bounds().diagonal());
            for ratio in [0.1, 0.01] {
                let s = simplify(&m, &SimplifyParams { target_triangles: (m.triangles.len() as f64 * ratio) as usize, max_error: f32::INFINITY });
                assert!(normals_agree(&m, &s), "{file} at {ratio}: a triangle turned past 90°");
                assert!(s.triangles().len() <= (m.triangles.len() as f64 * ratio) as usize, "{file} at {ratio}: {} triangles", s.triangles().len());
            }
        }
    }

    /// Splits every triangle into four at its edge midpoints (shared midpoints shared).
    pub fn subdivide(m: &Mesh) -> Mesh {
        let mut out = Mesh { positions: m.positions.clone(), ..Default::default() };
        let mut mid: rustc_hash::FxHashMap<(u32, u32), u32> = Default::default();
        let mut midpoint = |a: u32, b: u32, out: &mut Mesh| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                out.positions.push(0.5 * (out.positions[a as usize] + out.positions[b as usize]));
                out.positions.len() as u32 - 1
            })
        };
        for (t, &[a, b, c]) in m.triangles.iter().enumerate() {
            let (ab, bc, ca) = (midpoint(a, b, &mut out), midpoint(b, c, &mut out), midpoint(c, a, &mut out));
            out.triangles.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
            out.groups.extend([m.groups[t]; 4]);
        }
        out
    }
}

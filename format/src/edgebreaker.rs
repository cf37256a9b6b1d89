//! Edgebreaker connectivity coding (Rossignac 1999, "Edgebreaker: Connectivity
//! compression for triangle meshes"; handles after Lopes, Rossignac, Safonova,
//! Szymczak and Tavares 2003, "Edgebreaker: a simple implementation for
//! surfaces with handles").
//!
//! The encoder walks each connected component triangle by triangle, keeping
//! the boundary of the visited region as loops of vertices, and writes one
//! symbol per triangle after the first (per triangle, when it starts from a
//! boundary loop, below): C when the triangle brings a new
//! vertex, L or R when it also borders the visited region on the left or the
//! right of the gate edge, E when it closes a loop of three, S when its tip lies
//! further along the loop and splits it in two (the right part is walked
//! first, the left part waits on a stack). A sixth symbol covers what a sphere
//! never needs: M joins the current loop with one waiting on the stack (once
//! per handle; its record says which loop, where, and how long), and D is a C
//! whose new vertex is a dummy (below). Where an S tip lies
//! follows from the symbols alone: summing loop lengths backwards over them
//! gives the length of each S's right loop, so S costs no extra bits.
//!
//! Any triangle list without a repeated index inside a triangle is accepted.
//! It is made closed and manifold first, and restored after decoding:
//! - an edge is glued only when exactly two triangles use it in opposite
//!   directions; any other edge (open, non-manifold, inconsistently oriented)
//!   is cut into boundary edges;
//! - a vertex whose triangles then form several fans gets a copy per extra fan,
//!   listed so that the decoder merges each copy back into its original;
//! - each boundary loop gets a dummy vertex fanned to its edges, brought by a
//!   D (a C marked as a dummy) so that the decoder drops it with its
//!   triangles (versions 1 to 3 list them). Components with a boundary are
//!   walked first, each from one of its loops (of three edges or more) as the
//!   first loop of the walk, in place of a first triangle: that loop's dummy
//!   and fan are never coded, only its length. (Version 3 files start such a
//!   component at a triangle of the fan instead, with the dummy as its first
//!   vertex; that fan's other triangles cost a symbol each, about a third of
//!   the symbols on soups of small open parts.)
//!
//! So decoding gives back every triangle with its orientation, up to the order
//! of vertices and triangles and the rotation of corners within a triangle.
//! Vertices no triangle uses are not coded.
//!
//! Decoding is one forward walk, `rebuild`, that takes each symbol from a
//! `Walk` as it needs it: from a [`Connectivity`]'s lists ([`decode`],
//! after checking that their loop lengths add up), or from a coded stream
//! whose models see the loop each symbol acts on (`meshcode`'s versions 5 and 6).
//! Each step is checked against that loop, so a hostile stream gives an
//! error, never a broken loop.

use std::fmt;

/// Symbols, in the order their codes take in the entropy models.
pub const C: u8 = 0;
pub const L: u8 = 1;
pub const R: u8 = 2;
pub const S: u8 = 3;
pub const E: u8 = 4;
pub const M: u8 = 5;
/// A C whose new vertex is a dummy (version 4): the dummies of loops that do
/// not start a component need no list, and the symbols after a D, which walk
/// the dummy's fan, get a context of their own.
pub const D: u8 = 6;
pub const SYMBOLS: usize = 7;

const NONE: u32 = u32::MAX;
/// Most triangles (dummies included) a decoder accepts: bounds the memory a
/// hostile header can ask for.
pub const MAX_TRIANGLES: u32 = 1 << 26;

/// A join of the current loop with a waiting one (symbol M).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Merge {
    /// Position of the waiting loop on the stack, 0 = top.
    pub depth: u32,
    /// Steps from that loop's gate to the tip's vertex.
    pub offset: u32,
    /// Length of that loop, in vertices.
    pub length: u32,
}

/// A mesh's connectivity as Edgebreaker codes it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Connectivity {
    /// One symbol per triangle that does not start a component.
    pub symbols: Vec<u8>,
    /// One per M, in order.
    pub merges: Vec<Merge>,
    /// Triangles and vertices decoded, dummies and copies included.
    pub triangle_count: u32,
    pub vertex_count: u32,
    /// Per component, the first ones, that starts from a boundary loop: the
    /// loop's length (at least 3). Its vertices are the component's first,
    /// decoded in the loop's order.
    pub start_loops: Vec<u32>,
    /// Version 3 files: how many components, the first ones, start at a
    /// triangle of a boundary loop's fan with its dummy as their first vertex.
    /// The encoder no longer writes these.
    pub dummy_starts: u32,
    /// Versions 1 to 3: decoded indices of the other dummy vertices,
    /// ascending (version 4 marks them with D).
    pub dummies: Vec<u32>,
    /// `[copy, original]` decoded indices, ascending by copy.
    pub copies: Vec<[u32; 2]>,
}

/// Where each decoded vertex and triangle came from in the encoder's input.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Order {
    /// Per kept vertex (see [`Decoded::keep`]), its input index.
    pub vertices: Vec<u32>,
    /// Per kept triangle, its input index.
    pub triangles: Vec<u32>,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CodingError {
    /// The encoder's input cannot be coded.
    Input(String),
    /// The coded data is inconsistent (truncated, corrupt or hostile).
    Corrupt(String),
}

impl fmt::Display for CodingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CodingError::Input(m) => write!(f, "mesh cannot be coded: {m}"),
            CodingError::Corrupt(m) => write!(f, "coded mesh is corrupt: {m}"),
        }
    }
}

impl std::error::Error for CodingError {}

fn corrupt<T>(message: impl Into<String>) -> Result<T, CodingError> {
    Err(CodingError::Corrupt(message.into()))
}

#[inline]
fn next(c: u32) -> u32 {
    if c % 3 == 2 {
        c - 2
    } else {
        c + 1
    }
}

#[inline]
fn prev(c: u32) -> u32 {
    if c.is_multiple_of(3) {
        c + 2
    } else {
        c - 1
    }
}

/// The input made closed and manifold, as a corner table: corner `c` is
/// vertex `corners[c]` of triangle `c / 3`, and `opposite[c]` is the corner
/// facing it across the edge opposite `c`.
struct Closed {
    corners: Vec<u32>,
    opposite: Vec<u32>,
    /// Per closed vertex: its input vertex, or NONE for a dummy.
    source: Vec<u32>,
    real_triangles: u32,
}

/// The mesh closed for coding: checked, its edges glued, its non-manifold
/// vertices split, and each boundary loop closed by a dummy.
fn close(triangles: &[[u32; 3]], vertex_count: u32) -> Result<Closed, CodingError> {
    check_input(triangles, vertex_count)?;
    let mut corners: Vec<u32> = triangles.iter().flatten().copied().collect();
    let mut opposite = glue(&corners);
    let mut source = split_fans(&mut corners, &opposite, vertex_count);
    close_boundaries(&mut corners, &mut opposite, &mut source);
    debug_assert!(opposite.iter().all(|&o| o != NONE));
    Ok(Closed { corners, opposite, source, real_triangles: triangles.len() as u32 })
}

fn check_input(triangles: &[[u32; 3]], vertex_count: u32) -> Result<(), CodingError> {
    for (t, tri) in triangles.iter().enumerate() {
        if tri.iter().any(|&v| v >= vertex_count) {
            return Err(CodingError::Input(format!("triangle {t} uses vertex {} of {vertex_count}", tri.iter().max().unwrap())));
        }
        if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
            return Err(CodingError::Input(format!("triangle {t} repeats a vertex: {tri:?}")));
        }
    }
    // Dummy triangles add at most one per corner.
    if triangles.len() as u64 * 2 > MAX_TRIANGLES as u64 {
        return Err(CodingError::Input(format!("{} triangles; at most {} can be coded", triangles.len(), MAX_TRIANGLES / 2)));
    }
    Ok(())
}

/// Per corner, the corner across its opposite edge (NONE on a boundary):
/// edges used exactly twice in opposite directions are glued.
fn glue(corners: &[u32]) -> Vec<u32> {
    let n = corners.len() as u32;
    let mut edges: Vec<(u64, u32)> = (0..n)
        .map(|c| {
            let (u, v) = (corners[next(c) as usize], corners[prev(c) as usize]);
            ((u.min(v) as u64) << 32 | u.max(v) as u64, c)
        })
        .collect();
    edges.sort_unstable();
    let mut opposite = vec![NONE; n as usize];
    for group in edges.chunk_by(|x, y| x.0 == y.0) {
        if let [(_, c), (_, d)] = *group {
            if corners[next(c) as usize] == corners[prev(d) as usize] {
                opposite[c as usize] = d;
                opposite[d as usize] = c;
            }
        }
    }
    opposite
}

/// One vertex per fan of glued triangles around it: a vertex with several
/// fans gets a copy for each after the first. Returns per vertex its input
/// vertex.
fn split_fans(corners: &mut [u32], opposite: &[u32], vertex_count: u32) -> Vec<u32> {
    let n = corners.len() as u32;
    let mut source: Vec<u32> = (0..vertex_count).collect();
    let mut has_fan = vec![false; vertex_count as usize];
    let mut done = vec![false; n as usize];
    let mut fan = Vec::new();
    for c in 0..n {
        if done[c as usize] {
            continue;
        }
        let v = corners[c as usize];
        fan.clear();
        fan.push(c);
        done[c as usize] = true;
        // Swing one way (across the edge leaving v), then the other.
        let mut k = c;
        while let Some(o) = Some(opposite[prev(k) as usize]).filter(|&o| o != NONE) {
            k = prev(o);
            if done[k as usize] {
                break;
            }
            done[k as usize] = true;
            fan.push(k);
        }
        let mut k = c;
        while let Some(o) = Some(opposite[next(k) as usize]).filter(|&o| o != NONE) {
            k = next(o);
            if done[k as usize] {
                break;
            }
            done[k as usize] = true;
            fan.push(k);
        }
        let id = if has_fan[v as usize] {
            source.push(v);
            source.len() as u32 - 1
        } else {
            has_fan[v as usize] = true;
            v
        };
        for &k in &fan {
            corners[k as usize] = id;
        }
    }
    source
}

/// Closes each boundary loop with a dummy vertex (NONE in `source`) and a
/// fan of dummy triangles. After the fans are split each vertex starts at
/// most one boundary edge.
fn close_boundaries(corners: &mut Vec<u32>, opposite: &mut Vec<u32>, source: &mut Vec<u32>) {
    let n = corners.len() as u32;
    let mut outgoing = vec![NONE; source.len()];
    for c in 0..n {
        if opposite[c as usize] == NONE {
            outgoing[corners[next(c) as usize] as usize] = c;
        }
    }
    for c0 in 0..n {
        if opposite[c0 as usize] != NONE {
            continue;
        }
        let d = source.len() as u32;
        source.push(NONE);
        let first = corners.len() as u32;
        let mut c = c0;
        loop {
            // Boundary edge u -> w closed by the dummy triangle (w, u, d).
            let (u, w) = (corners[next(c) as usize], corners[prev(c) as usize]);
            let base = corners.len() as u32;
            corners.extend([w, u, d]);
            opposite.extend([NONE, NONE, c]);
            opposite[c as usize] = base + 2;
            if base != first {
                // The previous dummy triangle's edge d -> u meets this one's u -> d.
                opposite[(base - 2) as usize] = base;
                opposite[base as usize] = base - 2;
            }
            c = outgoing[w as usize];
            if c == NONE || opposite[c as usize] != NONE {
                break;
            }
        }
        let last = corners.len() as u32 - 3;
        opposite[(last + 1) as usize] = first;
        opposite[first as usize] = last + 1;
    }
}

/// A vertex of a boundary loop, and the loop edge from it to the next one.
#[derive(Clone, Copy)]
struct Node {
    vertex: u32,
    prev: u32,
    next: u32,
    /// Encoder: the corner facing the edge in its visited triangle (so the
    /// triangle across is `opposite[corner] / 3`). Decoder: that corner's vertex.
    facing: u32,
    /// Encoder only: the loop it belongs to, and the next node of its vertex.
    loop_id: u32,
    same: u32,
}

/// Loops of nodes, shared by the encoder and the decoder so that both walk the
/// same structure.
#[derive(Default)]
struct Loops {
    nodes: Vec<Node>,
}

impl Loops {
    fn add(&mut self, vertex: u32, prev: u32, next: u32, facing: u32, loop_id: u32) -> u32 {
        self.nodes.push(Node { vertex, prev, next, facing, loop_id, same: NONE });
        let n = self.nodes.len() as u32 - 1;
        self.nodes[prev as usize].next = n;
        self.nodes[next as usize].prev = n;
        n
    }
    /// A component's first loop (its first triangle, or a boundary loop):
    /// node `i` has vertex `v[i]` and faces `facing[i]`. Returns the first node.
    fn ring(&mut self, v: &[u32], facing: &[u32], loop_id: u32) -> u32 {
        let n = self.nodes.len() as u32;
        let k = v.len() as u32;
        for i in 0..k {
            self.nodes.push(Node {
                vertex: v[i as usize],
                prev: n + (i + k - 1) % k,
                next: n + (i + 1) % k,
                facing: facing[i as usize],
                loop_id,
                same: NONE,
            });
        }
        n
    }
    fn next(&self, n: u32) -> u32 {
        self.nodes[n as usize].next
    }
    fn prev(&self, n: u32) -> u32 {
        self.nodes[n as usize].prev
    }
    fn vertex(&self, n: u32) -> u32 {
        self.nodes[n as usize].vertex
    }
    /// Link `x -> y`.
    fn link(&mut self, x: u32, y: u32) {
        self.nodes[x as usize].next = y;
        self.nodes[y as usize].prev = x;
    }
    fn walk(&self, mut n: u32, steps: u32, forward: bool) -> u32 {
        for _ in 0..steps {
            n = if forward { self.next(n) } else { self.prev(n) };
        }
        n
    }
    /// Splice for S and M: the triangle (b, a, w) with gate `a -> b` and tip
    /// node `w`. The loop `a -> b` becomes `a -> w' -> (w's old successors)`,
    /// and `w -> b`. Returns the new node `w'`.
    fn splice(&mut self, a: u32, w: u32, facing_aw: u32, facing_wb: u32) -> u32 {
        let b = self.next(a);
        let after = self.next(w);
        let node = self.nodes[w as usize];
        let w2 = self.add(node.vertex, a, after, node.facing, node.loop_id);
        self.nodes[a as usize].facing = facing_aw;
        self.link(w, b);
        self.nodes[w as usize].facing = facing_wb;
        w2
    }
}

/// Codes `triangles` (indices into `vertex_count` vertices).
pub fn encode(triangles: &[[u32; 3]], vertex_count: u32) -> Result<(Connectivity, Order), CodingError> {
    let closed = close(triangles, vertex_count)?;
    let mut encoder = Encoder::new(&closed);
    // Components with a boundary first, each from the first of its loops of
    // three edges or more, then the others from a triangle. A dummy triangle
    // is (w, u, d), its boundary edge w -> u; the triangle across u -> d is
    // the loop's next, (u, y, d).
    let real = closed.real_triangles;
    for start in (real..encoder.visited.len() as u32).chain(0..real) {
        if let Some(gate) = encoder.first_loop(start) {
            encoder.traverse(gate);
        }
    }
    Ok(encoder.finish(vertex_count))
}

/// The encoder's state as it walks the closed mesh.
struct Encoder<'a> {
    closed: &'a Closed,
    visited: Vec<bool>,
    /// Closed vertex -> decoded index.
    decoded: Vec<u32>,
    /// Closed vertices in decoded order, and triangles in visiting order.
    emitted: Vec<u32>,
    triangle_order: Vec<u32>,
    out: Connectivity,
    loops: Loops,
    /// Per vertex, the first of its nodes (the rest follow by `same`).
    head: Vec<u32>,
    loop_len: Vec<u32>,
    /// Loops waiting after a split: (gate node, loop id).
    stack: Vec<(u32, u32)>,
    /// The loop being walked.
    current: u32,
    /// A first loop's vertices, the corners facing its edges, and the
    /// triangles it closes (kept to reuse their memory).
    ring: (Vec<u32>, Vec<u32>, Vec<u32>),
}

impl<'a> Encoder<'a> {
    fn new(closed: &'a Closed) -> Encoder<'a> {
        let (vertex_total, triangle_total) = (closed.source.len(), closed.corners.len() / 3);
        Encoder {
            closed,
            visited: vec![false; triangle_total],
            decoded: vec![NONE; vertex_total],
            emitted: Vec::with_capacity(vertex_total),
            triangle_order: Vec::with_capacity(triangle_total),
            out: Connectivity::default(),
            loops: Loops::default(),
            head: vec![NONE; vertex_total],
            loop_len: Vec::new(),
            stack: Vec::new(),
            current: 0,
            ring: Default::default(),
        }
    }

    fn emit(&mut self, v: u32) {
        self.decoded[v as usize] = self.emitted.len() as u32;
        self.emitted.push(v);
    }

    /// Adds node `n` to its vertex's list.
    fn attach(&mut self, n: u32) {
        let v = self.loops.vertex(n) as usize;
        self.loops.nodes[n as usize].same = self.head[v];
        self.head[v] = n;
    }

    /// Removes node `n` from its vertex's list.
    fn detach(&mut self, n: u32) {
        let v = self.loops.vertex(n) as usize;
        let after = self.loops.nodes[n as usize].same;
        if self.head[v] == n {
            self.head[v] = after;
            return;
        }
        let mut k = self.head[v];
        while self.loops.nodes[k as usize].same != n {
            k = self.loops.nodes[k as usize].same;
        }
        self.loops.nodes[k as usize].same = after;
    }

    /// Gives the nodes from `from` round to `to` the loop id `id`.
    fn relabel(&mut self, from: u32, to: u32, id: u32) {
        let mut k = from;
        loop {
            self.loops.nodes[k as usize].loop_id = id;
            if k == to {
                break;
            }
            k = self.loops.next(k);
        }
    }

    /// A component's first loop, from triangle `start` (a dummy's fan of
    /// three or more, or a real triangle), not yet visited; returns its gate.
    fn first_loop(&mut self, start: u32) -> Option<u32> {
        let Closed { corners, opposite, real_triangles, .. } = self.closed;
        if self.visited[start as usize] {
            return None;
        }
        let (mut v, mut facing, mut fan) = std::mem::take(&mut self.ring);
        v.clear();
        facing.clear();
        fan.clear();
        if start >= *real_triangles {
            let mut t = start;
            loop {
                fan.push(t);
                t = opposite[3 * t as usize] / 3;
                if t == start {
                    break;
                }
            }
            if fan.len() < 3 {
                self.ring = (v, facing, fan);
                return None;
            }
            for &t in &fan {
                self.visited[t as usize] = true;
                v.push(corners[3 * t as usize]);
                facing.push(3 * t + 2);
            }
            self.out.start_loops.push(fan.len() as u32);
        } else {
            let c0 = 3 * start;
            self.visited[start as usize] = true;
            fan.push(start);
            v.extend([corners[c0 as usize], corners[c0 as usize + 1], corners[c0 as usize + 2]]);
            facing.extend([c0 + 2, c0, c0 + 1]);
        }
        self.triangle_order.extend_from_slice(&fan);
        for &x in &v {
            self.emit(x);
        }
        self.current = self.loop_len.len() as u32;
        self.loop_len.push(v.len() as u32);
        let first = self.loops.ring(&v, &facing, self.current);
        for n in first..first + v.len() as u32 {
            self.attach(n);
        }
        self.ring = (v, facing, fan);
        Some(first)
    }

    /// Codes the component from `gate`, a symbol a triangle, until its
    /// loops are all closed.
    fn traverse(&mut self, mut gate: u32) {
        let Closed { corners, opposite, .. } = self.closed;
        loop {
            let a = gate;
            let b = self.loops.next(a);
            let c = opposite[self.loops.nodes[a as usize].facing as usize];
            let t = c / 3;
            self.visited[t as usize] = true;
            self.triangle_order.push(t);
            let w = corners[c as usize];
            if self.decoded[w as usize] == NONE {
                gate = self.new_vertex(a, b, c, w);
                continue;
            }
            let p = self.loops.prev(a);
            let q = self.loops.next(b);
            let left = opposite[self.loops.nodes[p as usize].facing as usize] / 3 == t;
            let right = opposite[self.loops.nodes[b as usize].facing as usize] / 3 == t;
            gate = match (left, right) {
                (true, true) => match self.close_loop(p, a, b, q) {
                    Some(g) => g,
                    None => break,
                },
                (true, false) => self.left(p, a, b, c),
                (false, true) => self.right(a, b, q, c),
                (false, false) => {
                    let tip = self.tip_node(w, c);
                    if self.loops.nodes[tip as usize].loop_id == self.current {
                        self.split(a, b, c, tip)
                    } else {
                        self.merge(a, b, c, tip)
                    }
                }
            };
        }
    }

    /// C (or D for a dummy): the tip `w` is new; the gate moves to it.
    fn new_vertex(&mut self, a: u32, b: u32, c: u32, w: u32) -> u32 {
        self.emit(w);
        self.out.symbols.push(if self.closed.source[w as usize] == NONE { D } else { C });
        self.loops.nodes[a as usize].facing = next(c);
        let nw = self.loops.add(w, a, b, prev(c), self.current);
        self.attach(nw);
        self.loop_len[self.current as usize] += 1;
        nw
    }

    /// E: across both sides, the loop is (w, a, b) and closes; the next gate
    /// is the last waiting loop's, if any. (A loop that touches itself at w
    /// cannot get here: each of w's nodes bounds its own wedge of unvisited
    /// triangles.)
    fn close_loop(&mut self, p: u32, a: u32, b: u32, q: u32) -> Option<u32> {
        debug_assert_eq!(p, q);
        self.out.symbols.push(E);
        for n in [p, a, b] {
            self.detach(n);
        }
        let (gate, id) = self.stack.pop()?;
        self.current = id;
        Some(gate)
    }

    /// L: the triangle closes the edge before the gate.
    fn left(&mut self, p: u32, a: u32, b: u32, c: u32) -> u32 {
        self.out.symbols.push(L);
        self.detach(a);
        self.loops.link(p, b);
        self.loops.nodes[p as usize].facing = prev(c);
        self.loop_len[self.current as usize] -= 1;
        p
    }

    /// R: the triangle closes the edge after the gate.
    fn right(&mut self, a: u32, b: u32, q: u32, c: u32) -> u32 {
        self.out.symbols.push(R);
        self.detach(b);
        self.loops.link(a, q);
        self.loops.nodes[a as usize].facing = next(c);
        self.loop_len[self.current as usize] -= 1;
        a
    }

    /// The node of the tip `w` (of corner `c`) whose unvisited wedge holds
    /// the triangle.
    fn tip_node(&self, w: u32, c: u32) -> u32 {
        let Closed { corners, opposite, .. } = self.closed;
        let mut nw = self.head[w as usize];
        if self.loops.nodes[nw as usize].same != NONE {
            let mut k = c;
            let x = loop {
                let k2 = prev(opposite[prev(k) as usize]);
                if self.visited[(k2 / 3) as usize] {
                    break corners[next(k) as usize];
                }
                k = k2;
            };
            while self.loops.vertex(self.loops.prev(nw)) != x {
                nw = self.loops.nodes[nw as usize].same;
            }
        }
        nw
    }

    /// S: the tip is on the current loop, which splits in two; the shorter
    /// part is walked first, the other waits on the stack.
    fn split(&mut self, a: u32, b: u32, c: u32, nw: u32) -> u32 {
        self.out.symbols.push(S);
        // Walk both ways from the gate to find the shorter part.
        let (mut f, mut g, mut steps) = (b, a, 0u32);
        let right_shorter = loop {
            if f == nw {
                break true;
            }
            if g == nw {
                break false;
            }
            f = self.loops.next(f);
            g = self.loops.prev(g);
            steps += 1;
        };
        let current = self.current;
        let len = self.loop_len[current as usize];
        let (l1, l2) = if right_shorter { (steps + 1, len + 1 - (steps + 1)) } else { (len + 1 - (steps + 1), steps + 1) };
        let w2 = self.loops.splice(a, nw, next(c), prev(c));
        self.attach(w2);
        let fresh = self.loop_len.len() as u32;
        let start = if right_shorter { nw } else { a };
        self.relabel(start, self.loops.prev(start), fresh);
        if right_shorter {
            self.loop_len.push(l1);
            self.loop_len[current as usize] = l2;
            self.stack.push((a, current));
            self.current = fresh;
        } else {
            self.loop_len.push(l2);
            self.loop_len[current as usize] = l1;
            self.stack.push((a, fresh));
        }
        nw
    }

    /// M: the tip is on a waiting loop, which joins the current one.
    fn merge(&mut self, a: u32, b: u32, c: u32, nw: u32) -> u32 {
        self.out.symbols.push(M);
        let other = self.loops.nodes[nw as usize].loop_id;
        let position = self.stack.iter().rposition(|&(_, id)| id == other).expect("a loop other than the current one is on the stack");
        let (other_gate, _) = self.stack.remove(position);
        let mut offset = 0;
        let mut k = other_gate;
        while k != nw {
            k = self.loops.next(k);
            offset += 1;
        }
        let length = self.loop_len[other as usize];
        self.out.merges.push(Merge { depth: (self.stack.len() - position) as u32, offset, length });
        let w2 = self.loops.splice(a, nw, next(c), prev(c));
        self.attach(w2);
        let current = self.current;
        let total = self.loop_len[current as usize] + length + 1;
        // Relabel the shorter part (the waiting loop's nodes run from w2 to
        // nw, the current one's from b round to a): walking the whole merged
        // loop would be quadratic.
        let (keep, from, to) = if self.loop_len[current as usize] >= length { (current, w2, nw) } else { (other, b, a) };
        self.relabel(from, to, keep);
        self.loop_len[keep as usize] = total;
        self.current = keep;
        nw
    }

    /// The connectivity and the order of the input's vertices and triangles.
    fn finish(self, vertex_count: u32) -> (Connectivity, Order) {
        let Encoder { closed, emitted, triangle_order, mut out, .. } = self;
        let triangle_total = closed.corners.len() / 3;
        debug_assert_eq!(triangle_order.len(), triangle_total);
        // The start loops' fans are not decoded.
        out.triangle_count = triangle_total as u32 - out.start_loops.iter().sum::<u32>();
        out.vertex_count = emitted.len() as u32;
        // Of the copies of an input vertex, the first decoded is kept.
        let mut first = vec![NONE; vertex_count as usize];
        let mut order = Order::default();
        for (i, &v) in emitted.iter().enumerate() {
            let s = closed.source[v as usize];
            if s == NONE {
                continue; // a dummy, marked by its D
            }
            if first[s as usize] != NONE {
                out.copies.push([i as u32, first[s as usize]]);
            } else {
                first[s as usize] = i as u32;
                order.vertices.push(s);
            }
        }
        order.triangles = triangle_order.into_iter().filter(|&t| t < closed.real_triangles).collect();
        (out, order)
    }
}

/// Per decoded vertex, its index among kept vertices (copies take their
/// original's, dummies NONE). Kept vertices keep their decoded order.
pub(crate) fn keep_vertices(vertex_count: u32, dummies: &[u32], copies: &[[u32; 2]]) -> Result<(Vec<u32>, u32), CodingError> {
    const COPY: u32 = NONE - 1;
    let mut keep = vec![0u32; vertex_count as usize];
    for &d in dummies {
        match keep.get_mut(d as usize) {
            Some(k) if *k == 0 => *k = NONE,
            _ => return corrupt(format!("dummy vertex {d} of {vertex_count}")),
        }
    }
    for &[copy, original] in copies {
        if copy >= vertex_count || original >= copy || keep[original as usize] != 0 || keep[copy as usize] != 0 {
            return corrupt(format!("copy {copy} of vertex {original} ({vertex_count} vertices)"));
        }
        keep[copy as usize] = COPY;
    }
    let mut kept = 0;
    for k in keep.iter_mut() {
        if *k == 0 {
            *k = kept;
            kept += 1;
        }
    }
    for &[copy, original] in copies {
        keep[copy as usize] = keep[original as usize];
    }
    Ok((keep, kept))
}

/// A decoded mesh, before dummies and copies are resolved.
#[derive(Clone, Debug, Default)]
pub struct Decoded {
    /// Triangles over decoded vertices, dummies included.
    pub triangles: Vec<[u32; 3]>,
    /// Per decoded vertex, the vertices that predict it: `[a, b, o]` for the
    /// parallelogram `a + b - o` across the gate it was added on; a component's
    /// first three vertices have `[NONE; 3]`, `[v0, NONE, NONE]` and
    /// `[v0, v1, NONE]`; a start loop's vertices `[the one before, NONE, NONE]`.
    pub predictors: Vec<[u32; 3]>,
    /// Per decoded vertex, its index among kept ones (NONE for dummies).
    pub keep: Vec<u32>,
    pub kept_vertices: u32,
}

/// Rebuilds the triangles and per-vertex predictors from `code`.
pub fn decode(code: &Connectivity) -> Result<Decoded, CodingError> {
    decode_listed(code, false).map(|(decoded, _)| decoded)
}

/// What the walk met at a symbol, as versions 5 and 6 code it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Met {
    /// The gate the symbol acts on (its context).
    pub gate: Gate,
    /// For an S: the length of its right loop, which versions 5 and 6 code after it.
    pub split: u32,
    /// The symbol is its component's first.
    pub starts: bool,
}

/// The gate a symbol acts on, as the decoder sees it before the symbol.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Gate {
    /// The length of its loop.
    pub length: u32,
    /// The loop's edge after the gate lies on the mesh's boundary (on a
    /// start loop, no triangle decoded across it).
    pub next_on_boundary: bool,
}

/// [`decode`], with what the walk met at each symbol.
pub(crate) fn decode_walked(code: &Connectivity) -> Result<(Decoded, Vec<Met>), CodingError> {
    decode_listed(code, true)
}

fn decode_listed(code: &Connectivity, record: bool) -> Result<(Decoded, Vec<Met>), CodingError> {
    let symbols = &code.symbols;
    if code.triangle_count > MAX_TRIANGLES || code.vertex_count > code.triangle_count.saturating_mul(3) {
        return corrupt(format!("{} triangles, {} vertices", code.triangle_count, code.vertex_count));
    }
    let (ends, splits) = components(code)?;
    let right_lens = right_loop_lengths(code, &ends, splits)?;
    if code.dummy_starts as usize > ends.len() {
        return corrupt(format!("{} components start at a dummy, of {}", code.dummy_starts, ends.len()));
    }
    // Forwards: rebuild, popping the right loops' lengths.
    let mut listed =
        Listed { code, at: 0, component: 0, right_lens, merges: 0, met: record.then(|| Vec::with_capacity(symbols.len())), starting: false };
    let (mut out, mut dummies) = rebuild(&mut listed, symbols.len(), code.triangle_count, code.vertex_count, code.dummy_starts)?;
    // A dummy in two lists is refused as a repeat.
    dummies.extend_from_slice(&code.dummies);
    dummies.sort_unstable();
    (out.keep, out.kept_vertices) = keep_vertices(code.vertex_count, &dummies, &code.copies)?;
    Ok((out, listed.met.unwrap_or_default()))
}

/// The first pass: where each component ends (at an E with an empty stack)
/// and how many S symbols there are, checked against the counts declared.
/// Each component starts with three vertices (or its start loop's) and
/// brings one more per C; in version 3 files the first vertices of the first
/// `dummy_starts` components are dummies.
fn components(code: &Connectivity) -> Result<(Vec<usize>, usize), CodingError> {
    let symbols = &code.symbols;
    let loops_in = code.start_loops.len();
    if code.dummy_starts > 0 && loops_in > 0 {
        return corrupt("components start both at dummies and at loops");
    }
    if code.start_loops.iter().any(|&k| k < 3) {
        return corrupt("a start loop of fewer than three vertices");
    }
    let loop_vertices: u64 = code.start_loops.iter().map(|&k| k as u64).sum();
    // Arrays are sized up front (regrowing them was a few per cent of a small
    // mesh's decoding): from the first pass's counts where it has them, and
    // here, before it, a guess of a component per 16 symbols.
    let mut ends = Vec::with_capacity(loops_in + 1 + symbols.len() / 16);
    let mut depth = 0u32;
    let mut splits = 0usize;
    let mut merges = 0usize;
    let mut new_vertices = 0u32;
    for (i, &s) in symbols.iter().enumerate() {
        // C, L and R, most symbols, only count new vertices (no branch on which).
        if s <= R {
            new_vertices += u32::from(s == C);
            continue;
        }
        match s {
            S => {
                depth += 1;
                splits += 1;
            }
            D => new_vertices += 1,
            E if depth == 0 => ends.push(i),
            E => depth -= 1,
            M => {
                let Some(m) = code.merges.get(merges) else { return corrupt("more M symbols than merge records") };
                if m.depth >= depth {
                    return corrupt(format!("merge with loop {} of {depth} waiting", m.depth));
                }
                depth -= 1;
                merges += 1;
            }
            _ => return corrupt(format!("symbol {s}")),
        }
    }
    if merges != code.merges.len() || depth != 0 || ends.last().map_or(!symbols.is_empty(), |&e| e + 1 != symbols.len()) {
        return corrupt("symbols end inside a component");
    }
    if loops_in > ends.len() {
        return corrupt(format!("{loops_in} components start at a loop, of {}", ends.len()));
    }
    if symbols.len() + ends.len() - loops_in != code.triangle_count as usize {
        return corrupt(format!(
            "{} symbols and {} components, {loops_in} of them from a loop, for {} triangles",
            symbols.len(),
            ends.len(),
            code.triangle_count
        ));
    }
    let vertices = new_vertices as u64 + 3 * (ends.len() - loops_in) as u64 + loop_vertices;
    if vertices != code.vertex_count as u64 {
        return corrupt(format!("{vertices} vertices decoded, {} declared", code.vertex_count));
    }
    Ok((ends, splits))
}

/// Backwards over each component: the lengths of the loops, so of each S's
/// right loop. They are found last S first, so the forward pass pops them.
fn right_loop_lengths(code: &Connectivity, ends: &[usize], splits: usize) -> Result<Vec<u32>, CodingError> {
    let symbols = &code.symbols;
    let mut right_lens: Vec<u32> = Vec::with_capacity(splits);
    let mut stack: Vec<u32> = Vec::new();
    let mut merge_index = code.merges.len();
    let mut end = symbols.len();
    // No loop is longer than every vertex twice over (a bound for hostile input).
    let limit = code.vertex_count.saturating_mul(2).saturating_add(3);
    for (k, &last) in ends.iter().enumerate().rev() {
        let begin = if k == 0 { 0 } else { ends[k - 1] + 1 };
        debug_assert_eq!(last + 1, end);
        let mut cur: Option<u32> = None;
        stack.clear();
        for i in (begin..end).rev() {
            let bad = || corrupt::<()>(format!("loop lengths do not add up at symbol {i}"));
            // C shortens the loop by one (of more than three), L and R lengthen
            // it: most symbols, done without a branch on which (D, a C, has one).
            let s = symbols[i];
            if let Some(x) = cur.filter(|&x| s <= R && x >= 2 + u32::from(s == C)) {
                let x = x + 1 - 2 * u32::from(s == C);
                if x > limit {
                    bad()?;
                }
                cur = Some(x);
                continue;
            }
            match (s, cur) {
                (E, _) => {
                    if let Some(x) = cur {
                        stack.push(x);
                    }
                    cur = Some(3);
                }
                (_, None) => bad()?,
                (C | D, Some(x)) if x >= 3 => cur = Some(x - 1),
                (L | R, Some(x)) => cur = Some(x + 1),
                (S, Some(x)) if x >= 2 => {
                    let Some(l2) = stack.pop().filter(|&l2| l2 >= 2) else { return corrupt(format!("S without a left loop at symbol {i}")) };
                    right_lens.push(x);
                    cur = Some(x + l2 - 1);
                }
                (M, Some(x)) => {
                    merge_index -= 1;
                    let m = code.merges[merge_index];
                    let before = x.checked_sub(m.length + 1).filter(|&b| b >= 2 && m.length >= 2 && m.offset < m.length);
                    let Some(before) = before else { return corrupt(format!("merge {merge_index} does not fit its loops")) };
                    let at = (stack.len() as u32).checked_sub(m.depth);
                    let Some(at) = at else { return corrupt(format!("merge {merge_index} depth")) };
                    stack.insert(at as usize, m.length);
                    cur = Some(before);
                }
                _ => bad()?,
            }
            if cur.is_some_and(|x| x > limit) {
                bad()?;
            }
        }
        if cur != Some(code.start_loops.get(k).copied().unwrap_or(3)) || !stack.is_empty() {
            return corrupt(format!("component {k} does not start with its first loop"));
        }
        end = begin;
    }
    Ok(right_lens)
}

/// One symbol of the walk with what comes with it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Step {
    pub symbol: u8,
    /// For an S: the length of its right loop (walked first).
    pub split: u32,
    /// For an M: its record.
    pub merge: Merge,
}

/// Where [`rebuild`] reads the walk: a [`Connectivity`]'s lists, or a
/// stream read as it goes (version 5 and 6 files, whose symbols' contexts depend
/// on the loop being walked).
pub(crate) trait Walk {
    /// A component starts: its start loop's length, or None (it starts from a triangle).
    fn start(&mut self) -> Result<Option<u32>, CodingError>;
    /// The next symbol, at `gate`.
    fn step(&mut self, gate: Gate) -> Result<Step, CodingError>;
}

/// A [`Connectivity`]'s lists, checked beforehand, as a [`Walk`].
struct Listed<'a> {
    code: &'a Connectivity,
    at: usize,
    component: usize,
    /// Last S first.
    right_lens: Vec<u32>,
    merges: usize,
    /// When asked for: what the walk met at each symbol.
    met: Option<Vec<Met>>,
    /// A component has started and its first symbol is still to come.
    starting: bool,
}

impl Walk for Listed<'_> {
    fn start(&mut self) -> Result<Option<u32>, CodingError> {
        self.component += 1;
        self.starting = true;
        Ok(self.code.start_loops.get(self.component - 1).copied())
    }
    #[inline(always)]
    fn step(&mut self, gate: Gate) -> Result<Step, CodingError> {
        let symbol = self.code.symbols[self.at];
        self.at += 1;
        let mut step = Step { symbol, split: 0, merge: Merge { depth: 0, offset: 0, length: 0 } };
        match symbol {
            S => step.split = self.right_lens.pop().ok_or_else(|| CodingError::Corrupt("an S without its loop length".into()))?,
            M => {
                step.merge = *self.code.merges.get(self.merges).ok_or_else(|| CodingError::Corrupt("more M symbols than merge records".into()))?;
                self.merges += 1;
            }
            _ => {}
        }
        if let Some(met) = &mut self.met {
            met.push(Met { gate, split: step.split, starts: std::mem::take(&mut self.starting) });
        }
        Ok(step)
    }
}

/// Rebuilds the triangles and per-vertex predictors from `walk`: `symbols`
/// symbols, for the `triangle_count` triangles and `vertex_count` vertices
/// declared (the first vertex of each of the first `dummy_starts`
/// components is a dummy: version 3). Every step is checked against the
/// loop it acts on, so that a walk read as it goes (not checked before)
/// gives an error, never a broken loop. Returns the mesh (its `keep` left
/// empty) and the dummies met, ascending.
pub(crate) fn rebuild(
    walk: &mut impl Walk,
    symbols: usize,
    triangle_count: u32,
    vertex_count: u32,
    dummy_starts: u32,
) -> Result<(Decoded, Vec<u32>), CodingError> {
    if triangle_count > MAX_TRIANGLES || vertex_count > triangle_count.saturating_mul(3) || symbols > triangle_count as usize {
        return corrupt(format!("{triangle_count} triangles, {vertex_count} vertices, {symbols} symbols"));
    }
    let mut r = Rebuilder {
        out: Decoded {
            triangles: Vec::with_capacity(triangle_count as usize),
            predictors: Vec::with_capacity(vertex_count as usize),
            keep: Vec::new(),
            kept_vertices: 0,
        },
        dummies: Vec::new(),
        loops: Loops::default(),
        waiting: Vec::new(),
        vertex_count,
        ring: Vec::new(),
        facing: Vec::new(),
    };
    // A node a vertex, and one more for each S's and M's tip.
    r.loops.nodes.reserve(vertex_count as usize + symbols / 8);
    let (mut read, mut component) = (0usize, 0u32);
    while read < symbols {
        let (mut gate, mut len) = r.first_loop(walk, component < dummy_starts)?;
        component += 1;
        loop {
            if read == symbols {
                return corrupt("symbols end inside a component");
            }
            if r.out.triangles.len() as u32 >= triangle_count {
                return corrupt(format!("more than the {triangle_count} triangles declared"));
            }
            // (Only start loops' edges face no vertex. The edge before the
            // gate too, one more dependent load a symbol, slowed decoding by
            // 4 % for 0.4 % fewer bytes over 35 levels, none on the Crytek
            // Sponza's.)
            let next_on_boundary = r.loops.nodes[r.loops.next(gate) as usize].facing == NONE;
            let step = walk.step(Gate { length: len, next_on_boundary })?;
            read += 1;
            match r.apply(step, gate, len, read - 1)? {
                Some(next) => (gate, len) = next,
                None => break,
            }
        }
    }
    let Rebuilder { out, dummies, .. } = r;
    if out.triangles.len() as u32 != triangle_count || out.predictors.len() as u32 != vertex_count {
        return corrupt(format!(
            "{} triangles and {} vertices decoded, {triangle_count} and {vertex_count} declared",
            out.triangles.len(),
            out.predictors.len()
        ));
    }
    Ok((out, dummies))
}

/// The decoder's state as it rebuilds the mesh.
struct Rebuilder {
    out: Decoded,
    /// The dummy vertices met.
    dummies: Vec<u32>,
    loops: Loops,
    /// Loops waiting after a split: (gate node, length).
    waiting: Vec<(u32, u32)>,
    vertex_count: u32,
    /// A start loop's vertices and facing corners (kept to reuse their memory).
    ring: Vec<u32>,
    facing: Vec<u32>,
}

impl Rebuilder {
    fn new_vertex(&mut self, predictor: [u32; 3]) -> Result<u32, CodingError> {
        if self.out.predictors.len() as u32 >= self.vertex_count {
            return corrupt(format!("more than the {} vertices declared", self.vertex_count));
        }
        self.out.predictors.push(predictor);
        Ok(self.out.predictors.len() as u32 - 1)
    }

    /// A component's first loop: a start loop the walk names, or a first
    /// triangle (its first vertex a dummy when `dummy`); returns its gate
    /// and length.
    #[inline]
    fn first_loop(&mut self, walk: &mut impl Walk, dummy: bool) -> Result<(u32, u32), CodingError> {
        if let Some(len) = walk.start()? {
            // A boundary loop, each vertex predicted by the one before (on
            // the Crytek Sponza's base, extending the edge before it cost
            // 1.6 % more position bytes); its edges face the dummy, which is
            // not decoded.
            if len < 3 || len as usize > (self.vertex_count as usize).saturating_sub(self.out.predictors.len()) {
                return corrupt(format!("a start loop of {len} vertices"));
            }
            let (mut ring, mut facing) = (std::mem::take(&mut self.ring), std::mem::take(&mut self.facing));
            ring.clear();
            let mut previous = NONE;
            for _ in 0..len {
                previous = self.new_vertex([previous, NONE, NONE])?;
                ring.push(previous);
            }
            facing.clear();
            facing.resize(len as usize, NONE);
            let gate = self.loops.ring(&ring, &facing, 0);
            (self.ring, self.facing) = (ring, facing);
            Ok((gate, len))
        } else {
            let v0 = self.new_vertex([NONE; 3])?;
            let v1 = self.new_vertex([v0, NONE, NONE])?;
            let v2 = self.new_vertex([v0, v1, NONE])?;
            if dummy {
                self.dummies.push(v0);
            }
            self.out.triangles.push([v0, v1, v2]);
            Ok((self.loops.ring(&[v0, v1, v2], &[v2, v0, v1], 0), 3))
        }
    }

    /// Applies symbol number `at` at the gate of a loop of `len`: its
    /// triangle, and the next gate and loop length (`None` when the
    /// component is done).
    #[inline]
    fn apply(&mut self, step: Step, gate: u32, len: u32, at: usize) -> Result<Option<(u32, u32)>, CodingError> {
        let Step { symbol: s, split, merge: m } = step;
        let loops = &mut self.loops;
        let a = gate;
        let b = loops.next(a);
        let (va, vb) = (loops.vertex(a), loops.vertex(b));
        let (w, next) = match s {
            C | D => {
                let w = self.new_vertex([va, vb, self.loops.nodes[a as usize].facing])?;
                if s == D {
                    self.dummies.push(w);
                }
                let loops = &mut self.loops;
                loops.nodes[a as usize].facing = vb;
                (w, (loops.add(w, a, b, va, 0), len + 1))
            }
            L | R if len < 3 => return corrupt(format!("an {} on a loop of {len} at symbol {at}", if s == L { 'L' } else { 'R' })),
            L => {
                let p = loops.prev(a);
                loops.link(p, b);
                loops.nodes[p as usize].facing = va;
                (loops.vertex(p), (p, len - 1))
            }
            R => {
                let q = loops.next(b);
                loops.link(a, q);
                loops.nodes[a as usize].facing = vb;
                (loops.vertex(q), (a, len - 1))
            }
            E if len != 3 => return corrupt(format!("an E on a loop of {len} at symbol {at}")),
            E => {
                let w = loops.vertex(loops.prev(a));
                self.out.triangles.push([vb, va, w]);
                return Ok(self.waiting.pop());
            }
            S => {
                let l1 = split;
                let Some(l2) = (len + 1).checked_sub(l1).filter(|&l2| l2 >= 2 && l1 >= 2) else {
                    return corrupt(format!("S at symbol {at} splits a loop of {len} at {l1}"));
                };
                let nw = if l1 <= l2 { loops.walk(b, l1 - 1, true) } else { loops.walk(a, l2 - 1, false) };
                loops.splice(a, nw, vb, va);
                self.waiting.push((a, l2));
                (loops.vertex(nw), (nw, l1))
            }
            M => {
                let Some(at) = (self.waiting.len() as u32).checked_sub(m.depth.saturating_add(1)) else {
                    return corrupt(format!("merge with loop {} of {} waiting", m.depth, self.waiting.len()));
                };
                let (g, length) = self.waiting.remove(at as usize);
                if length != m.length || m.offset >= length {
                    return corrupt(format!("a merge names a loop of {} at {} that has {length}", m.length, m.offset));
                }
                let nw = loops.walk(g, m.offset, true);
                loops.splice(a, nw, vb, va);
                (loops.vertex(nw), (nw, len + length + 1))
            }
            _ => return corrupt(format!("symbol {s}")),
        };
        self.out.triangles.push([vb, va, w]);
        Ok(Some(next))
    }
}

impl Decoded {
    /// The kept triangles (none touching a dummy) over kept vertices, with
    /// copies merged back; taken out of `self`, in place.
    pub fn resolve(&mut self) -> Vec<[u32; 3]> {
        let mut triangles = std::mem::take(&mut self.triangles);
        let keep = &self.keep;
        // Without a branch on whether a triangle stays: dummies' fans come
        // and go with no pattern to predict.
        let mut kept = 0;
        for i in 0..triangles.len() {
            let t = triangles[i].map(|v| keep[v as usize]);
            triangles[kept] = t;
            kept += usize::from((t[0] != NONE) & (t[1] != NONE) & (t[2] != NONE));
        }
        triangles.truncate(kept);
        triangles
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Triangles as sets of cyclic rotations, so that two lists compare equal
    /// when they hold the same oriented triangles.
    pub(crate) fn canonical(triangles: impl IntoIterator<Item = [u32; 3]>) -> Vec<[u32; 3]> {
        let mut out: Vec<[u32; 3]> = triangles
            .into_iter()
            .map(|t| {
                let r = (0..3).min_by_key(|&i| t[i]).unwrap();
                [t[r], t[(r + 1) % 3], t[(r + 2) % 3]]
            })
            .collect();
        out.sort_unstable();
        out
    }

    /// Encodes, decodes and checks the decoded triangles are the input's.
    pub(crate) fn round_trip(triangles: &[[u32; 3]], vertex_count: u32) -> Connectivity {
        let (code, order) = encode(triangles, vertex_count).unwrap();
        let mut decoded = decode(&code).unwrap_or_else(|e| panic!("{e}: {triangles:?} {code:?}"));
        let got = decoded.resolve();
        assert_eq!(got.len(), triangles.len());
        assert_eq!(order.triangles.len(), triangles.len());
        // Decoded vertex i is input vertex order.vertices[i].
        let mapped = canonical(got.iter().map(|t| t.map(|v| order.vertices[v as usize])));
        assert_eq!(mapped, canonical(triangles.iter().copied()));
        // Triangle by triangle too.
        for (k, t) in got.iter().enumerate() {
            let input = triangles[order.triangles[k] as usize];
            assert_eq!(canonical([t.map(|v| order.vertices[v as usize])]), canonical([input]));
        }
        code
    }

    pub(crate) fn grid(n: u32) -> Vec<[u32; 3]> {
        let mut t = Vec::new();
        for y in 0..n {
            for x in 0..n {
                let v = y * (n + 1) + x;
                t.push([v, v + 1, v + n + 2]);
                t.push([v, v + n + 2, v + n + 1]);
            }
        }
        t
    }

    /// A torus of `n` × `m` quads (genus one, so one handle).
    pub(crate) fn torus(n: u32, m: u32) -> Vec<[u32; 3]> {
        let mut t = Vec::new();
        let id = |i: u32, j: u32| (i % n) * m + j % m;
        for i in 0..n {
            for j in 0..m {
                t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        t
    }

    #[test]
    fn tetrahedron_is_one_triangle_and_three_symbols() {
        let tris = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];
        let code = round_trip(&tris, 4);
        assert_eq!(code.symbols.len(), 3);
        assert!(code.dummies.is_empty() && code.copies.is_empty() && code.merges.is_empty());
        assert_eq!((code.symbols[0], code.symbols[2]), (C, E));
    }

    /// A grid walked from its boundary loop meets a boundary edge after the
    /// gate on its first symbol and on some more (each of the 32 boundary
    /// edges is taken once, by the triangle across it); a closed torus never
    /// does.
    #[test]
    fn gates_see_the_boundary_edge_after_them() {
        let (code, _) = encode(&grid(8), 81).unwrap();
        let (_, met) = decode_walked(&code).unwrap();
        assert_eq!(met[0].gate, Gate { length: 32, next_on_boundary: true }, "the first gate lies on the 32-edge boundary");
        let bordered = met.iter().filter(|m| m.gate.next_on_boundary).count();
        assert!(bordered > 8 && bordered < met.len(), "{bordered} of {}", met.len());
        let (code, _) = encode(&torus(6, 5), 30).unwrap();
        let (_, met) = decode_walked(&code).unwrap();
        assert!(met.iter().all(|m| !m.gate.next_on_boundary));
    }

    #[test]
    fn open_grid_starts_from_its_boundary_and_codes_no_dummy() {
        let tris = grid(8);
        let code = round_trip(&tris, 81);
        // The 32 boundary edges are the first loop; no dummy is decoded.
        assert_eq!(code.start_loops, [32]);
        assert!(code.dummies.is_empty() && code.merges.is_empty());
        assert!(decode(&code).unwrap().keep.iter().all(|&k| k != NONE));
        // A symbol a triangle; the 49 inner vertices each arrive by a C.
        assert_eq!((code.symbols.len(), code.triangle_count, code.vertex_count), (128, 128, 81));
        let cs = code.symbols.iter().filter(|&&s| s == C).count();
        assert_eq!(cs, 49);
    }

    #[test]
    fn a_second_hole_keeps_its_dummy_and_a_two_edge_loop_starts_no_component() {
        // The grid with its middle quad removed: the outer loop starts the
        // walk, the hole's dummy is decoded and listed.
        let mut tris = grid(4);
        let middle = 2 * (2 * 4 + 1);
        tris.drain(middle..middle + 2);
        let code = round_trip(&tris, 25);
        assert_eq!((code.start_loops.len(), code.symbols.iter().filter(|&&s| s == D).count()), (1, 1));
        assert!(code.dummies.is_empty());
        assert!([4, 16].contains(&code.start_loops[0]), "{:?}", code.start_loops);
        // A tetrahedron with a fin on its edge 0-1: the edge's three uses are
        // cut, so the tetrahedron gets a boundary loop of two edges (0 -> 1 and
        // 1 -> 0), which cannot start a walk: the tetrahedron starts from a
        // triangle and that loop's dummy comes by a D. The fin, apart (its
        // corners 0 and 1 are copies), starts from its loop of three.
        let fin = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3], [0, 1, 4]];
        let code = round_trip(&fin, 5);
        assert_eq!(code.start_loops, [3]);
        assert_eq!(code.symbols.iter().filter(|&&s| s == D).count(), 1);
        assert_eq!(code.copies.len(), 2);
    }

    #[test]
    fn torus_handle_is_one_merge() {
        let tris = torus(6, 5);
        let code = round_trip(&tris, 30);
        assert!(code.dummies.is_empty());
        assert_eq!(code.merges.len(), 1, "{:?}", code.symbols);
        // Two handles.
        let mut double = torus(6, 5);
        double.extend(torus(4, 4).iter().map(|t| t.map(|v| v + 30)));
        let code = round_trip(&double, 46);
        assert_eq!(code.merges.len(), 2);
    }

    #[test]
    fn non_manifold_input_round_trips() {
        // Bowtie: two triangles sharing only a vertex; a fin: three triangles
        // on one edge; a flipped neighbour; a duplicate; an unused vertex.
        let tris = [[0, 1, 2], [0, 3, 4], [5, 6, 7], [5, 7, 8], [6, 5, 9], [5, 6, 10], [10, 11, 5], [0, 1, 2], [2, 1, 12]];
        let code = round_trip(&tris, 14);
        assert!(!code.copies.is_empty());
    }

    /// Random soups over few vertices (non-manifold edges and vertices, flips),
    /// tori with holes or pinched at a vertex, and surfaces of genus up to 4.
    #[test]
    fn random_soups_round_trip() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut rand = |n: u32| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 33) % n as u64) as u32
        };
        let mut merges = 0;
        for k in 0..3000 {
            let (vertices, mut tris) = if k % 3 == 2 {
                // Tori joined through a removed triangle each: genus up to 4.
                let mut tris = torus(3 + rand(5), 3 + rand(5));
                let mut vertices = tris.iter().flatten().max().unwrap() + 1;
                for _ in 0..1 + rand(3) {
                    let (n, m) = (3 + rand(5), 3 + rand(5));
                    let hole = tris.swap_remove(rand(tris.len() as u32) as usize);
                    let mut other = torus(n, m);
                    let [p, q, r] = other.swap_remove(rand(other.len() as u32) as usize);
                    let glue = |v: u32| {
                        if v == p {
                            hole[1]
                        } else if v == q {
                            hole[0]
                        } else if v == r {
                            hole[2]
                        } else {
                            v + vertices
                        }
                    };
                    tris.extend(other.iter().map(|t| t.map(glue)));
                    vertices += n * m;
                }
                (vertices, tris)
            } else if k % 3 == 0 {
                let vertices = 4 + rand(12);
                let count = 1 + rand(40);
                let mut tris = Vec::new();
                while tris.len() < count as usize {
                    let t = [rand(vertices), rand(vertices), rand(vertices)];
                    if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                        tris.push(t);
                    }
                }
                (vertices, tris)
            } else {
                // Tori, some with holes, some glued at a vertex.
                let (n, m) = (3 + rand(6), 3 + rand(6));
                let mut tris = torus(n, m);
                for _ in 0..rand(4) {
                    let i = rand(tris.len() as u32) as usize;
                    tris.swap_remove(i);
                }
                if rand(2) == 0 {
                    let (from, to) = (rand(n * m), rand(n * m));
                    tris.iter_mut().for_each(|t| {
                        t.iter_mut().for_each(|v| {
                            if *v == from {
                                *v = to
                            }
                        })
                    });
                    tris.retain(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
                }
                (n * m, tris)
            };
            // Shuffle triangles so the traversal starts anywhere.
            for i in (1..tris.len()).rev() {
                tris.swap(i, rand(i as u32 + 1) as usize);
            }
            let code = round_trip(&tris, vertices);
            merges += code.merges.len();
        }
        assert!(merges > 1000, "merges {merges}");
    }

    #[test]
    fn hostile_connectivity_is_an_error() {
        let (code, _) = encode(&torus(5, 5), 25).unwrap();
        // Every single-symbol change, truncation and count change either
        // decodes consistently or errors; never panics.
        for i in 0..code.symbols.len() {
            for s in 0..9u8 {
                let mut bad = code.clone();
                bad.symbols[i] = s;
                let _ = decode(&bad);
            }
            let mut short = code.clone();
            short.symbols.truncate(i);
            assert!(decode(&short).is_err());
        }
        // A wrong offset or length can still fit the loops: it decodes,
        // wrongly (the container's checksum catches that), and must not panic.
        for delta in [1u32, 2, 1000, u32::MAX / 2] {
            let mut bad = code.clone();
            bad.merges[0].offset = bad.merges[0].offset.wrapping_add(delta);
            let _ = decode(&bad);
            bad.merges[0].length = bad.merges[0].length.wrapping_add(delta);
            let _ = decode(&bad);
        }
        for field in [0, 1] {
            for delta in [1u32, 2, 1000, u32::MAX / 2] {
                let mut bad = code.clone();
                match field {
                    0 => bad.triangle_count = bad.triangle_count.wrapping_add(delta),
                    _ => bad.vertex_count = bad.vertex_count.wrapping_add(delta),
                }
                assert!(decode(&bad).is_err(), "field {field} + {delta}");
            }
        }
        // One vertex fewer or more than three a component and one a C: refused
        // before the rebuild, by name.
        for count in [code.vertex_count - 1, code.vertex_count + 1] {
            let bad = Connectivity { vertex_count: count, ..code.clone() };
            assert!(matches!(decode(&bad), Err(CodingError::Corrupt(m)) if m.ends_with(&format!("vertices decoded, {count} declared"))), "{count}");
        }
        let mut bad = code.clone();
        bad.dummies.push(3);
        bad.copies.push([2, 7]);
        assert!(decode(&bad).is_err());
        // Start loops of a wrong length, too short, too many, or mixed with
        // version 3's dummy starts: refused.
        let (code, _) = encode(&grid(6), 49).unwrap();
        assert_eq!(code.start_loops, [24]);
        for loops in [vec![23], vec![25], vec![2], vec![0], vec![u32::MAX], vec![24, 3], vec![]] {
            let bad = Connectivity { start_loops: loops.clone(), ..code.clone() };
            assert!(decode(&bad).is_err(), "{loops:?}");
        }
        assert!(decode(&Connectivity { dummy_starts: 1, ..code.clone() }).is_err());
    }
}

//! Vertex splits, coded: the refinements of a progressive mesh (Hoppe,
//! "Progressive Meshes", 1996) in packets that a viewer applies, in order,
//! to the coarse base it already shows.
//!
//! A [`Refiner`] holds the mesh as the decoder has it, with each vertex's
//! triangles. The encoder runs one too and predicts from exactly what the
//! decoder will hold, so no prediction can drift.
//!
//! What a split costs, field by field:
//! - the vertex: raw bits, as many as the vertex count needs;
//! - its restored position and the new vertex's, quantized on the stream's
//!   grid: the first from where the vertex is now, the second from
//!   `2·now − restored` (the collapse put the vertex between the two);
//! - colours: the vertex's restored colour from its colour now, the new
//!   vertex's from that;
//! - which of the vertex's triangles move to the new vertex: a bit each,
//!   modelled on whether the triangle lies nearer the new vertex;
//! - the triangles that come back: each corner is the vertex, the new one,
//!   one of their neighbours (common neighbours first: a short index), or
//!   any vertex (raw); a group as "the same as the last" or raw.
//!
//! A triangle's group is any number per triangle the stream carries: a
//! material, or (in bundles) the probe that sees the triangle best, which a
//! neighbour predicts well.
//!
//! A separate part (a piece the simplifier removed whole) is coded as its
//! positions and colours in deltas and its corners as distances back from
//! the newest vertex. All of a packet is one rANS section (a model per
//! field, tables in the file, as in [`crate::meshcode`]).
//!
//! Layout: magic `EMVS`, version byte, LEB128 counts (first refinement,
//! refinements, vertices and triangles before, vertices and triangles
//! after, position bits, group count, whether there are colours), the grid's
//! box (6 × f32 LE), the section, a CRC-32 (u32 LE) of all that precedes.

use crate::edgebreaker::{CodingError, MAX_TRIANGLES};
use crate::meshcode::{bit_length, framed, unzigzag, zigzag, Grid, MeshData, Reader, Sink, Source, Writer};

const MAGIC: &[u8; 4] = b"EMVS";
const VERSION: u8 = 1;
/// Most triangles one split may bring back.
const MAX_ADDED: u32 = 255;
/// Most vertices a stream may reach.
const MAX_VERTICES: u64 = 1 << 26;

// The section's models.
const KIND: usize = 0;
const RESTORED: usize = 1; // 3, per axis
const NEW: usize = 4; // 3
const COLOUR: usize = 7; // 3
const MOVED: usize = 10; // 2, by the geometric guess
const ADDED: usize = 12;
const CORNER: usize = 13; // 3, per corner
const NEIGHBOUR: usize = 16;
const GROUP: usize = 17;
const PART: usize = 18;
const PART_POSITION: usize = 19; // 3
const FAN: usize = 22;
const TURN: usize = 23; // 3, by the turn the vertex's other triangles suggest
const MODELS: usize = 26;
/// Counts of returning triangles from this one up are escaped.
const ADDED_ESCAPE: u32 = 63;

/// One refinement of a progressive mesh, in the decoder's numbering: the
/// base's vertices and triangles first, then each refinement's new ones.
#[derive(Clone, Debug, PartialEq)]
pub enum Refinement {
    /// `vertex` moves to `position` (its colour becomes `colour`); a vertex
    /// appears at `new_position`; in the triangles `moved`, the corners that
    /// are `vertex` become the new vertex (`moved` ascending); the triangles `added` (one group
    /// each in `groups`, a number per triangle) appear.
    Split {
        vertex: u32,
        position: [f32; 3],
        new_position: [f32; 3],
        colour: [u8; 3],
        new_colour: [u8; 3],
        moved: Vec<u32>,
        added: Vec<[u32; 3]>,
        groups: Vec<u32>,
    },
    /// A separate piece: vertices (with colours when the mesh has them) and
    /// triangles appended.
    Part { positions: Vec<[f32; 3]>, colours: Vec<[u8; 3]>, triangles: Vec<[u32; 3]>, groups: Vec<u32> },
}

/// A mesh being refined: the decoder's state, and the encoder's model of it.
pub struct Refiner {
    /// Colours when the base has them (one per vertex), groups always (one
    /// per triangle).
    pub mesh: MeshData,
    /// Refinements applied so far.
    pub applied: u64,
    /// Per vertex, its triangles, ascending.
    incident: Vec<Vec<u32>>,
    colours: bool,
}

fn corrupt<T>(message: impl Into<String>) -> Result<T, CodingError> {
    Err(CodingError::Corrupt(message.into()))
}

impl Refiner {
    /// Starts from `base` (its groups filled with 0 when it has none).
    pub fn new(mut base: MeshData) -> Result<Refiner, CodingError> {
        let n = base.positions.len();
        if base.triangles.iter().flatten().any(|&v| v as usize >= n) {
            return corrupt("base triangle corner out of range");
        }
        if base.groups.is_empty() {
            base.groups = vec![0; base.triangles.len()];
        }
        if base.groups.len() != base.triangles.len() || !(base.colours.is_empty() || base.colours.len() == n) {
            return corrupt("base attributes do not match its vertices and triangles");
        }
        let mut incident = vec![Vec::new(); n];
        for (t, tri) in base.triangles.iter().enumerate() {
            add_incident(&mut incident, *tri, t as u32);
        }
        let colours = !base.colours.is_empty();
        Ok(Refiner { mesh: base, applied: 0, incident, colours })
    }

    /// Applies one refinement. One that does not fit the mesh is an error
    /// and changes nothing.
    pub fn apply(&mut self, r: &Refinement) -> Result<(), CodingError> {
        let n = self.mesh.positions.len() as u32;
        let finite = |p: &[f32; 3]| p.iter().all(|x| x.is_finite());
        match r {
            Refinement::Split { vertex, position, new_position, colour, new_colour, moved, added, groups } => {
                let v = *vertex as usize;
                if *vertex >= n || !finite(position) || !finite(new_position) || groups.len() != added.len() || added.iter().flatten().any(|&c| c > n)
                {
                    return corrupt(format!("split {} does not fit the mesh", self.applied));
                }
                if moved.windows(2).any(|w| w[0] >= w[1]) || moved.iter().any(|t| self.incident[v].binary_search(t).is_err()) {
                    return corrupt(format!("split {} moves triangles not around its vertex, or not in ascending order", self.applied));
                }
                self.mesh.positions[v] = *position;
                self.mesh.positions.push(*new_position);
                if self.colours {
                    self.mesh.colours[v] = *colour;
                    self.mesh.colours.push(*new_colour);
                }
                self.incident[v].retain(|t| moved.binary_search(t).is_err());
                for &t in moved {
                    for c in &mut self.mesh.triangles[t as usize] {
                        if *c == *vertex {
                            *c = n;
                        }
                    }
                }
                self.incident.push(moved.clone());
                self.append(added, groups);
            }
            Refinement::Part { positions, colours, triangles, groups } => {
                let total = n as usize + positions.len();
                if positions.is_empty()
                    || !positions.iter().all(finite)
                    || (self.colours && colours.len() != positions.len())
                    || groups.len() != triangles.len()
                    || triangles.iter().flatten().any(|&c| c as usize >= total)
                {
                    return corrupt(format!("part {} does not fit the mesh", self.applied));
                }
                self.mesh.positions.extend(positions);
                if self.colours {
                    self.mesh.colours.extend(colours);
                }
                self.incident.resize(total, Vec::new());
                self.append(triangles, groups);
            }
        }
        self.applied += 1;
        Ok(())
    }

    fn append(&mut self, triangles: &[[u32; 3]], groups: &[u32]) {
        for (tri, &g) in triangles.iter().zip(groups) {
            add_incident(&mut self.incident, *tri, self.mesh.triangles.len() as u32);
            self.mesh.triangles.push(*tri);
            self.mesh.groups.push(g);
        }
    }

    /// Decodes a packet and applies its refinements. Packets must come in
    /// stream order; on an error the mesh keeps the refinements before the
    /// faulty one (a valid mesh still).
    pub fn apply_packet(&mut self, bytes: &[u8]) -> Result<(), CodingError> {
        let (_, mut input) = framed(bytes, MAGIC, VERSION..=VERSION, "vertex-split packet")?;
        let body = input.bytes.len();
        let mut h = [0u64; 10];
        for x in h.iter_mut() {
            *x = input.varint()?;
        }
        let [first, count, vertices_before, triangles_before, vertices_after, triangles_after, bits, group_count, has_colours, _reserved] = h;
        let (n, t) = (self.mesh.positions.len() as u64, self.mesh.triangles.len() as u64);
        if first != self.applied || vertices_before != n || triangles_before != t {
            return corrupt(format!("vertex-split packet starts at refinement {first} ({vertices_before} vertices), but the mesh has {} refinements ({n} vertices): packets out of order", self.applied));
        }
        if vertices_after > MAX_VERTICES
            || triangles_after > MAX_TRIANGLES as u64
            || vertices_after < n
            || triangles_after < t
            || count > vertices_after - n
            || !(1..=24).contains(&bits)
            || group_count == 0
            || group_count > 1 << 24
            || has_colours != self.colours as u64
        {
            return corrupt("vertex-split packet counts out of range");
        }
        let mut box_ = [0f32; 6];
        for x in box_.iter_mut() {
            *x = f32::from_le_bytes(input.take(4)?.try_into().unwrap_or_default());
        }
        if box_.iter().any(|x| !x.is_finite()) {
            return corrupt("vertex-split packet box is not finite");
        }
        let coding = Coding::new(Grid::new([box_[0], box_[1], box_[2]], [box_[3], box_[4], box_[5]], bits as u32), group_count as u32);
        let mut source = Source::new(&mut input, MODELS)?;
        for _ in 0..count {
            let r = self.read(&mut source, &coding, vertices_after, triangles_after)?;
            self.apply(&r)?;
        }
        if self.mesh.positions.len() as u64 != vertices_after || self.mesh.triangles.len() as u64 != triangles_after || input.at != body {
            return corrupt("vertex-split packet does not end where its header says");
        }
        Ok(())
    }

    /// Reads one refinement from the section (the inverse of `write`); the
    /// mesh may not grow past `max_vertices` and `max_triangles`.
    fn read(&self, src: &mut Source, coding: &Coding, max_vertices: u64, max_triangles: u64) -> Result<Refinement, CodingError> {
        let n = self.mesh.positions.len() as u32;
        let grid = &coding.grid;
        match src.symbol(KIND) {
            0 => {
                let vertex = src.raw(bit_length(n.saturating_sub(1)))?;
                if vertex >= n {
                    return corrupt("split vertex out of range");
                }
                let now = grid.quantize(self.mesh.positions[vertex as usize]);
                let mut restored = [0u32; 3];
                let mut new = [0u32; 3];
                for i in 0..3 {
                    restored[i] = coding.axis(now[i] as i64 + unzigzag(src.value(RESTORED + i)?))?;
                }
                for i in 0..3 {
                    new[i] = coding.axis(new_predicted(now[i], restored[i], grid.max as i64) + unzigzag(src.value(NEW + i)?))?;
                }
                let (position, new_position) = (grid.dequantize(restored), grid.dequantize(new));
                let (mut colour, mut new_colour) = ([0u8; 3], [0u8; 3]);
                if self.colours {
                    let was = self.mesh.colours[vertex as usize];
                    for i in 0..3 {
                        colour[i] = was[i].wrapping_add(unzigzag(src.value(COLOUR + i)?) as u8);
                    }
                    for i in 0..3 {
                        new_colour[i] = colour[i].wrapping_add(unzigzag(src.value(COLOUR + i)?) as u8);
                    }
                }
                let mut moved = Vec::new();
                for &t in &self.incident[vertex as usize] {
                    if src.symbol(MOVED + self.nearer_new(t, vertex, position, new_position)) == 1 {
                        moved.push(t);
                    }
                }
                let (added, groups) = self.read_added(src, coding, vertex, &moved)?;
                Ok(Refinement::Split { vertex, position, new_position, colour, new_colour, moved, added, groups })
            }
            1 => self.read_part(src, coding, max_vertices, max_triangles),
            _ => corrupt("refinement kind out of range"),
        }
    }

    /// Reads the triangles a split of `vertex` brings back, with their groups.
    fn read_added(&self, src: &mut Source, coding: &Coding, vertex: u32, moved: &[u32]) -> Result<(Vec<[u32; 3]>, Vec<u32>), CodingError> {
        let n = self.mesh.positions.len() as u32;
        let count = match src.symbol(ADDED) as u32 {
            ADDED_ESCAPE => ADDED_ESCAPE + src.value(ADDED)?,
            c => c,
        };
        if count > MAX_ADDED {
            return corrupt("split brings back too many triangles");
        }
        let mut neighbours = self.neighbours(vertex, moved);
        let mut predicted = self.first_group(vertex, moved);
        let (mut added, mut groups) = (Vec::new(), Vec::new());
        for _ in 0..count {
            let mut tri = [0u32; 3];
            if src.symbol(FAN) == 0 {
                let k = src.value(NEIGHBOUR)? as usize;
                if k >= neighbours.len() {
                    return corrupt("neighbour out of range");
                }
                let x = neighbours.remove(k);
                let turn = src.symbol(TURN + self.turn_guess(vertex, x, moved));
                tri = if turn == 0 { [vertex, n, x] } else { [vertex, x, n] };
            } else {
                for (slot, c) in tri.iter_mut().enumerate() {
                    *c = match src.symbol(CORNER + slot) {
                        0 => vertex,
                        1 => n,
                        _ => src.raw(bit_length(n))?,
                    };
                }
            }
            predicted = coding.read_group(src, predicted)?;
            added.push(tri);
            groups.push(predicted);
        }
        Ok((added, groups))
    }

    /// Reads a part: a piece simplification removed whole.
    fn read_part(&self, src: &mut Source, coding: &Coding, max_vertices: u64, max_triangles: u64) -> Result<Refinement, CodingError> {
        let n = self.mesh.positions.len() as u32;
        let (vertices, triangles) = (src.value(PART)? as u64, src.value(PART)? as u64);
        if vertices == 0 || n as u64 + vertices > max_vertices || self.mesh.triangles.len() as u64 + triangles > max_triangles {
            return corrupt("part larger than its packet");
        }
        let mut previous = self.last_quantized(&coding.grid);
        let mut positions = Vec::with_capacity(vertices as usize);
        for _ in 0..vertices {
            let mut q = [0u32; 3];
            for i in 0..3 {
                q[i] = coding.axis(previous[i] as i64 + unzigzag(src.value(PART_POSITION + i)?))?;
            }
            positions.push(coding.grid.dequantize(q));
            previous = q;
        }
        let mut colours = Vec::new();
        if self.colours {
            let mut previous = self.mesh.colours.last().copied().unwrap_or([128; 3]);
            for _ in 0..vertices {
                for (i, x) in previous.iter_mut().enumerate() {
                    *x = x.wrapping_add(unzigzag(src.value(COLOUR + i)?) as u8);
                }
                colours.push(previous);
            }
        }
        let total = n as u64 + vertices;
        let mut tris = Vec::with_capacity(triangles as usize);
        for _ in 0..triangles {
            let mut tri = [0u32; 3];
            for c in &mut tri {
                let back = src.value(PART)? as u64;
                *c = total.checked_sub(back + 1).ok_or_else(|| CodingError::Corrupt("part corner out of range".into()))? as u32;
            }
            tris.push(tri);
        }
        let mut groups = Vec::with_capacity(tris.len());
        for _ in 0..triangles {
            groups.push(coding.read_group(src, *groups.last().unwrap_or(&0))?);
        }
        Ok(Refinement::Part { positions, colours, triangles: tris, groups })
    }

    /// Writes one refinement (its positions already on the grid) into the
    /// section, predicted from the mesh as it is before it.
    fn write(&self, sink: &mut Sink, r: &Refinement, coding: &Coding) -> Result<(), CodingError> {
        let n = self.mesh.positions.len() as u32;
        let grid = &coding.grid;
        match r {
            Refinement::Split { vertex, position, new_position, colour, new_colour, moved, added, groups } => {
                if *vertex >= n || added.len() > MAX_ADDED as usize {
                    return Err(CodingError::Input(format!("split {} does not fit the mesh", self.applied)));
                }
                sink.symbol(KIND, 0);
                sink.raw(*vertex, bit_length(n.saturating_sub(1)));
                let now = grid.quantize(self.mesh.positions[*vertex as usize]);
                let (restored, new) = (grid.quantize(*position), grid.quantize(*new_position));
                for i in 0..3 {
                    sink.value(RESTORED + i, zigzag(restored[i] as i64 - now[i] as i64));
                }
                for i in 0..3 {
                    sink.value(NEW + i, zigzag(new[i] as i64 - new_predicted(now[i], restored[i], grid.max as i64)));
                }
                if self.colours {
                    let was = self.mesh.colours[*vertex as usize];
                    for i in 0..3 {
                        sink.value(COLOUR + i, wrap(colour[i], was[i]));
                    }
                    for i in 0..3 {
                        sink.value(COLOUR + i, wrap(new_colour[i], colour[i]));
                    }
                }
                for &t in &self.incident[*vertex as usize] {
                    sink.symbol(MOVED + self.nearer_new(t, *vertex, *position, *new_position), moved.binary_search(&t).is_ok() as usize);
                }
                self.write_added(sink, coding, *vertex, moved, added, groups);
            }
            Refinement::Part { positions, colours, triangles, groups } => {
                sink.symbol(KIND, 1);
                sink.value(PART, positions.len() as u32);
                sink.value(PART, triangles.len() as u32);
                let mut previous = self.last_quantized(grid);
                for &p in positions {
                    let q = grid.quantize(p);
                    for i in 0..3 {
                        sink.value(PART_POSITION + i, zigzag(q[i] as i64 - previous[i] as i64));
                    }
                    previous = q;
                }
                if self.colours {
                    let mut previous = self.mesh.colours.last().copied().unwrap_or([128; 3]);
                    for &c in colours {
                        for i in 0..3 {
                            sink.value(COLOUR + i, wrap(c[i], previous[i]));
                        }
                        previous = c;
                    }
                }
                let total = n as u64 + positions.len() as u64;
                for &c in triangles.iter().flatten() {
                    sink.value(PART, (total - 1).saturating_sub(c as u64) as u32);
                }
                let mut predicted = 0;
                for &g in groups {
                    coding.write_group(sink, g, predicted);
                    predicted = g;
                }
            }
        }
        Ok(())
    }

    /// Writes the triangles a split of `vertex` brings back, with their groups.
    fn write_added(&self, sink: &mut Sink, coding: &Coding, vertex: u32, moved: &[u32], added: &[[u32; 3]], groups: &[u32]) {
        let n = self.mesh.positions.len() as u32;
        let count = added.len() as u32;
        sink.symbol(ADDED, count.min(ADDED_ESCAPE) as usize);
        if count >= ADDED_ESCAPE {
            sink.value(ADDED, count - ADDED_ESCAPE);
        }
        let mut neighbours = self.neighbours(vertex, moved);
        let mut predicted = self.first_group(vertex, moved);
        for (tri, &g) in added.iter().zip(groups) {
            // The usual triangle: the vertex, the new one and a neighbour, in either turn.
            let fan = match *tri {
                [a, b, x] if a == vertex && b == n => Some((x, 0)),
                [a, x, b] if a == vertex && b == n => Some((x, 1)),
                _ => None,
            };
            match fan.and_then(|(x, turn)| Some((neighbours.iter().position(|&c| c == x)?, x, turn))) {
                Some((k, x, turn)) => {
                    sink.symbol(FAN, 0);
                    sink.value(NEIGHBOUR, k as u32);
                    neighbours.remove(k);
                    sink.symbol(TURN + self.turn_guess(vertex, x, moved), turn);
                }
                None => {
                    sink.symbol(FAN, 1);
                    for (slot, &c) in tri.iter().enumerate() {
                        if c == vertex {
                            sink.symbol(CORNER + slot, 0);
                        } else if c == n {
                            sink.symbol(CORNER + slot, 1);
                        } else {
                            sink.symbol(CORNER + slot, 2);
                            sink.raw(c, bit_length(n));
                        }
                    }
                }
            }
            coding.write_group(sink, g, predicted);
            predicted = g;
        }
    }

    /// The model for whether triangle `t` moves: 1 when the centre of its
    /// other corners is nearer the new vertex than the restored one.
    fn nearer_new(&self, t: u32, vertex: u32, position: [f32; 3], new_position: [f32; 3]) -> usize {
        let (mut centre, mut count) = ([0f32; 3], 0.0);
        for &c in self.mesh.triangles[t as usize].iter().filter(|&&c| c != vertex) {
            let p = self.mesh.positions[c as usize];
            centre = std::array::from_fn(|i| centre[i] + p[i]);
            count += 1.0;
        }
        if count == 0.0 {
            return 0;
        }
        let d2 = |p: [f32; 3]| (0..3).map(|i| (p[i] - centre[i] / count).powi(2)).sum::<f32>();
        (d2(new_position) < d2(position)) as usize
    }

    /// The model for the turn of a returning triangle `(vertex, new, x)`
    /// (0) or `(vertex, x, new)` (1): what a triangle already on the edge
    /// `vertex`–`x` (or `new`–`x`, for one that moves) suggests, for
    /// consistently turning faces: 1 for 0, 2 for 1, 0 when none does.
    fn turn_guess(&self, vertex: u32, x: u32, moved: &[u32]) -> usize {
        for &t in &self.incident[vertex as usize] {
            let tri = self.mesh.triangles[t as usize];
            let Some(i) = tri.iter().position(|&c| c == vertex) else { continue };
            // `vertex -> x` there; the new vertex takes `vertex`'s place in one that moves.
            let forward = tri[(i + 1) % 3] == x;
            if forward || tri[(i + 2) % 3] == x {
                return 1 + (forward == moved.binary_search(&t).is_ok()) as usize;
            }
        }
        0
    }

    /// The vertices next to `vertex` once `moved` (ascending, as in every
    /// helper here) have gone to the new vertex: those next to both first,
    /// then the others, each ascending.
    fn neighbours(&self, vertex: u32, moved: &[u32]) -> Vec<u32> {
        // Each corner beside the vertex, marked 1 beside a triangle that
        // stays, 2 beside one that moves; sorted, equal corners run together.
        let around = &self.incident[vertex as usize];
        let mut marks: Vec<(u32, u8)> = Vec::with_capacity(2 * around.len());
        for &t in around {
            let side = if moved.binary_search(&t).is_ok() { 2 } else { 1 };
            marks.extend(self.mesh.triangles[t as usize].iter().filter(|&&c| c != vertex).map(|&c| (c, side)));
        }
        marks.sort_unstable();
        let runs = marks.chunk_by(|a, b| a.0 == b.0).map(|run| (run[0].0, run.iter().fold(0, |m, x| m | x.1)));
        let mut out: Vec<u32> = runs.clone().filter(|r| r.1 == 3).map(|r| r.0).collect();
        out.extend(runs.filter(|r| r.1 != 3).map(|r| r.0));
        out
    }

    /// The group a split's first returning triangle is predicted to have:
    /// that of the vertex's first triangle that stays, else 0.
    fn first_group(&self, vertex: u32, moved: &[u32]) -> u32 {
        let around = &self.incident[vertex as usize];
        around.iter().find(|t| moved.binary_search(t).is_err()).or(around.first()).map_or(0, |&t| self.mesh.groups[t as usize])
    }

    fn last_quantized(&self, grid: &Grid) -> [u32; 3] {
        self.mesh.positions.last().map_or([0; 3], |&p| grid.quantize(p))
    }
}

/// How a packet's refinements are coded: positions on `grid`, triangle
/// groups among `group_count` (raw in `group_bits` when not as predicted).
struct Coding {
    grid: Grid,
    group_count: u32,
    group_bits: u32,
}

impl Coding {
    fn new(grid: Grid, group_count: u32) -> Coding {
        Coding { grid, group_count, group_bits: bit_length(group_count - 1) }
    }

    /// A quantized coordinate, which must be on the grid.
    fn axis(&self, x: i64) -> Result<u32, CodingError> {
        if (0..=self.grid.max as i64).contains(&x) {
            Ok(x as u32)
        } else {
            corrupt("position off the grid")
        }
    }

    fn read_group(&self, src: &mut Source, predicted: u32) -> Result<u32, CodingError> {
        if self.group_count == 1 || src.symbol(GROUP) == 0 {
            return Ok(predicted);
        }
        let g = src.raw(self.group_bits)?;
        if g < self.group_count {
            Ok(g)
        } else {
            corrupt("group out of range")
        }
    }

    fn write_group(&self, sink: &mut Sink, g: u32, predicted: u32) {
        if self.group_count > 1 {
            sink.symbol(GROUP, (g != predicted) as usize);
            if g != predicted {
                sink.raw(g, self.group_bits);
            }
        }
    }
}

/// A colour component's difference, zigzagged.
fn wrap(a: u8, b: u8) -> u32 {
    zigzag(a.wrapping_sub(b) as i8 as i64)
}

/// `2·now − restored`, on the grid.
fn new_predicted(now: u32, restored: u32, max: i64) -> i64 {
    (2 * now as i64 - restored as i64).clamp(0, max)
}

fn add_incident(incident: &mut [Vec<u32>], tri: [u32; 3], t: u32) {
    for (i, &c) in tri.iter().enumerate() {
        // A corner repeated in the triangle is listed once.
        if !tri[..i].contains(&c) {
            incident[c as usize].push(t);
        }
    }
}

/// The packets of a file that holds several one after the other, each
/// frame checked (applying one needs the mesh it refines).
pub fn packets(bytes: &[u8]) -> Result<Vec<&[u8]>, CodingError> {
    let mut out = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        let rest = &bytes[at..];
        if rest.len() < 5 || &rest[..4] != MAGIC || rest[4] != VERSION {
            return corrupt(format!("no vertex-split packet (EMVS, version {VERSION}) at byte {at}"));
        }
        let mut input = Reader { bytes: rest, at: 5 };
        for _ in 0..10 {
            input.varint()?;
        }
        input.take(24)?;
        Source::new(&mut input, MODELS)?;
        let end = input.at + 4;
        if end > rest.len() {
            return corrupt("vertex-split packet truncated");
        }
        let packet = &rest[..end];
        framed(packet, MAGIC, VERSION..=VERSION, "vertex-split packet")?;
        out.push(packet);
        at += end;
    }
    Ok(out)
}

/// A coded packet, and the mesh's triangle count once it is applied.
#[derive(Clone, Debug, PartialEq)]
pub struct Packet {
    pub bytes: Vec<u8>,
    pub triangles: u64,
}

/// Codes `refinements` (applied to `base`, the mesh as the decoder will
/// have it) in packets that each bring back at least `packet_triangles`
/// triangles (the last: the rest), positions on a grid of `2^bits` steps per
/// axis of the box around every position.
pub fn encode(base: &MeshData, refinements: &[Refinement], bits: u32, packet_triangles: usize) -> Result<Vec<Packet>, CodingError> {
    if !(1..=24).contains(&bits) {
        return Err(CodingError::Input(format!("{bits} position bits; 1 to 24 are supported")));
    }
    let mut state = Refiner::new(base.clone()).map_err(|e| CodingError::Input(e.to_string()))?;
    let mut every = base.positions.clone();
    let mut group_count = base.groups.iter().max().map_or(1, |&g| g + 1);
    for r in refinements {
        match r {
            Refinement::Split { position, new_position, groups, .. } => {
                every.extend([*position, *new_position]);
                group_count = group_count.max(groups.iter().max().map_or(0, |&g| g + 1));
            }
            Refinement::Part { positions, groups, .. } => {
                every.extend(positions);
                group_count = group_count.max(groups.iter().max().map_or(0, |&g| g + 1));
            }
        }
    }
    let lo: [f32; 3] = std::array::from_fn(|i| every.iter().map(|p| p[i]).fold(f32::INFINITY, f32::min));
    let hi: [f32; 3] = std::array::from_fn(|i| every.iter().map(|p| p[i]).fold(f32::NEG_INFINITY, f32::max));
    // A cube: the same step on every axis, so a short axis costs no extra bits.
    let side = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f32::max);
    let hi: [f32; 3] = std::array::from_fn(|i| lo[i] + side);
    if every.iter().flatten().any(|x| !x.is_finite()) {
        return Err(CodingError::Input("a position is not finite".into()));
    }
    let coding = Coding::new(Grid::new(lo, hi, bits), group_count);
    let grid = &coding.grid;
    let on_grid = |p: [f32; 3]| grid.dequantize(grid.quantize(p));
    let mut packets = Vec::new();
    let mut rest = refinements;
    while !rest.is_empty() {
        let before = (state.applied, state.mesh.positions.len() as u64, state.mesh.triangles.len() as u64);
        let mut sink = Sink::new(MODELS);
        let mut taken = 0;
        while taken < rest.len() && (state.mesh.triangles.len() as u64 - before.2) < packet_triangles.max(1) as u64 {
            // The decoder's positions are on the grid; so are the encoder's.
            let r = match &rest[taken] {
                Refinement::Split { vertex, position, new_position, colour, new_colour, moved, added, groups } => {
                    // Returning triangles turned to start at the vertex (the same triangles).
                    let added =
                        added.iter().map(|&t| t.iter().position(|&c| c == *vertex).map_or(t, |i| [t[i], t[(i + 1) % 3], t[(i + 2) % 3]])).collect();
                    // Moved triangles ascending, as the decoder finds them.
                    let mut moved = moved.clone();
                    moved.sort_unstable();
                    Refinement::Split {
                        vertex: *vertex,
                        position: on_grid(*position),
                        new_position: on_grid(*new_position),
                        colour: *colour,
                        new_colour: *new_colour,
                        moved,
                        added,
                        groups: groups.clone(),
                    }
                }
                Refinement::Part { positions, colours, triangles, groups } => Refinement::Part {
                    positions: positions.iter().map(|&p| on_grid(p)).collect(),
                    colours: colours.clone(),
                    triangles: triangles.clone(),
                    groups: groups.clone(),
                },
            };
            state.write(&mut sink, &r, &coding)?;
            state.apply(&r).map_err(|e| CodingError::Input(e.to_string()))?;
            taken += 1;
        }
        rest = &rest[taken..];
        let mut out = Writer::default();
        out.bytes.extend_from_slice(MAGIC);
        out.bytes.push(VERSION);
        let (vertices, triangles) = (state.mesh.positions.len() as u64, state.mesh.triangles.len() as u64);
        for x in [before.0, taken as u64, before.1, before.2, vertices, triangles, bits as u64, group_count as u64, state.colours as u64, 0] {
            out.varint(x);
        }
        for x in lo.iter().chain(&hi) {
            out.bytes.extend_from_slice(&x.to_le_bytes());
        }
        out.section(sink);
        let crc = crc32fast::hash(&out.bytes);
        out.bytes.extend_from_slice(&crc.to_le_bytes());
        packets.push(Packet { bytes: out.bytes, triangles });
    }
    Ok(packets)
}

//! The coded mesh: a proxy mesh (or any level of it sent whole) in a few
//! kilobytes, decodable on a phone or in a browser with no C toolchain.
//!
//! Connectivity is coded by Edgebreaker ([`crate::edgebreaker`]). Positions
//! are quantized on a grid of `2^bits` steps per axis of the mesh's box and
//! predicted by the parallelogram rule (Touma and Gotsman 1998): a vertex that
//! arrives by a C across the gate `a -> b` of the triangle `(a, b, o)` is
//! predicted at `a + b - o`. Colours (optional, RGB8 per vertex) use the same
//! predictors. Residuals and CLERS symbols are entropy coded (rANS: coded by
//! the `constriction` crate, decoded by `Source` with no division).
//! Residuals use static models stored in the file, as an Elias-gamma bucket
//! (their bit length, modelled) followed by raw bits. Connectivity uses
//! adaptive models (`Adaptive`), too few symbols on a coarse level to pay
//! for tables: CLERS in the context of the previous symbol, the current
//! loop's length and whether the loop's edge after the gate lies on the
//! mesh's boundary (`context`), each model starting from a prior made from
//! other scenes (`PRIORS`); the records' numbers as buckets. A CRC-32
//! closes the file.
//!
//! Layout (all integers LEB128 unless said; `format/SCHEMA.md` has it
//! whole): magic `EMMC`, version byte,
//! counts, box (6 × f32 LE), then length-prefixed sections: connectivity,
//! positions, groups (runs in decoded order: length − 1 as a value, then the
//! group in raw bits; empty with one group), colours; then the CRC-32 (u32
//! LE) of all that precedes.

use crate::edgebreaker::{self, CodingError, Connectivity, Decoded, Merge, Order};
use constriction::stream::model::{EncoderModel, EntropyModel, SmallContiguousCategoricalEntropyModel};
use constriction::stream::stack::DefaultAnsCoder;
use constriction::stream::Encode;
use priors::PRIORS;
use std::ops::RangeInclusive;

mod priors;

const MAGIC: &[u8; 4] = b"EMMC";
/// Version 2 leaves out the dummies that start components (version 1 files,
/// which list every dummy, are still read); version 3 codes groups as runs
/// (before, a flag a triangle: a fifth of the symbols to decode, for as
/// many bits); version 4 starts components with a boundary from a loop, the
/// count of such components in the place of version 3's dummy starts and
/// their lengths (less three, as values) after the symbols, and marks the
/// other dummies by a seventh symbol, D, in place of their list; version 5
/// codes connectivity under adaptive models (no tables), each symbol in the
/// context of the current loop's length, with each S's split after it, and
/// is decoded as the mesh is rebuilt ([`edgebreaker::rebuild`]); version
/// 6 adds to a symbol's context whether the loop's edge after the gate lies
/// on the mesh's boundary, starts each component's first symbol afresh, and
/// starts each model from a prior ([`PRIORS`]), not uniform.
const VERSION: u8 = 6;
const NONE: u32 = u32::MAX;
/// Probabilities are 12-bit fixed point (constriction's "small" preset: a
/// decoding table of 4,096 entries a model).
const PRECISION: u32 = 12;

/// An indexed triangle mesh with a group (material) per triangle and,
/// optionally, a colour per vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    pub positions: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle (empty: all group 0).
    pub groups: Vec<u32>,
    /// Per vertex (empty: no colours).
    pub colours: Vec<[u8; 3]>,
}

/// Bytes per section, for reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sizes {
    pub header: usize,
    pub connectivity: usize,
    pub positions: usize,
    pub groups: usize,
    pub colours: usize,
}

impl Sizes {
    pub fn total(&self) -> usize {
        self.header + self.connectivity + self.positions + self.groups + self.colours + 4
    }
}

#[derive(Clone, Debug)]
pub struct Encoded {
    pub bytes: Vec<u8>,
    /// Where each decoded vertex and triangle came from.
    pub order: Order,
    pub sizes: Sizes,
}

/// Codes `mesh` with positions quantized to `bits` (1..=24) per axis.
pub fn encode(mesh: &MeshData, bits: u32) -> Result<Encoded, CodingError> {
    let input = |m: String| Err(CodingError::Input(m));
    if !(1..=24).contains(&bits) {
        return input(format!("{bits} position bits; 1 to 24 are supported"));
    }
    if !mesh.groups.is_empty() && mesh.groups.len() != mesh.triangles.len() {
        return input(format!("{} groups for {} triangles", mesh.groups.len(), mesh.triangles.len()));
    }
    if !mesh.colours.is_empty() && mesh.colours.len() != mesh.positions.len() {
        return input(format!("{} colours for {} vertices", mesh.colours.len(), mesh.positions.len()));
    }
    if let Some(i) = mesh.positions.iter().position(|p| p.iter().any(|x| !x.is_finite())) {
        return input(format!("vertex {i} is not finite: {:?}", mesh.positions[i]));
    }
    let (code, order) = edgebreaker::encode(&mesh.triangles, mesh.positions.len() as u32)?;
    // The decoder's own pass gives the prediction structure.
    let (decoded, met) = edgebreaker::decode_walked(&code)?;

    let (lo, hi) = match order.vertices.first() {
        None => ([0.0; 3], [0.0; 3]),
        Some(&first) => order.vertices.iter().fold((mesh.positions[first as usize], mesh.positions[first as usize]), |(lo, hi), &v| {
            let p = mesh.positions[v as usize];
            (std::array::from_fn(|i| lo[i].min(p[i])), std::array::from_fn(|i| hi[i].max(p[i])))
        }),
    };
    let grid = Grid::new(lo, hi, bits);
    // Per kept vertex, in decoded order.
    let quantized: Vec<[u32; 3]> = order.vertices.iter().map(|&v| grid.quantize(mesh.positions[v as usize])).collect();
    let group_count = mesh.groups.iter().max().map_or(1, |&g| g + 1);
    let has_colours = !mesh.colours.is_empty();

    let mut out = Writer::default();
    out.bytes.extend_from_slice(MAGIC);
    out.bytes.push(VERSION);
    for n in [
        code.triangle_count,
        code.vertex_count,
        code.symbols.len() as u32,
        code.merges.len() as u32,
        code.start_loops.len() as u32,
        copy_models(code.copies.len() as u32) as u32,
        code.copies.len() as u32,
        group_count,
        has_colours as u32,
        bits,
    ] {
        out.varint(n as u64);
    }
    for x in lo.iter().chain(&hi) {
        out.bytes.extend_from_slice(&x.to_le_bytes());
    }
    let mut sizes = Sizes { header: out.bytes.len(), ..Sizes::default() };

    // Connectivity, in the order the decoder reads it (see `Stream`).
    // Dummies come by their D: versions 4 and 5 list none (the count stays
    // in the header for the readers of versions 1 to 3).
    debug_assert!(code.dummies.is_empty());
    sizes.connectivity = out.section(connectivity_sink(&code, &met));

    // Positions, then colours, in decoded order, predicted alike.
    let mut sink = Sink::new(3);
    encode_predicted(&mut sink, &decoded, &quantized, grid.max, [0; 3], |q, p| zigzag(q as i64 - p as i64));
    sizes.positions = out.section(sink);

    let mut sink = Sink::new(1);
    let group_bits = bit_length(group_count - 1);
    if group_count > 1 {
        let groups: Vec<u32> = order.triangles.iter().map(|&t| mesh.groups[t as usize]).collect();
        for run in groups.chunk_by(|a, b| a == b) {
            sink.value(0, run.len() as u32 - 1);
            sink.raw(run[0], group_bits);
        }
    }
    sizes.groups = out.section(sink);

    let mut sink = Sink::new(3);
    if has_colours {
        let colours: Vec<[u32; 3]> = order.vertices.iter().map(|&v| mesh.colours[v as usize].map(u32::from)).collect();
        encode_predicted(&mut sink, &decoded, &colours, 255, [128; 3], |c, p| zigzag(((c as i32 - p as i32) as i8) as i64));
    }
    sizes.colours = out.section(sink);

    let crc = crc32fast::hash(&out.bytes);
    out.bytes.extend_from_slice(&crc.to_le_bytes());
    debug_assert_eq!(out.bytes.len(), sizes.total());
    Ok(Encoded { bytes: out.bytes, order, sizes })
}

/// Decodes a coded mesh; any inconsistency is an error, never a panic.
pub fn decode(bytes: &[u8]) -> Result<MeshData, CodingError> {
    let corrupt = |m: &str| CodingError::Corrupt(m.to_string());
    let (version, mut input) = framed(bytes, MAGIC, 1..=VERSION, "coded mesh")?;
    let body = input.bytes.len();
    let header = Header::read(&mut input, version)?;
    let mut lo = [0f32; 3];
    let mut hi = [0f32; 3];
    for x in lo.iter_mut().chain(hi.iter_mut()) {
        *x = f32::from_le_bytes(input.take(4)?.try_into().unwrap_or_default());
    }
    if lo.iter().chain(&hi).any(|x| !x.is_finite()) {
        return Err(corrupt("box is not finite"));
    }
    let grid = Grid::new(lo, hi, header.bits);
    let mut decoded = if version >= 5 {
        read_connectivity(&mut input, &header)?
    } else {
        edgebreaker::decode(&read_static_connectivity(&mut input, &header, body)?)?
    };
    let triangles = decoded.resolve();
    let mut source = Source::new(&mut input, 3)?;
    let quantized =
        decode_predicted(&mut source, &decoded, grid.max, [0; 3], |p, r| u32::try_from(p as i64 + unzigzag(r)).ok().filter(|&x| x <= grid.max))?;
    // (In place: a grid point and a position take the same room.)
    let positions: Vec<[f32; 3]> = quantized.into_iter().map(|q| grid.dequantize(q)).collect();
    let groups = read_groups(&mut input, &header, triangles.len())?;
    let mut source = Source::new(&mut input, 3)?;
    let mut colours = Vec::new();
    if header.has_colours == 1 {
        let all = decode_predicted(&mut source, &decoded, 255, [128; 3], |p, r| Some((p as u8).wrapping_add(unzigzag(r) as u8) as u32))?;
        colours = all.iter().map(|c| c.map(|x| x as u8)).collect();
    }
    if input.at != body {
        return Err(corrupt("bytes left after the last section"));
    }
    Ok(MeshData { positions, triangles, groups, colours })
}

/// A coded mesh's counts, after its version.
struct Header {
    version: u8,
    triangle_count: u32,
    vertex_count: u32,
    symbol_count: u32,
    merge_count: u32,
    /// Version 1 has no count of dummy starts: every dummy is listed.
    /// Version 4 and later have start loops in that place.
    dummy_starts: u32,
    loop_count: u32,
    /// Versions 5 and 6 have, in the place of the dummies' count, the number
    /// of static models of the copies.
    dummy_count: u32,
    copy_count: u32,
    group_count: u32,
    has_colours: u32,
    bits: u32,
}

impl Header {
    fn read(input: &mut Reader, version: u8) -> Result<Header, CodingError> {
        let corrupt = |m: &str| CodingError::Corrupt(m.to_string());
        let mut count = || input.varint().and_then(|c| u32::try_from(c).map_err(|_| corrupt("count over 32 bits")));
        let [triangle_count, vertex_count, symbol_count, merge_count] = [count()?, count()?, count()?, count()?];
        let starts = if version > 1 { count()? } else { 0 };
        let (dummy_starts, loop_count) = if version >= 4 { (0, starts) } else { (starts, 0) };
        let [dummy_count, copy_count, group_count, has_colours, bits] = [count()?, count()?, count()?, count()?, count()?];
        if triangle_count > edgebreaker::MAX_TRIANGLES
            || symbol_count > triangle_count
            || [merge_count, starts, dummy_count, copy_count].iter().any(|&n| n > vertex_count)
            || vertex_count > triangle_count.saturating_mul(3)
            || !(1..=24).contains(&bits)
            || has_colours > 1
            || group_count == 0
        {
            return Err(corrupt("counts out of range"));
        }
        if version >= 5 && dummy_count != copy_models(copy_count) as u32 {
            return Err(corrupt("copy models"));
        }
        let header = Header {
            version,
            triangle_count,
            vertex_count,
            symbol_count,
            merge_count,
            dummy_starts,
            loop_count,
            dummy_count,
            copy_count,
            group_count,
            has_colours,
            bits,
        };
        Ok(header)
    }
}

/// The groups section: per triangle its group; in version 3 and later as
/// runs, before it a flag a triangle (whether a new group, raw, follows).
fn read_groups(input: &mut Reader, header: &Header, n: usize) -> Result<Vec<u32>, CodingError> {
    let corrupt = |m: &str| CodingError::Corrupt(m.to_string());
    let group_count = header.group_count;
    let mut source = Source::new(input, 1)?;
    let group_bits = bit_length(group_count - 1);
    let mut groups = Vec::with_capacity(n);
    if header.version < 3 {
        let mut group = 0;
        for _ in 0..n {
            if source.symbol(0) == 1 {
                group = source.raw(group_bits)?;
                if group >= group_count {
                    return Err(corrupt("group out of range"));
                }
            }
            groups.push(group);
        }
    } else if group_count == 1 {
        groups.resize(n, 0);
    } else {
        while groups.len() < n {
            let run = source.value(0)? as usize;
            let group = source.raw(group_bits)?;
            // (run + 1 triangles; the loop leaves at least one to go.)
            if run >= n - groups.len() {
                return Err(corrupt("group run past the last triangle"));
            }
            if group >= group_count {
                return Err(corrupt("group out of range"));
            }
            groups.resize(groups.len() + run + 1, group);
        }
    }
    Ok(groups)
}

/// How many static models the copies have: none (adaptive ones) under 64
/// copies, else 3 (gaps, distances, changes of distance in a run). Static
/// models cost 35-50 bytes of tables on every level tried, but decode in a
/// third of the time: on the Dabrovic Sponza's 664-triangle level, 341
/// copies under adaptive models took 11 µs of its 38.
fn copy_models(copies: u32) -> usize {
    if copies < 64 {
        0
    } else {
        3
    }
}

/// The connectivity section of versions 5 and 6 (see [`read_connectivity`]).
/// `met` is what the decoder's walk meets at each symbol.
fn connectivity_sink(code: &Connectivity, met: &[edgebreaker::Met]) -> Sink {
    let fixed = copy_models(code.copies.len() as u32);
    let mut sink = Sink::new(fixed);
    let mut models = ConnectivityModels::new(VERSION);
    let (mut loops, mut merges) = (code.start_loops.iter(), code.merges.iter());
    for ((&s, met), c) in code.symbols.iter().zip(met).zip(contexts(&code.symbols, met)) {
        if met.starts {
            if let Some(&k) = loops.next() {
                sink.adaptive_value(&mut models.start, k - 3);
            }
        }
        sink.adaptive(&mut models.symbols[c], s as usize);
        match s {
            edgebreaker::S => sink.adaptive_value(&mut models.split, met.split - 2),
            edgebreaker::M => {
                let m = merges.next().expect("a record per M");
                for (model, x) in models.merge.iter_mut().zip([m.depth, m.offset, m.length]) {
                    sink.adaptive_value(model, x);
                }
            }
            _ => {}
        }
    }
    let (mut last, mut distance) = (0, 0);
    for &[copy, original] in &code.copies {
        let gap = copy - last;
        let run = gap == 1;
        let coded = if run { zigzag((copy - original) as i64 - distance as i64) } else { copy - original };
        if fixed == 0 {
            sink.adaptive_value(&mut models.copy_gap, gap);
            sink.adaptive_value(&mut models.copy_distance[usize::from(run)], coded);
        } else {
            sink.value(0, gap);
            sink.value(1 + usize::from(run), coded);
        }
        (last, distance) = (copy, copy - original);
    }
    sink
}

/// The connectivity section of versions 5 and 6, read as the mesh is rebuilt:
/// per component, its start loop's length less three (when it has one),
/// then its symbols, each S followed by its right loop's length less two
/// and each M by its record; then the copies (index gaps and distances to
/// their originals), under adaptive models but for 64 copies or more (see
/// [`copy_models`]).
fn read_connectivity(input: &mut Reader, header: &Header) -> Result<Decoded, CodingError> {
    let Header { version, symbol_count, triangle_count, vertex_count, loop_count, merge_count, copy_count, .. } = *header;
    let corrupt = |m: &str| CodingError::Corrupt(m.to_string());
    let fixed = copy_models(copy_count);
    let source = Source::new(input, fixed)?;
    let models = ConnectivityModels::new(version);
    // (A rebuild for each version: a version test at each symbol cost 2-4 %.)
    let counts = (symbol_count, triangle_count, vertex_count, loop_count, merge_count);
    let ((mut decoded, dummies), mut source, mut models) =
        if version >= 6 { rebuild_stream::<6>(source, models, counts)? } else { rebuild_stream::<5>(source, models, counts)? };
    let mut copies = Vec::with_capacity((copy_count as usize).min(input.bytes.len()));
    let (mut last, mut distance) = (0u32, 0u32);
    for _ in 0..copy_count {
        let gap = if fixed == 0 { source.adaptive_value(&mut models.copy_gap)? } else { source.value(0)? };
        last = last.checked_add(gap).ok_or_else(|| corrupt("copy index"))?;
        let run = gap == 1;
        let coded =
            if fixed == 0 { source.adaptive_value(&mut models.copy_distance[usize::from(run)])? } else { source.value(1 + usize::from(run))? };
        let d = if run { u32::try_from(distance as i64 + unzigzag(coded)).ok() } else { Some(coded) };
        distance = d.ok_or_else(|| corrupt("copy distance"))?;
        let original = last.checked_sub(distance).ok_or_else(|| corrupt("copy original"))?;
        copies.push([last, original]);
    }
    (decoded.keep, decoded.kept_vertices) = edgebreaker::keep_vertices(vertex_count, &dummies, &copies)?;
    Ok(decoded)
}

/// The mesh and its dummies rebuilt from a version 5 or 6 stream, with the
/// stream's coder and models for the copies after it.
type Rebuilt<'a> = ((Decoded, Vec<u32>), Source<'a>, ConnectivityModels);

/// Rebuilds from a version 5 or 6 stream of `counts` (symbols, triangles,
/// vertices, start loops, merge records).
fn rebuild_stream<const VERSION: u8>(
    source: Source<'_>,
    models: ConnectivityModels,
    counts: (u32, u32, u32, u32, u32),
) -> Result<Rebuilt<'_>, CodingError> {
    let (symbol_count, triangle_count, vertex_count, loop_count, merge_count) = counts;
    let mut stream = Stream::<VERSION> { source, models, previous: None, loops: loop_count, merges: merge_count };
    let rebuilt = edgebreaker::rebuild(&mut stream, symbol_count as usize, triangle_count, vertex_count, 0)?;
    if stream.loops != 0 {
        return Err(CodingError::Corrupt(format!("{loop_count} components start at a loop, of {}", loop_count - stream.loops)));
    }
    if stream.merges != 0 {
        return Err(CodingError::Corrupt(format!("{merge_count} merge records, {} M symbols", merge_count - stream.merges)));
    }
    Ok((rebuilt, stream.source, stream.models))
}

/// Connectivity of versions 5 and 6 as [`edgebreaker::rebuild`] walks it.
struct Stream<'a, const VERSION: u8> {
    source: Source<'a>,
    models: ConnectivityModels,
    previous: Option<u8>,
    /// Start loops and merge records declared and not yet read.
    loops: u32,
    merges: u32,
}

impl<const VERSION: u8> edgebreaker::Walk for Stream<'_, VERSION> {
    fn start(&mut self) -> Result<Option<u32>, CodingError> {
        if VERSION >= 6 {
            self.previous = None;
        }
        if self.loops == 0 {
            return Ok(None);
        }
        self.loops -= 1;
        let k = self.source.adaptive_value(&mut self.models.start)?;
        k.checked_add(3).map(Some).ok_or_else(|| CodingError::Corrupt("start loop length".into()))
    }
    #[inline(always)]
    fn step(&mut self, gate: edgebreaker::Gate) -> Result<edgebreaker::Step, CodingError> {
        let symbol = self.source.adaptive(&mut self.models.symbols[context(self.previous, gate, VERSION)]) as u8;
        self.previous = Some(symbol);
        let mut step = edgebreaker::Step { symbol, split: 0, merge: Merge { depth: 0, offset: 0, length: 0 } };
        match symbol {
            edgebreaker::S => step.split = self.source.adaptive_value(&mut self.models.split)?.saturating_add(2),
            edgebreaker::M => {
                if self.merges == 0 {
                    return Err(CodingError::Corrupt("more M symbols than merge records".into()));
                }
                self.merges -= 1;
                let [depth, offset, length] = [0, 1, 2].map(|i| self.source.adaptive_value(&mut self.models.merge[i]));
                step.merge = Merge { depth: depth?, offset: offset?, length: length? };
            }
            _ => {}
        }
        Ok(step)
    }
}

/// The connectivity section of versions 1 to 4: the symbols under static
/// models, one per previous symbol, then the records' numbers under one more.
fn read_static_connectivity(input: &mut Reader, header: &Header, body: usize) -> Result<Connectivity, CodingError> {
    let Header { version, triangle_count, vertex_count, dummy_starts, symbol_count, loop_count, merge_count, dummy_count, copy_count, .. } = *header;
    let mut code = Connectivity { triangle_count, vertex_count, dummy_starts, ..Connectivity::default() };
    // Room for the records up front (a few per cent of a small mesh's time),
    // no more than the file's bytes could hold whatever counts it claims.
    let room = |n: u32| (n as usize).min(body);
    code.symbols.reserve(symbol_count as usize);
    code.start_loops.reserve(room(loop_count));
    code.merges.reserve(room(merge_count));
    code.dummies.reserve(room(dummy_count));
    code.copies.reserve(room(copy_count));
    let corrupt = |m: &str| CodingError::Corrupt(m.to_string());
    // Versions before 4 have no D, so a model fewer.
    let symbols = if version >= 4 { edgebreaker::SYMBOLS } else { edgebreaker::D as usize };
    let mut source = Source::new(input, symbols + 1)?;
    let mut context = 0;
    for _ in 0..symbol_count {
        let s = source.symbol(context);
        if s >= symbols {
            return Err(corrupt("symbol out of range"));
        }
        code.symbols.push(s as u8);
        context = s;
    }
    let values = symbols;
    for _ in 0..loop_count {
        let k = source.value(values)?.checked_add(3).ok_or_else(|| corrupt("start loop length"))?;
        code.start_loops.push(k);
    }
    for _ in 0..merge_count {
        code.merges.push(Merge { depth: source.value(values)?, offset: source.value(values)?, length: source.value(values)? });
    }
    let mut last = 0u32;
    for _ in 0..dummy_count {
        last = last.checked_add(source.value(values)?).ok_or_else(|| corrupt("dummy index"))?;
        code.dummies.push(last);
    }
    let mut last = 0u32;
    for _ in 0..copy_count {
        last = last.checked_add(source.value(values)?).ok_or_else(|| corrupt("copy index"))?;
        let original = last.checked_sub(source.value(values)?).ok_or_else(|| corrupt("copy original"))?;
        code.copies.push([last, original]);
    }
    Ok(code)
}

/// The adaptive models of versions 5 and 6's connectivity.
struct ConnectivityModels {
    /// Per [`context`]; eight symbols, the last never
    /// coded, for eight 16-bit lanes.
    symbols: [Adaptive<{ edgebreaker::SYMBOLS + 1 }>; CONTEXTS],
    start: Adaptive<BUCKETS>,
    split: Adaptive<BUCKETS>,
    merge: [Adaptive<BUCKETS>; 3],
    copy_gap: Adaptive<BUCKETS>,
    /// The distance from a copy to its original; for a copy right after
    /// another, the change from that one's distance (zigzag), which a run of
    /// copies along a seam (two sheets cut apart at a non-manifold edge)
    /// keeps at zero: 29 % fewer bytes of copies on the Dabrovic Sponza's
    /// base.
    copy_distance: [Adaptive<BUCKETS>; 2],
}

impl ConnectivityModels {
    /// The models as a file of `version` (5 or later) starts them.
    fn new(version: u8) -> Self {
        ConnectivityModels {
            // (Copied from constants: building the models at each decode
            // was part of a 5-8 % slowdown on coarse levels.)
            symbols: if version >= 6 { SYMBOL_MODELS[1] } else { SYMBOL_MODELS[0] },
            start: Adaptive::default(),
            split: Adaptive::default(),
            merge: Default::default(),
            copy_gap: Adaptive::default(),
            copy_distance: Default::default(),
        }
    }
}

/// Symbol contexts (see [`context`]).
#[doc(hidden)]
pub const CONTEXTS: usize = (edgebreaker::SYMBOLS + 1) * 3 * 2;
/// What a prior is worth, in symbols seen: the models adapt at the rate of
/// their ninth symbol from the start (see [`Adaptive::learn`]).
const PRIOR_SEEN: u8 = 8;

/// The symbol models as version 5 (uniform, but that only a loop of three
/// closes with an E) and version 6 (from [`PRIORS`] where it has one) start
/// them.
const SYMBOL_MODELS: [[Adaptive<{ edgebreaker::SYMBOLS + 1 }>; CONTEXTS]; 2] = {
    let mut out = [[Adaptive::with_rare(usize::MAX); CONTEXTS]; 2];
    let mut c = 0;
    while c < CONTEXTS {
        // (The loop's length class, as `context` lays contexts out.)
        if (c / 2) % 3 != 0 {
            out[0][c] = Adaptive::with_rare(edgebreaker::E as usize);
        }
        out[1][c] = match PRIORS[c] {
            Some(bound) => Adaptive { bound, seen: PRIOR_SEEN },
            None => out[0][c],
        };
        c += 1;
    }
    out
};

/// A symbol's context: the symbol before it in its component (or none),
/// the length of the loop it acts on (3 or less, 4, more) and, from
/// version 6, whether the loop's edge after the gate lies on the mesh's
/// boundary (version 5: as if it never did; and a component's first symbol
/// follows the last of the one before). Only a loop of three can end with
/// an E, and only a C or D can follow on a shorter one; knowing the length
/// took the Crytek Sponza base's symbols from 576 to 466 bytes. The decoder
/// knows every length forwards only if each S's split is coded (26 bytes
/// there), as versions 5 and 6 do. A boundary edge after the gate changes
/// the odds of the R that would take its triangle: knowing it, the Crytek
/// Sponza base's symbols took 17 bytes (4 %) fewer.
#[inline(always)]
fn context(previous: Option<u8>, gate: edgebreaker::Gate, version: u8) -> usize {
    let previous = previous.map_or(edgebreaker::SYMBOLS, usize::from);
    let boundary = version >= 6 && gate.next_on_boundary;
    ((previous & 7) * 3 + (gate.length.clamp(3, 5) - 3) as usize) * 2 + usize::from(boundary)
}

/// The context of each symbol as the current version codes it.
fn contexts<'a>(symbols: &'a [u8], met: &'a [edgebreaker::Met]) -> impl Iterator<Item = usize> + 'a {
    let mut previous = None;
    symbols.iter().zip(met).map(move |(&s, met)| {
        if met.starts {
            previous = None;
        }
        let c = context(previous, met.gate, VERSION);
        previous = Some(s);
        c
    })
}

/// Each Edgebreaker symbol of `mesh`'s connectivity with its [`context`],
/// in coded order: what `PRIORS` is made from (by the builder's
/// `connectivity_priors` example).
#[doc(hidden)]
pub fn symbol_contexts(mesh: &MeshData) -> Result<Vec<(usize, u8)>, CodingError> {
    let (code, _) = edgebreaker::encode(&mesh.triangles, mesh.positions.len() as u32)?;
    let (_, met) = edgebreaker::decode_walked(&code)?;
    Ok(contexts(&code.symbols, &met).zip(code.symbols.iter().copied()).collect())
}

/// The decoded vertices whose values are coded, in decoded order, with
/// their kept index: neither dummies nor copies (a copy's kept index is its
/// original's, already seen, as kept indices are given in decoded order).
fn coded_vertices(keep: &[u32]) -> impl Iterator<Item = (usize, u32)> + '_ {
    let mut next = 0;
    keep.iter()
        .enumerate()
        .filter(move |&(_, &k)| {
            let new = k == next;
            next += u32::from(new);
            new
        })
        .map(|(v, &k)| (v, k))
}

/// Codes one triple per kept vertex (`values`, by kept index), in decoded
/// order, as residuals from its prediction (positions and colours alike);
/// `residual(actual, predicted)` is the number coded.
fn encode_predicted(sink: &mut Sink, decoded: &Decoded, values: &[[u32; 3]], max: u32, first: [u32; 3], residual: impl Fn(u32, u32) -> u32) {
    let mut previous = first;
    for (v, k) in coded_vertices(&decoded.keep) {
        let predicted = predict(&decoded.predictors[v], &decoded.keep, values, previous, max);
        let value = values[k as usize];
        for i in 0..3 {
            sink.value(i, residual(value[i], predicted[i]));
        }
        previous = value;
    }
}

/// The inverse of `encode_predicted`: a triple per kept vertex;
/// `value(predicted, coded)` is None when out of range.
fn decode_predicted(
    source: &mut Source,
    decoded: &Decoded,
    max: u32,
    first: [u32; 3],
    value: impl Fn(u32, u32) -> Option<u32>,
) -> Result<Vec<[u32; 3]>, CodingError> {
    let mut values = vec![[0u32; 3]; decoded.kept_vertices as usize];
    let mut previous = first;
    for (v, k) in coded_vertices(&decoded.keep) {
        let predicted = predict(&decoded.predictors[v], &decoded.keep, &values, previous, max);
        let mut decoded = [0; 3];
        for i in 0..3 {
            decoded[i] = source
                .try_value(i)
                .and_then(|r| value(predicted[i], r))
                .ok_or_else(|| CodingError::Corrupt("value out of range, over 32 bits or past the raw bits".into()))?;
        }
        values[k as usize] = decoded;
        previous = decoded;
    }
    Ok(values)
}

/// The predicted value of a vertex from its predictors, decoded vertices
/// (`keep` gives their kept index, NONE for dummies, whose values are not
/// coded); `values` by kept index.
#[inline(always)]
fn predict(predictors: &[u32; 3], keep: &[u32], values: &[[u32; 3]], previous: [u32; 3], max: u32) -> [u32; 3] {
    let real = |v: u32| v != NONE && keep[v as usize] != NONE;
    let value = |v: u32| values[keep[v as usize] as usize];
    let [a, b, o] = *predictors;
    match (real(a), real(b), real(o)) {
        (true, true, true) => {
            let (a, b, o) = (value(a), value(b), value(o));
            std::array::from_fn(|i| (a[i] as i64 + b[i] as i64 - o[i] as i64).clamp(0, max as i64) as u32)
        }
        (true, true, false) => {
            let (a, b) = (value(a), value(b));
            std::array::from_fn(|i| (a[i] + b[i]) / 2)
        }
        (true, false, _) => value(a),
        (false, true, _) => value(b),
        (false, false, _) => previous,
    }
}

/// A quantization grid: `2^bits` steps per axis of a box.
pub(crate) struct Grid {
    lo: [f32; 3],
    step: [f32; 3],
    pub(crate) max: u32,
}

impl Grid {
    pub(crate) fn new(lo: [f32; 3], hi: [f32; 3], bits: u32) -> Grid {
        let max = (1u32 << bits) - 1;
        let step = std::array::from_fn(|i| if hi[i] > lo[i] { (hi[i] - lo[i]) / max as f32 } else { 0.0 });
        Grid { lo, step, max }
    }
    pub(crate) fn quantize(&self, p: [f32; 3]) -> [u32; 3] {
        std::array::from_fn(|i| if self.step[i] > 0.0 { ((p[i] - self.lo[i]) / self.step[i]).round().clamp(0.0, self.max as f32) as u32 } else { 0 })
    }
    pub(crate) fn dequantize(&self, q: [u32; 3]) -> [f32; 3] {
        std::array::from_fn(|i| self.lo[i] + q[i] as f32 * self.step[i])
    }
}

pub(crate) fn zigzag(x: i64) -> u32 {
    ((x << 1) ^ (x >> 63)) as u32
}

pub(crate) fn unzigzag(x: u32) -> i64 {
    (x >> 1) as i64 ^ -((x & 1) as i64)
}

pub(crate) fn bit_length(x: u32) -> u32 {
    32 - x.leading_zeros()
}

#[derive(Default)]
pub(crate) struct Writer {
    pub(crate) bytes: Vec<u8>,
}

impl Writer {
    pub(crate) fn varint(&mut self, mut x: u64) {
        while x >= 0x80 {
            self.bytes.push(x as u8 | 0x80);
            x >>= 7;
        }
        self.bytes.push(x as u8);
    }

    /// Writes a section: its models, entropy-coded words and raw bits. Returns
    /// its size in bytes.
    pub(crate) fn section(&mut self, sink: Sink) -> usize {
        let start = self.bytes.len();
        let mut tables = Vec::new();
        for counts in &sink.counts {
            let used = counts.iter().rposition(|&c| c > 0).map_or(0, |i| i + 1);
            tables.push(fixed_point(if used == 0 { &[0] } else { &counts[..used] }));
        }
        for table in &tables {
            self.varint(table.len() as u64);
            for &p in &table[..table.len() - 1] {
                self.varint(p as u64);
            }
        }
        let models: Vec<_> = tables
            .iter()
            .map(|t| SmallContiguousCategoricalEntropyModel::from_nonzero_fixed_point_probabilities(t, false).expect("probabilities sum to one"))
            .collect();
        // ANS is a stack: symbols go in backwards so they come out forwards.
        let mut coder = DefaultAnsCoder::new();
        for &coded in sink.symbols.iter().rev() {
            match coded {
                Coded::Static { model, symbol } => coder.encode_symbol(symbol as usize, &models[model as usize]),
                Coded::Adaptive { low, size } => coder.encode_symbol((), Span { low, size }),
            }
            .expect("symbol has a nonzero probability");
        }
        let words = coder.into_compressed().unwrap_or_default();
        self.varint(words.len() as u64);
        for w in words {
            self.bytes.extend_from_slice(&w.to_le_bytes());
        }
        let mut raw = sink.raw;
        let bytes = sink.raw_bits.div_ceil(8);
        raw.truncate(bytes);
        self.varint(bytes as u64);
        self.bytes.extend_from_slice(&raw);
        self.bytes.len() - start
    }
}

/// Adaptive models' probabilities are 15-bit fixed point.
const ADAPTIVE_BITS: u32 = 15;
/// Symbols of an adaptive bucket model: a number's bit length, 0 to 14,
/// or 15 for 15 and more (the excess then in 5 raw bits). Sixteen lanes of
/// 16 bits: the model's search and update are a few vector instructions.
pub(crate) const BUCKETS: usize = 16;
const LONG: u32 = BUCKETS as u32 - 1;

/// A model that learns as it codes, kept as its cumulative distribution
/// (AV1's adaptive CDFs): after each symbol every boundary below it moves a
/// 2^-rate share of the way to 0 and every one above it the same share of
/// the way to the top, so the symbol gains what the others lose. The rate
/// starts at 3 (a model whose first symbols are its only evidence follows
/// them fast) and slows to 5 after 32 symbols, AV1's schedule three steps
/// faster. Each symbol has one quantile of the 2^15 besides its share, so
/// none is ever impossible. With static tables instead (versions 1 to 4) a
/// coarse level paid for them: 70 to 90 bytes of the Crytek Sponza base's
/// connectivity; adaptive models also follow runs (a row of small parts of
/// one shape). Finding a symbol is a count of the boundaries at or below
/// the quantile, with no branch.
#[derive(Clone, Copy)]
pub(crate) struct Adaptive<const K: usize> {
    /// Per symbol, the share of symbols up to it, of 2^15 − K; the last is
    /// always 2^15 − K.
    bound: [u16; K],
    seen: u8,
}

/// The quantiles adaptive models share out, besides one a symbol.
const fn shared(k: usize) -> u32 {
    (1 << ADAPTIVE_BITS) - k as u32
}

impl<const K: usize> Default for Adaptive<K> {
    fn default() -> Self {
        Self::with_rare(K)
    }
}

impl<const K: usize> Adaptive<K> {
    /// A model that starts with `rare` at no share (a symbol the context all
    /// but rules out), the others equal; all equal when `rare` is K or more.
    const fn with_rare(rare: usize) -> Self {
        let others = if rare < K { K - 1 } else { K } as u32;
        let mut bound = [0u16; K];
        let mut i = 0;
        while i < K {
            let below = i as u32 + 1 - (i >= rare) as u32;
            bound[i] = (below * shared(K) / others) as u16;
            i += 1;
        }
        Adaptive { bound, seen: 0 }
    }
    /// Where `symbol` lies among the quantiles: (start, size).
    #[inline(always)]
    fn span(&self, symbol: usize) -> (u16, u16) {
        let low = if symbol == 0 { 0 } else { self.bound[symbol - 1] + symbol as u16 };
        (low, self.bound[symbol] + symbol as u16 + 1 - low)
    }
    /// The symbol at `quantile`, with its span. (Lane by lane in 16 bits, which
    /// the compiler turns into vector instructions.)
    #[inline(always)]
    fn find(&self, quantile: u32) -> (usize, u16, u16) {
        // (bound + i + 1 <= q, in signed 16 bits: both sides below 2^15.)
        // The bounds ascend, so the lanes below the quantile are a prefix:
        // its length is the trailing ones of their mask (a bit scan).
        let q = quantile as i16;
        let mut below = 0u32;
        for i in 0..K {
            below |= u32::from((self.bound[i] as i16 + i as i16) < q) << i;
        }
        let symbol = ((!below).trailing_zeros() as usize).min(K - 1);
        let (low, size) = self.span(symbol);
        (symbol, low, size)
    }
    #[inline(always)]
    fn learn(&mut self, symbol: usize) {
        let rate = 3 + u32::from(self.seen > 15) + u32::from(self.seen > 31);
        self.seen = self.seen.saturating_add(1);
        // Differences fit in 16 bits: the bounds lie in 0..2^15.
        for i in 0..K {
            let b = self.bound[i] as i16;
            let target = if i < symbol { 0 } else { shared(K) as i16 };
            self.bound[i] = (b + ((target - b) >> rate)) as u16;
        }
    }
}

/// One adaptive symbol's span, as `constriction` encodes it.
struct Span {
    low: u16,
    size: u16,
}

impl EntropyModel<{ ADAPTIVE_BITS as usize }> for Span {
    type Symbol = ();
    type Probability = u16;
}

impl EncoderModel<{ ADAPTIVE_BITS as usize }> for Span {
    fn left_cumulative_and_probability(&self, _: impl std::borrow::Borrow<()>) -> Option<(u16, std::num::NonZeroU16)> {
        Some((self.low, std::num::NonZeroU16::new(self.size)?))
    }
}

/// 12-bit probabilities from counts, every symbol at least 1/4096.
fn fixed_point(counts: &[u64]) -> Vec<u16> {
    let total: u64 = counts.iter().sum();
    let spare = (1u64 << PRECISION) - counts.len() as u64;
    let mut p: Vec<u16> = counts.iter().map(|&c| 1 + (c * spare).checked_div(total).unwrap_or(0) as u16).collect();
    let sum: u64 = p.iter().map(|&x| x as u64).sum();
    let top = (0..counts.len()).max_by_key(|&i| (counts[i], std::cmp::Reverse(i))).unwrap_or(0);
    p[top] += ((1u64 << PRECISION) - sum) as u16;
    p
}

/// One coded symbol of a section.
#[derive(Clone, Copy)]
enum Coded {
    /// Symbol `symbol` of static model `model` (stored in the section).
    Static { model: u8, symbol: u8 },
    /// A symbol of an adaptive model, as its span of the 2^15 quantiles
    /// where it was coded (the decoder follows the same adaptation).
    Adaptive { low: u16, size: u16 },
}

/// Symbols and raw bits of a section, gathered before coding (static models
/// are built from their counts).
pub(crate) struct Sink {
    counts: Vec<Vec<u64>>,
    symbols: Vec<Coded>,
    raw: Vec<u8>,
    raw_bits: usize,
}

impl Sink {
    /// A section with `models` static models (none: adaptive models only).
    pub(crate) fn new(models: usize) -> Sink {
        Sink { counts: vec![Vec::new(); models], symbols: Vec::new(), raw: Vec::new(), raw_bits: 0 }
    }
    pub(crate) fn symbol(&mut self, model: usize, symbol: usize) {
        let counts = &mut self.counts[model];
        if counts.len() <= symbol {
            counts.resize(symbol + 1, 0);
        }
        counts[symbol] += 1;
        self.symbols.push(Coded::Static { model: model as u8, symbol: symbol as u8 });
    }
    /// `symbol` under an adaptive model, which then learns it.
    pub(crate) fn adaptive<const K: usize>(&mut self, model: &mut Adaptive<K>, symbol: usize) {
        let (low, size) = model.span(symbol);
        self.symbols.push(Coded::Adaptive { low, size });
        model.learn(symbol);
    }
    /// A number as its bit length (under an adaptive model) and the bits
    /// under the top one (raw).
    pub(crate) fn adaptive_value(&mut self, model: &mut Adaptive<BUCKETS>, x: u32) {
        let n = bit_length(x);
        self.adaptive(model, n.min(LONG) as usize);
        if n >= LONG {
            self.raw(n - LONG, 5);
        }
        if n > 1 {
            self.raw(x & !(1 << (n - 1)), n - 1);
        }
    }
    pub(crate) fn raw(&mut self, value: u32, bits: u32) {
        for i in 0..bits {
            if self.raw_bits.is_multiple_of(8) {
                self.raw.push(0);
            }
            *self.raw.last_mut().unwrap() |= (((value >> i) & 1) as u8) << (self.raw_bits % 8);
            self.raw_bits += 1;
        }
    }
    /// A number as its bit length (modelled) and the bits under the top one (raw).
    pub(crate) fn value(&mut self, model: usize, x: u32) {
        let n = bit_length(x);
        self.symbol(model, n as usize);
        if n > 1 {
            self.raw(x & !(1 << (n - 1)), n - 1);
        }
    }
}

/// The body of a file framed as this crate's files are (a 4-byte magic, a
/// version byte, the body, a CRC-32 of all before it), read past its
/// version, with that version (one of `versions`); `what` names the kind of
/// file in errors.
pub(crate) fn framed<'a>(bytes: &'a [u8], magic: &[u8; 4], versions: RangeInclusive<u8>, what: &str) -> Result<(u8, Reader<'a>), CodingError> {
    let corrupt = |m: String| Err(CodingError::Corrupt(m));
    if bytes.len() < magic.len() + 5 || &bytes[..4] != magic {
        return corrupt(format!("not a {what} (no {} header)", String::from_utf8_lossy(magic)));
    }
    if !versions.contains(&bytes[4]) {
        let known =
            if versions.start() == versions.end() { format!("{}", versions.start()) } else { format!("{} to {}", versions.start(), versions.end()) };
        return corrupt(format!("{what} version {} (this reader knows {known})", bytes[4]));
    }
    let (body, crc) = bytes.split_at(bytes.len() - 4);
    if crc32fast::hash(body).to_le_bytes() != crc {
        return corrupt(format!("{what} checksum mismatch (truncated or damaged)"));
    }
    Ok((bytes[4], Reader { bytes: body, at: 5 }))
}

pub(crate) struct Reader<'a> {
    pub(crate) bytes: &'a [u8],
    pub(crate) at: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn take(&mut self, n: usize) -> Result<&'a [u8], CodingError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or_else(|| CodingError::Corrupt("truncated".into()))?;
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }
    pub(crate) fn varint(&mut self) -> Result<u64, CodingError> {
        let mut x = 0u64;
        for shift in (0..64).step_by(7) {
            let b = self.take(1)?[0];
            x |= ((b & 0x7f) as u64) << shift;
            if b < 0x80 {
                return Ok(x);
            }
        }
        Err(CodingError::Corrupt("varint too long".into()))
    }
}

/// A model being decoded with: its cumulative probabilities (the symbols'
/// in order, then 4,096) and, built at its first symbol, the symbol of each
/// of the 4,096 quantiles.
struct Model {
    /// Symbol s spans quantiles `cdf[s]..cdf[s + 1]`; at most 64 symbols
    /// (checked when read).
    cdf: [u16; 65],
    /// `cdf[s + 1] - cdf[s]`, kept although derivable: each symbol's step then
    /// waits on one load, not two and a subtraction (4 % of a small mesh's
    /// decoding). Slots past `symbols` hold nothing meaningful and are never
    /// read (the table holds only symbols below it).
    size: [u16; 64],
    symbols: usize,
    table: Option<Box<[u8; 1 << PRECISION]>>,
}

impl Model {
    /// The table, each byte written once (a run per symbol).
    #[cold]
    fn fill_table(&mut self) -> &[u8; 1 << PRECISION] {
        let mut table = Vec::with_capacity(1 << PRECISION);
        for s in 0..self.symbols {
            table.resize(self.cdf[s + 1] as usize, s as u8);
        }
        self.table.insert(table.into_boxed_slice().try_into().expect("the last symbol ends at 4,096"))
    }
}

/// A section being decoded. The rANS decoding is done here rather than by
/// `constriction` (which encodes): its lookup tables took longer to build than
/// a small mesh takes to decode, and searching instead was slower per symbol.
/// This one fills a table of one byte a quantile, a run per symbol, the first
/// time a model is used. The steps are constriction's `AnsCoder<u32, u64>`
/// (words popped from the end; a word read whenever the state falls under
/// 2³²), so both read the same files (tests decode what constriction coded).
pub(crate) struct Source<'a> {
    models: Vec<Model>,
    /// The unread entropy-coded words, as little-endian bytes (read from the end).
    words: &'a [u8],
    state: u64,
    raw: &'a [u8],
    raw_at: usize,
}

impl<'a> Source<'a> {
    pub(crate) fn new(input: &mut Reader<'a>, models: usize) -> Result<Source<'a>, CodingError> {
        let corrupt = |m: &str| CodingError::Corrupt(format!("section models: {m}"));
        let mut tables = Vec::with_capacity(models);
        for _ in 0..models {
            let n = input.varint()? as usize;
            if n == 0 || n > 64 {
                return Err(corrupt("alphabet size"));
            }
            let mut cdf = [0u16; 65];
            let mut sum = 0u64;
            for c in &mut cdf[1..n] {
                let x = input.varint()?;
                // Every symbol at least 1/4096 and the last one too (x
                // bounded before the sum, which a huge x would overflow).
                if x == 0 || x >= 1 << PRECISION || sum + x >= 1 << PRECISION {
                    return Err(corrupt("probabilities"));
                }
                sum += x;
                *c = sum as u16;
            }
            cdf[n] = 1 << PRECISION;
            let size = std::array::from_fn(|s| cdf[s + 1].wrapping_sub(cdf[s]));
            tables.push(Model { cdf, size, symbols: n, table: None });
        }
        let count = input.varint()? as usize;
        if count > input.bytes.len() / 4 {
            return Err(corrupt("word count"));
        }
        let words = input.take(count * 4)?;
        let mut source = Source { models: tables, words, state: 0, raw: &[], raw_at: 0 };
        // The first word read is the top of the state: never zero.
        if let Some(first) = source.pop() {
            if first == 0 {
                return Err(corrupt("entropy coder"));
            }
            source.state = first as u64;
            if let Some(second) = source.pop() {
                source.state = source.state << 32 | second as u64;
            }
        }
        let raw_len = input.varint()? as usize;
        source.raw = input.take(raw_len)?;
        Ok(source)
    }

    /// The last unread word.
    #[inline]
    fn pop(&mut self) -> Option<u32> {
        let (rest, last) = self.words.split_last_chunk::<4>()?;
        self.words = rest;
        Some(u32::from_le_bytes(*last))
    }

    /// The next symbol of `model`. Any state decodes to some symbol, so
    /// damaged data gives wrong symbols (which the callers' range checks and
    /// the file's CRC catch), never a failure here.
    #[inline(always)]
    pub(crate) fn symbol(&mut self, model: usize) -> usize {
        let m = &mut self.models[model];
        let quantile = (self.state & ((1 << PRECISION) - 1)) as usize;
        let symbol = match &m.table {
            Some(table) => table[quantile],
            None => m.fill_table()[quantile],
        } as usize;
        let (low, size) = (m.cdf[symbol], m.size[symbol]);
        self.advance(PRECISION, quantile as u32 - low as u32, size as u32);
        symbol
    }
    /// The state after a symbol of `size` quantiles out of 2^`precision`,
    /// `quantile - low` into it.
    #[inline(always)]
    fn advance(&mut self, precision: u32, into: u32, size: u32) {
        self.state = (self.state >> precision) * size as u64 + into as u64;
        if self.state < 1 << 32 {
            if let Some(word) = self.pop() {
                self.state = self.state << 32 | word as u64;
            }
        }
    }
    /// The next symbol of an adaptive model, which then learns it.
    #[inline(always)]
    pub(crate) fn adaptive<const K: usize>(&mut self, model: &mut Adaptive<K>) -> usize {
        let quantile = (self.state & ((1 << ADAPTIVE_BITS) - 1)) as u32;
        let (symbol, low, size) = model.find(quantile);
        self.advance(ADAPTIVE_BITS, quantile - low as u32, size as u32);
        model.learn(symbol);
        symbol
    }
    /// A number coded by [`Sink::adaptive_value`].
    #[inline(always)]
    pub(crate) fn adaptive_value(&mut self, model: &mut Adaptive<BUCKETS>) -> Result<u32, CodingError> {
        let mut n = self.adaptive(model) as u32;
        if n == LONG {
            n += self.bits(5).ok_or_else(|| CodingError::Corrupt("raw bits run out".into()))?;
        }
        let below = n.saturating_sub(1);
        let low =
            (n <= 32).then(|| self.bits(below)).flatten().ok_or_else(|| CodingError::Corrupt("value over 32 bits or raw bits run out".into()))?;
        Ok(if n == 0 { 0 } else { 1 << below | low })
    }
    pub(crate) fn raw(&mut self, bits: u32) -> Result<u32, CodingError> {
        (bits <= 32).then(|| self.bits(bits)).flatten().ok_or_else(|| CodingError::Corrupt("raw bits run out".into()))
    }
    /// The next `bits` (at most 32) raw bits, None past the end.
    #[inline(always)]
    fn bits(&mut self, bits: u32) -> Option<u32> {
        let end = self.raw_at + bits as usize;
        if end > self.raw.len() * 8 {
            return None;
        }
        // At most 32 bits from any bit offset: within five bytes, read as one
        // little-endian word of eight where eight are left.
        let (byte, shift) = (self.raw_at / 8, self.raw_at % 8);
        let window = match self.raw.get(byte..byte + 8) {
            Some(eight) => u64::from_le_bytes(eight.try_into().ok()?),
            // Near the end: the bytes that are left.
            None => self.raw[byte.min(self.raw.len())..].iter().rev().fold(0u64, |w, &b| w << 8 | b as u64),
        };
        self.raw_at = end;
        Some(((window >> shift) & ((1u64 << bits) - 1)) as u32)
    }
    /// A number coded as its bit length (a symbol of `model`) and the bits
    /// below its leading one (raw). Always inlined too, so the state stays
    /// in a register through the loops over records (the copies of
    /// non-manifold vertices: 3 % of the Dabrovic Sponza's 664 triangles).
    #[inline(always)]
    pub(crate) fn value(&mut self, model: usize) -> Result<u32, CodingError> {
        self.try_value(model).ok_or_else(|| CodingError::Corrupt("value over 32 bits or raw bits run out".into()))
    }
    /// `value`, None where it fails (returned in a register, for hot loops).
    /// It, `symbol` and `bits` are always inlined so that the coder's state
    /// stays in a register through a loop: 5 % of a small level's decoding.
    #[inline(always)]
    fn try_value(&mut self, model: usize) -> Option<u32> {
        let n = self.symbol(model) as u32;
        // (A hostile table has bit lengths up to 63: refused before the shift.)
        if n > 32 {
            return None;
        }
        let below = n.saturating_sub(1);
        let low = self.bits(below)?;
        Some(if n == 0 { 0 } else { 1 << below | low })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edgebreaker::tests::{canonical, grid, torus};

    fn wavy_grid(n: u32) -> MeshData {
        let positions = (0..(n + 1) * (n + 1)).map(|i| {
            let (x, y) = ((i % (n + 1)) as f32, (i / (n + 1)) as f32);
            [x, (x * 0.3).sin() + (y * 0.2).cos(), y]
        });
        let positions: Vec<[f32; 3]> = positions.collect();
        let triangles = grid(n);
        let groups = (0..triangles.len() as u32).map(|t| (t / 40) % 3).collect();
        let colours = positions.iter().map(|p| [(p[0] * 9.0) as u8, 200, (p[1] * 60.0 + 128.0) as u8]).collect();
        MeshData { positions, triangles, groups, colours }
    }

    /// Decoded vertex i is input vertex `order.vertices[i]`: positions within
    /// half a grid step, colours and groups exact, triangles the same.
    pub(crate) fn check_round_trip(mesh: &MeshData, bits: u32) -> Encoded {
        let encoded = encode(mesh, bits).unwrap();
        let back = decode(&encoded.bytes).unwrap();
        let order = &encoded.order;
        assert_eq!(back.positions.len(), order.vertices.len());
        let (lo, hi) = mesh
            .positions
            .iter()
            .fold(([f32::MAX; 3], [f32::MIN; 3]), |(l, h), p| (std::array::from_fn(|i| l[i].min(p[i])), std::array::from_fn(|i| h[i].max(p[i]))));
        for (k, &v) in order.vertices.iter().enumerate() {
            for i in 0..3 {
                let step = (hi[i] - lo[i]) / ((1u32 << bits) - 1) as f32;
                assert!((back.positions[k][i] - mesh.positions[v as usize][i]).abs() <= step * 0.5001 + 1e-6, "vertex {v} axis {i}");
            }
            if !mesh.colours.is_empty() {
                assert_eq!(back.colours[k], mesh.colours[v as usize]);
            }
        }
        let mapped = canonical(back.triangles.iter().map(|t| t.map(|v| order.vertices[v as usize])));
        assert_eq!(mapped, canonical(mesh.triangles.iter().copied()));
        for (k, &t) in order.triangles.iter().enumerate() {
            assert_eq!(back.groups[k], mesh.groups.get(t as usize).copied().unwrap_or(0));
        }
        encoded
    }

    #[test]
    fn grid_with_groups_and_colours_round_trips() {
        let mesh = wavy_grid(30);
        let encoded = check_round_trip(&mesh, 14);
        // 1800 triangles: connectivity well under 2 bits a triangle.
        let bits = encoded.sizes.connectivity as f64 * 8.0 / mesh.triangles.len() as f64;
        assert!(bits < 2.0, "{bits} bits a triangle");
        check_round_trip(&MeshData { colours: Vec::new(), groups: Vec::new(), ..mesh }, 10);
    }

    /// On a regular grid the parallelogram rule predicts every vertex that
    /// has a parallelogram (all but the first triangle's and those next to the
    /// border's dummy) exactly. (43 divides 2^14 - 1, so the grid's points lie
    /// exactly on the quantization grid.)
    #[test]
    fn parallelograms_predict_a_regular_grid_exactly() {
        let n = 43;
        let positions: Vec<[f32; 3]> =
            (0..(n + 1) * (n + 1)).map(|i| [(i % (n + 1)) as f32, 0.5 * (i / (n + 1)) as f32, 0.25 * (i % (n + 1)) as f32]).collect();
        let mesh = MeshData { positions, triangles: grid(n), ..MeshData::default() };
        check_round_trip(&mesh, 14);
        let (code, order) = edgebreaker::encode(&mesh.triangles, mesh.positions.len() as u32).unwrap();
        let decoded = edgebreaker::decode(&code).unwrap();
        let grid = Grid::new([0.0; 3], [43.0, 21.5, 10.75], 14);
        let quantized: Vec<[u32; 3]> = order.vertices.iter().map(|&v| grid.quantize(mesh.positions[v as usize])).collect();
        let mut exact = 0;
        for (v, p) in decoded.predictors.iter().enumerate() {
            if decoded.keep[v] != NONE && p.iter().all(|&x| x != NONE && decoded.keep[x as usize] != NONE) {
                assert_eq!(predict(p, &decoded.keep, &quantized, [0; 3], grid.max), quantized[decoded.keep[v] as usize], "vertex {v}");
                exact += 1;
            }
        }
        assert!(exact > mesh.positions.len() * 3 / 4, "{exact} predicted of {}", mesh.positions.len());
    }

    #[test]
    fn torus_soup_and_empty_meshes_round_trip() {
        let tris = torus(12, 7);
        let positions = (0..84).map(|i| {
            let (a, b) = ((i / 7) as f32 * 0.52, (i % 7) as f32 * 0.9);
            [(2.0 + b.cos()) * a.cos(), b.sin(), (2.0 + b.cos()) * a.sin()]
        });
        check_round_trip(&MeshData { positions: positions.collect(), triangles: tris, ..MeshData::default() }, 14);
        let soup = MeshData {
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [5.0; 3], [5.0, 6.0, 5.0], [6.0, 5.0, 5.0]],
            triangles: vec![[0, 1, 2], [3, 4, 5], [0, 2, 1]],
            groups: vec![0, 7, 2],
            colours: Vec::new(),
        };
        check_round_trip(&soup, 14);
        let empty = MeshData::default();
        assert_eq!(decode(&encode(&empty, 14).unwrap().bytes).unwrap(), empty);
    }

    /// Found by the `splits` fuzz target: a model's probability as large as
    /// a LEB128 number goes (2^64 − 1) overflowed the sum it was checked by.
    #[test]
    fn a_huge_probability_in_a_model_table_is_an_error_not_an_overflow() {
        let mut bytes = vec![2u8];
        bytes.extend([0xff; 9]);
        bytes.push(0x01);
        assert!(Source::new(&mut Reader { bytes: &bytes, at: 0 }, 1).is_err());
    }

    /// The hand-written rANS decoder against constriction's encoder, on
    /// models of one symbol (probability 1), two, and 64 (most rare), in
    /// sections from empty to long enough for many word reads.
    #[test]
    fn sections_decode_to_the_symbols_and_raw_bits_coded() {
        let mut state = 99u64;
        let mut next = move |n: u64| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) % n
        };
        for length in [0usize, 1, 7, 300, 20_000] {
            let mut sink = Sink::new(3);
            let mut expected = Vec::new();
            for k in 0..length {
                let model = k % 3;
                let symbol = match model {
                    0 => 0,
                    // Skewed: symbol 1 about one time in a hundred.
                    1 => usize::from(next(100) == 0),
                    _ => [next(64), next(3)][next(2) as usize] as usize,
                };
                sink.symbol(model, symbol);
                let bits = next(20) as u32;
                let raw = next(1 << bits) as u32;
                sink.raw(raw, bits);
                expected.push((model, symbol, bits, raw));
            }
            let mut out = Writer::default();
            out.section(sink);
            let mut reader = Reader { bytes: &out.bytes, at: 0 };
            let mut source = Source::new(&mut reader, 3).unwrap();
            for (k, &(model, symbol, bits, raw)) in expected.iter().enumerate() {
                assert_eq!(source.symbol(model), symbol, "symbol {k} of {length}");
                assert_eq!(source.raw(bits).unwrap(), raw, "raw bits {k} of {length}");
            }
            assert_eq!(reader.at, out.bytes.len());
        }
    }

    #[test]
    fn damaged_files_are_errors() {
        let mesh = wavy_grid(6);
        let bytes = encode(&mesh, 14).unwrap().bytes;
        for n in 0..bytes.len() {
            assert!(decode(&bytes[..n]).is_err(), "truncated to {n}");
        }
        for i in 0..bytes.len() {
            for bit in [0, 3, 7] {
                let mut bad = bytes.clone();
                bad[i] ^= 1 << bit;
                assert!(decode(&bad).is_err(), "byte {i} bit {bit}");
            }
        }
        // A later version, its checksum correct, names the versions this reader knows.
        let mut later = bytes[..bytes.len() - 4].to_vec();
        later[4] = VERSION + 1;
        later.extend_from_slice(&crc32fast::hash(&later).to_le_bytes());
        let message = decode(&later).unwrap_err().to_string();
        assert!(message.contains(&format!("version {} (this reader knows 1 to {VERSION})", VERSION + 1)), "{message}");
    }

    #[test]
    fn components_with_a_boundary_start_from_a_loop_and_older_files_still_decode() {
        // Two open grids: each starts from its boundary loop, so no dummy is coded.
        let one = wavy_grid(4);
        let mut two = one.clone();
        let n = one.positions.len() as u32;
        two.positions.extend(one.positions.iter().map(|p| [p[0] + 10.0, p[1], p[2]]));
        two.triangles.extend(one.triangles.iter().map(|t| t.map(|v| v + n)));
        two.groups.extend(one.groups.clone());
        two.colours.extend(one.colours.clone());
        let coded = check_round_trip(&two, 14);
        let mut reader = Reader { bytes: &coded.bytes, at: 5 };
        let counts: Vec<u64> = (0..6).map(|_| reader.varint().unwrap()).collect();
        assert_eq!((counts[0], counts[4], counts[5]), (two.triangles.len() as u64, 2, 0), "all triangles, two start loops, no dummy");
        // A header claiming more start loops than there are components is refused.
        let mut bad = MAGIC.to_vec();
        bad.push(VERSION);
        let mut w = Writer::default();
        for (i, &c) in counts.iter().enumerate() {
            w.varint(if i == 4 { 3 } else { c });
        }
        bad.extend_from_slice(&w.bytes);
        bad.extend_from_slice(&coded.bytes[reader.at..coded.bytes.len() - 4]);
        let crc = crc32fast::hash(&bad);
        bad.extend_from_slice(&crc.to_le_bytes());
        assert!(matches!(decode(&bad), Err(CodingError::Corrupt(m)) if m.contains("start at a loop")), "{:?}", decode(&bad));
        // Version 1 (every dummy listed), version 2 (a group flag a
        // triangle), version 3 (components start at a dummy) and version 4
        // (static models): the fuzzing seeds, written before the next
        // version; the version 5 seeds; and the version 4 seed re-encoded by
        // version 6. Each re-encoded gives the same mesh, and the three
        // codings of the version 4 seed's mesh give the same mesh.
        let seeds = [
            (&include_bytes!("../../fuzz/seeds/proxy/0.emmc")[..], 1),
            (&include_bytes!("../../fuzz/seeds/proxy/1.emmc")[..], 2),
            (&include_bytes!("../../fuzz/seeds/proxy/2.emmc")[..], 3),
            (&include_bytes!("../../fuzz/seeds/proxy/3.emmc")[..], 4),
            // Version 5: the version 4 seed re-encoded, and 80 bowties (80
            // copies, so under static models).
            (&include_bytes!("../../fuzz/seeds/proxy/4.emmc")[..], 5),
            (&include_bytes!("../../fuzz/seeds/proxy/5.emmc")[..], 5),
            (&include_bytes!("../../fuzz/seeds/proxy/6.emmc")[..], 6),
        ];
        let mut same = Vec::new();
        for (i, (seed, version)) in seeds.into_iter().enumerate() {
            assert_eq!(seed[4], version);
            let old = decode(seed).unwrap_or_else(|e| panic!("a version {version} file decodes: {e}"));
            assert!(!old.triangles.is_empty());
            assert!(version == 1 || old.groups.iter().any(|&g| g != old.groups[0]), "several groups");
            let again = decode(&encode(&old, 14).unwrap().bytes).unwrap();
            // The same triangles (by their corners' positions, each rotated
            // to start at its least corner) with their groups, in any order.
            let set = |m: &MeshData| {
                let mut out: Vec<([[u32; 3]; 3], u32)> = m
                    .triangles
                    .iter()
                    .zip(&m.groups)
                    .map(|(t, &g)| {
                        let c = t.map(|v| m.positions[v as usize].map(f32::to_bits));
                        let r = (0..3).min_by_key(|&i| c[i]).unwrap();
                        ([c[r], c[(r + 1) % 3], c[(r + 2) % 3]], g)
                    })
                    .collect();
                out.sort_unstable();
                out
            };
            assert_eq!(set(&again), set(&old), "version {version}");
            if [3, 4, 6].contains(&i) {
                same.push(set(&old));
            }
        }
        assert!(same[1] == same[0] && same[2] == same[0], "versions 4, 5 and 6 of one mesh decode alike");
        // The version 6 seed is the version 4 seed's mesh as version 6's
        // encoder wrote it. The same bytes now: the encoder still codes as
        // version 6 files mean (the priors applied, the contexts as laid
        // out); a change to either needs a new version.
        let four = decode(include_bytes!("../../fuzz/seeds/proxy/3.emmc")).unwrap();
        assert!(
            encode(&four, 14).unwrap().bytes == include_bytes!("../../fuzz/seeds/proxy/6.emmc"),
            "version {VERSION} no longer writes what it wrote"
        );
    }

    /// Files that pass the checksum but lie: every field rewritten, the CRC
    /// recomputed. Errors or a mesh; never a panic.
    #[test]
    fn hostile_files_do_not_panic() {
        // A grid; the version 4 seed's mesh (open parts, start loops); 80
        // bowties (copies under static models); each as the current version writes it.
        let seed = decode(include_bytes!("../../fuzz/seeds/proxy/3.emmc")).unwrap();
        for (mesh, trials) in [(wavy_grid(5), 20000), (seed, 10000)] {
            mutate(&encode(&mesh, 14).unwrap().bytes, trials);
        }
        mutate(include_bytes!("../../fuzz/seeds/proxy/5.emmc"), 10000);
    }

    /// Found by fuzzing past the checksum: a version 2 file whose model
    /// gives a bit length over 32 overflowed the shift that rebuilds the
    /// number (a panic with overflow checks on).
    #[test]
    fn a_value_over_32_bits_is_an_error_not_an_overflow() {
        let bytes = include_bytes!("../../fuzz/regressions/proxy-value-over-32-bits");
        assert!(decode(bytes).is_err());
    }

    /// Rewrites bytes of `bytes` (a coded mesh) and its CRC `trials` times;
    /// decoding gives an error or a mesh, never a panic.
    fn mutate(bytes: &[u8], trials: usize) {
        let body = bytes.len() - 4;
        let mut state = 12345u64;
        for trial in 0..trials {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let mut bad = bytes[..body].to_vec();
            let i = (state >> 33) as usize % body;
            bad[i] = (state >> 20) as u8;
            if trial % 3 == 0 {
                let j = (state >> 40) as usize % body;
                bad[j] = bad[j].wrapping_add(1);
            }
            let crc = crc32fast::hash(&bad);
            bad.extend_from_slice(&crc.to_le_bytes());
            if let Ok(m) = decode(&bad) {
                assert!(m.triangles.iter().flatten().all(|&v| (v as usize) < m.positions.len()));
                assert_eq!(m.groups.len(), m.triangles.len());
            }
        }
    }
}

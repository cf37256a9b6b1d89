//! A probe's depth for glides: the distance from the probe to what it sees,
//! at the corners of an n × n lattice on each cube face, so the viewer can
//! raise the panorama into a mesh (a vertex a corner) and draw it from a
//! camera moving along a path. Corners, not texel centres: the corners on a
//! face's edge are the same directions as those of the face beside it, so
//! the six faces' meshes meet without cracks.
//!
//! Layout: magic `EMDC`, version byte (1), n (LEB128), near and far
//! distances (2 × f32 LE), then one entropy-coded section (as in
//! [`crate::meshcode`]) holding the 6·(n+1)² 16-bit codes, faces in
//! [`crate::CUBE_FACES`] order, rows top down, each as the residual from the
//! gradient prediction (left + above − above-left; a face's first row and
//! column from their one neighbour). Code 0 means nothing is hit (sky); code
//! c in 1..=65535 the distance near·(far/near)^((c − 1)/65534), steps of
//! 0.02 % for a range of 10⁵. Then the CRC-32 (u32 LE) of all before it.

use crate::edgebreaker::CodingError;
use crate::meshcode::{framed, unzigzag, zigzag, Sink, Source, Writer};

const MAGIC: &[u8; 4] = b"EMDC";
const VERSION: u8 = 1;
/// The largest lattice read (a hostile header cannot make a huge cube).
pub const MAX_SIZE: u32 = 1024;
const TOP: f32 = 65534.0;

#[derive(Clone, Debug, PartialEq)]
pub struct DepthCube {
    /// Cells a face edge: (size + 1)² corners a face.
    pub size: u32,
    pub near: f32,
    pub far: f32,
    /// Per corner, face by face, rows top down: the distance code (0: sky).
    pub codes: Vec<u16>,
}

impl DepthCube {
    /// A cube of `size` cells a face edge from the distance at each corner
    /// (in [`DepthCube::corner_direction`] order; None: nothing hit).
    pub fn new(size: u32, near: f32, far: f32, distances: &[Option<f32>]) -> DepthCube {
        let mut cube = DepthCube { size, near, far, codes: Vec::with_capacity(distances.len()) };
        cube.codes = distances.iter().map(|&d| cube.code(d)).collect();
        cube
    }

    /// Corners a face edge.
    pub fn side(&self) -> usize {
        self.size as usize + 1
    }

    /// The unit direction of corner `i` (face by face, rows top down).
    pub fn corner_direction(&self, i: usize) -> [f32; 3] {
        corner_direction(self.size, i)
    }

    /// The code of a distance (clamped to near..far); `None` (sky) is 0.
    pub fn code(&self, distance: Option<f32>) -> u16 {
        let Some(d) = distance else { return 0 };
        let f = (d.max(self.near) / self.near).ln() / (self.far / self.near).ln();
        1 + (f.clamp(0.0, 1.0) * TOP).round() as u16
    }

    /// The distance a code stands for (None: sky).
    pub fn distance(&self, code: u16) -> Option<f32> {
        (code > 0).then(|| self.near * (self.far / self.near).powf(f32::from(code - 1) / TOP))
    }

    /// The gradient prediction of corner `i`'s code from those before it.
    fn predicted(&self, codes: &[u16], i: usize) -> i64 {
        let n = self.side();
        let at = |k: usize| i64::from(codes[k]);
        match (i % n, (i / n) % n) {
            (0, 0) => 0,
            (0, _) => at(i - n),
            (_, 0) => at(i - 1),
            _ => at(i - 1) + at(i - n) - at(i - n - 1),
        }
    }

    pub fn encode(&self) -> Vec<u8> {
        let mut out = Writer::default();
        out.bytes.extend_from_slice(MAGIC);
        out.bytes.push(VERSION);
        out.varint(u64::from(self.size));
        out.bytes.extend_from_slice(&self.near.to_le_bytes());
        out.bytes.extend_from_slice(&self.far.to_le_bytes());
        let mut sink = Sink::new(1);
        for (i, &code) in self.codes.iter().enumerate() {
            sink.value(0, zigzag(i64::from(code) - self.predicted(&self.codes, i)));
        }
        out.section(sink);
        let crc = crc32fast::hash(&out.bytes);
        out.bytes.extend_from_slice(&crc.to_le_bytes());
        out.bytes
    }

    /// Decodes a cube; any inconsistency is an error, never a panic.
    pub fn decode(bytes: &[u8]) -> Result<DepthCube, CodingError> {
        let corrupt = |m: String| Err(CodingError::Corrupt(m));
        let (_, mut input) = framed(bytes, MAGIC, VERSION..=VERSION, "depth cube")?;
        let body_len = input.bytes.len();
        let size = input.varint()?;
        if size == 0 || size > u64::from(MAX_SIZE) {
            return corrupt(format!("a lattice of {size} cells a face edge"));
        }
        let mut float = || input.take(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        let (near, far) = (float()?, float()?);
        if !(near.is_finite() && far.is_finite() && near > 0.0 && far > near) {
            return corrupt(format!("depth range {near}..{far}"));
        }
        let corners = 6 * (size as usize + 1).pow(2);
        let mut cube = DepthCube { size: size as u32, near, far, codes: Vec::with_capacity(corners) };
        let mut source = Source::new(&mut input, 1)?;
        for i in 0..corners {
            let code = cube.predicted(&cube.codes, i) + unzigzag(source.value(0)?);
            let Ok(code) = u16::try_from(code) else { return corrupt(format!("depth code {code}")) };
            cube.codes.push(code);
        }
        if input.at != body_len {
            return corrupt("bytes after the corners".into());
        }
        Ok(cube)
    }
}

/// The unit direction of corner `i` of a cube of `size` cells a face edge
/// (face by face, rows top down): the builder casts its rays along these.
pub fn corner_direction(size: u32, i: usize) -> [f32; 3] {
    let n = size as usize + 1;
    let (face, row, column) = (i / (n * n), (i / n) % n, i % n);
    let d = crate::cube_direction(face, column as f32 / size as f32, row as f32 / size as f32);
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    d.map(|c| c / len)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A probe 1.5 above a floor, with walls 4 away on ±X and sky elsewhere.
    fn room(size: u32) -> DepthCube {
        let corners = 6 * (size as usize + 1).pow(2);
        let distances: Vec<Option<f32>> = (0..corners)
            .map(|i| {
                let d = corner_direction(size, i);
                let floor = (d[1] < -1e-6).then(|| 1.5 / -d[1]);
                let wall = (d[0].abs() > 1e-6).then(|| 4.0 / d[0].abs());
                match (floor, wall) {
                    (Some(f), Some(w)) => Some(f.min(w)),
                    (f, w) => f.or(w),
                }
            })
            .collect();
        DepthCube::new(size, 0.05, 5000.0, &distances)
    }

    #[test]
    fn cubes_round_trip_compactly_with_shared_edges() {
        let cube = room(32);
        let bytes = cube.encode();
        assert_eq!(DepthCube::decode(&bytes).unwrap(), cube);
        let corners = cube.codes.len();
        assert!(bytes.len() < corners, "{} bytes for {corners} corners: planes predict well", bytes.len());
        // A corner on a face's edge is the same direction as its twin on the next face.
        let n = cube.side();
        let px_left_column_top = corner_direction(32, 0); // +X face, row 0, column 0
        let twin = (0..corners).filter(|&i| i / (n * n) != 0).find(|&i| {
            let d = corner_direction(32, i);
            (0..3).all(|k| (d[k] - px_left_column_top[k]).abs() < 1e-6)
        });
        let twin = twin.expect("a corner of another face in the same direction");
        assert_eq!(cube.codes[twin], cube.codes[0]);
        // Codes keep distances to 0.02 % over the whole range.
        for d in [0.05f32, 0.3, 1.7, 42.0, 4999.0] {
            let back = cube.distance(cube.code(Some(d))).unwrap();
            assert!((back - d).abs() / d < 2e-4, "{d} → {back}");
        }
        assert_eq!(cube.distance(cube.code(None)), None);
    }

    #[test]
    fn damaged_and_hostile_cubes_are_errors() {
        let bytes = room(4).encode();
        for cut in 0..bytes.len() {
            assert!(DepthCube::decode(&bytes[..cut]).is_err());
        }
        for i in 0..bytes.len() {
            let mut bad = bytes.clone();
            bad[i] ^= 0x24;
            assert!(DepthCube::decode(&bad).is_err(), "flip at {i}");
        }
        // A huge lattice with a valid checksum.
        let mut hostile = b"EMDC\x01\xff\xff\x03".to_vec();
        hostile.extend_from_slice(&0.1f32.to_le_bytes());
        hostile.extend_from_slice(&10f32.to_le_bytes());
        let crc = crc32fast::hash(&hostile);
        hostile.extend_from_slice(&crc.to_le_bytes());
        assert!(DepthCube::decode(&hostile).is_err());
    }
}

//! Point-to-go from a panorama: per probe, a small cube map of what each
//! direction hits, how far away (log-quantized, 8 bits) and which probe sees
//! that point best, so a tap on the panorama becomes a 3D point and a
//! destination with no geometry on the device.
//!
//! Layout: magic `EMDM`, version byte (1), the face size n and the probe
//! count (LEB128), near and far distances (2 × f32 LE), then one entropy-coded
//! section (as in [`crate::meshcode`]: rANS models, words, raw bits) holding
//! the 6·n² texels in [`crate::CUBE_FACES`] order, rows top down: first every
//! depth code as a residual from its left neighbour (the one above at a
//! row's start), then the probes as runs (length, probe + 1). Depth code 0
//! means nothing is hit (sky); code c in 1..=255 the distance
//! near·(far/near)^((c − 1)/254). Probe 0 means no probe sees the point.
//! Then the CRC-32 (u32 LE) of all before it.

use crate::edgebreaker::CodingError;
use crate::meshcode::{framed, unzigzag, zigzag, Sink, Source, Writer};
use crate::seen::NONE;

const MAGIC: &[u8; 4] = b"EMDM";
const VERSION: u8 = 1;
/// The largest face size read (a hostile header cannot make a huge map).
pub const MAX_SIZE: u32 = 256;

#[derive(Clone, Debug, PartialEq)]
pub struct DepthMap {
    pub size: u32,
    pub near: f32,
    pub far: f32,
    /// Per texel, the depth code (0: nothing hit).
    pub depth: Vec<u8>,
    /// Per texel, the probe that sees the point best, or [`NONE`].
    pub best: Vec<u32>,
}

impl DepthMap {
    /// The code of a distance (clamped to near..far); `None` (sky) is 0.
    pub fn code(&self, distance: Option<f32>) -> u8 {
        let Some(d) = distance else { return 0 };
        let f = (d.max(self.near) / self.near).ln() / (self.far / self.near).ln();
        1 + (f.clamp(0.0, 1.0) * 254.0).round() as u8
    }

    /// The distance a code stands for.
    pub fn distance(&self, code: u8) -> Option<f32> {
        (code > 0).then(|| self.near * (self.far / self.near).powf(f32::from(code - 1) / 254.0))
    }

    /// The texel a world direction falls in.
    pub fn texel(&self, d: [f32; 3]) -> usize {
        let (face, s, t) = crate::cube_face_of(d);
        let n = self.size as usize;
        let (x, y) = (((s * n as f32) as usize).min(n - 1), ((t * n as f32) as usize).min(n - 1));
        face * n * n + y * n + x
    }

    /// What the direction `d` hits: its distance and the probe seeing it best.
    pub fn look(&self, d: [f32; 3]) -> Option<(f32, u32)> {
        let i = self.texel(d);
        Some((self.distance(self.depth[i])?, self.best[i]))
    }

    /// The prediction of texel `i`'s depth code from those before it.
    fn predicted(&self, depth: &[u8], i: usize) -> u8 {
        let n = self.size as usize;
        match (i % n, (i / n) % n) {
            (0, 0) => 0,
            (0, _) => depth[i - n],
            _ => depth[i - 1],
        }
    }

    pub fn encode(&self) -> Vec<u8> {
        let mut out = Writer::default();
        out.bytes.extend_from_slice(MAGIC);
        out.bytes.push(VERSION);
        out.varint(u64::from(self.size));
        out.varint(u64::from(self.best.iter().filter(|&&b| b != NONE).max().map_or(0, |&b| b + 1)));
        out.bytes.extend_from_slice(&self.near.to_le_bytes());
        out.bytes.extend_from_slice(&self.far.to_le_bytes());
        let mut sink = Sink::new(3);
        for (i, &code) in self.depth.iter().enumerate() {
            sink.value(0, zigzag(i64::from(code) - i64::from(self.predicted(&self.depth, i))));
        }
        for run in self.best.chunk_by(|a, b| a == b) {
            sink.value(1, run.len() as u32);
            sink.value(2, if run[0] == NONE { 0 } else { run[0] + 1 });
        }
        out.section(sink);
        let crc = crc32fast::hash(&out.bytes);
        out.bytes.extend_from_slice(&crc.to_le_bytes());
        out.bytes
    }

    /// Decodes a map whose probes must be below `probes` (`u32::MAX`: any);
    /// any inconsistency is an error, never a panic.
    pub fn decode(bytes: &[u8], probes: u32) -> Result<DepthMap, CodingError> {
        let corrupt = |m: String| Err(CodingError::Corrupt(m));
        let (_, mut input) = framed(bytes, MAGIC, VERSION..=VERSION, "depth map")?;
        let body_len = input.bytes.len();
        let (size, count) = (input.varint()?, input.varint()?);
        if size == 0 || size > u64::from(MAX_SIZE) || count > u64::from(probes) {
            return corrupt(format!("a {size}-texel face or {count} probes (of {probes})"));
        }
        let mut float = || input.take(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        let (near, far) = (float()?, float()?);
        if !(near.is_finite() && far.is_finite() && near > 0.0 && far > near) {
            return corrupt(format!("depth range {near}..{far}"));
        }
        let texels = 6 * (size * size) as usize;
        let mut map = DepthMap { size: size as u32, near, far, depth: Vec::with_capacity(texels), best: Vec::with_capacity(texels) };
        let mut source = Source::new(&mut input, 3)?;
        for i in 0..texels {
            let code = i64::from(map.predicted(&map.depth, i)) + unzigzag(source.value(0)?);
            let Ok(code) = u8::try_from(code) else { return corrupt(format!("depth code {code}")) };
            map.depth.push(code);
        }
        while map.best.len() < texels {
            let (length, probe) = (source.value(1)? as usize, source.value(2)?);
            if length == 0 || length > texels - map.best.len() || u64::from(probe) > count {
                return corrupt("a run out of range".into());
            }
            map.best.extend(std::iter::repeat_n(if probe == 0 { NONE } else { probe - 1 }, length));
        }
        if input.at != body_len {
            return corrupt("bytes after the texels".into());
        }
        Ok(map)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map() -> DepthMap {
        let size = 8;
        let mut m = DepthMap { size, near: 0.1, far: 100.0, depth: Vec::new(), best: Vec::new() };
        for face in 0..6u32 {
            for i in 0..size * size {
                let hit = face != 2; // the +Y face is sky
                m.depth.push(m.code(hit.then_some(1.0 + face as f32 + (i / size) as f32 * 0.1)));
                m.best.push(if hit { face % 3 } else { NONE });
            }
        }
        m
    }

    #[test]
    fn maps_round_trip_compactly_and_look_up_by_direction() {
        let m = map();
        let bytes = m.encode();
        assert!(bytes.len() < 400, "{} bytes for 384 texels", bytes.len());
        assert_eq!(DepthMap::decode(&bytes, 3).unwrap(), m);
        // Straight ahead (−Z, face 5): distance about 1 + 5 + row 4 · 0.1, probe 2.
        let (d, probe) = m.look([0.0, 0.0, -1.0]).unwrap();
        assert!((d - 6.4).abs() / 6.4 < 0.015, "{d}");
        assert_eq!(probe, 2);
        assert_eq!(m.look([0.0, 1.0, 0.0]), None, "the sky");
        // Codes: within 1.4 % (half a step of (far/near)^(1/254)) over the range.
        for d in [0.1f32, 0.5, 3.0, 42.0, 100.0] {
            let back = m.distance(m.code(Some(d))).unwrap();
            assert!((back - d).abs() / d < 0.014, "{d} → {back}");
        }
    }

    #[test]
    fn damaged_and_hostile_maps_are_errors() {
        let bytes = map().encode();
        assert!(DepthMap::decode(&bytes, 2).is_err(), "a probe beyond the graph");
        for cut in 0..bytes.len() {
            assert!(DepthMap::decode(&bytes[..cut], 3).is_err());
        }
        for i in 0..bytes.len() {
            let mut bad = bytes.clone();
            bad[i] ^= 0x24;
            assert!(DepthMap::decode(&bad, 3).is_err(), "flip at {i}");
        }
        // A huge face size with a valid checksum.
        let mut hostile = b"EMDM\x01\xff\xff\x03\x01".to_vec();
        hostile.extend_from_slice(&0.1f32.to_le_bytes());
        hostile.extend_from_slice(&10f32.to_le_bytes());
        let crc = crc32fast::hash(&hostile);
        hostile.extend_from_slice(&crc.to_le_bytes());
        assert!(DepthMap::decode(&hostile, 3).is_err());
    }
}

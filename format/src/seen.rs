//! Point-to-go's table: for each triangle of a proxy level, in the coded
//! mesh's decoded order, the probe that sees it best (or none), so a tap on
//! the proxy needs no ray casting beyond the proxy itself.
//!
//! Edgebreaker visits triangles neighbour after neighbour, so long runs share
//! a probe: the table is run-length coded. Layout: magic `EMSN`, version byte
//! (1), the triangle count (LEB128), runs as LEB128 pairs (length, probe + 1,
//! 0 meaning no probe sees the triangle), then the CRC-32 (u32 LE) of all
//! that precedes.

use crate::edgebreaker::{CodingError, MAX_TRIANGLES};
use crate::meshcode::{framed, Writer};

const MAGIC: &[u8; 4] = b"EMSN";
const VERSION: u8 = 1;
/// A triangle no probe sees.
pub const NONE: u32 = u32::MAX;

pub fn encode(best: &[u32]) -> Vec<u8> {
    let mut out = Writer::default();
    out.bytes.extend_from_slice(MAGIC);
    out.bytes.push(VERSION);
    out.varint(best.len() as u64);
    for run in best.chunk_by(|a, b| a == b) {
        out.varint(run.len() as u64);
        out.varint(if run[0] == NONE { 0 } else { u64::from(run[0]) + 1 });
    }
    let crc = crc32fast::hash(&out.bytes);
    out.bytes.extend_from_slice(&crc.to_le_bytes());
    out.bytes
}

/// Decodes a table for a level of `triangles` triangles whose probes are
/// below `probes`; any inconsistency is an error, never a panic.
pub fn decode(bytes: &[u8], triangles: usize, probes: u32) -> Result<Vec<u32>, CodingError> {
    let best = decode_runs(bytes, Some(triangles))?;
    match best.iter().find(|&&p| p != NONE && p >= probes) {
        Some(p) => Err(CodingError::Corrupt(format!("the table names probe {p}, but there are {probes}"))),
        None => Ok(best),
    }
}

/// Decodes a table whatever its length and probes (for checks of a bundle's
/// files), or, given `triangles`, only a table of that length.
pub fn decode_runs(bytes: &[u8], triangles: Option<usize>) -> Result<Vec<u32>, CodingError> {
    let corrupt = |m: String| Err(CodingError::Corrupt(m));
    let (_, mut input) = framed(bytes, MAGIC, VERSION..=VERSION, "point-to-go table")?;
    let body = input.bytes;
    let count = input.varint()?;
    if count > u64::from(MAX_TRIANGLES) || triangles.is_some_and(|t| t as u64 != count) {
        return corrupt(format!("table for {count} triangles, but the mesh has {}", triangles.map_or("fewer".into(), |t| t.to_string())));
    }
    let count = count as usize;
    let mut best = Vec::with_capacity(count);
    while input.at < body.len() {
        let (length, probe) = (input.varint()?, input.varint()?);
        if length == 0 || length > (count - best.len()) as u64 {
            return corrupt("a run overflows the table".into());
        }
        let probe = match u32::try_from(probe) {
            Ok(0) => NONE,
            Ok(p) if p != NONE => p - 1,
            _ => return corrupt(format!("probe {probe} out of range")),
        };
        best.extend(std::iter::repeat_n(probe, length as usize));
    }
    if best.len() != count {
        return corrupt(format!("runs cover {} of {count} triangles", best.len()));
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_round_trip_and_runs_make_them_small() {
        let best: Vec<u32> = (0..10_000u32).map(|t| if t % 1000 < 30 { NONE } else { t / 700 }).collect();
        let bytes = encode(&best);
        assert!(bytes.len() < 150, "{} bytes for 10,000 triangles in 15 probes", bytes.len());
        assert_eq!(decode(&bytes, best.len(), 15).unwrap(), best);
        assert_eq!(decode(&encode(&[]), 0, 0).unwrap(), Vec::<u32>::new());
    }

    #[test]
    fn damaged_or_mismatched_tables_are_errors() {
        let best = vec![0, 0, 1, 2, 2, NONE];
        let bytes = encode(&best);
        assert!(decode(&bytes, 7, 3).is_err(), "wrong triangle count");
        assert!(decode(&bytes, 6, 2).is_err(), "probe beyond the graph");
        for cut in 0..bytes.len() {
            assert!(decode(&bytes[..cut], 6, 3).is_err());
        }
        for i in 0..bytes.len() {
            let mut bad = bytes.clone();
            bad[i] ^= 0x41;
            assert!(decode(&bad, 6, 3).is_err(), "flip at byte {i}");
        }
        // Well-formed but hostile: runs longer than the table, with a valid CRC.
        let mut hostile = b"EMSN\x01\x06\xff\xff\xff\xff\x0f\x01".to_vec();
        let crc = crc32fast::hash(&hostile);
        hostile.extend_from_slice(&crc.to_le_bytes());
        assert!(decode(&hostile, 6, 3).is_err());
    }
}

//! The 3D proxy's mesh decoder (Edgebreaker connectivity, quantized
//! positions, colours), as the viewer runs it on downloaded levels: the
//! input as it comes, and again with its last four bytes replaced by the
//! right CRC-32, so that mutations reach the sections behind the checksum
//! (a mutated file almost never passes it).
#![no_main]
use libfuzzer_sys::fuzz_target;

fn check(bytes: &[u8]) {
    if let Ok(mesh) = exploremaps_format::meshcode::decode(bytes) {
        // What the decoder returns must index its own vertices.
        let n = mesh.positions.len();
        assert!(mesh.triangles.iter().flatten().all(|&v| (v as usize) < n), "a decoded triangle indexes past the vertices");
        assert_eq!(mesh.groups.len(), mesh.triangles.len(), "a group per triangle");
    }
}

fuzz_target!(|data: &[u8]| {
    check(data);
    if let Some(body) = data.len().checked_sub(4).map(|n| &data[..n]) {
        let mut fixed = body.to_vec();
        fixed.extend_from_slice(&crc32fast::hash(body).to_le_bytes());
        check(&fixed);
    }
});

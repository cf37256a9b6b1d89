//! The 3D proxy's mesh decoder (Edgebreaker connectivity, quantized
//! positions, colours), as the viewer runs it on downloaded levels.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(mesh) = exploremaps_format::meshcode::decode(data) {
        // What the decoder returns must index its own vertices.
        let n = mesh.positions.len();
        assert!(mesh.triangles.iter().flatten().all(|&v| (v as usize) < n), "a decoded triangle indexes past the vertices");
    }
});

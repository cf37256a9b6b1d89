//! The proxy's vertex-split packets as the viewer applies them: a file of
//! packets taken apart, then each applied in turn to a small base mesh (a
//! plane simplified to 8 triangles; the seeds are its real stream).
#![no_main]
use exploremaps_format::splits::{packets, Refiner};
use libfuzzer_sys::fuzz_target;

const BASE: &[u8] = include_bytes!("splits_base.emmc");

fuzz_target!(|data: &[u8]| {
    let base = exploremaps_format::meshcode::decode(BASE).expect("the committed base decodes");
    let mut refiner = Refiner::new(base).expect("a valid base");
    let Ok(list) = packets(data) else { return };
    for packet in list {
        let ok = refiner.apply_packet(packet).is_ok();
        // Whatever came in, the mesh stays whole: every corner a vertex, an
        // attribute for every vertex and triangle.
        let m = &refiner.mesh;
        assert!(m.triangles.iter().flatten().all(|&v| (v as usize) < m.positions.len()), "a corner past the vertices");
        assert!(m.colours.len() == m.positions.len() && m.groups.len() == m.triangles.len(), "attributes out of step");
        if !ok {
            return;
        }
    }
});

//! OBJ with its MTL: the input is the OBJ, then a NUL byte, then the MTL
//! (the seeds' OBJ says `mtllib s.mtl`).
#![no_main]
use libfuzzer_sys::fuzz_target;
#[path = "scene.rs"]
mod scene;

fuzz_target!(|data: &[u8]| {
    let (obj, mtl) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    scene::load_files(&[("s.obj", obj), ("s.mtl", mtl)]);
});

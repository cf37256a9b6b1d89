//! PLY, ASCII and binary.
#![no_main]
use libfuzzer_sys::fuzz_target;
#[path = "scene.rs"]
mod scene;

fuzz_target!(|data: &[u8]| {
    scene::load_files(&[("s.ply", data)]);
});

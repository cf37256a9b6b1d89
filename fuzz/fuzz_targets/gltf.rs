//! glTF 2.0, as JSON (`.gltf`) or binary (`.glb`, chosen by its magic bytes).
#![no_main]
use libfuzzer_sys::fuzz_target;
#[path = "scene.rs"]
mod scene;

fuzz_target!(|data: &[u8]| {
    let name = if data.starts_with(b"glTF") { "s.glb" } else { "s.gltf" };
    scene::load_files(&[(name, data)]);
});

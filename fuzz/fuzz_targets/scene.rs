//! Shared by the scene targets: writes the input as scene files in one
//! temporary folder (made once per process, in memory under /dev/shm where
//! there is one, so no input goes to disk) and loads them as `plan` would.

use exploremaps_builder::scene_io::{load, LoadOptions};
use std::path::PathBuf;
use std::sync::OnceLock;

fn folder() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let mut b = tempfile::Builder::new();
        b.prefix("exploremaps-fuzz");
        let shm = std::path::Path::new("/dev/shm");
        if shm.is_dir() { b.tempdir_in(shm) } else { b.tempdir() }.unwrap().keep()
    })
}

/// Writes each `(name, bytes)` into the folder, then loads the first. A load
/// may fail with an error; it may not panic, hang or exhaust memory.
pub fn load_files(files: &[(&str, &[u8])]) {
    // The loaders catch the panics of tobj's MTL parser and gltf's validator
    // (known bugs, each turned into an error): back to the default panic hook,
    // so only a panic that escapes the loader aborts (libfuzzer-sys aborts on
    // any panic that reaches it).
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| drop(std::panic::take_hook()));
    let dir = folder();
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    let _ = load(&dir.join(files[0].0), &LoadOptions::default());
}

//! `serve`: the request head a client sends, then the answer for a small
//! bundle. Whatever the bytes, a file is served only from inside the bundle.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;
use std::sync::OnceLock;
// serve.rs belongs to the command-line binary, which has no library target.
#[allow(dead_code)]
#[path = "../../src/serve.rs"]
mod serve;

/// A bundle folder with two files, and a secret file beside it.
fn bundle() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::Builder::new().prefix("exploremaps-fuzz").tempdir().unwrap().keep();
        std::fs::create_dir_all(dir.join("b/probes/0")).unwrap();
        std::fs::write(dir.join("b/graph.json"), b"{\"probes\": []}").unwrap();
        std::fs::write(dir.join("b/probes/0/512_px.jpg"), b"face").unwrap();
        std::fs::write(dir.join("secret.txt"), b"SECRET").unwrap();
        dir.join("b").canonicalize().unwrap()
    })
}

fuzz_target!(|data: &[u8]| {
    let Ok(request) = serve::read_head(&mut std::io::Cursor::new(data), || Ok(())) else { return };
    let response = serve::respond(bundle(), None, &request);
    if matches!(response.status, 200 | 206) {
        assert!(!response.body.windows(6).any(|w| w == b"SECRET"), "served a file outside the bundle for {:?}", request.url);
    }
});

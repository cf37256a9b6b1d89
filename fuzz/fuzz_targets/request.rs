//! `serve`: the answer for a small bundle to any method, URL, range and
//! encoding (hyper parses the bytes on the wire; this is what it hands
//! over). Whatever they are, a file is served only from inside the bundle.
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
    // The first line: method and URL; the second: the Range header; the first byte's low bit: gzip.
    let text = String::from_utf8_lossy(data);
    let mut lines = text.split('\n');
    let mut first = lines.next().unwrap_or("").split_whitespace();
    let request = serve::Request {
        method: first.next().unwrap_or("GET").to_string(),
        url: first.next().unwrap_or("/").to_string(),
        range: lines.next().map(str::to_string),
        gzip: data.first().is_some_and(|b| b & 1 == 1),
    };
    let response = serve::respond(bundle(), None, &request);
    if matches!(response.status, 200 | 206) {
        assert!(!response.body.windows(6).any(|w| w == b"SECRET"), "served a file outside the bundle for {:?}", request.url);
    }
});

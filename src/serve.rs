//! `exploremaps serve`: a small static HTTP/1.1 server (on std::net) for one
//! bundle and the web viewer. It serves only files inside the bundle folder (after resolving
//! symbolic links), answers byte ranges (browsers seek videos with them),
//! and falls back to the built web viewer for a bundle written without it.
//!
//! Limits, so no client can hold the server: a request line of at most 8 KiB
//! (else 414), headers of at most 8 KiB a line, 100 lines and 64 KiB in all
//! (else 431), the whole request within 10 s (else 408), and at most 64
//! connections at once (the next get 503 at once).

use anyhow::{Context, Result};
use exploremaps_builder::bundle::WEB_VIEWER_FILES;
use std::path::{Component, Path, PathBuf};

/// Decodes %XX escapes; `None` for malformed ones or non-UTF-8 results.
fn percent_decode(s: &str) -> Option<String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The relative path a URL names, or `None` if it tries to leave the folder.
fn relative_path(url: &str) -> Option<PathBuf> {
    let path = url.split(['?', '#']).next().unwrap_or("");
    let mut path = percent_decode(path)?;
    if path.ends_with('/') {
        path.push_str("index.html");
    }
    if path.contains('\\') || path.contains('\0') {
        return None;
    }
    let rel = PathBuf::from(path.trim_start_matches('/'));
    rel.components().all(|c| matches!(c, Component::Normal(_))).then_some(rel)
}

fn content_type(path: &Path) -> &'static str {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("html") => "text/html; charset=utf-8",
        Some("js") => "text/javascript",
        Some("wasm") => "application/wasm",
        Some("json") => "application/json",
        Some("jpg" | "jpeg") => "image/jpeg",
        Some("png") => "image/png",
        Some("mp4") => "video/mp4",
        Some("css") => "text/css",
        _ => "application/octet-stream",
    }
}

/// Parses a single `bytes=` range against a length: (start, end inclusive).
fn byte_range(header: &str, len: u64) -> Option<(u64, u64)> {
    let spec = header.trim().strip_prefix("bytes=")?;
    if spec.contains(',') || len == 0 {
        return None;
    }
    let (a, b) = spec.split_once('-')?;
    let (start, end) = match (a.trim(), b.trim()) {
        ("", n) => (len.saturating_sub(n.parse().ok()?), len - 1),
        (s, "") => (s.parse().ok()?, len - 1),
        (s, e) => (s.parse().ok()?, e.parse::<u64>().ok()?.min(len - 1)),
    };
    (start <= end && start < len).then_some((start, end))
}

/// A response: status, content type, extra headers, body.
pub struct Response {
    pub status: u16,
    pub content_type: &'static str,
    pub headers: Vec<String>,
    pub body: Vec<u8>,
}

fn text(status: u16, body: &str) -> Response {
    Response { status, content_type: "text/plain; charset=utf-8", headers: Vec::new(), body: body.as_bytes().to_vec() }
}

/// Where a request's file is: inside the bundle, else (for the viewer's own
/// files) in the built web viewer.
fn locate(root: &Path, web: Option<&Path>, rel: &Path) -> Result<PathBuf, u16> {
    let candidate = root.join(rel);
    match candidate.canonicalize() {
        // Symbolic links may not lead out of the bundle.
        Ok(real) if real.starts_with(root) && real.is_file() => Ok(real),
        Ok(real) if !real.starts_with(root) => Err(403),
        _ => {
            let name = rel.to_str().unwrap_or("");
            match web {
                Some(web) if WEB_VIEWER_FILES.contains(&name) && web.join(name).is_file() => Ok(web.join(name)),
                _ => Err(404),
            }
        }
    }
}

/// Whether a type is worth compressing (JPEG, PNG and MP4 are compressed already).
fn compressible(content_type: &str) -> bool {
    ["text/", "application/wasm", "application/json"].iter().any(|t| content_type.starts_with(t))
}

/// The answer to a parsed request; `root` is the canonical bundle folder.
/// Text and wasm go gzipped to a client that accepts it (as static hosts send
/// them: the web viewer's module is a third of its size), unless a range
/// was asked for.
pub fn respond(root: &Path, web: Option<&Path>, request: &Request) -> Response {
    let (method, url, range) = (request.method.as_str(), request.url.as_str(), request.range.as_deref());
    if method != "GET" && method != "HEAD" {
        return text(405, "only GET and HEAD are served");
    }
    let Some(rel) = relative_path(url) else { return text(403, "that path leads outside the bundle") };
    let file = match locate(root, web, &rel) {
        Ok(f) => f,
        Err(403) => return text(403, "that path leads outside the bundle"),
        Err(_) => return text(404, &format!("{} is not in this bundle", rel.display())),
    };
    let bytes = match std::fs::read(&file) {
        Ok(b) => b,
        Err(e) => return text(500, &format!("cannot read {}: {e}", rel.display())),
    };
    let len = bytes.len() as u64;
    let mut headers = vec!["Accept-Ranges: bytes".to_string(), "Cache-Control: no-cache".to_string()];
    let (status, body) = match range.map(|r| byte_range(r, len)) {
        Some(Some((start, end))) => {
            headers.push(format!("Content-Range: bytes {start}-{end}/{len}"));
            (206, bytes[start as usize..=end as usize].to_vec())
        }
        Some(None) => {
            let mut r = text(416, "unsatisfiable range");
            r.headers.push(format!("Content-Range: bytes */{len}"));
            return r;
        }
        None if request.gzip && compressible(content_type(&file)) => {
            use std::io::Write;
            let mut encoder = flate2::write::GzEncoder::new(Vec::with_capacity(bytes.len() / 3), flate2::Compression::default());
            let compressed = encoder.write_all(&bytes).and_then(|()| encoder.finish());
            match compressed {
                Ok(body) => {
                    headers.extend(["Content-Encoding: gzip".to_string(), "Vary: Accept-Encoding".to_string()]);
                    (200, body)
                }
                Err(_) => (200, bytes),
            }
        }
        None => (200, bytes),
    };
    Response { status, content_type: content_type(&file), headers, body }
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        206 => "Partial Content",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        414 => "URI Too Long",
        416 => "Range Not Satisfiable",
        431 => "Request Header Fields Too Large",
        503 => "Service Unavailable",
        _ => "Internal Server Error",
    }
}

const MAX_LINE: usize = 8 * 1024;
const MAX_HEADER_LINES: usize = 100;
const MAX_HEADER_BYTES: usize = 64 * 1024;
const REQUEST_TIME: std::time::Duration = std::time::Duration::from_secs(10);
const MAX_CONNECTIONS: usize = 64;

/// A request's method, URL, `Range` header and whether it accepts gzip.
pub struct Request {
    pub method: String,
    pub url: String,
    pub range: Option<String>,
    pub gzip: bool,
}

/// Reads the request line and headers from a connection within the limits
/// (module header).
fn read_request(stream: &std::net::TcpStream) -> Result<Request, u16> {
    let started = std::time::Instant::now();
    let mut reader = std::io::BufReader::new(stream.try_clone().map_err(|_| 500u16)?);
    read_head(&mut reader, || {
        let left = REQUEST_TIME.checked_sub(started.elapsed()).filter(|d| !d.is_zero()).ok_or(408u16)?;
        stream.set_read_timeout(Some(left)).map_err(|_| 500u16)
    })
}

/// Parses a request's head from `reader` within the size limits; `before_line`
/// runs before each line is read (the connection sets its deadline there).
/// Apart from the socket, this is all the parsing a client's bytes reach.
pub fn read_head(reader: &mut impl std::io::BufRead, mut before_line: impl FnMut() -> Result<(), u16>) -> Result<Request, u16> {
    use std::io::{BufRead, Read};
    // One line, at most `MAX_LINE` bytes.
    let mut next_line = |too_long: u16| -> Result<String, u16> {
        before_line()?;
        let mut line = Vec::new();
        match reader.by_ref().take(MAX_LINE as u64 + 1).read_until(b'\n', &mut line) {
            Ok(_) if line.len() > MAX_LINE => Err(too_long),
            Ok(_) => String::from_utf8(line).map_err(|_| 400),
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => Err(408),
            Err(_) => Err(400),
        }
    };
    let line = next_line(414)?;
    let mut parts = line.split_whitespace();
    let (method, url) = (parts.next().unwrap_or("").to_string(), parts.next().unwrap_or("").to_string());
    if url.is_empty() {
        return Err(400);
    }
    let (mut range, mut bytes, mut gzip) = (None, 0, false);
    for count in 0.. {
        let header = next_line(431)?;
        if header.trim().is_empty() {
            break;
        }
        bytes += header.len();
        if count >= MAX_HEADER_LINES || bytes > MAX_HEADER_BYTES {
            return Err(431);
        }
        if let Some((name, value)) = header.split_once(':') {
            if name.trim().eq_ignore_ascii_case("range") {
                range = Some(value.trim().to_string());
            } else if name.trim().eq_ignore_ascii_case("accept-encoding") {
                gzip = value.split(',').any(|e| e.split(';').next().is_some_and(|c| c.trim().eq_ignore_ascii_case("gzip")));
            }
        }
    }
    Ok(Request { method, url, range, gzip })
}

/// Reads one request from a connection, answers it and closes the connection.
/// One request a connection (`Connection: close`): no keep-alive bookkeeping,
/// which is where a browser can end up waiting for an answer that never comes.
fn handle(stream: std::net::TcpStream, root: &Path, web: Option<&Path>) -> std::io::Result<()> {
    let (method, response) = match read_request(&stream) {
        Ok(r) => {
            let response = respond(root, web, &r);
            tracing::debug!("{} {} -> {}", r.method, r.url, response.status);
            (r.method, response)
        }
        Err(status) => (String::new(), text(status, reason(status))),
    };
    answer(stream, &method, &response)
}

fn answer(stream: std::net::TcpStream, method: &str, response: &Response) -> std::io::Result<()> {
    use std::io::Write;
    stream.set_write_timeout(Some(REQUEST_TIME))?;
    let mut head = format!(
        "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nConnection: close\r\n",
        response.status,
        reason(response.status),
        response.content_type,
        response.body.len()
    );
    for h in &response.headers {
        head.push_str(h);
        head.push_str("\r\n");
    }
    head.push_str("\r\n");
    let mut out = std::io::BufWriter::new(stream);
    out.write_all(head.as_bytes())?;
    if method != "HEAD" {
        out.write_all(&response.body)?;
    }
    out.flush()
}

/// Serves `bundle` on `address` until interrupted.
pub fn serve(bundle: &Path, address: &str, web: Option<&Path>) -> Result<()> {
    let root = bundle.canonicalize().with_context(|| format!("{}: no such bundle folder", bundle.display()))?;
    // A tour `export` wrote is served as it is, without our viewer.
    let tour = root.join(exploremaps_builder::export::MARKER).is_file();
    let web = if tour { None } else { web };
    // A folder without graph.json is not a bundle; a graph the viewer cannot
    // read is still served, so the viewer shows the reason in the page.
    if !tour && !root.join(exploremaps_format::GRAPH_FILE).is_file() {
        anyhow::bail!(
            "{}: no graph.json here; is this a bundle folder written by `exploremaps build` (or a tour written by `exploremaps export`)?",
            root.display()
        );
    }
    let graph_file = root.join(exploremaps_format::GRAPH_FILE);
    let graph = std::fs::read_to_string(&graph_file).map_err(|e| e.to_string());
    if let (false, Err(e)) =
        (tour, graph.and_then(|text| exploremaps_format::Graph::from_json(&text).map_err(|e| exploremaps_format::error_chain(&e))))
    {
        tracing::warn!("{}: {e}", graph_file.display());
    }
    let listener = std::net::TcpListener::bind(address)
        .map_err(|e| anyhow::anyhow!("cannot listen on {address}: {e}; choose another --address (e.g. 127.0.0.1:8081)"))?;
    let shown = listener.local_addr().map_or(address.to_string(), |a| a.to_string());
    if !root.join("index.html").is_file() && web.is_none() {
        tracing::warn!("this bundle has no web viewer and none is built; run web/build.sh, then `exploremaps serve` again");
    }
    println!("serving {} at http://{shown}/ (Ctrl-C stops)", root.display());
    use std::io::Write;
    let _ = std::io::stdout().flush();
    let web = web.map(Path::to_path_buf);
    let open = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    for stream in listener.incoming() {
        let Ok(stream) = stream else { continue };
        use std::sync::atomic::Ordering;
        if open.fetch_add(1, Ordering::SeqCst) >= MAX_CONNECTIONS {
            open.fetch_sub(1, Ordering::SeqCst);
            let _ = answer(stream, "GET", &text(503, "too many connections; try again"));
            continue;
        }
        let (root, web, open) = (root.clone(), web.clone(), open.clone());
        std::thread::spawn(move || {
            if let Err(e) = handle(stream, &root, web.as_deref()) {
                tracing::debug!("connection: {e}");
            }
            open.fetch_sub(1, Ordering::SeqCst);
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_that_leave_the_folder_are_refused() {
        assert_eq!(relative_path("/probes/0/pano.jpg?x=1").unwrap(), PathBuf::from("probes/0/pano.jpg"));
        assert_eq!(relative_path("/").unwrap(), PathBuf::from("index.html"));
        assert_eq!(relative_path("/a%20b.jpg").unwrap(), PathBuf::from("a b.jpg"));
        for bad in ["/../x", "/a/../../x", "/%2e%2e/x", "/a/%2E%2E/%2E%2E/x", "/..%2fx", "/a\\..\\x", "/%zz", "/./x"] {
            assert!(relative_path(bad).is_none(), "{bad}");
        }
    }

    #[test]
    fn text_and_wasm_go_gzipped_to_clients_that_take_it() {
        let dir = tempfile::tempdir().unwrap();
        let script = "let x = 1;\n".repeat(1000);
        std::fs::write(dir.path().join("a.js"), &script).unwrap();
        std::fs::write(dir.path().join("b.jpg"), [0xffu8, 0xd8, 1, 2, 3]).unwrap();
        let root = dir.path().canonicalize().unwrap();
        let get = |url: &str, range: Option<&str>, gzip: bool| {
            respond(&root, None, &Request { method: "GET".into(), url: url.into(), range: range.map(str::to_string), gzip })
        };
        let zipped = get("/a.js", None, true);
        assert!(zipped.headers.iter().any(|h| h == "Content-Encoding: gzip") && zipped.body.len() < script.len() / 10);
        let mut back = String::new();
        std::io::Read::read_to_string(&mut flate2::read::GzDecoder::new(zipped.body.as_slice()), &mut back).unwrap();
        assert_eq!(back, script);
        for (url, range, gzip) in [("/a.js", None, false), ("/a.js", Some("bytes=0-9"), true), ("/b.jpg", None, true)] {
            let plain = get(url, range, gzip);
            assert!(!plain.headers.iter().any(|h| h.starts_with("Content-Encoding")), "{url} {range:?} {gzip}");
        }
        assert_eq!(get("/a.js", Some("bytes=0-9"), true).body, b"let x = 1;");
    }

    #[test]
    fn byte_ranges_follow_the_http_forms() {
        assert_eq!(byte_range("bytes=0-9", 100), Some((0, 9)));
        assert_eq!(byte_range("bytes=90-", 100), Some((90, 99)));
        assert_eq!(byte_range("bytes=-10", 100), Some((90, 99)));
        assert_eq!(byte_range("bytes=50-500", 100), Some((50, 99)));
        assert_eq!(byte_range("bytes=100-", 100), None);
        assert_eq!(byte_range("bytes=5-1", 100), None);
        assert_eq!(byte_range("bytes=0-1,5-6", 100), None);
        assert_eq!(byte_range("items=0-1", 100), None);
    }

    /// Sends `request` (from another thread: the server may stop reading) and
    /// returns the status of the answer.
    fn status_of(address: std::net::SocketAddr, request: Vec<u8>, stall: bool) -> u16 {
        use std::io::{Read, Write};
        let mut client = std::net::TcpStream::connect(address).unwrap();
        let mut writer = client.try_clone().unwrap();
        let sender = std::thread::spawn(move || {
            let _ = writer.write_all(&request);
            if stall {
                std::thread::sleep(REQUEST_TIME + std::time::Duration::from_secs(2));
            }
        });
        let mut answer = Vec::new();
        let _ = client.read_to_end(&mut answer);
        drop(sender);
        let text = String::from_utf8_lossy(&answer);
        text.split_whitespace().nth(1).and_then(|s| s.parse().ok()).unwrap_or(0)
    }

    #[test]
    fn oversized_slow_and_excess_requests_are_refused() {
        let bundle = tempfile::tempdir().unwrap();
        std::fs::write(bundle.path().join("graph.json"), "{}").unwrap();
        std::fs::write(bundle.path().join("a.txt"), "hello").unwrap();
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let address = listener.local_addr().unwrap();
        drop(listener);
        let root = bundle.path().to_path_buf();
        std::thread::spawn(move || serve(&root, &address.to_string(), None));
        // Wait until it listens.
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
        while std::net::TcpStream::connect(address).is_err() {
            assert!(std::time::Instant::now() < deadline, "serve did not start");
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        assert_eq!(status_of(address, b"GET /a.txt HTTP/1.1\r\nHost: x\r\n\r\n".to_vec(), false), 200);
        let huge_header = [b"GET /a.txt HTTP/1.1\r\nX-Big: ".to_vec(), vec![b'a'; 10 << 20], b"\r\n\r\n".to_vec()].concat();
        assert_eq!(status_of(address, huge_header, false), 431, "a 10 MB header line");
        let many: String = (0..200).map(|i| format!("X-{i}: 1\r\n")).collect();
        assert_eq!(status_of(address, format!("GET /a.txt HTTP/1.1\r\n{many}\r\n").into_bytes(), false), 431, "200 header lines");
        let long_url = format!("GET /{} HTTP/1.1\r\n\r\n", "a".repeat(20_000));
        assert_eq!(status_of(address, long_url.into_bytes(), false), 414);
        // Clients that send half a request and stall: each gets 408 after the
        // request time; while they hold every slot, one more gets 503 at once.
        // (A moment first, for the threads of the requests above to end.)
        std::thread::sleep(std::time::Duration::from_millis(300));
        let stalled: Vec<_> =
            (0..MAX_CONNECTIONS).map(|_| std::thread::spawn(move || status_of(address, b"GET /a.txt HTTP/1.1\r\n".to_vec(), true))).collect();
        std::thread::sleep(std::time::Duration::from_secs(2));
        let started = std::time::Instant::now();
        assert_eq!(status_of(address, b"GET /a.txt HTTP/1.1\r\n\r\n".to_vec(), false), 503, "every slot is held");
        assert!(started.elapsed() < std::time::Duration::from_secs(2), "refused at once");
        for s in stalled {
            assert_eq!(s.join().unwrap(), 408);
        }
        assert_eq!(status_of(address, b"GET /a.txt HTTP/1.1\r\n\r\n".to_vec(), false), 200, "slots free again");
    }
}

//! `exploremaps serve`: a static HTTP/1.1 server for one bundle and the web
//! viewer. Connections, request parsing, limits and timeouts are hyper's, on
//! tokio (an idle or stalled connection costs a task, not a thread); what is
//! answered is `respond`'s: only files inside the bundle folder (after
//! resolving symbolic links), byte ranges (browsers seek videos with them),
//! text and wasm gzipped, and the built web viewer for a bundle written
//! without it.
//!
//! Limits, so no client can hold the server: a URL of at most 8 KiB (else
//! 414), a request head of at most 64 KiB and 100 header lines (else 431),
//! the head within 10 s of the connection or of the previous answer (else
//! the connection is closed), and at most 768 connections at once (the
//! next get 503 at once; file descriptors are the bound, 1024 by default).

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
    if url.len() > MAX_URL {
        return text(414, "the URL is too long");
    }
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

const MAX_URL: usize = 8 * 1024;
const MAX_HEAD: usize = 64 * 1024;
const MAX_HEADER_LINES: usize = 100;
const REQUEST_TIME: std::time::Duration = std::time::Duration::from_secs(10);
const MAX_CONNECTIONS: usize = 768;

/// A request's method, URL, `Range` header and whether it accepts gzip.
pub struct Request {
    pub method: String,
    pub url: String,
    pub range: Option<String>,
    pub gzip: bool,
}

impl Request {
    /// What `respond` reads of a request hyper has parsed.
    fn of<B>(request: &hyper::Request<B>) -> Request {
        let header = |name| request.headers().get(name).and_then(|v| v.to_str().ok());
        let gzip = header(hyper::header::ACCEPT_ENCODING)
            .is_some_and(|v| v.split(',').any(|e| e.split(';').next().is_some_and(|c| c.trim().eq_ignore_ascii_case("gzip"))));
        Request {
            method: request.method().as_str().to_string(),
            url: request.uri().path_and_query().map_or("/", |p| p.as_str()).to_string(),
            range: header(hyper::header::RANGE).map(str::to_string),
            gzip,
        }
    }
}

/// `respond`'s answer as hyper sends it (no body to a HEAD request).
fn to_hyper(response: Response) -> hyper::Response<http_body_util::Full<hyper::body::Bytes>> {
    let mut out = hyper::Response::new(http_body_util::Full::new(hyper::body::Bytes::from(response.body)));
    *out.status_mut() = hyper::StatusCode::from_u16(response.status).unwrap_or(hyper::StatusCode::INTERNAL_SERVER_ERROR);
    let headers = out.headers_mut();
    headers.insert(hyper::header::CONTENT_TYPE, hyper::header::HeaderValue::from_static(response.content_type));
    for h in &response.headers {
        if let Some((name, value)) = h.split_once(": ") {
            if let (Ok(name), Ok(value)) = (hyper::header::HeaderName::try_from(name), hyper::header::HeaderValue::try_from(value)) {
                headers.append(name, value);
            }
        }
    }
    out
}

/// Answers the requests of one connection, within the limits (module header).
async fn connection(stream: tokio::net::TcpStream, root: std::sync::Arc<PathBuf>, web: std::sync::Arc<Option<PathBuf>>) {
    let service = hyper::service::service_fn(move |request: hyper::Request<hyper::body::Incoming>| {
        let request = Request::of(&request);
        let response = respond(&root, web.as_deref(), &request);
        tracing::debug!("{} {} -> {}", request.method, request.url, response.status);
        std::future::ready(Ok::<_, std::convert::Infallible>(to_hyper(response)))
    });
    let served = hyper::server::conn::http1::Builder::new()
        .timer(hyper_util::rt::TokioTimer::new())
        .header_read_timeout(REQUEST_TIME)
        .max_header_size(MAX_HEAD)
        .max_headers(MAX_HEADER_LINES)
        .serve_connection(hyper_util::rt::TokioIo::new(stream), service)
        .await;
    if let Err(e) = served {
        tracing::debug!("connection: {e}");
    }
}

/// Accepts connections for ever, each answered by a task of its own while
/// fewer than [`MAX_CONNECTIONS`] are open, else with 503 at once.
async fn accept(listener: std::net::TcpListener, root: PathBuf, web: Option<PathBuf>) -> Result<()> {
    use tokio::io::AsyncWriteExt;
    listener.set_nonblocking(true)?;
    let listener = tokio::net::TcpListener::from_std(listener)?;
    let (root, web) = (std::sync::Arc::new(root), std::sync::Arc::new(web));
    let open = std::sync::Arc::new(tokio::sync::Semaphore::new(MAX_CONNECTIONS));
    loop {
        let mut stream = match listener.accept().await {
            Ok((stream, _)) => stream,
            // Out of file descriptors, or a connection reset before it was taken: a moment, then on.
            Err(e) => {
                tracing::debug!("accept: {e}");
                tokio::time::sleep(std::time::Duration::from_millis(10)).await;
                continue;
            }
        };
        let Ok(permit) = open.clone().try_acquire_owned() else {
            tokio::spawn(async move {
                let busy = b"HTTP/1.1 503 Service Unavailable\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";
                let _ = tokio::time::timeout(REQUEST_TIME, stream.write_all(busy)).await;
            });
            continue;
        };
        let (root, web) = (root.clone(), web.clone());
        tokio::spawn(async move {
            connection(stream, root, web).await;
            drop(permit);
        });
    }
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
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build().context("cannot start the server's runtime")?;
    runtime.block_on(accept(listener, root, web.map(Path::to_path_buf)))
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
    /// returns the status of the answer (0 for none) and how long it took.
    fn status_of(address: std::net::SocketAddr, request: Vec<u8>) -> (u16, std::time::Duration) {
        use std::io::{Read, Write};
        let started = std::time::Instant::now();
        let mut client = std::net::TcpStream::connect(address).unwrap();
        client.set_read_timeout(Some(std::time::Duration::from_secs(30))).unwrap();
        let mut writer = client.try_clone().unwrap();
        let sender = std::thread::spawn(move || {
            let _ = writer.write_all(&request);
        });
        // One answer: the head, then as many bytes as it says.
        let mut answer = Vec::new();
        let mut buf = [0u8; 65536];
        while let Ok(n @ 1..) = client.read(&mut buf) {
            answer.extend_from_slice(&buf[..n]);
            let text = String::from_utf8_lossy(&answer);
            if let Some(head_end) = text.find("\r\n\r\n") {
                let length = text[..head_end]
                    .lines()
                    .find_map(|l| l.to_ascii_lowercase().strip_prefix("content-length:").map(|v| v.trim().parse::<usize>().unwrap_or(0)))
                    .unwrap_or(0);
                if answer.len() >= head_end + 4 + length {
                    break;
                }
            }
        }
        drop(sender);
        let text = String::from_utf8_lossy(&answer);
        (text.split_whitespace().nth(1).and_then(|s| s.parse().ok()).unwrap_or(0), started.elapsed())
    }

    #[test]
    fn oversized_requests_are_refused_and_stalled_clients_delay_no_one() {
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
        let get = b"GET /a.txt HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n".to_vec();
        assert_eq!(status_of(address, get.clone()).0, 200);
        let huge_header = [b"GET /a.txt HTTP/1.1\r\nX-Big: ".to_vec(), vec![b'a'; 10 << 20], b"\r\n\r\n".to_vec()].concat();
        assert_eq!(status_of(address, huge_header).0, 431, "a 10 MB header line");
        let many: String = (0..200).map(|i| format!("X-{i}: 1\r\n")).collect();
        assert_eq!(status_of(address, format!("GET /a.txt HTTP/1.1\r\n{many}\r\n").into_bytes()).0, 431, "200 header lines");
        let long_url = format!("GET /{} HTTP/1.1\r\nConnection: close\r\n\r\n", "a".repeat(20_000));
        assert_eq!(status_of(address, long_url.into_bytes()).0, 414);
        // 200 clients send half a request line and stall; ordinary ones are
        // served meanwhile, each within a second; the stalled are let go
        // after the request time.
        let stalled_at = std::time::Instant::now();
        let stalled: Vec<std::net::TcpStream> = (0..200)
            .map(|_| {
                let mut s = std::net::TcpStream::connect(address).unwrap();
                std::io::Write::write_all(&mut s, b"GET /a.txt HT").unwrap();
                s
            })
            .collect();
        let waits: Vec<std::time::Duration> = (0..20)
            .map(|_| {
                let (status, took) = status_of(address, get.clone());
                assert_eq!(status, 200);
                took
            })
            .collect();
        let slowest = waits.iter().max().unwrap();
        eprintln!("the slowest of 20 ordinary requests beside 200 stalled clients: {slowest:?}");
        assert!(*slowest < std::time::Duration::from_secs(1), "an ordinary request waited {slowest:?} beside 200 stalled ones");
        for mut s in stalled {
            s.set_read_timeout(Some(REQUEST_TIME + std::time::Duration::from_secs(5))).unwrap();
            let mut rest = Vec::new();
            let closed = std::io::Read::read_to_end(&mut s, &mut rest).is_ok();
            assert!(closed, "a stalled connection was let go");
        }
        let held = stalled_at.elapsed();
        assert!(held >= REQUEST_TIME && held < REQUEST_TIME + std::time::Duration::from_secs(5), "stalled clients held {held:?}");
    }
}

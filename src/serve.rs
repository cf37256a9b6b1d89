//! `exploremaps serve`: a small static HTTP/1.1 server (on std::net) for one
//! bundle and the web viewer. It serves only files inside the bundle folder (after resolving
//! symbolic links), answers byte ranges (browsers seek videos with them),
//! and falls back to the built web viewer for a bundle written without it.

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
struct Response {
    status: u16,
    content_type: &'static str,
    headers: Vec<String>,
    body: Vec<u8>,
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

fn respond(root: &Path, web: Option<&Path>, method: &str, url: &str, range: Option<&str>) -> Response {
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
        416 => "Range Not Satisfiable",
        _ => "Internal Server Error",
    }
}

/// Reads one request from a connection, answers it and closes the connection.
/// One request a connection (`Connection: close`): no keep-alive bookkeeping,
/// which is where a browser can end up waiting for an answer that never comes.
fn handle(stream: std::net::TcpStream, root: &Path, web: Option<&Path>) -> std::io::Result<()> {
    use std::io::{BufRead, BufReader, Write};
    stream.set_read_timeout(Some(std::time::Duration::from_secs(10)))?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut line = String::new();
    reader.read_line(&mut line)?;
    let mut parts = line.split_whitespace();
    let (method, url) = (parts.next().unwrap_or("").to_string(), parts.next().unwrap_or("").to_string());
    let mut range = None;
    // Headers, up to a sane number and the blank line.
    for _ in 0..100 {
        let mut header = String::new();
        if reader.read_line(&mut header)? == 0 || header.trim().is_empty() {
            break;
        }
        if let Some((name, value)) = header.split_once(':') {
            if name.trim().eq_ignore_ascii_case("range") {
                range = Some(value.trim().to_string());
            }
        }
    }
    let response = if url.is_empty() { text(400, "bad request") } else { respond(root, web, &method, &url, range.as_deref()) };
    tracing::debug!("{method} {url} -> {}", response.status);
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
    // A folder without graph.json is not a bundle; a graph the viewer cannot
    // read is still served, so the viewer shows the reason in the page.
    if !root.join(exploremaps_format::GRAPH_FILE).is_file() {
        anyhow::bail!("{}: no graph.json here; is this a bundle folder written by `exploremaps build`?", root.display());
    }
    if let Err(e) = exploremaps_viewer::native::read_graph(&root) {
        tracing::warn!("{e}");
    }
    let listener = std::net::TcpListener::bind(address).map_err(|e| anyhow::anyhow!("cannot listen on {address}: {e}; choose another --address (e.g. 127.0.0.1:8081)"))?;
    let shown = listener.local_addr().map_or(address.to_string(), |a| a.to_string());
    if !root.join("index.html").is_file() && web.is_none() {
        tracing::warn!("this bundle has no web viewer and none is built; run web/build.sh, then `exploremaps serve` again");
    }
    println!("serving {} at http://{shown}/ (Ctrl-C stops)", root.display());
    use std::io::Write;
    let _ = std::io::stdout().flush();
    let web = web.map(Path::to_path_buf);
    for stream in listener.incoming() {
        let Ok(stream) = stream else { continue };
        let (root, web) = (root.clone(), web.clone());
        std::thread::spawn(move || {
            if let Err(e) = handle(stream, &root, web.as_deref()) {
                tracing::debug!("connection: {e}");
            }
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
}

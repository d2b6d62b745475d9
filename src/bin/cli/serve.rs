//! `cgv serve`: a small static file server on 127.0.0.1 for the web viewer
//! (browsers refuse ES modules and wasm from file:// URLs). GET and HEAD
//! only, files under the folder only, the MIME types a viewer needs, and
//! single byte ranges (RFC 9110, section 14), so a player can fetch part of
//! a long file.

use anyhow::{bail, Context, Result};
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Component, Path, PathBuf};

#[derive(clap::Args)]
#[command(after_help = "Example:\n  cgv serve www --port 8080   # then open http://127.0.0.1:8080/?src=media/walk.cgv")]
pub struct Args {
    /// Folder to serve (the viewer is in www/).
    #[arg(default_value = "www")]
    dir: PathBuf,
    /// Port on 127.0.0.1 (0 picks a free one).
    #[arg(long, default_value_t = 8080)]
    port: u16,
}

fn mime(path: &Path) -> &'static str {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("html") => "text/html; charset=utf-8",
        Some("js") | Some("mjs") => "text/javascript; charset=utf-8",
        Some("wasm") => "application/wasm",
        Some("css") => "text/css; charset=utf-8",
        Some("json") => "application/json",
        Some("png") => "image/png",
        Some("svg") => "image/svg+xml",
        Some("glb") => "model/gltf-binary",
        _ => "application/octet-stream",
    }
}

/// Maps a request path to a file under `root`, refusing anything that
/// would leave it.
fn resolve(root: &Path, target: &str) -> Option<PathBuf> {
    let path = target.split(['?', '#']).next()?;
    let mut out = root.to_path_buf();
    for c in Path::new(path.trim_start_matches('/')).components() {
        match c {
            Component::Normal(p) => out.push(p),
            Component::CurDir => {}
            _ => return None,
        }
    }
    if out.is_dir() {
        out.push("index.html");
    }
    out.is_file().then_some(out)
}

/// The byte range `a..=b` a `Range` header value asks of a file of `len`
/// bytes: `Ok(None)` to send the whole file (no header, another unit, or
/// several ranges, which a server may ignore), `Err(())` when no byte of
/// it is in the file (416).
fn byte_range(value: &str, len: u64) -> Result<Option<(u64, u64)>, ()> {
    let Some(spec) = value.trim().strip_prefix("bytes=") else { return Ok(None) };
    if spec.contains(',') {
        return Ok(None);
    }
    let (first, last) = spec.split_once('-').ok_or(())?;
    let num = |t: &str| t.trim().parse::<u64>().map_err(|_| ());
    let (a, b) = match (first.trim().is_empty(), last.trim().is_empty()) {
        // The last n bytes.
        (true, false) => (len.saturating_sub(num(last)?), len.checked_sub(1).ok_or(())?),
        (false, true) => (num(first)?, len.saturating_sub(1)),
        (false, false) => (num(first)?, num(last)?.min(len.saturating_sub(1))),
        (true, true) => return Err(()),
    };
    if a >= len || a > b {
        return Err(());
    }
    Ok(Some((a, b)))
}

/// The request line and the `Range` header's value, headers drained.
fn read_request(reader: &mut impl BufRead) -> std::io::Result<(String, Option<String>)> {
    let mut line = String::new();
    reader.read_line(&mut line)?;
    let (mut h, mut range) = (String::new(), None);
    while reader.read_line(&mut h)? > 2 {
        if let Some((name, value)) = h.split_once(':') {
            if name.trim().eq_ignore_ascii_case("range") {
                range = Some(value.trim().to_string());
            }
        }
        h.clear();
    }
    Ok((line, range))
}

/// Writes the status, the headers and `length` bytes of `body` (none for HEAD).
fn reply_from(
    out: &mut TcpStream,
    (status, headers): (&str, &str),
    body: &mut dyn Read,
    length: u64,
    head: bool,
) -> std::io::Result<()> {
    write!(
        out,
        "HTTP/1.1 {status}\r\n{headers}Content-Length: {length}\r\nCache-Control: no-cache\r\nConnection: close\r\n\r\n"
    )?;
    if !head {
        // Streamed, so a long file is never held in memory.
        std::io::copy(&mut body.take(length), out)?;
    }
    Ok(())
}

fn reply(out: &mut TcpStream, status: &str, headers: &str, body: &[u8], head: bool) -> std::io::Result<()> {
    reply_from(out, (status, headers), &mut &body[..], body.len() as u64, head)
}

/// The file at `path`, whole or the range the request asks for.
fn send_file(out: &mut TcpStream, path: &Path, range: Option<&str>, head: bool) -> std::io::Result<()> {
    let mut file = std::fs::File::open(path)?;
    let len = file.metadata()?.len();
    let kind = format!("Content-Type: {}\r\nAccept-Ranges: bytes\r\n", mime(path));
    match range.map_or(Ok(None), |r| byte_range(r, len)) {
        Ok(Some((a, b))) => {
            file.seek(SeekFrom::Start(a))?;
            let headers = format!("{kind}Content-Range: bytes {a}-{b}/{len}\r\n");
            reply_from(out, ("206 Partial Content", &headers), &mut file, b - a + 1, head)
        }
        Ok(None) => reply_from(out, ("200 OK", &kind), &mut file, len, head),
        Err(()) => {
            let headers = format!("Content-Type: text/plain\r\nContent-Range: bytes */{len}\r\n");
            reply(out, "416 Range Not Satisfiable", &headers, b"range not satisfiable\n", head)
        }
    }
}

fn handle(root: &Path, stream: TcpStream) -> std::io::Result<()> {
    let (line, range) = read_request(&mut BufReader::new(stream.try_clone()?))?;
    let mut parts = line.split_whitespace();
    let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or("/"));
    let mut out = stream;
    let text = "Content-Type: text/plain\r\n";
    if method != "GET" && method != "HEAD" {
        return reply(&mut out, "405 Method Not Allowed", text, b"GET only\n", false);
    }
    match resolve(root, target) {
        Some(p) => send_file(&mut out, &p, range.as_deref(), method == "HEAD"),
        None => reply(&mut out, "404 Not Found", text, b"not found\n", method == "HEAD"),
    }
}

pub fn run(args: Args) -> Result<()> {
    if !args.dir.is_dir() {
        bail!("{}: not a folder", args.dir.display());
    }
    let root = args.dir.canonicalize()?;
    let listener =
        TcpListener::bind(("127.0.0.1", args.port)).with_context(|| format!("listening on port {}", args.port))?;
    let port = listener.local_addr()?.port();
    println!("serving {} at http://127.0.0.1:{port}/ (Ctrl-C stops)", root.display());
    if !root.join("pkg").is_dir() {
        eprintln!("note: {} has no pkg/ folder; build the viewer with pkg-scripts/web.sh", root.display());
    }
    for stream in listener.incoming().flatten() {
        let root = root.clone();
        std::thread::spawn(move || {
            let _ = handle(&root, stream);
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::byte_range;

    #[test]
    fn ranges_as_rfc_9110_reads_them() {
        assert_eq!(byte_range("bytes=0-9", 100), Ok(Some((0, 9))));
        assert_eq!(byte_range("bytes=90-", 100), Ok(Some((90, 99))));
        assert_eq!(byte_range("bytes=-10", 100), Ok(Some((90, 99))));
        assert_eq!(byte_range("bytes=-1000", 100), Ok(Some((0, 99))));
        assert_eq!(byte_range("bytes=50-1000", 100), Ok(Some((50, 99))));
        assert_eq!(byte_range("bytes=100-", 100), Err(()));
        assert_eq!(byte_range("bytes=9-3", 100), Err(()));
        assert_eq!(byte_range("bytes=-", 100), Err(()));
        assert_eq!(byte_range("bytes=x-3", 100), Err(()));
        assert_eq!(byte_range("bytes=0-1,5-6", 100), Ok(None), "several ranges: the whole file");
        assert_eq!(byte_range("items=0-1", 100), Ok(None));
        assert_eq!(byte_range("bytes=-5", 0), Err(()));
    }
}

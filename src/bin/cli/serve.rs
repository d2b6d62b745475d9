//! `cgv serve`: a small static file server on 127.0.0.1 for the web viewer
//! (browsers refuse ES modules and wasm from file:// URLs). GET and HEAD
//! only, files under the folder only, the MIME types a viewer needs.

use anyhow::{bail, Context, Result};
use std::io::{BufRead, BufReader, Write};
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

fn handle(root: &Path, stream: TcpStream) -> std::io::Result<()> {
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut line = String::new();
    reader.read_line(&mut line)?;
    // Drain the headers.
    let mut h = String::new();
    while reader.read_line(&mut h)? > 2 {
        h.clear();
    }
    let mut parts = line.split_whitespace();
    let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or("/"));
    let mut out = stream;
    let reply = |out: &mut TcpStream, status: &str, kind: &str, body: &[u8], head: bool| -> std::io::Result<()> {
        write!(
            out,
            "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-cache\r\nConnection: close\r\n\r\n",
            body.len()
        )?;
        if !head {
            out.write_all(body)?;
        }
        Ok(())
    };
    if method != "GET" && method != "HEAD" {
        return reply(&mut out, "405 Method Not Allowed", "text/plain", b"GET only\n", false);
    }
    match resolve(root, target).and_then(|p| std::fs::read(&p).ok().map(|b| (p, b))) {
        Some((p, body)) => reply(&mut out, "200 OK", mime(&p), &body, method == "HEAD"),
        None => reply(&mut out, "404 Not Found", "text/plain", b"not found\n", method == "HEAD"),
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

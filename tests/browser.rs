//! The web viewer in a real headless Chromium, driven through chromedriver's
//! WebDriver HTTP API (no Node needed): the page plays a fixture with
//! WebCodecs + the wasm core + the wgpu renderer on WebGPU and on WebGL2,
//! the frame counter advances, screenshots show the figure and change; a
//! corrupt file gives an error on the page and the page keeps working; and
//! inside the page, WebCodecs' luma samples and the wasm reconstruction
//! equal the native decoder's.
//!
//! Needs what `pkg-scripts/setup.sh` installs (chromium, chromium-driver)
//! and the web package (`pkg-scripts/web.sh`, which `pkg-scripts/test.sh`
//! runs first). Screenshots are kept in the test's temp folder as artifacts.
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

mod common;

use serde_json::{json, Value};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const CHROME_ARGS: &[&str] = &[
    "--headless",
    "--no-sandbox",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-quic",
    "--enable-unsafe-webgpu",
    "--enable-unsafe-swiftshader",
    "--enable-features=Vulkan",
    "--use-vulkan=swiftshader",
    "--use-angle=swiftshader",
    "--window-size=800,640",
    // performance.memory to the byte (the memory measurement).
    "--enable-precise-memory-info",
];

/// Kills a child process when dropped.
struct Guard(Child);
impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// One HTTP/1.1 request with a JSON body; returns the JSON reply.
fn http(port: u16, method: &str, path: &str, body: Option<&Value>) -> Value {
    let body = body.map(|b| b.to_string()).unwrap_or_default();
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(120))).unwrap();
    write!(
        s,
        "{method} {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )
    .unwrap();
    // Read the head, then exactly Content-Length bytes (chromedriver may keep
    // the connection open whatever we ask).
    let mut out = Vec::new();
    let mut byte = [0u8; 4096];
    let head_end = loop {
        let n = s.read(&mut byte).unwrap();
        assert!(n > 0, "connection closed before the reply's head");
        out.extend_from_slice(&byte[..n]);
        if let Some(i) = out.windows(4).position(|w| w == b"\r\n\r\n") {
            break i + 4;
        }
    };
    let head = String::from_utf8_lossy(&out[..head_end]).to_ascii_lowercase();
    let len = head
        .lines()
        .find_map(|l| l.strip_prefix("content-length:").map(|v| v.trim().parse::<usize>().unwrap_or(0)))
        .unwrap_or(0);
    while out.len() < head_end + len {
        let n = s.read(&mut byte).unwrap();
        if n == 0 {
            break;
        }
        out.extend_from_slice(&byte[..n]);
    }
    serde_json::from_slice(&out[head_end..(head_end + len).min(out.len())]).unwrap_or(Value::Null)
}

struct Browser {
    port: u16,
    session: String,
    _driver: Guard,
}

impl Browser {
    fn start(profile: &Path) -> Browser {
        let driver_bin = std::env::var("CHROMEDRIVER").unwrap_or_else(|_| "/usr/bin/chromedriver".into());
        let port = free_port();
        let driver = Command::new(&driver_bin)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("{driver_bin}: {e} (pkg-scripts/setup.sh installs chromium-driver)"));
        let driver = Guard(driver);
        let deadline = Instant::now() + Duration::from_secs(20);
        while TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(Instant::now() < deadline, "chromedriver did not start");
            std::thread::sleep(Duration::from_millis(100));
        }
        let mut args: Vec<String> = CHROME_ARGS.iter().map(|s| s.to_string()).collect();
        args.push(format!("--user-data-dir={}", profile.display()));
        let caps = json!({"capabilities": {"alwaysMatch": {"browserName": "chrome",
            "goog:chromeOptions": {"binary": std::env::var("CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into()), "args": args}}}});
        let v = http(port, "POST", "/session", Some(&caps));
        let session = v["value"]["sessionId"].as_str().unwrap_or_else(|| panic!("no session: {v}")).to_string();
        Browser { port, session, _driver: driver }
    }

    fn go(&self, url: &str) {
        http(self.port, "POST", &format!("/session/{}/url", self.session), Some(&json!({"url": url})));
    }

    /// Runs `script` (a function body; `arguments` holds `args`) and returns its value.
    fn js(&self, script: &str, args: Value) -> Value {
        let v = http(
            self.port,
            "POST",
            &format!("/session/{}/execute/sync", self.session),
            Some(&json!({"script": script, "args": args})),
        );
        v["value"].clone()
    }

    /// Runs an async script: it must call `arguments[arguments.length - 1](result)`.
    fn js_async(&self, script: &str, args: Value) -> Value {
        http(self.port, "POST", &format!("/session/{}/timeouts", self.session), Some(&json!({"script": 120000})));
        let v = http(
            self.port,
            "POST",
            &format!("/session/{}/execute/async", self.session),
            Some(&json!({"script": script, "args": args})),
        );
        v["value"].clone()
    }

    fn screenshot(&self, path: &Path) -> Vec<u8> {
        let v = http(self.port, "GET", &format!("/session/{}/screenshot", self.session), None);
        let b64 = v["value"].as_str().expect("screenshot");
        use base64::Engine;
        let png = base64::engine::general_purpose::STANDARD.decode(b64).unwrap();
        std::fs::write(path, &png).unwrap();
        png
    }

    /// Polls `script` until it returns true, or panics with `what`.
    fn wait(&self, what: &str, script: &str, secs: u64) {
        let deadline = Instant::now() + Duration::from_secs(secs);
        loop {
            if self.js(script, json!([])) == json!(true) {
                return;
            }
            assert!(Instant::now() < deadline, "timed out waiting for {what}; page says {}", self.js(STATE, json!([])));
            std::thread::sleep(Duration::from_millis(200));
        }
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        http(self.port, "DELETE", &format!("/session/{}", self.session), None);
    }
}

/// What the first player shows: message, stats text, frame.
const STATE: &str = "const p = document.getElementById('a'); const r = p.shadowRoot; \
    return {msg: r.querySelector('.msg').textContent, stats: r.querySelector('.stats').textContent, \
    frame: p.dataset.frame, decoded: (p.frames || []).length, error: document.getElementById('error').textContent};";

/// Pixels of the screenshot that differ from the renderer's background, in the viewer's area.
fn figure_pixels(png_bytes: &[u8]) -> (usize, Vec<u8>) {
    let (px, ch) = common::decode_png(png_bytes);
    let bg = cgv::render::BACKGROUND;
    let fig = px
        .chunks_exact(ch)
        .filter(|p| {
            // Lit surface: brighter than the page's dark greys.
            p[..3].iter().zip(bg).all(|(a, b)| *a > b.saturating_add(40))
        })
        .count();
    (fig, px)
}

/// A folder with the viewer (www/ and its pkg/) and the fixtures, served.
fn site(name: &str) -> (PathBuf, Guard, u16) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let pkg = root.join("www/pkg/cgv_bg.wasm");
    assert!(pkg.exists(), "{} is missing: build the web package with pkg-scripts/web.sh first", pkg.display());
    // One folder per test: tests run in parallel, each with its own browser profile.
    let dir = common::temp_dir(&format!("browser-site-{name}"));
    for f in ["index.html", "cgv-player.js", "cgv-stream.js"] {
        std::fs::copy(root.join("www").join(f), dir.join(f)).unwrap();
    }
    // The three.js module, its demo page, and the parts of three.js it loads.
    std::fs::create_dir_all(dir.join("three")).unwrap();
    for f in ["three/cgv-three.js", "three/index.html", "three/skinned.html"] {
        std::fs::copy(root.join("www").join(f), dir.join(f)).unwrap();
    }
    let three = root.join("www/node_modules/three");
    assert!(three.exists(), "{} is missing: run pkg-scripts/setup.sh (npm ci in www)", three.display());
    for f in [
        "build/three.module.js",
        "build/three.core.js",
        "examples/jsm/controls/OrbitControls.js",
        "examples/jsm/loaders/GLTFLoader.js",
        "examples/jsm/utils/BufferGeometryUtils.js",
        "examples/jsm/utils/SkeletonUtils.js",
    ] {
        let to = dir.join("node_modules/three").join(f);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(three.join(f), to).unwrap();
    }
    for pkg in ["pkg", "pkg-decoder"] {
        std::fs::create_dir_all(dir.join(pkg)).unwrap();
        for e in std::fs::read_dir(root.join("www").join(pkg)).unwrap() {
            let e = e.unwrap();
            std::fs::copy(e.path(), dir.join(pkg).join(e.file_name())).unwrap();
        }
    }
    for f in ["walk-cgv.cgv", "walk-gv.cgv", "walk-cgv.cgv.cgv.positions", "walk-gv.cgv.cgv.positions"] {
        std::fs::copy(root.join("tests/fixtures/v1").join(f), dir.join(f)).unwrap();
    }
    std::fs::copy(root.join("tests/fixtures/v6/walk-cgv-source.cgv"), dir.join("walk-source.cgv")).unwrap();
    std::fs::copy(root.join("tests/fixtures/v8/fox-textured.cgv"), dir.join("fox.cgv")).unwrap();
    std::fs::copy(root.join("tests/fixtures/v9/walk-cgv-normal.cgv"), dir.join("normal.cgv")).unwrap();
    std::fs::copy(root.join("tests/fixtures/v11/ball-hat-loose.cgv"), dir.join("hat.cgv")).unwrap();
    std::fs::copy(root.join("tests/fixtures/v13/walk-bones.cgv"), dir.join("bones.cgv")).unwrap();
    std::fs::copy(root.join("tests/fixtures/v17/walk-skinned.cgv"), dir.join("skinned.cgv")).unwrap();
    for f in [
        "v18/walk-skinned-residual.cgv",
        "v18/walk-normal-residual.cgv",
        "v19/walk-normal-spatial.cgv",
        "v20/walk-vertices.cgv",
    ] {
        std::fs::copy(root.join("tests/fixtures").join(f), dir.join(&f[4..])).unwrap();
    }
    std::fs::copy(root.join("tests/fixtures/v16/walk-capture-frame-meshes.cgv"), dir.join("capture.cgv")).unwrap();
    // The built-in figure with its UVs and procedural checks, encoded now.
    let textured = dir.join("walk-textured.cgv");
    let out = Command::new(env!("CARGO_BIN_EXE_cgv"))
        .args(["encode", "builtin:walk-textured", "--frames", "0..12", "--grid", "32", "-o"])
        .arg(&textured)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // A corrupt copy: one flipped byte in the middle.
    let mut bad = std::fs::read(dir.join("walk-cgv.cgv")).unwrap();
    let k = bad.len() / 2;
    bad[k] ^= 0x55;
    std::fs::write(dir.join("corrupt.cgv"), bad).unwrap();
    let port = free_port();
    let server = Command::new(env!("CARGO_BIN_EXE_cgv"))
        .args(["serve", dir.to_str().unwrap(), "--port", &port.to_string()])
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let server = Guard(server);
    wait_for_port(port, "cgv serve");
    (dir, server, port)
}

/// Waits (10 s at most) for a server to listen on `port`.
fn wait_for_port(port: u16, what: &str) {
    let deadline = Instant::now() + Duration::from_secs(10);
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(Instant::now() < deadline, "{what} did not start");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// In the page: WebCodecs' luma samples of the GV fixture against the
/// native decode (through its dequantized positions, which pin every
/// sample), and the page's CGV reconstruction against the native one.
const EXACTNESS: &str = r#"
const done = arguments[arguments.length - 1];
(async () => {
  const m = await import('/cgv-player.js');
  await m.loadWasm();
  const { Player } = await import('/pkg/cgv.js');
  const get = async (u) => new Uint8Array(await (await fetch(u)).arrayBuffer());
  // GV: every luma sample WebCodecs gives equals the native openh264 sample.
  const gv = new Player('');
  gv.push(await get('/walk-gv.cgv'));
  const h = JSON.parse(gv.header_json());
  const n = h.grid, N = n * n;
  const want = new Float32Array((await get('/walk-gv.cgv.cgv.positions')).buffer);
  let samples = 0, mismatches = 0;
  const decs = h.streams.map(() => new m.LumaDecoder(n));
  for (let f = 0; f < h.frames; f++) {
    for (let s = 0; s < h.streams.length; s++) {
      const luma = await decs[s].decode(gv.access_unit(s, f), f);
      const q = h.streams[s].quant, step = (q.max - q.min) / 255;
      for (let i = 0; i < N; i++) {
        const expected = Math.round((want[(f * N + i) * 3 + s] - q.min) / step);
        samples++;
        if (luma[i] !== expected) mismatches++;
      }
    }
  }
  // CGV: the page's own decode of the fixture against the native positions.
  const p = document.getElementById('a');
  const cgvWant = new Float32Array((await get('/walk-cgv.cgv.cgv.positions')).buffer);
  let worst = 0;
  p.frames.forEach((x, f) => x.forEach((v, i) => { worst = Math.max(worst, Math.abs(v - cgvWant[f * x.length + i])); }));
  done({ samples, mismatches, worst, frames: p.frames.length });
})().catch((e) => done({ error: String(e && e.stack || e) }));
"#;

/// A fixture's frozen positions (`tests/fixtures/NAME`: f32 LE, x, y, z).
fn frozen(name: &str) -> Vec<f32> {
    let bytes = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures").join(name)).unwrap();
    bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

/// How far the page's input vertices of frame `k` (`{k, v}`, as the
/// players' `source_vertices` gave them) lie from `fixture`'s frozen ones.
fn off_frozen(got: &serde_json::Value, fixture: &str) -> (usize, f64) {
    let k = got["k"].as_u64().unwrap() as usize;
    let want = frozen(&format!("{fixture}.source.positions"));
    let got: Vec<f64> = got["v"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let frame = &want[k * got.len()..(k + 1) * got.len()];
    (k, got.iter().zip(frame).map(|(a, b)| (a - *b as f64).abs()).fold(0.0, f64::max))
}

#[test]
fn viewer_plays_renders_and_recovers_in_headless_chromium() {
    let (dir, _server, port) = site("viewer");
    let art = common::temp_dir("browser-artifacts");
    let browser = Browser::start(&dir.join("profile"));
    let base = format!("http://127.0.0.1:{port}");
    // Decoded, and the first frame shown (the view is made while frames decode).
    let frames_loaded =
        "const p = document.getElementById('a'); return (p.frames || []).length === 4 && p.dataset.frame !== undefined;";

    for (backend, query) in [("WebGPU", ""), ("WebGL2", "&webgl")] {
        browser.go(&format!("{base}/?src=walk-cgv.cgv&autoplay{query}"));
        browser.wait("the fixture's 4 frames", frames_loaded, 90);
        let state = browser.js(STATE, json!([]));
        assert!(state["stats"].as_str().unwrap_or("").starts_with(backend), "{backend}: {state}");
        // Playing (looping): the frame counter moves.
        let mut seen = std::collections::BTreeSet::new();
        for _ in 0..15 {
            seen.insert(browser.js(STATE, json!([]))["frame"].to_string());
            std::thread::sleep(Duration::from_millis(70));
        }
        assert!(seen.len() >= 2, "{backend}: the frame counter did not advance ({seen:?})");
        // Two times, two pictures: both show the figure, and they differ.
        let shots: Vec<(usize, Vec<u8>)> = [0, 3]
            .iter()
            .map(|&f| {
                browser.js(
                    &format!("const p = document.getElementById('a'); p.pause(); p.show({f}); return true;"),
                    json!([]),
                );
                std::thread::sleep(Duration::from_millis(300));
                figure_pixels(&browser.screenshot(&art.join(format!("{backend}-frame{f}.png"))))
            })
            .collect();
        for (i, (fig, _)) in shots.iter().enumerate() {
            assert!(*fig > 2000, "{backend} shot {i}: only {fig} figure pixels (see {})", art.display());
        }
        assert_ne!(shots[0].1, shots[1].1, "{backend}: frames 0 and 3 look identical");
    }

    // Exactness against the native decoder, inside the page (WebGL2 page still loaded).
    let r = browser.js_async(EXACTNESS, json!([]));
    assert!(r.get("error").is_none(), "{r}");
    assert_eq!(r["frames"], 4, "{r}");
    assert!(r["samples"].as_u64().unwrap_or(0) == 4 * 3 * 256 && r["mismatches"] == 0, "WebCodecs vs openh264: {r}");
    // The fixture's tolerance for the cgv decoder (tests/fixtures.rs): 1e-5 of the diagonal.
    let diag = 2.2151663f64;
    assert!(r["worst"].as_f64().unwrap() <= 1e-5 * diag, "wasm vs native reconstruction: {r}");

    // A version-6 file: the input's own mesh drawn when shaded, the grid for λ.
    browser.js("document.getElementById('a').load('walk-source.cgv'); return true;", json!([]));
    browser.wait("the v6 fixture's 3 frames", "const p = document.getElementById('a'); return (p.frames || []).length === 3 && p.dataset.frame !== undefined;", 60);
    browser.js("const p = document.getElementById('a'); p.pause(); p.show(2); return true;", json!([]));
    std::thread::sleep(Duration::from_millis(300));
    let surface = "return document.getElementById('a').dataset.surface;";
    assert_eq!(browser.js(surface, json!([])), json!("source"), "{}", browser.js(STATE, json!([])));
    let (fig, _) = figure_pixels(&browser.screenshot(&art.join("source-mesh.png")));
    assert!(fig > 2000, "the source mesh shows {fig} figure pixels");
    browser.js(
        "const p = document.getElementById('a'); p.setAttribute('mode', 'lambda'); p.show(2); return true;",
        json!([]),
    );
    assert_eq!(browser.js(surface, json!([])), json!("grid"));

    // A version-8 file: the input's mesh drawn with its texture (Fox: orange fur).
    draw_shaded(&browser);
    let (orange, _) = textured_colours(&browser, "fox.cgv", &art.join("textured.png"));
    assert!(orange > 1000, "the textured fox shows {orange} orange pixels (see {})", art.display());

    // The built-in figure, textured with orange and cream checks.
    let (orange, cream) = textured_colours(&browser, "walk-textured.cgv", &art.join("walk-textured.png"));
    assert!(
        orange > 300 && cream > 300,
        "the built-in figure shows {orange} orange and {cream} cream pixels (see {})",
        art.display()
    );

    // A version-11 file: each held frame's loose vertices (the hat) go with
    // it, and the page's input vertices are the frozen ones.
    browser.js("document.getElementById('a').load('hat.cgv'); return true;", json!([]));
    let held = "const p = document.getElementById('a'); \
        const ks = Object.keys(p.frames || {}).map(Number).filter((k) => p.frames[k] && p.frames[k].loose); \
        if (ks.length < 3) return null; const k = ks[ks.length - 1]; \
        return { k, v: Array.from(p.player.source_vertices(p.frames[k], p.frames[k].loose, p.frames[k].skinned)) };";
    browser.wait("the v11 fixture's frames", &held.replace("return {", "return !!{"), 60);
    let (k, worst) = off_frozen(&browser.js(held, json!([])), "v11/ball-hat-loose.cgv");
    assert!(worst < 1e-4, "frame {k} of the v11 fixture's input vertices differ by {worst} in the page");

    // A version-13 file: frames predicted by bones give the frozen input
    // vertices in the page too (the skin weights reach the wasm decoder);
    // so do a version-17 file (bones on the vertices plus the grid's
    // residual) and version 18's vertex residual over them or over the
    // closed loop, version 19's spatially predicted one, and version 20's
    // file without a grid or video (no WebCodecs decoder at all).
    let pages = [
        ("bones.cgv", "v13/walk-bones.cgv"),
        ("skinned.cgv", "v17/walk-skinned.cgv"),
        ("walk-skinned-residual.cgv", "v18/walk-skinned-residual.cgv"),
        ("walk-normal-residual.cgv", "v18/walk-normal-residual.cgv"),
        ("walk-normal-spatial.cgv", "v19/walk-normal-spatial.cgv"),
        ("walk-vertices.cgv", "v20/walk-vertices.cgv"),
    ];
    for (page, fixture) in pages {
        browser.js(&format!("document.getElementById('a').load('{page}'); return true;"), json!([]));
        let held = "const p = document.getElementById('a'); \
            const ks = Object.keys(p.frames || {}).map(Number).filter((k) => p.frames[k]); \
            if (ks.length < 6) return null; const k = ks[ks.length - 1]; \
            const loose = p.frames[k].loose || new Float32Array(0); \
            return { k, v: Array.from(p.player.source_vertices(p.frames[k], loose, p.frames[k].skinned)) };";
        browser.wait(&format!("{fixture}'s frames"), &held.replace("return {", "return !!{"), 60);
        let (k, worst) = off_frozen(&browser.js(held, json!([])), fixture);
        assert!(worst < 1e-4, "frame {k} of {fixture}'s input vertices differ by {worst} in the page");
    }

    // A version-16 file (a capture, `--mesh frames`): each frame drawn as
    // its own mesh, rebuilt in the page to the frozen vertices.
    browser.js("document.getElementById('a').load('capture.cgv'); return true;", json!([]));
    let all =
        "const p = document.getElementById('a'); return (p.frames || []).filter((x) => x && x.mesh).length === 4;";
    browser.wait("the v16 fixture's 4 frame meshes", all, 60);
    browser.js("const p = document.getElementById('a'); p.pause(); p.show(3); return true;", json!([]));
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(browser.js(surface, json!([])), json!("frame"), "{}", browser.js(STATE, json!([])));
    let meshes = browser.js(
        "const p = document.getElementById('a'); \
         return [0, 1, 2, 3].map((k) => ({ v: Array.from(p.frames[k].mesh.vertices), f: p.frames[k].mesh.faces.length }));",
        json!([]),
    );
    let faces: Vec<u64> = meshes.as_array().unwrap().iter().map(|m| m["f"].as_u64().unwrap() / 3).collect();
    assert_eq!(faces, [1466, 1814, 1722, 1392], "the capture's faces a frame in the page");
    let got: Vec<f64> = meshes
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|m| m["v"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()))
        .collect();
    let want = frozen("v16/walk-capture-frame-meshes.cgv.frame-meshes.positions");
    assert_eq!(got.len(), want.len(), "the frame meshes' vertices");
    let worst = got.iter().zip(&want).map(|(a, b)| (a - *b as f64).abs()).fold(0.0, f64::max);
    assert!(worst < 1e-4, "the v16 fixture's frame meshes differ by {worst} in the page");
    let (fig, _) = figure_pixels(&browser.screenshot(&art.join("frame-mesh.png")));
    assert!(fig > 2000, "the frame's own mesh shows {fig} figure pixels");

    // A version-9 file: x, y, z corrections at 16 x 16 beside a 32 x 32
    // normal picture, each stream's WebCodecs decoder at its own size.
    browser.js("document.getElementById('a').load('normal.cgv'); return true;", json!([]));
    browser.wait("the v9 fixture's 6 frames", "const p = document.getElementById('a'); return (p.frames || []).length === 6 && p.dataset.frame !== undefined;", 60);
    browser.js("const p = document.getElementById('a'); p.pause(); p.show(5); return true;", json!([]));
    std::thread::sleep(Duration::from_millis(300));
    let (fig, _) = figure_pixels(&browser.screenshot(&art.join("normal-correction.png")));
    assert!(fig > 2000, "the v9 file shows {fig} figure pixels: {}", browser.js(STATE, json!([])));

    // A corrupt file dropped on the page: a clear error; then a good file plays.
    browser.go(&format!("{base}/"));
    browser.js_async(
        "const done = arguments[arguments.length - 1];
         fetch('/corrupt.cgv').then((r) => r.arrayBuffer()).then((b) => {
           const dt = new DataTransfer();
           dt.items.add(new File([b], 'corrupt.cgv'));
           document.dispatchEvent(new DragEvent('drop', { dataTransfer: dt, bubbles: true, cancelable: true }));
           done(true);
         });",
        json!([]),
    );
    browser.wait(
        "an error message",
        "const p = document.getElementById('a'); return p.shadowRoot.querySelector('.msg').textContent.includes('Cannot play');",
        60,
    );
    let state = browser.js(STATE, json!([]));
    assert!(
        state["error"].as_str().unwrap_or("").contains("CRC") || state["msg"].as_str().unwrap_or("").contains("CRC"),
        "{state}"
    );
    browser.screenshot(&art.join("corrupt.png"));
    browser.js("document.getElementById('a').load('walk-gv.cgv'); return true;", json!([]));
    browser.wait("the good file after the bad one", frames_loaded, 60);
    let (fig, _) = figure_pixels(&browser.screenshot(&art.join("after-corrupt.png")));
    assert!(fig > 2000, "after a corrupt file the viewer shows {fig} figure pixels");

    // A browser without WebCodecs: a message that says so, not a blank canvas.
    browser.go(&format!("{base}/"));
    browser
        .js("delete window.VideoDecoder; document.getElementById('a').load('walk-cgv.cgv'); return true;", json!([]));
    browser.wait(
        "the no-WebCodecs message",
        "return document.getElementById('a').shadowRoot.querySelector('.msg').textContent.includes('WebCodecs');",
        30,
    );
    eprintln!("screenshots in {}", art.display());
}

/// A page with one player of `src` (buffer 0.1 s: a window of 8 frames)
/// that logs the element's events into `window.log`.
const LONG_PAGE: &str = r#"<!doctype html><meta charset="utf-8">
<cgv-player id="a" src="long.cgv" buffer="0.1" loop style="width:320px;height:280px"></cgv-player><div id="error"></div>
<script type="module">
import '/cgv-player.js';
window.log = [];
const p = document.getElementById('a');
for (const e of ['loadedmetadata', 'progress', 'play', 'pause', 'timeupdate', 'seeking', 'seeked', 'ended', 'error'])
  p.addEventListener(e, () => window.log.push(e));
// Frames the stream had decoded when a seek landed (random access: a seek
// decodes from the point before the frame, not from frame 0).
p.addEventListener('seeked', () => { window.decodedAtSeek = p.stream.stats.decoded; window.seekedAt = performance.now(); });
</script>"#;

/// Worst difference between the page's frame `f` and the native decode's.
fn page_frame_error(browser: &Browser, f: usize, native: &[Vec<glam::Vec3>]) -> f64 {
    let got = browser.js(&format!("return Array.from(document.getElementById('a').frames[{f}] || []);"), json!([]));
    let got: Vec<f64> = got.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert_eq!(got.len(), 3 * native[f].len(), "frame {f} is not held");
    native[f].iter().flat_map(|p| p.to_array()).zip(&got).map(|(a, b)| (a as f64 - b).abs()).fold(0.0, f64::max)
}

/// `frames` frames of the default motion at grid `n` with a random-access
/// point every 10 frames, written to `path`: its bytes, the native decoder's
/// frames, and the diagonal.
fn motion_file(path: &Path, frames: usize, n: usize) -> (Vec<u8>, Vec<Vec<glam::Vec3>>, f64) {
    motion_file_with_segments(path, frames, n, &[])
}

/// [`motion_file`] with segments starting at `segments` (format version 15).
fn motion_file_with_segments(
    path: &Path,
    frames: usize,
    n: usize,
    segments: &[u32],
) -> (Vec<u8>, Vec<Vec<glam::Vec3>>, f64) {
    let src = cgv::mesh::builtin::motion(frames);
    let opts = cgv::codec::EncodeOptions {
        grid: n,
        source_mesh: false,
        random_access: 10.0 / 30.0,
        segments: segments.to_vec(),
        ..Default::default()
    };
    let (bytes, _) = cgv::codec::encode(&src, &opts, &mut |_, _, _| {}).unwrap();
    std::fs::write(path, &bytes).unwrap();
    let file = cgv::format::read(&bytes).unwrap();
    let diag = file.header.source.diagonal as f64;
    let mut dec = cgv::codec::FileDecoder::new(file, cgv::solve::SolverKind::Predictive).unwrap();
    let native = (0..frames).map(|_| dec.next_frame().unwrap().0).collect();
    (bytes, native, diag)
}

#[test]
fn the_player_seeks_loops_in_bounded_memory_and_behaves_like_video() {
    // Issue 19: a motion longer than twice the decode-ahead window keeps
    // only that window; looping and seeking decode again from the bytes
    // held, from the random-access point before the frame (one every 10
    // frames here); a seek lands on the native decoder's frame; the element
    // offers <video>'s properties, events and keyboard controls.
    let (dir, _server, port) = site("long");
    let (_, native, diag) = motion_file(&dir.join("long.cgv"), 40, 16);
    std::fs::write(dir.join("long.html"), LONG_PAGE).unwrap();

    let browser = Browser::start(&dir.join("profile"));
    browser.go(&format!("http://127.0.0.1:{port}/long.html"));
    browser.wait("the first frame", "return document.getElementById('a').dataset.frame === '0';", 90);
    let p = "const p = document.getElementById('a');";
    let d = browser.js(&format!("{p} return [p.duration, p.paused, p.loop, p.currentTime];"), json!([]));
    let duration = d[0].as_f64().unwrap();
    assert!((duration - 40.0 / 30.0).abs() < 1e-9 && d[1] == json!(true) && d[2] == json!(true), "{d}");
    assert_eq!(d[3].as_f64(), Some(0.0), "{d}");
    // Playing, looping, at a quarter speed... then at full speed: the held
    // frames stay within the window (8 ahead, 2 behind, the one shown).
    browser.js(&format!("{p} p.playbackRate = 2; p.play(); return true;"), json!([]));
    let (mut most, mut frames) = (0, Vec::new());
    for _ in 0..60 {
        let v = browser.js(&format!("{p} return [p.bufferedFrames, +p.dataset.frame];"), json!([]));
        most = most.max(v[0].as_u64().unwrap());
        frames.push(v[1].as_u64().unwrap());
        std::thread::sleep(Duration::from_millis(100));
    }
    let wrapped = frames.windows(2).any(|w| w[1] + 20 < w[0]);
    assert!(wrapped, "the motion did not loop: {frames:?}");
    assert!(most <= 11, "{most} frames held for a window of 8");
    // A seek forward and one back (to a frame long dropped) land on the
    // native decoder's frames.
    for f in [25usize, 5, 33] {
        let before = browser.js(
            &format!(
                "{p} p.pause(); window.log = []; const d = p.stream.stats.decoded; p.currentTime = {f} / 30; return d;"
            ),
            json!([]),
        );
        browser.wait(&format!("the seek to frame {f}"), "return window.log.includes('seeked');", 60);
        assert_eq!(browser.js(&format!("{p} return +p.dataset.frame;"), json!([])), json!(f));
        let worst = page_frame_error(&browser, f, &native);
        assert!(worst <= 1e-4 * diag, "frame {f}: {worst} from the native decode");
        // From the point at or before f: f % 10 + 1 frames (and at most one
        // the pump had in hand when the seek came).
        let decoded =
            browser.js("return window.decodedAtSeek;", json!([])).as_u64().unwrap() - before.as_u64().unwrap();
        assert!(decoded as usize <= f % 10 + 2, "the seek to {f} decoded {decoded} frames");
    }
    // Two seeks in a row, the second asked before the first lands (a
    // dragged slider): the second wins, on the native frame.
    browser.js(
        &format!("{p} p.pause(); window.log = []; p.currentTime = 35 / 30; p.currentTime = 15 / 30; return true;"),
        json!([]),
    );
    browser.wait("the second of two seeks", "return document.getElementById('a').dataset.frame === '15';", 60);
    assert!(page_frame_error(&browser, 15, &native) <= 1e-4 * diag, "frame 15 after two seeks");
    browser.js(&format!("{p} p.currentTime = 33 / 30; return true;"), json!([]));
    browser.wait("back to frame 33", "return document.getElementById('a').dataset.frame === '33';", 60);
    // Keyboard: arrows step, space plays and pauses.
    browser.js(
        &format!("{p} p.focus(); p.dispatchEvent(new KeyboardEvent('keydown', {{ key: 'ArrowRight' }})); return true;"),
        json!([]),
    );
    browser.wait("the frame after 33", "return document.getElementById('a').dataset.frame === '34';", 30);
    let key = |k: &str| {
        browser.js(
            &format!("{p} p.dispatchEvent(new KeyboardEvent('keydown', {{ key: '{k}' }})); return p.paused;"),
            json!([]),
        )
    };
    assert_eq!(key(" "), json!(false));
    assert_eq!(key(" "), json!(true));
    // Without loop: playing to the end stops there and says so.
    browser.js(
        &format!("{p} p.loop = false; window.log = []; p.currentTime = 37 / 30; p.play(); return true;"),
        json!([]),
    );
    browser.wait("the ended event", "return window.log.includes('ended');", 60);
    let log = browser.js("return window.log;", json!([]));
    for e in ["seeking", "seeked", "play", "timeupdate", "pause", "ended"] {
        assert!(log.as_array().unwrap().iter().any(|x| x == e), "no {e} event: {log}");
    }
    assert_eq!(browser.js(&format!("{p} return [+p.dataset.frame, p.paused];"), json!([])), json!([39, true]));
    let labels = browser.js(&format!("{p} return [...p.shadowRoot.querySelectorAll('button, input, select')].every((e) => e.getAttribute('aria-label'));"), json!([]));
    assert_eq!(labels, json!(true), "every control is labelled");
}

/// A page whose player fetches its file with small first requests (1 KiB),
/// so that a test file of a few dozen KiB is fetched in pieces.
const RANGE_PAGE: &str = r#"<!doctype html><meta charset="utf-8"><body><div id="error"></div>
<script type="module">
import { MotionStream } from '/cgv-stream.js';
import '/cgv-player.js';
MotionStream.prefixBytes = 1024;
window.log = [];
const p = document.createElement('cgv-player');
Object.assign(p, { id: 'a' });
p.setAttribute('buffer', '0.1');
p.style.cssText = 'width:320px;height:280px';
p.addEventListener('seeked', () => window.log.push('seeked'));
p.setAttribute('src', 'ranged.cgv');
document.body.appendChild(p);
</script>"#;

#[test]
fn the_player_fetches_only_the_points_it_needs_by_range_requests() {
    // Issue 19: from a server that answers range requests (cgv serve), a
    // version-10 file is fetched in pieces: header, index, the first
    // point's frames, then the points a seek needs; from one that does not
    // (Python's http.server), whole. Both land on the native frames. The
    // file has a segment from frame 53 (version 15): points 0, 10, ..., 50
    // and 53, so a seek to 55 needs point 6.
    let (dir, _server, port) = site("ranged");
    let (bytes, native, diag) = motion_file_with_segments(&dir.join("ranged.cgv"), 60, 32, &[53]);
    std::fs::write(dir.join("ranged.html"), RANGE_PAGE).unwrap();
    let py_port = free_port();
    let _python = Command::new("python3")
        .args(["-m", "http.server", "--bind", "127.0.0.1", "--directory", dir.to_str().unwrap()])
        .arg(py_port.to_string())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map(Guard)
        .expect("python3 -m http.server");
    let browser = Browser::start(&dir.join("profile"));
    let p = "const p = document.getElementById('a');";
    let state = |b: &Browser| {
        b.js(
            &format!(
                "{p} const s = p.stream; return [s.ranged, s.fetched, [...s.fetchedPoints].sort((a, b) => a - b)];"
            ),
            json!([]),
        )
    };
    browser.go(&format!("http://127.0.0.1:{port}/ranged.html"));
    browser.wait("the first frame", "return document.getElementById('a').dataset.frame === '0';", 90);
    let first = state(&browser);
    assert_eq!(first[0], json!(true), "range requests were not used: {first}");
    assert!(first[1].as_u64().unwrap() < bytes.len() as u64 / 2, "{first} of {} bytes", bytes.len());
    for (f, fetched, not) in [(55usize, 6u64, 3u64), (25, 2, 4)] {
        browser.js(&format!("{p} p.pause(); window.log = []; p.currentTime = {f} / 30; return true;"), json!([]));
        browser.wait(&format!("the seek to frame {f}"), "return window.log.includes('seeked');", 60);
        assert!(page_frame_error(&browser, f, &native) <= 1e-4 * diag, "frame {f}");
        let s = state(&browser);
        let points: Vec<u64> = s[2].as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect();
        assert!(points.contains(&fetched) && !points.contains(&not), "after the seek to {f}: points {points:?}");
    }
    // A server without ranges: the file comes whole, and plays the same.
    wait_for_port(py_port, "python3 -m http.server");
    browser.go(&format!("http://127.0.0.1:{py_port}/ranged.html"));
    browser.wait("the first frame (no ranges)", "return document.getElementById('a').dataset.frame === '0';", 90);
    assert_eq!(state(&browser)[0], json!(false));
    browser.js(&format!("{p} p.pause(); window.log = []; p.currentTime = 55 / 30; return true;"), json!([]));
    browser.wait("the seek to frame 55 (no ranges)", "return window.log.includes('seeked');", 60);
    assert!(page_frame_error(&browser, 55, &native) <= 1e-4 * diag);
}

/// The three.js demo page's state: the frame its mesh holds, a checksum
/// of its positions, its vertex count, and an error if it had one.
const THREE_STATE: &str = "const m = window.cgvMesh; if (!m) return { error: window.cgvError || null }; \
    const p = m.geometry.getAttribute('position').array; let sum = 0; for (let i = 0; i < p.length; i += 7) sum += p[i]; \
    return { frame: m.frame, sum, vertices: p.length / 3, textured: !!m.material.map };";

#[test]
fn the_three_js_module_plays_a_motion_in_a_scene() {
    // Issue 19: www/three/cgv-three.js gives a THREE.Mesh whose positions
    // follow the motion, decoded by our wasm; its demo page lights it in a
    // scene with OrbitControls. The figure is drawn, animates, and the
    // input's own mesh comes textured when the file carries a texture.
    let (_dir, _server, port) = site("three");
    let art = common::temp_dir("browser-three");
    let browser = Browser::start(&_dir.join("profile"));
    let bright = |png: &[u8]| {
        let (px, ch) = common::decode_png(png);
        px.chunks_exact(ch).filter(|p| p[..3].iter().map(|&c| c as u32).sum::<u32>() > 3 * 120).count()
    };
    // And a file whose frames are predicted by bones (format v13), and one
    // whose bones move the mesh's own vertices (v17, the skinned codec).
    let files = [("walk-source.cgv", 6274), ("walk-cgv.cgv", 16 * 16), ("bones.cgv", 6274), ("skinned.cgv", 6274)];
    for (file, vertices) in files {
        browser.go(&format!("http://127.0.0.1:{port}/three/index.html?src=../{file}"));
        browser.wait(&format!("{file} in three.js"), "return !!window.cgvMesh || !!window.cgvError;", 90);
        let s = browser.js(THREE_STATE, json!([]));
        assert!(s["error"].is_null(), "{file}: {s}");
        assert_eq!(s["vertices"], json!(vertices), "{file}: the input's own mesh, or the grid without one: {s}");
        // Decoded by the decoder package alone: the renderer's is not fetched.
        let wasm = browser.js(
            "return performance.getEntriesByType('resource').map((e) => e.name).filter((n) => n.endsWith('.wasm'));",
            json!([]),
        );
        assert!(
            wasm.as_array()
                .is_some_and(|w| w.iter().all(|n| n.as_str().unwrap().ends_with("/pkg-decoder/cgv_bg.wasm"))),
            "{wasm}"
        );
        // It animates: left to its clock, the frame moves.
        let mut seen = std::collections::BTreeSet::new();
        for _ in 0..20 {
            seen.insert(browser.js(THREE_STATE, json!([]))["frame"].to_string());
            std::thread::sleep(Duration::from_millis(30));
        }
        assert!(seen.len() >= 2, "{file}: the mesh stayed on one frame ({seen:?})");
        // Held at two times: two frames, other positions, another picture, the figure lit in both.
        let mut shots = Vec::new();
        for f in [0, 2] {
            browser.js(&format!("window.cgvTime = {f} / 30 + 0.001; return true;"), json!([]));
            browser.wait(&format!("{file} frame {f}"), &format!("return window.cgvMesh.frame === {f};"), 30);
            std::thread::sleep(Duration::from_millis(200));
            let png = browser.screenshot(&art.join(format!("{file}-{f}.png")));
            shots.push((browser.js(THREE_STATE, json!([])), png));
        }
        browser.js("window.cgvTime = undefined; return true;", json!([]));
        assert_ne!(shots[0].0["sum"], shots[1].0["sum"], "{file}: two frames with the same positions");
        for (st, png) in &shots {
            let lit = bright(png);
            assert!(lit > 1500, "{file} frame {}: {lit} lit pixels (see {})", st["frame"], art.display());
        }
        assert!(shots[0].1 != shots[1].1, "{file}: frames 0 and 2 look the same (see {})", art.display());
    }
    // A capture (format v16): each frame its own mesh, its own vertex count.
    browser.go(&format!("http://127.0.0.1:{port}/three/index.html?src=../capture.cgv"));
    browser.wait("capture.cgv in three.js", "return !!window.cgvMesh || !!window.cgvError;", 90);
    for (f, vertices) in [(0, 735), (2, 863)] {
        browser.js(&format!("window.cgvTime = {f} / 30 + 0.001; return true;"), json!([]));
        browser.wait(&format!("capture frame {f}"), &format!("return window.cgvMesh.frame === {f};"), 30);
        std::thread::sleep(Duration::from_millis(200));
        let s = browser.js(THREE_STATE, json!([]));
        assert_eq!(s["vertices"], json!(vertices), "capture frame {f}: its own mesh: {s}");
        let lit = bright(&browser.screenshot(&art.join(format!("capture-{f}.png"))));
        assert!(lit > 1000, "capture frame {f}: {lit} lit pixels (see {})", art.display());
    }
    browser.js("window.cgvTime = undefined; return true;", json!([]));
    // Fox (format v8): the input's mesh with its texture, orange fur in the picture.
    browser.go(&format!("http://127.0.0.1:{port}/three/index.html?src=../fox.cgv"));
    browser.wait("fox.cgv in three.js", "return !!window.cgvMesh || !!window.cgvError;", 90);
    let s = browser.js(THREE_STATE, json!([]));
    assert_eq!(s["textured"], json!(true), "{s}");
    std::thread::sleep(Duration::from_millis(500));
    let (px, ch) = common::decode_png(&browser.screenshot(&art.join("fox.png")));
    let orange = px.chunks_exact(ch).filter(|p| p[0] as i32 > p[2] as i32 + 60 && p[0] > 120).count();
    assert!(orange > 1000, "the textured fox shows {orange} orange pixels in three.js (see {})", art.display());
}

/// Playback speed in the browser against the native decoder on the same
/// file (not pass/fail tests: speed is measured, not asserted). Run:
/// `cargo test --release --test browser -- --ignored --nocapture --test-threads 1 viewer_speed`
/// (after pkg-scripts/web.sh). Each prints the native reconstruction ms per
/// frame, then per backend the time to first frame, WebCodecs and wasm
/// reconstruction ms per frame, and the playback rate.
fn viewer_speed(name: &str, grid: usize, qp: u8, fill_holes: bool, bones: Option<u16>, skinned: bool) {
    let (dir, _server, port) = site("speed");
    let path = common::real_sequence(name);
    let open = cgv::mesh::OpenOptions { fill_holes, ..Default::default() };
    let src = cgv::mesh::open_sequence(path.to_str().unwrap(), &open).unwrap();
    let frames = src.frame_count();
    let mut opts = cgv::codec::EncodeOptions { grid, bones, ..Default::default() };
    opts.video.qp = qp;
    if skinned {
        opts.representation = cgv::format::Representation::Skinned;
    }
    // The correction mode `cgv encode` picks by default.
    opts.corrections = cgv::codec::auto_corrections(&opts.video, grid, src.fps());
    let (bytes, _) = cgv::codec::encode(src.as_ref(), &opts, &mut |_, _, _| {}).unwrap();
    let file_name = format!("{name}-{grid}.cgv");
    std::fs::write(dir.join(&file_name), &bytes).unwrap();
    let file = cgv::format::read(&bytes).unwrap();
    let header = file.header.clone();
    let mut dec = cgv::codec::FileDecoder::new(file, cgv::solve::SolverKind::Predictive).unwrap();
    let native: f64 = (0..frames).map(|_| dec.next_frame().unwrap().1.solve_seconds).sum::<f64>() / frames as f64;
    let label = format!(
        "{name} N={grid} QP {qp} ({} bytes, {:?} corrections, max lag {}, {} bones)",
        bytes.len(),
        header.corrections,
        header.max_lag,
        header.skin.map_or(0, |s| s.bones)
    );
    println!("{label}: native reconstruction {:.2} ms/frame", native * 1e3);
    let browser = Browser::start(&dir.join("profile"));
    for query in ["", "&webgl"] {
        // Not playing while it decodes: drawing on the software renderers
        // takes the same two cores, and the timings would measure that.
        browser.go(&format!("http://127.0.0.1:{port}/?src={file_name}{query}"));
        browser.wait(
            &format!("all of {name}"),
            &format!("const p = document.getElementById('a'); return (p.frames || []).length === {frames} && p.dataset.frame !== undefined;"),
            600,
        );
        let s = browser.js("return Object.assign({}, document.getElementById('a').stats);", json!([]));
        // Then play from the cache for a few seconds for the frame rate.
        browser.js("document.getElementById('a').play();", json!([]));
        std::thread::sleep(Duration::from_secs(4));
        let fps = browser.js("return document.getElementById('a').stats.fps;", json!([]));
        println!(
            "{label}, {:.0} kbit/s: {} first frame after {:.0} ms; WebCodecs {:.2} ms/frame, \
             reconstruction {:.2} ms/frame, playback {:.0} fps",
            s["kbps"].as_f64().unwrap_or(0.0),
            s["backend"],
            s["firstFrameMs"].as_f64().unwrap_or(0.0),
            s["decodeMs"].as_f64().unwrap_or(0.0),
            s["reconstructMs"].as_f64().unwrap_or(0.0),
            fps.as_f64().unwrap_or(0.0)
        );
    }
}

#[test]
#[ignore]
fn viewer_speed_on_samba_at_128() {
    viewer_speed("samba", 128, 30, false, None, false);
}

/// The skinned codec's file (format v17, 48 bones on the vertices) at the
/// QP where it is about as large as the closed loop's at 30.
#[test]
#[ignore]
fn viewer_speed_on_samba_skinned() {
    viewer_speed("samba", 128, 36, false, Some(48), true);
}

/// The same file without bones, for what the skinned prediction costs.
#[test]
#[ignore]
fn viewer_speed_on_samba_at_128_without_bones() {
    viewer_speed("samba", 128, 30, false, Some(0), false);
}

/// A file that uses cycle predictions (format v4), at the larger grid.
#[test]
#[ignore]
fn viewer_speed_on_horse_gallop_at_256() {
    viewer_speed("horse-gallop", 256, 30, true, None, false);
}

/// Page memory over a long motion (a measurement, like the speed runs):
/// `CGV_LONG=out/long/samba-10min.cgv cargo test --release --test browser
/// -- --ignored --nocapture viewer_memory` (docs/scripts/long/run.sh makes
/// the file). Plays a minute, sampling the JS heap (Chromium's
/// performance.memory, precise) and the wasm memory every 5 s, then seeks
/// to 90 % of the motion and back to 10 %, timing each seek.
#[test]
#[ignore]
fn viewer_memory_on_a_long_motion() {
    let Ok(long) = std::env::var("CGV_LONG") else { panic!("set CGV_LONG to a long .cgv file") };
    let (dir, _server, port) = site("memory");
    std::fs::copy(&long, dir.join("long.cgv")).unwrap();
    std::fs::write(dir.join("long.html"), LONG_PAGE.replace(" buffer=\"0.1\"", "")).unwrap();
    let browser = Browser::start(&dir.join("profile"));
    browser.go(&format!("http://127.0.0.1:{port}/long.html"));
    browser.wait("the first frame", "return document.getElementById('a').dataset.frame === '0';", 120);
    let sample = "const p = document.getElementById('a'); const m = performance.memory; \
        return import('/cgv-player.js').then((x) => x.loadWasm()).then((w) => [m.usedJSHeapSize / 1048576, \
        m.totalJSHeapSize / 1048576, w.memory.buffer.byteLength / 1048576, p.bufferedFrames, +p.dataset.frame]);";
    let sample = format!("const done = arguments[arguments.length - 1]; (() => {{ {sample} }})().then(done);");
    browser.js("document.getElementById('a').play(); return true;", json!([]));
    for k in 0..=12 {
        let v = browser.js_async(&sample, json!([]));
        println!(
            "{:>3} s: JS heap used {:.1} MiB (total {:.1}), wasm memory {:.1} MiB, {} frames held, frame {}",
            5 * k,
            v[0].as_f64().unwrap_or(0.0),
            v[1].as_f64().unwrap_or(0.0),
            v[2].as_f64().unwrap_or(0.0),
            v[3],
            v[4]
        );
        std::thread::sleep(Duration::from_secs(5));
    }
    let n = browser.js("return document.getElementById('a').header.frames;", json!([])).as_u64().unwrap();
    // Seeks to 90 %, back to 10 %, then to eight more seconds spread over
    // the motion (none held), each timed in the page from the request to
    // the seeked event (the frame is then shown).
    let mut times = Vec::new();
    for f in [n * 9 / 10, n / 10].into_iter().chain((1..=8).map(|k| (n * (2 * k + 1) / 18 + 7 * k) % n)) {
        browser.js(&format!("const p = document.getElementById('a'); p.pause(); window.log = []; window.seekStart = performance.now(); p.currentTime = {f} / p.header.fps; return true;"), json!([]));
        browser.wait(&format!("the seek to {f}"), "return window.log.includes('seeked');", 900);
        let ms = browser.js("return window.seekedAt - window.seekStart;", json!([])).as_f64().unwrap_or(f64::NAN);
        let v = browser.js_async(&sample, json!([]));
        println!(
            "seek to frame {f} of {n}: {ms:.0} ms; JS heap {:.1} MiB, wasm {:.1} MiB, {} frames held",
            v[0].as_f64().unwrap_or(0.0),
            v[2].as_f64().unwrap_or(0.0),
            v[3]
        );
        times.push(ms);
    }
    let worst = times.iter().copied().fold(0.0, f64::max);
    println!("seeks: worst {worst:.0} ms, mean {:.0} ms", times.iter().sum::<f64>() / times.len() as f64);
}

#[test]
fn the_decoder_package_is_a_small_first_download() {
    // Issue 19: the decoder alone (pkg-scripts/web.sh: no `render`
    // feature, wasm-opt -Oz) is at most 300 KB gzipped, for pages that
    // draw with three.js; the full package carries wgpu besides.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("www");
    let gzipped = |pkg: &str| {
        let wasm =
            std::fs::read(root.join(pkg).join("cgv_bg.wasm")).expect("build the packages with pkg-scripts/web.sh");
        // gzip -9 is deflate's best level plus an 18-byte frame.
        miniz_oxide::deflate::compress_to_vec(&wasm, 10).len() + 18
    };
    let (decoder, full) = (gzipped("pkg-decoder"), gzipped("pkg"));
    println!("decoder package {decoder} bytes gzipped, full package {full}");
    assert!(decoder <= 300_000, "the decoder package is {decoder} bytes gzipped");
    assert!(full > 2 * decoder, "the renderer went missing from the full package ({full} bytes)");
}

/// Sets player `a` to draw shaded.
fn draw_shaded(browser: &Browser) {
    browser.js("document.getElementById('a').setAttribute('mode', 'shaded'); return true;", json!([]));
}

/// Loads `file` in player `a`, waits until it is drawn textured, saves a
/// screenshot at `shot`, and counts its orange and its cream pixels.
fn textured_colours(browser: &Browser, file: &str, shot: &Path) -> (usize, usize) {
    browser.js(
        "const p = document.getElementById('a'); delete p.dataset.textured; p.load(arguments[0]); return true;",
        json!([file]),
    );
    browser.wait(
        &format!("{file}, textured"),
        "const p = document.getElementById('a'); return p.dataset.textured === 'yes';",
        60,
    );
    std::thread::sleep(Duration::from_millis(300));
    let (px, ch) = common::decode_png(&browser.screenshot(shot));
    let orange = px.chunks_exact(ch).filter(|p| p[0] as i32 > p[2] as i32 + 60 && p[0] > 120).count();
    let cream = px
        .chunks_exact(ch)
        .filter(|p| p[0] > 180 && p[1] > 170 && p[2] > 140 && p[0] as i32 - (p[2] as i32) < 60)
        .count();
    (orange, cream)
}

/// A skinned glTF from `cgv skin` plays in three.js as three.js plays any
/// skin: its own GLTFLoader finds a SkinnedMesh with every bone and the
/// residual's morph targets, the AnimationMixer moves it, and two times
/// give two pictures of a lit figure.
#[test]
fn a_skinned_gltf_from_cgv_skin_plays_in_three_js() {
    let (dir, _server, port) = site("skinned");
    let art = common::temp_dir("browser-skinned");
    let out = Command::new(env!("CARGO_BIN_EXE_cgv"))
        .args(["skin", "builtin:walk", "--frames", "0..24", "--bones", "12", "--morph-targets", "2", "-o"])
        .arg(dir.join("walk-skin.glb"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let browser = Browser::start(&dir.join("profile"));
    browser.go(&format!("http://127.0.0.1:{port}/three/skinned.html?src=../walk-skin.glb"));
    browser.wait("the skinned glTF in three.js", "return !!window.skinReady || !!window.skinError;", 60);
    let state = browser.js("return window.skinError ? { error: window.skinError } : window.skinState();", json!([]));
    assert!(state["error"].is_null(), "{state}");
    assert_eq!(
        (state["skinned"].clone(), state["bones"].clone(), state["vertices"].clone(), state["morphs"].clone()),
        (json!(true), json!(12), json!(6274), json!(2)),
        "{state}"
    );
    let bright = |png: &[u8]| {
        let (px, ch) = common::decode_png(png);
        px.chunks_exact(ch).filter(|p| p[..3].iter().map(|&c| c as u32).sum::<u32>() > 3 * 120).count()
    };
    let mut shots = Vec::new();
    for t in [0.0, 0.4] {
        browser.js(&format!("window.skinTime = {t}; return true;"), json!([]));
        std::thread::sleep(Duration::from_millis(300));
        shots.push(browser.screenshot(&art.join(format!("walk-skin-{t}.png"))));
    }
    for png in &shots {
        let lit = bright(png);
        assert!(lit > 1500, "{lit} lit pixels (see {})", art.display());
    }
    assert!(shots[0] != shots[1], "the bones did not move the figure (see {})", art.display());
}

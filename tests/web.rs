//! The wasm build in headless Chromium (wasm-bindgen-test): the container
//! reader and the reconstruction on the v1 to v6 fixtures give the native
//! decoder's positions; WebCodecs gives exactly openh264's samples; the
//! renderer draws on WebGPU and on WebGL2.
//!
//! Run by pkg-scripts/test.sh:
//! `cargo test --release --target wasm32-unknown-unknown --test web`
//! (runner, chromedriver and browser flags: .cargo/config.toml and
//! pkg-scripts/webdriver.json).
#![cfg(target_arch = "wasm32")]
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

use cgv::web::{Player, View};
use wasm_bindgen::prelude::*;
use wasm_bindgen_test::*;

wasm_bindgen_test_configure!(run_in_browser);

const GV: &[u8] = include_bytes!("fixtures/v1/walk-gv.cgv");
const GV_POS: &[u8] = include_bytes!("fixtures/v1/walk-gv.cgv.cgv.positions");
const CGV: &[u8] = include_bytes!("fixtures/v1/walk-cgv.cgv");
const CGV_POS: &[u8] = include_bytes!("fixtures/v1/walk-cgv.cgv.cgv.positions");
const MOTION: &[u8] = include_bytes!("fixtures/v2/walk-cgv-motion.cgv");
const MOTION_POS: &[u8] = include_bytes!("fixtures/v2/walk-cgv-motion.cgv.cgv.positions");
const MOTION3: &[u8] = include_bytes!("fixtures/v3/walk-cgv-motion.cgv");
const MOTION3_POS: &[u8] = include_bytes!("fixtures/v3/walk-cgv-motion.cgv.cgv.positions");
const CYCLE4: &[u8] = include_bytes!("fixtures/v4/walk-cgv-cycle.cgv");
const CYCLE4_POS: &[u8] = include_bytes!("fixtures/v4/walk-cgv-cycle.cgv.cgv.positions");
const FILTER5: &[u8] = include_bytes!("fixtures/v5/walk-cgv-filter.cgv");
const FILTER5_POS: &[u8] = include_bytes!("fixtures/v5/walk-cgv-filter.cgv.cgv.positions");
const SOURCE6: &[u8] = include_bytes!("fixtures/v6/walk-cgv-source.cgv");
const SOURCE6_POS: &[u8] = include_bytes!("fixtures/v6/walk-cgv-source.cgv.cgv.positions");
const SOURCE6_VERTICES: &[u8] = include_bytes!("fixtures/v6/walk-cgv-source.cgv.source.positions");
const OFFSETS7: &[u8] = include_bytes!("fixtures/v7/walk-cgv-offsets.cgv");
const OFFSETS7_POS: &[u8] = include_bytes!("fixtures/v7/walk-cgv-offsets.cgv.cgv.positions");
const OFFSETS7_VERTICES: &[u8] = include_bytes!("fixtures/v7/walk-cgv-offsets.cgv.source.positions");
const NORMAL9: &[u8] = include_bytes!("fixtures/v9/walk-cgv-normal.cgv");
const NORMAL9_POS: &[u8] = include_bytes!("fixtures/v9/walk-cgv-normal.cgv.cgv.positions");
const RELAX9: &[u8] = include_bytes!("fixtures/v9/walk-cgv-relax.cgv");
const RELAX9_POS: &[u8] = include_bytes!("fixtures/v9/walk-cgv-relax.cgv.cgv.positions");

#[wasm_bindgen(inline_js = r#"
const decoders = new Map();
function key(au) {
  for (let i = 0; i + 3 < au.length; i++) if (au[i] === 0 && au[i + 1] === 0 && au[i + 2] === 1 && (au[i + 3] & 31) === 5) return true;
  return false;
}
function codec(au) {
  for (let i = 0; i + 4 < au.length; i++) if (au[i] === 0 && au[i + 1] === 0 && au[i + 2] === 1 && (au[i + 3] & 31) === 7) {
    const h = (b) => b.toString(16).padStart(2, '0'); return `avc1.${h(au[i + 4])}${h(au[i + 5])}${h(au[i + 6])}`;
  }
  return 'avc1.42001f';
}
// One WebCodecs decoder per stream id; returns the n x n luma plane.
export async function webcodecs_luma(id, au, n, ts) {
  let d = decoders.get(id);
  if (!d) {
    d = { waiting: [] };
    d.dec = new VideoDecoder({
      output: async (f) => {
        const rect = { x: f.visibleRect.x, y: f.visibleRect.y, width: n, height: n };
        const buf = new Uint8Array(f.allocationSize({ rect }));
        const layout = await f.copyTo(buf, { rect });
        f.close();
        const out = new Uint8Array(n * n);
        for (let r = 0; r < n; r++) out.set(buf.subarray(layout[0].offset + r * layout[0].stride, layout[0].offset + r * layout[0].stride + n), r * n);
        d.waiting.shift().resolve(out);
      },
      error: (e) => d.waiting.splice(0).forEach((w) => w.reject(e)),
    });
    d.dec.configure({ codec: codec(au), optimizeForLatency: true });
    decoders.set(id, d);
  }
  const p = new Promise((resolve, reject) => d.waiting.push({ resolve, reject }));
  d.dec.decode(new EncodedVideoChunk({ type: key(au) ? 'key' : 'delta', timestamp: ts, data: au }));
  return p;
}
export function canvas(w, h) {
  const c = document.createElement('canvas');
  c.width = w; c.height = h;
  document.body.appendChild(c);
  return c;
}
// Pixels of a canvas that differ from the background, read through a 2D canvas.
export function figure_pixels(c) {
  const t = document.createElement('canvas');
  t.width = c.width; t.height = c.height;
  const g = t.getContext('2d');
  g.drawImage(c, 0, 0);
  const d = g.getImageData(0, 0, c.width, c.height).data;
  let n = 0;
  for (let i = 0; i < d.length; i += 4) if (d[i] > 60 || d[i + 1] > 60 || d[i + 2] > 60) n++;
  return n;
}
"#)]
extern "C" {
    async fn webcodecs_luma(id: String, au: Vec<u8>, n: u32, ts: u32) -> JsValue;
    fn canvas(w: u32, h: u32) -> web_sys::HtmlCanvasElement;
    fn figure_pixels(c: &web_sys::HtmlCanvasElement) -> u32;
}

fn floats(b: &[u8]) -> Vec<f32> {
    b.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

/// Decodes a whole file in the wasm Player with WebCodecs pictures.
async fn decode(name: &str, bytes: &[u8]) -> (Vec<f32>, Vec<Vec<Vec<u8>>>) {
    let mut p = Player::new("").unwrap();
    p.push(bytes).unwrap();
    let h = cgv::format::read(bytes).unwrap().header;
    let (mut out, mut lumas) = (Vec::new(), vec![Vec::new(); h.streams.len()]);
    for f in 0..h.frames {
        for s in 0..h.streams.len() {
            // Version 9: a stream's pictures may be on a coarser grid.
            let n = h.streams[s].size(h.grid);
            if p.has_frame(s, f) {
                let au = p.access_unit(s, f).unwrap();
                let l: Vec<u8> =
                    js_sys::Uint8Array::new(&webcodecs_luma(format!("{name}{s}"), au, n, f).await).to_vec();
                lumas[s].push(l.clone());
                p.supply_luma(s, l).unwrap();
            }
        }
        out.extend(p.decode_next().unwrap());
    }
    (out, lumas)
}

#[wasm_bindgen_test]
async fn webcodecs_samples_equal_openh264() {
    // The GV fixture's positions are its dequantized samples, so they pin
    // every sample the native decoder produced.
    let h = cgv::format::read(GV).unwrap().header;
    let want = floats(GV_POS);
    let (_, lumas) = decode("gv", GV).await;
    let n2 = (h.grid * h.grid) as usize;
    for (s, stream) in lumas.iter().enumerate() {
        let q = h.streams[s].quant;
        for (f, l) in stream.iter().enumerate() {
            for i in 0..n2 {
                let native = q.quantize(want[(f * n2 + i) * 3 + s]);
                assert_eq!(l[i], native, "stream {s} frame {f} sample {i}");
            }
        }
    }
}

#[wasm_bindgen_test]
async fn wasm_reconstruction_equals_native() {
    for (name, bytes, pos, tol) in [
        ("gv2", GV, GV_POS, 1e-6f32),
        ("cgv", CGV, CGV_POS, 1e-5),
        ("motion", MOTION, MOTION_POS, 1e-5),
        ("motion3", MOTION3, MOTION3_POS, 1e-5),
        ("cycle4", CYCLE4, CYCLE4_POS, 1e-5),
        ("filter5", FILTER5, FILTER5_POS, 1e-5),
        ("source6", SOURCE6, SOURCE6_POS, 1e-5),
        ("offsets7", OFFSETS7, OFFSETS7_POS, 1e-5),
        ("normal9", NORMAL9, NORMAL9_POS, 1e-5),
        ("relax9", RELAX9, RELAX9_POS, 1e-5),
    ] {
        let diag = cgv::format::read(bytes).unwrap().header.source.diagonal;
        let (got, _) = decode(name, bytes).await;
        let want = floats(pos);
        assert_eq!(got.len(), want.len());
        let worst = got.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
        assert!(worst <= tol * diag, "{name}: {worst} > {tol} of {diag}");
    }
}

#[wasm_bindgen_test]
async fn renderer_draws_on_webgpu_and_webgl2() {
    let x = floats(CGV_POS);
    let n2 = 16 * 16 * 3;
    let mut backends = Vec::new();
    for force_webgl in [false, true] {
        let c = canvas(160, 160);
        let mut v = View::create(c.clone(), 16, force_webgl).await.unwrap();
        v.set_frame(&x[..n2], "shaded").unwrap();
        v.draw().unwrap();
        let fig = figure_pixels(&c);
        backends.push(v.backend());
        assert!(fig > 800 && fig < 160 * 160 * 9 / 10, "{}: {fig} figure pixels", v.backend());
    }
    assert_eq!(backends, ["WebGPU", "WebGL2"]);
}

#[wasm_bindgen_test]
fn a_file_asking_for_more_memory_than_allowed_is_refused() {
    // The v5 fixture's decoder needs a few hundred KB; allowed 10 KB, the
    // player refuses it when its header arrives, before allocating.
    let mut p = Player::new("").unwrap();
    p.set_memory_limit_mib(0.01);
    let e = JsValue::from(p.push(FILTER5).err().expect("refused"));
    let msg = js_sys::Error::from(e).message().as_string().unwrap();
    assert!(msg.contains("more than the limit of 0.0 MiB"), "{msg}");
    // The default limit takes it.
    Player::new("").unwrap().push(FILTER5).unwrap();
}

#[wasm_bindgen_test]
fn the_player_gives_back_the_input_mesh_of_version_six_and_seven_files() {
    // The v6 and v7 fixtures' grid frames (their frozen positions) through
    // the player's source mesh give the frozen input vertices, as natively.
    for (file, pos, vertices) in [(OFFSETS7, OFFSETS7_POS, OFFSETS7_VERTICES), (SOURCE6, SOURCE6_POS, SOURCE6_VERTICES)]
    {
        let mut p = Player::new("").unwrap();
        assert!(p.source_faces().is_empty());
        p.push(file).unwrap();
        let h = cgv::format::read(file).unwrap().header;
        assert_eq!(p.source_faces().len(), 3 * 12544);
        let (grid, want) = (floats(pos), floats(vertices));
        let n = 3 * (h.grid * h.grid) as usize;
        let got: Vec<f32> = grid.chunks(n).flat_map(|g| p.source_vertices(g, &[], &[]).unwrap()).collect();
        assert_eq!(got.len(), want.len());
        let worst = got.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
        assert!(worst <= 1e-5 * h.source.diagonal, "{worst}");
        assert!(p.source_vertices(&grid[..9], &[], &[]).is_err());
        // These files have no loose vertices (format v11): none may be given.
        assert!(p.source_vertices(&grid[..n], &[0.0; 3], &[]).is_err());
        assert!(p.loose_vertices().is_empty());
    }
    let grid = floats(SOURCE6_POS);
    let n = 3 * 16 * 16;
    // A file without one says so.
    let mut q = Player::new("").unwrap();
    q.push(FILTER5).unwrap();
    assert!(q.source_faces().is_empty() && q.source_vertices(&grid[..n], &[], &[]).is_err());
}

#[wasm_bindgen_test]
async fn a_rewound_player_decodes_the_same_frames_again() {
    // A player that keeps a window of frames loops and seeks back by
    // rewinding to frame 0 with the bytes it holds: the same pictures give
    // the same positions, bit for bit.
    let (first, lumas) = decode("rewind", FILTER5).await;
    let h = cgv::format::read(FILTER5).unwrap().header;
    let mut p = Player::new("").unwrap();
    assert!(p.rewind().is_err(), "no header yet");
    p.push(FILTER5).unwrap();
    let mut again = Vec::new();
    for lap in 0..2 {
        let mut used = vec![0; h.streams.len()];
        for f in 0..h.frames {
            for s in 0..h.streams.len() {
                if p.has_frame(s, f) {
                    p.supply_luma(s, lumas[s][used[s]].clone()).unwrap();
                    used[s] += 1;
                }
            }
            let x = p.decode_next().unwrap();
            if lap == 1 {
                again.extend(x);
            }
        }
        p.rewind().unwrap();
        assert_eq!(p.next_frame(), 0);
    }
    assert_eq!(first, again);
}

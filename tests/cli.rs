//! The `cgv` binary as a user runs it.
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

mod common;

use std::path::Path;
use std::process::Command;

fn cgv(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_cgv")).args(args).output().unwrap()
}

#[test]
fn info_reports_the_default_motion() {
    let out = cgv(&["info", "builtin:walk", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["frames"], 72);
    assert_eq!(v["usable"], true);
    assert_eq!(v["topology"]["genus"], 0);
    let text = cgv(&["info", "builtin:walk"]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("ready for a geometry image"));
}

#[test]
fn remesh_writes_glb_png_and_reports_error() {
    let dir = common::temp_dir("cli-remesh");
    let glb = dir.join("walk.glb");
    let out =
        cgv(&["remesh", "builtin:walk", "-o", glb.to_str().unwrap(), "--grid", "32", "--error-stride", "24", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["grid_vertices"], 1024);
    assert_eq!(v["error"]["frames_measured"], 3);
    assert!(v["error"]["rms_mean"].as_f64().unwrap() < 0.02);
    // The map kept is the one whose grid lies closest to the reference frame.
    let passes = v["parameterization"]["area_passes"].as_u64().unwrap();
    assert!((1..=200).contains(&passes), "{passes} passes");
    assert!(v["parameterization"]["score"].as_f64().unwrap() > 0.0);
    assert!(glb.exists() && dir.join("walk.png").exists());
    let png = std::fs::read(dir.join("walk.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
}

/// `--fit-places` moves some of the input's places and brings its vertices
/// closer to the uncompressed grid; without it none move. `cgv encode`
/// takes it too, and the file decodes to the input's own mesh.
#[test]
fn fit_places_moves_places_and_lowers_the_floor() {
    let dir = common::temp_dir("cli-fit-places");
    let glb = dir.join("walk.glb");
    let remesh = |extra: &[&str]| -> serde_json::Value {
        let args =
            [&["remesh", "builtin:walk", "-o", glb.to_str().unwrap(), "--grid", "32", "--json"][..], extra].concat();
        let out = cgv(&args);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let (own, fit) = (remesh(&[]), remesh(&["--fit-places"]));
    assert_eq!(own["places_moved"], 0);
    assert!(fit["places_moved"].as_u64().unwrap() > 0, "{}", fit["places_moved"]);
    let rms = |v: &serde_json::Value| v["error"]["vertex_rms_mean"].as_f64().unwrap();
    assert!(rms(&fit) < rms(&own), "{} against {}", rms(&fit), rms(&own));
    let file = dir.join("walk.cgv");
    let out = encode_walk_gv16(&["--fit-places"], &file);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let decoded = dir.join("walk-decoded.glb");
    let out = cgv(&["decode", file.to_str().unwrap(), "-o", decoded.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn bad_input_fails_clearly_and_leaves_nothing() {
    let dir = common::temp_dir("cli-bad");
    let obj = dir.join("broken.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap();
    let out_glb = dir.join("out.glb");
    let out = cgv(&["remesh", obj.to_str().unwrap(), "-o", out_glb.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("broken.obj") && err.contains("uses vertex 4"), "{err}");
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left.len(), 1, "{left:?}");
    let out = cgv(&["info", dir.join("missing").to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing"));
    let out = cgv(&["remesh", "builtin:walk", "-o", out_glb.to_str().unwrap(), "--grid", "33"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("grid size 33"));
}

/// `cgv encode builtin:walk --codec gv --grid 16 EXTRA -o OUT`.
fn encode_walk_gv16(extra: &[&str], out: &std::path::Path) -> std::process::Output {
    let args =
        [&["encode", "builtin:walk", "--codec", "gv", "--grid", "16"][..], extra, &["-o", out.to_str().unwrap()]];
    cgv(&args.concat())
}

#[test]
fn each_codec_is_named_for_what_its_files_store() {
    // Issue 18, honest names: `--codec` names what the file stores, `cgv
    // info` reads it back from the streams, and the first round's `cgv`
    // is `auto`'s other name.
    let dir = common::temp_dir("cli-codec-names");
    let cases = [
        ("normal", &[][..], "normal"),
        ("predictive", &[][..], "predictive"),
        ("conformal", &[][..], "conformal"),
        ("gv", &[][..], "gv"),
        ("cgv", &["--qp", "40"][..], "predictive"),
        ("auto", &["--qp", "20"][..], "normal"),
    ];
    for (codec, extra, stored) in cases {
        let file = dir.join(format!("{codec}.cgv"));
        let args = [&["encode", "builtin:walk", "--frames", "0..3", "--grid", "16", "--codec", codec][..], extra];
        let out = cgv(&[&args.concat()[..], &["-o", file.to_str().unwrap()]].concat());
        assert!(out.status.success(), "{codec}: {}", String::from_utf8_lossy(&out.stderr));
        assert!(String::from_utf8_lossy(&out.stdout).contains(&format!("({stored} codec,")), "{codec}");
        let info = cgv(&["info", file.to_str().unwrap(), "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
        assert_eq!(v["codec"], stored, "{codec}");
        let text = cgv(&["info", file.to_str().unwrap()]);
        assert!(String::from_utf8_lossy(&text.stdout).contains(&format!("codec         {stored} (")), "{codec}");
    }
    // The conformal codec stores H and λ and no corrections; the others no λ.
    let streams = |codec: &str| -> Vec<String> {
        let info = cgv(&["info", dir.join(format!("{codec}.cgv")).to_str().unwrap(), "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
        v["header"]["streams"].as_array().unwrap().iter().map(|s| s["name"].as_str().unwrap().to_string()).collect()
    };
    let conformal = streams("conformal");
    let has = |s: &str| conformal.iter().any(|c| c == s);
    assert!(has("H") && has("lambda") && !has("dx"), "{conformal:?}");
    assert!(streams("normal").iter().any(|s| s == "dn"));
    // The paper's solver cannot read corrections: refused before any work, by name.
    let out = cgv(&["encode", "builtin:walk", "--codec", "normal", "--solver", "paper", "-o", "x.cgv"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--codec conformal"), "{err}");
    let out = cgv(&["encode", "builtin:walk", "--codec", "lambda", "-o", "x.cgv"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("conformal") && err.contains("normal"), "{err}");
}

#[test]
fn encode_info_and_decode_a_gv_file() {
    let dir = common::temp_dir("cli-codec");
    let cgv_file = dir.join("walk.cgv");
    let out =
        cgv(&["encode", "builtin:walk", "--codec", "gv", "--grid", "16", "-o", cgv_file.to_str().unwrap(), "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["report"]["frames"], 72);
    // --area-passes caps the passes, and the text report names the grid's error.
    let capped = dir.join("capped.cgv");
    let out = encode_walk_gv16(&["--area-passes", "10"], &capped);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("grid: resamples the reference frame to"), "{text}");
    let line = text.lines().find(|l| l.contains("area-correction passes kept")).unwrap_or_default();
    let kept = line.split("; ").nth(1).and_then(|t| t.split(' ').next()).and_then(|n| n.parse::<u32>().ok());
    assert!(kept.is_some_and(|k| (1..=10).contains(&k)), "{text}");
    let info = cgv(&["info", cgv_file.to_str().unwrap(), "--json"]);
    assert!(info.status.success(), "{}", String::from_utf8_lossy(&info.stderr));
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(v["header"]["codec"], "gv");
    assert_eq!(v["header"]["grid"], 16);
    // The file carries the input's mesh (format version 6, offsets from 7): decode gives
    // back its 6274 vertices and 12544 faces, or the grid mesh when asked.
    let glb = dir.join("decoded.glb");
    let dec = cgv(&["decode", cgv_file.to_str().unwrap(), "-o", glb.to_str().unwrap(), "--json"]);
    assert!(dec.status.success(), "{}", String::from_utf8_lossy(&dec.stderr));
    let v: serde_json::Value = serde_json::from_slice(&dec.stdout).unwrap();
    assert_eq!(
        (v["mesh"].as_str(), v["vertices"].as_u64(), v["faces"].as_u64()),
        (Some("source"), Some(6274), Some(12544))
    );
    // As OBJ frames, the input's own vertices in its order: frame 40 lies
    // within the coarse N = 16 grid's reach of the input's frame 40 (measured
    // 2.93 % of the diagonal: the grid is 256 samples for 6274 vertices).
    let objs = dir.join("decoded");
    let dec = cgv(&["decode", cgv_file.to_str().unwrap(), "-o", objs.to_str().unwrap()]);
    assert!(dec.status.success(), "{}", String::from_utf8_lossy(&dec.stderr));
    let (rebuilt, faces) = cgv::mesh::obj::read_obj(&objs.join("frame_0040.obj")).unwrap();
    let walk = cgv::mesh::builtin::motion(72);
    assert_eq!(rebuilt.len(), 6274);
    assert_eq!(common::sorted_faces(&faces), common::sorted_faces(&walk.topology.faces));
    let (rms, _) = cgv::metrics::vertex_error(&rebuilt, &walk.frames[40]);
    let diagonal = cgv::mesh::Bounds::of(&walk.frames[40]).diagonal() as f64;
    eprintln!("source vertices at N = 16: RMS {:.3} % of the diagonal", 100.0 * rms / diagonal);
    assert!(rms / diagonal < 0.05, "{rms}");
    let grid_glb = dir.join("grid.glb");
    let dec = cgv(&["decode", cgv_file.to_str().unwrap(), "-o", grid_glb.to_str().unwrap(), "--mesh", "grid"]);
    assert!(dec.status.success(), "{}", String::from_utf8_lossy(&dec.stderr));
    let back = cgv::mesh::open_sequence(grid_glb.to_str().unwrap(), &Default::default()).unwrap();
    assert_eq!((back.frame_count(), back.topology().vertex_count), (72, 256));
    // Without the source mesh the file is smaller, and --mesh source is refused by name.
    let plain = dir.join("plain.cgv");
    let out = encode_walk_gv16(&["--no-source-mesh"], &plain);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::metadata(&plain).unwrap().len() < std::fs::metadata(&cgv_file).unwrap().len());
    let dec = cgv(&["decode", plain.to_str().unwrap(), "-o", dir.join("p.glb").to_str().unwrap(), "--mesh", "source"]);
    assert!(
        String::from_utf8_lossy(&dec.stderr).contains("carries no source mesh"),
        "{}",
        String::from_utf8_lossy(&dec.stderr)
    );

    // A damaged file: a clear error naming it, and no output left behind.
    let mut bytes = std::fs::read(&cgv_file).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x40;
    let bad = dir.join("bad.cgv");
    std::fs::write(&bad, &bytes).unwrap();
    let bad_out = dir.join("bad.glb");
    let dec = cgv(&["decode", bad.to_str().unwrap(), "-o", bad_out.to_str().unwrap()]);
    assert!(!dec.status.success());
    let err = String::from_utf8_lossy(&dec.stderr);
    assert!(err.contains("bad.cgv") && err.contains("CRC"), "{err}");
    assert!(!bad_out.exists());
    let e = cgv(&["encode", "builtin:walk", "-o", dir.join("x.mp4").to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&e.stderr).contains(".cgv"));
}

#[test]
fn encode_info_and_decode_motion_corrections() {
    let dir = common::temp_dir("cli-motion");
    let f = dir.join("walk.cgv");
    let args = ["encode", "builtin:walk", "--frames", "0..8", "--grid", "16", "--corrections", "motion"];
    let out = cgv(&[&args[..], &["-o", f.to_str().unwrap()]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let info = cgv(&["info", f.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&info.stdout);
    let version = format!("format version {}", cgv::format::VERSION);
    assert!(text.contains(&version) && text.contains("corrections   motion"), "{text}");
    assert!(text.contains("random access frame 0 only"), "{text}");
    let info = cgv(&["info", f.to_str().unwrap(), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(
        (v["version"].as_u64(), v["header"]["corrections"].as_str()),
        (Some(cgv::format::VERSION as u64), Some("motion"))
    );
    assert_eq!(v["filters"].as_array().map(Vec::len), Some(8));
    // At a coarse QP the encoder filters corrections, and info says so;
    // --no-correction-filter leaves every frame's filter at 0.
    for (flag, filtered) in [(None, true), (Some("--no-correction-filter"), false)] {
        let coarse = dir.join("coarse.cgv");
        let mut a = args.to_vec();
        a.extend(["--qp", "48", "-o", coarse.to_str().unwrap()]);
        a.extend(flag);
        let out = cgv(&a);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let text = String::from_utf8_lossy(&cgv(&["info", coarse.to_str().unwrap()]).stdout).to_string();
        assert_eq!(text.contains("filtered on"), filtered, "{flag:?}: {text}");
    }
    // Corrections every second frame: frames 0, 1, 3, 5, 7 carry them.
    let sparse = dir.join("sparse.cgv");
    let out = cgv(&[&args[..], &["--correction-interval", "2", "-o", sparse.to_str().unwrap()]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let info = cgv(&["info", sparse.to_str().unwrap(), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(v["header"]["key_frames"], serde_json::json!([0, 1, 3, 5, 7]));
    let dec = cgv(&["decode", sparse.to_str().unwrap(), "-o", dir.join("sparse.glb").to_str().unwrap()]);
    assert!(dec.status.success(), "{}", String::from_utf8_lossy(&dec.stderr));
    let zero = cgv(&[&args[..], &["--correction-interval", "0", "-o", sparse.to_str().unwrap()]].concat());
    assert!(!zero.status.success());
    // Random-access points every 0.1 s (3 frames): the points restart the
    // key frames; decoding frames 5..8 starts at point 3 and says so.
    let points = dir.join("points.cgv");
    let out =
        cgv(&[&args[..], &["--correction-interval", "2", "--random-access", "0.1"], &["-o", points.to_str().unwrap()]]
            .concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&cgv(&["info", points.to_str().unwrap()]).stdout).to_string();
    assert!(text.contains("random access every 3 frames (0.10 s): 3 points"), "{text}");
    let v: serde_json::Value =
        serde_json::from_slice(&cgv(&["info", points.to_str().unwrap(), "--json"]).stdout).unwrap();
    assert_eq!(v["header"]["key_frames"], serde_json::json!([0, 1, 3, 4, 6, 7]));
    let part = dir.join("part");
    let dec =
        cgv(&["decode", points.to_str().unwrap(), "--frames", "5..8", "--mesh", "grid", "-o", part.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&dec.stdout).to_string();
    assert!(dec.status.success() && text.contains("started at frame 3") && text.contains("2 frames decoded"), "{text}");
    assert_eq!(
        std::fs::read_dir(&part)
            .unwrap()
            .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "obj"))
            .count(),
        3
    );
    let bad = cgv(&["decode", points.to_str().unwrap(), "--frames", "5..9", "-o", part.to_str().unwrap()]);
    assert!(
        String::from_utf8_lossy(&bad.stderr).contains("--frames 5..9 are not inside its 8 frames"),
        "{}",
        String::from_utf8_lossy(&bad.stderr)
    );
    // A range that starts past the end is refused by the same rule on input
    // (it once left a frame count below zero).
    let past = dir.join("past.cgv");
    let bad = cgv(&["encode", "builtin:walk", "--frames", "500..", "-o", past.to_str().unwrap()]);
    let e = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && e.contains("frames 500..72 are not inside its 72 frames"), "{e}");
    assert!(!past.exists());
    let bad = cgv(&[&args[..], &["--random-access=-1", "-o", points.to_str().unwrap()]].concat());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("random-access"), "{}", String::from_utf8_lossy(&bad.stderr));
    // Scaled corrections have no interval: refused by name, nothing written.
    let scaled = dir.join("scaled.cgv");
    let out = cgv(&["encode", "builtin:walk", "--frames", "0..4", "--grid", "16", "--corrections", "scaled"]
        .iter()
        .chain(&["--correction-interval", "2", "-o", scaled.to_str().unwrap()])
        .copied()
        .collect::<Vec<_>>());
    assert!(String::from_utf8_lossy(&out.stderr).contains("motion corrections") && !scaled.exists());
    let glb = dir.join("decoded.glb");
    let dec = cgv(&["decode", f.to_str().unwrap(), "-o", glb.to_str().unwrap()]);
    assert!(dec.status.success(), "{}", String::from_utf8_lossy(&dec.stderr));
    let bad = cgv(&["encode", "builtin:walk", "--corrections", "sideways", "-o", f.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&bad.stderr).contains("scaled"), "{}", String::from_utf8_lossy(&bad.stderr));
}

#[test]
fn eval_writes_reports_and_plots_or_nothing() {
    let dir = common::temp_dir("cli-eval");
    let p = |n: &str| dir.join(n).to_str().unwrap().to_string();
    // A bad plot name is refused before any work, and nothing is written.
    let out =
        cgv(&["eval", "builtin:walk", "--frames", "0..4", "--grid", "32", "--md", &p("r.md"), "--plot", &p("r.gif")]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains(".svg or .png"));
    assert!(!dir.join("r.md").exists());
    let out = cgv(&[
        "eval",
        "builtin:walk",
        "--frames",
        "0..6",
        "--grid",
        "32",
        "--codecs",
        "gv,cgv",
        "--rates",
        "medium,high",
        "--surface-every",
        "3",
        "--md",
        &p("r.md"),
        "--json",
        &p("r.json"),
        "--plot",
        &p("r.svg"),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("r.json")).unwrap()).unwrap();
    assert_eq!(v["points"].as_array().unwrap().len(), 2);
    assert_eq!(v["frames"], 6);
    // `cgv`, the first round's name, runs the predictive codec and is reported by its name.
    assert_eq!(v["points"][0]["results"][1]["codec"], "predictive");
    assert!(std::fs::read_to_string(dir.join("r.md")).unwrap().contains("Table 2"));
    for svg in ["r.svg", "r-frames.svg"] {
        let s = std::fs::read_to_string(dir.join(svg)).unwrap();
        assert!(s.starts_with("<svg") && s.contains("predictive"), "{svg}");
    }
    // No temporary files left beside the reports.
    let names: Vec<String> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    assert_eq!(names.len(), 4, "{names:?}");
}

/// Counts pixels that differ from the renderer's background.
fn figure_pixels(png_path: &std::path::Path) -> (usize, usize) {
    let (px, ch) = common::decode_png(&std::fs::read(png_path).unwrap());
    let bg = cgv::render::BACKGROUND;
    let fig = px.chunks_exact(ch).filter(|p| p[..3].iter().zip(bg).any(|(a, b)| a.abs_diff(b) > 8)).count();
    (fig, px.len() / ch)
}

#[test]
fn render_draws_the_figure_offscreen() {
    let dir = common::temp_dir("cli-render");
    let fixture = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/v1/walk-cgv.cgv");
    let gv = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/v1/walk-gv.cgv");
    for (mode, extra) in [("shaded", vec![]), ("h", vec![]), ("lambda", vec![]), ("error", vec!["--reference", gv])] {
        let out_png = dir.join(format!("{mode}.png"));
        let mut args = vec!["render", fixture, "--frame", "3", "--size", "200x160", "--mode", mode, "-o"];
        args.push(out_png.to_str().unwrap());
        args.extend(extra);
        let out = cgv(&args);
        assert!(out.status.success(), "{mode}: {}", String::from_utf8_lossy(&out.stderr));
        let (fig, all) = figure_pixels(&out_png);
        // The figure covers a good part of the frame, but not all of it.
        assert!(fig > all / 20 && fig < all * 9 / 10, "{mode}: {fig} of {all} pixels");
    }
    let out = cgv(&["render", fixture, "--frame", "9", "-o", dir.join("x.png").to_str().unwrap()]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("has 4"));
    let out = cgv(&["render", fixture, "--mode", "error", "-o", dir.join("y.png").to_str().unwrap()]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("--reference"));
}

/// The command's standard error as text.
fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn bad_options_fail_by_name_before_the_motion_is_read() {
    // The input does not exist: each option's error must come first.
    let dir = common::temp_dir("cli-options");
    let out_file = dir.join("o.cgv");
    let o = out_file.to_str().unwrap();
    let cases: [(&[&str], &str); 5] = [
        (&["--grid", "2200"], "grid size 2200 must be even and in 16..=2160"),
        (&["--grid", "8"], "grid size 8 must be even and in 16..=2160"),
        (&["--qp", "60"], "QP 60 is not in 0..=51"),
        (&["--kbps", "0"], "a bitrate of 0 kbit/s is not above 0"),
        (&["--layers", "3"], "layers must be 1 or 2"),
    ];
    for (extra, want) in cases {
        let mut args = vec!["encode", "no-such-motion", "-o", o];
        args.extend_from_slice(extra);
        let out = cgv(&args);
        let err = stderr(&out);
        assert!(!out.status.success() && err.contains(want) && !err.contains("no-such-motion"), "{extra:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{extra:?}: one line, said once: {err}");
    }
    // A missing output folder is named as such, before any work.
    let out = cgv(&["encode", "no-such-motion", "-o", "no-such-dir/o.cgv"]);
    assert!(stderr(&out).contains("no-such-dir/o.cgv: the folder no-such-dir does not exist"), "{}", stderr(&out));
    assert!(std::fs::read_dir(&dir).unwrap().next().is_none(), "nothing written");
}

#[test]
fn a_bad_file_is_reported_once() {
    let dir = common::temp_dir("cli-once");
    let zero = dir.join("zero.cgv");
    std::fs::write(&zero, [0u8; 64]).unwrap();
    let out = cgv(&["decode", zero.to_str().unwrap(), "-o", dir.join("z.glb").to_str().unwrap()]);
    let err = stderr(&out);
    assert_eq!(err.trim(), format!("error: {}: not a .cgv file (bad magic number)", zero.display()), "{err}");
}

/// A one-frame motion-corrected file whose header asks a decoder for a
/// 2160 x 2160 grid and 255 past velocities (about 14 GB), with one-byte
/// access units that are no H.264 at all.
fn greedy_file() -> Vec<u8> {
    use cgv::format::{self, stream, Coverage, FrameInfo, Header, Quantizer, StreamInfo};
    let stream = |name, coverage| StreamInfo {
        name,
        layer: 1,
        refines: None,
        quant: Quantizer::new(-1.0, 1.0),
        coverage,
        scaled: false,
        shrink: 0,
    };
    let mut streams: Vec<StreamInfo> = stream::SEED.map(|n| stream(n, Coverage::First)).to_vec();
    streams.extend(stream::CORRECTION.map(|n| stream(n, Coverage::All)));
    let header = Header {
        grid: 2160,
        seam: format::SEAM_RULE.into(),
        frames: 1,
        fps: 30.0,
        codec: format::CodecKind::Cgv,
        streams,
        key_frames: vec![0],
        anchors: vec![],
        solver: format::SolverKind::Predictive,
        settings: format::Settings { qp: 20, kbps: None, gop: 30, cabac: true, layers: 1, residual_steps: 0.0 },
        source: Default::default(),
        corrections: format::CorrectionMode::Motion,
        max_lag: 255,
        source_mesh: None,
        appearance: None,
        random_access: None,
        skin: None,
        segments: Vec::new(),
        frame_meshes: false,
        vertex_residual: None,
    };
    let mut bytes = format::write_header(&header).unwrap();
    bytes.extend(format::write_frame(0, &FrameInfo::default(), &[&[1u8][..]; 6]));
    bytes.extend(format::write_chunk(format::TAG_END, 0, 1, &[]));
    bytes
}

#[test]
fn a_file_asking_for_too_much_memory_is_refused() {
    let dir = common::temp_dir("cli-memory");
    let path = dir.join("greedy.cgv");
    std::fs::write(&path, greedy_file()).unwrap();
    let glb = dir.join("g.glb");
    let out = cgv(&["decode", path.to_str().unwrap(), "-o", glb.to_str().unwrap()]);
    let err = stderr(&out);
    assert!(!out.status.success() && err.contains("more than the limit of 1024.0 MiB"), "{err}");
    // Allowed more, it gets as far as H.264, which refuses the bytes.
    let out = cgv(&["decode", path.to_str().unwrap(), "-o", glb.to_str().unwrap(), "--memory-limit", "20000"]);
    let err = stderr(&out);
    assert!(!out.status.success() && err.contains("H.264") && !err.contains("limit"), "{err}");
    assert!(!glb.exists());
}

/// Runs the Khronos glTF-Validator (tests/node, installed by
/// pkg-scripts/setup.sh) on `files`; returns each file's report line.
fn validate_gltf(files: &[&std::path::Path]) -> Vec<serde_json::Value> {
    let here = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/node");
    assert!(here.join("node_modules/gltf-validator").exists(), "run pkg-scripts/setup.sh (npm ci in tests/node)");
    let out = Command::new("node").arg(here.join("validate-gltf.mjs")).args(files).output().unwrap();
    String::from_utf8_lossy(&out.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

#[test]
fn every_glb_we_write_passes_the_khronos_validator() {
    let dir = common::temp_dir("cli-gltf-valid");
    let p = |n: &str| dir.join(n).to_str().unwrap().to_string();
    let ok = |out: std::process::Output| assert!(out.status.success(), "{}", stderr(&out));
    ok(cgv(&["remesh", "builtin:walk", "--frames", "0..5", "--grid", "16", "-o", &p("remesh.glb")]));
    ok(cgv(&["encode", "builtin:walk", "--frames", "0..5", "--grid", "16", "-o", &p("w.cgv")]));
    ok(cgv(&["decode", &p("w.cgv"), "-o", &p("decoded.glb")]));
    ok(cgv(&["remesh", "builtin:walk", "--frames", "0..1", "--grid", "16", "-o", &p("one-frame.glb")]));
    let files = ["remesh.glb", "decoded.glb", "one-frame.glb"].map(|n| dir.join(n));
    let reports = validate_gltf(&files.iter().map(|f| f.as_path()).collect::<Vec<_>>());
    assert_eq!(reports.len(), 3);
    for r in &reports {
        assert_eq!(r["errors"], 0, "{r}");
    }
    // The validator finds what it should: the stride-less shared view that
    // the writer once produced is an error.
    let glb = std::fs::read(&files[0]).unwrap();
    let json_len = u32::from_le_bytes([glb[12], glb[13], glb[14], glb[15]]) as usize;
    let mut doc: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    assert_eq!(doc["bufferViews"][1]["byteStride"], 12);
    // Recomputed normals, unit length (the validator checks that), as morph targets too.
    let prim = &doc["meshes"][0]["primitives"][0];
    assert!(prim["attributes"]["NORMAL"].is_u64() && prim["targets"][0]["NORMAL"].is_u64(), "{prim}");
    doc["bufferViews"][1].as_object_mut().unwrap().remove("byteStride");
    let mut json = serde_json::to_vec(&doc).unwrap();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let mut broken = glb[..12].to_vec();
    broken.extend((json.len() as u32).to_le_bytes());
    broken.extend(b"JSON");
    broken.extend(&json);
    broken.extend(&glb[20 + json_len..]);
    let total = broken.len() as u32;
    broken[8..12].copy_from_slice(&total.to_le_bytes());
    let bad = dir.join("stride-less.glb");
    std::fs::write(&bad, broken).unwrap();
    let r = &validate_gltf(&[bad.as_path()])[0];
    assert!(r["errors"].as_u64().unwrap() > 0, "{r}");
    assert!(r["messages"].to_string().contains("MESH_PRIMITIVE_ACCESSOR_WITHOUT_BYTESTRIDE"), "{r}");
}

#[test]
fn a_textured_gltf_comes_back_with_its_uvs_and_texture() {
    // Fox.gltf: skinned, a 1024 x 1024 PNG, 1728 stored vertices split at
    // UV seams (290 welded, which the grid is made of).
    let fox = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/gltf/Fox.gltf");
    let dir = common::temp_dir("cli-textured");
    let (cgv_file, glb) = (dir.join("fox.cgv"), dir.join("fox.glb"));
    let fox_arg = fox.to_str().unwrap();
    let out = cgv(&["encode", fox_arg, "--frames", "0..3", "--grid", "32", "-o", cgv_file.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let info = String::from_utf8_lossy(&cgv(&["info", cgv_file.to_str().unwrap()]).stdout).to_string();
    let version = format!("format version {}", cgv::format::VERSION);
    assert!(info.contains(&version) && info.contains("1728 vertices"), "{info}");
    let out = cgv(&["decode", cgv_file.to_str().unwrap(), "-o", glb.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(validate_gltf(&[glb.as_path()])[0]["errors"], 0);
    // Read back with the gltf crate: the input's UVs, material and image.
    let input = cgv::mesh::open_sequence(fox_arg, &Default::default()).unwrap();
    let look = &input.appearance().expect("Fox has UVs and a texture").look;
    let g = gltf::Gltf::from_slice(&std::fs::read(&glb).unwrap()).unwrap();
    let blob = g.blob.as_deref().unwrap();
    let prim = g.document.meshes().next().unwrap().primitives().next().unwrap();
    let uvs: Vec<[f32; 2]> = prim.reader(|_| Some(blob)).read_tex_coords(0).unwrap().into_f32().collect();
    assert_eq!(uvs, look.uvs);
    let material = prim.material();
    let texture = material.pbr_metallic_roughness().base_color_texture().expect("a base colour texture");
    let gltf::image::Source::View { view, mime_type } = texture.texture().source().source() else {
        panic!("the image is not embedded")
    };
    let (mime, png) = look.texture.as_ref().unwrap();
    assert_eq!((mime_type, &blob[view.offset()..view.offset() + view.length()]), (mime.as_str(), &png[..]));
    assert_eq!(&png[1..4], b"PNG");
    // An OBJ folder: vt per vertex (v flipped, OBJ's way), a material and the PNG beside.
    let objs = dir.join("frames");
    let out = cgv(&["decode", cgv_file.to_str().unwrap(), "-o", objs.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(std::fs::read(objs.join("texture.png")).unwrap(), *png);
    assert!(std::fs::read_to_string(objs.join("material.mtl")).unwrap().contains("map_Kd texture.png"));
    let text = std::fs::read_to_string(objs.join("frame_0000.obj")).unwrap();
    let vt: Vec<&str> = text.lines().filter(|l| l.starts_with("vt ")).collect();
    assert_eq!(vt.len(), 1728);
    assert_eq!(vt[7], format!("vt {} {}", look.uvs[7][0], 1.0 - look.uvs[7][1]));
    // And it reads back as a sequence of the stored vertices.
    let again = cgv::mesh::open_sequence(objs.to_str().unwrap(), &Default::default()).unwrap();
    assert_eq!((again.frame_count(), again.topology().vertex_count), (3, 1728));
}

#[test]
fn the_built_in_figure_comes_textured_when_asked() {
    // builtin:walk-textured: the default motion with cylindrical UVs (its
    // seam split) and a 64 x 64 PNG of checks, a textured input without a file.
    let dir = common::temp_dir("cli-builtin-textured");
    let (cgv_file, glb) = (dir.join("walk.cgv"), dir.join("walk.glb"));
    let out =
        cgv(&["encode", "builtin:walk-textured", "--frames", "0..4", "--grid", "32", "-o", cgv_file.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let info = String::from_utf8_lossy(&cgv(&["info", cgv_file.to_str().unwrap()]).stdout).to_string();
    assert!(info.contains("image/png"), "{info}");
    let out = cgv(&["decode", cgv_file.to_str().unwrap(), "-o", glb.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(validate_gltf(&[glb.as_path()])[0]["errors"], 0);
    let input = cgv::mesh::open_sequence("builtin:walk-textured", &Default::default()).unwrap();
    let a = input.appearance().expect("UVs and a texture");
    // Welded to the motion's own vertices, some split at the seam.
    assert!(a.welded.len() > input.topology().vertex_count);
    assert!(a.welded.iter().all(|&w| (w as usize) < input.topology().vertex_count));
    let g = gltf::Gltf::from_slice(&std::fs::read(&glb).unwrap()).unwrap();
    let blob = g.blob.as_deref().unwrap();
    let prim = g.document.meshes().next().unwrap().primitives().next().unwrap();
    let uvs: Vec<[f32; 2]> = prim.reader(|_| Some(blob)).read_tex_coords(0).unwrap().into_f32().collect();
    assert_eq!(uvs, a.look.uvs);
    // No face spans more than half a turn of u: the seam is split.
    for f in &a.faces {
        let u = f.map(|v| a.look.uvs[v as usize][0]);
        assert!(u.iter().fold(0f32, |m, &x| m.max(x)) - u.iter().fold(2f32, |m, &x| m.min(x)) <= 0.5, "{f:?}");
    }
    assert!(prim.material().pbr_metallic_roughness().base_color_texture().is_some());
}

/// One raw HTTP/1.1 request to `cgv serve`: the status line, the headers
/// (lower-case names) and the body.
fn http_get(port: u16, path: &str, range: Option<&str>) -> (String, Vec<(String, String)>, Vec<u8>) {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    let range = range.map_or(String::new(), |r| format!("Range: {r}\r\n"));
    write!(s, "GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n{range}\r\n").unwrap();
    let mut all = Vec::new();
    s.read_to_end(&mut all).unwrap();
    let split = all.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8_lossy(&all[..split]).to_string();
    let mut lines = head.lines();
    let status = lines.next().unwrap().to_string();
    let headers = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_string()))
        .collect();
    (status, headers, all[split + 4..].to_vec())
}

#[test]
fn serve_answers_byte_ranges() {
    // A player seeks in a long file by fetching byte ranges (issue 19).
    let dir = common::temp_dir("cli-serve");
    let body: Vec<u8> = (0..5000u32).map(|i| (i * 7 % 251) as u8).collect();
    std::fs::write(dir.join("motion.cgv"), &body).unwrap();
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_cgv"))
        .args(["serve", dir.to_str().unwrap(), "--port", &port.to_string()])
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    struct Kill(std::process::Child);
    impl Drop for Kill {
        fn drop(&mut self) {
            let _ = self.0.kill();
        }
    }
    let _server = Kill(child);
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(std::time::Instant::now() < deadline, "cgv serve did not start");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let header = |h: &[(String, String)], k: &str| h.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone());
    let (status, h, whole) = http_get(port, "/motion.cgv", None);
    assert!(status.contains("200"), "{status}");
    assert_eq!((whole, header(&h, "accept-ranges")), (body.clone(), Some("bytes".into())));
    let (status, h, part) = http_get(port, "/motion.cgv", Some("bytes=1000-1999"));
    assert!(status.contains("206"), "{status}");
    assert_eq!(part, body[1000..2000]);
    assert_eq!(header(&h, "content-range"), Some("bytes 1000-1999/5000".into()));
    let (_, _, tail) = http_get(port, "/motion.cgv", Some("bytes=-100"));
    assert_eq!(tail, body[4900..]);
    let (status, h, _) = http_get(port, "/motion.cgv", Some("bytes=6000-"));
    assert!(status.contains("416"), "{status}");
    assert_eq!(header(&h, "content-range"), Some("bytes */5000".into()));
    let (status, _, _) = http_get(port, "/../secret", None);
    assert!(status.contains("404"), "{status}");
}

#[test]
fn a_manifest_encodes_many_skips_what_is_done_and_reports_failures() {
    // Issue 20: many inputs to outputs in one process, done jobs skipped,
    // outputs atomic, a failed job not stopping the others, the same bytes
    // every time.
    let dir = common::temp_dir("cli-manifest");
    let jobs = r#"[
        {"input": "builtin:walk", "output": "a.cgv", "args": ["--frames", "0..3"]},
        {"input": "builtin:walk", "output": "b.cgv", "args": ["--frames", "0..3", "--qp", "36"]},
        {"input": "missing/frames", "output": "c.cgv"}
    ]"#;
    std::fs::write(dir.join("jobs.json"), jobs).unwrap();
    let m = dir.join("jobs.json");
    let run = || cgv(&["encode", "--manifest", m.to_str().unwrap(), "--grid", "16", "--no-source-mesh"]);
    let out = run();
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(!out.status.success(), "a failed job fails the run");
    assert!(text.contains("3 jobs: 2 encoded, 0 skipped (done before), 1 failed"), "{text}");
    assert!(stderr(&out).contains("c.cgv: failed: ") && stderr(&out).contains("missing/frames"), "{}", stderr(&out));
    assert!(!dir.join("c.cgv").exists(), "no output for the failed job");
    let a = std::fs::read(dir.join("a.cgv")).unwrap();
    assert!(cgv::format::read(&a).is_ok());
    // Run again: both done jobs are skipped.
    let text = String::from_utf8_lossy(&run().stdout).to_string();
    assert!(text.contains("0 encoded, 2 skipped"), "{text}");
    // A job whose options changed is done again; the same job gives the same bytes.
    let changed = jobs.replace(r#""--qp", "36""#, r#""--qp", "30""#);
    std::fs::write(&m, changed).unwrap();
    std::fs::remove_file(dir.join("a.cgv")).unwrap();
    let text = String::from_utf8_lossy(&run().stdout).to_string();
    assert!(text.contains("2 encoded, 0 skipped"), "{text}");
    assert_eq!(std::fs::read(dir.join("a.cgv")).unwrap(), a, "the encoder is deterministic");
    // A bad manifest is an error naming the file.
    std::fs::write(&m, "{\"input\": 1}").unwrap();
    let out = run();
    assert!(!out.status.success() && stderr(&out).contains("not a manifest"), "{}", stderr(&out));
}

/// Issue 20: with the defaults (`--grid auto`, `--codec auto`) a budget
/// picks the grid first (256 from 1.2 bits per 128 x 128 sample a frame),
/// then the codec on that grid (normal from 0.25 to 1.3 bits per grid
/// sample a frame, predictive above), and the file is on budget.
#[test]
fn grid_auto_picks_the_grid_then_the_codec_for_a_budget() {
    let dir = common::temp_dir("cli-grid-auto");
    // The default motion is 72 frames at 30 fps: 300 kbit/s is 0.61 bits
    // per 128² sample a frame; 3000 is 6.1, which is 1.5 per 256² sample.
    for (kbps, grid, codec) in [(300.0, 128, "normal"), (3000.0, 256, "predictive")] {
        let file = dir.join(format!("{kbps}.cgv"));
        let args = ["encode", "builtin:walk", "--no-source-mesh", "--kbps", &kbps.to_string()];
        let out = cgv(&[&args[..], &["-o", file.to_str().unwrap()]].concat());
        assert!(out.status.success(), "{kbps}: {}", String::from_utf8_lossy(&out.stderr));
        let info = cgv(&["info", file.to_str().unwrap(), "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
        assert_eq!((v["header"]["grid"].as_u64(), v["codec"].as_str()), (Some(grid), Some(codec)), "{kbps}");
        let rate = std::fs::metadata(&file).unwrap().len() as f64 * 8.0 / 1000.0 / (72.0 / 30.0);
        assert!((rate / kbps - 1.0).abs() <= 0.05, "{kbps} kbit/s asked, {rate:.1} made");
    }
    // Each pass streamed into a file of its own: only the kept ones are
    // left, and a refused budget leaves nothing, partial or whole.
    let refused = dir.join("refused.cgv");
    let out = cgv(&["encode", "builtin:walk", "--no-source-mesh", "--kbps", "2", "-o", refused.to_str().unwrap()]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("ask for more"));
    let mut names: Vec<String> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    assert_eq!(names, ["300.cgv", "3000.cgv"]);
}

/// What `cgv info` calls usable encodes: a mesh of long thin parts (the
/// stress corpus's, written as two OBJ frames) is called usable and
/// encodes; where a fold is left after every remedy (no area passes), the
/// encode still finishes and warns with the share of the surface.
#[test]
fn a_mesh_info_calls_usable_encodes() {
    let dir = common::temp_dir("cli-usable");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    let (p, f) = common::stress::body_with_limbs(6, 40.0);
    for t in 0..2 {
        let moved: Vec<glam::Vec3> = p.iter().map(|&q| q + glam::Vec3::new(0.05 * t as f32, 0.0, 0.0)).collect();
        common::write_obj(&frames.join(format!("{t}.obj")), &moved, &f);
    }
    let input = frames.to_str().unwrap();
    let info = cgv(&["info", input, "--json"]);
    assert!(info.status.success(), "{}", String::from_utf8_lossy(&info.stderr));
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(v["usable"], true, "{v}");
    let out = dir.join("limbs.cgv");
    let enc = cgv(&["encode", input, "-o", out.to_str().unwrap(), "--grid", "64"]);
    assert!(enc.status.success(), "{}", String::from_utf8_lossy(&enc.stderr));
    assert!(!String::from_utf8_lossy(&enc.stderr).contains("folds"));
    let enc = cgv(&["encode", input, "-o", out.to_str().unwrap(), "--grid", "64", "--area-correction", "0"]);
    let stderr = String::from_utf8_lossy(&enc.stderr);
    assert!(enc.status.success(), "{stderr}");
    assert!(stderr.contains("warning: the parameterization still folds over"), "{stderr}");
    let dec = cgv(&["decode", out.to_str().unwrap(), "-o", dir.join("back.glb").to_str().unwrap()]);
    assert!(dec.status.success(), "{}", String::from_utf8_lossy(&dec.stderr));
}

/// `cgv skin`: a skinning decomposition of the default motion, written as a
/// skinned glTF that passes the Khronos validator, with its error reported
/// and within reach of the motion (a walking figure is articulated).
#[test]
fn skin_writes_a_valid_skinned_gltf_and_reports_its_error() {
    let dir = common::temp_dir("cli-skin");
    let glb = dir.join("walk-skin.glb");
    let out =
        cgv(&["skin", "builtin:walk", "--frames", "0..24", "--bones", "12", "-o", glb.to_str().unwrap(), "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rms = v["vertex_rms"].as_f64().unwrap();
    eprintln!("walk, 24 frames, 12 bones: {v}");
    assert!(rms > 0.0 && rms < 0.01, "vertex RMS {rms} of the diagonal");
    assert!(v["compact_bits_per_vertex_frame"].as_f64().unwrap() > 0.0);
    let r = &validate_gltf(&[glb.as_path()])[0];
    assert_eq!(r["errors"], 0, "{r}");
    // Too few bones for four joints a vertex: refused by name, nothing written.
    let bad = dir.join("bad.glb");
    let out = cgv(&["skin", "builtin:walk", "--bones", "2", "-o", bad.to_str().unwrap()]);
    assert!(!out.status.success() && stderr(&out).contains("--bones") && !bad.exists());
}

/// `cgv skin --morph-targets`: what the bones miss as morph targets of the
/// skinned mesh, weighed every frame: the GLB passes the validator, reads
/// back with its targets and their weights' track, and the error falls.
#[test]
fn skin_morph_targets_lower_the_error_in_a_valid_gltf() {
    let dir = common::temp_dir("cli-skin-morph");
    let run = |k: &str, glb: &std::path::Path| {
        let out = cgv(&[
            "skin",
            "builtin:walk",
            "--frames",
            "0..24",
            "--bones",
            "8",
            "--morph-targets",
            k,
            "-o",
            glb.to_str().unwrap(),
            "--json",
            "--surface-every",
            "0",
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let (plain, morphed) = (dir.join("plain.glb"), dir.join("morphed.glb"));
    let (a, b) = (run("0", &plain), run("4", &morphed));
    eprintln!("walk, 8 bones: vertex RMS {} without, {} with 4 targets", a["vertex_rms"], b["vertex_rms"]);
    assert_eq!(b["morph_targets"], 4);
    assert!(b["vertex_rms"].as_f64().unwrap() < 0.9 * a["vertex_rms"].as_f64().unwrap(), "{a} {b}");
    assert!(b["compact_bits_per_vertex_frame"].as_f64() > a["compact_bits_per_vertex_frame"].as_f64());
    let r = &validate_gltf(&[morphed.as_path()])[0];
    assert_eq!(r["errors"], 0, "{r}");
    let g = gltf::Gltf::from_slice(&std::fs::read(&morphed).unwrap()).unwrap();
    let prim = g.document.meshes().next().unwrap().primitives().next().unwrap();
    assert_eq!(prim.morph_targets().count(), 4);
    let weights = g
        .document
        .animations()
        .next()
        .unwrap()
        .channels()
        .filter(|c| c.target().property() == gltf::animation::Property::MorphTargetWeights);
    assert_eq!(weights.count(), 1, "one track of the targets' weights");
    // More targets than frames: refused by name, nothing written.
    let bad = dir.join("bad.glb");
    let out = cgv(&[
        "skin",
        "builtin:walk",
        "--frames",
        "0..3",
        "--bones",
        "4",
        "--morph-targets",
        "5",
        "-o",
        bad.to_str().unwrap(),
    ]);
    assert!(!out.status.success() && stderr(&out).contains("morph") && !bad.exists(), "{}", stderr(&out));
}

/// `cgv skin --affine`: affine bones are reported (error and compact size,
/// below the rigid fit's error on the same bones) but written nowhere,
/// since glTF joints cannot shear: asking for a GLB with them is refused.
#[test]
fn skin_affine_reports_without_a_gltf() {
    let dir = common::temp_dir("cli-skin-affine");
    let args = ["skin", "builtin:walk", "--frames", "0..24", "--bones", "12", "--json", "--surface-every", "0"];
    let glb = dir.join("rigid.glb");
    let rigid = cgv(&[&args[..], &["-o", glb.to_str().unwrap()]].concat());
    let affine = cgv(&[&args[..], &["--affine"]].concat());
    assert!(rigid.status.success() && affine.status.success(), "{}", stderr(&affine));
    let (r, a): (serde_json::Value, serde_json::Value) =
        (serde_json::from_slice(&rigid.stdout).unwrap(), serde_json::from_slice(&affine.stdout).unwrap());
    eprintln!("walk, 12 bones, vertex RMS of the diagonal: rigid {}, affine {}", r["vertex_rms"], a["vertex_rms"]);
    assert!(a["affine"] == true && a["glb_bytes"].is_null(), "{a}");
    assert!(a["vertex_rms"].as_f64().unwrap() < r["vertex_rms"].as_f64().unwrap(), "{a} against {r}");
    assert_eq!(a["compact_bits_per_vertex_frame"], r["compact_bits_per_vertex_frame"]);
    let bad = dir.join("affine.glb");
    let out = cgv(&["skin", "builtin:walk", "--affine", "-o", bad.to_str().unwrap()]);
    assert!(!out.status.success() && stderr(&out).contains("--affine") && !bad.exists(), "{}", stderr(&out));
}

/// `cgv skin --target-error`: the fewest bones of the ladder within the
/// target; each count tried is reported, the errors falling; a target no
/// count meets is reported unmet, not hidden; it cannot go with --bones.
#[test]
fn skin_chooses_the_fewest_bones_within_a_target_error() {
    let dir = common::temp_dir("cli-skin-target");
    let glb = dir.join("walk-skin.glb");
    let run = |target: &str| {
        let out =
            cgv(&["skin", "builtin:walk", "--frames", "0..12", "--target-error", target, "-o", glb.to_str().unwrap()]);
        let out = [
            &out,
            &cgv(&[
                "skin",
                "builtin:walk",
                "--frames",
                "0..12",
                "--target-error",
                target,
                "-o",
                glb.to_str().unwrap(),
                "--json",
                "--surface-every",
                "0",
            ]),
        ];
        assert!(out.iter().all(|o| o.status.success()), "{}", stderr(out[0]));
        assert!(
            String::from_utf8_lossy(&out[0].stdout).contains("target"),
            "{}",
            String::from_utf8_lossy(&out[0].stdout)
        );
        serde_json::from_slice::<serde_json::Value>(&out[1].stdout).unwrap()
    };
    let v = run("1");
    let tried = v["target"]["tried"].as_array().unwrap();
    assert!(v["target"]["met"] == true && v["vertex_rms"].as_f64().unwrap() <= 0.01, "{v}");
    assert_eq!(v["bones"], tried.last().unwrap()["bones"], "{v}");
    let v = run("0.00001");
    let tried = v["target"]["tried"].as_array().unwrap();
    assert!(v["target"]["met"] == false && v["bones"] == 64 && tried.len() == 7, "{v}");
    let rms: Vec<f64> = tried.iter().map(|t| t["vertex_rms"].as_f64().unwrap()).collect();
    assert!(rms[6] < rms[0], "{rms:?}");
    let out = cgv(&["skin", "builtin:walk", "--bones", "8", "--target-error", "1", "-o", glb.to_str().unwrap()]);
    assert!(!out.status.success() && stderr(&out).contains("--target-error"), "{}", stderr(&out));
}

/// Behaviour kept through refactoring: these encodes give the bytes the
/// encoder gave before the front ends shared one `EncodeRequest` and the
/// format was split (commit 3d0243d's `cgv`, measured 2026-12-04: length
/// and CRC-32 of each file with its version field and header CRC zeroed,
/// so that a new format version that changes nothing else keeps them; the
/// real sequences named relative to their folder, since the file records
/// the input's name; figures recomputed at 7441fbc, and on 2026-12-06 for
/// format v20's source-mesh references, which shrink every file carrying
/// the input's mesh: walk 66,980 -> 64,304 bytes, walk-target 61,865 ->
/// 59,189, pcow 41,123 -> 40,685, samba 112,928 -> 109,976; walk-kbps,
/// without the mesh, unchanged). A change that means to change the bytes
/// updates the figures here and says so.
#[test]
fn the_same_options_give_the_same_bytes() {
    let dir = common::temp_dir("cli-same-bytes");
    let data = common::real_sequence("pcow").parent().unwrap().to_path_buf();
    common::real_sequence("samba");
    let jobs: [(&str, Vec<&str>, usize, u32); 5] = [
        ("walk", vec!["builtin:walk", "--frames", "0..12", "--grid", "32", "--qp", "24"], 64304, 0xa0ce_599a),
        (
            "walk-kbps",
            vec!["builtin:walk", "--frames", "0..12", "--grid", "32", "--kbps", "300", "--no-source-mesh"],
            14920,
            0xb0a0_ee42,
        ),
        (
            "walk-target",
            vec!["builtin:walk", "--frames", "0..12", "--grid", "32", "--target-error", "0.5"],
            59189,
            0x0469_c5e9,
        ),
        ("pcow", vec!["pcow", "--frames", "0..4", "--grid", "64", "--qp", "20"], 40685, 0x2c4b_85c0),
        (
            "samba",
            vec!["samba", "--frames", "0..3", "--grid", "64", "--qp", "26", "--codec", "predictive"],
            109976,
            0xca3b_5757,
        ),
    ];
    for (name, args, len, crc) in jobs {
        let out = dir.join(format!("{name}.cgv"));
        let run = Command::new(env!("CARGO_BIN_EXE_cgv"))
            .current_dir(&data)
            .args([&["encode"][..], &args, &["-o", out.to_str().unwrap()]].concat())
            .output()
            .unwrap();
        assert!(run.status.success(), "{name}: {}", stderr(&run));
        let mut bytes = std::fs::read(&out).unwrap();
        // The version field and the header's CRC over it say which reader
        // is needed, not what was coded: the rest must not change.
        let header_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        bytes[8..10].fill(0);
        bytes[16 + header_len..20 + header_len].fill(0);
        assert_eq!((bytes.len(), crc32fast::hash(&bytes)), (len, crc), "{name}: the bytes changed");
    }
}

/// A skinning beside the peers (`cgv eval --skin-bones`), and bones for a
/// .cgv file's decoded motion (`cgv decode --skinned`): a skinned glTF that
/// passes the validator.
#[test]
fn skinning_joins_eval_as_a_peer_and_decode_writes_bones() {
    let dir = common::temp_dir("cli-skin-eval");
    let p = |n: &str| dir.join(n).to_str().unwrap().to_string();
    let out = cgv(&[
        "eval",
        "builtin:walk",
        "--frames",
        "0..8",
        "--grid",
        "16",
        "--codecs",
        "predictive",
        "--rates",
        "low",
        "--surface-every",
        "4",
        "--skin-bones",
        "4,8",
        "--json",
        &p("eval.json"),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(p("eval.json")).unwrap()).unwrap();
    let curves = report["peers"]["report"]["curves"].as_array().or_else(|| report["peers"]["curves"].as_array());
    let text = report["peers"].to_string();
    assert!(text.contains("skinned glTF") && text.contains("skinning, compact"), "{}", report["peers"]);
    if let Some(c) = curves {
        let rms: Vec<f64> =
            c[0]["points"].as_array().unwrap().iter().map(|x| x["vertex_rms"].as_f64().unwrap()).collect();
        // More bones, less error; the KG error beside it.
        assert!(rms.len() == 2 && rms[1] < rms[0] && rms[0] > 0.0, "{rms:?}");
        assert!(c[0]["points"][0]["kg"].as_f64().is_some_and(|k| k > 0.0), "{}", c[0]);
    }
    let bad = cgv(&["eval", "builtin:walk", "--skin-bones", "2", "--md", &p("x.md")]);
    assert!(!bad.status.success() && stderr(&bad).contains("--skin-bones"));
    assert!(cgv(&["encode", "builtin:walk", "--frames", "0..12", "--grid", "32", "-o", &p("w.cgv")]).status.success());
    let out = cgv(&["decode", &p("w.cgv"), "--skinned", "--bones", "8", "-o", &p("w-skin.glb"), "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["skin_vertex_rms_of_decoded"].as_f64().unwrap() < 0.02, "{v}");
    assert_eq!(validate_gltf(&[std::path::Path::new(&p("w-skin.glb"))])[0]["errors"], 0);
    // With the residual as 3 morph targets: closer to what the file decodes to.
    let args = ["decode", &p("w.cgv"), "--skinned", "--bones", "8", "--morph-targets", "3", "--json", "-o"];
    let out = cgv(&[&args[..], &[p("w-morph.glb").as_str()]].concat());
    assert!(out.status.success(), "{}", stderr(&out));
    let m: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (with, without) = (m["skin_vertex_rms_of_decoded"].as_f64().unwrap(), v["skin_vertex_rms_of_decoded"].as_f64());
    assert!(m["morph_targets"] == 3 && Some(with) < without, "{m} against {v}");
    assert_eq!(validate_gltf(&[std::path::Path::new(&p("w-morph.glb"))])[0]["errors"], 0);
}

/// `cgv info` on a file with bones (format v13): how many, where their
/// weights lie, and which frames they predicted.
#[test]
fn info_names_the_bones_and_the_frames_they_predict() {
    let fixture = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/v13/walk-bones.cgv");
    let out = cgv(&["info", fixture]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("bones         4 (weights on a 16 x 16 grid; 5 of 8 frames predicted by them)"), "{text}");
    assert!(text.contains("bones 3, bones and velocity 2, bones and smoothed velocity 0"), "{text}");
    let bad = cgv(&["encode", "builtin:walk", "--bones", "many", "-o", "/nonexistent/x.cgv"]);
    assert!(!bad.status.success() && stderr(&bad).contains("give auto or a count"), "{}", stderr(&bad));
}

/// `--codec skinned` (format version 17): the file says what it stores,
/// decodes to the input's own mesh, refuses its grid (a residual, not a
/// surface), and an encode without the source mesh or bones is refused
/// with what to do.
#[test]
fn the_skinned_codec_round_trips_and_refuses_what_it_cannot() {
    let dir = common::temp_dir("cli-skinned");
    let file = dir.join("walk.cgv");
    let f = file.to_str().unwrap();
    let out = cgv(&[
        "encode",
        "builtin:walk",
        "--frames",
        "0..6",
        "--grid",
        "16",
        "--codec",
        "skinned",
        "--bones",
        "4",
        "-o",
        f,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("skinned codec") && text.contains("rest pose ("), "{text}");
    let info = cgv(&["info", f]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(text.contains("version 21") && text.contains("bones         4 on the source mesh's vertices"), "{text}");
    let objs = dir.join("objs");
    let out = cgv(&["decode", f, "-o", objs.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(std::fs::read_dir(&objs).unwrap().count(), 6);
    let grid = cgv(&["decode", f, "--mesh", "grid", "-o", dir.join("grid").to_str().unwrap()]);
    assert!(!grid.status.success() && stderr(&grid).contains("what its bones miss"), "{}", stderr(&grid));
    let x = dir.join("x.cgv");
    for (flag, value, says) in
        [("--no-source-mesh", None, "needs the source mesh"), ("--bones", Some("0"), "bone count")]
    {
        let mut args = vec!["encode", "builtin:walk", "--frames", "0..6", "--codec", "skinned", flag];
        args.extend(value);
        args.extend(["-o", x.to_str().unwrap()]);
        let out = cgv(&args);
        assert!(!out.status.success() && stderr(&out).contains(says), "{flag}: {}", stderr(&out));
    }
    assert!(!x.exists(), "a refused encode leaves no file");
}

/// `cgv decode --skinned` of a skinned file (format v17) writes the file's
/// own bones, not a fit (its 4, whatever --bones says), within reach of
/// what the file decodes to, and the glTF reads back as the motion.
#[test]
fn decode_skinned_of_a_skinned_file_writes_its_own_bones() {
    let dir = common::temp_dir("cli-skinned-glb");
    let (file, glb) = (dir.join("walk.cgv"), dir.join("walk.glb"));
    let (f, g) = (file.to_str().unwrap(), glb.to_str().unwrap());
    let args = ["encode", "builtin:walk", "--frames", "0..6", "--grid", "16", "--codec", "skinned", "--bones", "4"];
    assert!(cgv(&[&args[..], &["-o", f]].concat()).status.success());
    let out = cgv(&["decode", f, "--skinned", "--bones", "12", "-o", g, "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["bones"], 4, "{v}");
    // The bones alone against the decoded frames (bones plus the grid's
    // residual): what the residual carries, measured 0.20 %.
    let rms = v["skin_vertex_rms_of_decoded"].as_f64().unwrap();
    assert!(rms < 0.005, "{v}");
    let info = cgv(&["info", g, "--json"]);
    let i: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!((i["frames"].as_u64(), i["vertices"].as_u64()), (Some(6), Some(6274)), "{i}");
}

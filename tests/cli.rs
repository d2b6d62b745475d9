//! The `cgv` binary as a user runs it.

mod common;

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
    assert!(glb.exists() && dir.join("walk.png").exists());
    let png = std::fs::read(dir.join("walk.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
}

#[test]
fn bad_input_fails_clearly_and_leaves_nothing() {
    let dir = common::temp_dir("cli-bad");
    let obj = dir.join("broken.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let out_glb = dir.join("out.glb");
    let out = cgv(&["remesh", obj.to_str().unwrap(), "-o", out_glb.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("broken.obj") && err.contains("boundary loop"), "{err}");
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left.len(), 1, "{left:?}");
    let out = cgv(&["info", dir.join("missing").to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing"));
    let out = cgv(&["remesh", "builtin:walk", "-o", out_glb.to_str().unwrap(), "--grid", "33"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("grid size 33"));
}

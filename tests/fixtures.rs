//! Frozen `.cgv` files (docs/FORMAT.md, "Compatibility"): every later
//! version must read each file in `tests/fixtures/v*/` and decode the same
//! positions, which are stored beside it (`NAME.SOLVER.positions`: f32
//! little-endian x, y, z per grid sample, frame after frame).
//!
//! The files were written by `cgv encode` (the commands are in
//! tests/fixtures/README.md) and must never be regenerated: a change that
//! breaks this test breaks the compatibility promise. A missing expected
//! file is written only when `CGV_BLESS_FIXTURES=1` (when adding a fixture).
//!
//! Tolerances, relative to the source's bounding-box diagonal: GV is a
//! dequantization, exact up to f32 rounding (1e-6); the cgv decoder adds
//! sparse solves whose summation order may differ between platforms (1e-5);
//! the paper's solver is an iterative L-BFGS whose stopping point can move
//! with rounding (1e-4).
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

mod common;

use cgv::codec::FileDecoder;
use cgv::format::{self, CgvFile, CodecKind, CorrectionMode};
use cgv::format::{Extrapolation, StreamName};
use cgv::solve::SolverKind;
use std::path::{Path, PathBuf};

/// `name` is `vN/FILE`.
fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures").join(name)
}

/// The fixture `name` (`vN/FILE`), read.
fn open(name: &str) -> CgvFile {
    let path = fixture(name);
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    format::read(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn decode(file: CgvFile, solver: SolverKind) -> Vec<f32> {
    let mut dec = FileDecoder::new(file, solver).unwrap();
    let mut out = Vec::new();
    for _ in 0..dec.frame_count() {
        let (x, _) = dec.next_frame().unwrap();
        out.extend(x.iter().flat_map(|p| p.to_array()));
    }
    out
}

fn check(name: &str, solver: SolverKind, tolerance: f64) {
    let file = open(name);
    let diag = file.header.source.diagonal as f64;
    let got = decode(file, solver);
    compare(&format!("{name}.{solver}.positions"), &got, tolerance * diag);
}

/// `got` against the stored `expected` (written once, when blessing).
fn compare(expected: &str, got: &[f32], tolerance: f64) {
    let expected_path = fixture(expected);
    if !expected_path.exists() && std::env::var("CGV_BLESS_FIXTURES").is_ok_and(|v| v == "1") {
        let bytes: Vec<u8> = got.iter().flat_map(|v| v.to_le_bytes()).collect();
        std::fs::write(&expected_path, bytes).unwrap();
    }
    let bytes = std::fs::read(&expected_path)
        .unwrap_or_else(|e| panic!("{}: {e} (see the note at the top of this file)", expected_path.display()));
    let want: Vec<f32> = bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    assert_eq!(got.len(), want.len(), "{expected}: value count");
    let worst = got.iter().zip(&want).map(|(a, b)| (a - b).abs() as f64).fold(0.0, f64::max);
    assert!(worst <= tolerance, "{expected}: differs by {worst} (> {tolerance})");
}

#[test]
fn every_fixture_is_named_for_what_it_stores() {
    // Issue 18's honest names, read from the streams of files of every
    // version (the header's `codec` field is `cgv` for all but GV).
    use format::Representation::{Conformal, Gv, Normal, Predictive, Skinned};
    let named = [
        ("v1/walk-gv.cgv", Gv),
        ("v1/walk-cgv.cgv", Predictive),
        ("v2/walk-cgv-motion.cgv", Predictive),
        ("v3/walk-cgv-motion.cgv", Predictive),
        ("v8/fox-textured.cgv", Predictive),
        ("v9/walk-cgv-normal.cgv", Normal),
        ("v10/walk-cgv-random-access.cgv", Normal),
        ("v11/walk-conformal.cgv", Conformal),
        ("v17/walk-skinned.cgv", Skinned),
    ];
    for (name, kind) in named {
        assert_eq!(open(name).header.representation(), kind, "{name}");
    }
}

#[test]
fn v11_conformal_fixture_decodes_as_frozen_with_both_solvers() {
    // The seed paper's representation alone: H every frame, λ at key
    // frames, anchors, no corrections (`--codec conformal`).
    let f = open("v11/walk-conformal.cgv");
    assert!(f.header.correction_streams().is_none() && f.header.anchors.len() == 16);
    assert!(f.header.stream(StreamName::H).is_some() && f.header.stream(StreamName::Lambda).is_some());
    assert_eq!((f.header.solver, f.header.frames), (SolverKind::Paper, 4));
    check("v11/walk-conformal.cgv", SolverKind::Paper, 1e-4);
    check("v11/walk-conformal.cgv", SolverKind::Predictive, 1e-5);
}

#[test]
fn v1_gv_fixture_decodes_as_frozen() {
    let f = open("v1/walk-gv.cgv");
    assert_eq!((f.header.codec, f.header.grid, f.header.frames), (CodecKind::Gv, 16, 4));
    check("v1/walk-gv.cgv", SolverKind::Predictive, 1e-6);
}

#[test]
fn v1_cgv_fixture_decodes_as_frozen_with_both_solvers() {
    let f = open("v1/walk-cgv.cgv");
    assert_eq!((f.header.codec, f.header.grid, f.header.frames), (CodecKind::Cgv, 16, 4));
    assert_eq!(f.header.key_frames, vec![0, 2]);
    assert!(f.header.streams.iter().any(|s| s.layer == 2 && s.name == StreamName::Dx));
    check("v1/walk-cgv.cgv", SolverKind::Predictive, 1e-5);
    check("v1/walk-cgv.cgv", SolverKind::Paper, 1e-4);
}

#[test]
fn v2_motion_fixture_decodes_as_frozen() {
    let f = open("v2/walk-cgv-motion.cgv");
    assert_eq!((f.version, f.header.corrections), (2, CorrectionMode::Motion));
    assert_eq!((f.header.codec, f.header.grid, f.header.frames), (CodecKind::Cgv, 16, 6));
    assert!(f.header.streams.iter().any(|s| s.layer == 2 && s.name == StreamName::Dz));
    check("v2/walk-cgv-motion.cgv", SolverKind::Predictive, 1e-5);
}

#[test]
fn v2_gv_and_scaled_cgv_fixtures_decode_as_frozen() {
    let f = open("v2/walk-gv.cgv");
    assert_eq!((f.version, f.header.codec, f.header.frames), (2, CodecKind::Gv, 4));
    check("v2/walk-gv.cgv", SolverKind::Predictive, 1e-6);
    let f = open("v2/walk-cgv.cgv");
    assert_eq!((f.version, f.header.corrections, f.header.anchors.len()), (2, CorrectionMode::Scaled, 16));
    check("v2/walk-cgv.cgv", SolverKind::Predictive, 1e-5);
    check("v2/walk-cgv.cgv", SolverKind::Paper, 1e-4);
}

#[test]
fn v3_motion_fixture_without_h_decodes_as_frozen() {
    let f = open("v3/walk-cgv-motion.cgv");
    assert_eq!((f.version, f.header.corrections), (3, CorrectionMode::Motion));
    assert!(f.header.stream(StreamName::H).is_none() && f.header.stream(StreamName::Lambda).is_none());
    assert!(f.header.streams.iter().any(|s| s.layer == 2 && s.name == StreamName::Dz));
    check("v3/walk-cgv-motion.cgv", SolverKind::Predictive, 1e-5);
}

#[test]
fn v4_cycle_fixture_decodes_as_frozen() {
    let f = open("v4/walk-cgv-cycle.cgv");
    assert_eq!((f.version, f.header.corrections), (4, CorrectionMode::Motion));
    // Cycle predictions (a lag of 36, the default motion's gait period,
    // among others) and corrections on frames 0, 1, 3, 5, ... only.
    assert!(
        f.header.max_lag >= 36
            && f.frames.iter().any(|i| i.predictor.extrapolation == Extrapolation::Cycle && i.predictor.lag == 36)
    );
    assert_eq!(&f.header.key_frames[..4], [0, 1, 3, 5]);
    check("v4/walk-cgv-cycle.cgv", SolverKind::Predictive, 1e-5);
}

#[test]
fn v5_filter_fixture_decodes_as_frozen() {
    let f = open("v5/walk-cgv-filter.cgv");
    assert_eq!((f.version, f.header.corrections), (5, CorrectionMode::Motion));
    // Corrections filtered by each of the encoder's choices on some frame.
    for passes in [1, 2, 4] {
        assert!(f.frames.iter().any(|i| i.filter == passes), "no frame with {passes} passes");
    }
    check("v5/walk-cgv-filter.cgv", SolverKind::Predictive, 1e-5);
}

/// The input's vertices rebuilt on every frame of `name` against the
/// frozen ones: turning the stored places (and offsets) into vertices is
/// part of what the file means.
fn check_source(name: &str, f: CgvFile) {
    let diag = f.header.source.diagonal as f64;
    let mut dec = FileDecoder::new(f, SolverKind::Predictive).unwrap();
    let source = dec.source_mesh().unwrap();
    let mut got = Vec::new();
    for _ in 0..dec.frame_count() {
        let (x, _) = dec.next_frame().unwrap();
        got.extend(source.vertices(&x, dec.loose(), dec.at_vertices()).iter().flat_map(|p| p.to_array()));
    }
    compare(&format!("{name}.source.positions"), &got, 1e-5 * diag);
}

#[test]
fn v6_source_mesh_fixture_decodes_as_frozen() {
    let f = open("v6/walk-cgv-source.cgv");
    assert_eq!((f.version, f.header.corrections), (6, CorrectionMode::Motion));
    let walk = cgv::mesh::builtin::motion(1);
    let mesh = f.source_mesh.as_ref().expect("the file carries its input's mesh");
    assert_eq!((&mesh.faces, mesh.places.len()), (&walk.topology.faces, walk.topology.vertex_count));
    check("v6/walk-cgv-source.cgv", SolverKind::Predictive, 1e-5);
    check_source("v6/walk-cgv-source.cgv", f);
}

#[test]
fn v12_walked_source_mesh_fixture_decodes_as_frozen() {
    // The built-in figure's faces coded as a walk, its places from their
    // predictions: every face comes back with its vertices in their order.
    let f = open("v12/walk-source-walked.cgv");
    assert_eq!(f.version, 12);
    assert!(f.header.source_mesh.is_some_and(|m| m.walk));
    let walk = cgv::mesh::builtin::motion(1);
    let mesh = f.source_mesh.as_ref().expect("the file carries its input's mesh");
    assert_eq!(common::sorted_faces(&mesh.faces), common::sorted_faces(&walk.topology.faces));
    assert_eq!(mesh.places.len(), walk.topology.vertex_count);
    check("v12/walk-source-walked.cgv", SolverKind::Predictive, 1e-5);
    check_source("v12/walk-source-walked.cgv", f);
}

#[test]
fn v13_bones_fixture_decodes_as_frozen() {
    // Frames predicted by 4 bones (codes 16 and 17), random-access points
    // at 0, 3 and 6 where the bones restart from the decoded point.
    let f = open("v13/walk-bones.cgv");
    assert_eq!(f.version, 13);
    let skin = f.header.skin.expect("the file has bones");
    assert_eq!((skin.bones, f.header.random_access), (4, Some(3)));
    let codes: Vec<u8> = f.frames.iter().map(|i| i.predictor.to_byte()).collect();
    assert_eq!(codes, [0, 16, 17, 0, 16, 17, 0, 16]);
    assert!(f.frames.iter().enumerate().all(|(k, i)| i.bones.as_ref().is_some_and(|b| b.is_empty() == (k % 3 == 0))));
    check("v13/walk-bones.cgv", SolverKind::Predictive, 1e-5);
    check_source("v13/walk-bones.cgv", f);
}

#[test]
fn v14_packed_bones_fixture_decodes_as_frozen() {
    // Version 13's fixture's settings, its weights and bones units packed.
    let f = open("v14/walk-bones-packed.cgv");
    assert_eq!(f.version, 14);
    let skin = f.header.skin.expect("the file has bones");
    assert!(skin.packed);
    assert_eq!((skin.bones, f.header.random_access), (4, Some(3)));
    let codes: Vec<u8> = f.frames.iter().map(|i| i.predictor.to_byte()).collect();
    assert_eq!(codes, [0, 16, 17, 0, 16, 17, 0, 16]);
    assert!(f.frames.iter().enumerate().all(|(k, i)| i.bones.as_ref().is_some_and(|b| b.is_empty() == (k % 3 == 0))));
    check("v14/walk-bones-packed.cgv", SolverKind::Predictive, 1e-5);
    check_source("v14/walk-bones-packed.cgv", f);
}

#[test]
fn v17_skinned_fixture_decodes_as_frozen() {
    // Bones on the source mesh's vertices (`--codec skinned`): the weights
    // and rest pose in the SKIN chunk, a bones unit every frame (the
    // random-access points at 0, 3 and 6 too), the grid what they miss.
    let f = open("v17/walk-skinned.cgv");
    assert_eq!(f.version, 17);
    assert_eq!(f.header.representation(), format::Representation::Skinned);
    let skin = f.header.skin.expect("the file has bones");
    assert!(skin.on_vertices() && skin.packed);
    assert_eq!((skin.bones, f.header.random_access), (4, Some(3)));
    let weights = f.skin.as_ref().expect("the SKIN chunk");
    let vertices = f.source_mesh.as_ref().expect("the source mesh").places.len();
    assert_eq!((weights.influences.len(), weights.rest.len()), (vertices, vertices));
    assert!(f.frames.iter().all(|i| i.bones.as_ref().is_some_and(|b| !b.is_empty())));
    check("v17/walk-skinned.cgv", SolverKind::Predictive, 1e-5);
    check_source("v17/walk-skinned.cgv", f);
}

#[test]
fn v18_vertex_residual_fixtures_decode_as_frozen() {
    // What the video missed at the source mesh's vertices, every frame
    // (`--vertex-residual`): over bones on the vertices with random-access
    // points at 0, 3 and 6 (the residual restarts there), and over the
    // closed loop's normal codec.
    for (name, frames) in [("v18/walk-skinned-residual.cgv", 8), ("v18/walk-normal-residual.cgv", 6)] {
        let f = open(name);
        assert_eq!(f.version, 18, "{name}");
        // Some frame adds to the last one's residual.
        assert!(residual_modes(&f).contains(&1), "{name}");
        check_residual_fixture(name, f, frames);
    }
}

#[test]
fn v19_spatial_residual_fixture_decodes_as_frozen() {
    // The residual's values as what the walk's parallelogram rule misses
    // (modes 2 at the random-access points and 3 between): a 16² grid is
    // coarse for the figure's 6,274 vertices, so what it misses is smooth.
    let name = "v19/walk-normal-spatial.cgv";
    let f = open(name);
    assert_eq!(f.version, 19);
    assert!(f.header.vertex_residual.is_some_and(|r| r.spatial));
    assert_eq!(residual_modes(&f), [2, 3, 3, 2, 3, 3]);
    // Not only as frozen: every vertex within half a step a coordinate of
    // the motion it was made from (none clamped at this step).
    within_half_a_step(&f);
    // The residual is coded against the cgv solver's grid, not the paper's.
    let paper = FileDecoder::new(f.clone(), SolverKind::Paper).err().map(|e| e.to_string());
    assert!(paper.as_deref().is_some_and(|e| e.contains("cgv solver")), "{paper:?}");
    check_residual_fixture(name, f, 6);
}

#[test]
fn v20_vertices_fixture_decodes_as_frozen() {
    // No grid and no video: the vertices themselves, every frame, from the
    // header's origin (`--codec vertices`), their units' counts sparse and
    // values in contexts where that is shorter; random-access points at 0
    // and 3.
    let name = "v20/walk-vertices.cgv";
    let f = open(name);
    assert_eq!(f.version, 20);
    assert_eq!(f.header.representation(), format::Representation::Vertices);
    assert!(f.header.streams.is_empty() && f.units.iter().all(Vec::is_empty));
    let r = f.header.vertex_residual.expect("a vertex residual");
    assert!(r.origin.is_some() && r.sparse && r.contexts && r.spatial);
    // Every unit in contexts with escapes (flag 8): spatial at the points
    // (2), its change spatial between (3); the escapes keep every
    // histogram narrow, so the counts are dense.
    assert_eq!(residual_modes(&f), [10, 11, 11, 10, 11, 11]);
    within_half_a_step(&f);
    check_residual_fixture(name, f, 6);
}

/// Every decoded vertex of a fixture of the built-in motion's first frames
/// lies within half its residual's step a coordinate of the motion (no
/// value clamped at that step).
fn within_half_a_step(f: &format::CgvFile) {
    let step = f.header.vertex_residual.map_or(0.0, |r| r.step);
    let truth = cgv::mesh::builtin::motion(f.header.frames as usize);
    let mut dec = FileDecoder::new(f.clone(), SolverKind::Predictive).unwrap();
    let source = dec.source_mesh().unwrap();
    for (k, frame) in truth.frames.iter().enumerate() {
        let got = dec.next_source_frame(&source).unwrap().1;
        let worst = got.iter().zip(frame.iter()).map(|(a, b)| (*a - *b).abs().max_element()).fold(0.0, f32::max);
        assert!(worst <= 0.5 * step * 1.001, "frame {k}: a vertex {worst} off (step {step})");
    }
}

/// Each frame's residual unit's mode byte.
fn residual_modes(f: &format::CgvFile) -> Vec<u8> {
    f.frames.iter().map(|i| i.residual.as_ref().and_then(|u| u.first().copied()).unwrap_or(u8::MAX)).collect()
}

/// A residual fixture of `frames` frames with random-access points every 3
/// decodes as frozen, and a seek back to frame 3 as a decode from the start.
fn check_residual_fixture(name: &str, f: format::CgvFile, frames: u32) {
    assert_eq!((f.header.frames, f.header.random_access), (frames, Some(3)), "{name}");
    let step = f.header.vertex_residual.expect("a vertex residual").step;
    assert!(step > 0.0 && f.frames.iter().all(|i| i.residual.as_ref().is_some_and(|u| u.len() > 1)), "{name}");
    check(name, SolverKind::Predictive, 1e-5);
    // After the last frame, a seek back to the point at frame 3 decodes the
    // frames after it as a decode from frame 0 does (the residual restarts).
    let vertices = |dec: &mut FileDecoder, k: usize| -> Vec<Vec<glam::Vec3>> {
        let source = dec.source_mesh().unwrap();
        (0..k).map(|_| dec.next_source_frame(&source).unwrap().1).collect()
    };
    let whole = vertices(&mut FileDecoder::new(f.clone(), SolverKind::Predictive).unwrap(), frames as usize);
    let mut late = FileDecoder::new(f.clone(), SolverKind::Predictive).unwrap();
    vertices(&mut late, frames as usize);
    late.seek(3).unwrap();
    assert_eq!(vertices(&mut late, frames as usize - 3), whole[3..], "{name}");
    check_source(name, f);
}

#[test]
fn v7_source_offsets_fixture_decodes_as_frozen() {
    let f = open("v7/walk-cgv-offsets.cgv");
    assert_eq!(f.version, 7);
    let mesh = f.source_mesh.as_ref().expect("the file carries its input's mesh");
    assert!(mesh.offsets.is_some(), "and the vertices' offsets");
    check("v7/walk-cgv-offsets.cgv", SolverKind::Predictive, 1e-5);
    check_source("v7/walk-cgv-offsets.cgv", f);
}

#[test]
fn v8_appearance_fixture_decodes_as_frozen() {
    let f = open("v8/fox-textured.cgv");
    assert_eq!(f.version, 8);
    let look = f.appearance.as_ref().expect("the file carries its input's look");
    assert_eq!(look.uvs.len(), 1728);
    let (mime, png) = look.texture.as_ref().expect("and its texture");
    assert_eq!((mime.as_str(), &png[1..4]), ("image/png", &b"PNG"[..]));
    check("v8/fox-textured.cgv", SolverKind::Predictive, 1e-5);
    check_source("v8/fox-textured.cgv", f);
}

#[test]
fn v9_normal_correction_fixture_decodes_as_frozen() {
    let f = open("v9/walk-cgv-normal.cgv");
    assert_eq!((f.version, f.header.corrections), (9, CorrectionMode::Motion));
    let sizes: Vec<(&str, u32)> = f.header.streams.iter().map(|s| (s.name.as_str(), s.size(f.header.grid))).collect();
    assert_eq!(sizes[3..], [("dx", 16), ("dy", 16), ("dz", 16), ("dn", 32)]);
    check("v9/walk-cgv-normal.cgv", SolverKind::Predictive, 1e-5);
}

#[test]
fn v9_relaxation_fixture_decodes_as_frozen() {
    // The same layout at QP 36, where the encoder relaxes a frame.
    let f = open("v9/walk-cgv-relax.cgv");
    assert_eq!(f.version, 9);
    assert!(f.frames.iter().any(|i| i.relax > 0), "{:?}", f.frames.iter().map(|i| i.relax).collect::<Vec<_>>());
    check("v9/walk-cgv-relax.cgv", SolverKind::Predictive, 1e-5);
}

#[test]
fn v10_random_access_fixture_decodes_as_frozen_from_every_point() {
    let f = open("v10/walk-cgv-random-access.cgv");
    assert_eq!((f.version, f.header.corrections, f.header.random_access), (10, CorrectionMode::Motion, Some(6)));
    assert_eq!(f.index.len(), 3);
    let origins: Vec<bool> = f.frames.iter().map(|i| i.seed_origin.is_some()).collect();
    assert_eq!(origins, (0..14).map(|k| k % 6 == 0).collect::<Vec<_>>(), "a seed origin at each point");
    check("v10/walk-cgv-random-access.cgv", SolverKind::Predictive, 1e-5);
    // A decoder that starts at a later point gives the frozen frames from there.
    let diag = f.header.source.diagonal as f64;
    let n = (f.header.grid * f.header.grid) as usize * 3;
    let frames = f.header.frames as usize;
    let mut dec = FileDecoder::new(f, SolverKind::Predictive).unwrap();
    for start in [12, 6] {
        assert_eq!(dec.seek(start as u32).unwrap(), 0);
        let got: Vec<f32> =
            (start..frames).flat_map(|_| dec.next_frame().unwrap().0).flat_map(|p| p.to_array()).collect();
        let expected = std::fs::read(fixture("v10/walk-cgv-random-access.cgv.cgv.positions")).unwrap();
        let want = expected[4 * start * n..].chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]));
        assert_eq!(got.len(), want.len());
        let worst = got.iter().zip(want).map(|(a, b)| (a - b).abs() as f64).fold(0.0, f64::max);
        assert!(worst <= 1e-5 * diag, "from frame {start}: differs by {worst}");
    }
}

#[test]
fn v15_segments_fixture_decodes_as_frozen_from_every_point() {
    // Points every 6 frames and where the segment at frame 9 starts.
    let f = open("v15/walk-cgv-segments.cgv");
    assert_eq!((f.version, f.header.random_access, &f.header.segments[..]), (15, Some(6), &[9][..]));
    assert_eq!((f.index.len(), f.header.point_index(11), f.header.point_frame(2)), (4, 2, Some(9)));
    check_from_points("v15/walk-cgv-segments.cgv", f, &[12, 9, 6]);
}

/// The fixture `name` (read as `f`) decodes as frozen from the start and
/// from each of the points `starts`, one seek after the other.
fn check_from_points(name: &str, f: CgvFile, starts: &[usize]) {
    check(name, SolverKind::Predictive, 1e-5);
    let expected = std::fs::read(fixture(&format!("{name}.cgv.positions"))).unwrap();
    let n = (f.header.grid * f.header.grid) as usize * 3;
    let (frames, diag) = (f.header.frames as usize, f.header.source.diagonal as f64);
    let mut dec = FileDecoder::new(f, SolverKind::Predictive).unwrap();
    for &start in starts {
        assert_eq!(dec.seek(start as u32).unwrap(), 0, "frame {start} is a point");
        let got: Vec<f32> =
            (start..frames).flat_map(|_| dec.next_frame().unwrap().0).flat_map(|p| p.to_array()).collect();
        let want = expected[4 * start * n..].chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]));
        let worst = got.iter().zip(want).map(|(a, b)| (a - b).abs() as f64).fold(0.0, f64::max);
        assert!(worst <= 1e-5 * diag, "{name} from frame {start}: differs by {worst}");
    }
}

#[test]
fn v21_weights_at_a_point_fixture_decodes_as_frozen_from_every_point() {
    // A capture's two segments, the second's weights at its point, frame 3.
    let name = "v21/walk-capture-bones.cgv";
    let f = open(name);
    assert_eq!((f.version, &f.header.segments[..]), (21, &[3][..]));
    assert!(f.header.skin.is_some_and(|s| s.point_weights));
    assert!(f.frames[3].bones.as_ref().is_some_and(|u| !u.is_empty()), "frame 3 has its weights");
    // From the second point, then back to the first: its weights are the chunk's again.
    check_from_points(name, f, &[3, 0]);
}

#[test]
fn v16_frame_meshes_fixture_decodes_each_frames_mesh_as_frozen() {
    let name = "v16/walk-capture-frame-meshes.cgv";
    let f = open(name);
    assert!(f.version == 16 && f.header.frame_meshes && f.header.source_mesh.is_none());
    check(name, SolverKind::Predictive, 1e-5);
    // Each frame's own mesh, rebuilt on its decoded grid: its vertices
    // frozen, frame after frame, and its faces' count the capture's.
    let diag = f.header.source.diagonal as f64;
    let mut dec = FileDecoder::new(f, SolverKind::Predictive).unwrap();
    let (mut got, mut faces) = (Vec::new(), Vec::new());
    for t in 0..dec.frame_count() as u32 {
        let (x, _) = dec.next_frame().unwrap();
        let (v, f) = dec.frame_mesh(t, &x).unwrap().expect("a mesh every frame");
        got.extend(v.iter().flat_map(|p| p.to_array()));
        faces.push(f.len());
    }
    assert_eq!(faces, [1466, 1814, 1722, 1392], "the capture's faces a frame");
    compare(&format!("{name}.frame-meshes.positions"), &got, 1e-5 * diag);
}

/// 14 frames of a ball (an icosphere of 642 vertices) bouncing and
/// squashing, with a hat: a tetrahedron of four vertices riding above it
/// and turning, a part of its own.
fn ball_with_a_hat() -> cgv::mesh::InMemory {
    let (ball, mut faces) = common::icosphere(3);
    let n = ball.len() as u32;
    let tetra = [[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0f32]];
    let frames = (0..14)
        .map(|t| {
            let t = t as f32 / 30.0;
            let (lift, squash) = ((t * 9.0).sin().abs() * 0.5, 1.0 - 0.2 * (t * 9.0).cos().abs());
            let mut x: Vec<glam::Vec3> =
                ball.iter().map(|p| glam::Vec3::new(p.x / squash.sqrt(), p.y * squash + lift, p.z)).collect();
            let (turn, at) = (glam::Quat::from_rotation_y(6.0 * t), glam::Vec3::new(0.0, squash + lift + 0.3, 0.0));
            x.extend(tetra.iter().map(|c| at + turn * glam::Vec3::from(*c) * 0.15));
            x
        })
        .collect();
    faces.extend([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]].map(|f| f.map(|i| n + i)));
    let topology = cgv::mesh::Topology { vertex_count: ball.len() + 4, faces };
    cgv::mesh::InMemory { label: "ball-with-a-hat".into(), fps: 30.0, topology, frames }
}

#[test]
fn v11_loose_vertices_fixture_decodes_as_frozen() {
    let name = "v11/ball-hat-loose.cgv";
    if !fixture(name).exists() && std::env::var("CGV_BLESS_FIXTURES").is_ok_and(|v| v == "1") {
        // Written once (tests/fixtures/README.md), then frozen.
        use cgv::codec::{encode, h264::VideoSettings, EncodeOptions};
        let opts = EncodeOptions {
            grid: 32,
            video: VideoSettings { qp: 24, ..Default::default() },
            random_access: 0.2,
            ..Default::default()
        };
        let (bytes, _) = encode(&ball_with_a_hat(), &opts, &mut |_, _, _| {}).unwrap();
        std::fs::write(fixture(name), bytes).unwrap();
    }
    let f = open(name);
    let h = &f.header;
    assert_eq!((f.version, h.loose_vertices(), h.random_access, h.loose_follow_grid()), (11, Some(4), Some(6), true));
    assert!(f.frames.iter().all(|i| i.loose.as_ref().is_some_and(|l| format::LooseFrame::parse(l, 4, 0).is_ok())));
    check(name, SolverKind::Predictive, 1e-5);
    check_source(name, open(name));
}

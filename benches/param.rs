//! Parameterization and resampling speed (issue targets on the 2-core CI
//! machine: samba's reference frame parameterized in under 5 s, resampling at
//! 100+ frames/s at N = 256), and the parameterization the encoder runs,
//! which scores the area-correction passes by the grid's resampling error. Uses samba from ../shared/data when present
//! (unpacked under target/), else the embedded default motion.
//!
//! Run: `cargo bench --bench param` (`-- surface-distance` for the
//! resampling error's measure alone)
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

use cgv::geometry_image::parameterize_for_grid;
use cgv::grid::Grid;
use cgv::mesh::{open_sequence, FrameSource, OpenOptions};
use cgv::metrics::surface::{symmetric, symmetric_rms, symmetric_rms_to, Target};
use cgv::param::{parameterize, ParamOptions};
use cgv::resample::SampleMap;
use criterion::{criterion_group, criterion_main, Criterion};
use std::path::Path;

fn samba() -> Option<Box<dyn FrameSource>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let archive = root.join("../shared/data/samba.tar.xz");
    let dest = root.join("target/bench-data");
    if !dest.join("samba").exists() {
        if !archive.exists() {
            return None;
        }
        std::fs::create_dir_all(&dest).ok()?;
        let ok = std::process::Command::new("tar").arg("xJf").arg(&archive).arg("-C").arg(&dest).status().ok()?;
        if !ok.success() {
            return None;
        }
    }
    open_sequence(dest.join("samba").to_str()?, &OpenOptions::default()).ok()
}

fn bench(c: &mut Criterion) {
    let (name, src): (&str, Box<dyn FrameSource>) = match samba() {
        Some(s) => ("samba", s),
        None => ("builtin-walk", Box::new(cgv::mesh::builtin::default_motion())),
    };
    let topo = src.topology().clone();
    let frame = src.read_frame(0).expect("first frame");
    let mut g = c.benchmark_group("geometry-image");
    g.sample_size(10);
    g.bench_function(format!("parameterize/{name}"), |b| {
        b.iter(|| parameterize(&topo, &frame, &ParamOptions::default()).expect("parameterize"))
    });
    // What the encoder runs: the passes scored by the grid's resampling error.
    for n in [128usize, 256] {
        let grid = Grid::new(n).expect("grid");
        g.bench_function(format!("parameterize-for-grid/{name}/{n}"), |b| {
            b.iter(|| parameterize_for_grid(&topo, &frame, grid, &ParamOptions::default()).expect("parameterize"))
        });
    }
    g.bench_function(format!("parameterize-conformal-only/{name}"), |b| {
        b.iter(|| {
            parameterize(&topo, &frame, &ParamOptions { area_correction: 0.0, ..Default::default() }).expect("param")
        })
    });
    let param = parameterize(&topo, &frame, &ParamOptions::default()).expect("parameterize");
    for n in [128usize, 256, 512] {
        let grid = Grid::new(n).expect("grid");
        g.bench_function(format!("locate-samples/{name}/{n}"), |b| {
            b.iter(|| SampleMap::build(grid, &topo.faces, &param).expect("locate"))
        });
        let map = SampleMap::build(grid, &topo.faces, &param).expect("locate");
        let mut out = Vec::new();
        g.bench_function(format!("resample-frame/{name}/{n}"), |b| b.iter(|| map.apply_into(&frame, &mut out)));
    }
    g.bench_function(format!("read-obj-frame/{name}"), |b| b.iter(|| src.read_frame(1).expect("frame")));
    // A frame's grid against the frame (its resampling error), as a
    // capture's registration measures every frame several times: the
    // full figure (both parry trees and the maxima), the RMS alone (both
    // trees the fast-built Lbvh), and the RMS with the frame's tree built
    // once (`symmetric_rms_to`, as the cone sets' scores share it).
    for n in [128usize, 256] {
        let grid = Grid::new(n).expect("grid");
        let faces = grid.topology().faces;
        let g_pos = SampleMap::build(grid, &topo.faces, &param).expect("locate").apply(&frame);
        let (a, b) = ((&frame[..], &topo.faces[..]), (&g_pos[..], &faces[..]));
        g.bench_function(format!("surface-distance/symmetric/{name}/{n}"), |bn| {
            bn.iter(|| symmetric(a.0, a.1, b.0, b.1).expect("distance"))
        });
        g.bench_function(format!("surface-distance/rms/{name}/{n}"), |bn| {
            bn.iter(|| symmetric_rms(a.0, a.1, b.0, b.1).expect("distance"))
        });
        let target = Target::new(a.0, a.1).expect("tree");
        g.bench_function(format!("surface-distance/rms-to-built/{name}/{n}"), |bn| {
            bn.iter(|| symmetric_rms_to(b, &|_| None, a, &target, (f64::INFINITY, 1)).expect("distance"))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! The input's own mesh in a file (the `SMSH` chunk): its size in version
//! 12's coding (the faces walked, the places predicted) against versions
//! 6-11's layout, for every shared sequence that unpacks (printed as a
//! table), and how long samba's takes to code and to read back (criterion).
//! The grid is N = 128 (the offsets depend on it; the faces and places
//! do not).
//!
//! Run: `cargo bench --bench source_mesh`
#![allow(clippy::unwrap_used, clippy::expect_used)] // benchmarks may stop on any failure

use cgv::codec::{prepare, EncodeOptions};
use cgv::format::SourceMesh;
use cgv::mesh::{open_sequence, FrameSelection, OpenOptions};
use criterion::{criterion_group, criterion_main, Criterion};
use std::path::Path;

const SEQUENCES: [&str; 7] = ["samba", "horse-gallop", "pcow", "horse-collapse", "face-poses", "cylinder", "wolf"];

/// The stored mesh of sequence `name` (unpacked under target/), if its archive is there.
fn stored_mesh(name: &str) -> Option<SourceMesh> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let archive = root.join(format!("../shared/data/{name}.tar.xz"));
    let dest = root.join("target/bench-data");
    if !dest.join(name).exists() {
        std::fs::create_dir_all(&dest).ok()?;
        let ok = std::process::Command::new("tar").arg("xJf").arg(archive).arg("-C").arg(&dest).status().ok()?;
        ok.success().then_some(())?;
    }
    let opts = OpenOptions { frames: Some(FrameSelection { start: 0, end: Some(2) }), ..Default::default() };
    let src = open_sequence(dest.join(name).to_str()?, &opts).ok()?;
    let image = prepare(src.as_ref(), &EncodeOptions { grid: 128, ..Default::default() }).ok()?;
    Some(image.source_mesh_as_stored(src.topology(), src.appearance()))
}

fn bench(c: &mut Criterion) {
    eprintln!("| sequence | vertices | faces | v6-11 layout (bytes) | v12 (bytes) | v12 / v6-11 | bits a face, a vertex (v12) |");
    eprintln!("|---|---|---|---|---|---|---|");
    let mut samba = None;
    for name in SEQUENCES {
        let Some(mesh) = stored_mesh(name) else {
            eprintln!("| {name} | (not in ../shared/data) | | | | | |");
            continue;
        };
        let (plain, walked) = (mesh.to_bytes_plain().len(), mesh.to_bytes().len());
        let (v, f) = (mesh.places.len(), mesh.faces.len());
        eprintln!(
            "| {name} | {v} | {f} | {plain} | {walked} | {:.2} | {:.1}, {:.1} |",
            walked as f64 / plain as f64,
            walked as f64 * 8.0 / f as f64,
            walked as f64 * 8.0 / v as f64
        );
        if name == "samba" {
            samba = Some(mesh);
        }
    }
    let Some(mesh) = samba else { return };
    let (bytes, info) = (mesh.to_bytes(), mesh.info());
    let mut g = c.benchmark_group("source-mesh");
    g.sample_size(10);
    g.bench_function("samba/code", |b| b.iter(|| mesh.to_bytes()));
    g.bench_function("samba/read", |b| b.iter(|| SourceMesh::parse(&bytes, &info, 0).unwrap()));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! Coding speed: the whole encoder after the parameterization
//! (`encode_prepared`: resample, predict, the closed loop's corrections,
//! H.264, the file) on 30 frames of the default motion, at N = 128 and
//! 256, at a QP and on a bitrate (the budget's repeated coding included).
//! Issue 20 asks for 30 frames/s at N = 256; criterion reports the time of
//! the 30 frames (Throughput: frames).
//!
//! Run: `cargo bench --bench encode`
#![allow(clippy::unwrap_used, clippy::expect_used)] // benchmarks may stop on any failure

use cgv::codec::{encode_prepared, prepare, CodecChoice, EncodeOptions};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

const FRAMES: usize = 30;

fn bench(c: &mut Criterion) {
    let src = cgv::mesh::builtin::motion(FRAMES);
    let mut g = c.benchmark_group("encode");
    g.sample_size(10);
    g.throughput(Throughput::Elements(FRAMES as u64));
    for n in [128usize, 256] {
        for (name, kbps) in [("qp-30", None), ("kbps-600", Some(600.0))] {
            let mut opts = EncodeOptions { grid: n, ..Default::default() };
            opts.video.qp = 30;
            opts.video.kbps = kbps;
            let opts = CodecChoice::Auto.apply(opts, None).expect("options");
            let image = prepare(&src, &opts).expect("prepare");
            g.bench_function(format!("encode-prepared-{FRAMES}-frames/{name}/{n}"), |b| {
                b.iter(|| encode_prepared(&src, &opts, &image, &mut |_, _, _| {}).expect("encode"))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

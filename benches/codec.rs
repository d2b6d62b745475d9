//! Codec speed: H.264 encode and decode of one grid frame per stream, and
//! reconstruction of one frame by each solver and predictor (bones
//! included) (the paper: 12 s/frame to
//! compress, 23 s/frame to reconstruct, on a 2011 PC). Default motion.
//!
//! Run: `cargo bench --bench codec`
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

use cgv::codec::h264::{Decoder, Encoder, VideoSettings};
use cgv::codec::{choose_anchors, Corrections, Layout};
use cgv::format::quant::Quantizer;
use cgv::format::{CorrectionMode, SkinInfo, SkinWeights};
use cgv::grid::stencil::Stencils;
use cgv::grid::Grid;
use cgv::param::{parameterize, ParamOptions};
use cgv::resample::SampleMap;
use cgv::solve::paper::PaperSolver;
use cgv::solve::predictor::{Extrapolation, Predictor, PredictorCode, DEFAULT_MAX_LAG};
use cgv::solve::skinned::SkinnedPredictor;
use criterion::{criterion_group, criterion_main, Criterion};
use glam::Vec3;

fn bench(c: &mut Criterion) {
    let m = cgv::mesh::builtin::motion(2);
    let param = parameterize(&m.topology, &m.frames[0], &ParamOptions::default()).expect("parameterize");
    let mut g = c.benchmark_group("codec");
    g.sample_size(10);
    for n in [64usize, 128, 256] {
        let grid = Grid::new(n).expect("grid");
        let map = SampleMap::build(grid, &m.topology.faces, &param).expect("locate");
        let st = Stencils::new(grid);
        let (g0, g1) = (map.apply(&m.frames[0]), map.apply(&m.frames[1]));
        let (f0, f1) = (st.features(&g0), st.features(&g1));
        // H.264: the H stream of two frames (an IDR frame, then a P frame).
        let q = Quantizer::new(-0.05, 0.05);
        let s0: Vec<u8> = f0.h.iter().map(|&x| q.quantize(x)).collect();
        let s1: Vec<u8> = f1.h.iter().map(|&x| q.quantize(x)).collect();
        g.bench_function(format!("h264-encode-2-frames/{n}"), |b| {
            b.iter(|| {
                let mut e = Encoder::new(n, n, &VideoSettings::default()).expect("encoder");
                (e.encode(&s0).expect("encode"), e.encode(&s1).expect("encode"))
            })
        });
        let mut e = Encoder::new(n, n, &VideoSettings::default()).expect("encoder");
        let (a0, a1) = (e.encode(&s0).expect("encode"), e.encode(&s1).expect("encode"));
        g.bench_function(format!("h264-decode-2-frames/{n}"), |b| {
            b.iter(|| {
                let mut d = Decoder::new().expect("decoder");
                (d.decode(&a0, n, n).expect("decode"), d.decode(&a1, n, n).expect("decode"))
            })
        });
        let anchors = choose_anchors(&g0, 16);
        let at = |g: &[Vec3]| -> Vec<Vec3> { anchors.iter().map(|&i| g[i as usize]).collect() };
        // The cgv decoder after H.264: predict (rigid extrapolation plus
        // `steps` mean-curvature steps) and commit; the factorization is
        // made once per sequence, before the timed loop.
        for steps in [0u8, 1] {
            let mut p = Predictor::new(st.clone(), anchors.clone());
            let code = PredictorCode { steps, ..PredictorCode::plain(Extrapolation::Rigid) };
            let x0 = p.predict(code, Some(&g0), Some(&f0.h), &at(&g0)).expect("predict");
            p.commit(x0, &at(&g0));
            g.bench_function(format!("reconstruct-cgv-{steps}-steps/{n}"), |b| {
                b.iter(|| {
                    let x = p.predict(code, None, Some(&f1.h), &at(&g1)).expect("predict");
                    std::hint::black_box(&x);
                })
            });
        }
        // The motion decoder's whole step, commit included (the tangential
        // coefficients, and with cycle predictions on, the new frame's
        // smoothed velocity kept among the last 60): smoothed velocity with
        // cycles off, and a cycle prediction (lag 2) with them on.
        for (name, max_lag, code) in [
            ("smoothed-velocity", 0, PredictorCode::plain(Extrapolation::SmoothVelocity)),
            ("cycle", DEFAULT_MAX_LAG, PredictorCode { lag: 2, ..PredictorCode::plain(Extrapolation::Cycle) }),
        ] {
            let mut p = Predictor::new(st.clone(), Vec::new()).with_max_lag(max_lag);
            for x in [&g0, &g1, &g0, &g1] {
                p.commit(x.clone(), &[]);
            }
            g.bench_function(format!("reconstruct-motion-{name}-and-commit/{n}"), |b| {
                b.iter(|| {
                    let x = p.predict(code, None, None, &[]).expect("predict");
                    p.commit(x, &[]);
                })
            });
        }
        // Format v5: applying a motion correction after the frame's filter,
        // at the most passes the encoder chooses (4), and the encoder's
        // choice among its filters.
        let err: Vec<Vec3> = g1.iter().zip(&g0).map(|(a, b)| (*a - *b) * 0.1).collect();
        let d: Vec<Vec<f32>> = (0..3).map(|c| err.iter().map(|e| e[c]).collect()).collect();
        let mut corr = Corrections::new(CorrectionMode::Motion, Layout::WORLD, st.clone());
        corr.apply(&mut g0.clone(), vec![vec![0.0; g0.len()]; 3], (0, 0));
        g.bench_function(format!("correction-filter-4-passes/{n}"), |b| {
            b.iter(|| {
                let mut x = g0.clone();
                corr.clone().apply(&mut x, d.clone(), (4, 0));
                x
            })
        });
        g.bench_function(format!("correction-filter-choice/{n}"), |b| b.iter(|| corr.best_filter(&g0, &d, &g1)));
        // Format v9: x, y, z at half size and the normal picture, applied
        // (the decoder's step), and made (the encoder's).
        let normal = Corrections::new(CorrectionMode::Motion, Layout { shrink: 1, normal: true }, st.clone());
        let mut pictures = normal.world_pictures(&err, 0.0);
        pictures.push(normal.normal_picture(&g0, &err, &pictures, 0.0));
        g.bench_function(format!("correction-normal-apply/{n}"), |b| {
            b.iter(|| {
                let mut x = g0.clone();
                normal.clone().apply(&mut x, pictures.clone(), (0, 1));
                x
            })
        });
        g.bench_function(format!("correction-normal-pictures/{n}"), |b| {
            b.iter(|| {
                let mut p = normal.world_pictures(&err, 0.0);
                p.push(normal.normal_picture(&g0, &err, &p, 0.0));
                p
            })
        });
        // Format v13: 32 bones, their weights on a 32 x 32 grid. The
        // decoder's step (a frame's transforms from its unit, the rest pose
        // skinned, the skinned prediction; timed with a return to the rest
        // pose first, a copy and the bones' centroids) and the encoder's
        // fit of a frame's transforms.
        let mut enc = bone_predictor(grid);
        enc.commit(&g0);
        let unit = enc.encode(&g1);
        let mut dec = bone_predictor(grid);
        g.bench_function(format!("reconstruct-bones/{n}"), |b| {
            b.iter(|| {
                dec.reset();
                dec.commit(&g0);
                dec.decode(&unit).expect("bones");
                let m = dec.motion().expect("motion");
                g0.iter().zip(&m).map(|(p, d)| *p + *d).collect::<Vec<Vec3>>()
            })
        });
        g.bench_function(format!("bones-fit-a-frame/{n}"), |b| b.iter(|| enc.encode(&g1)));
        g.bench_function(format!("reconstruct-paper/{n}"), |b| {
            b.iter(|| {
                let mut s = PaperSolver::new(st.clone(), anchors.clone());
                s.set_lambda(&f1.lambda);
                s.solve_frame(&f1.h, &at(&g1), Some(&g0)).expect("solve")
            })
        });
    }
    g.finish();
}

/// 32 bones in 8 x 4 blocks of the weights' 32 x 32 grid, each sample
/// shared with the next bone.
fn bone_predictor(grid: Grid) -> SkinnedPredictor {
    let side = 32usize.min(grid.n);
    let shrink = (grid.n / side).trailing_zeros() as u8;
    let info = SkinInfo {
        bones: 32,
        shrink,
        rotation_step: 1.0 / 512.0,
        translation_step: 1e-3,
        packed: true,
        rest_step: None,
        point_weights: false,
    };
    let influences = (0..side * side)
        .map(|k| {
            let b = (8 * (k % side) / side + 8 * (4 * (k / side) / side)) as u8;
            [(b, 200), ((b + 1) % 32, 55), (0, 0), (0, 0)]
        })
        .collect();
    SkinnedPredictor::new(grid, &info, &SkinWeights { influences, ..Default::default() }).expect("bones")
}

criterion_group!(benches, bench);
criterion_main!(benches);

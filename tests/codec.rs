//! Encoding and decoding round trips on the default motion.

mod common;

use cgv::codec::{encode, h264, h264::VideoSettings, EncodeOptions, SequenceDecoder};
use cgv::container::{self, CodecKind, CorrectionMode};
use cgv::grid::Grid;
use cgv::mesh::{Bounds, FrameSource};
use cgv::param::parameterize;
use cgv::resample::SampleMap;
use cgv::solve::SolverKind;

/// Encodes `src`, decodes it with `solver`, and returns the per-frame RMS and
/// max vertex error against the uncompressed grid, relative to the diagonal.
fn round_trip(src: &dyn FrameSource, opts: &EncodeOptions, solver: SolverKind) -> (usize, Vec<(f64, f64)>) {
    let (bytes, _) = encode(src, opts, &mut |_, _, _| {}).unwrap();
    let file = container::read(&bytes).unwrap();
    let mut dec = SequenceDecoder::new(file, solver, h264::Decoder::new).unwrap();
    let first = src.read_frame(0).unwrap();
    let param = parameterize(src.topology(), &first, &opts.param).unwrap();
    let map = SampleMap::build(Grid::new(opts.grid).unwrap(), &src.topology().faces, &param).unwrap();
    let diag = Bounds::of(&first).diagonal() as f64;
    let errs = (0..src.frame_count())
        .map(|i| {
            let truth = map.apply(&src.read_frame(i).unwrap());
            let (x, _) = dec.next_frame().unwrap();
            let (rms, max) = cgv::metrics::vertex_error(&x, &truth);
            (rms / diag, max / diag)
        })
        .collect();
    (bytes.len(), errs)
}

#[test]
fn gv_round_trip_within_bounds_and_layer_two_refines() {
    let src = cgv::demo::motion(8);
    let base = EncodeOptions { codec: CodecKind::Gv, grid: 64, ..Default::default() };
    let (bytes1, e1) = round_trip(&src, &base, SolverKind::Cgv);
    let (bytes2, e2) = round_trip(&src, &EncodeOptions { layers: 2, ..base.clone() }, SolverKind::Cgv);
    let worst = |e: &[(f64, f64)]| e.iter().map(|x| x.0).fold(0.0, f64::max);
    // Measured at QP 20: 0.61 % and 0.068 % RMS of the diagonal.
    assert!(worst(&e1) < 0.008, "one layer: {e1:?}");
    assert!(worst(&e2) < 0.001, "two layers: {e2:?}");
    assert!(bytes2 > bytes1 && bytes1 > 2000, "{bytes1} {bytes2}");
    // A coarser QP gives a smaller file.
    let (bytes_coarse, _) = round_trip(
        &src,
        &EncodeOptions { video: cgv::codec::h264::VideoSettings { qp: 40, ..base.video }, ..base },
        SolverKind::Cgv,
    );
    assert!(bytes_coarse < bytes1);
}

#[test]
fn decoding_is_deterministic_and_bad_streams_are_errors() {
    let src = cgv::demo::motion(4);
    let opts = EncodeOptions { codec: CodecKind::Cgv, grid: 32, ..Default::default() };
    let (bytes, _) = encode(&src, &opts, &mut |_, _, _| {}).unwrap();
    let decode_all = |bytes: &[u8], solver| -> cgv::Result<Vec<Vec<glam::Vec3>>> {
        let file = container::read(bytes).map_err(|e| cgv::Error::Container { path: "mem".into(), source: e })?;
        let mut dec = SequenceDecoder::new(file, solver, h264::Decoder::new)?;
        (0..4).map(|_| dec.next_frame().map(|f| f.0)).collect()
    };
    for solver in [SolverKind::Cgv, SolverKind::Paper] {
        let a = decode_all(&bytes, solver).unwrap();
        let b = decode_all(&bytes, solver).unwrap();
        assert_eq!(a, b, "{solver} is not deterministic");
        assert!(a.iter().flatten().all(|p| p.is_finite()));
    }
    // Replace the first access unit with garbage under a valid CRC.
    let file = container::read(&bytes).unwrap();
    let mut h = file.header.clone();
    h.source.label = "x".into();
    let mut bad = container::write_header(&h).unwrap();
    for f in 0..h.frames {
        let garbage = vec![0, 0, 0, 1, 0x65, 0xff, 0xff, 0xff];
        let units: Vec<&[u8]> = (0..h.streams.len())
            .filter(|&s| h.stream_has_frame(s, f))
            .map(|s| if f == 0 && s == 0 { garbage.as_slice() } else { file.units[s][f as usize].as_slice() })
            .collect();
        bad.extend(container::write_frame(f, &file.frames[f as usize], &units));
    }
    bad.extend(container::write_chunk(container::TAG_END, 0, h.frames, &[]));
    let e = decode_all(&bad, SolverKind::Cgv).unwrap_err();
    assert!(matches!(e, cgv::Error::Video(_)), "{e}");
}

/// Every frame within the corrections' quantization at QP 20 (RMS 1e-3,
/// max 5e-3 of the diagonal), and none past frame 1 above 3x the mean:
/// frames 0 and 1 start the loop (no velocity yet); after them, no growth.
fn assert_faithful_without_drift(errs: &[(f64, f64)]) {
    let mean = errs.iter().map(|e| e.0).sum::<f64>() / errs.len() as f64;
    for (i, (rms, max)) in errs.iter().enumerate() {
        assert!(*rms < 1e-3 && *max < 5e-3, "frame {i}: rms {rms} max {max}");
        assert!(i < 2 || *rms < 3.0 * mean, "frame {i} drifts: rms {rms}, mean {mean}");
    }
}

#[test]
fn cgv_round_trip_is_faithful_and_does_not_drift() {
    // 12 frames of the default motion, N = 64, QP 20: the closed loop keeps
    // every frame within the corrections' quantization.
    let src = cgv::demo::motion(12);
    let opts = EncodeOptions { codec: CodecKind::Cgv, grid: 64, ..Default::default() };
    let (bytes, errs) = round_trip(&src, &opts, SolverKind::Cgv);
    eprintln!("cgv: {bytes} bytes, {errs:?}");
    assert_faithful_without_drift(&errs);
}

#[test]
fn motion_corrections_round_trip_without_drift() {
    // The same 12 frames with motion corrections (format v2, v3 without H): the decoder
    // applies the change of the running sum, and the closed loop holds.
    let src = cgv::demo::motion(12);
    let mut opts =
        EncodeOptions { codec: CodecKind::Cgv, grid: 64, corrections: CorrectionMode::Motion, ..Default::default() };
    let (bytes, errs) = round_trip(&src, &opts, SolverKind::Cgv);
    eprintln!("cgv motion QP 20: {bytes} bytes, {errs:?}");
    assert_faithful_without_drift(&errs);
    let (file_bytes, _) = encode(&src, &opts, &mut |_, _, _| {}).unwrap();
    let file = container::read(&file_bytes).unwrap();
    assert_eq!((file.version, file.header.corrections), (3, CorrectionMode::Motion));
    // No H or λ: the motion predictor takes no mean-curvature step.
    let names: Vec<&str> = file.header.streams.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["seed_x", "seed_y", "seed_z", "dx", "dy", "dz"]);
    let e = SequenceDecoder::new(file.clone(), SolverKind::Paper, h264::Decoder::new).err().expect("paper refuses");
    assert!(e.to_string().contains("leaves out"), "{e}");
    assert!(file.frames.iter().all(|f| f.correction_scale == 0.0 && f.predictor & 3 != 0 || f.predictor == 0));

    // At a coarse QP the loop still holds: no frame strays from the mean.
    opts.video.qp = 44;
    let (coarse_bytes, coarse) = round_trip(&src, &opts, SolverKind::Cgv);
    let mean = coarse.iter().map(|e| e.0).sum::<f64>() / coarse.len() as f64;
    eprintln!("cgv motion QP 44: {coarse_bytes} bytes, mean {mean:.2e}, {coarse:?}");
    assert!(mean < 1e-2 && coarse.iter().all(|e| e.0 < 1.5 * mean), "{coarse:?}");

    // Past MOTION_MAX_QP the corrections and the seed stay at it (coarser,
    // the loop breaks down): the same bytes for them at QP 48 and 51.
    let short = cgv::demo::motion(4);
    let streams = |qp: u8| {
        let o = EncodeOptions { video: VideoSettings { qp, ..opts.video }, ..opts.clone() };
        let (_, report) = encode(&short, &o, &mut |_, _, _| {}).unwrap();
        report.stream_bytes
    };
    assert_eq!(cgv::codec::MOTION_MAX_QP, 48);
    assert_eq!(streams(48), streams(51));
    assert_ne!(streams(40), streams(48));
}

#[test]
fn cgv_round_trip_at_high_quality() {
    let src = cgv::demo::motion(4);
    let mut opts = EncodeOptions { codec: CodecKind::Cgv, grid: 32, layers: 2, ..Default::default() };
    opts.video.qp = 8;
    let (bytes, errs) = round_trip(&src, &opts, SolverKind::Cgv);
    eprintln!("cgv high: {bytes} bytes, {errs:?}");
    for (i, (rms, max)) in errs.iter().enumerate() {
        assert!(*rms < 1e-4 && *max < 1e-3, "frame {i}: rms {rms} max {max}");
    }
}

#[test]
fn auto_corrections_follow_the_measured_crossover() {
    use cgv::codec::auto_corrections;
    let at = |qp: u8, kbps: Option<f32>| VideoSettings { qp, kbps, ..Default::default() };
    assert_eq!(auto_corrections(&at(20, None), 128, 30.0), CorrectionMode::Scaled);
    assert_eq!(auto_corrections(&at(26, None), 128, 30.0), CorrectionMode::Motion);
    assert_eq!(auto_corrections(&at(40, None), 128, 30.0), CorrectionMode::Motion);
    // 150 kbit/s at N = 128, 30 fps: 0.31 bits per sample per frame.
    assert_eq!(auto_corrections(&at(20, Some(150.0)), 128, 30.0), CorrectionMode::Motion);
    // 400 kbit/s: 0.81 at N = 128, 0.20 at N = 256.
    assert_eq!(auto_corrections(&at(20, Some(400.0)), 128, 30.0), CorrectionMode::Scaled);
    assert_eq!(auto_corrections(&at(20, Some(400.0)), 256, 30.0), CorrectionMode::Motion);
}

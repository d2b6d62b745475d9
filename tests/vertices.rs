//! The vertices codec (format version 20): no grid, no video, the input's
//! own vertices every frame to the asked error, or the finest a budget
//! holds; a step finer than its values hold is refused.

#![allow(clippy::unwrap_used)]

use cgv::codec::{encode, EncodeOptions, FileDecoder};
use cgv::format::Representation;
use cgv::mesh::{Bounds, FrameSource};
use cgv::solve::SolverKind;
use glam::Vec3;

fn options(percent: Option<f32>, kbps: Option<f32>) -> EncodeOptions {
    let mut opts =
        EncodeOptions { representation: Representation::Vertices, vertex_residual: percent, ..Default::default() };
    opts.video.kbps = kbps;
    opts
}

/// Every frame's decoded vertices, as the input indexes them.
fn decoded(bytes: &[u8], src: &dyn FrameSource) -> Vec<Vec<Vec3>> {
    let file = cgv::format::read(bytes).unwrap();
    assert_eq!(file.header.representation(), Representation::Vertices);
    let mut dec = FileDecoder::new(file, SolverKind::Predictive).unwrap();
    let mesh = dec.source_mesh().unwrap();
    (0..src.frame_count()).map(|_| src.on_input(dec.next_source_frame(&mesh).unwrap().1)).collect()
}

/// The worst coordinate error over all frames, and the vertex RMS relative
/// to the first frame's diagonal.
fn errors(src: &dyn FrameSource, got: &[Vec<Vec3>]) -> (f32, f64) {
    let (mut worst, mut sum, mut n) = (0f32, 0f64, 0usize);
    for (f, frame) in got.iter().enumerate() {
        for (a, b) in frame.iter().zip(src.read_frame(f).unwrap()) {
            worst = worst.max((*a - b).abs().max_element());
            sum += f64::from((*a - b).length_squared());
            n += 1;
        }
    }
    let diagonal = f64::from(Bounds::of(&src.read_frame(0).unwrap()).diagonal());
    (worst, (sum / n as f64).sqrt() / diagonal)
}

#[test]
fn a_clip_comes_back_within_half_a_step_at_every_vertex() {
    // The plain figure and the textured one (its stored vertices split at
    // the UV seams, each copy coded and decoded alike).
    for spec in ["builtin:walk", "builtin:walk-textured"] {
        let src = cgv::mesh::open_sequence(spec, &Default::default()).unwrap();
        let (bytes, report) = encode(src.as_ref(), &options(Some(0.1), None), &mut |_, _, _| {}).unwrap();
        let file = cgv::format::read(&bytes).unwrap();
        assert_eq!((file.header.min_version(), file.header.streams.len()), (20, 0), "{spec}");
        assert_eq!(file.header.appearance.is_some(), spec.ends_with("textured"), "{spec}");
        let step = file.header.vertex_residual.unwrap().step;
        let (worst, rms) = errors(src.as_ref(), &decoded(&bytes, src.as_ref()));
        assert!(worst <= 0.5 * step * 1.001, "{spec}: a coordinate {worst} off, step {step}");
        // A uniform quantizer's error: half a step's RMS over three axes.
        assert!((rms / 0.001 - 1.0).abs() < 0.05, "{spec}: vertex RMS {rms}");
        assert_eq!(report.bytes, bytes.len());
        assert!(report.source_mesh_bytes + report.vertex_residual_bytes < bytes.len(), "{report:?}");
    }
}

#[test]
fn a_budget_gets_the_finest_error_it_holds() {
    let src = cgv::mesh::builtin::motion(12);
    let mut last = f64::INFINITY;
    for kbps in [500.0, 1400.0] {
        let (bytes, report) = encode(&src, &options(None, Some(kbps)), &mut |_, _, _| {}).unwrap();
        let miss = report.budget_miss.unwrap();
        assert!((-cgv::codec::BUDGET_TOLERANCE..=0.0).contains(&miss), "{kbps} kbit/s: {miss:+.3}");
        let (_, rms) = errors(&src, &decoded(&bytes, &src));
        assert!(rms < last, "{kbps} kbit/s: {rms} after {last}");
        last = rms;
    }
    // Below the codec's smallest file: refused, saying so.
    let small = encode(&src, &options(None, Some(5.0)), &mut |_, _, _| {}).unwrap_err().to_string();
    assert!(small.contains("smallest file"), "{small}");
    // Above its finest file: refused too, saying what that file takes.
    let large = encode(&src, &options(None, Some(20000.0)), &mut |_, _, _| {}).unwrap_err().to_string();
    assert!(large.contains("finest file"), "{large}");
}

#[test]
fn a_step_finer_than_a_unit_holds_is_refused() {
    // The figure walks 40 diagonals away from where it starts: a vertex
    // 1023 steps from the first frame's centre bounds the step.
    let mut src = cgv::mesh::builtin::motion(4);
    let diagonal = Bounds::of(&src.frames[0]).diagonal();
    src.frames[3].iter_mut().for_each(|p| p.x += 40.0 * diagonal);
    let e = encode(&src, &options(Some(0.01), None), &mut |_, _, _| {}).unwrap_err().to_string();
    assert!(e.contains("at least") && e.contains("--vertex-residual"), "{e}");
    let (bytes, _) = encode(&src, &options(Some(5.0), None), &mut |_, _, _| {}).unwrap();
    let step = cgv::format::read(&bytes).unwrap().header.vertex_residual.unwrap().step;
    let (worst, _) = errors(&src, &decoded(&bytes, &src));
    assert!(worst <= 0.5 * step * 1.001, "a coordinate {worst} off, step {step}");
}

/// `cgv eval --codecs vertices`: each rate point's size met by the step,
/// measured on the input's own vertices (the file's own mesh line counted),
/// the error falling as the rate grows.
#[test]
fn the_vertices_entry_of_eval_meets_its_sizes_by_the_step() {
    use cgv::eval::{self, EvalCodec, EvalOptions, Rates};
    let src = cgv::mesh::builtin::motion(6);
    let mut opts = EvalOptions {
        codecs: vec![EvalCodec::VERTICES],
        rates: Rates::Kbps(vec![700.0, 1400.0]),
        surface_every: 3,
        ..Default::default()
    };
    opts.base.grid = 16;
    let report = eval::run(&src, &opts, &|_| {}).unwrap();
    let [low, high] = [&report.points[0].results[0], &report.points[1].results[0]];
    for (r, p) in [(low, &report.points[0]), (high, &report.points[1])] {
        assert!(r.matched && r.vertex_residual.is_some() && r.own_mesh_bytes.is_some(), "{r:?}");
        assert!(
            (r.bytes as f64 / p.target_bytes as f64 - 1.0).abs() <= opts.tolerance,
            "{} of {}",
            r.bytes,
            p.target_bytes
        );
        // A uniform quantizer on twice the asked error: the vertex RMS is it.
        let asked = f64::from(r.vertex_residual.unwrap()) / 100.0;
        assert!((r.source.vertex_rms / asked - 1.0).abs() < 0.1, "{} for {asked}", r.source.vertex_rms);
        assert!(r.surface_rms.is_some_and(|s| s < r.source.vertex_rms), "{r:?}");
    }
    assert!(high.source.vertex_rms < 0.5 * low.source.vertex_rms);
}

/// `auto` picks the vertices codec for a clip of fewer than 24 frames that
/// keeps the input's mesh and leaves the grid to it; a budget below its
/// smallest file goes to the closed loop (whose mesh line, with places and
/// offsets, is larger still: refused), one above its finest gets the
/// finest; a grid size asked for keeps the grid.
#[test]
fn auto_picks_the_vertices_codec_for_a_clip_of_a_few_frames() {
    use cgv::codec::{CodecChoice, EncodeRequest, GridChoice};
    let src = cgv::mesh::builtin::motion(8);
    let encode = |grid: GridChoice, kbps: Option<f32>| {
        let mut base = EncodeOptions::default();
        base.video.kbps = kbps;
        let r = EncodeRequest { base, codec: CodecChoice::Auto, grid, ..Default::default() };
        r.encode(&src, &mut || Ok(Vec::new()), &mut |_, _, _| {}).map(|m| m.report)
    };
    let request = |grid, kbps| encode(grid, kbps).unwrap();
    let plain = request(GridChoice::Auto, None);
    assert_eq!(plain.codec, Representation::Vertices);
    let small = encode(GridChoice::Auto, Some(40.0)).unwrap_err().to_string();
    assert!(small.contains("source mesh") && small.contains("ask for more"), "{small}");
    let ample = request(GridChoice::Auto, Some(50_000.0));
    assert_eq!(ample.codec, Representation::Vertices);
    assert!(ample.budget_miss.is_some_and(|m| m < -0.5), "{:?}", ample.budget_miss);
    assert_ne!(request(GridChoice::Size(16), None).codec, Representation::Vertices);
    // A clip that moves far from where it starts holds no 0.05 % step:
    // the closed loop, saying why.
    let mut far = cgv::mesh::builtin::motion(4);
    let diagonal = Bounds::of(&far.frames[0]).diagonal();
    far.frames[3].iter_mut().for_each(|p| p.x += 40.0 * diagonal);
    let r = EncodeRequest { codec: CodecChoice::Auto, ..Default::default() };
    let made = r.encode(&far, &mut || Ok(Vec::new()), &mut |_, _, _| {}).unwrap();
    assert_ne!(made.report.codec, Representation::Vertices);
    assert!(made.report.auto_passed_over.as_deref().is_some_and(|w| w.contains("at least")), "{:?}", made.report);
    // 24 frames and more: the skinned codec, as before.
    let long = cgv::mesh::builtin::motion(24);
    let r = EncodeRequest { grid: GridChoice::Size(16), ..Default::default() };
    let made = r.encode(&long, &mut || Ok(Vec::new()), &mut |_, _, _| {}).unwrap();
    assert_ne!(made.report.codec, Representation::Vertices);
}

//! The encoder (native: it drives OpenH264). Two passes over the input, so
//! no more than one frame is held at a time: the first finds each stream's
//! range, the second quantizes and codes; for the `cgv` decoder it also runs
//! that decoder on what it coded (closed loop, see [`crate::solve::cgv`]).

use super::features::{Features, Stencils};
use super::h264::{Decoder as H264Decoder, Encoder as H264Encoder, VideoSettings};
use super::quant::{Quantizer, Range};
use super::{choose_anchors, Corrections, VideoDecoder, CORRECTION, SEED};
use crate::container::{
    self, CodecKind, CorrectionMode, Coverage, FrameInfo, Header, Settings, SourceInfo, StreamInfo,
};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::mesh::{analyze, Bounds, FrameSource};
use crate::param::choose::parameterize_for_grid;
use crate::param::{ParamOptions, Parameterization};
use crate::resample::SampleMap;
use crate::solve::cgv::{
    Extrapolation, Predictor, PredictorCode, ALL_EXTRAPOLATIONS, DEFAULT_MAX_LAG, MOTION_EXTRAPOLATIONS,
};
use crate::solve::SolverKind;
use glam::Vec3;

/// How much finer (in QP) the frame-0 seed is coded than the other streams,
/// and the finest QP it gets. Measured on the default motion at N = 64: at
/// QP 40 frame 0 was 3.5x the sequence's mean error with the seed at QP 40,
/// 1.2x at QP 16; but a seed at QP 0 leaves white 8-bit rounding noise that
/// the correction streams cannot code (frame 0 at 0.078 % of the diagonal
/// at QP 20, against 0.028 % with the seed at QP 8).
pub const SEED_QP_OFFSET: u8 = 24;
pub const SEED_MIN_QP: u8 = 8;

/// Anchors per frame for the paper's solver, by default.
pub const PAPER_ANCHORS: usize = 16;

/// How to encode.
#[derive(Debug, Clone)]
pub struct EncodeOptions {
    pub codec: CodecKind,
    pub grid: usize,
    pub video: VideoSettings,
    /// A key frame (λ) every this many frames; 0 for the first frame only.
    pub key_interval: u32,
    /// Anchor samples stored per frame (float32). `None`: the codec's
    /// default, [`PAPER_ANCHORS`] for CGV without corrections (the paper's
    /// solver needs them) and none with corrections (measured: on the
    /// default motion at N = 64, 16 anchors cost 10–60 % more bytes than
    /// none for the same or higher error; 192 bytes a frame is 46 kbit/s).
    pub anchors: Option<usize>,
    /// CGV for the `cgv` decoder: code the closed-loop corrections (else the
    /// decoder runs open loop on H and the anchors alone, and drifts).
    pub correction: bool,
    /// CGV for the `cgv` decoder: how the corrections apply (see
    /// [`CorrectionMode`]; motion needs format version 2, and
    /// leaves out H and λ, version 3).
    pub corrections: CorrectionMode,
    /// CGV: most mean-curvature steps a frame's predictor may take.
    pub max_steps: u8,
    /// CGV with motion corrections: code the corrections on frames 0, 1
    /// and every this many frames after (the file's key frames); the frames
    /// between are the prediction alone, and cost no picture at all (an
    /// all-skip picture still costs about 10 bytes a stream).
    pub correction_interval: u32,
    /// CGV with corrections: the longest lag a cycle prediction may use
    /// (0: none). The file uses cycles only where they pay ([`CYCLE_GAIN`]),
    /// and its `max_lag` is the longest lag the uncoded loop chose, so that
    /// a decoder keeps no more past velocities than the motion needs.
    pub max_lag: u8,
    /// CGV with corrections: let the encoder choose a filter for each
    /// frame's correction (format version 5, see
    /// [`Corrections`](super::Corrections)); off, every frame's is 0 (for
    /// measuring what the filter does).
    pub correction_filter: bool,
    /// 1, or 2 for a residual layer on every stream but the seeds.
    pub layers: u8,
    /// Layer-2 range, in layer-1 quantization steps.
    pub residual_steps: f32,
    /// The decoder recorded in the file as intended.
    pub solver: SolverKind,
    pub param: ParamOptions,
    /// The frame whose surface is parameterized.
    pub reference: usize,
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions {
            codec: CodecKind::Cgv,
            grid: 128,
            video: VideoSettings::default(),
            key_interval: 10,
            anchors: None,
            correction: true,
            corrections: CorrectionMode::Scaled,
            max_steps: 1,
            correction_interval: 1,
            max_lag: DEFAULT_MAX_LAG,
            correction_filter: true,
            layers: 1,
            residual_steps: 8.0,
            solver: SolverKind::Cgv,
            param: ParamOptions::default(),
            reference: 0,
        }
    }
}

/// What an encode produced.
#[derive(Debug, Clone, serde::Serialize)]
pub struct EncodeReport {
    pub bytes: usize,
    pub frames: usize,
    /// Bytes of H.264 per stream.
    pub stream_bytes: Vec<(String, usize)>,
    /// Bytes of the frame chunks besides the access units: framing, lengths,
    /// predictor, correction scale and anchors.
    pub side_bytes: usize,
    pub parameterization: Parameterization,
    pub seconds_parameterize: f64,
    pub seconds_coding: f64,
    pub seconds_total: f64,
}

struct Stream {
    info: StreamInfo,
    enc: H264Encoder,
    /// What H.264 kept, as the decoder will see it.
    dec: H264Decoder,
    bytes: usize,
}

fn values<'a>(name: &str, f: &'a Features, g: &'a [Vec3], scratch: &'a mut Vec<f32>) -> &'a [f32] {
    match name {
        "H" => &f.h,
        "lambda" => &f.lambda,
        _ => {
            let c = match name {
                "x" | "seed_x" => 0,
                "y" | "seed_y" => 1,
                _ => 2,
            };
            scratch.clear();
            scratch.extend(g.iter().map(|p| p[c]));
            scratch
        }
    }
}

/// Encodes a motion into `.cgv` bytes. `progress(stage, done, total)` is
/// called as frames are processed.
pub fn encode(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(Vec<u8>, EncodeReport)> {
    let prepared = prepare(src, opts)?;
    encode_prepared(src, opts, &prepared, progress)
}

/// What every encode of one motion at one grid size shares: the
/// parameterization of the reference frame and the grid's sample map.
pub struct Prepared {
    pub param: Parameterization,
    pub map: SampleMap,
    pub seconds: f64,
}

/// Checks the options and the motion, parameterizes, and locates the samples.
pub fn prepare(src: &dyn FrameSource, opts: &EncodeOptions) -> Result<Prepared> {
    let t_start = std::time::Instant::now();
    let grid = Grid::new(opts.grid)?;
    if grid.n < 16 {
        return Err(Error::Argument(format!("grid size {} is below H.264's 16x16 minimum", grid.n)));
    }
    let frames = src.frame_count();
    if opts.reference >= frames {
        return Err(Error::Argument(format!(
            "reference frame {} is past the last frame {}",
            opts.reference,
            frames as i64 - 1
        )));
    }
    let topology = src.topology();
    let reference = src.read_frame(opts.reference)?;
    if let Err(problem) = analyze(topology, &reference).require_sphere() {
        return Err(Error::mesh(src.label(), problem));
    }
    let param = parameterize_for_grid(topology, &reference, grid, &opts.param)?;
    let map = SampleMap::build(grid, &topology.faces, &param)?;
    Ok(Prepared { param, map, seconds: t_start.elapsed().as_secs_f64() })
}

/// [`encode`] with the parameterization already made (see [`prepare`]).
pub fn encode_prepared(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    prepared: &Prepared,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(Vec<u8>, EncodeReport)> {
    let t_start = std::time::Instant::now();
    let grid = Grid::new(opts.grid)?;
    if prepared.map.grid.n != grid.n {
        return Err(Error::Argument("the prepared sample map is for another grid size".into()));
    }
    if !(1..=2).contains(&opts.layers) {
        return Err(Error::Argument(format!("layers must be 1 or 2, not {}", opts.layers)));
    }
    let closed_loop = opts.codec == CodecKind::Cgv && opts.solver == SolverKind::Cgv && opts.correction;
    let anchor_count = opts.anchors.unwrap_or(if closed_loop { 0 } else { PAPER_ANCHORS });
    if opts.codec == CodecKind::Cgv && anchor_count < 4 && !closed_loop {
        return Err(Error::Argument(
            "CGV without corrections (or for the paper's solver) needs at least 4 anchors".into(),
        ));
    }
    let frames = src.frame_count();
    let topology = src.topology().clone();
    let reference = src.read_frame(opts.reference)?;
    let map = &prepared.map;
    let seconds_parameterize = prepared.seconds;
    let st = Stencils::new(grid);
    let motion = closed_loop && opts.corrections == CorrectionMode::Motion;
    // Motion files have no λ: their key frames are the frames with
    // corrections, 0, 1 (which has no velocity to predict with yet), then
    // every `interval`-th.
    let interval = if motion { opts.correction_interval } else { opts.key_interval };
    if motion && interval == 0 {
        return Err(Error::Argument("the correction interval must be at least 1".into()));
    }
    let corrected = |f: usize| !motion || f == 0 || (f - 1) % interval as usize == 0;
    let key_frames: Vec<u32> = match (interval, motion) {
        (0, _) | (1, true) => vec![0],
        (_, true) => (0..frames as u32).filter(|&f| corrected(f as usize)).collect(),
        _ => (0..frames as u32).step_by(interval as usize).collect(),
    };
    let mut names: Vec<(&str, Coverage)> = match opts.codec {
        CodecKind::Gv => vec![("x", Coverage::All), ("y", Coverage::All), ("z", Coverage::All)],
        CodecKind::Cgv => {
            // Motion files leave out H and λ (format version 3): the motion
            // predictor never chose an H step (0 frames of 48-175 on
            // horse-gallop, pcow and samba at QP 36 and 44), and they were
            // 7-10 % of its files.
            let mut v = if motion { Vec::new() } else { vec![("H", Coverage::All), ("lambda", Coverage::Key)] };
            v.extend(SEED.map(|s| (s, Coverage::First)));
            v
        }
    };
    if closed_loop {
        let coverage = if motion && interval > 1 { Coverage::Key } else { Coverage::All };
        names.extend(CORRECTION.map(|s| (s, coverage)));
    }
    let is_correction = |name: &str| CORRECTION.contains(&name);

    // Pass 1: ranges (the corrections are scaled per frame instead).
    let mut ranges = vec![Range::default(); names.len()];
    let mut first_grid = Vec::new();
    let mut scratch = Vec::new();
    for fi in 0..frames {
        let g = map.apply(&src.read_frame(fi)?);
        let feats = if opts.codec == CodecKind::Cgv { st.features(&g) } else { Features::default() };
        let key = key_frames.binary_search(&(fi as u32)).is_ok();
        for (k, (name, cov)) in names.iter().enumerate() {
            let has = match cov {
                Coverage::All => true,
                Coverage::Key => key,
                Coverage::First => fi == 0,
            };
            if has && !is_correction(name) {
                ranges[k].add(values(name, &feats, &g, &mut scratch));
            }
        }
        if fi == 0 {
            first_grid = g;
        }
        progress("analysing", fi + 1, frames);
    }
    let anchors = if opts.codec == CodecKind::Cgv { choose_anchors(&first_grid, anchor_count) } else { Vec::new() };
    let allowed: &[Extrapolation] = if motion { &MOTION_EXTRAPOLATIONS } else { &ALL_EXTRAPOLATIONS };
    let uncoded = if closed_loop && (motion || opts.max_lag > 0) {
        // Without cycles, and with them where allowed: cycle predictions
        // only where the motion repeats (see CYCLE_GAIN).
        let lags: &[u8] = if opts.max_lag > 0 { &[0, opts.max_lag] } else { &[0] };
        let mut runs = uncoded_loops(src, map, &st, &first_grid, allowed, lags, &corrected)?.into_iter();
        let without = runs.next().ok_or_else(|| Error::Numerical("no uncoded loop".into()))?;
        match runs.next() {
            Some(w) if w.energy < CYCLE_GAIN * without.energy => Some(w),
            _ => Some(without),
        }
    } else {
        None
    };
    let max_lag = uncoded.as_ref().map_or(0, |u| u.longest_lag);
    let motion_quant = match (&uncoded, motion) {
        (Some(u), true) => u.running_sum_quantizers(),
        _ => Vec::new(),
    };

    // Streams: layer 1 for each name, then layer 2 refinements.
    let mut infos: Vec<StreamInfo> = names
        .iter()
        .zip(&ranges)
        .map(|((name, cov), r)| StreamInfo {
            name: name.to_string(),
            layer: 1,
            refines: None,
            quant: match CORRECTION.iter().position(|c| c == name) {
                Some(c) if motion => motion_quant[c],
                Some(_) => Quantizer::new(-1.0, 1.0),
                None => r.quantizer(),
            },
            coverage: *cov,
            scaled: is_correction(name) && !motion,
        })
        .collect();
    if opts.layers == 2 {
        for k in 0..names.len() {
            if names[k].1 == Coverage::First {
                continue;
            }
            infos.push(StreamInfo {
                name: names[k].0.to_string(),
                layer: 2,
                refines: Some(k as u16),
                quant: infos[k].quant.residual(opts.residual_steps),
                coverage: names[k].1,
                scaled: false,
            });
        }
    }
    // A bitrate target is shared among the streams by how many frames each codes.
    let weight = |c: Coverage| match c {
        Coverage::All => 1.0,
        Coverage::Key => key_frames.len() as f32 / frames as f32,
        Coverage::First => 1.0 / frames as f32,
    };
    let total_weight: f32 = infos.iter().map(|i| weight(i.coverage)).sum();
    let mut streams: Vec<Stream> = Vec::with_capacity(infos.len());
    for info in &infos {
        let mut vs = opts.video;
        // Rate control spreads a stream's bits over the pictures it has.
        vs.fps = src.fps() * if info.coverage == Coverage::Key { weight(Coverage::Key) } else { 1.0 };
        if info.coverage == Coverage::First {
            // The seed is one frame that every later frame is predicted
            // from: finer than the rest, at a constant QP.
            vs.qp = vs.qp.saturating_sub(SEED_QP_OFFSET).max(SEED_MIN_QP);
            vs.kbps = None;
        } else if let Some(kbps) = opts.video.kbps {
            vs.kbps = Some((kbps * weight(info.coverage) / total_weight).max(1.0));
        }
        streams.push(Stream {
            info: info.clone(),
            enc: H264Encoder::new(grid.n, grid.n, &vs)?,
            dec: H264Decoder::new()?,
            bytes: 0,
        });
    }

    let header = Header {
        grid: grid.n as u32,
        seam: container::SEAM_RULE.into(),
        frames: frames as u32,
        fps: src.fps(),
        codec: opts.codec,
        streams: infos,
        key_frames: key_frames.clone(),
        anchors: anchors.clone(),
        solver: opts.solver.to_string(),
        settings: Settings {
            qp: opts.video.qp,
            kbps: opts.video.kbps,
            gop: opts.video.gop,
            cabac: opts.video.cabac,
            layers: opts.layers,
            residual_steps: if opts.layers == 2 { opts.residual_steps } else { 0.0 },
        },
        source: SourceInfo {
            label: src.label().display().to_string(),
            vertices: topology.vertex_count as u32,
            faces: topology.faces.len() as u32,
            diagonal: Bounds::of(&reference).diagonal(),
        },
        corrections: if motion { CorrectionMode::Motion } else { CorrectionMode::Scaled },
        max_lag,
    };
    let mut out =
        container::write_header(&header).map_err(|e| Error::Container { path: src.label().into(), source: e })?;

    // Pass 2: code. With corrections the encoder runs the decoder's
    // predictor on the decoded data (closed loop), so what it corrects is
    // exactly what the decoder will have.
    let mut predictor = Predictor::new(st.clone(), anchors.clone()).with_max_lag(max_lag);
    let mut corrections = Corrections::new(header.corrections, st.clone());
    let mut seconds_coding = 0.0;
    let mut side_bytes = 0;
    let (pre, post): (Vec<usize>, Vec<usize>) = (0..streams.len()).partition(|&k| {
        let base = streams[k].info.refines.map_or(k, usize::from);
        !is_correction(&streams[base].info.name)
    });
    for fi in 0..frames {
        let g = map.apply(&src.read_frame(fi)?);
        let feats = if opts.codec == CodecKind::Cgv { st.features(&g) } else { Features::default() };
        let t = std::time::Instant::now();
        let mut coder = FrameCoder {
            header: &header,
            frame: fi as u32,
            decoded: vec![None; streams.len()],
            units: vec![None; streams.len()],
        };
        coder.code(&mut streams, &pre, &|name| values(name, &feats, &g, &mut Vec::new()).to_vec())?;
        let anchor_pos: Vec<Vec3> = anchors.iter().map(|&a| g[a as usize]).collect();
        let mut info = FrameInfo {
            predictor: 0,
            lag: 0,
            filter: 0,
            correction_scale: 0.0,
            anchors: anchor_pos.iter().map(|p| p.to_array()).collect(),
        };
        if closed_loop {
            let vals = super::frame_values(&header, &coder.decoded, 0.0)?;
            let get = |name: &str| -> Option<&Vec<f32>> { header.stream(name).and_then(|s| vals[s].as_ref()) };
            let seed = super::positions(&get, SEED);
            let hv = get("H").map(Vec::as_slice);
            // Choose the predictor that lands closest to the true frame.
            let (code, pred) = predictor.closest(allowed, opts.max_steps, seed.as_deref(), hv, &anchor_pos, &g)?;
            let err: Vec<Vec3> = g.iter().zip(&pred).map(|(p, q)| *p - *q).collect();
            let scale = if motion { 0.0 } else { correction_scale(&err) };
            let carried = corrections.stream_values(err, scale);
            coder.code(&mut streams, &post, &|name| {
                let c = CORRECTION.iter().position(|&n| n == name).unwrap_or(0);
                carried.iter().map(|e| e[c]).collect()
            })?;
            let vals = super::frame_values(&header, &coder.decoded, scale)?;
            let get = |name: &str| -> Option<&Vec<f32>> { header.stream(name).and_then(|s| vals[s].as_ref()) };
            let mut x = pred;
            match super::positions(&get, CORRECTION) {
                Some(d) => {
                    if opts.correction_filter {
                        info.filter = corrections.best_filter(&x, &d, &g);
                    }
                    corrections.apply(&mut x, d, info.filter);
                }
                None if !corrected(fi) => {}
                None => return Err(Error::Video("corrections were not coded".into())),
            }
            predictor.commit(x, &anchor_pos);
            info.predictor = code.to_byte();
            info.lag = code.lag;
            info.correction_scale = scale;
        }
        seconds_coding += t.elapsed().as_secs_f64();
        let units: Vec<&[u8]> = coder.units.iter().flatten().map(Vec::as_slice).collect();
        let chunk = container::write_frame(fi as u32, &info, &units);
        for (k, au) in coder.units.iter().enumerate() {
            streams[k].bytes += au.as_ref().map_or(0, Vec::len);
        }
        side_bytes += chunk.len() - units.iter().map(|u| u.len()).sum::<usize>();
        out.extend_from_slice(&chunk);
        progress("encoding", fi + 1, frames);
    }
    out.extend_from_slice(&container::write_chunk(container::TAG_END, 0, frames as u32, &[]));
    let report = EncodeReport {
        bytes: out.len(),
        frames,
        stream_bytes: streams
            .iter()
            .map(|s| (format!("{}{}", s.info.name, if s.info.layer == 2 { "/2" } else { "" }), s.bytes))
            .collect(),
        side_bytes,
        parameterization: prepared.param.clone(),
        seconds_parameterize,
        seconds_coding,
        seconds_total: seconds_parameterize + t_start.elapsed().as_secs_f64(),
    };
    Ok((out, report))
}

/// Cycle predictions are used in a file only if, on the true frames, they
/// cut the corrections' total squared size below this fraction of what the
/// velocity predictors leave. Chosen per frame wherever merely closer, they
/// cost more than they saved on motion that does not repeat: samba at 69
/// kbit/s (N = 128) took cycles at lags 2 to 41 on 132 of 175 frames, for
/// 8 % less correction energy, and its vertex RMS rose from 0.54 % to
/// 0.90 % (the running sum then adds up differences of unrelated
/// velocities, which widened its range 45 %). Measured ratios at N = 128:
/// horse-gallop 0.35 (a 24-frame gallop played twice), the default motion
/// (72 frames, two gait cycles) 0.66, pcow 0.88, samba 0.92.
pub const CYCLE_GAIN: f64 = 0.75;

/// What the closed loop does on the true frames (no coding): the range of
/// the motion-mode running sum and the longest cycle lag it chose.
struct UncodedLoop {
    ranges: [Range; 3],
    longest_lag: u8,
    /// Sum over the corrected frames of the squared corrections.
    energy: f64,
}

impl UncodedLoop {
    /// Motion mode: the quantizers of the three correction streams. The
    /// streams carry the running sum of the corrections, so their range is
    /// the uncoded loop's, widened by [`MOTION_MARGIN`] for the coding
    /// noise; a value outside is clamped and the next frame's correction
    /// takes up the rest. The three share one width (each keeps its own
    /// centre): the same step on every axis spends the bits where the
    /// squared error is (equal distortion per component is what minimizes
    /// the total at a given rate); per-axis widths made the narrow axes
    /// finer than the wide one needed.
    fn running_sum_quantizers(&self) -> Vec<Quantizer> {
        let width = self.ranges.iter().map(|r| r.quantizer()).map(|q| q.max - q.min).fold(0.0, f32::max);
        self.ranges
            .iter()
            .map(|r| {
                let q = r.quantizer();
                let half = width * (0.5 + MOTION_MARGIN);
                let centre = (q.min + q.max) / 2.0;
                Quantizer::new(centre - half, centre + half)
            })
            .collect()
    }
}

/// Runs the loop without coding (no anchors, no H steps: what the motion
/// predictor uses), once for each longest lag in `lags`, over one reading
/// of the frames: the frames with corrections (`corrected`) are decoded as
/// the true ones, the others as their prediction.
fn uncoded_loops(
    src: &dyn FrameSource,
    map: &SampleMap,
    st: &Stencils,
    seed: &[Vec3],
    allowed: &[Extrapolation],
    lags: &[u8],
    corrected: &dyn Fn(usize) -> bool,
) -> Result<Vec<UncodedLoop>> {
    struct Run {
        sim: Predictor,
        sum: Vec<Vec3>,
        out: UncodedLoop,
    }
    let mut runs: Vec<Run> = lags
        .iter()
        .map(|&lag| Run {
            sim: Predictor::new(st.clone(), Vec::new()).with_max_lag(lag),
            sum: vec![Vec3::ZERO; st.grid.len()],
            out: UncodedLoop { ranges: [Range::default(); 3], longest_lag: 0, energy: 0.0 },
        })
        .collect();
    for fi in 0..src.frame_count() {
        let g = map.apply(&src.read_frame(fi)?);
        for Run { sim, sum, out } in &mut runs {
            let (code, pred): (PredictorCode, _) = sim.closest(allowed, 0, Some(seed), None, &[], &g)?;
            out.longest_lag = out.longest_lag.max(code.lag);
            if !corrected(fi) {
                sim.commit(pred, &[]);
                continue;
            }
            out.energy += crate::solve::cgv::squared_distance(&g, &pred);
            for ((s, p), q) in sum.iter_mut().zip(&g).zip(&pred) {
                *s += *p - *q;
            }
            for (c, r) in out.ranges.iter_mut().enumerate() {
                r.add(&sum.iter().map(|s| s[c]).collect::<Vec<f32>>());
            }
            sim.commit(g.clone(), &[]);
        }
    }
    Ok(runs.into_iter().map(|r| r.out).collect())
}

/// The correction mode that measured better for these settings (cgv eval
/// on samba, pcow and horse-gallop at N = 128 and 256, docs/RESULTS.md):
/// motion below [`AUTO_SCALED_BITS`] bits per grid sample per frame or at
/// QP [`AUTO_MOTION_QP`] and coarser, scaled above (where its per-frame
/// scale buys precision that a fixed 8-bit range cannot).
pub fn auto_corrections(video: &VideoSettings, grid: usize, fps: f32) -> CorrectionMode {
    let motion = match video.kbps {
        Some(kbps) => (kbps as f64 * 1000.0 / fps.max(1e-3) as f64 / (grid * grid) as f64) < AUTO_SCALED_BITS,
        None => video.qp >= AUTO_MOTION_QP,
    };
    if motion {
        CorrectionMode::Motion
    } else {
        CorrectionMode::Scaled
    }
}

/// See [`auto_corrections`]: the best mode changed between 0.3-0.4 (motion)
/// and 0.7-1.1 (scaled) bits per sample per frame, and between motion at
/// QP 26-27 and scaled at QP 23-35 (whose files were as large as motion's
/// at QP 20-25).
pub const AUTO_SCALED_BITS: f64 = 0.5;
pub const AUTO_MOTION_QP: u8 = 26;

/// How much wider (each side, as a fraction of the range) the motion-mode
/// quantizers are than the uncoded loop's values. Measured on samba at
/// N = 128: 0.1 left no visible clamping; a range 25 % too narrow (clamping
/// the extremes) cost 1.9x the bytes for 1.7x the error at QP 24.
pub const MOTION_MARGIN: f32 = 0.1;

/// The correction scale: the largest error component, rounded up to a power
/// of 2^(1/4), so that consecutive frames usually share it (H.264 predicts
/// across frames best when sample values mean the same thing). Clipping the
/// largest errors instead (a 99.5 % quantile) was measured worse: what is
/// clipped comes back doubled through the velocity extrapolation.
fn correction_scale(err: &[Vec3]) -> f32 {
    let m = err.iter().map(|e| e.abs().max_element()).filter(|m| m.is_finite()).fold(0.0, f32::max);
    if m <= 0.0 {
        return f32::MIN_POSITIVE.sqrt();
    }
    2f32.powf((m.log2() * 4.0).ceil() / 4.0).max(m)
}

/// One frame's coding: its access units and what the decoder will see.
struct FrameCoder<'a> {
    header: &'a Header,
    frame: u32,
    /// Decoded 8-bit samples per stream (as a decoder gets them).
    decoded: Vec<Option<Vec<u8>>>,
    units: Vec<Option<Vec<u8>>>,
}

impl FrameCoder<'_> {
    /// Codes streams `ks` (each layer 2 after its base) with the values
    /// `value_of(name)`, in the natural domain.
    fn code(&mut self, streams: &mut [Stream], ks: &[usize], value_of: &dyn Fn(&str) -> Vec<f32>) -> Result<()> {
        let n = self.header.grid as usize;
        for &k in ks {
            if !self.header.stream_has_frame(k, self.frame) {
                continue;
            }
            let info = &streams[k].info;
            let q = info.quant;
            let samples: Vec<u8> = match info.refines {
                None => value_of(&info.name).iter().map(|&v| q.quantize(v)).collect(),
                Some(base) => {
                    // What layer 1 left.
                    let bq = streams[base as usize].info.quant;
                    let b = self.decoded[base as usize]
                        .as_ref()
                        .ok_or_else(|| Error::Video("layer 2 before its base layer".into()))?;
                    value_of(&info.name).iter().zip(b).map(|(&v, &d)| q.quantize(v - bq.dequantize(d))).collect()
                }
            };
            let au = streams[k].enc.encode(&samples)?;
            self.decoded[k] = Some(streams[k].dec.decode(&au, n, n)?);
            self.units[k] = Some(au);
        }
        Ok(())
    }
}

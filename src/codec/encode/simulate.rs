//! Step 3: the closed loop on the true frames, without coding: whether
//! cycle predictions pay ([`CYCLE_GAIN`]) and how long a lag the file needs,
//! and, for motion corrections, the range of their running sum.

use super::plan::Plan;
use super::EncodeOptions;
use crate::codec::corrections::{Corrections, Layout};
use crate::error::{Error, Result};
use crate::format::quant::{Quantizer, Range};
use crate::format::CorrectionMode;
use crate::grid::Stencils;
use crate::mesh::FrameSource;
use crate::resample::SampleMap;
use crate::solve::predictor::{squared_distance, Extrapolation, Predictor, PredictorCode};
use crate::solve::skinned::SkinnedPredictor;
use glam::Vec3;
use rayon::prelude::*;

/// What the simulation decided.
pub(super) struct Simulation {
    /// The file's `max_lag` (0: no cycle predictions).
    pub max_lag: u8,
    /// Motion corrections: the quantizers of the three correction streams.
    pub motion_quant: Vec<Quantizer>,
    /// Whether the file predicts with the bones it was given (see [`BONE_GAIN`]).
    pub bones: bool,
}

/// Runs the uncoded loop where the plan needs it: always for motion
/// corrections or bones, and for scaled ones when cycles are allowed.
pub(super) fn simulate(
    src: &dyn FrameSource,
    plan: &Plan,
    opts: &EncodeOptions,
    (map, st): (&SampleMap, &Stencils),
    skin: Option<&SkinnedPredictor>,
) -> Result<Simulation> {
    if !(plan.closed_loop && (plan.motion || opts.max_lag > 0 || skin.is_some())) {
        return Ok(Simulation { max_lag: 0, motion_quant: Vec::new(), bones: false });
    }
    // Without cycles, and with them where allowed: cycle predictions only
    // where the motion repeats (see CYCLE_GAIN); each without bones and,
    // if given, with them (see BONE_GAIN).
    let lags: &[u8] = if opts.max_lag > 0 { &[0, opts.max_lag] } else { &[0] };
    let skins: &[Option<&SkinnedPredictor>] = if skin.is_some() { &[None, skin] } else { &[None] };
    let variants: Vec<(u8, Option<&SkinnedPredictor>)> =
        lags.iter().flat_map(|&l| skins.iter().map(move |&s| (l, s))).collect();
    let frames = Frames { corrected: &|f| plan.corrected(f), rap: &|f| plan.is_rap(f) };
    let runs = uncoded_loops(src, (map, st, plan.layout), plan.allowed, &variants, &frames, opts)?;
    // The run of a longest lag, with bones or without.
    let run =
        |lag: u8, bones: bool| variants.iter().position(|v| v.0 == lag && v.1.is_some() == bones).map(|k| &runs[k]);
    let energy = |lag: u8, bones: bool| run(lag, bones).map_or(f64::INFINITY, |r| r.energy);
    let bones = energy(0, true) < BONE_GAIN * energy(0, false);
    let lag = if energy(opts.max_lag, bones) < CYCLE_GAIN * energy(0, bones) { opts.max_lag } else { 0 };
    let kept = run(lag, bones).ok_or_else(|| Error::Numerical("no uncoded loop".into()))?;
    let motion_quant = if plan.motion { kept.running_sum_quantizers() } else { Vec::new() };
    Ok(Simulation { max_lag: kept.longest_lag, motion_quant, bones })
}

/// Bones are used in a file only if, on the true frames, they cut the
/// corrections' total squared size below this fraction of what the other
/// predictors leave: their weights and every frame's transforms cost bits
/// (samba, 32 bones at N = 128: a 6.6 KB chunk and about 150 bytes a
/// frame). Measured ratios (N = 128, 32 bones): horse-gallop 0.011, pcow
/// 0.016, samba 0.096, the default motion 0.02; horse-collapse 0.56, where
/// bones cost +24 % BD-rate on vertex RMS (`cgv eval`, normal codec), so
/// it is left out.
pub const BONE_GAIN: f64 = 0.25;

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
    /// Of x, y, z, and the normal picture if there is one.
    ranges: Vec<Range>,
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
    /// finer than the wide one needed. A normal picture (format v9) shares
    /// it too, though its own range is narrower (what x, y, z leave): on
    /// samba at N = 128 its own range gave +12 % BD-rate (surface RMS)
    /// against x, y, z at full size, 2x it -4 %, 3x -9 %, 4x -8 %, and the
    /// shared width is about 2.6x.
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

/// Which frames have corrections, and which are random-access points.
struct Frames<'a> {
    corrected: &'a (dyn Fn(usize) -> bool + Sync),
    rap: &'a (dyn Fn(usize) -> bool + Sync),
}

/// Runs the loop without coding (no anchors, no H steps: what the motion
/// predictor uses), once for each longest lag and bones in `variants`, over one reading
/// of the frames: the frames with corrections are decoded as the true
/// ones, the others as their prediction; at each random-access point the
/// loop starts afresh from the true frame, as the decoder does from its seed.
/// Where `opts` slide the samples, the true frame is slid to the prediction as the
/// coding loop slides it (`super::slide`).
fn uncoded_loops(
    src: &dyn FrameSource,
    (map, st, layout): (&SampleMap, &Stencils, Layout),
    allowed: &[Extrapolation],
    variants: &[(u8, Option<&SkinnedPredictor>)],
    frames: &Frames,
    opts: &EncodeOptions,
) -> Result<Vec<UncodedLoop>> {
    struct Run {
        sim: Predictor,
        /// The motion-mode running sum of the corrections, as pictures.
        sum: Corrections,
        out: UncodedLoop,
    }
    let mut runs: Vec<Run> = variants
        .iter()
        .map(|&(lag, skin)| Run {
            sim: Predictor::new(st.clone(), Vec::new()).with_max_lag(lag).with_skin(skin.cloned()),
            sum: Corrections::new(CorrectionMode::Motion, layout, st.clone()),
            out: UncodedLoop {
                ranges: vec![Range::default(); 3 + usize::from(layout.normal)],
                longest_lag: 0,
                energy: 0.0,
            },
        })
        .collect();
    for fi in 0..src.frame_count() {
        let g = map.apply(&src.read_frame(fi)?);
        let surface = super::slide::Surface::of_frame(src, opts, fi)?;
        let rap = (frames.rap)(fi);
        // The runs are independent: one per core.
        runs.par_iter_mut().try_for_each(|Run { sim, sum, out }| -> Result<()> {
            if rap {
                sim.reset();
                sum.reset();
            }
            let seed = rap.then_some(g.as_slice());
            sim.encode_bones(&g);
            let (code, pred): (PredictorCode, _) = sim.closest(allowed, 0, seed, None, &[], &g)?;
            out.longest_lag = out.longest_lag.max(code.lag);
            if !(frames.corrected)(fi) {
                sim.commit(pred, &[]);
                return Ok(());
            }
            let g = match &surface {
                Some(surface) => super::slide::slid(st, &g, &pred, surface),
                None => g.clone(),
            };
            out.energy += squared_distance(&g, &pred);
            let err: Vec<Vec3> = g.iter().zip(&pred).map(|(p, q)| *p - *q).collect();
            let mut pictures = sum.world_pictures(&err, 0.0);
            if layout.normal {
                let normal = sum.normal_picture(&pred, &err, &pictures, 0.0);
                pictures.push(normal);
            }
            for (r, p) in out.ranges.iter_mut().zip(&pictures) {
                r.add(p);
            }
            sum.record(pictures);
            sim.commit(g, &[]);
            Ok(())
        })?;
    }
    Ok(runs.into_iter().map(|r| r.out).collect())
}

/// How much wider (each side, as a fraction of the range) the motion-mode
/// quantizers are than the uncoded loop's values. Measured on samba at
/// N = 128: 0.1 left no visible clamping; a range 25 % too narrow (clamping
/// the extremes) cost 1.9x the bytes for 1.7x the error at QP 24.
pub const MOTION_MARGIN: f32 = 0.1;

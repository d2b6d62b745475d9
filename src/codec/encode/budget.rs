//! With a bitrate (`--kbps`): the whole file, not only its video, kept
//! within [`BUDGET_TOLERANCE`] of the bitrate times the motion's duration.
//!
//! OpenH264's rate control alone missed by 9–60 % on 60-frame clips (it
//! spreads a stream's bits over that stream's pictures only, cannot spend
//! what a well-predicted stream does not need, and knows nothing of the
//! chunks around the video: frame side data, the source mesh). So the
//! encode is repeated, at most [`MAX_PASSES`] times, with the video's
//! target scaled by how far the last file's video part missed what the
//! budget leaves it (the file minus what the rate control does not
//! govern), and the closest file is kept. A budget the codec cannot meet
//! at all is refused, with the smallest file it makes (QP 51 everywhere)
//! or the largest (QP 0). One it can meet that the passes still missed
//! (a clip of a few frames leaves the rate control little to spread its
//! bits over) gets a constant QP instead, bisected on the files' sizes,
//! where that lands nearer. Where the file keeps the input's mesh and the
//! budget is large (at least [`RESIDUAL_BUDGET_BITS`]), a vertex residual
//! under the same budget is tried too, and the file with the lower vertex
//! RMS on the input's vertices kept: past the grid's floor more video buys
//! nothing.

use super::residual_step::search_step;
use super::target::{residual_qp_for, Truth, COARSEST_QP};
use super::{encode_prepared, encode_prepared_into, EncodeOptions, EncodeReport, COARSE_WEIGHTS_QP};
use crate::error::{Error, Result};
use crate::geometry_image::GeometryImage;
use crate::mesh::FrameSource;
use crate::output::{Count, Sink};

/// How far from the budget a file may be: 5 %, the bound. The
/// passes aim at the middle.
pub const BUDGET_TOLERANCE: f64 = 0.05;
/// Most encodes one budget takes before the bounds are checked.
pub const MAX_PASSES: usize = 5;
/// Bits per input vertex per frame from which a budget tries a vertex
/// residual too. The skinned file without one measured cheaper at equal
/// vertex error up to about 4.5 bits/v/f on pcow and horse-collapse and
/// 6 to 8 on horse-gallop and samba (docs/RESULTS.md, "The vertex
/// residual"): below 3 the try would cost its encodes for nothing.
pub const RESIDUAL_BUDGET_BITS: f64 = 3.0;

/// A budget's vertex residual try: its step and QP, the errors of the file
/// with it and of the one without (relative to the diagonal, on the
/// sampled frames `--target-error` measures), and which was kept: the
/// lower vertex RMS on the input's vertices, what the residual codes and
/// what users compare with Draco and gltfpack.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct BudgetResidual {
    /// The residual's step, percent of the diagonal (`--vertex-residual`).
    pub percent: f32,
    /// The video's QP under it.
    pub qp: u8,
    pub vertex_rms_with: f64,
    pub surface_rms_with: f64,
    /// None where the file without a residual cannot reach the budget.
    pub vertex_rms_without: Option<f64>,
    pub surface_rms_without: Option<f64>,
    pub kept: bool,
}

/// [`super::encode_prepared`] within [`BUDGET_TOLERANCE`] of
/// `opts.video.kbps` × the duration (one plain pass without a bitrate).
pub fn encode_on_budget(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    image: &GeometryImage,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(Vec<u8>, EncodeReport)> {
    encode_on_budget_into(src, opts, image, &mut || Ok(Vec::new()), progress)
}

/// [`encode_on_budget`] with each pass written into a sink of its own
/// from `open`; the closest pass's sink is returned, the others dropped.
/// Bones the options leave to the encoder (`bones: None`) are a fixed cost
/// that a small budget may not afford: where the file with them cannot
/// keep it, the budget is tried without them.
pub fn encode_on_budget_into<S: Sink>(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    image: &GeometryImage,
    open: &mut dyn FnMut() -> Result<S>,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(S, EncodeReport)> {
    let opts = &with_weights_for_budget(src, opts, image)?;
    if let Some(qp) = residual_budget_qp(src, opts) {
        return with_residual_tried(src, opts, image, qp, open, progress);
    }
    with_or_without_bones(src, opts, image, open, progress)
}

/// The budget as asked, or without the encoder's bones where the file with
/// them cannot keep it.
fn with_or_without_bones<S: Sink>(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    image: &GeometryImage,
    open: &mut dyn FnMut() -> Result<S>,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(S, EncodeReport)> {
    match on_budget(src, opts, image, open, progress) {
        Err(Error::BudgetTooSmall(_)) if opts.bones.is_none() && opts.video.kbps.is_some() => {
            let without = EncodeOptions { bones: Some(0), ..opts.clone() };
            on_budget(src, &without, image, open, progress)
        }
        r => r,
    }
}

/// The video's QP for a budget's residual try, where the budget has one:
/// a bitrate of at least [`RESIDUAL_BUDGET_BITS`] a vertex a frame, for a
/// file that can have a residual (`--target-error`'s rule).
fn residual_budget_qp(src: &dyn FrameSource, opts: &EncodeOptions) -> Option<u8> {
    let kbps = f64::from(opts.video.kbps?);
    let vertices = src.topology().vertex_count.max(1) as f64;
    let bits = kbps * 1000.0 / f64::from(src.fps()).max(1e-3) / vertices;
    residual_qp_for(opts).filter(|_| bits >= RESIDUAL_BUDGET_BITS)
}

/// The budget kept as asked and with a vertex residual (its step searched
/// for the budget at `qp`), each measured on the sampled frames as
/// `--target-error` measures; the file within the budget with the lower
/// vertex RMS is kept, the report's `budget_residual` saying what was
/// tried, its passes and times adding up every encode and measure.
fn with_residual_tried<S: Sink>(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    image: &GeometryImage,
    qp: u8,
    open: &mut dyn FnMut() -> Result<S>,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(S, EncodeReport)> {
    let start = std::time::Instant::now();
    // The file without one, unless the budget is past its largest.
    let plain = match with_or_without_bones(src, opts, image, &mut || Ok(Vec::new()), progress) {
        Ok(p) => Ok(p),
        Err(Error::BudgetTooLarge(why)) => Err(why),
        Err(e) => return Err(e),
    };
    let target = budget_bytes(src, opts.video.kbps.unwrap_or_default());
    let (found, mut passes, mut coding) = residual_for_budget(src, opts, image, qp, target, progress)?;
    if let Ok((_, r)) = &plain {
        (passes, coding) = (passes + r.passes, coding + r.seconds_coding);
    }
    let account = |mut r: EncodeReport, passes: usize, coding: f64| {
        (r.passes, r.seconds_coding) = (passes, coding);
        r.seconds_total = r.seconds_parameterize + start.elapsed().as_secs_f64();
        r
    };
    let mut kept = |bytes: Vec<u8>, report: EncodeReport| -> Result<(S, EncodeReport)> {
        let mut sink = open()?;
        sink.put(&bytes)?;
        Ok((sink, report))
    };
    let Some(percent) = found else {
        let (plain, report) = plain.map_err(Error::BudgetTooLarge)?;
        return kept(plain, account(report, passes, coding));
    };
    let (bytes, report) = encode_prepared(src, &residual_options(opts, qp, percent), image, &mut |_, _, _| {})?;
    let (passes, coding) = (passes + 1, coding + report.seconds_coding);
    let truth = Truth::read(src)?;
    let with = truth.errors(&bytes, src, image)?;
    let plain = plain.ok().map(|(b, r)| truth.errors(&b, src, image).map(|e| (b, r, e))).transpose()?;
    let tried = BudgetResidual {
        percent: percent as f32,
        qp,
        vertex_rms_with: with.1.unwrap_or(f64::NAN),
        surface_rms_with: with.0,
        vertex_rms_without: plain.as_ref().map(|p| p.2 .1.unwrap_or(f64::NAN)),
        surface_rms_without: plain.as_ref().map(|p| p.2 .0),
        kept: plain.as_ref().is_none_or(|(_, r, e)| !within(r.budget_miss) || closer(with, *e)),
    };
    match plain {
        Some((plain, report, _)) if !tried.kept => {
            kept(plain, account(EncodeReport { budget_residual: Some(tried), ..report }, passes, coding))
        }
        _ => {
            let miss = Some(report.bytes as f64 / target - 1.0);
            let report = EncodeReport { budget_residual: Some(tried), budget_miss: miss, ..report };
            kept(bytes, account(report, passes, coding))
        }
    }
}

/// The residual's step (percent of the diagonal) whose file lands within
/// [`BUDGET_TOLERANCE`] of `target` bytes, if one does, with the encodes
/// the search took and their coding seconds.
fn residual_for_budget(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    image: &GeometryImage,
    qp: u8,
    target: f64,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(Option<f64>, usize, f64)> {
    let (mut nearest, mut coding): (Option<(f64, usize)>, f64) = (None, 0.0);
    let tries = search_step(target as usize, BUDGET_TOLERANCE / 2.0, &mut |p| {
        let label = format!("a {p:.3} % vertex residual for the budget");
        let r =
            encode_prepared_into(src, &residual_options(opts, qp, p), image, &mut Count::default(), &mut |s, d, t| {
                progress(&format!("{s} ({label})"), d, t)
            })?;
        coding += r.seconds_coding;
        if nearest.is_none_or(|(_, s)| off(s, target) > off(r.bytes, target)) {
            nearest = Some((p, r.bytes));
        }
        Ok(r.bytes)
    })?;
    let found = nearest.filter(|(_, s)| off(*s, target) <= BUDGET_TOLERANCE).map(|(p, _)| p);
    Ok((found, tries, coding))
}

/// The options of a budget's residual file: `opts` at a constant `qp` with
/// a vertex residual of `percent` (what [`with_residual_tried`] made, for
/// the options a caller reports).
pub(super) fn residual_options(opts: &EncodeOptions, qp: u8, percent: f64) -> EncodeOptions {
    EncodeOptions { vertex_residual: Some(percent as f32), ..at_constant_qp(opts, qp) }
}

/// How far a file of `size` bytes is from `target`, as a fraction.
fn off(size: usize, target: f64) -> f64 {
    (size as f64 / target - 1.0).abs()
}

/// Whether a budget's file is within [`BUDGET_TOLERANCE`] (no miss: yes).
fn within(miss: Option<f64>) -> bool {
    miss.is_none_or(|m| m.abs() <= BUDGET_TOLERANCE)
}

/// Whether errors `a` (surface RMS, vertex RMS) are below `b`: by the
/// vertex RMS where both have one, else by the surface RMS.
fn closer(a: (f64, Option<f64>), b: (f64, Option<f64>)) -> bool {
    match (a.1, b.1) {
        (Some(x), Some(y)) => x < y,
        _ => a.0 < b.0,
    }
}

/// A budget of `kbps` in bytes over the motion's duration.
fn budget_bytes(src: &dyn FrameSource, kbps: f32) -> f64 {
    f64::from(kbps) * 1000.0 / 8.0 * src.frame_count() as f64 / f64::from(src.fps())
}

/// The skinned codec under a bitrate, its weights left to the rate: coarse
/// where the budget is below the fine-weighted file at
/// [`COARSE_WEIGHTS_QP`] (one encode to find out), as a constant QP from
/// there on would have them.
fn with_weights_for_budget(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    image: &GeometryImage,
) -> Result<EncodeOptions> {
    let mut o = opts.clone();
    let Some(kbps) = opts.video.kbps.filter(|_| opts.vertex_bones() && opts.coarse_weights.is_none()) else {
        return Ok(o);
    };
    let fine = EncodeOptions { coarse_weights: Some(false), ..at_constant_qp(opts, COARSE_WEIGHTS_QP) };
    let size = encode_prepared_into(src, &fine, image, &mut Count::default(), &mut |_, _, _| {})?.bytes;
    o.coarse_weights = Some(size as f64 > budget_bytes(src, kbps));
    Ok(o)
}

/// [`encode_on_budget_into`] with the options as they are.
fn on_budget<S: Sink>(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    image: &GeometryImage,
    open: &mut dyn FnMut() -> Result<S>,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(S, EncodeReport)> {
    let Some(kbps) = opts.video.kbps else {
        let mut sink = open()?;
        let report = encode_prepared_into(src, opts, image, &mut sink, progress)?;
        return Ok((sink, report));
    };
    let target = budget_bytes(src, kbps);
    let miss = |size: usize| off(size, target);
    let mut o = opts.clone();
    let mut best: Option<(S, EncodeReport)> = None;
    let (mut coding, mut total, mut passes) = (0.0, 0.0, 0);
    for pass in 0..MAX_PASSES {
        let mut sink = open()?;
        let report = encode_prepared_into(src, &o, image, &mut sink, &mut |stage, done, total| {
            progress(&format!("{stage} (pass {} for {kbps} kbit/s)", pass + 1), done, total)
        })?;
        coding += report.seconds_coding;
        total += report.seconds_total - if pass > 0 { report.seconds_parameterize } else { 0.0 };
        passes = pass + 1;
        let (size, video) = (report.bytes, report.stream_bytes.iter().map(|s| s.1).sum::<usize>());
        let fixed = size - video;
        let (mesh, residual) = (report.source_mesh_bytes, report.vertex_residual_bytes);
        let scaled = o.video.kbps.unwrap_or(kbps) as f64 * (target - fixed as f64) / video.max(1) as f64;
        if best.as_ref().is_none_or(|b| miss(size) < miss(b.1.bytes)) {
            best = Some((sink, report));
        }
        if miss(size) <= BUDGET_TOLERANCE / 2.0 {
            break;
        }
        if target <= fixed as f64 {
            let mut way_out =
                if mesh > 0 { format!(", {mesh} of them the source mesh (--no-source-mesh)") } else { String::new() };
            if residual > 0 {
                way_out += &format!(", {residual} the vertex residual (a larger --vertex-residual, or none)");
            }
            return Err(Error::BudgetTooSmall(format!(
                "a budget of {kbps} kbit/s is {target:.0} bytes for this motion, and what is not video alone \
                 takes {fixed}{way_out}: ask for more"
            )));
        }
        o.video.kbps = Some(scaled.clamp(0.01, 1e7) as f32);
    }
    let (sink, mut report) = best.ok_or_else(|| Error::Argument("no encode was made".into()))?;
    (report.passes, report.seconds_coding, report.seconds_total) = (passes, coding, total);
    report.budget_miss = Some(report.bytes as f64 / target - 1.0);
    if miss(report.bytes) <= BUDGET_TOLERANCE {
        return Ok((sink, report));
    }
    refuse_or_keep(src, opts, image, target, (sink, report), open)
}

/// When the passes missed: the budget is refused if it is outside what
/// the codec can make at all (QP 51 or QP 0 on every stream), else the
/// nearer of the closest pass and the best constant QP is kept, its
/// `budget_miss` saying by how much.
fn refuse_or_keep<S: Sink>(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    image: &GeometryImage,
    target: f64,
    closest: (S, EncodeReport),
    open: &mut dyn FnMut() -> Result<S>,
) -> Result<(S, EncodeReport)> {
    let seconds = src.frame_count() as f64 / f64::from(src.fps());
    let kbps = |bytes: usize| bytes as f64 * 8.0 / 1000.0 / seconds;
    let at_qp = |qp: u8| -> Result<usize> {
        Ok(encode_prepared_into(src, &at_constant_qp(opts, qp), image, &mut Count::default(), &mut |_, _, _| {})?.bytes)
    };
    let size = closest.1.bytes as f64;
    if size > target {
        let smallest = at_qp(COARSEST_QP)?;
        if smallest as f64 > target * (1.0 + BUDGET_TOLERANCE) {
            return Err(Error::BudgetTooSmall(format!(
                "the smallest file this codec makes of this motion (QP 51) is {:.1} kbit/s, above the budget of {:.1}",
                kbps(smallest),
                kbps(target as usize)
            )));
        }
    } else {
        let largest = at_qp(0)?;
        if (largest as f64) < target * (1.0 - BUDGET_TOLERANCE) {
            // One 8-bit layer saturates (GV at N = 128 near 400 kbit/s on
            // samba): a second layer can spend more, where the layout has one.
            if opts.layers == 1 && !(opts.normal_correction() && opts.closed_loop()) {
                let two = EncodeOptions { layers: 2, ..opts.clone() };
                drop(closest);
                return on_budget(src, &two, image, open, &mut |_, _, _| {});
            }
            return Err(Error::BudgetTooLarge(format!(
                "the largest file this codec makes of this motion (QP 0{}) is {:.1} kbit/s, below the budget of {:.1}",
                if opts.layers == 2 { ", two layers" } else { ", one layer: a normal correction has no second" },
                kbps(largest),
                kbps(target as usize)
            )));
        }
    }
    nearer_by_qp(src, opts, image, target, closest, open)
}

/// A budget the codec can reach that the rate control missed (a few
/// frames leave it little to spread over): the constant QP whose file is
/// nearest the budget, bisected on sizes alone (a file shrinks as the QP
/// rises), replaces the closest pass where it is nearer.
fn nearer_by_qp<S: Sink>(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    image: &GeometryImage,
    target: f64,
    closest: (S, EncodeReport),
    open: &mut dyn FnMut() -> Result<S>,
) -> Result<(S, EncodeReport)> {
    let t = std::time::Instant::now();
    let at = |qp: u8| at_constant_qp(opts, qp);
    let (mut sizes, mut coding) = (Vec::new(), 0.0);
    let mut size_at = |qp: u8| -> Result<usize> {
        if let Some(&(_, size)) = sizes.iter().find(|s: &&(u8, usize)| s.0 == qp) {
            return Ok(size);
        }
        let r = encode_prepared_into(src, &at(qp), image, &mut Count::default(), &mut |_, _, _| {})?;
        coding += r.seconds_coding;
        sizes.push((qp, r.bytes));
        Ok(r.bytes)
    };
    let (mut lo, mut hi) = (0u8, 51u8);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if size_at(mid)? as f64 >= target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let (size_lo, size_hi) = (size_at(lo)?, size_at(hi)?);
    let miss = |size: usize| off(size, target);
    let (qp, size) = if miss(size_lo) <= miss(size_hi) { (lo, size_lo) } else { (hi, size_hi) };
    let searched = sizes.len();
    if miss(size) >= miss(closest.1.bytes) {
        return Ok(closest);
    }
    let (earlier, earlier_coding, earlier_total) =
        (closest.1.passes, closest.1.seconds_coding, closest.1.seconds_total);
    drop(closest);
    let mut sink = open()?;
    let mut report = encode_prepared_into(src, &at(qp), image, &mut sink, &mut |_, _, _| {})?;
    // Every coding of the frames: the rate-control passes, the search, this one.
    report.passes = earlier + searched + 1;
    report.seconds_coding += earlier_coding + coding;
    report.seconds_total = earlier_total + t.elapsed().as_secs_f64();
    report.budget_miss = Some(report.bytes as f64 / target - 1.0);
    Ok((sink, report))
}

/// `opts` with every stream at a constant `qp`, no rate control.
fn at_constant_qp(opts: &EncodeOptions, qp: u8) -> EncodeOptions {
    let mut o = opts.clone();
    (o.video.qp, o.video.kbps, o.video.qp_max) = (qp, None, None);
    o
}

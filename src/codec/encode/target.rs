//! `cgv encode --target-error E`: the smallest file whose surface RMS is at
//! most E of the bounding-box diagonal, the other way to ask for a size,
//! since the error is what a user knows.
//!
//! The error is measured as `cgv eval` measures it (the symmetric surface
//! distance between the decoded grid, without the carrier's added faces,
//! or the skinned codec's decoded mesh, and the input's frame, relative to
//! the first frame's diagonal; mean over frames), on [`SAMPLE_FRAMES`] frames spread over the motion, so
//! that no more than those are held. The file is decoded as a decoder
//! would, so the figure includes everything the decoder does. The QP is
//! bisected (an error that falls as the QP falls), then bisected again with
//! the kept file's corrections where the auto rules change them: 7 to 12
//! encodes (docs/RESULTS.md, "`--target-error`"). Where the file keeps the
//! input's mesh, a vertex residual (format v18) is tried too, at
//! [`RESIDUAL_QP`]: below the grid's floor it is the only way to the
//! target, and above it often the smaller file (1 to 4 more encodes).

use crate::codec::{encode_prepared, CodecChoice, EncodeOptions, EncodeReport, FileDecoder};
use crate::error::{Error, Result};
use crate::format::Representation;
use crate::geometry_image::{surface_vertices, GeometryImage};
use crate::mesh::{Bounds, Frame, FrameSource};
use crate::metrics::surface;

/// Frames the error is measured on (all of a shorter motion).
pub const SAMPLE_FRAMES: usize = 12;
/// H.264's coarsest QP: a file kept there is the codec's smallest.
pub const COARSEST_QP: u8 = 51;
/// The video's QP under a vertex residual, by codec: the skinned codec's
/// residual video is cheap and the vertex residual's bits follow its
/// error little (pcow's first 48 frames, N = 128, a 0.1 % residual: QP
/// 36 / 42 / 48 / 51 5.93 / 5.71 / 5.66 / 5.79 bits/v/f, all 0.094 to 0.099
/// % vertex RMS); the closed loop's grid carries the whole motion, and a
/// fine one leaves the residual less (face-poses, 0.1 %: QP 20 / 30 / 40,
/// 9.7 / 15.1 / 17.1 bits/v/f).
pub const RESIDUAL_QP: [(Representation, u8); 2] = [(Representation::Skinned, 45), (Representation::Normal, 20)];
/// Steps of the vertex residual's search: from the target itself (its
/// vertex RMS about the target, its surface RMS below), coarser while the
/// target holds.
const RESIDUAL_STEPS: [f64; 4] = [1.0, 1.5, 2.25, 3.375];

/// What [`encode_to_error`] made.
#[derive(Debug, Clone, serde::Serialize)]
pub struct TargetReport {
    /// The file's surface RMS over the sampled frames, relative to the diagonal.
    pub surface_rms: f64,
    /// The QP of the file kept.
    pub qp: u8,
    /// The vertex residual of the file kept (percent of the diagonal), if
    /// it has one.
    pub vertex_residual: Option<f32>,
    /// The frames it was measured on.
    pub frames_measured: Vec<usize>,
    /// Encodes the search took.
    pub encodes: usize,
}

/// The options and geometry image for a target error. `regrid` is given
/// for `--grid auto`: `opts` are on N = 128, whose resampling floor then
/// decides the grid ([`crate::codec::auto_grid_for_error`]), and
/// `regrid(n)` makes the options on another grid. One rule for the CLI and
/// Python.
pub fn prepare_for_error(
    src: &dyn FrameSource,
    opts: EncodeOptions,
    target: f64,
    regrid: Option<&dyn Fn(usize) -> Result<EncodeOptions>>,
) -> Result<(EncodeOptions, GeometryImage)> {
    let image = crate::codec::prepare(src, &opts)?;
    let Some(regrid) = regrid else { return Ok((opts, image)) };
    let diagonal = Bounds::of(&src.read_frame(opts.reference)?).diagonal() as f64;
    let floor = image.param.score.unwrap_or(0.0) / diagonal.max(f64::MIN_POSITIVE);
    match crate::codec::auto_grid_for_error(target, floor) {
        n if n == opts.grid => Ok((opts, image)),
        n => {
            let opts = regrid(n)?;
            let image = crate::codec::prepare(src, &opts)?;
            Ok((opts, image))
        }
    }
}

/// The frames measured: evenly spread, first and last included.
fn sample(frames: usize) -> Vec<usize> {
    let k = SAMPLE_FRAMES.min(frames);
    let mut s: Vec<usize> = (0..k).map(|i| if k > 1 { i * (frames - 1) / (k - 1) } else { 0 }).collect();
    s.dedup();
    s
}

/// The input's sampled frames and the diagonal errors are relative to.
pub(super) struct Truth {
    frames: Vec<(usize, Frame)>,
    diagonal: f64,
}

impl Truth {
    pub(super) fn read(src: &dyn FrameSource) -> Result<Truth> {
        let frames =
            sample(src.frame_count()).into_iter().map(|f| Ok((f, src.read_frame(f)?))).collect::<Result<Vec<_>>>()?;
        let diagonal = frames.first().map_or(0.0, |(_, x)| Bounds::of(x).diagonal() as f64);
        Ok(Truth { frames, diagonal })
    }

    /// The surface RMS of a file over the sampled frames, relative to the
    /// diagonal: of its grid, or of the input's mesh where the file's bones
    /// act on it (the skinned codec's grid is a residual) or it has a
    /// vertex residual.
    pub(super) fn measure(&self, bytes: &[u8], src: &dyn FrameSource, image: &GeometryImage) -> Result<f64> {
        Ok(self.errors(bytes, src, image)?.0)
    }

    /// [`Self::measure`]'s surface RMS, and where the file carries the
    /// input's mesh the vertex RMS of its vertices as decoded, both
    /// relative to the diagonal.
    pub(super) fn errors(
        &self,
        bytes: &[u8],
        src: &dyn FrameSource,
        image: &GeometryImage,
    ) -> Result<(f64, Option<f64>)> {
        let file =
            crate::format::read(bytes).map_err(|e| Error::Container { path: src.label().to_path_buf(), source: e })?;
        let solver = file.header.solver;
        let on_mesh = file.header.adds_at_vertices();
        let mut dec = FileDecoder::new(file, solver)?;
        let mesh = dec.source_mesh();
        let (topology, faces) = (src.topology(), image.surface_faces(src.topology()));
        let (mut surface, mut squared) = (0.0, 0.0);
        let last = self.frames.last().map_or(0, |s| s.0);
        let mut next = self.frames.iter().peekable();
        for f in 0..=last {
            let (x, _) = dec.next_frame()?;
            let Some((_, truth)) = next.next_if(|s| s.0 == f) else { continue };
            let vertices = mesh.as_ref().map(|m| src.on_input(m.vertices(&x, dec.loose(), dec.at_vertices())));
            if let Some(v) = &vertices {
                let sum: f64 = v.iter().zip(truth.iter()).map(|(a, b)| f64::from((*a - *b).length_squared())).sum();
                squared += sum / v.len().max(1) as f64;
            }
            let d = match vertices.filter(|_| on_mesh) {
                Some(v) => surface::symmetric(&v, &topology.faces, truth, &topology.faces)?,
                None => surface::symmetric(&surface_vertices(&x, dec.loose()), &faces, truth, &topology.faces)?,
            };
            surface += d.rms;
        }
        let (n, diagonal) = (self.frames.len().max(1) as f64, self.diagonal.max(f64::MIN_POSITIVE));
        let vertex = mesh.is_some().then(|| (squared / n).sqrt() / diagonal);
        Ok((surface / n / diagonal, vertex))
    }
}

/// Encodes at the coarsest QP whose file is within `target` (a fraction of
/// the diagonal: 0.0005 for 0.05 %); refuses a target the finest QP misses,
/// with the error it reaches.
pub fn encode_to_error(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    codec: CodecChoice,
    image: &GeometryImage,
    target: f64,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(Vec<u8>, EncodeReport, TargetReport)> {
    if !(target.is_finite() && target > 0.0) {
        return Err(Error::Argument(format!("the target error must be above 0, not {target}")));
    }
    let start = std::time::Instant::now();
    let truth = Truth::read(src)?;
    let (mut encodes, mut coding) = (0, 0.0);
    // One encode at `qp`, with the codec's choices for it (the corrections
    // and, for `auto`, the layout), or those of `pin` (see below).
    let mut try_qp = |qp: u8, pin: Option<&EncodeOptions>| -> Result<Found> {
        let mut o = opts.clone();
        (o.video.qp, o.video.kbps) = (qp, None);
        let mut o = codec.apply(o, Some(opts.solver))?;
        if let Some(p) = pin {
            (o.corrections, o.representation, o.vertex_residual) = (p.corrections, p.representation, p.vertex_residual);
        }
        let label = format!("QP {qp} for {:.4} %", 100.0 * target);
        let (bytes, report) =
            encode_prepared(src, &o, image, &mut |stage, d, t| progress(&format!("{stage} ({label})"), d, t))?;
        encodes += 1;
        coding += report.seconds_coding;
        let error = truth.measure(&bytes, src, image)?;
        Ok(Found { bytes, report, error, qp, options: o })
    };
    let (kept, missed) = bisect(target, 0, 30, &mut |qp| try_qp(qp, None))?;
    let residual = match residual_qp(opts, codec) {
        Some(qp) => with_residual(target, &mut |p| try_qp(qp, Some(&residual_options(opts, codec, qp, p)?)))?,
        None => None,
    };
    let (kept, residual) = match (kept, residual) {
        (Some(k), Some(r)) if r.bytes.len() < k.bytes.len() => (r, true),
        (Some(k), _) => (k, false),
        (None, Some(r)) => (r, true),
        (None, None) => return Err(refusal(target, missed.as_ref(), opts.vertex_bones())),
    };
    let mut kept = kept;
    // The auto rules change the corrections at some QPs (motion from QP
    // 26 on), and the error can jump there (samba at N = 128: 0.067 % at
    // QP 25, 0.168 % at 26): so past such a boundary the coarser QPs are
    // searched again with the kept file's corrections.
    if !residual && missed.as_ref().is_some_and(|m| m.qp == kept.qp + 1 && differs(&m.options, &kept.options)) {
        let pin = kept.options.clone();
        let (coarser, _) =
            bisect(target, kept.qp, (kept.qp + COARSEST_QP).div_ceil(2), &mut |qp| try_qp(qp, Some(&pin)))?;
        if let Some(c) = coarser.filter(|c| c.bytes.len() < kept.bytes.len()) {
            kept = c;
        }
    }
    let Found { bytes, mut report, error: surface_rms, qp, options } = kept;
    // The times add up every pass, measuring included.
    (report.passes, report.seconds_coding) = (encodes, coding);
    report.seconds_total = report.seconds_parameterize + start.elapsed().as_secs_f64();
    let frames_measured = sample(src.frame_count());
    let vertex_residual = options.vertex_residual;
    Ok((bytes, report, TargetReport { surface_rms, qp, vertex_residual, frames_measured, encodes }))
}

/// The video's QP for a vertex residual, where the file can have one (it
/// keeps the input's mesh and the options leave the residual to the
/// encoder).
fn residual_qp(opts: &EncodeOptions, codec: CodecChoice) -> Option<u8> {
    residual_qp_for(&codec.apply(opts.clone(), Some(opts.solver)).ok()?)
}

/// [`residual_qp`] for options whose codec is settled: the file keeps the
/// input's mesh over a grid the encoder knows, and the options leave the
/// residual to the encoder (a `--kbps` budget asks this too).
pub(super) fn residual_qp_for(o: &EncodeOptions) -> Option<u8> {
    let eligible = o.source_mesh && !o.frame_meshes && o.vertex_residual.is_none() && o.grid_known();
    eligible.then(|| residual_qp_of(o.representation))
}

/// [`RESIDUAL_QP`]'s QP for a representation (the closed loop's for any
/// not listed).
pub fn residual_qp_of(r: Representation) -> u8 {
    RESIDUAL_QP.iter().find(|(c, _)| *c == r).map_or(RESIDUAL_QP[1].1, |(_, q)| *q)
}

/// The options of a try at `qp` with a vertex residual of `percent`.
fn residual_options(opts: &EncodeOptions, codec: CodecChoice, qp: u8, percent: f64) -> Result<EncodeOptions> {
    let mut o = opts.clone();
    (o.video.qp, o.video.kbps) = (qp, None);
    let o = codec.apply(o, Some(opts.solver))?;
    Ok(EncodeOptions { vertex_residual: Some(percent as f32), ..o })
}

/// The coarsest vertex residual of [`RESIDUAL_STEPS`] times the target that
/// meets it (`encode(percent)`), if any does.
fn with_residual(target: f64, encode: &mut dyn FnMut(f64) -> Result<Found>) -> Result<Option<Found>> {
    let mut kept = None;
    for step in RESIDUAL_STEPS {
        let found = encode(100.0 * target * step)?;
        if found.error > target {
            break;
        }
        kept = Some(found);
    }
    Ok(kept)
}

/// One encode and its measured error.
struct Found {
    bytes: Vec<u8>,
    report: EncodeReport,
    error: f64,
    qp: u8,
    options: EncodeOptions,
}

fn differs(a: &EncodeOptions, b: &EncodeOptions) -> bool {
    a.corrections != b.corrections || a.representation != b.representation
}

/// Bisects QPs above `floor` (known to meet the target, or 0), starting at
/// `first`, for the coarsest that meets it: that encode, and the finest
/// that missed it.
fn bisect(
    target: f64,
    floor: u8,
    first: u8,
    encode: &mut dyn FnMut(u8) -> Result<Found>,
) -> Result<(Option<Found>, Option<Found>)> {
    let (mut meets, mut misses): (Option<Found>, Option<Found>) = (None, None);
    let mut qp = first.max(floor);
    loop {
        let found = encode(qp)?;
        if found.error <= target {
            meets = Some(found);
        } else {
            misses = Some(found);
        }
        let hi = misses.as_ref().map_or(COARSEST_QP + 1, |m| m.qp);
        // Known to meet: the coarsest that did, else the floor (0 is not known).
        let lo = meets.as_ref().map(|m| m.qp).or((floor > 0).then_some(floor));
        match lo {
            Some(lo) if hi <= lo + 1 => return Ok((meets, misses)),
            Some(lo) => qp = (lo + hi) / 2,
            None if hi == 0 => return Ok((meets, misses)),
            None => qp = hi / 2,
        }
    }
}

fn refusal(target: f64, at_zero: Option<&Found>, skinned: bool) -> Error {
    let further = if skinned { "more --bones, or a larger --grid" } else { "a larger --grid, or --layers 2" };
    Error::Argument(format!(
        "a surface RMS of {:.4} % of the diagonal is below what this file reaches: {:.4} % at QP 0 \
         ({further}, goes further)",
        100.0 * target,
        100.0 * at_zero.map_or(f64::NAN, |m| m.error)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sampled_frames_span_the_motion() {
        assert_eq!(sample(1), vec![0]);
        assert_eq!(sample(5), vec![0, 1, 2, 3, 4]);
        let s = sample(175);
        assert_eq!((s.len(), s[0], s[s.len() - 1]), (SAMPLE_FRAMES, 0, 174));
    }
}

//! The vertices codec (format version 20): a file without a grid or video
//! that codes the input's own vertices every frame, as the vertex residual
//! unit codes what a video misses (`crate::codec::vertex_residual`), here
//! from a fixed origin: each vertex as what the parallelogram rule over
//! the mesh misses (Touma and Gotsman 1998, "Triangle mesh compression"),
//! or its change from the frame before, plain or so predicted, whichever
//! codes smallest, on a step of twice the asked RMS error.
//!
//! It is for clips of a few frames, where what users ship is Draco on
//! every frame (the same parallelogram rule, the faces each frame) and a
//! video's fixed cost (the seed, the first pictures, the grid's places)
//! is most of a file: here the faces are coded once and nothing else is.
//! It stores no λ or H and no grid: neither conformal nor a geometry video.

use super::{plan, EncodeOptions, EncodeReport, BUDGET_TOLERANCE};
use crate::codec::vertex_residual::VertexResidual;
use crate::error::{Error, Result};
use crate::format::vertex_residual::{VertexResidualInfo, MAX_VALUE};
use crate::format::{self, CodecKind, FrameInfo, Header, Representation, Settings, SourceInfo, SourceMesh};
use crate::mesh::{Bounds, FrameSource};
use crate::output::Sink;
use crate::solve::SolverKind;
use glam::Vec3;
use std::time::Instant;

/// The vertex RMS error (percent of the first frame's bounding-box
/// diagonal) of a vertices file for which neither `--vertex-residual` nor
/// a bitrate is given: below what the peers' finest common setting gives
/// on the shared sequences (docs/RESULTS.md).
pub const DEFAULT_VERTEX_PERCENT: f32 = 0.05;

/// The coarsest error a budget's search tries (percent of the diagonal).
const COARSEST_PERCENT: f64 = 10.0;

/// Most bytes of frames held in memory for a budget's passes; a longer
/// motion is read again on each pass.
const HELD_BYTES: usize = 1 << 28;

/// [`super::encode_into`] for the vertices codec: one pass at the asked
/// error, or with a bitrate the finest error whose file keeps within it.
pub fn encode_vertices_into<S: Sink>(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    open: &mut dyn FnMut() -> Result<S>,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(S, EncodeReport)> {
    let t0 = Instant::now();
    check(opts)?;
    let input = Input::read(src, progress)?;
    let finest = input.finest_percent();
    let step_percent = |p: f64| p.max(finest);
    let (percent, searched) = match opts.video.kbps {
        None => {
            let p = f64::from(opts.vertex_residual.unwrap_or(DEFAULT_VERTEX_PERCENT));
            // The finest has a margin of its own: a percentage rounded
            // through f32 just below it holds its values too.
            if p < finest * (1.0 - 1e-5) {
                return Err(Error::Argument(format!(
                    "{}: a vertices file holds each vertex within {MAX_VALUE} steps of the first frame's centre, \
                     so this motion's error is at least {finest:.4} % of the diagonal (--vertex-residual {finest:.4} \
                     or more)",
                    src.label().display()
                )));
            }
            (p, 0)
        }
        Some(kbps) => search_budget(src, &input, opts, f64::from(kbps), finest)?,
    };
    let mut sink = open()?;
    let mut report = write(src, &input, opts, step_percent(percent), &mut sink, progress)?;
    report.passes = searched + 1;
    report.seconds_total = t0.elapsed().as_secs_f64();
    report.seconds_coding = report.seconds_total;
    if let Some(kbps) = opts.video.kbps {
        report.budget_miss = Some(report.bytes as f64 / budget_bytes(src, f64::from(kbps)) - 1.0);
    }
    Ok((sink, report))
}

/// The finest vertex RMS error (percent of the first frame's diagonal) a
/// vertices file of `src` can ask for (`cgv eval` searches above it).
pub fn finest_vertex_percent(src: &dyn FrameSource) -> Result<f64> {
    Ok(Input::read(src, &mut |_, _, _| {})?.finest_percent())
}

/// What the codec refuses: options that need a grid or a video.
fn check(opts: &EncodeOptions) -> Result<()> {
    if !opts.source_mesh || opts.frame_meshes {
        return Err(Error::Argument(
            "the vertices codec codes the input's own mesh: it needs the source mesh, and one mesh for every frame"
                .into(),
        ));
    }
    if let Some(p) = opts.vertex_residual.filter(|p| !(p.is_finite() && *p > 0.0)) {
        return Err(Error::Argument(format!("a vertex residual of {p} %: give a positive percentage of the diagonal")));
    }
    if opts.vertex_residual.is_some() && opts.video.kbps.is_some() {
        return Err(Error::Argument(
            "the vertices codec takes an error (--vertex-residual) or a bitrate (--kbps), not both".into(),
        ));
    }
    Ok(())
}

/// The input as the file stores it: the mesh (a textured input's split
/// at its seams), each stored vertex's input vertex, the origin and the
/// frames where memory allows.
struct Input {
    mesh: SourceMesh,
    /// The mesh's chunk payload, as parsed into `mesh`.
    payload: Vec<u8>,
    /// Each stored vertex's vertex in the input's frames (none: the same).
    welded: Option<Vec<u32>>,
    origin: Vec3,
    diagonal: f32,
    /// The largest distance of a coordinate from the origin, any frame.
    reach: f32,
    held: Option<Vec<Vec<Vec3>>>,
}

impl Input {
    fn read(src: &dyn FrameSource, progress: &mut dyn FnMut(&str, usize, usize)) -> Result<Input> {
        let (faces, welded) = match src.appearance() {
            Some(a) => (a.faces.clone(), Some(a.welded.clone())),
            None => (src.topology().faces.clone(), None),
        };
        let count = welded.as_ref().map_or(src.topology().vertex_count, Vec::len);
        let mesh = SourceMesh {
            faces,
            // No grid: every place is the same, which the chunk codes in a few bytes.
            places: vec![[0, 0]; count],
            offsets: None,
            loose_of: Vec::new(),
            loose_anchors: Vec::new(),
        };
        mesh.info().validate().map_err(|m| Error::Argument(format!("{}: {m}", src.label().display())))?;
        // The faces as the decoder reads them (the chunk may walk them in
        // another order), which the spatial units' walk follows.
        let container = |e| Error::Container { path: src.label().into(), source: e };
        let payload = mesh.to_bytes();
        let mesh = SourceMesh::parse(&payload, &mesh.info(), 0).map_err(container)?;
        let first = src.read_frame(0)?;
        let bounds = Bounds::of(&first);
        let origin = (bounds.min + bounds.max) * 0.5;
        let frames = src.frame_count();
        let hold = frames.saturating_mul(count).saturating_mul(12) <= HELD_BYTES;
        let (mut reach, mut held) = (0f32, hold.then(Vec::new));
        for f in 0..frames {
            progress("reading", f, frames);
            let x = if f == 0 { first.clone() } else { src.read_frame(f)? };
            reach = x.iter().fold(reach, |m, p| m.max((*p - origin).abs().max_element()));
            if let Some(h) = &mut held {
                h.push(x);
            }
        }
        Ok(Input { mesh, payload, welded, origin, diagonal: bounds.diagonal(), reach, held })
    }

    /// The finest error (percent of the diagonal) whose step holds every
    /// vertex of every frame within [`MAX_VALUE`] steps of the origin.
    fn finest_percent(&self) -> f64 {
        let step = f64::from(self.reach) / f64::from(MAX_VALUE) * 1.001;
        100.0 * step / 2.0 / f64::from(self.diagonal.max(f32::MIN_POSITIVE))
    }

    /// Frame `f`'s stored vertices less the origin: what the units code.
    fn target(&self, src: &dyn FrameSource, f: usize) -> Result<Vec<Vec3>> {
        let read;
        let x = match &self.held {
            Some(h) => &h[f],
            None => {
                read = src.read_frame(f)?;
                &read
            }
        };
        let at = |k: usize| -> Vec3 {
            let v = self.welded.as_ref().map_or(Some(k), |w| w.get(k).map(|&v| v as usize));
            v.and_then(|v| x.get(v)).copied().unwrap_or(self.origin) - self.origin
        };
        Ok((0..self.mesh.places.len()).map(at).collect())
    }
}

/// The budget in bytes for `kbps` over the motion's duration.
fn budget_bytes(src: &dyn FrameSource, kbps: f64) -> f64 {
    kbps * 1000.0 / 8.0 * src.frame_count() as f64 / f64::from(src.fps())
}

/// The finest error whose file keeps within `kbps` (bisection on its
/// logarithm: the size falls as the error grows), and the passes it took.
fn search_budget(
    src: &dyn FrameSource,
    input: &Input,
    opts: &EncodeOptions,
    kbps: f64,
    finest: f64,
) -> Result<(f64, usize)> {
    let budget = budget_bytes(src, kbps);
    let size =
        |p: f64| -> Result<f64> { Ok(write(src, input, opts, p, &mut Vec::new(), &mut |_, _, _| {})?.bytes as f64) };
    let coarsest = COARSEST_PERCENT.max(finest);
    if size(coarsest)? > budget {
        return Err(Error::BudgetTooSmall(format!(
            "{kbps} kbit/s: the vertices codec's smallest file for {} ({coarsest} % of the diagonal) is larger",
            src.label().display()
        )));
    }
    let largest = size(finest)?;
    if largest < budget * (1.0 - BUDGET_TOLERANCE) {
        return Err(Error::BudgetTooLarge(format!(
            "{kbps} kbit/s: the vertices codec's finest file for {} ({finest:.4} % of the diagonal, the finest its \
             values hold) is {:.0} kbit/s",
            src.label().display(),
            largest * 8.0 / 1000.0 * f64::from(src.fps()) / src.frame_count() as f64
        )));
    }
    if largest <= budget {
        return Ok((finest, 2));
    }
    let (mut lo, mut hi, mut passes) = (finest.ln(), coarsest.ln(), 2);
    // The error of the finest file measured within the budget.
    let mut kept = coarsest;
    // Within the tolerance of the budget, or 30 halvings of the range.
    while passes < 32 {
        let mid = 0.5 * (lo + hi);
        let bytes = size(mid.exp())?;
        passes += 1;
        if bytes > budget {
            lo = mid;
        } else {
            (hi, kept) = (mid, mid.exp());
            if bytes >= budget * (1.0 - BUDGET_TOLERANCE) {
                break;
            }
        }
    }
    Ok((kept, passes))
}

/// Writes the file at `percent` into `sink`.
fn write(
    src: &dyn FrameSource,
    input: &Input,
    opts: &EncodeOptions,
    percent: f64,
    sink: &mut dyn Sink,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<EncodeReport> {
    let step = (2.0 * percent / 100.0 * f64::from(input.diagonal)) as f32;
    let header = header_of(src, input, opts, step);
    let container = |e| Error::Container { path: src.label().into(), source: e };
    let prefix = format::write_header(&header).map_err(container)?;
    let mut mesh_chunk = format::write_chunk(format::TAG_SOURCE_MESH, 0, 0, &input.payload);
    if let Some(a) = src.appearance() {
        mesh_chunk.extend(format::write_appearance(&a.look));
    }
    // Each chunk within the reader's limit (both together, as the grid
    // codecs check them).
    if mesh_chunk.len() > format::MAX_CHUNK {
        let e = format::ContainerError::TooLarge {
            what: "source mesh and appearance",
            value: mesh_chunk.len() as u64,
            limit: format::MAX_CHUNK as u64,
        };
        return Err(container(e));
    }
    sink.put(&prefix)?;
    sink.put(&mesh_chunk)?;
    let mut coder = VertexResidual::new(step, input.mesh.places.len());
    coder.set_faces(&input.mesh.faces);
    coder.set_version_20(true);
    let (mut bytes, mut residual_bytes, mut offsets) = (prefix.len() + mesh_chunk.len(), 0, Vec::new());
    for f in 0..header.frames {
        progress("coding", f as usize, header.frames as usize);
        if header.is_random_access_point(f) {
            coder.reset();
            offsets.push(bytes as u64);
        }
        let target = input.target(src, f as usize)?;
        let unit =
            coder.code(&target).ok_or_else(|| Error::Numerical("the vertex residual's range coder failed".into()))?;
        residual_bytes += unit.len();
        let chunk = format::write_frame(f, &FrameInfo { residual: Some(unit), ..FrameInfo::default() }, &[]);
        bytes += chunk.len();
        sink.put(&chunk)?;
    }
    let mut tail = Vec::new();
    if header.random_access.is_some() {
        tail.extend(format::write_index(&offsets));
    }
    tail.extend(format::write_chunk(format::TAG_END, 0, header.frames, &[]));
    sink.put(&tail)?;
    Ok(report(bytes + tail.len(), header.frames as usize, mesh_chunk.len(), residual_bytes))
}

/// The header of a file without streams.
fn header_of(src: &dyn FrameSource, input: &Input, opts: &EncodeOptions, step: f32) -> Header {
    let frames = src.frame_count();
    let random_access = plan::random_access_interval(opts.random_access, src.fps(), frames);
    let key_frames = (0..frames as u32).filter(|&f| f == 0 || random_access.is_some_and(|k| f % k == 0)).collect();
    let topology = src.topology();
    Header {
        // No grid: the smallest size a header may name, which no reader uses.
        grid: format::MIN_GRID,
        seam: format::SEAM_RULE.into(),
        frames: frames as u32,
        fps: src.fps(),
        codec: CodecKind::Gv,
        streams: Vec::new(),
        key_frames,
        anchors: Vec::new(),
        solver: SolverKind::Predictive,
        settings: Settings { qp: 0, kbps: opts.video.kbps, gop: 0, cabac: false, layers: 1, residual_steps: 0.0 },
        source: SourceInfo {
            label: src.label().display().to_string(),
            vertices: topology.vertex_count as u32,
            faces: topology.faces.len() as u32,
            diagonal: input.diagonal,
        },
        corrections: Default::default(),
        max_lag: 0,
        source_mesh: Some(input.mesh.info()),
        appearance: src.appearance().map(|a| a.look.info()),
        random_access,
        skin: None,
        segments: Vec::new(),
        frame_meshes: false,
        vertex_residual: Some(VertexResidualInfo {
            step,
            spatial: true,
            sparse: true,
            contexts: true,
            origin: Some(input.origin.to_array()),
        }),
    }
}

fn report(bytes: usize, frames: usize, source_mesh_bytes: usize, vertex_residual_bytes: usize) -> EncodeReport {
    EncodeReport {
        codec: Representation::Vertices,
        bytes,
        frames,
        stream_bytes: Vec::new(),
        side_bytes: bytes - source_mesh_bytes - vertex_residual_bytes,
        source_mesh_bytes,
        skin_bytes: 0,
        rest_pose_bytes: 0,
        frame_mesh_bytes: 0,
        vertex_residual_bytes,
        parameterization: None,
        seconds_parameterize: 0.0,
        seconds_coding: 0.0,
        seconds_total: 0.0,
        passes: 1,
        budget_miss: None,
        auto_passed_over: None,
        budget_residual: None,
    }
}

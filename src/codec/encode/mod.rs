//! The encoder (native: it drives OpenH264), in four steps over the input,
//! each reading the frames one at a time, so no more than one is held:
//!
//! 1. [`plan`]: the options checked, the streams and key frames laid out;
//! 2. [`analyse`]: every frame resampled for the streams' ranges;
//! 3. [`simulate`]: the closed loop run on the true frames without coding,
//!    for the cycle lags and the motion corrections' ranges;
//! 4. [`code`]: every frame quantized and coded; for the predictive decoder
//!    the decoder's own per-frame step ([`super::reconstruct`]) runs on what
//!    was coded (closed loop), so what it corrects is what the decoder has;
//! 5. with a bitrate, [`budget`]: step 4 repeated until the file keeps it;
//!    with a target error, [`target`]: the QP searched.
//!
//! [`request`] is an encode as a user asks for it, which the front ends
//! fill and call.

mod analyse;
mod bones;
mod budget;
mod choice;
mod code;
mod header;
mod plan;
mod request;
pub mod residual_step;
mod simulate;
mod slide;
mod target;
mod vertex_bones;
mod vertices;
mod weights_refit;

pub use bones::{DEFAULT_BONES, MIN_BONE_FRAMES};
pub use budget::{
    encode_on_budget, encode_on_budget_into, BudgetResidual, BUDGET_TOLERANCE, MAX_PASSES, RESIDUAL_BUDGET_BITS,
};
pub use choice::CodecChoice;
pub use request::{EncodeRequest, Encoded, GridChoice, Made};
pub use simulate::MOTION_MARGIN;
pub use target::{encode_to_error, prepare_for_error, residual_qp_of, TargetReport, RESIDUAL_QP};
pub use vertex_bones::{skinned_bones, skinned_grid, COARSE_WEIGHTS_QP};
pub use vertices::{encode_vertices_into, finest_vertex_percent, DEFAULT_VERTEX_PERCENT};

use super::h264::VideoSettings;
use crate::error::{Error, Result};
use crate::format::{self, CodecKind, CorrectionMode, Representation};
use crate::geometry_image::GeometryImage;
use crate::grid::{Grid, Stencils};
use crate::mesh::{Bounds, FrameSource};
use crate::output::Sink;
use crate::param::{ParamOptions, Parameterization};
use crate::solve::predictor::{DEFAULT_MAX_LAG, MAX_STEPS};
use crate::solve::SolverKind;

/// How much finer (in QP) the frame-0 seed is coded than the other streams,
/// and the finest QP it gets. Measured on the default motion at N = 64: at
/// QP 40 frame 0 was 3.5x the sequence's mean error with the seed at QP 40,
/// 1.2x at QP 16; but a seed at QP 0 leaves white 8-bit rounding noise that
/// the correction streams cannot code (frame 0 at 0.078 % of the diagonal
/// at QP 20, against 0.028 % with the seed at QP 8).
pub const SEED_QP_OFFSET: u8 = 24;
pub const SEED_MIN_QP: u8 = 8;

/// Seconds between random-access points by default: a seek decodes at
/// most this much motion before the frame it wants.
pub const DEFAULT_RANDOM_ACCESS: f32 = 2.0;

/// Anchors per frame for the paper's solver, by default.
pub const PAPER_ANCHORS: usize = 16;

/// How to encode.
#[derive(Debug, Clone)]
pub struct EncodeOptions {
    /// What the file stores. The three closed-loop choices besides it
    /// (corrections or not, along the normal or not, which header codec)
    /// all follow from it.
    pub representation: Representation,
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
    /// With a normal correction: how many times the x, y, z pictures' grid
    /// is halved (as far as the grid allows, down to 16 a side).
    pub correction_shrink: u8,
    /// 1, or 2 for a residual layer on every stream but the seeds.
    pub layers: u8,
    /// Layer-2 range, in layer-1 quantization steps.
    pub residual_steps: f32,
    /// The decoder recorded in the file as intended.
    pub solver: SolverKind,
    pub param: ParamOptions,
    /// The frame whose surface is parameterized.
    pub reference: usize,
    /// Carry the input's own mesh (format version 6), so that a decoder
    /// gives back the user's vertices and faces, not only the grid mesh.
    pub source_mesh: bool,
    /// With the source mesh, move input vertices' places where a nearby one
    /// follows the motion better ([`GeometryImage::fit_places`]): their
    /// floor falls by a quarter to a half, which pays at the highest rates
    /// only; at lower ones the longer offsets carry more coding noise
    /// (docs/RESULTS.md, "The input's own mesh").
    pub fit_places: bool,
    /// Seconds between random-access points (format version 10), where a
    /// player can start decoding: each restarts every stream and the
    /// closed loop, at the cost of a seed and intra pictures; 0 for frame 0
    /// only. Rounded to whole frames; a motion shorter than two intervals
    /// gets none.
    pub random_access: f32,
    /// Closed-loop codecs: bones as a predictor (format version 13): a
    /// skinning decomposition's weights go in the file, and each frame may
    /// be predicted by the bones (`crate::solve::skinned`) where that lands
    /// closer than the other predictors. `Some(n)`: n bones (1 to 255;
    /// 0 for none); `None` (the default): [`DEFAULT_BONES`] in a motion of
    /// at least [`MIN_BONE_FRAMES`] frames. Either way a file keeps them
    /// only where they cut the corrections 4x (`BONE_GAIN`).
    pub bones: Option<u16>,
    /// Carry every frame's own mesh (format version 16: a source whose
    /// frames are each their own triangulation, an unregistered capture's,
    /// [`FrameSource::frame_mesh`]), so that a decoder gives back each
    /// frame's own vertices and faces; it costs about a source mesh a frame.
    pub frame_meshes: bool,
    /// Frames where a new segment starts (format version 15): an
    /// unregistered capture's topology changes there and its grid with
    /// it, so each is a random-access point (the closed loop restarts
    /// rather than code the jump). Increasing, in 1..frames.
    pub segments: Vec<u32>,
    /// The skinned codec: its weights stored coarse (`Some(true)`), fine,
    /// or (`None`) by the rate ([`EncodeOptions::coarse_weights`]).
    pub coarse_weights: Option<bool>,
    /// Format version 18: code what the video misses at each of the source
    /// mesh's vertices, to about this RMS error (percent of the bounding
    /// box's diagonal; the step is twice it), every frame
    /// (`crate::codec::vertex_residual`). None: not at all.
    pub vertex_residual: Option<f32>,
    /// The grid's samples carry no correspondence (an unregistered
    /// capture registered on the grid): the closed loop may code each
    /// sample anywhere on the frame's own mesh near its place, the point
    /// nearest its prediction (`slide`), so that it spends no corrections
    /// on where a sample lies on the body. The decoder is the same. Only
    /// the closed-loop codecs slide (GV and the paper's solver code the
    /// grid as it is), and only a source with every frame's own mesh
    /// ([`FrameSource::frame_mesh`]): another is refused at its first frame.
    pub slide: bool,
    /// Frames `a..b` whose grid follows the body exactly (a capture's
    /// registered runs, frames that share one mesh, mapped once:
    /// `crate::features::capture::is_registered_run`), which `slide` leaves
    /// where they are: their places carry the correspondence. Slid, samba's
    /// 24-frame clip in runs of 12 frames took 1.6x the bits for the same
    /// error (docs/RESULTS.md).
    pub registered_runs: Vec<(u32, u32)>,
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions {
            representation: Representation::Predictive,
            grid: 128,
            video: VideoSettings::default(),
            key_interval: 10,
            anchors: None,
            corrections: CorrectionMode::Scaled,
            max_steps: 1,
            correction_interval: 1,
            max_lag: DEFAULT_MAX_LAG,
            correction_filter: true,
            correction_shrink: 1,
            layers: 1,
            residual_steps: 8.0,
            solver: SolverKind::Predictive,
            param: ParamOptions::default(),
            reference: 0,
            source_mesh: true,
            fit_places: false,
            random_access: DEFAULT_RANDOM_ACCESS,
            bones: None,
            frame_meshes: false,
            segments: Vec::new(),
            coarse_weights: None,
            vertex_residual: None,
            slide: false,
            registered_runs: Vec::new(),
        }
    }
}

impl EncodeOptions {
    /// Whether frame `fi`'s samples slide ([`EncodeOptions::slide`], not
    /// in a registered run).
    pub fn slides(&self, fi: usize) -> bool {
        self.slide && !self.registered_runs.iter().any(|&(a, b)| (a as usize..b as usize).contains(&fi))
    }

    /// Checks every option against what the codec can do, before any work:
    /// each problem gets one error that names the option.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::Argument(m));
        format::check_grid_size(self.grid as u64).map_err(Error::Argument)?;
        self.video.validate().map_err(Error::Argument)?;
        if !(1..=2).contains(&self.layers) {
            return bad(format!("layers must be 1 or 2, not {}", self.layers));
        }
        if self.layers == 2 && !(self.residual_steps.is_finite() && self.residual_steps > 0.0) {
            return bad(format!("the residual layer's range ({} steps) must be above 0", self.residual_steps));
        }
        if self.correction_shrink > format::MAX_SHRINK {
            return bad(format!("correction_shrink {} is above {}", self.correction_shrink, format::MAX_SHRINK));
        }
        if self.normal_correction() && self.layers == 2 && self.closed_loop() {
            return bad("a normal correction has no residual layer (layers 1)".into());
        }
        if let Some(b) = self.bones.filter(|&b| b > format::skin::MAX_BONES) {
            return bad(format!("{b} bones: at most {}", format::skin::MAX_BONES));
        }
        if self.vertex_bones() && !(self.source_mesh && self.bones.is_some_and(|b| b > 0)) {
            return bad(
                "the skinned codec (bones on the vertices) needs the source mesh and a bone count (1 to 255)".into()
            );
        }
        if self.frame_meshes && self.source_mesh {
            return bad("frame meshes replace the source mesh: ask for one or the other".into());
        }
        if let Some(p) = self.vertex_residual {
            if !(p.is_finite() && p > 0.0) {
                return bad(format!("a vertex residual of {p} %: give a positive percentage of the diagonal"));
            }
            if !self.source_mesh || self.frame_meshes || !self.grid_known() {
                return bad("a vertex residual needs the source mesh and the skinned, gv, normal or predictive codec \
                            (whose decoded grid the encoder knows)"
                    .into());
            }
        }
        if self.max_steps > MAX_STEPS {
            return bad(format!("max_steps {} is above {MAX_STEPS}", self.max_steps));
        }
        if !(self.random_access.is_finite() && self.random_access >= 0.0) {
            return bad(format!("random-access points {} s apart: give 0 (none) or more", self.random_access));
        }
        if self.motion() && self.correction_interval == 0 {
            return bad("the correction interval must be at least 1".into());
        }
        if self.codec() == CodecKind::Cgv && self.anchor_count() < 4 && !self.closed_loop() {
            return bad("CGV without corrections (or for the paper's solver) needs at least 4 anchors".into());
        }
        Ok(())
    }

    /// Whether the encoder runs the predictive decoder in its loop: the
    /// corrections' representations, for the decoder they need.
    pub(crate) fn closed_loop(&self) -> bool {
        matches!(self.representation, Representation::Predictive | Representation::Normal)
            && self.solver == SolverKind::Predictive
    }

    /// Whether the encoder decodes the grid as the decoder will (GV and the
    /// closed loop; not the paper's solver), which a vertex residual and
    /// loose vertices are coded against.
    pub(crate) fn grid_known(&self) -> bool {
        self.codec() == CodecKind::Gv || self.closed_loop()
    }

    /// The header's `codec` field for this representation.
    pub fn codec(&self) -> CodecKind {
        if matches!(self.representation, Representation::Gv | Representation::Skinned | Representation::Vertices) {
            CodecKind::Gv
        } else {
            CodecKind::Cgv
        }
    }

    /// Version 17: whether `bones` act on the source mesh's own vertices
    /// and the grid codes what they miss (the skinned codec, `vertex_bones`).
    pub fn vertex_bones(&self) -> bool {
        self.representation == Representation::Skinned
    }

    /// Whether the corrections are laid out along the predicted surface's
    /// normal (format version 9: `dn`, x, y, z coarser; see
    /// [`Corrections`](super::Corrections)).
    pub fn normal_correction(&self) -> bool {
        self.representation == Representation::Normal
    }

    /// Whether the corrections are coded as their running sum.
    fn motion(&self) -> bool {
        self.closed_loop() && self.corrections == CorrectionMode::Motion
    }

    /// The skinned codec's weights coarse: as asked, else at a constant QP
    /// from [`COARSE_WEIGHTS_QP`] on (a bitrate's encode has it decided
    /// before it codes, in `budget.rs`).
    pub fn coarse_weights(&self) -> bool {
        self.coarse_weights.unwrap_or(self.video.kbps.is_none() && self.video.qp >= COARSE_WEIGHTS_QP)
    }

    fn anchor_count(&self) -> usize {
        self.anchors.unwrap_or(if self.closed_loop() { 0 } else { PAPER_ANCHORS })
    }
}

/// What an encode produced.
#[derive(Debug, Clone, serde::Serialize)]
pub struct EncodeReport {
    /// What the file stores, by the codec's name.
    pub codec: format::Representation,
    pub bytes: usize,
    pub frames: usize,
    /// Bytes of H.264 per stream.
    pub stream_bytes: Vec<(String, usize)>,
    /// Bytes of the frame chunks besides the access units: framing, lengths,
    /// predictor, correction scale and anchors.
    pub side_bytes: usize,
    /// Bytes of the source mesh chunk (0 without one) and, with bones on
    /// the vertices (version 17), of its rest pose in the `SKIN` chunk
    /// (`rest_pose_bytes`): the mesh, which a skinned mesh's size leaves
    /// out too.
    pub source_mesh_bytes: usize,
    /// Bytes of the bones' weights (the `SKIN` chunk, less the rest pose,
    /// and version 21's at random-access points; 0 without bones); each
    /// frame's bone motions are in `side_bytes`.
    pub skin_bytes: usize,
    /// Version 17: bytes of the rest pose (in `source_mesh_bytes`).
    pub rest_pose_bytes: usize,
    /// Bytes of the frames' own meshes (format version 16; 0 without).
    pub frame_mesh_bytes: usize,
    /// Bytes of the vertex residual (format version 18; 0 without), not
    /// in `side_bytes`.
    pub vertex_residual_bytes: usize,
    /// The map of the reference frame (none: the vertices codec has no grid).
    pub parameterization: Option<Parameterization>,
    pub seconds_parameterize: f64,
    pub seconds_coding: f64,
    pub seconds_total: f64,
    /// Times the frames were coded: 1, or with a bitrate the passes
    /// [`encode_on_budget`] took (the times above add them all up).
    pub passes: usize,
    /// With a bitrate: how far the file is from the budget (its size over
    /// the bitrate times the duration, minus 1). Past
    /// [`BUDGET_TOLERANCE`] only where the rate control could not land a
    /// budget the codec can reach; the closest pass is kept then.
    pub budget_miss: Option<f64>,
    /// `auto`'s first pick when it was not kept, and why: the skinned
    /// codec's smallest file above the budget, or a target error it met
    /// only there with a larger file than the closed loop's.
    pub auto_passed_over: Option<String>,
    /// With a large bitrate: the vertex residual tried under the same
    /// budget, and the errors that decided between the two files.
    pub budget_residual: Option<BudgetResidual>,
}

/// Encodes a motion into `.cgv` bytes; with a bitrate, the file within
/// [`BUDGET_TOLERANCE`] of it or refused ([`encode_on_budget`]; where the
/// rate control misses a budget the codec can reach, the closest pass,
/// `budget_miss` saying how far off). `progress(stage,
/// done, total)` is called as frames are processed.
pub fn encode(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(Vec<u8>, EncodeReport)> {
    encode_into(src, opts, &mut || Ok(Vec::new()), progress)
}

/// [`encode`] into sinks that `open` makes, one per coding pass (a file
/// being written, say): each frame's chunk goes out as it is coded, so
/// memory does not grow with the motion. The sink of the pass kept is
/// returned; the others are dropped.
pub fn encode_into<S: Sink>(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    open: &mut dyn FnMut() -> Result<S>,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(S, EncodeReport)> {
    if opts.representation == Representation::Vertices {
        return encode_vertices_into(src, opts, open, progress);
    }
    let image = prepare(src, opts)?;
    encode_on_budget_into(src, opts, &image, open, progress)
}

/// Checks the options and the motion, parameterizes the reference frame,
/// locates the grid's samples on it and, with `fit_places`, chooses each
/// input vertex's place ([`GeometryImage::fit_places`]).
pub fn prepare(src: &dyn FrameSource, opts: &EncodeOptions) -> Result<GeometryImage> {
    opts.validate()?;
    let frames = src.frame_count();
    if opts.reference >= frames {
        return Err(Error::Argument(format!(
            "reference frame {} is past the last frame {}",
            opts.reference,
            frames as i64 - 1
        )));
    }
    let reference = src.read_frame(opts.reference)?;
    let mut param = opts.param.clone();
    if !opts.source_mesh {
        // Loose vertices are rebuilt through the source mesh: without it,
        // every part goes on the grid.
        param.loose_max_vertices = 0;
    }
    let mut image = GeometryImage::build(src.label(), src.topology(), &reference, Grid::new(opts.grid)?, &param)?;
    if opts.source_mesh && opts.fit_places {
        image.fit_places(src, opts.reference)?;
    }
    Ok(image)
}

/// [`encode`] with the geometry image already made (see [`prepare`]),
/// one pass at the options' QP or rate control.
pub fn encode_prepared(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    image: &GeometryImage,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(Vec<u8>, EncodeReport)> {
    let mut bytes = Vec::new();
    let report = encode_prepared_into(src, opts, image, &mut bytes, progress)?;
    Ok((bytes, report))
}

/// [`encode_prepared`] into `sink`, chunk by chunk.
pub fn encode_prepared_into(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    image: &GeometryImage,
    sink: &mut dyn Sink,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<EncodeReport> {
    let t_start = std::time::Instant::now();
    opts.validate()?;
    let plan = plan::Plan::new(opts, src.frame_count(), src.fps())?;
    if image.map.grid != plan.grid {
        return Err(Error::Argument("the geometry image is for another grid size".into()));
    }
    if !opts.source_mesh && !image.carrier.loose.is_empty() {
        return Err(Error::Argument(
            "a geometry image with loose vertices needs the source mesh (prepare it without --no-source-mesh)".into(),
        ));
    }
    // The source mesh first: an input too large for a file fails before the passes.
    let source = if opts.source_mesh { Some(source_mesh_chunk(src, image, !opts.vertex_bones())?) } else { None };
    let diagonal = Bounds::of(&src.read_frame(opts.reference)?).diagonal();
    let vertex_bones = fit_vertex_bones(src, opts, (image, &plan), diagonal, progress)?;
    let residual = vertex_bones.as_ref().map(|bones| vertex_bones::Residual { src, bones });
    // With bones on the vertices the grid codes what they miss.
    let src: &dyn FrameSource = match &residual {
        Some(r) => r,
        None => src,
    };
    let st = Stencils::new(plan.grid);
    let analysis = analyse::analyse(src, &plan, &image.map, &st, progress)?;
    let bones = bones::fit_bones(src, &plan, opts, &image.map, diagonal, progress)?;
    let skin = bones.as_ref().map(|b| &b.predictor);
    let simulation = simulate::simulate(src, &plan, opts, (&image.map, &st), skin)?;
    let bones = bones.filter(|_| simulation.bones);
    let residual = residual_coding(opts, source.as_ref(), (image, src), diagonal)?;
    let (source_chunk, source_info) = source.map_or((None, None), |(chunk, info)| (Some(chunk), Some(info)));
    let mut header = header::header(&plan, src, opts, (&analysis, &simulation), diagonal, source_info);
    header.vertex_residual = residual.as_ref().map(|r| r.info());
    header.appearance = src.appearance().filter(|_| opts.source_mesh).map(|a| a.look.info());
    header.skin = bones.as_ref().map(|b| b.info).or(vertex_bones.as_ref().map(|b| b.info));
    let chunks = code::Chunks {
        source: source_chunk.as_deref(),
        skin: bones.as_ref().map(|b| &b.weights).or(vertex_bones.as_ref().map(|b| &b.weights)),
        bone_units: vertex_bones.as_ref().map(|b| &b.units[..]),
        point_units: bones.as_ref().map(|b| &b.point_units[..]),
        residual,
    };
    let coded = code::code(src, opts, (&plan, &header), (image, chunks), &st, sink, progress)?;
    let rest_pose_bytes = vertex_bones.as_ref().map_or(0, |b| format::skin::rest_bytes(&b.weights.rest).len());
    Ok(report_of(coded, header.representation(), plan.frames, image, rest_pose_bytes, t_start))
}

/// The report of one pass: what [`code::code`] wrote, the rest pose's bytes
/// counted with the source mesh (the mesh, which a skinned mesh's size
/// leaves out too) rather than the weights.
fn report_of(
    coded: code::Coded,
    codec: format::Representation,
    frames: usize,
    image: &GeometryImage,
    rest_pose_bytes: usize,
    t_start: std::time::Instant,
) -> EncodeReport {
    let seconds_parameterize = image.seconds();
    EncodeReport {
        codec,
        bytes: coded.bytes,
        frames,
        stream_bytes: coded.stream_bytes,
        side_bytes: coded.side_bytes,
        source_mesh_bytes: coded.source_mesh_bytes + rest_pose_bytes,
        skin_bytes: coded.skin_bytes - rest_pose_bytes,
        rest_pose_bytes,
        frame_mesh_bytes: coded.frame_mesh_bytes,
        vertex_residual_bytes: coded.vertex_residual_bytes,
        parameterization: Some(image.param.clone()),
        seconds_parameterize,
        seconds_coding: coded.seconds_coding,
        seconds_total: seconds_parameterize + t_start.elapsed().as_secs_f64(),
        passes: 1,
        budget_miss: None,
        auto_passed_over: None,
        budget_residual: None,
    }
}

/// Version 18: what codes the vertex residual, where the options ask for
/// one: the source mesh as the decoder will read it (from its chunk) and
/// its step.
fn residual_coding(
    opts: &EncodeOptions,
    source: Option<&(Vec<u8>, format::SourceMeshInfo)>,
    (image, src): (&GeometryImage, &dyn FrameSource),
    diagonal: f32,
) -> Result<Option<code::ResidualCoding>> {
    let (Some(percent), Some((chunk, info))) = (opts.vertex_residual, source) else { return Ok(None) };
    let label = || src.label().display().to_string();
    let container = |e: format::ContainerError| Error::Container { path: src.label().into(), source: e };
    let (smsh, _) = format::parse_chunk(chunk, 0)
        .map_err(container)?
        .ok_or_else(|| Error::Argument(format!("{}: the source mesh chunk is cut short", label())))?;
    let mesh = format::SourceMesh::parse(smsh.payload, info, 0).map_err(container)?;
    let step = 2.0 * percent / 100.0 * diagonal;
    let welded = src.appearance().map(|a| a.welded.clone());
    Ok(Some(code::ResidualCoding::new(image.map.grid, &mesh, welded, step)))
}

/// The skinned codec's bones on the vertices (none for the others).
fn fit_vertex_bones(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    (image, plan): (&GeometryImage, &plan::Plan),
    diagonal: f32,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<Option<vertex_bones::VertexBones>> {
    let Some(n) = opts.bones.filter(|_| opts.vertex_bones()) else { return Ok(None) };
    if !image.carrier.loose.is_empty() {
        return Err(Error::Argument(
            "the skinned codec cannot carry tiny loose parts (their own vertices every frame): encode with \
             --loose-parts 0"
                .into(),
        ));
    }
    vertex_bones::fit(src, plan, (n, opts.coarse_weights()), diagonal, progress).map(Some)
}

/// The `SMSH` chunk of the input's mesh (and `APPR` after it) with the
/// header's description of it, or an error naming the way out
/// when the mesh is more than a file may carry.
fn source_mesh_chunk(
    src: &dyn FrameSource,
    image: &GeometryImage,
    offsets: bool,
) -> Result<(Vec<u8>, format::SourceMeshInfo)> {
    let mut mesh = image.source_mesh_as_stored(src.topology(), src.appearance());
    if !offsets {
        // Bones on the vertices: the rest pose is the file's, and the grid
        // (what the bones miss) has no surface to offset from.
        mesh.offsets = None;
    }
    mesh.info().validate().map_err(|m| Error::Argument(format!("{m}: encode with --no-source-mesh")))?;
    let mut chunk = format::write_source_mesh(&mesh);
    if let Some(a) = src.appearance() {
        a.look.info().validate().map_err(|m| Error::Argument(format!("{m}: encode with --no-source-mesh")))?;
        chunk.extend(format::write_appearance(&a.look));
    }
    if chunk.len() > format::MAX_CHUNK {
        return Err(Error::Argument(format!(
            "the source mesh takes {} bytes, more than a chunk may ({}): encode with --no-source-mesh",
            chunk.len(),
            format::MAX_CHUNK
        )));
    }
    Ok((chunk, mesh.info()))
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

/// The grid size for a bitrate (`--grid auto`): N = 256 from
/// [`AUTO_GRID_BITS`] bits per N = 128 sample per frame up, else 128; 128
/// without a bitrate (a QP). Where N = 128 stopped beating 256 in `cgv
/// eval` (docs/eval, BD curves crossing): about 0.6 bits on samba, 1.2-1.8
/// on pcow, past 4 on horse-gallop (N = 256 never won there).
pub fn auto_grid(video: &VideoSettings, fps: f32) -> usize {
    match video.kbps {
        Some(kbps) if f64::from(kbps) * 1000.0 / f64::from(fps.max(1e-3)) / (128.0 * 128.0) >= AUTO_GRID_BITS => 256,
        _ => 128,
    }
}

/// See [`auto_grid`]: the middle of the crossings measured.
pub const AUTO_GRID_BITS: f64 = 1.2;

/// See [`auto_grid_for_error`]. Samba (12 frames, floor 0.044 % at 128,
/// 0.015 % at 256), target 0.05 % (1.14 times the floor): N = 128 reached
/// it at QP 26 in 848 kbit/s, N = 256 at QP 40 in 1103; a margin of 1.5
/// had chosen 256. Over all frames, QP 0 at 128 reaches 1.07 times the floor.
pub const AUTO_GRID_FLOOR_MARGIN: f64 = 1.1;

/// The grid size for a target surface error (`--grid auto` with
/// `--target-error`): 256 when the target is below [`AUTO_GRID_FLOOR_MARGIN`]
/// times what N = 128 resamples the motion to (`floor_128`, relative to the
/// diagonal: no encode goes below its grid's floor), else 128.
pub fn auto_grid_for_error(target: f64, floor_128: f64) -> usize {
    if target < AUTO_GRID_FLOOR_MARGIN * floor_128 {
        256
    } else {
        128
    }
}

/// Whether a normal correction measured better for these settings (`cgv
/// eval --normal-correction` against without, on samba, horse-gallop and
/// pcow at N = 128, docs/RESULTS.md): it won at every rate point from 0.29
/// to 0.80 bits per grid sample per frame and tied at 1.27, lost at every
/// point at 0.15 and below and at 1.67, and the one-layer files it makes
/// cannot reach the two-layer points. By QP (one layer): it won at its
/// QPs 13 to 26 (and pcow's scaled 33), lost at 33 to 39 (motion).
pub fn auto_normal_correction(video: &VideoSettings, grid: usize, fps: f32, layers: u8) -> bool {
    if layers != 1 {
        return false;
    }
    match video.kbps {
        Some(kbps) => {
            let bits = kbps as f64 * 1000.0 / fps.max(1e-3) as f64 / (grid * grid) as f64;
            (AUTO_NORMAL_BITS.0..=AUTO_NORMAL_BITS.1).contains(&bits)
        }
        None => (AUTO_NORMAL_QP.0..=AUTO_NORMAL_QP.1).contains(&video.qp),
    }
}

/// See [`auto_normal_correction`]: bits per grid sample per frame, and QPs.
pub const AUTO_NORMAL_BITS: (f64, f64) = (0.25, 1.3);
pub const AUTO_NORMAL_QP: (u8, u8) = (12, 30);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_follows_the_rate_and_the_target() {
        let at = |kbps: Option<f32>| auto_grid(&VideoSettings { kbps, ..Default::default() }, 30.0);
        // 1.2 bits per 128 x 128 sample per frame at 30 fps: 589.8 kbit/s.
        assert_eq!(
            (at(None), at(Some(300.0)), at(Some(589.0)), at(Some(590.0)), at(Some(4000.0))),
            (128, 128, 128, 256, 256)
        );
        // Samba's floor at 128 is about 0.044 %: 0.05 % stays at 128, 0.03 % needs 256.
        assert_eq!((auto_grid_for_error(0.0005, 0.00044), auto_grid_for_error(0.0003, 0.00044)), (128, 256));
    }
}

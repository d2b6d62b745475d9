//! One encode as a user asks for it: the options in a user's terms (a codec
//! by name, a grid size or `auto`, the corrections or `auto`, a QP, a
//! bitrate or a target error), turned into the encoder's options and run.
//! The CLI, the Python package and the Ray tasks fill one of these and call
//! it, so that a new option, its check and its default are written once;
//! the front ends only parse and print.

use super::target::{encode_to_error, prepare_for_error, TargetReport, COARSEST_QP};
use super::vertex_bones::{skinned_bones, skinned_grid};
use super::{auto_grid, encode_into, CodecChoice, EncodeOptions, EncodeReport, MIN_BONE_FRAMES};
use crate::error::{Error, Result};
use crate::format::CorrectionMode;
use crate::mesh::FrameSource;
use crate::output::Sink;
use crate::solve::SolverKind;

/// `--grid`: a size, or chosen for the rate (or the target error).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GridChoice {
    #[default]
    Auto,
    Size(usize),
}

impl GridChoice {
    /// `auto` or a size N.
    pub fn parse(s: &str) -> std::result::Result<GridChoice, String> {
        match s {
            "auto" => Ok(GridChoice::Auto),
            n => n.parse().map(GridChoice::Size).map_err(|_| format!("'{n}' is not a grid size (N, or auto)")),
        }
    }
}

/// An encode as asked for. `base` holds every option that is not decided
/// by the choices beside it (its grid, codec, solver and corrections are
/// overwritten); its `video.fps` is the motion's, set when the motion is
/// known.
#[derive(Debug, Clone, Default)]
pub struct EncodeRequest {
    pub base: EncodeOptions,
    pub codec: CodecChoice,
    /// The decoder the file names as intended (None: the codec's own).
    pub solver: Option<SolverKind>,
    pub grid: GridChoice,
    /// Scaled or motion corrections (None: by the rate, as `auto`).
    pub corrections: Option<CorrectionMode>,
    /// The smallest file whose surface RMS is at most this percentage of
    /// the diagonal, instead of a QP or a bitrate.
    pub target_error: Option<f64>,
}

/// What [`EncodeRequest::encode`] made: the file, the options it was made
/// with, and the encoder's report.
pub struct Encoded<S> {
    pub file: Made<S>,
    pub options: EncodeOptions,
    pub report: EncodeReport,
    /// The target error's search, when one was asked.
    pub target: Option<TargetReport>,
}

/// The file of an encode: streamed into the sink as it was coded, or (a
/// target error's search decodes each file it makes) in memory.
pub enum Made<S> {
    Streamed(S),
    Bytes(Vec<u8>),
}

impl EncodeRequest {
    /// The encoder's options for a motion at `fps` frames/s, on `grid` when
    /// given (else the request's, `auto` by the bitrate, or N = 128 first
    /// for a target error), checked.
    pub fn options_on(&self, fps: f32, grid: Option<usize>) -> Result<EncodeOptions> {
        let mut base = self.base.clone();
        base.video.fps = fps;
        base.grid = match (grid, self.grid) {
            (Some(n), _) | (None, GridChoice::Size(n)) => n,
            (None, GridChoice::Auto) if self.target_error.is_some() => 128,
            (None, GridChoice::Auto) => auto_grid(&base.video, fps),
        };
        let mut opts = self.codec.apply(base, self.solver)?;
        if let Some(c) = self.corrections {
            opts.corrections = c;
        }
        self.check(&opts)?;
        Ok(opts)
    }

    /// `auto`'s first pick: the skinned codec, whenever the file keeps the
    /// input's mesh (which its bones act on) and the motion has
    /// [`MIN_BONE_FRAMES`] frames to repay the weights and rest pose.
    /// Measured (N = 128, all frames, vertex RMS on the input's vertices at
    /// equal bits), against `normal` with bones on the grid: samba −58 %
    /// BD-rate (48 bones), pcow −69 % (24); horse-gallop and horse-collapse
    /// lower at every rate it reaches. Its smallest file is larger, so a
    /// budget below it, or a target error it meets only at its smallest
    /// file, goes to the closed loop ([`encode`](Self::encode)).
    fn auto_skinned(&self, src: &dyn FrameSource) -> Option<EncodeRequest> {
        let b = &self.base;
        let fits = self.codec == CodecChoice::Auto
            && b.source_mesh
            && !b.frame_meshes
            && b.bones != Some(0)
            && src.frame_count() >= MIN_BONE_FRAMES;
        fits.then(|| EncodeRequest {
            codec: CodecChoice::Named(crate::format::Representation::Skinned),
            ..self.clone()
        })
    }

    /// `auto`'s pick for a clip of fewer than [`MIN_BONE_FRAMES`] frames:
    /// the vertices codec (no grid), whenever the file keeps the input's
    /// own mesh and the grid is left to `auto`. Measured on face-poses (9
    /// frames), wolf (6) and cylinder (4): fewer bits at every vertex error
    /// from 1 % to 0.05 % than the closed loop with a residual and than
    /// Draco and gltfpack (docs/RESULTS.md, "Clips of a few frames").
    fn auto_vertices(&self, src: &dyn FrameSource) -> Option<EncodeRequest> {
        let b = &self.base;
        let fits = self.codec == CodecChoice::Auto
            && self.grid == GridChoice::Auto
            && b.source_mesh
            && !b.frame_meshes
            && !src.has_frame_meshes()
            && src.frame_count() < MIN_BONE_FRAMES;
        fits.then(|| EncodeRequest {
            codec: CodecChoice::Named(crate::format::Representation::Vertices),
            ..self.clone()
        })
    }

    /// [`options_on`](Self::options_on) the request's own grid.
    pub fn options(&self, fps: f32) -> Result<EncodeOptions> {
        self.options_on(fps, None)
    }

    /// The checks that need the request as well as the options.
    fn check(&self, opts: &EncodeOptions) -> Result<()> {
        opts.validate()?;
        if self.target_error.is_some() && opts.video.kbps.is_some() {
            return Err(Error::Argument("a bitrate and a target error ask for the size two ways: give one".into()));
        }
        if let Some(t) = self.target_error.filter(|t| !(t.is_finite() && *t > 0.0)) {
            return Err(Error::Argument(format!("the target error must be above 0 %, not {t} %")));
        }
        if opts.correction_interval > 1 && opts.corrections != CorrectionMode::Motion {
            return Err(Error::Argument(
                "a correction interval applies to motion corrections, and these are scaled \
                 (ask for motion corrections)"
                    .into(),
            ));
        }
        Ok(())
    }

    /// Encodes `src`: into sinks that `open` makes, one per coding pass (the
    /// last is kept), or, for a target error, into memory. `auto` tries the
    /// skinned codec first where it applies ([`auto_skinned`](Self::auto_skinned))
    /// and keeps the closed loop's file where the skinned one cannot be
    /// made within the budget, or meets a target error only at its
    /// smallest file and the closed loop's is smaller; the report says so.
    pub fn encode<S: Sink>(
        &self,
        src: &dyn FrameSource,
        open: &mut dyn FnMut() -> Result<S>,
        progress: &mut dyn FnMut(&str, usize, usize),
    ) -> Result<Encoded<S>> {
        if let Some(vertices) = self.auto_vertices(src) {
            return vertices.encode_vertices_for_auto(self, src, open, progress);
        }
        let Some(skinned) = self.auto_skinned(src) else { return self.encode_as_asked(src, open, progress) };
        let why = match skinned.encode_as_asked(src, open, progress) {
            Err(Error::BudgetTooSmall(why)) => why,
            Ok(made) if made.target.as_ref().is_some_and(|t| t.qp == COARSEST_QP) => {
                let Ok(mut other) = self.encode_as_asked(src, open, progress) else { return Ok(made) };
                if other.report.bytes >= made.report.bytes {
                    return Ok(made);
                }
                other.report.auto_passed_over = Some(format!(
                    "skinned: it meets the target only at its smallest file, {} bytes",
                    made.report.bytes
                ));
                return Ok(other);
            }
            made => return made,
        };
        let mut other = self.encode_as_asked(src, open, progress)?;
        other.report.auto_passed_over = Some(format!("skinned: {why}"));
        Ok(other)
    }

    /// [`encode`](Self::encode) with the codec as asked (`auto` is the
    /// closed loop's rules here).
    fn encode_as_asked<S: Sink>(
        &self,
        src: &dyn FrameSource,
        open: &mut dyn FnMut() -> Result<S>,
        progress: &mut dyn FnMut(&str, usize, usize),
    ) -> Result<Encoded<S>> {
        let skinned = self.codec == CodecChoice::Named(crate::format::Representation::Skinned);
        if self.codec == CodecChoice::Named(crate::format::Representation::Vertices) {
            return self.encode_vertices(src, open, progress);
        }
        if skinned && self.base.bones.is_none() {
            let mut r = self.clone();
            r.base.bones = Some(skinned_bones(src.topology().vertex_count));
            return r.encode_as_asked(src, open, progress);
        }
        // The skinned codec's grid codes a residual at the vertices' places:
        // its size follows the mesh, not the rate.
        let grid = (skinned && self.grid == GridChoice::Auto).then(|| skinned_grid(src.topology().vertex_count));
        let opts = self.options_on(src.fps(), grid)?;
        let Some(percent) = self.target_error else {
            let (sink, report) = encode_into(src, &opts, open, progress)?;
            // A budget's residual, where it was kept, is in the file's options.
            let options = match report.budget_residual.filter(|r| r.kept) {
                Some(r) => super::budget::residual_options(&opts, r.qp, f64::from(r.percent)),
                None => opts,
            };
            return Ok(Encoded { file: Made::Streamed(sink), options, report, target: None });
        };
        // With a grid chosen for it, N = 128's resampling floor decides.
        let fps = src.fps();
        let regrid = |n| self.options_on(fps, Some(n));
        let auto =
            (self.grid == GridChoice::Auto && !skinned).then_some(&regrid as &dyn Fn(usize) -> Result<EncodeOptions>);
        let (opts, image) = prepare_for_error(src, opts, percent / 100.0, auto)?;
        let (bytes, report, target) = encode_to_error(src, &opts, self.codec, &image, percent / 100.0, progress)?;
        Ok(Encoded { file: Made::Bytes(bytes), options: opts, report, target: Some(target) })
    }
}

impl EncodeRequest {
    /// The vertices codec: its error is the quantizer's, known without
    /// decoding, so a target error is asked of it directly (the vertex RMS
    /// is the target; the surface RMS, measured on the surface, is at most
    /// about that).
    fn encode_vertices<S: Sink>(
        &self,
        src: &dyn FrameSource,
        open: &mut dyn FnMut() -> Result<S>,
        progress: &mut dyn FnMut(&str, usize, usize),
    ) -> Result<Encoded<S>> {
        let mut opts = self.options_on(src.fps(), Some(crate::format::MIN_GRID as usize))?;
        if let Some(percent) = self.target_error {
            opts.vertex_residual = Some(percent as f32);
        }
        let (sink, report) = super::encode_vertices_into(src, &opts, open, progress)?;
        Ok(Encoded { file: Made::Streamed(sink), options: opts, report, target: None })
    }
}

impl EncodeRequest {
    /// `auto`'s vertices file (`self`), with what a request outside its
    /// range makes instead: below its smallest file, or finer than its
    /// values hold, `asked`'s closed loop (the report says why); above its
    /// finest file, the finest (the report's `budget_miss` says how far
    /// below the budget).
    fn encode_vertices_for_auto<S: Sink>(
        &self,
        asked: &EncodeRequest,
        src: &dyn FrameSource,
        open: &mut dyn FnMut() -> Result<S>,
        progress: &mut dyn FnMut(&str, usize, usize),
    ) -> Result<Encoded<S>> {
        match self.encode_vertices(src, open, progress) {
            // Below its smallest file, or an error finer than its values
            // hold (a clip that moves far from where it starts), or a
            // budget and an error both asked: the closed loop's rules.
            Err(Error::BudgetTooSmall(why) | Error::Argument(why)) => {
                let mut other = asked.encode_as_asked(src, open, progress)?;
                other.report.auto_passed_over = Some(format!("vertices: {why}"));
                Ok(other)
            }
            Err(Error::BudgetTooLarge(_)) => {
                let kbps = self.base.video.kbps.map(f64::from);
                let mut finest = self.clone();
                finest.base.video.kbps = None;
                finest.base.vertex_residual = Some(super::finest_vertex_percent(src)? as f32);
                let mut made = finest.encode_vertices(src, open, progress)?;
                let seconds = src.frame_count() as f64 / f64::from(src.fps());
                made.report.budget_miss = kbps.map(|k| made.report.bytes as f64 * 8.0 / 1000.0 / seconds / k - 1.0);
                Ok(made)
            }
            made => made,
        }
    }
}

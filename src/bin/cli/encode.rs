//! `cgv encode`: a motion into a `.cgv` file, with any of the codecs.

use super::InputArgs;
use anyhow::{bail, Context, Result};
use cgv::codec::{h264::VideoSettings, CodecChoice, EncodeOptions, EncodeRequest, GridChoice, Made};
use cgv::features::capture::{Capture, CaptureFiles, CaptureLimit};
use cgv::features::report::RegisterReport;
use cgv::features::store::Spilled;
use cgv::format::CorrectionMode;
use cgv::output::AtomicFile;
use cgv::param::ParamOptions;
use cgv::solve::SolverKind;
use std::path::PathBuf;

#[derive(Clone, Copy, clap::ValueEnum)]
enum Corrections {
    Auto,
    Scaled,
    Motion,
}

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Output .cgv file.
    #[arg(short, long)]
    output: PathBuf,
    /// Encode many motions: a JSON file listing jobs, each
    /// `{"input": ..., "output": ..., "args": ["--grid", "256", ...]}` (any
    /// `cgv encode` options; those given here apply to every job before its
    /// own). A job whose output exists and was made by the same job is
    /// skipped; each output is written atomically; a failed job does not
    /// stop the others (the exit status says some failed). Used as
    /// `cgv encode --manifest JOBS.json [OPTIONS]`, without INPUT and -o.
    #[arg(long, value_name = "JOBS.json")]
    manifest: Option<PathBuf>,
    /// What the file stores. All but gv start from a seed at frame 0 and
    /// the grid's intrinsic and extrinsic geometry.
    /// `normal`: a prediction from the decoded past, corrected in closed
    /// loop along the predicted surface's normal (dn, one scalar picture
    /// a frame at full size: the extrinsic channel) and by x, y, z on a
    /// grid halved --correction-shrink times (format version 9).
    /// `predictive`: the same prediction corrected by x, y, z at full size
    /// (versions 1-8; scaled corrections also carry H and λ).
    /// `auto` (the default; `cgv` is another name for it): `skinned` for a
    /// motion of 24 frames or more whose file keeps the input's mesh (lower
    /// vertex error at equal bits on every motion measured, docs/RESULTS.md,
    /// "Bones on the vertices"), unless a --kbps is below its smallest file
    /// or a --target-error is met at a smaller size without bones; `vertices`
    /// for a shorter one that keeps your mesh, unless you give a --grid size
    /// (fewer bits at every error measured on clips of 4 to 9 frames, the
    /// QP then unused); else normal from
    /// 0.25 to 1.3 bits per grid sample per frame (or QP 12 to 30) with one
    /// layer, where it measured better, else predictive (docs/RESULTS.md,
    /// "One scalar channel per frame").
    /// `conformal`: the seed paper's representation, the mean curvature H
    /// every frame, the conformal factor λ at key frames and anchors, no
    /// corrections; decoded by the paper's solver, or by `--solver cgv` on
    /// H and the anchors alone (it drifts; for measurement).
    /// `gv`: geometry video, x, y, z every frame (the baseline).
    /// `skinned`: bones on your mesh's own vertices (a skinning
    /// decomposition: --bones rigid bones, by default one for each 150
    /// vertices from 32 to 48, four weights a vertex, the rest pose) and
    /// what they miss as a geometry video, for
    /// articulated motion (format version 17; docs/RESULTS.md, "Bones on
    /// the vertices").
    /// `vertices`: no grid and no video: your mesh's faces once and its
    /// vertices every frame, each as what its neighbours (or the frame
    /// before) predict misses, to the vertex RMS error --vertex-residual
    /// asks (default 0.05 % of the diagonal), --target-error asks, or the
    /// finest a --kbps holds; no parameterization. For clips of a few
    /// frames, where a video's fixed cost is most of the file (format
    /// version 20; docs/RESULTS.md, "Clips of a few frames").
    #[arg(long, default_value = "auto", value_parser = CodecChoice::parse,
          value_name = "auto|normal|predictive|conformal|gv|skinned|vertices")]
    codec: CodecChoice,
    /// The decoder the file names as intended, `cgv` (the predictive one)
    /// or `paper` (only for --codec conformal, whose default it is);
    /// `cgv decode --solver` overrides it.
    #[arg(long)]
    solver: Option<SolverKind>,
    /// Constant H.264 quantization parameter, 0..=51 (lower: larger and
    /// finer). The skinned codec's grid holds only what its bones miss, so
    /// the same QP buys a far smaller error there: QP 30 to 45 is its
    /// usual range (samba: QP 41 0.17 % vertex RMS at 0.5 bits per vertex
    /// per frame, QP 20 0.047 % at 3.0).
    #[arg(long, default_value_t = 20, conflicts_with = "kbps")]
    qp: u8,
    /// Bitrate budget in kbit/s at the motion's frame rate, instead of a
    /// constant QP: the whole file (source mesh and frame data included)
    /// lands within 5 % of it; the coding is repeated until it does (a few
    /// passes, each far shorter than the parameterization). A budget the
    /// codec cannot reach is refused with the range it can; where it can
    /// but the rate control does not land it within 5 % in five passes, a
    /// constant QP is searched, and if neither lands it the nearest file
    /// is kept with a warning saying how far off it is. From 3 bits a
    /// vertex a frame, a file that keeps your mesh is also made with a
    /// --vertex-residual filling the same budget, and the one nearer your
    /// vertices kept (both errors are printed; a few more encodes): past
    /// the grid's floor more video buys nothing, a residual does (pcow's
    /// first 48 frames at 1000 kbit/s: 0.027 % vertex RMS against 0.149 %).
    /// The vertices codec (auto's pick for a clip under 24 frames) meets
    /// a budget by its step; above its finest file it makes that file,
    /// with a note saying how far below the budget it is.
    #[arg(long)]
    kbps: Option<f32>,
    /// The other way to ask for a size: the smallest file whose surface RMS
    /// is at most this percentage of the bounding-box diagonal (0.05 for
    /// 0.05 %), measured as `cgv eval` does on 12 frames spread over the
    /// motion (the skinned codec's on your mesh, the others' on the grid);
    /// the QP is searched (7 to 12 encodes). A target below what the file
    /// reaches at QP 0 is refused with the error it reaches. The vertices
    /// codec (auto's pick for a clip under 24 frames) takes it as its
    /// vertex RMS, which bounds the surface RMS with room (about 2.5x).
    #[arg(long, value_name = "PERCENT", conflicts_with_all = ["kbps", "qp"])]
    target_error: Option<f64>,
    /// A key frame (λ) every N frames; 0 for the first frame only.
    #[arg(long, default_value_t = 10)]
    keyframes: u32,
    /// Anchor samples stored per frame (float32 positions). Default: 16 for
    /// the conformal codec (at least 4), none otherwise.
    #[arg(long)]
    anchors: Option<usize>,
    /// normal and predictive: never filter a frame's correction (format v5 lets the encoder
    /// smooth each frame's correction by 1, 2 or 4 averaging passes where
    /// that lands closer to the true frame, which keeps H.264's block noise
    /// at low bitrates from piling up; for measurement).
    #[arg(long)]
    no_correction_filter: bool,
    /// Leave out the input's own mesh (its faces and each vertex's place on
    /// the grid, written once: format version 6), so that a decoder can only
    /// give back the grid mesh; smaller by what `source mesh` reports.
    #[arg(long)]
    no_source_mesh: bool,
    /// INPUT is a folder of OBJ (or glTF/GLB) frames, each its own mesh (a
    /// capture without correspondence): features are found on every frame
    /// (heat kernel signature maxima), tracked, and every frame mapped onto
    /// the grid with four tracked features as its cones and its cut where
    /// the last frame's ran, so that the grid follows the body; what
    /// decodes is that registered grid mesh (no source mesh), or with
    /// --mesh frames each frame's own. Where the topology changes, a new
    /// segment starts (see --segments). The grid is --grid's N, 128 for
    /// auto.
    #[arg(long)]
    unregistered: bool,
    /// With --unregistered, the mesh a decoder gives back: `grid` (the
    /// grid mesh, a registered animation of the capture: one mesh whose
    /// vertices move, which you can skin, morph or edit), or `frames` (each
    /// frame's own triangulation too, rebuilt on its decoded grid: format
    /// version 16, its faces and each vertex's place stored every frame,
    /// which costs about a source mesh's bytes a frame).
    #[arg(long, value_enum, default_value = "grid", requires = "unregistered")]
    mesh: CaptureMesh,
    /// With --unregistered, code each grid sample where the registration
    /// put it on the frame's surface. By default the encoder codes it at
    /// the point of the frame's own mesh nearest what the decoder predicts,
    /// within a grid step of that place (the surface is the same; the
    /// samples' jitter on the body is not coded): on the remeshed test
    /// captures 5-22 % fewer bits at a given --qp for up to 11 % more
    /// surface error, about 2-8 % less error at equal bits
    /// (docs/RESULTS.md), and with --mesh frames each frame's own vertices
    /// come back placed on the decoded grid.
    #[arg(long, requires = "unregistered")]
    no_slide: bool,
    /// With --unregistered: refuse a segment (at most --random-access
    /// seconds of frames of one topology) whose registration would hold
    /// more than this many MiB (its frames are held at once, with their own
    /// meshes and grids), while it is read. Registered frames go to a
    /// temporary file in TMPDIR, so a capture's length is bounded by the
    /// disk, not by memory.
    #[arg(long, value_name = "MIB", default_value_t = DEFAULT_CAPTURE_MIB, requires = "unregistered",
          value_parser = clap::value_parser!(u64).range(1..))]
    memory_limit: u64,
    /// Store each input vertex's place where the grid follows it best over
    /// the motion (up to a cell from its own, judged on 16 frames): the
    /// rebuilt vertices' floor falls 25-49 % on the shared sequences, which
    /// pays at the highest rates (horse-collapse at `max`: -22 % vertex
    /// RMS); at `low` to `high` the vertices come back 1-7 % farther.
    #[arg(long)]
    fit_places: bool,
    /// normal and predictive: how the corrections are coded. `scaled`: each frame's error,
    /// scaled to the frame's largest. `motion`: their running sum at a
    /// fixed scale, so H.264 skips what the prediction got right (better at
    /// low and middle bitrates; such files leave out H and λ, which only the
    /// paper's solver would read). `auto`: motion at QP 26 and coarser or
    /// below 0.5 bits per grid sample per frame, else scaled (measured, see
    /// docs/RESULTS.md).
    #[arg(long, value_enum, default_value = "auto")]
    corrections: Corrections,
    /// The normal codec: halve the x, y, z pictures' grid this
    /// many times (0..=3; as far as the grid allows, down to 16 a side).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(0..=3))]
    correction_shrink: u8,
    /// All but gv: most mean-curvature steps the encoder may choose per frame (0..=3).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(0..=3))]
    max_steps: u8,
    /// normal and predictive with motion corrections: code the corrections on frames 0 and 1
    /// and every K-th frame after; the frames between are predicted alone
    /// and cost no picture. Worth it at the lowest bitrates, where a
    /// picture's fixed cost is a large part of a frame's bits (2 won
    /// samba's lowest points, see docs/RESULTS.md).
    #[arg(long, default_value_t = 1, value_name = "K", value_parser = clap::value_parser!(u32).range(1..))]
    correction_interval: u32,
    /// normal and predictive: the longest lag, in frames, of a cycle prediction (x₋₁ plus the
    /// smoothed velocity of LAG frames ago), which makes a repeating motion
    /// (a gait, a looped animation) nearly free after its first cycle. Used
    /// only if it cuts the corrections by a quarter; 0 turns it off. The
    /// file records the longest lag it uses, and a decoder keeps that many
    /// past velocities.
    #[arg(long, default_value_t = cgv::solve::predictor::DEFAULT_MAX_LAG)]
    max_lag: u8,
    /// Grid size N: each frame is N x N samples (even, 16..=2160), or
    /// `auto`: 256 for a --kbps of 1.2 bits or more per 128 x 128 sample per
    /// frame (about 590 kbit/s at 30 fps), 128 below and with --qp; with
    /// --target-error, 256 when the target is below 1.1 times what 128
    /// resamples the motion to (docs/RESULTS.md, "--grid auto"). `--codec
    /// auto` then picks the codec on the grid chosen.
    #[arg(long, default_value = "auto", value_parser = GridChoice::parse)]
    grid: GridChoice,
    /// Seconds between random-access points, where a player can start
    /// decoding (a seek decodes at most this much before the frame it
    /// wants): each restarts every stream with an IDR picture and the
    /// closed loop from a new seed (format version 10; its cost is in
    /// docs/RESULTS.md, "Random access"). 0: frame 0 only, as before
    /// version 10; a motion shorter than two intervals gets none either.
    #[arg(long, value_name = "SECONDS", default_value_t = cgv::codec::DEFAULT_RANDOM_ACCESS)]
    random_access: f32,
    /// Frames where a new segment starts (format version 15), each a
    /// random-access point besides those of --random-access: where a
    /// capture's grid jumps (a new map), the closed loop restarts rather
    /// than code the jump. `--unregistered` starts one itself where the
    /// capture's topology changes and at each random-access point (every
    /// 2 s with --random-access 0), each tracked and mapped on its own;
    /// give more as `--segments 40,95`.
    #[arg(long, value_name = "FRAMES", value_delimiter = ',')]
    segments: Vec<u32>,
    /// normal and predictive: bones as a predictor (format versions 13 and
    /// 14). A skinning decomposition of the motion (rigid bones, four
    /// weights) goes in the file, its weights on a 32 x 32 grid (about 5.4 KB
    /// for 32 bones), and each frame may be predicted by the bones, the
    /// corrections coding what they miss. `auto`: 32 bones in a motion of
    /// at least 24 frames; N: that many (1-255); 0: none. A file keeps them
    /// only where they cut the corrections 4x: articulated motion (samba,
    /// pcow, horse-gallop: -28 % to -46 % BD-rate on vertex RMS), not a
    /// collapsing horse. With --codec skinned: the bones on the vertices
    /// (auto: one for each 150 vertices, 32 to 48).
    #[arg(long, value_name = "auto|N", default_value = "auto", value_parser = parse_bones)]
    bones: BonesArg,
    /// --codec skinned: its weights `fine` (255 levels) or `coarse` (an
    /// influence under 5 % dropped, 32 levels: about half the bytes).
    /// `auto`: coarse from QP 39 on, or under a --kbps below the fine
    /// file at QP 39, where the residual is too coarse to show the
    /// difference (docs/RESULTS.md, "Bones on the vertices").
    #[arg(long, value_enum, default_value = "auto")]
    weights: Weights,
    /// Code what the video misses at each vertex of your mesh, every
    /// frame, to about this RMS error (percent of the bounding-box
    /// diagonal: 0.05 for 0.05 %; format version 18). The grid's
    /// resampling leaves a floor at your vertices (pcow: 0.09 %) that no
    /// QP goes below; this goes below it, for a few bits a vertex a frame
    /// (docs/RESULTS.md, "The vertex residual"). With the skinned, gv,
    /// normal or predictive codec and the source mesh; loose parts are
    /// coded as finely.
    #[arg(long, value_name = "PERCENT")]
    vertex_residual: Option<f32>,
    /// Frames between H.264 intra frames.
    #[arg(long, default_value_t = 30)]
    gop: u32,
    /// Use CAVLC instead of CABAC entropy coding.
    #[arg(long)]
    cavlc: bool,
    /// 2 adds a residual layer per stream for precision beyond 8 bits.
    #[arg(long, default_value_t = 1)]
    layers: u8,
    /// Range of the residual layer, in base-layer quantization steps.
    #[arg(long, default_value_t = 8.0)]
    residual_steps: f32,
    /// Parameterization: area correction exponent (0 keeps the map conformal).
    #[arg(long, default_value_t = ParamOptions::default().area_correction)]
    area_correction: f64,
    /// Parameterization: most area-correction passes. Of the maps they go
    /// through, the one whose grid lies closest to the reference frame's
    /// surface is kept.
    #[arg(long, default_value_t = ParamOptions::default().area_passes)]
    area_passes: usize,
    /// Parts of at most this many vertices (all but the largest part) are
    /// coded as their own vertices every frame instead of joining the grid
    /// by a tube: by default scraps and detached triangles. Larger parts (an
    /// eye, a button) can be coded so too, but measured costlier than on the
    /// grid (docs/RESULTS.md, "Loose parts"). 0: every part on the grid.
    #[arg(long, value_name = "VERTICES", default_value_t = ParamOptions::default().loose_max_vertices)]
    loose_parts: usize,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

/// The encode `args` ask for (parsing only: the library checks it).
fn request(args: &Args) -> EncodeRequest {
    let video = VideoSettings { qp: args.qp, kbps: args.kbps, gop: args.gop, cabac: !args.cavlc, ..Default::default() };
    let base = EncodeOptions {
        video,
        key_interval: args.keyframes,
        correction_filter: !args.no_correction_filter,
        correction_shrink: args.correction_shrink,
        max_steps: args.max_steps,
        max_lag: args.max_lag,
        correction_interval: args.correction_interval,
        anchors: args.anchors,
        layers: args.layers,
        residual_steps: args.residual_steps,
        param: ParamOptions {
            area_correction: args.area_correction,
            area_passes: args.area_passes,
            loose_max_vertices: args.loose_parts,
            ..Default::default()
        },
        reference: 0,
        source_mesh: !args.no_source_mesh && !args.unregistered,
        fit_places: args.fit_places,
        random_access: args.random_access,
        bones: args.bones.0,
        coarse_weights: match args.weights {
            Weights::Auto => None,
            Weights::Fine => Some(false),
            Weights::Coarse => Some(true),
        },
        segments: args.segments.clone(),
        frame_meshes: args.mesh == CaptureMesh::Frames,
        slide: args.unregistered && !args.no_slide,
        vertex_residual: args.vertex_residual,
        ..EncodeOptions::default()
    };
    EncodeRequest {
        base,
        codec: args.codec,
        solver: args.solver,
        // A registered capture is coded on the grid it was registered on.
        grid: if args.unregistered { GridChoice::Size(register_grid(args)) } else { args.grid },
        corrections: match args.corrections {
            Corrections::Auto => None,
            Corrections::Scaled => Some(CorrectionMode::Scaled),
            Corrections::Motion => Some(CorrectionMode::Motion),
        },
        target_error: args.target_error,
    }
}

pub fn run(args: Args) -> Result<()> {
    if args.manifest.is_some() {
        bail!("--manifest takes no INPUT or -o of its own: each job names its input and output");
    }
    encode_one(&args)
}

/// Runs one job's command line (`encode INPUT -o OUT [options]`) as
/// `cgv encode` would.
pub fn run_job(argv: &[String]) -> Result<()> {
    let args = parse_job(argv)?;
    if args.manifest.is_some() {
        bail!("a job may not name a manifest of its own");
    }
    encode_one(&args)
}

/// Parses one job's command line.
fn parse_job(argv: &[String]) -> Result<Args> {
    #[derive(clap::Parser)]
    // A job's own options come after the shared ones, and win.
    #[command(args_override_self = true)]
    struct Job {
        #[command(flatten)]
        args: Args,
    }
    let job = <Job as clap::Parser>::try_parse_from(argv).map_err(|e| anyhow::anyhow!("{}", e.to_string().trim()))?;
    Ok(job.args)
}

/// Encodes one motion (the whole command without --manifest).
fn encode_one(args: &Args) -> Result<()> {
    let (input, output) = (&args.input, args.output.as_path());
    if output.extension().is_none_or(|e| e != "cgv") {
        bail!("{}: the output should end in .cgv", output.display());
    }
    cgv::output::check_output_folder(output)?;
    // Every option is checked before the motion is read.
    let mut request = request(args);
    request.options(input.fps)?;
    let (src, registration) = match args.unregistered {
        true => {
            let (src, report) = registered(args)?;
            // An open capture's grid mesh without the faces over its holes
            // is the mesh the file carries (each sample its own place).
            request.base.source_mesh = report.lid_faces > 0 && !args.no_source_mesh && !request.base.frame_meshes;
            // A registered run's samples carry its correspondence: not slid.
            request.base.registered_runs = report.registered_runs.iter().map(|&[a, b]| (a as u32, b as u32)).collect();
            let segments = &mut request.base.segments;
            segments.extend(&report.segments);
            segments.sort_unstable();
            segments.dedup();
            (src, Some(report))
        }
        false => (input.open()?, None),
    };
    let pb = super::progress(src.frame_count(), "encoding", args.json);
    let mut progress = |stage: &str, done: usize, _| {
        if done == 1 {
            pb.set_message(stage.to_string());
            pb.set_position(0);
        }
        pb.set_position(done as u64);
    };
    // Each pass streams into a file of its own (frames in, chunks out) and
    // the one kept is renamed into place.
    let made = request
        .encode(src.as_ref(), &mut || AtomicFile::create(output), &mut progress)
        .with_context(|| format!("encoding {}", src.label().display()))?;
    pb.finish_and_clear();
    match made.file {
        Made::Streamed(f) => f.commit()?,
        Made::Bytes(b) => cgv::output::write_atomic(output, &b)?,
    }
    let coded = (&made.options, &made.report, made.target.as_ref());
    print_report(args, src.as_ref(), coded, registration.as_ref())
}

/// Grid size an unregistered capture is registered on with `--grid auto`.
const REGISTER_GRID: usize = 128;

fn register_grid(args: &Args) -> usize {
    match args.grid {
        GridChoice::Size(n) => n,
        GridChoice::Auto => REGISTER_GRID,
    }
}

/// The default `--memory-limit` of a capture's registration (and of `cgv
/// info --unregistered`'s tracking), MiB.
pub const DEFAULT_CAPTURE_MIB: u64 = 8192;

/// The unregistered capture `args.input` registered onto the grid, and
/// the registration's report (where its segments start, after frame 0),
/// which is also printed on stderr.
fn registered(args: &Args) -> Result<(Box<dyn cgv::mesh::FrameSource>, RegisterReport)> {
    let dir = std::path::Path::new(&args.input.input);
    let n = register_grid(args);
    let limit = CaptureLimit { bytes: args.memory_limit.saturating_mul(1 << 20), grid_samples: Some(n * n) };
    let capture = CaptureFiles::open(dir, args.input.frames, limit)?;
    let grid = cgv::grid::Grid::new(n)?;
    let longest = cgv::features::segments::longest_segment(args.random_access, args.input.fps);
    // Only the segment in hand is held; the registered frames go to a
    // temporary file, which the encoder reads a frame at a time.
    let mut store = Spilled::new(dir, args.input.fps, grid)?;
    let pb = super::progress(capture.len(), "reading", args.json);
    let mut progress = |step: &str, done: usize, _| {
        // Reading the frames for their topology, then registering them.
        if pb.message() != step {
            pb.reset();
            pb.set_message(step.to_string());
        }
        pb.set_position(done as u64)
    };
    let fps = args.input.fps;
    let r = cgv::features::register::register_into(dir, fps, &capture, grid, longest, &mut store, &mut progress)
        .with_context(|| format!("registering {}", dir.display()))?;
    pb.finish_and_clear();
    eprintln!(
        "registered {} frames on {n}²: {:.1} features a frame, {} tracks, the cones' tracks seen in {:.0} % of their frames \
         (each in {} of the frames, the worst segment's), \
         {} frames turned back to the first's sides, {} that no symmetry matches, {} bridged from their neighbours (their grid jumped), \
         {} smoothed in time, {} rebuilt from their neighbours (their grid lay far from their mesh); the grid lies {:.4} % of \
         the diagonal from each frame's own mesh on average (worst frame {:.4} %; surface RMS, the floor under any coding); \
         {:.1} s in all ({:.1} s the kept pieces' features, {:.1} s their maps)",
        r.frames,
        r.features_per_frame,
        r.tracks,
        100.0 * r.cones_seen_overall,
        r.cones_seen.map(|x| format!("{:.0} %", 100.0 * x)).join(" / "),
        r.turned_frames,
        r.unmatched_frames,
        r.bridged_frames,
        r.smoothed_frames,
        r.rebuilt_frames,
        100.0 * r.resampling_mean,
        100.0 * r.resampling_worst,
        r.seconds,
        r.seconds_features,
        r.seconds_maps
    );
    if !r.registered_runs.is_empty() {
        eprintln!(
            "  {} frames share one mesh with their neighbours (registered runs): their features carried by their vertices, \
             one map a run, as a registered motion's",
            r.shared_mesh_frames()
        );
    }
    if r.lid_faces > 0 {
        eprintln!(
            "  {} grid faces over the capture's holes left out of the grid mesh (their samples off the frames' own meshes)",
            r.lid_faces
        );
    }
    if !r.segments.is_empty() {
        eprintln!(
            "segments (each its own tracks and map) start at frames 0, {} (every {longest} frames, where the topology changes and where a registered run starts or ends)",
            join(&r.segments)
        );
        for t in &r.per_segment {
            let seen = t.cones_seen.map(|x| format!("{:.0}", 100.0 * x)).join(" / ");
            eprintln!(
                "    frames {:>4}-{:<4}  cones seen in {seen} % of them; {} unmatched, {} bridged; grid {:.4} % off (worst {:.4} %)",
                t.start,
                t.start + t.frames - 1,
                t.unmatched_frames,
                t.bridged_frames,
                100.0 * t.resampling_mean,
                100.0 * t.resampling_worst
            );
        }
    }
    Ok((Box::new(store), r))
}

/// What mesh an unregistered capture's file gives back.
#[derive(Clone, Copy, PartialEq, Debug, clap::ValueEnum)]
pub enum CaptureMesh {
    Grid,
    Frames,
}

/// The bytes of each part of the file.
fn print_sizes(report: &cgv::codec::EncodeReport) {
    for (name, b) in &report.stream_bytes {
        println!("  stream {name:<8} {b:>10} bytes");
    }
    println!(
        "  frame chunks    {:>10} bytes (chunk framing, anchors, predictor, scale, bone motions)",
        report.side_bytes
    );
    if report.skin_bytes > 0 {
        println!(
            "  bone weights    {:>10} bytes (--bones: the skin's weights, once, and a capture's at each segment)",
            report.skin_bytes
        );
    }
    let gridless = report.codec == cgv::format::Representation::Vertices;
    if gridless {
        println!("  vertices        {:>10} bytes (each vertex, every frame)", report.vertex_residual_bytes);
    } else if report.vertex_residual_bytes > 0 {
        println!(
            "  vertex residual {:>10} bytes (--vertex-residual: what the video missed at each vertex, every frame)",
            report.vertex_residual_bytes
        );
    }
    if report.frame_mesh_bytes > 0 {
        println!(
            "  frame meshes    {:>10} bytes (--mesh frames: each frame's faces and vertex places, every frame)",
            report.frame_mesh_bytes
        );
    }
    if report.rest_pose_bytes > 0 {
        println!(
            "  source mesh     {:>10} bytes (the input's faces, vertex places and rest pose ({} bytes), once)",
            report.source_mesh_bytes, report.rest_pose_bytes
        );
    } else if gridless {
        println!("  source mesh     {:>10} bytes (the input's faces, once)", report.source_mesh_bytes);
    } else if report.source_mesh_bytes > 0 {
        println!(
            "  source mesh     {:>10} bytes (the input's faces and vertex places, once; --no-source-mesh leaves it out)",
            report.source_mesh_bytes
        );
    }
}

/// What `cgv encode` prints of what it made.
fn print_report(
    args: &Args,
    src: &dyn cgv::mesh::FrameSource,
    (opts, report, target): (&EncodeOptions, &cgv::codec::EncodeReport, Option<&cgv::codec::TargetReport>),
    registration: Option<&RegisterReport>,
) -> Result<()> {
    let output = &args.output;
    let seconds = report.frames as f64 / src.fps() as f64;
    let kbps = report.bytes as f64 * 8.0 / 1000.0 / seconds;
    warn_budget(args, report);
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "output": output, "bytes": report.bytes, "kbps": kbps, "report": report, "target": target,
                "registration": registration
            }))?
        );
    } else {
        println!(
            "{} -> {} ({} codec, {} frames, {} bytes, {:.1} kbit/s at {} fps)",
            src.label().display(),
            output.display(),
            report.codec,
            report.frames,
            report.bytes,
            kbps,
            src.fps()
        );
        if let Some(why) = &report.auto_passed_over {
            println!("  auto passed over {why}");
        }
        if let Some(r) = &report.budget_residual {
            let against = match (r.vertex_rms_without, r.surface_rms_without) {
                (Some(v), Some(s)) => format!("against {:.4} % and {:.4} % without", 100.0 * v, 100.0 * s),
                _ => "(without it no file reaches the budget)".into(),
            };
            println!(
                "  vertex residual tried under the budget ({:.3} % at QP {}): vertex RMS {:.4} %, surface RMS {:.4} % {against}: {}",
                r.percent,
                r.qp,
                100.0 * r.vertex_rms_with,
                100.0 * r.surface_rms_with,
                if r.kept { "kept" } else { "not kept" }
            );
        }
        print_sizes(report);
        if let Some(p) = &report.parameterization {
            super::warn_folds(&p.distortion);
            // A capture's grid is its own mesh: its floor is the
            // registration's, printed with it.
            if let Some(score) = p.score.filter(|_| !args.unregistered) {
                let diagonal = cgv::mesh::Bounds::of(&src.read_frame(opts.reference)?).diagonal() as f64;
                println!(
                    "  grid: resamples the reference frame to {:.4} % of its bounding-box diagonal (RMS surface distance; {} area-correction passes kept)",
                    100.0 * score / diagonal,
                    p.area_passes
                );
            }
        }
        print_rate(args, report, target, registration);
    }
    Ok(())
}

/// What `cgv encode` says of a file that missed its budget.
fn warn_budget(args: &Args, report: &cgv::codec::EncodeReport) {
    let output = &args.output;
    let gridless = report.codec == cgv::format::Representation::Vertices;
    if let Some(miss) = report.budget_miss.filter(|m| gridless && *m < -cgv::codec::BUDGET_TOLERANCE) {
        eprintln!(
            "note: {} is {:+.1} % from the budget of {} kbit/s: the vertices codec's finest file (auto's pick for a \
             clip of a few frames; each vertex within 1023 steps of the first frame's centre) takes no more",
            output.display(),
            100.0 * miss,
            args.kbps.unwrap_or_default()
        );
    } else if let Some(miss) = report.budget_miss.filter(|m| m.abs() > cgv::codec::BUDGET_TOLERANCE) {
        eprintln!(
            "warning: {} is {:+.1} % from the budget of {} kbit/s: neither the rate control nor a constant QP \
             lands it within {} % ({} codings of the frames); the nearest file is kept",
            output.display(),
            100.0 * miss,
            args.kbps.unwrap_or_default(),
            100.0 * cgv::codec::BUDGET_TOLERANCE,
            report.passes
        );
    }
}

/// `cgv encode`'s lines on the rate: the target's error, the budget's
/// miss, the passes and times (with a capture's `registration`, whose
/// seconds come before the coding and count in the total).
fn print_rate(
    args: &Args,
    report: &cgv::codec::EncodeReport,
    target: Option<&cgv::codec::TargetReport>,
    registration: Option<&RegisterReport>,
) {
    if let Some(t) = target {
        let how = match t.vertex_residual {
            Some(p) => format!("QP {} and a {p:.4} % vertex residual, the coarsest of those tried within it", t.qp),
            None => format!("QP {}, the coarsest within it", t.qp),
        };
        println!(
            "  surface RMS {:.4} % of the diagonal (target {:.4} %; mean over frames {:?}) at {how}",
            100.0 * t.surface_rms,
            args.target_error.unwrap_or(0.0),
            t.frames_measured,
        );
        // A capture's file is measured against its registered grid, which
        // lies off the capture's own meshes by the registration's floor.
        if let Some(r) = registration {
            println!(
                "  (against the registered grid; the grid lies {:.4} % from the capture's own meshes on average, \
                 which the coding's error adds to)",
                100.0 * r.resampling_mean
            );
        }
    }
    if let Some(miss) = report.budget_miss {
        println!("  budget: {:+.2} % from {} kbit/s", 100.0 * miss, args.kbps.unwrap_or_default());
    }
    let passes = match (report.passes, target) {
        (1, _) => String::new(),
        (n, Some(_)) => format!(" in {n} passes for the target"),
        (n, None) => format!(" in {n} passes for the budget"),
    };
    let registering = registration.map_or(0.0, |r| r.seconds);
    let registration = registration.map_or(String::new(), |r| format!("registration {:.2} s, ", r.seconds));
    let total = report.seconds_total + registering;
    println!(
        "  time: {registration}parameterize {:.2} s, coding {:.2} s{passes}, total {total:.2} s ({:.1} ms/frame)",
        report.seconds_parameterize,
        report.seconds_coding,
        1000.0 * total / report.frames as f64
    );
}

/// `--weights`: the skinned codec's weights' precision.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum Weights {
    Auto,
    Fine,
    Coarse,
}

/// `--bones`: `auto` (the encoder's choice, `None`) or a count.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BonesArg(pub Option<u16>);

pub(crate) fn parse_bones(s: &str) -> Result<BonesArg, String> {
    match s {
        "auto" => Ok(BonesArg(None)),
        n => n
            .parse::<u16>()
            .map(|n| BonesArg(Some(n)))
            .map_err(|_| format!("give auto or a count of 0 to 255, not {n}")),
    }
}

/// Frame numbers as `a, b, c`.
fn join(frames: &[u32]) -> String {
    frames.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
}

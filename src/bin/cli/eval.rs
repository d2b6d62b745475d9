//! `cgv eval`: GV, the paper's CGV and the project's CGV at matched
//! bitrates, with the paper's smoothness metric and the errors it did not
//! report (see `cgv::eval`).

use super::InputArgs;
use anyhow::{bail, Context, Result};
use cgv::codec::EncodeOptions;
use cgv::eval::{self, EvalCodec, EvalOptions, Rates};
use std::path::PathBuf;

#[derive(clap::Args)]
#[command(after_help = "Rate points are file sizes. The presets are the sizes GV reaches at a QP \
    (low 36, medium 28, high 20, max 12, ultra 12 with a second layer); --kbps gives bitrates at 30 fps instead, like the paper's \
    Table 1. For each codec the QP (and a second layer when needed) is searched until the file is \
    within --tolerance of the target. Four or more points give a BD-rate against GV.\n\n\
    Examples:\n  cgv eval builtin:walk --frames 0..24 --grid 64 --md walk.md --plot walk.svg\n  \
    cgv eval data/samba --grid 128 --kbps 1500,2600,5600 --json samba.json\n\n\
    Against Draco and gltfpack (the Python package's cgv.peers measures them on the same frames):\n  \
    python -m cgv.peers data/samba --frames 0..60 --json peers.json\n  \
    cgv eval data/samba --frames 0..60 --codecs predictive,normal --kbps 150,300,600,1200,2400 --peers peers.json --plot samba.svg")]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Grid size N.
    #[arg(long, default_value_t = 128)]
    grid: usize,
    /// Named rate points (low, medium, high, max, ultra).
    #[arg(long, value_delimiter = ',', default_value = "low,medium,high,max,ultra", conflicts_with = "kbps")]
    rates: Vec<String>,
    /// Rate points in kbit/s at 30 fps.
    #[arg(long, value_delimiter = ',')]
    kbps: Option<Vec<f64>>,
    /// Codecs to compare, named for what their files store (as `cgv encode
    /// --codec`): gv (x, y, z), conformal (the paper's H and λ, decoded by
    /// its Eq. 1 solver), predictive (closed-loop x, y, z corrections),
    /// normal (closed-loop corrections along the normal, x, y, z coarser),
    /// skinned (--bones bones on the input's own vertices, by default one
    /// for each 150 vertices from 32 to 48,
    /// what they miss as x, y, z; its errors are on the input's vertices
    /// and surface, its grid being a residual), skinned-residual (the same
    /// with a vertex residual, format v18, whose step meets each rate
    /// point's size, the video at QP 45: below the grid's floor at the
    /// vertices). predictive and normal keep, at each rate point, the best of their
    /// correction modes; predictive-scaled, predictive-motion,
    /// normal-scaled and normal-motion run one mode only. The first
    /// round's names still work: paper is conformal, cgv predictive,
    /// cgv-scaled and cgv-motion predictive-scaled and predictive-motion.
    #[arg(long, value_delimiter = ',', default_value = "gv,conformal,predictive,normal")]
    codecs: Vec<EvalCodec>,
    /// Parts of at most this many vertices (all but the largest) are coded
    /// as their own vertices (see `cgv encode --help`; 0: none).
    #[arg(long, value_name = "VERTICES", default_value_t = cgv::param::ParamOptions::default().loose_max_vertices)]
    loose_parts: usize,
    /// Measure the surface distance to the original frames on every K-th frame (0: never; it is the slow part).
    #[arg(long, default_value_t = 1, value_name = "K")]
    surface_every: usize,
    /// Relative tolerance of the bitrate matching.
    #[arg(long, default_value_t = 0.05)]
    tolerance: f64,
    /// Frames between H.264 intra frames.
    #[arg(long, default_value_t = 30)]
    gop: u32,
    /// Seconds between random-access points, as in `cgv encode` (0: frame
    /// 0 only, as files before format version 10).
    #[arg(long, value_name = "SECONDS", default_value_t = cgv::codec::DEFAULT_RANDOM_ACCESS)]
    random_access: f32,
    /// conformal and scaled corrections: a key frame (λ) every N frames; 0 for the first frame only.
    #[arg(long, default_value_t = 10)]
    keyframes: u32,
    /// Anchor samples per frame (default: 16 for conformal, none for the others).
    #[arg(long)]
    anchors: Option<usize>,
    /// The motion-corrected codecs: code the corrections on every K-th frame, as in `cgv encode`.
    #[arg(long, default_value_t = 1, value_name = "K", value_parser = clap::value_parser!(u32).range(1..))]
    correction_interval: u32,
    /// predictive and normal: the longest lag of a cycle prediction (0: off), as in `cgv encode`.
    #[arg(long, default_value_t = cgv::solve::predictor::DEFAULT_MAX_LAG)]
    max_lag: u8,
    /// predictive and normal: never filter a frame's correction, as in `cgv encode` (for measurement).
    #[arg(long)]
    no_correction_filter: bool,
    /// Move input vertices' places where a nearby one follows the motion
    /// better, as `cgv encode --fit-places` does.
    #[arg(long)]
    fit_places: bool,
    /// normal: halve the x, y, z pictures' grid this many times (0..=3; as
    /// far as the grid allows, down to 16 a side), as in `cgv encode`.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(0..=3))]
    correction_shrink: u8,
    /// predictive and normal: bones as a predictor, as `cgv encode --bones`
    /// (auto, N, or 0 for none).
    #[arg(long, value_name = "auto|N", default_value = "auto", value_parser = super::encode::parse_bones)]
    bones: super::encode::BonesArg,
    /// Write the report as JSON.
    #[arg(long, value_name = "OUT.json")]
    json: Option<PathBuf>,
    /// Write the report as Markdown (printed to stdout when neither --md nor --json is given).
    #[arg(long, value_name = "OUT.md")]
    md: Option<PathBuf>,
    /// Most MiB of input frames held in memory for the many encodes; a
    /// longer motion is read again from its files on each pass (slower, but
    /// memory stays flat in its length).
    #[arg(long, value_name = "MIB", default_value_t = cgv::eval::IN_MEMORY_BYTES >> 20)]
    in_memory_mib: usize,
    /// Put Draco and gltfpack on the chart and tables: the JSON that
    /// `python -m cgv.peers` wrote for the same input and frames.
    #[arg(long, value_name = "PEERS.json")]
    peers: Option<PathBuf>,
    /// Put a skinning decomposition beside the peers: bones and four weights
    /// per vertex fitted to the motion (`cgv skin`), at each of these bone
    /// counts, as the skinned glTF's bytes and in the compact form the
    /// skinning literature counts (e.g. 8,16,32).
    #[arg(long, value_name = "B,B,...", value_delimiter = ',')]
    skin_bones: Vec<usize>,
    /// Write the rate-distortion chart (.svg or .png) and, beside it, the per-frame chart (NAME-frames.EXT).
    #[arg(long, value_name = "OUT.svg|png")]
    plot: Option<PathBuf>,
}

fn plot_paths(p: &std::path::Path) -> Result<(PathBuf, PathBuf, bool)> {
    let ext = p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let png = match ext.as_deref() {
        Some("svg") => false,
        Some("png") => true,
        _ => bail!("{}: the plot must end in .svg or .png", p.display()),
    };
    let stem = p.file_stem().and_then(|s| s.to_str()).unwrap_or("plot");
    let frames = p.with_file_name(format!("{stem}-frames.{}", if png { "png" } else { "svg" }));
    Ok((p.to_path_buf(), frames, png))
}

/// The peers' report, refused before the long run when it was made on
/// other frames.
fn read_peers(
    path: &std::path::Path,
    src: &dyn cgv::mesh::FrameSource,
    every: usize,
) -> Result<eval::peers::PeerReport> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let peers = eval::peers::PeerReport::parse(path, &text)?;
    peers.check(path, &src.read_frame(0)?, src.frame_count(), every)?;
    Ok(peers)
}

pub fn run(args: Args) -> Result<()> {
    for p in [&args.json, &args.md].into_iter().flatten() {
        if p.parent().is_some_and(|d| !d.as_os_str().is_empty() && !d.is_dir()) {
            bail!("{}: its folder does not exist", p.display());
        }
    }
    let plots = args.plot.as_deref().map(plot_paths).transpose()?;
    let src = args.input.open()?;
    let mut peers = args.peers.as_deref().map(|p| read_peers(p, src.as_ref(), args.surface_every)).transpose()?;
    if let Some(b) = args.skin_bones.iter().find(|b| !(4..=255).contains(*b)) {
        bail!("--skin-bones {b}: a skinned glTF has 4 to 255 bones");
    }
    if !args.skin_bones.is_empty() {
        peers = Some(eval::skinning::add_skinning(src.as_ref(), &args.skin_bones, args.surface_every, peers)?);
    }
    let mut base = EncodeOptions {
        grid: args.grid,
        key_interval: args.keyframes,
        anchors: args.anchors,
        max_lag: args.max_lag,
        correction_interval: args.correction_interval,
        correction_filter: !args.no_correction_filter,
        correction_shrink: args.correction_shrink,
        random_access: args.random_access,
        fit_places: args.fit_places,
        bones: args.bones.0,
        ..Default::default()
    };
    base.video.gop = args.gop;
    base.param.loose_max_vertices = args.loose_parts;
    let opts = EvalOptions {
        base,
        codecs: args.codecs.clone(),
        rates: match &args.kbps {
            Some(k) => Rates::Kbps(k.clone()),
            None => Rates::Presets(args.rates.clone()),
        },
        surface_every: args.surface_every,
        tolerance: args.tolerance,
        in_memory_bytes: args.in_memory_mib.saturating_mul(1 << 20),
    };
    let pb = indicatif::ProgressBar::new_spinner();
    pb.enable_steady_tick(std::time::Duration::from_millis(200));
    pb.set_message(format!("evaluating {} ({} frames)", src.label().display(), src.frame_count()));
    let report = eval::run(src.as_ref(), &opts, &|m| pb.set_message(m.to_string()))
        .with_context(|| format!("evaluating {}", src.label().display()))?;
    pb.finish_and_clear();
    let mut report = report;
    if let Some(p) = peers {
        report.peers = eval::peers::compare(&report, p);
    }
    let md = eval::report::markdown(&report);
    // Render everything first, then write: an interrupted or failed run
    // leaves no half-written report.
    let mut outputs: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    if let Some(p) = &args.json {
        outputs.push((p.clone(), serde_json::to_vec_pretty(&report)?));
    }
    if let Some(p) = &args.md {
        outputs.push((p.clone(), md.clone().into_bytes()));
    }
    if let Some((rd, frames, png)) = plots {
        outputs.push((rd, eval::plot::render(&report, eval::plot::Chart::RateDistortion, png)?));
        outputs.push((frames, eval::plot::render(&report, eval::plot::Chart::PerFrame, png)?));
    }
    for (p, bytes) in &outputs {
        cgv::output::write_atomic(p, bytes)?;
        eprintln!("wrote {}", p.display());
    }
    if args.json.is_none() && args.md.is_none() {
        print!("{md}");
    }
    Ok(())
}

//! `cgv info`: what a sequence is and whether it can become a geometry video.

use super::InputArgs;
use anyhow::{Context, Result};
use cgv::format::StreamName;
use cgv::mesh::carrier::CarrierReport;
use cgv::mesh::{analyze, Bounds};
use rayon::prelude::*;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
    /// Only read the first frame (skip checking every frame's vertex count, faces and coordinates).
    #[arg(long)]
    quick: bool,
    /// INPUT is a folder of OBJ (or glTF/GLB) frames, each its own mesh (a
    /// capture without correspondence): report each frame's size, the
    /// features found (heat kernel signature maxima) and how well they track.
    #[arg(long)]
    unregistered: bool,
    /// With --unregistered: refuse a segment (at most 2 s of frames of one
    /// topology) whose frames would hold more than this many MiB (a
    /// segment's frames are held at once), while it is read.
    #[arg(long, value_name = "MIB", default_value_t = super::encode::DEFAULT_CAPTURE_MIB, requires = "unregistered", value_parser = clap::value_parser!(u64).range(1..))]
    memory_limit: u64,
}

/// Reads every frame after the first (in parallel, with a progress bar
/// unless `quiet`): the motion's bounds from `first` on, and the first
/// frame's error, if one cannot be read.
fn check_frames(src: &dyn cgv::mesh::FrameSource, first: Bounds, quiet: bool) -> (Bounds, Option<String>) {
    let n = src.frame_count();
    let pb = super::progress(n.saturating_sub(1), "checking", quiet);
    let results: Vec<cgv::Result<Bounds>> = (1..n)
        .into_par_iter()
        .map(|i| {
            let f = src.read_frame(i);
            pb.inc(1);
            f.map(|f| Bounds::of(&f))
        })
        .collect();
    pb.finish_and_clear();
    let mut motion = first;
    for r in results {
        match r {
            Ok(b) => motion = motion.union(&b),
            Err(e) => return (motion, Some(e.to_string())),
        }
    }
    (motion, None)
}

pub fn run(args: Args) -> Result<()> {
    if args.input.input.ends_with(".cgv") {
        return cgv_info(&args);
    }
    if args.unregistered {
        return unregistered_info(&args);
    }
    let src = args.input.open()?;
    let first = src.read_frame(0)?;
    let topo = analyze(src.topology(), &first);
    let bounds = Bounds::of(&first);
    let n = src.frame_count();
    let (motion_bounds, frame_error) =
        if args.quick { (bounds, None) } else { check_frames(src.as_ref(), bounds, args.json) };
    let carrier = cgv::mesh::carrier::Carrier::build(src.label(), src.topology(), &first);
    let usable = carrier.is_ok() && frame_error.is_none();
    let closing = carrier.as_ref().ok().map(|c| c.report.clone());
    if args.json {
        let report = serde_json::json!({
            "input": src.label(),
            "kind": src.kind(),
            "frames": n,
            "fps": src.fps(),
            "vertices": src.topology().vertex_count,
            "faces": src.topology().faces.len(),
            "first_frame_bounds": bounds,
            "first_frame_diagonal": bounds.diagonal(),
            "motion_bounds": (!args.quick).then_some(motion_bounds),
            "topology": topo,
            "frames_checked": !args.quick,
            "frame_error": frame_error,
            "usable": usable,
            "closing": closing,
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!("{} ({})", src.label().display(), src.kind());
        println!("  frames        {} at {} fps ({:.2} s)", n, src.fps(), n as f32 / src.fps());
        println!("  vertices      {}", src.topology().vertex_count);
        println!("  faces         {}", src.topology().faces.len());
        println!("  edges         {}", topo.edges);
        println!(
            "  bounds        {:?} .. {:?} (diagonal {:.4}, first frame)",
            bounds.min.to_array(),
            bounds.max.to_array(),
            bounds.diagonal()
        );
        if !args.quick {
            println!("  motion bounds diagonal {:.4} over all frames", motion_bounds.diagonal());
        }
        println!("  components    {}", topo.components);
        println!("  boundary      {} loops, {} edges", topo.boundary_loops, topo.boundary_edges);
        println!("  Euler char.   {}", topo.euler_characteristic);
        match topo.genus {
            Some(g) => println!("  genus         {g}"),
            None => println!("  genus         undefined (not a connected manifold)"),
        }
        // What the encoder closes up is a note; the rest stops it.
        let label = if carrier.is_ok() { "note" } else { "problem" };
        for p in &topo.problems {
            println!("  {label}: {p}");
        }
        if let Some(e) = &frame_error {
            println!("  problem: {e}");
        }
        if let Err(e) = &carrier {
            println!("  problem: {e}");
        }
        println!("  verdict: {}", verdict(usable, &topo, closing.as_ref()));
    }
    Ok(())
}

/// `cgv info --unregistered`: the capture's frames, features and tracks.
fn unregistered_info(args: &Args) -> Result<()> {
    use cgv::features::capture::{Capture, CaptureFiles, CaptureLimit};
    use cgv::features::report::RegisterReport;
    use cgv::features::segments::{longest_segment, segment_ranges};
    let dir = std::path::Path::new(&args.input.input);
    let limit = CaptureLimit { bytes: args.memory_limit.saturating_mul(1 << 20), grid_samples: None };
    let capture = CaptureFiles::open(dir, args.input.frames, limit)?;
    // Each segment (of one topology, at most the encoder's default
    // random-access interval) is read and tracked on its own, as encode
    // does.
    let longest = longest_segment(0.0, args.input.fps);
    let pb = super::progress(capture.len(), "reading", args.json);
    let ranges = segment_ranges(&capture, longest, &mut |_, done, _| pb.set_position(done as u64))?;
    let starts: Vec<usize> = ranges.iter().map(|r| r.start).collect();
    pb.reset();
    pb.set_message("tracking");
    let (segments, (lo, hi), runs) = tracked_segments(dir, &capture, &ranges, &pb)?;
    pb.finish_and_clear();
    let frames = capture.len();
    // The segments' tracking joined as the registration's report joins it.
    let all = RegisterReport::joined(&starts, segments.iter().map(RegisterReport::of_tracking));
    let (features_per_frame, tracks) = (all.features_per_frame, all.tracks);
    let (seen, overall) = (all.cones_seen, all.cones_seen_overall);
    let rate = frames as f64 / segments.iter().map(|t| t.seconds).sum::<f64>().max(1e-9);
    if args.json {
        let report = serde_json::json!({
            "input": dir,
            "kind": "unregistered mesh frames",
            "frames": frames,
            "vertices_min": lo,
            "vertices_max": hi,
            "features_per_frame": features_per_frame,
            "tracks": tracks,
            "cones_seen": seen,
            "cones_seen_overall": overall,
            "segments": starts,
            "segments_cones_seen": segments.iter().map(|t| t.cones_seen()).collect::<Vec<_>>(),
            "registered_runs": runs.iter().map(|r| [r.start, r.end]).collect::<Vec<_>>(),
            "frames_per_second": rate,
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!("{} (unregistered: every frame its own mesh)", dir.display());
    println!("  frames        {frames} at {} fps", args.input.fps);
    println!("  vertices      {lo} to {hi} a frame");
    match starts.len() {
        1 => println!("  segments      1 (the topology never changes, at most {longest} frames)"),
        n => println!(
            "  segments      {n}, from frames {} (every {longest} frames, where the topology changes and where a registered run starts or ends; each its own map, a run's pieces one)",
            starts.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")
        ),
    }
    if !runs.is_empty() {
        let each = runs.iter().map(|r| format!("{}-{}", r.start, r.end - 1)).collect::<Vec<_>>().join(", ");
        println!(
            "  registered    frames {each} share one mesh (their features carried by their vertices, one map a run)"
        );
    }
    println!("  features      {features_per_frame:.1} a frame (heat kernel signature maxima), {tracks} tracks");
    let worst = if starts.len() > 1 { " (in each cone's worst segment)" } else { "" };
    println!(
        "  cones         the 4 longest tracks{}, seen in {:.0} % of their frames; each in {} of the frames{worst}",
        if starts.len() > 1 { " of each segment" } else { "" },
        100.0 * overall,
        seen.map(|x| format!("{:.0} %", 100.0 * x)).join(" / ")
    );
    if starts.len() > 1 {
        print_segments(&ranges, &segments);
    }
    println!("  speed         {rate:.1} frames/s (features and tracking)");
    Ok(())
}

/// A capture's segments (`ranges`) and what tracking them found.
type Tracking = (Vec<cgv::features::track::Tracked>, (usize, usize), Vec<std::ops::Range<usize>>);

/// Each segment (`ranges`) of `capture` tracked as `encode` tracks it, the
/// fewest and most vertices a frame has, and which segments are registered
/// runs (frames that share one mesh).
fn tracked_segments(
    dir: &std::path::Path,
    capture: &cgv::features::capture::CaptureFiles,
    ranges: &[std::ops::Range<usize>],
    pb: &indicatif::ProgressBar,
) -> Result<Tracking> {
    use cgv::features::capture::{is_registered_run, Capture, CaptureFrame};
    let (mut lo, mut hi, mut runs) = (usize::MAX, 0, Vec::<std::ops::Range<usize>>::new());
    let mut segments = Vec::with_capacity(ranges.len());
    // The last run's mesh: a run cut at the longest segment goes on in the
    // next segment, as the encoder's registration goes on with its map.
    let mut run_mesh: Option<CaptureFrame> = None;
    for r in ranges {
        let frames = capture.frames(r.clone())?;
        let sizes = frames.iter().map(|f| f.positions.len());
        (lo, hi) = (lo.min(sizes.clone().min().unwrap_or(lo)), hi.max(sizes.max().unwrap_or(0)));
        let last = runs.last().filter(|l| l.end == r.start);
        let goes_on = last.is_some() && run_mesh.as_ref().is_some_and(|m| frames.iter().all(|f| f.shares_mesh(m)));
        match runs.last_mut() {
            Some(l) if goes_on => l.end = r.end,
            _ if is_registered_run(&frames) => {
                runs.push(r.clone());
                run_mesh = frames.first().cloned();
            }
            _ => run_mesh = None,
        }
        let tracked = cgv::features::tracking::track_capture(dir, &frames);
        segments.push(tracked.with_context(|| format!("the segment of frames {r:?}"))?);
        pb.set_position(r.end as u64);
    }
    Ok((segments, (lo.min(hi), hi), runs))
}

/// How each segment's cones track: which stretch tracks worst, for a
/// `--segments` or `--frames` choice.
fn print_segments(ranges: &[std::ops::Range<usize>], segments: &[cgv::features::track::Tracked]) {
    for (r, t) in ranges.iter().zip(segments) {
        let seen = t.cones_seen().map(|x| format!("{:.0}", 100.0 * x)).join(" / ");
        println!("    frames {:>4}-{:<4}  cones seen in {seen} % of them", r.start, r.end - 1);
    }
}

/// What `cgv info` says of the mesh a file gives back.
fn mesh_line(file: &cgv::format::CgvFile) -> String {
    if !file.header.frame_meshes {
        return format!("source mesh   {}", source_mesh_line(file.header.source_mesh.as_ref()));
    }
    let bytes: usize = file.frames.iter().filter_map(|f| f.mesh.as_ref()).map(Vec::len).sum();
    format!(
        "frame meshes  every frame its own ({bytes} bytes, {:.0} a frame; decoders give each back)",
        bytes as f64 / f64::from(file.header.frames.max(1))
    )
}

/// What `cgv info` says of a file's source mesh.
fn source_mesh_line(m: Option<&cgv::format::SourceMeshInfo>) -> String {
    match m {
        Some(m) => format!(
            "{} vertices, {} faces{}{} (decoders give them back)",
            m.vertices,
            m.faces,
            if m.offset_step.is_some() { ", with their offsets from the grid" } else { "" },
            m.loose.map_or(String::new(), |l| format!(", {l} of them loose (coded as themselves every frame)"))
        ),
        None => "none (decoders give back the grid mesh)".into(),
    }
}

/// One line on whether and how the motion can be encoded.
fn verdict(usable: bool, topo: &cgv::mesh::TopologyReport, closing: Option<&CarrierReport>) -> String {
    match closing {
        _ if !usable => "not usable as is".into(),
        _ if topo.is_sphere() => "closed genus-0 manifold, all frames consistent: ready for a geometry image".into(),
        Some(c) => format!(
            "usable: the encoder closes it up for the grid ({} loops closed, {} handles cut, {} part(s) joined \
             ({} of the joins by bridging two holes), {} vertex copies, {} faces flipped, {} repeated faces left out; {} tiny part(s) of {} vertices \
             coded as themselves) and gives its own mesh back",
            c.closed_loops,
            c.handles,
            c.parts,
            c.bridges,
            c.split_vertices,
            c.flipped_faces,
            c.dropped_faces,
            c.loose_parts,
            c.loose_vertices
        ),
        None => "not usable as is".into(),
    }
}

/// `cgv info FILE.cgv`: the header and the size of each stream.
fn cgv_info(args: &Args) -> Result<()> {
    let path = std::path::Path::new(&args.input.input);
    let file = super::decode::read_cgv(path)?;
    let h = &file.header;
    let seconds = h.frames as f64 / h.fps as f64;
    if args.json {
        let mut summary = file.summary();
        summary["file"] = serde_json::json!(path);
        println!("{}", serde_json::to_string_pretty(&summary)?);
        return Ok(());
    }
    println!("{} (.cgv format version {})", path.display(), file.version);
    println!("  codec         {} ({}), intended solver {}", h.representation(), representation_text(h), h.solver);
    println!("  frames        {} at {} fps ({:.2} s)", h.frames, h.fps, seconds);
    let gridless = h.representation() == cgv::format::Representation::Vertices;
    match gridless {
        true => println!("  grid          none (the vertices are coded as themselves)"),
        false => println!("  grid          {0} x {0} ({1})", h.grid, h.seam),
    }
    println!("  size          {} bytes, {:.1} kbit/s", file.bytes, file.bytes as f64 * 8.0 / 1000.0 / seconds);
    println!("  key frames    {} ({:?}...)", h.key_frames.len(), &h.key_frames[..h.key_frames.len().min(5)]);
    match h.random_access {
        Some(k) => println!(
            "  random access every {k} frames ({:.2} s): {} points, a seek decodes at most {} frames",
            k as f64 / h.fps as f64,
            h.random_access_points(),
            k - 1
        ),
        None => println!("  random access frame 0 only (a seek decodes from the start)"),
    }
    if !h.segments.is_empty() {
        let starts: Vec<String> = h.segments.iter().map(u32::to_string).collect();
        println!(
            "  segments      {}, from frames 0, {} (each a random-access point)",
            starts.len() + 1,
            starts.join(", ")
        );
    }
    println!("  anchors       {:?}", h.anchors);
    print_bones_and_residual(&file);
    if h.stream(StreamName::Dx).is_some() {
        println!(
            "  corrections   {}",
            match h.corrections {
                cgv::format::CorrectionMode::Scaled => "scaled (each frame's error, times the frame's scale)",
                cgv::format::CorrectionMode::Motion => "motion (running sum: the change since the last frame applies)",
            }
        );
    }
    if !gridless {
        print_settings(h);
    }
    println!("  source        {} ({} vertices, diagonal {})", h.source.label, h.source.vertices, h.source.diagonal);
    println!("  {}", mesh_line(&file));
    if let Some(a) = &h.appearance {
        let texture =
            a.texture.as_ref().map_or("no texture".into(), |t| format!("texture ({}, {} bytes)", t.mime, t.bytes));
        println!("  appearance    texture coordinates, base colour {:?}, {texture}", a.base_color);
    }
    print_streams(h, &file.stream_bytes());
    if h.stream(StreamName::Dx).is_some() {
        print_predictors(h, &file.frames);
        print_passes(&file.frames, "filtered", "averaging passes", |f| f.filter);
        print_passes(&file.frames, "relaxed", "tangential relaxation passes", |f| f.relax);
    }
    Ok(())
}

/// The video's settings.
fn print_settings(h: &cgv::format::Header) {
    println!(
        "  settings      QP {}{}, GOP {}, {}, {} layer(s)",
        h.settings.qp,
        h.settings.kbps.map(|k| format!(" (target {k} kbit/s)")).unwrap_or_default(),
        h.settings.gop,
        if h.settings.cabac { "CABAC" } else { "CAVLC" },
        h.settings.layers
    );
}

/// The bones (versions 13 and 17) and the vertex residual (18), if any.
fn print_bones_and_residual(file: &cgv::format::CgvFile) {
    let h = &file.header;
    if let Some(skin) = h.skin.filter(|s| s.on_vertices()) {
        println!(
            "  bones         {} on the source mesh's vertices (four weights each, rest pose in the file)",
            skin.bones
        );
    } else if let Some(skin) = &h.skin {
        let skinned = file.frames.iter().filter(|f| f.predictor.extrapolation.is_skinned()).count();
        let side = h.grid >> skin.shrink;
        // Version 21: the random-access points that carry their own weights.
        let own: Vec<usize> = (0..file.frames.len())
            .filter(|&f| h.is_random_access_point(f as u32))
            .filter(|&f| file.frames[f].bones.as_ref().is_some_and(|u| !u.is_empty()))
            .collect();
        let own = match own.is_empty() {
            true => String::new(),
            false => format!(
                "; weights of their own from frames {}",
                own.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")
            ),
        };
        println!(
            "  bones         {} (weights on a {side} x {side} grid{own}; {skinned} of {} frames predicted by them)",
            skin.bones, h.frames
        );
    }
    if let Some(r) = h.vertex_residual {
        let bytes: usize = file.frames.iter().map(|f| f.residual.as_ref().map_or(0, Vec::len)).sum();
        let diagonal = f64::from(h.source.diagonal).max(f64::MIN_POSITIVE);
        println!(
            "  residual      at each vertex, every frame, in steps of {:.4} % of the diagonal ({bytes} bytes)",
            100.0 * f64::from(r.step) / diagonal
        );
        // The unit's first byte: 0 / 1 itself or its change, 2 / 3 the same
        // predicted over the surface (version 19), plus 4 for sparse
        // counts (version 20).
        let mut modes = [0usize; 4];
        file.frames
            .iter()
            .filter_map(|f| f.residual.as_ref()?.first())
            .for_each(|&m| modes[usize::from((m & 3).min(3))] += 1);
        println!(
            "                frames coded as the residual {}, its change {}; predicted over the surface: {}, {}",
            modes[0], modes[1], modes[2], modes[3]
        );
    }
}

/// How the encoder chose to predict each frame (see src/solve/predictor.rs).
fn print_predictors(h: &cgv::format::Header, frames: &[cgv::format::FrameInfo]) {
    let mut counts = [0usize; 7];
    let mut with_h = 0;
    let mut lags = std::collections::BTreeMap::<u8, usize>::new();
    for f in frames {
        counts[f.predictor.extrapolation as usize] += 1;
        with_h += usize::from(f.predictor.steps > 0);
        if f.predictor.lag > 0 {
            *lags.entry(f.predictor.lag).or_default() += 1;
        }
    }
    let lags: Vec<String> = lags.iter().map(|(l, n)| format!("{n} at lag {l}")).collect();
    println!(
        "  predictors    rigid {}, velocity {}, smoothed velocity {}, cycle {}{}{}; with mean-curvature steps {}",
        counts[0],
        counts[1],
        counts[2],
        counts[3],
        if lags.is_empty() { String::new() } else { format!(" ({})", lags.join(", ")) },
        match h.skin {
            Some(_) => format!(
                ", bones {}, bones and velocity {}, bones and smoothed velocity {}",
                counts[4], counts[5], counts[6]
            ),
            None => String::new(),
        },
        with_h
    );
}

/// One line a stream: its name, layer, frames, picture size, range, bytes.
fn print_streams(h: &cgv::format::Header, stream_bytes: &[usize]) {
    for (s, b) in h.streams.iter().zip(stream_bytes) {
        println!(
            "  stream {:<7} layer {} {:?} {}² range [{:.4e}, {:.4e}]{} {:>9} bytes",
            s.name,
            s.layer,
            s.coverage,
            s.size(h.grid),
            s.quant.min,
            s.quant.max,
            if s.scaled { " x frame scale" } else { "" },
            b
        );
    }
}

/// How many frames took how many passes of one per-frame step (the
/// correction filter, the tangential relaxation); nothing if none did.
fn print_passes(frames: &[cgv::format::FrameInfo], verb: &str, what: &str, passes: fn(&cgv::format::FrameInfo) -> u8) {
    let mut by = std::collections::BTreeMap::<u8, usize>::new();
    for p in frames.iter().map(passes).filter(|&p| p > 0) {
        *by.entry(p).or_default() += 1;
    }
    if !by.is_empty() {
        let list: Vec<String> = by.iter().map(|(p, n)| format!("{n} with {p}")).collect();
        println!("  corrections   {verb} on {} frames ({what}: {})", by.values().sum::<usize>(), list.join(", "));
    }
}

/// What a file of this codec stores, in a few words.
fn representation_text(h: &cgv::format::Header) -> &'static str {
    use cgv::format::Representation as R;
    match h.representation() {
        R::Gv => "x, y, z every frame",
        R::Conformal => "H every frame, λ at key frames, anchors",
        R::Predictive if h.stream(cgv::format::StreamName::H).is_some() => {
            "closed-loop x, y, z corrections to a prediction; H and λ beside them"
        }
        R::Predictive => "closed-loop x, y, z corrections to a prediction",
        R::Normal => "closed-loop corrections along the normal, x, y, z coarser",
        R::Skinned => "bones on the source mesh's vertices; what they miss as x, y, z every frame",
        R::Vertices => "the source mesh's own vertices every frame, no grid and no video",
    }
}

//! Captures without correspondence (every frame its own mesh): the built-in
//! walk remeshed frame by frame, its features found and tracked, every
//! frame mapped with the tracked features as cones, coded, and the decoded
//! grid measured against the registered truth.

#![allow(clippy::unwrap_used)]

mod common;

use cgv::codec::{encode, EncodeOptions, FileDecoder};
use cgv::features::capture::CaptureFrame;
use cgv::features::register::{register, register_tracked};
use cgv::features::segments::{longest_segment, segment_ranges, segment_starts};
use cgv::features::symmetry::{apply_symmetry, TURNS};
use cgv::features::tracking::{track_capture, track_features};
use cgv::grid::Grid;
use cgv::mesh::unregister::{keep_for, remesh_frame, Remesh};
use cgv::mesh::{Bounds, FrameSource, InMemory};
use glam::Vec3;
use std::path::Path;

/// `n` frames of `src`, each simplified on its own (keeping 50 to 80 % of
/// the faces) and shuffled.
fn remeshed(src: &dyn FrameSource, n: usize) -> Vec<CaptureFrame> {
    remeshed_from(src, n, 0)
}

/// [`remeshed`] for a clip that starts at frame `first` of its motion:
/// each frame simplified as that frame of the whole would be.
fn remeshed_from(src: &dyn FrameSource, n: usize, first: usize) -> Vec<CaptureFrame> {
    let faces = &src.topology().faces;
    (0..n)
        .map(|t| {
            let k = first + t;
            let (positions, faces) =
                remesh_frame(&src.read_frame(t).unwrap(), faces, keep_for(k, 0.5, 0.8, 5), k as u64);
            CaptureFrame { positions, faces }
        })
        .collect()
}

/// Per-frame spacing drifts (fractions) as "mean M, worst frame W" in
/// percent.
fn drift_summary(drifts: &[f64]) -> String {
    let mean = drifts.iter().sum::<f64>() / drifts.len().max(1) as f64;
    let worst = drifts.iter().cloned().fold(0.0, f64::max);
    format!("mean {:.1}, worst frame {:.1}", 100.0 * mean, 100.0 * worst)
}

/// Surface RMS of `frames` (on `grid`'s mesh) against `truth`'s frames,
/// relative to each frame's diagonal.
fn surface_rms(truth: &dyn FrameSource, grid: Grid, frames: &[Vec<Vec3>]) -> Vec<f64> {
    let faces = grid.topology().faces;
    frames
        .iter()
        .enumerate()
        .map(|(t, g)| {
            let f = truth.read_frame(t).unwrap();
            let d = cgv::metrics::surface::symmetric(&f, &truth.topology().faces, g, &faces).unwrap();
            d.rms / Bounds::of(&f).diagonal() as f64
        })
        .collect()
}

/// Swim: where every 7th grid sample sits on the body (the original vertex
/// nearest it, read on frame 0) against where it sits in its segment's
/// first frame (`starts`: where segments after the first start, each its
/// own map), RMS per frame, relative to frame 0's diagonal.
fn swim(truth: &dyn FrameSource, registered: &InMemory, starts: &[u32]) -> Vec<f32> {
    let frames: Vec<Vec<Vec3>> = (0..registered.frames.len()).map(|t| truth.read_frame(t).unwrap()).collect();
    let rest = &frames[0];
    let nearest = |t: usize, p: Vec3| nearest_vertex(&frames[t], p);
    let body =
        |t: usize| -> Vec<Vec3> { registered.frames[t].iter().step_by(7).map(|&p| rest[nearest(t, p)]).collect() };
    let diag = Bounds::of(rest).diagonal();
    let mut first = body(0);
    (0..frames.len())
        .map(|t| {
            let b = body(t);
            if starts.contains(&(t as u32)) {
                first = b.clone();
            }
            (b.iter().zip(&first).map(|(x, y)| x.distance_squared(*y)).sum::<f32>() / b.len() as f32).sqrt() / diag
        })
        .collect()
}

/// `opts` with the codec the probe names (`CGV_CODEC=normal`, any
/// `cgv encode --codec` name), else as they are (the predictive codec),
/// and the bones it names (`CGV_BONES`).
fn probe_codec(mut opts: EncodeOptions) -> EncodeOptions {
    // CGV_BONES=N: the closed loop's bones (0: none), for every row.
    if let Some(n) = std::env::var("CGV_BONES").ok().and_then(|b| b.parse().ok()) {
        opts.bones = Some(n);
    }
    match std::env::var("CGV_CODEC") {
        Ok(name) => cgv::codec::CodecChoice::parse(&name).unwrap().apply(opts, None).unwrap(),
        Err(_) => opts,
    }
}

/// Encodes a registered motion on its grid's mesh and decodes the grid.
fn round_trip(src: &InMemory, grid: usize, qp: u8) -> (usize, Vec<Vec<Vec3>>) {
    round_trip_in(src, grid, qp, &[])
}

/// [`round_trip`] with segments (random-access points where a new map starts).
fn round_trip_in(src: &InMemory, grid: usize, qp: u8, segments: &[u32]) -> (usize, Vec<Vec<Vec3>>) {
    round_trip_slid(src, grid, qp, segments, false)
}

/// [`round_trip_in`], the closed loop's targets slid along each frame's
/// own mesh (`src`'s) where `slide` (`EncodeOptions::slide`).
fn round_trip_slid(
    src: &dyn FrameSource,
    grid: usize,
    qp: u8,
    segments: &[u32],
    slide: bool,
) -> (usize, Vec<Vec<Vec3>>) {
    // CGV_SEPARATE=1: each segment coded as its own file (its own bones).
    if std::env::var("CGV_SEPARATE").is_ok() && segments.len() > 1 {
        let mut starts: Vec<usize> = segments.iter().map(|&s| s as usize).filter(|&s| s > 0).collect();
        starts.insert(0, 0);
        let ends: Vec<usize> = starts.iter().skip(1).copied().chain([src.frame_count()]).collect();
        let (mut total, mut all) = (0, Vec::new());
        for (&s, &e) in starts.iter().zip(&ends) {
            let piece = Slice { src, start: s, len: e - s };
            let (b, f) = round_trip_slid(&piece, grid, qp, &[], slide);
            total += b;
            all.extend(f);
        }
        return (total, all);
    }
    let mut opts = EncodeOptions { grid, source_mesh: false, segments: segments.to_vec(), slide, ..Default::default() };
    opts.video.qp = qp;
    let opts = probe_codec(opts);
    let (bytes, _) = encode(src, &opts, &mut |_, _, _| {}).unwrap();
    let file = cgv::format::read(&bytes).unwrap();
    print_ranges(if slide { "slid" } else { "coded" }, &file);
    let mut dec = FileDecoder::new(file, cgv::solve::SolverKind::Predictive).unwrap();
    let frames = (0..src.frame_count()).map(|_| dec.next_frame().unwrap().0).collect();
    (bytes.len(), frames)
}

/// Frames `start..start + len` of `src`.
struct Slice<'a> {
    src: &'a dyn FrameSource,
    start: usize,
    len: usize,
}

impl FrameSource for Slice<'_> {
    fn label(&self) -> &std::path::Path {
        self.src.label()
    }
    fn frame_count(&self) -> usize {
        self.len
    }
    fn fps(&self) -> f32 {
        self.src.fps()
    }
    fn topology(&self) -> &cgv::mesh::Topology {
        self.src.topology()
    }
    fn read_frame(&self, i: usize) -> cgv::Result<cgv::mesh::Frame> {
        self.src.read_frame(self.start + i)
    }
    fn kind(&self) -> &'static str {
        self.src.kind()
    }
    fn frame_mesh(&self, i: usize) -> cgv::Result<Option<std::borrow::Cow<'_, cgv::mesh::FrameMesh>>> {
        self.src.frame_mesh(self.start + i)
    }
    fn has_frame_meshes(&self) -> bool {
        self.src.has_frame_meshes()
    }
}

/// CGV_RANGES=1: each scaled stream's quantizer width and the frames'
/// correction scales (their median and largest), what sets the step the
/// corrections are coded with.
fn print_ranges(tag: &str, file: &cgv::format::CgvFile) {
    if std::env::var("CGV_RANGES").is_err() {
        return;
    }
    let widths: Vec<String> = file
        .header
        .streams
        .iter()
        .filter(|s| s.scaled)
        .map(|s| format!("{} {:.3e}", s.name, s.quant.max - s.quant.min))
        .collect();
    let mut scales: Vec<f32> = file.frames.iter().map(|f| f.correction_scale).collect();
    scales.sort_by(f32::total_cmp);
    let (median, top) = (scales.get(scales.len() / 2).copied(), scales.last().copied());
    println!("ranges {tag}: {widths:?}; correction scale median {median:?}, largest {top:?}");
}

/// The walk remeshed every frame: its features lie on the extremities
/// (each cone's feature is the farthest point of the body in some
/// direction, within 5 % of the diagonal), the cones' tracks run through
/// every frame, most frames' maps agree, and the decoded grid is within
/// 1 % of the diagonal of the registered truth in every frame.
#[test]
fn a_remeshed_walk_is_tracked_registered_and_coded() {
    let walk = cgv::mesh::builtin::motion(12);
    let frames = remeshed(&walk, 12);
    assert!(frames.windows(2).all(|w| w[0].positions.len() != w[1].positions.len()));
    let tracked = track_capture(Path::new("walk"), &frames).unwrap();
    assert_eq!(tracked.cones_seen(), [1.0; 4], "{:?}", tracked.tracks);
    let first = walk.read_frame(0).unwrap();
    let diag = Bounds::of(&first).diagonal();
    for k in tracked.cones {
        let t = tracked.tracks[k].seen.iter().position(Option::is_some).unwrap();
        let p = tracked.features[t][tracked.tracks[k].seen[t].unwrap() as usize].position;
        let f = walk.read_frame(t).unwrap();
        let extreme = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z].iter().any(|d| {
            let reach = f.iter().map(|q| q.dot(*d)).fold(f32::MIN, f32::max);
            reach - p.dot(*d) < 0.05 * diag
        });
        assert!(extreme, "feature at {p} is on no extremity");
    }
    let grid = Grid::new(64).unwrap();
    let (registered, report) = register(Path::new("walk"), 30.0, &frames, grid, 0, &mut |_, _, _| {}).unwrap();
    // Every frame's cut follows the last one's: all maps agree up to a
    // turn, and the grid stays where it was on the body.
    assert_eq!(report.unmatched_frames, 0, "{report:?}");
    let swum = swim(&walk, &registered.grid, &[]);
    assert!(swum.iter().all(|&s| s < SWIM_BOUND), "swim {swum:?}");
    // On the grid's own mesh the encoder maps nothing: each sample is its vertex.
    let opts = EncodeOptions { grid: 64, source_mesh: false, ..Default::default() };
    let image = cgv::codec::prepare(&registered, &opts).unwrap();
    assert_eq!(image.map.apply(&registered.grid.frames[5]), registered.grid.frames[5]);
    let mapped = surface_rms(&walk, grid, &registered.grid.frames);
    // The report's floor: each grid against its frame's own mesh (no
    // truth), as far as against the truth within the simplification's error.
    let own: Vec<f64> = (0..12)
        .map(|t| {
            let (c, g) = (&frames[t], &registered.grid.frames[t]);
            let d = cgv::metrics::surface::symmetric(&c.positions, &c.faces, g, &grid.topology().faces).unwrap();
            d.rms / Bounds::of(&c.positions).diagonal() as f64
        })
        .collect();
    let mean = own.iter().sum::<f64>() / 12.0;
    assert!((report.resampling_mean - mean).abs() < 1e-9 * mean.max(1e-9), "{report:?} {own:?}");
    assert_eq!(report.resampling_worst, own.iter().copied().fold(0.0, f64::max));
    assert!(report.resampling_mean > 0.0 && report.resampling_worst < 0.01, "{report:?}");
    let (bytes, decoded) = round_trip(&registered.grid, 64, 20);
    let coded = surface_rms(&walk, grid, &decoded);
    eprintln!("{bytes} bytes; registration {mapped:?}; decoded {coded:?}; swim {swum:?}");
    assert!(coded.iter().all(|&e| e < 0.01), "{coded:?}");
}

/// Frame `t`'s own vertices as `dec` rebuilds them on its decoded grid
/// `x`, against the capture frame `c`'s: RMS, of `c`'s diagonal.
fn own_vertices_error(dec: &mut FileDecoder, t: usize, x: &[Vec3], c: &CaptureFrame) -> f64 {
    let (v, _) = dec.frame_mesh(t as u32, x).unwrap().unwrap();
    let order = cgv::format::frame_mesh::first_use_order(&c.faces, c.positions.len());
    let sq: f64 = (0..v.len()).map(|k| v[order[k] as usize].distance_squared(c.positions[k]) as f64).sum();
    (sq / v.len() as f64).sqrt() / Bounds::of(&c.positions).diagonal() as f64
}

/// The walk's first 6 frames remeshed and registered on the 64 grid: the
/// truth, the capture, the grid and the registered capture.
fn six_frames_registered() -> (InMemory, Vec<CaptureFrame>, Grid, cgv::features::register::Registered) {
    let walk = cgv::mesh::builtin::motion(6);
    let frames = remeshed(&walk, 6);
    let grid = Grid::new(64).unwrap();
    let (registered, _) = register(Path::new("walk"), 30.0, &frames, grid, 0, &mut |_, _, _| {}).unwrap();
    (walk, frames, grid, registered)
}

/// A capture registered from its files a segment at a time, its frames
/// spilled to a temporary file (what `cgv encode --unregistered` does),
/// is the capture registered in memory: every frame's grid and own mesh,
/// its vertices' places, and the report.
#[test]
fn a_spilled_registration_is_the_one_held_in_memory() {
    use cgv::features::capture::{read_capture, CaptureFiles, CaptureLimit};
    use cgv::features::register::register_into;
    use cgv::features::store::Spilled;
    let dir = common::temp_dir("unregistered-spilled").join("walk");
    let out = cgv(&["unregister", "builtin:walk", "--frames", "0..8", "-o", dir.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let grid = Grid::new(32).unwrap();
    let frames = read_capture(&dir, None, CaptureLimit::NONE).unwrap();
    let (held, report) = register(&dir, 30.0, &frames, grid, 4, &mut |_, _, _| {}).unwrap();
    let files = CaptureFiles::open(&dir, None, CaptureLimit::NONE).unwrap();
    let mut spilled = Spilled::new(&dir, 30.0, grid).unwrap();
    let mut steps = Vec::new();
    let mut progress = |step: &str, done: usize, _: usize| steps.push((step.to_string(), done));
    let streamed = register_into(&dir, 30.0, &files, grid, 4, &mut spilled, &mut progress).unwrap();
    assert_eq!((&report.segments, report.rebuilt_frames), (&streamed.segments, streamed.rebuilt_frames));
    assert_eq!(
        (report.resampling_mean, report.resampling_worst),
        (streamed.resampling_mean, streamed.resampling_worst)
    );
    assert_eq!(spilled.frame_count(), 8);
    for t in 0..8 {
        assert_eq!(spilled.read_frame(t).unwrap(), held.read_frame(t).unwrap(), "frame {t}");
        assert_eq!(spilled.frame_mesh(t).unwrap(), held.frame_mesh(t).unwrap(), "frame {t}'s own mesh");
    }
    assert!(spilled.bytes() > 8 * 32 * 32 * 12, "{} bytes spilled", spilled.bytes());
    assert_eq!(steps.last(), Some(&("registering".to_string(), 8)), "{steps:?}");
    assert!(steps.iter().any(|(s, _)| s == "reading"), "{steps:?}");
}

/// The grid's diagonals lie the better way across the body: every frame
/// of the registered walk lies nearer its own mesh than the same grid
/// turned a quarter (which lays every quad's split the other way).
#[test]
fn the_grids_diagonals_lie_the_better_way() {
    let (_, frames, grid, registered) = six_frames_registered();
    let faces = grid.topology().faces;
    let far = |t: usize, g: &[Vec3]| {
        let f = &frames[t];
        cgv::metrics::surface::symmetric(&f.positions, &f.faces, g, &faces).unwrap().rms
    };
    let (mut kept, mut quarter) = (0.0, 0.0);
    for (t, g) in registered.grid.frames.iter().enumerate() {
        kept += far(t, g);
        quarter += far(t, &apply_symmetry(grid, g, TURNS[1]));
    }
    eprintln!("surface RMS summed over the frames: kept {kept}, turned a quarter {quarter}");
    assert!(kept < quarter, "kept {kept}, turned a quarter {quarter}");
}

/// `--mesh frames`: every frame's own triangulation comes back, rebuilt on
/// its decoded grid: the capture's faces (its vertices renumbered in the
/// order the coder walks them, the faces perhaps reordered), every vertex near where the capture has
/// it; and a frame mesh unit that does not parse is refused by its frame.
#[test]
fn each_frames_own_mesh_comes_back() {
    let (_, frames, _, registered) = six_frames_registered();
    let mut opts = EncodeOptions { grid: 64, source_mesh: false, frame_meshes: true, ..Default::default() };
    opts.video.qp = 20;
    let (bytes, report) = encode(&registered, &opts, &mut |_, _, _| {}).unwrap();
    let plain = encode(&registered, &EncodeOptions { frame_meshes: false, ..opts.clone() }, &mut |_, _, _| {});
    // The difference: the units, their lengths and the header's flag.
    let more = bytes.len() - plain.unwrap().0.len();
    assert!((report.frame_mesh_bytes..report.frame_mesh_bytes + 64).contains(&more), "{more} bytes more");
    let file = cgv::format::read(&bytes).unwrap();
    assert!(file.version == cgv::format::VERSION && file.header.frame_meshes && file.header.min_version() == 16);
    let mut dec = FileDecoder::new(file.clone(), cgv::solve::SolverKind::Predictive).unwrap();
    let mut errors = Vec::new();
    for (t, truth) in frames.iter().enumerate() {
        let (x, _) = dec.next_frame().unwrap();
        let (vertices, faces) = dec.frame_mesh(t as u32, &x).unwrap().expect("a mesh every frame");
        let order = cgv::format::frame_mesh::first_use_order(&truth.faces, truth.positions.len());
        // The same faces, each as it was, perhaps in another order.
        let mut renumbered: Vec<[u32; 3]> = truth.faces.iter().map(|f| f.map(|v| order[v as usize])).collect();
        let mut faces = faces;
        renumbered.sort_unstable();
        faces.sort_unstable();
        assert!(faces == renumbered, "frame {t}'s faces are not the capture's");
        let diag = Bounds::of(&truth.positions).diagonal() as f64;
        let sq: f64 = (0..truth.positions.len())
            .map(|v| vertices[order[v] as usize].distance_squared(truth.positions[v]) as f64)
            .sum();
        errors.push((sq / truth.positions.len() as f64).sqrt() / diag);
    }
    eprintln!("frame meshes: {} of {} bytes; vertex RMS per frame {errors:?}", report.frame_mesh_bytes, bytes.len());
    // The decoded grid's error at QP 20 (measured 0.03-0.17 %), not the places'.
    assert!(errors.iter().all(|&e| e < 0.005), "{errors:?}");
    // Frame 2's unit with a vertex count it does not have: refused, by frame.
    let unit = file.frames[2].mesh.clone().unwrap();
    let mut at = cgv::format::parse_header(&bytes).unwrap().unwrap().1;
    let mut out = bytes.clone();
    while let Some((chunk, next)) = cgv::format::reader::parse_chunk(&bytes, at).unwrap() {
        if chunk.tag == cgv::format::TAG_FRAME && chunk.frame == 2 {
            let mut payload = chunk.payload.to_vec();
            let start = payload.len() - unit.len();
            payload[start] ^= 1;
            let patched = cgv::format::write_chunk(cgv::format::TAG_FRAME, 0, 2, &payload);
            out.splice(at..next, patched);
            break;
        }
        at = next;
    }
    let err = cgv::format::read(&out).unwrap_err().to_string();
    assert!(err.contains("frame 2's mesh"), "{err}");
}

/// Samples slid along each frame's own mesh (`EncodeOptions::slide`, the
/// CLI's default for a capture): the decoded grid stays on the capture's
/// surface as the unslid one does, each frame's own vertices come back on
/// what the decoder has (to the offsets' step, where unslid they carry the
/// grid's coding error), and a motion without frames of its own is
/// refused, by frame, rather than slid onto nothing.
#[test]
fn slid_samples_code_the_same_surface() {
    let (walk, frames, grid, registered) = six_frames_registered();
    let run = |slide: bool| {
        let mut opts = EncodeOptions { grid: 64, source_mesh: false, frame_meshes: true, slide, ..Default::default() };
        opts.video.qp = 20;
        let (bytes, _) = encode(&registered, &opts, &mut |_, _, _| {}).unwrap();
        let mut dec = FileDecoder::new(cgv::format::read(&bytes).unwrap(), cgv::solve::SolverKind::Predictive).unwrap();
        let (mut grids, mut own) = (Vec::new(), Vec::new());
        for (t, c) in frames.iter().enumerate() {
            let (x, _) = dec.next_frame().unwrap();
            own.push(own_vertices_error(&mut dec, t, &x, c));
            grids.push(x);
        }
        (bytes.len(), surface_rms(&walk, grid, &grids), own)
    };
    let (plain_bytes, plain, plain_own) = run(false);
    let (slid_bytes, slid, slid_own) = run(true);
    eprintln!("unslid {plain_bytes} B {plain:?} own {plain_own:?}; slid {slid_bytes} B {slid:?} own {slid_own:?}");
    let mean = |e: &[f64]| e.iter().sum::<f64>() / e.len() as f64;
    assert!(mean(&slid) <= 1.25 * mean(&plain), "{slid:?} against {plain:?}");
    // The offsets' step is 1e-4 of the diagonal.
    assert!(slid_own.iter().all(|&e| e < 2e-4) && mean(&slid_own) < mean(&plain_own), "{slid_own:?}");
    let mut opts = EncodeOptions { grid: 64, source_mesh: false, slide: true, ..Default::default() };
    opts.video.qp = 20;
    let err = encode(&registered.grid, &opts, &mut |_, _, _| {}).unwrap_err().to_string();
    assert!(err.contains("frame 0") && err.contains("own mesh"), "{err}");
}

/// Swim (RMS, of the diagonal) that a frame of the remeshed walk stays
/// under; the walk's frames swim 1-2 % (the places' noise of a
/// remeshed body), a map in another class of the cut 20 % and more.
const SWIM_BOUND: f32 = 0.04;

/// One cone's feature taken out of a middle frame before tracking: its
/// track bridges the gap, the frame is mapped with the cone where the
/// track's sightings around it put it, and its grid stays on the body.
#[test]
fn a_frame_with_a_feature_missing_still_maps_consistently() {
    let walk = cgv::mesh::builtin::motion(10);
    let frames = remeshed(&walk, 10);
    let (label, grid, gap) = (Path::new("walk"), Grid::new(64).unwrap(), 5);
    let all = track_capture(label, &frames).unwrap();
    let (_, first) = register_tracked(label, 30.0, &frames, all.clone(), grid).unwrap();
    let k = first.cone_tracks[0];
    let mut features = all.features.clone();
    features[gap].remove(all.tracks[k].seen[gap].unwrap() as usize);
    let centers: Vec<Vec3> = frames.iter().map(CaptureFrame::center).collect();
    let tracked = track_features(label, features, &centers, Bounds::of(&frames[0].positions).diagonal()).unwrap();
    let (registered, report) = register_tracked(label, 30.0, &frames, tracked, grid).unwrap();
    assert!(report.cones_seen.contains(&0.9), "the gap is bridged and the track a cone still: {report:?}");
    // One frame of the forty the cones have is missed.
    assert!((report.cones_seen_overall - 0.975).abs() < 1e-9, "{report:?}");
    assert_eq!(report.unmatched_frames, 0, "{report:?}");
    let swum = swim(&walk, &registered.grid, &[]);
    assert!(swum.iter().all(|&s| s < SWIM_BOUND), "swim {swum:?}");
}

/// Fins (a third face on an edge: the simplifier pinches two of
/// horse-gallop's rims together in frames 5 to 7 of the capture) map as
/// well as the frames around them: left in, the carrier made each fin a
/// part of its own, joined by a tube the map spread over (those frames
/// resampled 0.67-0.85 % off, the others 0.07-0.13 %).
#[test]
fn frames_with_fins_map_as_well_as_their_neighbours() {
    let dir = common::real_sequence("horse-gallop");
    let full = cgv::mesh::open_sequence(dir.to_str().unwrap(), &Default::default()).unwrap();
    let clip = InMemory {
        label: dir.clone(),
        fps: 30.0,
        topology: full.topology().clone(),
        frames: (4..8).map(|t| full.read_frame(t).unwrap()).collect(),
    };
    let frames = remeshed_from(&clip, 4, 4);
    let fins = |c: &CaptureFrame| {
        let topo = cgv::mesh::Topology { vertex_count: c.positions.len(), faces: c.faces.clone() };
        cgv::mesh::analyze(&topo, &c.positions).non_manifold_edges
    };
    assert!(frames[1..].iter().all(|c| fins(c) > 0) && fins(&frames[0]) == 0, "the case this test is about");
    let grid = Grid::new(128).unwrap();
    let (registered, report) = register(&dir, 30.0, &frames, grid, 0, &mut |_, _, _| {}).unwrap();
    let err = surface_rms(&clip, grid, &registered.grid.frames);
    eprintln!("horse-gallop frames 4-7 (fins in 5-7): registration {err:?}; {report:?}");
    assert!(err.iter().all(|&e| e < 0.003), "{err:?}");
}

/// The walk remeshed, with a hole opened in frames 4 to 7 (one face
/// gone; a hole in one frame only is noise): two segments, each registered on its own, and a file with a
/// random-access point where the second starts, which decodes from there
/// as from the start.
/// `frames`' segments of at most `longest` frames.
fn ranges(frames: &[CaptureFrame], longest: usize) -> Vec<std::ops::Range<usize>> {
    segment_ranges(&frames, longest, &mut |_, _, _| {}).unwrap()
}

#[test]
fn a_clip_whose_topology_changes_halfway_gets_two_segments() {
    let walk = cgv::mesh::builtin::motion(8);
    let mut frames = remeshed(&walk, 8);
    // A hole in one frame only (capture noise) starts no segment.
    let mut flicker = frames.clone();
    flicker[2].faces.swap_remove(0);
    assert_eq!(segment_starts(&flicker), [0]);
    // At most 3 frames a segment: one every 3 frames.
    assert_eq!(ranges(&frames, 3), [0..3, 3..6, 6..8]);
    for f in &mut frames[4..] {
        f.faces.swap_remove(0);
    }
    assert_eq!(segment_starts(&frames), [0, 4]);
    // `cgv info` lists the two and how each tracks.
    let dir = common::temp_dir("unregistered-two-segments");
    for (t, f) in frames.iter().enumerate() {
        let topology = cgv::mesh::Topology { vertex_count: f.positions.len(), faces: f.faces.clone() };
        cgv::mesh::obj::write_obj(&dir.join(format!("{t}.obj")), &f.positions, &topology).unwrap();
    }
    let info = cgv(&["info", dir.to_str().unwrap(), "--unregistered", "--json"]);
    let report: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(report["segments"], serde_json::json!([0, 4]), "{report}");
    assert_eq!(report["segments_cones_seen"].as_array().map(Vec::len), Some(2), "{report}");
    let text = String::from_utf8_lossy(&cgv(&["info", dir.to_str().unwrap(), "--unregistered"]).stdout).into_owned();
    assert!(text.contains("frames    0-3 ") && text.contains("frames    4-7 "), "{text}");
    // Frames 3 and 6 lie within SEGMENT_FRAMES of the change at 4.
    assert_eq!(ranges(&frames, 3), [0..4, 4..8]);
    assert_eq!(ranges(&frames, 0), [0..4, 4..8]);
    let grid = Grid::new(32).unwrap();
    let (registered, report) = register(Path::new("walk"), 30.0, &frames, grid, 60, &mut |_, _, _| {}).unwrap();
    assert_eq!((report.frames, &report.segments[..], report.unmatched_frames), (8, &[4][..], 0), "{report:?}");
    let opts = EncodeOptions { grid: 32, source_mesh: false, segments: report.segments.clone(), ..Default::default() };
    let all = decoded_from_both_points(&registered, &opts, 15);
    let truth: Vec<f64> = surface_rms(&walk, grid, &all);
    assert!(truth.iter().all(|&e| e < 0.02), "{truth:?}");
    // With bones, the second segment has weights of its own (version 21).
    let opts = EncodeOptions { bones: Some(4), ..opts };
    let all = decoded_from_both_points(&registered, &opts, 21);
    let truth: Vec<f64> = surface_rms(&walk, grid, &all);
    assert!(truth.iter().all(|&e| e < 0.02), "{truth:?}");
    // A last segment of one frame carries no weights: bones predict none
    // of its frames.
    let (bytes, _) = encode(&registered, &EncodeOptions { segments: vec![4, 7], ..opts }, &mut |_, _, _| {}).unwrap();
    let file = cgv::format::read(&bytes).unwrap();
    let weights = |f: usize| file.frames[f].bones.as_ref().map_or(0, Vec::len);
    assert!(file.header.is_random_access_point(7) && weights(4) > 0 && weights(7) == 0);
    let mut dec = FileDecoder::new(file.clone(), cgv::solve::SolverKind::Predictive).unwrap();
    let all: Vec<Vec<Vec3>> = (0..8).map(|_| dec.next_frame().unwrap().0).collect();
    let truth: Vec<f64> = surface_rms(&walk, grid, &all);
    assert!(truth.iter().all(|&e| e < 0.02), "{truth:?}");
    let mut from7 = FileDecoder::new(file, cgv::solve::SolverKind::Predictive).unwrap();
    assert_eq!(from7.seek(7).unwrap(), 0);
    assert_eq!(from7.next_frame().unwrap().0, all[7]);
}

/// A capture in registered runs (a vendor's "stabilized segments": frames
/// that share one mesh, their vertices moving with the body) maps each run
/// once, as a registered motion is mapped: a segment of its own, its
/// features carried by their vertices, every frame's samples where the
/// first frame's map put them, so the grid does not swim on the body.
#[test]
fn a_capture_in_registered_runs_maps_each_run_once() {
    let walk = cgv::mesh::builtin::motion(9);
    let faces = &walk.topology().faces;
    // Frames 0-2 each their own mesh, 3-8 one run of frame 3's mesh.
    let mut frames = remeshed(&walk, 3);
    let run = Remesh::of(&walk.read_frame(3).unwrap(), faces, 0.6, 3);
    for t in 3..9 {
        frames.push(CaptureFrame { positions: run.positions(&walk.read_frame(t).unwrap()), faces: run.faces.clone() });
    }
    assert_eq!(ranges(&frames, 60), [0..3, 3..9]);
    assert_eq!(ranges(&frames, 4), [0..3, 3..8, 8..9]);
    let tracked = track_capture(Path::new("walk"), &frames[3..]).unwrap();
    assert!(tracked.tracks.iter().all(|k| k.frames_seen() == 6), "carried features are seen in every frame");
    let grid = Grid::new(32).unwrap();
    let (registered, report) = register(Path::new("walk"), 30.0, &frames, grid, 60, &mut |_, _, _| {}).unwrap();
    assert_eq!((&report.segments[..], &report.registered_runs[..]), (&[3][..], &[[3, 9]][..]), "{report:?}");
    assert_eq!((report.per_segment[1].cones_seen, report.per_segment[1].unmatched_frames), ([1.0; 4], 0));
    let places = |t: usize| &registered.meshes[t].places;
    assert!((4..9).all(|t| places(t) == places(3)), "one map serves the run");
    // Cut at the longest segment (4 frames), the run goes on with its map.
    let (cut, cut_report) = register(Path::new("walk"), 30.0, &frames, grid, 4, &mut |_, _, _| {}).unwrap();
    assert_eq!((&cut_report.segments[..], &cut_report.registered_runs[..]), (&[3, 8][..], &[[3, 9]][..]));
    assert!((3..9).all(|t| cut.grid.frames[t] == registered.grid.frames[t] && cut.meshes[t].places == *places(3)));
    assert!(places(1) != places(0), "frames each their own mesh are mapped each on its own");
    // Two runs back to back (frames 0-3 and 4-8): the second starts from
    // the first's cones, cut and turn, so the grid stays on the body (1.4 %
    // of the diagonal from frame 0 at frame 4; 14 % with cones of its own).
    let second = Remesh::of(&walk.read_frame(4).unwrap(), faces, 0.7, 4);
    let two: Vec<CaptureFrame> = (0..9)
        .map(|t| {
            let r = if t < 4 { &run } else { &second };
            CaptureFrame { positions: r.positions(&walk.read_frame(t).unwrap()), faces: r.faces.clone() }
        })
        .collect();
    let (both, r) = register(Path::new("walk"), 30.0, &two, grid, 60, &mut |_, _, _| {}).unwrap();
    assert_eq!((&r.segments[..], &r.registered_runs[..]), (&[4][..], &[[0, 4], [4, 9]][..]));
    let step = swim(&walk, &both.grid, &[]);
    eprintln!("two runs, swim against frame 0: {step:?}");
    assert!(step[4] < 0.03, "{step:?}");
    // Where the samples sit on the body, against the run's first frame.
    let swum = swim(&walk, &registered.grid, &report.segments);
    let own = {
        let each = remeshed_from(&walk, 9, 0);
        let (alone, r) = register(Path::new("walk"), 30.0, &each[3..], grid, 60, &mut |_, _, _| {}).unwrap();
        assert!(r.registered_runs.is_empty());
        let moved: Vec<_> = (3..9).map(|t| walk.read_frame(t).unwrap()).collect();
        let topology = walk.topology().clone();
        swim(&InMemory { label: "walk".into(), fps: 30.0, topology, frames: moved }, &alone.grid, &[])
    };
    eprintln!("swim, one map a run: {:?}; each frame its own: {own:?}", &swum[3..]);
    let worst = |s: &[f32]| s.iter().copied().fold(0.0, f32::max);
    assert!(worst(&swum[3..]) < 0.25 * worst(&own), "{swum:?} against {own:?}");
    let opts = EncodeOptions { grid: 32, source_mesh: false, segments: report.segments.clone(), ..Default::default() };
    let (bytes, _) = encode(&registered, &opts, &mut |_, _, _| {}).unwrap();
    // A registered run's samples are not slid: a file of runs alone slid
    // is the one not slid.
    let runs = vec![(0, 3), (3, 9)];
    let slid = |registered_runs| EncodeOptions { slide: true, registered_runs, ..opts.clone() };
    assert_eq!(encode(&registered, &slid(runs), &mut |_, _, _| {}).unwrap().0, bytes);
    assert_ne!(encode(&registered, &slid(vec![(3, 9)]), &mut |_, _, _| {}).unwrap().0, bytes);
    let mut dec = FileDecoder::new(cgv::format::read(&bytes).unwrap(), cgv::solve::SolverKind::Predictive).unwrap();
    let all: Vec<Vec<Vec3>> = (0..9).map(|_| dec.next_frame().unwrap().0).collect();
    let truth = surface_rms(&walk, grid, &all);
    assert!(truth.iter().all(|&e| e < 0.02), "{truth:?}");
}

/// `src` coded with `opts` (a point at frame 4) as format version
/// `version`, decoded from frame 0; frames 4 on decode alike from frame 4.
fn decoded_from_both_points(src: &dyn FrameSource, opts: &EncodeOptions, version: u16) -> Vec<Vec<Vec3>> {
    let (bytes, _) = encode(src, opts, &mut |_, _, _| {}).unwrap();
    let file = cgv::format::read(&bytes).unwrap();
    assert_eq!((file.header.min_version(), &file.header.segments[..]), (version, &[4][..]));
    assert!(file.header.is_random_access_point(4) && file.index.len() == 2, "{:?}", file.index);
    if version == 21 {
        let weights = |f: usize| file.frames[f].bones.as_ref().map_or(0, Vec::len);
        assert!(weights(0) == 0 && weights(4) > 0, "frame 4 carries its segment's weights");
    }
    let mut dec = FileDecoder::new(file.clone(), cgv::solve::SolverKind::Predictive).unwrap();
    let all: Vec<Vec<Vec3>> = (0..8).map(|_| dec.next_frame().unwrap().0).collect();
    let mut from4 = FileDecoder::new(file, cgv::solve::SolverKind::Predictive).unwrap();
    assert_eq!(from4.seek(4).unwrap(), 0, "frame 4 is a point: nothing decoded before it");
    for (t, frame) in all.iter().enumerate().skip(4) {
        assert_eq!(&from4.next_frame().unwrap().0, frame, "frame {t}");
    }
    all
}

/// The walk remeshed and registered in segments of 4 frames: each segment
/// goes on where the last left off (the same cones, the cut traced on,
/// the grid turned to match), so its grid moves on the body at a segment's
/// start no more than within a segment, and the bones the encoder fits to
/// the whole motion hold on both sides.
#[test]
fn segments_go_on_where_the_last_left_off() {
    let walk = cgv::mesh::builtin::motion(12);
    let frames = remeshed(&walk, 12);
    let grid = Grid::new(32).unwrap();
    let mut heard = Vec::new();
    let mut progress = |stage: &str, done, total| heard.push((stage.to_string(), done, total));
    let (registered, report) = register(Path::new("walk"), 30.0, &frames, grid, 4, &mut progress).unwrap();
    assert_eq!(report.segments, [4, 8], "{report:?}");
    // Progress while the frames are read for their topology (a few at a
    // time, as many as the threads allow), then after each segment.
    let reading = heard.iter().take_while(|h| h.0 == "reading").count();
    assert_eq!(heard.get(reading.max(1) - 1), Some(&("reading".to_string(), 12, 12)), "{heard:?}");
    let registering = |done| ("registering".to_string(), done, 12);
    assert_eq!(heard[reading..], [registering(4), registering(8), registering(12)]);
    // Where the samples lie on the body against frame 0: a step at each
    // start, against the steps within the segments.
    let on_body = swim(&walk, &registered.grid, &[]);
    let step = |t: usize| (on_body[t] - on_body[t - 1]).abs();
    let within = (1..12).filter(|t| t % 4 != 0).map(step).fold(0.0, f32::max);
    let at_starts = [step(4), step(8)];
    println!("swim against frame 0 {on_body:?}; steps within {within}, at the starts {at_starts:?}");
    assert!(at_starts.iter().all(|&s| s <= 2.0 * within + 0.005), "{on_body:?}");
}

/// Measures a real sequence remeshed every frame against its registered
/// self (not a pass/fail test): `CGV_PROBE=samba cargo test --release
/// --test unregistered -- --ignored --nocapture`. Each row's last column
/// is the coding's own error (the decoded grid against the grid coded);
/// it also prints the spacing drift (`cgv::metrics::spacing_drift`) of the
/// registered grid against the pinned one (below) and, at each QP, of the
/// decoded grid against the coded one.
/// Diagnostics: `CGV_JITTER=1` prints where the samples lie on the body
/// frame to frame (`CGV_JITTER=pinned`: of the pinned motion), and
/// `CGV_PINNED=1` codes frame 0's registered grid carried by the truth's
/// correspondence (the capture's map without its swim) at each QP;
/// `CGV_TRUE_FRAMES=1` registers the sequence's own frames (one
/// connectivity) in place of the remeshed capture; `CGV_TURNS=1` prints
/// the registration alone with every grid turned a quarter.
#[test]
#[ignore]
fn unregistered_against_registered() {
    let name = std::env::var("CGV_PROBE").unwrap_or_else(|_| "samba".into());
    let frames: usize = std::env::var("CGV_FRAMES").ok().and_then(|s| s.parse().ok()).unwrap_or(24);
    let n: usize = std::env::var("CGV_GRID").ok().and_then(|s| s.parse().ok()).unwrap_or(128);
    // CGV_START=K: the clip from frame K (its first frame mapped afresh).
    let start: usize = std::env::var("CGV_START").ok().and_then(|s| s.parse().ok()).unwrap_or(0);
    let dir = common::real_sequence(&name);
    let full = cgv::mesh::open_sequence(dir.to_str().unwrap(), &Default::default()).unwrap();
    let truth = InMemory {
        label: dir.clone(),
        fps: 30.0,
        topology: full.topology().clone(),
        frames: (start..start + frames).map(|t| full.read_frame(t).unwrap()).collect(),
    };
    let capture = if std::env::var("CGV_TRUE_FRAMES").is_ok() {
        truth
            .frames
            .iter()
            .map(|f| CaptureFrame { positions: f.clone(), faces: truth.topology.faces.clone() })
            .collect()
    } else if let Some(k) = std::env::var("CGV_STABLE").ok().and_then(|s| s.parse::<usize>().ok()) {
        // CGV_STABLE=K: runs of K frames that share one mesh (a vendor's
        // stabilized segments), each its first frame simplified.
        let faces = &truth.topology.faces;
        let mut run = None;
        (0..frames)
            .map(|t| {
                let f = truth.read_frame(t).unwrap();
                if t % k.max(1) == 0 {
                    run = Some(Remesh::of(&f, faces, keep_for(start + t, 0.5, 0.8, 5), (start + t) as u64));
                }
                let r = run.as_ref().unwrap();
                CaptureFrame { positions: r.positions(&f), faces: r.faces.clone() }
            })
            .collect()
    } else {
        remeshed_from(&truth, frames, start)
    };
    let grid = Grid::new(n).unwrap();
    let r: usize = std::env::var("CGV_REGISTER_GRID").ok().and_then(|s| s.parse().ok()).unwrap_or(n);
    // Segments as the encoder makes them (a map every 2 s at 30 frames/s).
    let (registered, report) =
        register(&dir, 30.0, &capture, Grid::new(r).unwrap(), longest_segment(0.0, 30.0), &mut |_, _, _| {}).unwrap();
    let mapped = surface_rms(&truth, Grid::new(r).unwrap(), &registered.grid.frames);
    // CGV_TURNS=1: the registration alone with every grid turned a
    // quarter (each quad's split laid the other way across the body).
    if std::env::var("CGV_TURNS").is_ok() {
        let g = Grid::new(r).unwrap();
        let turned: Vec<Vec<Vec3>> = registered.grid.frames.iter().map(|f| apply_symmetry(g, f, TURNS[1])).collect();
        let e = surface_rms(&truth, g, &turned);
        println!("registration alone turned a quarter {:.4} %", 100.0 * e.iter().sum::<f64>() / e.len() as f64);
    }
    println!(
        "{name}, {frames} frames, N = {n}, registered on {r}: {report:?}; registration alone {:.4} % (worst frame {:.4} %)",
        100.0 * mapped.iter().sum::<f64>() / frames as f64,
        100.0 * mapped.iter().cloned().fold(0.0, f64::max)
    );
    // The capture's own frames against the truth: the simplification's
    // error, under which no map of them can go.
    let own: Vec<f64> = (0..frames)
        .map(|t| {
            let f = &truth.frames[t];
            let c = &capture[t];
            let d = cgv::metrics::surface::symmetric(f, &truth.topology.faces, &c.positions, &c.faces).unwrap();
            d.rms / Bounds::of(f).diagonal() as f64
        })
        .collect();
    println!(
        "the capture itself {:.4} % (worst frame {:.4} %); registration per frame (%): {:?}",
        100.0 * own.iter().sum::<f64>() / frames as f64,
        100.0 * own.iter().cloned().fold(0.0, f64::max),
        mapped.iter().map(|x| (x * 1e5).round() / 1e3).collect::<Vec<_>>()
    );
    // Each capture frame's slivers: faces with an angle under 1 degree.
    let slivers: Vec<usize> = capture
        .iter()
        .map(|c| {
            c.faces
                .iter()
                .filter(|f| {
                    let p = f.map(|v| c.positions[v as usize]);
                    (0..3).any(|k| {
                        let (a, b) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                        a.angle_between(b).to_degrees() < 1.0
                    })
                })
                .count()
        })
        .collect();
    println!("faces with an angle under 1 degree, per frame: {slivers:?}");
    let edges: Vec<(usize, usize, usize)> = capture
        .iter()
        .map(|c| {
            let mut count = std::collections::HashMap::<(u32, u32), usize>::new();
            for f in &c.faces {
                for k in 0..3 {
                    let (a, b) = (f[k], f[(k + 1) % 3]);
                    *count.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
            let boundary = count.values().filter(|&&n| n == 1).count();
            let over = count.values().filter(|&&n| n > 2).count();
            let topo = cgv::mesh::Topology { vertex_count: c.positions.len(), faces: c.faces.clone() };
            let r = cgv::mesh::analyze(&topo, &c.positions);
            (boundary, over, r.components * 1000 + r.boundary_loops * 100 + r.non_manifold_edges)
        })
        .collect();
    println!("(boundary edges, edges of 3+ faces, parts) per frame: {edges:?}");
    // Spacing drift (`cgv::metrics::spacing_drift`: each sample's grid
    // spacing against the pinned grid's, frame 0's map carried by the
    // truth): how far the map's sampling density moves on the body.
    let register_stencils = cgv::grid::stencil::Stencils::new(Grid::new(r).unwrap());
    let carried = pinned_motion(&truth, &registered.grid, &report.segments);
    let drifts: Vec<f64> = (0..frames)
        .map(|t| cgv::metrics::spacing_drift(&register_stencils, &carried.frames[t], &registered.grid.frames[t], &[]))
        .collect();
    println!(
        "spacing drift against the pinned grid (%): {}; per frame {:?}",
        drift_summary(&drifts),
        drifts.iter().map(|x| (x * 1e3).round() / 10.0).collect::<Vec<_>>()
    );
    let across = swim(&truth, &registered.grid, &[]);
    let at_starts: Vec<String> = report
        .segments
        .iter()
        .map(|&s| format!("{s}: {:.2} -> {:.2}", 100.0 * across[s as usize - 1], 100.0 * across[s as usize]))
        .collect();
    println!("swim against frame 0 across segment starts (% of the diagonal): {at_starts:?}");
    let swim = swim(&truth, &registered.grid, &report.segments);
    let rest = &truth.frames[0];
    let diag = Bounds::of(rest).diagonal();
    let nearest = |t: usize, p: Vec3| nearest_vertex(&truth.frames[t], p);
    if let Ok(which) = std::env::var("CGV_JITTER") {
        let pinned = (which == "pinned").then(|| pinned_motion(&truth, &registered.grid, &report.segments));
        print_body_motion(&truth, &pinned.as_ref().unwrap_or(&registered.grid).frames);
    }
    println!(
        "swim per frame (% of the diagonal): {:?}",
        swim.iter().map(|x| (x * 1e4).round() / 1e2).collect::<Vec<_>>()
    );
    // Each cone's drift: where its track puts it on the body (the nearest
    // original vertex, read on frame 0) against where it was in frame 0. A
    // large drift is a track that jumped to another limb; swim without
    // drift is the map's doing.
    let tracked = track_capture(&dir, &capture).unwrap();
    let gaps = report.cone_tracks.map(|k| {
        let seen = &tracked.tracks[k].seen;
        (0..seen.len()).filter(|&t| seen[t].is_none()).collect::<Vec<_>>()
    });
    println!("frames each cone's track misses: {gaps:?}");
    let cone_at = |t: usize| {
        report.cone_tracks.map(|k| {
            let p = cgv::features::track::place(&tracked.tracks[k], &tracked.features, t).unwrap();
            rest[nearest(t, p)]
        })
    };
    let c0 = cone_at(0);
    let drift: Vec<[f32; 4]> = (0..frames)
        .map(|t| {
            let c = cone_at(t);
            std::array::from_fn(|i| (c[i].distance(c0[i]) / diag * 1e3).round() / 10.0)
        })
        .collect();
    println!("cone drift per frame (% of the diagonal): {drift:?}");
    // CGV_JITTER=regions: each sample's jitter on the body by how near it
    // lies (on frame 0) to a cone, or to another long track's feature.
    if std::env::var("CGV_JITTER").as_deref() == Ok("regions") {
        let others: Vec<Vec3> = (0..tracked.tracks.len())
            .filter(|k| !report.cone_tracks.contains(k) && tracked.tracks[*k].frames_seen() * 2 >= frames)
            .filter_map(|k| cgv::features::track::place(&tracked.tracks[k], &tracked.features, 0))
            .map(|p| rest[nearest(0, p)])
            .collect();
        print_jitter_regions(&truth, &registered.grid.frames, &c0, &others);
    }
    let bits = |bytes: usize| bytes as f64 * 8.0 / (truth.topology.vertex_count * frames) as f64;
    // --mesh frames at QP 28: what each frame's own mesh costs, and how far
    // its rebuilt vertices are from the capture's own.
    let mut opts = EncodeOptions {
        grid: n,
        source_mesh: false,
        frame_meshes: true,
        segments: report.segments.clone(),
        slide: std::env::var("CGV_SLIDE").is_ok(),
        ..Default::default()
    };
    opts.video.qp = 28;
    let (bytes, coded) = encode(&registered, &opts, &mut |_, _, _| {}).unwrap();
    let mut dec = FileDecoder::new(cgv::format::read(&bytes).unwrap(), cgv::solve::SolverKind::Predictive).unwrap();
    let (mut own_err, mut capture_vertices) = (Vec::new(), 0);
    for (t, c) in capture.iter().enumerate() {
        let (x, _) = dec.next_frame().unwrap();
        own_err.push(own_vertices_error(&mut dec, t, &x, c));
        capture_vertices += c.positions.len();
    }
    println!(
        "--mesh frames, QP 28: {} of {} bytes are the frame meshes ({:.0} a frame, {:.1} bits per capture vertex \
         a frame; the whole file {:.2} bits per original vertex a frame); the capture's own vertices rebuilt at \
         {:.4} % vertex RMS (worst frame {:.4} %)",
        coded.frame_mesh_bytes,
        bytes.len(),
        coded.frame_mesh_bytes as f64 / frames as f64,
        coded.frame_mesh_bytes as f64 * 8.0 / capture_vertices as f64,
        bits(bytes.len()),
        100.0 * own_err.iter().sum::<f64>() / frames as f64,
        100.0 * own_err.iter().cloned().fold(0.0, f64::max)
    );
    // CGV_PINNED=1: frame 0's grid carried by the truth's correspondence
    // (the capture's map without its swim), coded at each QP.
    let pinned = std::env::var("CGV_PINNED").is_ok().then(|| pinned_motion(&truth, &registered.grid, &report.segments));
    // CGV_QPS=16,28 for some rows only (empty: none).
    let qps: Vec<u8> = std::env::var("CGV_QPS")
        .unwrap_or_else(|_| "16,22,28,34".into())
        .split(',')
        .filter_map(|q| q.trim().parse().ok())
        .collect();
    // CGV_SLIDE=1: the capture coded with its targets slid along the
    // surface (`EncodeOptions::slide`); CGV_SLIDE=both: a row each way.
    let slides: &[bool] = match std::env::var("CGV_SLIDE").as_deref() {
        Ok("both") => &[false, true],
        Ok(_) => &[true],
        Err(_) => &[false],
    };
    let mut registered_rows = std::collections::HashMap::new();
    for (qp, &slide) in qps.iter().flat_map(|&q| slides.iter().map(move |s| (q, s))) {
        let (reg_bytes, reg_err) = registered_rows.entry(qp).or_insert_with(|| {
            let mut opts = EncodeOptions { grid: n, source_mesh: false, ..Default::default() };
            opts.video.qp = qp;
            // CGV_REGISTERED_SEGMENTS=1: the registered rows with the
            // capture's random-access points (what its segments cost).
            if std::env::var("CGV_REGISTERED_SEGMENTS").is_ok() {
                opts.segments = report.segments.clone();
            }
            let opts = probe_codec(opts);
            let (bytes, _) = encode(&truth, &opts, &mut |_, _, _| {}).unwrap();
            let file = cgv::format::read(&bytes).unwrap();
            print_ranges("registered", &file);
            let mut dec = FileDecoder::new(file, cgv::solve::SolverKind::Predictive).unwrap();
            let reg: Vec<Vec<Vec3>> = (0..frames).map(|_| dec.next_frame().unwrap().0).collect();
            (bytes.len(), surface_rms(&truth, grid, &reg))
        });
        let (ubytes, decoded) = round_trip_slid(&registered, n, qp, &report.segments, slide);
        let un_err = surface_rms(&truth, grid, &decoded);
        // The coding's own error: the decoded grid against the grid coded.
        let coding = surface_rms(&registered.grid, grid, &decoded);
        let mean = |e: &[f64]| 100.0 * e.iter().sum::<f64>() / e.len() as f64;
        if let Some(p) = &pinned {
            let (pbytes, pdec) = round_trip_in(p, n, qp, &report.segments);
            println!(
                "pinned QP {qp}: {:.3} b/v/f, {:.4} % against the truth, {:.4} % against its input",
                bits(pbytes),
                mean(&surface_rms(&truth, grid, &pdec)),
                mean(&surface_rms(p, grid, &pdec))
            );
        }
        let worst = |e: &[f64]| e.iter().cloned().fold(0.0, f64::max) / (e.iter().sum::<f64>() / e.len() as f64);
        // The decoded grid's spacing against the coded one's (where both
        // are on one grid).
        if r == n {
            let stencils = cgv::grid::stencil::Stencils::new(grid);
            let coded_drift: Vec<f64> = (0..frames)
                .map(|t| cgv::metrics::spacing_drift(&stencils, &registered.grid.frames[t], &decoded[t], &[]))
                .collect();
            println!("QP {qp}: spacing drift, decoded against coded (%): {}", drift_summary(&coded_drift));
        }
        println!(
            "| {name} ({frames}){} | {n} | {qp} | {:.3} | {:.4} | {:.3} | {:.4} | {:.2} | {:.4} |",
            if slide { ", slid" } else { "" },
            bits(*reg_bytes),
            mean(reg_err),
            bits(ubytes),
            mean(&un_err),
            worst(&un_err),
            mean(&coding)
        );
    }
}

fn cgv(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_cgv")).args(args).output().unwrap()
}

/// The commands: `cgv unregister` makes a capture of the walk, `cgv info
/// --unregistered` reports its features and tracks, a plain encode of it
/// is refused with a pointer to the option, `cgv encode --unregistered`
/// codes it and the file decodes, with `--mesh frames` to each frame's own
/// mesh.
#[test]
fn the_commands_make_report_and_code_a_capture() {
    let dir = common::temp_dir("unregistered-cli");
    let capture = dir.join("capture");
    let capture_s = capture.to_str().unwrap();
    let out = cgv(&["unregister", "builtin:walk", "--frames", "0..8", "-o", capture_s]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(cgv::mesh::obj::frame_files(&capture).unwrap().len(), 8);
    let info = cgv(&["info", capture_s, "--unregistered", "--json"]);
    assert!(info.status.success(), "{}", String::from_utf8_lossy(&info.stderr));
    let report: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(report["frames"], 8);
    assert!(report["vertices_min"].as_u64() < report["vertices_max"].as_u64(), "{report}");
    assert!(report["cones_seen"].as_array().unwrap().iter().all(|x| x.as_f64() == Some(1.0)), "{report}");
    assert_eq!(report["cones_seen_overall"].as_f64(), Some(1.0), "{report}");
    assert_eq!(report["segments"], serde_json::json!([0]), "one topology: one segment");
    assert_eq!(report["segments_cones_seen"], serde_json::json!([[1.0, 1.0, 1.0, 1.0]]), "{report}");
    let file = dir.join("capture.cgv");
    let plain = cgv(&["encode", capture_s, "--grid", "32", "-o", file.to_str().unwrap()]);
    assert!(!plain.status.success() && String::from_utf8_lossy(&plain.stderr).contains("--unregistered"));
    assert!(!file.exists());
    let past =
        cgv(&["encode", capture_s, "--unregistered", "--grid", "32", "--segments", "8", "-o", file.to_str().unwrap()]);
    assert!(!past.status.success() && String::from_utf8_lossy(&past.stderr).contains("segments"));
    assert!(!file.exists());
    // A registration past --memory-limit (8 frames on 256²: 1.5 MiB a
    // frame) is refused, nothing written.
    let args = ["encode", capture_s, "--unregistered", "--grid", "256", "--memory-limit", "4", "-o"];
    let big = cgv(&[&args[..], &[file.to_str().unwrap()]].concat());
    let err = String::from_utf8_lossy(&big.stderr);
    assert!(!big.status.success() && err.contains("--memory-limit") && err.contains(capture_s), "{err}");
    assert!(!file.exists());
    // A segment asked for at frame 4: a random-access point there.
    let args = ["encode", capture_s, "--unregistered", "--grid", "32", "--segments", "4", "-o", file.to_str().unwrap()];
    let coded = cgv(&args);
    assert!(coded.status.success(), "{}", String::from_utf8_lossy(&coded.stderr));
    let said = String::from_utf8_lossy(&coded.stderr);
    assert!(said.contains("registered 8 frames") && said.contains("from each frame's own mesh"), "{said}");
    // The grid's own line (the geometry image's floor) is no figure for a
    // capture: its grid is its own mesh.
    assert!(!String::from_utf8_lossy(&coded.stdout).contains("resamples the reference frame"));
    // The time line counts the registration: its total is no less.
    let stdout = String::from_utf8_lossy(&coded.stdout).to_string();
    let time = stdout.lines().find(|l| l.contains("time: ")).unwrap_or_default();
    let secs = |after: &str| -> f64 {
        let rest = &time[time.find(after).map_or(time.len(), |i| i + after.len())..];
        rest.split(' ').next().and_then(|x| x.parse().ok()).unwrap_or(f64::NAN)
    };
    assert!(secs("registration ") > 0.0 && secs("total ") >= secs("registration "), "{time}");
    let info = String::from_utf8_lossy(&cgv(&["info", file.to_str().unwrap()]).stdout).to_string();
    assert!(info.contains("segments      2, from frames 0, 4"), "{info}");
    // --json carries the registration's report, its floor included.
    let json = cgv(&[&args[..], &["--json"]].concat());
    assert!(json.status.success(), "{}", String::from_utf8_lossy(&json.stderr));
    let report: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    let registration = &report["registration"];
    // (Its segments are those it found: none; frame 4's was asked for.)
    assert_eq!((registration["frames"].as_u64(), &registration["segments"]), (Some(8), &serde_json::json!([])));
    // ... and how each tracked and lies from its meshes: here the one, from
    // frame 0, of all 8 frames, whose floor is the whole one's.
    let tracking = &registration["per_segment"];
    assert_eq!((&tracking[0]["start"], &tracking[0]["frames"]), (&serde_json::json!(0), &serde_json::json!(8)));
    assert_eq!(tracking.as_array().map(Vec::len), Some(1), "{registration}");
    assert!(registration["resampling_mean"].as_f64().is_some_and(|e| e > 0.0 && e < 0.05), "{registration}");
    assert_eq!(tracking[0]["resampling_worst"], registration["resampling_worst"], "{registration}");
    // The whole registration's time holds its kept pieces' features and maps.
    let secs = |k: &str| registration[k].as_f64().unwrap_or(f64::NAN);
    assert!(secs("seconds") >= secs("seconds_features") + secs("seconds_maps") - 1e-3, "{registration}");
    // --memory-limit is for a capture only.
    let plain = cgv(&["encode", "builtin:walk", "--memory-limit", "64", "-o", file.to_str().unwrap()]);
    assert!(!plain.status.success() && String::from_utf8_lossy(&plain.stderr).contains("--unregistered"));
    let glb = dir.join("capture.glb");
    let decoded = cgv(&["decode", file.to_str().unwrap(), "-o", glb.to_str().unwrap()]);
    assert!(decoded.status.success(), "{}", String::from_utf8_lossy(&decoded.stderr));
    // --mesh frames: each frame's own mesh comes back, one OBJ a frame.
    let frames_file = dir.join("frames.cgv");
    let args = ["encode", capture_s, "--unregistered", "--grid", "32", "--mesh", "frames", "-o"];
    let coded = cgv(&[&args[..], &[frames_file.to_str().unwrap()]].concat());
    assert!(coded.status.success(), "{}", String::from_utf8_lossy(&coded.stderr));
    assert!(String::from_utf8_lossy(&coded.stdout).contains("frame meshes"));
    let info = String::from_utf8_lossy(&cgv(&["info", frames_file.to_str().unwrap()]).stdout).to_string();
    assert!(info.contains("frame meshes  every frame its own"), "{info}");
    let objs = dir.join("frames");
    let decoded = cgv(&["decode", frames_file.to_str().unwrap(), "-o", objs.to_str().unwrap()]);
    assert!(decoded.status.success(), "{}", String::from_utf8_lossy(&decoded.stderr));
    let (ours, theirs) = (cgv::mesh::obj::frame_files(&objs).unwrap(), cgv::mesh::obj::frame_files(&capture).unwrap());
    assert_eq!(ours.len(), 8);
    for (a, b) in ours.iter().zip(&theirs) {
        let (a, b) = (cgv::mesh::obj::read_obj(a).unwrap(), cgv::mesh::obj::read_obj(b).unwrap());
        assert_eq!((a.0.len(), a.1.len()), (b.0.len(), b.1.len()), "each frame's own vertex and face counts");
    }
    // A glTF animation cannot change its faces: refused, nothing written;
    // --mesh frames of a registered motion: refused by name.
    let bad = dir.join("frames.glb");
    let out = cgv(&["decode", frames_file.to_str().unwrap(), "-o", bad.to_str().unwrap()]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("folder") && !bad.exists());
    let out = cgv(&["encode", "builtin:walk", "--mesh", "frames", "-o", bad.to_str().unwrap()]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("--unregistered") && !bad.exists());
}

/// `cgv unregister --stable` makes a capture in registered runs, which
/// `cgv info` lists and `cgv encode` maps a run at a time.
#[test]
fn a_capture_in_stable_runs_from_the_commands() {
    let dir = common::temp_dir("unregistered-stable");
    let capture = dir.join("capture");
    let capture_s = capture.to_str().unwrap();
    let zero = cgv(&["unregister", "builtin:walk", "--frames", "0..8", "--stable", "0", "-o", capture_s]);
    assert!(!zero.status.success() && String::from_utf8_lossy(&zero.stderr).contains("--stable") && !capture.exists());
    let out = cgv(&["unregister", "builtin:walk", "--frames", "0..8", "--stable", "4", "-o", capture_s]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let frames =
        cgv::features::capture::read_capture(&capture, None, cgv::features::capture::CaptureLimit::NONE).unwrap();
    assert!(
        frames[1].shares_mesh(&frames[3]) && frames[4].shares_mesh(&frames[7]) && !frames[3].shares_mesh(&frames[4])
    );
    let info = cgv(&["info", capture_s, "--unregistered", "--json"]);
    let report: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(
        (&report["segments"], &report["registered_runs"]),
        (&serde_json::json!([0, 4]), &serde_json::json!([[0, 4], [4, 8]]))
    );
    assert_eq!(report["cones_seen_overall"].as_f64(), Some(1.0), "{report}");
    let text = String::from_utf8_lossy(&cgv(&["info", capture_s, "--unregistered"]).stdout).into_owned();
    assert!(text.contains("frames 0-3, 4-7 share one mesh"), "{text}");
    let file = dir.join("capture.cgv");
    let coded = cgv(&["encode", capture_s, "--unregistered", "--grid", "32", "-o", file.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&coded.stderr);
    assert!(coded.status.success() && err.contains("8 frames share one mesh"), "{err}");
    // One run cut into segments of 4 frames (2 s at 2 fps) is listed whole.
    let one = dir.join("one-run");
    let out = cgv(&["unregister", "builtin:walk", "--frames", "0..9", "--stable", "9", "-o", one.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let info = cgv(&["info", one.to_str().unwrap(), "--unregistered", "--fps", "2", "--json"]);
    let report: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(
        (&report["segments"], &report["registered_runs"]),
        (&serde_json::json!([0, 4, 8]), &serde_json::json!([[0, 9]]))
    );
}

/// A capture of GLB frames reads as the same capture in OBJ: each frame's
/// own vertices and faces (welded as the glTF reader welds). `--frames A..B`
/// takes frames A to B - 1 (not A to A + (B - A) - A). A folder with both
/// kinds, and a glTF frame that is an animation, are refused by name.
#[test]
fn a_capture_of_glb_frames_reads_as_its_obj_frames() {
    use cgv::features::capture::{read_capture, Capture, CaptureFiles, CaptureLimit};
    use cgv::mesh::{gltf_out::write_glb, Topology};
    let dir = common::temp_dir("unregistered-glb");
    let (objs, glbs) = (dir.join("obj"), dir.join("glb"));
    let out = cgv(&["unregister", "builtin:walk", "--frames", "0..4", "-o", objs.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    std::fs::create_dir_all(&glbs).unwrap();
    let from_obj = read_capture(&objs, None, CaptureLimit::NONE).unwrap();
    for (t, f) in from_obj.iter().enumerate() {
        let topology = Topology { vertex_count: f.positions.len(), faces: f.faces.clone() };
        let path = glbs.join(format!("frame_{t}.glb"));
        write_glb(&path, &topology, 1, 30.0, "capture", None, |_| Ok(f.positions.clone())).unwrap();
    }
    let from_glb = read_capture(&glbs, None, CaptureLimit::NONE).unwrap();
    assert_eq!(from_glb.len(), 4);
    for (a, b) in from_obj.iter().zip(&from_glb) {
        assert_eq!((a.positions.len(), a.faces.len()), (b.positions.len(), b.faces.len()));
        let sq: f32 = a.positions.iter().zip(&b.positions).map(|(p, q)| p.distance_squared(*q)).sum();
        assert!(sq < 1e-10, "positions {sq}");
    }
    // A capture past the limit is refused while it is read, by name.
    // The first frame sets the pace: one frame a batch, so the limit is
    // passed by the second frame, not by a whole batch.
    let one = CaptureLimit { bytes: CaptureLimit::NONE.frame_bytes(&from_obj[0]), grid_samples: None };
    match read_capture(&glbs, None, one) {
        Err(e @ cgv::Error::CaptureMemory { frames, needed, limit, .. }) => {
            assert!(frames == 2 && needed > limit && e.to_string().contains(glbs.to_str().unwrap()), "{e}");
        }
        other => panic!("{:?}", other.map(|f| f.len())),
    }
    // A segment is read on its own: the limit holds for its frames, and
    // the error says where it starts.
    let largest = from_glb.iter().map(|f| CaptureLimit::NONE.frame_bytes(f)).max().unwrap();
    let files = CaptureFiles::open(&glbs, None, CaptureLimit { bytes: largest, grid_samples: None }).unwrap();
    assert_eq!(files.frames(3..4).unwrap().len(), 1);
    match files.frames(2..4) {
        Err(e @ cgv::Error::CaptureMemory { first: 2, frames: 2, .. }) => {
            assert!(e.to_string().contains("from frame 2"), "{e}")
        }
        other => panic!("{:?}", other.map(|f| f.len())),
    }
    let middle = read_capture(&glbs, Some("1..3".parse().unwrap()), CaptureLimit::NONE).unwrap();
    assert_eq!(middle.len(), 2);
    assert_eq!(middle[0].faces, from_glb[1].faces);
    assert_eq!(middle[1].faces, from_glb[2].faces);
    let info = cgv(&["info", glbs.to_str().unwrap(), "--unregistered", "--json"]);
    assert!(info.status.success(), "{}", String::from_utf8_lossy(&info.stderr));
    let report: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(report["frames"], 4);
    // Both kinds in one folder.
    std::fs::copy(objs.join("0.obj"), glbs.join("0.obj")).unwrap();
    let mixed = read_capture(&glbs, None, CaptureLimit::NONE).unwrap_err().to_string();
    assert!(mixed.contains("both OBJ (1) and glTF (4)") && mixed.contains(glbs.to_str().unwrap()), "{mixed}");
    std::fs::remove_file(glbs.join("0.obj")).unwrap();
    // A frame that is an animation of 3 frames.
    let f = &from_obj[0];
    let topology = Topology { vertex_count: f.positions.len(), faces: f.faces.clone() };
    let moving = glbs.join("frame_4.glb");
    write_glb(&moving, &topology, 3, 30.0, "capture", None, |_| Ok(f.positions.clone())).unwrap();
    let err = read_capture(&glbs, None, CaptureLimit::NONE).unwrap_err().to_string();
    assert!(err.contains("frame_4.glb") && err.contains("bakes to 3 frames"), "{err}");
}

/// The vertex of `f` nearest `p` (by brute force: a probe's few frames).
fn nearest_vertex(f: &[Vec3], p: Vec3) -> usize {
    (0..f.len()).min_by(|&a, &b| f[a].distance_squared(p).total_cmp(&f[b].distance_squared(p))).unwrap_or(0)
}

/// The point of triangle `t` nearest `p`, as barycentric weights.
fn nearest_on_triangle(p: Vec3, t: [Vec3; 3]) -> [f32; 3] {
    let (a, b, c) = (t[0], t[1], t[2]);
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    [1.0 - v - w, v, w]
}

/// The registered grid's frame 0 pinned to the truth's surface (each sample
/// at its nearest point on a face around its nearest vertex) and carried
/// through the truth's frames by its correspondence, and so again from
/// each segment's first frame (`starts`, as [`swim`]'s): the capture's map
/// with no swim (a diagnostic: which of the two the coding pays for).
fn pinned_motion(truth: &InMemory, registered: &InMemory, starts: &[u32]) -> InMemory {
    let mut spots = Vec::new();
    let mut frames = Vec::with_capacity(truth.frames.len());
    for (t, f) in truth.frames.iter().enumerate() {
        if t == 0 || starts.contains(&(t as u32)) {
            spots = spots_on(truth, t, &registered.frames[t]);
        }
        frames.push(spots.iter().map(|s| at_spot(truth, f, *s)).collect());
    }
    InMemory { frames, ..pinned_shell(registered) }
}

/// A face of the truth and barycentric weights on it.
type Spot = (usize, [f32; 3]);

/// Where each of `points` lies on truth frame `t`: its nearest point on a
/// face round its nearest vertex.
fn spots_on(truth: &InMemory, t: usize, points: &[Vec3]) -> Vec<Spot> {
    let (f, faces) = (&truth.frames[t], &truth.topology.faces);
    let mut around: Vec<Vec<usize>> = vec![Vec::new(); f.len()];
    for (k, face) in faces.iter().enumerate() {
        face.iter().for_each(|&v| around[v as usize].push(k));
    }
    points
        .iter()
        .map(|&p| {
            let v = nearest_vertex(f, p);
            let on = |k: &usize| {
                let w = nearest_on_triangle(p, faces[*k].map(|i| f[i as usize]));
                (at_spot(truth, f, (*k, w)).distance(p), (*k, w))
            };
            around[v].iter().map(on).min_by(|a, b| a.0.total_cmp(&b.0)).unwrap().1
        })
        .collect()
}

/// The point of `frame` (a truth frame) at `spot`.
fn at_spot(truth: &InMemory, frame: &[Vec3], (k, w): Spot) -> Vec3 {
    let t = truth.topology.faces[k].map(|i| frame[i as usize]);
    t[0] * w[0] + t[1] * w[1] + t[2] * w[2]
}

/// Where every 7th sample of `grid_frame` lies on the body: its spot on
/// truth frame `t`, read on frame 0.
fn body_places(truth: &InMemory, grid_frame: &[Vec3], t: usize) -> Vec<Vec3> {
    let samples: Vec<Vec3> = grid_frame.iter().step_by(7).copied().collect();
    spots_on(truth, t, &samples).into_iter().map(|s| at_spot(truth, &truth.frames[0], s)).collect()
}

/// `src` without its frames.
fn pinned_shell(src: &InMemory) -> InMemory {
    InMemory { label: src.label.clone(), fps: src.fps, topology: src.topology.clone(), frames: Vec::new() }
}

/// Prints where `grid_frames`' samples lie on the body ([`body_places`])
/// from frame to frame: each step, and each second difference (motion
/// that a predictor from the past cannot follow), RMS and median, in % of
/// frame 0's diagonal; and the medians' means.
fn print_body_motion(truth: &InMemory, grid_frames: &[Vec<Vec3>]) {
    let diag = Bounds::of(&truth.frames[0]).diagonal();
    let b: Vec<Vec<Vec3>> = (0..grid_frames.len()).map(|t| body_places(truth, &grid_frames[t], t)).collect();
    let rms = |v: &[f32]| (v.iter().map(|x| x * x).sum::<f32>() / v.len() as f32).sqrt() / diag * 100.0;
    let med = |v: &mut [f32]| {
        v.sort_by(f32::total_cmp);
        v[v.len() / 2] / diag * 100.0
    };
    let summary = |mut d: Vec<f32>| (rms(&d), med(&mut d));
    let step: Vec<(f32, f32)> =
        (1..b.len()).map(|t| summary(b[t].iter().zip(&b[t - 1]).map(|(x, y)| x.distance(*y)).collect())).collect();
    let jitter: Vec<(f32, f32)> = (1..b.len().saturating_sub(1))
        .map(|t| summary((0..b[t].len()).map(|i| (b[t + 1][i] - 2.0 * b[t][i] + b[t - 1][i]).length()).collect()))
        .collect();
    let mean_median = |v: &[(f32, f32)]| v.iter().map(|x| x.1).sum::<f32>() / v.len().max(1) as f32;
    let show = |v: &[(f32, f32)]| v.iter().map(|(r, m)| format!("{r:.2}/{m:.2}")).collect::<Vec<_>>();
    println!("body step per frame (RMS/median %): {:?}; mean median {:.3} %", show(&step), mean_median(&step));
    println!(
        "body jitter (second difference, RMS/median %): {:?}; mean median {:.3} %",
        show(&jitter),
        mean_median(&jitter)
    );
}

/// Each sample's mean jitter on the body (second difference of
/// [`body_places`]; at least 3 frames) by where it lies on frame 0: within
/// 10 % of the diagonal of a cone, else of another long track's feature,
/// else elsewhere; by its distance to the nearest cone in steps of 15 % of
/// the diagonal; and by its grid steps from the square's border.
fn print_jitter_regions(truth: &InMemory, grid_frames: &[Vec<Vec3>], cones: &[Vec3; 4], others: &[Vec3]) {
    let diag = Bounds::of(&truth.frames[0]).diagonal();
    let b: Vec<Vec<Vec3>> = (0..grid_frames.len()).map(|t| body_places(truth, &grid_frames[t], t)).collect();
    let n = b[0].len();
    let jit: Vec<f32> = (0..n)
        .map(|i| {
            let d: f32 = (1..b.len() - 1).map(|t| (b[t + 1][i] - 2.0 * b[t][i] + b[t - 1][i]).length()).sum();
            d / (b.len() - 2) as f32 / diag * 100.0
        })
        .collect();
    let near = |p: Vec3, set: &[Vec3]| set.iter().map(|c| c.distance(p)).fold(f32::MAX, f32::min) / diag;
    let mut bins = [(0.0f32, 0usize); 3];
    let mut by_cone = [(0.0f32, 0usize); 5];
    for i in 0..n {
        let (dc, dof) = (near(b[0][i], cones), near(b[0][i], others));
        let k = if dc < 0.1 {
            0
        } else if dof < 0.1 {
            1
        } else {
            2
        };
        bins[k].0 += jit[i];
        bins[k].1 += 1;
        let q = ((dc / 0.15) as usize).min(4);
        by_cone[q].0 += jit[i];
        by_cone[q].1 += 1;
    }
    let show =
        |v: &[(f32, usize)]| v.iter().map(|(s, c)| format!("{:.3} ({c})", s / (*c).max(1) as f32)).collect::<Vec<_>>();
    println!(
        "{} other long tracks; mean jitter % near a cone / near another feature / elsewhere: {:?}",
        others.len(),
        show(&bins)
    );
    // By distance to the square's border (the cut) in grid steps.
    let side = (grid_frames[0].len() as f64).sqrt() as usize;
    let mut by_border = [(0.0f32, 0usize); 6];
    for (i, j) in jit.iter().enumerate() {
        let (r, c) = ((i * 7) / side, (i * 7) % side);
        let d = r.min(c).min(side - 1 - r).min(side - 1 - c);
        let k = [0usize, 2, 4, 8, 16].iter().filter(|&&e| d >= e).count() - 1 + usize::from(d >= 32);
        by_border[k].0 += j;
        by_border[k].1 += 1;
    }
    let mut sorted = jit.clone();
    sorted.sort_by(f32::total_cmp);
    let q = |f: f64| sorted[((sorted.len() - 1) as f64 * f) as usize];
    println!("jitter quantiles 50/90/99 %: {:.3} / {:.3} / {:.3}; by steps from the border (0-1, 2-3, 4-7, 8-15, 16-31, 32+): {:?}", q(0.5), q(0.9), q(0.99), show(&by_border));
    println!(
        "mean jitter % by distance to the nearest cone (0-15, 15-30, 30-45, 45-60, 60+ % of the diagonal): {:?}",
        show(&by_cone)
    );
}

/// An open capture (the wolf: three open parts) comes back without the
/// grid faces over its holes and between its parts: the registration
/// leaves them out, the file carries the grid mesh without them, and what
/// decodes has as many faces; its grid then lies no further from each
/// frame's own mesh than with them. A closed capture keeps every face.
#[test]
fn an_open_capture_comes_back_without_the_faces_over_its_holes() {
    let dir = common::temp_dir("unregistered-open");
    let wolf = common::real_sequence("wolf");
    let capture = dir.join("capture");
    let out = cgv(&["unregister", wolf.to_str().unwrap(), "--frames", "0..3", "-o", capture.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let frames =
        cgv::features::capture::read_capture(&capture, None, cgv::features::capture::CaptureLimit::NONE).unwrap();
    let grid = Grid::new(32).unwrap();
    let (registered, report) =
        register(&capture, 30.0, &frames, grid, longest_segment(0.0, 30.0), &mut |_, _, _| {}).unwrap();
    let all = grid.topology().faces;
    let kept = &registered.grid.topology.faces;
    assert!(report.lid_faces > 0 && kept.len() + report.lid_faces == all.len(), "{report:?}");
    let on = |faces: &[[u32; 3]], t: usize| {
        let f = &frames[t];
        cgv::metrics::surface::symmetric_rms(&f.positions, &f.faces, &registered.grid.frames[t], faces).unwrap()
    };
    for (t, f) in frames.iter().enumerate() {
        assert!(on(kept, t) <= on(&all, t) * 1.001, "frame {t}: {} against {}", on(kept, t), on(&all, t));
        // The kept faces' samples lie on the frame's own mesh (those at a
        // hole's rim too: moved onto it).
        let own = cgv::metrics::surface::Target::new(&f.positions, &f.faces).unwrap();
        let diagonal = Bounds::of(&f.positions).diagonal() as f64;
        let off = kept.iter().flatten().map(|&s| own.distance(registered.grid.frames[t][s as usize]));
        assert!(off.fold(0.0, f64::max) < 1e-5 * diagonal, "frame {t}");
    }
    let file = dir.join("wolf.cgv");
    let args = ["encode", capture.to_str().unwrap(), "--unregistered", "--grid", "32", "-o", file.to_str().unwrap()];
    let coded = cgv(&args);
    assert!(coded.status.success(), "{}", String::from_utf8_lossy(&coded.stderr));
    assert!(String::from_utf8_lossy(&coded.stderr).contains("grid faces over the capture's holes left out"));
    // A target error is met on the grid's kept faces, and says that the
    // grid lies off the capture's own meshes by the registration's floor.
    let aimed = cgv(&[&args[..], &["--target-error", "1"]].concat());
    let said = String::from_utf8_lossy(&aimed.stdout).into_owned();
    assert!(aimed.status.success() && said.contains("against the registered grid; the grid lies"), "{said}");
    let reached = said.split("surface RMS ").nth(1).and_then(|r| r.split(' ').next()?.parse::<f64>().ok());
    assert!(reached.is_some_and(|e| e <= 1.0), "{said}");
    let objs = dir.join("decoded");
    let decoded = cgv(&["decode", file.to_str().unwrap(), "-o", objs.to_str().unwrap()]);
    assert!(decoded.status.success(), "{}", String::from_utf8_lossy(&decoded.stderr));
    let first = &cgv::mesh::obj::frame_files(&objs).unwrap()[0];
    let (_, faces) = cgv::mesh::obj::read_obj(first).unwrap();
    assert_eq!(faces.len(), kept.len());
    // The walk is closed: nothing left out.
    let walk: Vec<CaptureFrame> = remeshed(&cgv::mesh::builtin::motion(3), 3);
    let (closed, report) = register(Path::new("walk"), 30.0, &walk, grid, 60, &mut |_, _, _| {}).unwrap();
    assert_eq!((report.lid_faces, closed.grid.topology.faces.len()), (0, all.len()));
}

//! An unregistered capture (every frame its own mesh) registered onto one
//! grid, as the seed paper builds a CGV from one (section 4): features
//! detected on every frame ([`detect`](super::detect)), tracked through
//! the frames ([`track`](super::track)), and every frame mapped onto the
//! square orbifold with the same four tracked features as its cones. The
//! orbifold map of a sphere-like surface is fixed by its cones (Aigerman
//! and Lipman 2015), so the grid sample at a place lands on the same point
//! of a near-isometrically moving body in every frame: the grid frames are
//! a registered animation of the capture, which the codec codes as any
//! other motion.

use super::capture::{is_registered_run, Capture, CaptureFrame};
use super::cones::chosen_cones;
use super::follow::CutTrace;
use super::frame_map::{cut_frame, finish_cut, map_frame, map_run, nearest, FrameCut, Mapped};
use super::handover::{self, Handover, RunMap};
pub use super::report::RegisterReport;
use super::segments::segment_ranges;
use super::store::FrameStore;
pub use super::store::Registered;
use super::symmetry::{apply_symmetry, symmetry_between, turn_place, Symmetry, IDENTITY};
pub use super::track::Tracked;
use super::track::{place, Track};
use super::tracking::track_capture;
use super::{diagonals, jumps, lids, outliers, segments, smooth};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::mesh::{Bounds, FrameMesh, InMemory};
use glam::Vec3;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// The capture `frames` (named `label`) on `grid`, held in memory: each
/// frame's grid positions, as a motion on the grid's own mesh, and the
/// report ([`register_into`]).
pub fn register(
    label: &Path,
    fps: f32,
    frames: &[CaptureFrame],
    grid: Grid,
    longest: usize,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(Registered, RegisterReport)> {
    let mut store = Registered::empty(label, fps, grid);
    let report = register_into(label, fps, &frames, grid, longest, &mut store, progress)?;
    Ok((store, report))
}

/// The capture `capture` (named `label`) on `grid`, each frame's grid and
/// own mesh written to `store`, and the report. The capture is registered
/// segment by segment ([`segment_ranges`]: where its topology changes,
/// where a registered run starts or ends, and every `longest` frames),
/// each read on its own and with its own
/// tracks and maps ([`registered_parts`]), going on where the last left
/// off ([`handover`]: its cones, its cut, its turn of the square); only
/// the segment in hand is held. `progress` hears ("reading", frames read,
/// frames) while the segments are found, then ("registering", frames
/// done, frames) after each segment.
pub fn register_into(
    label: &Path,
    fps: f32,
    capture: &dyn Capture,
    grid: Grid,
    longest: usize,
    store: &mut dyn FrameStore,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<RegisterReport> {
    let t0 = std::time::Instant::now();
    let ranges = segment_ranges(capture, longest, progress)?;
    let several = ranges.len() > 1;
    let (mut all, mut starts): (Option<RegisterReport>, Vec<usize>) = (None, Vec::new());
    // Each frame's resampling error, as the pieces' checks measured it,
    // and each frame's diagonal.
    let (mut errors, mut diagonals) = (Vec::with_capacity(capture.len()), Vec::with_capacity(capture.len()));
    let mut last: Option<Handover> = None;
    for r in ranges {
        let (a, b) = (r.start, r.end);
        let in_segment = |e: Error| match several {
            false => e,
            true => Error::Argument(format!("the segment of frames {a}..{b}: {e}")),
        };
        let part = capture.frames(r)?;
        diagonals.extend(part.iter().map(|f| Bounds::of(&f.positions).diagonal() as f64));
        let (pieces, next) = registered_parts(label, fps, &part, grid, last.as_ref()).map_err(in_segment)?;
        progress("registering", b, capture.len());
        last = Some(next);
        for (start, src, report, measured) in pieces {
            // Every piece comes measured ([`measure_pieces`]); the outlier
            // pass checks the count.
            errors.extend(measured.into_iter().flatten());
            starts.push(a + start);
            for (g, m) in src.grid.frames.into_iter().zip(src.meshes) {
                store.push(g, m)?;
            }
            match &mut all {
                None => all = Some(report),
                Some(so_far) => so_far.join(a + start, &report),
            }
        }
    }
    let mut report = all.ok_or_else(|| Error::Argument(format!("{}: a capture without frames", label.display())))?;
    report.rebuilt_frames = outliers::rebuilt(grid, capture, &starts, store, &mut errors)?;
    let kept = lids::kept_faces(grid, &report.lid_votes, report.lid_pieces);
    report.lid_faces = grid.topology().faces.len() - kept.len();
    if report.lid_faces > 0 {
        errors = lids::onto_own_meshes(capture, store, &kept)?;
        store.set_faces(kept);
    }
    let relative: Vec<f64> = errors.iter().zip(&diagonals).map(|(e, d)| e / d.max(f64::MIN_POSITIVE)).collect();
    report.set_floors(&relative);
    report.seconds = t0.elapsed().as_secs_f64();
    Ok(report)
}

/// One segment `part` registered, as one piece or as the pieces of its
/// halves ([`halves`]). Where fewer than four of its tracks, or of the
/// cones chosen, are seen in enough of its frames
/// ([`segments::untracked_split`]), the halves of a segment of at least
/// [`segments::EARLY_SPLIT`] frames are registered before the whole is
/// mapped, and kept if their frames do not swim ([`segments::swims`]).
/// Otherwise the whole is mapped, and where its tracks fail, it swims
/// ([`segments::split_at`]) or its early halves did, the halves are kept
/// if their worst frame lies no further from its own mesh than the
/// whole's. Returns each piece's first frame (in `part`), grid and
/// report, and what the next segment starts from. Each piece goes on from
/// the last one's `handover`.
fn registered_parts(
    label: &Path,
    fps: f32,
    part: &[CaptureFrame],
    grid: Grid,
    handover: Option<&Handover>,
) -> Result<(Vec<Piece>, Handover)> {
    if is_registered_run(part) || going_on(part, handover).is_some() {
        let (src, report, next) = register_run(label, fps, part, grid, handover)?;
        let mut whole = vec![(0, src, report, None)];
        measure_pieces(part, &mut whole, grid)?;
        return Ok((whole, next));
    }
    let mut tracked = track_capture(label, part)?;
    // Mapping a long segment that is split anyway took most of whole
    // pcow's registration (385 s; its kept pieces' features and maps,
    // 81 s); a shorter one's halves won or lost against it about as often.
    let long = part.len() >= segments::EARLY_SPLIT;
    let share = |t: &Track| t.frames_seen() as f64 / part.len().max(1) as f64;
    let untracked = segments::untracked_split(part.len(), tracked.tracks.iter().map(share)).filter(|_| long);
    let mut early = untracked.map(|mid| halves(label, fps, part, grid, handover, mid));
    if let Some(pieces) = steady_halves(part, &mut early, grid)? {
        return Ok(pieces);
    }
    let first_trace;
    (tracked.cones, first_trace) = chosen_cones(label, part, &tracked, (grid, diagonal_of(part)), handover)?;
    let unseen = segments::untracked_split(part.len(), tracked.cones_seen().into_iter());
    if long && untracked.is_none() {
        early = unseen.map(|mid| halves(label, fps, part, grid, handover, mid));
        if let Some(pieces) = steady_halves(part, &mut early, grid)? {
            return Ok(pieces);
        }
    }
    let (src, report, next) = register_piece(label, fps, part, tracked, first_trace, grid, handover)?;
    let (swims, errors) = segments::split_at(part, &src.grid.frames, grid)?;
    let mut whole = vec![(0, src, report, errors)];
    // Halves tried early (which swim, or did not register) are not tried
    // again.
    let split = match early {
        Some(tried) => tried,
        None => swims.or(unseen).and_then(|mid| halves(label, fps, part, grid, handover, mid)),
    };
    if let Some((mut pieces, end)) = split {
        if worst_resampling(part, &mut pieces, grid)? <= worst_resampling(part, &mut whole, grid)? {
            return Ok((pieces, end));
        }
    }
    measure_pieces(part, &mut whole, grid)?;
    Ok((whole, next))
}

/// `part` registered as its halves split at `mid`, the second going on
/// from the first: their pieces and what the next segment starts from, or
/// `None` if either fails to register.
fn halves(
    label: &Path,
    fps: f32,
    part: &[CaptureFrame],
    grid: Grid,
    handover: Option<&Handover>,
    mid: usize,
) -> Option<(Vec<Piece>, Handover)> {
    let (left, between) = registered_parts(label, fps, &part[..mid], grid, handover).ok()?;
    let (right, end) = registered_parts(label, fps, &part[mid..], grid, Some(&between)).ok()?;
    let right = right.into_iter().map(|(s, g, r, e)| (s + mid, g, r, e));
    Some((left.into_iter().chain(right).collect(), end))
}

/// The halves in `early`, taken out, if they registered and their frames
/// do not swim ([`segments::swims`]); halves that swim are left for the
/// whole to be compared with.
fn steady_halves(
    part: &[CaptureFrame],
    early: &mut Option<Option<(Vec<Piece>, Handover)>>,
    grid: Grid,
) -> Result<Option<(Vec<Piece>, Handover)>> {
    let Some(Some((pieces, _))) = early else { return Ok(None) };
    measure_pieces(part, pieces, grid)?;
    let errors: Vec<f64> = pieces.iter().flat_map(|p| p.3.iter().flatten()).copied().collect();
    Ok(if segments::swims(&errors) { None } else { early.take().flatten() })
}

/// The diagonal of a piece's first frame (the tracker's and cut's scale).
fn diagonal_of(part: &[CaptureFrame]) -> f32 {
    part.first().map_or(0.0, |f| Bounds::of(&f.positions).diagonal())
}

/// Each of `pieces` (of `part`) with its frames' resampling errors
/// ([`outliers::resampling_errors`]), measured where its checks did not.
fn measure_pieces(part: &[CaptureFrame], pieces: &mut [Piece], grid: Grid) -> Result<()> {
    for (start, src, _, measured) in pieces.iter_mut().filter(|p| p.3.is_none()) {
        let frames = &src.grid.frames;
        let frames_of = part.get(*start..*start + frames.len());
        let piece = frames_of
            .ok_or_else(|| Error::Argument(format!("a piece of {} frames past the segment's end", frames.len())))?;
        *measured = Some(outliers::resampling_errors(piece, frames, grid)?);
    }
    Ok(())
}

/// The furthest any frame of `part`, registered as `pieces` (measured
/// here where they were not), lies from its own mesh.
fn worst_resampling(part: &[CaptureFrame], pieces: &mut [Piece], grid: Grid) -> Result<f64> {
    measure_pieces(part, pieces, grid)?;
    Ok(pieces.iter().flat_map(|p| p.3.iter().flatten()).copied().fold(0.0, f64::max))
}

/// A registered piece of a capture: its first frame, grid and report, and
/// its frames' resampling errors (`None` until measured).
type Piece = (usize, Registered, RegisterReport, Option<Vec<f64>>);

/// [`register`] with the features already found and tracked.
pub fn register_tracked(
    label: &Path,
    fps: f32,
    frames: &[CaptureFrame],
    tracked: Tracked,
    grid: Grid,
) -> Result<(Registered, RegisterReport)> {
    fits(label, frames, &tracked)?;
    let mut tracked = tracked;
    let first_trace;
    (tracked.cones, first_trace) = chosen_cones(label, frames, &tracked, (grid, diagonal_of(frames)), None)?;
    register_piece(label, fps, frames, tracked, first_trace, grid, None).map(|(src, report, _)| (src, report))
}

/// [`register_tracked`] with the cones chosen ([`chosen_cones`]: the
/// first frame's cut traced from `first_trace`), going on from the last
/// piece's `handover` ([`handover`]), and what the next piece starts
/// from.
fn register_piece(
    label: &Path,
    fps: f32,
    frames: &[CaptureFrame],
    tracked: Tracked,
    first_trace: Option<&CutTrace>,
    grid: Grid,
    handover: Option<&Handover>,
) -> Result<(Registered, RegisterReport, Handover)> {
    fits(label, frames, &tracked)?;
    let t1 = std::time::Instant::now();
    let diagonal = diagonal_of(frames);
    let cones_at = cone_places(&tracked);
    let mut mapped = mapped_in_turn(label, frames, &cones_at, first_trace, grid)?;
    // The cut gives each cone its side by the order its path leaves the
    // corner in, which the trace mostly keeps (the square's first side is
    // wherever the walk round the corner starts: any turn). The reference
    // is the assignment most frames share up to a turn of the square; a
    // frame with another order is mapped again with its cut traced from
    // the nearest agreeing frame's, and a frame whose cones sit on other
    // sides is turned back by the turn that puts them there.
    let agreeing = |r: &[usize; 4]| mapped.iter().filter(|m| symmetry_between(&m.sides, r).is_some()).count();
    let reference = mapped.iter().map(|m| m.sides).max_by_key(|r| agreeing(r)).unwrap_or([0, 1, 2, 3]);
    // Frame t mapped again with its cut traced from `trace`.
    let remap = |t: usize, trace: &CutTrace| map_frame(label, &frames[t], &cones_at(t), Some(trace), grid);
    remapped_to_agree(&remap, &mut mapped, &reference)?;
    let jumping = steady_jumps(&remap, &mut mapped, &reference, grid, diagonal)?;
    // The next piece's cut follows the last cut that went the reference's
    // way round (not one still jumping, to be bridged, or unmatched).
    let steady = |t: &usize| !jumping.contains(t) && symmetry_between(&mapped[*t].sides, &reference).is_some();
    let last_trace = (0..mapped.len()).rev().find(steady).map(|t| mapped[t].trace.clone());
    // Which samples lie on each frame's own faces, as its grid is turned;
    // a frame bridged from its neighbours, or that no turn matches, has a
    // grid its map does not describe and says nothing.
    let on_input: Vec<Vec<bool>> = (0..mapped.len())
        .filter(|t| !jumping.contains(t))
        .filter_map(|t| symmetry_between(&mapped[t].sides, &reference).map(|s| (t, s)))
        .map(|(t, s)| apply_symmetry(grid, &mapped[t].on_input, s))
        .collect();
    let (mut positions, mut places, turned, unmatched) = turned_back(grid, mapped, &reference);
    let smoothed = bridged_and_smoothed(grid, frames, &jumping, &mut positions, &mut places)?;
    let turn = turned_to(grid, frames, handover, &mut positions, &mut places)?;
    let on_input: Vec<Vec<bool>> = on_input.iter().map(|o| apply_symmetry(grid, o, turn)).collect();
    let mut report = RegisterReport {
        frames: frames.len(),
        turned_frames: turned,
        unmatched_frames: unmatched,
        bridged_frames: jumping.len(),
        smoothed_frames: smoothed,
        seconds_maps: t1.elapsed().as_secs_f64(),
        lid_votes: lids::over_holes(grid, &on_input),
        lid_pieces: 1,
        ..RegisterReport::of_tracking(&tracked)
    };
    for s in &mut report.per_segment {
        (s.unmatched_frames, s.bridged_frames) = (unmatched, jumping.len());
    }
    let last_grid = positions.last().cloned().unwrap_or_default();
    let next = Handover::of(&tracked, last_trace, last_grid);
    Ok((registered(label, fps, grid, frames, positions, places), report, next))
}

/// A piece's frames registered: each frame's grid `positions` as a motion
/// on the grid's mesh, and its own mesh with its vertices' `places`.
fn registered(
    label: &Path,
    fps: f32,
    grid: Grid,
    frames: &[CaptureFrame],
    positions: Vec<Vec<Vec3>>,
    places: Vec<Vec<[u32; 2]>>,
) -> Registered {
    let meshes = frames.iter().zip(places).map(|(f, places)| FrameMesh { places, ..f.mesh() }).collect();
    let grid = InMemory { label: PathBuf::from(label), fps, topology: grid.topology(), frames: positions };
    Registered { grid, meshes }
}

/// A registered run ([`is_registered_run`]: frames that share one mesh)
/// registered as one piece with one map, as a registered motion is: the
/// last piece's map where this piece goes on with its run (a run cut at
/// the longest segment; its cones carried, [`carried_cones`]), else a map
/// made on its first frame ([`new_run_map`]) with the cones the last piece
/// hands over ([`handed_over`]), or, for a capture's first piece, with
/// features carried by their vertices ([`track_capture`]). One map does
/// not jump or swim, so nothing is bridged, smoothed or turned back.
fn register_run(
    label: &Path,
    fps: f32,
    frames: &[CaptureFrame],
    grid: Grid,
    handover: Option<&Handover>,
) -> Result<(Registered, RegisterReport, Handover)> {
    let t1 = std::time::Instant::now();
    let goes_on_with_run = going_on(frames, handover).is_some();
    let (run, trace, tracked) = match going_on(frames, handover) {
        Some(run) => (run.clone(), handover.and_then(|h| h.trace.clone()), carried_cones(frames, run.cones)),
        None => {
            let mut tracked = match handover {
                Some(h) => carried_cones(frames, handed_over(&frames[0], h)),
                None => track_capture(label, frames)?,
            };
            fits(label, frames, &tracked)?;
            let (run, trace) = new_run_map(label, frames, &mut tracked, grid, handover)?;
            (run, trace, tracked)
        }
    };
    let positions: Vec<Vec<Vec3>> = frames.par_iter().map(|f| run.grid_of(grid, &f.positions)).collect();
    let places = vec![run.places.clone(); frames.len()];
    let report = RegisterReport {
        frames: frames.len(),
        registered_runs: vec![[0, frames.len()]],
        goes_on_with_run,
        seconds_maps: t1.elapsed().as_secs_f64(),
        lid_votes: lids::over_holes(grid, &vec![run.on_input.clone(); frames.len()]),
        lid_pieces: 1,
        ..RegisterReport::of_tracking(&tracked)
    };
    let mut next = Handover::of(&tracked, trace, positions.last().cloned().unwrap_or_default());
    next.run = Some(run);
    Ok((registered(label, fps, grid, frames, positions, places), report, next))
}

/// The last piece's run map ([`Handover::run`]) where every frame of
/// `frames` has the run's mesh: this piece goes on with the run.
fn going_on<'h>(frames: &[CaptureFrame], handover: Option<&'h Handover>) -> Option<&'h RunMap> {
    handover.and_then(|h| h.run.as_ref()).filter(|r| !frames.is_empty() && frames.iter().all(|f| r.goes_on_in(f)))
}

/// A run's map made on its first frame ([`map_run`]) with its cones
/// chosen or going on from the last piece's `handover`
/// ([`chosen_cones`], which sets `tracked`'s), turned as any piece's grid
/// is ([`turned_to`]); and its cut's trace.
fn new_run_map(
    label: &Path,
    frames: &[CaptureFrame],
    tracked: &mut Tracked,
    grid: Grid,
    handover: Option<&Handover>,
) -> Result<(RunMap, Option<CutTrace>)> {
    let first_trace;
    (tracked.cones, first_trace) = chosen_cones(label, frames, tracked, (grid, diagonal_of(frames)), handover)?;
    let (map, places, trace) = map_run(label, &frames[0], &cone_places(tracked)(0), first_trace, grid)?;
    let mut positions: Vec<Vec<Vec3>> = frames.par_iter().map(|f| map.apply(&f.positions)).collect();
    let mut places = [places];
    let turn = turned_to(grid, frames, handover, &mut positions, &mut places)?;
    let [places] = places;
    let vertex = |k: usize| tracked.tracks[k].seen[0].map_or(0, |i| tracked.features[0][i as usize].vertex);
    let run = RunMap {
        faces: frames[0].faces.clone(),
        vertex_count: frames[0].positions.len(),
        on_input: apply_symmetry(grid, &map.on_input, turn),
        map: std::sync::Arc::new(map),
        turn,
        places,
        cones: tracked.cones.map(vertex),
    };
    Ok((run, Some(trace)))
}

/// The vertices of `first` nearest where the last piece's cones would be
/// in it ([`Handover::cones`], less the frame's center): a run that starts
/// after another piece is the same body a frame later, so it takes those
/// cones rather than features of its own, and its map starts where the
/// last one left off.
fn handed_over(first: &CaptureFrame, h: &Handover) -> [u32; 4] {
    let center = first.center();
    h.cones.map(|p| nearest(&first.positions, p + center).unwrap_or(0))
}

/// A registered run's cones at vertices `cones` carried through `frames`
/// (which share the run's mesh) as its only features: a piece that goes on
/// with the last piece's map, or starts a run from the cones the last
/// piece hands over, needs no features of its own, only its cones for its
/// map, the report and the next piece to go on from.
fn carried_cones(frames: &[CaptureFrame], cones: [u32; 4]) -> Tracked {
    let at = |f: &CaptureFrame, v: u32| super::detect::Feature {
        vertex: v,
        position: f.positions.get(v as usize).copied().unwrap_or_default(),
        descriptor: Default::default(),
        weak: false,
    };
    Tracked {
        features: frames.iter().map(|f| cones.iter().map(|&v| at(f, v)).collect()).collect(),
        centers: frames.iter().map(CaptureFrame::center).collect(),
        tracks: (0..4).map(|k| Track { seen: vec![Some(k); frames.len()] }).collect(),
        cones: [0, 1, 2, 3],
        seconds: 0.0,
    }
}

/// Each frame's cones: the chosen tracks' places, and whether each track
/// saw its feature there.
fn cone_places(tracked: &Tracked) -> impl Fn(usize) -> [(Vec3, bool); 4] + Sync + '_ {
    |t: usize| {
        tracked.cones.map(|k| {
            let track = &tracked.tracks[k];
            (place(track, &tracked.features, t).unwrap_or(Vec3::ZERO), track.seen[t].is_some())
        })
    }
}

/// An error unless `tracked` holds the features of every one of
/// `frames`, and there are some.
fn fits(label: &Path, frames: &[CaptureFrame], tracked: &Tracked) -> Result<()> {
    if frames.is_empty() {
        return Err(no_frames(label));
    }
    if tracked.features.len() != frames.len() {
        return Err(Error::Argument(format!(
            "{}: features of {} frames for a capture of {}",
            label.display(),
            tracked.features.len(),
            frames.len()
        )));
    }
    Ok(())
}

/// The error of a piece without frames.
fn no_frames(label: &Path) -> Error {
    Error::Argument(format!("{}: a piece of a capture without frames", label.display()))
}

/// Every frame of `frames` mapped with its cones `cones_at` (each place,
/// and whether its track saw the cone there), its cut following the
/// previous frame's (the first's following `first_trace`, if given): its
/// corner nearest that corner, its paths pulled towards those paths, so
/// that the paths keep going the same way round the body. Shortest paths
/// alone can take another way from one frame to the next, and the map
/// (the grid on the body) changes with them.
fn mapped_in_turn(
    label: &Path,
    frames: &[CaptureFrame],
    cones_at: &(dyn Fn(usize) -> [(Vec3, bool); 4] + Sync),
    first_trace: Option<&CutTrace>,
    grid: Grid,
) -> Result<Vec<Mapped>> {
    // One frame as the rule has it: a cut that cannot follow the last
    // frame's (pcow's frames 30-60: "no path ... avoids the other cuts")
    // is made afresh; a frame whose map then goes another way round is
    // found later.
    let one = |t: usize, trace: Option<&CutTrace>| match map_frame(label, &frames[t], &cones_at(t), trace, grid) {
        Err(_) if trace.is_some() => map_frame(label, &frames[t], &cones_at(t), None, grid),
        done => done,
    };
    // Only the cuts must go in turn (each follows the last), so a run of
    // frames is cut one after another and its area passes, most of a
    // map's time, run side by side, beside the next run's cuts. Where a
    // cut or its passes fail, that frame is mapped by the rule above and
    // the frames after it are cut again from there: the maps are those of
    // frame after frame.
    // Each cut holds its carrier and factored system until its passes
    // end: at most two runs of them at once.
    let run = (2 * rayon::current_num_threads()).clamp(2, RUN_MOST);
    // Frames from `t` on cut in turn after `trace`, up to a run of them
    // (fewer where a cut fails).
    let cut_run = |t: usize, trace: Option<&CutTrace>| {
        let mut cuts: Vec<FrameCut> = Vec::new();
        for u in t..frames.len().min(t + run) {
            let last = cuts.last().map(|c| &c.trace).or(trace);
            let Ok(cut) = cut_frame(label, &frames[u], &cones_at(u), last) else { break };
            cuts.push(cut);
        }
        cuts
    };
    let mut mapped: Vec<Mapped> = Vec::with_capacity(frames.len());
    let mut cuts = cut_run(0, first_trace);
    while mapped.len() < frames.len() {
        let t = mapped.len();
        let whole = cuts.len() == run;
        let next_trace = cuts.last().map(|c| c.trace.clone());
        let (done, next) = rayon::join(
            || cuts.into_par_iter().enumerate().map(|(i, c)| finish_cut(c, &frames[t + i], grid)).collect::<Vec<_>>(),
            || if whole { cut_run(t + run, next_trace.as_ref()) } else { Vec::new() },
        );
        mapped.extend(done.into_iter().map_while(Result::ok));
        cuts = next;
        if mapped.len() < frames.len() && mapped.len() < t + run {
            let m = one(mapped.len(), mapped.last().map(|m: &Mapped| &m.trace).or(first_trace))?;
            mapped.push(m);
            cuts = cut_run(mapped.len(), mapped.last().map(|m| &m.trace));
        }
    }
    Ok(mapped)
}

/// Every frame's grid and places of a piece turned so that the grid's
/// diagonals lie the better way ([`diagonals::better_turns`]), by the one
/// of those two turns that puts its first grid nearest the last piece's
/// last ([`handover::nearest_turn`]). Returns the turn.
fn turned_to(
    grid: Grid,
    frames: &[CaptureFrame],
    handover: Option<&Handover>,
    positions: &mut [Vec<Vec3>],
    places: &mut [Vec<[u32; 2]>],
) -> Result<Symmetry> {
    let turns = diagonals::better_turns(grid, frames, positions)?;
    let m = match (handover, positions.first()) {
        (Some(h), Some(first)) => handover::nearest_turn(grid, &h.grid, first, &turns),
        _ => turns[0],
    };
    if m == IDENTITY {
        return Ok(m);
    }
    for (g, p) in positions.iter_mut().zip(places.iter_mut()) {
        *g = apply_symmetry(grid, g, m);
        p.iter_mut().for_each(|q| *q = turn_place(*q, m));
    }
    Ok(m)
}

/// Frame `t` of a capture mapped again with its cut traced from a trace.
type Remap<'a> = dyn Fn(usize, &CutTrace) -> Result<Mapped> + Sync + 'a;

/// Each frame whose cones' order round the corner differs from
/// `reference`'s mapped again with its cut traced from the nearest
/// agreeing frame's before and after, each trace first as it is, then
/// pulled [`RETRY_PULL`] times as hard, until one agrees.
fn remapped_to_agree(remap: &Remap, mapped: &mut [Mapped], reference: &[usize; 4]) -> Result<()> {
    let matches = |m: &Mapped| symmetry_between(&m.sides, reference).is_some();
    let good: Vec<usize> = (0..mapped.len()).filter(|&t| matches(&mapped[t])).collect();
    let others: Vec<usize> = (0..mapped.len()).filter(|t| good.binary_search(t).is_err()).collect();
    // Each frame tries the agreeing frames' traces only, which no try
    // changes: the frames are mapped again side by side.
    let again: Vec<Option<Mapped>> = others
        .par_iter()
        .map(|&t| {
            let before = good.iter().rev().find(|&&g| g < t);
            let after = good.iter().find(|&&g| g > t);
            let tries = [1.0, RETRY_PULL].into_iter().flat_map(|pull| [before, after].map(|g| g.map(|&g| (g, pull))));
            // A trace this frame's cut cannot follow is a try that failed.
            tries.flatten().filter_map(|(g, pull)| remap(t, &mapped[g].trace.pulled(pull)).ok()).find(matches)
        })
        .collect();
    for (t, m) in others.into_iter().zip(again) {
        if let Some(m) = m {
            mapped[t] = m;
        }
    }
    Ok(())
}

/// The frames of `jumping` bridged from the steady frames around them
/// ([`jumps::bridged`]), then every grid smoothed in time
/// ([`smooth::smooth`]); returns how many frames took the smoothed grid.
fn bridged_and_smoothed(
    grid: Grid,
    frames: &[CaptureFrame],
    jumping: &[usize],
    positions: &mut [Vec<Vec3>],
    places: &mut [Vec<[u32; 2]>],
) -> Result<usize> {
    for &t in jumping {
        let steady = |k: &usize| !jumping.contains(k);
        let before = (0..t).rev().find(steady).map(|k| (k, positions[k].as_slice()));
        let after = (t + 1..frames.len()).find(steady).map(|k| (k, positions[k].as_slice()));
        let (g, p) = jumps::bridged(grid, t, before, after, &frames[t].positions, &frames[t].faces)?;
        if !g.is_empty() {
            (positions[t], places[t]) = (g, p);
        }
    }
    let surfaces: Vec<smooth::Surface> = frames.iter().map(|f| (f.positions.as_slice(), f.faces.as_slice())).collect();
    let diagonal = Bounds::of(&frames[0].positions).diagonal();
    smooth::smooth(positions, &surfaces, &grid.topology().faces, diagonal)
}

/// Frames whose grid jumps ([`jumps::found`]: its cut went another way
/// round the body with its cones on the same sides) mapped again with the
/// cut traced from the last steady frame's, then from the next frame's,
/// each as it is and pulled [`RETRY_PULL`] times as hard; the first try
/// that no longer jumps is kept. Returns the frames that still jump
/// (`diagonal`: the capture's).
fn steady_jumps(
    remap: &Remap,
    mapped: &mut [Mapped],
    reference: &[usize; 4],
    grid: Grid,
    diagonal: f32,
) -> Result<Vec<usize>> {
    // Grids are compared as turned_back will store them.
    let turned = |m: &Mapped| match symmetry_between(&m.sides, reference) {
        Some(s) if s != IDENTITY => apply_symmetry(grid, &m.grid, s),
        _ => m.grid.clone(),
    };
    let mut grids: Vec<Vec<Vec3>> = mapped.iter().map(turned).collect();
    jumps::found(&mut grids, diagonal, &mut |t, from, passes| {
        let tries = from.into_iter().flatten().flat_map(|n| [(n, 1.0), (n, RETRY_PULL)]);
        for (from, pull) in tries {
            let Ok(again) = remap(t, &mapped[from].trace.pulled(pull)) else { continue };
            if symmetry_between(&again.sides, reference).is_none() {
                continue;
            }
            let a = turned(&again);
            if passes(&a) {
                mapped[t] = again;
                return Ok(Some(a));
            }
        }
        Ok(None)
    })
}

/// Each frame's grid and its vertices' places turned so that its cones
/// sit on `reference`'s sides, and how many frames were turned and how
/// many no turn matches (left as they are).
fn turned_back(grid: Grid, mapped: Vec<Mapped>, reference: &[usize; 4]) -> Turned {
    let (mut turned, mut unmatched) = (0, 0);
    let (mut positions, mut places) = (Vec::with_capacity(mapped.len()), Vec::with_capacity(mapped.len()));
    for m in mapped {
        match symmetry_between(&m.sides, reference) {
            Some(s) if s == IDENTITY => {
                positions.push(m.grid);
                places.push(m.places);
            }
            Some(s) => {
                turned += 1;
                positions.push(apply_symmetry(grid, &m.grid, s));
                places.push(m.places.iter().map(|&q| turn_place(q, s)).collect());
            }
            None => {
                unmatched += 1;
                positions.push(m.grid);
                places.push(m.places);
            }
        }
    }
    (positions, places, turned, unmatched)
}

/// [`turned_back`]'s grids, places, turned and unmatched frames.
type Turned = (Vec<Vec<Vec3>>, Vec<Vec<[u32; 2]>>, usize, usize);

/// Most frames [`mapped_in_turn`] cuts ahead of their area passes.
const RUN_MOST: usize = 8;

/// How much harder a frame mapped again pulls its cut to the trace.
const RETRY_PULL: f64 = 3.0;

#[cfg(test)]
mod tests {
    use super::*;

    /// The worst frame of a segment's pieces is measured on the frames each
    /// piece covers: halves with one frame off their mesh are worse than a
    /// whole with every frame on it, and a piece past the end is an error.
    #[test]
    fn pieces_are_judged_by_their_worst_frame() {
        let grid = Grid::new(4).unwrap();
        let faces = grid.topology().faces;
        let p: Vec<Vec3> = (0..16).map(|i| Vec3::new((i % 4) as f32, (i / 4) as f32, ((i * 7) % 5) as f32)).collect();
        let part = vec![CaptureFrame { positions: p.clone(), faces: faces.clone() }; 6];
        let piece = |start: usize, frames: Vec<Vec<Vec3>>| {
            let grid = InMemory { label: PathBuf::new(), fps: 30.0, topology: grid.topology(), frames };
            (start, Registered { grid, meshes: Vec::new() }, RegisterReport::default(), None)
        };
        let mut whole = [piece(0, vec![p.clone(); 6])];
        let off: Vec<Vec3> = p.iter().map(|&x| x * 1.1).collect();
        let mut halves = [piece(0, vec![p.clone(); 3]), piece(3, vec![p.clone(), off, p.clone()])];
        let w = worst_resampling(&part, &mut whole, grid).unwrap();
        let h = worst_resampling(&part, &mut halves, grid).unwrap();
        assert!(w < 1e-6 && h > 0.1, "{w} {h}");
        // Measured once, kept with the pieces.
        assert!(halves.iter().all(|p| p.3.as_ref().is_some_and(|e| e.len() == 3)));
        assert!(worst_resampling(&part, &mut [piece(4, vec![p.clone(); 3])], grid).is_err());
        // Errors a piece's checks measured already are taken as they are.
        let (start, src, report, _) = piece(0, vec![p.clone(); 6]);
        let mut known = [(start, src, report, Some(vec![0.5; 6]))];
        assert_eq!(worst_resampling(&part, &mut known, grid).unwrap(), 0.5);
    }

    /// Maps made a run at a time (the cuts in turn, their area passes side
    /// by side) are those made frame after frame; a frame that cannot be
    /// mapped at all is the error it was.
    #[test]
    fn maps_made_in_runs_are_those_of_frame_after_frame() {
        let src = crate::mesh::builtin::motion(7);
        let mut frames: Vec<CaptureFrame> = src
            .frames
            .iter()
            .enumerate()
            .map(|(t, p)| {
                let (positions, faces) =
                    crate::mesh::unregister::remesh_frame(p, &src.topology.faces, 0.6 + 0.04 * t as f32, t as u64);
                CaptureFrame { positions, faces }
            })
            .collect();
        let label = Path::new("walk");
        let tracked = super::super::tracking::track_capture(label, &frames).unwrap();
        let at = cone_places(&tracked);
        let grid = Grid::new(32).unwrap();
        let in_runs = mapped_in_turn(label, &frames, &at, None, grid).unwrap();
        let mut in_turn: Vec<Mapped> = Vec::new();
        for (t, frame) in frames.iter().enumerate() {
            let trace = in_turn.last().map(|m| &m.trace);
            in_turn.push(map_frame(label, frame, &at(t), trace, grid).unwrap());
        }
        assert_eq!(in_runs.len(), frames.len());
        for (a, b) in in_runs.iter().zip(&in_turn) {
            assert_eq!((&a.grid, &a.places, a.sides), (&b.grid, &b.places, b.sides));
        }
        // A frame without faces: no cut, no map afresh either.
        frames[5].faces.clear();
        assert!(mapped_in_turn(label, &frames, &at, None, grid).is_err());
    }
}

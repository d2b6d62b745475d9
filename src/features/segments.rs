//! A capture's segments: stretches of frames that are each tracked and
//! mapped with their own tracks, since no map carries over a change of
//! topology, and a long capture's features come and go; each goes on
//! from the last one's cones, cut and turn where it can
//! ([`super::handover`]). Each segment starts at a random-access point of
//! the file (format version 15).

use super::capture::{Capture, CaptureFrame};
use super::outliers::resampling_errors;
use crate::error::Result;
use crate::grid::Grid;
use crate::mesh::{analyze, Topology};
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

/// Where a capture's segments start: frame 0, and each frame whose
/// topology (Euler characteristic, parts, holes) differs from the
/// segment's and stays so for [`SEGMENT_FRAMES`] frames (an arm that
/// touches the body, a part that appears). No map carries over such a
/// change, so each segment is registered on its own.
pub fn segment_starts(frames: &[CaptureFrame]) -> Vec<usize> {
    starts_of(&frames.par_iter().map(class).collect::<Vec<_>>())
}

/// A frame's topology: its Euler characteristic, parts and holes, or
/// `None` for a frame that is not a manifold (a simplifier's pinched
/// edge), whose counts mean nothing.
type Class = Option<(i64, usize, usize)>;

fn class(f: &CaptureFrame) -> Class {
    let r = analyze(&Topology { vertex_count: f.positions.len(), faces: f.faces.clone() }, &f.positions);
    let manifold = r.non_manifold_edges == 0 && r.non_manifold_vertices == 0;
    manifold.then_some((r.euler_characteristic, r.components, r.boundary_loops))
}

/// [`segment_starts`] of frames of topology `classes`; a frame that is
/// not a manifold has no say.
fn starts_of(classes: &[Class]) -> Vec<usize> {
    let mut starts = vec![0];
    let mut current = classes.iter().flatten().next().copied();
    for t in 1..classes.len() {
        let Some(c) = classes[t] else { continue };
        let lasting = classes[t..classes.len().min(t + SEGMENT_FRAMES)].iter().all(|k| k.is_none_or(|k| k == c));
        if current.is_some_and(|cur| cur != c) && lasting {
            starts.push(t);
            current = Some(c);
        }
    }
    starts
}

/// The frames of each segment of `capture`, in order: one starts where
/// the topology changes ([`segment_starts`]), where a registered run
/// starts or ends ([`run_starts`]) and at every multiple of `longest`
/// frames (0: no limit) that is not within [`SEGMENT_FRAMES`] of such a
/// change (a run cut there goes on with one map,
/// `super::handover::RunMap`). A long capture's features come and go (pcow's 204
/// frames as one segment: its cones' tracks seen in 100 / 73 / 40 / 33 %
/// of them, 29 frames that no turn of the grid matches), so a capture is
/// tracked and mapped a stretch at a time; at multiples of the encoder's
/// random-access interval a new map costs no extra point. The frames are
/// read a few at a time (`progress` hears how many so far), never all at
/// once.
pub fn segment_ranges(
    capture: &dyn Capture,
    longest: usize,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<Vec<Range<usize>>> {
    let (n, batch) = (capture.len(), 4 * rayon::current_num_threads());
    let mut classes = Vec::with_capacity(n);
    for a in (0..n).step_by(batch.max(1)) {
        let frames = capture.frames(a..n.min(a + batch))?;
        classes.extend(frames.par_iter().map(|f| (class(f), mesh_key(f))).collect::<Vec<_>>());
        progress("reading", classes.len(), n);
    }
    let (classes, keys): (Vec<Class>, Vec<MeshKey>) = classes.into_iter().unzip();
    let mut changes = starts_of(&classes);
    changes.extend(run_starts(&keys));
    changes.sort_unstable();
    changes.dedup();
    let near_change = |t: usize| changes.iter().any(|&c| c.abs_diff(t) < SEGMENT_FRAMES);
    let mut starts = changes.clone();
    if longest > 0 {
        starts.extend((longest..n).step_by(longest).filter(|&t| !near_change(t)));
        starts.sort_unstable();
    }
    let ends = starts.iter().skip(1).copied().chain([n]);
    Ok(starts.iter().zip(ends).map(|(&a, b)| a..b).collect())
}

/// A frame's mesh, as far as telling whether the next frame shares it
/// goes: its vertex count and a hash of its faces (a collision costs
/// nothing but a segment start: [`super::capture::is_registered_run`]
/// decides).
type MeshKey = (usize, u64);

fn mesh_key(f: &CaptureFrame) -> MeshKey {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    f.faces.hash(&mut h);
    (f.positions.len(), h.finish())
}

/// The registered runs among frames of meshes `keys` ([`mesh_key`]): each
/// stretch `[a, b)` of at least [`SEGMENT_FRAMES`] frames that share one
/// mesh.
fn registered_runs(keys: &[MeshKey]) -> Vec<(usize, usize)> {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (t, k) in keys.iter().enumerate() {
        match runs.last_mut() {
            Some((a, end)) if keys[*a] == *k => *end = t + 1,
            _ => runs.push((t, t + 1)),
        }
    }
    runs.retain(|(a, b)| b - a >= SEGMENT_FRAMES);
    runs
}

/// Where registered runs ([`registered_runs`]) start and end: each is a
/// segment of its own, which one map serves, and the frame after one
/// starts the next.
fn run_starts(keys: &[MeshKey]) -> Vec<usize> {
    let mut starts: Vec<usize> = registered_runs(keys).into_iter().flat_map(|(a, b)| [a, b]).collect();
    starts.retain(|&t| t > 0 && t < keys.len());
    starts.dedup();
    starts
}

/// Frames a new topology must last to start a segment.
pub const SEGMENT_FRAMES: usize = 3;

/// The longest segment, in seconds of the capture, where the encoder's
/// random-access interval does not give one: the encoder's default
/// interval (`crate::codec::DEFAULT_RANDOM_ACCESS`, which this module
/// cannot import: the codec sits above it).
pub const SEGMENT_SECONDS: f32 = 2.0;

/// [`SEGMENT_SECONDS`]' (or `seconds`', if positive) frames at `fps`.
pub fn longest_segment(seconds: f32, fps: f32) -> usize {
    let s = if seconds > 0.0 { seconds } else { SEGMENT_SECONDS };
    (s * fps).round().max(1.0) as usize
}

/// The shortest segment a failing one is split into.
pub const SHORTEST: usize = 12;
/// The shortest segment whose tracks' failure splits it before it is
/// mapped ([`untracked_split`]): every 60-frame segment of two pcow
/// captures (204 frames each) whose tracks failed lost to its halves,
/// while 30-frame ones kept their whole about as often (one capture's
/// frames 0-30 as halves: frames 13-22 0.13-0.19 % off the truth, whole
/// 0.05-0.08 %).
pub const EARLY_SPLIT: usize = 4 * SHORTEST;
/// A segment holds while each cone's track is seen in at least this share
/// of its frames (the tracking target)...
pub const SEEN: f64 = 0.95;
/// ... and no frame's grid resamples the frame's own mesh more than this
/// many times as far off as the segment's mean (its swim target).
pub const WORST: f64 = 3.0;

/// Where to split a segment of `frames` frames before it is mapped, given
/// the share of its frames each of its tracks (or its four cones' tracks)
/// is seen in: at its middle where fewer than four are seen in [`SEEN`]
/// of them, so that no four cones meet the tracking target; nowhere if it
/// has fewer than twice [`SHORTEST`] frames. Measured on pcow's 204
/// frames: tracked in stretches of 60 frames, one stretch's cones' tracks
/// were seen in 60 % of its frames.
pub fn untracked_split(frames: usize, seen: impl Iterator<Item = f64>) -> Option<usize> {
    let tracked = seen.filter(|&s| s >= SEEN).count();
    (frames >= 2 * SHORTEST && tracked < 4).then_some(frames / 2)
}

/// Where to split a registered segment (`part`, registered as `grids`)
/// whose frames swim ([`WORST`]): at its middle, or nowhere if it holds or
/// has fewer than twice [`SHORTEST`] frames; and each frame's resampling
/// error where it was measured (for the registration's later use).
/// Measured on pcow's 204 frames: tracked in stretches of 60 frames,
/// frames 3-8 of one stretch resampled 0.5-1.8 % off the truth (its
/// 24-frame clip: 0.06 % at most).
pub fn split_at(part: &[CaptureFrame], grids: &[Vec<Vec3>], grid: Grid) -> Result<(Option<usize>, Option<Vec<f64>>)> {
    if part.len() < 2 * SHORTEST {
        return Ok((None, None));
    }
    let errors = resampling_errors(part, grids, grid)?;
    Ok((swims(&errors).then_some(part.len() / 2), Some(errors)))
}

/// Whether frames whose grids lie `errors` from their own meshes swim: the
/// worst more than [`WORST`] times as far off as their mean.
pub fn swims(errors: &[f64]) -> bool {
    let mean = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
    errors.iter().any(|&e| e > WORST * mean)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `frames` copies of a grid's own mesh as a capture and its grids,
    /// with frame `off` (if any) put 10 % further out.
    fn case(frames: usize, off: Option<usize>) -> (Vec<CaptureFrame>, Vec<Vec<Vec3>>, Grid) {
        let grid = Grid::new(4).unwrap_or_else(|e| panic!("{e}"));
        let faces = grid.topology().faces;
        let p: Vec<Vec3> = (0..16).map(|i| Vec3::new((i % 4) as f32, (i / 4) as f32, ((i * 7) % 5) as f32)).collect();
        let capture = vec![CaptureFrame { positions: p.clone(), faces }; frames];
        let grids = (0..frames).map(|t| if Some(t) == off { p.iter().map(|&x| x * 1.1).collect() } else { p.clone() });
        (capture, grids.collect(), grid)
    }

    /// A segment is split at its middle where one frame's grid lies far
    /// off its mesh, and not where it holds or is too short to split.
    #[test]
    fn a_swimming_segment_is_split_at_its_middle() {
        let (part, grids, grid) = case(24, None);
        let measured = resampling_errors(&part, &grids, grid).ok();
        assert_eq!(split_at(&part, &grids, grid).ok(), Some((None, measured)));
        let (part, grids, grid) = case(25, Some(5));
        assert_eq!(split_at(&part, &grids, grid).ok().map(|s| s.0), Some(Some(12)));
        let (part, grids, grid) = case(23, Some(5));
        assert_eq!(split_at(&part, &grids, grid).ok(), Some((None, None)), "too short");
        assert!(swims(&[1.0, 1.0, 1.0, 1.0, 9.0]) && !swims(&[1.0, 1.5, 0.6]) && !swims(&[]));
    }

    /// A registered run (frames that share one mesh) is a segment of its
    /// own; frames each their own mesh, or sharing one for fewer than
    /// three frames, start none.
    #[test]
    fn a_registered_run_is_a_segment_of_its_own() {
        let k = |m: u64| (10, m);
        assert_eq!(run_starts(&[k(1), k(2), k(3), k(4)]), Vec::<usize>::new());
        assert_eq!(run_starts(&[k(1), k(2), k(2), k(3)]), Vec::<usize>::new(), "two frames are no run");
        assert_eq!(run_starts(&[k(1), k(2), k(2), k(2), k(2), k(3), k(4)]), vec![1, 5]);
        assert_eq!(run_starts(&[k(7), k(7), k(7), k(8), k(8), k(8)]), vec![3]);
        assert_eq!(run_starts(&[k(7), k(7), k(7), (11, 7)]), vec![3], "another vertex count");
        assert_eq!(registered_runs(&[k(1), k(2), k(2), k(2), k(2), k(3), k(4)]), [(1, 5)]);
    }

    /// A segment is split before it is mapped where fewer than four
    /// tracks are seen in 95 % of its frames, and not where four are or
    /// it is too short to split.
    #[test]
    fn a_segment_without_four_tracked_features_is_split_at_its_middle() {
        let (four, three) = ([1.0, 0.96, 0.95, 1.0, 0.2], [1.0, 1.0, 1.0, 0.94]);
        assert_eq!(untracked_split(24, four.into_iter()), None);
        assert_eq!(untracked_split(24, three.into_iter()), Some(12));
        assert_eq!(untracked_split(61, three.into_iter()), Some(30));
        assert_eq!(untracked_split(23, three.into_iter()), None, "too short");
    }
}

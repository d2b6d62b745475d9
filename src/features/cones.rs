//! A piece's four cones, among its tracks: the last piece's where their
//! tracks go on ([`handover`]), else the set of long tracks whose maps
//! resample the piece's frames best, as the encoder races cone placements
//! for a registered motion (`crate::geometry_image`). The seed paper pins
//! its tracked features as the parameterization's constraints (section
//! 4.2); the square orbifold map (Aigerman and Lipman 2015) takes four.

use super::capture::CaptureFrame;
use super::follow::CutTrace;
use super::frame_map::{frame_carrier, map_on};
use super::handover::{self, Handover};
use super::track::{place, Track, Tracked};
use crate::error::Result;
use crate::grid::Grid;
use crate::mesh::carrier::Carrier;
use crate::metrics::surface::{symmetric_rms_to, Target};
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

/// A piece's cones: the last piece's where their tracks go on (with its
/// last cut, to trace the first frame's from), else the best set
/// ([`best_cones`]).
pub(super) fn chosen_cones<'h>(
    label: &Path,
    frames: &[CaptureFrame],
    tracked: &Tracked,
    (grid, diagonal): (Grid, f32),
    handover: Option<&'h Handover>,
) -> Result<([usize; 4], Option<&'h CutTrace>)> {
    let long = may_be_cones(&tracked.tracks);
    let going_on = handover.and_then(|h| {
        let cones = handover::continuing_cones(tracked, &h.cones, |k| long.contains(&k), diagonal);
        cones.map(|c| (c, h.trace.as_ref()))
    });
    match going_on {
        Some(found) => Ok(found),
        None => Ok((best_cones(label, frames, tracked, grid)?, None)),
    }
}

/// Tracks seen in at least this share of the frames the longest one is
/// seen in may be cones.
const CONE_SEEN: f64 = 0.9;
/// Most sets of four tracks [`best_cones`] tries.
const CONE_SETS: usize = 15;

/// Frames of a capture [`best_cones`] maps with each set: its first, last
/// and two between.
const SCORED_FRAMES: usize = 4;

/// The tracks seen in at least [`CONE_SEEN`] of the frames the longest
/// one is seen in: those that may be cones.
fn may_be_cones(tracks: &[Track]) -> Vec<usize> {
    let longest = tracks.iter().map(Track::frames_seen).max().unwrap_or(0) as f64;
    (0..tracks.len()).filter(|&k| tracks[k].frames_seen() as f64 >= CONE_SEEN * longest).collect()
}

/// Of the sets of four long tracks, the one whose maps resample
/// [`SCORED_FRAMES`] frames best (their grids' mean surface RMS against
/// the frames), as the encoder races cone placements
/// (`crate::geometry_image`): where they sit decides how much of the grid
/// each limb gets. The first frame alone chose sets that resampled the
/// rest 1.5-2x worse (horse-gallop 0.156 % against 0.102 for another set).
/// Scored the better way round ([`diagonals`]), whole pcow's frames
/// 118-119 took cones 0.5-0.7 % off (0.07-0.09 % as it is): not done.
fn best_cones(label: &Path, frames: &[CaptureFrame], tracked: &Tracked, grid: Grid) -> Result<[usize; 4]> {
    let long = may_be_cones(&tracked.tracks);
    let mut sets: Vec<[usize; 4]> = Vec::new();
    for a in 0..long.len() {
        for b in a + 1..long.len() {
            for c in b + 1..long.len() {
                for d in c + 1..long.len() {
                    sets.push([long[a], long[b], long[c], long[d]]);
                }
            }
        }
    }
    if sets.len() <= 1 {
        return Ok(tracked.cones);
    }
    sets.truncate(CONE_SETS);
    let last = frames.len() - 1;
    let mut scored_frames: Vec<usize> = (0..SCORED_FRAMES).map(|i| i * last / (SCORED_FRAMES - 1)).collect();
    scored_frames.dedup();
    // Each scored frame's carrier and query tree, built once for every
    // set's map of it.
    let built: Vec<Option<(Carrier, Target)>> = scored_frames
        .par_iter()
        .map(|&t| {
            Some((frame_carrier(label, &frames[t]).ok()?, Target::new(&frames[t].positions, &frames[t].faces).ok()?))
        })
        .collect();
    let faces = grid.topology().faces;
    let score = |set: &[usize; 4], t: usize, built: &Option<(Carrier, Target)>| -> Option<f64> {
        let (carrier, target) = built.as_ref()?;
        let at = set.map(|k| (place(&tracked.tracks[k], &tracked.features, t).unwrap_or(Vec3::ZERO), true));
        let g = map_on(carrier.clone(), &frames[t], &at, None, grid).ok()?.grid;
        let f = (&frames[t].positions[..], &frames[t].faces[..]);
        symmetric_rms_to((&g, &faces), &|_| None, f, target, (f64::INFINITY, 1)).ok()
    };
    let runs: Vec<(usize, usize)> =
        (0..sets.len()).flat_map(|s| (0..scored_frames.len()).map(move |i| (s, i))).collect();
    let errors: Vec<Option<f64>> =
        runs.par_iter().map(|&(s, i)| score(&sets[s], scored_frames[i], &built[i])).collect();
    // `runs` holds each set's frames together: a set whose map failed on
    // any of them is out.
    let scored: Vec<(f64, [usize; 4])> = errors
        .chunks(scored_frames.len())
        .zip(&sets)
        .filter_map(|(e, set)| e.iter().copied().sum::<Option<f64>>().map(|e| (e, *set)))
        .collect();
    Ok(scored.into_iter().min_by(|a, b| a.0.total_cmp(&b.0)).map_or(tracked.cones, |x| x.1))
}

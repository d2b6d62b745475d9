//! The features of a capture without correspondence, detected on every
//! frame and tracked through the frames: the first half of its
//! registration ([`super::register`]), as the seed paper's section 4
//! builds its CGVs (heat kernel signature maxima, [`super::detect`];
//! matched between adjacent frames, [`super::track`]), and the four tracks
//! the maps take as their cones at first.

use super::capture::{is_registered_run, CaptureFrame};
use super::detect::{features_near, surface_area, Feature, SEPARATION};
use super::track::{track, Track, Tracked};
use crate::error::{Error, Result};
use crate::mesh::Bounds;
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

/// The features of every frame of `frames` (named `label`), tracked.
pub fn track_capture(label: &Path, frames: &[CaptureFrame]) -> Result<Tracked> {
    if frames.is_empty() {
        return Err(Error::Argument(format!("{}: a capture without frames", label.display())));
    }
    if is_registered_run(frames) {
        return carried_features(label, frames);
    }
    let t0 = std::time::Instant::now();
    let features = features_in_runs(frames)?;
    let centers: Vec<Vec3> = frames.par_iter().map(CaptureFrame::center).collect();
    let mut tracked = track_features(label, features, &centers, Bounds::of(&frames[0].positions).diagonal())?;
    tracked.seconds = t0.elapsed().as_secs_f64();
    Ok(tracked)
}

/// The features of a registered run ([`is_registered_run`]), found on its
/// first, middle and last frames and carried to every frame by the vertex
/// each lies on, which is one point of the body in all of them: each a
/// track seen in every frame, with nothing to match (the paper tracks
/// features because a capture's frames share no vertices; these do). A
/// feature of a later frame counts where no earlier one lies within
/// [`SEPARATION`]: the first frame's alone left samba's 24-frame clip, in
/// runs of 12 frames, one set of cones to map with, which resampled the
/// truth at 0.055 % where the maps made frame by frame, choosing among
/// five tracks, reached 0.034 %.
fn carried_features(label: &Path, frames: &[CaptureFrame]) -> Result<Tracked> {
    let t0 = std::time::Instant::now();
    let last = frames.len() - 1;
    let mut found: Vec<Feature> = Vec::new();
    for t in [0, last / 2, last] {
        let f = &frames[t];
        let radius = SEPARATION * surface_area(&f.faces, &f.positions).sqrt();
        let at = |x: &Feature| f.positions.get(x.vertex as usize).copied().unwrap_or(x.position);
        // A weak maximum stands in for a track's lost feature; none is lost here.
        for x in features_near(&f.faces, &f.positions, None)?.0.into_iter().filter(|x| !x.weak) {
            if found.iter().all(|y| at(y).distance(at(&x)) > radius) {
                found.push(x);
            }
        }
    }
    // (Every frame has the first's vertices: `is_registered_run`.)
    let at = |f: &CaptureFrame, x: &Feature| Feature {
        position: f.positions.get(x.vertex as usize).copied().unwrap_or(x.position),
        ..x.clone()
    };
    let features: Vec<Vec<Feature>> = frames.iter().map(|f| found.iter().map(|x| at(f, x)).collect()).collect();
    let tracks: Vec<Track> = (0..found.len() as u32).map(|i| Track { seen: vec![Some(i); frames.len()] }).collect();
    let cones = cone_tracks(&tracks)
        .ok_or_else(|| Error::Argument(format!("{}: fewer than four features in a registered run", label.display())))?;
    let centers = frames.par_iter().map(CaptureFrame::center).collect();
    Ok(Tracked { features, centers, tracks, cones, seconds: t0.elapsed().as_secs_f64() })
}

/// Frames in a run of [`features_in_runs`]: a fixed length, so that the
/// features do not depend on the machine's thread count.
const FEATURE_RUN: usize = 12;

/// Every frame's features, in runs of [`FEATURE_RUN`] consecutive frames
/// (in parallel), each frame's eigenpairs started from the frame before's
/// (`features_near`): LOBPCG then takes a few iterations, not tens.
fn features_in_runs(frames: &[CaptureFrame]) -> Result<Vec<Vec<Feature>>> {
    let run = |frames: &[CaptureFrame]| -> Result<Vec<Vec<Feature>>> {
        let (mut out, mut last) = (Vec::with_capacity(frames.len()), None);
        for f in frames {
            let (found, spectrum) = features_near(&f.faces, &f.positions, last.as_ref().map(|(p, s)| (*p, s)))?;
            out.push(found);
            last = Some((f.positions.as_slice(), spectrum));
        }
        Ok(out)
    };
    let parts: Vec<Vec<Vec<Feature>>> = frames.par_chunks(FEATURE_RUN).map(run).collect::<Result<_>>()?;
    Ok(parts.into_iter().flatten().collect())
}

/// Features found on every frame (`features`, of a capture named `label`
/// whose frames' centers are `centers`, [`CaptureFrame::center`], and
/// first frame's diagonal is `diagonal`), tracked.
pub fn track_features(label: &Path, features: Vec<Vec<Feature>>, centers: &[Vec3], diagonal: f32) -> Result<Tracked> {
    if centers.len() != features.len() {
        return Err(Error::Argument(format!(
            "{}: the centers of {} frames for features of {}",
            label.display(),
            centers.len(),
            features.len()
        )));
    }
    let t0 = std::time::Instant::now();
    let tracks = track(&features, centers, diagonal);
    let cones = cone_tracks(&tracks).ok_or_else(|| {
        Error::Argument(format!("{}: fewer than four features could be tracked through the frames", label.display()))
    })?;
    let centers = centers.to_vec();
    Ok(Tracked { features, centers, tracks, cones, seconds: t0.elapsed().as_secs_f64() })
}

/// The four tracks seen in the most frames (among equals, the earliest,
/// then the strongest feature there).
fn cone_tracks(tracks: &[Track]) -> Option<[usize; 4]> {
    let mut order: Vec<usize> = (0..tracks.len()).collect();
    let first_index = |k: usize| tracks[k].seen.iter().position(Option::is_some).unwrap_or(usize::MAX);
    let strength = |k: usize| {
        let s = first_index(k);
        tracks[k].seen.get(s).copied().flatten().unwrap_or(u32::MAX)
    };
    order.sort_by_key(|&k| (std::cmp::Reverse(tracks[k].frames_seen()), first_index(k), strength(k)));
    let picked: Vec<usize> = order.into_iter().take(4).collect();
    picked.try_into().ok()
}

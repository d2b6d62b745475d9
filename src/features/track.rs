//! Features followed through a capture (the seed paper, section 4.1): each
//! frame's features matched to the tracks alive in the frames before it by
//! the distance of their signatures and places, the closest pairs first; a
//! pair more than [`RATIO`] times the best pair's distance is dropped, as
//! the paper drops them. A track unseen for more than [`GAP`] frames ends,
//! so a feature that vanishes for a few frames (a hand against the body)
//! keeps its track when it comes back.

use super::detect::Feature;
use glam::Vec3;

/// A pair further apart than this many times the frame's best pair is no
/// match (the paper's rule).
pub const RATIO: f32 = 4.0;
/// The best pair's distance is taken as at least this: the signature of
/// one place differs by up to a few tenths between two triangulations, and
/// 4x a near-exact pair would drop the true pairs of the other features.
/// Measured on 24 frames remeshed (`cgv info --unregistered`): 0.1 split
/// horse-gallop's features into 17 tracks and pcow's into 26, 0.2 into 10
/// and 15 (the cones' tracks seen in 100/100/100/83 % and 100/92/88/75 %
/// of the frames); samba's 5 either way.
pub const NOISE: f32 = 0.2;
/// Frames a track may go unseen and still be matched.
pub const GAP: usize = 4;
/// A pair's places may differ by at most this fraction of the diagonal.
pub const MAX_STEP: f32 = 0.15;
/// The place's part in a pair's distance: a diagonal's move away from
/// where the track's velocity puts it counts as this many units of
/// signature (log-ratio) difference.
pub const PLACE_WEIGHT: f32 = 3.0;

/// One feature through the frames.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// Per frame, the feature's index among that frame's, if seen.
    pub seen: Vec<Option<u32>>,
}

impl Track {
    /// Frames the track was seen in.
    pub fn frames_seen(&self) -> usize {
        self.seen.iter().filter(|s| s.is_some()).count()
    }
}

/// Tracks through `frames` (each frame's features), `diagonal` the
/// motion's bounding-box diagonal.
pub fn track(frames: &[Vec<Feature>], diagonal: f32) -> Vec<Track> {
    let n = frames.len();
    let mut tracks: Vec<Track> = Vec::new();
    // Per track: its last sighting (frame, feature) and its velocity there
    // (a hand moves several times its size in a few frames).
    let mut last: Vec<(usize, Feature, Vec3)> = Vec::new();
    for (t, features) in frames.iter().enumerate() {
        let alive: Vec<usize> = (0..tracks.len()).filter(|&k| t - last[k].0 <= GAP + 1).collect();
        let mut pairs: Vec<(f32, usize, usize)> = Vec::new();
        for &k in &alive {
            let (s, seen, v) = &last[k];
            let predicted = seen.position + *v * (t - s) as f32;
            for (i, f) in features.iter().enumerate() {
                let step = predicted.distance(f.position) / diagonal.max(f32::MIN_POSITIVE);
                if step <= MAX_STEP {
                    pairs.push((signature_distance(seen, f) + PLACE_WEIGHT * step, k, i));
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let best = pairs.first().map_or(0.0, |p| p.0);
        let (mut track_taken, mut feature_taken) = (vec![false; tracks.len()], vec![false; features.len()]);
        for &(d, k, i) in &pairs {
            if d > RATIO * best.max(NOISE) || track_taken[k] || feature_taken[i] {
                continue;
            }
            (track_taken[k], feature_taken[i]) = (true, true);
            tracks[k].seen[t] = Some(i as u32);
            let v = (features[i].position - last[k].1.position) / (t - last[k].0) as f32;
            last[k] = (t, features[i].clone(), v);
        }
        for (i, f) in features.iter().enumerate().filter(|(i, _)| !feature_taken[*i]) {
            let mut seen = vec![None; n];
            seen[t] = Some(i as u32);
            tracks.push(Track { seen });
            last.push((t, f.clone(), Vec3::ZERO));
        }
    }
    tracks
}

/// The distance of two features' signatures.
fn signature_distance(a: &Feature, b: &Feature) -> f32 {
    a.descriptor.iter().zip(&b.descriptor).map(|(x, y)| (x - y) * (x - y)).sum::<f32>().sqrt()
}

/// Where track `k` is in frame `t`: its feature's place where seen, else
/// the place between its sightings before and after (linearly), or the
/// nearest sighting; `None` for a track never seen.
pub fn place(track: &Track, frames: &[Vec<Feature>], t: usize) -> Option<Vec3> {
    let at = |s: usize| track.seen[s].map(|i| frames[s][i as usize].position);
    if let Some(p) = at(t) {
        return Some(p);
    }
    let before = (0..t).rev().find_map(|s| at(s).map(|p| (s, p)));
    let after = (t + 1..track.seen.len()).find_map(|s| at(s).map(|p| (s, p)));
    match (before, after) {
        (Some((s0, p0)), Some((s1, p1))) => Some(p0.lerp(p1, (t - s0) as f32 / (s1 - s0) as f32)),
        (Some((_, p)), None) | (None, Some((_, p))) => Some(p),
        (None, None) => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feature(x: f32, sig: f32) -> Feature {
        Feature { vertex: 0, position: Vec3::new(x, 0.0, 0.0), descriptor: [sig; super::super::detect::TIMES] }
    }

    /// Two features drifting apart; the second vanishes for two frames and
    /// comes back: two tracks, the second seen in all frames but those.
    #[test]
    fn a_feature_that_vanishes_for_a_while_keeps_its_track() {
        let frames: Vec<Vec<Feature>> = (0..8)
            .map(|t| {
                let mut f = vec![feature(0.01 * t as f32, 1.0)];
                if !(3..5).contains(&t) {
                    f.push(feature(0.5 + 0.01 * t as f32, 0.2));
                }
                f
            })
            .collect();
        let tracks = track(&frames, 1.0);
        assert_eq!(tracks.len(), 2, "{tracks:?}");
        assert_eq!(tracks[0].frames_seen(), 8);
        assert_eq!(tracks[1].frames_seen(), 6);
        let p = place(&tracks[1], &frames, 3).unwrap();
        assert!((p.x - 0.53).abs() < 1e-5, "{p}");
    }

    /// A feature that jumps across the body is a new track, not a match.
    #[test]
    fn a_jump_starts_a_new_track() {
        let frames = vec![vec![feature(0.0, 1.0)], vec![feature(0.5, 1.0)]];
        assert_eq!(track(&frames, 1.0).len(), 2);
    }
}

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
/// A weak maximum ([`Feature::weak`]) may be a track's only this close to
/// where the track is expected (a fraction of the diagonal): the misses
/// it mends were 0.1-2.3 % away where the body stays in place, the next
/// other maxima 10 % and more; a walking cow's head moves 5 % a frame and
/// the damped prediction ([`DAMPING`]) lags half of that, so its weak
/// maxima lay 4-6 % away: at 0.04 the probe's pcow capture kept its fourth
/// cone in 83 % of the frames (and its map resampled at 0.175 %), at 0.06
/// in 96 % (0.055 %).
pub const WEAK_STEP: f32 = 0.06;
/// How much of a track's last velocity its next place is predicted with:
/// one step's velocity is noisy (a feature sits on a vertex), and the full
/// step overshot where a head turned. Measured on the 24-frame captures:
/// 1 gave pcow's cones 100/92/88/75 % of the frames and horse-gallop's
/// 100/100/100/83, 0.5 gave 100/96/92/88 and 100 each, 0 gave
/// 100/100/92/88 and 100/100/100/96 (samba's the same with each).
pub const DAMPING: f32 = 0.5;
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

/// A capture's features and tracks, and the four tracks chosen as cones.
#[derive(Debug, Clone)]
pub struct Tracked {
    pub features: Vec<Vec<Feature>>,
    /// Each frame's center ([`super::capture::CaptureFrame::center`]), where the body is.
    pub centers: Vec<Vec3>,
    pub tracks: Vec<Track>,
    pub cones: [usize; 4],
    pub seconds: f64,
}

impl Tracked {
    /// Features found per frame, on average (the weak candidates not
    /// counted).
    pub fn features_per_frame(&self) -> f64 {
        let strong = self.features.iter().flatten().filter(|f| !f.weak).count();
        strong as f64 / self.features.len().max(1) as f64
    }

    /// The share of frames each cone's track was seen in.
    pub fn cones_seen(&self) -> [f64; 4] {
        self.cones.map(|k| self.tracks[k].frames_seen() as f64 / self.features.len().max(1) as f64)
    }

    /// The share of the four cones' frames in which their tracks were seen.
    pub fn cones_seen_overall(&self) -> f64 {
        self.cones_seen().iter().sum::<f64>() / 4.0
    }
}

/// Per track: its last sighting (frame, feature) and its velocity there
/// (a hand moves several times its size in a few frames).
type Sighting = (usize, Feature, Vec3);

/// Tracks through `frames` (each frame's features), `centers` each
/// frame's center ([`CaptureFrame::center`]), `diagonal` the motion's
/// bounding-box diagonal. Places are compared in the body's own frame,
/// each less its frame's center: a body that travels (pcow's centroid
/// moves 3.6 % of the diagonal a frame on average, up to 12.8 %) carries
/// its features out of reach of a prediction from their last velocity,
/// and of a track that lost them for a few frames.
///
/// [`CaptureFrame::center`]: super::capture::CaptureFrame::center
pub fn track(frames: &[Vec<Feature>], centers: &[Vec3], diagonal: f32) -> Vec<Track> {
    let frames = &on_the_body(frames, centers);
    let n = frames.len();
    let mut tracks: Vec<Track> = Vec::new();
    let mut last: Vec<Sighting> = Vec::new();
    for (t, features) in frames.iter().enumerate() {
        let alive: Vec<usize> = (0..tracks.len()).filter(|&k| t - last[k].0 <= GAP + 1).collect();
        let mut taken = vec![false; features.len()];
        // The strong features first; the weak only for the tracks left.
        let mut matched = pairs_in(t, features, &alive, &last, diagonal, false, &mut taken);
        let left: Vec<usize> = alive.iter().copied().filter(|k| !matched.iter().any(|m| m.0 == *k)).collect();
        matched.extend(pairs_in(t, features, &left, &last, diagonal, true, &mut taken));
        for (k, i) in matched {
            tracks[k].seen[t] = Some(i as u32);
            let v = (features[i].position - last[k].1.position) / (t - last[k].0) as f32;
            last[k] = (t, features[i].clone(), v);
        }
        for (i, f) in features.iter().enumerate().filter(|(i, f)| !taken[*i] && !f.weak) {
            let mut seen = vec![None; n];
            seen[t] = Some(i as u32);
            tracks.push(Track { seen });
            last.push((t, f.clone(), Vec3::ZERO));
        }
    }
    filled(joined(tracks, frames, diagonal), frames, diagonal)
}

/// `tracks` with each gap of at most [`GAP`] frames between two sightings
/// filled where a frame has a free weak maximum (one no track holds)
/// within [`WEAK_STEP`] of the place between them ([`place`], frame by
/// frame, a frame just filled counting as a sighting): the nearest is
/// taken, the longest tracks first. A filled frame is seen like any
/// other: a cone's place there is that maximum's. The matching above
/// predicts from the last sighting alone, and a head that swings leaves
/// its damped prediction further behind than that (whole pcow's segment
/// 60-89 lost its head for three frames so, with weak maxima by the place
/// between its sightings).
fn filled(mut tracks: Vec<Track>, frames: &[Vec<Feature>], diagonal: f32) -> Vec<Track> {
    let mut held: Vec<Vec<bool>> = frames.iter().map(|f| vec![false; f.len()]).collect();
    for (t, i) in tracks.iter().flat_map(|tr| tr.seen.iter().enumerate().filter_map(|(t, s)| Some((t, (*s)?)))) {
        held[t][i as usize] = true;
    }
    let mut order: Vec<usize> = (0..tracks.len()).collect();
    order.sort_by_key(|&k| std::cmp::Reverse(tracks[k].frames_seen()));
    for k in order {
        let seen: Vec<usize> = (0..frames.len()).filter(|&t| tracks[k].seen[t].is_some()).collect();
        for (&t0, &t1) in seen.iter().zip(seen.iter().skip(1)).filter(|(a, b)| **b - **a - 1 <= GAP) {
            for t in t0 + 1..t1 {
                let Some(p) = place(&tracks[k], frames, t) else { continue };
                let free = frames[t].iter().enumerate().filter(|(i, f)| f.weak && !held[t][*i]);
                let nearest = free.map(|(i, f)| (f.position.distance(p), i)).min_by(|a, b| a.0.total_cmp(&b.0));
                if let Some((_, i)) = nearest.filter(|n| n.0 <= WEAK_STEP * diagonal) {
                    tracks[k].seen[t] = Some(i as u32);
                    held[t][i] = true;
                }
            }
        }
    }
    tracks
}

/// `frames`' features with each place less its frame's center (a frame
/// without one keeps its places).
fn on_the_body(frames: &[Vec<Feature>], centers: &[Vec3]) -> Vec<Vec<Feature>> {
    let shifted =
        |f: &Vec<Feature>, c: Vec3| f.iter().map(|x| Feature { position: x.position - c, ..x.clone() }).collect();
    frames.iter().enumerate().map(|(t, f)| shifted(f, centers.get(t).copied().unwrap_or_default())).collect()
}

/// `tracks` with each pair that is one feature seen twice made one: a
/// track born beside another that lost its feature for a frame (its
/// signature changed more than the ratio allows), after which the two
/// share the sightings. Two tracks are one where neither is seen strong
/// in a frame the other is, and the later's first sighting is within
/// [`WEAK_STEP`] of the earlier's place then, or within [`MAX_STEP`] with
/// a signature within [`RATIO`] x [`NOISE`]; in a frame both saw, the
/// strong sighting stays. pcow's tail was split so (its signature fell
/// 0.81 in a frame, the place moved 0.1 % of the diagonal).
fn joined(mut tracks: Vec<Track>, frames: &[Vec<Feature>], diagonal: f32) -> Vec<Track> {
    let strong = |tr: &Track, t: usize| tr.seen[t].is_some_and(|i| !frames[t][i as usize].weak);
    let first = |tr: &Track| tr.seen.iter().position(Option::is_some).unwrap_or(usize::MAX);
    let mut a = 0;
    while a < tracks.len() {
        let partner = (0..tracks.len()).find(|&b| {
            let (ta, tb) = (&tracks[a], &tracks[b]);
            let s = first(tb);
            if b == a || s <= first(ta) || (0..frames.len()).any(|t| strong(ta, t) && strong(tb, t)) {
                return false;
            }
            let (Some(p), Some(i)) = (place(ta, frames, s), tb.seen[s]) else { return false };
            let f = &frames[s][i as usize];
            let step = p.distance(f.position) / diagonal.max(f32::MIN_POSITIVE);
            let before = (0..s).rev().find_map(|t| ta.seen[t].map(|j| &frames[t][j as usize]));
            step <= WEAK_STEP || (step <= MAX_STEP && before.is_some_and(|g| signature_distance(g, f) <= RATIO * NOISE))
        });
        match partner {
            Some(b) => {
                let later = tracks.remove(b);
                a -= usize::from(b < a);
                for (t, s) in later.seen.iter().enumerate() {
                    if s.is_some() && (tracks[a].seen[t].is_none() || strong(&later, t)) {
                        tracks[a].seen[t] = *s;
                    }
                }
            }
            None => a += 1,
        }
    }
    tracks
}

/// The pairs (track, feature) of frame `t` among the tracks `alive` and
/// the features not `taken` that are `weak` or not, the closest first; a
/// pair more than [`RATIO`] times the best's distance is no match.
fn pairs_in(
    t: usize,
    features: &[Feature],
    alive: &[usize],
    last: &[Sighting],
    diagonal: f32,
    weak: bool,
    taken: &mut [bool],
) -> Vec<(usize, usize)> {
    let mut pairs: Vec<(f32, usize, usize)> = Vec::new();
    for &k in alive {
        let (s, seen, v) = &last[k];
        let predicted = seen.position + *v * DAMPING * (t - s) as f32;
        for (i, f) in features.iter().enumerate().filter(|(i, f)| f.weak == weak && !taken[*i]) {
            let step = predicted.distance(f.position) / diagonal.max(f32::MIN_POSITIVE);
            if step <= if weak { WEAK_STEP } else { MAX_STEP } {
                pairs.push((signature_distance(seen, f) + PLACE_WEIGHT * step, k, i));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let best = pairs.first().map_or(0.0, |p| p.0);
    let mut matched: Vec<(usize, usize)> = Vec::new();
    for (d, k, i) in pairs {
        if d > RATIO * best.max(NOISE) || taken[i] || matched.iter().any(|m| m.0 == k) {
            continue;
        }
        taken[i] = true;
        matched.push((k, i));
    }
    matched
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
        Feature {
            vertex: 0,
            position: Vec3::new(x, 0.0, 0.0),
            descriptor: [sig; super::super::detect::TIMES],
            weak: false,
        }
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
        let tracks = track(&frames, &[], 1.0);
        assert_eq!(tracks.len(), 2, "{tracks:?}");
        assert_eq!(tracks[0].frames_seen(), 8);
        assert_eq!(tracks[1].frames_seen(), 6);
        let p = place(&tracks[1], &frames, 3).unwrap();
        assert!((p.x - 0.53).abs() < 1e-5, "{p}");
    }

    /// A weak maximum near a track that lost its feature for a frame is
    /// taken; one far from every track is no feature and starts no track.
    #[test]
    fn a_weak_maximum_is_taken_only_near_a_track_that_lacks_its_feature() {
        let frames: Vec<Vec<Feature>> = (0..6)
            .map(|t| {
                let mut f = vec![feature(0.01 * t as f32, 1.0), feature(0.5 + 0.01 * t as f32, 0.2)];
                if t == 3 {
                    f[1].weak = true;
                    f.push(Feature { weak: true, ..feature(0.9, 0.2) });
                }
                f
            })
            .collect();
        let tracks = track(&frames, &[], 1.0);
        assert_eq!(tracks.len(), 2, "{tracks:?}");
        assert_eq!(tracks[1].seen[3], Some(1));
        assert!(tracks.iter().all(|k| k.frames_seen() == 6));
    }

    /// A track moving a tenth of the diagonal a frame whose feature is
    /// weak for a frame: the damped prediction lags 5 % behind it, and the
    /// weak maximum is still taken.
    #[test]
    fn a_weak_maximum_of_a_fast_track_is_taken() {
        let frames: Vec<Vec<Feature>> = (0..6)
            .map(|t| {
                let mut f = vec![feature(0.1 * t as f32, 1.0), feature(2.0, 0.2)];
                f[0].weak = t == 3;
                f
            })
            .collect();
        let tracks = track(&frames, &[], 1.0);
        assert_eq!(tracks.len(), 2, "{tracks:?}");
        assert!(tracks.iter().all(|k| k.frames_seen() == 6), "{tracks:?}");
    }

    /// A fast feature that turns back, weak for two frames: its damped
    /// prediction runs on past the weak maxima, but they lie by the place
    /// between its sightings around them, and fill the gap. Maxima further
    /// off than [`WEAK_STEP`] do not.
    #[test]
    fn a_gap_is_filled_by_the_weak_maxima_between_its_sightings() {
        let frames = |off: f32| -> Vec<Vec<Feature>> {
            (0..8)
                .map(|t| {
                    let mut f = feature(if t <= 3 { 0.12 * t as f32 } else { 0.31 }, 1.0);
                    if (4..6).contains(&t) {
                        f.position.y += off;
                        f.weak = true;
                    }
                    vec![f]
                })
                .collect()
        };
        let tracks = track(&frames(0.01), &[], 1.0);
        assert_eq!(tracks.len(), 1, "{tracks:?}");
        assert_eq!(tracks[0].frames_seen(), 8, "{tracks:?}");
        let far = track(&frames(0.1), &[], 1.0);
        assert_eq!(far.iter().map(Track::frames_seen).max(), Some(6), "{far:?}");
    }

    /// A feature whose signature changes by more than the ratio allows is
    /// dropped by its track and born again as another: the two are joined.
    #[test]
    fn a_track_split_by_a_changed_signature_is_joined() {
        let frames: Vec<Vec<Feature>> = (0..8)
            .map(|t| {
                let jump = if t >= 4 { 1.0 } else { 0.0 };
                vec![feature(0.01 * t as f32, 1.0), feature(0.5 + 0.01 * t as f32, 0.2 + jump)]
            })
            .collect();
        let split = track(&frames, &[], 1.0);
        assert_eq!(split.len(), 2, "{split:?}");
        assert!(split.iter().all(|k| k.frames_seen() == 8), "{split:?}");
        // Far apart where the second is born, they stay two.
        let apart: Vec<Vec<Feature>> = (0..8)
            .map(|t| {
                let x = if t >= 4 { 0.6 } else { 0.5 };
                let sig = if t >= 4 { 1.2 } else { 0.2 };
                vec![feature(0.01 * t as f32, 1.0), feature(x + 0.01 * t as f32, sig)]
            })
            .collect();
        assert_eq!(track(&apart, &[], 1.0).len(), 3);
    }

    /// A body that travels half a diagonal a frame: its features keep their
    /// tracks through it, and one that vanishes for longer than a track
    /// waits ([`GAP`]) is joined to its track when it comes back, where it
    /// was on the body; without the body's centers nothing matches.
    #[test]
    fn features_of_a_travelling_body_keep_their_tracks() {
        let n = GAP + 8;
        let centers: Vec<Vec3> = (0..n).map(|t| Vec3::new(0.0, 0.5 * t as f32, 0.0)).collect();
        let frames: Vec<Vec<Feature>> = (0..n)
            .map(|t| {
                let on =
                    |x: f32, sig: f32| Feature { position: feature(x, sig).position + centers[t], ..feature(x, sig) };
                let mut f = vec![on(0.0, 1.0)];
                if !(2..GAP + 4).contains(&t) {
                    f.push(on(0.5 + 0.001 * t as f32, 0.2));
                }
                f
            })
            .collect();
        let tracks = track(&frames, &centers, 1.0);
        assert_eq!(tracks.len(), 2, "{tracks:?}");
        assert_eq!(tracks[0].frames_seen(), n);
        assert_eq!(tracks[1].frames_seen(), n - GAP - 2);
        assert!(track(&frames, &[], 1.0).len() > 2);
    }

    /// A feature that jumps across the body is a new track, not a match.
    #[test]
    fn a_jump_starts_a_new_track() {
        let frames = vec![vec![feature(0.0, 1.0)], vec![feature(0.5, 1.0)]];
        assert_eq!(track(&frames, &[], 1.0).len(), 2);
    }
}

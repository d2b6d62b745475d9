//! A piece of a capture registered where the last piece left off, for
//! [`register`](super::register): the same cones where their tracks go
//! on, the first frame's cut traced from the last frame's (as each frame
//! follows the one before it, [`follow`](super::follow)), and the whole
//! piece turned by the square's turn that puts its first grid nearest the
//! last piece's last grid.
//!
//! Pieces (segments, and the halves of those that fail their checks) are
//! registered each with its own tracks; the encoder fits one set of bone
//! weights to the whole grid motion (`crate::codec::encode::bones`). A
//! piece whose map starts elsewhere on the body (whole samba, made piece
//! by piece: its grid moved 31-41 % of the diagonal at each segment's
//! start) leaves those weights wrong on one side of the start or the other.

use super::detect::Feature;
use super::follow::CutTrace;
use super::symmetry::{apply_symmetry, Symmetry, TURNS};
use super::track::{place, Track};
use crate::grid::Grid;
use glam::Vec3;

/// What the next piece starts from: where the last piece's cones would be
/// one frame on (each moved on by its last step), its last steady frame's
/// cut (none where no frame was steady), and its last grid, as stored.
#[derive(Debug, Clone)]
pub struct Handover {
    pub cones: [Vec3; 4],
    pub trace: Option<CutTrace>,
    pub grid: Vec<Vec3>,
}

impl Handover {
    /// The handover of a piece whose cones follow `cones` (indices into
    /// `tracks`), whose last steady frame's cut is `trace` and last grid
    /// `grid`.
    pub fn of(
        tracks: &[Track],
        features: &[Vec<Feature>],
        cones: [usize; 4],
        trace: Option<CutTrace>,
        grid: Vec<Vec3>,
    ) -> Self {
        let last = features.len().saturating_sub(1);
        let ahead = |k: usize| {
            let at = |t: usize| place(&tracks[k], features, t);
            match (at(last), last.checked_sub(1).and_then(at)) {
                (Some(p), Some(q)) => 2.0 * p - q,
                (p, _) => p.unwrap_or(Vec3::ZERO),
            }
        };
        Handover { cones: cones.map(ahead), trace, grid }
    }
}

/// How far from the last piece's cone (moved on by its last step) a
/// track's first place may be to carry that cone on, in diagonals: the
/// tracker's own step for a feature it lost.
pub const LINK: f32 = super::track::WEAK_STEP;

/// The tracks that carry `cones` on into a piece: for each cone, in
/// order, a track of `tracks` that `may_be_cone` allows, seen in the
/// piece's first frame within [`LINK`] diagonals of it, the nearest pairs
/// taken first; `None` unless all four are found.
pub fn continuing_cones(
    tracks: &[Track],
    features: &[Vec<Feature>],
    cones: &[Vec3; 4],
    may_be_cone: impl Fn(usize) -> bool,
    diagonal: f32,
) -> Option<[usize; 4]> {
    let mut pairs: Vec<(f32, usize, usize)> = Vec::new();
    let seen_first = |k: usize| tracks[k].seen.first().is_some_and(Option::is_some);
    for k in (0..tracks.len()).filter(|&k| may_be_cone(k) && seen_first(k)) {
        let Some(p) = place(&tracks[k], features, 0) else { continue };
        for (c, cone) in cones.iter().enumerate() {
            let d = p.distance(*cone);
            if d <= LINK * diagonal {
                pairs.push((d, c, k));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut found: [Option<usize>; 4] = [None; 4];
    for (_, c, k) in pairs {
        if found[c].is_none() && !found.contains(&Some(k)) {
            found[c] = Some(k);
        }
    }
    let [a, b, c, d] = found;
    Some([a?, b?, c?, d?])
}

/// The turn of the square, of `turns`, that takes grid frame `first`
/// nearest `last` (the smallest sum of squared distances between like
/// samples).
pub fn nearest_turn(grid: Grid, last: &[Vec3], first: &[Vec3], turns: &[Symmetry]) -> Symmetry {
    let far = |m: &Symmetry| -> f64 {
        let turned = apply_symmetry(grid, first, *m);
        turned.iter().zip(last).map(|(a, b)| f64::from(a.distance_squared(*b))).sum()
    };
    turns.iter().copied().min_by(|a, b| far(a).total_cmp(&far(b))).unwrap_or(TURNS[0])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::detect::TIMES;

    fn feature(position: Vec3) -> Feature {
        Feature { vertex: 0, position, descriptor: [0.0; TIMES], weak: false }
    }

    /// Each cone goes on with the track seen nearest it in the piece's
    /// first frame; a cone with no track within reach, or a track refused
    /// as a cone, leaves none carried on.
    #[test]
    fn cones_go_on_with_the_tracks_that_start_where_they_were() {
        let places = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y];
        let cones = [-Vec3::Y + 0.1, Vec3::Z, Vec3::X * 1.05, -Vec3::X];
        // A sixth track, first seen in frame 1 right where cone 0 was
        // heading: not seen in the piece's first frame, so not taken.
        let first: Vec<Feature> = places.iter().map(|&p| feature(p)).collect();
        let mut second = first.clone();
        second.push(feature(cones[0]));
        let features = vec![first, second];
        let mut tracks: Vec<Track> = (0..5).map(|k| Track { seen: vec![Some(k), Some(k)] }).collect();
        tracks.push(Track { seen: vec![None, Some(5)] });
        let diagonal = 10.0;
        let all = |_: usize| true;
        assert_eq!(continuing_cones(&tracks, &features, &cones, all, diagonal), Some([4, 2, 0, 3]));
        let far = [Vec3::X, Vec3::Y, Vec3::Z, Vec3::splat(5.0)];
        assert_eq!(continuing_cones(&tracks, &features, &far, all, diagonal), None);
        assert_eq!(continuing_cones(&tracks, &features, &cones, |k| k != 4, diagonal), None);
    }

    /// A piece whose first grid is the last grid turned is turned back.
    #[test]
    fn the_turn_back_to_the_last_grid_is_found() {
        let grid = Grid::new(6).unwrap();
        let last: Vec<Vec3> = (0..36).map(|s| Vec3::new((s % 6) as f32, (s / 6) as f32, (s * s % 7) as f32)).collect();
        for (k, m) in TURNS.iter().enumerate() {
            let first = apply_symmetry(grid, &last, *m);
            let back = nearest_turn(grid, &last, &first, &TURNS);
            assert_eq!(apply_symmetry(grid, &first, back), last, "turn {k}");
        }
    }
}

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

use super::capture::CaptureFrame;
use super::follow::CutTrace;
use super::symmetry::{apply_symmetry, Symmetry, TURNS};
use super::track::{place, Tracked};
use crate::grid::Grid;
use crate::resample::SampleMap;
use glam::Vec3;
use std::sync::Arc;

/// What the next piece starts from: where the last piece's cones would be
/// one frame on on the body (each moved on by its last step, less the
/// frame's center: a body that travels, as pcow does by several % of the
/// diagonal a frame, moves them all alike), its last steady frame's cut
/// (none where no frame was steady), and its last grid, as stored.
#[derive(Debug, Clone)]
pub struct Handover {
    pub cones: [Vec3; 4],
    pub trace: Option<CutTrace>,
    pub grid: Vec<Vec3>,
    /// Where the last piece was a registered run: its one map, for a next
    /// piece that goes on with the same mesh.
    pub run: Option<RunMap>,
}

/// A registered run's one map ([`super::frame_map::map_run`]), handed on
/// so that a run longer than a segment (cut at the encoder's
/// random-access interval, so that a segment's frames fit in memory) is
/// one map throughout, as a registered motion's: the run's mesh, the map,
/// the turn its grid was given, the vertices' places and which samples lie
/// on the frame's own faces (both turned), and the cones' vertices.
#[derive(Debug, Clone)]
pub struct RunMap {
    pub faces: Vec<[u32; 3]>,
    pub vertex_count: usize,
    pub map: Arc<SampleMap>,
    pub turn: Symmetry,
    pub places: Vec<[u32; 2]>,
    pub on_input: Vec<bool>,
    pub cones: [u32; 4],
}

impl RunMap {
    /// Whether `frame` has the run's mesh ([`CaptureFrame::shares_mesh`]).
    pub fn goes_on_in(&self, frame: &CaptureFrame) -> bool {
        frame.positions.len() == self.vertex_count && frame.faces == self.faces
    }

    /// The grid of a frame of the run (its positions `frame`), turned.
    pub fn grid_of(&self, grid: Grid, frame: &[Vec3]) -> Vec<Vec3> {
        apply_symmetry(grid, &self.map.apply(frame), self.turn)
    }
}

impl Handover {
    /// The handover of a piece `tracked` (its cones, its frames' features
    /// and centers) whose last steady frame's cut is `trace` and last
    /// grid `grid`.
    pub fn of(tracked: &Tracked, trace: Option<CutTrace>, grid: Vec<Vec3>) -> Self {
        let last = tracked.features.len().saturating_sub(1);
        let ahead = |k: usize| {
            let at = |t: usize| on_body(tracked, k, t);
            match (at(last), last.checked_sub(1).and_then(at)) {
                (Some(p), Some(q)) => 2.0 * p - q,
                (p, _) => p.unwrap_or(Vec3::ZERO),
            }
        };
        Handover { cones: tracked.cones.map(ahead), trace, grid, run: None }
    }
}

/// Where track `k` of `tracked` is in frame `t`, less the frame's center.
fn on_body(tracked: &Tracked, k: usize, t: usize) -> Option<Vec3> {
    let center = tracked.centers.get(t).copied().unwrap_or_default();
    place(&tracked.tracks[k], &tracked.features, t).map(|p| p - center)
}

/// How far from the last piece's cone (moved on by its last step) a
/// track's first place may be to carry that cone on, in diagonals: the
/// tracker's own step for a feature it lost.
pub const LINK: f32 = super::track::WEAK_STEP;

/// The tracks of a piece (`tracked`) that carry `cones` (on the body, as
/// [`Handover`] has them) on into it: for each cone, in order, a track
/// that `may_be_cone` allows, seen in the piece's first frame within
/// [`LINK`] diagonals of it, the nearest pairs taken first; `None` unless
/// all four are found.
pub fn continuing_cones(
    tracked: &Tracked,
    cones: &[Vec3; 4],
    may_be_cone: impl Fn(usize) -> bool,
    diagonal: f32,
) -> Option<[usize; 4]> {
    let tracks = &tracked.tracks;
    let mut pairs: Vec<(f32, usize, usize)> = Vec::new();
    let seen_first = |k: usize| tracks[k].seen.first().is_some_and(Option::is_some);
    for k in (0..tracks.len()).filter(|&k| may_be_cone(k) && seen_first(k)) {
        let Some(p) = on_body(tracked, k, 0) else { continue };
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
    use crate::features::detect::{Feature, TIMES};
    use crate::features::track::Track;

    fn feature(position: Vec3) -> Feature {
        Feature { vertex: 0, position, descriptor: [0.0; TIMES], weak: false }
    }

    /// Each cone goes on with the track seen nearest it in the piece's
    /// first frame, on the body (the piece's frames moved 3 units, their
    /// centers with them); a cone with no track within reach, or a track
    /// refused as a cone, leaves none carried on.
    #[test]
    fn cones_go_on_with_the_tracks_that_start_where_they_were() {
        let travel = Vec3::new(3.0, 0.0, 0.0);
        let places = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y];
        let cones = [-Vec3::Y + 0.1, Vec3::Z, Vec3::X * 1.05, -Vec3::X];
        // A sixth track, first seen in frame 1 right where cone 0 was
        // heading: not seen in the piece's first frame, so not taken.
        let first: Vec<Feature> = places.iter().map(|&p| feature(p + travel)).collect();
        let mut second = first.clone();
        second.push(feature(cones[0] + travel));
        let mut tracks: Vec<Track> = (0..5).map(|k| Track { seen: vec![Some(k), Some(k)] }).collect();
        tracks.push(Track { seen: vec![None, Some(5)] });
        let features = vec![first, second];
        let piece = |centers: Vec<Vec3>| Tracked {
            features: features.clone(),
            centers,
            tracks: tracks.clone(),
            cones: [0, 1, 2, 3],
            seconds: 0.0,
        };
        let (moved, still) = (piece(vec![travel; 2]), piece(vec![Vec3::ZERO; 2]));
        let diagonal = 10.0;
        let all = |_: usize| true;
        assert_eq!(continuing_cones(&moved, &cones, all, diagonal), Some([4, 2, 0, 3]));
        assert_eq!(continuing_cones(&still, &cones, all, diagonal), None, "the travel is past reach");
        let far = [Vec3::X, Vec3::Y, Vec3::Z, Vec3::splat(5.0)];
        assert_eq!(continuing_cones(&moved, &far, all, diagonal), None);
        assert_eq!(continuing_cones(&moved, &cones, |k| k != 4, diagonal), None);
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

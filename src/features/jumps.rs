//! Frames whose grid jumps: a map fixed by its cones can still take its
//! cut another way round the body (the seed paper's section 4.2 maps each
//! frame on its own), and then every sample lands elsewhere on the body in
//! that frame. Such a frame is found by the grid's own speed, without a
//! registered truth: a sample moves with the body, a few percent of the
//! diagonal a frame, and a jump moves every sample 10-40 %. A frame that
//! still jumps when mapped again is [`bridged`] from its neighbours.

use super::nearest::nearest_vertices;
use crate::error::Result;
use crate::grid::Grid;
use crate::metrics::surface::Target;
use crate::resample::quantized_place;
use glam::Vec3;
use rayon::prelude::*;

/// A frame is a jump where its grid lies further from the last steady
/// frame's than this many times the median speed, plus the median for
/// each further frame between them (horse-gallop's 24-frame capture:
/// steady frames 0.9-2.5 % of the diagonal a frame, jumps 15-35 %; an
/// allowance of 4 medians per frame let a 15 % jump two frames on pass).
pub const JUMP: f32 = 4.0;

/// RMS distance between two grids' samples, less their mean move: a body
/// that travels through space moves every sample alike, and that is no
/// jump (pcow walks 6 % of its diagonal a frame, so 4 such medians let a
/// 18 % jump of its map pass).
pub fn rms_distance(a: &[Vec3], b: &[Vec3]) -> f32 {
    let count = a.len().min(b.len()).max(1) as f32;
    let mean = a.iter().zip(b).map(|(x, y)| *x - *y).sum::<Vec3>() / count;
    let sum: f32 = a.iter().zip(b).map(|(x, y)| (*x - *y - mean).length_squared()).sum();
    (sum / count).sqrt()
}

/// The median of a capture's per-frame speeds (each grid's RMS move from
/// the frame before's).
pub fn median(mut speeds: Vec<f32>) -> f32 {
    speeds.sort_by(f32::total_cmp);
    speeds.get(speeds.len() / 2).copied().unwrap_or(0.0)
}

/// The most median speed [`found`] counts, a fraction of the diagonal a
/// frame: a body moves a few percent a frame less its travel (pcow 3 %),
/// and where most of a stretch's frames jump (pcow's 192-203: 7 of 11
/// moves 15-35 %) its median is itself a jump, and none would be found.
pub const MOST_SPEED: f32 = 0.04;

/// The least move (a fraction of the diagonal) that is a jump: a capture
/// that barely moves has a median speed near zero, and its maps' own
/// noise would count as jumps.
pub const LEAST_JUMP: f32 = 0.05;

/// Whether grid `g`, `frames` after the steady grid `steady`, jumped
/// (`diagonal`: the capture's).
pub fn jumped(g: &[Vec3], steady: &[Vec3], frames: usize, median: f32, diagonal: f32) -> bool {
    let d = rms_distance(g, steady);
    d > median * (JUMP + frames.saturating_sub(1) as f32) && d > LEAST_JUMP * diagonal
}

/// Frames whose grids (`grids`, compared as stored) jump, walked from the
/// [`anchor`] forwards and then backwards, each against the last steady
/// frame in its direction. A frame that jumps is offered to `fix` with the
/// frames to retry from (that steady frame, and the next one on) and a
/// test its new grid must pass (no jump, and closer to the steady frame
/// than its own); a grid `fix` returns replaces the frame's and it is
/// steady. Returns the frames that still jump, in order (`diagonal`: the
/// capture's).
pub fn found(grids: &mut [Vec<Vec3>], diagonal: f32, fix: &mut Fix) -> Result<Vec<usize>> {
    let n = grids.len();
    let speeds = (1..n).map(|t| rms_distance(&grids[t], &grids[t - 1])).collect();
    let median = median(speeds).min(MOST_SPEED * diagonal);
    let a = anchor(grids, median, diagonal);
    let mut left = Vec::new();
    for (order, step) in [((a + 1..n).collect::<Vec<_>>(), 1), ((0..a).rev().collect(), -1)] {
        let mut s = a;
        for t in order {
            let frames = t.abs_diff(s);
            if !jumped(&grids[t], &grids[s], frames, median, diagonal) {
                s = t;
                continue;
            }
            let (steady, own) = (&grids[s], &grids[t]);
            let passes = |g: &[Vec3]| {
                !jumped(g, steady, frames, median, diagonal) && rms_distance(g, steady) < rms_distance(own, steady)
            };
            let next = t.checked_add_signed(step).filter(|&k| k < n);
            match fix(t, [Some(s), next], &passes)? {
                Some(g) => (grids[t], s) = (g, t),
                None => left.push(t),
            }
        }
    }
    left.sort_unstable();
    Ok(left)
}

/// [`found`]'s retry of a jumping frame: the frame, the frames to retry
/// from, and the test a new grid must pass; the new grid, if any.
pub type Fix<'a> = dyn FnMut(usize, [Option<usize>; 2], &dyn Fn(&[Vec3]) -> bool) -> Result<Option<Vec<Vec3>>> + 'a;

/// Frames either side of a frame that [`anchor`] compares it with.
pub const ANCHOR_WINDOW: usize = 4;

/// The frame whose grid the most frames within [`ANCHOR_WINDOW`] of it
/// are steady against (as a share of those there are; the first of equals).
/// A walk must start from a steady frame: from one whose map went another
/// way round, every frame after it looks like a jump (pcow's frames
/// 180-191, walked from 180: 11 frames bridged from it, carried 2-22 % of
/// the diagonal across the body).
pub fn anchor(grids: &[Vec<Vec3>], median: f32, diagonal: f32) -> usize {
    let share = |a: usize| {
        let near = a.saturating_sub(ANCHOR_WINDOW)..(a + ANCHOR_WINDOW + 1).min(grids.len());
        let others: Vec<usize> = near.filter(|&b| b != a).collect();
        let steady = others.iter().filter(|&&b| !jumped(&grids[b], &grids[a], a.abs_diff(b), median, diagonal)).count();
        steady as f64 / others.len().max(1) as f64
    };
    let shares: Vec<f64> = (0..grids.len()).into_par_iter().map(share).collect();
    (0..grids.len()).fold(0, |best, a| if shares[a] > shares[best] { a } else { best })
}

/// A frame's grid rebuilt from the steady frames around it: each sample
/// where a straight line in time between its places in `before` and
/// `after` (each a frame index and its grid; either may be missing) puts
/// it in frame `t`, moved onto the frame's surface (`positions`,
/// `faces`); and each of the frame's vertices placed at its nearest
/// sample, so that its own mesh (`--mesh frames`) is rebuilt on this grid.
pub fn bridged(
    grid: Grid,
    t: usize,
    before: Option<(usize, &[Vec3])>,
    after: Option<(usize, &[Vec3])>,
    positions: &[Vec3],
    faces: &[[u32; 3]],
) -> Result<(Vec<Vec3>, Vec<[u32; 2]>)> {
    let target = Target::new(positions, faces)?;
    let line: Vec<Vec3> = match (before, after) {
        (Some((a, p)), Some((b, q))) => {
            let w = (t - a) as f32 / (b - a).max(1) as f32;
            p.iter().zip(q).map(|(x, y)| x.lerp(*y, w)).collect()
        }
        (Some((_, p)), None) | (None, Some((_, p))) => p.to_vec(),
        (None, None) => return Ok((Vec::new(), Vec::new())),
    };
    let samples = fitted(grid, line, &target, positions);
    let n = grid.n;
    let places = nearest_vertices(positions, &samples)
        .into_iter()
        .map(|s| quantized_place(grid.uv((s as usize % n) as i64, (s as usize / n) as i64)))
        .collect();
    Ok((samples, places))
}

/// Rounds of [`fitted`]: each moves the samples by their smoothed pulls.
const FIT_ROUNDS: usize = 80;
/// Passes of the 3 x 3 box over the grid that smooth the pulls.
const PULL_PASSES: usize = 4;

/// `line` moved onto the surface as a whole: each sample's pull to its
/// nearest point there, smoothed over the grid, moves it, a few rounds,
/// before each lands on its nearest point. Each on its own, a galloping
/// leg's samples, predicted across the arc the hoof swings, snap to the
/// leg's side and leave the hoof bare (horse-gallop's bridged frames
/// resampled 0.5-1 % off where their neighbours were 0.07 %).
fn fitted(grid: Grid, mut line: Vec<Vec3>, target: &Target, vertices: &[Vec3]) -> Vec<Vec3> {
    for _ in 0..FIT_ROUNDS {
        let mut pulls: Vec<(Vec3, f32)> = line.par_iter().map(|&p| (target.nearest_point(p) - p, 1.0)).collect();
        // Each vertex of the frame pulls its nearest sample to it, so that
        // no part of the body is left bare.
        for (v, s) in vertices.iter().zip(nearest_vertices(vertices, &line)) {
            let s = s as usize;
            pulls[s] = (pulls[s].0 + (*v - line[s]), pulls[s].1 + 1.0);
        }
        let pulls = box_smoothed(grid.n, pulls.into_iter().map(|(d, c)| d / c).collect(), PULL_PASSES);
        line.iter_mut().zip(pulls).for_each(|(p, d)| *p += d);
    }
    line.par_iter().map(|&p| target.nearest_point(p)).collect()
}

/// `values` on an `n` x `n` grid (row by row), each pass replaced by the
/// mean of its 3 x 3 neighbourhood (clipped at the square's sides).
fn box_smoothed(n: usize, mut values: Vec<Vec3>, passes: usize) -> Vec<Vec3> {
    for _ in 0..passes {
        values = (0..n * n)
            .into_par_iter()
            .map(|k| {
                let (i, j) = (k % n, k / n);
                let (mut sum, mut count) = (Vec3::ZERO, 0.0);
                for y in j.saturating_sub(1)..(j + 2).min(n) {
                    for x in i.saturating_sub(1)..(i + 2).min(n) {
                        sum += values[y * n + x];
                        count += 1.0;
                    }
                }
                sum / count
            })
            .collect();
    }
    values
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The frames of `grids` that jump, nothing retried.
    fn jumping_frames(grids: &[Vec<Vec3>]) -> Vec<usize> {
        found(&mut grids.to_vec(), 1.0, &mut |_, _, _| Ok(None)).unwrap()
    }

    /// A grid moving steadily, with frames 4 and 5 turned end to end on
    /// the body and frame 9 once: those three are the jumps, and the
    /// frames after each are steady again; faster motion alone is no
    /// jump, nor is the whole body's travel.
    #[test]
    fn jumps_are_found_and_steady_motion_is_not() {
        let grids: Vec<Vec<Vec3>> = (0..12)
            .map(|t| {
                let turned = |i: usize| if [4, 5, 9].contains(&t) { 15 - i } else { i };
                (0..16).map(|i| Vec3::new(turned(i) as f32 * 0.1, 0.02 * t as f32, (i % 3) as f32 * 0.01)).collect()
            })
            .collect();
        assert_eq!(jumping_frames(&grids), vec![4, 5, 9]);
        let fast: Vec<Vec<Vec3>> =
            (0..12).map(|t| (0..16).map(|i| Vec3::new(i as f32, 0.02 * (t * t) as f32, 0.0)).collect()).collect();
        assert!(jumping_frames(&fast).is_empty());
        let travelling: Vec<Vec<Vec3>> = (0..12)
            .map(|t| (0..16).map(|i| Vec3::new(i as f32 * 0.1 + if t == 6 { 0.5 } else { 0.0 }, 0.0, 0.0)).collect())
            .collect();
        assert!(jumping_frames(&travelling).is_empty(), "the whole body's move is no jump");
        // Every other frame turned: the median move is itself a jump, and
        // only the cap on it finds them.
        let alternating: Vec<Vec<Vec3>> = (0..12).map(|t| grids[if t % 2 == 1 { 4 } else { 0 }].clone()).collect();
        assert_eq!(jumping_frames(&alternating), vec![1, 3, 5, 7, 9, 11]);
        // The first frame turned: the walk starts from a steady one, and
        // only the first frame jumps.
        let first: Vec<Vec<Vec3>> =
            grids.iter().enumerate().map(|(t, g)| if t == 0 { grids[4].clone() } else { g.clone() }).collect();
        assert_eq!(jumping_frames(&first[..4]), vec![0]);
        // A fix that passes the test replaces the grid, and the frame is
        // steady; one that does not is refused.
        let mut fixed = grids.clone();
        let steady = grids[3].clone();
        let left = found(&mut fixed, 1.0, &mut |t, from, passes| {
            assert!(from[0].is_some_and(|s| s != t && s != 9), "{t}: retried from a steady frame, not {from:?}");
            Ok(Some(steady.clone()).filter(|g| t != 9 && passes(g)))
        })
        .unwrap();
        assert_eq!(left, vec![9]);
        assert_eq!(fixed[4], grids[3]);
        // A still grid whose maps wobble 1 % of the diagonal in one frame:
        // its median speed is zero, and still no frame jumps.
        let still: Vec<Vec<Vec3>> = (0..12)
            .map(|t| (0..16).map(|i| Vec3::new(i as f32 * 0.05 + if t == 6 { 0.01 } else { 0.0 }, 0.0, 0.0)).collect())
            .collect();
        assert!(jumping_frames(&still).is_empty());
    }

    /// A square patch sampled by a 6 x 6 grid that the frames before and
    /// after hold above and below it, shifted along it: the bridged grid
    /// lies on the patch, unfolded (each row's samples in order), each
    /// sample within 0.15 (three quarters of a step) of midway between its
    /// two places (each vertex of the patch pulls the sample nearest it),
    /// and each of the frame's vertices is placed at a sample.
    #[test]
    fn a_bridged_frame_lies_on_its_surface_between_its_neighbours() {
        let grid = Grid::new(6).unwrap();
        // The patch the grid covers, midway, with a vertex in the middle.
        let plane = [
            Vec3::new(0.15, 0.0, 0.0),
            Vec3::new(1.15, 0.0, 0.0),
            Vec3::new(1.15, 1.0, 0.0),
            Vec3::new(0.15, 1.0, 0.0),
            Vec3::new(0.65, 0.5, 0.0),
        ];
        let faces = [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
        let at = |dx: f32, z: f32| -> Vec<Vec3> {
            (0..36).map(|k| Vec3::new((k % 6) as f32 * 0.2 + dx, (k / 6) as f32 * 0.2, z)).collect()
        };
        let (before, after) = (at(0.0, 0.1), at(0.3, -0.3));
        let (g, places) = bridged(grid, 3, Some((2, &before)), Some((4, &after)), &plane, &faces).unwrap();
        let truth = at(0.15, 0.0);
        assert!(g.iter().zip(&truth).all(|(p, q)| p.distance(*q) < 0.15 && p.z.abs() < 1e-6), "{g:?}");
        assert!((0..36).filter(|k| k % 6 != 5).all(|k| g[k].x < g[k + 1].x), "{g:?}");
        assert_eq!(places.len(), plane.len());
        let (none, _) = bridged(grid, 3, None, None, &plane, &faces).unwrap();
        assert!(none.is_empty());
    }
}

//! Choosing where on the grid each input vertex is rebuilt from, by its
//! error over the motion.
//!
//! The decoder rebuilds an input vertex from the grid triangle its stored
//! place falls in, plus an offset measured on the reference frame in that
//! triangle's frame (format v7; `resample::SourcePoints`). The
//! parameterization's own place is exact on the reference frame only; where
//! the grid is coarse for the surface (a cell stretched along a fold, a
//! part that grows in later frames) the triangle under it bends away from
//! the vertex. Any place works with the decoder's rule, so the encoder,
//! which sees the whole motion, may pick a nearby one that follows the
//! vertex better: a least-squares choice among a few candidates, the way
//! a displacement is fitted to a base mesh in V-DMC (ISO/IEC 23090-29),
//! with a hold-out test against over-fitting a few poses.
//!
//! Each vertex tries its own place and the places half a cell and a cell
//! away along each axis (25 in all); the candidate with the least squared
//! error over the *choosing* frames is kept only if it is also better than
//! the own place over the separate *checking* frames, both in the sum of
//! squares and in the worst frame. Nothing in the file format changes.

use crate::grid::Grid;
use crate::resample::{locate, offset_to, rebuild, shifted_place};
use glam::Vec3;

/// A grid frame and the input frame it was resampled from.
pub struct FitFrame<'a> {
    pub grid: &'a [Vec3],
    pub input: &'a [Vec3],
}

/// The candidate moves, in cells along each axis.
const STEPS: [f64; 5] = [-1.0, -0.5, 0.0, 0.5, 1.0];

/// New places for the vertices not in `fixed` (loose vertices, vertices no
/// face uses): `places` as the parameterization gave them, `reference` the
/// reference input frame and `reference_grid` its grid frame.
pub fn fit_places(
    grid: Grid,
    places: &[[u32; 2]],
    fixed: &[bool],
    (reference, reference_grid): (&[Vec3], &[Vec3]),
    choosing: &[FitFrame],
    checking: &[FitFrame],
) -> Vec<[u32; 2]> {
    use rayon::prelude::*;
    if choosing.is_empty() || checking.is_empty() {
        return places.to_vec();
    }
    let cell = (1i64 << 32) / grid.n as i64;
    places
        .par_iter()
        .enumerate()
        .map(|(v, &own)| {
            if fixed.get(v).copied().unwrap_or(true) || v >= reference.len() {
                return own;
            }
            let errors =
                |q: [u32; 2], frames: &[FitFrame]| place_errors(grid, q, v, (reference, reference_grid), frames);
            let mut best = (errors(own, choosing).0, own);
            for dx in STEPS {
                for dy in STEPS {
                    if dx == 0.0 && dy == 0.0 {
                        continue;
                    }
                    let by = |d: f64| (d * cell as f64) as i64;
                    let (Some(x), Some(y)) = (shifted_place(own[0], by(dx)), shifted_place(own[1], by(dy))) else {
                        continue;
                    };
                    let e = errors([x, y], choosing).0;
                    if e < best.0 {
                        best = (e, [x, y]);
                    }
                }
            }
            if best.1 == own {
                return own;
            }
            let (mine, theirs) = (errors(own, checking), errors(best.1, checking));
            if theirs.0 < mine.0 && theirs.1 <= mine.1 {
                best.1
            } else {
                own
            }
        })
        .collect()
}

/// (sum of squares, max) of vertex `v`'s distance from where the place `q`
/// (with its offset measured on the reference frame) rebuilds it, over
/// `frames`.
fn place_errors(
    grid: Grid,
    q: [u32; 2],
    v: usize,
    (reference, reference_grid): (&[Vec3], &[Vec3]),
    frames: &[FitFrame],
) -> (f32, f32) {
    let (corners, bary) = locate(grid, q);
    let offset = offset_to(reference_grid, corners, bary, reference[v]);
    frames.iter().fold((0.0, 0.0), |(sum, max), f| {
        let d = f.input.get(v).map_or(0.0, |x| rebuild(f.grid, corners, bary, offset).distance(*x));
        (sum + d * d, max.max(d))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat sheet on the grid's lattice that, in the later frames, bends
    /// along x = 0.3 (a hinge between grid columns): a vertex just past
    /// the hinge, whose own triangle straddles it, is better rebuilt from a
    /// triangle wholly on its side.
    #[test]
    fn a_vertex_by_a_hinge_moves_to_a_triangle_on_its_side() {
        let grid = Grid::new(8).unwrap();
        let sample = |i: usize| {
            let (a, b) = (i % 8, i / 8);
            // Sample (a, b) at the centre of its cell of [-1, 1]^2.
            ((a as f32 + 0.5) / 4.0 - 1.0, (b as f32 + 0.5) / 4.0 - 1.0)
        };
        let bend = |x: f32, y: f32, angle: f32| {
            if x <= 0.3 {
                Vec3::new(x, y, 0.0)
            } else {
                Vec3::new(0.3 + (x - 0.3) * angle.cos(), y, (x - 0.3) * angle.sin())
            }
        };
        let grid_frame = |angle: f32| (0..64).map(sample).map(|(x, y)| bend(x, y, angle)).collect::<Vec<_>>();
        // The vertex sits at x = 0.32 (past the hinge), y = 0.1, on the sheet.
        let q = [
            crate::format::source_mesh::quantize_place(0.32) >> 16 << 16,
            crate::format::source_mesh::quantize_place(0.1) >> 16 << 16,
        ];
        let uv = (crate::format::source_mesh::place(q[0]) as f32, crate::format::source_mesh::place(q[1]) as f32);
        let input = |angle: f32| vec![bend(uv.0, uv.1, angle)];
        let (g0, i0) = (grid_frame(0.0), input(0.0));
        let frames: Vec<(Vec<Vec3>, Vec<Vec3>)> =
            [0.8f32, 1.0, 1.2, 1.4].iter().map(|&a| (grid_frame(a), input(a))).collect();
        let fit = |r: std::ops::Range<usize>| -> Vec<FitFrame> {
            frames[r].iter().map(|(g, i)| FitFrame { grid: g, input: i }).collect()
        };
        let (choosing, checking) = (fit(0..2), fit(2..4));
        let own_error = place_errors(grid, q, 0, (&i0, &g0), &checking);
        let moved = fit_places(grid, &[q], &[false], (&i0, &g0), &choosing, &checking);
        assert_ne!(moved[0], q, "the vertex keeps a place whose triangle straddles the hinge");
        let new_error = place_errors(grid, moved[0], 0, (&i0, &g0), &checking);
        assert!(new_error.1 < 0.5 * own_error.1, "{new_error:?} against {own_error:?}");
        // A fixed vertex, or no frames to check against, keeps its place.
        assert_eq!(fit_places(grid, &[q], &[true], (&i0, &g0), &choosing, &checking), vec![q]);
        assert_eq!(fit_places(grid, &[q], &[false], (&i0, &g0), &choosing, &[]), vec![q]);
        // On the reference frame itself every place is exact.
        let rest = [FitFrame { grid: &g0, input: &i0 }];
        assert!(place_errors(grid, moved[0], 0, (&i0, &g0), &rest).1 < 1e-5);
    }
}

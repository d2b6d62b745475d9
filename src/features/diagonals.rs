//! Which way a registered capture's grid is turned, for
//! [`register`](super::register): the grid mesh splits every quad along
//! the same diagonal (`Grid::topology`), and a quarter turn of the square
//! lays that diagonal the other way across the body. The orbifold map
//! (Aigerman and Lipman 2015) is not alike both ways: at N = 128 the
//! uncompressed grid of samba's first frame lies 0.040 % of the diagonal
//! from its surface one way and 0.134 % the other, horse-gallop's 0.039
//! and 0.057, pcow's 0.093 and 0.139 (the registered motion's own map,
//! whose race, scored on the grid, kept the better way each time).
//! A capture's turn is otherwise set by the order its cones' cut paths
//! leave the corner (any of the four), so half its pieces got the worse
//! way: samba's first 60 frames resampled at 0.056 % where its first 24,
//! turned the other way, took 0.035.

use super::capture::CaptureFrame;
use super::outliers::resampling_error;
use super::symmetry::{apply_symmetry, Symmetry, TURNS};
use crate::error::Result;
use crate::grid::Grid;
use glam::Vec3;
use rayon::prelude::*;

/// Frames of a piece the two ways are scored on: its first, middle and
/// last.
const SCORED: usize = 3;

/// The two turns of the square (the identity and the half turn, or the
/// two quarter turns) that lay the grid's diagonals the way whose grids
/// (`grids`, one per frame of `frames`) lie nearer the frames' own meshes:
/// the mean symmetric surface RMS over [`SCORED`] frames.
pub fn better_turns(grid: Grid, frames: &[CaptureFrame], grids: &[Vec<Vec3>]) -> Result<[Symmetry; 2]> {
    let (straight, quarter) = ([TURNS[0], TURNS[2]], [TURNS[1], TURNS[3]]);
    let last = frames.len().min(grids.len()).saturating_sub(1);
    let mut scored: Vec<usize> = (0..SCORED).map(|i| i * last / (SCORED - 1)).collect();
    scored.dedup();
    let faces = grid.topology().faces;
    let far = |m: Symmetry| -> Result<f64> {
        let each: Vec<f64> = scored
            .par_iter()
            .map(|&t| resampling_error(&frames[t], &apply_symmetry(grid, &grids[t], m), &faces))
            .collect::<Result<_>>()?;
        Ok(each.iter().sum())
    };
    Ok(if far(quarter[0])? < far(straight[0])? { quarter } else { straight })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sheet folded along one diagonal of every quad (its height
    /// alternates across the other) is its own mesh where the grid's
    /// split runs along the folds, and far from it where a quarter turn
    /// lays the split across them: the turns that lay it along are chosen
    /// whichever way the grid came.
    #[test]
    fn the_diagonals_are_laid_along_the_ridges() {
        let grid = Grid::new(8).unwrap();
        let n = grid.n;
        // Ridges along (1, 1), the (0, 2) diagonal of each quad: height
        // alternates with i - j.
        let sheet: Vec<Vec3> = (0..n * n)
            .map(|s| {
                let (i, j) = ((s % n) as f32, (s / n) as f32);
                Vec3::new(i, j, if (s % n + s / n) % 2 == 0 { 0.0 } else { 1.0 })
            })
            .collect();
        let faces = grid.topology().faces;
        let frame = CaptureFrame { positions: sheet.clone(), faces: faces.clone() };
        let frames = vec![frame.clone(), frame];
        let straight = better_turns(grid, &frames, &[sheet.clone(), sheet.clone()]).unwrap();
        assert_eq!(straight, [TURNS[0], TURNS[2]]);
        // The same sheet come turned by a quarter: the quarter turns lay
        // it straight again.
        let turned = apply_symmetry(grid, &sheet, TURNS[1]);
        let quarter = better_turns(grid, &frames, &[turned.clone(), turned]).unwrap();
        assert_eq!(quarter, [TURNS[1], TURNS[3]]);
    }
}

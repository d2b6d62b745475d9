//! Frames whose grid resamples their own mesh far worse than the capture's
//! usual frame, which the jump finder ([`jumps::found`]) does not see: a
//! map that stays where its neighbours' are yet leaves part of the body
//! thinly sampled. No truth is needed to find them: their grid lies far
//! from their own mesh. Each is rebuilt from its steady neighbours
//! ([`jumps::bridged`]), and the new grid kept only where it lies closer
//! to the mesh (pcow's 204 frames, after the jump finder's fixes: 1-3
//! frames, each slightly closer).

use super::capture::{Capture, CaptureFrame};
use super::jumps;
use super::store::FrameStore;
use crate::error::Result;
use crate::grid::Grid;
use crate::metrics::surface::symmetric_rms;
use glam::Vec3;
use rayon::prelude::*;

/// How far (symmetric surface RMS) each frame's grid lies from the
/// frame's own mesh.
pub fn resampling_errors(frames: &[CaptureFrame], grids: &[Vec<Vec3>], grid: Grid) -> Result<Vec<f64>> {
    let faces = grid.topology().faces;
    frames.par_iter().zip(grids).map(|(f, g)| resampling_error(f, g, &faces)).collect()
}

/// How far one frame's grid (`g`, on the grid's `faces`) lies from the
/// frame's own mesh.
pub(super) fn resampling_error(f: &CaptureFrame, g: &[Vec3], faces: &[[u32; 3]]) -> Result<f64> {
    symmetric_rms(&f.positions, &f.faces, g, faces)
}

/// A frame is an outlier where its grid lies further from its mesh than
/// this many times the capture's median frame's (the swim target:
/// the worst frame at most 3x the mean).
pub const OUTLIER: f64 = 3.0;

/// The outlying frames of `capture` (registered in `store`, in pieces
/// that start at `starts`, each with its own map) rebuilt from their
/// neighbours in the same piece: between the steady frames around them,
/// or carried on from the frame before where the piece has no steady
/// frame after, or from the frame after where it has none before. A piece
/// that is all outliers is carried on from the last frame of the piece
/// before. `errors`: how far each frame's grid lies from its mesh
/// ([`resampling_errors`]), updated as frames are rebuilt. Returns how many
/// frames took their rebuilt grid.
pub fn rebuilt(
    grid: Grid,
    capture: &dyn Capture,
    starts: &[usize],
    store: &mut dyn FrameStore,
    errors: &mut [f64],
) -> Result<usize> {
    let n = capture.len();
    if errors.len() != n || store.len() != n {
        return Err(crate::error::Error::Argument(format!(
            "the resampling errors of {} frames and the grids of {} for {n}",
            errors.len(),
            store.len()
        )));
    }
    let mut sorted = errors.to_vec();
    sorted.sort_by(f64::total_cmp);
    let limit = OUTLIER * sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    let first: Vec<bool> = errors.iter().map(|&e| e <= limit).collect();
    let (mut steady, mut tried) = (first.clone(), vec![false; n]);
    let piece = |t: usize| {
        let p = starts.iter().rposition(|&s| s <= t).unwrap_or(0);
        (starts.get(p).copied().unwrap_or(0), starts.get(p + 1).copied().unwrap_or(n))
    };
    let mut count = 0;
    // Forward: each outlier with a steady frame just before it, in its
    // piece or, for a piece of outliers only, in the piece before.
    for t in 0..n {
        let (s, e) = piece(t);
        let whole = (s..e).all(|k| !first[k]);
        let before = (t > s || (whole && t > 0)).then(|| t - 1).filter(|&k| steady[k]);
        let Some(b) = before.filter(|_| !steady[t]) else { continue };
        let after = (t + 1..e).find(|&k| steady[k]).filter(|_| b >= s);
        steady[t] = rebuild(grid, capture, store, errors, t, (Some(b), after))?;
        (tried[t], count) = (true, count + usize::from(steady[t]));
    }
    // Backward: the outliers that open their piece, from the frame after.
    for t in (0..n.saturating_sub(1)).rev() {
        if !steady[t] && !tried[t] && t + 1 < piece(t).1 && steady[t + 1] {
            steady[t] = rebuild(grid, capture, store, errors, t, (None, Some(t + 1)))?;
            count += usize::from(steady[t]);
        }
    }
    Ok(count)
}

/// Frame `t`'s grid rebuilt from `before` and `after` (frame indices),
/// kept where it lies closer to the frame's mesh; whether it was kept.
fn rebuild(
    grid: Grid,
    capture: &dyn Capture,
    store: &mut dyn FrameStore,
    errors: &mut [f64],
    t: usize,
    (before, after): (Option<usize>, Option<usize>),
) -> Result<bool> {
    let frame = capture.frames(t..t + 1)?;
    let f = &frame[0];
    let side = |k: Option<usize>| k.map(|k| store.grid(k).map(|g| (k, g.into_owned()))).transpose();
    let (before, after) = (side(before)?, side(after)?);
    let before = before.as_ref().map(|(k, g)| (*k, g.as_slice()));
    let after = after.as_ref().map(|(k, g)| (*k, g.as_slice()));
    let (g, places) = jumps::bridged(grid, t, before, after, &f.positions, &f.faces)?;
    if g.is_empty() {
        return Ok(false);
    }
    let e = resampling_error(f, &g, &grid.topology().faces)?;
    if e >= errors[t] {
        return Ok(false);
    }
    store.replace(t, g, places)?;
    errors[t] = e;
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::store::Registered;
    use std::path::Path;

    /// A curved 6 x 6 patch moving along x, captured as the grid's own
    /// mesh, with its grids on the mesh except those of `off` (lifted off
    /// it by half its width); pieces start at `starts`.
    fn case(frames: usize, off: &[usize], starts: &[usize]) -> (usize, Vec<f64>, Vec<f64>) {
        let grid = Grid::new(6).unwrap();
        let faces = grid.topology().faces;
        let at = |t: usize, lift: f32| -> Vec<Vec3> {
            let x = |k: usize| (k % 6) as f32 * 0.2 + 0.05 * t as f32;
            (0..36).map(|k| Vec3::new(x(k), (k / 6) as f32 * 0.2, 0.3 * ((k % 6) as f32).sin() + lift)).collect()
        };
        let capture: Vec<CaptureFrame> =
            (0..frames).map(|t| CaptureFrame { positions: at(t, 0.0), faces: faces.clone() }).collect();
        let grids: Vec<Vec<Vec3>> = (0..frames).map(|t| at(t, if off.contains(&t) { 0.5 } else { 0.0 })).collect();
        let mut store = Registered::empty(Path::new("patch"), 30.0, grid);
        for (g, f) in grids.iter().zip(&capture) {
            store.push(g.clone(), f.mesh()).unwrap();
        }
        let before = resampling_errors(&capture, &grids, grid).unwrap();
        let mut errors = before.clone();
        let count = rebuilt(grid, &capture.as_slice(), starts, &mut store, &mut errors).unwrap();
        let grids = store.grid.frames;
        // A rebuilt frame's vertices are placed on its new grid.
        let placed: Vec<usize> = store.meshes.iter().map(|m| m.places.len()).collect();
        assert!(
            placed.iter().enumerate().all(|(t, &p)| p == if off.contains(&t) { 36 } else { 0 }),
            "{off:?}: {placed:?}"
        );
        // The errors it updates are each frame's as it now is.
        let after = resampling_errors(&capture, &grids, grid).unwrap();
        assert_eq!(errors, after);
        (count, before, after)
    }

    /// Outlying frames are rebuilt onto their mesh: one between steady
    /// frames, a run that ends its piece, one that opens its piece, and a
    /// piece of outliers only (carried on from the piece before); steady
    /// frames are left as they are.
    #[test]
    fn frames_far_from_their_mesh_are_rebuilt_from_their_neighbours() {
        let cases =
            [(vec![3], vec![0]), (vec![10, 11], vec![0]), (vec![6], vec![0, 6]), (vec![8, 9, 10, 11], vec![0, 8])];
        for (off, starts) in cases {
            let (count, before, after) = case(12, &off, &starts);
            assert_eq!(count, off.len(), "{off:?} {starts:?}: {before:?} -> {after:?}");
            for t in 0..12 {
                match off.contains(&t) {
                    true => assert!(
                        before[t] > 0.2 && after[t] < 0.02,
                        "{off:?} {starts:?} frame {t}: {before:?} -> {after:?}"
                    ),
                    false => assert_eq!(before[t], after[t]),
                }
            }
        }
    }
}

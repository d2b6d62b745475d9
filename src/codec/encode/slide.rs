//! The closed loop's target slid along the surface to the prediction, for
//! a grid motion that carries no correspondence (an unregistered capture
//! registered on the grid, `crate::features::register`): there only the
//! surface is the truth, not where a sample lies on it.
//!
//! Each frame's own map puts its samples a little elsewhere on the body
//! (the capture's "jitter", 0.5-0.7 % of the diagonal a frame on
//! horse-gallop and pcow, docs/RESULTS.md), and the closed loop would
//! spend its corrections on moving samples along the surface where the
//! prediction already lies on it. So the encoder's target for a sample is
//! the point of the frame's own mesh nearest the predicted sample, within
//! [`LEASH`] grid steps of where the registration put it, so that no slide
//! can build up from frame to frame. The slides are smoothed over the grid
//! ([`SMOOTHING`]) and put back on the mesh: each sample chasing its own
//! prediction leaves the grid's spacing ragged. The frame's own mesh, not
//! the grid's: a point slid along the grid mesh lies on its chords, below
//! the surface by the grid's own sag (the walk at N = 64: 0.011-0.017 % of
//! the diagonal off). The decoder does not change: it never knew the
//! target. (The normal meshes of Guskov et al. 2000 drop the tangential
//! part likewise; here it is dropped before the corrections are made, as
//! the normal picture, `crate::codec::corrections`, drops what is left
//! of it after.)

use super::EncodeOptions;
use crate::error::{Error, Result};
use crate::grid::Stencils;
use crate::mesh::{FrameMesh, FrameSource};
use glam::Vec3;
use parry3d::query::PointQuery;
use parry3d::shape::TriMesh;
use rayon::prelude::*;

/// How far a sample may slide from where the registration put it, in its
/// own grid steps (its mean distance to its four neighbours). Measured on
/// the remeshed horse-gallop clip (N = 128, 24 frames, b/v/f and surface
/// RMS % at QP 16 / 28 / 34, not slid: 10.00, 0.093 / 3.09, 0.162 / 1.71,
/// 0.242): 0.5 (4 passes) 9.31, 0.095 / 2.90, 0.163 / 1.62, 0.246; 1 (4
/// passes) 8.80, 0.118 / 2.65, 0.174 / 1.53, 0.249; 2 (4 passes) 9.32,
/// 0.231 / 2.65, 0.257 / 1.54, 0.304: the registration's samples jump
/// about a step a frame, and a sample slid further leaves its neighbours'.
pub const LEASH: f32 = 1.0;

/// Averaging passes over the slides (each sample's move from its place).
/// With a leash of 1, on the same clip: 4 passes (above); 16 passes 9.46,
/// 0.100 / 2.88, 0.161 / 1.61, 0.239; 64 passes 9.78, 0.095 / 3.01, 0.161
/// / 1.62, 0.243.
pub const SMOOTHING: usize = 16;

/// A frame's own mesh, prepared for nearest-point queries (as
/// `crate::metrics::surface::Target`, which the codec is below).
pub struct Surface {
    mesh: TriMesh,
}

impl Surface {
    /// Frame `fi`'s own mesh, prepared, where `opts` slide the samples;
    /// an error where they do and `src` has no mesh of the frame's own.
    pub fn of_frame(src: &dyn FrameSource, opts: &EncodeOptions, fi: usize) -> Result<Option<Surface>> {
        if !opts.slides(fi) {
            return Ok(None);
        }
        let mesh = src.frame_mesh(fi)?.ok_or_else(|| {
            Error::Argument(format!(
                "{}, frame {fi}: sliding the samples needs each frame's own mesh (an unregistered capture)",
                src.label().display()
            ))
        })?;
        Surface::new(&mesh).map(Some)
    }

    pub fn new(frame: &FrameMesh) -> Result<Surface> {
        let mesh = TriMesh::new(frame.positions.clone(), frame.faces.clone())
            .map_err(|e| Error::Numerical(format!("a frame's own mesh for the slide: {e:?}")))?;
        Ok(Surface { mesh })
    }

    /// The point of the mesh nearest `p` if one lies within `reach`.
    fn nearest_within(&self, p: Vec3, reach: f32) -> Option<Vec3> {
        self.mesh.project_local_point_with_max_dist(p, false, reach).map(|q| q.point)
    }
}

/// Each sample of `truth` (a grid frame of `st`'s grid, on `surface`)
/// slid towards `pred`'s: moved to the point of `surface` nearest its
/// prediction where that lies within [`LEASH`] grid steps of the sample,
/// the moves smoothed over the grid, and put back on the surface.
pub fn slid(st: &Stencils, truth: &[Vec3], pred: &[Vec3], surface: &Surface) -> Vec<Vec3> {
    let reach: Vec<f32> = (0..truth.len()).map(|s| LEASH * step(st, truth, s)).collect();
    let near = onto(surface, truth, pred, &reach);
    let moves: Vec<Vec3> = near.iter().zip(truth).map(|(a, b)| *a - *b).collect();
    let moves = st.smooth(moves, SMOOTHING);
    let wanted: Vec<Vec3> = truth.iter().zip(&moves).map(|(p, d)| *p + *d).collect();
    onto(surface, truth, &wanted, &reach)
}

/// Sample `s`'s mean distance to its four grid neighbours.
fn step(st: &Stencils, x: &[Vec3], s: usize) -> f32 {
    st.nbr[s].iter().map(|&k| x[s].distance(x[k as usize])).sum::<f32>() / 4.0
}

/// Each `wanted` point put on `surface`, where its nearest point there lies
/// within `reach` of the sample of `truth`; else the sample. The search
/// goes no further from the point than the sample (on the surface) lies.
fn onto(surface: &Surface, truth: &[Vec3], wanted: &[Vec3], reach: &[f32]) -> Vec<Vec3> {
    (0..truth.len())
        .into_par_iter()
        .map(|s| {
            let bound = wanted[s].distance(truth[s]) * (1.0 + 1e-4) + f32::EPSILON * truth[s].length();
            let q = surface.nearest_within(wanted[s], bound);
            q.filter(|q| q.distance(truth[s]) <= reach[s]).unwrap_or(truth[s])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The walk's registered grid: each frame slid towards its velocity
    /// prediction stays on the frame's surface: its grid mesh is as close to
    /// the frame's own mesh as the registered grid's.
    #[test]
    fn slid_frames_stay_on_their_surface() {
        use crate::mesh::{Bounds, FrameSource};
        use crate::metrics::surface::symmetric;
        let walk = crate::mesh::builtin::motion(6);
        let opts = super::super::EncodeOptions { grid: 64, ..Default::default() };
        let image = crate::codec::prepare(&walk, &opts).unwrap();
        let grid = image.map.grid;
        let st = Stencils::new(grid);
        let faces = grid.topology().faces;
        let g: Vec<Vec<Vec3>> = (0..6).map(|t| image.map.apply(&walk.read_frame(t).unwrap())).collect();
        let diag = Bounds::of(&g[0]).diagonal() as f64;
        for t in 2..6 {
            let pred: Vec<Vec3> = g[t - 1].iter().zip(&g[t - 2]).map(|(a, b)| 2.0 * *a - *b).collect();
            let own = FrameMesh {
                positions: walk.read_frame(t).unwrap(),
                faces: walk.topology().faces.clone(),
                places: vec![],
            };
            let s = slid(&st, &g[t], &pred, &Surface::new(&own).unwrap());
            let off = |x: &[Vec3]| symmetric(&own.positions, &own.faces, x, &faces).unwrap().rms / diag;
            let moved = s.iter().zip(&g[t]).map(|(a, b)| a.distance(*b) as f64).sum::<f64>() / s.len() as f64 / diag;
            println!("frame {t}: slid {:.6}, registered {:.6}, moved {moved:.6}", off(&s), off(&g[t]));
            assert!(off(&s) <= 1.02 * off(&g[t]) && moved > 1e-4, "frame {t}");
            // No sample further from its place than the leash.
            assert!((0..s.len()).all(|k| s[k].distance(g[t][k]) <= LEASH * step(&st, &g[t], k) * 1.0001));
        }
    }
}

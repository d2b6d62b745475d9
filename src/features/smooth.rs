//! A registered capture's grid smoothed in time. A frame mapped on its own
//! (the seed paper, section 4.2) swims: with the same four cones, even on
//! the same triangulation, the map of a body that moves not quite
//! isometrically (a dress, muscles) puts samba's samples 0.4-0.6 % of the
//! diagonal elsewhere on the body from frame to frame, and the closed
//! loop, which predicts each sample from its past, pays for that jitter as
//! motion. Each pass moves a sample halfway to the midpoint of its places
//! in the frames before and after, then onto the frame's surface (its
//! nearest point there), so that it slides along the surface only. Where
//! the body moves fast the midpoint falls off the surface (a galloping
//! leg's) and would land on another part: a sample whose midpoint lies
//! further than [`OFF_SURFACE`] from the surface keeps its place, and a
//! frame whose grid then resamples its surface more than [`WORSE`] times
//! as far off keeps its own grid.

use crate::error::Result;
use crate::metrics::surface::{symmetric, Target};
use glam::Vec3;
use rayon::prelude::*;

/// Passes over the frames. Measured on samba's 24-frame capture: at N =
/// 128, 3 passes took the grid's speed from 0.3-0.8 % of the diagonal a
/// frame to 0.1-0.6 and the coded error at QP 34 from 0.104 to 0.050 %
/// (2.75 bits a vertex a frame against 1.55; the registered motion's
/// 0.047 at 2.37); at N = 256, 6 passes (with [`WORSE`] 1.3) took it from
/// 0.048 % at 5.75 bits to 0.030 at 7.38, within 1.4x of the registered
/// motion's at equal bits where 3 passes (and 1.05) were 1.7-1.9x.
pub const PASSES: usize = 6;
/// How far (a fraction of the diagonal) a midpoint may lie off the
/// surface and still move its sample.
pub const OFF_SURFACE: f32 = 0.003;
/// A frame whose smoothed grid resamples its surface this many times
/// worse (surface RMS) than its own keeps its own. No horse-gallop frame
/// takes the smoothed grid even at 1.3 (forced on all of them, the coded
/// error at equal bits is the same); pcow's 20 of 22 frames that take it
/// cost about 4 % more error at equal bits than 12 did at 1.05.
pub const WORSE: f64 = 1.3;

/// A frame's own mesh: its positions and faces.
pub type Surface<'a> = (&'a [Vec3], &'a [[u32; 3]]);

/// `grids` (one per frame of `surfaces`, on the grid's `faces`) smoothed
/// in time; returns how many frames took the smoothed grid. `diagonal`:
/// the capture's.
pub fn smooth(grids: &mut [Vec<Vec3>], surfaces: &[Surface], faces: &[[u32; 3]], diagonal: f32) -> Result<usize> {
    if grids.len() < 3 {
        return Ok(0);
    }
    let own: Vec<Vec<Vec3>> = grids.to_vec();
    // Each inner frame's surface, built once for all the passes.
    let targets: Vec<Target> =
        surfaces[1..grids.len() - 1].iter().map(|s| Target::new(s.0, s.1)).collect::<Result<_>>()?;
    for _ in 0..PASSES {
        // The frame before as it was before this pass.
        let mut before = grids[0].clone();
        for t in 1..grids.len() - 1 {
            let (p, q) = (&grids[t], &grids[t + 1]);
            let target = &targets[t - 1];
            let moved: Vec<Vec3> = (0..p.len())
                .into_par_iter()
                .map(|i| {
                    let goal = p[i] + ((before[i] + q[i]) * 0.5 - p[i]) * 0.5;
                    let on = target.nearest_point(goal);
                    if on.distance(goal) > OFF_SURFACE * diagonal {
                        p[i]
                    } else {
                        on
                    }
                })
                .collect();
            before = std::mem::replace(&mut grids[t], moved);
        }
    }
    let mut kept = 0;
    for t in 1..grids.len() - 1 {
        let (positions, frame_faces) = surfaces[t];
        let smoothed = symmetric(positions, frame_faces, &grids[t], faces)?.rms;
        let mapped = symmetric(positions, frame_faces, &own[t], faces)?.rms;
        if smoothed > WORSE * mapped {
            grids[t] = own[t].clone();
        } else {
            kept += 1;
        }
    }
    Ok(kept)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat square sampled by a 5 x 5 grid that jitters along the plane
    /// from frame to frame: smoothed, the samples stay on the plane and
    /// move less from frame to frame.
    #[test]
    fn jitter_along_the_surface_is_smoothed_and_stays_on_it() {
        let plane: Vec<Vec3> = vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(2.0, -1.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
            Vec3::new(-1.0, 2.0, 0.0),
        ];
        let plane_faces = vec![[0, 1, 2], [0, 2, 3]];
        let grid_faces: Vec<[u32; 3]> = (0..4u32)
            .flat_map(|y| {
                (0..4u32).flat_map(move |x| {
                    let v = y * 5 + x;
                    [[v, v + 1, v + 6], [v, v + 6, v + 5]]
                })
            })
            .collect();
        let mut grids: Vec<Vec<Vec3>> = (0..8)
            .map(|t| {
                let jitter = if t % 2 == 0 { 0.02 } else { -0.02 };
                (0..25).map(|i| Vec3::new((i % 5) as f32 * 0.25 + jitter, (i / 5) as f32 * 0.25, 0.0)).collect()
            })
            .collect();
        let speed = |g: &[Vec<Vec3>]| -> f32 { g.windows(2).map(|w| w[1][12].distance(w[0][12])).sum() };
        let before = speed(&grids);
        let surfaces: Vec<Surface> = (0..8).map(|_| (plane.as_slice(), plane_faces.as_slice())).collect();
        let kept = smooth(&mut grids, &surfaces, &grid_faces, 4.0).unwrap();
        assert_eq!(kept, 6);
        assert!(speed(&grids) < 0.5 * before, "{} against {before}", speed(&grids));
        assert!(grids.iter().flatten().all(|p| p.z.abs() < 1e-6));
    }
}

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
//!
//! Such a frame (every frame of a galloping horse or a walking cow) is
//! then filtered once along the surface (`Window::AlongSurface`): each sample
//! moved to a quadratic's value at the frame, fitted to its places in the
//! two frames before and after (Savitzky and Golay's 5-point smoothing, A.
//! Savitzky and M. J. E. Golay, Anal. Chem. 36(8), 1964, table I), which a
//! steadily accelerating limb keeps, but with the move's component along
//! the grid's normal dropped, so that it slides on the surface.

use crate::error::Result;
use crate::metrics::surface::{symmetric_rms_to, Target};
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
/// takes the passes' grid even at 1.3 (forced on all of them, the coded
/// error at equal bits is the same), nor any of pcow's since its cones
/// were chosen anew (forced: its map's floor 0.055 -> 0.123 %); those are
/// filtered along the surface instead (`Window::AlongSurface`), under the same
/// allowance.
pub const WORSE: f64 = 1.3;

/// A frame's own mesh: its positions and faces.
pub type Surface<'a> = (&'a [Vec3], &'a [[u32; 3]]);

/// `grids` (one per frame of `surfaces`, on the grid's `faces`) smoothed
/// in time; returns how many frames took a smoothed grid (the passes' or
/// the filter's). `diagonal`: the capture's.
pub fn smooth(grids: &mut [Vec<Vec3>], surfaces: &[Surface], faces: &[[u32; 3]], diagonal: f32) -> Result<usize> {
    if grids.len() < 3 {
        return Ok(0);
    }
    let own: Vec<Vec<Vec3>> = grids.to_vec();
    // Each inner frame's surface, built once for all the passes.
    let targets: Vec<Target> =
        surfaces[1..grids.len() - 1].iter().map(|s| Target::new(s.0, s.1)).collect::<Result<_>>()?;
    let inner: Vec<usize> = (1..grids.len() - 1).collect();
    for _ in 0..PASSES {
        windowed(grids, &targets, faces, diagonal, &inner, Window::Midpoint);
    }
    // Each inner frame's own grid's resampling error, for both checks.
    let own_rms: Vec<f64> = inner
        .par_iter()
        .map(|&t| resampling(&own[t], faces, surfaces[t], &targets[t - 1], f64::INFINITY))
        .collect::<Result<_>>()?;
    let refused = keep_closer(grids, &own, &own_rms, (surfaces, &targets), faces, &inner)?;
    windowed(grids, &targets, faces, diagonal, &refused, Window::AlongSurface);
    let still = keep_closer(grids, &own, &own_rms, (surfaces, &targets), faces, &refused)?;
    Ok(grids.len() - 2 - still.len())
}

/// Each inner frame of `frames` whose grid resamples its surface more
/// than [`WORSE`] times as far off as its own grid (`own`, resampling at
/// `own_rms[t - 1]`) given its own back; returns those frames. `targets`:
/// the inner frames' surfaces, built once.
fn keep_closer(
    grids: &mut [Vec<Vec3>],
    own: &[Vec<Vec3>],
    own_rms: &[f64],
    (surfaces, targets): (&[Surface], &[Target]),
    faces: &[[u32; 3]],
    frames: &[usize],
) -> Result<Vec<usize>> {
    // Each measure stops once the grid is certainly refused (infinity).
    let allowed = |t: usize| WORSE * own_rms[t - 1];
    let smoothed: Vec<f64> = frames
        .par_iter()
        .map(|&t| resampling(&grids[t], faces, surfaces[t], &targets[t - 1], allowed(t)))
        .collect::<Result<_>>()?;
    let mut refused = Vec::new();
    for (&t, smoothed) in frames.iter().zip(smoothed) {
        if smoothed > allowed(t) {
            grids[t].clone_from(&own[t]);
            refused.push(t);
        }
    }
    Ok(refused)
}

/// How far a frame's grid lies from the frame's surface (symmetric surface
/// RMS), its query tree (`target`) already built; infinity once certainly
/// above `above`.
fn resampling(grid: &[Vec3], faces: &[[u32; 3]], surface: Surface, target: &Target, above: f64) -> Result<f64> {
    symmetric_rms_to((grid, faces), &|_| None, surface, target, (above, 1))
}

/// Savitzky-Golay's quadratic 5-point smoothing weights (sum 35).
const QUADRATIC_5: [f32; 5] = [-3.0, 12.0, 17.0, 12.0, -3.0];
/// Halfway to the midpoint of the frames before and after.
const HALFWAY_3: [f32; 3] = [1.0, 2.0, 1.0];

/// The two ways a frame is moved in time.
#[derive(Clone, Copy, PartialEq)]
enum Window {
    /// A midpoint pass: [`HALFWAY_3`], the whole move.
    Midpoint,
    /// The filter along the surface: [`QUADRATIC_5`] (or [`HALFWAY_3`]
    /// where a frame lacks two neighbours a side), the move's component
    /// along the grid's normal dropped.
    AlongSurface,
}

/// The inner frames `frames` (ascending) of `grids` moved once in time by
/// `window` and put back on the surface (`targets[t - 1]` is frame t's),
/// each from the grids as they were: a frame's new grid is written once no
/// later frame reads its old one, so at most three are held.
fn windowed(
    grids: &mut [Vec<Vec3>],
    targets: &[Target],
    faces: &[[u32; 3]],
    diagonal: f32,
    frames: &[usize],
    window: Window,
) {
    let mut pending: std::collections::VecDeque<(usize, Vec<Vec3>)> = std::collections::VecDeque::new();
    for &t in frames {
        while pending.front().is_some_and(|(u, _)| u + 2 < t) {
            if let Some((u, g)) = pending.pop_front() {
                grids[u] = g;
            }
        }
        let weights: &[f32] = match window {
            Window::AlongSurface if t >= 2 && t + 2 < grids.len() => &QUADRATIC_5,
            _ => &HALFWAY_3,
        };
        let along = window == Window::AlongSurface;
        let moved = moved_frame(grids, t, weights, along, &targets[t - 1], faces, diagonal);
        pending.push_back((t, moved));
    }
    for (u, g) in pending {
        grids[u] = g;
    }
}

/// Frame `t`'s samples moved to the `weights`' mean of their places in the
/// frames around it (`along`: the move's normal component dropped), then
/// onto the frame's surface; a sample whose goal lies further than
/// [`OFF_SURFACE`] from it keeps its place.
fn moved_frame(
    grids: &[Vec<Vec3>],
    t: usize,
    weights: &[f32],
    along: bool,
    target: &Target,
    faces: &[[u32; 3]],
    diagonal: f32,
) -> Vec<Vec3> {
    let (h, total) = (weights.len() / 2, weights.iter().sum::<f32>());
    let p = &grids[t];
    let normals = if along { crate::mesh::vertex_normals(p, faces) } else { Vec::new() };
    (0..p.len())
        .into_par_iter()
        .map(|i| {
            let mean: Vec3 = weights.iter().enumerate().map(|(k, w)| grids[t + k - h][i] * *w).sum::<Vec3>() / total;
            let d = mean - p[i];
            let goal = match normals.get(i) {
                Some(&n) => p[i] + d - n * d.dot(n),
                None => mean,
            };
            landed(target, p[i], goal, diagonal)
        })
        .collect()
}

/// A sample at `p` sent to `goal`: the surface's point nearest the goal,
/// or `p` itself where the goal lies further than [`OFF_SURFACE`] from the
/// surface (it would land on another part).
fn landed(target: &Target, p: Vec3, goal: Vec3, diagonal: f32) -> Vec3 {
    let on = target.nearest_point(goal);
    if on.distance(goal) > OFF_SURFACE * diagonal {
        p
    } else {
        on
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid on a plane that accelerates along it (a limb's swing, which
    /// the midpoint cuts short), with and without a jitter from frame to
    /// frame: filtered along the surface, where the 5-point window fits,
    /// the motion is kept exactly and the jitter falls to 13/35 of itself
    /// (the window's response to the fastest alternation); all stays on
    /// the plane.
    #[test]
    fn along_the_surface_a_quadratic_motion_is_kept_and_jitter_falls() {
        let plane = [
            Vec3::new(-10.0, -10.0, 0.0),
            Vec3::new(10.0, -10.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(-10.0, 10.0, 0.0),
        ];
        let plane_faces = [[0, 1, 2], [0, 2, 3]];
        let faces = crate::grid::Grid::new(4).unwrap().topology().faces;
        let targets: Vec<Target> = (1..8).map(|_| Target::new(&plane, &plane_faces).unwrap()).collect();
        let truth = |t: usize| 0.05 * (t * t) as f32;
        let at = |x: f32| -> Vec<Vec3> {
            (0..16).map(|i| Vec3::new((i % 4) as f32 * 0.3 + x, (i / 4) as f32 * 0.3, 0.0)).collect()
        };
        for amplitude in [0.0, 0.02] {
            let jitter = |t: usize| if t % 2 == 0 { amplitude } else { -amplitude };
            let mut grids: Vec<Vec<Vec3>> = (0..9).map(|t| at(truth(t) + jitter(t))).collect();
            windowed(&mut grids, &targets, &faces, 40.0, &(1..8).collect::<Vec<_>>(), Window::AlongSurface);
            for (t, g) in grids.iter().enumerate().take(7).skip(2) {
                let off = (g[5].x - at(truth(t))[5].x).abs();
                assert!(off < amplitude * 13.0 / 35.0 + 1e-4, "frame {t}, jitter {amplitude}: {off}");
            }
            assert!(grids.iter().flatten().all(|p| p.z.abs() < 1e-6));
        }
    }

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

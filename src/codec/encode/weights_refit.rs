//! The skin weights refitted for the grid the decoder uses them on. SSDR
//! (Le and Deng 2012, section 4.1) fits each coarse sample's weights to
//! that sample's own motion; the decoder expands them bilinearly to every
//! grid sample (`crate::solve::skinned`), and where a coarse cell spans a
//! joint or a stretched part of the map the expansion blends bones that no
//! fine sample there follows. This is SSDR's weight update with the
//! expansion inside it: each coarse sample's weights (non-negative,
//! summing to one, the four largest kept) minimize the error of the
//! skinning of the fine samples they reach, the other coarse samples'
//! weights held (Gauss–Seidel sweeps), the transforms SSDR's own.

use crate::format::skin::INFLUENCES;
use crate::grid::{coarse, Grid};
use crate::skin::{nnls, BoneTransform};
use glam::Vec3;

/// Expansion coefficients below this are left out of a footprint.
const REACH: f32 = 1e-4;

/// The fine motion the refit reads: some fine samples (`samples`, grid
/// indices), their rest places and their places in each frame.
pub(super) struct FineMotion {
    pub samples: Vec<u32>,
    pub rest: Vec<Vec3>,
    pub frames: Vec<Vec<Vec3>>,
}

type Influences = [(u16, f32); INFLUENCES];

/// Refits `weights` (on `coarse_grid`, expanded `shrink` times on the
/// decoder's grid) to `fine`, whose frame t the transforms `transforms[t]`
/// move; `sweeps` passes over the coarse samples.
pub(super) fn refit(
    coarse_grid: Grid,
    shrink: u8,
    weights: &mut [Influences],
    transforms: &[Vec<BoneTransform>],
    fine: &FineMotion,
    sweeps: usize,
) {
    let reach = footprints(coarse_grid, shrink, &fine.samples);
    let mut predicted = predict(weights, transforms, fine, &reach);
    for _ in 0..sweeps {
        for c in 0..weights.len() {
            let cand = candidates(coarse_grid, weights, c);
            let new = solve_sample(&reach[c], &cand, &weights[c], transforms, fine, &predicted);
            let Some(new) = new else { continue };
            for (t, p) in predicted.iter_mut().enumerate() {
                for &(k, beta) in &reach[c] {
                    let r = fine.rest[k as usize];
                    let old: Vec3 = weights[c].iter().map(|&(b, w)| w * transforms[t][b as usize].apply(r)).sum();
                    let now: Vec3 = new.iter().map(|&(b, w)| w * transforms[t][b as usize].apply(r)).sum();
                    p[k as usize] += beta * (now - old);
                }
            }
            weights[c] = new;
        }
    }
}

/// Each coarse sample's footprint among the fine samples: (index into
/// `samples`, expansion coefficient), by expanding its impulse.
fn footprints(coarse_grid: Grid, shrink: u8, samples: &[u32]) -> Vec<Vec<(u32, f32)>> {
    let fine_len = (coarse_grid.n << shrink).pow(2);
    let mut slot = vec![u32::MAX; fine_len];
    for (k, &s) in samples.iter().enumerate() {
        slot[s as usize] = k as u32;
    }
    let mut impulse = vec![0.0f32; coarse_grid.len()];
    (0..coarse_grid.len())
        .map(|c| {
            impulse[c] = 1.0;
            let field = coarse::expand(coarse_grid, &impulse, shrink);
            impulse[c] = 0.0;
            field
                .iter()
                .enumerate()
                .filter(|&(s, &b)| b > REACH && slot[s] != u32::MAX)
                .map(|(s, &b)| (slot[s], b))
                .collect()
        })
        .collect()
}

/// The expanded weights' skinning of every fine sample in every frame
/// (before the decoder's four-largest truncation).
fn predict(
    weights: &[Influences],
    transforms: &[Vec<BoneTransform>],
    fine: &FineMotion,
    reach: &[Vec<(u32, f32)>],
) -> Vec<Vec<Vec3>> {
    transforms
        .iter()
        .map(|m| {
            let mut p = vec![Vec3::ZERO; fine.samples.len()];
            for (inf, foot) in weights.iter().zip(reach) {
                for &(k, beta) in foot {
                    let r = fine.rest[k as usize];
                    p[k as usize] += beta * inf.iter().map(|&(b, w)| w * m[b as usize].apply(r)).sum::<Vec3>();
                }
            }
            p
        })
        .collect()
}

/// The bones of coarse sample `c` and of its four neighbours.
fn candidates(g: Grid, weights: &[Influences], c: usize) -> Vec<u16> {
    let (i, j) = ((c % g.n) as i64, (c / g.n) as i64);
    let mut cand: Vec<u16> = [(0, 0), (1, 0), (-1, 0), (0, 1), (0, -1)]
        .iter()
        .map(|&(di, dj)| g.canonical_index(i + di, j + dj) as usize)
        .flat_map(|n| weights[n].iter().filter(|p| p.1 > 0.0).map(|p| p.0))
        .collect();
    cand.sort_unstable();
    cand.dedup();
    cand
}

/// Coarse sample's new weights over `cand` (the four largest, solved
/// again if more were non-zero); `None` where its footprint is empty or
/// the solve gives nothing.
fn solve_sample(
    foot: &[(u32, f32)],
    cand: &[u16],
    old: &Influences,
    transforms: &[Vec<BoneTransform>],
    fine: &FineMotion,
    predicted: &[Vec<Vec3>],
) -> Option<Influences> {
    if foot.is_empty() || cand.is_empty() {
        return None;
    }
    nnls::influences(cand, |c| weights_over(foot, c, old, transforms, fine, predicted))
}

/// The non-negative weights over `cand` that best give the footprint's
/// frames, what the other coarse samples give held, with a heavy row
/// asking them to sum to one.
fn weights_over(
    foot: &[(u32, f32)],
    cand: &[u16],
    old: &Influences,
    transforms: &[Vec<BoneTransform>],
    fine: &FineMotion,
    predicted: &[Vec<Vec3>],
) -> Vec<f64> {
    let mut eq = nnls::NormalEquations::new(cand.len());
    let mut cols = vec![Vec3::ZERO; cand.len()];
    for (t, m) in transforms.iter().enumerate() {
        for &(k, beta) in foot {
            let (k, r) = (k as usize, fine.rest[k as usize]);
            let own: Vec3 = old.iter().map(|&(b, w)| w * m[b as usize].apply(r)).sum();
            for (col, &b) in cols.iter_mut().zip(cand) {
                *col = beta * m[b as usize].apply(r);
            }
            eq.add(&cols, fine.frames[t][k] - predicted[t][k] + beta * own);
        }
    }
    eq.solve_weights()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use glam::Mat3;

    /// A sheet whose right part turns about a joint narrower than a coarse
    /// cell, from weights that fit nothing (a half of each bone
    /// everywhere): the refit finds the joint, as close as the weights the
    /// truth has at the middle of each coarse cell, or closer.
    #[test]
    fn the_refit_finds_a_joint_through_the_expansion() {
        let (coarse_grid, shrink) = (Grid { n: 8 }, 2u8);
        let samples: Vec<u32> = (0..32 * 32).collect();
        let rest: Vec<Vec3> =
            samples.iter().map(|&s| Vec3::new((s % 32) as f32 / 32.0, (s / 32) as f32 / 32.0, 0.0)).collect();
        let joint = |x: f32| ((x - 0.47) / 0.06).clamp(0.0, 1.0);
        let transforms: Vec<Vec<BoneTransform>> = (0..6)
            .map(|t| {
                let r = Mat3::from_rotation_y(0.15 * t as f32);
                let pivot = Vec3::new(0.5, 0.0, 0.0);
                vec![BoneTransform::default(), BoneTransform { linear: r, translation: pivot - r * pivot }]
            })
            .collect();
        let frames: Vec<Vec<Vec3>> = transforms
            .iter()
            .map(|m| rest.iter().map(|&r| (1.0 - joint(r.x)) * m[0].apply(r) + joint(r.x) * m[1].apply(r)).collect())
            .collect();
        let fine = FineMotion { samples, rest, frames };
        let reach = footprints(coarse_grid, shrink, &fine.samples);
        let error = |w: &[Influences]| {
            let p = predict(w, &transforms, &fine, &reach);
            p.iter()
                .zip(&fine.frames)
                .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (*x - *y).length_squared()))
                .sum::<f32>()
        };
        let sampled: Vec<Influences> = (0..64)
            .map(|c| {
                let w = joint(((c % 8) as f32 * 4.0 + 1.5) / 32.0);
                [(0, 1.0 - w), (1, w), (0, 0.0), (0, 0.0)]
            })
            .collect();
        let mut weights = vec![[(0, 0.5), (1, 0.5), (0, 0.0), (0, 0.0)]; 64];
        let before = error(&weights);
        refit(coarse_grid, shrink, &mut weights, &transforms, &fine, 3);
        let after = error(&weights);
        assert!(after < 0.05 * before && after <= 1.01 * error(&sampled), "{before} -> {after} ({})", error(&sampled));
        for inf in &weights {
            let total: f32 = inf.iter().map(|p| p.1).sum();
            assert!((total - 1.0).abs() < 1e-4 && inf.iter().all(|p| p.1 >= 0.0), "{inf:?}");
        }
    }
}

//! Smooth skinning decomposition with rigid bones (Le and Deng 2012, "Smooth
//! skinning decomposition with rigid bones", ACM TOG 31(6); the method of
//! Electronic Arts' Dem Bones): fit B bones and at most four weights per
//! vertex to a whole motion by alternating
//!
//! 1. the weights, each vertex's own non-negative least-squares problem over
//!    its candidate bones with the weights summing to one (section 4.1),
//!    the four largest kept; and
//! 2. the transforms, each bone's weighted rigid fit to what the other
//!    bones leave of every frame (section 4.2), frames in parallel.
//!
//! It starts from rigid clustering (section 5; Kavan, Sloan and O'Sullivan
//! 2010): vertices grouped by their places in the rest pose, each group's
//! rigid motion fitted, each vertex moved to the group whose motion follows
//! it best, a few times. A vertex's candidate bones are those that move it
//! or its neighbours on the mesh, so a weight solve has a handful of
//! unknowns instead of B. (SSDR's Laplacian smoothing of the weights is not
//! done: the weights fit the motion alone.)

use super::{nnls, procrustes, BoneTransform, Skinning, INFLUENCES};
use crate::error::{Error, Result};
use glam::Vec3;
use rayon::prelude::*;

/// How to decompose.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SkinOptions {
    /// Bones (1 to 255: a compact file stores a bone in 8 bits).
    pub bones: usize,
    /// Alternations of weights and transforms after the clustering.
    pub iterations: usize,
    /// The frame that is the rest pose.
    pub rest: usize,
    /// Affine bones (any 3 x 3 matrix and a translation a frame) instead of
    /// rigid ones: less error for the same count, but glTF's joints cannot
    /// play them (they shear).
    pub affine: bool,
}

impl Default for SkinOptions {
    fn default() -> Self {
        SkinOptions { bones: 32, iterations: 20, rest: 0, affine: false }
    }
}

/// Rounds of rigid clustering before the alternation.
const CLUSTER_ROUNDS: usize = 3;
/// Frames the clustering looks at, spread over the motion (it only groups).
const CLUSTER_FRAMES: usize = 24;

/// The decomposition of `frames` (every frame the same vertices, `faces`
/// over them), with `report(iteration, vertex RMS)` after each alternation.
pub fn decompose(
    frames: &[Vec<Vec3>],
    faces: &[[u32; 3]],
    opts: &SkinOptions,
    report: &mut dyn FnMut(usize, f64),
) -> Result<Skinning> {
    let Some(rest) = frames.get(opts.rest) else {
        return Err(Error::Argument(format!("rest frame {} of a motion of {} frames", opts.rest, frames.len())));
    };
    let nv = rest.len();
    if frames.iter().any(|f| f.len() != nv) || nv == 0 {
        return Err(Error::Argument("the frames do not all have the same vertices".into()));
    }
    if !(1..=255).contains(&opts.bones) || opts.bones > nv {
        return Err(Error::Argument(format!("{} bones for {nv} vertices: 1 to 255, at most one a vertex", opts.bones)));
    }
    let neighbours = neighbours(nv, faces);
    let mut skin = cluster(frames, rest, opts.bones);
    for it in 0..opts.iterations {
        skin.influences = update_weights(frames, &skin, &neighbours);
        skin.transforms = update_transforms(frames, &skin, opts.affine);
        report(it + 1, rms(frames, &skin));
    }
    Ok(skin)
}

/// Root mean square distance between the frames and the skinning's.
pub fn rms(frames: &[Vec<Vec3>], skin: &Skinning) -> f64 {
    let sum: f64 = (0..frames.len())
        .into_par_iter()
        .map(|t| skin.frame(t).iter().zip(&frames[t]).map(|(a, b)| a.distance_squared(*b) as f64).sum::<f64>())
        .sum();
    (sum / (frames.len() * skin.rest.len()) as f64).sqrt()
}

/// Each vertex's neighbours on the mesh.
fn neighbours(nv: usize, faces: &[[u32; 3]]) -> Vec<Vec<u32>> {
    let mut n = vec![Vec::new(); nv];
    for f in faces {
        for k in 0..3 {
            let (a, b) = (f[k] as usize, f[(k + 1) % 3]);
            if a < nv && (b as usize) < nv && !n[a].contains(&b) {
                n[a].push(b);
                n[b as usize].push(a as u32);
            }
        }
    }
    n
}

/// Rigid clustering: groups by k-means on the rest pose (seeded by
/// farthest points), then each group's rigid motion fitted and each vertex
/// moved to the group that follows it best over [`CLUSTER_FRAMES`]
/// frames, [`CLUSTER_ROUNDS`] times. Every vertex one bone, weight one.
fn cluster(frames: &[Vec<Vec3>], rest: &[Vec3], bones: usize) -> Skinning {
    let mut label = kmeans(rest, bones);
    let picked: Vec<usize> =
        (0..CLUSTER_FRAMES.min(frames.len())).map(|k| k * frames.len() / CLUSTER_FRAMES.min(frames.len())).collect();
    let sub: Vec<Vec<Vec3>> = picked.iter().map(|&t| frames[t].clone()).collect();
    for _ in 0..CLUSTER_ROUNDS {
        let skin = single(rest, &label, bones, &sub);
        label = (0..rest.len())
            .into_par_iter()
            .map(|v| {
                let err = |b: usize| -> f32 {
                    sub.iter()
                        .enumerate()
                        .map(|(t, f)| skin.transforms[t][b].apply(rest[v]).distance_squared(f[v]))
                        .sum()
                };
                (0..bones).min_by(|&a, &b| err(a).total_cmp(&err(b))).unwrap_or(0) as u16
            })
            .collect();
        reseed_empty(&mut label, bones, rest);
    }
    let mut skin = single(rest, &label, bones, frames);
    skin.transforms = update_transforms(frames, &skin, false);
    skin
}

/// The skinning with one bone a vertex (`label`), each bone's transforms
/// fitted to its vertices over `frames`.
fn single(rest: &[Vec3], label: &[u16], bones: usize, frames: &[Vec<Vec3>]) -> Skinning {
    let influences = label.iter().map(|&b| one(b)).collect();
    let members = members(label, bones);
    let transforms = frames
        .par_iter()
        .map(|f| members.iter().map(|m| procrustes::fit(m.iter().map(|&v| (rest[v], f[v], 1.0)))).collect())
        .collect();
    Skinning { rest: rest.to_vec(), bones, influences, transforms }
}

fn one(b: u16) -> [(u16, f32); INFLUENCES] {
    let mut inf = [(0, 0.0); INFLUENCES];
    inf[0] = (b, 1.0);
    inf
}

fn members(label: &[u16], bones: usize) -> Vec<Vec<usize>> {
    let mut m = vec![Vec::new(); bones];
    for (v, &b) in label.iter().enumerate() {
        m[b as usize].push(v);
    }
    m
}

/// A bone left without vertices takes the vertex farthest from its own
/// group's centre (in the rest pose), so that every bone moves something.
fn reseed_empty(label: &mut [u16], bones: usize, rest: &[Vec3]) {
    for b in 0..bones {
        let m = members(label, bones);
        if !m[b].is_empty() {
            continue;
        }
        let centre = |g: &Vec<usize>| g.iter().map(|&v| rest[v]).sum::<Vec3>() / g.len().max(1) as f32;
        let centres: Vec<Vec3> = m.iter().map(centre).collect();
        let far = (0..rest.len()).filter(|&v| m[label[v] as usize].len() > 1).max_by(|&a, &c| {
            let d = |v: usize| rest[v].distance_squared(centres[label[v] as usize]);
            d(a).total_cmp(&d(c))
        });
        if let Some(v) = far {
            label[v] = b as u16;
        }
    }
}

/// k-means on the rest pose: `k` seeds by farthest-point sampling, then a
/// few Lloyd steps.
fn kmeans(rest: &[Vec3], k: usize) -> Vec<u16> {
    let mut seeds = vec![rest[0]];
    let mut d: Vec<f32> = rest.iter().map(|p| p.distance_squared(seeds[0])).collect();
    while seeds.len() < k {
        let far = (0..rest.len()).max_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(0);
        seeds.push(rest[far]);
        for (dv, p) in d.iter_mut().zip(rest) {
            *dv = dv.min(p.distance_squared(rest[far]));
        }
    }
    let nearest = |p: Vec3, seeds: &[Vec3]| {
        (0..seeds.len())
            .min_by(|&a, &b| p.distance_squared(seeds[a]).total_cmp(&p.distance_squared(seeds[b])))
            .unwrap_or(0)
    };
    let mut label = vec![0u16; rest.len()];
    for _ in 0..8 {
        label = rest.par_iter().map(|&p| nearest(p, &seeds) as u16).collect();
        let (mut sum, mut n) = (vec![Vec3::ZERO; k], vec![0usize; k]);
        for (v, &b) in label.iter().enumerate() {
            sum[b as usize] += rest[v];
            n[b as usize] += 1;
        }
        for b in (0..k).filter(|&b| n[b] > 0) {
            seeds[b] = sum[b] / n[b] as f32;
        }
    }
    label
}

/// SSDR's weight update: each vertex's weights over its candidate bones
/// (those that move it or a neighbour), non-negative and summing to one,
/// the [`INFLUENCES`] largest kept and solved again.
fn update_weights(frames: &[Vec<Vec3>], skin: &Skinning, neighbours: &[Vec<u32>]) -> Vec<[(u16, f32); INFLUENCES]> {
    (0..skin.rest.len())
        .into_par_iter()
        .map(|v| {
            let mut cand: Vec<u16> = std::iter::once(v as u32)
                .chain(neighbours[v].iter().copied())
                .flat_map(|u| skin.influences[u as usize].iter().filter(|i| i.1 > 0.0).map(|i| i.0))
                .collect();
            cand.sort_unstable();
            cand.dedup();
            nnls::influences(&cand, |c| vertex_weights(frames, skin, v, c)).unwrap_or(skin.influences[v])
        })
        .collect()
}

/// The non-negative weights over bones `cand` that best give vertex `v`'s
/// frames from its rest place, with a heavy row asking them to sum to one.
fn vertex_weights(frames: &[Vec<Vec3>], skin: &Skinning, v: usize, cand: &[u16]) -> Vec<f64> {
    let mut eq = nnls::NormalEquations::new(cand.len());
    let r = skin.rest[v];
    let mut cols = vec![Vec3::ZERO; cand.len()];
    for (t, f) in frames.iter().enumerate() {
        for (c, &b) in cols.iter_mut().zip(cand) {
            *c = skin.transforms[t][b as usize].apply(r);
        }
        eq.add(&cols, f[v]);
    }
    eq.solve_weights()
}

/// SSDR's transform update: in each frame (in parallel), each bone in turn
/// fitted rigidly to what the other bones leave of its vertices.
fn update_transforms(frames: &[Vec<Vec3>], skin: &Skinning, affine: bool) -> Vec<Vec<BoneTransform>> {
    let mut members: Vec<Vec<(usize, f32)>> = vec![Vec::new(); skin.bones];
    for (v, inf) in skin.influences.iter().enumerate() {
        for &(b, w) in inf.iter().filter(|i| i.1 > 0.0) {
            members[b as usize].push((v, w));
        }
    }
    let rest = &skin.rest;
    frames
        .par_iter()
        .enumerate()
        .map(|(t, f)| {
            let mut m = skin.transforms[t].clone();
            let mut residual: Vec<Vec3> = skin.frame(t).iter().zip(f).map(|(s, x)| *x - *s).collect();
            for (b, group) in members.iter().enumerate().filter(|(_, g)| !g.is_empty()) {
                let old = m[b];
                let q = |&(v, w): &(usize, f32)| (rest[v], residual[v] + w * old.apply(rest[v]), w);
                m[b] = if affine {
                    procrustes::fit_affine(group.iter().map(q))
                } else {
                    procrustes::fit(group.iter().map(q))
                };
                for &(v, w) in group {
                    residual[v] += w * (old.apply(rest[v]) - m[b].apply(rest[v]));
                }
            }
            m
        })
        .collect()
}

//! Maps to the square orbifold as solutions of one sparse linear system
//! (Aigerman & Lipman, "Orbifold Tutte Embeddings", ACM TOG 34(6), 2015): each
//! free vertex is the weighted average of its neighbours, each neighbour seen
//! through the orbifold isometry that relates the two (identity, or a
//! half-turn about a cone where the edge crosses the cut), and the four cones
//! are fixed. Any positive weights give a bijection onto the orbifold (their
//! Theorem 1). With symmetric cotangent weights (Pinkall & Polthier 1993) the
//! solution minimizes the Dirichlet energy, i.e. it is the discrete harmonic
//! map, as conformal as the cones' positions allow, and the system is SPD
//! (Cholesky); the unsymmetric weights of the stretch minimization (see
//! [`super`]) give a system that is that kind of matrix times a diagonal
//! one, solved by Cholesky too ([`OrbifoldSystem::solve_scaled`]).
//!
//! Every isometry of the square orbifold is `u -> ±u + t`, so the x and y
//! coordinates decouple: one sparse matrix, two right-hand sides.

use super::cut::{Cut, Iso, CONE_UV};
use crate::error::Result;
use crate::mesh::adjacency::{origin, target, Adjacency, NONE};
use crate::sparse::{Cholesky, Pattern};
use glam::{DVec2, DVec3};
use std::sync::Arc;

/// Smallest edge weight, relative to the mean absolute cotangent weight.
/// Negative cotangent weights (obtuse triangles) are clamped to it, which
/// keeps the map a bijection at a tiny cost in conformality.
pub const MIN_WEIGHT_REL: f64 = 1e-3;

/// Largest half-cotangent a corner may have (see [`half_cotangents`]).
pub const MAX_HALF_COT: f64 = 1e3;

/// Half the cotangent of the angle at each corner of each face.
pub fn half_cotangents(faces: &[[u32; 3]], pos: &[DVec3]) -> Vec<[f64; 3]> {
    faces
        .iter()
        .map(|f| {
            let p = f.map(|i| pos[i as usize]);
            let mut c = [0.0; 3];
            for k in 0..3 {
                let (a, b) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                // Bounded: a triangle without area would give an infinite
                // weight (1e3 is a corner of 0.06 degrees).
                let cross = a.cross(b).length().max(1e-300);
                c[k] = (0.5 * a.dot(b) / cross).clamp(-MAX_HALF_COT, MAX_HALF_COT);
            }
            c
        })
        .collect()
}

/// Cotangent weight of each half-edge (the same on both halves of an edge),
/// clamped to be positive.
pub fn cotangent_weights(faces: &[[u32; 3]], adj: &Adjacency, pos: &[DVec3]) -> Vec<f64> {
    let cot = half_cotangents(faces, pos);
    let half = |h: usize| cot[h / 3][(h % 3 + 2) % 3];
    let mut w: Vec<f64> = (0..faces.len() * 3)
        .map(|h| {
            let o = adj.opposite[h];
            half(h) + if o == NONE { 0.0 } else { half(o as usize) }
        })
        .collect();
    let mean = w.iter().map(|x| x.abs()).sum::<f64>() / w.len().max(1) as f64;
    for x in &mut w {
        *x = x.max(MIN_WEIGHT_REL * mean);
    }
    w
}

/// The linear system of a map to the orbifold, for any positive weights.
pub struct OrbifoldSystem {
    /// Shared with the area passes that own the system.
    faces: Arc<[[u32; 3]]>,
    /// The cut's cones (top, right, bottom, left), pinned at [`CONE_UV`].
    cones: [u32; 4],
    /// For half-edge h (i -> j): the isometry taking j's canonical position
    /// into the frame of i's canonical copy, as seen across h's face.
    rel: Vec<Iso>,
    /// Unknown index of each vertex, or u32::MAX for a cone.
    index: Vec<u32>,
    unknowns: usize,
    chol: Option<Cholesky>,
    /// The layout of [`solve_scaled`](Self::solve_scaled)'s entries.
    pattern: Option<Pattern>,
}

impl OrbifoldSystem {
    pub fn new(faces: Arc<[[u32; 3]]>, nv: usize, cut: &Cut) -> Self {
        let mut index = vec![0u32; nv];
        let mut n = 0u32;
        for (v, slot) in index.iter_mut().enumerate() {
            if cut.cones.contains(&(v as u32)) {
                *slot = u32::MAX;
            } else {
                *slot = n;
                n += 1;
            }
        }
        let rel = (0..faces.len() * 3)
            .map(|h| {
                let (f, k) = (h / 3, h % 3);
                let (gi, gj) = (cut.corner_iso[f][k], cut.corner_iso[f][(k + 1) % 3]);
                // gi⁻¹ ∘ gj, with gi⁻¹(x) = si (x - ti).
                Iso { s: gi.s * gj.s, t: gi.s * (gj.t - gi.t) }
            })
            .collect();
        OrbifoldSystem { faces, cones: cut.cones, rel, index, unknowns: n as usize, chol: None, pattern: None }
    }

    fn cone_uv(&self, v: u32) -> DVec2 {
        CONE_UV[self.cones.iter().position(|&c| c == v).unwrap_or(0)]
    }

    fn unpack(&self, x: &[f64]) -> Vec<DVec2> {
        let n = self.unknowns;
        self.index
            .iter()
            .enumerate()
            .map(
                |(v, &i)| {
                    if i == u32::MAX {
                        self.cone_uv(v as u32)
                    } else {
                        DVec2::new(x[i as usize], x[n + i as usize])
                    }
                },
            )
            .collect()
    }

    /// Solves with symmetric weights (w[h] = w[opposite(h)]) by Cholesky.
    pub fn solve_symmetric(&mut self, w: &[f64]) -> Result<Vec<DVec2>> {
        self.solve_scaled(w, &vec![1.0; self.index.len()])
    }

    /// Solves with the weights `w0[h] · c[target(h)]`: symmetric weights
    /// `w0` scaled by a positive factor of each vertex, the form every
    /// stretch-minimization pass gives (it divides the weights into a
    /// vertex by that vertex's stretch). That system A is not symmetric,
    /// but A = B C with C = diag(c) and B = A C⁻¹ symmetric (its
    /// off-diagonal is −w0 r, the conformal system's) and positive
    /// definite: each edge adds w0 (a xᵢ² + xⱼ²/a − 2 r xᵢ xⱼ) ≥ 0 with
    /// a = cⱼ/cᵢ to its quadratic form, and the cones pin it. So B y = b is
    /// solved by Cholesky, with the ordering, analysis and layout of the
    /// first solve (the conformal map's, c = 1), and x = C⁻¹ y: a third of
    /// the time of the LU it replaces (same maps to rounding).
    pub fn solve_scaled(&mut self, w0: &[f64], c: &[f64]) -> Result<Vec<DVec2>> {
        let n = self.unknowns;
        let mut entries = Vec::with_capacity(w0.len() + n);
        let mut rhs = vec![0.0; 2 * n];
        for (h, &w0h) in w0.iter().enumerate() {
            let (i, j) = (origin(&self.faces, h as u32), target(&self.faces, h as u32));
            let ii = self.index[i as usize];
            if ii == u32::MAX {
                continue;
            }
            let r = self.rel[h];
            let wh = w0h * c[j as usize];
            entries.push((ii, ii, wh / c[i as usize]));
            let mut b = wh * r.t;
            match self.index[j as usize] {
                u32::MAX => b += wh * r.s * self.cone_uv(j),
                // The lower triangle: the upper is the opposite half-edge's.
                jj if jj < ii => entries.push((ii, jj, -w0h * r.s)),
                _ => {}
            }
            rhs[ii as usize] += b.x;
            rhs[n + ii as usize] += b.y;
        }
        match (&mut self.chol, &self.pattern) {
            (Some(chol), Some(pattern)) => chol.refactor_in(pattern, &entries)?,
            _ => {
                self.chol = Some(Cholesky::factor_supernodal(n, &entries)?);
                self.pattern = Some(Pattern::new(n, &entries)?);
            }
        }
        if let Some(chol) = &self.chol {
            chol.solve(&mut rhs, 2)?;
        }
        for (v, &i) in self.index.iter().enumerate() {
            if i != u32::MAX {
                rhs[i as usize] /= c[v];
                rhs[n + i as usize] /= c[v];
            }
        }
        Ok(self.unpack(&rhs))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::param::cut::{self, Graph};

    /// A closed latitude-longitude sphere: two poles, `rings` x `segments`
    /// vertices between.
    fn sphere(rings: usize, segments: usize) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let mut pos = vec![DVec3::Z, -DVec3::Z];
        for r in 1..=rings {
            let theta = std::f64::consts::PI * r as f64 / (rings + 1) as f64;
            for s in 0..segments {
                let phi = std::f64::consts::TAU * s as f64 / segments as f64;
                // Uneven in phi, so that some cotangent weights are far apart.
                let phi = phi + 0.3 * (3.0 * phi).sin();
                pos.push(DVec3::new(theta.sin() * phi.cos(), 1.5 * theta.sin() * phi.sin(), theta.cos()));
            }
        }
        let at = |r: usize, s: usize| (2 + (r - 1) * segments + s % segments) as u32;
        let mut faces = Vec::new();
        for s in 0..segments {
            faces.push([0, at(1, s), at(1, s + 1)]);
            faces.push([1, at(rings, s + 1), at(rings, s)]);
            for r in 1..rings {
                faces.push([at(r, s), at(r + 1, s), at(r + 1, s + 1)]);
                faces.push([at(r, s), at(r + 1, s + 1), at(r, s + 1)]);
            }
        }
        (pos, faces)
    }

    /// The system A x = b for weights `w` (one per half-edge: the weight of
    /// target(h) in the average that places origin(h)), stated directly.
    fn assemble(system: &OrbifoldSystem, w: &[f64]) -> (Vec<(u32, u32, f64)>, Vec<f64>) {
        let n = system.unknowns;
        let mut entries = Vec::with_capacity(w.len() + n);
        let mut rhs = vec![0.0; 2 * n];
        for (h, &wh) in w.iter().enumerate() {
            let (i, j) = (origin(&system.faces, h as u32), target(&system.faces, h as u32));
            let ii = system.index[i as usize];
            if ii == u32::MAX {
                continue;
            }
            let r = system.rel[h];
            // wh (u_i - r(u_j)) summed over the neighbours is zero.
            entries.push((ii, ii, wh));
            let mut b = wh * r.t;
            match system.index[j as usize] {
                u32::MAX => b += wh * r.s * system.cone_uv(j),
                jj => entries.push((ii, jj, -wh * r.s)),
            }
            rhs[ii as usize] += b.x;
            rhs[n + ii as usize] += b.y;
        }
        (entries, rhs)
    }

    /// `solve_scaled` (Cholesky on A C⁻¹) solves the unsymmetric system
    /// A x = b of the weights w0[h] · c[target(h)] itself.
    #[test]
    fn scaled_weights_are_solved_by_cholesky() {
        let (pos, faces) = sphere(12, 16);
        let nv = pos.len();
        let adj = Adjacency::build(&faces);
        let graph = Graph::new(nv, &faces, &pos);
        let (cones, corner) = cut::choose_cones(&graph, nv);
        let cut = Cut::new(&faces, &adj, &graph, cones, corner, false, None).unwrap();
        let mut system = OrbifoldSystem::new(faces.as_slice().into(), nv, &cut);
        let w0 = cotangent_weights(&faces, &adj, &pos);
        // Factors from 0.05 to 20, as many stretch passes leave them.
        let c: Vec<f64> = (0..nv).map(|v| (3.0 * (v as f64 * 0.7).sin()).exp()).collect();
        let uv = system.solve_scaled(&w0, &c).unwrap();
        // Twice: the second solve reuses the first one's layout.
        let c2: Vec<f64> = c.iter().map(|x| x.sqrt()).collect();
        let uv2 = system.solve_scaled(&w0, &c2).unwrap();
        for (c, uv) in [(&c, &uv), (&c2, &uv2)] {
            let w: Vec<f64> = (0..w0.len()).map(|h| w0[h] * c[target(&faces, h as u32) as usize]).collect();
            let (entries, rhs) = assemble(&system, &w);
            let n = system.unknowns;
            let mut x = vec![0.0; 2 * n];
            for (v, &i) in system.index.iter().enumerate() {
                if i != u32::MAX {
                    (x[i as usize], x[n + i as usize]) = (uv[v].x, uv[v].y);
                }
            }
            let mut r = rhs.iter().map(|b| -b).collect::<Vec<f64>>();
            for &(i, j, a) in &entries {
                r[i as usize] += a * x[j as usize];
                r[n + i as usize] += a * x[n + j as usize];
            }
            let scale = rhs.iter().fold(0.0f64, |m, b| m.max(b.abs()));
            let worst = r.iter().fold(0.0f64, |m, e| m.max(e.abs()));
            assert!(worst < 1e-9 * scale, "residual {worst:e} of right-hand sides up to {scale:e}");
        }
        // Different weights, different maps: the test is not of a constant.
        let moved = uv.iter().zip(&uv2).map(|(a, b)| a.distance(*b)).fold(0.0, f64::max);
        assert!(moved > 1e-3, "the two maps differ by {moved:e} only");
    }
}

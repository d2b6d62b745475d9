//! Maps to the square orbifold as solutions of one sparse linear system
//! (Aigerman & Lipman, "Orbifold Tutte Embeddings", ACM TOG 34(6), 2015): each
//! free vertex is the weighted average of its neighbours, each neighbour seen
//! through the orbifold isometry that relates the two (identity, or a
//! half-turn about a cone where the edge crosses the cut), and the four cones
//! are fixed. Any positive weights give a bijection onto the orbifold (their
//! Theorem 1). With symmetric cotangent weights (Pinkall & Polthier 1993) the
//! solution minimizes the Dirichlet energy, i.e. it is the discrete harmonic
//! map, as conformal as the cones' positions allow, and the system is SPD
//! (Cholesky); with the unsymmetric weights of the stretch minimization
//! (see [`super`]) it is solved by LU.
//!
//! Every isometry of the square orbifold is `u -> ±u + t`, so the x and y
//! coordinates decouple: one sparse matrix, two right-hand sides.

use super::cut::{Cut, Iso, CONE_UV};
use crate::error::Result;
use crate::mesh::adjacency::{origin, target, Adjacency, NONE};
use crate::sparse::{Cholesky, SparseLu};
use glam::{DVec2, DVec3};

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
pub struct OrbifoldSystem<'a> {
    faces: &'a [[u32; 3]],
    /// The cut's cones (top, right, bottom, left), pinned at [`CONE_UV`].
    cones: [u32; 4],
    /// For half-edge h (i -> j): the isometry taking j's canonical position
    /// into the frame of i's canonical copy, as seen across h's face.
    rel: Vec<Iso>,
    /// Unknown index of each vertex, or u32::MAX for a cone.
    index: Vec<u32>,
    unknowns: usize,
    chol: Option<Cholesky>,
    lu: Option<SparseLu>,
}

impl<'a> OrbifoldSystem<'a> {
    pub fn new(faces: &'a [[u32; 3]], nv: usize, cut: &Cut) -> Self {
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
        OrbifoldSystem { faces, cones: cut.cones, rel, index, unknowns: n as usize, chol: None, lu: None }
    }

    fn cone_uv(&self, v: u32) -> DVec2 {
        CONE_UV[self.cones.iter().position(|&c| c == v).unwrap_or(0)]
    }

    /// Rows of the system for weights `w` (one per half-edge: the weight of
    /// target(h) in the average that places origin(h)).
    fn assemble(&self, w: &[f64]) -> (Vec<(u32, u32, f64)>, Vec<f64>) {
        let n = self.unknowns;
        let mut entries = Vec::with_capacity(w.len() + n);
        let mut rhs = vec![0.0; 2 * n];
        for (h, &wh) in w.iter().enumerate() {
            let (i, j) = (origin(self.faces, h as u32), target(self.faces, h as u32));
            let ii = self.index[i as usize];
            if ii == u32::MAX {
                continue;
            }
            let r = self.rel[h];
            // wh (u_i - r(u_j)) summed over the neighbours is zero.
            entries.push((ii, ii, wh));
            let mut b = wh * r.t;
            match self.index[j as usize] {
                u32::MAX => b += wh * r.s * self.cone_uv(j),
                jj => entries.push((ii, jj, -wh * r.s)),
            }
            rhs[ii as usize] += b.x;
            rhs[n + ii as usize] += b.y;
        }
        (entries, rhs)
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
        let (mut entries, mut rhs) = self.assemble(w);
        entries.retain(|&(r, c, _)| r >= c);
        match &mut self.chol {
            Some(c) => c.refactor(&entries)?,
            None => self.chol = Some(Cholesky::factor(self.unknowns, &entries)?),
        }
        if let Some(c) = &self.chol {
            c.solve(&mut rhs, 2);
        }
        Ok(self.unpack(&rhs))
    }

    /// Solves with any positive weights by LU.
    pub fn solve_general(&mut self, w: &[f64]) -> Result<Vec<DVec2>> {
        let (entries, mut rhs) = self.assemble(w);
        let lu = self.lu.get_or_insert_with(|| SparseLu::new(self.unknowns));
        lu.solve(&entries, &mut rhs, 2)?;
        Ok(self.unpack(&rhs))
    }
}

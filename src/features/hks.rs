//! The heat kernel signature (Sun, Ovsjanikov and Guibas 2009, "A concise
//! and provably informative multi-scale signature based on heat
//! diffusion"): at vertex x and time t, HKS(x, t) = Σ_k e^(−λ_k t) φ_k(x)²
//! over the Laplace–Beltrami operator's low eigenpairs. The seed paper
//! (section 4) detects the features of an unregistered capture as its local
//! maxima at a short diffusion time, and tracks them by it: it depends on
//! the intrinsic geometry only, so it barely moves under the near-isometric
//! motion of a body, and it does not care how a frame is triangulated.
//!
//! The operator is the cotangent Laplacian L with the lumped mass matrix M
//! (Pinkall and Polthier 1993), L φ = λ M φ, on the mesh scaled to unit
//! area (so that times compare across frames). Its lowest eigenpairs come
//! from LOBPCG (`linfa-linalg`; Knyazev 2001) on the shift-inverted
//! symmetric form M^½ (L + σM)⁻¹ M^½, whose largest eigenvalues 1 / (λ + σ)
//! are the Laplacian's lowest, applied through one sparse Cholesky factor.

use crate::error::{Error, Result};
use crate::mesh::adjacency::{origin, target, Adjacency, NONE};
use crate::param::orbifold::cotangent_weights;
use crate::sparse::Cholesky;
use glam::{DVec3, Vec3};
use linfa_linalg::lobpcg::lobpcg;
use linfa_linalg::Order;
use ndarray::{Array2, ArrayView2};

/// The shift σ of the inverted operator, on a mesh of unit area (where the
/// first non-zero eigenvalue of a body is about 10 to 100).
const SHIFT: f64 = 1e-2;
/// LOBPCG's residual tolerance and iteration limit. 1e-4 found as many
/// features 1.3-1.45x faster (`cgv info --unregistered`), but their places
/// moved enough to change the cut: samba's 24 remeshed frames had 8 frames
/// unmatched instead of 2 (`tests/unregistered.rs`'s probe).
const TOLERANCE: f32 = 1e-5;
const MAX_ITERATIONS: usize = 200;

/// The lowest eigenpairs of a mesh's Laplacian.
pub struct Spectrum {
    /// Eigenvalues, ascending (the first about 0), on the mesh scaled to
    /// unit area.
    pub values: Vec<f64>,
    /// `vectors[k][v]`: eigenvector k at vertex v, M-orthonormal.
    pub vectors: Vec<Vec<f64>>,
}

impl Spectrum {
    /// The lowest `k` eigenpairs of the Laplacian of `faces` over
    /// `positions` (a vertex no face uses gets a tiny mass of its own).
    pub fn of(faces: &[[u32; 3]], positions: &[Vec3], k: usize) -> Result<Spectrum> {
        Spectrum::near(faces, positions, k, None)
    }

    /// [`of`](Self::of), LOBPCG started from `guess` (k vectors over these
    /// vertices, a nearby frame's eigenvectors carried over) where given:
    /// a near-isometric motion moves the low eigenvectors little, and a
    /// start close to their span converges in a few iterations.
    pub fn near(faces: &[[u32; 3]], positions: &[Vec3], k: usize, guess: Option<&[Vec<f64>]>) -> Result<Spectrum> {
        let n = positions.len();
        if k + 1 >= n || faces.is_empty() {
            return Err(Error::Argument(format!("{k} eigenpairs of a mesh of {n} vertices and {} faces", faces.len())));
        }
        let (stiffness, mass) = laplacian(faces, positions);
        let mut entries = stiffness;
        entries.extend(mass.iter().enumerate().map(|(i, &m)| (i as u32, i as u32, SHIFT * m)));
        let chol = Cholesky::factor(n, &entries)?;
        let root: Vec<f64> = mass.iter().map(|m| m.sqrt()).collect();
        // y ↦ M^½ (L + σM)⁻¹ M^½ y, a block of columns at a time.
        let operator = |x: ArrayView2<f64>| -> Array2<f64> {
            let cols = x.ncols();
            let mut rhs = vec![0.0; n * cols];
            for j in 0..cols {
                for i in 0..n {
                    rhs[j * n + i] = root[i] * x[(i, j)];
                }
            }
            // A factor that solved once solves again; a failure leaves zeros,
            // which LOBPCG reports as not converged.
            if chol.solve(&mut rhs, cols).is_err() {
                rhs.iter_mut().for_each(|v| *v = 0.0);
            }
            Array2::from_shape_fn((n, cols), |(i, j)| root[i] * rhs[j * n + i])
        };
        let guess = guess.filter(|g| g.len() == k && g.iter().all(|v| v.len() == n));
        let start = match guess {
            // A little of the hashed start keeps the block full rank.
            Some(g) => Array2::from_shape_fn((n, k), |(i, j)| root[i] * g[j][i] + 1e-3 * start_vector(i, j)),
            None => Array2::from_shape_fn((n, k), |(i, j)| start_vector(i, j)),
        };
        let found = match lobpcg(operator, start, |_| {}, None, TOLERANCE, MAX_ITERATIONS, Order::Largest) {
            Ok(r) => r,
            // The best it reached: the lowest eigenpairs converge first, and
            // the signature at short times reads those least.
            Err((_, Some(r))) => r,
            Err((e, None)) => return Err(Error::Numerical(format!("Laplacian eigenpairs: {e}"))),
        };
        let mut pairs: Vec<(f64, Vec<f64>)> = (0..found.eigvals.len())
            .map(|j| {
                let lambda = (1.0 / found.eigvals[j] - SHIFT).max(0.0);
                (lambda, (0..n).map(|i| found.eigvecs[(i, j)] / root[i]).collect())
            })
            .collect();
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (values, vectors) = pairs.into_iter().unzip();
        Ok(Spectrum { values, vectors })
    }

    /// HKS(v, t) at every vertex.
    pub fn hks(&self, t: f64) -> Vec<f64> {
        let n = self.vectors.first().map_or(0, Vec::len);
        let mut h = vec![0.0; n];
        for (&lambda, phi) in self.values.iter().zip(&self.vectors) {
            let e = (-lambda * t).exp();
            for (h, p) in h.iter_mut().zip(phi) {
                *h += e * p * p;
            }
        }
        h
    }
}

/// A deterministic, well-spread start for LOBPCG: low-frequency cosines of
/// the vertex index would align with the mesh's order, so a hash instead.
fn start_vector(i: usize, j: usize) -> f64 {
    let mut x = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    x ^= x >> 31;
    x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x ^= x >> 29;
    (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
}

/// The cotangent stiffness entries (each edge once, both diagonals) and the
/// lumped masses, on the mesh scaled to unit area.
fn laplacian(faces: &[[u32; 3]], positions: &[Vec3]) -> (Vec<(u32, u32, f64)>, Vec<f64>) {
    let pos: Vec<DVec3> = positions.iter().map(|p| p.as_dvec3()).collect();
    let area = |f: &[u32; 3]| {
        let [a, b, c] = f.map(|i| pos[i as usize]);
        0.5 * (b - a).cross(c - a).length()
    };
    let total: f64 = faces.iter().map(area).sum::<f64>().max(f64::MIN_POSITIVE);
    let mut mass = vec![0.0; pos.len()];
    for f in faces {
        let a = area(f) / total / 3.0;
        for &v in f {
            mass[v as usize] += a;
        }
    }
    let floor = 1e-6 / pos.len() as f64;
    mass.iter_mut().for_each(|m| *m = m.max(floor));
    // Cotangent weights are scale-free: the unit-area scaling is the masses'.
    let adj = Adjacency::build(faces);
    let weights = cotangent_weights(faces, &adj, &pos);
    let mut entries = Vec::with_capacity(faces.len() * 6);
    for (h, &w) in weights.iter().enumerate() {
        let o = adj.opposite[h];
        if o != NONE && (o as usize) < h {
            continue;
        }
        let (i, j) = (origin(faces, h as u32), target(faces, h as u32));
        entries.extend([(i, j, -w), (i, i, w), (j, j, w)]);
    }
    (entries, mass)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use std::collections::HashMap;

    /// An octahedron with each face split into four `levels` times, on the unit sphere.
    pub(crate) fn sphere(levels: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut p = vec![Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];
        let mut f: Vec<[u32; 3]> =
            vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
        for _ in 0..levels {
            let mut mid = HashMap::new();
            let mut at = |a: u32, b: u32, p: &mut Vec<Vec3>| {
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    p.push(((p[a as usize] + p[b as usize]) * 0.5).normalize());
                    p.len() as u32 - 1
                })
            };
            f = f
                .iter()
                .flat_map(|&[a, b, c]| {
                    let (ab, bc, ca) = (at(a, b, &mut p), at(b, c, &mut p), at(c, a, &mut p));
                    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
                })
                .collect();
        }
        (p, f)
    }

    /// An octahedron refined into a sphere: the first eigenvalue is 0 with
    /// a constant vector, the next three equal (the sphere's l = 1 band,
    /// 8π on the unit-area sphere), and with whole bands (l ≤ 2: 9 pairs)
    /// the signature is nearly the same at
    /// every vertex.
    #[test]
    fn a_sphere_has_its_spectrum() {
        let (p, f) = sphere(3);
        let s = Spectrum::of(&f, &p, 9).unwrap();
        assert!(s.values[0].abs() < 1e-6, "{:?}", s.values);
        let l1 = 8.0 * std::f64::consts::PI;
        for &v in &s.values[1..4] {
            assert!((v / l1 - 1.0).abs() < 0.05, "{:?} against {l1}", s.values);
        }
        let h = s.hks(0.01);
        let (lo, hi) = h.iter().fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(hi / lo < 1.2, "{lo} .. {hi}");
    }

    /// Cold against warm starts on consecutive frames of a real motion:
    /// `CGV_PROBE=/tmp/data/samba/samba cargo test --release --lib warm_start -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn warm_start_probe() {
        let dir = std::env::var("CGV_PROBE").unwrap();
        let src = crate::mesh::open_sequence(&dir, &Default::default()).unwrap();
        let faces = &src.topology().faces;
        let mut last: Option<Spectrum> = None;
        let (mut cold, mut warm) = (0.0, 0.0);
        for f in 0..8 {
            let p = src.read_frame(f).unwrap();
            let t = std::time::Instant::now();
            let c = Spectrum::of(faces, &p, 32).unwrap();
            cold += t.elapsed().as_secs_f64();
            let t = std::time::Instant::now();
            let w = Spectrum::near(faces, &p, 32, last.as_ref().map(|s| s.vectors.as_slice())).unwrap();
            warm += t.elapsed().as_secs_f64();
            let d = c.values.iter().zip(&w.values).map(|(a, b)| (a - b).abs() / a.max(1e-9)).fold(0.0, f64::max);
            eprintln!("frame {f}: cold {:.3} s, warm {:.3} s so far; values differ by {d:.2e}", cold, warm);
            last = Some(w);
        }
    }
}

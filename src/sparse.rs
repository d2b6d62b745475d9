//! Sparse solves: a thin layer over faer's supernodal Cholesky (LLᵀ, for
//! symmetric positive-definite systems) and LU (for unsymmetric ones), so the
//! rest of the crate states systems as (row, column, value) entries and never
//! sees faer's types.

use crate::error::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::lu;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Conj, Par};
use faer::{Mat, Side};

/// A factored sparse SPD matrix.
pub struct Cholesky {
    n: usize,
    symbolic: SymbolicLlt<usize>,
    llt: Llt<usize, f64>,
}

/// Sums duplicate entries and keeps the lower triangle.
fn assemble(n: usize, entries: &[(u32, u32, f64)]) -> Result<SparseColMat<usize, f64>> {
    let lower: Vec<(u32, u32, f64)> = entries.iter().map(|&(r, c, v)| (r.max(c), r.min(c), v)).collect();
    assemble_general(n, &lower)
}

impl Cholesky {
    /// Factors the symmetric matrix given by `entries` (either triangle or
    /// both; duplicates are summed, and (r, c) and (c, r) are the same entry).
    pub fn factor(n: usize, entries: &[(u32, u32, f64)]) -> Result<Cholesky> {
        let a = assemble(n, entries)?;
        let symbolic = SymbolicLlt::try_new(a.symbolic(), Side::Lower)
            .map_err(|e| Error::Numerical(format!("Cholesky analysis: {e:?}")))?;
        let llt = Llt::try_new_with_symbolic(symbolic.clone(), a.as_ref(), Side::Lower)
            .map_err(|e| Error::Numerical(format!("matrix is not positive definite: {e:?}")))?;
        Ok(Cholesky { n, symbolic, llt })
    }

    /// Factors a matrix with the same sparsity pattern as this one, reusing
    /// the fill-reducing ordering and symbolic analysis.
    pub fn refactor(&mut self, entries: &[(u32, u32, f64)]) -> Result<()> {
        let a = assemble(self.n, entries)?;
        self.llt = Llt::try_new_with_symbolic(self.symbolic.clone(), a.as_ref(), Side::Lower)
            .map_err(|e| Error::Numerical(format!("matrix is not positive definite: {e:?}")))?;
        Ok(())
    }

    pub fn dim(&self) -> usize {
        self.n
    }

    /// Solves A X = B for `k` right-hand sides stored one after another in `rhs`.
    pub fn solve(&self, rhs: &mut [f64], k: usize) {
        assert_eq!(rhs.len(), self.n * k, "right-hand side has the wrong length");
        let mut b = Mat::<f64>::from_fn(self.n, k, |i, j| rhs[j * self.n + i]);
        self.llt.solve_in_place(b.as_mut());
        for j in 0..k {
            for i in 0..self.n {
                rhs[j * self.n + i] = b[(i, j)];
            }
        }
    }
}

/// Sums duplicate (row, column, value) entries into a sparse matrix.
fn assemble_general(n: usize, entries: &[(u32, u32, f64)]) -> Result<SparseColMat<usize, f64>> {
    let mut e = entries.to_vec();
    e.sort_unstable_by_key(|&(r, c, _)| (c, r));
    let mut trip: Vec<Triplet<usize, usize, f64>> = Vec::with_capacity(e.len());
    for (r, c, v) in e {
        if r as usize >= n || c as usize >= n {
            return Err(Error::Numerical(format!("matrix entry ({r}, {c}) outside a {n} x {n} system")));
        }
        match trip.last_mut() {
            Some(t) if t.row == r as usize && t.col == c as usize => t.val += v,
            _ => trip.push(Triplet::new(r as usize, c as usize, v)),
        }
    }
    SparseColMat::try_new_from_triplets(n, n, &trip).map_err(|e| Error::Numerical(format!("sparse assembly: {e:?}")))
}

/// Sparse square solves by LU with partial pivoting, for the unsymmetric
/// systems of barycentric (Tutte-type) maps. The fill-reducing ordering and
/// symbolic analysis of the first matrix are reused for the next ones (same
/// pattern, new values: the area-correction passes).
///
/// The factorization is forced supernodal. faer's automatic choice takes the
/// simplicial one for these mesh systems, and there it was 44 % of a
/// parameterization's time (the default motion at N = 128, `perf`); the
/// supernodal one takes 6 %, and `cgv remesh` of horse-gallop's first
/// frames went from 25 s to 13 s (same maps to 1e-12, up to pivoting).
pub struct SparseLu {
    n: usize,
    symbolic: Option<lu::SymbolicLu<usize>>,
    numeric: lu::NumericLu<usize, f64>,
}

impl SparseLu {
    pub fn new(n: usize) -> SparseLu {
        SparseLu { n, symbolic: None, numeric: lu::NumericLu::new() }
    }

    /// Factors the matrix given by (row, column, value) entries (duplicates
    /// are summed) and solves A X = B for `k` right-hand sides stored one
    /// after another in `rhs`.
    pub fn solve(&mut self, entries: &[(u32, u32, f64)], rhs: &mut [f64], k: usize) -> Result<()> {
        if rhs.len() != self.n * k {
            return Err(Error::Numerical(format!(
                "right-hand side of length {} for {k} columns of {}",
                rhs.len(),
                self.n
            )));
        }
        let a = assemble_general(self.n, entries)?;
        if self.symbolic.is_none() {
            let params = lu::LuSymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            };
            let symbolic = lu::factorize_symbolic_lu(a.symbolic(), params)
                .map_err(|e| Error::Numerical(format!("LU analysis: {e:?}")))?;
            self.symbolic = Some(symbolic);
        }
        let symbolic = self.symbolic.as_ref().ok_or_else(|| Error::Numerical("LU analysis missing".into()))?;
        // Sequential: the wasm build has no thread pool. (Natively faer's
        // global parallelism could be passed here; not measured.)
        let par = Par::Seq;
        let scratch = StackReq::any_of(&[
            symbolic.factorize_numeric_lu_scratch::<f64>(par, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(k, par),
        ]);
        let mut buf = MemBuffer::try_new(scratch).map_err(|e| Error::Numerical(format!("LU workspace: {e:?}")))?;
        let factors = symbolic
            .factorize_numeric_lu(&mut self.numeric, a.as_ref(), par, MemStack::new(&mut buf), Default::default())
            .map_err(|e| Error::Numerical(format!("singular matrix: {e:?}")))?;
        let mut b = Mat::<f64>::from_fn(self.n, k, |i, j| rhs[j * self.n + i]);
        factors.solve_in_place_with_conj(Conj::No, b.as_mut(), par, MemStack::new(&mut buf));
        for j in 0..k {
            for i in 0..self.n {
                rhs[j * self.n + i] = b[(i, j)];
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn solves_small_unsymmetric_system() {
        // [2 1; 0 3] x = [3 3] -> x = [1 1]
        let mut lu = SparseLu::new(2);
        let mut b = vec![3.0, 3.0];
        lu.solve(&[(0, 0, 2.0), (0, 1, 1.0), (1, 1, 3.0)], &mut b, 1).unwrap();
        assert!((b[0] - 1.0).abs() < 1e-12 && (b[1] - 1.0).abs() < 1e-12, "{b:?}");
    }

    use super::*;

    #[test]
    fn solves_small_spd_system() {
        // [4 1 0; 1 3 1; 0 1 2] x = [1 2 3], duplicates summed.
        let e = [(0, 0, 2.0), (0, 0, 2.0), (1, 0, 1.0), (1, 1, 3.0), (2, 1, 1.0), (1, 2, 0.0), (2, 2, 2.0)];
        let c = Cholesky::factor(3, &e).unwrap();
        let mut b = vec![1.0, 2.0, 3.0];
        c.solve(&mut b, 1);
        let x = b;
        let r = [4.0 * x[0] + x[1] - 1.0, x[0] + 3.0 * x[1] + x[2] - 2.0, x[1] + 2.0 * x[2] - 3.0];
        assert!(r.iter().all(|v| v.abs() < 1e-12), "{r:?}");
    }

    #[test]
    fn rejects_indefinite() {
        assert!(Cholesky::factor(2, &[(0, 0, 1.0), (1, 1, -1.0)]).is_err());
    }
}

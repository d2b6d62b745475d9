//! Sparse symmetric positive-definite solves: a thin layer over faer's
//! supernodal Cholesky (LLᵀ), so the rest of the crate states systems as
//! (row, column, value) entries and never sees faer's types.

use crate::error::{Error, Result};
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, Lu, SymbolicLlt, SymbolicLu};
use faer::sparse::{SparseColMat, Triplet};
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

/// A factored sparse square matrix (LU with partial pivoting), for the
/// unsymmetric systems of barycentric (Tutte-type) maps.
pub struct SparseLu {
    n: usize,
    symbolic: Option<SymbolicLu<usize>>,
    lu: Option<Lu<usize, f64>>,
}

impl SparseLu {
    pub fn new(n: usize) -> SparseLu {
        SparseLu { n, symbolic: None, lu: None }
    }

    /// Factors the matrix given by (row, column, value) entries; duplicates
    /// are summed. The symbolic analysis of the first call is reused.
    pub fn factor(&mut self, entries: &[(u32, u32, f64)]) -> Result<()> {
        let a = assemble_general(self.n, entries)?;
        if self.symbolic.is_none() {
            self.symbolic =
                Some(SymbolicLu::try_new(a.symbolic()).map_err(|e| Error::Numerical(format!("LU analysis: {e:?}")))?);
        }
        let sym = self.symbolic.clone().ok_or_else(|| Error::Numerical("LU analysis missing".into()))?;
        self.lu = Some(
            Lu::try_new_with_symbolic(sym, a.as_ref())
                .map_err(|e| Error::Numerical(format!("singular matrix: {e:?}")))?,
        );
        Ok(())
    }

    /// Solves A X = B for `k` right-hand sides stored one after another.
    pub fn solve(&self, rhs: &mut [f64], k: usize) -> Result<()> {
        let lu = self.lu.as_ref().ok_or_else(|| Error::Numerical("solve before factor".into()))?;
        assert_eq!(rhs.len(), self.n * k, "right-hand side has the wrong length");
        let mut b = Mat::<f64>::from_fn(self.n, k, |i, j| rhs[j * self.n + i]);
        lu.solve_in_place(b.as_mut());
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
        lu.factor(&[(0, 0, 2.0), (0, 1, 1.0), (1, 1, 3.0)]).unwrap();
        let mut b = vec![3.0, 3.0];
        lu.solve(&mut b, 1).unwrap();
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

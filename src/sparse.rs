//! Sparse solves: a thin layer over faer's sparse Cholesky (LLᵀ, for
//! symmetric positive-definite systems), so the rest of the crate states
//! systems as (row, column, value) entries and never sees faer's types.

use crate::error::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMat, Triplet};
use faer::{Conj, Par};
use faer::{Mat, Side};

/// A factored sparse SPD matrix.
pub struct Cholesky {
    n: usize,
    /// Boxed: the analysis is large, and the predictor holds a Cholesky.
    symbolic: Box<SymbolicCholesky<usize>>,
    /// The factor's values (in `symbolic`'s layout).
    values: Vec<f64>,
}

/// Sums duplicate entries and keeps the lower triangle.
fn assemble(n: usize, entries: &[(u32, u32, f64)]) -> Result<SparseColMat<usize, f64>> {
    let lower: Vec<(u32, u32, f64)> = entries.iter().map(|&(r, c, v)| (r.max(c), r.min(c), v)).collect();
    assemble_general(n, &lower)
}

impl Cholesky {
    /// Factors the symmetric matrix given by `entries` (either triangle or
    /// both; duplicates are summed, and (r, c) and (c, r) are the same entry),
    /// simplicial or supernodal as faer chooses.
    pub fn factor(n: usize, entries: &[(u32, u32, f64)]) -> Result<Cholesky> {
        Cholesky::factor_with(n, entries, SupernodalThreshold::AUTO)
    }

    /// [`factor`](Self::factor), always supernodal. faer's choice is the
    /// simplicial factorization for the parameterization's mesh systems,
    /// where it was 17 % of samba's parameterization at N = 256 (`perf`)
    /// and the supernodal one is 3-4x faster (as for the LU it replaced).
    pub fn factor_supernodal(n: usize, entries: &[(u32, u32, f64)]) -> Result<Cholesky> {
        Cholesky::factor_with(n, entries, SupernodalThreshold::FORCE_SUPERNODAL)
    }

    fn factor_with(n: usize, entries: &[(u32, u32, f64)], threshold: SupernodalThreshold) -> Result<Cholesky> {
        let a = assemble(n, entries)?;
        let params = CholeskySymbolicParams { supernodal_flop_ratio_threshold: threshold, ..Default::default() };
        let symbolic = factorize_symbolic_cholesky(a.symbolic(), Side::Lower, SymmetricOrdering::Amd, params)
            .map_err(|e| Error::Numerical(format!("Cholesky analysis: {e:?}")))?;
        let mut c = Cholesky { n, values: vec![0.0; symbolic.len_val()], symbolic: Box::new(symbolic) };
        c.numeric(a.as_ref())?;
        Ok(c)
    }

    /// Factors a matrix of the same sparsity pattern as this one, with its
    /// entries laid out by `pattern` (made from this matrix's entries),
    /// reusing the fill-reducing ordering and symbolic analysis.
    pub fn refactor_in(&mut self, pattern: &Pattern, entries: &[(u32, u32, f64)]) -> Result<()> {
        if pattern.n != self.n {
            return Err(Error::Numerical(format!("a {} x {0} layout for a {} x {1} matrix", pattern.n, self.n)));
        }
        let values = pattern.values(entries)?;
        self.numeric(SparseColMatRef::new(pattern.symbolic.as_ref(), &values))
    }

    fn numeric(&mut self, a: SparseColMatRef<'_, usize, f64>) -> Result<()> {
        let par = Par::Seq;
        let scratch = self.symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default());
        let mut buf =
            MemBuffer::try_new(scratch).map_err(|e| Error::Numerical(format!("Cholesky workspace: {e:?}")))?;
        self.symbolic
            .factorize_numeric_llt(
                &mut self.values,
                a,
                Side::Lower,
                Default::default(),
                par,
                MemStack::new(&mut buf),
                Default::default(),
            )
            .map_err(|e| Error::Numerical(format!("matrix is not positive definite: {e:?}")))?;
        Ok(())
    }

    pub fn dim(&self) -> usize {
        self.n
    }

    /// Solves A X = B for `k` right-hand sides stored one after another in `rhs`.
    pub fn solve(&self, rhs: &mut [f64], k: usize) -> Result<()> {
        assert_eq!(rhs.len(), self.n * k, "right-hand side has the wrong length");
        let par = Par::Seq;
        let mut b = Mat::<f64>::from_fn(self.n, k, |i, j| rhs[j * self.n + i]);
        let scratch = self.symbolic.solve_in_place_scratch::<f64>(k, par);
        let mut buf =
            MemBuffer::try_new(scratch).map_err(|e| Error::Numerical(format!("Cholesky workspace: {e:?}")))?;
        LltRef::new(&self.symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            b.as_mut(),
            par,
            MemStack::new(&mut buf),
        );
        for j in 0..k {
            for i in 0..self.n {
                rhs[j * self.n + i] = b[(i, j)];
            }
        }
        Ok(())
    }
}

/// The lower triangle's layout of a symmetric matrix given by a list of
/// (row, column, value) entries, and where each entry lands in it: matrices
/// listed by the same entries in the same order (new values, the area
/// passes') are then laid out without sorting, which took as long as their
/// factorization.
pub struct Pattern {
    n: usize,
    /// Each entry's (row, column), lower triangle, as first listed.
    at: Vec<(u32, u32)>,
    /// Each entry's place among the matrix's values.
    slot: Vec<u32>,
    symbolic: SymbolicSparseColMat<usize>,
}

impl Pattern {
    pub fn new(n: usize, entries: &[(u32, u32, f64)]) -> Result<Pattern> {
        let at: Vec<(u32, u32)> = entries.iter().map(|&(r, c, _)| (r.max(c), r.min(c))).collect();
        if let Some(&(r, c)) = at.iter().find(|&&(r, _)| r as usize >= n) {
            return Err(Error::Numerical(format!("matrix entry ({r}, {c}) outside a {n} x {n} system")));
        }
        let mut order: Vec<u32> = (0..at.len() as u32).collect();
        order.sort_unstable_by_key(|&k| (at[k as usize].1, at[k as usize].0));
        let (mut slot, mut col_ptr, mut row_idx) = (vec![0u32; at.len()], vec![0usize; n + 1], Vec::new());
        let mut last = None;
        for k in order {
            let (r, c) = at[k as usize];
            if last != Some((r, c)) {
                row_idx.push(r as usize);
                col_ptr[c as usize + 1] += 1;
                last = Some((r, c));
            }
            slot[k as usize] = row_idx.len() as u32 - 1;
        }
        for c in 0..n {
            col_ptr[c + 1] += col_ptr[c];
        }
        // Sorted and without repeats by construction, which is what it checks.
        let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        Ok(Pattern { n, at, slot, symbolic })
    }

    /// The matrix's values (in this layout) for `entries`, which must list
    /// the same (row, column) pairs in the same order as the first.
    fn values(&self, entries: &[(u32, u32, f64)]) -> Result<Vec<f64>> {
        let same = entries.len() == self.at.len()
            && entries.iter().zip(&self.at).all(|(&(r, c, _), &rc)| (r.max(c), r.min(c)) == rc);
        if !same {
            return Err(Error::Numerical("a matrix listed in another pattern than its layout's".into()));
        }
        let mut values = vec![0.0; self.symbolic.row_idx().len()];
        for (&(_, _, v), &k) in entries.iter().zip(&self.slot) {
            values[k as usize] += v;
        }
        Ok(values)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_small_spd_system() {
        // [4 1 0; 1 3 1; 0 1 2] x = [1 2 3], duplicates summed.
        let e = [(0, 0, 2.0), (0, 0, 2.0), (1, 0, 1.0), (1, 1, 3.0), (2, 1, 1.0), (1, 2, 0.0), (2, 2, 2.0)];
        let c = Cholesky::factor(3, &e).unwrap();
        let mut b = vec![1.0, 2.0, 3.0];
        c.solve(&mut b, 1).unwrap();
        let x = b;
        let r = [4.0 * x[0] + x[1] - 1.0, x[0] + 3.0 * x[1] + x[2] - 2.0, x[1] + 2.0 * x[2] - 3.0];
        assert!(r.iter().all(|v| v.abs() < 1e-12), "{r:?}");
    }

    /// A matrix laid out once and refactored with new values solves as if
    /// assembled from scratch; entries listed otherwise are refused.
    #[test]
    fn pattern_refactors_new_values() {
        let entries =
            |d: f64| vec![(0, 0, d), (1, 0, 1.0), (0, 1, 0.0), (1, 1, 3.0), (2, 1, 1.0), (2, 2, 2.0), (0, 0, 1.0)];
        let mut c = Cholesky::factor_supernodal(3, &entries(3.0)).unwrap();
        let pattern = Pattern::new(3, &entries(3.0)).unwrap();
        c.refactor_in(&pattern, &entries(9.0)).unwrap();
        let mut x = vec![1.0, 2.0, 3.0];
        c.solve(&mut x, 1).unwrap();
        // [10 1 0; 1 3 1; 0 1 2] x = [1 2 3]
        let r = [10.0 * x[0] + x[1] - 1.0, x[0] + 3.0 * x[1] + x[2] - 2.0, x[1] + 2.0 * x[2] - 3.0];
        assert!(r.iter().all(|v| v.abs() < 1e-12), "{r:?}");
        let mut other = entries(9.0);
        other.swap(0, 1);
        assert!(c.refactor_in(&pattern, &other).is_err());
        assert!(c.refactor_in(&pattern, &other[1..]).is_err());
        assert!(Pattern::new(2, &entries(1.0)).is_err());
    }

    #[test]
    fn rejects_indefinite() {
        assert!(Cholesky::factor(2, &[(0, 0, 1.0), (1, 1, -1.0)]).is_err());
    }
}

//! Non-negative least squares on the normal equations, for the tiny
//! systems of SSDR's weight update (a vertex's handful of candidate
//! bones): minimize ½ xᵀ G x − hᵀ x subject to x ≥ 0, by the active-set
//! method of Lawson and Hanson (1974, "Solving least squares problems",
//! chapter 23). Hand-written: faer has no constrained solver, and these
//! systems have at most a dozen unknowns, where a dense Cholesky of the
//! passive set is all it takes.

/// The solution of `min ½ xᵀ G x − hᵀ x, x ≥ 0` for `G` (n x n, row-major,
/// symmetric positive semi-definite) and `h`.
pub fn solve(g: &[f64], h: &[f64]) -> Vec<f64> {
    let n = h.len();
    let mut x = vec![0.0; n];
    let mut passive = vec![false; n];
    for _ in 0..3 * n + 3 {
        // The negative gradient; a zero variable whose entry is positive
        // would lower the objective by growing.
        let grad: Vec<f64> = (0..n).map(|i| h[i] - (0..n).map(|j| g[i * n + j] * x[j]).sum::<f64>()).collect();
        let scale = h.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
        let Some(enter) =
            (0..n).filter(|&i| !passive[i] && grad[i] > 1e-12 * scale).max_by(|&a, &b| grad[a].total_cmp(&grad[b]))
        else {
            break;
        };
        passive[enter] = true;
        // Inner loop: solve on the passive set; step back to stay feasible.
        // Each step takes at least one variable out, so n + 1 steps end it;
        // a system that gives no finite solution (degenerate input) keeps
        // the last feasible x.
        for _ in 0..=n {
            let z = solve_passive(g, h, &passive);
            if z.iter().any(|v| !v.is_finite()) {
                return x;
            }
            if (0..n).all(|i| !passive[i] || z[i] > 0.0) {
                x = z;
                break;
            }
            let alpha = (0..n)
                .filter(|&i| passive[i] && z[i] <= 0.0)
                .map(|i| x[i] / (x[i] - z[i]).max(1e-300))
                .fold(1.0f64, f64::min);
            for i in 0..n {
                x[i] += alpha * (z[i] - x[i]);
                if passive[i] && x[i] <= 1e-15 {
                    (passive[i], x[i]) = (false, 0.0);
                }
            }
            if !passive.iter().any(|&p| p) {
                break;
            }
        }
    }
    x
}

/// The unconstrained minimizer over the passive variables (the others
/// zero), by Cholesky with a tiny ridge for a singular G.
/// Weight of the sum-to-one row, relative to the mean diagonal of the
/// normal equations: large enough that SSDR's weights sum to one within
/// 1e-3 before they are normalized.
pub const SUM_TO_ONE: f64 = 1e3;

/// The normal equations of a weight fit, summed one observation at a
/// time: each a point's place under every candidate bone (`cols`) and
/// where it should be (`target`).
pub struct NormalEquations {
    n: usize,
    g: Vec<f64>,
    h: Vec<f64>,
}

impl NormalEquations {
    pub fn new(n: usize) -> NormalEquations {
        NormalEquations { n, g: vec![0.0; n * n], h: vec![0.0; n] }
    }

    pub fn add(&mut self, cols: &[glam::Vec3], target: glam::Vec3) {
        let n = self.n;
        for i in 0..n {
            self.h[i] += cols[i].dot(target) as f64;
            for j in 0..=i {
                self.g[i * n + j] += cols[i].dot(cols[j]) as f64;
            }
        }
    }

    /// The non-negative weights, summing to one ([`solve_weights`]).
    pub fn solve_weights(mut self) -> Vec<f64> {
        let n = self.n;
        for i in 0..n {
            for j in 0..i {
                self.g[j * n + i] = self.g[i * n + j];
            }
        }
        solve_weights(self.g, self.h)
    }
}

/// [`solve`] for weights: `g` and `h` (n x n and n) with a heavy row asking
/// the unknowns to sum to one added ([`SUM_TO_ONE`]), SSDR's weight solve.
pub fn solve_weights(mut g: Vec<f64>, mut h: Vec<f64>) -> Vec<f64> {
    let n = h.len();
    let mean_diag = (0..n).map(|i| g[i * n + i]).sum::<f64>() / n.max(1) as f64;
    let mu = SUM_TO_ONE * mean_diag.max(1e-30);
    for i in 0..n {
        h[i] += mu;
        for j in 0..n {
            g[i * n + j] += mu;
        }
    }
    solve(&g, &h)
}

/// A sample's influences from its candidate bones: the weights `solve`
/// gives over `cand`, the [`INFLUENCES`](super::INFLUENCES) largest kept and
/// solved again if any was dropped, scaled to sum to one; `None` if they
/// sum to nothing.
pub fn influences(cand: &[u16], solve: impl Fn(&[u16]) -> Vec<f64>) -> Option<[(u16, f32); super::INFLUENCES]> {
    let mut ranked: Vec<(u16, f64)> = cand.iter().copied().zip(solve(cand)).filter(|x| x.1 > 0.0).collect();
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1));
    ranked.truncate(super::INFLUENCES);
    let kept: Vec<u16> = ranked.iter().map(|x| x.0).collect();
    let w = if kept.len() < cand.len() { solve(&kept) } else { ranked.iter().map(|x| x.1).collect() };
    let total: f64 = w.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return None;
    }
    let mut inf = [(0u16, 0.0f32); super::INFLUENCES];
    for (slot, (&b, &x)) in inf.iter_mut().zip(kept.iter().zip(&w)) {
        *slot = (b, (x / total) as f32);
    }
    Some(inf)
}

fn solve_passive(g: &[f64], h: &[f64], passive: &[bool]) -> Vec<f64> {
    let n = h.len();
    let idx: Vec<usize> = (0..n).filter(|&i| passive[i]).collect();
    let m = idx.len();
    let ridge = 1e-12 * idx.iter().map(|&i| g[i * n + i]).fold(1e-300f64, f64::max);
    let mut l = vec![0.0; m * m];
    for a in 0..m {
        for b in 0..=a {
            let mut s = g[idx[a] * n + idx[b]] + if a == b { ridge } else { 0.0 };
            for k in 0..b {
                s -= l[a * m + k] * l[b * m + k];
            }
            l[a * m + b] = if a == b { s.max(1e-300).sqrt() } else { s / l[b * m + b] };
        }
    }
    let mut y: Vec<f64> = idx.iter().map(|&i| h[i]).collect();
    for a in 0..m {
        y[a] = (y[a] - (0..a).map(|k| l[a * m + k] * y[k]).sum::<f64>()) / l[a * m + a];
    }
    for a in (0..m).rev() {
        y[a] = (y[a] - (a + 1..m).map(|k| l[k * m + a] * y[k]).sum::<f64>()) / l[a * m + a];
    }
    let mut z = vec![0.0; n];
    for (a, &i) in idx.iter().enumerate() {
        z[i] = y[a];
    }
    z
}

#[cfg(test)]
mod tests {
    use super::*;

    /// G = AᵀA and h = Aᵀb of a small least-squares problem.
    fn normal(a: &[[f64; 3]], b: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let mut g = vec![0.0; 9];
        let mut h = vec![0.0; 3];
        for (row, &bi) in a.iter().zip(b) {
            for i in 0..3 {
                h[i] += row[i] * bi;
                for j in 0..3 {
                    g[i * 3 + j] += row[i] * row[j];
                }
            }
        }
        (g, h)
    }

    #[test]
    fn an_interior_solution_is_the_least_squares_one() {
        let a = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]];
        let (g, h) = normal(&a, &[0.2, 0.3, 0.5, 1.0]);
        let x = solve(&g, &h);
        for (xi, want) in x.iter().zip([0.2, 0.3, 0.5]) {
            assert!((xi - want).abs() < 1e-9, "{x:?}");
        }
    }

    #[test]
    fn a_variable_the_data_pulls_negative_is_held_at_zero() {
        // Unconstrained: x = (1, -1, 0.5); with x ≥ 0 the second is 0.
        let a = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let (g, h) = normal(&a, &[1.0, -1.0, 0.5]);
        let x = solve(&g, &h);
        assert_eq!(x[1], 0.0);
        assert!((x[0] - 1.0).abs() < 1e-9 && (x[2] - 0.5).abs() < 1e-9, "{x:?}");
    }

    #[test]
    fn degenerate_systems_end_with_a_finite_answer() {
        // Two identical columns (two bones that move a vertex alike): any
        // split of the weight is a solution; one is returned, finite.
        let x = solve(&[1.0, 1.0, 1.0, 1.0], &[1.0, 1.0]);
        assert!(x.iter().all(|v| v.is_finite() && *v >= 0.0) && (x[0] + x[1] - 1.0).abs() < 1e-6, "{x:?}");
        // Non-finite input (a degenerate fit upstream) ends too.
        let x = solve(&[f64::NAN, 0.0, 0.0, 1.0], &[1.0, 1.0]);
        assert_eq!(x.len(), 2);
    }
}

//! The paper's decoder, as written (Quynh et al. 2011, section 5.3, Eq. 1):
//!
//! ```text
//! min_v  Σ (|Δv_i|² − H_i²)² + Σ |λ(v_i)² − λ_i²|²
//! ```
//!
//! with the anchors fixed and the previous decoded frame, moved by the rigid
//! motion between the two frames' anchors, as the initial guess; solved by
//! L-BFGS (Nocedal 1980) with a backtracking line search. The squares drop
//! the sign of H and the direction of Δv, so this decoder drifts; it is kept
//! so that the difference can be measured.

use super::SolveStats;
use crate::error::{Error, Result};
use crate::grid::stencil::Stencils;
use glam::Vec3;

/// L-BFGS memory.
const MEMORY: usize = 8;
pub const MAX_ITERATIONS: usize = 200;
/// Stop when the gradient norm falls below this fraction of its first value.
pub const GRADIENT_TOLERANCE: f64 = 1e-6;

pub struct PaperSolver {
    st: Stencils,
    anchors: Vec<u32>,
    is_anchor: Vec<bool>,
    lambda: Vec<f32>,
    prev: Option<(Vec<Vec3>, Vec<Vec3>)>,
}

impl PaperSolver {
    pub fn new(st: Stencils, anchors: Vec<u32>) -> PaperSolver {
        let mut is_anchor = vec![false; st.grid.len()];
        for &a in &anchors {
            is_anchor[a as usize] = true;
        }
        PaperSolver { st, anchors, is_anchor, lambda: Vec::new(), prev: None }
    }

    /// Forgets the previous frame (a random-access point, whose seed is the
    /// next frame's guess).
    pub fn reset(&mut self) {
        self.prev = None;
    }

    /// Sets the conformal factor of the current key frame.
    pub fn set_lambda(&mut self, lambda: &[f32]) {
        self.lambda = lambda.to_vec();
    }

    /// Energy and gradient (per coordinate, f64) of Eq. 1 at `x`, scaled by `s4`.
    fn energy(&self, x: &[Vec3], h: &[f32], s4: f64, grad: &mut [f64]) -> f64 {
        grad.iter_mut().for_each(|g| *g = 0.0);
        let mut e = 0.0;
        for v in 0..x.len() {
            let s = self.st.nbr[v];
            let lap = self.st.laplacian(x, v).as_dvec3();
            let r = (lap.length_squared() - (h[v] as f64).powi(2)) / s4.sqrt();
            e += r * r;
            // d r / d x_v = 2 lap / sqrt(s4); d/d neighbour = -lap/2 / sqrt(s4)
            let g = lap * (4.0 * r / s4.sqrt());
            for k in 0..3 {
                grad[3 * v + k] += g[k];
                for &nb in &s {
                    grad[3 * nb as usize + k] -= 0.25 * g[k];
                }
            }
            // λ term: λ(v) = mean |x_v - x_p|.
            let mut lam = 0.0;
            let mut dirs = [glam::DVec3::ZERO; 4];
            for (k, &nb) in s.iter().enumerate() {
                let d = (x[v] - x[nb as usize]).as_dvec3();
                let l = d.length().max(1e-300);
                lam += 0.25 * l;
                dirs[k] = d / l;
            }
            let target = self.lambda.get(v).copied().unwrap_or(0.0) as f64;
            let r2 = (lam * lam - target * target) / s4.sqrt();
            e += r2 * r2;
            let coef = 2.0 * r2 * 2.0 * lam / s4.sqrt();
            for (k, &nb) in s.iter().enumerate() {
                let g = dirs[k] * (0.25 * coef);
                for c in 0..3 {
                    grad[3 * v + c] += g[c];
                    grad[3 * nb as usize + c] -= g[c];
                }
            }
        }
        for (v, &a) in self.is_anchor.iter().enumerate() {
            if a {
                grad[3 * v..3 * v + 3].iter_mut().for_each(|g| *g = 0.0);
            }
        }
        e
    }

    pub fn solve_frame(
        &mut self,
        h: &[f32],
        anchors: &[Vec3],
        init: Option<&[Vec3]>,
    ) -> Result<(Vec<Vec3>, SolveStats)> {
        let n = self.st.grid.len();
        if h.len() != n || anchors.len() != self.anchors.len() || self.lambda.len() != n {
            return Err(Error::Argument("frame data does not match the grid, anchors or key frame".into()));
        }
        let mut x: Vec<Vec3> = super::warm_start(init, &self.prev, anchors)?;
        for (k, &a) in self.anchors.iter().enumerate() {
            x[a as usize] = anchors[k];
        }
        // Scale the energy to order one: residuals are lengths squared.
        let s = (self.lambda.iter().map(|&l| l as f64).sum::<f64>() / n as f64).max(1e-12);
        let s4 = s.powi(4);
        let mut g = vec![0.0; 3 * n];
        let mut e = self.energy(&x, h, s4, &mut g);
        let g0 = g.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-300);
        let mut hist: History = Default::default();
        let mut stats = SolveStats::default();
        let mut g_new = vec![0.0; 3 * n];
        for it in 0..MAX_ITERATIONS {
            let d = lbfgs_direction(&g, &hist, s);
            let slope = dot(&g, &d);
            if slope >= 0.0 {
                hist.clear();
                continue;
            }
            // Backtracking (Armijo) line search.
            let mut t = 1.0;
            let mut accepted = false;
            let mut trial = x.clone();
            for _ in 0..30 {
                for v in 0..n {
                    trial[v] = x[v] + Vec3::new(d[3 * v] as f32, d[3 * v + 1] as f32, d[3 * v + 2] as f32) * t as f32;
                }
                let e_new = self.energy(&trial, h, s4, &mut g_new);
                if e_new <= e + 1e-4 * t * slope {
                    let svec: Vec<f64> = d.iter().map(|v| v * t).collect();
                    let yvec: Vec<f64> = g_new.iter().zip(&g).map(|(a, b)| a - b).collect();
                    let sy = dot(&svec, &yvec);
                    if sy > 1e-300 {
                        hist.push_back((svec, yvec, 1.0 / sy));
                        if hist.len() > MEMORY {
                            hist.pop_front();
                        }
                    }
                    std::mem::swap(&mut x, &mut trial);
                    std::mem::swap(&mut g, &mut g_new);
                    e = e_new;
                    accepted = true;
                    break;
                }
                t *= 0.5;
            }
            stats.iterations = it + 1;
            stats.residual = dot(&g, &g).sqrt() / g0;
            if !accepted || stats.residual < GRADIENT_TOLERANCE {
                stats.converged = stats.residual < GRADIENT_TOLERANCE;
                break;
            }
        }
        if x.iter().any(|p| !p.is_finite()) {
            return Err(Error::Numerical("the paper solve produced non-finite positions".into()));
        }
        self.prev = Some((x.clone(), anchors.to_vec()));
        Ok((x, stats))
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

/// L-BFGS's memory: the last steps s, gradient changes y and 1 / (s · y).
type History = std::collections::VecDeque<(Vec<f64>, Vec<f64>, f64)>;

/// The L-BFGS search direction from gradient `g` (Nocedal and Wright's
/// two-loop recursion); without history, the steepest descent scaled to
/// a step of about 1 % of `s`, the energy's length scale.
fn lbfgs_direction(g: &[f64], hist: &History, s: f64) -> Vec<f64> {
    let mut d: Vec<f64> = g.iter().map(|v| -v).collect();
    let mut alphas = Vec::with_capacity(hist.len());
    for (sv, yv, rho) in hist.iter().rev() {
        let a = rho * dot(sv, &d);
        axpy(-a, yv, &mut d);
        alphas.push(a);
    }
    if let Some((sv, yv, _)) = hist.back() {
        let gamma = dot(sv, yv) / dot(yv, yv).max(1e-300);
        d.iter_mut().for_each(|v| *v *= gamma);
    } else {
        let gn = dot(g, g).sqrt().max(1e-300);
        d.iter_mut().for_each(|v| *v *= s * 1e-2 / gn);
    }
    for ((sv, yv, rho), a) in hist.iter().zip(alphas.iter().rev()) {
        let b = rho * dot(yv, &d);
        axpy(a - b, sv, &mut d);
    }
    d
}

//! What a conformal geometry video stores about each grid frame (the paper,
//! section 5.1), computed with the grid's four-sample stencil
//! ([`crate::grid::Grid::stencil`]):
//!
//! - conformal factor λ(v) = mean length of the four grid edges at v;
//! - mean curvature H(v) = (Δv, n(v)), Δv = v − mean of the four neighbours,
//!   n(v) the unit normal x_u × x_v from central differences
//!   x_u = (v₊ᵤ − v₋ᵤ)/2, x_v = (v₊ᵥ − v₋ᵥ)/2;
//! - for the project's decoder, the tangential part of Δv in the grid
//!   directions: Δv = a x_u + b x_v + c n. On a conformal grid a = b = 0
//!   (x_uu + x_vv is normal there); on a grid that trades angles for area
//!   they carry the metric's Christoffel terms, which depend on the metric
//!   only and so, like λ, change little over a near-isometric motion.

use super::Grid;
use glam::Vec3;

/// Differential quantities of one grid frame.
#[derive(Debug, Clone, Default)]
pub struct Features {
    pub lambda: Vec<f32>,
    pub h: Vec<f32>,
    pub a: Vec<f32>,
    pub b: Vec<f32>,
}

/// Precomputed stencils of a grid.
#[derive(Debug, Clone)]
pub struct Stencils {
    pub grid: Grid,
    /// +u, +v, -u, -v neighbours of each sample.
    pub nbr: Vec<[u32; 4]>,
}

impl Stencils {
    pub fn new(grid: Grid) -> Stencils {
        Stencils { grid, nbr: (0..grid.len() as u32).map(|i| grid.stencil(i)).collect() }
    }

    /// Uniform Laplacian Δv = v − mean of the stencil.
    pub fn laplacian(&self, x: &[Vec3], v: usize) -> Vec3 {
        let s = self.nbr[v];
        x[v] - (x[s[0] as usize] + x[s[1] as usize] + x[s[2] as usize] + x[s[3] as usize]) * 0.25
    }

    /// Central differences (x_u, x_v).
    pub fn tangents(&self, x: &[Vec3], v: usize) -> (Vec3, Vec3) {
        let s = self.nbr[v];
        ((x[s[0] as usize] - x[s[2] as usize]) * 0.5, (x[s[1] as usize] - x[s[3] as usize]) * 0.5)
    }

    /// λ(v): mean length of the four stencil edges.
    pub fn lambda(&self, x: &[Vec3], v: usize) -> f32 {
        self.nbr[v].iter().map(|&s| x[v].distance(x[s as usize])).sum::<f32>() * 0.25
    }

    /// Everything a CGV frame stores about grid positions `x`.
    pub fn features(&self, x: &[Vec3]) -> Features {
        let n = x.len();
        let mut f = Features {
            lambda: Vec::with_capacity(n),
            h: Vec::with_capacity(n),
            a: Vec::with_capacity(n),
            b: Vec::with_capacity(n),
        };
        for v in 0..n {
            let lap = self.laplacian(x, v);
            let (xu, xv) = self.tangents(x, v);
            let nv = xu.cross(xv).normalize_or_zero();
            f.lambda.push(self.lambda(x, v));
            f.h.push(lap.dot(nv));
            // Solve [xu xv n] (a, b, c) = lap by Cramer's rule.
            let det = xu.cross(xv).dot(nv);
            let (a, b) =
                if det.abs() > 1e-20 { (lap.cross(xv).dot(nv) / det, xu.cross(lap).dot(nv) / det) } else { (0.0, 0.0) };
            f.a.push(a);
            f.b.push(b);
        }
        f
    }

    /// A field after `passes` averaging passes, each of which halves a
    /// sample's own weight against its four neighbours' mean.
    pub fn smooth(&self, mut v: Vec<Vec3>, passes: usize) -> Vec<Vec3> {
        if passes == 0 {
            // Most frames' corrections (filter 0): no scratch copy of the field.
            return v;
        }
        let mut next = v.clone();
        for _ in 0..passes {
            for (i, o) in next.iter_mut().enumerate() {
                let s = self.nbr[i];
                let mean = (v[s[0] as usize] + v[s[1] as usize] + v[s[2] as usize] + v[s[3] as usize]) * 0.25;
                *o = (v[i] + mean) * 0.5;
            }
            std::mem::swap(&mut v, &mut next);
        }
        v
    }
}

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
    pub fn smooth(&self, v: Vec<Vec3>, passes: usize) -> Vec<Vec3> {
        if passes == 0 {
            // Most frames' corrections (filter 0): no scratch copy of the field.
            return v;
        }
        // Flat components, so a row's x, y and z run in one contiguous loop.
        let mut v: Vec<f32> = v.iter().flat_map(|p| p.to_array()).collect();
        let mut next = v.clone();
        for _ in 0..passes {
            self.smooth_pass(&v, &mut next);
            std::mem::swap(&mut v, &mut next);
        }
        v.chunks_exact(3).map(Vec3::from_slice).collect()
    }

    /// One averaging pass from `v` into `o` (x, y, z of each sample in turn).
    /// Inside the square a sample's neighbours are ±1 and ±n away, so rows of
    /// contiguous slices stand in for the table there and the compiler
    /// vectorizes them (most of the encoder's time at N = 256 was this
    /// loop); only the border, where the seams glue, reads the table. Each
    /// component's sums are the ones `Vec3` arithmetic makes, in its order.
    fn smooth_pass(&self, v: &[f32], o: &mut [f32]) {
        let n = self.grid.n;
        let mut by_table = |i: usize| {
            let s = self.nbr[i].map(|s| 3 * s as usize);
            for c in 0..3 {
                let sum = v[s[0] + c] + v[s[1] + c] + v[s[2] + c] + v[s[3] + c];
                o[3 * i + c] = (v[3 * i + c] + sum * 0.25) * 0.5;
            }
        };
        if n < 3 {
            (0..n * n).for_each(by_table);
            return;
        }
        for j in 0..n {
            let row = j * n;
            if j == 0 || j == n - 1 {
                (row..row + n).for_each(&mut by_table);
                continue;
            }
            by_table(row);
            by_table(row + n - 1);
        }
        for j in 1..n - 1 {
            let row = 3 * j * n;
            let m = 3 * n;
            let (below, here, above) = (&v[row - m + 3..row - 3], &v[row..row + m], &v[row + m + 3..row + 2 * m - 3]);
            let out = &mut o[row + 3..row + m - 3];
            for (k, o) in out.iter_mut().enumerate() {
                let mean = (here[k + 6] + above[k] + here[k] + below[k]) * 0.25;
                *o = (here[k + 3] + mean) * 0.5;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smoothing_by_rows_is_the_tables_average_to_the_bit() {
        for n in [2usize, 4, 6, 16] {
            let st = Stencils::new(Grid { n });
            // A field with no symmetry, so a wrong neighbour shows.
            let v: Vec<Vec3> =
                (0..n * n).map(|i| Vec3::new((i as f32 * 0.37).sin(), (i * i % 7) as f32, i as f32 / 3.0)).collect();
            let mut by_table = v.clone();
            for _ in 0..3 {
                by_table = (0..n * n)
                    .map(|i| {
                        let s = st.nbr[i];
                        let mean = (by_table[s[0] as usize]
                            + by_table[s[1] as usize]
                            + by_table[s[2] as usize]
                            + by_table[s[3] as usize])
                            * 0.25;
                        (by_table[i] + mean) * 0.5
                    })
                    .collect();
            }
            assert_eq!(st.smooth(v, 3), by_table, "n = {n}");
        }
    }
}

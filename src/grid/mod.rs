//! The seamless N × N grid of a geometry image.
//!
//! Sample (i, j), 0 ≤ i, j < N, sits at the cell centre
//! `u = -1 + (2i + 1) / N`, `v = -1 + (2j + 1) / N` of the square [-1, 1]²;
//! it is stored at index `j N + i`. The square is folded shut along its
//! border as in the octahedral geometry images of Praun & Hoppe (2003): each
//! half of a side is glued to the other half by the half-turn about the
//! side's middle. The result is a sphere (a flat orbifold with four cone
//! points of angle π at the middles of the sides; the four corners meet in
//! one ordinary point).
//!
//! **Neighbour rule.** Extend the indices to all integers with the half-turns
//! about the side middles: across the right side `(i, j) ~ (2N-1-i, N-1-j)`,
//! across the left `(i, j) ~ (-1-i, N-1-j)`, across the top
//! `(i, j) ~ (N-1-i, 2N-1-j)`, across the bottom `(i, j) ~ (N-1-i, -1-j)`.
//! The four stencil neighbours of (i, j) are the canonical samples of
//! (i±1, j) and (i, j±1). Every sample has exactly four stencil entries.
//! Next to a cone, two entries are the same sample (for example (N-1, N/2-1)
//! and (N-1, N/2) are each other's neighbour both directly and across the
//! right side), so those samples have three distinct neighbours. N must be
//! even, so no sample lies on the border or on a cone.

pub mod coarse;
pub mod stencil;

use crate::error::{Error, Result};
use crate::mesh::Topology;
use glam::DVec2;
pub use stencil::{Features, Stencils};

/// Largest grid size accepted: the largest a `.cgv` file may have
/// ([`crate::format::MAX_GRID`]). Smaller sizes than a file's 16 are
/// allowed here, where the grid's own rules are tested.
pub const MAX_N: usize = crate::format::MAX_GRID as usize;

#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Grid {
    pub n: usize,
}

impl Grid {
    pub fn new(n: usize) -> Result<Grid> {
        if !(4..=MAX_N).contains(&n) || n % 2 != 0 {
            return Err(Error::Argument(format!("grid size {n} must be even and in 4..={MAX_N}")));
        }
        Ok(Grid { n })
    }

    pub fn len(&self) -> usize {
        self.n * self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    pub fn index(&self, i: usize, j: usize) -> u32 {
        (j * self.n + i) as u32
    }

    /// Position of sample (i, j) (any integers: the extended lattice) in the plane.
    pub fn uv(&self, i: i64, j: i64) -> DVec2 {
        let n = self.n as f64;
        DVec2::new(-1.0 + (2 * i + 1) as f64 / n, -1.0 + (2 * j + 1) as f64 / n)
    }

    /// The sample that the extended-lattice point (a, b) is glued to.
    pub fn canonical(&self, a: i64, b: i64) -> (usize, usize) {
        let n = self.n as i64;
        // Translations by 4 in u or v (2N in index) are in the gluing group.
        let (mut a, mut b) = (a.rem_euclid(2 * n), b.rem_euclid(2 * n));
        loop {
            if a >= n {
                (a, b) = (2 * n - 1 - a, n - 1 - b);
            } else if a < 0 {
                (a, b) = (-1 - a, n - 1 - b);
            } else if b >= n {
                (a, b) = (n - 1 - a, 2 * n - 1 - b);
            } else if b < 0 {
                (a, b) = (n - 1 - a, -1 - b);
            } else {
                return (a as usize, b as usize);
            }
        }
    }

    /// The point of the square [-1, 1]² that the plane point `p` is glued
    /// to: the continuous form of [`canonical`](Self::canonical) (the same
    /// half-turns about the side middles; a translation by 4 is two of them).
    pub fn canonical_uv(p: DVec2) -> DVec2 {
        let (mut u, mut v) = ((p.x + 1.0).rem_euclid(4.0) - 1.0, (p.y + 1.0).rem_euclid(4.0) - 1.0);
        for _ in 0..8 {
            if u > 1.0 {
                (u, v) = (2.0 - u, -v);
            } else if u < -1.0 {
                (u, v) = (-2.0 - u, -v);
            } else if v > 1.0 {
                (u, v) = (-u, 2.0 - v);
            } else if v < -1.0 {
                (u, v) = (-u, -2.0 - v);
            } else {
                break;
            }
        }
        DVec2::new(u.clamp(-1.0, 1.0), v.clamp(-1.0, 1.0))
    }

    pub fn canonical_index(&self, a: i64, b: i64) -> u32 {
        let (i, j) = self.canonical(a, b);
        self.index(i, j)
    }

    /// The four stencil neighbours of sample `idx`: +u, +v, -u, -v.
    pub fn stencil(&self, idx: u32) -> [u32; 4] {
        let (i, j) = ((idx as usize % self.n) as i64, (idx as usize / self.n) as i64);
        [
            self.canonical_index(i + 1, j),
            self.canonical_index(i, j + 1),
            self.canonical_index(i - 1, j),
            self.canonical_index(i, j - 1),
        ]
    }

    /// The distinct neighbours of sample `idx`.
    pub fn neighbours(&self, idx: u32) -> Vec<u32> {
        let mut s = self.stencil(idx).to_vec();
        s.sort_unstable();
        s.dedup();
        s
    }

    /// The grid's quads, counter-clockwise in the square, each once; quads
    /// that collapse at a cone are left out.
    pub fn quads(&self) -> Vec<[u32; 4]> {
        self.cells().into_iter().map(|(_, q)| q).collect()
    }

    /// [`quads`](Self::quads), each with the extended-lattice point of its
    /// first corner (the cell's place in the plane).
    pub fn cells(&self) -> Vec<((i64, i64), [u32; 4])> {
        let n = self.n as i64;
        let mut seen = std::collections::HashSet::new();
        let mut quads = Vec::with_capacity(self.len());
        for b in -1..n {
            for a in -1..n {
                let q = [(a, b), (a + 1, b), (a + 1, b + 1), (a, b + 1)].map(|(x, y)| self.canonical_index(x, y));
                if (0..n - 1).contains(&a) && (0..n - 1).contains(&b) {
                    // Inside the square: four distinct samples, and no other
                    // cell of the lattice folds onto these (only border
                    // cells reach across a side), so no check is needed.
                    quads.push(((a, b), q));
                    continue;
                }
                let mut key = q;
                key.sort_unstable();
                if key[0] == key[1] || key[1] == key[2] || key[2] == key[3] {
                    continue;
                }
                if seen.insert(key) {
                    quads.push(((a, b), q));
                }
            }
        }
        quads
    }

    /// The grid mesh: each quad split along its (0, 2) diagonal. A closed
    /// genus-0 triangle mesh with N² vertices and 2N² - 4 triangles.
    pub fn topology(&self) -> Topology {
        let faces = self.quads().iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        Topology { vertex_count: self.len(), faces }
    }
}

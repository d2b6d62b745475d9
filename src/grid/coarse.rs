//! A field on a coarser grid: the tangential corrections are coded at half
//! (or quarter) resolution, because they are smooth (on samba, 2 x 2 means
//! keep 94 % of their energy) and matter little for the shape.
//!
//! One level halves the grid. A coarse sample is the mean of its 2 x 2
//! block; back on the fine grid, each sample is the bilinear blend of its
//! four nearest coarse samples (weights 9, 3, 3, 1 over 16), taken across
//! the seams by the coarse grid's own gluing: with N even, the half-turns
//! that fold the fine square map 2 x 2 blocks onto 2 x 2 blocks, so the
//! coarse grid of N / 2 is folded by the same rule (`super` module docs).

use super::Grid;

/// The grid halved `levels` times, if every level is even-sized and at
/// least `min` samples a side.
pub fn coarser(grid: Grid, levels: u8, min: usize) -> Option<Grid> {
    let mut n = grid.n;
    for _ in 0..levels {
        if n % 2 != 0 || n / 2 < min || (n / 2) % 2 != 0 {
            return None;
        }
        n /= 2;
    }
    Some(Grid { n })
}

/// `v` (on `fine`) halved `levels` times: means of 2 x 2 blocks.
pub fn shrink(fine: Grid, v: &[f32], levels: u8) -> Vec<f32> {
    let (mut n, mut v) = (fine.n, v.to_vec());
    for _ in 0..levels {
        let m = n / 2;
        let at = |i: usize, j: usize| v[j * n + i];
        v = (0..m * m)
            .map(|k| {
                let (i, j) = (2 * (k % m), 2 * (k / m));
                (at(i, j) + at(i + 1, j) + at(i, j + 1) + at(i + 1, j + 1)) * 0.25
            })
            .collect();
        n = m;
    }
    v
}

/// `v` (on `coarse`) doubled `levels` times, bilinearly across the seams.
pub fn expand(coarse: Grid, v: &[f32], levels: u8) -> Vec<f32> {
    let (mut g, mut v) = (coarse, v.to_vec());
    for _ in 0..levels {
        let n = 2 * g.n;
        v = (0..n * n)
            .map(|k| {
                let (i, j) = ((k % n) as i64, (k / n) as i64);
                // The nearest coarse sample and the next one towards this
                // fine sample, in each direction.
                let (ci, cj) = (i / 2, j / 2);
                let (di, dj) = (if i % 2 == 0 { -1 } else { 1 }, if j % 2 == 0 { -1 } else { 1 });
                let at = |a: i64, b: i64| v[g.canonical_index(a, b) as usize];
                (9.0 * at(ci, cj) + 3.0 * at(ci + di, cj) + 3.0 * at(ci, cj + dj) + at(ci + di, cj + dj)) / 16.0
            })
            .collect();
        g = Grid { n };
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_field_stays_constant_both_ways() {
        let fine = Grid::new(16).unwrap();
        let coarse = coarser(fine, 2, 4).unwrap();
        assert_eq!(coarse.n, 4);
        let s = shrink(fine, &vec![2.5; fine.len()], 2);
        assert_eq!(s.len(), 16);
        assert!(s.iter().all(|&x| (x - 2.5).abs() < 1e-6));
        let e = expand(coarse, &s, 2);
        assert_eq!(e.len(), fine.len());
        assert!(e.iter().all(|&x| (x - 2.5).abs() < 1e-6));
    }

    #[test]
    fn expanding_blends_across_the_seam_by_the_grid_gluing() {
        // A coarse field that is 1 at one sample on the right side: the fine
        // samples across that side, where the half-turn takes it, see it.
        let coarse = Grid::new(8).unwrap();
        let mut v = vec![0.0; coarse.len()];
        v[coarse.index(7, 1) as usize] = 1.0;
        let e = expand(coarse, &v, 1);
        let fine = Grid::new(16).unwrap();
        // Fine (15, 2) sits in the block of coarse (7, 1): weight 9/16.
        assert!((e[fine.index(15, 2) as usize] - 9.0 / 16.0).abs() < 1e-6);
        // Across the right side, coarse (7, 1) is glued to (8, 6): the fine
        // sample (15, 13), in the block of coarse (7, 6), takes 3/16 of it.
        assert!((e[fine.index(15, 13) as usize] - 3.0 / 16.0).abs() < 1e-6);
        // Far from it, nothing.
        assert_eq!(e[fine.index(4, 8) as usize], 0.0);
    }

    #[test]
    fn sizes_that_do_not_halve_evenly_are_refused() {
        let g = Grid::new(20).unwrap();
        assert_eq!(coarser(g, 1, 4).map(|g| g.n), Some(10));
        assert_eq!(coarser(g, 2, 4), None, "10 halves to 5, odd");
        assert_eq!(coarser(Grid::new(128).unwrap(), 2, 16).map(|g| g.n), Some(32));
        assert_eq!(coarser(Grid::new(32).unwrap(), 1, 16).map(|g| g.n), Some(16));
        assert_eq!(coarser(Grid::new(32).unwrap(), 2, 16), None);
    }
}

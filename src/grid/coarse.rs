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
        v = double(g, &v);
        g = Grid { n: 2 * g.n };
    }
    v
}

/// One doubling: each fine sample blends the nearest coarse sample and the
/// next ones towards it in each direction (9, 3, 3, 1 over 16).
fn double(g: Grid, v: &[f32]) -> Vec<f32> {
    let (m, n) = (g.n, 2 * g.n);
    // Towards the next coarse sample: down for even fine indices, up for odd.
    let toward = |i: usize| if i % 2 == 0 { (i / 2) as i64 - 1 } else { (i / 2) as i64 + 1 };
    let blend = |a: f32, b: f32, c: f32, d: f32| (9.0 * a + 3.0 * b + 3.0 * c + d) / 16.0;
    // Any sample, by the gluing rule.
    let glued = |i: usize, j: usize| {
        let at = |a: i64, b: i64| v[g.canonical_index(a, b) as usize];
        let (ci, cj, ti, tj) = ((i / 2) as i64, (j / 2) as i64, toward(i), toward(j));
        blend(at(ci, cj), at(ti, cj), at(ci, tj), at(ti, tj))
    };
    let mut out = Vec::with_capacity(n * n);
    for j in 0..n {
        let tj = toward(j);
        if !(0..m as i64).contains(&tj) || n < 4 {
            out.extend((0..n).map(|i| glued(i, j)));
            continue;
        }
        // Inside the coarse square no gluing applies: rows are read directly,
        // as `canonical_index` would index them; only the first and last
        // fine samples of the row reach across a side.
        let (here, next) = (&v[(j / 2) * m..][..m], &v[tj as usize * m..][..m]);
        out.push(glued(0, j));
        out.extend((1..n - 1).map(|i| {
            let (ci, ti) = (i / 2, toward(i) as usize);
            blend(here[ci], here[ti], next[ci], next[ti])
        }));
        out.push(glued(n - 1, j));
    }
    out
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
    fn doubling_reads_the_gluing_everywhere_to_the_bit() {
        // The direct indices inside the square against the gluing rule for
        // every sample, on a field with no symmetry.
        for m in [2, 4, 8] {
            doubling_reads_the_gluing_on(Grid { n: m });
        }
    }

    fn doubling_reads_the_gluing_on(coarse: Grid) {
        let v: Vec<f32> = (0..coarse.len()).map(|k| (k as f32 * 0.61).sin() + (k % 5) as f32).collect();
        let m = coarse.n as i64;
        let by_rule: Vec<f32> = (0..4 * coarse.len() as i64)
            .map(|k| {
                let (i, j) = (k % (2 * m), k / (2 * m));
                let (ci, cj, di, dj) = (i / 2, j / 2, if i % 2 == 0 { -1 } else { 1 }, if j % 2 == 0 { -1 } else { 1 });
                let at = |a: i64, b: i64| v[coarse.canonical_index(a, b) as usize];
                (9.0 * at(ci, cj) + 3.0 * at(ci + di, cj) + 3.0 * at(ci, cj + dj) + at(ci + di, cj + dj)) / 16.0
            })
            .collect();
        assert_eq!(expand(coarse, &v, 1), by_rule);
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

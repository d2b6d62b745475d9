//! The square's symmetries, for [`register`](super::register): the
//! orbifold map puts each cone on a side of the square wherever its cut
//! leaves the corner first, so two frames' maps (or two segments') may
//! differ by a turn of the square, which moves every grid sample and every
//! stored place alike (Aigerman and Lipman 2015, the square orbifold's
//! rotations).

use crate::grid::Grid;
use crate::resample::quantized_place;

/// A symmetry of the square (and of the grid: the sides' middles, where
/// the cones sit, go to sides' middles) as an integer 2 x 2 matrix.
pub type Symmetry = [[i32; 2]; 2];
pub const IDENTITY: Symmetry = [[1, 0], [0, 1]];
/// The square's four turns (its mirrors are no use: see [`symmetry_between`]).
pub const TURNS: [Symmetry; 4] = [[[1, 0], [0, 1]], [[0, -1], [1, 0]], [[-1, 0], [0, -1]], [[0, 1], [-1, 0]]];
/// The sides' middles (top, right, bottom, left), as `crate::param::cut::CONE_UV`.
pub const SIDES: [[i32; 2]; 4] = [[0, 1], [1, 0], [0, -1], [-1, 0]];

pub fn apply(m: Symmetry, p: [i32; 2]) -> [i32; 2] {
    [m[0][0] * p[0] + m[0][1] * p[1], m[1][0] * p[0] + m[1][1] * p[1]]
}

/// The turn of the square taking each cone's side in a frame whose sides
/// hold cones `sides` to its side in the reference's `reference`. Only
/// turns: the frames are oriented alike, so a mirrored assignment means
/// two tracks traded places (a cow's two hind legs), which no symmetry
/// mends.
pub fn symmetry_between(sides: &[usize; 4], reference: &[usize; 4]) -> Option<Symmetry> {
    TURNS.iter().copied().find(|&m| {
        (0..4).all(|a| {
            let b = SIDES.iter().position(|&q| q == apply(m, SIDES[a]));
            b.is_some_and(|b| reference[b] == sides[a])
        })
    })
}

/// Grid frame `g` (a value a sample) moved by the symmetry `m`: sample p
/// goes to m p.
pub fn apply_symmetry<T: Copy>(grid: Grid, g: &[T], m: Symmetry) -> Vec<T> {
    let n = grid.n as i32;
    let mut out = g.to_vec();
    for (s, &p) in g.iter().enumerate() {
        // Centred odd coordinates: sample i at 2i + 1 - N.
        let c = [2 * (s as i32 % n) + 1 - n, 2 * (s as i32 / n) + 1 - n];
        let [x, y] = apply(m, c);
        out[(((y + n - 1) / 2) * n + (x + n - 1) / 2) as usize] = p;
    }
    out
}

/// A stored place moved by the square's symmetry `m` (as
/// [`apply_symmetry`] moves the samples: linear in the centred coordinates).
pub fn turn_place(q: [u32; 2], m: Symmetry) -> [u32; 2] {
    let u = q.map(crate::format::source_mesh::place);
    let t = |r: [i32; 2]| f64::from(r[0]) * u[0] + f64::from(r[1]) * u[1];
    quantized_place(glam::DVec2::new(t(m[0]), t(m[1])))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Each symmetry of the square is found from where it moves the cones,
    /// and four quarter turns of a grid frame give it back.
    #[test]
    fn the_squares_symmetries_are_found_and_applied() {
        let reference = [2, 0, 3, 1];
        for m in &TURNS {
            let m = *m;
            let mut sides = [0; 4];
            for (a, s) in sides.iter_mut().enumerate() {
                let b = SIDES.iter().position(|&q| q == apply(m, SIDES[a])).unwrap_or(0);
                *s = reference[b];
            }
            assert_eq!(symmetry_between(&sides, &reference), Some(m));
        }
        assert_eq!(symmetry_between(&[0, 2, 1, 3], &[0, 1, 2, 3]), None);
        // A mirrored assignment is two tracks swapped, not a turn.
        assert_eq!(symmetry_between(&[0, 3, 2, 1], &[0, 1, 2, 3]), None);
        let grid = Grid { n: 8 };
        let g: Vec<Vec3> = (0..64).map(|s| Vec3::new(s as f32, 0.0, 0.0)).collect();
        let mut h = g.clone();
        for _ in 0..4 {
            h = apply_symmetry(grid, &h, TURNS[1]);
            assert_eq!(h.len(), 64);
        }
        assert_eq!(h, g);
        assert_ne!(apply_symmetry(grid, &g, TURNS[1]), g);
    }
}

//! Bridges: a strip of triangles joining two boundary loops into a tube.
//!
//! The carrier joins its parts into one sphere. A connected sum through one
//! triangle (a thin tube) makes the conformal map squeeze everything past
//! it: the map's scale falls off exponentially along a thin neck, so a part
//! behind one gets few samples. Where two parts each have a hole, joining
//! the two rims by a strip makes a neck as wide as the holes (a body cut at
//! the neck is glued back at the neck). The strip is the loop-to-loop
//! triangulation of Fuchs, Kedem and Uselton 1977 ("Optimal surface
//! reconstruction from planar contours"), taken greedily: each step
//! advances along the rim whose next diagonal is shorter.

use glam::Vec3;

/// The faces of a strip between two boundary loops, each given as its rim
/// vertices in the order the surface runs them (surface on the left of
/// `a[i] -> a[i + 1]`): each rim edge gets one face, oriented as the
/// surface beside it, so the result is a closed tube. `pos` holds the
/// vertices' positions; both rims have at least three vertices.
pub fn strip(a: &[u32], b: &[u32], pos: &[Vec3]) -> Vec<[u32; 3]> {
    let p = |v: u32| pos[v as usize];
    // Start at the closest pair, so the strip does not twist.
    let (mut sa, mut sb, mut best) = (0, 0, f32::INFINITY);
    for (i, &u) in a.iter().enumerate() {
        for (j, &w) in b.iter().enumerate() {
            let d = p(u).distance_squared(p(w));
            if d < best {
                (sa, sb, best) = (i, j, d);
            }
        }
    }
    let (m, n) = (a.len(), b.len());
    // The strip runs `a` backwards and `b` forwards, so both rims' edges
    // appear reversed in it, as a face beside them needs.
    let ra = |k: usize| a[(sa + m - k % m) % m];
    let rb = |l: usize| b[(sb + l) % n];
    let mut faces = Vec::with_capacity(m + n);
    let (mut k, mut l) = (0, 0);
    while k < m || l < n {
        let shorter_a = p(ra(k + 1)).distance(p(rb(l))) <= p(ra(k)).distance(p(rb(l + 1)));
        let advance_a = match (k, l) {
            // The walk must never come back to a diagonal it drew (a
            // strip that ran all of one rim first would close that rim
            // into a fan instead): a rim is finished only when the other
            // is all but finished, and the first run along one rim stops
            // two vertices short of its end.
            _ if k + 1 == m && l + 1 < n => false,
            _ if l + 1 == n && k + 1 < m => true,
            (_, 0) if k + 2 >= m => false,
            (0, _) if l + 2 >= n => true,
            _ => l == n || (k < m && shorter_a),
        };
        if advance_a {
            faces.push([ra(k), ra(k + 1), rb(l)]);
            k += 1;
        } else {
            faces.push([rb(l), ra(k), rb(l + 1)]);
            l += 1;
        }
    }
    faces
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::adjacency::{origin, Adjacency, NONE};
    use crate::mesh::topology::boundary_loops;

    /// Two capped rings of `m` and `n` vertices, the second `shift` above
    /// the first and `offset` aside, bridged: the surface must be closed,
    /// manifold, consistently oriented and free of repeated faces.
    fn bridge_capped_rings(m: usize, n: usize, shift: f32, offset: f32) {
        let ring = |n: usize, y: f32, x: f32| {
            (0..n).map(move |i| {
                let t = i as f32 / n as f32 * std::f32::consts::TAU;
                Vec3::new(x + t.cos(), y, t.sin())
            })
        };
        let mut pos: Vec<Vec3> = ring(m, 0.0, 0.0).chain(ring(n, shift, offset)).collect();
        pos.extend([Vec3::new(0.0, -1.0, 0.0), Vec3::new(offset, shift + 1.0, 0.0)]);
        let (a, b): (Vec<u32>, Vec<u32>) = ((0..m as u32).collect(), (m as u32..(m + n) as u32).collect());
        let (bottom, top) = ((m + n) as u32, (m + n + 1) as u32);
        let mut faces: Vec<[u32; 3]> = (0..m).map(|i| [a[i], a[(i + 1) % m], bottom]).collect();
        faces.extend((0..n).map(|i| [b[(i + 1) % n], b[i], top]));
        let adj = Adjacency::build(&faces);
        let rims: Vec<Vec<u32>> =
            boundary_loops(&faces, &adj).iter().map(|lp| lp.iter().map(|&h| origin(&faces, h)).collect()).collect();
        assert_eq!(rims.len(), 2);
        let bridge = strip(&rims[0], &rims[1], &pos);
        assert_eq!(bridge.len(), m + n);
        faces.extend(bridge);
        let case = format!("rings of {m} and {n}, shifted {shift}, offset {offset}");
        let adj = Adjacency::build(&faces);
        assert!(adj.is_manifold(), "{case}");
        assert!(adj.opposite.iter().all(|&o| o != NONE), "{case}: an edge is left open");
        assert!(adj.inconsistent_edges.is_empty(), "{case}");
        let mut sorted: Vec<[u32; 3]> = faces
            .iter()
            .map(|f| {
                let mut f = *f;
                f.sort_unstable();
                f
            })
            .collect();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), faces.len(), "{case}: a face is repeated");
    }

    #[test]
    fn a_strip_closes_two_capped_rings_into_a_sphere() {
        for (m, n) in [(3, 3), (3, 4), (7, 5), (4, 12), (12, 3)] {
            // Facing rings, and rings far apart or aside, where the
            // greedy walk would run one rim first.
            for (shift, offset) in [(1.0, 0.0), (0.01, 0.0), (5.0, 0.5), (0.0, 3.0)] {
                bridge_capped_rings(m, n, shift, offset);
            }
        }
    }
}

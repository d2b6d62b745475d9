//! A linear bounding volume hierarchy for nearest-point queries on a
//! triangle mesh that is built for one set of queries and dropped: the
//! faces ordered along a Morton curve of their centroids (Lauterbach et
//! al. 2009, "Fast BVH construction on GPUs", section 4), and a binary
//! tree of boxes over runs of that order.
//!
//! Why not parry's tree, which the metrics use elsewhere: scoring a map
//! builds one for its grid mesh (131k faces at N = 256) to answer some
//! 20k queries, and parry's SAH build was 13 % of samba's parameterization;
//! this one is a sort and a pass. Its queries find the same nearest
//! distance (each triangle is projected by parry's own point-triangle
//! projection), only the tree is coarser.

use crate::error::{Error, Result};
use glam::Vec3;
use parry3d::query::PointQuery;
use parry3d::shape::Triangle;
use rayon::prelude::*;

/// Faces per leaf (at most).
const LEAF: usize = 4;

#[derive(Clone, Copy)]
struct Aabb {
    min: Vec3,
    max: Vec3,
}

impl Aabb {
    fn of(t: &[Vec3; 3]) -> Aabb {
        Aabb { min: t[0].min(t[1]).min(t[2]), max: t[0].max(t[1]).max(t[2]) }
    }

    fn union(self, o: Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// Squared distance from `p` to the box (0 inside).
    fn distance_squared(&self, p: Vec3) -> f32 {
        (self.min - p).max(p - self.max).max(Vec3::ZERO).length_squared()
    }
}

/// A triangle mesh prepared for nearest-distance queries.
pub struct Lbvh {
    /// The triangles, in Morton order.
    tris: Vec<[Vec3; 3]>,
    /// The tree, root first: each node's range of `tris` is the run of one
    /// Morton prefix, so its box is compact.
    nodes: Vec<Node>,
}

#[derive(Clone, Copy)]
struct Node {
    aabb: Aabb,
    /// Children (both at least 1), or 0 for a leaf of `tris[first..end]`.
    left: u32,
    right: u32,
    first: u32,
    end: u32,
}

impl Lbvh {
    pub fn new(positions: &[Vec3], faces: &[[u32; 3]]) -> Result<Lbvh> {
        let n = positions.len();
        if let Some(f) = faces.iter().find(|f| f.iter().any(|&v| v as usize >= n)) {
            return Err(Error::Numerical(format!("a face {f:?} of a {n}-vertex distance query mesh")));
        }
        let tris: Vec<[Vec3; 3]> = faces.par_iter().map(|f| f.map(|v| positions[v as usize])).collect();
        let centre = |t: &[Vec3; 3]| (t[0] + t[1] + t[2]) / 3.0;
        let (lo, hi) =
            tris.iter().map(centre).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), c| (lo.min(c), hi.max(c)));
        let scale = 1023.0 / (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
        // Morton code above, face index below: a total order, so the tree
        // does not depend on the sort.
        let mut keys: Vec<u64> = tris
            .par_iter()
            .enumerate()
            .map(|(i, t)| {
                let q = ((centre(t) - lo) * scale).clamp(Vec3::ZERO, Vec3::splat(1023.0));
                ((morton(q.x as u32, q.y as u32, q.z as u32) as u64) << 32) | i as u64
            })
            .collect();
        keys.par_sort_unstable();
        let tris: Vec<[Vec3; 3]> = keys.par_iter().map(|k| tris[(*k & 0xffff_ffff) as usize]).collect();
        let mut tree = Lbvh { tris, nodes: Vec::with_capacity(2 * faces.len() / LEAF + 1) };
        if !keys.is_empty() {
            tree.build(&keys, 0);
        }
        Ok(tree)
    }

    /// Adds the node of `keys` (the run starting at `tris[first]`) and its
    /// subtree; returns its index.
    fn build(&mut self, keys: &[u64], first: usize) -> u32 {
        let at = self.nodes.len();
        let end = first + keys.len();
        let leaf = Node { aabb: Aabb::of(&self.tris[first]), left: 0, right: 0, first: first as u32, end: end as u32 };
        self.nodes.push(leaf);
        if keys.len() <= LEAF {
            let aabb = self.tris[first..end].iter().map(Aabb::of).fold(leaf.aabb, Aabb::union);
            self.nodes[at].aabb = aabb;
            return at as u32;
        }
        // Split where the highest bit that differs across the run turns on.
        let top = 63 - (keys[0] ^ keys[keys.len() - 1]).leading_zeros();
        let split = keys.partition_point(|k| k & (1 << top) == 0);
        let left = self.build(&keys[..split], first);
        let right = self.build(&keys[split..], first + split);
        let aabb = self.nodes[left as usize].aabb.union(self.nodes[right as usize].aabb);
        self.nodes[at] = Node { aabb, left, right, ..leaf };
        at as u32
    }

    /// Distance from `p` to the nearest triangle (infinity for no triangles).
    pub fn distance(&self, p: Vec3) -> f64 {
        if self.nodes.is_empty() {
            return f64::INFINITY;
        }
        let mut best = f32::INFINITY;
        // A hair of slack, so that rounding in a box's distance cannot
        // prune a triangle as near as the best.
        let beyond = |d2: f32, best: f32| d2 > best * best * (1.0 + 1e-5);
        // Each level adds one node to the stack (and one popped at once),
        // and a level splits on one bit of a 64-bit key: at most 65 deep.
        let (mut stack, mut len) = ([(0u32, 0.0f32); 66], 1);
        while len > 0 {
            len -= 1;
            let (i, d2) = stack[len];
            if beyond(d2, best) {
                continue;
            }
            let node = &self.nodes[i as usize];
            if node.left == 0 {
                for t in &self.tris[node.first as usize..node.end as usize] {
                    // A triangle's box is cheaper to measure than the triangle.
                    if !beyond(Aabb::of(t).distance_squared(p), best) {
                        best = best.min(triangle_distance(t, p));
                    }
                }
                continue;
            }
            let mut children = [node.left, node.right].map(|c| (c, self.nodes[c as usize].aabb.distance_squared(p)));
            // The nearer child is searched first (pushed last).
            if children[1].1 < children[0].1 {
                children.swap(0, 1);
            }
            stack[len] = children[1];
            stack[len + 1] = children[0];
            len += 2;
        }
        best as f64
    }
}

/// Distance from `p` to triangle `t` (parry's projection, as its trees measure).
fn triangle_distance(t: &[Vec3; 3], p: Vec3) -> f32 {
    p.distance(Triangle::new(t[0], t[1], t[2]).project_local_point(p, false).point)
}

/// The 30-bit Morton code of three 10-bit coordinates.
fn morton(x: u32, y: u32, z: u32) -> u32 {
    fn spread(mut v: u32) -> u32 {
        v &= 0x3ff;
        v = (v | (v << 16)) & 0x0300_00ff;
        v = (v | (v << 8)) & 0x0300_f00f;
        v = (v | (v << 4)) & 0x030c_30c3;
        (v | (v << 2)) & 0x0924_9249
    }
    (spread(x) << 2) | (spread(y) << 1) | spread(z)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wavy sheet folded back over itself (so that the nearest triangle
    /// is often not the one below a point), and points around it.
    fn sheet_and_points() -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<Vec3>) {
        let n = 40u32;
        let mut pos = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (u, v) = (i as f32 / (n - 1) as f32, j as f32 / (n - 1) as f32);
                let a = 5.0 * u;
                pos.push(Vec3::new(a.cos() * (1.0 - 0.1 * u), a.sin() * (1.0 - 0.1 * u), v + 0.05 * (9.0 * u).sin()));
            }
        }
        let mut faces = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let k = j * n + i;
                faces.push([k, k + 1, k + n + 1]);
                faces.push([k, k + n + 1, k + n]);
            }
        }
        let mut points = Vec::new();
        let mut x = 12345u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as f32 / u32::MAX as f32 * 3.0 - 1.5
        };
        for _ in 0..500 {
            points.push(Vec3::new(next(), next(), next() * 0.5 + 0.5));
        }
        (pos, faces, points)
    }

    #[test]
    fn finds_the_same_distance_as_every_triangle() {
        let (pos, faces, points) = sheet_and_points();
        let tree = Lbvh::new(&pos, &faces).expect("tree");
        for p in points.iter().copied().chain(pos.iter().map(|q| *q + Vec3::splat(1e-3))) {
            let brute =
                faces.iter().map(|f| triangle_distance(&f.map(|v| pos[v as usize]), p)).fold(f32::INFINITY, f32::min);
            assert_eq!(tree.distance(p), brute as f64, "at {p}");
        }
    }

    #[test]
    fn an_empty_mesh_is_infinitely_far_and_a_bad_index_an_error() {
        let tree = Lbvh::new(&[Vec3::ZERO], &[]).expect("tree");
        assert_eq!(tree.distance(Vec3::ONE), f64::INFINITY);
        assert!(Lbvh::new(&[Vec3::ZERO, Vec3::X], &[[0, 1, 2]]).is_err());
    }

    #[test]
    fn morton_interleaves_the_bits() {
        assert_eq!(morton(1, 0, 0), 0b100);
        assert_eq!(morton(0, 1, 0), 0b010);
        assert_eq!(morton(0, 0, 1), 0b001);
        assert_eq!(morton(3, 0, 0), 0b100100);
        assert_eq!(morton(1023, 1023, 1023), (1 << 30) - 1);
    }
}

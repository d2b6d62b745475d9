//! Test captures without correspondence, made from registered ones so that
//! the truth is known: every frame simplified on its own to a different
//! size (meshoptimizer's edge-collapse simplifier, Kapoulkine, through the
//! `meshopt` crate) and its vertices shuffled, as a capture rig's
//! per-frame meshes share nothing but the surface.

use glam::Vec3;
use meshopt::{SimplifyOptions, VertexDataAdapter};

/// Frame `frame` of a motion (`positions` over `faces`) as its own mesh:
/// about `keep` of its faces, vertex order shuffled by `seed`. The
/// simplifier keeps a subset of the vertices where they were, so the
/// frame's surface stays within its error of the original.
pub fn remesh_frame(positions: &[Vec3], faces: &[[u32; 3]], keep: f32, seed: u64) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let remesh = Remesh::of(positions, faces, keep, seed);
    (remesh.positions(positions), remesh.faces)
}

/// One frame's simplification, which other frames of the motion may share
/// (a registered run of a capture: a vendor's "stabilized segment").
pub struct Remesh {
    /// The motion's vertices kept, in the new mesh's (shuffled) order.
    used: Vec<u32>,
    pub faces: Vec<[u32; 3]>,
}

impl Remesh {
    /// [`remesh_frame`]'s simplification of the frame `positions`.
    pub fn of(positions: &[Vec3], faces: &[[u32; 3]], keep: f32, seed: u64) -> Remesh {
        let indices: Vec<u32> = faces.iter().flatten().copied().collect();
        let bytes: Vec<u8> = positions.iter().flat_map(|p| p.to_array()).flat_map(f32::to_le_bytes).collect();
        let target = ((indices.len() as f32 * keep.clamp(0.01, 1.0)) as usize / 3 * 3).max(3);
        let simplified = match VertexDataAdapter::new(&bytes, 12, 0) {
            Ok(adapter) => meshopt::simplify(&indices, &adapter, target, 1.0, SimplifyOptions::LockBorder, None),
            Err(_) => indices,
        };
        // The vertices the faces use, in a shuffled order.
        let mut used: Vec<u32> = simplified.clone();
        used.sort_unstable();
        used.dedup();
        shuffle(&mut used, seed);
        let mut new_index = vec![u32::MAX; positions.len()];
        for (k, &v) in used.iter().enumerate() {
            new_index[v as usize] = k as u32;
        }
        let faces = simplified.chunks_exact(3).map(|f| [f[0], f[1], f[2]].map(|v| new_index[v as usize])).collect();
        Remesh { used, faces }
    }

    /// The kept vertices' places in a frame `positions` of the motion.
    pub fn positions(&self, positions: &[Vec3]) -> Vec<Vec3> {
        self.used.iter().map(|&v| positions.get(v as usize).copied().unwrap_or_default()).collect()
    }
}

/// The fraction of faces frame `frame` keeps, between `lo` and `hi`,
/// different every frame and the same for the same seed.
pub fn keep_for(frame: usize, lo: f32, hi: f32, seed: u64) -> f32 {
    let u = (mix(seed ^ (frame as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)) >> 40) as f32 / (1u64 << 24) as f32;
    lo + (hi - lo) * u
}

/// Fisher–Yates with SplitMix64: a fixed permutation per seed, no
/// dependency for a test-data shuffle.
fn shuffle(v: &mut [u32], seed: u64) {
    let mut state = seed;
    for i in (1..v.len()).rev() {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let j = (mix(state) % (i as u64 + 1)) as usize;
        v.swap(i, j);
    }
}

fn mix(mut x: u64) -> u64 {
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The built-in body simplified to about half: fewer vertices, every
    /// one of them an original vertex, every face over them, and another
    /// seed another order.
    #[test]
    fn a_frame_is_simplified_and_shuffled() {
        let (p, f) = crate::mesh::builtin::rest_mesh();
        let (q, g) = remesh_frame(&p, &f, 0.5, 1);
        assert!(q.len() < p.len() * 3 / 4 && g.len() < f.len() * 3 / 4 && !g.is_empty(), "{} {}", q.len(), g.len());
        assert!(q.iter().all(|x| p.contains(x)));
        assert!(g.iter().flatten().all(|&v| (v as usize) < q.len()));
        let (r, _) = remesh_frame(&p, &f, 0.5, 2);
        assert_ne!(q, r);
        assert!((0..10).map(|t| keep_for(t, 0.4, 0.8, 7)).all(|k| (0.4..=0.8).contains(&k)));
        // One simplification shared by another frame: its faces, and the
        // same vertices at that frame's places.
        let remesh = Remesh::of(&p, &f, 0.5, 1);
        assert_eq!((remesh.positions(&p), &remesh.faces), (q.clone(), &g));
        let moved: Vec<Vec3> = p.iter().map(|x| *x + Vec3::X).collect();
        assert!(remesh.positions(&moved).iter().zip(&q).all(|(a, b)| *a == *b + Vec3::X));
    }
}

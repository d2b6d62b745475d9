//! Skinning decompositions: a motion as a few bones (one rigid transform per
//! bone per frame) and at most four weights per vertex summing to one, so
//! that linear blend skinning of a rest pose gives every frame back. It is
//! what three.js and every engine play natively, and the strongest rival of
//! a geometry video on articulated motion.
//!
//! - [`ssdr`]: the fit (Le and Deng 2012, "Smooth skinning decomposition
//!   with rigid bones"), initialised by rigid clustering;
//! - [`count`]: the fewest bones within an error target;
//! - [`nnls`]: the small non-negative least-squares solves its weights need;
//! - [`procrustes`]: the weighted rigid fit its transforms need;
//! - [`residual`]: what a skinning misses, as a few morph targets;
//! - [`gltf`]: a skinning as a standard skinned, animated glTF;
//! - [`errors`]: how far a skinning is from its frames.

#[cfg(not(target_arch = "wasm32"))]
pub mod count;
#[cfg(not(target_arch = "wasm32"))]
pub mod errors;
#[cfg(not(target_arch = "wasm32"))]
pub mod gltf;
pub mod nnls;
pub mod procrustes;
#[cfg(not(target_arch = "wasm32"))]
pub mod residual;
#[cfg(not(target_arch = "wasm32"))]
pub mod ssdr;

pub use procrustes::BoneTransform;
#[cfg(not(target_arch = "wasm32"))]
pub use ssdr::{decompose, SkinOptions};

use glam::Vec3;

/// Influences a vertex may have (glTF's `JOINTS_0`/`WEIGHTS_0` hold four).
pub const INFLUENCES: usize = 4;

/// A skinned motion: frame t of vertex v is
/// `Σ_k weight[v][k] · transforms[t][bone[v][k]] · rest[v]`.
#[derive(Debug, Clone)]
pub struct Skinning {
    /// The rest pose (the bind pose: every bone's transform the identity).
    pub rest: Vec<Vec3>,
    /// Bones.
    pub bones: usize,
    /// Each vertex's bones and weights (a weight of 0: no influence);
    /// the weights sum to one.
    pub influences: Vec<[(u16, f32); INFLUENCES]>,
    /// Each frame's transform of each bone.
    pub transforms: Vec<Vec<BoneTransform>>,
}

impl Skinning {
    /// Frame `t` by linear blend skinning.
    pub fn frame(&self, t: usize) -> Vec<Vec3> {
        let m = &self.transforms[t];
        self.rest
            .iter()
            .zip(&self.influences)
            .map(|(&r, inf)| inf.iter().map(|&(b, w)| w * m[b as usize].apply(r)).sum())
            .collect()
    }

    pub fn frames(&self) -> usize {
        self.transforms.len()
    }

    /// Bits of the decomposition in the compact form the skinning
    /// literature's figures use: each bone's 3 x 4 matrix at 16 bits an
    /// entry every frame, and per vertex four (8-bit bone, 8-bit weight)
    /// pairs once; the rest pose not counted.
    pub fn compact_bits(&self) -> u64 {
        let per_frame = self.bones as u64 * 12 * 16;
        per_frame * self.frames() as u64 + self.rest.len() as u64 * INFLUENCES as u64 * 16
    }
}

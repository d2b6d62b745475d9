//! Version 13: bones as the closed loop's predictor (the decoder's side is
//! `crate::solve::skinned`). Three parts:
//!
//! - the header's `skin` ([`SkinInfo`]): the bone count, the coarse grid the
//!   weights live on (the grid halved `shrink` times), and the quantizer
//!   steps of the bones' motions;
//! - the `SKIN` chunk, once, after the source mesh and appearance and
//!   before frame 0 ([`SkinWeights`]): per coarse sample, [`INFLUENCES`]
//!   pairs `(bone u8, weight u8)`, deflated (RFC 1951, raw);
//! - in every frame chunk, one length-prefixed unit after the access units
//!   and before the loose vertices ([`BoneMotions`]): empty at a
//!   random-access point; else each bone's rigid transform from the
//!   segment's rest pose (the decoded random-access point) about the bone's
//!   centroid there, 6 integers a bone (rotation vector in `rotation_step`
//!   radians, translation in `translation_step` mesh units), each the
//!   zigzag LEB128 difference from 2 M₋₁ − M₋₂ (the two frames before,
//!   identity at and before the random-access point), deflated (RFC 1951,
//!   raw).

use super::{leb128, ContainerError};
use serde::{Deserialize, Serialize};

/// Influences a coarse sample stores (glTF's four).
pub const INFLUENCES: usize = 4;
/// Most bones (a bone index is a byte).
pub const MAX_BONES: u16 = 255;
/// Most times the grid may be halved for the weights.
pub const MAX_SKIN_SHRINK: u8 = 5;
/// Smallest side of the weights' coarse grid.
pub const MIN_SKIN_GRID: usize = 4;
/// Numbers a bone's motion has: a rotation vector and a translation.
pub const MOTION_PARAMS: usize = 6;
/// Most bytes a motion's zigzag LEB128 difference takes (an i32).
const DIFF_BYTES: usize = 5;

/// The header's `skin`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SkinInfo {
    /// Bones, 1..=[`MAX_BONES`].
    pub bones: u16,
    /// The weights are on the grid halved this many times.
    pub shrink: u8,
    /// Radians a rotation-vector unit is.
    pub rotation_step: f32,
    /// Mesh units a translation unit is.
    pub translation_step: f32,
}

impl SkinInfo {
    /// Checks the fields against grid size `grid`; returns the coarse side.
    pub fn check(&self, grid: u32) -> Result<usize, String> {
        let side = coarse_side(grid as usize, self.shrink)
            .ok_or_else(|| format!("skin weights on the grid halved {} times", self.shrink))?;
        if !(1..=MAX_BONES).contains(&self.bones) {
            return Err(format!("{} bones (1..={MAX_BONES})", self.bones));
        }
        let steps = [self.rotation_step, self.translation_step];
        if steps.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(format!("skin steps {steps:?} are not positive numbers"));
        }
        Ok(side)
    }

    /// The `SKIN` chunk's raw (inflated) size: two bytes an influence.
    pub fn weights_bytes(&self, grid: u32) -> usize {
        coarse_side(grid as usize, self.shrink).map_or(0, |s| s * s * INFLUENCES * 2)
    }
}

/// The side of `grid` halved `shrink` times, if every level halves an
/// even side and the last is at least [`MIN_SKIN_GRID`].
pub fn coarse_side(grid: usize, shrink: u8) -> Option<usize> {
    let mut n = grid;
    for _ in 0..shrink.min(MAX_SKIN_SHRINK + 1) {
        if n % 2 != 0 {
            return None;
        }
        n /= 2;
    }
    (shrink <= MAX_SKIN_SHRINK && n >= MIN_SKIN_GRID).then_some(n)
}

/// The `SKIN` chunk: each coarse sample's bones and weights (weights out of
/// their sum; a sample's sum is positive).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SkinWeights {
    pub influences: Vec<[(u8, u8); INFLUENCES]>,
}

impl SkinWeights {
    pub fn to_bytes(&self) -> Vec<u8> {
        let raw: Vec<u8> = self.influences.iter().flatten().flat_map(|&(b, w)| [b, w]).collect();
        miniz_oxide::deflate::compress_to_vec(&raw, 9)
    }

    /// Reads and checks the chunk of a file whose header says `info` on
    /// grid `grid` (the chunk at byte `offset`).
    pub fn parse(payload: &[u8], info: &SkinInfo, grid: u32, offset: usize) -> Result<SkinWeights, ContainerError> {
        let bad = |msg: String| ContainerError::Chunk { offset, msg: format!("skin weights: {msg}") };
        let want = info.weights_bytes(grid);
        let raw = miniz_oxide::inflate::decompress_to_vec_with_limit(payload, want)
            .map_err(|e| bad(format!("do not inflate within their size ({:?})", e.status)))?;
        if raw.len() != want {
            return Err(bad(format!("{} bytes, expected {want}", raw.len())));
        }
        let mut influences = Vec::with_capacity(want / (2 * INFLUENCES));
        for (k, s) in raw.chunks_exact(2 * INFLUENCES).enumerate() {
            let pairs: [(u8, u8); INFLUENCES] = std::array::from_fn(|i| (s[2 * i], s[2 * i + 1]));
            let total: u32 = pairs.iter().map(|p| u32::from(p.1)).sum();
            if total == 0 || pairs.iter().any(|&(b, w)| w > 0 && u16::from(b) >= info.bones) {
                return Err(bad(format!("sample {k} has no weight or names a bone past {}", info.bones)));
            }
            influences.push(pairs);
        }
        Ok(SkinWeights { influences })
    }
}

/// One frame's bone motions as the file codes them: integers in the
/// header's steps.
pub type Motion = [i32; MOTION_PARAMS];

/// A frame's bones unit: the motions' differences from `last`.
pub struct BoneMotions;

impl BoneMotions {
    /// The unit of `motions` after `expected` (the same length).
    pub fn to_bytes(motions: &[Motion], expected: &[Motion]) -> Vec<u8> {
        let mut raw = Vec::with_capacity(motions.len() * MOTION_PARAMS);
        for (m, l) in motions.iter().zip(expected) {
            for (a, b) in m.iter().zip(l) {
                let d = i64::from(*a) - i64::from(*b);
                leb128::write(&mut raw, ((d << 1) ^ (d >> 63)) as u64);
            }
        }
        miniz_oxide::deflate::compress_to_vec(&raw, 9)
    }

    /// Most bytes the unit of `bones` bones may take (deflate's worst case
    /// past the raw numbers' is a few bytes).
    pub fn max_bytes(bones: u16) -> usize {
        usize::from(bones) * MOTION_PARAMS * DIFF_BYTES + 64
    }

    /// The motions a unit codes after `last` (one per bone). The frame
    /// chunk at `offset` is named in errors.
    pub fn parse(payload: &[u8], last: &[Motion], offset: usize) -> Result<Vec<Motion>, ContainerError> {
        let bad = |msg: &str| ContainerError::Chunk { offset, msg: format!("bone motions: {msg}") };
        let limit = last.len() * MOTION_PARAMS * DIFF_BYTES;
        let payload = miniz_oxide::inflate::decompress_to_vec_with_limit(payload, limit)
            .map_err(|_| bad("they do not inflate within their size"))?;
        let mut at = 0;
        let mut out = Vec::with_capacity(last.len());
        for l in last {
            let mut m = [0i32; MOTION_PARAMS];
            for (x, b) in m.iter_mut().zip(l) {
                let z = leb128::read(&payload, &mut at, DIFF_BYTES).ok_or_else(|| bad("a cut or overlong number"))?;
                let d = (z >> 1) as i64 ^ -((z & 1) as i64);
                *x = i32::try_from(i64::from(*b) + d).map_err(|_| bad("a motion past 32 bits"))?;
            }
            out.push(m);
        }
        if at != payload.len() {
            return Err(bad("bytes after the last bone"));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn motions_and_weights_round_trip_and_bad_ones_are_refused() {
        let last = vec![[0, 1, -2, 3, 0, 0], [5, 5, 5, 5, 5, 5]];
        let m = vec![[1, 1, -2, 300, -70000, 0], [5, 4, 6, 5, 5, i32::MIN]];
        let b = BoneMotions::to_bytes(&m, &last);
        assert_eq!(BoneMotions::parse(&b, &last, 0).unwrap(), m);
        assert!(BoneMotions::parse(&b[..b.len() / 2], &last, 0).is_err());
        // One number too many, deflated.
        let mut raw = Vec::new();
        (0..13).for_each(|_| leb128::write(&mut raw, 2));
        assert!(BoneMotions::parse(&miniz_oxide::deflate::compress_to_vec(&raw, 9), &last, 0).is_err());
        let info = SkinInfo { bones: 3, shrink: 2, rotation_step: 1e-3, translation_step: 1e-3 };
        assert_eq!(info.check(16), Ok(4));
        assert!(info.check(8).is_err());
        let w = SkinWeights { influences: vec![[(0, 200), (2, 55), (0, 0), (0, 0)]; 16] };
        assert_eq!(SkinWeights::parse(&w.to_bytes(), &info, 16, 0).unwrap(), w);
        let mut bad = w.clone();
        bad.influences[3][1].0 = 3;
        assert!(SkinWeights::parse(&bad.to_bytes(), &info, 16, 0).is_err());
        assert!(SkinWeights::parse(&w.to_bytes(), &info, 32, 0).is_err());
    }
}

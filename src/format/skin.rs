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
//!
//! Version 14 (`SkinInfo::packed`) codes both smaller: a sample's weights
//! without its empty pairs and its bones by reference to its neighbours'
//! ([`SkinWeights::to_bytes`]), and a unit's differences as Exp-Golomb
//! codes, one order for the rotations and one for the translations
//! ([`BoneMotions::to_bytes`]): per-frame deflate spent 153 bytes a frame
//! on samba's 32 bones where these take 111.

use super::bits::{exp_golomb_bits, BitReader, BitWriter};
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
    /// Version 14: the weights and the bones units are packed (absent:
    /// version 13's deflated bytes).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub packed: bool,
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

    /// The `SKIN` chunk's largest raw (inflated) size: two bytes an
    /// influence (version 14: a count a sample and an escape a pair more).
    pub fn weights_bytes(&self, grid: u32) -> usize {
        let per_sample = INFLUENCES * 2 + if self.packed { 1 + INFLUENCES } else { 0 };
        coarse_side(grid as usize, self.shrink).map_or(0, |s| s * s * per_sample)
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
    /// The chunk's payload as `info` says (version 13 or 14).
    pub fn to_bytes(&self, info: &SkinInfo) -> Vec<u8> {
        debug_assert_eq!(coarse_side_of(self.influences.len()).pow(2), self.influences.len());
        let raw: Vec<u8> = if info.packed {
            self.packed(coarse_side_of(self.influences.len()))
        } else {
            self.influences.iter().flatten().flat_map(|&(b, w)| [b, w]).collect()
        };
        miniz_oxide::deflate::compress_to_vec(&raw, 9)
    }

    /// Version 14's raw bytes (a pair without weight is left out and read
    /// back as (0, 0)), three runs deflate finds patterns in apart:
    /// each sample's count of pairs with a weight; their bones, each as its
    /// place among the bones of the sample before it in its row and of the
    /// one above ([`neighbour_bones`]; 0 to 7), or [`NEW_BONE`] and the
    /// bone; their weights. The pairs in the order the sample has them.
    fn packed(&self, side: usize) -> Vec<u8> {
        let (mut counts, mut bones, mut weights) = (Vec::new(), Vec::new(), Vec::new());
        for (k, inf) in self.influences.iter().enumerate() {
            let known = neighbour_bones(&self.influences, side, k);
            let kept: Vec<(u8, u8)> = inf.iter().copied().filter(|p| p.1 > 0).collect();
            counts.push(kept.len() as u8);
            for (b, w) in kept {
                match known.iter().position(|&x| x == b) {
                    Some(i) => bones.push(i as u8),
                    None => bones.extend([NEW_BONE, b]),
                }
                weights.push(w);
            }
        }
        [counts, bones, weights].concat()
    }

    /// Reads and checks the chunk of a file whose header says `info` on
    /// grid `grid` (the chunk at byte `offset`).
    pub fn parse(payload: &[u8], info: &SkinInfo, grid: u32, offset: usize) -> Result<SkinWeights, ContainerError> {
        let bad = |msg: String| ContainerError::Chunk { offset, msg: format!("skin weights: {msg}") };
        let most = info.weights_bytes(grid);
        let raw = miniz_oxide::inflate::decompress_to_vec_with_limit(payload, most)
            .map_err(|e| bad(format!("do not inflate within their size ({:?})", e.status)))?;
        let side = coarse_side(grid as usize, info.shrink).unwrap_or(0);
        let influences = if info.packed {
            unpack(&raw, side).map_err(bad)?
        } else {
            if raw.len() != most {
                return Err(bad(format!("{} bytes, expected {most}", raw.len())));
            }
            raw.chunks_exact(2 * INFLUENCES).map(|s| std::array::from_fn(|i| (s[2 * i], s[2 * i + 1]))).collect()
        };
        for (k, pairs) in influences.iter().enumerate() {
            let total: u32 = pairs.iter().map(|p| u32::from(p.1)).sum();
            if total == 0 || pairs.iter().any(|&(b, w)| w > 0 && u16::from(b) >= info.bones) {
                return Err(bad(format!("sample {k} has no weight or names a bone past {}", info.bones)));
            }
        }
        Ok(SkinWeights { influences })
    }
}

/// A packed bone that is none of the neighbours'.
const NEW_BONE: u8 = 8;

/// The side of a square grid of `len` samples.
fn coarse_side_of(len: usize) -> usize {
    (len as f64).sqrt().round() as usize
}

/// The bones of sample `k`'s left neighbour in its row, then those of the
/// one above that are new, the pairs with a weight only, in their order.
fn neighbour_bones(influences: &[[(u8, u8); INFLUENCES]], side: usize, k: usize) -> Vec<u8> {
    let mut known = Vec::with_capacity(2 * INFLUENCES);
    let left = (side > 0 && k % side > 0).then(|| k - 1);
    let up = k.checked_sub(side.max(1)).filter(|_| side > 0);
    for n in [left, up].into_iter().flatten() {
        for &(b, w) in influences.get(n).into_iter().flatten() {
            if w > 0 && !known.contains(&b) {
                known.push(b);
            }
        }
    }
    known
}

/// Version 14's raw bytes back as `side`² samples of pairs.
fn unpack(raw: &[u8], side: usize) -> Result<Vec<[(u8, u8); INFLUENCES]>, String> {
    let n = side * side;
    let counts = raw.get(..n).ok_or("fewer counts than samples")?;
    if let Some(k) = counts.iter().position(|&c| c == 0 || usize::from(c) > INFLUENCES) {
        return Err(format!("sample {k} has {} pairs (1 to {INFLUENCES})", counts[k]));
    }
    let pairs: usize = counts.iter().map(|&c| usize::from(c)).sum();
    let (mut at, mut out) = (n, Vec::with_capacity(n));
    for (k, &c) in counts.iter().enumerate() {
        // Sample k is not in `out` yet: its known bones are its neighbours'.
        let known = neighbour_bones(&out, side, k);
        let mut inf = [(0u8, 0u8); INFLUENCES];
        for slot in inf.iter_mut().take(usize::from(c)) {
            let code = *raw.get(at).ok_or("the bones end early")?;
            at += 1;
            // A placeholder weight until the weights' run: the pair counts
            // as one the next samples may refer to.
            slot.1 = 1;
            slot.0 = if code == NEW_BONE {
                at += 1;
                *raw.get(at - 1).ok_or("the bones end early")?
            } else {
                *known.get(usize::from(code)).ok_or_else(|| format!("sample {k} names neighbour bone {code}"))?
            };
        }
        out.push(inf);
    }
    let weights = raw.get(at..at + pairs).ok_or("the weights end early")?;
    if raw.len() != at + pairs {
        return Err("bytes after the weights".into());
    }
    if weights.contains(&0) {
        return Err("a packed pair without weight".into());
    }
    let mut w = weights.iter();
    for (inf, &c) in out.iter_mut().zip(counts) {
        for slot in inf.iter_mut().take(usize::from(c)) {
            slot.1 = w.next().copied().unwrap_or(0);
        }
    }
    Ok(out)
}

/// One frame's bone motions as the file codes them: integers in the
/// header's steps.
pub type Motion = [i32; MOTION_PARAMS];

/// A frame's bones unit: the motions' differences from `last`.
pub struct BoneMotions;

impl BoneMotions {
    /// The unit of `motions` after `expected` (the same length), packed
    /// (version 14) or deflated.
    pub fn to_bytes(motions: &[Motion], expected: &[Motion], packed: bool) -> Vec<u8> {
        let diffs = motions.iter().zip(expected).flat_map(|(m, l)| {
            m.iter().zip(l).map(|(a, b)| {
                let d = i64::from(*a) - i64::from(*b);
                ((d << 1) ^ (d >> 63)) as u64
            })
        });
        if packed {
            return pack(&diffs.collect::<Vec<u64>>());
        }
        let mut raw = Vec::with_capacity(motions.len() * MOTION_PARAMS);
        diffs.for_each(|z| leb128::write(&mut raw, z));
        miniz_oxide::deflate::compress_to_vec(&raw, 9)
    }

    /// Most bytes the unit of `bones` bones may take: deflate's worst case
    /// is a few bytes past the raw numbers'; a packed number (below 2³³)
    /// takes at most 67 bits at any order.
    pub fn max_bytes(bones: u16, packed: bool) -> usize {
        let numbers = usize::from(bones) * MOTION_PARAMS;
        if packed {
            1 + numbers * 67usize.div_ceil(8)
        } else {
            numbers * DIFF_BYTES + 64
        }
    }

    /// The motions a unit codes after `last` (one per bone). The frame
    /// chunk at `offset` is named in errors.
    pub fn parse(payload: &[u8], last: &[Motion], offset: usize, packed: bool) -> Result<Vec<Motion>, ContainerError> {
        let bad = |msg: &str| ContainerError::Chunk { offset, msg: format!("bone motions: {msg}") };
        let diffs = if packed {
            unpack_diffs(payload, last.len() * MOTION_PARAMS).map_err(bad)?
        } else {
            let limit = last.len() * MOTION_PARAMS * DIFF_BYTES;
            let raw = miniz_oxide::inflate::decompress_to_vec_with_limit(payload, limit)
                .map_err(|_| bad("they do not inflate within their size"))?;
            let mut at = 0;
            let mut diffs = Vec::with_capacity(last.len() * MOTION_PARAMS);
            while at < raw.len() && diffs.len() < last.len() * MOTION_PARAMS {
                diffs.push(leb128::read(&raw, &mut at, DIFF_BYTES).ok_or_else(|| bad("a cut or overlong number"))?);
            }
            if at != raw.len() {
                return Err(bad("bytes after the last bone"));
            }
            diffs
        };
        if diffs.len() != last.len() * MOTION_PARAMS {
            return Err(bad("fewer numbers than bones"));
        }
        let mut out = Vec::with_capacity(last.len());
        for (l, z) in last.iter().zip(diffs.chunks_exact(MOTION_PARAMS)) {
            let mut m = [0i32; MOTION_PARAMS];
            for ((x, b), &z) in m.iter_mut().zip(l).zip(z) {
                let d = (z >> 1) as i64 ^ -((z & 1) as i64);
                *x = i64::from(*b)
                    .checked_add(d)
                    .and_then(|v| i32::try_from(v).ok())
                    .ok_or_else(|| bad("a motion past 32 bits"))?;
            }
            out.push(m);
        }
        Ok(out)
    }
}

/// Of a bone's six numbers, the rotation's (the first three) are class 0,
/// the translation's class 1.
fn class(k: usize) -> usize {
    (k % MOTION_PARAMS) / 3
}

/// Version 14's unit: a byte with each class's Exp-Golomb order (rotation
/// high nibble, translation low), the one that codes its numbers in the
/// fewest bits, then every number's code in order.
fn pack(diffs: &[u64]) -> Vec<u8> {
    let order = |c: usize| {
        let bits = |k: u32| -> u64 {
            diffs
                .iter()
                .enumerate()
                .filter(|(i, _)| class(*i) == c)
                .map(|(_, &z)| u64::from(exp_golomb_bits(z, k)))
                .sum()
        };
        (0..16).min_by_key(|&k| bits(k)).unwrap_or(0)
    };
    let ks = [order(0), order(1)];
    let mut w = BitWriter::default();
    w.put(u64::from(ks[0] << 4 | ks[1]), 8);
    for (i, &z) in diffs.iter().enumerate() {
        w.exp_golomb(z, ks[class(i)]);
    }
    w.finish()
}

/// Zigzag numbers a packed unit may hold: the difference of two i32 needs
/// no more than 33 bits.
const MAX_ZIGZAG: u64 = 1 << 33;

/// `count` numbers of a packed unit.
fn unpack_diffs(payload: &[u8], count: usize) -> Result<Vec<u64>, &'static str> {
    let mut r = BitReader::new(payload);
    let ks = r.get(8).ok_or("an empty unit")?;
    let ks = [(ks >> 4) as u32, (ks & 15) as u32];
    let diffs = (0..count)
        .map(|i| r.exp_golomb(ks[class(i)]).filter(|&z| z < MAX_ZIGZAG).ok_or("a cut or overlong number"))
        .collect::<Result<Vec<u64>, _>>()?;
    if !r.at_padding() {
        return Err("bits after the last bone");
    }
    Ok(diffs)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn motions_round_trip_in_both_codings_and_bad_ones_are_refused() {
        let last = vec![[0, 1, -2, 3, 0, 0], [5, 5, 5, 5, 5, 5]];
        let m = vec![[1, 1, -2, 300, -70000, 0], [5, 4, 6, 5, 5, i32::MIN]];
        for packed in [false, true] {
            let b = BoneMotions::to_bytes(&m, &last, packed);
            assert!(b.len() <= BoneMotions::max_bytes(2, packed));
            assert_eq!(BoneMotions::parse(&b, &last, 0, packed).unwrap(), m);
            assert!(BoneMotions::parse(&b[..b.len() / 2], &last, 0, packed).is_err(), "cut, packed {packed}");
            assert!(BoneMotions::parse(&b, &last[..1], 0, packed).is_err(), "a bone too many, packed {packed}");
        }
        // One number too many, deflated.
        let mut raw = Vec::new();
        (0..13).for_each(|_| leb128::write(&mut raw, 2));
        assert!(BoneMotions::parse(&miniz_oxide::deflate::compress_to_vec(&raw, 9), &last, 0, false).is_err());
        // Packed: a set bit after the last code.
        let mut b = BoneMotions::to_bytes(&last, &last, true);
        b.push(0x80);
        assert!(BoneMotions::parse(&b, &last, 0, true).is_err());
        // Packed: a difference past 33 bits, or one that takes a motion
        // past i32, is refused (not wrapped, not a panic).
        let mut w = crate::format::bits::BitWriter::default();
        w.put(0, 8);
        w.exp_golomb(u64::MAX - 1, 0);
        (1..12).for_each(|_| w.exp_golomb(0, 0));
        assert!(BoneMotions::parse(&w.finish(), &last, 0, true).is_err());
        let top = vec![[i32::MAX; MOTION_PARAMS]; 2];
        let mut w = crate::format::bits::BitWriter::default();
        w.put(0, 8);
        (0..12).for_each(|_| w.exp_golomb(2, 0));
        assert!(BoneMotions::parse(&w.finish(), &top, 0, true).is_err());
        // The worst a packed unit can be: every difference the widest.
        let far = vec![[i32::MAX; MOTION_PARAMS]; 3];
        let near = vec![[i32::MIN; MOTION_PARAMS]; 3];
        assert!(BoneMotions::to_bytes(&far, &near, true).len() <= BoneMotions::max_bytes(3, true));
    }

    /// Small differences cost fewer bits packed than deflated, as on samba.
    #[test]
    fn packed_motions_are_smaller_on_small_differences() {
        let last = vec![[0; MOTION_PARAMS]; 32];
        // Differences of a few units, two-sided geometric (P(|d| = n) ∝
        // 0.7ⁿ) as a motion's are, in no pattern deflate could find.
        let mut seed = 12345u32;
        let mut small = || {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12345);
            let u = f64::from((seed >> 8) & 0xffff) / 65536.0 + 1e-6;
            let n = (u.ln() / 0.7f64.ln()).floor() as i32;
            if seed & 0x8000_0000 != 0 {
                n
            } else {
                -n
            }
        };
        let m: Vec<Motion> = (0..32).map(|_| std::array::from_fn(|_| small())).collect();
        assert!(BoneMotions::to_bytes(&m, &last, true).len() < BoneMotions::to_bytes(&m, &last, false).len());
    }

    #[test]
    fn weights_round_trip_in_both_codings_and_bad_ones_are_refused() {
        for packed in [false, true] {
            let info = SkinInfo { bones: 3, shrink: 2, rotation_step: 1e-3, translation_step: 1e-3, packed };
            assert_eq!(info.check(16), Ok(4));
            assert!(info.check(8).is_err());
            let mut w = SkinWeights { influences: vec![[(0, 200), (2, 55), (0, 0), (0, 0)]; 16] };
            w.influences[5] = [(1, 10), (2, 20), (0, 30), (1, 0)];
            w.influences[6] = [(2, 255), (0, 0), (0, 0), (0, 0)];
            // Packed, a pair without weight comes back as (0, 0), which
            // skins alike.
            let mut back = w.clone();
            if packed {
                back.influences[5][3] = (0, 0);
            }
            assert_eq!(SkinWeights::parse(&w.to_bytes(&info), &info, 16, 0).unwrap(), back, "packed {packed}");
            let mut bad = w.clone();
            bad.influences[3][1].0 = 3;
            assert!(SkinWeights::parse(&bad.to_bytes(&info), &info, 16, 0).is_err());
            assert!(SkinWeights::parse(&w.to_bytes(&info), &info, 32, 0).is_err());
            let bytes = w.to_bytes(&info);
            assert!(SkinWeights::parse(&bytes[..bytes.len() - 3], &info, 16, 0).is_err());
        }
    }

    #[test]
    fn packed_weights_refuse_what_no_encoder_writes() {
        let info = SkinInfo { bones: 3, shrink: 2, rotation_step: 1e-3, translation_step: 1e-3, packed: true };
        let deflate = |raw: &[u8]| miniz_oxide::deflate::compress_to_vec(raw, 9);
        // A count of 0, of 5; a neighbour bone the first sample has none of.
        for first in [0u8, 5] {
            let raw = [vec![first], vec![1; 15], [NEW_BONE, 0].repeat(16), vec![255; 16]].concat();
            assert!(SkinWeights::parse(&deflate(&raw), &info, 16, 0).is_err());
        }
        let raw = [vec![1; 16], vec![0; 16], vec![255; 16]].concat();
        assert!(SkinWeights::parse(&deflate(&raw), &info, 16, 0).is_err());
        // A pair of weight 0; a byte after the weights.
        let good = [vec![1; 16], [NEW_BONE, 0].repeat(16), vec![255; 16]].concat();
        assert!(SkinWeights::parse(&deflate(&good), &info, 16, 0).is_ok());
        let mut zero = good.clone();
        zero[16 + 32] = 0;
        assert!(SkinWeights::parse(&deflate(&zero), &info, 16, 0).is_err());
        let long = [good, vec![1]].concat();
        assert!(SkinWeights::parse(&deflate(&long), &info, 16, 0).is_err());
    }
}

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
//! Version 17 (`SkinInfo::rest_step`) puts the bones on the source mesh's
//! own vertices instead of the grid (the decoder's side is
//! `crate::solve::skinned` too): the `SKIN` chunk holds, not deflated as a
//! whole, the LEB128 length of the deflated weights (version 14's packing,
//! one sample per source vertex, each referring to the vertex before it),
//! those, then each vertex's rest position deflated apart (three integers
//! in `rest_step` mesh units, zigzag LEB128 differences from the vertex
//! before it; a report counts them with the mesh); every frame has a
//! bones unit (random-access points too: the rest pose is the file's, not
//! a decoded frame), coding its transforms from that rest pose; and the
//! grid codes what the bones miss (see `crate::codec::vertex_bones`).
//!
//! Version 21 (`SkinInfo::point_weights`): a random-access point's bones
//! unit, empty before, may hold weights for the frames up to the next
//! point, packed and deflated as the `SKIN` chunk's; an empty one means
//! the `SKIN` chunk's.
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
    /// Version 17: the bones act on the source mesh's vertices, whose rest
    /// positions the `SKIN` chunk carries in steps of this many mesh units
    /// (absent: the bones act on the grid). Needs `packed`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rest_step: Option<f32>,
    /// Version 21: a random-access point's bones unit may carry weights of
    /// its own, packed as the `SKIN` chunk's, for the frames up to the
    /// next point (empty: the `SKIN` chunk's). A capture's segments each
    /// have their own map, so a grid sample is another point of the body
    /// in each. Needs `packed`, bones on the grid.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub point_weights: bool,
}

impl SkinInfo {
    /// Checks the fields against grid size `grid`; returns the coarse side.
    pub fn check(&self, grid: u32) -> Result<usize, String> {
        let side = coarse_side(grid as usize, self.shrink)
            .ok_or_else(|| format!("skin weights on the grid halved {} times", self.shrink))?;
        if !(1..=MAX_BONES).contains(&self.bones) {
            return Err(format!("{} bones (1..={MAX_BONES})", self.bones));
        }
        let steps = [self.rotation_step, self.translation_step, self.rest_step.unwrap_or(1.0)];
        if steps.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(format!("skin steps {steps:?} are not positive numbers"));
        }
        if self.on_vertices() && (self.shrink != 0 || !self.packed) {
            return Err("bones on the vertices are packed and on no coarse grid (shrink 0)".into());
        }
        if self.point_weights && (self.on_vertices() || !self.packed) {
            return Err("weights at random-access points need packed bones on the grid".into());
        }
        Ok(side)
    }

    /// Most bytes a random-access point's bones unit may take for
    /// `samples` weights' samples: none, or (version 21) packed weights
    /// deflated, a little past their raw size at worst (stored blocks).
    pub fn point_unit_bytes(&self, samples: usize) -> usize {
        if self.point_weights {
            let raw = self.weights_bytes(samples);
            raw + raw / 64 + 16
        } else {
            0
        }
    }

    /// Version 17: whether the bones act on the source mesh's vertices.
    pub fn on_vertices(&self) -> bool {
        self.rest_step.is_some()
    }

    /// The `SKIN` chunk's largest raw (inflated) size for `samples`
    /// samples: two bytes an influence (version 14: a count a sample and an
    /// escape a pair more).
    pub fn weights_bytes(&self, samples: usize) -> usize {
        samples * (INFLUENCES * 2 + if self.packed { 1 + INFLUENCES } else { 0 })
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
    /// Version 17: each vertex's rest position in the header's
    /// `rest_step` (empty: the bones act on the grid).
    pub rest: Vec<[i32; 3]>,
}

impl SkinWeights {
    /// The chunk's payload as `info` says (version 13 or 14).
    pub fn to_bytes(&self, info: &SkinInfo) -> Vec<u8> {
        if info.on_vertices() {
            let weights = miniz_oxide::deflate::compress_to_vec(&self.packed(1), 9);
            let mut out = Vec::with_capacity(weights.len() + 5);
            leb128::write(&mut out, weights.len() as u64);
            out.extend(weights);
            out.extend(rest_bytes(&self.rest));
            return out;
        }
        let raw: Vec<u8> = if info.packed {
            debug_assert_eq!(coarse_side_of(self.influences.len()).pow(2), self.influences.len());
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

    /// Reads and checks the chunk of a file whose header says `info`, for
    /// `samples` samples (`Header::skin_samples`; the chunk at byte
    /// `offset`).
    pub fn parse(
        payload: &[u8],
        info: &SkinInfo,
        samples: usize,
        offset: usize,
    ) -> Result<SkinWeights, ContainerError> {
        let bad = |msg: String| ContainerError::Chunk { offset, msg: format!("skin weights: {msg}") };
        if info.on_vertices() {
            return parse_on_vertices(payload, info, samples).map_err(bad);
        }
        let most = info.weights_bytes(samples);
        let raw = miniz_oxide::inflate::decompress_to_vec_with_limit(payload, most)
            .map_err(|e| bad(format!("do not inflate within their size ({:?})", e.status)))?;
        let influences = if info.packed {
            let (inf, at) = unpack(&raw, samples, coarse_side_of(samples)).map_err(&bad)?;
            if at != raw.len() {
                return Err(bad("bytes after the weights".into()));
            }
            inf
        } else {
            if raw.len() != most {
                return Err(bad(format!("{} bytes, expected {most}", raw.len())));
            }
            raw.chunks_exact(2 * INFLUENCES).map(|s| std::array::from_fn(|i| (s[2 * i], s[2 * i + 1]))).collect()
        };
        check_bones(&influences, info).map_err(bad)?;
        Ok(SkinWeights { influences, rest: Vec::new() })
    }
}

/// Version 17's `SKIN` payload: the packed weights deflated (their length
/// first, LEB128), then the rest positions deflated ([`rest_bytes`]), so
/// that a report can tell the rest pose (the mesh) from the weights.
fn parse_on_vertices(payload: &[u8], info: &SkinInfo, n: usize) -> Result<SkinWeights, String> {
    let mut at = 0;
    let len = leb128::read(payload, &mut at, DIFF_BYTES).ok_or("a bad weights length")?;
    let end = usize::try_from(len).ok().and_then(|l| at.checked_add(l)).filter(|&e| e <= payload.len());
    let end = end.ok_or("the weights overrun the chunk")?;
    let inflate = |bytes: &[u8], most: usize, what: &str| {
        miniz_oxide::inflate::decompress_to_vec_with_limit(bytes, most)
            .map_err(|e| format!("the {what} do not inflate within their size ({:?})", e.status))
    };
    let raw = inflate(&payload[at..end], info.weights_bytes(n), "weights")?;
    let (influences, used) = unpack(&raw, n, 1)?;
    if used != raw.len() {
        return Err("bytes after the weights".into());
    }
    let rest = unpack_rest(&inflate(&payload[end..], n * 3 * DIFF_BYTES, "rest positions")?, n)?;
    check_bones(&influences, info)?;
    Ok(SkinWeights { influences, rest })
}

/// Each sample has weight and names only the header's bones.
fn check_bones(influences: &[[(u8, u8); INFLUENCES]], info: &SkinInfo) -> Result<(), String> {
    for (k, pairs) in influences.iter().enumerate() {
        let total: u32 = pairs.iter().map(|p| u32::from(p.1)).sum();
        if total == 0 || pairs.iter().any(|&(b, w)| w > 0 && u16::from(b) >= info.bones) {
            return Err(format!("sample {k} has no weight or names a bone past {}", info.bones));
        }
    }
    Ok(())
}

/// Version 17's rest positions deflated: three zigzag LEB128 differences
/// from the vertex before each.
pub fn rest_bytes(rest: &[[i32; 3]]) -> Vec<u8> {
    let mut raw = Vec::with_capacity(rest.len() * 6);
    let mut last = [0i32; 3];
    for p in rest {
        for (x, l) in p.iter().zip(&mut last) {
            let d = i64::from(*x) - i64::from(*l);
            leb128::write(&mut raw, ((d << 1) ^ (d >> 63)) as u64);
            *l = *x;
        }
    }
    miniz_oxide::deflate::compress_to_vec(&raw, 9)
}

/// Version 17's rest positions, `n` vertices' zigzag LEB128 differences
/// from the vertex before, filling `raw`.
fn unpack_rest(raw: &[u8], n: usize) -> Result<Vec<[i32; 3]>, String> {
    let (mut at, mut last, mut out) = (0, [0i32; 3], Vec::with_capacity(n));
    for v in 0..n {
        for l in &mut last {
            let z = leb128::read(raw, &mut at, DIFF_BYTES).ok_or_else(|| format!("vertex {v}'s rest is cut"))?;
            let d = (z >> 1) as i64 ^ -((z & 1) as i64);
            *l = i64::from(*l).checked_add(d).and_then(|x| i32::try_from(x).ok()).ok_or("a rest past 32 bits")?;
        }
        out.push(last);
    }
    if at != raw.len() {
        return Err("bytes after the rest positions".into());
    }
    Ok(out)
}

/// A sample's (bone, weight) pairs as stored.
type Pairs = [(u8, u8); INFLUENCES];

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

/// Version 14's raw bytes back as `n` samples of pairs, `side` to a row
/// (1: each refers to the one before it), and where they end.
fn unpack(raw: &[u8], n: usize, side: usize) -> Result<(Vec<Pairs>, usize), String> {
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
    if weights.contains(&0) {
        return Err("a packed pair without weight".into());
    }
    let mut w = weights.iter();
    for (inf, &c) in out.iter_mut().zip(counts) {
        for slot in inf.iter_mut().take(usize::from(c)) {
            slot.1 = w.next().copied().unwrap_or(0);
        }
    }
    Ok((out, at + pairs))
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

    /// Version 17's chunk: each vertex's weights (each referring to the
    /// vertex before) and rest position round trip; a cut, a rest too many
    /// or a missing weight is refused.
    #[test]
    fn vertex_weights_and_rest_round_trip_and_bad_ones_are_refused() {
        let info = SkinInfo {
            bones: 3,
            shrink: 0,
            rotation_step: 1e-3,
            translation_step: 1e-3,
            packed: true,
            rest_step: Some(1e-4),
            point_weights: false,
        };
        assert!(info.check(32).is_ok() && info.on_vertices());
        assert!(SkinInfo { packed: false, ..info }.check(32).is_err(), "vertex bones are packed");
        assert!(SkinInfo { shrink: 1, ..info }.check(32).is_err(), "and on no coarse grid");
        assert!(SkinInfo { rest_step: Some(0.0), ..info }.check(32).is_err());
        let w = SkinWeights {
            influences: vec![
                [(0, 200), (2, 55), (0, 0), (0, 0)],
                [(2, 255), (0, 0), (0, 0), (0, 0)],
                [(1, 9), (0, 0), (0, 0), (0, 0)],
            ],
            rest: vec![[0, -5, 70000], [i32::MIN, i32::MAX, 3], [1, 1, 1]],
        };
        let bytes = w.to_bytes(&info);
        assert_eq!(SkinWeights::parse(&bytes, &info, 3, 0).unwrap(), w);
        assert!(SkinWeights::parse(&bytes, &info, 2, 0).is_err(), "a vertex too many");
        assert!(SkinWeights::parse(&bytes, &info, 4, 0).is_err(), "a vertex too few");
        for cut in [1, 5, bytes.len() - 1] {
            assert!(SkinWeights::parse(&bytes[..cut], &info, 3, 0).is_err(), "cut at {cut}");
        }
        let mut empty = w.clone();
        empty.influences[1] = [(0, 0); INFLUENCES];
        assert!(SkinWeights::parse(&empty.to_bytes(&info), &info, 3, 0).is_err(), "a vertex without weight");
        let mut far = w.clone();
        far.influences[0][0].0 = 3;
        assert!(SkinWeights::parse(&far.to_bytes(&info), &info, 3, 0).is_err(), "a bone past the header's");
        // A weights length past the chunk, not a panic.
        let mut long = Vec::new();
        leb128::write(&mut long, u64::from(u32::MAX));
        long.extend(&bytes[1..]);
        assert!(SkinWeights::parse(&long, &info, 3, 0).is_err());
    }

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
            let info = SkinInfo {
                bones: 3,
                shrink: 2,
                rotation_step: 1e-3,
                translation_step: 1e-3,
                packed,
                rest_step: None,
                point_weights: false,
            };
            assert_eq!(info.check(16), Ok(4));
            assert!(info.check(8).is_err());
            let mut w = SkinWeights { influences: vec![[(0, 200), (2, 55), (0, 0), (0, 0)]; 16], ..Default::default() };
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
        let info = SkinInfo {
            bones: 3,
            shrink: 2,
            rotation_step: 1e-3,
            translation_step: 1e-3,
            packed: true,
            rest_step: None,
            point_weights: false,
        };
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

//! Version 18: the vertex residual, what the video missed at each of the
//! source mesh's vertices, quantized on the header's step and coded every
//! frame. The grid's resampling bounds how close a geometry video comes to
//! the input's own vertices (a floor of 0.09 % of the diagonal on pcow);
//! a residual at the vertices has none, and as MPEG-4 FAMC codes what its
//! skinning misses per vertex (Mamou, Zaharia and Prêteux 2009) it costs
//! a few bits a vertex where the peers that code every vertex (Draco) cost
//! ten or more.
//!
//! Each frame chunk of such a file ends with one more length-prefixed unit:
//!
//! ```text
//! mode     u8          0: the values are the residual; 1: they add to the
//!                      previous frame's decoded residual (zero at a
//!                      random-access point); version 19: 2 and 3, the same
//!                      predicted over the surface (`super::vertex_order`);
//!                      version 20: plus 4 where the counts are sparse
//! K        LEB128      the largest |value| (at most MAX_VALUE)
//! counts   2K+1 LEB128 how many values are -K, ..., K (their sum is 3V);
//!                      sparse (version 20): how many counts are not 0,
//!                      then for each its gap from the one before (LEB128,
//!                      the first's from -K) and the count (LEB128): a
//!                      histogram that spans a vertex coded whole, most of
//!                      its 2K+1 counts 0, costs what it holds
//! words    u32 LE ...  the 3V values, x, y, z of vertex after vertex,
//!                      range coded (constriction 0.5's RangeEncoder<u32,
//!                      u64>) with the model `model` makes of the counts;
//!                      words past those the values need are not read
//! ```
//!
//! A reader checks the unit's frame ([`ResidualUnit::check`]) and the
//! decoder decodes its values ([`ResidualUnit::parse`]): once, not twice.
//!
//! Range coding with the frame's own histogram comes within the
//! histogram's few bytes of the values' entropy; deflate of their bytes
//! (the loose vertices' coding) cannot reach it for values of one or two
//! bits each. constriction is used rather than a hand-written coder: it
//! is kept, documented, and its range coder is fixed across releases.

use super::{leb128, ContainerError};
use constriction::stream::model::DefaultContiguousCategoricalEntropyModel;
use constriction::stream::queue::{DefaultRangeDecoder, DefaultRangeEncoder};
use constriction::stream::{Decode, Encode};

/// The largest |value| a unit may hold: the encoder clamps beyond it (a
/// residual over 1023 steps means a step far too fine for the video).
pub const MAX_VALUE: u32 = 1023;
/// The model's probability precision, in bits (constriction's default).
const PRECISION: u32 = 24;

/// The header's `vertex_residual`: version 18.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VertexResidualInfo {
    /// Mesh units a value is (finite, > 0).
    pub step: f32,
    /// Version 19: units may code their values as what each vertex's
    /// neighbours predict misses (modes 2 and 3).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub spatial: bool,
    /// Version 20: units may list their histogram's counts sparsely.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub sparse: bool,
    /// Version 20: a file without video (no streams): the residual is the
    /// vertex itself less this point (the first frame's bounding-box
    /// centre), so that the decoder adds it to this and nothing else.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin: Option<[f32; 3]>,
}

/// Which unit layouts a file's header allows (its `vertex_residual`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Modes {
    /// Version 19: modes 2 and 3.
    pub spatial: bool,
    /// Version 20: sparse counts.
    pub sparse: bool,
}

impl Modes {
    /// Every layout this version writes.
    pub const ALL: Modes = Modes { spatial: true, sparse: true };
}

impl VertexResidualInfo {
    pub fn validate(&self) -> Result<(), String> {
        if self.step.is_finite() && self.step > 0.0 {
            Ok(())
        } else {
            Err(format!("vertex residual step {} is not a positive number", self.step))
        }
        .and_then(|()| match self.origin {
            Some(o) if !o.iter().all(|x| x.is_finite()) => Err("vertex residual origin is not finite".into()),
            _ => Ok(()),
        })
    }

    /// The unit layouts the header allows.
    pub fn modes(&self) -> Modes {
        Modes { spatial: self.spatial, sparse: self.sparse }
    }
}

/// How a unit's values apply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// The values are the residual.
    Intra,
    /// The values add to the previous frame's residual.
    Delta,
}

/// One frame's unit: its mode and 3 V values.
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualUnit {
    pub mode: Mode,
    /// Version 19: the values are what the walk's predictions miss, in the
    /// walk's order (`super::vertex_order`), not the vertices' own.
    pub spatial: bool,
    pub values: Vec<i32>,
}

/// The fixed-point model of a unit's histogram: each value of -K..=K gets
/// 1 + its share of the rest (so that every value can be coded), the most
/// frequent one what rounding leaves. Integers only: encoder and decoder,
/// native and wasm, build the same model.
fn model(counts: &[u64]) -> Option<DefaultContiguousCategoricalEntropyModel> {
    let total: u64 = counts.iter().sum();
    let room = (1u64 << PRECISION).checked_sub(counts.len() as u64)?;
    if total == 0 {
        return None;
    }
    let mut p: Vec<u32> = counts.iter().map(|&c| (1 + c * room / total) as u32).collect();
    let left = (1u64 << PRECISION) - p.iter().map(|&q| u64::from(q)).sum::<u64>();
    let most = (0..counts.len()).max_by_key(|&i| (counts[i], std::cmp::Reverse(i)))?;
    p[most] += left as u32;
    DefaultContiguousCategoricalEntropyModel::from_nonzero_fixed_point_probabilities(&p, false).ok()
}

impl ResidualUnit {
    /// The unit's bytes (values beyond [`MAX_VALUE`] are the caller's to
    /// clamp; they are clamped here too), its counts listed sparsely where
    /// `modes` allows that and it is shorter. `None` only if the range
    /// coder fails, which a model giving every value a nonzero share rules
    /// out.
    pub fn to_bytes(&self, modes: Modes) -> Option<Vec<u8>> {
        let max = MAX_VALUE as i32;
        let values: Vec<i32> = self.values.iter().map(|&v| v.clamp(-max, max)).collect();
        let k = values.iter().map(|v| v.unsigned_abs()).max().unwrap_or(0);
        let mut counts = vec![0u64; 2 * k as usize + 1];
        for &v in &values {
            counts[(v + k as i32) as usize] += 1;
        }
        let mode = u8::from(self.mode == Mode::Delta) + 2 * u8::from(self.spatial);
        let dense = dense_counts(&counts);
        let sparse = modes.sparse.then(|| sparse_counts(&counts)).filter(|s| s.len() < dense.len());
        let mut out = vec![mode + if sparse.is_some() { SPARSE } else { 0 }];
        leb128::write(&mut out, u64::from(k));
        out.extend(sparse.unwrap_or(dense));
        // One value alone needs no words: the counts say it all.
        if counts.iter().filter(|&&c| c > 0).count() <= 1 {
            return Some(out);
        }
        let mut coder = DefaultRangeEncoder::new();
        let symbols = values.iter().map(|&v| (v + k as i32) as usize);
        coder.encode_iid_symbols(symbols, model(&counts)?.as_view()).ok()?;
        let Ok(words) = coder.into_compressed();
        out.extend(words.iter().flat_map(|w| w.to_le_bytes()));
        Some(out)
    }

    /// Reads a unit of `count` values (3 V) from a frame chunk at byte
    /// `offset` (named in errors): [`Self::check`], then the values.
    pub fn parse(payload: &[u8], count: usize, modes: Modes, offset: usize) -> Result<ResidualUnit, ContainerError> {
        let (mode, spatial, counts, at) = Self::check(payload, count, modes, offset)?;
        let k = counts.len() / 2;
        let words: Vec<u32> =
            payload[at..].chunks_exact(4).map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]])).collect();
        let values = decode_values(words, &counts, k).ok_or_else(|| ContainerError::Chunk {
            offset,
            msg: "vertex residual: the coded values do not decode".into(),
        })?;
        Ok(ResidualUnit { mode, spatial, values })
    }

    /// What a reader checks of a unit without range decoding it (the
    /// decoder's [`Self::parse`] does): its mode, its largest value and
    /// counts, and whole words after them; modes 2 and 3, and sparse
    /// counts, only where the header allows them (`modes`). Returns the
    /// mode, whether it is spatial, the counts and where the words start.
    pub fn check(
        payload: &[u8],
        count: usize,
        modes: Modes,
        offset: usize,
    ) -> Result<(Mode, bool, Vec<u64>, usize), ContainerError> {
        let bad = |msg: String| ContainerError::Chunk { offset, msg: format!("vertex residual: {msg}") };
        let first = *payload.first().ok_or_else(|| bad("an empty unit".into()))?;
        let sparse = first & SPARSE != 0;
        let (mode, spatial) = match first & !SPARSE {
            _ if sparse && !modes.sparse => return Err(bad(format!("unknown mode {first}"))),
            0 => (Mode::Intra, false),
            1 => (Mode::Delta, false),
            2 if modes.spatial => (Mode::Intra, true),
            3 if modes.spatial => (Mode::Delta, true),
            _ => return Err(bad(format!("unknown mode {first}"))),
        };
        let mut at = 1;
        let k = leb128::read(payload, &mut at, 2).filter(|&k| k <= u64::from(MAX_VALUE));
        let k = k.ok_or_else(|| bad(format!("a bad largest value (at most {MAX_VALUE})")))? as usize;
        let counts = match sparse {
            false => read_dense(payload, &mut at, k),
            true => read_sparse(payload, &mut at, k),
        }
        .ok_or_else(|| bad("a bad count".into()))?;
        let total: u64 = counts.iter().sum();
        if total != count as u64 {
            return Err(bad(format!("counts sum to {total}, not the {count} values of the mesh's vertices")));
        }
        if k > 0 && counts[0] + counts[2 * k] == 0 {
            return Err(bad(format!("K = {k} is not the largest value")));
        }
        if (payload.len() - at) % 4 != 0 {
            return Err(bad(format!("{} bytes of coded values, not whole 32-bit words", payload.len() - at)));
        }
        Ok((mode, spatial, counts, at))
    }
}

/// The mode byte's flag of sparse counts (version 20).
const SPARSE: u8 = 4;

/// The 2K + 1 counts, each in LEB128.
fn dense_counts(counts: &[u64]) -> Vec<u8> {
    let mut out = Vec::new();
    counts.iter().for_each(|&c| leb128::write(&mut out, c));
    out
}

/// Version 20: how many counts are not 0, then each one's gap from the one
/// before and its count.
fn sparse_counts(counts: &[u64]) -> Vec<u8> {
    let mut out = Vec::new();
    leb128::write(&mut out, counts.iter().filter(|&&c| c > 0).count() as u64);
    let mut next = 0;
    for (i, &c) in counts.iter().enumerate().filter(|(_, &c)| c > 0) {
        leb128::write(&mut out, (i - next) as u64);
        leb128::write(&mut out, c);
        next = i + 1;
    }
    out
}

fn read_dense(payload: &[u8], at: &mut usize, k: usize) -> Option<Vec<u64>> {
    (0..2 * k + 1).map(|_| leb128::read(payload, at, 5)).collect()
}

/// Sparse counts, each inside -K..=K and none listed twice.
fn read_sparse(payload: &[u8], at: &mut usize, k: usize) -> Option<Vec<u64>> {
    let mut counts = vec![0u64; 2 * k + 1];
    let listed = leb128::read(payload, at, 2).filter(|&n| n <= counts.len() as u64)?;
    let mut next = 0usize;
    for _ in 0..listed {
        let i = next.checked_add(usize::try_from(leb128::read(payload, at, 2)?).ok()?)?;
        *counts.get_mut(i)? = leb128::read(payload, at, 5).filter(|&c| c > 0)?;
        next = i + 1;
    }
    Some(counts)
}

/// The values the range coder's `words` hold under the counts' model.
fn decode_values(words: Vec<u32>, counts: &[u64], k: usize) -> Option<Vec<i32>> {
    let count: u64 = counts.iter().sum();
    if count == 0 {
        return words.is_empty().then(Vec::new);
    }
    let mut present = (0..counts.len()).filter(|&i| counts[i] > 0);
    if let (Some(only), None) = (present.next(), present.next()) {
        return words.is_empty().then(|| vec![only as i32 - k as i32; count as usize]);
    }
    let model = model(counts)?;
    let mut decoder = DefaultRangeDecoder::from_compressed(words).ok()?;
    let symbols = decoder.decode_iid_symbols(count as usize, model.as_view());
    let values: Result<Vec<i32>, _> = symbols.map(|s| s.map(|s| s as i32 - k as i32)).collect();
    let values = values.ok()?;
    // A value whose count is 0 only a broken unit decodes.
    let mut seen = vec![0u64; counts.len()];
    for &v in &values {
        seen[(v + k as i32) as usize] += 1;
    }
    (seen == counts).then_some(values)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::{Mode, Modes, ResidualUnit, MAX_VALUE};

    #[test]
    fn units_read_back_and_cost_about_their_entropy() {
        // Mostly 0 and ±1, as a residual a step finer than the video's error is.
        let values: Vec<i32> = (0..3000).map(|i: i32| ((i * 7919) % 13 - 6) / 4).collect();
        let unit = ResidualUnit { mode: Mode::Delta, spatial: true, values };
        let bytes = unit.to_bytes(Modes::default()).unwrap();
        assert_eq!(ResidualUnit::parse(&bytes, 3000, Modes::ALL, 0).unwrap(), unit);
        assert!(
            ResidualUnit::parse(&bytes, 3000, Modes::default(), 0).is_err(),
            "mode 3 in a file without spatial units"
        );
        let mut hist = std::collections::HashMap::new();
        unit.values.iter().for_each(|v| *hist.entry(*v).or_insert(0.0) += 1.0);
        let entropy: f64 = hist.values().map(|c: &f64| -c * (c / 3000.0).log2()).sum();
        let bits = bytes.len() as f64 * 8.0;
        assert!(bits < entropy * 1.02 + 120.0, "{bits} bits for {entropy:.0} bits of entropy");
    }

    #[test]
    fn broken_units_are_errors() {
        let unit = ResidualUnit { mode: Mode::Intra, spatial: false, values: vec![0, 1, -1, 2000, 0, 0] };
        let bytes = unit.to_bytes(Modes::default()).unwrap();
        // Clamped to the largest value a unit may hold.
        assert_eq!(ResidualUnit::parse(&bytes, 6, Modes::ALL, 0).unwrap().values[3], MAX_VALUE as i32);
        assert!(ResidualUnit::parse(&bytes, 9, Modes::ALL, 0).is_err(), "counts for another mesh");
        assert!(ResidualUnit::parse(&[], 6, Modes::ALL, 0).is_err());
        assert!(ResidualUnit::parse(&[4, 0, 6], 6, Modes::ALL, 0).is_err(), "unknown mode");
        assert!(
            ResidualUnit::parse(&[2, 0, 6], 6, Modes::default(), 0).is_err(),
            "a spatial mode in a version 18 file"
        );
        // K = 1 with no value at ±1: not the largest value.
        assert!(ResidualUnit::parse(&[0, 1, 0, 6, 0], 6, Modes::ALL, 0).is_err(), "a K past the values");
        assert!(ResidualUnit::parse(&bytes[..bytes.len() - 1], 6, Modes::ALL, 0).is_err(), "a cut word");
        for cut in 0..bytes.len() {
            let _ = ResidualUnit::parse(&bytes[..cut], 6, Modes::ALL, 0);
        }
        let mut flipped = bytes.clone();
        for i in 0..flipped.len() {
            flipped[i] ^= 0x5a;
            let _ = ResidualUnit::parse(&flipped, 6, Modes::ALL, 0);
            flipped[i] ^= 0x5a;
        }
        assert!(ResidualUnit::parse(&[4, 0, 1, 0, 6], 6, Modes::default(), 0).is_err(), "sparse counts in a v19 file");
        // All zero: the counts say so and no word follows.
        let zero = ResidualUnit { mode: Mode::Intra, spatial: false, values: vec![0; 6] };
        assert_eq!(
            ResidualUnit::parse(&zero.to_bytes(Modes::default()).unwrap(), 6, Modes::default(), 0).unwrap(),
            zero
        );
    }

    /// A histogram that spans one large value (a vertex coded whole, the
    /// rest small) lists its counts sparsely, and reads back either way.
    #[test]
    fn sparse_counts_cost_what_they_hold() {
        let mut values: Vec<i32> = (0..600).map(|i: i32| (i % 5) - 2).collect();
        values[7] = 900;
        let unit = ResidualUnit { mode: Mode::Intra, spatial: true, values };
        let (dense, sparse) = (unit.to_bytes(Modes { spatial: true, sparse: false }), unit.to_bytes(Modes::ALL));
        let (dense, sparse) = (dense.unwrap(), sparse.unwrap());
        assert_eq!(sparse[0], 2 + 4, "the sparse flag");
        assert!(sparse.len() + 1500 < dense.len(), "{} bytes against {}", sparse.len(), dense.len());
        for bytes in [&dense, &sparse] {
            assert_eq!(ResidualUnit::parse(bytes, 600, Modes::ALL, 0).unwrap(), unit);
        }
        // A gap past the histogram, a count listed as 0: errors, not panics.
        assert!(ResidualUnit::parse(&[4, 1, 1, 3, 6], 6, Modes::ALL, 0).is_err());
        assert!(ResidualUnit::parse(&[4, 1, 2, 0, 6, 0, 0], 6, Modes::ALL, 0).is_err());
        for cut in 0..sparse.len() {
            let _ = ResidualUnit::parse(&sparse[..cut], 600, Modes::ALL, 0);
        }
    }
}

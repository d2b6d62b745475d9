//! A vertex residual unit's values after its mode byte
//! (`super::vertex_residual`): the histograms of the values, then the
//! values range coded under the models the histograms make (constriction
//! 0.5's `RangeEncoder<u32, u64>`, 32-bit words, little-endian).
//!
//! ```text
//! histogram  K (LEB128, at most MAX_VALUE), then the counts of -K..=K:
//!            2K+1 LEB128, or (sparse, version 20) how many are not 0 and
//!            for each its gap from the one before and its count
//! words      u32 LE ...
//! ```
//!
//! One histogram, or (version 20, with contexts) [`CONTEXTS`] of them: a
//! value is then coded under the model of its context, the size of the
//! value three before it (the same coordinate of the vertex before, in the
//! unit's order) up to 3. A smooth surface's guesses miss by little in
//! smooth regions and by more at creases, so a value's neighbour says
//! which histogram it follows (face-poses' and wolf's vertices files 2 to
//! 7 % smaller than with one histogram, docs/RESULTS.md). A histogram
//! with one value alone codes no words for it: its count says it all.

use super::leb128;
use super::vertex_residual::MAX_VALUE;
use constriction::stream::model::DefaultContiguousCategoricalEntropyModel;
use constriction::stream::queue::{DefaultRangeDecoder, DefaultRangeEncoder};
use constriction::stream::{Decode, Encode};

/// The models of a unit with contexts, for a value three before of size
/// 0, 1, 2 and 3 or more.
pub const CONTEXTS: usize = 4;
/// The model's probability precision, in bits (constriction's default).
const PRECISION: u32 = 24;

/// One histogram: the largest |value| K and the counts of -K..=K.
#[derive(Debug, Clone, PartialEq)]
pub struct Histogram {
    k: usize,
    counts: Vec<u64>,
}

/// How a histogram's values are coded.
enum Coding {
    /// No value has this context.
    Empty,
    /// One value alone: no words.
    Only(i32),
    Model(DefaultContiguousCategoricalEntropyModel),
}

impl Histogram {
    fn of(values: impl Iterator<Item = i32> + Clone) -> Histogram {
        let k = values.clone().map(|v| v.unsigned_abs() as usize).max().unwrap_or(0);
        let mut counts = vec![0u64; 2 * k + 1];
        values.for_each(|v| counts[(v + k as i32) as usize] += 1);
        Histogram { k, counts }
    }

    fn total(&self) -> u64 {
        self.counts.iter().sum()
    }

    /// K and the counts, dense or sparse.
    fn write(&self, sparse: bool, out: &mut Vec<u8>) {
        leb128::write(out, self.k as u64);
        if !sparse {
            self.counts.iter().for_each(|&c| leb128::write(out, c));
            return;
        }
        leb128::write(out, self.counts.iter().filter(|&&c| c > 0).count() as u64);
        let mut next = 0;
        for (i, &c) in self.counts.iter().enumerate().filter(|(_, &c)| c > 0) {
            leb128::write(out, (i - next) as u64);
            leb128::write(out, c);
            next = i + 1;
        }
    }

    /// K and its counts (a count at -K or K where K > 0), each listed
    /// inside -K..=K and none twice; a message says what is wrong.
    fn read(payload: &[u8], at: &mut usize, sparse: bool) -> Result<Histogram, String> {
        let k = leb128::read(payload, at, 2).filter(|&k| k <= u64::from(MAX_VALUE));
        let k = k.ok_or(format!("a bad largest value (at most {MAX_VALUE})"))? as usize;
        let counts = match sparse {
            false => (0..2 * k + 1).map(|_| leb128::read(payload, at, 5)).collect(),
            true => read_sparse(payload, at, k),
        }
        .ok_or("a bad count")?;
        if k > 0 && counts[0] + counts[2 * k] == 0 {
            return Err(format!("K = {k} is not the largest value"));
        }
        Ok(Histogram { k, counts })
    }

    fn coding(&self) -> Option<Coding> {
        let mut present = (0..self.counts.len()).filter(|&i| self.counts[i] > 0);
        Some(match (present.next(), present.next()) {
            (None, _) => Coding::Empty,
            (Some(only), None) => Coding::Only(only as i32 - self.k as i32),
            _ => Coding::Model(model(&self.counts)?),
        })
    }
}

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

/// The fixed-point model of a histogram: each value of -K..=K gets 1 +
/// its share of the rest (so that every value can be coded), the most
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

/// Value `i`'s context among `values` (0 without contexts).
fn context(values: &[i32], i: usize, contexts: bool) -> usize {
    match (contexts, i.checked_sub(3)) {
        (true, Some(j)) => (values[j].unsigned_abs() as usize).min(CONTEXTS - 1),
        _ => 0,
    }
}

/// The histograms and words of `values` (each within ±[`MAX_VALUE`]), with
/// or without contexts, the counts sparse where `sparse` allows and that
/// is shorter; and whether they are. `None` only if the range coder fails.
pub fn encode(values: &[i32], sparse: bool, contexts: bool) -> Option<(Vec<u8>, bool)> {
    let n = if contexts { CONTEXTS } else { 1 };
    let of = |c: usize| (0..values.len()).filter(move |&i| context(values, i, contexts) == c).map(|i| values[i]);
    let hists: Vec<Histogram> = (0..n).map(|c| Histogram::of(of(c))).collect();
    let written = |sparse: bool| {
        let mut out = Vec::new();
        hists.iter().for_each(|h| h.write(sparse, &mut out));
        out
    };
    let (dense, listed) = (written(false), sparse.then(|| written(true)));
    let listed = listed.filter(|s| s.len() < dense.len());
    let sparse = listed.is_some();
    let mut out = listed.unwrap_or(dense);
    let codings: Vec<Coding> = hists.iter().map(Histogram::coding).collect::<Option<_>>()?;
    let mut coder = DefaultRangeEncoder::new();
    for (i, &v) in values.iter().enumerate() {
        let c = context(values, i, contexts);
        if let Coding::Model(m) = &codings[c] {
            coder.encode_symbol((v + hists[c].k as i32) as usize, m.as_view()).ok()?;
        }
    }
    let Ok(words) = coder.into_compressed();
    out.extend(words.iter().flat_map(|w| w.to_le_bytes()));
    Some((out, sparse))
}

/// The histograms of a unit of `count` values at `at` (moved past them),
/// checked: their counts add up to `count`.
pub fn check(
    payload: &[u8],
    at: &mut usize,
    count: usize,
    sparse: bool,
    contexts: bool,
) -> Result<Vec<Histogram>, String> {
    let n = if contexts { CONTEXTS } else { 1 };
    let hists = (0..n).map(|_| Histogram::read(payload, at, sparse)).collect::<Result<Vec<_>, _>>()?;
    let total: u64 = hists.iter().map(Histogram::total).sum();
    if total != count as u64 {
        return Err(format!("counts sum to {total}, not the {count} values of the mesh's vertices"));
    }
    Ok(hists)
}

/// The values the words hold under the histograms' models; `None` if they
/// do not decode to values matching the histograms.
pub fn decode(words: Vec<u32>, hists: &[Histogram], contexts: bool) -> Option<Vec<i32>> {
    let count: u64 = hists.iter().map(Histogram::total).sum();
    let codings: Vec<Coding> = hists.iter().map(Histogram::coding).collect::<Option<_>>()?;
    let coded = codings.iter().any(|c| matches!(c, Coding::Model(_)));
    if !coded && !words.is_empty() {
        return None;
    }
    let mut decoder = DefaultRangeDecoder::from_compressed(words).ok()?;
    let mut values: Vec<i32> = Vec::with_capacity(count as usize);
    let mut seen: Vec<Vec<u64>> = hists.iter().map(|h| vec![0; h.counts.len()]).collect();
    for i in 0..count as usize {
        let c = context(&values, i, contexts);
        let k = hists.get(c)?.k as i32;
        let v = match codings.get(c)? {
            Coding::Empty => return None,
            Coding::Only(v) => *v,
            Coding::Model(m) => decoder.decode_symbol(m.as_view()).ok()? as i32 - k,
        };
        *seen[c].get_mut((v + k) as usize)? += 1;
        values.push(v);
    }
    // A value whose count is 0, or counts a context never reaches, only a
    // broken unit decodes.
    seen.iter().zip(hists).all(|(s, h)| *s == h.counts).then_some(values)
}

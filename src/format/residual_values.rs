//! A vertex residual unit's values after its mode byte
//! (`super::vertex_residual`): the histograms of the values, then the
//! values range coded under the models the histograms make (constriction
//! 0.5's `RangeEncoder<u32, u64>`, 32-bit words, little-endian).
//!
//! ```text
//! histogram  K (LEB128, at most MAX_VALUE), then the counts of -K..=K:
//!            2K+1 LEB128, or (sparse, version 20) how many are not 0 and
//!            for each its gap from the one before and its count; with
//!            escapes (version 20), then the count beyond ±K (LEB128)
//! escapes    (version 20) each value beyond its histogram's ±K, LEB128
//! words      u32 LE ...
//! ```
//!
//! With escapes (version 20) a histogram holds -L..=L, L at most the
//! largest |value|, and one more count, of the values beyond (the
//! escape symbol's); each such value follows the histograms as a zigzag
//! LEB128, in the unit's order, before the words. A value far out (a part's
//! first vertex, coded whole) then costs two bytes rather than a count of
//! its own and a rare symbol's 14 bits.
//!
//! One histogram, or (version 20, with contexts) [`CONTEXTS`] of them: a
//! value is then coded under the model of its context, the sizes of the
//! values three and six before it (the same coordinate of the two
//! vertices before, in the unit's order) summed, up to 5. A smooth surface's guesses miss by little in
//! smooth regions and by more at creases, so a value's neighbour says
//! which histogram it follows (face-poses' and wolf's vertices files 2 to
//! 7 % smaller than with one histogram, docs/RESULTS.md). A histogram
//! with one value alone codes no words for it: its count says it all.

use super::leb128;

/// The largest |value| a unit may hold: the encoder clamps beyond it (a
/// residual over 1023 steps means a step far too fine for the video).
pub const MAX_VALUE: u32 = 1023;
use constriction::stream::model::DefaultContiguousCategoricalEntropyModel;
use constriction::stream::queue::{DefaultRangeDecoder, DefaultRangeEncoder};
use constriction::stream::{Decode, Encode};

/// The models of a unit with contexts, for the sizes of the two values
/// before of that coordinate summing to 0, 1, 2, 3, 4 and 5 or more.
pub const CONTEXTS: usize = 6;
/// The model's probability precision, in bits (constriction's default).
const PRECISION: u32 = 24;

/// Which of version 20's layouts a unit uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Layout {
    /// The counts listed sparsely.
    pub sparse: bool,
    /// [`CONTEXTS`] histograms.
    pub contexts: bool,
    /// Each histogram's values beyond ±K escaped.
    pub escapes: bool,
}

/// One histogram: K, the counts of -K..=K and, with escapes, of the values
/// beyond (the last count: the escape symbol's).
#[derive(Debug, Clone, PartialEq)]
pub struct Histogram {
    k: usize,
    counts: Vec<u64>,
    escapes: bool,
}

/// How a histogram's symbols are coded.
enum Coding {
    /// No value has this context.
    Empty,
    /// One symbol alone: no words.
    Only(usize),
    Model(DefaultContiguousCategoricalEntropyModel),
}

impl Histogram {
    /// The histogram of `values` on -K..=K, K the one of `ks` that codes
    /// them in the fewest bits (estimated; the largest |value| without
    /// escapes).
    fn of(values: &[i32], escapes: bool) -> Histogram {
        let largest = values.iter().map(|v| v.unsigned_abs() as usize).max().unwrap_or(0);
        let mut ks = vec![largest];
        if escapes {
            ks.extend((0..10).map(|j| (1usize << j) - 1).filter(|&k| k < largest));
        }
        let mut best: Option<(f64, Histogram)> = None;
        for k in ks {
            let mut h = Histogram { k, counts: vec![0u64; 2 * k + 1 + usize::from(escapes)], escapes };
            for &v in values {
                let s = h.symbol(v);
                h.counts[s] += 1;
            }
            let bits = h.estimated_bits();
            if best.as_ref().is_none_or(|(b, _)| bits < *b) {
                best = Some((bits, h));
            }
        }
        best.map_or(Histogram { k: 0, counts: vec![0; 1 + usize::from(escapes)], escapes }, |(_, h)| h)
    }

    /// The symbols' entropy, about 3 bytes a listed count and 2 an escaped
    /// value: what choosing K weighs.
    fn estimated_bits(&self) -> f64 {
        let total = self.total() as f64;
        let entropy: f64 =
            self.counts.iter().filter(|&&c| c > 0).map(|&c| -(c as f64) * (c as f64 / total).log2()).sum();
        let listed = self.counts.iter().filter(|&&c| c > 0).count() as f64;
        entropy + 24.0 * listed + 16.0 * self.escaped() as f64
    }

    fn total(&self) -> u64 {
        self.counts.iter().sum()
    }

    /// How many values lie beyond ±K.
    fn escaped(&self) -> u64 {
        if self.escapes {
            self.counts.last().copied().unwrap_or(0)
        } else {
            0
        }
    }

    /// K and the counts, dense or sparse, and with escapes their count.
    fn write(&self, sparse: bool, out: &mut Vec<u8>) {
        let values = &self.counts[..2 * self.k + 1];
        leb128::write(out, self.k as u64);
        if sparse {
            leb128::write(out, values.iter().filter(|&&c| c > 0).count() as u64);
            let mut next = 0;
            for (i, &c) in values.iter().enumerate().filter(|(_, &c)| c > 0) {
                leb128::write(out, (i - next) as u64);
                leb128::write(out, c);
                next = i + 1;
            }
        } else {
            values.iter().for_each(|&c| leb128::write(out, c));
        }
        if self.escapes {
            leb128::write(out, self.escaped());
        }
    }

    /// K and its counts, each listed inside -K..=K and none twice (without
    /// escapes, a count at -K or K where K > 0); a message says what is
    /// wrong.
    fn read(payload: &[u8], at: &mut usize, layout: Layout) -> Result<Histogram, String> {
        let k = leb128::read(payload, at, 2).filter(|&k| k <= u64::from(MAX_VALUE));
        let k = k.ok_or(format!("a bad largest value (at most {MAX_VALUE})"))? as usize;
        let mut counts = match layout.sparse {
            false => (0..2 * k + 1).map(|_| leb128::read(payload, at, 5)).collect(),
            true => read_sparse(payload, at, k),
        }
        .ok_or("a bad count")?;
        if layout.escapes {
            counts.push(leb128::read(payload, at, 5).ok_or("a bad count of escaped values")?);
        } else if k > 0 && counts[0] + counts[2 * k] == 0 {
            return Err(format!("K = {k} is not the largest value"));
        }
        Ok(Histogram { k, counts, escapes: layout.escapes })
    }

    fn coding(&self) -> Option<Coding> {
        let mut present = (0..self.counts.len()).filter(|&i| self.counts[i] > 0);
        Some(match (present.next(), present.next()) {
            (None, _) => Coding::Empty,
            (Some(only), None) => Coding::Only(only),
            _ => Coding::Model(model(&self.counts)?),
        })
    }

    /// The symbol of `v`: its place in -K..=K, or the escape.
    fn symbol(&self, v: i32) -> usize {
        if v.unsigned_abs() as usize <= self.k {
            (v + self.k as i32) as usize
        } else {
            2 * self.k + 1
        }
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

/// The fixed-point model of a histogram: each symbol gets 1 + its share of
/// the rest (so that every symbol can be coded), the most frequent one
/// what rounding leaves. Integers only: encoder and decoder, native and
/// wasm, build the same model.
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

/// Value `i`'s context among `values` (0 without contexts): |value i - 3|
/// + |value i - 6| (those that exist), up to 5.
fn context(values: &[i32], i: usize, contexts: bool) -> usize {
    if !contexts {
        return 0;
    }
    let size = |back: usize| i.checked_sub(back).map_or(0, |j| values[j].unsigned_abs() as usize);
    (size(3) + size(6)).min(CONTEXTS - 1)
}

fn zigzag(v: i32) -> u64 {
    u64::from(((v << 1) ^ (v >> 31)) as u32)
}

/// The histograms, escapes and words of `values` (each within
/// ±[`MAX_VALUE`]) in `layout`, the counts sparse only where that is
/// shorter (the layout returned says). `None` only if the range coder
/// fails.
pub fn encode(values: &[i32], layout: Layout) -> Option<(Vec<u8>, Layout)> {
    let n = if layout.contexts { CONTEXTS } else { 1 };
    let contexts: Vec<usize> = (0..values.len()).map(|i| context(values, i, layout.contexts)).collect();
    let of =
        |c: usize| -> Vec<i32> { values.iter().zip(&contexts).filter(|(_, &x)| x == c).map(|(&v, _)| v).collect() };
    let hists: Vec<Histogram> = (0..n).map(|c| Histogram::of(&of(c), layout.escapes)).collect();
    let written = |sparse: bool| {
        let mut out = Vec::new();
        hists.iter().for_each(|h| h.write(sparse, &mut out));
        out
    };
    let (dense, listed) = (written(false), layout.sparse.then(|| written(true)));
    let listed = listed.filter(|s| s.len() < dense.len());
    let used = Layout { sparse: listed.is_some(), ..layout };
    let mut out = listed.unwrap_or(dense);
    let codings: Vec<Coding> = hists.iter().map(Histogram::coding).collect::<Option<_>>()?;
    let mut coder = DefaultRangeEncoder::new();
    for (&v, &c) in values.iter().zip(&contexts) {
        let h = &hists[c];
        let symbol = h.symbol(v);
        if symbol > 2 * h.k {
            leb128::write(&mut out, zigzag(v));
        }
        if let Coding::Model(m) = &codings[c] {
            coder.encode_symbol(symbol, m.as_view()).ok()?;
        }
    }
    let Ok(words) = coder.into_compressed();
    out.extend(words.iter().flat_map(|w| w.to_le_bytes()));
    Some((out, used))
}

/// The histograms of a unit of `count` values at `at` and its escaped
/// values (`at` moved past them), checked: their counts add up to `count`
/// and every escaped value lies within ±[`MAX_VALUE`].
pub fn check(
    payload: &[u8],
    at: &mut usize,
    count: usize,
    layout: Layout,
) -> Result<(Vec<Histogram>, Vec<i32>), String> {
    let n = if layout.contexts { CONTEXTS } else { 1 };
    let hists = (0..n).map(|_| Histogram::read(payload, at, layout)).collect::<Result<Vec<_>, _>>()?;
    let total: u64 = hists.iter().map(Histogram::total).sum();
    if total != count as u64 {
        return Err(format!("counts sum to {total}, not the {count} values of the mesh's vertices"));
    }
    let escaped: u64 = hists.iter().map(Histogram::escaped).sum();
    let escapes = (0..escaped)
        .map(|_| {
            let z = leb128::read(payload, at, 2).filter(|&z| z <= 2 * u64::from(MAX_VALUE));
            z.map(|z| (z >> 1) as i32 ^ -((z & 1) as i32)).ok_or("a bad escaped value")
        })
        .collect::<Result<Vec<i32>, _>>()?;
    Ok((hists, escapes))
}

/// The values the words hold under the histograms' models, the escaped
/// ones taken in order from `escapes`; `None` if they do not decode to
/// values matching the histograms (an escaped value within its
/// histogram's ±K included).
pub fn decode(words: Vec<u32>, (hists, escapes): (&[Histogram], &[i32]), contexts: bool) -> Option<Vec<i32>> {
    let count: u64 = hists.iter().map(Histogram::total).sum();
    let codings: Vec<Coding> = hists.iter().map(Histogram::coding).collect::<Option<_>>()?;
    let coded = codings.iter().any(|c| matches!(c, Coding::Model(_)));
    if !coded && !words.is_empty() {
        return None;
    }
    let mut decoder = DefaultRangeDecoder::from_compressed(words).ok()?;
    let mut values: Vec<i32> = Vec::with_capacity(count as usize);
    let mut escaped = escapes.iter();
    let mut seen: Vec<Vec<u64>> = hists.iter().map(|h| vec![0; h.counts.len()]).collect();
    for i in 0..count as usize {
        let c = context(&values, i, contexts);
        let h = hists.get(c)?;
        let symbol = match codings.get(c)? {
            Coding::Empty => return None,
            Coding::Only(s) => *s,
            Coding::Model(m) => decoder.decode_symbol(m.as_view()).ok()?,
        };
        let v = match symbol > 2 * h.k {
            true => escaped.next().copied().filter(|v| v.unsigned_abs() as usize > h.k)?,
            false => symbol as i32 - h.k as i32,
        };
        *seen[c].get_mut(symbol)? += 1;
        values.push(v);
    }
    // A symbol whose count is 0, or counts a context never reaches, only a
    // broken unit decodes.
    seen.iter().zip(hists).all(|(s, h)| *s == h.counts).then_some(values)
}

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
//!                      version 20: plus 4 where the counts are sparse,
//!                      plus 8 for six histograms (contexts) with escapes
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

pub use super::residual_values::MAX_VALUE;
use super::residual_values::{self, Histogram, Layout};
use super::ContainerError;

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
    /// Version 20: units may code their values in contexts
    /// (`super::residual_values`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub contexts: bool,
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
    /// Version 20: values coded in contexts.
    pub contexts: bool,
}

impl Modes {
    /// Every layout this version writes.
    pub const ALL: Modes = Modes { spatial: true, sparse: true, contexts: true };
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
        Modes { spatial: self.spatial, sparse: self.sparse, contexts: self.contexts }
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

impl ResidualUnit {
    /// The unit's bytes (values beyond [`MAX_VALUE`] are the caller's to
    /// clamp; they are clamped here too): with or without contexts, the
    /// counts dense or sparse, as `modes` allows and whichever is shortest.
    /// `None` only if the range coder fails, which a model giving every
    /// value a nonzero share rules out.
    pub fn to_bytes(&self, modes: Modes) -> Option<Vec<u8>> {
        let max = MAX_VALUE as i32;
        let values: Vec<i32> = self.values.iter().map(|&v| v.clamp(-max, max)).collect();
        let mode = u8::from(self.mode == Mode::Delta) + 2 * u8::from(self.spatial);
        let mut best: Option<Vec<u8>> = None;
        // Version 20's contexts and escapes come together (the header's
        // `contexts`), or neither.
        for rich in [false, true].into_iter().filter(|&c| !c || modes.contexts) {
            let layout = Layout { sparse: modes.sparse, contexts: rich, escapes: rich };
            let (coded, used) = residual_values::encode(&values, layout)?;
            let flags = if used.sparse { SPARSE } else { 0 } + if rich { CONTEXTED } else { 0 };
            let unit = [&[mode + flags][..], &coded].concat();
            if best.as_ref().is_none_or(|b| unit.len() < b.len()) {
                best = Some(unit);
            }
        }
        best
    }

    /// Reads a unit of `count` values (3 V) from a frame chunk at byte
    /// `offset` (named in errors): [`Self::check`], then the values.
    pub fn parse(payload: &[u8], count: usize, modes: Modes, offset: usize) -> Result<ResidualUnit, ContainerError> {
        let (mode, spatial, (hists, escapes), at) = Self::check(payload, count, modes, offset)?;
        let contexts = payload.first().is_some_and(|m| m & CONTEXTED != 0);
        let words: Vec<u32> =
            payload[at..].chunks_exact(4).map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]])).collect();
        let values = residual_values::decode(words, (&hists, &escapes), contexts).ok_or_else(|| {
            ContainerError::Chunk { offset, msg: "vertex residual: the coded values do not decode".into() }
        })?;
        Ok(ResidualUnit { mode, spatial, values })
    }

    /// What a reader checks of a unit without range decoding it (the
    /// decoder's [`Self::parse`] does): its mode, its histograms, and whole
    /// words after them; modes 2 and 3, sparse counts and contexts only
    /// where the header allows them (`modes`). Returns the mode, whether it
    /// is spatial, the histograms and escaped values, and where the words
    /// start.
    pub fn check(
        payload: &[u8],
        count: usize,
        modes: Modes,
        offset: usize,
    ) -> Result<(Mode, bool, Coded, usize), ContainerError> {
        let bad = |msg: String| ContainerError::Chunk { offset, msg: format!("vertex residual: {msg}") };
        let first = *payload.first().ok_or_else(|| bad("an empty unit".into()))?;
        let (sparse, contexts) = (first & SPARSE != 0, first & CONTEXTED != 0);
        let (mode, spatial) = match first & !(SPARSE | CONTEXTED) {
            _ if sparse && !modes.sparse || contexts && !modes.contexts => {
                return Err(bad(format!("unknown mode {first}")))
            }
            0 => (Mode::Intra, false),
            1 => (Mode::Delta, false),
            2 if modes.spatial => (Mode::Intra, true),
            3 if modes.spatial => (Mode::Delta, true),
            _ => return Err(bad(format!("unknown mode {first}"))),
        };
        let mut at = 1;
        let layout = Layout { sparse, contexts, escapes: contexts };
        let coded = residual_values::check(payload, &mut at, count, layout).map_err(bad)?;
        if (payload.len() - at) % 4 != 0 {
            return Err(bad(format!("{} bytes of coded values, not whole 32-bit words", payload.len() - at)));
        }
        Ok((mode, spatial, coded, at))
    }
}

/// A unit's histograms and escaped values, as read.
pub type Coded = (Vec<Histogram>, Vec<i32>);

/// The mode byte's flag of sparse counts (version 20).
const SPARSE: u8 = 4;
/// The mode byte's flag of values coded in contexts, with escapes (version
/// 20).
const CONTEXTED: u8 = 8;

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
        let sparse_only = Modes { spatial: true, sparse: true, contexts: false };
        let (dense, sparse) =
            (unit.to_bytes(Modes { spatial: true, sparse: false, contexts: false }), unit.to_bytes(sparse_only));
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

    /// Values whose size follows their neighbour's (runs of quiet and of
    /// busy vertices, as a surface's smooth parts and creases give): coded
    /// in contexts they take fewer bytes, read back exactly, and only where
    /// the header allows contexts.
    #[test]
    fn values_in_contexts_cost_less_where_neighbours_agree() {
        let values: Vec<i32> = (0..6000)
            .map(|i: i32| {
                let busy = (i / 300) % 2 == 1;
                let r = (i * 7919 + 13) % 97;
                if busy {
                    r % 9 - 4
                } else {
                    i32::from(r == 0) - i32::from(r == 1)
                }
            })
            .collect();
        let unit = ResidualUnit { mode: Mode::Delta, spatial: false, values };
        let flat = unit.to_bytes(Modes { spatial: false, sparse: true, contexts: false }).unwrap();
        let contexts = unit.to_bytes(Modes::ALL).unwrap();
        assert_eq!(contexts[0] & 8, 8, "the contexts flag");
        assert!(contexts.len() * 10 < flat.len() * 9, "{} bytes against {}", contexts.len(), flat.len());
        assert_eq!(ResidualUnit::parse(&contexts, 6000, Modes::ALL, 0).unwrap(), unit);
        let sparse_only = Modes { spatial: true, sparse: true, contexts: false };
        assert!(ResidualUnit::parse(&contexts, 6000, sparse_only, 0).is_err(), "contexts in a header without them");
        let mut flipped = contexts.clone();
        for i in (0..flipped.len()).step_by(7) {
            flipped[i] ^= 0x11;
            let _ = ResidualUnit::parse(&flipped, 6000, Modes::ALL, 0);
            flipped[i] ^= 0x11;
        }
    }
}

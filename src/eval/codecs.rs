//! The codecs `cgv eval` compares, named for what their files store, and
//! how each sets the encoder's options.

use crate::codec::EncodeOptions;
use crate::format::{CorrectionMode, Representation};
use crate::solve::SolverKind;
use serde::Serialize;

/// A codec as `cgv eval` runs it: what its files store, and for the
/// closed-loop ones, whether the corrections are fixed to one
/// [`CorrectionMode`] or matched at each rate point from the variants
/// ([`EvalCodec::variants`]; of those no larger than the target allows,
/// the one with the lower error is kept: what an encoder that knows its
/// own reconstruction can do).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EvalCodec {
    representation: Representation,
    /// `None`: the best of the variants.
    corrections: Option<CorrectionMode>,
    /// A vertex residual (format v18) whose step is searched for the rate
    /// point's size, the video at the fixed QP `--target-error` uses.
    residual: bool,
}

/// Names `--codecs` accepts besides the codecs' own: those of the first
/// round, when the closed-loop codecs were all called `cgv`.
const ALIASES: [(&str, EvalCodec); 4] = [
    ("paper", EvalCodec::CONFORMAL),
    ("cgv", EvalCodec::PREDICTIVE),
    ("cgv-scaled", EvalCodec::PREDICTIVE_SCALED),
    ("cgv-motion", EvalCodec::PREDICTIVE_MOTION),
];

/// The variants' correction interval: [`EvalCodec::variants`] tries motion
/// corrections on every second frame too (which made samba's lowest point
/// at N = 128 reachable at all: with corrections on every frame the
/// smallest file, at the loop's coarsest QP, is 10 % too large; every
/// second frame fits at QP 37, with 1.07 % surface RMS against GV's
/// 1.15 %).
const EVERY_SECOND: u32 = 2;

/// With bones, [`EvalCodec::variants`] tries these correction intervals too.
const BONE_INTERVALS: [u32; 2] = [4, 8];

/// The best-of entries pass over a variant whose worst frame's error is more
/// than this many times its mean (the no-drift bound of issue 6) for one
/// without such a spike whose worst frame is no worse: pcow at N = 128,
/// `max` point, the scaled encode had 0.181 % surface RMS with frame 122 at
/// 0.620 % (3.4x), the motion encode 0.238 % with none past 1.3x (GV:
/// 0.334 %, 1.1x). Without the second condition face-poses' lowest point
/// kept a 7.4 % encode (worst frame 18 %) over a 2.2 % one (worst 7.0 %).
pub const SPIKE: f64 = 3.0;

impl EvalCodec {
    const fn of(representation: Representation, corrections: Option<CorrectionMode>) -> EvalCodec {
        EvalCodec { representation, corrections, residual: false }
    }
    /// Geometry video: x, y, z.
    pub const GV: EvalCodec = EvalCodec::of(Representation::Gv, None);
    /// The seed paper's representation (H, λ at key frames, anchors, seed),
    /// decoded by the paper's Eq. 1 solver.
    pub const CONFORMAL: EvalCodec = EvalCodec::of(Representation::Conformal, None);
    /// Closed-loop prediction and x, y, z corrections, the best of the
    /// scaled and motion variants at each rate point.
    pub const PREDICTIVE: EvalCodec = EvalCodec::of(Representation::Predictive, None);
    /// The same with the normal layout (format v9).
    pub const NORMAL: EvalCodec = EvalCodec::of(Representation::Normal, None);
    pub const PREDICTIVE_SCALED: EvalCodec = EvalCodec::of(Representation::Predictive, Some(CorrectionMode::Scaled));
    pub const PREDICTIVE_MOTION: EvalCodec = EvalCodec::of(Representation::Predictive, Some(CorrectionMode::Motion));
    pub const NORMAL_SCALED: EvalCodec = EvalCodec::of(Representation::Normal, Some(CorrectionMode::Scaled));
    pub const NORMAL_MOTION: EvalCodec = EvalCodec::of(Representation::Normal, Some(CorrectionMode::Motion));
    /// Bones on the input's own vertices and what they miss as x, y, z
    /// (format v17): measured on the input's vertices, its grid being a
    /// residual, not a surface.
    pub const SKINNED: EvalCodec = EvalCodec::of(Representation::Skinned, None);
    /// The same with a vertex residual (format v18): the rate point's size
    /// is met by the residual's step, the video at
    /// [`crate::codec::RESIDUAL_QP`]'s QP for the skinned codec.
    pub const SKINNED_RESIDUAL: EvalCodec =
        EvalCodec { representation: Representation::Skinned, corrections: None, residual: true };
    /// No grid and no video (format v20): the input's vertices every frame,
    /// the rate point's size met by their step.
    pub const VERTICES: EvalCodec = EvalCodec::of(Representation::Vertices, None);

    /// What `cgv eval` runs unless told otherwise.
    pub const ALL: [EvalCodec; 4] = [EvalCodec::GV, EvalCodec::CONFORMAL, EvalCodec::PREDICTIVE, EvalCodec::NORMAL];

    /// Every codec `--codecs` names, in the order reports list them.
    pub const NAMED: [EvalCodec; 11] = [
        EvalCodec::GV,
        EvalCodec::CONFORMAL,
        EvalCodec::PREDICTIVE,
        EvalCodec::NORMAL,
        EvalCodec::PREDICTIVE_SCALED,
        EvalCodec::PREDICTIVE_MOTION,
        EvalCodec::NORMAL_SCALED,
        EvalCodec::NORMAL_MOTION,
        EvalCodec::SKINNED,
        EvalCodec::SKINNED_RESIDUAL,
        EvalCodec::VERTICES,
    ];

    /// The encodes a best-of entry matches at each rate point (codec,
    /// correction interval); None for a codec encoded one way. With bones,
    /// motion corrections on every fourth and eighth frame too: between
    /// corrections the bones carry the motion alone, which is the lowest
    /// rates' best use of bits (a skinned mesh's size).
    pub fn variants(self, bones: bool) -> Option<Vec<(EvalCodec, u32)>> {
        if self.corrections.is_some() || !self.closed_loop() || self.residual || self.vertices() {
            return None;
        }
        let with = |c| EvalCodec::of(self.representation, Some(c));
        let (scaled, motion) = (with(CorrectionMode::Scaled), with(CorrectionMode::Motion));
        let mut v = vec![(scaled, 1), (motion, 1), (motion, EVERY_SECOND)];
        if bones {
            v.extend(BONE_INTERVALS.map(|k| (motion, k)));
        }
        Some(v)
    }

    /// Whether its files carry a vertex residual whose step is searched.
    pub(super) fn residual(self) -> bool {
        self.residual
    }

    /// Whether the codec lays its corrections out along the normal.
    pub(super) fn normal(self) -> bool {
        self.representation == Representation::Normal
    }

    /// Whether its files carry bones on the input's vertices (and so the
    /// source mesh), the grid coding only what they miss.
    pub(super) fn skinned(self) -> bool {
        self.representation == Representation::Skinned
    }

    /// Whether its files have no grid (format v20).
    pub(super) fn vertices(self) -> bool {
        self.representation == Representation::Vertices
    }

    /// Whether it is measured on the input's own vertices, which its
    /// decoder gives (the skinned codec's grid is what its bones miss; the
    /// vertices codec has none).
    pub(super) fn on_vertices(self) -> bool {
        self.skinned() || self.vertices()
    }

    fn closed_loop(self) -> bool {
        matches!(self.representation, Representation::Predictive | Representation::Normal)
    }

    pub(super) fn options(self, base: &EncodeOptions) -> EncodeOptions {
        // The grid codecs are compared as they code the motion; the source
        // mesh, the same for all, is reported once (Report::source_mesh_bytes).
        EncodeOptions {
            representation: self.representation,
            solver: self.solver(),
            corrections: self.corrections.unwrap_or(CorrectionMode::Scaled),
            source_mesh: self.on_vertices(),
            ..base.clone()
        }
    }

    pub(super) fn solver(self) -> SolverKind {
        if self.representation == Representation::Conformal {
            SolverKind::Paper
        } else {
            SolverKind::Predictive
        }
    }

    /// The name `--codecs` and the reports use: the representation's, and
    /// the corrections' when fixed (`normal-motion`).
    pub fn name(self) -> &'static str {
        use CorrectionMode::{Motion, Scaled};
        match (self.representation, self.corrections) {
            (Representation::Skinned, _) if self.residual => "skinned-residual",
            (Representation::Predictive, Some(Scaled)) => "predictive-scaled",
            (Representation::Predictive, Some(Motion)) => "predictive-motion",
            (Representation::Normal, Some(Scaled)) => "normal-scaled",
            (Representation::Normal, Some(Motion)) => "normal-motion",
            (r, _) => r.name(),
        }
    }
}

impl Serialize for EvalCodec {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl std::str::FromStr for EvalCodec {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let own = EvalCodec::NAMED.into_iter().find(|c| c.name() == s);
        own.or_else(|| ALIASES.iter().find(|a| a.0 == s).map(|a| a.1)).ok_or_else(|| {
            let names: Vec<&str> = EvalCodec::NAMED.iter().map(|c| c.name()).collect();
            format!("unknown codec '{s}' (expected {})", names.join(", "))
        })
    }
}

impl std::fmt::Display for EvalCodec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

//! What a frame chunk says about how the predictive decoder predicts the
//! frame (its predictor and lag bytes). The bytes are decoded here once;
//! the predictor reads the result.

/// Largest predictor byte (bits 0..=1: extrapolation 0..=3, bits 2..=3:
/// steps 0..=3, bit 4 (version 13): skinned, bits 0..=1 then saying what
/// is added, 0 nothing, 1 velocity, 2 smoothed velocity).
pub const MAX_PREDICTOR: u8 = 0b1_1111;
/// The predictor byte's skinned bit (version 13).
pub const SKINNED_BIT: u8 = 0b1_0000;
/// Most mean-curvature steps a predictor code can ask for.
pub const MAX_STEPS: u8 = 3;

/// How a frame is extrapolated from the decoded past (the predictor
/// byte's bits 0..=1; `crate::solve::predictor` computes each).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Extrapolation {
    /// The previous frame moved by the rigid motion of its anchors (the
    /// previous frame itself when there are fewer than 3 anchors).
    #[default]
    Rigid,
    /// Constant velocity: 2 x₋₁ − x₋₂.
    Velocity,
    /// x₋₁ plus the velocity x₋₁ − x₋₂ smoothed over the grid
    /// (`solve::predictor::SMOOTHING_PASSES` averaging passes): the coding noise of the two
    /// past frames is not doubled, while the smooth motion of a body is kept.
    SmoothVelocity,
    /// x₋₁ plus the velocity of [`PredictorCode::lag`] frames ago,
    /// x₋ₗ − x₋ₗ₋₁, smoothed like [`SmoothVelocity`](Self::SmoothVelocity)
    /// (format version 4): exact but for the smoothing for a motion that
    /// repeats every `lag` frames while the body travels at constant
    /// velocity (horse-gallop is a 24-frame cycle played twice). Unsmoothed,
    /// it carried the coding noise of two more decoded frames into every
    /// prediction (horse-gallop, N = 128: surface RMS 0.83 / 0.42 % against
    /// 0.77 / 0.38 % smoothed at GV's `low` and `medium` sizes, and a
    /// smoothness metric above GV's instead of 20-25 % below).
    Cycle,
    /// Version 13: x₋₁ moved as the bones move, x₋₁ + L − L₋₁ (L the
    /// file's skinning of this frame, `crate::solve::skinned`).
    Skinned,
    /// Version 13: [`Skinned`](Self::Skinned) plus what the bones missed of
    /// the last frame's motion, (x₋₁ − x₋₂) − (L₋₁ − L₋₂).
    SkinnedVelocity,
    /// Version 13: the same, smoothed like [`SmoothVelocity`](Self::SmoothVelocity).
    SkinnedSmoothVelocity,
}

impl Extrapolation {
    /// Whether the extrapolation uses the file's bones.
    pub fn is_skinned(self) -> bool {
        matches!(self, Extrapolation::Skinned | Extrapolation::SkinnedVelocity | Extrapolation::SkinnedSmoothVelocity)
    }
}

/// A frame's predictor: the extrapolation (bits 0..=1 of the predictor
/// byte), the number of mean-curvature steps (bits 2..=3), and the lag of a
/// cycle prediction (the byte after it; 0 for the other extrapolations).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PredictorCode {
    pub extrapolation: Extrapolation,
    pub steps: u8,
    pub lag: u8,
}

impl PredictorCode {
    /// A code without mean-curvature steps.
    pub fn plain(extrapolation: Extrapolation) -> PredictorCode {
        PredictorCode { extrapolation, steps: 0, lag: 0 }
    }

    /// From the predictor and lag bytes; `None` for a byte past
    /// [`MAX_PREDICTOR`], a cycle without a lag of at least 2, or a lag on
    /// another extrapolation.
    pub fn from_bytes(b: u8, lag: u8) -> Option<PredictorCode> {
        let extrapolation = match b & 3 {
            0 if b & SKINNED_BIT != 0 => Extrapolation::Skinned,
            1 if b & SKINNED_BIT != 0 => Extrapolation::SkinnedVelocity,
            2 if b & SKINNED_BIT != 0 => Extrapolation::SkinnedSmoothVelocity,
            _ if b & SKINNED_BIT != 0 => return None,
            0 => Extrapolation::Rigid,
            1 => Extrapolation::Velocity,
            2 => Extrapolation::SmoothVelocity,
            _ => Extrapolation::Cycle,
        };
        let lag_ok = match extrapolation {
            Extrapolation::Cycle => lag >= 2,
            _ => lag == 0,
        };
        (b <= MAX_PREDICTOR && lag_ok).then_some(PredictorCode { extrapolation, steps: (b >> 2) & 3, lag })
    }

    /// The predictor byte (the lag is [`lag`](Self::lag)).
    pub fn to_byte(self) -> u8 {
        let e = match self.extrapolation {
            Extrapolation::Rigid => 0,
            Extrapolation::Velocity => 1,
            Extrapolation::SmoothVelocity => 2,
            Extrapolation::Cycle => 3,
            Extrapolation::Skinned => SKINNED_BIT,
            Extrapolation::SkinnedVelocity => SKINNED_BIT | 1,
            Extrapolation::SkinnedSmoothVelocity => SKINNED_BIT | 2,
        };
        e | (self.steps.min(MAX_STEPS) << 2)
    }
}

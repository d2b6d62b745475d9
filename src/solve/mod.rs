//! Rebuilding grid positions from what a conformal geometry video stores.
//!
//! - [`paper`]: the paper's Eq. 1 as written (squared magnitudes), solved by
//!   L-BFGS from the previous frame moved rigidly onto the new anchors.
//! - [`predictor`]: the project's predictive decoder: each frame predicted from the decoded
//!   past (rigid or velocity extrapolation, then mean-curvature steps with a
//!   matrix factored once per sequence), plus the encoder's closed-loop
//!   corrections.
//! - [`rigid`]: the rigid motion between anchor sets (Horn 1987).
//! - [`skinned`]: bones as a predictor (format version 13): the previous
//!   frame moved by each bone's rigid motion, blended by its weights.

pub mod paper;
pub mod predictor;
pub mod rigid;
pub mod skinned;

use crate::error::{Error, Result};
use glam::Vec3;
use serde::Serialize;

/// The first guess for a frame: `init` when given (frame 0's seed), else the
/// previous decoded frame moved by the rigid motion that best maps its
/// anchors onto this frame's (the paper, section 5.3).
pub(crate) fn warm_start(
    init: Option<&[Vec3]>,
    prev: &Option<(Vec<Vec3>, Vec<Vec3>)>,
    anchors: &[Vec3],
) -> Result<Vec<Vec3>> {
    match (init, prev) {
        (Some(i), _) => Ok(i.to_vec()),
        (None, Some((px, pa))) => {
            let m = rigid::fit(pa, anchors);
            Ok(px.iter().map(|&p| m.apply(p)).collect())
        }
        (None, None) => Err(Error::Argument("the first frame needs an initial guess".into())),
    }
}

pub use crate::format::SolverKind;

/// What a solve of one frame did.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct SolveStats {
    pub iterations: usize,
    /// Last relative update (cgv) or relative gradient norm (paper).
    pub residual: f64,
    pub converged: bool,
}

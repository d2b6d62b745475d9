//! Rebuilding grid positions from what a conformal geometry video stores.
//!
//! - [`paper`]: the paper's Eq. 1 as written (squared magnitudes), solved by
//!   L-BFGS from the previous frame moved rigidly onto the new anchors.
//! - [`cgv`]: the project's formulation, a fixed point of sparse linear solves
//!   with one factorization per key-frame segment.
//! - [`rigid`]: the rigid motion between anchor sets (Horn 1987).

pub mod cgv;
pub mod paper;
pub mod rigid;

use serde::{Deserialize, Serialize};

/// Which decoder to run on a CGV file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum SolverKind {
    /// The project's solver (see [`cgv`]).
    #[default]
    Cgv,
    /// The paper's Eq. 1 as written (see [`paper`]).
    Paper,
}

impl std::str::FromStr for SolverKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "cgv" => Ok(SolverKind::Cgv),
            "paper" => Ok(SolverKind::Paper),
            _ => Err(format!("unknown solver '{s}' (expected cgv or paper)")),
        }
    }
}

impl std::fmt::Display for SolverKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SolverKind::Cgv => "cgv",
            SolverKind::Paper => "paper",
        })
    }
}

/// What a solve of one frame did.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct SolveStats {
    pub iterations: usize,
    /// Last relative update (cgv) or relative gradient norm (paper).
    pub residual: f64,
    pub converged: bool,
}

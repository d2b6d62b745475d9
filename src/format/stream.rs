//! The names of a file's scalar streams. Each is written in the header as
//! the string it has always had (`"H"`, `"lambda"`, `"dx"`, ...); a name
//! this reader does not know is an error, not a guess.

use serde::{Deserialize, Serialize};

/// What one scalar stream carries, per grid sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum StreamName {
    /// Mean curvature (the paper's extrinsic geometry).
    #[serde(rename = "H")]
    H,
    /// Conformal factor (the paper's intrinsic geometry), at key frames.
    #[serde(rename = "lambda")]
    Lambda,
    /// Tangential coefficients of the Laplacian (read, never written).
    #[serde(rename = "a")]
    A,
    #[serde(rename = "b")]
    B,
    /// Frame 0's positions, the first guess of a CGV decoder.
    #[serde(rename = "seed_x")]
    SeedX,
    #[serde(rename = "seed_y")]
    SeedY,
    #[serde(rename = "seed_z")]
    SeedZ,
    /// A geometry video's positions.
    #[serde(rename = "x")]
    X,
    #[serde(rename = "y")]
    Y,
    #[serde(rename = "z")]
    Z,
    /// The closed-loop corrections of the predictive decoder.
    #[serde(rename = "dx")]
    Dx,
    #[serde(rename = "dy")]
    Dy,
    #[serde(rename = "dz")]
    Dz,
    /// Version 9: what coarse `dx`, `dy`, `dz` leave of the correction,
    /// along the predicted surface's normal (the extrinsic channel).
    #[serde(rename = "dn")]
    Dn,
}

/// A geometry video's coordinate streams.
pub const POSITION: [StreamName; 3] = [StreamName::X, StreamName::Y, StreamName::Z];
/// The frame-0 seed streams.
pub const SEED: [StreamName; 3] = [StreamName::SeedX, StreamName::SeedY, StreamName::SeedZ];
/// The correction streams along the world axes.
pub const CORRECTION: [StreamName; 3] = [StreamName::Dx, StreamName::Dy, StreamName::Dz];

impl StreamName {
    /// The name as the header writes it.
    pub fn as_str(self) -> &'static str {
        match self {
            StreamName::H => "H",
            StreamName::Lambda => "lambda",
            StreamName::A => "a",
            StreamName::B => "b",
            StreamName::SeedX => "seed_x",
            StreamName::SeedY => "seed_y",
            StreamName::SeedZ => "seed_z",
            StreamName::X => "x",
            StreamName::Y => "y",
            StreamName::Z => "z",
            StreamName::Dx => "dx",
            StreamName::Dy => "dy",
            StreamName::Dz => "dz",
            StreamName::Dn => "dn",
        }
    }

    /// The coordinate (0, 1, 2) of a position, seed or correction stream.
    pub fn axis(self) -> Option<usize> {
        [POSITION, SEED, CORRECTION].iter().find_map(|set| set.iter().position(|&s| s == self))
    }

    pub fn is_correction(self) -> bool {
        CORRECTION.contains(&self) || self == StreamName::Dn
    }
}

impl std::fmt::Display for StreamName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // `pad`, so widths in format strings apply.
        f.pad(self.as_str())
    }
}

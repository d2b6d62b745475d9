//! # cgv — conformal geometry videos
//!
//! The reference implementation of *conformal geometry videos* (Quynh, He,
//! Chen, Xia, Sun, Hoi: "Modeling 3D articulated motions with conformal
//! geometry videos (CGVs)", ACM Multimedia 2011). A platform-free core: mesh
//! sequence I/O ([`mesh`], the embedded default motion in [`mesh::builtin`]), seamless
//! geometry images ([`param`], [`grid`], [`resample`]) and metrics
//! ([`metrics`]). Platform code lives at the edges (the `cgv` binary).

// Numerical kernels index several arrays in lockstep (positions, normals,
// stencils); index loops say that more plainly than zipped iterators.
#![allow(clippy::needless_range_loop)]

pub mod codec;
pub mod error;
#[cfg(not(target_arch = "wasm32"))]
pub mod eval;
#[cfg(not(target_arch = "wasm32"))]
pub mod features;
pub mod format;
#[cfg(not(target_arch = "wasm32"))]
pub mod geometry_image;
pub mod geometry_png;
pub mod grid;
pub mod mesh;
pub mod metrics;
pub mod output;
pub mod param;
// An encoder's step, like `geometry_image` (rayon): not in the wasm decoder.
#[cfg(not(target_arch = "wasm32"))]
pub mod place_fit;
#[cfg(feature = "render")]
pub mod render;
pub mod resample;
pub mod skin;
pub mod solve;
pub mod sparse;
#[cfg(target_arch = "wasm32")]
pub mod web;

pub use error::{Error, MeshProblem, Result};

//! The codecs (the paper, sections 3 and 5): the motion resampled on the
//! seamless grid, coded as scalar streams of grayscale H.264
//! (`crate::format::quant` for the samples, [`h264`] natively, WebCodecs in
//! the browser).
//!
//! - A **GV** file (geometry video, the baseline) codes the grid's x, y, z
//!   every frame.
//! - A **CGV** file codes, at frame 0, a coarse copy of the positions
//!   (`seed_x/y/z`) the decoders start from, and then either the paper's
//!   representation (mean curvature H every frame, the conformal factor λ at
//!   key frames, a few anchor positions) for the paper's solver, or
//!   closed-loop corrections to the predictive decoder's prediction from
//!   the decoded past (`crate::solve::predictor`): `dx/dy/dz` along the
//!   world axes, or from version 9 `dn` along the predicted surface's
//!   normal and `dt/db` along it, coarser ([`corrections`]).
//!   Motion-corrected files, the default at low rates, carry no H and no λ.
//!
//! [`reconstruct`] is what the decoder does with a frame, called by the
//! encoder's closed loop too; [`decode`] decodes a file natively; `encode`
//! is the encoder.

pub mod corrections;
#[cfg(not(target_arch = "wasm32"))]
pub mod decode;
#[cfg(not(target_arch = "wasm32"))]
mod encode;
#[cfg(not(target_arch = "wasm32"))]
pub mod h264;
pub mod loose;
pub mod reconstruct;
pub mod vertex_residual;

pub use corrections::{smoothed_normals, Corrections, Layout, FILTER_CHOICES};
#[cfg(not(target_arch = "wasm32"))]
pub use decode::{FileDecoder, UnitDecoder};
#[cfg(not(target_arch = "wasm32"))]
pub use encode::residual_step;
#[cfg(not(target_arch = "wasm32"))]
pub use encode::{
    auto_corrections, auto_grid, auto_grid_for_error, auto_normal_correction, encode, encode_into, encode_on_budget,
    encode_on_budget_into, encode_prepared, encode_prepared_into, encode_to_error, encode_vertices_into,
    finest_vertex_percent, prepare, prepare_for_error, residual_qp_of, skinned_bones, skinned_grid, BudgetResidual,
    CodecChoice, EncodeOptions, EncodeReport, EncodeRequest, Encoded, GridChoice, Made, TargetReport, AUTO_GRID_BITS,
    AUTO_GRID_FLOOR_MARGIN, AUTO_MOTION_QP, AUTO_SCALED_BITS, BUDGET_TOLERANCE, DEFAULT_BONES, DEFAULT_RANDOM_ACCESS,
    DEFAULT_VERTEX_PERCENT, MAX_PASSES, MIN_BONE_FRAMES, MOTION_MARGIN, PAPER_ANCHORS, RESIDUAL_BUDGET_BITS,
    RESIDUAL_QP,
};
pub use reconstruct::{
    frame_values, place_loose, FrameStats, Reconstructor, SequenceDecoder, SourceMeshDecoder, DEFAULT_MEMORY_LIMIT,
};

use glam::Vec3;

/// Picks anchor samples spread over the surface: farthest-point sampling in
/// 3D from the sample farthest from the centroid. Four or more such points
/// on a real body are not coplanar.
pub fn choose_anchors(grid_positions: &[Vec3], count: usize) -> Vec<u32> {
    let n = grid_positions.len();
    if n == 0 || count == 0 {
        return Vec::new();
    }
    let c = grid_positions.iter().copied().sum::<Vec3>() / n as f32;
    let far = |d: &dyn Fn(usize) -> f32| (0..n).max_by(|&a, &b| d(a).total_cmp(&d(b))).unwrap_or(0);
    let mut chosen = vec![far(&|i| grid_positions[i].distance(c)) as u32];
    let mut dist: Vec<f32> = grid_positions.iter().map(|p| p.distance(grid_positions[chosen[0] as usize])).collect();
    while chosen.len() < count.min(n) {
        let next = far(&|i| dist[i]);
        chosen.push(next as u32);
        for (d, p) in dist.iter_mut().zip(grid_positions) {
            *d = d.min(p.distance(grid_positions[next]));
        }
    }
    chosen
}

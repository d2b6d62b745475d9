//! How far a skinning is from the frames it was fitted to: vertex RMS (mean
//! over frames) and max, surface RMS and max on every few frames, and the
//! KG error, each length relative to a diagonal the caller names (each
//! frame's, or the first frame's as the peers' reports use).

use super::Skinning;
use crate::error::Result;
use glam::Vec3;

/// A skinning's errors against its frames.
#[derive(Debug, Clone, Copy, Default)]
pub struct SkinErrors {
    pub vertex_rms: f64,
    pub vertex_max: f64,
    /// Over the measured frames (none when `surface_every` is 0).
    pub surface_rms: Option<f64>,
    pub surface_max: Option<f64>,
    /// KG error (%, each frame's centroid).
    pub kg: f64,
}

/// The errors of `skin` against `frames` (over `faces`), frame t's lengths
/// divided by `diagonal(t)`, the surface measured on every
/// `surface_every`-th frame (0: none).
pub fn measure(
    frames: &[Vec<Vec3>],
    faces: &[[u32; 3]],
    skin: &Skinning,
    surface_every: usize,
    diagonal: &dyn Fn(usize) -> f64,
) -> Result<SkinErrors> {
    measure_frames(frames, faces, &|t| skin.frame(t), surface_every, diagonal)
}

/// [`measure`] of any frames a skinning plays (`played(t)`: frame t, as
/// with its residual's morph targets).
pub fn measure_frames(
    frames: &[Vec<Vec3>],
    faces: &[[u32; 3]],
    played: &dyn Fn(usize) -> Vec<Vec3>,
    surface_every: usize,
    diagonal: &dyn Fn(usize) -> f64,
) -> Result<SkinErrors> {
    let n = frames.len().max(1) as f64;
    let (mut e, mut surface) = (SkinErrors::default(), Vec::new());
    let mut kg = crate::metrics::KgError::default();
    for (t, f) in frames.iter().enumerate() {
        let (x, diag) = (played(t), diagonal(t));
        let (rms, max) = crate::metrics::vertex_error(&x, f);
        (e.vertex_rms, e.vertex_max) = (e.vertex_rms + rms / diag / n, e.vertex_max.max(max / diag));
        kg.add_frame(f, &x);
        if surface_every > 0 && t % surface_every == 0 {
            let d = crate::metrics::surface::symmetric(&x, faces, f, faces)?;
            surface.push(d.rms / diag);
            e.surface_max = Some(e.surface_max.unwrap_or(0.0).max(d.max / diag));
        }
    }
    e.surface_rms = (!surface.is_empty()).then(|| surface.iter().sum::<f64>() / surface.len() as f64);
    e.kg = kg.value();
    Ok(e)
}

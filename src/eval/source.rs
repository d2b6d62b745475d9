//! Errors on the input's own vertices, each rebuilt from a decoded grid
//! frame where it lies on the grid mesh ([`SourcePoints`]): the measures
//! the dynamic-mesh-compression literature and Draco or gltfpack users
//! know (vertex RMSE relative to the bounding-box diagonal, KG error),
//! beside the grid's own errors.

use crate::metrics::{self, KgError};
use crate::resample::SourcePoints;
use glam::Vec3;
use serde::Serialize;

/// A codec's errors on the input's vertices, relative to the diagonal.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SourceErrors {
    /// Mean over frames of each frame's RMS distance between the input's
    /// vertices and the rebuilt ones.
    pub vertex_rms: f64,
    /// Largest distance over all frames.
    pub vertex_max: f64,
    /// KG error (percent) against each frame's centroid (Karni & Gotsman's).
    pub kg: f64,
    /// KG error (percent) against each vertex's mean over time.
    pub kg_temporal: f64,
}

/// Accumulates [`SourceErrors`] frame by frame.
pub struct SourceMeasure<'a> {
    points: &'a SourcePoints,
    /// Each vertex's loose vertex plus one (0: rebuilt from the grid).
    loose_of: Vec<u32>,
    diagonal: f64,
    rms_sum: f64,
    frames: usize,
    max: f64,
    kg: KgError,
}

impl<'a> SourceMeasure<'a> {
    pub fn new(points: &'a SourcePoints, loose_of: Vec<u32>, diagonal: f64) -> SourceMeasure<'a> {
        SourceMeasure { points, loose_of, diagonal, rms_sum: 0.0, frames: 0, max: 0.0, kg: KgError::default() }
    }

    /// Adds one frame: the input's vertices, a decoded grid frame and the
    /// loose vertices decoded with it; returns this frame's RMS, relative to
    /// the diagonal.
    pub fn add_frame(&mut self, input: &[Vec3], grid_frame: &[Vec3], loose: &[Vec3]) -> f64 {
        let mut rebuilt = self.points.apply(grid_frame);
        crate::codec::place_loose(&mut rebuilt, &self.loose_of, loose);
        self.add_vertices(input, &rebuilt)
    }

    /// Adds one frame's vertices as a decoder rebuilt them; returns its
    /// RMS, relative to the diagonal.
    pub fn add_vertices(&mut self, input: &[Vec3], rebuilt: &[Vec3]) -> f64 {
        let (rms, max) = metrics::vertex_error(rebuilt, input);
        self.kg.add_frame(input, rebuilt);
        self.rms_sum += rms / self.diagonal;
        self.max = self.max.max(max / self.diagonal);
        self.frames += 1;
        rms / self.diagonal
    }

    pub fn finish(&self) -> SourceErrors {
        SourceErrors {
            vertex_rms: self.rms_sum / self.frames.max(1) as f64,
            vertex_max: self.max,
            kg: self.kg.value(),
            kg_temporal: self.kg.temporal(),
        }
    }
}

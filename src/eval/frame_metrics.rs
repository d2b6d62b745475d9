//! One frame's measures of a decoded file against the input: on the grid
//! (the grid codecs) or on the input's own vertices (the skinned codec,
//! whose grid is what its bones miss).

use super::source::SourceMeasure;
use super::{Ctx, FrameMetrics};
use crate::error::Result;
use crate::geometry_image::surface_vertices;
use crate::grid::stencil::Stencils;
use crate::metrics::{self, surface};
use glam::Vec3;

impl Ctx<'_> {
    /// Frame `f`'s errors of a decoded grid frame `x` (with its loose
    /// vertices) against `input`.
    pub(super) fn grid_metrics(
        &self,
        f: usize,
        input: &[Vec3],
        (x, loose): (&[Vec3], &[Vec3]),
        (kg, source): (&mut metrics::KgError, &mut SourceMeasure),
        (st, faces): (&Stencils, &[[u32; 3]]),
    ) -> Result<FrameMetrics> {
        let topology = self.src.topology();
        let truth = &self.prepared.map.apply(input);
        let (rms, max) = metrics::vertex_error(x, truth);
        kg.add_frame(truth, x);
        let surf = (self.opts.surface_every > 0 && f % self.opts.surface_every == 0)
            .then(|| surface::symmetric(&surface_vertices(x, loose), faces, input, &topology.faces))
            .transpose()?;
        Ok(FrameMetrics {
            frame: f,
            vertex_rms: rms / self.diagonal,
            vertex_max: max / self.diagonal,
            smoothness: metrics::smoothness(st, truth, x) / self.diagonal,
            spacing_drift: metrics::spacing_drift(st, truth, x, &self.prepared.map.on_input),
            surface_rms: surf.map(|d| d.rms / self.diagonal),
            surface_max: surf.map(|d| d.max / self.diagonal),
            source_vertex_rms: source.add_frame(input, x, loose),
        })
    }

    /// Frame `f`'s errors of the input's own vertices `v` as decoded (the
    /// skinned codec's): the grid's own measures (smoothness, spacing)
    /// do not apply and are NaN.
    pub(super) fn vertex_metrics(
        &self,
        f: usize,
        input: &[Vec3],
        v: &[Vec3],
        (kg, source): (&mut metrics::KgError, &mut SourceMeasure),
    ) -> Result<FrameMetrics> {
        let faces = &self.src.topology().faces;
        let (rms, max) = metrics::vertex_error(v, input);
        kg.add_frame(input, v);
        let surf = (self.opts.surface_every > 0 && f % self.opts.surface_every == 0)
            .then(|| surface::symmetric(v, faces, input, faces))
            .transpose()?;
        Ok(FrameMetrics {
            frame: f,
            vertex_rms: rms / self.diagonal,
            vertex_max: max / self.diagonal,
            smoothness: f64::NAN,
            spacing_drift: f64::NAN,
            surface_rms: surf.map(|d| d.rms / self.diagonal),
            surface_max: surf.map(|d| d.max / self.diagonal),
            source_vertex_rms: source.add_vertices(input, v),
        })
    }
}

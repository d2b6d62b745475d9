//! Choosing the parameterization by what the grid makes of the surface: of
//! the maps the area-correction passes go through
//! ([`parameterize_scored`]), keep the one whose grid mesh lies closest to
//! the reference frame's surface (the symmetric RMS distance of
//! [`metrics::surface`](crate::metrics::surface)).
//!
//! This is the resampling error every codec starts from (the uncompressed
//! grid's), so it bounds the surface error of the best encode. Measured on
//! the reference frame, at N = 128, mean over 8 frames of the sequence
//! (`cgv remesh` reports the same figure): horse-gallop 0.285 % of the
//! diagonal after format v5's fixed 40 passes, 0.208 % after 200; pcow
//! 0.169 % after 40, 0.119 % after 20, 0.174 % after 200; samba 0.056 %
//! after 40, 0.046 % after 200. No fixed count suits all three.

use super::{parameterize_scored, ParamOptions, Parameterization};
use crate::error::Result;
use crate::grid::Grid;
use crate::mesh::Topology;
use crate::metrics::surface;
use crate::resample::SampleMap;
use glam::Vec3;

/// [`super::parameterize`] of `reference`, keeping of the area-correction
/// passes the map whose `grid` resamples `reference` with the lowest
/// symmetric RMS surface distance (reported in
/// [`Parameterization::score`], in the mesh's units).
pub fn parameterize_for_grid(
    topology: &Topology,
    reference: &[Vec3],
    grid: Grid,
    opts: &ParamOptions,
) -> Result<Parameterization> {
    let grid_faces = grid.topology().faces;
    let target = surface::Target::new(reference, &topology.faces)?;
    let mut score = |p: &Parameterization| -> Result<f64> {
        // A map whose samples cannot all be located (it cannot happen for a
        // map without folds, which is all the passes keep) is no candidate.
        let Ok(map) = SampleMap::build(grid, &topology.faces, p) else {
            return Ok(f64::INFINITY);
        };
        let g = map.apply(reference);
        Ok(surface::symmetric_to(&g, &grid_faces, reference, &topology.faces, &target)?.rms)
    };
    parameterize_scored(topology, reference, opts, Some(&mut score))
}

//! Geometry images as pictures: x, y, z of each grid sample as the red,
//! green and blue of a 16-bit PNG, scaled to the frame's bounding box. Row j
//! of the picture is row j of the grid (v grows downwards in the picture).

use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::mesh::Bounds;
use glam::Vec3;

/// Encodes a geometry image as a 16-bit RGB PNG.
pub fn geometry_image_png(grid: &Grid, positions: &[Vec3]) -> Result<Vec<u8>> {
    if positions.len() != grid.len() {
        return Err(Error::Argument(format!("{} positions for a {}² grid", positions.len(), grid.n)));
    }
    let b = Bounds::of(positions);
    let ext = (b.max - b.min).max(Vec3::splat(f32::MIN_POSITIVE));
    let mut data = Vec::with_capacity(grid.len() * 6);
    for p in positions {
        let t = ((*p - b.min) / ext).clamp(Vec3::ZERO, Vec3::ONE);
        for c in t.to_array() {
            data.extend_from_slice(&((c * 65535.0).round() as u16).to_be_bytes());
        }
    }
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, grid.n as u32, grid.n as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Sixteen);
        let mut w = enc.write_header().map_err(|e| Error::Numerical(format!("PNG: {e}")))?;
        w.write_image_data(&data).map_err(|e| Error::Numerical(format!("PNG: {e}")))?;
    }
    Ok(out)
}

//! A capture without correspondence: every frame its own mesh, read from
//! a folder of OBJ, or of glTF and GLB, files.

use crate::error::{Error, Result};
use crate::mesh::{FrameMesh, FrameSelection};
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

/// One frame of a capture: its own mesh.
#[derive(Debug, Clone)]
pub struct CaptureFrame {
    pub positions: Vec<Vec3>,
    pub faces: Vec<[u32; 3]>,
}

impl CaptureFrame {
    /// The frame as a [`FrameMesh`], its places not known yet.
    pub(crate) fn mesh(&self) -> FrameMesh {
        FrameMesh { positions: self.positions.clone(), faces: self.faces.clone(), places: Vec::new() }
    }

    /// The surface's centroid (its faces' centroids weighted by area):
    /// where the body is, whatever its triangulation (a vertex mean moves
    /// with the simplifier's density). Zero for a frame without area.
    pub fn center(&self) -> Vec3 {
        let (mut sum, mut area) = (glam::DVec3::ZERO, 0.0);
        for f in &self.faces {
            let [a, b, c] = f.map(|v| self.positions.get(v as usize).copied().unwrap_or_default().as_dvec3());
            let w = (b - a).cross(c - a).length();
            sum += w * (a + b + c) / 3.0;
            area += w;
        }
        if area > 0.0 {
            (sum / area).as_vec3()
        } else {
            Vec3::ZERO
        }
    }
}

/// The frames of a folder of OBJ, or of glTF and GLB, files (`frames`, if
/// given, a range of them), each its own mesh
/// ([`crate::mesh::open::capture_files`]).
pub fn read_capture(dir: &Path, frames: Option<FrameSelection>) -> Result<Vec<CaptureFrame>> {
    let files = crate::mesh::open::capture_files(dir)?;
    let (first, count) = match frames {
        Some(s) => s.resolve(files.len()).map_err(|e| Error::Argument(format!("{}: {e}", dir.display())))?,
        None => (0, files.len()),
    };
    files[first..first + count]
        .par_iter()
        .map(|f| crate::mesh::open::read_still(f).map(|(positions, faces)| CaptureFrame { positions, faces }))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame's center is its surface's, not its vertices': a square of
    /// two triangles with an extra vertex crowded into one corner.
    #[test]
    fn the_center_is_the_surfaces() {
        let p = |x: f32, y: f32| Vec3::new(x, y, 1.0);
        let frame = CaptureFrame {
            positions: vec![p(0.0, 0.0), p(2.0, 0.0), p(2.0, 2.0), p(0.0, 2.0), p(0.1, 0.1)],
            faces: vec![[0, 1, 2], [0, 2, 3]],
        };
        assert!(frame.center().distance(p(1.0, 1.0)) < 1e-6, "{}", frame.center());
        assert_eq!(CaptureFrame { positions: vec![], faces: vec![] }.center(), Vec3::ZERO);
    }
}

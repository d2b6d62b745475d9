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

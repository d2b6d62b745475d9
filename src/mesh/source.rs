//! Mesh sequences read frame by frame. A [`FrameSource`] knows its
//! connectivity and frame count up front and reads any frame on demand, so no
//! command needs every frame in memory at once. Opening a file as a source
//! is `super::open`'s work.

use super::{Frame, Topology};
use crate::error::{Error, MeshProblem, Result};
use glam::Vec3;
use std::path::{Path, PathBuf};

/// A registered mesh sequence that can be read one frame at a time.
pub trait FrameSource: Send + Sync {
    /// What the sequence was read from (a path, or `builtin:...`).
    fn label(&self) -> &Path;
    fn frame_count(&self) -> usize;
    /// Frames per second of the motion.
    fn fps(&self) -> f32;
    fn topology(&self) -> &Topology;
    /// Reads frame `i`, checked against the first frame's connectivity and
    /// for finite coordinates.
    fn read_frame(&self, i: usize) -> Result<Frame>;
    /// Short description of the kind of input, for reports.
    fn kind(&self) -> &'static str;
    /// The input's own vertices, texture coordinates and base colour,
    /// when it has them (a textured glTF).
    fn appearance(&self) -> Option<&super::Appearance> {
        None
    }
    /// Frame `i`'s own mesh, where every frame has its own (a registered
    /// capture's, whose frames this source gives on the grid): none for a
    /// sequence whose frames share their vertices.
    fn frame_mesh(&self, _i: usize) -> Result<Option<std::borrow::Cow<'_, FrameMesh>>> {
        Ok(None)
    }
    /// Whether every frame has a mesh of its own ([`Self::frame_mesh`]),
    /// without reading one.
    fn has_frame_meshes(&self) -> bool {
        false
    }
    /// A decoded source mesh's vertices (the file's stored order) indexed
    /// as this sequence's: a textured input's stored mesh splits vertices
    /// along UV seams, each copy decoding alike.
    fn on_input(&self, stored: Vec<Vec3>) -> Frame {
        match self.appearance() {
            Some(a) => a.on_sequence(&stored, self.topology().vertex_count),
            None => stored,
        }
    }
}

/// One frame's own mesh and where each of its vertices lies in the
/// frame's parameterization (quantized as a file stores places:
/// `crate::format::source_mesh::quantize_place`).
#[derive(Debug, Clone, PartialEq)]
pub struct FrameMesh {
    pub positions: Vec<Vec3>,
    pub faces: Vec<[u32; 3]>,
    pub places: Vec<[u32; 2]>,
}

/// Checks a frame against the sequence's first frame.
pub fn check_frame(path: &Path, topology: &Topology, positions: &[Vec3], faces: Option<&[[u32; 3]]>) -> Result<()> {
    if positions.len() != topology.vertex_count {
        return Err(Error::mesh(
            path,
            MeshProblem::VertexCountMismatch { expected: topology.vertex_count, found: positions.len() },
        ));
    }
    if let Some(faces) = faces {
        if faces.len() != topology.faces.len() {
            return Err(Error::mesh(
                path,
                MeshProblem::FaceCountMismatch { expected: topology.faces.len(), found: faces.len() },
            ));
        }
        if let Some(face) = faces.iter().zip(&topology.faces).position(|(a, b)| a != b) {
            return Err(Error::mesh(path, MeshProblem::FacesDiffer { face }));
        }
    }
    if let Some(vertex) = positions.iter().position(|p| !p.is_finite()) {
        return Err(Error::mesh(path, MeshProblem::NonFinite { vertex }));
    }
    Ok(())
}

/// A sequence held in memory (the embedded default motion, tests).
pub struct InMemory {
    pub label: PathBuf,
    pub fps: f32,
    pub topology: Topology,
    pub frames: Vec<Frame>,
}

impl FrameSource for InMemory {
    fn label(&self) -> &Path {
        &self.label
    }
    fn frame_count(&self) -> usize {
        self.frames.len()
    }
    fn fps(&self) -> f32 {
        self.fps
    }
    fn topology(&self) -> &Topology {
        &self.topology
    }
    fn kind(&self) -> &'static str {
        "in-memory sequence"
    }
    fn read_frame(&self, i: usize) -> Result<Frame> {
        let f = self.frames.get(i).ok_or_else(|| {
            Error::Argument(format!("frame {i} is past the last frame {}", self.frames.len() as i64 - 1))
        })?;
        check_frame(&self.label, &self.topology, f, None)?;
        Ok(f.clone())
    }
}

//! Triangle meshes and registered mesh sequences: one connectivity shared by
//! every frame, one array of positions per frame.

pub mod adjacency;
mod bridge;
pub mod builtin;
pub mod carrier;
pub mod gltf_in;
pub mod gltf_out;
pub mod obj;
pub mod open;
pub mod source;
pub mod topology;
#[cfg(not(target_arch = "wasm32"))]
pub mod unregister;

use glam::Vec3;

pub use adjacency::Adjacency;
pub use open::{open_sequence, FrameSelection, OpenOptions};
pub use source::{FrameMesh, FrameSource, InMemory};
pub use topology::{analyze, TopologyReport};

/// How the input looks beyond its shape: its vertices as it stored them
/// (a glTF splits them at UV seams; the sequence welds them), the faces
/// over those, and (for the file) their texture coordinates and the
/// material's base colour.
#[derive(Debug, Clone, PartialEq)]
pub struct Appearance {
    /// For each stored vertex, the sequence vertex it is.
    pub welded: Vec<u32>,
    /// The faces over the stored vertices.
    pub faces: Vec<[u32; 3]>,
    /// Their texture coordinates and the base colour, as a file carries them.
    pub look: crate::format::Appearance,
}

impl Appearance {
    /// Positions of the stored vertices indexed as the sequence's: a
    /// decoded source mesh's, whose copies of a vertex split at a seam
    /// decode alike.
    pub fn on_sequence(&self, stored: &[Vec3], vertex_count: usize) -> Frame {
        let mut v = vec![Vec3::ZERO; vertex_count];
        for (&w, p) in self.welded.iter().zip(stored) {
            if let Some(slot) = v.get_mut(w as usize) {
                *slot = *p;
            }
        }
        v
    }

    /// For each sequence vertex, the first stored vertex that is it.
    pub fn stored_of(&self, vertex_count: usize) -> Vec<u32> {
        let mut first = vec![0u32; vertex_count];
        for (k, &v) in self.welded.iter().enumerate().rev() {
            if let Some(slot) = first.get_mut(v as usize) {
                *slot = k as u32;
            }
        }
        first
    }
}

/// Positions of one frame, indexed like the sequence's vertices.
pub type Frame = Vec<Vec3>;

/// Connectivity shared by every frame of a sequence: counter-clockwise
/// triangles (seen from outside) over `vertex_count` vertices.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topology {
    pub vertex_count: usize,
    pub faces: Vec<[u32; 3]>,
}

/// Axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Bounds {
    pub min: Vec3,
    pub max: Vec3,
}

impl Bounds {
    pub fn of(points: &[Vec3]) -> Bounds {
        let mut min = Vec3::splat(f32::INFINITY);
        let mut max = Vec3::splat(f32::NEG_INFINITY);
        for p in points {
            min = min.min(*p);
            max = max.max(*p);
        }
        Bounds { min, max }
    }
    pub fn diagonal(&self) -> f32 {
        (self.max - self.min).length()
    }
    pub fn union(&self, other: &Bounds) -> Bounds {
        Bounds { min: self.min.min(other.min), max: self.max.max(other.max) }
    }
}

/// Twice the area vector of a triangle (its normal times twice its area).
pub fn triangle_area_vector(a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    (b - a).cross(c - a)
}

/// Unit vertex normals: the area-weighted mean of the faces' normals
/// around each vertex (+z where they cancel or there is no face, so that
/// every normal is a unit vector, as glTF requires).
pub fn vertex_normals(positions: &[Vec3], faces: &[[u32; 3]]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for f in faces {
        let [a, b, c] = f.map(|i| positions[i as usize]);
        let area = triangle_area_vector(a, b, c);
        for &i in f {
            n[i as usize] += area;
        }
    }
    n.iter().map(|v| v.try_normalize().unwrap_or(Vec3::Z)).collect()
}

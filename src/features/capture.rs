//! A capture without correspondence: every frame its own mesh, read from
//! a folder of OBJ, or of glTF and GLB, files.

use crate::error::{Error, Result};
use crate::mesh::{FrameMesh, FrameSelection};
use glam::Vec3;
use rayon::prelude::*;
use std::borrow::Cow;
use std::ops::Range;
use std::path::{Path, PathBuf};

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

    /// Whether `other` is this frame's mesh moved: as many vertices and
    /// the same faces, so that each vertex is one point of the body in
    /// both (a registered stretch of a capture: a vendor's "stabilized
    /// segment").
    pub fn shares_mesh(&self, other: &CaptureFrame) -> bool {
        self.positions.len() == other.positions.len() && self.faces == other.faces
    }
}

/// Whether `frames`, at least two, all share the first one's mesh
/// ([`CaptureFrame::shares_mesh`]): a registered run, which one map serves
/// as it serves a registered motion.
pub fn is_registered_run(frames: &[CaptureFrame]) -> bool {
    frames.len() >= 2 && frames[1..].iter().all(|f| f.shares_mesh(&frames[0]))
}

/// How much reading a capture may hold: a segment's frames are held at
/// once (the registration looks across them), so a long segment is
/// refused while it is read, not when memory runs out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaptureLimit {
    /// Most bytes the frames may take, as [`CaptureLimit::frame_bytes`]
    /// counts them.
    pub bytes: u64,
    /// Samples of the grid each frame is registered on; `None`: the frames
    /// are only tracked (`cgv info --unregistered`), not registered.
    pub grid_samples: Option<usize>,
}

impl CaptureLimit {
    /// No limit (tests, callers that bound their input themselves).
    pub const NONE: CaptureLimit = CaptureLimit { bytes: u64::MAX, grid_samples: None };

    /// About what `frame` holds: the frame itself, and where it is
    /// registered, its copy kept as the frame's own mesh with each
    /// vertex's place, and its grid twice (the maps' and the smoothing's).
    pub fn frame_bytes(&self, frame: &CaptureFrame) -> u64 {
        let (v, f) = (frame.positions.len() as u64, frame.faces.len() as u64);
        let mesh = 12 * v + 12 * f;
        match self.grid_samples {
            None => mesh,
            Some(n) => 2 * mesh + 8 * v + 24 * n as u64,
        }
    }
}

/// A capture's frames as a registration reads them: a stretch at a time,
/// from memory or from its files.
pub trait Capture: Sync {
    /// Frames in the capture.
    fn len(&self) -> usize;
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The frames of `range`, each its own mesh.
    fn frames(&self, range: Range<usize>) -> Result<Cow<'_, [CaptureFrame]>>;
}

impl Capture for &[CaptureFrame] {
    fn len(&self) -> usize {
        <[CaptureFrame]>::len(self)
    }
    fn frames(&self, range: Range<usize>) -> Result<Cow<'_, [CaptureFrame]>> {
        let n = <[CaptureFrame]>::len(self);
        self.get(range.clone())
            .map(Cow::Borrowed)
            .ok_or_else(|| Error::Argument(format!("frames {range:?} of a capture of {n}")))
    }
}

/// A capture's frame files (a folder of OBJ, or of glTF and GLB, files,
/// [`crate::mesh::open::capture_files`]), read when asked for, never more
/// at once than `limit` allows.
pub struct CaptureFiles {
    dir: PathBuf,
    files: Vec<PathBuf>,
    limit: CaptureLimit,
}

impl CaptureFiles {
    /// The frame files of `dir` (`frames`, if given, a range of them).
    pub fn open(dir: &Path, frames: Option<FrameSelection>, limit: CaptureLimit) -> Result<CaptureFiles> {
        let files = crate::mesh::open::capture_files(dir)?;
        let (first, count) = match frames {
            Some(s) => s.resolve(files.len()).map_err(|e| Error::Argument(format!("{}: {e}", dir.display())))?,
            None => (0, files.len()),
        };
        Ok(CaptureFiles { dir: dir.into(), files: files[first..first + count].to_vec(), limit })
    }
}

impl Capture for CaptureFiles {
    fn len(&self) -> usize {
        self.files.len()
    }

    /// The frames of `range`, read a few at a time in parallel: never more
    /// at once than the largest frame so far says fit under the limit, so
    /// the limit is passed by one frame at most, and then refused.
    fn frames(&self, range: Range<usize>) -> Result<Cow<'_, [CaptureFrame]>> {
        let files = self.files.get(range.clone()).ok_or_else(|| {
            Error::Argument(format!("{}: frames {range:?} of a capture of {}", self.dir.display(), self.files.len()))
        })?;
        let (mut read, mut held, mut largest) = (Vec::with_capacity(files.len()), 0u64, 0u64);
        while read.len() < files.len() {
            // The first frame alone, to learn a frame's size.
            let room = match largest {
                0 => 1,
                _ => self.limit.bytes.saturating_sub(held) / largest,
            };
            let batch = (2 * rayon::current_num_threads()).min(room.max(1) as usize).min(files.len() - read.len());
            let part: Vec<CaptureFrame> = files[read.len()..read.len() + batch]
                .par_iter()
                .map(|f| crate::mesh::open::read_still(f).map(|(positions, faces)| CaptureFrame { positions, faces }))
                .collect::<Result<_>>()?;
            for f in &part {
                let bytes = self.limit.frame_bytes(f);
                (held, largest) = (held.saturating_add(bytes), largest.max(bytes));
            }
            read.extend(part);
            if held > self.limit.bytes {
                return Err(Error::CaptureMemory {
                    path: self.dir.clone(),
                    first: range.start,
                    frames: read.len(),
                    needed: held,
                    limit: self.limit.bytes,
                });
            }
        }
        Ok(Cow::Owned(read))
    }
}

/// Every frame of a folder of OBJ, or of glTF and GLB, files (`frames`, if
/// given, a range of them), each its own mesh, held at once within `limit`
/// ([`CaptureFiles`]).
pub fn read_capture(dir: &Path, frames: Option<FrameSelection>, limit: CaptureLimit) -> Result<Vec<CaptureFrame>> {
    let capture = CaptureFiles::open(dir, frames, limit)?;
    capture.frames(0..capture.len()).map(Cow::into_owned)
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

    /// A run is registered where every frame has the first's vertices (in
    /// number) and faces, wherever its vertices moved.
    #[test]
    fn a_run_is_registered_where_its_frames_share_one_mesh() {
        let tri = |z: f32, faces| CaptureFrame { positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.0, z)], faces };
        let a = tri(0.0, vec![[0, 1, 2]]);
        assert!(is_registered_run(&[a.clone(), tri(0.5, vec![[0, 1, 2]]), tri(2.0, vec![[0, 1, 2]])]));
        assert!(!is_registered_run(std::slice::from_ref(&a)), "one frame is no run");
        assert!(!is_registered_run(&[a.clone(), tri(0.0, vec![[0, 2, 1]])]), "other faces");
        let mut more = a.clone();
        more.positions.push(Vec3::ONE);
        assert!(!is_registered_run(&[a, more]), "another vertex");
    }
}

//! Mesh sequences read frame by frame. A [`FrameSource`] knows its
//! connectivity and frame count up front and reads any frame on demand, so no
//! command needs every frame in memory at once.

use super::obj::{frame_number, read_obj};
use super::topology::HoleFill;
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
}

/// Options for [`open_sequence`].
#[derive(Debug, Clone)]
pub struct OpenOptions {
    /// Frame rate given to OBJ sequences and used to bake glTF animations.
    pub fps: f32,
    /// glTF: which animation to bake (index or name); the first by default.
    pub animation: Option<String>,
    /// Close boundary loops (see [`HoleFill`]).
    pub fill_holes: bool,
    /// Keep only these frames (the first kept frame becomes frame 0).
    pub frames: Option<FrameSelection>,
}

/// A range of frames, `A..B` (B excluded), `A..`, `..B` or `A..=B`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameSelection {
    pub start: usize,
    /// One past the last frame; `None` for the end of the sequence.
    pub end: Option<usize>,
}

impl std::str::FromStr for FrameSelection {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let bad = || format!("'{s}' is not a frame range (expected A..B, A.., ..B or A..=B)");
        let (a, b, inclusive) = if let Some((a, b)) = s.split_once("..=") {
            (a, Some(b), true)
        } else if let Some((a, b)) = s.split_once("..") {
            (a, if b.is_empty() { None } else { Some(b) }, false)
        } else {
            return Err(bad());
        };
        let start = if a.is_empty() { 0 } else { a.trim().parse().map_err(|_| bad())? };
        let end = match b {
            Some(b) => {
                let e: usize = b.trim().parse().map_err(|_| bad())?;
                Some(if inclusive { e + 1 } else { e })
            }
            None => None,
        };
        if end.is_some_and(|e| e <= start) {
            return Err(format!("frame range '{s}' is empty"));
        }
        Ok(FrameSelection { start, end })
    }
}

impl Default for OpenOptions {
    fn default() -> Self {
        OpenOptions { fps: 30.0, animation: None, fill_holes: false, frames: None }
    }
}

/// The name under which the embedded default motion is opened.
pub const BUILTIN_DEFAULT: &str = "builtin:walk";

/// Opens a sequence: a folder of OBJ files, one OBJ file, a glTF 2.0 file
/// (`.gltf`, `.glb`) with an animation, or [`BUILTIN_DEFAULT`].
pub fn open_sequence(spec: &str, opts: &OpenOptions) -> Result<Box<dyn FrameSource>> {
    if !(opts.fps.is_finite() && opts.fps > 0.0 && opts.fps <= 1000.0) {
        return Err(Error::Argument(format!("frame rate {} is not in (0, 1000]", opts.fps)));
    }
    let source: Box<dyn FrameSource> = if spec == BUILTIN_DEFAULT || spec == "builtin" {
        Box::new(crate::demo::default_motion())
    } else {
        let path = Path::new(spec);
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
        if meta.is_dir() {
            Box::new(ObjFolder::open(path, opts.fps)?)
        } else {
            match ext.as_deref() {
                Some("obj") => Box::new(ObjFolder::single(path, opts.fps)?),
                Some("gltf") | Some("glb") => {
                    Box::new(super::gltf_in::GltfSource::open(path, opts.fps, opts.animation.as_deref())?)
                }
                _ => {
                    return Err(Error::Argument(format!(
                    "{}: unknown input kind (expected a folder of .obj files, .obj, .gltf, .glb or {BUILTIN_DEFAULT})",
                    path.display()
                )))
                }
            }
        }
    };
    let mut source = source;
    if opts.fill_holes {
        let plan = HoleFill::plan(source.topology());
        if !plan.loops.is_empty() {
            source = Box::new(FilledHoles { inner: source, plan });
        }
    }
    if let Some(sel) = opts.frames {
        let count = source.frame_count();
        let end = sel.end.unwrap_or(count);
        if end > count {
            return Err(Error::Argument(format!(
                "{}: frames {}..{end} asked for, but the sequence has {count}",
                source.label().display(),
                sel.start
            )));
        }
        source = Box::new(Slice { inner: source, start: sel.start, len: end - sel.start });
    }
    Ok(source)
}

/// Frames `start..start + len` of another sequence.
struct Slice {
    inner: Box<dyn FrameSource>,
    start: usize,
    len: usize,
}

impl FrameSource for Slice {
    fn label(&self) -> &Path {
        self.inner.label()
    }
    fn frame_count(&self) -> usize {
        self.len
    }
    fn fps(&self) -> f32 {
        self.inner.fps()
    }
    fn topology(&self) -> &Topology {
        self.inner.topology()
    }
    fn kind(&self) -> &'static str {
        self.inner.kind()
    }
    fn read_frame(&self, i: usize) -> Result<Frame> {
        if i >= self.len {
            return Err(Error::Argument(format!("frame {i} is past the last selected frame {}", self.len as i64 - 1)));
        }
        self.inner.read_frame(self.start + i)
    }
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

/// A folder of OBJ files, one per frame, in the order of the number in their
/// names; or a single OBJ file as a one-frame sequence.
pub struct ObjFolder {
    label: PathBuf,
    files: Vec<PathBuf>,
    fps: f32,
    topology: Topology,
}

impl ObjFolder {
    pub fn open(dir: &Path, fps: f32) -> Result<ObjFolder> {
        let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
        let mut files = Vec::new();
        for entry in entries {
            let entry = entry.map_err(|e| Error::io(dir, e))?;
            let p = entry.path();
            if p.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("obj")) {
                files.push(p);
            }
        }
        if files.is_empty() {
            return Err(Error::Argument(format!("{}: no .obj files in this folder", dir.display())));
        }
        // Numeric order first (2 before 10), then by name for files without a number.
        files.sort_by(|a, b| {
            (frame_number(a).is_none(), frame_number(a), a.file_name()).cmp(&(
                frame_number(b).is_none(),
                frame_number(b),
                b.file_name(),
            ))
        });
        Self::from_files(dir, files, fps)
    }

    pub fn single(path: &Path, fps: f32) -> Result<ObjFolder> {
        Self::from_files(path, vec![path.to_path_buf()], fps)
    }

    fn from_files(label: &Path, files: Vec<PathBuf>, fps: f32) -> Result<ObjFolder> {
        let (positions, faces) = read_obj(&files[0])?;
        let topology = Topology { vertex_count: positions.len(), faces };
        check_frame(&files[0], &topology, &positions, None)?;
        Ok(ObjFolder { label: label.to_path_buf(), files, fps, topology })
    }
}

impl FrameSource for ObjFolder {
    fn label(&self) -> &Path {
        &self.label
    }
    fn frame_count(&self) -> usize {
        self.files.len()
    }
    fn fps(&self) -> f32 {
        self.fps
    }
    fn topology(&self) -> &Topology {
        &self.topology
    }
    fn kind(&self) -> &'static str {
        if self.files.len() == 1 && self.files[0] == self.label {
            "OBJ file"
        } else {
            "folder of OBJ files"
        }
    }
    fn read_frame(&self, i: usize) -> Result<Frame> {
        let path = self
            .files
            .get(i)
            .ok_or_else(|| Error::Argument(format!("frame {i} is past the last frame {}", self.files.len() - 1)))?;
        let (positions, faces) = read_obj(path)?;
        check_frame(path, &self.topology, &positions, Some(&faces))?;
        Ok(positions)
    }
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

/// A sequence whose holes are closed by [`HoleFill`].
struct FilledHoles {
    inner: Box<dyn FrameSource>,
    plan: HoleFill,
}

impl FrameSource for FilledHoles {
    fn label(&self) -> &Path {
        self.inner.label()
    }
    fn frame_count(&self) -> usize {
        self.inner.frame_count()
    }
    fn fps(&self) -> f32 {
        self.inner.fps()
    }
    fn topology(&self) -> &Topology {
        &self.plan.topology
    }
    fn kind(&self) -> &'static str {
        self.inner.kind()
    }
    fn read_frame(&self, i: usize) -> Result<Frame> {
        let mut f = self.inner.read_frame(i)?;
        self.plan.apply(&mut f);
        Ok(f)
    }
}

//! Opening what a user names as a motion: a folder of OBJ files, one OBJ
//! file, a glTF 2.0 animation or the built-in motion, with the adapters the
//! options ask for (holes closed, a range of frames).

use super::builtin;
use super::gltf_in::GltfSource;
use super::obj::ObjFolder;
use super::source::FrameSource;
use super::topology::HoleFill;
use super::{Frame, Topology};
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// The frames of a capture folder (every frame its own mesh): its OBJ
/// files, or else its glTF and GLB files, one a frame, ordered by the
/// number in their names. A folder holding both kinds is refused: which
/// are the frames is not clear.
pub fn capture_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let obj = super::obj::files_with(dir, &["obj"])?;
    let gltf = super::obj::files_with(dir, &["gltf", "glb"])?;
    match (obj.is_empty(), gltf.is_empty()) {
        (false, true) => Ok(obj),
        (true, false) => Ok(gltf),
        (true, true) => Err(Error::Argument(format!(
            "{}: no .obj, .gltf or .glb files in this folder (a capture is one mesh file a frame)",
            dir.display()
        ))),
        (false, false) => Err(Error::Argument(format!(
            "{}: both OBJ ({}) and glTF ({}) files in this folder; a capture's frames are of one kind",
            dir.display(),
            obj.len(),
            gltf.len()
        ))),
    }
}

/// One frame of a capture: an OBJ file, or a glTF or GLB file whose scene
/// is one still mesh (all its primitives, coincident vertices welded),
/// positions and faces.
pub fn read_still(path: &Path) -> Result<(Frame, Vec<[u32; 3]>)> {
    let is_obj = path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    if is_obj {
        return super::obj::read_obj(path);
    }
    let src = GltfSource::open(path, 30.0, None)?;
    if src.frame_count() != 1 {
        return Err(Error::Gltf {
            path: path.to_path_buf(),
            msg: format!(
                "a capture frame is one still mesh, but this file's animation bakes to {} frames at 30 frames/s \
                 (a motion whose frames share one mesh is read without --unregistered)",
                src.frame_count()
            ),
        });
    }
    Ok((src.read_frame(0)?, src.topology().faces.clone()))
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

impl FrameSelection {
    /// The first frame and the count this range selects of `total` frames;
    /// a message (to which the caller adds what it read) when the range is
    /// not inside them. The one check that `--frames` in every command and
    /// Python's `frames=` share.
    pub fn resolve(self, total: usize) -> std::result::Result<(usize, usize), String> {
        let end = self.end.unwrap_or(total);
        if self.start >= end || end > total {
            return Err(format!("frames {}..{end} are not inside its {total} frames", self.start));
        }
        Ok((self.start, end - self.start))
    }
}

impl Default for OpenOptions {
    fn default() -> Self {
        OpenOptions { fps: 30.0, animation: None, fill_holes: false, frames: None }
    }
}

/// Opens a sequence: a folder of OBJ files, one OBJ file, a glTF 2.0 file
/// (`.gltf`, `.glb`) with an animation, [`builtin::NAME`] or
/// [`builtin::TEXTURED_NAME`].
pub fn open_sequence(spec: &str, opts: &OpenOptions) -> Result<Box<dyn FrameSource>> {
    if !(opts.fps.is_finite() && opts.fps > 0.0 && opts.fps <= 1000.0) {
        return Err(Error::Argument(format!("frame rate {} is not in (0, 1000]", opts.fps)));
    }
    let source: Box<dyn FrameSource> = if spec == builtin::NAME || spec == "builtin" {
        Box::new(builtin::default_motion())
    } else if spec == builtin::TEXTURED_NAME {
        Box::new(builtin::textured_motion(builtin::FRAMES))
    } else {
        let path = Path::new(spec);
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
        if meta.is_dir() {
            Box::new(ObjFolder::open(path, opts.fps)?)
        } else {
            match ext.as_deref() {
                Some("obj") => Box::new(ObjFolder::single(path, opts.fps)?),
                Some("gltf") | Some("glb") => Box::new(GltfSource::open(path, opts.fps, opts.animation.as_deref())?),
                _ => {
                    return Err(Error::Argument(format!(
                        "{}: unknown input kind (expected a folder of .obj files, .obj, .gltf, .glb or {})",
                        path.display(),
                        builtin::NAME
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
        let (start, len) = sel
            .resolve(source.frame_count())
            .map_err(|m| Error::Argument(format!("{}: {m}", source.label().display())))?;
        source = Box::new(Slice { inner: source, start, len });
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
    fn appearance(&self) -> Option<&super::Appearance> {
        self.inner.appearance()
    }
    fn read_frame(&self, i: usize) -> Result<Frame> {
        if i >= self.len {
            return Err(Error::Argument(format!("frame {i} is past the last selected frame {}", self.len as i64 - 1)));
        }
        self.inner.read_frame(self.start + i)
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

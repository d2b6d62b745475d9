//! Errors of the library, sorted by culprit: the input (a file or its
//! contents), the caller (an argument), or the computation itself.

use std::path::PathBuf;

/// What is wrong with a mesh or a mesh sequence. Each variant names the
/// offending element so a user can find it in the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshProblem {
    #[error("has no faces")]
    NoFaces,
    #[error("face {face} uses vertex {index}, but there are only {count} vertices")]
    IndexOutOfRange { face: usize, index: i64, count: usize },
    #[error("has {found} vertices, but the first frame has {expected} (a capture whose frames are each their own mesh: `cgv info` and `cgv encode` read one with --unregistered)")]
    VertexCountMismatch { expected: usize, found: usize },
    #[error("has {found} faces, but the first frame has {expected} (a capture whose frames are each their own mesh: `cgv info` and `cgv encode` read one with --unregistered)")]
    FaceCountMismatch { expected: usize, found: usize },
    #[error("face {face} differs from the first frame's face {face} (frames must share one connectivity, or be read with --unregistered)")]
    FacesDiffer { face: usize },
    #[error("vertex {vertex} has a non-finite coordinate")]
    NonFinite { vertex: usize },
    #[error("face {face} is degenerate (it repeats vertex {vertex})")]
    DegenerateFace { face: usize, vertex: u32 },
    #[error("face {face} has zero area")]
    ZeroAreaFace { face: usize },
    #[error("faces {first} and {second} are duplicates (same three vertices)")]
    DuplicateFace { first: usize, second: usize },
    #[error("edge ({a}, {b}) is shared by {count} faces (non-manifold edge)")]
    NonManifoldEdge { a: u32, b: u32, count: usize },
    #[error("edge ({a}, {b}) is used twice in the same direction (inconsistent face orientation)")]
    InconsistentOrientation { a: u32, b: u32 },
    #[error("vertex {vertex} is non-manifold (its faces form {fans} separate fans)")]
    NonManifoldVertex { vertex: u32, fans: usize },
    #[error("vertex {vertex} is not used by any face")]
    UnusedVertex { vertex: u32 },
    #[error("has {count} connected components")]
    Components { count: usize },
    #[error("has {loops} boundary loop(s) made of {edges} boundary edges (the surface is open)")]
    Holes { loops: usize, edges: usize },
    #[error("has genus {genus}")]
    Genus { genus: i64 },
}

/// The library's error type.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or writing a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file is not valid in its format (OBJ, glTF, ...).
    #[error("{}:{line}: {msg}", path.display())]
    Parse { path: PathBuf, line: usize, msg: String },
    /// A glTF file could not be read or baked.
    #[error("{}: glTF: {msg}", path.display())]
    Gltf { path: PathBuf, msg: String },
    /// A mesh or frame is valid in its format but unusable as a motion.
    #[error("{}: {problem}", path.display())]
    Mesh { path: PathBuf, problem: MeshProblem },
    /// A `.cgv` file is malformed (see [`crate::format::ContainerError`]).
    #[error("{}: {source}", path.display())]
    Container {
        path: PathBuf,
        #[source]
        source: crate::format::ContainerError,
    },
    /// Decoding a file would need more memory than the caller allows.
    #[error(
        "decoding this file needs about {:.1} MiB, more than the limit of {:.1} MiB (the caller may raise it: \
         --memory-limit in the CLI, set_memory_limit_mib in the web player)",
        *needed as f64 / 1048576.0,
        *limit as f64 / 1048576.0
    )]
    Memory { needed: u64, limit: u64 },
    /// Reading (and registering) a capture would hold more memory than the
    /// caller allows (a segment's frames are held at once).
    #[error(
        "{}: {frames} frames from frame {first}, held at once (one segment's), already need about {:.1} MiB, \
         more than the limit of {:.1} MiB (raise --memory-limit, shorten the segments with --random-access, \
         or take the capture in parts with --frames A..B)",
        path.display(),
        *needed as f64 / 1048576.0,
        *limit as f64 / 1048576.0
    )]
    CaptureMemory { path: PathBuf, first: usize, frames: usize, needed: u64, limit: u64 },
    /// An H.264 stream could not be encoded or decoded.
    #[error("video: {0}")]
    Video(String),
    /// The caller asked for something that cannot be done.
    #[error("invalid argument: {0}")]
    Argument(String),
    /// A budget (`--kbps`) below the smallest file the codec makes of the
    /// motion: told apart so that `auto` can try a codec whose smallest
    /// file is smaller.
    #[error("invalid argument: {0}")]
    BudgetTooSmall(String),
    /// A budget above the largest file the codec makes of the motion:
    /// told apart so that a vertex residual can be tried to fill it.
    #[error("invalid argument: {0}")]
    BudgetTooLarge(String),
    /// A numerical step failed (a singular system, a map that folds over).
    #[error("{0}")]
    Numerical(String),
    /// The GPU renderer could not start or draw (no adapter, a lost device).
    #[error("render: {0}")]
    Render(String),
    /// A chart could not be drawn (`cgv eval --plot`).
    #[error("plot: {0}")]
    Plot(String),
}

impl Error {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), source }
    }
    pub fn mesh(path: impl Into<PathBuf>, problem: MeshProblem) -> Self {
        Error::Mesh { path: path.into(), problem }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

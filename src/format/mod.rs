//! The `.cgv` file format, versions 1 to 21 (documented in
//! `docs/FORMAT.md`, with the compatibility promise): this writer writes
//! version 21, the reader reads all twenty-one. Split as the png crate splits
//! its decoder:
//!
//! - [`header`]: what a file holds, the frame chunk's side data, and which
//!   version each feature needs ([`Header::min_version`]);
//! - [`validate`]: the header's checks, before anything is allocated;
//! - [`reader`]: a whole file, chunk by chunk; [`stream_reader`]: the same as
//!   bytes arrive, or in pieces from random-access points;
//! - [`writer`]: the prefix, chunks, frames and the index;
//! - the payloads: [`source_mesh`] (with [`connectivity`] and [`places`]),
//!   [`appearance`], [`loose`], [`skin`] (with [`bits`]), [`vertex_residual`] (with [`vertex_order`]), the samples' [`quant`]izer, the
//!   [`stream`] names and the [`predictor`] codes.
//!
//! The prefix and the chunks:
//!
//! ```text
//! magic    8 bytes   89 43 47 56 0D 0A 1A 0A   ("\x89CGV\r\n\x1a\n")
//! version  u16 LE    1 to 19
//! flags    u16 LE    0
//! length   u32 LE    header length L (at most 1 MiB)
//! header   L bytes   UTF-8 JSON (serde), see [`Header`]
//! crc      u32 LE    CRC-32 of version..header
//! chunks   ...       until an END chunk
//! ```
//!
//! Each chunk: `tag [4] | stream u16 | reserved u16 | frame u32 | length u32 |
//! payload | crc u32` (CRC-32 of tag..payload). Tags: `FRAM` (what a frame
//! needs besides its video: predictor, correction scale, anchors, see
//! [`FrameInfo`]; from version 2 followed by the frame's access units, each
//! after its LEB128 length), `AUNT` (version 1: one H.264 access unit,
//! Annex-B, of `stream` at `frame`), `SMSH` (version 6: the input's mesh,
//! once, before frame 0), `SKIN` (version 13: bone weights, once, before
//! frame 0), `RIDX` (version 10: the random-access points'
//! offsets, right before the end), `CEND` (end of file). Chunks are
//! ordered by frame, so a reader can start on frame 0 before the rest of the
//! file has arrived.

pub mod appearance;
pub mod bits;
pub mod connectivity;
pub mod frame_mesh;
pub mod header;
mod leb128;
pub mod loose;
pub mod places;
pub mod predictor;
pub mod quant;
pub mod reader;
pub mod residual_values;
pub mod skin;
pub mod source_mesh;
pub mod stream;
pub mod stream_reader;
pub mod validate;
pub mod vertex_order;
pub mod vertex_residual;
pub mod writer;

pub use appearance::{Appearance, AppearanceInfo, TextureInfo};
pub use header::{
    check_segments, random_access_point, CodecKind, CorrectionMode, Coverage, FrameInfo, Header, Representation,
    Settings, SolverKind, SourceInfo, StreamInfo, MAX_FILTER, MAX_RELAX, MAX_SHRINK, SEAM_RULE,
};
pub use loose::LooseFrame;
pub use predictor::{Extrapolation, PredictorCode, MAX_PREDICTOR, MAX_STEPS};
pub use quant::Quantizer;
pub use reader::{index_tail_bytes, parse_chunk, parse_header, parse_index_tail, read, CgvFile, Chunk};
pub use skin::{BoneMotions, SkinInfo, SkinWeights};

pub use source_mesh::{Offsets, SourceMesh, SourceMeshInfo};

pub use stream::StreamName;
pub use stream_reader::StreamReader;
pub use writer::{
    write_appearance, write_chunk, write_frame, write_header, write_index, write_skin, write_source_mesh,
};

pub const MAGIC: [u8; 8] = [0x89, b'C', b'G', b'V', b'\r', b'\n', 0x1A, b'\n'];
/// The newest version this reader reads and this writer writes.
pub const VERSION: u16 = 21;
/// Largest header accepted.
pub const MAX_HEADER: usize = 1 << 20;
/// Largest chunk payload accepted (an access unit of a 2160² frame at QP 0
/// stays far below it, and so does the largest source mesh that deflates
/// at all).
pub const MAX_CHUNK: usize = 64 << 20;
pub const MAX_FRAMES: u32 = 10_000_000;
pub const MAX_STREAMS: usize = 32;
pub const MAX_ANCHORS: usize = 4096;
/// The grid sizes a file may have: even, and from H.264's 16 x 16 minimum
/// to the largest square frame the encoder's H.264 level takes (2160 rows).
/// The encoder checks its options and the reader checks headers against
/// this one range.
pub const MIN_GRID: u32 = 16;
pub const MAX_GRID: u32 = 2160;

/// Whether `n` is a grid size a file may have (see [`MIN_GRID`]).
pub fn check_grid_size(n: u64) -> Result<(), String> {
    if (MIN_GRID as u64..=MAX_GRID as u64).contains(&n) && n % 2 == 0 {
        Ok(())
    } else {
        Err(format!("grid size {n} must be even and in {MIN_GRID}..={MAX_GRID}"))
    }
}

pub const TAG_ACCESS_UNIT: [u8; 4] = *b"AUNT";
pub const TAG_FRAME: [u8; 4] = *b"FRAM";
pub const TAG_END: [u8; 4] = *b"CEND";
/// Version 6: the input's mesh, once, before frame 0's chunk.
pub const TAG_SOURCE_MESH: [u8; 4] = *b"SMSH";
/// Version 8: how the source mesh looks, right after it.
pub const TAG_APPEARANCE: [u8; 4] = *b"APPR";
/// Version 10: the byte offsets of the random-access points' frame chunks,
/// right before the end chunk.
pub const TAG_INDEX: [u8; 4] = *b"RIDX";
/// Version 13: the skin weights, after the source mesh and appearance.
pub const TAG_SKIN: [u8; 4] = *b"SKIN";

/// What is wrong with a `.cgv` file, with the byte offset where it was found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ContainerError {
    #[error("not a .cgv file (bad magic number)")]
    BadMagic,
    #[error("format version {found} is newer than this reader (it reads up to {VERSION})")]
    UnsupportedVersion { found: u16 },
    #[error("truncated at byte {offset}: {what} needs {needed} more bytes")]
    Truncated { offset: usize, what: &'static str, needed: usize },
    #[error("corrupted at byte {offset}: {what} fails its CRC check")]
    BadCrc { offset: usize, what: &'static str },
    #[error("{what} is {value}, more than the limit {limit}")]
    TooLarge { what: &'static str, value: u64, limit: u64 },
    #[error("bad header: {0}")]
    Header(String),
    #[error("at byte {offset}: {msg}")]
    Chunk { offset: usize, msg: String },
}

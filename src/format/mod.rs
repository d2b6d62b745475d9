//! The `.cgv` file format, versions 1 to 11 (documented in `docs/FORMAT.md`).
//! Version 2 puts each frame in one chunk (version 1: one chunk per access
//! unit, 20 bytes each, a quarter of a low-bitrate file) and adds one
//! header field, `corrections` (see [`CorrectionMode`]). Version 3 has the
//! layout of version 2 and lets a motion-corrected CGV file leave out the
//! `H` and `lambda` streams. Version 4 adds cycle predictions: a lag byte
//! in the frame chunk and the header field `max_lag`. Version 5 adds a
//! filter byte to the frame chunk: the averaging passes the decoder applies
//! to the frame's correction. Version 6 may carry the input's own mesh
//! ([`source_mesh`]: the `SMSH` chunk after the header, and the header
//! field `source_mesh`); version 7 its vertices' offsets from the grid mesh;
//! version 8 how it looks ([`appearance`]: UVs, base colour, texture).
//! Version 9 may code `dx`, `dy`, `dz` on a coarser grid (`shrink`) and
//! what they leave along the surface's normal (`dn`). Version 10 may have
//! random-access points ([`Header::random_access`]): every stream restarts
//! there and the decoder's state resets, and an `RIDX` chunk before the end
//! lists their byte offsets, so a player seeks without decoding from frame 0.
//! Version 11 may code a tiny part's vertices as themselves ([`loose`]:
//! a unit after each frame's access units, and the source mesh says which
//! vertices they are).
//! This writer writes version 11; the reader reads all eleven.
//!
//! ```text
//! magic    8 bytes   89 43 47 56 0D 0A 1A 0A   ("\x89CGV\r\n\x1a\n")
//! version  u16 LE    1 to 11
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
//! once, before frame 0), `RIDX` (version 10: the random-access points'
//! offsets, right before the end), `CEND` (end of file). Chunks are
//! ordered by frame, so a reader can start on frame 0 before the rest of the
//! file has arrived.

pub mod appearance;
pub mod connectivity;
mod leb128;
pub mod loose;
pub mod places;
pub mod predictor;
pub mod quant;
pub mod source_mesh;
pub mod stream;

pub use appearance::{Appearance, AppearanceInfo, TextureInfo};
pub use loose::LooseFrame;
pub use predictor::{Extrapolation, PredictorCode, SolverKind, MAX_PREDICTOR, MAX_STEPS};
pub use quant::Quantizer;
use serde::{Deserialize, Serialize};
pub use source_mesh::{Offsets, SourceMesh, SourceMeshInfo};
use std::fmt;
pub use stream::StreamName;

pub const MAGIC: [u8; 8] = [0x89, b'C', b'G', b'V', b'\r', b'\n', 0x1A, b'\n'];
/// The newest version this reader reads and this writer writes.
pub const VERSION: u16 = 12;
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

/// How a CGV file's correction streams `dx`, `dy`, `dz` correct the cgv
/// decoder's prediction (see `crate::codec::reconstruct`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CorrectionMode {
    /// Version 1: each frame's decoded values, times the frame's correction
    /// scale, are added to the prediction.
    #[default]
    Scaled,
    /// Version 2: the difference between this frame's decoded values and
    /// the previous frame's (zero before frame 0) is added, so the streams
    /// carry the running sum of the corrections and H.264's cheapest mode,
    /// a block copied from the previous picture, means "no correction".
    Motion,
}

/// The header's `codec` field, frozen since version 1: `gv` for a geometry
/// video, `cgv` for every file built on the grid's intrinsic and extrinsic
/// streams or on corrections to a prediction. What such a file really
/// stores is its [`Representation`] ([`Header::representation`]), which
/// is the name users see.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CodecKind {
    /// H every frame and λ at key frames, corrections, or both (see
    /// [`Representation`]).
    Cgv,
    /// Geometry video: x, y, z every frame.
    Gv,
}

/// What a file stores, named so: derived from the streams its header
/// lists, so every version has one without a field of its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Representation {
    /// Geometry video: x, y, z every frame.
    Gv,
    /// The seed paper's: mean curvature H every frame, the conformal factor
    /// λ at key frames, anchors and a seed; no corrections.
    Conformal,
    /// A prediction from the decoded past plus closed-loop corrections in
    /// three channels, x, y, z (H and λ beside them in scaled files).
    Predictive,
    /// The same prediction, corrected along the predicted surface's normal
    /// (`dn`, one scalar channel at full size) and by x, y, z on a coarser
    /// grid (version 9).
    Normal,
}

impl Representation {
    /// The name `cgv encode --codec` and `cgv info` use.
    pub fn name(self) -> &'static str {
        match self {
            Representation::Gv => "gv",
            Representation::Conformal => "conformal",
            Representation::Predictive => "predictive",
            Representation::Normal => "normal",
        }
    }
}

impl fmt::Display for Representation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One coded scalar stream.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StreamInfo {
    /// What the stream carries.
    pub name: StreamName,
    /// 1 for the base layer, 2 for the residual layer refining stream `refines`.
    pub layer: u8,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refines: Option<u16>,
    pub quant: Quantizer,
    /// Which frames the stream has.
    pub coverage: Coverage,
    /// The decoded values are multiplied by the frame's correction scale
    /// ([`FrameInfo::correction_scale`]): the closed-loop corrections.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub scaled: bool,
    /// Version 9: the stream's pictures are the grid halved this many times
    /// (`grid >> shrink` samples a side; see `crate::grid::coarse`). Only
    /// `dx`, `dy`, `dz` beside a `dn` stream are shrunk, all three alike.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub shrink: u8,
}

impl StreamInfo {
    /// The side of this stream's pictures in a file of grid size `grid`.
    pub fn size(&self, grid: u32) -> u32 {
        grid >> self.shrink
    }
}

/// Per-frame side data (the `FRAM` chunk). Payload: `predictor u8 | lag u8
/// | filter u8 | relax u8 | correction_scale f32 | anchors (f32
/// x, y, z each)`, little-endian. The lag byte is zero before version 4,
/// the filter byte before version 5, the relax byte (reserved) before version 9.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrameInfo {
    /// How the predictive decoder predicts this frame before its
    /// correction is added: the predictor and lag bytes (a cycle's lag is
    /// 2..=the header's `max_lag`, and less than the frame's index).
    pub predictor: PredictorCode,
    /// Version 5: averaging passes the predictive decoder applies to this
    /// frame's correction before adding it (0..=[`MAX_FILTER`]; see
    /// `crate::codec::reconstruct`).
    pub filter: u8,
    /// Version 9: passes of tangential relaxation after this frame's
    /// correction (0..=[`MAX_RELAX`]; see `crate::codec::corrections`).
    pub relax: u8,
    /// Scale of the correction streams at this frame (0 without corrections).
    pub correction_scale: f32,
    pub anchors: Vec<[f32; 3]>,
    /// Version 10, at each random-access point of a file that has them:
    /// the point the seed streams' values are relative to (the seed is
    /// their values plus it), so that their one range spans the body, not
    /// everywhere it travels.
    pub seed_origin: Option<[f32; 3]>,
    /// Version 11, in every frame of a file with loose vertices: their
    /// residuals, the unit after the access units as the file has it
    /// (deflated: [`LooseFrame::parse`] reads it; a reader checks it but
    /// keeps it small).
    pub loose: Option<Vec<u8>>,
}

impl FrameInfo {
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = vec![self.predictor.to_byte(), self.predictor.lag, self.filter, self.relax];
        out.extend_from_slice(&self.correction_scale.to_le_bytes());
        out.extend(self.anchors.iter().flatten().flat_map(|v| v.to_le_bytes()));
        out.extend(self.seed_origin.iter().flatten().flat_map(|v| v.to_le_bytes()));
        out
    }

    /// The side data of frame `frame` of a version-`version` file whose
    /// header is `header`.
    fn parse(
        payload: &[u8],
        header: &Header,
        version: u16,
        frame: u32,
        offset: usize,
    ) -> Result<FrameInfo, ContainerError> {
        let bad = |msg: String| ContainerError::Chunk { offset, msg };
        let anchors = header.anchors.len();
        if payload.len() != header.side_data_len(frame) {
            return Err(bad(format!(
                "frame {frame}'s side data has {} bytes, expected {}",
                payload.len(),
                header.side_data_len(frame)
            )));
        }
        // A cycle prediction names a lag the header allows and the frames
        // since the last random-access point can serve.
        let since = frame - header.random_access_point(frame);
        let predictor = PredictorCode::from_bytes(payload[0], payload[1])
            .filter(|c| c.lag == 0 || (c.lag <= header.max_lag && u32::from(c.lag) < since));
        let filter = payload[2];
        let filter_ok = filter == 0 || (version >= 5 && filter <= MAX_FILTER);
        let relax = payload[3];
        let relax_ok = relax == 0 || (version >= 9 && relax <= MAX_RELAX);
        let (Some(predictor), true, true) = (predictor, filter_ok, relax_ok) else {
            return Err(bad(format!(
                "unknown predictor {:?} at frame {frame} (lags up to {} allowed; filters up to {} from version 5, \
                 relaxation up to {} from version 9, this file is version {version})",
                &payload[..4],
                header.max_lag,
                MAX_FILTER,
                MAX_RELAX
            )));
        };
        let f32_at = |o: usize| f32::from_le_bytes([payload[o], payload[o + 1], payload[o + 2], payload[o + 3]]);
        let correction_scale = f32_at(4);
        if !(correction_scale.is_finite() && correction_scale >= 0.0) {
            return Err(bad(format!("correction scale {correction_scale} is not a finite non-negative number")));
        }
        let anchors: Vec<[f32; 3]> = (0..anchors).map(|k| [0, 4, 8].map(|o| f32_at(8 + 12 * k + o))).collect();
        let at = 8 + 12 * anchors.len();
        let seed_origin = (payload.len() > at).then(|| [0, 4, 8].map(|o| f32_at(at + o)));
        if anchors.iter().chain(&seed_origin).flatten().any(|v| !v.is_finite()) {
            return Err(bad("non-finite anchor position or seed origin".into()));
        }
        Ok(FrameInfo { predictor, filter, relax, correction_scale, anchors, seed_origin, loose: None })
    }
}

/// Most times a stream's grid may be halved (version 9).
pub const MAX_SHRINK: u8 = 3;

/// Most passes of tangential relaxation a frame may ask for (version 9).
pub const MAX_RELAX: u8 = 4;

/// Most averaging passes a frame's correction filter may ask for.
pub const MAX_FILTER: u8 = 8;

/// The frames a stream is coded at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Coverage {
    /// Every frame.
    All,
    /// The key frames.
    Key,
    /// Frame 0, and (version 10) every random-access point.
    First,
}

impl Coverage {
    /// Whether a stream of this coverage has a frame that is or is not a
    /// key frame (`key`) and a random-access point (`rap`; frame 0 always
    /// is). The one rule the encoder and the reader share.
    pub fn has(self, key: bool, rap: bool) -> bool {
        match self {
            Coverage::All => true,
            Coverage::Key => key,
            Coverage::First => rap,
        }
    }
}

/// Encoder settings, recorded for information.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    pub qp: u8,
    #[serde(default)]
    pub kbps: Option<f32>,
    pub gop: u32,
    pub cabac: bool,
    pub layers: u8,
    /// Layer-2 range in layer-1 steps (0 when there is no second layer).
    #[serde(default)]
    pub residual_steps: f32,
}

/// About the input the file was made from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct SourceInfo {
    pub label: String,
    pub vertices: u32,
    pub faces: u32,
    /// Bounding-box diagonal of the first input frame.
    pub diagonal: f32,
}

/// The header of a `.cgv` file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Grid size N: frames are N x N samples.
    pub grid: u32,
    /// The seam rule of the grid (see `src/grid.rs`).
    pub seam: String,
    pub frames: u32,
    pub fps: f32,
    pub codec: CodecKind,
    pub streams: Vec<StreamInfo>,
    /// Frames at which the key-frame streams are coded (always includes 0).
    pub key_frames: Vec<u32>,
    /// Grid samples whose positions are stored (float32) in every frame.
    pub anchors: Vec<u32>,
    /// The decoder the encoder intended (`cgv` or `paper`).
    pub solver: SolverKind,
    pub settings: Settings,
    #[serde(default)]
    pub source: SourceInfo,
    /// Version 2: how the correction streams apply (absent: scaled).
    #[serde(default, skip_serializing_if = "is_scaled")]
    pub corrections: CorrectionMode,
    /// Version 4: the longest lag of a cycle prediction in this file (0,
    /// or absent: none). A decoder keeps this many past smoothed velocities.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub max_lag: u8,
    /// Version 6: the input's mesh is in the `SMSH` chunk (absent: it is not).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source_mesh: Option<SourceMeshInfo>,
    /// Version 8: the source mesh's texture coordinates and base colour
    /// are in the `APPR` chunk (absent: they are not).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub appearance: Option<AppearanceInfo>,
    /// Version 10: a random-access point every this many frames (frames
    /// 0, K, 2K, ...; absent: frame 0 only). At each, every stream's picture
    /// is an IDR picture, the `first` streams (the seed) have a picture, the
    /// decoder's state starts afresh as at frame 0, and the file ends with an
    /// `RIDX` chunk of their offsets.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub random_access: Option<u32>,
}

fn is_scaled(m: &CorrectionMode) -> bool {
    *m == CorrectionMode::Scaled
}

fn is_zero(v: &u8) -> bool {
    *v == 0
}

/// The seam rule written by this version.
pub const SEAM_RULE: &str = "octahedral-half-turn";

impl Header {
    /// Checks the header's own consistency and limits.
    pub fn validate(&self) -> Result<(), ContainerError> {
        let bad = |m: String| Err(ContainerError::Header(m));
        check_grid_size(self.grid.into()).map_err(ContainerError::Header)?;
        if self.seam != SEAM_RULE {
            return bad(format!("unknown seam rule '{}'", self.seam));
        }
        if self.frames == 0 || self.frames > MAX_FRAMES {
            return bad(format!("frame count {} is not in 1..={MAX_FRAMES}", self.frames));
        }
        if !(self.fps.is_finite() && self.fps > 0.0 && self.fps <= 1000.0) {
            return bad(format!("frame rate {} is not in (0, 1000]", self.fps));
        }
        if self.streams.is_empty() || self.streams.len() > MAX_STREAMS {
            return bad(format!("{} streams (1..={MAX_STREAMS} allowed)", self.streams.len()));
        }
        for (i, s) in self.streams.iter().enumerate() {
            if !s.quant.is_valid() {
                return bad(format!("stream {i} has an invalid range"));
            }
            let side = s.size(self.grid);
            let shrinkable = s.name.axis().is_some() && s.name.is_correction() && self.stream(StreamName::Dn).is_some();
            if s.shrink > 0 && !(shrinkable && side >= MIN_GRID && side % 2 == 0 && s.shrink <= MAX_SHRINK) {
                return bad(format!(
                    "stream {i} ({}) is shrunk {} times to {side} samples a side: only dx, dy, dz beside dn \
                     may be, at most {MAX_SHRINK} times, to an even size of at least {MIN_GRID}",
                    s.name, s.shrink
                ));
            }
            match (s.layer, s.refines) {
                (1, None) => {}
                (2, Some(r))
                    if (r as usize) < i
                        && self.streams[r as usize].layer == 1
                        && self.streams[r as usize].shrink == 0 => {}
                _ => return bad(format!("stream {i} has an invalid layer {} / refines {:?}", s.layer, s.refines)),
            }
        }
        if self.key_frames.first() != Some(&0)
            || self.key_frames.windows(2).any(|w| w[1] <= w[0])
            || self.key_frames.last().is_some_and(|&k| k >= self.frames)
        {
            return bad("key frames must start at 0, increase, and lie inside the sequence".into());
        }
        let samples = self.grid * self.grid;
        if self.anchors.len() > MAX_ANCHORS || self.anchors.iter().any(|&a| a >= samples) {
            return bad(format!("anchors must be at most {MAX_ANCHORS} grid samples below {samples}"));
        }
        // The paper's solver needs anchors; the closed loop (correction
        // streams) does not.
        let closed_loop = self.is_closed_loop();
        let world: Vec<u8> =
            stream::CORRECTION.iter().filter_map(|&n| self.stream(n)).map(|s| self.streams[s].shrink).collect();
        let normal = self.stream(StreamName::Dn).is_some();
        if !(world.is_empty() && !normal || world.len() == 3 && world.windows(2).all(|w| w[0] == w[1])) {
            return bad("correction streams are dx, dy, dz (all three the same size), with or without dn".into());
        }
        if self.corrections == CorrectionMode::Motion {
            let ok = self.codec == CodecKind::Cgv
                && self.correction_streams().is_some()
                && self.streams.iter().all(|s| !s.scaled);
            if !ok {
                return bad("motion corrections need a CGV file with unscaled correction streams".into());
            }
        }
        if self.codec == CodecKind::Cgv
            && (self.stream(StreamName::H).is_none() || self.stream(StreamName::Lambda).is_none())
            && self.corrections != CorrectionMode::Motion
        {
            return bad("only a motion-corrected CGV file may leave out the H and lambda streams".into());
        }
        if self.max_lag > 0 && !closed_loop {
            return bad("cycle predictions (max_lag) need correction streams".into());
        }
        if self.codec == CodecKind::Cgv && self.anchors.len() < 4 && !closed_loop {
            return bad("a CGV file without correction streams needs at least 4 anchors".into());
        }
        if let Some(m) = &self.source_mesh {
            m.validate().map_err(ContainerError::Header)?;
        }
        if let Some(a) = &self.appearance {
            if self.source_mesh.is_none() {
                return bad("an appearance needs a source mesh".into());
            }
            a.validate().map_err(ContainerError::Header)?;
        }
        self.validate_random_access()
    }

    /// Random-access points: an interval of at least 1 frame, and each
    /// point a key frame (the key-frame streams restart there too).
    fn validate_random_access(&self) -> Result<(), ContainerError> {
        let Some(k) = self.random_access else { return Ok(()) };
        if k == 0 || k > MAX_FRAMES {
            return Err(ContainerError::Header(format!("random_access {k} is not in 1..={MAX_FRAMES}")));
        }
        if let Some(r) = (0..self.frames).step_by(k as usize).find(|&r| !self.is_key_frame(r)) {
            return Err(ContainerError::Header(format!("random-access point {r} is not a key frame")));
        }
        Ok(())
    }

    /// The oldest format version that can hold this header: 12 for a
    /// source mesh coded as a walk, 11 for loose
    /// vertices, 10 for random-access points, 9 for a normal
    /// correction or a shrunk stream, 8 for an
    /// appearance, 7 for the
    /// source mesh's vertex offsets, 6 for the source mesh, 4 for cycle
    /// predictions, 3 for a CGV file without H, 2 for motion corrections,
    /// else 1.
    pub fn min_version(&self) -> u16 {
        if self.source_mesh.is_some_and(|m| m.walk) {
            12
        } else if self.loose_vertices().is_some() {
            11
        } else if self.random_access.is_some() {
            10
        } else if self.stream(StreamName::Dn).is_some() || self.streams.iter().any(|s| s.shrink > 0) {
            9
        } else if self.appearance.is_some() {
            8
        } else if self.source_mesh.is_some_and(|m| m.offset_step.is_some()) {
            7
        } else if self.source_mesh.is_some() {
            6
        } else if self.max_lag > 0 {
            4
        } else if self.codec == CodecKind::Cgv && self.stream(StreamName::H).is_none() {
            3
        } else if self.corrections == CorrectionMode::Motion {
            2
        } else {
            1
        }
    }

    /// Whether the file codes corrections to the predictive decoder's
    /// prediction (the closed loop), so the encoder knows the decoded grid.
    pub fn is_closed_loop(&self) -> bool {
        self.streams.iter().any(|s| s.scaled) || self.corrections == CorrectionMode::Motion
    }

    /// Version 11: whether loose vertices follow the decoded grid (see
    /// `crate::codec::loose`): in files whose decoded grid the encoder
    /// knows, GV and the closed loop; not with the paper's solver alone.
    pub fn loose_follow_grid(&self) -> bool {
        self.codec == CodecKind::Gv || self.is_closed_loop()
    }

    /// Version 11: how many loose vertices each frame carries, if any.
    pub fn loose_vertices(&self) -> Option<u32> {
        self.source_mesh.and_then(|m| m.loose)
    }

    pub fn is_key_frame(&self, f: u32) -> bool {
        self.key_frames.binary_search(&f).is_ok()
    }

    /// The length of frame `f`'s side data: 8 bytes, 12 an anchor, and in a
    /// file with random-access points and a seed, 12 more at each point
    /// (the seed origin).
    pub fn side_data_len(&self, f: u32) -> usize {
        8 + 12 * self.anchors.len() + if self.has_seed_origin(f) { 12 } else { 0 }
    }

    /// Whether frame `f`'s side data ends with a seed origin: at the
    /// random-access points of a version-10 file that has them and a seed.
    pub fn has_seed_origin(&self, f: u32) -> bool {
        self.random_access.is_some() && self.is_random_access_point(f) && self.stream(StreamName::SeedX).is_some()
    }

    /// Whether frame `f` is a random-access point (frame 0 always is).
    pub fn is_random_access_point(&self, f: u32) -> bool {
        f == 0 || self.random_access.is_some_and(|k| f % k == 0)
    }

    /// The last random-access point at or before frame `f`: where a decoder
    /// that wants frame `f` starts.
    pub fn random_access_point(&self, f: u32) -> u32 {
        random_access_point(self.random_access, f)
    }

    /// The random-access points' count (the `RIDX` chunk's entries).
    pub fn random_access_points(&self) -> u32 {
        self.random_access.map_or(1, |k| self.frames.div_ceil(k))
    }

    /// Whether stream `s` has an access unit at frame `f`.
    pub fn stream_has_frame(&self, s: usize, f: u32) -> bool {
        self.streams[s].coverage.has(self.is_key_frame(f), self.is_random_access_point(f))
    }

    /// The stream named `name` in layer 1, if present.
    pub fn stream(&self, name: StreamName) -> Option<usize> {
        self.streams.iter().position(|s| s.layer == 1 && s.name == name)
    }

    /// What the file stores (see [`Representation`]).
    pub fn representation(&self) -> Representation {
        match (self.codec, self.correction_streams()) {
            (CodecKind::Gv, _) => Representation::Gv,
            (CodecKind::Cgv, None) => Representation::Conformal,
            (CodecKind::Cgv, Some(_)) if self.stream(StreamName::Dn).is_some() => Representation::Normal,
            (CodecKind::Cgv, Some(_)) => Representation::Predictive,
        }
    }

    /// The names of the file's correction streams: `dx`, `dy`, `dz`, and
    /// from version 9 `dn` after them if the file has it; `None` without
    /// corrections.
    pub fn correction_streams(&self) -> Option<Vec<StreamName>> {
        self.stream(StreamName::Dx)?;
        let mut names = stream::CORRECTION.to_vec();
        names.extend(self.stream(StreamName::Dn).map(|_| StreamName::Dn));
        Some(names)
    }

    /// The layer-2 stream refining stream `base`, if any.
    pub fn refinement(&self, base: usize) -> Option<usize> {
        self.streams.iter().position(|s| s.layer == 2 && s.refines == Some(base as u16))
    }

    /// The number of chunks a complete version-1 file has before its END
    /// chunk (versions 2 and 3: one per frame).
    pub fn expected_chunks(&self) -> u64 {
        let mut n = 0u64;
        for f in 0..self.frames {
            n += 1 + (0..self.streams.len()).filter(|&s| self.stream_has_frame(s, f)).count() as u64;
        }
        n
    }
}

/// The last random-access point at or before frame `f` with a point every
/// `interval` frames (none but frame 0 without one): the one rule the
/// encoder's plan and [`Header::random_access_point`] share.
pub fn random_access_point(interval: Option<u32>, f: u32) -> u32 {
    interval.map_or(0, |k| f - f % k)
}

/// Writes the file prefix (magic, version [`VERSION`], header, CRC); the
/// frames follow as [`write_frame`] chunks, then an END chunk.
pub fn write_header(header: &Header) -> Result<Vec<u8>, ContainerError> {
    header.validate()?;
    let json = serde_json::to_vec(header).map_err(|e| ContainerError::Header(e.to_string()))?;
    if json.len() > MAX_HEADER {
        return Err(ContainerError::TooLarge { what: "header", value: json.len() as u64, limit: MAX_HEADER as u64 });
    }
    let mut out = Vec::with_capacity(json.len() + 24);
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(&json);
    let crc = crc32fast::hash(&out[8..]);
    out.extend_from_slice(&crc.to_le_bytes());
    Ok(out)
}

/// Version 6: the chunk carrying the input's mesh, written right after the header.
pub fn write_source_mesh(mesh: &SourceMesh) -> Vec<u8> {
    write_chunk(TAG_SOURCE_MESH, 0, 0, &mesh.to_bytes())
}

/// Version 8: the chunk of the source mesh's appearance, right after it.
pub fn write_appearance(look: &Appearance) -> Vec<u8> {
    write_chunk(TAG_APPEARANCE, 0, 0, &look.to_bytes())
}

/// Encodes one chunk.
pub fn write_chunk(tag: [u8; 4], stream: u16, frame: u32, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(payload.len() + 20);
    out.extend_from_slice(&tag);
    out.extend_from_slice(&stream.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes());
    out.extend_from_slice(&frame.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    out.extend_from_slice(payload);
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// Version 10: the index of the random-access points, the byte offset of
/// each one's frame chunk from the start of the file (u64 LE each, in frame
/// order), written right before the end chunk.
pub fn write_index(offsets: &[u64]) -> Vec<u8> {
    let payload: Vec<u8> = offsets.iter().flat_map(|o| o.to_le_bytes()).collect();
    write_chunk(TAG_INDEX, 0, 0, &payload)
}

/// The size of a version-10 file's tail, its `RIDX` and `CEND` chunks: what
/// a reader that has the header fetches from the end to learn where each
/// random-access point starts.
pub fn index_tail_bytes(header: &Header) -> u64 {
    let index = if header.random_access.is_some() { 20 + 8 * u64::from(header.random_access_points()) } else { 0 };
    index + 20
}

/// The offsets in an `RIDX` chunk at the end of `tail` (the last
/// [`index_tail_bytes`] bytes of a file with this header), checked.
pub fn parse_index_tail(header: &Header, tail: &[u8]) -> Result<Vec<u64>, ContainerError> {
    let want = index_tail_bytes(header) as usize;
    let bad = |msg: String| ContainerError::Chunk { offset: 0, msg };
    if header.random_access.is_none() || tail.len() < want {
        return Err(bad(format!("the file's tail has {} bytes, not the {want} of an index and end chunk", tail.len())));
    }
    let tail = &tail[tail.len() - want..];
    let (chunk, _) = parse_chunk(tail, 0)?.ok_or_else(|| bad("a truncated index chunk".into()))?;
    if chunk.tag != TAG_INDEX {
        return Err(bad("no random-access index before the end chunk".into()));
    }
    let offsets: Vec<u64> = chunk.payload.chunks_exact(8).map(|b| u64_at(b, 0)).collect();
    if offsets.len() as u32 != header.random_access_points() || offsets.windows(2).any(|w| w[1] <= w[0]) {
        return Err(bad(format!(
            "an index of {} offsets, not {} increasing ones",
            offsets.len(),
            header.random_access_points()
        )));
    }
    Ok(offsets)
}

/// A version-2 frame chunk: the frame's side data, then each access unit
/// the frame has (streams in header order) after its LEB128 length, and
/// from version 11 the loose vertices' unit the same way.
pub fn write_frame(frame: u32, info: &FrameInfo, units: &[&[u8]]) -> Vec<u8> {
    let mut payload = info.to_bytes();
    for au in units.iter().copied().chain(info.loose.as_deref()) {
        leb128::write(&mut payload, au.len() as u64);
        payload.extend_from_slice(au);
    }
    write_chunk(TAG_FRAME, 0, frame, &payload)
}

/// Reads a LEB128 length of at most 4 bytes at `b[*at..]`, advancing `at`.
fn read_len(b: &[u8], at: &mut usize) -> Option<usize> {
    leb128::read(b, at, 4).map(|n| n as usize)
}

fn u16_at(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}
fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}
fn u64_at(b: &[u8], o: usize) -> u64 {
    u64::from(u32_at(b, o)) | u64::from(u32_at(b, o + 4)) << 32
}

/// Parses the file prefix from the start of `bytes`. Returns `Ok(None)` when
/// more bytes are needed (streaming), else the header and its length in bytes.
pub fn parse_header(bytes: &[u8]) -> Result<Option<(Header, usize)>, ContainerError> {
    let have = bytes.len().min(8);
    if bytes[..have] != MAGIC[..have] {
        return Err(ContainerError::BadMagic);
    }
    if bytes.len() < 16 {
        return Ok(None);
    }
    let version = u16_at(bytes, 8);
    if version == 0 || version > VERSION {
        return Err(ContainerError::UnsupportedVersion { found: version });
    }
    let len = u32_at(bytes, 12) as usize;
    if len > MAX_HEADER {
        return Err(ContainerError::TooLarge { what: "header length", value: len as u64, limit: MAX_HEADER as u64 });
    }
    let end = 16 + len + 4;
    if bytes.len() < end {
        return Ok(None);
    }
    if crc32fast::hash(&bytes[8..16 + len]) != u32_at(bytes, 16 + len) {
        return Err(ContainerError::BadCrc { offset: 8, what: "the header" });
    }
    let header: Header =
        serde_json::from_slice(&bytes[16..16 + len]).map_err(|e| ContainerError::Header(e.to_string()))?;
    header.validate()?;
    if header.min_version() > version {
        return Err(ContainerError::Header(format!(
            "a version {version} file cannot hold what version {} added (corrections: {:?}, max_lag: {}, source mesh: {}, \
             streams: {})",
            header.min_version(),
            header.corrections,
            header.max_lag,
            header.source_mesh.is_some(),
            header.streams.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(" ")
        )));
    }
    Ok(Some((header, end)))
}

/// One chunk, borrowed from the file's bytes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chunk<'a> {
    pub tag: [u8; 4],
    pub stream: u16,
    pub frame: u32,
    pub payload: &'a [u8],
}

/// Parses the chunk at `bytes[offset..]`. `Ok(None)` means more bytes are
/// needed; otherwise returns the chunk and the offset after it.
pub fn parse_chunk(bytes: &[u8], offset: usize) -> Result<Option<(Chunk<'_>, usize)>, ContainerError> {
    let b = &bytes[offset.min(bytes.len())..];
    if b.len() < 16 {
        return Ok(None);
    }
    let len = u32_at(b, 12) as usize;
    if len > MAX_CHUNK {
        return Err(ContainerError::TooLarge { what: "chunk length", value: len as u64, limit: MAX_CHUNK as u64 });
    }
    if b.len() < 16 + len + 4 {
        return Ok(None);
    }
    if crc32fast::hash(&b[..16 + len]) != u32_at(b, 16 + len) {
        return Err(ContainerError::BadCrc { offset, what: "a chunk" });
    }
    let tag = [b[0], b[1], b[2], b[3]];
    if ![TAG_ACCESS_UNIT, TAG_FRAME, TAG_END, TAG_SOURCE_MESH, TAG_APPEARANCE, TAG_INDEX].contains(&tag) {
        return Err(ContainerError::Chunk {
            offset,
            msg: format!("unknown chunk tag {:?}", String::from_utf8_lossy(&tag)),
        });
    }
    let chunk = Chunk { tag, stream: u16_at(b, 4), frame: u32_at(b, 8), payload: &b[16..16 + len] };
    Ok(Some((chunk, offset + 16 + len + 4)))
}

/// A whole `.cgv` file in memory, checked: every chunk is where the header
/// says it must be, with nothing missing or extra.
#[derive(Debug, Clone)]
pub struct CgvFile {
    /// The format version the file declares.
    pub version: u16,
    pub header: Header,
    /// Access units per stream per frame (empty where the stream has no frame).
    pub units: Vec<Vec<Vec<u8>>>,
    /// Side data per frame (the default for a frame a reader that
    /// jumped has not been given).
    pub frames: Vec<FrameInfo>,
    /// Version 6: the input's mesh, when the file carries it.
    pub source_mesh: Option<SourceMesh>,
    /// Version 8: how it looks, when the file says.
    pub appearance: Option<Appearance>,
    /// The byte offset of each random-access point's first chunk, as read
    /// (frame 0's alone before version 10); a version-10 file's `RIDX`
    /// chunk was checked against them.
    pub index: Vec<u64>,
    /// Size of the file in bytes.
    pub bytes: usize,
}

impl CgvFile {
    /// Bytes of H.264 per stream, in the header's order.
    pub fn stream_bytes(&self) -> Vec<usize> {
        self.units.iter().map(|u| u.iter().map(Vec::len).sum()).collect()
    }

    /// What `cgv info --json` says of the file (and the Python package's
    /// `info`): version, size, header, bytes per stream, and each frame's
    /// side data.
    pub fn summary(&self) -> serde_json::Value {
        let h = &self.header;
        let seconds = h.frames as f64 / h.fps as f64;
        let stream_bytes = self.stream_bytes();
        let f = &self.frames;
        serde_json::json!({
            "version": self.version, "bytes": self.bytes, "kbps": self.bytes as f64 * 8.0 / 1000.0 / seconds,
            "codec": h.representation(), "header": h, "stream_bytes": stream_bytes,
            "predictors": f.iter().map(|f| f.predictor.to_byte()).collect::<Vec<_>>(),
            "lags": f.iter().map(|f| f.predictor.lag).collect::<Vec<_>>(),
            "filters": f.iter().map(|f| f.filter).collect::<Vec<_>>(),
            "relax": f.iter().map(|f| f.relax).collect::<Vec<_>>(),
            "correction_scales": f.iter().map(|f| f.correction_scale).collect::<Vec<_>>(),
        })
    }
}

/// Reads and checks a complete `.cgv` file.
pub fn read(bytes: &[u8]) -> Result<CgvFile, ContainerError> {
    let mut r = StreamReader::default();
    r.push(bytes)?;
    r.finish()
}

/// Reads a `.cgv` file as its bytes arrive (a browser's fetch stream): each
/// [`push`](StreamReader::push) checks every chunk now complete, so frame
/// f can be decoded as soon as [`frame_arrived`](StreamReader::frame_arrived)
/// says so. The same checks as [`read`], which is built on it.
///
/// A version-10 file may also arrive in pieces (HTTP range requests): once
/// the reader has the header, the source mesh and the random-access index
/// ([`set_index`](StreamReader::set_index), from the file's tail), it can
/// [`jump`](StreamReader::jump) to any random-access point and take the
/// bytes from that point's offset on, with the same checks.
#[derive(Debug, Clone, Default)]
pub struct StreamReader {
    /// Bytes not yet consumed (a partial header or chunk).
    pending: Vec<u8>,
    /// Bytes consumed so far (for error offsets).
    consumed: usize,
    file: Option<CgvFile>,
    /// The next chunk expected: frame `frame`, slot 0 its FRAM chunk, slot 1 + s stream s.
    frame: u32,
    slot: usize,
    /// Version 10: the `RIDX` chunk has been read.
    indexed: bool,
    /// Version 10: the index came from [`set_index`](Self::set_index), and
    /// each point's chunk is checked against it as it arrives.
    index_given: bool,
    /// The reader is past the end chunk.
    ended: bool,
    /// The end chunk has been read (after a jump, `ended` starts over).
    end_seen: bool,
    /// Which frames have arrived whole, and how many from 0 in a row.
    arrived: Vec<bool>,
    contiguous: u32,
}

impl StreamReader {
    /// The header, once it has arrived.
    pub fn header(&self) -> Option<&Header> {
        self.file.as_ref().map(|f| &f.header)
    }

    /// The file so far: every frame for which
    /// [`frame_arrived`](Self::frame_arrived) is true is whole.
    pub fn file(&self) -> Option<&CgvFile> {
        self.file.as_ref()
    }

    /// Frames from 0 on whose chunks have all arrived, in a row.
    pub fn complete_frames(&self) -> u32 {
        self.contiguous
    }

    /// Whether frame `f`'s chunks have all arrived.
    pub fn frame_arrived(&self, f: u32) -> bool {
        self.arrived.get(f as usize).copied().unwrap_or(false)
    }

    /// Every frame and the end chunk have arrived.
    pub fn is_complete(&self) -> bool {
        self.end_seen && self.file.as_ref().is_some_and(|f| self.contiguous == f.header.frames)
    }

    /// Version 10: the random-access points' offsets, read from the file's
    /// tail ([`parse_index_tail`]) before the frames have arrived; the
    /// points already read must agree, and each later one is checked
    /// against it. Needed before a [`jump`](Self::jump).
    pub fn set_index(&mut self, offsets: Vec<u64>) -> Result<(), ContainerError> {
        let bad = |msg: &str| ContainerError::Chunk { offset: 0, msg: msg.into() };
        let file = self.file.as_mut().ok_or_else(|| bad("an index before the header"))?;
        if offsets.len() as u64 != u64::from(file.header.random_access_points()) || file.header.random_access.is_none()
        {
            return Err(bad("the index does not have one offset per random-access point"));
        }
        if !offsets.starts_with(&file.index) {
            return Err(bad("the index disagrees with the random-access points already read"));
        }
        file.index = offsets;
        self.index_given = true;
        Ok(())
    }

    /// Makes random-access point `point` (frame `point` K) the next thing
    /// the reader expects, at its offset: the bytes pushed next are the
    /// file's from there. What arrived before stays.
    pub fn jump(&mut self, point: u32) -> Result<(), ContainerError> {
        let at = self.bytes();
        let bad = |msg: String| ContainerError::Chunk { offset: at, msg };
        let file = self.file.as_ref().ok_or_else(|| bad("a jump before the header".into()))?;
        let h = &file.header;
        let waiting = (h.source_mesh.is_some() && file.source_mesh.is_none())
            || (h.appearance.is_some() && file.appearance.is_none());
        if !self.index_given || waiting {
            return Err(bad("a jump needs the header, the source mesh and the index first".into()));
        }
        let offset = *file.index.get(point as usize).ok_or_else(|| bad(format!("no random-access point {point}")))?;
        // An index was given, so the header has an interval.
        let interval = h.random_access.ok_or_else(|| bad("a jump in a file without random-access points".into()))?;
        self.frame = point * interval;
        (self.slot, self.indexed, self.ended) = (0, false, false);
        self.pending.clear();
        self.consumed = usize::try_from(offset).map_err(|_| bad("an offset past memory".into()))?;
        Ok(())
    }

    /// Records frame `f` as whole.
    fn mark_arrived(&mut self, f: u32) {
        let n = self.file.as_ref().map_or(0, |file| file.header.frames);
        if self.arrived.len() <= f as usize {
            self.arrived.resize(f as usize + 1, false);
        }
        self.arrived[f as usize] = true;
        while self.contiguous < n && self.frame_arrived(self.contiguous) {
            self.contiguous += 1;
        }
    }

    /// Bytes received so far.
    pub fn bytes(&self) -> usize {
        self.consumed + self.pending.len()
    }

    /// Adds bytes and checks every chunk they complete.
    pub fn push(&mut self, bytes: &[u8]) -> Result<(), ContainerError> {
        if self.ended && !bytes.is_empty() {
            return Err(ContainerError::Chunk { offset: self.bytes(), msg: "bytes after the end chunk".into() });
        }
        self.pending.extend_from_slice(bytes);
        let mut at = 0;
        if self.file.is_none() {
            match parse_header(&self.pending)? {
                None => return Ok(()),
                Some((header, len)) => {
                    let n = header.streams.len();
                    // Allocate per frame only as chunks arrive: a header cannot
                    // make us reserve memory the file does not back.
                    let version = u16_at(&self.pending, 8);
                    self.file = Some(CgvFile {
                        version,
                        header,
                        units: vec![Vec::new(); n],
                        frames: Vec::new(),
                        source_mesh: None,
                        appearance: None,
                        index: Vec::new(),
                        bytes: 0,
                    });
                    at = len;
                }
            }
        }
        // The chunks borrow the pending bytes while `accept` files them.
        let pending = std::mem::take(&mut self.pending);
        let end = self.accept_all(&pending, at);
        self.pending = pending;
        let at = end?;
        self.pending.drain(..at);
        self.consumed += at;
        Ok(())
    }

    /// Accepts every whole chunk of `pending` from `at` on; returns where
    /// the first incomplete one starts.
    fn accept_all(&mut self, pending: &[u8], mut at: usize) -> Result<usize, ContainerError> {
        loop {
            let offset = self.consumed + at;
            let Some((chunk, next)) = parse_chunk(pending, at).map_err(|e| shift(e, self.consumed))? else {
                return Ok(at);
            };
            let before = self.frame;
            self.accept(chunk, offset)?;
            if self.frame > before && before < self.file.as_ref().map_or(0, |f| f.header.frames) {
                self.mark_arrived(before);
            }
            at = next;
            if self.ended {
                if at != pending.len() {
                    return Err(ContainerError::Chunk {
                        offset: self.consumed + at,
                        msg: "bytes after the end chunk".into(),
                    });
                }
                return Ok(at);
            }
        }
    }

    fn accept(&mut self, chunk: Chunk<'_>, offset: usize) -> Result<(), ContainerError> {
        let Some(file) = self.file.as_mut() else {
            return Err(ContainerError::Chunk { offset, msg: "a chunk before the header".into() });
        };
        if let (Some(info), None, 0, 0) = (file.header.source_mesh, &file.source_mesh, self.frame, self.slot) {
            // Version 6: the source mesh comes first.
            if chunk.tag != TAG_SOURCE_MESH || chunk.frame != 0 {
                return Err(unexpected(&chunk, offset, "the source mesh", 0));
            }
            file.source_mesh = Some(SourceMesh::parse(chunk.payload, &info, offset)?);
            return Ok(());
        }
        if let (Some(look), Some(info), None, 0, 0) =
            (&file.header.appearance, file.header.source_mesh, &file.appearance, self.frame, self.slot)
        {
            // Version 8: the appearance comes right after the source mesh.
            if chunk.tag != TAG_APPEARANCE || chunk.frame != 0 {
                return Err(unexpected(&chunk, offset, "the appearance", 0));
            }
            file.appearance = Some(Appearance::parse(chunk.payload, look, &info, offset)?);
            return Ok(());
        }
        let header = &file.header;
        let nstreams = header.streams.len();
        if self.frame >= header.frames {
            if header.random_access.is_some() && !self.indexed {
                if chunk.tag != TAG_INDEX {
                    return Err(unexpected(&chunk, offset, "the random-access index", header.frames));
                }
                check_index(chunk.payload, &file.index, offset)?;
                self.indexed = true;
                return Ok(());
            }
            if chunk.tag != TAG_END {
                return Err(ContainerError::Chunk { offset, msg: "chunk after the last frame".into() });
            }
            (self.ended, self.end_seen) = (true, true);
            return Ok(());
        }
        let frame = self.frame;
        if self.slot == 0 && chunk.tag == TAG_FRAME && chunk.frame == frame && header.is_random_access_point(frame) {
            let point = header.random_access.map_or(0, |k| frame / k) as usize;
            match (self.index_given, file.index.get(point)) {
                (false, _) => file.index.push(offset as u64),
                (true, Some(&o)) if o == offset as u64 => {}
                _ => return Err(unexpected(&chunk, offset, "the random-access point the index names", frame)),
            }
        }
        let expect = |what: &str| unexpected(&chunk, offset, what, frame);
        if chunk.frame != frame {
            return Err(expect(if self.slot > 0 { "stream data" } else { "the frame chunk" }));
        }
        if file.version >= 2 {
            return Self::accept_frame(file, &mut self.frame, chunk, offset);
        }
        if self.slot > 0 {
            let s = self.slot - 1;
            if chunk.tag != TAG_ACCESS_UNIT || chunk.stream as usize != s {
                return Err(expect(&format!("stream {s}")));
            }
            let u = &mut file.units[s];
            u.resize(frame as usize + 1, Vec::new());
            u[frame as usize] = chunk.payload.to_vec();
        } else {
            if chunk.tag != TAG_FRAME {
                return Err(expect("the frame chunk"));
            }
            let info = FrameInfo::parse(chunk.payload, header, file.version, frame, offset)?;
            file.frames.push(info);
        }
        // Advance to the next expected chunk.
        let header = &file.header;
        loop {
            self.slot += 1;
            if self.slot > nstreams {
                self.slot = 0;
                self.frame += 1;
            }
            if self.frame >= header.frames || self.slot == 0 || header.stream_has_frame(self.slot - 1, self.frame) {
                break;
            }
        }
        if self.frame >= header.frames {
            for u in &mut file.units {
                u.resize(header.frames as usize, Vec::new());
            }
        }
        Ok(())
    }

    /// Version 2 on: one chunk per frame, its side data, then each access
    /// unit after its length.
    fn accept_frame(file: &mut CgvFile, next: &mut u32, chunk: Chunk<'_>, offset: usize) -> Result<(), ContainerError> {
        let (header, frame) = (&file.header, *next);
        let nstreams = header.streams.len();
        // One chunk: side data, then each access unit after its length.
        if chunk.tag != TAG_FRAME {
            return Err(unexpected(&chunk, offset, "the frame chunk", frame));
        }
        let side = header.side_data_len(frame);
        let p = chunk.payload;
        if p.len() < side {
            return Err(ContainerError::Chunk {
                offset,
                msg: format!("frame chunk has {} bytes, fewer than its {side} bytes of side data", p.len()),
            });
        }
        let info = FrameInfo::parse(&p[..side], header, file.version, frame, offset)?;
        let mut at = side;
        let mut units = Vec::new();
        for s in (0..nstreams).filter(|&s| header.stream_has_frame(s, frame)) {
            let bad = |msg: String| ContainerError::Chunk { offset, msg };
            let len = read_len(p, &mut at).ok_or_else(|| bad(format!("stream {s}: bad access unit length")))?;
            if len > p.len() - at {
                return Err(bad(format!("stream {s}: access unit of {len} bytes overruns its frame chunk")));
            }
            units.push((s, p[at..at + len].to_vec()));
            at += len;
        }
        let mut info = info;
        if let Some(count) = header.loose_vertices() {
            let bad = |msg: String| ContainerError::Chunk { offset, msg };
            let len = read_len(p, &mut at).ok_or_else(|| bad("loose vertices: bad unit length".into()))?;
            if len > p.len() - at {
                return Err(bad(format!("loose vertices: a unit of {len} bytes overruns its frame chunk")));
            }
            LooseFrame::parse(&p[at..at + len], count, offset)?;
            info.loose = Some(p[at..at + len].to_vec());
            at += len;
        }
        if at != p.len() {
            return Err(ContainerError::Chunk {
                offset,
                msg: format!("frame chunk has {} bytes after its last access unit", p.len() - at),
            });
        }
        let total = header.frames as usize;
        // In frame order, but a jump may leave frames before it missing.
        if file.frames.len() <= frame as usize {
            file.frames.resize(frame as usize + 1, FrameInfo::default());
        }
        file.frames[frame as usize] = info;
        for (s, au) in units {
            let u = &mut file.units[s];
            if u.len() <= frame as usize {
                u.resize(frame as usize + 1, Vec::new());
            }
            u[frame as usize] = au;
        }
        *next += 1;
        if *next as usize >= total {
            for u in &mut file.units {
                u.resize(total, Vec::new());
            }
        }
        Ok(())
    }

    /// The whole file; an error if it has not all arrived.
    pub fn finish(self) -> Result<CgvFile, ContainerError> {
        let what = if self.file.is_none() { "the header" } else { "a chunk" };
        let complete = self.is_complete();
        match (self.file, complete) {
            (Some(mut f), true) => {
                f.bytes = self.consumed;
                Ok(f)
            }
            _ => Err(ContainerError::Truncated { offset: self.consumed + self.pending.len(), what, needed: 1 }),
        }
    }
}

/// An `RIDX` payload must list exactly the offsets the reader saw.
fn check_index(payload: &[u8], seen: &[u64], offset: usize) -> Result<(), ContainerError> {
    let listed: Vec<u64> = payload.chunks_exact(8).map(|b| u64_at(b, 0)).collect();
    if payload.len() % 8 != 0 || listed != seen {
        return Err(ContainerError::Chunk {
            offset,
            msg: format!(
                "the random-access index lists {} offsets {:?}..., but the points are at {:?}...",
                payload.len() / 8,
                &listed[..listed.len().min(4)],
                &seen[..seen.len().min(4)]
            ),
        });
    }
    Ok(())
}

/// A chunk that is not the one expected next.
fn unexpected(chunk: &Chunk<'_>, offset: usize, what: &str, frame: u32) -> ContainerError {
    let tag = String::from_utf8_lossy(&chunk.tag);
    let msg = format!("expected {what} of frame {frame}, found a {tag:?} chunk for frame {}", chunk.frame);
    ContainerError::Chunk { offset, msg }
}

/// Moves an error's byte offset from the pending buffer to the file.
fn shift(e: ContainerError, by: usize) -> ContainerError {
    match e {
        ContainerError::BadCrc { offset, what } => ContainerError::BadCrc { offset: offset + by, what },
        ContainerError::Chunk { offset, msg } => ContainerError::Chunk { offset: offset + by, msg },
        ContainerError::Truncated { offset, what, needed } => {
            ContainerError::Truncated { offset: offset + by, what, needed }
        }
        other => other,
    }
}

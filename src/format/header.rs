//! The header: what a file holds (its grid, streams, key frames, the
//! decoder it was made for, the settings it was coded with), the frame
//! chunk's side data ([`FrameInfo`]), and which format version each
//! feature needs ([`Header::min_version`]). Checked by [`super::validate`].

use super::{
    stream, AppearanceInfo, ContainerError, Extrapolation, PredictorCode, Quantizer, SkinInfo, SourceMeshInfo,
    StreamName,
};
use serde::{Deserialize, Serialize};
use std::fmt;

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
    /// Bones on the source mesh's own vertices (a skinning decomposition's
    /// weights and rest pose, each frame's transforms) and what they miss
    /// as x, y, z every frame on the grid (version 17).
    Skinned,
    /// No grid and no video: the input's own vertices, coded every frame
    /// as what the parallelogram rule over the mesh (or the frame before)
    /// misses (version 20's file without streams). Neither conformal nor a
    /// geometry video: for clips of a few frames, where a video's fixed
    /// cost is most of the file.
    Vertices,
}

impl Representation {
    /// The name `cgv encode --codec` and `cgv info` use.
    pub fn name(self) -> &'static str {
        match self {
            Representation::Gv => "gv",
            Representation::Conformal => "conformal",
            Representation::Predictive => "predictive",
            Representation::Normal => "normal",
            Representation::Skinned => "skinned",
            Representation::Vertices => "vertices",
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
    /// The stream's name in reports: `dx`, or `dx/2` for its refinement layer.
    pub fn label(&self) -> String {
        format!("{}{}", self.name, if self.layer == 2 { "/2" } else { "" })
    }

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
    /// Version 13, in every frame of a file with a skin: the bones unit
    /// (empty at a random-access point, or version 21's weights there; see
    /// [`super::skin`]), as the
    /// file has it; its motions are differences that only a decoder in
    /// order can resolve (`crate::solve::skinned`).
    pub bones: Option<Vec<u8>>,
    /// Version 16, in every frame of a file with frame meshes: the frame's
    /// own mesh unit ([`super::frame_mesh`]), as the file has it (checked).
    pub mesh: Option<Vec<u8>>,
    /// Version 18, in every frame of a file with a vertex residual: its
    /// unit ([`super::vertex_residual`]), as the file has it (checked).
    pub residual: Option<Vec<u8>>,
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
    pub(super) fn parse(
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
        // A skinned one, bones the header has and one previous frame (two
        // with the velocity of what the bones missed).
        let predictor = PredictorCode::from_bytes(payload[0], payload[1])
            .filter(|c| c.lag == 0 || (c.lag <= header.max_lag && u32::from(c.lag) < since))
            .filter(|c| {
                let needs = match c.extrapolation {
                    Extrapolation::Skinned => 1,
                    e if e.is_skinned() => 2,
                    _ => 0,
                };
                needs == 0 || (header.skin.is_some() && since >= needs)
            });
        let filter = payload[2];
        let filter_ok = filter == 0 || (version >= 5 && filter <= MAX_FILTER);
        let relax = payload[3];
        let relax_ok = relax == 0 || (version >= 9 && relax <= MAX_RELAX);
        let (Some(predictor), true, true) = (predictor, filter_ok, relax_ok) else {
            return Err(bad(format!(
                "unknown predictor {:?} at frame {frame} (lags up to {} allowed; filters up to {} from version 5, \
                 relaxation up to {} from version 9, bones with a skin from version 13, this file is version \
                 {version})",
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
        Ok(FrameInfo {
            predictor,
            filter,
            relax,
            correction_scale,
            anchors,
            seed_origin,
            loose: None,
            bones: None,
            mesh: None,
            residual: None,
        })
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
    /// Version 13: bones as a predictor, their weights in the `SKIN` chunk
    /// and each frame's motions in its bones unit (absent: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skin: Option<SkinInfo>,
    /// Version 15: frames where a segment starts (a capture whose
    /// topology changes there gets a new map), sorted, each a random-access
    /// point besides the interval's (absent: none). Needs `random_access`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub segments: Vec<u32>,
    /// Version 16: every frame carries its own mesh (an unregistered
    /// capture's, [`super::frame_mesh`]) in place of one source mesh.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub frame_meshes: bool,
    /// Version 18: every frame codes what the video missed at the source
    /// mesh's vertices, on this step ([`super::vertex_residual`]; absent:
    /// nothing).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vertex_residual: Option<super::vertex_residual::VertexResidualInfo>,
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
    /// The oldest format version that can hold this header: 20 for a file
    /// without streams, a vertex residual with sparse counts or contexts,
    /// or a source mesh whose faces name neighbours, 19 for a
    /// spatially predicted vertex residual, 18 for a vertex residual, 17
    /// for bones
    /// on the source mesh's vertices, 16 for frame
    /// meshes, 15 for segments, 14 for a packed skin, 13 for a skin,
    /// 12 for a
    /// source mesh coded as a walk, 11 for loose
    /// vertices, 10 for random-access points, 9 for a normal
    /// correction or a shrunk stream, 8 for an
    /// appearance, 7 for the
    /// source mesh's vertex offsets, 6 for the source mesh, 4 for cycle
    /// predictions, 3 for a CGV file without H, 2 for motion corrections,
    /// else 1.
    pub fn min_version(&self) -> u16 {
        let around = self.source_mesh.is_some_and(|m| m.around);
        if self.skin.is_some_and(|s| s.point_weights) {
            21
        } else if around || self.vertex_residual.is_some_and(|r| r.sparse || r.contexts || r.origin.is_some()) {
            20
        } else if self.vertex_residual.is_some_and(|r| r.spatial) {
            19
        } else if self.vertex_residual.is_some() {
            18
        } else if self.skin.is_some_and(|s| s.on_vertices()) {
            17
        } else if self.frame_meshes {
            16
        } else if !self.segments.is_empty() {
            15
        } else if self.skin.is_some_and(|s| s.packed) {
            14
        } else if self.skin.is_some() {
            13
        } else if self.source_mesh.is_some_and(|m| m.walk) {
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

    /// The samples the `SKIN` chunk holds weights for: the source mesh's
    /// vertices (version 17's bones on the vertices) or the coarse grid's
    /// (0 without a skin).
    pub fn skin_samples(&self) -> usize {
        match (&self.skin, &self.source_mesh) {
            (Some(s), Some(m)) if s.on_vertices() => m.vertices as usize,
            (Some(s), _) if !s.on_vertices() => {
                crate::format::skin::coarse_side(self.grid as usize, s.shrink).map_or(0, |n| n * n)
            }
            _ => 0,
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

    /// Whether a decoder adds something at the source mesh's vertices to
    /// the grid's rebuild: the bones' skinning (version 17) or the vertex
    /// residual (18).
    pub fn adds_at_vertices(&self) -> bool {
        self.skin.is_some_and(|s| s.on_vertices()) || self.vertex_residual.is_some()
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
        f == 0 || self.random_access.is_some_and(|k| f % k == 0) || self.segments.binary_search(&f).is_ok()
    }

    /// The last random-access point at or before frame `f`: where a decoder
    /// that wants frame `f` starts.
    pub fn random_access_point(&self, f: u32) -> u32 {
        random_access_point(self.random_access, &self.segments, f)
    }

    /// The random-access points' count (the `RIDX` chunk's entries).
    pub fn random_access_points(&self) -> u32 {
        self.random_access.map_or(1, |k| self.frames.div_ceil(k)) + self.segments_off_interval(self.frames)
    }

    /// The index (in the `RIDX` chunk) of the random-access point at or
    /// before frame `f`.
    pub fn point_index(&self, f: u32) -> u32 {
        let f = self.random_access_point(f);
        self.random_access.map_or(0, |k| f.div_ceil(k)) + self.segments_off_interval(f)
    }

    /// The frame of random-access point `k` (by its index), if there is one.
    pub fn point_frame(&self, k: u32) -> Option<u32> {
        let (mut lo, mut hi) = (0, self.frames);
        // The last frame whose point has index k: point_index rises with f.
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if self.point_index(mid) <= k {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        (lo > 0 && self.point_index(lo - 1) == k).then(|| self.random_access_point(lo - 1))
    }

    /// Segment starts before frame `f` that are not on the interval.
    fn segments_off_interval(&self, f: u32) -> u32 {
        let on = |s: u32| self.random_access.is_some_and(|k| s % k == 0);
        self.segments.iter().filter(|&&s| s < f && !on(s)).count() as u32
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
            (CodecKind::Gv, _) if self.streams.is_empty() => Representation::Vertices,
            (CodecKind::Gv, _) if self.skin.is_some_and(|s| s.on_vertices()) => Representation::Skinned,
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
/// `interval` frames (none but frame 0 without one) and at each of
/// `segments` (sorted): the one rule the encoder's plan and
/// [`Header::random_access_point`] share.
pub fn random_access_point(interval: Option<u32>, segments: &[u32], f: u32) -> u32 {
    let on_interval = interval.map_or(0, |k| f - f % k);
    let segment = segments.partition_point(|&s| s <= f).checked_sub(1).map_or(0, |i| segments[i]);
    on_interval.max(segment)
}

/// Checks segment starts against a motion of `frames` frames: increasing,
/// each in 1..frames (the header's rule, which the encoder's plan asks
/// first).
pub fn check_segments(segments: &[u32], frames: u32) -> Result<(), String> {
    if segments.windows(2).any(|w| w[1] <= w[0]) || segments.iter().any(|&s| s == 0 || s >= frames) {
        return Err(format!("segments {segments:?} must be increasing frames in 1..{frames}"));
    }
    Ok(())
}

/// The decoder a file was made for (the header's `solver`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum SolverKind {
    /// The project's predictive decoder: each frame predicted from the
    /// decoded past, then corrected (`crate::solve::predictor`). Written
    /// `cgv`, as it always has been.
    #[default]
    #[serde(rename = "cgv")]
    Predictive,
    /// The paper's Eq. 1 as written (`crate::solve::paper`).
    #[serde(rename = "paper")]
    Paper,
}

impl SolverKind {
    pub fn as_str(self) -> &'static str {
        match self {
            SolverKind::Predictive => "cgv",
            SolverKind::Paper => "paper",
        }
    }
}

impl std::str::FromStr for SolverKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "cgv" | "predictive" => Ok(SolverKind::Predictive),
            "paper" => Ok(SolverKind::Paper),
            _ => Err(format!("unknown solver '{s}' (expected cgv or paper)")),
        }
    }
}

impl std::fmt::Display for SolverKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.as_str())
    }
}

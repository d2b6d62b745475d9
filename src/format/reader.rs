//! The reader of a whole file: the prefix, one chunk at a time, and the
//! random-access index at the file's tail. [`super::stream_reader`] runs
//! these checks as bytes arrive.

use super::{
    leb128, Appearance, ContainerError, FrameInfo, Header, SkinWeights, SourceMesh, StreamReader, MAGIC, MAX_CHUNK,
    MAX_HEADER, TAG_ACCESS_UNIT, TAG_APPEARANCE, TAG_END, TAG_FRAME, TAG_INDEX, TAG_SKIN, TAG_SOURCE_MESH, VERSION,
};

/// Reads a LEB128 length of at most 4 bytes at `b[*at..]`, advancing `at`.
pub(super) fn read_len(b: &[u8], at: &mut usize) -> Option<usize> {
    leb128::read(b, at, 4).map(|n| n as usize)
}

pub(super) fn u16_at(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}
pub(super) fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}
pub(super) fn u64_at(b: &[u8], o: usize) -> u64 {
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
    if ![TAG_ACCESS_UNIT, TAG_FRAME, TAG_END, TAG_SOURCE_MESH, TAG_APPEARANCE, TAG_INDEX, TAG_SKIN].contains(&tag) {
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
    /// Version 13: the bones' weights, when the file has a skin.
    pub skin: Option<SkinWeights>,
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

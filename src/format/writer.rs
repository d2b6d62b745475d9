//! The writer: the file prefix, chunks, frames, the random-access index.

use super::{
    leb128, Appearance, ContainerError, FrameInfo, Header, SkinWeights, SourceMesh, MAGIC, MAX_HEADER, TAG_APPEARANCE,
    TAG_FRAME, TAG_INDEX, TAG_SKIN, TAG_SOURCE_MESH, VERSION,
};

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

/// Version 13: the skin weights' chunk, after the source mesh and
/// appearance (or the header).
pub fn write_skin(weights: &SkinWeights, info: &super::SkinInfo) -> Vec<u8> {
    write_chunk(TAG_SKIN, 0, 0, &weights.to_bytes(info))
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

/// A version-2 frame chunk: the frame's side data, then each access unit
/// the frame has (streams in header order) after its LEB128 length, and
/// the same way version 13's bones unit and version 11's loose vertices.
pub fn write_frame(frame: u32, info: &FrameInfo, units: &[&[u8]]) -> Vec<u8> {
    let mut payload = info.to_bytes();
    let side_units = [&info.bones, &info.loose, &info.mesh, &info.residual].into_iter().flatten().map(Vec::as_slice);
    for au in units.iter().copied().chain(side_units) {
        leb128::write(&mut payload, au.len() as u64);
        payload.extend_from_slice(au);
    }
    write_chunk(TAG_FRAME, 0, frame, &payload)
}

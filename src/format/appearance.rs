//! Version 8: how the input's own mesh looks (the `APPR` chunk, right after
//! the `SMSH` source mesh): each source vertex's texture coordinates and
//! the base colour of its material, a factor and optionally a texture
//! image, carried through from a glTF input so that the decoded mesh and the
//! viewer show it textured.
//!
//! Payload: the LEB128 length of a deflated block (RFC 1951, raw) holding
//! each vertex's (u, v) as two f32 (little-endian), that block, then the
//! texture image's bytes as they were (a PNG or JPEG file; the header's
//! `appearance.texture.bytes` long), nothing after. The header field gives
//! the base colour, the image's MIME type and its length.

use super::{leb128, ContainerError, SourceMeshInfo};
use serde::{Deserialize, Serialize};

/// Image types a file may carry (what glTF allows).
pub const TEXTURE_MIME: [&str; 2] = ["image/png", "image/jpeg"];

/// The header's description of the `APPR` chunk.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AppearanceInfo {
    /// The material's base colour factor, linear RGBA.
    pub base_color: [f32; 4],
    /// The base colour texture, when there is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture: Option<TextureInfo>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TextureInfo {
    pub mime: String,
    pub bytes: u32,
}

impl AppearanceInfo {
    pub fn validate(&self) -> Result<(), String> {
        if self.base_color.iter().any(|c| !(0.0..=1.0).contains(c)) {
            return Err(format!("base colour {:?} is not in [0, 1]", self.base_color));
        }
        if let Some(t) = &self.texture {
            if !TEXTURE_MIME.contains(&t.mime.as_str()) {
                return Err(format!("texture type '{}' (expected one of {TEXTURE_MIME:?})", t.mime));
            }
            if t.bytes == 0 || t.bytes as usize > super::MAX_CHUNK {
                return Err(format!("a texture of {} bytes (1..={} allowed)", t.bytes, super::MAX_CHUNK));
            }
        }
        Ok(())
    }
}

/// What the `APPR` chunk holds.
#[derive(Debug, Clone, PartialEq)]
pub struct Appearance {
    pub uvs: Vec<[f32; 2]>,
    pub base_color: [f32; 4],
    /// The texture image: its MIME type and its file's bytes.
    pub texture: Option<(String, Vec<u8>)>,
}

impl Appearance {
    pub fn info(&self) -> AppearanceInfo {
        AppearanceInfo {
            base_color: self.base_color,
            texture: self.texture.as_ref().map(|(mime, b)| TextureInfo { mime: mime.clone(), bytes: b.len() as u32 }),
        }
    }

    /// The chunk's payload.
    pub fn to_bytes(&self) -> Vec<u8> {
        let raw: Vec<u8> = self.uvs.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let block = miniz_oxide::deflate::compress_to_vec(&raw, 9);
        let mut out = Vec::with_capacity(block.len() + 8);
        leb128::write(&mut out, block.len() as u64);
        out.extend_from_slice(&block);
        if let Some((_, bytes)) = &self.texture {
            out.extend_from_slice(bytes);
        }
        out
    }

    /// Reads the payload of the chunk at byte `offset` for the source mesh
    /// `mesh` and the header's `info`.
    pub fn parse(
        payload: &[u8],
        info: &AppearanceInfo,
        mesh: &SourceMeshInfo,
        offset: usize,
    ) -> Result<Appearance, ContainerError> {
        let bad = |msg: String| ContainerError::Chunk { offset, msg: format!("appearance: {msg}") };
        let mut at = 0;
        let len = leb128::read(payload, &mut at, 5).ok_or_else(|| bad("cut short".into()))? as usize;
        let block = payload.get(at..at.saturating_add(len)).ok_or_else(|| bad("cut short".into()))?;
        let want = mesh.vertices as usize * 8;
        let raw = miniz_oxide::inflate::decompress_to_vec_with_limit(block, want)
            .map_err(|e| bad(format!("the texture coordinates do not inflate within their size ({:?})", e.status)))?;
        if raw.len() != want {
            return Err(bad(format!("{} bytes of texture coordinates, expected {want}", raw.len())));
        }
        let f = |c: &[u8]| f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        let uvs: Vec<[f32; 2]> = raw.chunks_exact(8).map(|c| [f(&c[..4]), f(&c[4..])]).collect();
        if let Some(v) = uvs.iter().position(|uv| !uv[0].is_finite() || !uv[1].is_finite()) {
            return Err(bad(format!("vertex {v}'s texture coordinates are not finite")));
        }
        let image = &payload[at + len..];
        let expected = info.texture.as_ref().map_or(0, |t| t.bytes as usize);
        if image.len() != expected {
            return Err(bad(format!("{} bytes of texture image, the header says {expected}", image.len())));
        }
        let texture = info.texture.as_ref().map(|t| (t.mime.clone(), image.to_vec()));
        Ok(Appearance { uvs, base_color: info.base_color, texture })
    }
}

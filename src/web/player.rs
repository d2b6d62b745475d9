//! The decoder at the wasm edge: bytes in, positions out.

use super::{js, positions};
use crate::codec::{SequenceDecoder, SourceMeshDecoder, DEFAULT_MEMORY_LIMIT};
use crate::format::{SolverKind, StreamReader};
use wasm_bindgen::prelude::*;

/// Reads a `.cgv` file as it arrives and rebuilds its frames in order. The
/// file's bytes are held once, in the reader; the page decodes each access
/// unit with WebCodecs and hands the luma planes back.
#[wasm_bindgen]
pub struct Player {
    reader: StreamReader,
    dec: Option<SequenceDecoder>,
    /// The next frame's luma planes, per stream, as the page supplies them.
    lumas: Vec<Option<Vec<u8>>>,
    solver: Option<SolverKind>,
    memory_limit: u64,
    /// The input's own mesh, once its chunk has arrived (format version 6).
    source: Option<SourceMeshDecoder>,
}

#[wasm_bindgen]
impl Player {
    /// `solver`: "cgv", "paper", or "" for the one recorded in the file.
    #[wasm_bindgen(constructor)]
    pub fn new(solver: &str) -> std::result::Result<Player, JsError> {
        let solver = if solver.is_empty() { None } else { Some(solver.parse::<SolverKind>().map_err(js)?) };
        Ok(Player {
            reader: StreamReader::default(),
            dec: None,
            lumas: Vec::new(),
            solver,
            memory_limit: DEFAULT_MEMORY_LIMIT,
            source: None,
        })
    }

    /// The most memory, in MiB, the decoder may need for a file (1024 by
    /// default); a file asking for more is refused with the push that
    /// brings its header, before any frame is decoded. (The reader has then
    /// taken the chunks that came in the same push; the format's own limits
    /// bound those.)
    pub fn set_memory_limit_mib(&mut self, mib: f64) {
        self.memory_limit = (mib.max(0.0) * 1048576.0) as u64;
    }

    /// Adds bytes of the file (the whole file, or the next piece of a stream).
    pub fn push(&mut self, bytes: &[u8]) -> std::result::Result<(), JsError> {
        self.reader.push(bytes).map_err(js)?;
        if let (None, Some(header)) = (&self.dec, self.reader.header()) {
            let solver = self.solver.unwrap_or(header.solver);
            self.lumas = vec![None; header.streams.len()];
            self.dec = Some(SequenceDecoder::new(header.clone(), solver, self.memory_limit).map_err(js)?);
        }
        if let (None, Some(dec), Some(mesh)) =
            (&self.source, self.dec.as_mut(), self.reader.file().and_then(|f| f.source_mesh.as_ref()))
        {
            dec.set_source_mesh(mesh).map_err(js)?;
            self.source = Some(SourceMeshDecoder::for_header(dec.header(), dec.grid(), mesh));
        }
        self.give_skin()
    }

    /// Version 13: hands the skin weights to a decoder that lacks them, once
    /// they have arrived (they come before frame 0).
    fn give_skin(&mut self) -> std::result::Result<(), JsError> {
        if let (Some(dec), Some(weights)) = (self.dec.as_mut(), self.reader.file().and_then(|f| f.skin.as_ref())) {
            if !dec.has_skin() {
                dec.set_skin(weights).map_err(js)?;
            }
        }
        Ok(())
    }

    /// The grid mesh's faces (three sample indices each, N x N samples in
    /// the order [`decode_next`](Self::decode_next) gives them), once the
    /// header has arrived: what to draw a file without the input's mesh with.
    pub fn grid_faces(&self) -> Vec<u32> {
        self.dec.as_ref().map_or_else(Vec::new, |d| d.grid().topology().faces.iter().flatten().copied().collect())
    }

    /// The input's own faces (three vertex indices each) when the file
    /// carries its mesh (format version 6), else empty: draw these with
    /// [`source_vertices`](Self::source_vertices) to show the user's mesh
    /// rather than the grid's.
    pub fn source_faces(&self) -> Vec<u32> {
        self.source.as_ref().map_or_else(Vec::new, |s| s.topology.faces.iter().flatten().copied().collect())
    }

    /// The input's vertices (x, y, z each) on a decoded grid frame (x, y,
    /// z per grid sample, as [`decode_next`](Self::decode_next) returns it)
    /// and that frame's loose vertices and skinned vertices (as
    /// [`loose_vertices`](Self::loose_vertices) and
    /// [`skinned_vertices`](Self::skinned_vertices) returned them after it;
    /// empty in files without them).
    pub fn source_vertices(
        &self,
        grid_frame: &[f32],
        loose: &[f32],
        skinned: &[f32],
    ) -> std::result::Result<Vec<f32>, JsError> {
        let source = self.source.as_ref().ok_or_else(|| JsError::new("the file carries no source mesh"))?;
        // A file without a grid (version 20) decodes no grid frame.
        let gridless = source.origin.is_some();
        let n = self.dec.as_ref().filter(|_| !gridless).map_or(0, |d| d.grid().len());
        if grid_frame.len() != 3 * n {
            return Err(JsError::new(&format!("{} values for a grid of {n} samples", grid_frame.len())));
        }
        let count = self.dec.as_ref().and_then(|d| d.header().loose_vertices()).unwrap_or(0) as usize;
        if loose.len() != 3 * count {
            return Err(JsError::new(&format!("{} values for {count} loose vertices", loose.len())));
        }
        let adds = self.dec.as_ref().is_some_and(|d| d.header().adds_at_vertices());
        let want = if adds { 3 * source.topology.vertex_count } else { 0 };
        if skinned.len() != want {
            return Err(JsError::new(&format!("{} skinned values for {want}", skinned.len())));
        }
        let skinned = positions(skinned);
        let skinned = adds.then_some(&skinned[..]);
        Ok(source
            .vertices(&positions(grid_frame), &positions(loose), skinned)
            .iter()
            .flat_map(|p| p.to_array())
            .collect())
    }

    /// The input's texture coordinates (u, v per source vertex) when the
    /// file says how its mesh looks (format version 8), else empty.
    pub fn source_uvs(&self) -> Vec<f32> {
        self.look().map_or_else(Vec::new, |a| a.uvs.iter().flatten().copied().collect())
    }

    /// The base colour texture's file bytes (PNG or JPEG: see
    /// `header.appearance.texture.mime`), else empty.
    pub fn texture_bytes(&self) -> Vec<u8> {
        self.look().and_then(|a| a.texture.as_ref()).map_or_else(Vec::new, |(_, b)| b.clone())
    }

    fn look(&self) -> Option<&crate::format::Appearance> {
        self.reader.file().and_then(|f| f.appearance.as_ref())
    }

    /// The header as JSON, once it has arrived.
    pub fn header_json(&self) -> Option<String> {
        self.reader.header().and_then(|h| serde_json::to_string(h).ok())
    }

    /// Frames from 0 on whose bytes have all arrived, in a row.
    pub fn complete_frames(&self) -> u32 {
        self.reader.complete_frames()
    }

    /// Whether frame `f`'s bytes have all arrived (a file fetched in pieces
    /// may have later frames before earlier ones).
    pub fn frame_arrived(&self, f: u32) -> bool {
        self.reader.frame_arrived(f)
    }

    /// How many bytes at the end of the file are its random-access index
    /// and end chunk (format version 10; the end chunk alone before), once
    /// the header has arrived: what a page fetches by a range request to
    /// learn where each point starts.
    pub fn index_tail_bytes(&self) -> f64 {
        self.reader.header().map_or(0.0, |h| crate::format::index_tail_bytes(h) as f64)
    }

    /// Takes the file's last [`index_tail_bytes`](Self::index_tail_bytes)
    /// bytes: the random-access index, checked. A page that fetches the
    /// file in pieces calls this before [`jump`](Self::jump).
    pub fn set_index(&mut self, tail: &[u8]) -> std::result::Result<(), JsError> {
        let h = self.reader.header().ok_or_else(|| JsError::new("the header has not arrived"))?;
        let offsets = crate::format::parse_index_tail(h, tail).map_err(js)?;
        self.reader.set_index(offsets).map_err(js)
    }

    /// The byte range [start, end) of random-access point `point`'s frames
    /// (to the next point, or to `file_bytes` for the last: the index and
    /// end chunk included), once the index is known; empty otherwise.
    pub fn point_bytes(&self, point: u32, file_bytes: f64) -> Vec<f64> {
        let index = self.reader.file().map_or(&[][..], |f| &f.index[..]);
        match (index.get(point as usize), index.get(point as usize + 1)) {
            (Some(&a), Some(&b)) => vec![a as f64, b as f64],
            (Some(&a), None) => vec![a as f64, file_bytes],
            _ => Vec::new(),
        }
    }

    /// The reader takes the bytes of random-access point `point` next (they
    /// start at its offset); what arrived before stays.
    pub fn jump(&mut self, point: u32) -> std::result::Result<(), JsError> {
        self.reader.jump(point).map_err(js)
    }

    pub fn is_complete(&self) -> bool {
        self.reader.is_complete()
    }

    /// Bytes received.
    pub fn bytes(&self) -> usize {
        self.reader.bytes()
    }

    /// The frame [`decode_next`](Self::decode_next) rebuilds next.
    pub fn next_frame(&self) -> u32 {
        self.dec.as_ref().map_or(0, |d| d.next_index())
    }

    /// Whether stream `s` has an access unit at `frame`.
    pub fn has_frame(&self, s: usize, frame: u32) -> bool {
        self.reader.header().is_some_and(|h| s < h.streams.len() && h.stream_has_frame(s, frame))
    }

    /// Stream `s`'s access unit (Annex-B) at `frame`, copied out for WebCodecs.
    pub fn access_unit(&self, s: usize, frame: u32) -> std::result::Result<Vec<u8>, JsError> {
        self.reader
            .file()
            .filter(|_| self.reader.frame_arrived(frame))
            .and_then(|f| f.units.get(s)?.get(frame as usize).cloned())
            .ok_or_else(|| JsError::new(&format!("stream {s} frame {frame} has not arrived")))
    }

    /// Hands in stream `s`'s decoded luma plane (width x height, row-major)
    /// for the next frame to rebuild.
    pub fn supply_luma(&mut self, s: usize, luma: Vec<u8>) -> std::result::Result<(), JsError> {
        *self.lumas.get_mut(s).ok_or_else(|| JsError::new(&format!("no stream {s}")))? = Some(luma);
        Ok(())
    }

    /// Starts the sequence again from frame 0, from the bytes already here
    /// (nothing is fetched again): a player that keeps only a window of
    /// frames loops or seeks back this way. The page starts its H.264
    /// decoders again too, since frame 0's pictures are where they start.
    pub fn rewind(&mut self) -> std::result::Result<(), JsError> {
        let header = self.reader.header().ok_or_else(|| JsError::new("the header has not arrived"))?.clone();
        let solver = self.solver.unwrap_or(header.solver);
        self.lumas = vec![None; header.streams.len()];
        let mut dec = SequenceDecoder::new(header, solver, self.memory_limit).map_err(js)?;
        // What the decoder took from the source mesh (loose vertices'
        // anchors, the spatial residual's walk) it needs again.
        if let Some(mesh) = self.reader.file().and_then(|f| f.source_mesh.as_ref()) {
            dec.set_source_mesh(mesh).map_err(js)?;
        }
        self.dec = Some(dec);
        self.give_skin()
    }

    /// The last random-access point at or before `frame` (format version
    /// 10; 0 in older files): where a seek to `frame` starts decoding.
    pub fn random_access_point(&self, frame: u32) -> u32 {
        self.reader.header().map_or(0, |h| h.random_access_point(frame.min(h.frames.saturating_sub(1))))
    }

    /// The index of the random-access point at or before `frame` (what
    /// [`point_bytes`](Self::point_bytes) and [`jump`](Self::jump) take):
    /// points every `random_access` frames and at each segment's start
    /// (format version 15).
    pub fn point_of(&self, frame: u32) -> u32 {
        self.reader.header().map_or(0, |h| h.point_index(frame.min(h.frames.saturating_sub(1))))
    }

    /// Makes random-access point `frame` the next frame to rebuild, from the
    /// bytes already here: a seek. The page starts its H.264 decoders
    /// again too, since the point's pictures are IDR pictures.
    pub fn seek(&mut self, frame: u32) -> std::result::Result<(), JsError> {
        let dec = self.dec.as_mut().ok_or_else(|| JsError::new("the header has not arrived"))?;
        dec.seek(frame).map_err(js)?;
        self.lumas = vec![None; dec.header().streams.len()];
        Ok(())
    }

    /// Version 11: the loose vertices (x, y, z each) of the frame
    /// [`decode_next`](Self::decode_next) rebuilt last; keep them with that
    /// frame for [`source_vertices`](Self::source_vertices). Empty in files
    /// without them.
    pub fn loose_vertices(&self) -> Vec<f32> {
        self.dec.as_ref().map_or_else(Vec::new, |d| d.loose().iter().flat_map(|p| p.to_array()).collect())
    }

    /// What the decoder adds at the source mesh's vertices (x, y, z each)
    /// at the frame [`decode_next`](Self::decode_next) rebuilt last: the
    /// bones' skinning (version 17), the vertex residual (18) or their
    /// sum; keep it with that frame for
    /// [`source_vertices`](Self::source_vertices). Empty in files with
    /// neither. (Named for the first of them, which came first.)
    pub fn skinned_vertices(&self) -> Vec<f32> {
        self.dec
            .as_ref()
            .and_then(|d| d.at_vertices())
            .map_or_else(Vec::new, |s| s.iter().flat_map(|p| p.to_array()).collect())
    }

    /// Version 16: frame `frame`'s own mesh (a capture's, `cgv encode
    /// --mesh frames`): its faces and its vertices rebuilt on that frame's
    /// decoded grid frame (as [`decode_next`](Self::decode_next) returned
    /// it); both empty in files without frame meshes. Ask right after
    /// decoding the frame: the player may drop a frame's bytes once it is
    /// behind.
    pub fn frame_mesh(&self, frame: u32, grid_frame: &[f32]) -> std::result::Result<FrameMesh, JsError> {
        let dec = self.dec.as_ref().ok_or_else(|| JsError::new("the header has not arrived"))?;
        let info =
            self.reader.file().filter(|_| self.reader.frame_arrived(frame)).and_then(|f| f.frames.get(frame as usize));
        let Some(unit) = info.and_then(|i| i.mesh.as_deref()) else {
            return Ok(FrameMesh { faces: Vec::new(), vertices: Vec::new() });
        };
        let n = dec.grid().len();
        if grid_frame.len() != 3 * n {
            return Err(JsError::new(&format!("{} values for a grid of {n} samples", grid_frame.len())));
        }
        let mesh = crate::format::frame_mesh::parse_unit(unit, frame, 0).map_err(js)?;
        let vertices = SourceMeshDecoder::new(dec.grid(), &mesh).vertices(&positions(grid_frame), &[], None);
        Ok(FrameMesh {
            faces: mesh.faces.iter().flatten().copied().collect(),
            vertices: vertices.iter().flat_map(|p| p.to_array()).collect(),
        })
    }

    /// Rebuilds the next frame from the pictures supplied: x, y, z per grid sample.
    pub fn decode_next(&mut self) -> std::result::Result<Vec<f32>, JsError> {
        let dec = self.dec.as_mut().ok_or_else(|| JsError::new("the header has not arrived"))?;
        let f = dec.next_index();
        let info = self
            .reader
            .file()
            .filter(|_| self.reader.frame_arrived(f))
            .and_then(|file| file.frames.get(f as usize))
            .ok_or_else(|| JsError::new(&format!("frame {f} has not arrived")))?;
        let lumas = std::mem::replace(&mut self.lumas, vec![None; dec.header().streams.len()]);
        let (x, _) = dec.push_frame(info, &lumas).map_err(js)?;
        Ok(x.iter().flat_map(|p| p.to_array()).collect())
    }
}

/// A frame's own mesh ([`Player::frame_mesh`]).
#[wasm_bindgen(getter_with_clone)]
pub struct FrameMesh {
    /// Three vertex indices a face.
    pub faces: Vec<u32>,
    /// x, y, z a vertex.
    pub vertices: Vec<f32>,
}

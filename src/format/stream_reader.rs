//! Reading a file as its bytes arrive, or in pieces from random-access
//! points (see [`StreamReader`]).

use super::reader::{read_len, u16_at, u64_at};
use super::{
    parse_chunk, parse_header, Appearance, CgvFile, Chunk, ContainerError, FrameInfo, Header, LooseFrame, SkinWeights,
    SourceMesh, TAG_ACCESS_UNIT, TAG_APPEARANCE, TAG_END, TAG_FRAME, TAG_INDEX, TAG_SKIN, TAG_SOURCE_MESH,
};

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
            || (h.appearance.is_some() && file.appearance.is_none())
            || (h.skin.is_some() && file.skin.is_none());
        if !self.index_given || waiting {
            return Err(bad("a jump needs the header, the source mesh, the skin and the index first".into()));
        }
        let offset = *file.index.get(point as usize).ok_or_else(|| bad(format!("no random-access point {point}")))?;
        // An index was given, so the header has random-access points.
        self.frame = h.point_frame(point).ok_or_else(|| bad(format!("no random-access point {point}")))?;
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
                        skin: None,
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
        if let (Some(skin), None, 0, 0) = (&file.header.skin, &file.skin, self.frame, self.slot) {
            // Version 13: the skin weights come after those, before frame 0.
            if chunk.tag != TAG_SKIN || chunk.frame != 0 {
                return Err(unexpected(&chunk, offset, "the skin weights", 0));
            }
            file.skin = Some(SkinWeights::parse(chunk.payload, skin, file.header.skin_samples(), offset)?);
            return Ok(());
        }
        let header = &file.header;
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
            let point = header.point_index(frame) as usize;
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
        self.accept_v1(chunk, offset)
    }

    /// Version 1: the frame chunk, then one chunk per access unit of each
    /// stream that has the frame.
    fn accept_v1(&mut self, chunk: Chunk<'_>, offset: usize) -> Result<(), ContainerError> {
        let Some(file) = self.file.as_mut() else {
            return Err(ContainerError::Chunk { offset, msg: "a chunk before the header".into() });
        };
        let (frame, header) = (self.frame, &file.header);
        let nstreams = header.streams.len();
        let expect = |what: &str| unexpected(&chunk, offset, what, frame);
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
        side_units(header, frame, (p, &mut at), &mut info, offset)?;
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

/// The next length-prefixed unit of a frame chunk's payload `p` at `at`
/// (moved past it), `what` naming it in errors.
fn next_unit<'a>(p: &'a [u8], at: &mut usize, what: &str, offset: usize) -> Result<&'a [u8], ContainerError> {
    let bad = |msg: String| ContainerError::Chunk { offset, msg: format!("{what}: {msg}") };
    let len = read_len(p, at).ok_or_else(|| bad("bad unit length".into()))?;
    if len > p.len() - *at {
        return Err(bad(format!("a unit of {len} bytes overruns its frame chunk")));
    }
    let unit = &p[*at..*at + len];
    *at += len;
    Ok(unit)
}

/// The units a frame chunk has after its access units, as the header says:
/// the bones (version 13), the loose vertices (11), the frame's own
/// mesh (16) and the vertex residual (18), each checked and kept in `info`; `at` moves past them.
fn side_units(
    header: &Header,
    frame: u32,
    (p, at): (&[u8], &mut usize),
    info: &mut FrameInfo,
    offset: usize,
) -> Result<(), ContainerError> {
    if let Some(skin) = &header.skin {
        let unit = next_unit(p, at, "bones", offset)?;
        // Every frame but a random-access point has one (with bones on the
        // vertices, every frame); a point's is empty or (version 21) holds
        // weights.
        let rap = header.is_random_access_point(frame) && !skin.on_vertices();
        let most = match rap {
            true => skin.point_unit_bytes(header.skin_samples()),
            false => crate::format::BoneMotions::max_bytes(skin.bones, skin.packed),
        };
        if unit.len() > most || (!rap && unit.is_empty()) {
            let least = usize::from(!rap).min(most);
            let msg = format!("bones: a unit of {} bytes (frame {frame}'s has {least} to {most})", unit.len());
            return Err(ContainerError::Chunk { offset, msg });
        }
        if rap && !unit.is_empty() {
            SkinWeights::parse(unit, skin, header.skin_samples(), offset)?;
        }
        info.bones = Some(unit.to_vec());
    }
    if let Some(count) = header.loose_vertices() {
        let unit = next_unit(p, at, "loose vertices", offset)?;
        LooseFrame::parse(unit, count, offset)?;
        info.loose = Some(unit.to_vec());
    }
    if header.frame_meshes {
        let unit = next_unit(p, at, &format!("frame {frame}'s mesh"), offset)?;
        crate::format::frame_mesh::parse_unit(unit, frame, offset)?;
        info.mesh = Some(unit.to_vec());
    }
    if let Some(r) = header.vertex_residual {
        let unit = next_unit(p, at, "vertex residual", offset)?;
        let values = header.source_mesh.map_or(0, |m| 3 * m.vertices as usize);
        crate::format::vertex_residual::ResidualUnit::check(unit, values, r.modes(), offset)?;
        info.residual = Some(unit.to_vec());
    }
    Ok(())
}

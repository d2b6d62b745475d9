//! Version 6: the input's own mesh, once per file (the `SMSH` chunk after
//! the header), so a decoder gives back the user's vertices and faces
//! rather than the grid mesh: the connectivity, and each vertex's place in
//! the parameterization, from which the decoder rebuilds the vertex on
//! every decoded grid frame.
//!
//! Payload, deflated (RFC 1951, raw) as a whole: the faces' 3 x `faces`
//! vertex indices, each as the zigzag-coded difference from the index
//! before it in LEB128 (neighbouring faces share vertices, so most
//! differences are small), then each vertex's place as two u32 (u, v in
//! [-1, 1] on 2^32 - 1 steps; 16 bits were too coarse: on the built-in
//! motion's map 115 of 6,274 vertices shared a place with another, and so a
//! decoded position). The header's
//! `source_mesh` gives the counts, so a reader knows the size before it
//! inflates anything.
//!
//! Version 7 may add, after the places, each vertex's offset from the grid
//! mesh as three integers in [-32767, 32767], zigzag-coded in LEB128 (most
//! offsets are small: one or two bytes each), times the header's
//! `offset_step`, in
//! the frame of the grid triangle the vertex lies in (see
//! `crate::resample::SourcePoints`): what resampling cut off (a sharp
//! corner, a low-poly figure's own vertices) comes back on every frame,
//! turning with the surface.
//!
//! Version 11 may add, last, for each vertex an unsigned LEB128 number:
//! 0 for a vertex rebuilt from the grid, k + 1 for the file's loose vertex
//! k (`super::loose`: a tiny part's vertex coded as itself every frame),
//! then each loose vertex's *anchor*, the grid sample whose motion it
//! follows (LEB128, below N²); the header's `loose` gives their count.
//!
//! Version 12 (the header's `walk`) codes the faces and the places
//! instead: a byte giving the faces' order (0: the input's, 1: a walk over
//! the mesh, see `super::connectivity`), a byte `shift` (0..=16: the low
//! bits every place leaves zero), the faces as `super::connectivity`
//! codes them, then each vertex's u and v, shifted right by `shift`, as
//! zigzag LEB128 differences from their prediction (`super::places`), in
//! the order the coded faces first use the vertices; the offsets and the
//! loose vertices follow as in versions 7 and 11, in vertex order.

use super::connectivity::{self, Order};
use super::{leb128, places, ContainerError};
use serde::{Deserialize, Serialize};

/// Most bytes one byte of the deflated payload may inflate to, so that
/// inflating a file's source mesh takes at most this many times the bytes
/// the file really has, besides the header's counts' bound (the parsed
/// faces take up to four times the inflated bytes on top). A regular mesh
/// in its own order compresses far: face-poses' 29,299-vertex scan grid
/// inflates 90 times (its faces 2.3 KB; version 20's files without a grid
/// give every vertex the same place), so the bound is deflate's own.
pub const MAX_INFLATION: usize = 1032;

/// Most vertices and faces a source mesh may have: a reader inflates at
/// most 15 bytes a face and 8 a vertex (152 MB here) and holds 12 bytes a
/// face and 8 a vertex parsed, whatever the file says.
pub const MAX_SOURCE_VERTICES: u32 = 1 << 22;
pub const MAX_SOURCE_FACES: u32 = 1 << 23;

/// The header's description of the `SMSH` chunk.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SourceMeshInfo {
    pub vertices: u32,
    pub faces: u32,
    /// Version 7: the step of the vertex offsets (absent: no offsets).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_step: Option<f32>,
    /// Version 11: how many loose vertices the frames carry (absent: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loose: Option<u32>,
    /// Version 12: the faces are coded as a walk and the places from their
    /// predictions (absent: versions 6 to 11's plain layout).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub walk: bool,
    /// Version 20: the walk's references may name the next new vertex in
    /// index order and a vertex's neighbours (`super::connectivity`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub around: bool,
}

impl SourceMeshInfo {
    pub fn validate(&self) -> Result<(), String> {
        if !(3..=MAX_SOURCE_VERTICES).contains(&self.vertices) || !(1..=MAX_SOURCE_FACES).contains(&self.faces) {
            return Err(format!(
                "source mesh of {} vertices and {} faces (3..={MAX_SOURCE_VERTICES} and 1..={MAX_SOURCE_FACES} allowed)",
                self.vertices, self.faces
            ));
        }
        if self.around && !self.walk {
            return Err("source mesh: `around` references need the walk's coding (`walk`)".into());
        }
        if let Some(step) = self.offset_step {
            if !(step.is_finite() && step > 0.0) {
                return Err(format!("source mesh offset step {step} is not a positive number"));
            }
        }
        if let Some(l) = self.loose {
            if !(1..=self.vertices.min(super::loose::MAX_LOOSE_VERTICES)).contains(&l) {
                return Err(format!("{l} loose vertices in a source mesh of {} vertices", self.vertices));
            }
        }
        Ok(())
    }

    /// The most bytes a vertex takes after the faces.
    fn vertex_bytes(&self) -> usize {
        let offsets = if self.offset_step.is_some() { 3 * 3 } else { 0 };
        // Its loose vertex, and (at most one a vertex) an anchor.
        let loose = if self.loose.is_some() { 3 + 5 } else { 0 };
        // Two u32, or (version 12) two differences of up to 5 bytes.
        let place = if self.walk { 2 * 5 } else { 8 };
        place + offsets + loose
    }

    /// The most bytes the inflated payload can have.
    fn max_inflated(&self) -> usize {
        // Version 12: an op, three references and three 5-byte differences.
        let face = if self.walk { 1 + 3 + 3 * 5 } else { 3 * 5 };
        2 + self.faces as usize * face + self.vertices as usize * self.vertex_bytes()
    }
}

/// The input's mesh as a file carries it.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceMesh {
    pub faces: Vec<[u32; 3]>,
    /// Each vertex's place in the parameterization, quantized ([`place`]).
    pub places: Vec<[u32; 2]>,
    /// Version 7: each vertex's offset from the grid mesh, quantized.
    pub offsets: Option<Offsets>,
    /// Version 11: each vertex's loose vertex plus one, 0 where the grid
    /// rebuilds it (empty: no loose vertices).
    pub loose_of: Vec<u32>,
    /// Version 11: each loose vertex's anchor sample (empty: none).
    pub loose_anchors: Vec<u32>,
}

/// Vertex offsets: `values` times `step` (mesh units) in each vertex's
/// grid-triangle frame (tangent, bitangent, normal).
#[derive(Debug, Clone, PartialEq)]
pub struct Offsets {
    pub step: f32,
    pub values: Vec<[i16; 3]>,
}

impl Offsets {
    /// Quantizes offsets on the step their largest component needs, and
    /// no finer than `finest` (cgv's encoder gives 4e-5 of the diagonal,
    /// far below any grid's floor: most values fit one or two bytes); None
    /// when they are all zero (or not finite).
    pub fn quantize(offsets: &[[f32; 3]], finest: f32) -> Option<Offsets> {
        let largest = offsets.iter().flatten().fold(0f32, |m, x| m.max(x.abs()));
        if !(largest.is_finite() && largest > 0.0) {
            return None;
        }
        let step = (largest / i16::MAX as f32).max(finest);
        let values = offsets.iter().map(|o| o.map(|x| (x / step).round().clamp(-32767.0, 32767.0) as i16)).collect();
        Some(Offsets { step, values })
    }

    /// The offset of vertex `v`, in mesh units.
    pub fn get(&self, v: usize) -> [f32; 3] {
        self.values.get(v).map_or([0.0; 3], |o| o.map(|x| x as f32 * self.step))
    }
}

const PLACE_STEPS: f64 = u32::MAX as f64;

/// A coordinate in [-1, 1] on 2^32 - 1 steps.
pub fn quantize_place(u: f64) -> u32 {
    ((u.clamp(-1.0, 1.0) + 1.0) / 2.0 * PLACE_STEPS).round() as u32
}

/// The coordinate a quantized place stands for.
pub fn place(q: u32) -> f64 {
    q as f64 / PLACE_STEPS * 2.0 - 1.0
}

impl SourceMesh {
    pub fn info(&self) -> SourceMeshInfo {
        SourceMeshInfo {
            vertices: self.places.len() as u32,
            faces: self.faces.len() as u32,
            offset_step: self.offsets.as_ref().map(|o| o.step),
            loose: self.loose_count(),
            walk: true,
            around: true,
        }
    }

    /// How many loose vertices the mesh's vertices name (None: none).
    pub fn loose_count(&self) -> Option<u32> {
        self.loose_of.iter().copied().max().filter(|&m| m > 0)
    }

    /// The chunk's payload as [`Self::info`] describes it (version 20's
    /// references): the faces in the input's order or walked, whichever
    /// deflates smaller.
    pub fn to_bytes(&self) -> Vec<u8> {
        self.to_bytes_with(true)
    }

    /// The payload by version 12's references (`around` false: a frame
    /// mesh's, version 16) or version 20's.
    pub fn to_bytes_with(&self, around: bool) -> Vec<u8> {
        let [input, walked] = [Order::Input, Order::Walk].map(|o| self.payload(o, around));
        if walked.len() < input.len() {
            walked
        } else {
            input
        }
    }

    /// The payload with the faces coded in `order`.
    fn payload(&self, order: Order, around: bool) -> Vec<u8> {
        let v = self.places.len();
        let faces: Vec<[u32; 3]> = match order {
            Order::Input => self.faces.clone(),
            Order::Walk => connectivity::walk_order(&self.faces, v).into_iter().map(|i| self.faces[i]).collect(),
        };
        // The low bits every place leaves zero (the encoder leaves 16).
        let shift = self.places.iter().flatten().map(|q| q.trailing_zeros()).min().unwrap_or(0).min(MAX_SHIFT);
        let mut raw = vec![order as u8, shift as u8];
        raw.extend(connectivity::encode(&faces, v, around));
        let max = i64::from(u32::MAX >> shift);
        let coded = places::walk(&faces, v, max, &mut |vertex, guess| {
            let p = self.places[vertex as usize].map(|q| i64::from(q >> shift));
            for c in 0..2 {
                leb128::write(&mut raw, zigzag(p[c] - guess[c]));
            }
            Ok(p)
        });
        debug_assert!(coded.is_ok(), "the coder's visit never fails");
        self.write_tail(&mut raw);
        miniz_oxide::deflate::compress_to_vec(&raw, 9)
    }

    /// The offsets and the loose vertices, in vertex order.
    fn write_tail(&self, raw: &mut Vec<u8>) {
        for &x in self.offsets.iter().flat_map(|o| &o.values).flatten() {
            leb128::write(raw, zigzag(x as i64));
        }
        if self.loose_count().is_some() {
            for &k in self.loose_of.iter().chain(&self.loose_anchors) {
                leb128::write(raw, u64::from(k));
            }
        }
    }

    /// Versions 6 to 11's payload (what `to_bytes` wrote before version
    /// 12; kept to make files of those versions in tests).
    pub fn to_bytes_plain(&self) -> Vec<u8> {
        let mut raw = Vec::with_capacity(self.faces.len() * 4 + self.places.len() * 8);
        let mut prev = 0i64;
        for &i in self.faces.iter().flatten() {
            let d = i as i64 - prev;
            prev = i as i64;
            leb128::write(&mut raw, zigzag(d));
        }
        for p in &self.places {
            raw.extend_from_slice(&p[0].to_le_bytes());
            raw.extend_from_slice(&p[1].to_le_bytes());
        }
        self.write_tail(&mut raw);
        miniz_oxide::deflate::compress_to_vec(&raw, 9)
    }

    /// Reads the payload of the chunk at byte `offset` that `info` describes.
    pub fn parse(payload: &[u8], info: &SourceMeshInfo, offset: usize) -> Result<SourceMesh, ContainerError> {
        let bad = |msg: String| ContainerError::Chunk { offset, msg: format!("source mesh: {msg}") };
        let limit = info.max_inflated().min(payload.len().saturating_mul(MAX_INFLATION));
        let raw = miniz_oxide::inflate::decompress_to_vec_with_limit(payload, limit)
            // Only the status: the error also holds the output buffer.
            .map_err(|e| bad(format!("does not inflate within its size ({:?})", e.status)))?;
        let mut at = 0usize;
        let (faces, places) = match info.walk {
            true => parse_walked(&raw, &mut at, info).map_err(bad)?,
            false => parse_plain(&raw, &mut at, info).map_err(bad)?,
        };
        let offsets = match info.offset_step {
            Some(step) => Some(Offsets { step, values: parse_offsets(&raw, &mut at, info.vertices, &bad)? }),
            None => None,
        };
        let (loose_of, loose_anchors) = match info.loose {
            Some(count) => (
                parse_loose_of(&raw, &mut at, info.vertices, count, &bad)?,
                (0..count)
                    .map(|k| {
                        let a = leb128::read(&raw, &mut at, 5).and_then(|a| u32::try_from(a).ok());
                        a.ok_or_else(|| bad(format!("loose vertex {k}'s anchor is cut short or out of range")))
                    })
                    .collect::<Result<Vec<u32>, _>>()?,
            ),
            None => (Vec::new(), Vec::new()),
        };
        if at != raw.len() {
            return Err(bad(format!("{} bytes after the vertex offsets", raw.len() - at)));
        }
        Ok(SourceMesh { faces, places, offsets, loose_of, loose_anchors })
    }
}

/// Most low bits a version-12 place may leave out.
const MAX_SHIFT: u32 = 16;

fn zigzag(d: i64) -> u64 {
    ((d << 1) ^ (d >> 63)) as u64
}

type FacesAndPlaces = (Vec<[u32; 3]>, Vec<[u32; 2]>);

/// Versions 6 to 11: the faces' indices as differences, the places as u32.
fn parse_plain(raw: &[u8], at: &mut usize, info: &SourceMeshInfo) -> Result<FacesAndPlaces, String> {
    let mut prev = 0i64;
    // At least a byte per index: the inflated bytes bound the faces.
    let mut faces = Vec::with_capacity((info.faces as usize).min(raw.len() / 3));
    for f in 0..info.faces {
        let mut face = [0u32; 3];
        for c in &mut face {
            let z = leb128::read(raw, at, 5).ok_or_else(|| format!("face {f} is cut short"))?;
            let d = (z >> 1) as i64 ^ -((z & 1) as i64);
            prev += d;
            if !(0..info.vertices as i64).contains(&prev) {
                return Err(format!("face {f} uses vertex {prev}, but there are {}", info.vertices));
            }
            *c = prev as u32;
        }
        faces.push(face);
    }
    let rest = &raw[*at..];
    let place_bytes = info.vertices as usize * 8;
    let nothing_after = info.offset_step.is_none() && info.loose.is_none();
    if rest.len() < place_bytes || (nothing_after && rest.len() != place_bytes) {
        let what = if info.offset_step.is_some() { "" } else { " (no offsets: the header has no offset_step)" };
        return Err(format!("{} bytes of vertex places, expected {place_bytes}{what}", rest.len()));
    }
    let u32_at = |c: &[u8]| u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
    let places = rest[..place_bytes].chunks_exact(8).map(|c| [u32_at(&c[..4]), u32_at(&c[4..])]).collect();
    *at += place_bytes;
    Ok((faces, places))
}

/// Version 12: the faces as a walk codes them, the places from their predictions.
fn parse_walked(raw: &[u8], at: &mut usize, info: &SourceMeshInfo) -> Result<FacesAndPlaces, String> {
    let (&order, &shift) = (raw.first().ok_or("no face order")?, raw.get(1).ok_or("no place shift")?);
    if order > Order::Walk as u8 || u32::from(shift) > MAX_SHIFT {
        return Err(format!("face order {order} or place shift {shift} is not one this reader knows"));
    }
    *at = 2;
    let faces = connectivity::decode(raw, at, info.faces, info.vertices, info.around)?;
    let shift = u32::from(shift);
    let max = i64::from(u32::MAX >> shift);
    let mut places = vec![[0u32; 2]; info.vertices as usize];
    places::walk(&faces, info.vertices as usize, max, &mut |v, guess| {
        let mut p = [0i64; 2];
        for c in 0..2 {
            let z = leb128::read(raw, at, 5).ok_or_else(|| format!("vertex {v}'s place is cut short"))?;
            p[c] = guess[c].saturating_add((z >> 1) as i64 ^ -((z & 1) as i64));
            if !(0..=max).contains(&p[c]) {
                return Err(format!("vertex {v}'s place is out of range"));
            }
        }
        places[v as usize] = p.map(|x| (x as u32) << shift);
        Ok(p)
    })?;
    Ok((faces, places))
}

/// Each of `vertices` vertices' loose vertex plus one (or 0), every loose
/// vertex below `count` named at least once.
fn parse_loose_of(
    raw: &[u8],
    at: &mut usize,
    vertices: u32,
    count: u32,
    bad: &dyn Fn(String) -> ContainerError,
) -> Result<Vec<u32>, ContainerError> {
    let mut loose_of = Vec::with_capacity((vertices as usize).min(raw.len().saturating_sub(*at)));
    let mut named = vec![false; count as usize];
    for v in 0..vertices {
        let k = leb128::read(raw, at, 3).ok_or_else(|| bad(format!("the loose vertices stop at vertex {v}")))?;
        if k > u64::from(count) {
            return Err(bad(format!("vertex {v} is loose vertex {}, but there are {count}", k - 1)));
        }
        if k > 0 {
            named[k as usize - 1] = true;
        }
        loose_of.push(k as u32);
    }
    if let Some(k) = named.iter().position(|n| !n) {
        return Err(bad(format!("loose vertex {k} belongs to no vertex")));
    }
    Ok(loose_of)
}

/// `vertices` offsets (three zigzag LEB128 integers each, in i16's range)
/// from `raw` at `at`.
fn parse_offsets(
    raw: &[u8],
    at: &mut usize,
    vertices: u32,
    bad: &dyn Fn(String) -> ContainerError,
) -> Result<Vec<[i16; 3]>, ContainerError> {
    let mut values = Vec::with_capacity((vertices as usize).min(raw.len().saturating_sub(*at) / 3));
    for v in 0..vertices {
        let mut o = [0i16; 3];
        for c in &mut o {
            let z = leb128::read(raw, at, 3).ok_or_else(|| bad(format!("the offsets stop at vertex {v}")))?;
            let x = (z >> 1) as i64 ^ -((z & 1) as i64);
            *c = i16::try_from(x)
                .ok()
                .filter(|x| *x != i16::MIN)
                .ok_or_else(|| bad(format!("vertex {v}'s offset is out of range")))?;
        }
        values.push(o);
    }
    Ok(values)
}

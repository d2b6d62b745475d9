//! What the decoder does with one frame, written once: the decoded 8-bit
//! samples become values ([`frame_values`]), and the values become grid
//! positions ([`Reconstructor`]). The encoder's closed loop calls the same
//! code on what it coded ([`Predictive`]), so the frames it corrects are the
//! decoder's, sample for sample.
//!
//! [`SequenceDecoder`] is push-style: it is fed each frame's side data and
//! decoded luma planes as they arrive (from OpenH264 natively, from
//! WebCodecs in the browser) and holds no file.

use super::corrections::{Corrections, Pictures};
use super::loose::LooseVertices;
use super::vertex_residual::VertexResidual;
use crate::error::{Error, Result};
use crate::format::stream::{POSITION, SEED};
use crate::format::vertex_residual::ResidualUnit;
use crate::format::{
    CodecKind, CorrectionMode, FrameInfo, Header, LooseFrame, PredictorCode, SkinWeights, SolverKind, SourceMesh,
    StreamName,
};
use crate::grid::{Grid, Stencils};
use crate::mesh::Topology;
use crate::resample::SourcePoints;
use crate::solve::paper::PaperSolver;
use crate::solve::predictor::{Extrapolation, Predictor};
use crate::solve::skinned::SkinnedPredictor;
use crate::solve::SolveStats;
use glam::Vec3;

/// Turns one frame's decoded 8-bit samples (per stream, `None` where the
/// stream has no frame) into values: dequantize, add each layer 2 to its
/// base, and scale the correction streams by the frame's scale.
pub fn frame_values(h: &Header, samples: &[Option<Vec<u8>>], scale: f32) -> Result<Vec<Option<Vec<f32>>>> {
    let mut out: Vec<Option<Vec<f32>>> = vec![None; h.streams.len()];
    for (s, smp) in samples.iter().enumerate() {
        let Some(smp) = smp else { continue };
        let q = h.streams[s].quant;
        let vals = smp.iter().map(|&x| q.dequantize(x));
        match h.streams[s].refines {
            Some(base) => {
                let b =
                    out[base as usize].as_mut().ok_or_else(|| Error::Argument("layer 2 without its base".into()))?;
                b.iter_mut().zip(vals).for_each(|(x, r)| *x += r);
            }
            None => out[s] = Some(vals.collect()),
        }
    }
    for (s, v) in out.iter_mut().enumerate() {
        if let (Some(v), true) = (v.as_mut(), h.streams[s].scaled) {
            v.iter_mut().for_each(|x| *x *= scale);
        }
    }
    Ok(out)
}

/// One frame's stream values, looked up by name.
pub struct Values<'a> {
    header: &'a Header,
    values: &'a [Option<Vec<f32>>],
    /// What the seed streams' values are relative to (version 10).
    seed_origin: Vec3,
}

impl<'a> Values<'a> {
    pub fn new(header: &'a Header, values: &'a [Option<Vec<f32>>]) -> Values<'a> {
        Values { header, values, seed_origin: Vec3::ZERO }
    }

    /// The frame's seed origin (format version 10's random-access points).
    pub fn with_seed_origin(mut self, origin: Option<[f32; 3]>) -> Values<'a> {
        self.seed_origin = origin.map_or(Vec3::ZERO, Vec3::from);
        self
    }

    /// The seed's positions, if the frame has them: the seed streams'
    /// values plus the frame's seed origin.
    pub fn seed(&self) -> Option<Vec<Vec3>> {
        let mut x = self.xyz(SEED)?;
        x.iter_mut().for_each(|p| *p += self.seed_origin);
        Some(x)
    }

    pub fn get(&self, name: StreamName) -> Option<&'a [f32]> {
        self.header.stream(name).and_then(|s| self.values[s].as_deref())
    }

    /// Streams' values as they are (each on its stream's grid), if all are there.
    pub fn pictures(&self, names: &[StreamName]) -> Option<Pictures> {
        names.iter().map(|&n| self.get(n).map(<[f32]>::to_vec)).collect()
    }

    /// The frame's correction pictures, if it has them.
    pub fn corrections(&self) -> Option<Pictures> {
        self.header.correction_streams().and_then(|names| self.pictures(&names))
    }

    /// Three streams as positions, if all are there.
    pub fn xyz(&self, names: [StreamName; 3]) -> Option<Vec<Vec3>> {
        let [x, y, z] = names.map(|n| self.get(n));
        let (x, y, z) = (x?, y?, z?);
        Some(x.iter().zip(y).zip(z).map(|((&x, &y), &z)| Vec3::new(x, y, z)).collect())
    }
}

/// The predictive decoder's state: the predictor over the decoded past and
/// the corrections. A frame is predicted ([`predict`](Self::predict) in the
/// decoder, [`choose`](Self::choose) in the encoder, which knows the true
/// frame), then [`finish`](Self::finish)ed: corrected and committed.
pub struct Predictive {
    pub predictor: Predictor,
    pub corrections: Corrections,
}

impl Predictive {
    pub fn new(header: &Header, st: Stencils) -> Predictive {
        let predictor = Predictor::new(st.clone(), header.anchors.clone()).with_max_lag(header.max_lag);
        Predictive { predictor, corrections: Corrections::of(header, st) }
    }

    /// Version 13: the bones of a file with a skin (`weights`, its `SKIN`
    /// chunk), before its first frame.
    pub fn set_skin(&mut self, header: &Header, weights: &SkinWeights) -> Result<()> {
        let info =
            header.skin.as_ref().ok_or_else(|| Error::Argument("skin weights for a file without bones".into()))?;
        let grid = Grid::new(header.grid as usize)?;
        self.predictor.set_skin(Some(SkinnedPredictor::new(grid, info, weights)?));
        Ok(())
    }

    /// Starts afresh, as at frame 0: at a random-access point (format
    /// version 10) the decoder forgets the decoded past and the previous
    /// correction pictures.
    pub fn reset(&mut self) {
        self.predictor.reset();
        self.corrections.reset();
    }

    /// The decoder's prediction of a frame with the file's predictor `code`.
    pub fn predict(&mut self, code: PredictorCode, values: &Values, anchors: &[Vec3]) -> Result<Vec<Vec3>> {
        let seed = values.seed();
        self.predictor.predict(code, seed.as_deref(), values.get(StreamName::H), anchors)
    }

    /// The encoder's prediction: of the extrapolations `allowed` and up to
    /// `max_steps` H steps, the one closest to `truth`.
    pub fn choose(
        &mut self,
        allowed: &[Extrapolation],
        max_steps: u8,
        values: &Values,
        anchors: &[Vec3],
        truth: &[Vec3],
    ) -> Result<(PredictorCode, Vec<Vec3>)> {
        let seed = values.seed();
        self.predictor.closest(allowed, max_steps, seed.as_deref(), values.get(StreamName::H), anchors, truth)
    }

    /// Adds the decoded correction (if the frame has one) to the prediction
    /// `x` after `steps` = (filter passes, relaxation passes), and records
    /// the result as decoded.
    pub fn finish(
        &mut self,
        mut x: Vec<Vec3>,
        correction: Option<Pictures>,
        steps: (u8, u8),
        anchors: &[Vec3],
    ) -> Vec<Vec3> {
        if let Some(d) = correction {
            self.corrections.apply(&mut x, d, steps);
        }
        self.predictor.commit(x.clone(), anchors);
        x
    }
}

/// How a file's frames are rebuilt from their values.
enum Rebuild {
    Gv,
    Predictive(Box<Predictive>),
    Paper(PaperSolver),
    /// Version 20: a file without streams has no grid to rebuild; its
    /// vertices are the residual's from the header's origin.
    Nothing,
}

/// Rebuilds grid positions from one frame's values, frame after frame.
pub struct Reconstructor {
    rebuild: Rebuild,
}

impl Reconstructor {
    /// Checks that the file has the streams `solver` needs.
    pub fn new(h: &Header, solver: SolverKind) -> Result<Reconstructor> {
        let require = |names: &[StreamName]| -> Result<()> {
            for &name in names {
                h.stream(name).ok_or_else(|| Error::Argument(format!("{:?} file without stream {name}", h.codec)))?;
            }
            Ok(())
        };
        let rebuild = match h.codec {
            CodecKind::Gv if h.streams.is_empty() => Rebuild::Nothing,
            CodecKind::Gv => {
                require(&POSITION)?;
                Rebuild::Gv
            }
            CodecKind::Cgv => {
                // Motion-corrected files may leave out H and λ (version 3),
                // which only the paper's solver and H steps read.
                let motion = h.corrections == CorrectionMode::Motion;
                if solver == SolverKind::Paper && motion && h.stream(StreamName::H).is_none() {
                    return Err(Error::Argument(
                        "the paper's solver needs H and lambda, which this motion-corrected file leaves out \
                         (decode it with the cgv solver)"
                            .into(),
                    ));
                }
                if !motion || solver == SolverKind::Paper {
                    require(&[StreamName::H, StreamName::Lambda])?;
                }
                require(&SEED)?;
                let st = Stencils::new(Grid::new(h.grid as usize)?);
                match solver {
                    SolverKind::Predictive => Rebuild::Predictive(Box::new(Predictive::new(h, st))),
                    SolverKind::Paper => Rebuild::Paper(PaperSolver::new(st, h.anchors.clone())),
                }
            }
        };
        Ok(Reconstructor { rebuild })
    }

    /// Version 13: the bones of a file with a skin. Only the predictive
    /// decoder predicts with them (a file with bones has corrections, so it
    /// is decoded by it).
    pub fn set_skin(&mut self, header: &Header, weights: &SkinWeights) -> Result<()> {
        match &mut self.rebuild {
            Rebuild::Predictive(p) => p.set_skin(header, weights),
            _ => Err(Error::Argument("bones need the predictive (cgv) decoder".into())),
        }
    }

    /// Whether [`set_skin`](Self::set_skin) gave the decoder its bones.
    pub fn has_skin(&self) -> bool {
        matches!(&self.rebuild, Rebuild::Predictive(p) if p.predictor.has_skin())
    }

    /// Forgets the frames rebuilt so far (a random-access point).
    pub fn reset(&mut self) {
        match &mut self.rebuild {
            Rebuild::Gv | Rebuild::Nothing => {}
            Rebuild::Predictive(p) => p.reset(),
            Rebuild::Paper(s) => s.reset(),
        }
    }

    /// Frame `f`'s positions from its side data and values.
    pub fn frame(&mut self, f: u32, info: &FrameInfo, values: &Values) -> Result<(Vec<Vec3>, SolveStats)> {
        let anchors: Vec<Vec3> = info.anchors.iter().map(|p| Vec3::from(*p)).collect();
        match &mut self.rebuild {
            Rebuild::Nothing => Ok((Vec::new(), SolveStats::default())),
            Rebuild::Gv => {
                let x = values
                    .xyz(POSITION)
                    .ok_or_else(|| Error::Argument(format!("GV frame {f} lacks a coordinate stream")))?;
                Ok((x, SolveStats::default()))
            }
            Rebuild::Predictive(p) => {
                let code = info.predictor;
                if let Some(unit) = &info.bones {
                    p.predictor.decode_bones(unit).map_err(|e| Error::Argument(format!("frame {f}: {e}")))?;
                }
                let x = p.predict(code, values, &anchors)?;
                let x = p.finish(x, values.corrections(), (info.filter, info.relax), &anchors);
                Ok((x, SolveStats { iterations: code.steps as usize, residual: 0.0, converged: true }))
            }
            Rebuild::Paper(solver) => {
                if let Some(l) = values.get(StreamName::Lambda) {
                    solver.set_lambda(l);
                }
                let hv = values.get(StreamName::H).ok_or_else(|| Error::Argument(format!("frame {f} has no H")))?;
                solver.solve_frame(hv, &anchors, values.seed().as_deref())
            }
        }
    }
}

/// What decoding one frame took.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct FrameStats {
    pub solve: SolveStats,
    pub video_seconds: f64,
    pub solve_seconds: f64,
}

/// Rebuilds a file's frames in order from their side data and decoded luma
/// planes, pushed as they arrive.
pub struct SequenceDecoder {
    header: Header,
    grid: Grid,
    reconstructor: Reconstructor,
    /// Version 11: the loose vertices' decoded past.
    loose: LooseVertices,
    /// Version 17: bones on the source mesh's vertices, and their skinning
    /// of the frame decoded last.
    vertex_bones: Option<SkinnedPredictor>,
    /// Version 18: the residual at the source mesh's vertices.
    vertex_residual: Option<VertexResidual>,
    /// What the decoder adds at the source mesh's vertices when it adds
    /// both the skinning and the residual.
    added: Vec<Vec3>,
    next: u32,
}

impl SequenceDecoder {
    /// Refuses a header whose decoding would need more than
    /// `memory_limit` bytes (see [`decoder_memory`]) before allocating.
    pub fn new(header: Header, solver: SolverKind, memory_limit: u64) -> Result<SequenceDecoder> {
        let needed = decoder_memory(&header, solver);
        if needed > memory_limit {
            return Err(Error::Memory { needed, limit: memory_limit });
        }
        let grid = Grid::new(header.grid as usize)?;
        // The residual codes what the cgv decoder's grid missed; added to
        // another solver's grid it would correct the wrong thing.
        if header.vertex_residual.is_some() && header.codec == CodecKind::Cgv && solver == SolverKind::Paper {
            return Err(Error::Argument(
                "this file's vertex residual is coded against the cgv solver's grid: decode it with the cgv solver"
                    .into(),
            ));
        }
        let reconstructor = Reconstructor::new(&header, solver)?;
        let loose = LooseVertices::for_header(&header);
        let vertices = header.source_mesh.map_or(0, |m| m.vertices as usize);
        let vertex_residual = header.vertex_residual.map(|r| VertexResidual::new(r.step, vertices));
        Ok(SequenceDecoder {
            header,
            grid,
            reconstructor,
            loose,
            vertex_bones: None,
            vertex_residual,
            added: Vec::new(),
            next: 0,
        })
    }

    pub fn header(&self) -> &Header {
        &self.header
    }

    pub fn grid(&self) -> Grid {
        self.grid
    }

    /// The frame [`push_frame`](Self::push_frame) rebuilds next.
    pub fn next_index(&self) -> u32 {
        self.next
    }

    /// Makes random-access point `f` the frame [`push_frame`](Self::push_frame)
    /// rebuilds next, forgetting the frames rebuilt so far: a seek. The
    /// caller's H.264 decoders restart there too (each stream's picture at
    /// `f` is an IDR picture).
    pub fn seek(&mut self, f: u32) -> Result<()> {
        let h = &self.header;
        if f >= h.frames || !h.is_random_access_point(f) {
            let segments = if h.segments.is_empty() { String::new() } else { format!(" and at {:?}", h.segments) };
            return Err(Error::Argument(format!(
                "frame {f} is not a random-access point (the file has one every {} frames{segments})",
                h.random_access.unwrap_or(h.frames)
            )));
        }
        self.restart();
        self.next = f;
        Ok(())
    }

    /// Rebuilds the next frame from its side data and each stream's decoded
    /// luma plane (the stream's size squared, row-major, see
    /// [`StreamInfo::size`](crate::format::StreamInfo::size); `None` where the
    /// stream has no frame).
    pub fn push_frame(&mut self, info: &FrameInfo, lumas: &[Option<Vec<u8>>]) -> Result<(Vec<Vec3>, SolveStats)> {
        let (f, h) = (self.next, &self.header);
        if f >= h.frames {
            return Err(Error::Argument("no frames left".into()));
        }
        if lumas.len() != h.streams.len() {
            return Err(Error::Video(format!("{} pictures for {} streams", lumas.len(), h.streams.len())));
        }
        for (s, luma) in lumas.iter().enumerate() {
            let n = (h.streams[s].size(h.grid) as usize).pow(2);
            let problem = match (h.stream_has_frame(s, f), luma) {
                (true, Some(l)) if l.len() != n => format!("a picture of {} samples, not {n}", l.len()),
                (true, None) => "no picture".into(),
                (false, Some(_)) => "a picture the stream does not have".into(),
                _ => continue,
            };
            return Err(Error::Video(format!("stream {s} frame {f}: {problem}")));
        }
        if h.skin.is_some() && !self.has_skin() {
            return Err(Error::Argument("a file with bones decoded without its skin weights".into()));
        }
        if f > 0 && h.is_random_access_point(f) {
            self.restart();
        }
        // Read before the decoder's state moves: a unit that does not decode
        // leaves it where it was.
        let residual = self.vertex_residual_unit(info)?;
        let h = &self.header;
        if let Some(b) = &mut self.vertex_bones {
            let unit = info.bones.as_deref().unwrap_or_default();
            b.decode(unit).map_err(|e| Error::Argument(format!("frame {f}: {e}")))?;
        }
        let vals = frame_values(h, lumas, info.correction_scale)?;
        let out = self.reconstructor.frame(f, info, &Values::new(h, &vals).with_seed_origin(info.seed_origin))?;
        match (&info.loose, h.loose_vertices()) {
            (Some(bytes), Some(count)) => {
                let l = LooseFrame::parse(bytes, count, 0).map_err(|e| Error::Argument(format!("frame {f}: {e}")))?;
                let grid = if h.loose_follow_grid() { &out.0[..] } else { &[] };
                self.loose.decode(&l, grid)?;
            }
            (None, None) => {}
            _ => return Err(Error::Argument(format!("frame {f}'s loose vertices do not match the header's"))),
        }
        self.apply_vertex_residual(residual)?;
        self.next += 1;
        Ok(out)
    }

    /// Every stream and the decoder's state start afresh, as at frame 0.
    fn restart(&mut self) {
        self.reconstructor.reset();
        self.loose.reset();
        self.vertex_bones.iter_mut().for_each(SkinnedPredictor::reset);
        self.vertex_residual.iter_mut().for_each(VertexResidual::reset);
    }

    /// Version 18: the frame's vertex residual unit, decoded (none in files
    /// without one).
    fn vertex_residual_unit(&self, info: &FrameInfo) -> Result<Option<ResidualUnit>> {
        let Some(r) = &self.vertex_residual else { return Ok(None) };
        let (f, values) = (self.next, 3 * r.residual().len());
        let unit = info.residual.as_deref().ok_or_else(|| Error::Argument(format!("frame {f}: no vertex residual")))?;
        let modes = self.header.vertex_residual.map(|r| r.modes()).unwrap_or_default();
        let unit =
            ResidualUnit::parse(unit, values, modes, 0).map_err(|e| Error::Argument(format!("frame {f}: {e}")))?;
        if unit.spatial && !r.spatial() {
            return Err(Error::Argument(format!(
                "frame {f}: a spatial vertex residual decoded without the source mesh"
            )));
        }
        Ok(Some(unit))
    }

    /// Version 18: the frame's residual, and with bones on the vertices its
    /// sum with the skinning ([`Self::at_vertices`]: the decoded vertex is
    /// the grid's rebuild plus that sum).
    fn apply_vertex_residual(&mut self, unit: Option<ResidualUnit>) -> Result<()> {
        let (Some(r), Some(unit)) = (&mut self.vertex_residual, unit) else { return Ok(()) };
        r.apply(&unit).map_err(|e| Error::Argument(e.into()))?;
        if let Some(s) = self.vertex_bones.as_ref().and_then(SkinnedPredictor::skinned) {
            self.added.clear();
            self.added.extend(s.iter().zip(r.residual()).map(|(s, r)| *s + *r));
        }
        Ok(())
    }

    /// Version 13: the file's skin weights (its `SKIN` chunk), needed
    /// before the first frame of a file with bones.
    pub fn set_skin(&mut self, weights: &SkinWeights) -> Result<()> {
        match &self.header.skin {
            Some(info) if info.on_vertices() => {
                self.vertex_bones = Some(SkinnedPredictor::on_vertices(info, weights)?);
                Ok(())
            }
            _ => self.reconstructor.set_skin(&self.header, weights),
        }
    }

    /// Whether [`set_skin`](Self::set_skin) gave the decoder its bones.
    pub fn has_skin(&self) -> bool {
        self.reconstructor.has_skin() || self.vertex_bones.is_some()
    }

    /// What the decoder adds at the source mesh's vertices to the grid's
    /// rebuild, at the frame decoded last, for
    /// [`SourceMeshDecoder::vertices`]: the bones' skinning (version 17),
    /// the vertex residual (version 18), or their sum; none in files with
    /// neither.
    pub fn at_vertices(&self) -> Option<&[Vec3]> {
        let skinned = self.vertex_bones.as_ref().and_then(SkinnedPredictor::skinned);
        match (skinned, &self.vertex_residual) {
            (Some(_), Some(_)) => Some(&self.added),
            (None, Some(r)) => Some(r.residual()),
            (s, None) => s,
        }
    }

    /// Version 17: the bones on the source mesh's vertices (their rest
    /// pose, weights and the last frame's transforms).
    pub fn vertex_bones(&self) -> Option<&SkinnedPredictor> {
        self.vertex_bones.as_ref()
    }

    /// The file's source mesh (its `SMSH` chunk), needed before the first
    /// frame where the decoder uses it: version 11's loose vertices follow
    /// its anchors, version 19's spatial residual walks its faces.
    pub fn set_source_mesh(&mut self, mesh: &SourceMesh) -> Result<()> {
        if self.header.loose_vertices().is_some() {
            self.loose.set_anchors(&mesh.loose_anchors, self.grid.len())?;
        }
        if let (Some(r), true) = (&mut self.vertex_residual, self.header.vertex_residual.is_some_and(|r| r.spatial)) {
            r.set_faces(&mesh.faces);
        }
        Ok(())
    }

    /// Version 11: the loose vertices of the frame rebuilt last (empty in
    /// files without them).
    pub fn loose(&self) -> &[Vec3] {
        self.loose.positions()
    }
}

/// The input's own mesh that a version-6 file carries, and where its
/// vertices lie on the grid: each decoded grid frame rebuilds them
/// ([`SourcePoints`], the rule the encoder's evaluation uses too).
pub struct SourceMeshDecoder {
    pub topology: Topology,
    pub points: SourcePoints,
    /// Version 11: each vertex's loose vertex plus one, 0 on the grid.
    pub loose_of: Vec<u32>,
    /// Version 20: a file without a grid rebuilds every vertex from this
    /// point (the vertex residual's origin) in place of a grid frame.
    pub origin: Option<Vec3>,
}

impl SourceMeshDecoder {
    pub fn new(grid: Grid, mesh: &SourceMesh) -> SourceMeshDecoder {
        let topology = Topology { vertex_count: mesh.places.len(), faces: mesh.faces.clone() };
        SourceMeshDecoder {
            topology,
            points: SourcePoints::from_places(grid, &mesh.places).with_offsets(mesh.offsets.as_ref()),
            loose_of: mesh.loose_of.clone(),
            origin: None,
        }
    }

    /// The same for a file whose header is `h`: without a grid (version
    /// 20), its vertices start from the residual's origin.
    pub fn for_header(h: &Header, grid: Grid, mesh: &SourceMesh) -> SourceMeshDecoder {
        let origin = h.vertex_residual.and_then(|r| r.origin).map(Vec3::from);
        SourceMeshDecoder { origin, ..SourceMeshDecoder::new(grid, mesh) }
    }

    /// The input's vertices on one decoded grid frame, with its loose
    /// vertices ([`SequenceDecoder::loose`]) and what the decoder adds at
    /// the vertices ([`SequenceDecoder::at_vertices`]: version 17's
    /// skinning, to which the grid frame, what the bones missed, adds, and
    /// version 18's residual).
    pub fn vertices(&self, grid_frame: &[Vec3], loose: &[Vec3], added: Option<&[Vec3]>) -> Vec<Vec3> {
        let mut x = match self.origin {
            Some(o) => vec![o; self.loose_of.len().max(self.topology.vertex_count)],
            None => self.points.apply(grid_frame),
        };
        if let Some(s) = added {
            x.iter_mut().zip(s).for_each(|(x, s)| *x += *s);
        }
        place_loose(&mut x, &self.loose_of, loose);
        x
    }
}

/// Puts each loose vertex where its frame decoded it (`loose_of`: each
/// vertex's loose vertex plus one, 0 where the grid rebuilt it).
pub fn place_loose(vertices: &mut [Vec3], loose_of: &[u32], loose: &[Vec3]) {
    for (x, &k) in vertices.iter_mut().zip(loose_of) {
        if let Some(p) = k.checked_sub(1).and_then(|k| loose.get(k as usize)) {
            *x = *p;
        }
    }
}

/// What an H step's factorization of `LᵀL + w PᵀP` holds for `n` grid
/// samples, over-estimated rather than under (not measured): 25 entries a
/// sample (16 bytes each) in the four copies the assembly makes, and a
/// Cholesky factor of 31 n log₂ n entries (nested dissection's fill on a
/// grid, for the 13-point stencil of the squared Laplacian; 12 bytes each).
/// Files without H take no step and need none of it.
fn factorization_bytes(n: u64) -> u64 {
    let log2 = 64 - n.max(2).leading_zeros() as u64;
    n.saturating_mul(25 * 16 * 4 + 12 * 31 * log2)
}

/// The default of [`SequenceDecoder::new`]'s memory limit: 1 GiB.
pub const DEFAULT_MEMORY_LIMIT: u64 = 1 << 30;

/// About the bytes a decoder of this header holds at once, before any
/// frame arrives: per stream a luma plane and its values; per grid sample
/// the decoded past (two frames, `max_lag` smoothed velocities, the motion
/// corrections' previous picture, the tangential coefficients) and, for H
/// steps and the paper's solver, their factorization or L-BFGS history;
/// a version-6 source mesh with its rebuilt vertices, version 11's loose
/// vertices (two frames and one being decoded), a version-8
/// appearance (texture coordinates and the texture image's bytes), and
/// version 13's bones.
pub fn decoder_memory(h: &Header, solver: SolverKind) -> u64 {
    let n = u64::from(h.grid) * u64::from(h.grid);
    let streams = h.streams.len() as u64 * n * (1 + 4);
    let frame = 12 * n;
    let past = match (h.codec, solver) {
        (CodecKind::Gv, _) => 2 * frame,
        (CodecKind::Cgv, SolverKind::Predictive) => {
            let factor = if h.stream(StreamName::H).is_some() { factorization_bytes(n) } else { 0 };
            (4 + u64::from(h.max_lag)) * frame + 8 * n + factor
        }
        (CodecKind::Cgv, SolverKind::Paper) => (4 + 2 * 8) * 3 * 8 * n,
    };
    let source = h.source_mesh.map_or(0, |m| u64::from(m.vertices) * 44 + u64::from(m.faces) * 24);
    // Version 18: the residual, its sum with the skinning, and a unit's
    // values; version 19's walk (a vertex's guess) and what rebuilding a
    // spatial unit holds (each vertex's known and rebuilt integers, and
    // those laid out again), and while the walk is made, a copy of the
    // faces and the faces around each vertex.
    let residual = h.vertex_residual.map_or(0, |r| {
        let (per_vertex, per_face) = if r.spatial { (36 + 20 + 48 + 5, 24) } else { (36, 0) };
        h.source_mesh.map_or(0, |m| u64::from(m.vertices) * per_vertex + u64::from(m.faces) * per_face)
    });
    let loose = u64::from(h.loose_vertices().unwrap_or(0)) * 3 * 12;
    let look = h.appearance.as_ref().map_or(0, |a| {
        let vertices = h.source_mesh.map_or(0, |m| u64::from(m.vertices));
        vertices * 8 + a.texture.as_ref().map_or(0, |t| u64::from(t.bytes))
    });
    // Version 13: four influences a sample, one bone's expanded field while
    // they are chosen, the rest pose and three skinned frames.
    let skin = match h.skin {
        // The weights, rest pose and skinning of each vertex.
        Some(s) if s.on_vertices() => h.skin_samples() as u64 * 64,
        // Version 21: the chunk's influences kept beside a point's, and
        // while a point's are read, its expanded ones and their members.
        Some(s) if s.point_weights => 3 * n * 32 + n * 8 + n * 4 + 4 * frame,
        Some(_) => n * 32 + n * 4 + 4 * frame,
        None => 0,
    };
    streams + past + source + look + loose + skin + residual
}

//! Step 4: every frame quantized and coded as H.264, stream by stream; for
//! the predictive decoder, the closed loop: the frame is predicted from
//! what was decoded so far, the error coded as corrections, and the
//! decoder's step ([`Predictive`]) run on the decoded corrections.

use super::analyse::{features, seed_origin, values};
use super::plan::Plan;
use super::slide::Surface;
use super::{EncodeOptions, SEED_MIN_QP, SEED_QP_OFFSET};
use crate::codec::corrections::Pictures;
use crate::codec::h264::{Decoder as H264Decoder, Encoder as H264Encoder};
use crate::codec::loose::{step_for as loose_step, LooseVertices};
use crate::codec::reconstruct::{frame_values, Predictive, SourceMeshDecoder, Values};
use crate::codec::vertex_residual::VertexResidual;
use crate::error::{Error, Result};
use crate::format::stream::{CORRECTION, POSITION};
use crate::format::vertex_residual::VertexResidualInfo;
use crate::format::{self, Coverage, FrameInfo, Header, Offsets, SkinWeights, SourceMesh, StreamInfo, StreamName};
use crate::geometry_image::GeometryImage;
use crate::grid::{Grid, Stencils};
use crate::mesh::FrameSource;
use crate::output::Sink;
use crate::resample::SourcePoints;
use glam::Vec3;

/// What the coded file is made of (its bytes went to the sink).
#[derive(Default)]
pub(super) struct Coded {
    /// The file's size.
    pub bytes: usize,
    /// Bytes of H.264 per stream (`name`, or `name/2` for a second layer).
    pub stream_bytes: Vec<(String, usize)>,
    /// Frame chunk bytes besides the access units.
    pub side_bytes: usize,
    /// The source mesh chunk's bytes.
    pub source_mesh_bytes: usize,
    /// The skin weights' bytes: the chunk's, and version 21's at the
    /// random-access points.
    pub skin_bytes: usize,
    /// The frames' own meshes' bytes (version 16).
    pub frame_mesh_bytes: usize,
    /// The vertex residual's bytes (version 18).
    pub vertex_residual_bytes: usize,
    pub seconds_coding: f64,
}

/// The chunks before frame 0: the source mesh's (and appearance's), as
/// made, the bones' weights and, with bones on the vertices (version 17),
/// each frame's bones unit.
pub(super) struct Chunks<'a> {
    pub source: Option<&'a [u8]>,
    pub skin: Option<&'a SkinWeights>,
    pub bone_units: Option<&'a [Vec<u8>]>,
    /// Version 21: each random-access point's weights unit, in order.
    pub point_units: Option<&'a [Vec<u8>]>,
    /// Version 18: the vertex residual's coder.
    pub residual: Option<ResidualCoding>,
}

/// Version 18: codes each frame's vertex residual against the frame as
/// the decoder rebuilds it at the source mesh's vertices.
pub(super) struct ResidualCoding {
    /// The source mesh as the decoder reads it.
    mesh: SourceMeshDecoder,
    /// Each stored vertex's vertex in the input's frames (none: the same).
    welded: Option<Vec<u32>>,
    coder: VertexResidual,
    step: f32,
}

impl ResidualCoding {
    pub fn new(grid: Grid, mesh: &SourceMesh, welded: Option<Vec<u32>>, step: f32) -> ResidualCoding {
        let mut coder = VertexResidual::new(step, mesh.places.len());
        coder.set_faces(&mesh.faces);
        coder.set_version_20(true);
        ResidualCoding { mesh: SourceMeshDecoder::new(grid, mesh), welded, coder, step }
    }

    pub fn info(&self) -> VertexResidualInfo {
        VertexResidualInfo {
            step: self.step,
            spatial: self.coder.spatial(),
            sparse: true,
            contexts: true,
            origin: None,
        }
    }

    /// The frame's unit: `input` (the source's frame: with bones on the
    /// vertices, what they miss) less the decoded grid rebuilt at the
    /// vertices.
    fn code(&mut self, input: &[Vec3], decoded: Option<&[Vec3]>) -> Result<Vec<u8>> {
        let grid =
            decoded.ok_or_else(|| Error::Video("a vertex residual over a grid the encoder did not decode".into()))?;
        let rebuilt = self.mesh.vertices(grid, &[], None);
        let truth = |k: usize| {
            let v = self.welded.as_ref().map_or(Some(k), |w| w.get(k).map(|&v| v as usize));
            v.and_then(|v| input.get(v)).copied().unwrap_or_default()
        };
        // A loose vertex takes its own decoded place: nothing to code there.
        let loose = |k: usize| self.mesh.loose_of.get(k).is_some_and(|&l| l > 0);
        let target: Vec<Vec3> =
            rebuilt.iter().enumerate().map(|(k, r)| if loose(k) { Vec3::ZERO } else { truth(k) - *r }).collect();
        self.coder.code(&target).ok_or_else(|| Error::Numerical("the vertex residual's range coder failed".into()))
    }
}

/// A sink and the length of what went into it: the index names offsets.
struct Written<'a> {
    sink: &'a mut dyn Sink,
    len: usize,
}

impl Written<'_> {
    fn put(&mut self, bytes: &[u8]) -> Result<()> {
        self.len += bytes.len();
        self.sink.put(bytes)
    }
}

struct Stream {
    info: StreamInfo,
    enc: H264Encoder,
    /// What H.264 kept, as the decoder will see it.
    dec: H264Decoder,
    bytes: usize,
}

/// One H.264 encoder per stream. A bitrate target is shared among the
/// streams by how many frames each codes; the seed, one frame that every
/// later frame is predicted from, is finer than the rest, at a constant QP.
fn open_streams(header: &Header, opts: &EncodeOptions, plan: &Plan) -> Result<Vec<Stream>> {
    let frames = plan.frames as f32;
    let weight = |c: Coverage| match c {
        Coverage::All => 1.0,
        Coverage::Key => plan.key_frames.len() as f32 / frames,
        Coverage::First => plan.raps() as f32 / frames,
    };
    // ... and by how many samples its pictures have.
    let share = |i: &StreamInfo| weight(i.coverage) / 4f32.powi(i.shrink.into());
    let total_weight: f32 = header.streams.iter().map(share).sum();
    let mut streams = Vec::with_capacity(header.streams.len());
    for info in &header.streams {
        let n = info.size(header.grid) as usize;
        let mut vs = opts.video;
        // Rate control spreads a stream's bits over the pictures it has.
        vs.fps = header.fps * if info.coverage == Coverage::Key { weight(Coverage::Key) } else { 1.0 };
        if info.coverage == Coverage::First {
            vs.qp = vs.qp.saturating_sub(SEED_QP_OFFSET).max(SEED_MIN_QP);
            vs.kbps = None;
        } else if let Some(kbps) = opts.video.kbps {
            vs.kbps = Some((kbps * share(info) / total_weight).max(1.0));
        }
        let (enc, dec) = (H264Encoder::new(n, n, &vs)?, H264Decoder::new()?);
        streams.push(Stream { info: info.clone(), enc, dec, bytes: 0 });
    }
    Ok(streams)
}

/// The closed loop's decoder, with the bones as the decoder will have
/// them (and the encoder's version 21 units for its points).
fn predictive_of(header: &Header, st: &Stencils, chunks: &Chunks) -> Result<Predictive> {
    let mut predictive = Predictive::new(header, st.clone());
    if let Some(weights) = chunks.skin.filter(|_| chunks.bone_units.is_none()) {
        predictive.set_skin(header, weights)?;
        if let (Some(units), Some(skin)) = (chunks.point_units, predictive.predictor.skin_mut()) {
            skin.set_point_units(units.to_vec())?;
        }
    }
    Ok(predictive)
}

/// A random-access point: every stream restarts with an IDR picture, and
/// the closed loop and the loose vertices from the seed, as the decoder
/// will.
fn restart(streams: &mut [Stream], predictive: &mut Predictive, loose: &mut LooseVertices) -> Result<()> {
    predictive.reset();
    loose.reset();
    for s in streams {
        s.enc.force_idr()?;
    }
    Ok(())
}

/// The streams but the corrections, and the corrections (with their
/// second layers): these are coded after the rest, which the prediction
/// reads.
fn corrections_last(streams: &[Stream]) -> (Vec<usize>, Vec<usize>) {
    (0..streams.len()).partition(|&k| {
        let base = streams[k].info.refines.map_or(k, usize::from);
        !streams[base].info.name.is_correction()
    })
}

/// A frame's anchors (the samples the header names, on grid frame `g`)
/// and its info so far.
fn frame_info(header: &Header, g: &[Vec3], seed_origin: Option<[f32; 3]>) -> (Vec<Vec3>, FrameInfo) {
    let anchors: Vec<Vec3> = header.anchors.iter().map(|&a| g[a as usize]).collect();
    let xyz = anchors.iter().map(|p| p.to_array()).collect();
    (anchors, FrameInfo { anchors: xyz, seed_origin, ..Default::default() })
}

pub(super) fn code(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    (plan, header): (&Plan, &Header),
    (image, chunks): (&GeometryImage, Chunks),
    st: &Stencils,
    sink: &mut dyn Sink,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<Coded> {
    let map = &image.map;
    // Each chunk goes out as it is made.
    let mut out = Written { sink, len: 0 };
    let (source_mesh_bytes, skin_bytes) = write_prefix(&mut out, src, header, &chunks)?;
    let mut predictive = predictive_of(header, st, &chunks)?;
    let mut streams = open_streams(header, opts, plan)?;
    let mut coded = Coded { source_mesh_bytes, skin_bytes, ..Default::default() };
    let mut residual = chunks.residual;
    let (pre, post) = corrections_last(&streams);
    let mut index = Vec::new();
    let loose_ids = &image.carrier.loose;
    let mut loose = LooseVertices::for_header(header);
    if header.loose_vertices().is_some() {
        loose.set_anchors(&image.loose_anchors, map.grid.len())?;
    }
    for fi in 0..plan.frames {
        let input = src.read_frame(fi)?;
        let g = map.apply(&input);
        let feats = features(plan, st, &g);
        let t = std::time::Instant::now();
        if plan.is_rap(fi) {
            index.push(out.len as u64);
            restart(&mut streams, &mut predictive, &mut loose)?;
            residual.iter_mut().for_each(|r| r.coder.reset());
        }
        let mut coder = FrameCoder::new(header, fi, streams.len());
        let origin = seed_origin(plan, fi, &g);
        coder.code(&mut streams, &pre, &|name| values(name, (&feats, &g), origin, &mut Vec::new()).to_vec())?;
        let (anchors, mut info) = frame_info(header, &g, origin);
        let decoded = if plan.closed_loop {
            let target = LoopTarget { truth: &g, surface: Surface::of_frame(src, opts, fi)?, st };
            Some(close_loop(
                &mut coder,
                &mut streams,
                &post,
                &mut predictive,
                &mut info,
                (opts, plan),
                &anchors,
                target,
            )?)
        } else if residual.is_some() || header.loose_vertices().is_some() {
            decoded_gv(header, &coder)?
        } else {
            None
        };
        info.residual = residual.as_mut().map(|r| r.code(&input, decoded.as_deref())).transpose()?;
        info.mesh =
            header.frame_meshes.then(|| frame_mesh_unit(src, fi, opts, map.grid, (&g, &decoded))).transpose()?;
        if header.loose_vertices().is_some() {
            let truth: Vec<Vec3> = loose_ids.iter().map(|&v| input[v as usize]).collect();
            let finest = residual.as_ref().map(|r| r.step);
            info.loose = Some(code_loose(&mut loose, (header, st, map), (decoded, finest), &truth, &g)?);
        }
        info.bones = chunks.bone_units.and_then(|u| u.get(fi).cloned()).or(info.bones);
        coded.seconds_coding += t.elapsed().as_secs_f64();
        put_frame(&mut out, fi, &info, &coder.units, (&mut streams, &mut coded))?;
        // Version 21: a random-access point's own weights count as the skin's.
        if plan.is_rap(fi) && header.skin.is_some_and(|s| s.point_weights) {
            let weights = info.bones.as_ref().map_or(0, Vec::len);
            (coded.skin_bytes, coded.side_bytes) = (coded.skin_bytes + weights, coded.side_bytes - weights);
        }
        progress("encoding", fi + 1, plan.frames);
    }
    put_end(&mut out, header, &index)?;
    coded.stream_bytes = streams.iter().map(|s| (s.info.label(), s.bytes)).collect();
    coded.bytes = out.len;
    Ok(coded)
}

/// A frame's decoded grid outside the closed loop: GV's x, y, z as the
/// decoder reads them (none in a file without them: the paper's solver
/// runs only in the decoder). The vertex residual and the loose vertices
/// are coded against it.
fn decoded_gv(header: &Header, coder: &FrameCoder) -> Result<Option<Vec<Vec3>>> {
    let vals = frame_values(header, &coder.decoded, 0.0)?;
    Ok(Values::new(header, &vals).xyz(POSITION))
}

/// After the last frame: the random-access index (where the file has
/// points) and the end chunk.
fn put_end(out: &mut Written, header: &Header, index: &[u64]) -> Result<()> {
    if header.random_access.is_some() {
        out.put(&format::write_index(index))?;
    }
    out.put(&format::write_chunk(format::TAG_END, 0, header.frames, &[]))
}

/// Writes frame `f`'s chunk (its side data `info` and access units
/// `units`, one slot a stream) and counts its bytes: each stream's, the
/// frame mesh's, the vertex residual's and the rest of the chunk's.
fn put_frame(
    out: &mut Written,
    f: usize,
    info: &FrameInfo,
    units: &[Option<Vec<u8>>],
    (streams, tally): (&mut [Stream], &mut Coded),
) -> Result<()> {
    let coded: Vec<&[u8]> = units.iter().flatten().map(Vec::as_slice).collect();
    let chunk = format::write_frame(f as u32, info, &coded);
    for (k, au) in units.iter().enumerate() {
        streams[k].bytes += au.as_ref().map_or(0, Vec::len);
    }
    let mesh = info.mesh.as_ref().map_or(0, Vec::len);
    let residual = info.residual.as_ref().map_or(0, Vec::len);
    tally.side_bytes += chunk.len() - coded.iter().map(|u| u.len()).sum::<usize>() - mesh - residual;
    tally.frame_mesh_bytes += mesh;
    tally.vertex_residual_bytes += residual;
    out.put(&chunk)
}

/// Low bits a frame mesh's places leave zero: 10 bits a coordinate (8 steps
/// a cell at N = 128); the offsets take up what the rounding moves.
const FRAME_PLACE_ZERO_BITS: u32 = 22;
/// A frame mesh's finest offset step, in diagonals: its rounding moves the
/// vertices 0.005 % RMS, far below any rate's error. Measured on samba's
/// remeshed frames (about 6,000 vertices, N = 128): places with 16 zero
/// bits and offsets at 4e-5 took 52.6 KB a frame, 22 bits 44.0 KB, and
/// offsets at 1e-4 41.0 KB (2.5e-4: 37.9 KB, 0.012 %); without offsets
/// the vertices lie on the grid, 0.19 % RMS off, in 36.9 KB.
const FRAME_OFFSET_STEP: f32 = 1e-4;

/// Frame `f`'s own mesh unit (version 16): its faces, its vertices' places
/// and their offsets from the uncompressed grid frame `registered` (from
/// the `decoded` one where the samples slid), as the source mesh of a
/// registered file has them from its reference frame.
fn frame_mesh_unit(
    src: &dyn FrameSource,
    f: usize,
    opts: &EncodeOptions,
    grid: Grid,
    (registered, decoded): (&[Vec3], &Option<Vec<Vec3>>),
) -> Result<Vec<u8>> {
    // Slid samples lie elsewhere on the surface than the grid coded: the
    // frame's own vertices are then placed on what the decoder has.
    let g = decoded.as_deref().filter(|_| opts.slides(f)).unwrap_or(registered);
    let mesh = src.frame_mesh(f)?.ok_or_else(|| {
        Error::Argument(format!(
            "{}: frame meshes asked for, but frame {f} has no mesh of its own (only a registered capture, \
             `--unregistered`, has)",
            src.label().display()
        ))
    })?;
    // The vertices renumbered in the order the faces' walk first uses them.
    let order = format::frame_mesh::first_use_order(&mesh.faces, mesh.places.len());
    let mut places = vec![[0u32; 2]; order.len()];
    let mut positions = vec![Vec3::ZERO; order.len()];
    for (v, &n) in order.iter().enumerate() {
        places[n as usize] = mesh.places[v].map(|q| crate::resample::coarser_place(q, FRAME_PLACE_ZERO_BITS));
        positions[n as usize] = mesh.positions[v];
    }
    let faces = mesh.faces.iter().map(|f| f.map(|v| order[v as usize])).collect();
    let offsets = SourcePoints::from_places(grid, &places).offsets_to(g, &positions);
    let finest = crate::mesh::Bounds::of(&positions).diagonal() * FRAME_OFFSET_STEP;
    let coded = SourceMesh {
        faces,
        places,
        offsets: Offsets::quantize(&offsets, finest),
        loose_of: Vec::new(),
        loose_anchors: Vec::new(),
    };
    Ok(format::frame_mesh::to_unit(&coded))
}

/// What comes before frame 0: the header, the source mesh's chunks and the
/// skin weights'. Returns the bytes of the last two.
fn write_prefix(out: &mut Written, src: &dyn FrameSource, header: &Header, chunks: &Chunks) -> Result<(usize, usize)> {
    out.put(&format::write_header(header).map_err(|e| Error::Container { path: src.label().into(), source: e })?)?;
    out.put(chunks.source.unwrap_or_default())?;
    let skin = match (chunks.skin, &header.skin) {
        (Some(w), Some(info)) => format::write_skin(w, info),
        _ => Vec::new(),
    };
    out.put(&skin)?;
    Ok((chunks.source.map_or(0, <[u8]>::len), skin.len()))
}

/// A frame's loose vertices coded against their prediction on the decoded
/// grid (`decoded`: the closed loop's or GV's, [`decoded_gv`]), on a step no
/// coarser than `finest` (the vertex residual's, where the file has one:
/// the loose vertices come as close as the others).
fn code_loose(
    loose: &mut LooseVertices,
    (header, st, map): (&Header, &Stencils, &crate::resample::SampleMap),
    (decoded, finest): (Option<Vec<Vec3>>, Option<f32>),
    truth: &[Vec3],
    g: &[Vec3],
) -> Result<Vec<u8>> {
    let diagonal = f64::from(header.source.diagonal);
    // The paper's solver runs only in the decoder: its grid error is
    // unknown here, and a thousandth of the diagonal stands in.
    let normal = decoded.as_deref().map_or(1e-3 * diagonal, |x| normal_error(st, x, g, &map.on_input));
    let grid = match (header.loose_follow_grid(), decoded.as_deref()) {
        (true, Some(x)) => x,
        (true, None) => return Err(Error::Video("loose vertices follow a grid the encoder did not decode".into())),
        (false, _) => &[],
    };
    let step = loose_step(normal, diagonal).min(finest.unwrap_or(f32::INFINITY));
    Ok(loose.code(truth, step, grid).to_bytes())
}

/// The typical error of the decoded grid along the true surface's normal
/// (a sample that slides along the surface moves it little): the median
/// absolute error over the samples on the input, times 1.4826, a normal
/// distribution's standard deviation. The mean square was 3x the surface
/// distance on wolf, led by a few samples where the map stretches.
fn normal_error(st: &Stencils, decoded: &[Vec3], truth: &[Vec3], on_input: &[bool]) -> f64 {
    let mut e: Vec<f32> = (0..truth.len().min(decoded.len()))
        .filter(|&v| on_input.get(v).copied().unwrap_or(true))
        .map(|v| {
            let (xu, xv) = st.tangents(truth, v);
            (decoded[v] - truth[v]).dot(xu.cross(xv).normalize_or_zero()).abs()
        })
        .collect();
    if e.is_empty() {
        return 0.0;
    }
    let mid = e.len() / 2;
    let (_, median, _) = e.select_nth_unstable_by(mid, f32::total_cmp);
    1.4826 * f64::from(*median)
}

/// What a frame's closed loop aims at: the true grid frame, and where
/// the samples may slide ([`EncodeOptions::slide`]) the frame's own mesh.
struct LoopTarget<'a> {
    truth: &'a [Vec3],
    surface: Option<Surface>,
    st: &'a Stencils,
}

/// The closed loop at one frame: predict from the decoded past and what
/// the frame decoded so far, code the error as corrections (`post`), and run
/// the decoder's step on the decoded corrections; `info` gets the frame's
/// predictor, filter and correction scale. Returns the decoded frame.
#[allow(clippy::too_many_arguments)]
fn close_loop(
    coder: &mut FrameCoder,
    streams: &mut [Stream],
    post: &[usize],
    predictive: &mut Predictive,
    info: &mut FrameInfo,
    (opts, plan): (&EncodeOptions, &Plan),
    anchors: &[Vec3],
    target: LoopTarget,
) -> Result<Vec<Vec3>> {
    let truth = target.truth;
    let header = coder.header;
    let vals = frame_values(header, &coder.decoded, 0.0)?;
    let values = Values::new(header, &vals).with_seed_origin(info.seed_origin);
    // The bones' transforms (every frame of a file with them), then the
    // predictor that lands closest to the true frame.
    info.bones = predictive.predictor.encode_bones(truth);
    let (code, pred) = predictive.choose(plan.allowed, opts.max_steps, &values, anchors, truth)?;
    let slid;
    let truth = match &target.surface {
        Some(surface) => {
            slid = super::slide::slid(target.st, truth, &pred, surface);
            &slid
        }
        None => truth,
    };
    let err: Vec<Vec3> = truth.iter().zip(&pred).map(|(p, q)| *p - *q).collect();
    let corrections = &predictive.corrections;
    let scale = if plan.motion { 0.0 } else { correction_scale(&corrections.world_pictures(&err, 1.0)) };
    let world = corrections.world_pictures(&err, scale);
    // x, y, z first; the normal picture carries what they left, as decoded.
    let is_normal = |k: &usize| {
        let base = streams[*k].info.refines.map_or(*k, usize::from);
        streams[base].info.name == StreamName::Dn
    };
    let (normal_ks, world_ks): (Vec<usize>, Vec<usize>) = post.iter().partition(|k| is_normal(k));
    coder.code(streams, &world_ks, &|name| world[name.axis().unwrap_or(0)].clone())?;
    if !normal_ks.is_empty() {
        let vals = frame_values(header, &coder.decoded, scale)?;
        if let Some(decoded) = Values::new(header, &vals).pictures(&CORRECTION) {
            let normal = corrections.normal_picture(&pred, &err, &decoded, scale);
            coder.code(streams, &normal_ks, &|_| normal.clone())?;
        }
    }
    let vals = frame_values(header, &coder.decoded, scale)?;
    let correction = Values::new(header, &vals).corrections();
    match &correction {
        Some(d) if opts.correction_filter => info.filter = predictive.corrections.best_filter(&pred, d, truth),
        Some(_) => {}
        None if !plan.corrected(coder.frame as usize) => {}
        None => return Err(Error::Video("corrections were not coded".into())),
    }
    if let (Some(d), true, true) = (&correction, opts.correction_filter, plan.layout.normal) {
        // What the decoder's relaxation would do after this filter.
        let mut x = pred.clone();
        predictive.corrections.clone().apply(&mut x, d.clone(), (info.filter, 0));
        info.relax = predictive.corrections.best_relax(&x, truth);
    }
    let decoded = predictive.finish(pred, correction, (info.filter, info.relax), anchors);
    info.predictor = code;
    info.correction_scale = scale;
    Ok(decoded)
}

/// The correction scale: the largest picture value, rounded up to a power
/// of 2^(1/4), so that consecutive frames usually share it (H.264 predicts
/// across frames best when sample values mean the same thing). Clipping the
/// largest errors instead (a 99.5 % quantile) was measured worse: what is
/// clipped comes back doubled through the velocity extrapolation.
fn correction_scale(pictures: &Pictures) -> f32 {
    let m = pictures.iter().flatten().map(|e| e.abs()).filter(|m| m.is_finite()).fold(0.0, f32::max);
    if m <= 0.0 {
        return f32::MIN_POSITIVE.sqrt();
    }
    2f32.powf((m.log2() * 4.0).ceil() / 4.0).max(m)
}

/// One frame's coding: its access units and what the decoder will see.
struct FrameCoder<'a> {
    header: &'a Header,
    frame: u32,
    /// Decoded 8-bit samples per stream (as a decoder gets them).
    decoded: Vec<Option<Vec<u8>>>,
    units: Vec<Option<Vec<u8>>>,
}

impl<'a> FrameCoder<'a> {
    /// Frame `fi`'s coder, nothing coded yet, over `streams` streams.
    fn new(header: &'a Header, fi: usize, streams: usize) -> Self {
        FrameCoder { header, frame: fi as u32, decoded: vec![None; streams], units: vec![None; streams] }
    }

    /// Codes streams `ks` (each layer 2 after its base) with the values
    /// `value_of(name)`, in the natural domain.
    fn code(&mut self, streams: &mut [Stream], ks: &[usize], value_of: &dyn Fn(StreamName) -> Vec<f32>) -> Result<()> {
        for &k in ks {
            if !self.header.stream_has_frame(k, self.frame) {
                continue;
            }
            let info = &streams[k].info;
            let n = info.size(self.header.grid) as usize;
            let q = info.quant;
            let samples: Vec<u8> = match info.refines {
                None => value_of(info.name).iter().map(|&v| q.quantize(v)).collect(),
                Some(base) => {
                    // What layer 1 left.
                    let bq = streams[base as usize].info.quant;
                    let b = self.decoded[base as usize]
                        .as_ref()
                        .ok_or_else(|| Error::Video("layer 2 before its base layer".into()))?;
                    value_of(info.name).iter().zip(b).map(|(&v, &d)| q.quantize(v - bq.dequantize(d))).collect()
                }
            };
            let au = streams[k].enc.encode(&samples)?;
            self.decoded[k] = Some(streams[k].dec.decode(&au, n, n)?);
            self.units[k] = Some(au);
        }
        Ok(())
    }
}

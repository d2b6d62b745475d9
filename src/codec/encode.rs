//! The encoder (native: it drives OpenH264). Two passes over the input, so
//! no more than one frame is held at a time: the first finds each stream's
//! range, the second quantizes and codes.

use super::features::{Features, Stencils};
use super::h264::{Decoder as H264Decoder, Encoder as H264Encoder, VideoSettings};
use super::quant::{Quantizer, Range};
use super::{choose_anchors, VideoDecoder};
use crate::container::{self, CodecKind, Coverage, Header, Settings, SourceInfo, StreamInfo};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::mesh::{analyze, Bounds, FrameSource};
use crate::param::{parameterize, ParamOptions, Parameterization};
use crate::resample::SampleMap;
use crate::solve::SolverKind;
use glam::Vec3;

fn median_abs(v: &[f32]) -> f32 {
    let mut a: Vec<f32> = v.iter().map(|x| x.abs()).collect();
    if a.is_empty() {
        return 0.0;
    }
    let k = a.len() / 2;
    *a.select_nth_unstable_by(k, |x, y| x.total_cmp(y)).1
}

/// How to encode.
#[derive(Debug, Clone)]
pub struct EncodeOptions {
    pub codec: CodecKind,
    pub grid: usize,
    pub video: VideoSettings,
    /// A key frame (λ) every this many frames; 0 for the first frame only.
    pub key_interval: u32,
    /// Code the tangential coefficients a, b every frame (else at key frames).
    /// The project's solver needs them every frame on motions that are not
    /// isometric (all real ones); see docs/RESULTS.md.
    pub intrinsics_every_frame: bool,
    pub anchors: usize,
    /// 1, or 2 for a residual layer on every stream but the seeds.
    pub layers: u8,
    /// Layer-2 range, in layer-1 quantization steps.
    pub residual_steps: f32,
    /// The decoder recorded in the file as intended.
    pub solver: SolverKind,
    pub param: ParamOptions,
    /// The frame whose surface is parameterized.
    pub reference: usize,
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions {
            codec: CodecKind::Cgv,
            grid: 128,
            video: VideoSettings::default(),
            key_interval: 10,
            intrinsics_every_frame: true,
            anchors: 16,
            layers: 1,
            residual_steps: 8.0,
            solver: SolverKind::Cgv,
            param: ParamOptions::default(),
            reference: 0,
        }
    }
}

/// What an encode produced.
#[derive(Debug, Clone, serde::Serialize)]
pub struct EncodeReport {
    pub bytes: usize,
    pub frames: usize,
    /// Bytes of H.264 per stream.
    pub stream_bytes: Vec<(String, usize)>,
    pub anchor_bytes: usize,
    pub parameterization: Parameterization,
    pub seconds_parameterize: f64,
    pub seconds_video: f64,
    pub seconds_total: f64,
}

struct Stream {
    info: StreamInfo,
    enc: H264Encoder,
    /// For a base layer with a refinement: a decoder to see what H.264 kept.
    dec: Option<H264Decoder>,
    bytes: usize,
}

fn values<'a>(name: &str, f: &'a Features, g: &'a [Vec3], scratch: &'a mut Vec<f32>) -> &'a [f32] {
    match name {
        "H" => &f.h,
        "lambda" => &f.lambda,
        "a" => &f.a,
        "b" => &f.b,
        _ => {
            let c = match name {
                "x" | "seed_x" => 0,
                "y" | "seed_y" => 1,
                _ => 2,
            };
            scratch.clear();
            scratch.extend(g.iter().map(|p| p[c]));
            scratch
        }
    }
}

/// Encodes a motion into `.cgv` bytes. `progress(stage, done, total)` is
/// called as frames are processed.
pub fn encode(
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(Vec<u8>, EncodeReport)> {
    let t_start = std::time::Instant::now();
    let grid = Grid::new(opts.grid)?;
    if grid.n < 16 {
        return Err(Error::Argument(format!("grid size {} is below H.264's 16x16 minimum", grid.n)));
    }
    if !(1..=2).contains(&opts.layers) {
        return Err(Error::Argument(format!("layers must be 1 or 2, not {}", opts.layers)));
    }
    if opts.codec == CodecKind::Cgv && opts.anchors < 4 {
        return Err(Error::Argument("CGV needs at least 4 anchors".into()));
    }
    let frames = src.frame_count();
    if opts.reference >= frames {
        return Err(Error::Argument(format!(
            "reference frame {} is past the last frame {}",
            opts.reference,
            frames - 1
        )));
    }
    let topology = src.topology().clone();
    let reference = src.read_frame(opts.reference)?;
    if let Err(problem) = analyze(&topology, &reference).require_sphere() {
        return Err(Error::mesh(src.label(), problem));
    }
    let param = parameterize(&topology, &reference, &opts.param)?;
    let seconds_parameterize = t_start.elapsed().as_secs_f64();
    let map = SampleMap::build(grid, &topology.faces, &param)?;
    let st = Stencils::new(grid);
    let key_frames: Vec<u32> =
        if opts.key_interval == 0 { vec![0] } else { (0..frames as u32).step_by(opts.key_interval as usize).collect() };
    let names: Vec<(&str, Coverage)> = match opts.codec {
        CodecKind::Gv => vec![("x", Coverage::All), ("y", Coverage::All), ("z", Coverage::All)],
        CodecKind::Cgv => vec![
            ("H", Coverage::All),
            ("lambda", Coverage::Key),
            ("a", if opts.intrinsics_every_frame { Coverage::All } else { Coverage::Key }),
            ("b", if opts.intrinsics_every_frame { Coverage::All } else { Coverage::Key }),
            ("seed_x", Coverage::First),
            ("seed_y", Coverage::First),
            ("seed_z", Coverage::First),
        ],
    };

    // Pass 1: ranges.
    let mut ranges = vec![Range::default(); names.len()];
    let mut scales: Vec<Option<f32>> = vec![None; names.len()];
    let mut first_grid = Vec::new();
    let mut scratch = Vec::new();
    for fi in 0..frames {
        let g = map.apply(&src.read_frame(fi)?);
        let feats = if opts.codec == CodecKind::Cgv { st.features(&g) } else { Features::default() };
        let key = key_frames.binary_search(&(fi as u32)).is_ok();
        for (k, (name, cov)) in names.iter().enumerate() {
            let has = match cov {
                Coverage::All => true,
                Coverage::Key => key,
                Coverage::First => fi == 0,
            };
            if has {
                let v = values(name, &feats, &g, &mut scratch);
                if matches!(*name, "a" | "b") {
                    // Companded: the scale is the median magnitude of the first frame.
                    let s = *scales[k].get_or_insert_with(|| median_abs(v).max(1e-6));
                    let y: Vec<f32> = v.iter().map(|x| (x / s).asinh()).collect();
                    ranges[k].add(&y);
                } else {
                    ranges[k].add(v);
                }
            }
        }
        if fi == 0 {
            first_grid = g;
        }
        progress("analysing", fi + 1, frames);
    }
    let anchors = choose_anchors(&first_grid, opts.anchors);

    // Streams: layer 1 for each name, then layer 2 refinements.
    let mut infos: Vec<StreamInfo> = names
        .iter()
        .zip(ranges.iter().zip(&scales))
        .map(|((name, cov), (r, s))| StreamInfo {
            name: name.to_string(),
            layer: 1,
            refines: None,
            quant: Quantizer { asinh_scale: *s, ..r.quantizer() },
            coverage: *cov,
        })
        .collect();
    if opts.layers == 2 {
        for k in 0..names.len() {
            if names[k].1 == Coverage::First {
                continue;
            }
            infos.push(StreamInfo {
                name: names[k].0.to_string(),
                layer: 2,
                refines: Some(k as u16),
                quant: infos[k].quant.residual(opts.residual_steps),
                coverage: names[k].1,
            });
        }
    }
    // A bitrate target is shared among the streams by how many frames each codes.
    let weight = |c: Coverage| match c {
        Coverage::All => 1.0,
        Coverage::Key => key_frames.len() as f32 / frames as f32,
        Coverage::First => 1.0 / frames as f32,
    };
    let total_weight: f32 = infos.iter().map(|i| weight(i.coverage)).sum();
    let mut streams: Vec<Stream> = Vec::with_capacity(infos.len());
    for (k, info) in infos.iter().enumerate() {
        let mut vs = opts.video;
        vs.fps = src.fps();
        if let Some(kbps) = opts.video.kbps {
            vs.kbps = Some((kbps * weight(info.coverage) / total_weight).max(1.0));
        }
        let refined = infos.iter().any(|i| i.refines == Some(k as u16));
        streams.push(Stream {
            info: info.clone(),
            enc: H264Encoder::new(grid.n, grid.n, &vs)?,
            dec: if refined { Some(H264Decoder::new()?) } else { None },
            bytes: 0,
        });
    }

    let header = Header {
        grid: grid.n as u32,
        seam: container::SEAM_RULE.into(),
        frames: frames as u32,
        fps: src.fps(),
        codec: opts.codec,
        streams: infos,
        key_frames: key_frames.clone(),
        anchors: anchors.clone(),
        solver: opts.solver.to_string(),
        settings: Settings {
            qp: opts.video.qp,
            kbps: opts.video.kbps,
            gop: opts.video.gop,
            cabac: opts.video.cabac,
            layers: opts.layers,
            residual_steps: if opts.layers == 2 { opts.residual_steps } else { 0.0 },
        },
        source: SourceInfo {
            label: src.label().display().to_string(),
            vertices: topology.vertex_count as u32,
            faces: topology.faces.len() as u32,
            diagonal: Bounds::of(&reference).diagonal(),
        },
    };
    let mut out =
        container::write_header(&header).map_err(|e| Error::Container { path: src.label().into(), source: e })?;

    // Pass 2: code.
    let mut seconds_video = 0.0;
    let mut anchor_bytes = 0;
    let mut base_decoded: Vec<Option<Vec<f32>>> = vec![None; streams.len()];
    for fi in 0..frames {
        let g = map.apply(&src.read_frame(fi)?);
        let feats = if opts.codec == CodecKind::Cgv { st.features(&g) } else { Features::default() };
        let t = std::time::Instant::now();
        for k in 0..streams.len() {
            if !header.stream_has_frame(k, fi as u32) {
                continue;
            }
            let name = streams[k].info.name.clone();
            let vals = values(&name, &feats, &g, &mut scratch).to_vec();
            let q: Quantizer = streams[k].info.quant;
            let samples: Vec<u8> = match streams[k].info.refines {
                None => vals.iter().map(|&v| q.quantize(q.compress(v))).collect(),
                Some(base) => {
                    // The residual in the base layer's coded domain.
                    let bq = streams[base as usize].info.quant;
                    let decoded = base_decoded[base as usize]
                        .take()
                        .ok_or_else(|| Error::Video("layer 2 before its base layer".into()))?;
                    vals.iter().zip(&decoded).map(|(&v, &d)| q.quantize(bq.compress(v) - d)).collect()
                }
            };
            let au = streams[k].enc.encode(&samples)?;
            if let Some(dec) = streams[k].dec.as_mut() {
                let back = dec.decode(&au, grid.n, grid.n)?;
                base_decoded[k] = Some(back.iter().map(|&s| q.dequantize(s)).collect());
            }
            streams[k].bytes += au.len();
            out.extend_from_slice(&container::write_chunk(container::TAG_ACCESS_UNIT, k as u16, fi as u32, &au));
        }
        seconds_video += t.elapsed().as_secs_f64();
        if !anchors.is_empty() {
            let payload: Vec<u8> =
                anchors.iter().flat_map(|&a| g[a as usize].to_array()).flat_map(f32::to_le_bytes).collect();
            anchor_bytes += payload.len();
            out.extend_from_slice(&container::write_chunk(container::TAG_ANCHORS, 0, fi as u32, &payload));
        }
        progress("encoding", fi + 1, frames);
    }
    out.extend_from_slice(&container::write_chunk(container::TAG_END, 0, frames as u32, &[]));
    let report = EncodeReport {
        bytes: out.len(),
        frames,
        stream_bytes: streams
            .iter()
            .map(|s| (format!("{}{}", s.info.name, if s.info.layer == 2 { "/2" } else { "" }), s.bytes))
            .collect(),
        anchor_bytes,
        parameterization: param,
        seconds_parameterize,
        seconds_video,
        seconds_total: t_start.elapsed().as_secs_f64(),
    };
    Ok((out, report))
}

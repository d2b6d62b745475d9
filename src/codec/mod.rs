//! The CGV and GV codecs (the paper, sections 3 and 5).
//!
//! Both resample the motion on the seamless grid and code scalar streams as
//! grayscale H.264 ([`quant`] for the samples, `h264` natively, WebCodecs in
//! the browser). A **GV** file codes the grid's x, y, z every frame. A **CGV**
//! file codes the mean curvature H every frame; λ ([`features`]) at key
//! frames; the positions of a few anchor samples every frame (float32); at
//! frame 0 only, a coarse copy of the positions (`seed_x/y/z`) that the
//! solvers start from, since a solve needs a first guess and the paper leaves
//! that frame's guess unsaid; and, for the project's decoder, the closed-loop
//! corrections `dx/dy/dz` (see [`crate::solve::cgv`]).

#[cfg(not(target_arch = "wasm32"))]
mod encode;
pub mod features;
#[cfg(not(target_arch = "wasm32"))]
pub mod h264;
pub mod quant;

#[cfg(not(target_arch = "wasm32"))]
pub use encode::{
    auto_corrections, encode, encode_prepared, prepare, EncodeOptions, EncodeReport, Prepared, AUTO_MOTION_QP,
    AUTO_SCALED_BITS, MOTION_MARGIN, PAPER_ANCHORS,
};

use crate::container::{CgvFile, CodecKind, CorrectionMode, Header};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::solve::cgv::{Predictor, PredictorCode};
use crate::solve::{paper::PaperSolver, SolveStats, SolverKind};
use features::Stencils;
use glam::Vec3;

/// Decodes one H.264 access unit into its luma samples (row-major,
/// `width * height`). Natively OpenH264; in the browser, WebCodecs.
pub trait VideoDecoder {
    fn decode(&mut self, access_unit: &[u8], width: usize, height: usize) -> Result<Vec<u8>>;
}

/// Picks anchor samples spread over the surface: farthest-point sampling in
/// 3D from the sample farthest from the centroid. Four or more such points
/// on a real body are not coplanar.
pub fn choose_anchors(grid_positions: &[Vec3], count: usize) -> Vec<u32> {
    let n = grid_positions.len();
    if n == 0 || count == 0 {
        return Vec::new();
    }
    let c = grid_positions.iter().copied().sum::<Vec3>() / n as f32;
    let far = |d: &dyn Fn(usize) -> f32| (0..n).max_by(|&a, &b| d(a).total_cmp(&d(b))).unwrap_or(0);
    let mut chosen = vec![far(&|i| grid_positions[i].distance(c)) as u32];
    let mut dist: Vec<f32> = grid_positions.iter().map(|p| p.distance(grid_positions[chosen[0] as usize])).collect();
    while chosen.len() < count.min(n) {
        let next = far(&|i| dist[i]);
        chosen.push(next as u32);
        for (d, p) in dist.iter_mut().zip(grid_positions) {
            *d = d.min(p.distance(grid_positions[next]));
        }
    }
    chosen
}

/// What decoding one frame took.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct FrameStats {
    pub solve: SolveStats,
    pub video_seconds: f64,
    pub solve_seconds: f64,
}

enum Rebuild {
    Gv,
    Cgv(Predictor, Corrections),
    Paper(PaperSolver),
}

/// Applies the decoded correction streams to the cgv decoder's prediction,
/// by the file's [`CorrectionMode`], after the frame's filter (format
/// version 5): `filter` averaging passes over the correction, as a video
/// codec's in-loop deblocking filter. At the lowest rates H.264 keeps
/// little of a correction but its block edges, and in motion mode they
/// never cancel: each frame adds the difference of two decoded pictures,
/// whose block noise the coarse corrections cannot take back, so it piles
/// up in the decoded surface (samba, N = 256, 67 kbit/s: smoothness 24.5
/// against GV's 22.9). The encoder chooses the filter per frame
/// ([`FILTER_CHOICES`]), so a correction whose detail is real keeps it.
/// Shared by the decoder and the encoder's closed loop.
#[derive(Debug, Clone)]
pub struct Corrections {
    mode: CorrectionMode,
    st: Stencils,
    /// Motion mode: the previous frame's decoded values.
    prev: Option<Vec<Vec3>>,
}

/// The filters (averaging passes) the encoder tries on each frame's
/// correction; it keeps the one that lands closest to the true frame.
pub const FILTER_CHOICES: [u8; 4] = [0, 1, 2, 4];

impl Corrections {
    pub fn new(mode: CorrectionMode, st: Stencils) -> Corrections {
        Corrections { mode, st, prev: None }
    }

    /// The correction this frame's decoded streams carry (`decoded`: the
    /// three streams' values, already scaled in scaled mode), unfiltered.
    fn increment(&self, decoded: &[Vec3]) -> Vec<Vec3> {
        match (self.mode, &self.prev) {
            (CorrectionMode::Motion, Some(prev)) => decoded.iter().zip(prev).map(|(d, q)| *d - *q).collect(),
            _ => decoded.to_vec(),
        }
    }

    /// Adds this frame's correction, after `filter` averaging passes, to
    /// the prediction `x`.
    pub fn apply(&mut self, x: &mut [Vec3], decoded: Vec<Vec3>, filter: u8) {
        let inc = crate::solve::cgv::smooth(&self.st, self.increment(&decoded), filter as usize);
        x.iter_mut().zip(&inc).for_each(|(p, d)| *p += *d);
        if self.mode == CorrectionMode::Motion {
            self.prev = Some(decoded);
        }
    }

    /// The encoder's choice of filter for this frame: of
    /// [`FILTER_CHOICES`], the one with which the correction `decoded`
    /// brings the prediction `x` closest to `truth` (the smallest on a tie).
    pub fn best_filter(&self, x: &[Vec3], decoded: &[Vec3], truth: &[Vec3]) -> u8 {
        let mut inc = self.increment(decoded);
        let mut done = 0;
        let mut best = (f64::INFINITY, 0);
        for f in FILTER_CHOICES {
            inc = crate::solve::cgv::smooth(&self.st, inc, (f - done) as usize);
            done = f;
            let e: f64 = x.iter().zip(&inc).zip(truth).map(|((p, d), t)| (*p + *d).distance_squared(*t) as f64).sum();
            if e < best.0 {
                best = (e, f);
            }
        }
        best.1
    }

    /// The encoder's side of [`apply`](Self::apply): what the correction
    /// streams must carry for this frame's correction to be `err`. Scaled:
    /// `err` over the frame's `scale`. Motion: the running sum, `err` plus
    /// what the previous picture held.
    pub fn stream_values(&self, mut err: Vec<Vec3>, scale: f32) -> Vec<Vec3> {
        match (self.mode, &self.prev) {
            (CorrectionMode::Scaled, _) => err.iter_mut().for_each(|e| *e /= scale),
            (CorrectionMode::Motion, Some(prev)) => err.iter_mut().zip(prev).for_each(|(e, p)| *e += *p),
            (CorrectionMode::Motion, None) => {}
        }
        err
    }
}

fn xyz(x: &[f32], y: &[f32], z: &[f32]) -> Vec<Vec3> {
    x.iter().zip(y).zip(z).map(|((&x, &y), &z)| Vec3::new(x, y, z)).collect()
}

/// The three streams `names` of one frame as positions, if all are there.
pub(crate) fn positions<'a>(get: &impl Fn(&str) -> Option<&'a Vec<f32>>, names: [&str; 3]) -> Option<Vec<Vec3>> {
    Some(xyz(get(names[0])?, get(names[1])?, get(names[2])?))
}

/// Names of the correction streams.
pub const CORRECTION: [&str; 3] = ["dx", "dy", "dz"];
/// Names of the frame-0 seed streams.
pub const SEED: [&str; 3] = ["seed_x", "seed_y", "seed_z"];

/// Turns one frame's decoded 8-bit samples (per stream, `None` where the
/// stream has no frame) into values: dequantize, add each layer 2 to its
/// base, and scale the
/// correction streams by the frame's scale. Shared by the decoder and the
/// encoder's closed loop, so both see the same numbers.
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

/// Decodes a `.cgv` file frame by frame, in order.
pub struct SequenceDecoder<D: VideoDecoder> {
    pub file: CgvFile,
    pub grid: Grid,
    decoders: Vec<D>,
    rebuild: Rebuild,
    next: u32,
}

fn now() -> f64 {
    #[cfg(not(target_arch = "wasm32"))]
    {
        use std::sync::OnceLock;
        static START: OnceLock<std::time::Instant> = OnceLock::new();
        START.get_or_init(std::time::Instant::now).elapsed().as_secs_f64()
    }
    #[cfg(target_arch = "wasm32")]
    {
        0.0
    }
}

impl<D: VideoDecoder> SequenceDecoder<D> {
    /// `make_decoder` creates one video decoder per stream.
    pub fn new(file: CgvFile, solver: SolverKind, mut make_decoder: impl FnMut() -> Result<D>) -> Result<Self> {
        let h = &file.header;
        let grid = Grid::new(h.grid as usize)?;
        let decoders = (0..h.streams.len()).map(|_| make_decoder()).collect::<Result<Vec<_>>>()?;
        let require = |names: &[&str]| -> Result<()> {
            for name in names {
                h.stream(name).ok_or_else(|| Error::Argument(format!("{:?} file without stream {name}", h.codec)))?;
            }
            Ok(())
        };
        let rebuild = match h.codec {
            CodecKind::Gv => {
                require(&["x", "y", "z"])?;
                Rebuild::Gv
            }
            CodecKind::Cgv => {
                // Motion-corrected files may leave out H and λ (version 3),
                // which only the paper's solver and H steps read.
                let motion = h.corrections == CorrectionMode::Motion;
                if solver == SolverKind::Paper && motion && h.stream("H").is_none() {
                    return Err(Error::Argument(
                        "the paper's solver needs H and lambda, which this motion-corrected file leaves out \
                         (decode it with the cgv solver)"
                            .into(),
                    ));
                }
                if !motion || solver == SolverKind::Paper {
                    require(&["H", "lambda"])?;
                }
                require(&SEED)?;
                if CORRECTION.iter().any(|n| h.stream(n).is_some()) {
                    require(&CORRECTION)?;
                }
                let st = Stencils::new(grid);
                match solver {
                    SolverKind::Cgv => {
                        let predictor = Predictor::new(st.clone(), h.anchors.clone()).with_max_lag(h.max_lag);
                        Rebuild::Cgv(predictor, Corrections::new(h.corrections, st))
                    }
                    SolverKind::Paper => Rebuild::Paper(PaperSolver::new(st, h.anchors.clone())),
                }
            }
        };
        Ok(SequenceDecoder { file, grid, decoders, rebuild, next: 0 })
    }

    pub fn frame_count(&self) -> usize {
        self.file.header.frames as usize
    }

    /// Streaming: copies frame `f`'s chunks from `file` (a
    /// [`crate::container::StreamReader`]'s file so far) before it is decoded.
    pub fn take_frame(&mut self, file: &CgvFile, f: u32) -> Result<()> {
        let fi = f as usize;
        let info = file.frames.get(fi).ok_or_else(|| Error::Argument(format!("frame {f} has not arrived")))?;
        if self.file.frames.len() <= fi {
            self.file.frames.resize(fi + 1, Default::default());
        }
        self.file.frames[fi] = info.clone();
        for s in 0..self.file.header.streams.len() {
            if self.file.header.stream_has_frame(s, f) {
                let au = file.units[s].get(fi).ok_or_else(|| Error::Argument(format!("frame {f} has not arrived")))?;
                let dst = &mut self.file.units[s];
                if dst.len() <= fi {
                    dst.resize(fi + 1, Vec::new());
                }
                dst[fi] = au.clone();
            }
        }
        Ok(())
    }

    /// The frame [`next_frame`](Self::next_frame) decodes next.
    pub fn next_index(&self) -> u32 {
        self.next
    }

    /// Decodes every stream's access unit at frame `f` into values.
    pub fn stream_values(&mut self, f: u32) -> Result<Vec<Option<Vec<f32>>>> {
        let h = &self.file.header;
        let n = self.grid.n;
        let mut samples: Vec<Option<Vec<u8>>> = vec![None; h.streams.len()];
        for (s, out) in samples.iter_mut().enumerate() {
            if h.stream_has_frame(s, f) {
                let au = self.file.units[s]
                    .get(f as usize)
                    .ok_or_else(|| Error::Argument(format!("stream {s} frame {f} has not arrived")))?;
                *out = Some(self.decoders[s].decode(au, n, n)?);
            }
        }
        let scale = self.file.frames.get(f as usize).map_or(0.0, |i| i.correction_scale);
        frame_values(h, &samples, scale)
    }

    /// Decodes the next frame: grid positions and statistics.
    pub fn next_frame(&mut self) -> Result<(Vec<Vec3>, FrameStats)> {
        let f = self.next;
        if f >= self.file.header.frames {
            return Err(Error::Argument("no frames left".into()));
        }
        let t0 = now();
        let vals = self.stream_values(f)?;
        let t1 = now();
        let h = &self.file.header;
        let get = |name: &str| -> Option<&Vec<f32>> { h.stream(name).and_then(|s| vals[s].as_ref()) };
        let mut stats = FrameStats { video_seconds: t1 - t0, ..Default::default() };
        let info =
            self.file.frames.get(f as usize).ok_or_else(|| Error::Argument(format!("frame {f} has no side data")))?;
        let anchors: Vec<Vec3> = info.anchors.iter().map(|p| Vec3::from(*p)).collect();
        let seed = positions(&get, SEED);
        let hv = get("H").map(Vec::as_slice);
        let positions = match &mut self.rebuild {
            Rebuild::Gv => positions(&get, ["x", "y", "z"])
                .ok_or_else(|| Error::Argument(format!("GV frame {f} lacks a coordinate stream")))?,
            Rebuild::Cgv(pred, corrections) => {
                let code = PredictorCode::from_bytes(info.predictor, info.lag)?;
                let mut x = pred.predict(code, seed.as_deref(), hv, &anchors)?;
                if let Some(d) = positions(&get, CORRECTION) {
                    corrections.apply(&mut x, d, info.filter);
                }
                pred.commit(x.clone(), &anchors);
                stats.solve = SolveStats { iterations: code.steps as usize, residual: 0.0, converged: true };
                x
            }
            Rebuild::Paper(solver) => {
                if let Some(l) = get("lambda") {
                    solver.set_lambda(l);
                }
                let hv = hv.ok_or_else(|| Error::Argument(format!("frame {f} has no H")))?;
                let (x, st) = solver.solve_frame(hv, &anchors, seed.as_deref())?;
                stats.solve = st;
                x
            }
        };
        stats.solve_seconds = now() - t1;
        self.next += 1;
        Ok((positions, stats))
    }
}

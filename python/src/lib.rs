//! Python bindings of the cgv library (PyO3 and rust-numpy), built by
//! maturin as `cgv._native` and re-exported by the `cgv` package.
//!
//! Arrays come in as numpy arrays (float32 positions of shape (F, V, 3),
//! integer faces of shape (M, 3)); a C-contiguous float32 array is read in
//! place, frame by frame, as the encoder streams it (other dtypes or
//! layouts are converted once). Decoded arrays are handed to numpy without
//! a copy. The GIL is released while the library works, so Python threads
//! (and Ray's workers) run alongside. Every library error is raised as
//! `cgv.Error` (a `ValueError`), or `OSError` for a file that cannot be
//! read, with the library's message, which names the file and the problem.

use cgv::codec::{CodecChoice, EncodeRequest, FileDecoder, GridChoice};
use cgv::format::CorrectionMode;
use cgv::mesh::source::check_frame;
use cgv::mesh::{Frame, FrameSource, OpenOptions, Topology};
use cgv::output::AtomicFile;
use glam::Vec3;
use numpy::{
    AllowTypeChange, PyArray1, PyArrayLike2, PyArrayLike3, PyArrayLikeDyn, PyArrayMethods, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyOSError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::{Path, PathBuf};

pyo3::create_exception!(
    cgv,
    Error,
    PyValueError,
    "An input cgv cannot use (a bad mesh, a malformed .cgv file, an option out of range); the message names the file and the problem."
);

fn raise(e: cgv::Error) -> PyErr {
    match e {
        cgv::Error::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => Error::new_err(e.to_string()),
    }
}

fn invalid(msg: String) -> PyErr {
    Error::new_err(msg)
}

/// A motion held by numpy: frame `i` is read from the array when the
/// encoder asks for it.
struct ArrayFrames<'a> {
    label: PathBuf,
    fps: f32,
    topology: Topology,
    coords: &'a [f32],
}

impl FrameSource for ArrayFrames<'_> {
    fn label(&self) -> &Path {
        &self.label
    }
    fn frame_count(&self) -> usize {
        self.coords.len() / (3 * self.topology.vertex_count)
    }
    fn fps(&self) -> f32 {
        self.fps
    }
    fn topology(&self) -> &Topology {
        &self.topology
    }
    fn kind(&self) -> &'static str {
        "numpy arrays"
    }
    fn read_frame(&self, i: usize) -> cgv::Result<Frame> {
        let n = 3 * self.topology.vertex_count;
        let chunk = self.coords.get(i * n..(i + 1) * n).ok_or_else(|| {
            cgv::Error::Argument(format!("frame {i} is past the last frame {}", self.frame_count() as i64 - 1))
        })?;
        let frame: Frame = chunk.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
        check_frame(&self.label, &self.topology, &frame, None)?;
        Ok(frame)
    }
}

/// Faces of shape (M, 3), every index a vertex of `vertices`.
fn faces_from(faces: &PyArrayLike2<'_, i64, AllowTypeChange>, vertices: usize) -> PyResult<Vec<[u32; 3]>> {
    let a = faces.as_array();
    if a.ncols() != 3 || a.nrows() == 0 {
        return Err(invalid(format!("faces: shape {:?}, expected (M, 3) with M >= 1", a.shape())));
    }
    let mut out = Vec::with_capacity(a.nrows());
    for (k, row) in a.rows().into_iter().enumerate() {
        let mut f = [0u32; 3];
        for (j, &v) in row.iter().enumerate() {
            if v < 0 || v as u64 >= vertices as u64 {
                return Err(invalid(format!("faces[{k}] names vertex {v}, not one of the {vertices} vertices")));
            }
            f[j] = v as u32;
        }
        out.push(f);
    }
    Ok(out)
}

/// Positions of shape (F, V, 3) as one flat slice (borrowed when the array
/// is C-contiguous float32, else copied into `owned`).
fn flat<'a>(frames: &'a PyArrayLike3<'_, f32, AllowTypeChange>, owned: &'a mut Vec<f32>) -> PyResult<&'a [f32]> {
    let shape = frames.shape();
    if shape[2] != 3 || shape[1] < 3 || shape[0] == 0 {
        return Err(invalid(format!("frames: shape {shape:?}, expected (F, V, 3) with F >= 1 and V >= 3")));
    }
    match frames.as_slice() {
        Ok(s) => Ok(s),
        Err(_) => {
            *owned = frames.as_array().iter().copied().collect();
            Ok(owned.as_slice())
        }
    }
}

/// The encode Python keywords ask for, named as `cgv encode`'s flags are
/// (with `_` for `-`; unknown keywords are a `TypeError`), checked for a
/// motion at `fps` (the library's checks: [`EncodeRequest`]).
fn encode_request(options: Option<&Bound<'_, PyDict>>, fps: f32) -> PyResult<EncodeRequest> {
    let mut r = EncodeRequest::default();
    let o = &mut r.base;
    for (key, value) in options.into_iter().flat_map(|d| d.iter()) {
        let key: String = key.extract()?;
        match key.as_str() {
            "codec" => r.codec = CodecChoice::parse(&value.extract::<String>()?).map_err(invalid)?,
            "grid" => {
                r.grid = match value.extract::<String>() {
                    Ok(a) if a == "auto" => GridChoice::Auto,
                    Ok(a) => return Err(invalid(format!("grid {a:?}: expected a size N or \"auto\""))),
                    Err(_) => GridChoice::Size(value.extract()?),
                }
            }
            "qp" => o.video.qp = value.extract()?,
            "kbps" => o.video.kbps = value.extract()?,
            "gop" => o.video.gop = value.extract()?,
            "keyframes" => o.key_interval = value.extract()?,
            "layers" => o.layers = value.extract()?,
            "max_lag" => o.max_lag = value.extract()?,
            "corrections" => {
                r.corrections = match value.extract::<String>()?.as_str() {
                    "auto" => None,
                    "scaled" => Some(CorrectionMode::Scaled),
                    "motion" => Some(CorrectionMode::Motion),
                    c => {
                        return Err(invalid(format!("corrections {c:?}: expected \"auto\", \"scaled\" or \"motion\"")))
                    }
                }
            }
            "correction_shrink" => o.correction_shrink = value.extract()?,
            "source_mesh" => o.source_mesh = value.extract()?,
            "fit_places" => o.fit_places = value.extract()?,
            "random_access" => o.random_access = value.extract()?,
            "bones" => {
                o.bones = match value.extract::<String>() {
                    Ok(a) if a == "auto" => None,
                    Ok(a) => return Err(invalid(format!("bones {a:?}: expected \"auto\" or a count"))),
                    Err(_) => Some(value.extract()?),
                }
            }
            "weights" => {
                o.coarse_weights = match value.extract::<String>()?.as_str() {
                    "auto" => None,
                    "fine" => Some(false),
                    "coarse" => Some(true),
                    w => return Err(invalid(format!("weights {w:?}: expected \"auto\", \"fine\" or \"coarse\""))),
                }
            }
            "target_error" => r.target_error = Some(value.extract::<f64>()?),
            "vertex_residual" => o.vertex_residual = Some(value.extract::<f32>()?),
            _ => {
                return Err(PyTypeError::new_err(format!(
                    "encode() got an unexpected keyword {key:?} (known: codec, grid, qp, kbps, gop, keyframes, layers, \
                     max_lag, corrections, correction_shrink, source_mesh, fit_places, random_access, bones, \
                     weights, target_error, vertex_residual)"
                )))
            }
        }
    }
    r.options(fps).map_err(raise)?;
    Ok(r)
}

/// Where an encode's file goes: back to Python as bytes, or streamed into
/// a file (frames in, chunks out), written atomically.
#[derive(Clone, Copy)]
enum Out<'a> {
    Bytes,
    File(&'a Path),
}

/// What an encode made: the file's bytes, or the size of the file written.
enum Made {
    Bytes(Vec<u8>),
    Written(usize),
}

fn run_encode(py: Python<'_>, src: &dyn FrameSource, r: &EncodeRequest, out: Out<'_>) -> PyResult<Made> {
    use cgv::codec::Made as File;
    let missed =
        |report: &cgv::codec::EncodeReport| report.budget_miss.filter(|m| m.abs() > cgv::codec::BUDGET_TOLERANCE);
    let (made, miss) = py
        .detach(|| -> cgv::Result<(Made, Option<f64>)> {
            match out {
                Out::Bytes => {
                    let e = r.encode(src, &mut || Ok(Vec::new()), &mut |_, _, _| {})?;
                    let (File::Streamed(bytes) | File::Bytes(bytes)) = e.file;
                    Ok((Made::Bytes(bytes), missed(&e.report)))
                }
                Out::File(path) => {
                    let e = r.encode(src, &mut || AtomicFile::create(path), &mut |_, _, _| {})?;
                    let size = match e.file {
                        File::Streamed(f) => f.commit().map(|()| e.report.bytes)?,
                        File::Bytes(b) => cgv::output::write_atomic(path, &b).map(|()| b.len())?,
                    };
                    Ok((Made::Written(size), missed(&e.report)))
                }
            }
        })
        .map_err(|e| invalid(format!("encoding {}: {e}", src.label().display())))?;
    if let Some(m) = miss {
        // As `cgv encode` warns: a reachable budget the rate control missed.
        let msg = format!(
            "the file is {:+.1} % from the budget: neither the rate control nor a constant QP lands it \
             within {} %; the nearest file is kept",
            100.0 * m,
            100.0 * cgv::codec::BUDGET_TOLERANCE
        );
        PyErr::warn(py, &py.get_type::<pyo3::exceptions::PyUserWarning>(), &std::ffi::CString::new(msg)?, 1)?;
    }
    Ok(made)
}

/// The bytes an encode made into `Out::Bytes`.
fn bytes_of(made: Made) -> Vec<u8> {
    match made {
        Made::Bytes(b) => b,
        Made::Written(_) => Vec::new(),
    }
}

/// encode(frames, faces, *, fps=30.0, **options) -> bytes
///
/// Encodes a motion into the bytes of a .cgv file. `frames`: positions of
/// shape (F, V, 3); `faces`: vertex indices of shape (M, 3), the same for
/// every frame. Options, as `cgv encode`'s flags: codec ("auto", also
/// called "cgv", the default; "normal", "predictive", "conformal", "gv", "skinned"),
/// grid (N, or "auto", the default: 256 for a high enough kbps or a
/// target error below N = 128's resampling floor, else 128), qp (default 20) or kbps (a budget the whole file
/// keeps within 5 %, or an error; a UserWarning where neither the rate
/// control nor a constant QP lands a reachable budget and the nearest
/// file is kept), gop,
/// keyframes, layers (1 or 2), max_lag, corrections ("auto",
/// "scaled", "motion"), correction_shrink, source_mesh (default True: the
/// file carries the input's own faces so that decode gives them back),
/// fit_places (default False: as `cgv encode --fit-places`),
/// random_access (seconds between random-access points, default 2; 0 for
/// frame 0 only), bones (as `cgv encode --bones`: a skinning's bones as the
/// predictor, 0 for none), weights (the skinned codec's: "auto", "fine"
/// or "coarse", as `cgv encode --weights`), target_error (instead of qp or kbps: the smallest file whose surface RMS
/// is at most this percentage of the diagonal, as `cgv encode
/// --target-error` finds it), vertex_residual (a percentage of the
/// diagonal: what the video misses at each vertex coded every frame to
/// about that RMS error, as `cgv encode --vertex-residual`).
#[pyfunction]
#[pyo3(signature = (frames, faces, *, fps = 30.0, **options))]
fn encode<'py>(
    py: Python<'py>,
    frames: PyArrayLike3<'py, f32, AllowTypeChange>,
    faces: PyArrayLike2<'py, i64, AllowTypeChange>,
    fps: f32,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyBytes>> {
    let request = encode_request(options, fps)?;
    let mut owned = Vec::new();
    let coords = flat(&frames, &mut owned)?;
    let vertex_count = frames.shape()[1];
    let topology = Topology { vertex_count, faces: faces_from(&faces, vertex_count)? };
    let src = ArrayFrames { label: PathBuf::from("<numpy arrays>"), fps, topology, coords };
    let bytes = bytes_of(run_encode(py, &src, &request, Out::Bytes)?);
    Ok(PyBytes::new(py, &bytes))
}

/// Opens `path` as `cgv encode PATH` does, with the GIL released.
fn open(
    py: Python<'_>,
    path: &Path,
    fps: f32,
    frames: Option<(usize, usize)>,
    fill_holes: bool,
    animation: Option<String>,
) -> PyResult<Box<dyn FrameSource>> {
    let frames = frames.map(|(start, end)| cgv::mesh::FrameSelection { start, end: Some(end) });
    let opts = OpenOptions { fps, animation, fill_holes, frames };
    py.detach(|| cgv::mesh::open_sequence(&path.to_string_lossy(), &opts)).map_err(raise)
}

/// encode_file(path, *, output=None, fps=30.0, frames=None, fill_holes=False, animation=None, **options) -> bytes | int
///
/// Encodes a motion read from `path` (a folder of OBJ files, one OBJ, a
/// glTF animation, or "builtin:walk") exactly as `cgv encode PATH` does
/// with the same options: the same bytes. `frames`: (start, end), end
/// excluded. Options as for `encode`. With `output` (a path) the file is
/// written there as `cgv encode -o` writes it, each frame's chunk as it is
/// coded (memory does not grow with the motion), atomically, and its size
/// in bytes is returned instead of the bytes.
#[pyfunction]
#[pyo3(signature = (path, *, output = None, fps = 30.0, frames = None, fill_holes = false, animation = None, **options))]
#[allow(clippy::too_many_arguments)] // the keywords Python sees
fn encode_file<'py>(
    py: Python<'py>,
    path: PathBuf,
    output: Option<PathBuf>,
    fps: f32,
    frames: Option<(usize, usize)>,
    fill_holes: bool,
    animation: Option<String>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let src = open(py, &path, fps, frames, fill_holes, animation)?;
    let request = encode_request(options, src.fps())?;
    let out = output.as_deref().map_or(Out::Bytes, Out::File);
    Ok(match run_encode(py, src.as_ref(), &request, out)? {
        Made::Bytes(bytes) => PyBytes::new(py, &bytes).into_any(),
        Made::Written(size) => size.into_pyobject(py)?.into_any(),
    })
}

/// (F, V, 3) float32 and (M, 3) uint32 arrays of a motion, moved into numpy.
type Arrays<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>);

fn arrays<'py>(py: Python<'py>, coords: Vec<f32>, frames: usize, faces: &[[u32; 3]]) -> PyResult<Arrays<'py>> {
    let v = coords.len() / (3 * frames.max(1));
    let positions = PyArray1::from_vec(py, coords).reshape([frames, v, 3])?.into_any();
    Ok((positions, faces_array(py, faces)?))
}

/// read_motion(path, *, fps=30.0, frames=None, fill_holes=False, animation=None) -> (positions, faces, fps)
///
/// Reads a motion as `cgv encode` does: positions (F, V, 3) float32, faces
/// (M, 3) uint32, and its frame rate.
#[pyfunction]
#[pyo3(signature = (path, *, fps = 30.0, frames = None, fill_holes = false, animation = None))]
fn read_motion<'py>(
    py: Python<'py>,
    path: PathBuf,
    fps: f32,
    frames: Option<(usize, usize)>,
    fill_holes: bool,
    animation: Option<String>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, f32)> {
    let src = open(py, &path, fps, frames, fill_holes, animation)?;
    let coords = py
        .detach(|| -> cgv::Result<Vec<f32>> {
            let mut coords = Vec::with_capacity(src.frame_count() * src.topology().vertex_count * 3);
            for i in 0..src.frame_count() {
                coords.extend(src.read_frame(i)?.iter().flat_map(|p| p.to_array()));
            }
            Ok(coords)
        })
        .map_err(raise)?;
    let (positions, faces) = arrays(py, coords, src.frame_count(), &src.topology().faces)?;
    Ok((positions, faces, src.fps()))
}

/// One frame's (V, 3) float32 array, moved into numpy.
fn frame_array<'py>(py: Python<'py>, frame: &[Vec3]) -> PyResult<Bound<'py, PyAny>> {
    let coords: Vec<f32> = frame.iter().flat_map(|p| p.to_array()).collect();
    Ok(PyArray1::from_vec(py, coords).reshape([frame.len(), 3])?.into_any())
}

fn faces_array<'py>(py: Python<'py>, faces: &[[u32; 3]]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<u32> = faces.iter().flatten().copied().collect();
    Ok(PyArray1::from_vec(py, flat).reshape([faces.len(), 3])?.into_any())
}

/// MotionReader(path, *, fps=30.0, frames=None, fill_holes=False, animation=None)
///
/// A motion read one frame at a time, for motions too long to hold:
/// ``len(reader)`` frames, ``reader.faces`` (M, 3) uint32, ``reader.fps``,
/// ``reader[i]`` frame i as (V, 3) float32, and iteration over the frames.
/// Memory stays that of one frame whatever the length (``read_motion``
/// returns the whole (F, V, 3) array).
#[pyclass(unsendable)]
struct MotionReader {
    src: Box<dyn FrameSource>,
}

#[pymethods]
impl MotionReader {
    #[new]
    #[pyo3(signature = (path, *, fps = 30.0, frames = None, fill_holes = false, animation = None))]
    fn new(
        py: Python<'_>,
        path: PathBuf,
        fps: f32,
        frames: Option<(usize, usize)>,
        fill_holes: bool,
        animation: Option<String>,
    ) -> PyResult<Self> {
        Ok(MotionReader { src: open(py, &path, fps, frames, fill_holes, animation)? })
    }

    fn __len__(&self) -> usize {
        self.src.frame_count()
    }

    #[getter]
    fn fps(&self) -> f32 {
        self.src.fps()
    }

    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        faces_array(py, &self.src.topology().faces)
    }

    fn __getitem__<'py>(&self, py: Python<'py>, i: isize) -> PyResult<Bound<'py, PyAny>> {
        let n = self.src.frame_count() as isize;
        let k = if i < 0 { i + n } else { i };
        if !(0..n).contains(&k) {
            return Err(pyo3::exceptions::PyIndexError::new_err(format!("frame {i} of a motion of {n} frames")));
        }
        let src = &self.src;
        let frame = py.detach(|| src.read_frame(k as usize)).map_err(raise)?;
        frame_array(py, &frame)
    }
}

/// Decoder(data, *, mesh="auto", memory_limit_mib=1024)
///
/// A .cgv file decoded one frame at a time, for motions too long to hold:
/// ``len(decoder)`` frames, ``decoder.faces`` (M, 3) uint32 of the mesh
/// ``decode`` would give (``mesh`` as there), ``decoder.fps``, iteration
/// over the frames as (V, 3) float32 arrays in order, and
/// ``decoder.seek(frame)`` to continue from there (decoded from its
/// random-access point). Memory stays that of the file and one frame.
#[pyclass(unsendable)]
struct Decoder {
    dec: FileDecoder,
    source: Option<cgv::codec::SourceMeshDecoder>,
    next: usize,
    frames: usize,
    fps: f32,
}

#[pymethods]
impl Decoder {
    #[new]
    #[pyo3(signature = (data, *, mesh = "auto", memory_limit_mib = 1024))]
    fn new(data: &[u8], mesh: &str, memory_limit_mib: u64) -> PyResult<Self> {
        let file = read_cgv(data)?;
        let (frames, fps, solver) = (file.header.frames as usize, file.header.fps, file.header.solver);
        let dec = FileDecoder::with_memory_limit(file, solver, memory_limit_mib << 20).map_err(raise)?;
        let source = pick_mesh(mesh, dec.source_mesh())?;
        Ok(Decoder { dec, source, next: 0, frames, fps })
    }

    fn __len__(&self) -> usize {
        self.frames
    }

    #[getter]
    fn fps(&self) -> f32 {
        self.fps
    }

    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &self.source {
            Some(s) => faces_array(py, &s.topology.faces),
            None => faces_array(py, &self.dec.grid.topology().faces),
        }
    }

    /// Continues from `frame` (the next frame iteration gives).
    fn seek(&mut self, py: Python<'_>, frame: isize) -> PyResult<()> {
        let Some(frame) = usize::try_from(frame).ok().filter(|&f| f < self.frames) else {
            return Err(invalid(format!("seek to frame {frame} of a file of {} frames", self.frames)));
        };
        let dec = &mut self.dec;
        py.detach(|| dec.seek(frame as u32)).map_err(raise)?;
        self.next = frame;
        Ok(())
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(&mut self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        if self.next >= self.frames {
            return Ok(None);
        }
        let (dec, source) = (&mut self.dec, &self.source);
        let x = py
            .detach(|| -> cgv::Result<Vec<Vec3>> {
                let (x, _) = dec.next_frame()?;
                Ok(match source {
                    Some(s) => s.vertices(&x, dec.loose(), dec.at_vertices()),
                    None => x,
                })
            })
            .map_err(raise)?;
        self.next += 1;
        frame_array(py, &x).map(Some)
    }
}

/// The source-mesh decoder `mesh` asks for ("auto", "source" or "grid").
fn pick_mesh(
    mesh: &str,
    carried: Option<cgv::codec::SourceMeshDecoder>,
) -> PyResult<Option<cgv::codec::SourceMeshDecoder>> {
    match (mesh, carried) {
        ("grid", Some(m)) if m.origin.is_some() => {
            Err(invalid("a vertices file has no grid, only your mesh: use mesh=\"source\" or \"auto\"".into()))
        }
        ("grid", _) | ("auto", None) => Ok(None),
        ("source" | "auto", Some(m)) => Ok(Some(m)),
        ("source", None) => Err(invalid("the file carries no source mesh (encode with source_mesh=True)".into())),
        (m, _) => Err(invalid(format!("mesh {m:?}: expected \"auto\", \"source\" or \"grid\""))),
    }
}

fn read_cgv(data: &[u8]) -> PyResult<cgv::format::CgvFile> {
    cgv::format::read(data).map_err(|e| raise(cgv::Error::Container { path: PathBuf::from("<bytes>"), source: e }))
}

/// decode(data, *, mesh="auto", frames=None, memory_limit_mib=1024) -> (positions, faces)
///
/// Decodes the bytes of a .cgv file: positions (F, V, 3) float32 and faces
/// (M, 3) uint32 of the input's own mesh when the file carries it (mesh
/// "auto" or "source"), else, or with mesh="grid", of the N x N grid mesh.
/// frames=(a, b): frames a to b - 1 only, decoded from the random-access
/// point at or before a (format version 10; frame 0 in older files).
#[pyfunction]
#[pyo3(signature = (data, *, mesh = "auto", frames = None, memory_limit_mib = 1024))]
fn decode<'py>(
    py: Python<'py>,
    data: &[u8],
    mesh: &str,
    frames: Option<(usize, usize)>,
    memory_limit_mib: u64,
) -> PyResult<Arrays<'py>> {
    let file = read_cgv(data)?;
    let total = file.header.frames as usize;
    let (a, b) = frames.unwrap_or((0, total));
    let (start, frames) = cgv::mesh::FrameSelection { start: a, end: Some(b) }
        .resolve(total)
        .map_err(|m| invalid(format!("frames=({a}, {b}): {m}")))?;
    let solver = file.header.solver;
    let mut dec = FileDecoder::with_memory_limit(file, solver, memory_limit_mib << 20).map_err(raise)?;
    let source = pick_mesh(mesh, dec.source_mesh())?;
    let faces = source.as_ref().map_or_else(|| dec.grid.topology().faces, |s| s.topology.faces.clone());
    let coords = py
        .detach(|| -> cgv::Result<Vec<f32>> {
            let mut coords = Vec::new();
            dec.seek(start as u32)?;
            for _ in 0..frames {
                let (x, _) = dec.next_frame()?;
                let x = match &source {
                    Some(s) => s.vertices(&x, dec.loose(), dec.at_vertices()),
                    None => x,
                };
                coords.extend(x.iter().flat_map(|p| p.to_array()));
            }
            Ok(coords)
        })
        .map_err(raise)?;
    arrays(py, coords, frames, &faces)
}

/// info(data) -> dict
///
/// What `cgv info FILE.cgv --json` says: version, size and bitrate, the
/// header (grid, frames, fps, streams...), bytes per stream, and each
/// frame's side data.
#[pyfunction]
fn info<'py>(py: Python<'py>, data: &[u8]) -> PyResult<Bound<'py, PyAny>> {
    let summary = read_cgv(data)?.summary().to_string();
    py.import("json")?.call_method1("loads", (summary,))
}

fn points(a: &PyArrayLike2<'_, f32, AllowTypeChange>, what: &str) -> PyResult<Vec<Vec3>> {
    let a = a.as_array();
    if a.ncols() != 3 {
        return Err(invalid(format!("{what}: shape {:?}, expected (V, 3)", a.shape())));
    }
    Ok(a.rows().into_iter().map(|r| Vec3::new(r[0], r[1], r[2])).collect())
}

/// vertex_error(a, b) -> (rms, max)
///
/// Root-mean-square and largest distance between corresponding points of
/// two (V, 3) arrays, in their units (divide by `diagonal` for the
/// relative figures cgv reports).
#[pyfunction]
fn vertex_error(
    a: PyArrayLike2<'_, f32, AllowTypeChange>,
    b: PyArrayLike2<'_, f32, AllowTypeChange>,
) -> PyResult<(f64, f64)> {
    let (a, b) = (points(&a, "a")?, points(&b, "b")?);
    if a.len() != b.len() {
        return Err(invalid(format!("a has {} points and b {}: they must correspond", a.len(), b.len())));
    }
    Ok(cgv::metrics::vertex_error(&a, &b))
}

/// diagonal(points) -> float
///
/// The length of the bounding box's diagonal of a (V, 3) or (F, V, 3)
/// array: what cgv's relative errors divide by.
#[pyfunction]
fn diagonal(points: PyArrayLikeDyn<'_, f32, AllowTypeChange>) -> PyResult<f64> {
    let a = points.as_array();
    if a.shape().last() != Some(&3) {
        return Err(invalid(format!("points: shape {:?}, expected (..., 3)", a.shape())));
    }
    let coords: Vec<f32> = a.iter().copied().collect();
    let p: Vec<Vec3> = coords.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
    Ok(if p.is_empty() { 0.0 } else { cgv::mesh::Bounds::of(&p).diagonal() as f64 })
}

/// surface_distance(a, a_faces, b, b_faces) -> dict
///
/// The symmetric point-to-surface distance between two triangle meshes
/// (area-weighted RMS and max, each way and the larger of the two), as
/// `cgv eval` measures it.
#[pyfunction]
fn surface_distance<'py>(
    py: Python<'py>,
    a: PyArrayLike2<'py, f32, AllowTypeChange>,
    a_faces: PyArrayLike2<'py, i64, AllowTypeChange>,
    b: PyArrayLike2<'py, f32, AllowTypeChange>,
    b_faces: PyArrayLike2<'py, i64, AllowTypeChange>,
) -> PyResult<Bound<'py, PyDict>> {
    let (pa, pb) = (points(&a, "a")?, points(&b, "b")?);
    let (fa, fb) = (faces_from(&a_faces, pa.len())?, faces_from(&b_faces, pb.len())?);
    let d = py.detach(|| cgv::metrics::surface::symmetric(&pa, &fa, &pb, &fb)).map_err(raise)?;
    let out = PyDict::new(py);
    for (k, v) in [
        ("rms", d.rms),
        ("max", d.max),
        ("rms_a_to_b", d.rms_a_to_b),
        ("rms_b_to_a", d.rms_b_to_a),
        ("max_a_to_b", d.max_a_to_b),
        ("max_b_to_a", d.max_b_to_a),
    ] {
        out.set_item(k, v)?;
    }
    Ok(out)
}

/// kg_error(original, decoded) -> (frame_centroid, temporal_mean)
///
/// The KG error (Karni and Gotsman) in percent of two (F, V, 3) sequences,
/// by both definitions `cgv eval` reports: against each frame's centroid
/// (the literature's) and against each vertex's mean over time.
#[pyfunction]
fn kg_error(
    original: PyArrayLike3<'_, f32, AllowTypeChange>,
    decoded: PyArrayLike3<'_, f32, AllowTypeChange>,
) -> PyResult<(f64, f64)> {
    let (o, d) = (original.as_array(), decoded.as_array());
    if o.shape() != d.shape() || o.shape()[2] != 3 {
        return Err(invalid(format!("shapes {:?} and {:?}: expected two equal (F, V, 3)", o.shape(), d.shape())));
    }
    let frame = |a: &numpy::ndarray::ArrayView3<f32>, i: usize| -> Vec<Vec3> {
        a.index_axis(numpy::ndarray::Axis(0), i).rows().into_iter().map(|r| Vec3::new(r[0], r[1], r[2])).collect()
    };
    let mut kg = cgv::metrics::KgError::default();
    for i in 0..o.shape()[0] {
        kg.add_frame(&frame(&o, i), &frame(&d, i));
    }
    Ok((kg.value(), kg.temporal()))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("Error", m.py().get_type::<Error>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("FORMAT_VERSION", cgv::format::VERSION)?;
    m.add_function(wrap_pyfunction!(encode, m)?)?;
    m.add_function(wrap_pyfunction!(encode_file, m)?)?;
    m.add_function(wrap_pyfunction!(read_motion, m)?)?;
    m.add_function(wrap_pyfunction!(decode, m)?)?;
    m.add_function(wrap_pyfunction!(info, m)?)?;
    m.add_function(wrap_pyfunction!(vertex_error, m)?)?;
    m.add_function(wrap_pyfunction!(diagonal, m)?)?;
    m.add_function(wrap_pyfunction!(surface_distance, m)?)?;
    m.add_function(wrap_pyfunction!(kg_error, m)?)?;
    m.add_class::<MotionReader>()?;
    m.add_class::<Decoder>()?;
    Ok(())
}

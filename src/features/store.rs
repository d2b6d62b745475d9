//! Where a registered capture's frames are kept while the capture is
//! registered segment by segment, and read from by the encoder: in memory
//! ([`Registered`], for tests and short clips) or spilled to a temporary
//! file ([`Spilled`], the command line's), so that a long capture's
//! registration holds only the segment in hand, and the encoder one frame
//! at a time.

use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::mesh::{FrameMesh, FrameSource, InMemory, Topology};
use glam::Vec3;
use std::borrow::Cow;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// A registration's frames as it writes them (each frame's grid and own
/// mesh, its vertices placed on its map) and as its outlier pass reads
/// and rewrites them.
pub trait FrameStore {
    /// Frames kept so far.
    fn len(&self) -> usize;
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Adds the next frame.
    fn push(&mut self, grid: Vec<Vec3>, mesh: FrameMesh) -> Result<()>;
    /// Frame `t`'s grid.
    fn grid(&self, t: usize) -> Result<Cow<'_, [Vec3]>>;
    /// Frame `t`'s grid and its vertices' places replaced (as many places
    /// as the frame has vertices).
    fn replace(&mut self, t: usize, grid: Vec<Vec3>, places: Vec<[u32; 2]>) -> Result<()>;
    /// Frame `t`'s grid replaced, its vertices' places kept.
    fn replace_grid(&mut self, t: usize, grid: Vec<Vec3>) -> Result<()>;
    /// The faces of the grid mesh the capture comes back as: the grid's,
    /// less those over its holes ([`super::lids`]).
    fn set_faces(&mut self, faces: Vec<[u32; 3]>);
}

/// A registered capture held in memory: its frames on the grid (a motion
/// on the grid's own mesh, which this source gives), and each frame's own
/// mesh with every vertex's place on that frame's map, turned as its grid
/// was.
pub struct Registered {
    pub grid: InMemory,
    pub meshes: Vec<FrameMesh>,
}

impl Registered {
    /// No frames yet, on `grid`.
    pub fn empty(label: &Path, fps: f32, grid: Grid) -> Registered {
        let grid = InMemory { label: label.into(), fps, topology: grid.topology(), frames: Vec::new() };
        Registered { grid, meshes: Vec::new() }
    }
}

impl FrameStore for Registered {
    fn len(&self) -> usize {
        self.grid.frames.len()
    }
    fn push(&mut self, grid: Vec<Vec3>, mesh: FrameMesh) -> Result<()> {
        self.grid.frames.push(grid);
        self.meshes.push(mesh);
        Ok(())
    }
    fn grid(&self, t: usize) -> Result<Cow<'_, [Vec3]>> {
        self.grid.frames.get(t).map(|g| Cow::Borrowed(g.as_slice())).ok_or_else(|| past_end(t, self.len()))
    }
    fn replace(&mut self, t: usize, grid: Vec<Vec3>, places: Vec<[u32; 2]>) -> Result<()> {
        let len = self.len();
        let (g, m) = self.grid.frames.get_mut(t).zip(self.meshes.get_mut(t)).ok_or_else(|| past_end(t, len))?;
        (*g, m.places) = (grid, places);
        Ok(())
    }
    fn replace_grid(&mut self, t: usize, grid: Vec<Vec3>) -> Result<()> {
        let len = self.len();
        let g = self.grid.frames.get_mut(t).ok_or_else(|| past_end(t, len))?;
        if g.len() != grid.len() {
            let label = self.grid.label.display();
            return Err(Error::Argument(format!(
                "{label}: frame {t} rewritten with {} samples (it has {})",
                grid.len(),
                g.len()
            )));
        }
        *g = grid;
        Ok(())
    }

    fn set_faces(&mut self, faces: Vec<[u32; 3]>) {
        self.grid.topology.faces = faces;
    }
}

impl FrameSource for Registered {
    fn label(&self) -> &Path {
        self.grid.label()
    }
    fn frame_count(&self) -> usize {
        self.grid.frame_count()
    }
    fn fps(&self) -> f32 {
        self.grid.fps()
    }
    fn topology(&self) -> &Topology {
        self.grid.topology()
    }
    fn read_frame(&self, i: usize) -> Result<crate::mesh::Frame> {
        self.grid.read_frame(i)
    }
    fn kind(&self) -> &'static str {
        "capture registered on the grid"
    }
    fn frame_mesh(&self, i: usize) -> Result<Option<Cow<'_, FrameMesh>>> {
        Ok(self.meshes.get(i).map(Cow::Borrowed))
    }
    fn has_frame_meshes(&self) -> bool {
        true
    }
}

/// A registered capture spilled to an unnamed temporary file (in
/// `TMPDIR`; gone when this is dropped), one record a frame: its grid,
/// then its own mesh's vertex and face counts, vertices, faces and
/// places, all little-endian.
pub struct Spilled {
    label: PathBuf,
    fps: f32,
    topology: Topology,
    samples: usize,
    file: Mutex<File>,
    /// Each frame's record: where it starts, its vertices and faces.
    records: Vec<(u64, u32, u32)>,
    end: u64,
}

impl Spilled {
    /// An empty spill of frames on `grid`.
    pub fn new(label: &Path, fps: f32, grid: Grid) -> Result<Spilled> {
        let file = tempfile::tempfile().map_err(|e| spill_error(label, e))?;
        let topology = grid.topology();
        let samples = topology.vertex_count;
        let records = Vec::new();
        Ok(Spilled { label: label.into(), fps, topology, samples, file: Mutex::new(file), records, end: 0 })
    }

    /// Bytes spilled so far.
    pub fn bytes(&self) -> u64 {
        self.end
    }

    /// Frame `t`'s record: where it starts, its vertices and faces.
    fn record(&self, t: usize) -> Result<(u64, u32, u32)> {
        self.records.get(t).copied().ok_or_else(|| past_end(t, self.records.len()))
    }

    /// `len` bytes from `at`.
    fn read_at(&self, at: u64, len: usize) -> Result<Vec<u8>> {
        let mut file = self.file.lock().map_err(|_| poisoned(&self.label))?;
        let mut bytes = vec![0; len];
        file.seek(SeekFrom::Start(at))
            .and_then(|_| file.read_exact(&mut bytes))
            .map_err(|e| spill_error(&self.label, e))?;
        Ok(bytes)
    }

    /// `bytes` written from `at`.
    fn write_at(&self, at: u64, bytes: &[u8]) -> Result<()> {
        let mut file = self.file.lock().map_err(|_| poisoned(&self.label))?;
        file.seek(SeekFrom::Start(at)).and_then(|_| file.write_all(bytes)).map_err(|e| spill_error(&self.label, e))
    }

    /// Frame `t`'s own mesh, its vertices placed.
    fn mesh(&self, t: usize) -> Result<FrameMesh> {
        let (at, nv, nf) = self.record(t)?;
        let (nv, nf) = (nv as usize, nf as usize);
        let bytes = self.read_at(at + 12 * self.samples as u64 + 8, 12 * nv + 12 * nf + 8 * nv)?;
        let words = words(&bytes);
        let positions = vec3s(&words[..3 * nv]);
        let faces = words[3 * nv..3 * nv + 3 * nf].chunks_exact(3).map(|f| [f[0], f[1], f[2]]).collect();
        let places = words[3 * nv + 3 * nf..].chunks_exact(2).map(|p| [p[0], p[1]]).collect();
        Ok(FrameMesh { positions, faces, places })
    }
}

impl FrameStore for Spilled {
    fn len(&self) -> usize {
        self.records.len()
    }
    fn push(&mut self, grid: Vec<Vec3>, mesh: FrameMesh) -> Result<()> {
        let (nv, nf) = (mesh.positions.len(), mesh.faces.len());
        if grid.len() != self.samples || mesh.places.len() != nv {
            return Err(Error::Argument(format!(
                "{}: a frame of {} samples and {} places spilled for a grid of {} and {nv} vertices",
                self.label.display(),
                grid.len(),
                mesh.places.len(),
                self.samples
            )));
        }
        let mut bytes = Vec::with_capacity(12 * self.samples + 8 + 32 * nv + 12 * nf);
        put_vec3s(&mut bytes, &grid);
        put_words(&mut bytes, [nv as u32, nf as u32]);
        put_vec3s(&mut bytes, &mesh.positions);
        mesh.faces.iter().for_each(|f| put_words(&mut bytes, *f));
        mesh.places.iter().for_each(|p| put_words(&mut bytes, *p));
        self.write_at(self.end, &bytes)?;
        self.records.push((self.end, nv as u32, nf as u32));
        self.end += bytes.len() as u64;
        Ok(())
    }
    fn grid(&self, t: usize) -> Result<Cow<'_, [Vec3]>> {
        let (at, _, _) = self.record(t)?;
        let bytes = self.read_at(at, 12 * self.samples)?;
        Ok(Cow::Owned(vec3s(&words(&bytes))))
    }
    fn replace(&mut self, t: usize, grid: Vec<Vec3>, places: Vec<[u32; 2]>) -> Result<()> {
        let (at, nv, nf) = self.record(t)?;
        if places.len() != nv as usize {
            return Err(Error::Argument(format!(
                "{}: frame {t} rewritten with {} places (it has {nv} vertices)",
                self.label.display(),
                places.len()
            )));
        }
        self.replace_grid(t, grid)?;
        let mut bytes = Vec::with_capacity(8 * places.len());
        places.iter().for_each(|p| put_words(&mut bytes, *p));
        self.write_at(at + 12 * self.samples as u64 + 8 + 12 * (nv as u64 + nf as u64), &bytes)
    }
    fn replace_grid(&mut self, t: usize, grid: Vec<Vec3>) -> Result<()> {
        let (at, _, _) = self.record(t)?;
        if grid.len() != self.samples {
            return Err(Error::Argument(format!(
                "{}: frame {t} rewritten with {} samples (it has {})",
                self.label.display(),
                grid.len(),
                self.samples
            )));
        }
        let mut bytes = Vec::with_capacity(12 * self.samples);
        put_vec3s(&mut bytes, &grid);
        self.write_at(at, &bytes)
    }

    fn set_faces(&mut self, faces: Vec<[u32; 3]>) {
        self.topology.faces = faces;
    }
}

impl FrameSource for Spilled {
    fn label(&self) -> &Path {
        &self.label
    }
    fn frame_count(&self) -> usize {
        self.records.len()
    }
    fn fps(&self) -> f32 {
        self.fps
    }
    fn topology(&self) -> &Topology {
        &self.topology
    }
    fn read_frame(&self, i: usize) -> Result<crate::mesh::Frame> {
        self.grid(i).map(Cow::into_owned)
    }
    fn kind(&self) -> &'static str {
        "capture registered on the grid"
    }
    fn frame_mesh(&self, i: usize) -> Result<Option<Cow<'_, FrameMesh>>> {
        self.mesh(i).map(|m| Some(Cow::Owned(m)))
    }
    fn has_frame_meshes(&self) -> bool {
        true
    }
}

fn put_words<const K: usize>(bytes: &mut Vec<u8>, words: [u32; K]) {
    words.iter().for_each(|w| bytes.extend_from_slice(&w.to_le_bytes()));
}

fn put_vec3s(bytes: &mut Vec<u8>, points: &[Vec3]) {
    points.iter().for_each(|p| put_words(bytes, p.to_array().map(f32::to_bits)));
}

fn words(bytes: &[u8]) -> Vec<u32> {
    bytes.chunks_exact(4).map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]])).collect()
}

fn vec3s(words: &[u32]) -> Vec<Vec3> {
    words.chunks_exact(3).map(|p| Vec3::new(f32::from_bits(p[0]), f32::from_bits(p[1]), f32::from_bits(p[2]))).collect()
}

fn past_end(t: usize, len: usize) -> Error {
    Error::Argument(format!("frame {t} of a registration of {len} frames"))
}

/// The error of the spill file, named by the capture it holds (the file
/// itself has no name).
fn spill_error(label: &Path, source: std::io::Error) -> Error {
    let path = PathBuf::from(format!("{} (registered frames spilled to TMPDIR)", label.display()));
    Error::Io { path, source }
}

fn poisoned(label: &Path) -> Error {
    Error::Argument(format!("{}: the spill file's lock was poisoned by a panic", label.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frames spilled come back as they went in, and a frame rewritten
    /// keeps its mesh; a frame of the wrong size is refused.
    #[test]
    fn spilled_frames_read_back_as_written() {
        let grid = Grid::new(4).unwrap();
        let mut spill = Spilled::new(Path::new("walk"), 30.0, grid).unwrap();
        let frame = |t: usize, nv: usize| {
            let g: Vec<Vec3> = (0..16).map(|k| Vec3::new(k as f32, t as f32, -0.5 * k as f32)).collect();
            let positions = (0..nv).map(|k| Vec3::splat(k as f32 + 0.25 * t as f32)).collect();
            let faces = (0..nv as u32 - 2).map(|k| [k, k + 1, k + 2]).collect();
            let places = (0..nv as u32).map(|k| [k * 3, k + t as u32]).collect();
            (g, FrameMesh { positions, faces, places })
        };
        let frames = [frame(0, 5), frame(1, 9), frame(2, 3)];
        for (g, m) in frames.clone() {
            spill.push(g, m).unwrap();
        }
        for (t, (g, m)) in frames.iter().enumerate() {
            assert_eq!(spill.read_frame(t).unwrap(), *g);
            assert_eq!(spill.frame_mesh(t).unwrap().unwrap().as_ref(), m);
        }
        let (g, m) = frame(7, 9);
        spill.replace(1, g.clone(), m.places.clone()).unwrap();
        assert_eq!(spill.read_frame(1).unwrap(), g);
        let mesh = spill.frame_mesh(1).unwrap().unwrap();
        assert_eq!((&mesh.positions, &mesh.places), (&frames[1].1.positions, &m.places));
        assert_eq!(spill.frame_mesh(2).unwrap().unwrap().as_ref(), &frames[2].1);
        assert!(spill.replace(1, g.clone(), vec![[0, 0]; 3]).is_err(), "places of another frame's size");
        // A grid alone replaced: its places kept, the next frame untouched.
        let (g2, _) = frame(8, 3);
        spill.replace_grid(0, g2.clone()).unwrap();
        assert_eq!(spill.read_frame(0).unwrap(), g2);
        assert_eq!(spill.frame_mesh(0).unwrap().unwrap().as_ref(), &frames[0].1);
        assert_eq!(spill.read_frame(1).unwrap(), g);
        assert!(spill.replace_grid(0, g2[..15].to_vec()).is_err(), "a grid of another size");
        assert!(spill.replace_grid(3, g2.clone()).is_err(), "a frame past the end");
        let mut held = Registered::empty(Path::new("walk"), 30.0, grid);
        held.push(frames[0].0.clone(), frames[0].1.clone()).unwrap();
        assert!(held.replace_grid(0, g2[..15].to_vec()).is_err() && held.replace_grid(1, g2.clone()).is_err());
        held.replace_grid(0, g2.clone()).unwrap();
        assert_eq!((held.grid(0).unwrap().as_ref(), &held.meshes[0]), (&g2[..], &frames[0].1));
        assert!(spill.push(g[..15].to_vec(), m).is_err(), "a grid of another size");
        assert!(spill.read_frame(3).is_err());
        assert_eq!(spill.frame_count(), 3);
    }
}

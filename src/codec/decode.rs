//! Native decoding: OpenH264 turns each stream's access units into luma
//! planes for the [`SequenceDecoder`]. [`UnitDecoder`] is push-style (a
//! frame's side data and access units in, as they arrive); [`FileDecoder`]
//! feeds it from a whole file in memory.

use super::h264::Decoder as H264Decoder;
use super::reconstruct::{FrameStats, SequenceDecoder, SourceMeshDecoder, DEFAULT_MEMORY_LIMIT};
use crate::error::{Error, Result};
use crate::format::{CgvFile, FrameInfo, Header, SolverKind};
use crate::grid::Grid;
use glam::Vec3;

/// Decodes frames in order from their side data and access units.
pub struct UnitDecoder {
    sequence: SequenceDecoder,
    videos: Vec<H264Decoder>,
}

impl UnitDecoder {
    /// Refuses a header whose decoding needs more than `memory_limit` bytes.
    pub fn new(header: Header, solver: SolverKind, memory_limit: u64) -> Result<UnitDecoder> {
        let videos = header.streams.iter().map(|_| H264Decoder::new()).collect::<Result<Vec<_>>>()?;
        Ok(UnitDecoder { sequence: SequenceDecoder::new(header, solver, memory_limit)?, videos })
    }

    pub fn header(&self) -> &Header {
        self.sequence.header()
    }

    /// The frame [`push_frame`](Self::push_frame) decodes next.
    pub fn next_index(&self) -> u32 {
        self.sequence.next_index()
    }

    /// Version 11: the loose vertices of the frame decoded last.
    pub fn loose(&self) -> &[Vec3] {
        self.sequence.loose()
    }

    /// What the decoder adds at the source mesh's vertices at the frame
    /// decoded last: the bones' skinning (version 17), the vertex residual
    /// (18) or their sum (see [`SequenceDecoder::at_vertices`]).
    pub fn at_vertices(&self) -> Option<&[Vec3]> {
        self.sequence.at_vertices()
    }

    /// Version 17: the bones on the source mesh's vertices.
    pub fn vertex_bones(&self) -> Option<&crate::solve::skinned::SkinnedPredictor> {
        self.sequence.vertex_bones()
    }

    /// The file's source mesh (see [`SequenceDecoder::set_source_mesh`]).
    pub fn set_source_mesh(&mut self, mesh: &crate::format::SourceMesh) -> Result<()> {
        self.sequence.set_source_mesh(mesh)
    }

    /// Version 13: the file's skin weights (see [`SequenceDecoder::set_skin`]).
    pub fn set_skin(&mut self, weights: &crate::format::SkinWeights) -> Result<()> {
        self.sequence.set_skin(weights)
    }

    /// Restarts at random-access point `f` (see [`SequenceDecoder::seek`]),
    /// with new H.264 decoders: `f`'s pictures are IDR pictures.
    pub fn seek(&mut self, f: u32) -> Result<()> {
        self.sequence.seek(f)?;
        self.videos = self.videos.iter().map(|_| H264Decoder::new()).collect::<Result<Vec<_>>>()?;
        Ok(())
    }

    /// Decodes the next frame from its side data and each stream's access
    /// unit (`None` where the stream has no picture at this frame).
    pub fn push_frame(&mut self, info: &FrameInfo, units: &[Option<&[u8]>]) -> Result<(Vec<Vec3>, FrameStats)> {
        let h = self.sequence.header();
        if units.len() != self.videos.len() {
            return Err(Error::Video(format!("{} access units for {} streams", units.len(), self.videos.len())));
        }
        let t0 = std::time::Instant::now();
        let mut lumas = Vec::with_capacity(units.len());
        for ((video, au), s) in self.videos.iter_mut().zip(units).zip(&h.streams) {
            let n = s.size(h.grid) as usize;
            lumas.push(au.map(|au| video.decode(au, n, n)).transpose()?);
        }
        let t1 = std::time::Instant::now();
        let (x, solve) = self.sequence.push_frame(info, &lumas)?;
        Ok((x, FrameStats { solve, video_seconds: (t1 - t0).as_secs_f64(), solve_seconds: t1.elapsed().as_secs_f64() }))
    }
}

/// A file in memory, decoded frame by frame, in order.
pub struct FileDecoder {
    pub file: CgvFile,
    pub grid: Grid,
    units: UnitDecoder,
}

/// A frame's own vertices and faces (format version 16's frame meshes).
pub type OwnMesh = (Vec<Vec3>, Vec<[u32; 3]>);

impl FileDecoder {
    /// With the default memory limit ([`DEFAULT_MEMORY_LIMIT`]).
    pub fn new(file: CgvFile, solver: SolverKind) -> Result<FileDecoder> {
        FileDecoder::with_memory_limit(file, solver, DEFAULT_MEMORY_LIMIT)
    }

    pub fn with_memory_limit(file: CgvFile, solver: SolverKind, memory_limit: u64) -> Result<FileDecoder> {
        let mut units = UnitDecoder::new(file.header.clone(), solver, memory_limit)?;
        if let Some(mesh) = &file.source_mesh {
            units.set_source_mesh(mesh)?;
        }
        if let Some(weights) = &file.skin {
            units.set_skin(weights)?;
        }
        Ok(FileDecoder { grid: Grid::new(file.header.grid as usize)?, file, units })
    }

    pub fn frame_count(&self) -> usize {
        self.file.header.frames as usize
    }

    /// The input's mesh, when the file carries it (format version 6).
    pub fn source_mesh(&self) -> Option<SourceMeshDecoder> {
        self.file.source_mesh.as_ref().map(|m| SourceMeshDecoder::for_header(&self.file.header, self.grid, m))
    }

    /// Version 16: frame `frame`'s own mesh (a capture's, `--mesh
    /// frames`), its vertices rebuilt on that frame's decoded grid
    /// `grid_frame`, with its faces; none in a file without frame meshes.
    pub fn frame_mesh(&self, frame: u32, grid_frame: &[Vec3]) -> Result<Option<OwnMesh>> {
        let Some(unit) = self.file.frames.get(frame as usize).and_then(|f| f.mesh.as_deref()) else {
            return Ok(None);
        };
        // The reader checked every unit; a file built in memory may not be.
        let mesh = crate::format::frame_mesh::parse_unit(unit, frame, 0)
            .map_err(|e| crate::error::Error::Argument(e.to_string()))?;
        let decoder = SourceMeshDecoder::new(self.grid, &mesh);
        Ok(Some((decoder.vertices(grid_frame, &[], None), mesh.faces)))
    }

    /// The frame [`next_frame`](Self::next_frame) decodes next.
    pub fn next_index(&self) -> u32 {
        self.units.next_index()
    }

    /// Version 11: the loose vertices of the frame decoded last (empty in
    /// files without them).
    pub fn loose(&self) -> &[Vec3] {
        self.units.loose()
    }

    /// What the decoder adds at the source mesh's vertices at the frame
    /// decoded last: the bones' skinning (version 17), the vertex residual
    /// (18) or their sum; none in files with neither.
    pub fn at_vertices(&self) -> Option<&[Vec3]> {
        self.units.at_vertices()
    }

    /// Version 17: the bones on the source mesh's vertices (a skinned
    /// file's; its rest pose, weights and the last frame's transforms).
    pub fn vertex_bones(&self) -> Option<&crate::solve::skinned::SkinnedPredictor> {
        self.units.vertex_bones()
    }

    /// The next frame's grid positions and the input's vertices rebuilt
    /// from them (with `source`, from [`source_mesh`](Self::source_mesh)).
    pub fn next_source_frame(&mut self, source: &SourceMeshDecoder) -> Result<(Vec<Vec3>, Vec<Vec3>, FrameStats)> {
        let (x, stats) = self.next_frame()?;
        let vertices = source.vertices(&x, self.loose(), self.at_vertices());
        Ok((x, vertices, stats))
    }

    /// Makes `frame` the one [`next_frame`](Self::next_frame) decodes next:
    /// from the last random-access point at or before it when that lies
    /// ahead of the decoder or `frame` lies behind it (a file without
    /// random-access points restarts from frame 0), decoding and dropping
    /// the frames in between. Returns how many frames it decoded.
    pub fn seek(&mut self, frame: u32) -> Result<u32> {
        let h = &self.file.header;
        if frame >= h.frames {
            return Err(Error::Argument(format!("frame {frame} is past the last frame {}", h.frames - 1)));
        }
        let rap = h.random_access_point(frame);
        let next = self.units.next_index();
        if frame < next || rap > next {
            self.units.seek(rap)?;
        }
        let mut decoded = 0;
        while self.units.next_index() < frame {
            self.next_frame()?;
            decoded += 1;
        }
        Ok(decoded)
    }

    /// Decodes the next frame: grid positions and what it took.
    pub fn next_frame(&mut self) -> Result<(Vec<Vec3>, FrameStats)> {
        let f = self.units.next_index();
        let (h, fi) = (&self.file.header, f as usize);
        let info = self.file.frames.get(fi).ok_or_else(|| Error::Argument("no frames left".into()))?;
        let units: Vec<Option<&[u8]>> = (0..h.streams.len())
            .map(|s| {
                self.file.units.get(s).and_then(|u| u.get(fi)).filter(|_| h.stream_has_frame(s, f)).map(Vec::as_slice)
            })
            .collect();
        self.units.push_frame(info, &units)
    }
}

//! An unregistered capture (every frame its own mesh) registered onto one
//! grid, as the seed paper builds a CGV from one (section 4): features
//! detected on every frame ([`detect`](super::detect)), tracked through
//! the frames ([`track`](super::track)), and every frame mapped onto the
//! square orbifold with the same four tracked features as its cones. The
//! orbifold map of a sphere-like surface is fixed by its cones (Aigerman
//! and Lipman 2015), so the grid sample at a place lands on the same point
//! of a near-isometrically moving body in every frame: the grid frames are
//! a registered animation of the capture, which the codec codes as any
//! other motion.

use super::detect::{features, Feature};
use super::track::{place, track, Track};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::mesh::carrier::Carrier;
use crate::mesh::{Bounds, FrameSelection, InMemory, Topology};
use crate::param::cut::{corner_for, Graph};
use crate::param::{parameterize, ParamOptions, Parameterization};
use crate::resample::SampleMap;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Area-correction passes of every frame's map: a fixed number, so that no
/// frame's map stops earlier than another's (pcow's best at N = 128 was
/// after 20, `crate::param::SCORED_PASSES`).
pub const AREA_PASSES: usize = 20;

/// One frame of a capture: its own mesh.
#[derive(Debug, Clone)]
pub struct CaptureFrame {
    pub positions: Vec<Vec3>,
    pub faces: Vec<[u32; 3]>,
}

/// The frames of a folder of OBJ files (`frames`, if given, a range of
/// them), each its own mesh.
pub fn read_capture(dir: &Path, frames: Option<FrameSelection>) -> Result<Vec<CaptureFrame>> {
    let files = crate::mesh::obj::frame_files(dir)?;
    let (a, b) = match frames {
        Some(s) => s.resolve(files.len()).map_err(|e| Error::Argument(format!("{}: {e}", dir.display())))?,
        None => (0, files.len()),
    };
    files[a..b]
        .par_iter()
        .map(|f| crate::mesh::obj::read_obj(f).map(|(positions, faces)| CaptureFrame { positions, faces }))
        .collect()
}

/// What the registration found, for `cgv info` and the encoder's report.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct RegisterReport {
    pub frames: usize,
    /// Features found per frame, on average.
    pub features_per_frame: f64,
    pub tracks: usize,
    /// The share of frames each cone's track was seen in (the rest placed
    /// between its sightings).
    pub cones_seen: [f64; 4],
    /// Frames whose map came out mirrored against the first frame's (the
    /// grid would flip there).
    pub mirrored_frames: usize,
    pub seconds_features: f64,
    pub seconds_maps: f64,
}

/// A capture's features and tracks, and the four tracks chosen as cones.
pub struct Tracked {
    pub features: Vec<Vec<Feature>>,
    pub tracks: Vec<Track>,
    pub cones: [usize; 4],
    pub seconds: f64,
}

impl Tracked {
    /// Features found per frame, on average.
    pub fn features_per_frame(&self) -> f64 {
        self.features.iter().map(Vec::len).sum::<usize>() as f64 / self.features.len().max(1) as f64
    }

    /// The share of frames each cone's track was seen in.
    pub fn cones_seen(&self) -> [f64; 4] {
        self.cones.map(|k| self.tracks[k].frames_seen() as f64 / self.features.len().max(1) as f64)
    }
}

/// The features of every frame of `frames` (named `label`), tracked.
pub fn track_capture(label: &Path, frames: &[CaptureFrame]) -> Result<Tracked> {
    if frames.is_empty() {
        return Err(Error::Argument(format!("{}: a capture without frames", label.display())));
    }
    let t0 = std::time::Instant::now();
    let features: Vec<Vec<Feature>> =
        frames.par_iter().map(|f| features(&f.faces, &f.positions)).collect::<Result<_>>()?;
    let tracks = track(&features, Bounds::of(&frames[0].positions).diagonal());
    let cones = cone_tracks(&tracks).ok_or_else(|| {
        Error::Argument(format!("{}: fewer than four features could be tracked through the frames", label.display()))
    })?;
    Ok(Tracked { features, tracks, cones, seconds: t0.elapsed().as_secs_f64() })
}

/// The capture `frames` (named `label`) on `grid`: each frame's grid
/// positions, as a motion on the grid's own mesh, and the report.
pub fn register(label: &Path, fps: f32, frames: &[CaptureFrame], grid: Grid) -> Result<(InMemory, RegisterReport)> {
    let mut tracked = track_capture(label, frames)?;
    let t1 = std::time::Instant::now();
    tracked.cones = best_cones(label, &frames[0], &tracked, grid)?;
    let mapped: Vec<(Vec<Vec3>, bool)> = (0..frames.len())
        .into_par_iter()
        .map(|t| {
            let at = tracked.cones.map(|k| place(&tracked.tracks[k], &tracked.features, t).unwrap_or(Vec3::ZERO));
            map_frame(label, &frames[t], &at, grid)
        })
        .collect::<Result<_>>()?;
    let report = RegisterReport {
        frames: frames.len(),
        features_per_frame: tracked.features_per_frame(),
        tracks: tracked.tracks.len(),
        cones_seen: tracked.cones_seen(),
        mirrored_frames: mapped.iter().filter(|m| m.1 != mapped[0].1).count(),
        seconds_features: tracked.seconds,
        seconds_maps: t1.elapsed().as_secs_f64(),
    };
    let source = InMemory {
        label: PathBuf::from(label),
        fps,
        topology: grid.topology(),
        frames: mapped.into_iter().map(|m| m.0).collect(),
    };
    Ok((source, report))
}

/// The four tracks seen in the most frames (among equals, the earliest,
/// then the strongest feature there).
fn cone_tracks(tracks: &[Track]) -> Option<[usize; 4]> {
    let mut order: Vec<usize> = (0..tracks.len()).collect();
    let first_index = |k: usize| tracks[k].seen.iter().position(Option::is_some).unwrap_or(usize::MAX);
    let strength = |k: usize| {
        let s = first_index(k);
        tracks[k].seen.get(s).copied().flatten().unwrap_or(u32::MAX)
    };
    order.sort_by_key(|&k| (std::cmp::Reverse(tracks[k].frames_seen()), first_index(k), strength(k)));
    let picked: Vec<usize> = order.into_iter().take(4).collect();
    picked.try_into().ok()
}

/// Tracks seen in at least this share of the frames the longest one is
/// seen in may be cones.
const CONE_SEEN: f64 = 0.9;
/// Most sets of four tracks [`best_cones`] tries.
const CONE_SETS: usize = 15;

/// Of the sets of four long tracks, the one whose map resamples the first
/// frame best (its grid's surface RMS against the frame), as the encoder
/// races cone placements (`crate::geometry_image`): where they sit decides
/// how much of the grid each limb gets.
fn best_cones(label: &Path, first: &CaptureFrame, tracked: &Tracked, grid: Grid) -> Result<[usize; 4]> {
    let longest = tracked.tracks.iter().map(Track::frames_seen).max().unwrap_or(0) as f64;
    let long: Vec<usize> =
        (0..tracked.tracks.len()).filter(|&k| tracked.tracks[k].frames_seen() as f64 >= CONE_SEEN * longest).collect();
    let mut sets: Vec<[usize; 4]> = Vec::new();
    for a in 0..long.len() {
        for b in a + 1..long.len() {
            for c in b + 1..long.len() {
                for d in c + 1..long.len() {
                    sets.push([long[a], long[b], long[c], long[d]]);
                }
            }
        }
    }
    if sets.len() <= 1 {
        return Ok(tracked.cones);
    }
    sets.truncate(CONE_SETS);
    let score = |set: &[usize; 4]| -> Option<f64> {
        let at = set.map(|k| place(&tracked.tracks[k], &tracked.features, 0).unwrap_or(Vec3::ZERO));
        let (g, _) = map_frame(label, first, &at, grid).ok()?;
        let d = crate::metrics::surface::symmetric(&first.positions, &first.faces, &g, &grid.topology().faces).ok()?;
        Some(d.rms)
    };
    let scored: Vec<(f64, [usize; 4])> = sets.par_iter().filter_map(|s| score(s).map(|e| (e, *s))).collect();
    Ok(scored.into_iter().min_by(|a, b| a.0.total_cmp(&b.0)).map_or(tracked.cones, |x| x.1))
}

/// The carrier's map with `cones`; a carrier too coarse for the cones'
/// paths to be cut apart is made finer, twice at most, as the encoder does
/// (`crate::geometry_image`).
fn map_with_cones(carrier: &mut Carrier, frame: &[Vec3], cones: [u32; 4]) -> Result<Parameterization> {
    let mut tries = 0;
    loop {
        let positions = carrier.positions(frame);
        let nv = carrier.topology.vertex_count;
        let pos: Vec<DVec3> = positions.iter().map(|p| p.as_dvec3()).collect();
        let corner = corner_for(&Graph::new(nv, &carrier.topology.faces, &pos), nv, &cones);
        let opts = ParamOptions { cones: Some((cones, corner)), area_passes: AREA_PASSES, ..Default::default() };
        match parameterize(&carrier.topology, &positions, &opts) {
            Err(_) if tries < 2 => carrier.subdivide(),
            done => return done,
        }
        tries += 1;
    }
}

/// One frame mapped with its cones nearest `at`: its grid positions, and
/// whether the map came out mirrored (the cones reordered by the cut).
fn map_frame(label: &Path, frame: &CaptureFrame, at: &[Vec3; 4], grid: Grid) -> Result<(Vec<Vec3>, bool)> {
    let topology = Topology { vertex_count: frame.positions.len(), faces: frame.faces.clone() };
    let mut carrier = Carrier::build(label, &topology, &frame.positions)?;
    let positions = carrier.positions(&frame.positions);
    let nearest = |p: Vec3| {
        (0..positions.len() as u32).min_by(|&a, &b| {
            positions[a as usize].distance_squared(p).total_cmp(&positions[b as usize].distance_squared(p))
        })
    };
    let mut cones = [0u32; 4];
    for (c, &p) in cones.iter_mut().zip(at) {
        *c = nearest(p).unwrap_or(0);
    }
    let param = map_with_cones(&mut carrier, &frame.positions, cones)?;
    let map = SampleMap::on_carrier(grid, &carrier, &param)?;
    Ok((map.apply(&frame.positions), param.cones != cones))
}

//! One frame of a capture mapped onto the square orbifold (Aigerman and
//! Lipman 2015) with four tracked features as its cones, as the seed paper
//! maps every frame with its tracked features as constraints (section 4.2):
//! the frame's closed surface ([`Carrier`]) without its fins, the cones
//! at the frame's vertices nearest the features, and the cut where the
//! last frame's ran ([`follow`]), so that the map goes the same way round
//! the body from frame to frame.

use super::capture::CaptureFrame;
use super::follow::{self, CutTrace};
use crate::error::Result;
use crate::grid::Grid;
use crate::mesh::carrier::Carrier;
use crate::mesh::{Bounds, Topology};
use crate::param::area::AreaPasses;
use crate::param::cut::{corner_for, Graph};
use crate::param::{ParamOptions, Parameterization};
use crate::resample::{carrier_places, SampleMap};
use glam::{DVec3, Vec3};
use std::path::Path;
use std::sync::Arc;

/// Area-correction passes of every frame's map: a fixed number, so that no
/// frame's map stops earlier than another's (pcow's best at N = 128 was
/// after 20, `crate::param::SCORED_PASSES`).
pub const AREA_PASSES: usize = 20;

/// What one frame's map needs before its area passes: the carrier (made
/// finer where the cones' paths could not be cut apart), the cut and
/// conformal map with the passes still to run, the cut's trace and which
/// cone (its index in the requested four) it put on each side of the
/// square. A piece's frames are cut one after another (each cut follows
/// the last), and their passes run side by side ([`finish_cut`]).
pub(super) struct FrameCut {
    carrier: Carrier,
    passes: AreaPasses,
    pub trace: CutTrace,
    sides: [usize; 4],
}

/// One try at the carrier's map with `cones` and, if `trace` is given,
/// its cut where the trace's ran and its missed cones where the trace had
/// them (else the corner is where the paths leave furthest apart,
/// [`follow::open_corner`], the paths shortest): the cut and the conformal
/// map, the new cut's trace and the cones' sides.
fn cut_once(
    carrier: &Carrier,
    frame: &[Vec3],
    cones: [u32; 4],
    seen: [bool; 4],
    trace: Option<&CutTrace>,
) -> Result<(AreaPasses, CutTrace, [usize; 4])> {
    let positions = carrier.positions(frame);
    let nv = carrier.topology.vertex_count;
    let pos: Vec<DVec3> = positions.iter().map(|p| p.as_dvec3()).collect();
    let graph = Graph::new(nv, &carrier.topology.faces, &pos);
    let diagonal = Bounds::of(&positions).diagonal().max(f32::MIN_POSITIVE) as f64;
    let cones = apart(&graph, trace.map_or(cones, |t| t.cones_in(&graph, cones, seen, diagonal)));
    let sig = follow::signatures(&graph, cones, diagonal);
    let corner = match trace.and_then(|t| t.corner_in(&sig, &cones)) {
        Some(c) => c,
        None => {
            let normals = crate::mesh::vertex_normals(&positions, &carrier.topology.faces);
            follow::open_corner(&graph, &pos, &normals, cones, diagonal)
                .unwrap_or_else(|| corner_for(&graph, nv, &cones))
        }
    };
    let opts = ParamOptions {
        cones: Some((cones, corner)),
        area_passes: AREA_PASSES,
        cut_guide: trace.map(|t| Arc::new(t.guide(&sig))),
        ..Default::default()
    };
    let passes = AreaPasses::start(&carrier.topology, &positions, &opts)?;
    let param = passes.current();
    let mut paths: [Vec<u32>; 4] = Default::default();
    for (side, path) in param.cut_paths.iter().enumerate() {
        let k = cones.iter().position(|&c| c == param.cones[side]).unwrap_or(side);
        paths[k] = path.clone();
    }
    let sides = param.cones.map(|v| cones.iter().position(|&c| c == v).unwrap_or(0));
    let traced = CutTrace::of(&sig, param.corner, &paths, sides);
    Ok((passes, traced, sides))
}

/// `attempt` on the carrier, which a failure makes finer, twice at most,
/// as the encoder does (`crate::geometry_image`): a carrier too coarse for
/// the cones' paths to be cut apart.
fn on_finer<T>(carrier: &mut Carrier, attempt: impl Fn(&Carrier) -> Result<T>) -> Result<T> {
    let mut tries = 0;
    loop {
        match attempt(carrier) {
            Err(_) if tries < 2 => carrier.subdivide(),
            done => return done,
        }
        tries += 1;
    }
}

/// The frame's cones: the carrier's vertices nearest `at`, and whether
/// each counts as seen there ([`one_cone_a_vertex`]).
fn cones_on(carrier: &Carrier, frame: &CaptureFrame, at: &[(Vec3, bool); 4]) -> ([u32; 4], [bool; 4]) {
    let positions = carrier.positions(&frame.positions);
    let cones = at.map(|(p, _)| nearest(&positions, p).unwrap_or(0));
    (cones, one_cone_a_vertex(cones, at.map(|(_, seen)| seen)))
}

/// One frame mapped with its cones nearest `at` (each place, and whether
/// its track saw the cone there) and its cut where `trace`'s ran, if given.
pub(super) fn map_frame(
    label: &Path,
    frame: &CaptureFrame,
    at: &[(Vec3, bool); 4],
    trace: Option<&CutTrace>,
    grid: Grid,
) -> Result<Mapped> {
    map_on(frame_carrier(label, frame)?, frame, at, trace, grid)
}

/// A frame's closed surface to map. A fin left in would become a part of
/// its own, joined to the body by a tube the map then spreads over
/// (horse-gallop's remeshed frames 5-7 resampled 0.67-0.85 % off; without
/// their fins 0.09-0.11 %).
pub(super) fn frame_carrier(label: &Path, frame: &CaptureFrame) -> Result<Carrier> {
    let topology =
        Topology { vertex_count: frame.positions.len(), faces: crate::mesh::topology::without_fins(&frame.faces) };
    Carrier::build(label, &topology, &frame.positions)
}

/// [`map_frame`] on the frame's `carrier` ([`frame_carrier`]): a failure
/// of the area passes, too, makes the carrier finer and tries again.
pub(super) fn map_on(
    mut carrier: Carrier,
    frame: &CaptureFrame,
    at: &[(Vec3, bool); 4],
    trace: Option<&CutTrace>,
    grid: Grid,
) -> Result<Mapped> {
    let (param, trace, sides) = finished(&mut carrier, frame, at, trace)?;
    mapped(&carrier, &param, frame, grid, trace, sides)
}

/// The frame's map on its `carrier` (made finer where it must be) with its
/// cones nearest `at`, its cut following `trace`, its area passes run: the
/// map, its cut's trace and the cones' sides.
fn finished(
    carrier: &mut Carrier,
    frame: &CaptureFrame,
    at: &[(Vec3, bool); 4],
    trace: Option<&CutTrace>,
) -> Result<(Parameterization, CutTrace, [usize; 4])> {
    let (cones, seen) = cones_on(carrier, frame, at);
    on_finer(carrier, |c| {
        let (passes, trace, sides) = cut_once(c, &frame.positions, cones, seen, trace)?;
        Ok((passes.finish(None)?, trace, sides))
    })
}

/// A registered run's map ([`super::capture::is_registered_run`]), as a
/// registered motion is mapped once (`crate::geometry_image`): its `first`
/// frame mapped as [`map_frame`] maps it, the map's samples then read on
/// every frame's own positions ([`SampleMap::apply`]), so that a sample is
/// one point of the body in every frame. Returns the map, the vertices'
/// places and the cut's trace.
pub(super) fn map_run(
    label: &Path,
    first: &CaptureFrame,
    at: &[(Vec3, bool); 4],
    trace: Option<&CutTrace>,
    grid: Grid,
) -> Result<(SampleMap, Vec<[u32; 2]>, CutTrace)> {
    let mut carrier = frame_carrier(label, first)?;
    let (param, trace, _) = finished(&mut carrier, first, at, trace)?;
    let map = SampleMap::on_carrier(grid, &carrier, &param)?;
    Ok((map, carrier_places(&carrier, &param), trace))
}

/// [`map_frame`]'s cut alone, its area passes left for [`finish_cut`]. A
/// failure of those passes is not retried here: where [`finish_cut`]
/// fails, [`map_frame`] maps the frame again from the start.
pub(super) fn cut_frame(
    label: &Path,
    frame: &CaptureFrame,
    at: &[(Vec3, bool); 4],
    trace: Option<&CutTrace>,
) -> Result<FrameCut> {
    let mut carrier = frame_carrier(label, frame)?;
    let (cones, seen) = cones_on(&carrier, frame, at);
    let (passes, trace, sides) = on_finer(&mut carrier, |c| cut_once(c, &frame.positions, cones, seen, trace))?;
    Ok(FrameCut { carrier, passes, trace, sides })
}

/// The frame's map from its cut ([`cut_frame`]): the same as [`map_frame`]'s
/// where the passes succeed.
pub(super) fn finish_cut(cut: FrameCut, frame: &CaptureFrame, grid: Grid) -> Result<Mapped> {
    let param = cut.passes.finish(None)?;
    mapped(&cut.carrier, &param, frame, grid, cut.trace, cut.sides)
}

/// The grid and the vertices' places of a frame's finished map.
fn mapped(
    carrier: &Carrier,
    param: &Parameterization,
    frame: &CaptureFrame,
    grid: Grid,
    trace: CutTrace,
    sides: [usize; 4],
) -> Result<Mapped> {
    let map = SampleMap::on_carrier(grid, carrier, param)?;
    let places = carrier_places(carrier, param);
    Ok(Mapped { grid: map.apply(&frame.positions), places, sides, trace, on_input: map.on_input })
}

/// `seen` with a cone that shares its vertex with another counted as
/// missed (the one not seen there, else the later), so that a trace puts
/// it where the last frame had it: no map has two cones at one vertex,
/// and two tracks may reach one (whole pcow's frames 120-180: a track's
/// place between its sightings on another's feature).
fn one_cone_a_vertex(cones: [u32; 4], mut seen: [bool; 4]) -> [bool; 4] {
    for k in 1..4 {
        // Where only one of the two was seen, the other is missed already.
        if (0..k).any(|j| cones[j] == cones[k] && seen[j]) {
            seen[k] = false;
        }
    }
    seen
}

/// `cones` with each that shares an earlier one's vertex moved to the
/// nearest vertex no cone holds: the last resort where no trace could put
/// it ([`one_cone_a_vertex`]), since a map needs four cones apart.
fn apart(graph: &Graph, mut cones: [u32; 4]) -> [u32; 4] {
    for k in 1..4 {
        if cones[..k].contains(&cones[k]) {
            let free = graph.neighbours(cones[k]).iter().filter(|(v, _)| !cones.contains(v));
            if let Some((v, _)) = free.min_by(|a, b| a.1.total_cmp(&b.1)) {
                cones[k] = *v;
            }
        }
    }
    cones
}

/// A frame's map: its grid positions, which cone (its index in the
/// requested four) the cut put on each side (top, right, bottom, left),
/// and where its cut ran.
pub(super) struct Mapped {
    pub grid: Vec<Vec3>,
    /// Each of the frame's own vertices' place on the map.
    pub places: Vec<[u32; 2]>,
    pub sides: [usize; 4],
    pub trace: CutTrace,
    /// Whether each sample lies on the frame's own faces (not on a lid
    /// over a hole, nor a tube between parts: [`super::lids`]).
    pub on_input: Vec<bool>,
}

/// The vertex of `positions` nearest `p`.
pub(super) fn nearest(positions: &[Vec3], p: Vec3) -> Option<u32> {
    (0..positions.len() as u32).min_by(|&a, &b| {
        positions[a as usize].distance_squared(p).total_cmp(&positions[b as usize].distance_squared(p))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Of two cones on one vertex, the one not seen there is missed, else
    /// the later; cones apart keep what their tracks saw.
    #[test]
    fn two_cones_on_one_vertex_leave_one_to_the_trace() {
        let all = [true; 4];
        assert_eq!(one_cone_a_vertex([1, 2, 3, 4], all), all);
        assert_eq!(one_cone_a_vertex([1, 2, 1, 4], all), [true, true, false, true]);
        assert_eq!(one_cone_a_vertex([1, 2, 1, 4], [false, true, true, true]), [false, true, true, true]);
        assert_eq!(one_cone_a_vertex([5, 5, 5, 4], all), [true, false, false, true]);
    }

    /// Cones on one vertex are moved apart, each to the nearest free
    /// neighbour; cones apart stay.
    #[test]
    fn cones_on_one_vertex_are_moved_apart() {
        // A row of five vertices, 1 apart, but 2 and 3 only 0.5.
        let pos: Vec<DVec3> = [0.0, 1.0, 2.0, 2.5, 3.5].iter().map(|&x| DVec3::new(x, 0.0, 0.0)).collect();
        let mut pos = pos;
        pos.extend(pos.clone().iter().map(|p| *p + DVec3::Y));
        let faces: Vec<[u32; 3]> = (0..4u32).flat_map(|i| [[i, i + 1, i + 6], [i, i + 6, i + 5]]).collect();
        let graph = Graph::new(10, &faces, &pos);
        assert_eq!(apart(&graph, [0, 1, 5, 9]), [0, 1, 5, 9]);
        let moved = apart(&graph, [2, 0, 2, 2]);
        assert_eq!(moved[..2], [2, 0]);
        assert_eq!(moved[2], 3, "the nearest neighbour of 2");
        assert!(!moved[..3].contains(&moved[3]) && graph.neighbours(2).iter().any(|n| n.0 == moved[3]), "{moved:?}");
    }
}

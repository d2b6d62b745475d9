//! Each frame's cut where the previous frame's ran, for
//! [`register`](super::register). The orbifold map is fixed by its cones
//! *and* the homotopy class of its cut (Aigerman and Lipman 2015): two
//! shortest-path cuts between the same cones can go different ways round
//! a body from one frame to the next, and the grid then swims over it.
//! So the cut is traced in the body's own coordinates (each point's
//! geodesic distances to the four cones, which a near-isometric motion
//! keeps, as the paper's isometric feature matching assumes) and the next
//! frame's corner and paths are put where the trace says
//! ([`crate::param::cut::Guide`]).

use crate::param::cut::{CutGuide, Graph};
use glam::{DVec3, Vec3};

/// A point's geodesic distances to the four cones, in diagonals.
pub type Signature = [f64; 4];

/// Each vertex's [`Signature`] on the mesh of `graph` with cones `cones`
/// and bounding-box diagonal `diagonal` (distances along edges).
pub fn signatures(graph: &Graph, cones: [u32; 4], diagonal: f64) -> Vec<Signature> {
    let free = vec![false; graph.vertex_count()];
    let d = cones.map(|c| graph.dijkstra(c, &free).0);
    (0..graph.vertex_count()).map(|v| std::array::from_fn(|k| d[k][v] / diagonal)).collect()
}

/// How far along its shortest path towards a cone [`open_corner`] looks
/// for the path's direction, in diagonals.
const LEAVING: f64 = 0.05;

/// A corner for the first frame where the four paths to the cones leave
/// in well-separated directions (the largest smallest angle between
/// neighbours round the vertex), among the vertices at least half as far
/// from the cones as the farthest. Where two paths leave together (the
/// farthest point from four legs, at the nose, sends all four down the
/// neck), a small change of the mesh trades their order round the corner
/// and gives another map; well apart, the order holds from frame to frame.
pub fn open_corner(graph: &Graph, pos: &[DVec3], normals: &[Vec3], cones: [u32; 4], diagonal: f64) -> Option<u32> {
    let free = vec![false; graph.vertex_count()];
    let trees = cones.map(|c| graph.dijkstra(c, &free));
    let nearest_cone = |v: usize| trees.iter().map(|t| t.0[v]).fold(f64::INFINITY, f64::min);
    let farthest = (0..pos.len()).map(nearest_cone).filter(|d| d.is_finite()).fold(0.0, f64::max);
    let leaving = |v: usize, k: usize| {
        let (dist, pred) = &trees[k];
        let mut w = v;
        while dist[v] - dist[w] < LEAVING * diagonal && pred[w] != u32::MAX {
            w = pred[w] as usize;
        }
        pos[w] - pos[v]
    };
    let spread = |v: usize| {
        let n = normals.get(v)?.as_dvec3();
        let e1 = leaving(v, 0).reject_from(n).try_normalize()?;
        let e2 = n.cross(e1);
        let mut angles: Vec<f64> = (0..4).map(|k| leaving(v, k)).map(|d| d.dot(e2).atan2(d.dot(e1))).collect();
        angles.sort_by(f64::total_cmp);
        let wrap = angles[0] + std::f64::consts::TAU - angles[3];
        Some(angles.windows(2).map(|w| w[1] - w[0]).fold(wrap, f64::min))
    };
    (0..pos.len())
        .filter(|&v| !cones.contains(&(v as u32)) && graph.degree(v as u32) >= 4 && nearest_cone(v) >= 0.5 * farthest)
        .filter_map(|v| spread(v).map(|s| (v as u32, s)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(v, _)| v)
}

/// How far apart two signatures are (in diagonals).
fn gap(a: &Signature, b: &Signature) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt()
}

/// Where a frame's cut ran: its corner's and its paths' points'
/// signatures (the paths per cone, in the order the cones were asked for).
#[derive(Debug, Clone)]
pub struct CutTrace {
    corner: Signature,
    paths: [Vec<Signature>; 4],
    /// The cones on the square's sides (see [`CutGuide::sides`]).
    sides: [usize; 4],
    /// [`away`](Self::away)'s factor: how hard the paths are pulled.
    pull: f64,
}

impl CutTrace {
    /// The trace of the cut with corner `corner`, paths `paths` (vertex
    /// indices, per cone) and cones on the sides `sides`, on a mesh whose
    /// vertices have signatures `sig`.
    pub fn of(sig: &[Signature], corner: u32, paths: &[Vec<u32>; 4], sides: [usize; 4]) -> CutTrace {
        let at = |v: u32| sig.get(v as usize).copied().unwrap_or([f64::NAN; 4]);
        let paths = paths.each_ref().map(|p| p.iter().map(|&v| at(v)).collect());
        CutTrace { corner: at(corner), paths, sides, pull: 1.0 }
    }

    /// The same trace pulling `pull` times as hard.
    pub fn pulled(&self, pull: f64) -> CutTrace {
        CutTrace { pull: self.pull * pull, ..self.clone() }
    }

    /// `cones` with each one not `seen` (its track missed this frame, so
    /// it sits where the sightings around it were, in space: off the body
    /// when a limb swings) moved to the vertex whose geodesic distances to
    /// the seen cones are nearest the traced cone's. Needs two seen cones.
    pub fn cones_in(&self, graph: &Graph, cones: [u32; 4], seen: [bool; 4], diagonal: f64) -> [u32; 4] {
        if seen.iter().filter(|&&s| s).count() < 2 || seen.iter().all(|&s| s) {
            return cones;
        }
        let free = vec![false; graph.vertex_count()];
        let seen_from: Vec<(usize, Vec<f64>)> =
            (0..4).filter(|&j| seen[j]).map(|j| (j, graph.dijkstra(cones[j], &free).0)).collect();
        let mut out = cones;
        for k in (0..4).filter(|&k| !seen[k]) {
            let Some(was) = self.paths[k].last() else { continue };
            let miss = |v: usize| seen_from.iter().map(|(j, d)| (d[v] / diagonal - was[*j]).powi(2)).sum::<f64>();
            let free_vertex = |v: &usize| !out.contains(&(*v as u32));
            if let Some(v) = (0..graph.vertex_count()).filter(free_vertex).min_by(|&a, &b| miss(a).total_cmp(&miss(b)))
            {
                out[k] = v as u32;
            }
        }
        out
    }

    /// The vertex (not one of `cones`) nearest the traced corner.
    pub fn corner_in(&self, sig: &[Signature], cones: &[u32; 4]) -> Option<u32> {
        (0..sig.len() as u32)
            .filter(|v| !cones.contains(v))
            .min_by(|&a, &b| gap(&sig[a as usize], &self.corner).total_cmp(&gap(&sig[b as usize], &self.corner)))
    }

    /// The guide to a cut like the traced one on a mesh whose vertices
    /// have signatures `sig`: per cone, each vertex's distance from the
    /// traced path, and twice more by how much nearer it is to another
    /// cone's (near the corner all paths are close, and two that trade
    /// places there put the cones round the corner in another order:
    /// another map), and the traced order of the cones.
    pub fn guide(&self, sig: &[Signature]) -> CutGuide {
        CutGuide { away: self.away(sig), sides: self.sides }
    }

    fn away(&self, sig: &[Signature]) -> [Vec<f64>; 4] {
        let near: [Vec<f64>; 4] = self
            .paths
            .each_ref()
            .map(|path| sig.iter().map(|s| path.iter().map(|q| gap(s, q)).fold(f64::INFINITY, f64::min)).collect());
        std::array::from_fn(|k| {
            (0..sig.len())
                .map(|v| {
                    let other = (0..4).filter(|&j| j != k).map(|j| near[j][v]).fold(f64::INFINITY, f64::min);
                    self.pull * (near[k][v] + 2.0 * (near[k][v] - other).max(0.0))
                })
                .collect()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a strip of squares, signatures are distances along it, and a
    /// trace finds its corner and a missed cone again.
    #[test]
    fn a_traced_corner_is_found_again() {
        // A 6 x 2 ladder of vertices: v = 2 i + j at (i, j).
        let pos: Vec<DVec3> = (0..12).map(|v| DVec3::new((v / 2) as f64, (v % 2) as f64, 0.0)).collect();
        let faces: Vec<[u32; 3]> =
            (0..5u32).flat_map(|i| [[2 * i, 2 * i + 2, 2 * i + 1], [2 * i + 1, 2 * i + 2, 2 * i + 3]]).collect();
        let graph = Graph::new(12, &faces, &pos);
        let cones = [0, 1, 10, 11];
        let sig = signatures(&graph, cones, 1.0);
        assert_eq!(sig[4][0], 2.0);
        let paths = [vec![5, 4, 2, 0], vec![5, 3, 1], vec![5, 6, 8, 10], vec![5, 7, 9, 11]];
        let trace = CutTrace::of(&sig, 5, &paths, [0, 1, 2, 3]);
        assert_eq!(trace.corner_in(&sig, &cones), Some(5));
        // A cone its track missed, put at vertex 4, goes back where the
        // trace's was (10) by its distances to the three seen.
        assert_eq!(trace.cones_in(&graph, [0, 1, 4, 11], [true, true, false, true], 1.0), cones);
        let away = trace.guide(&sig).away;
        assert_eq!(away[0][2], 0.0);
        assert!(away[0][9] > away[0][3]);
    }
}

//! Topology checks for the surfaces a geometry image can be made of: one
//! connected, closed, orientable 2-manifold of genus 0, without degenerate or
//! duplicate faces. `analyze` measures; `TopologyReport::require_sphere` turns
//! the first problem into an error; `fill_holes` closes boundary loops.

use super::adjacency::{next, origin, target, Adjacency, NONE};
use super::{triangle_area_vector, Bounds, Topology};
use crate::error::MeshProblem;
use glam::Vec3;

/// Relative area under which a face counts as having zero area: twice its
/// area is below this times the squared bounding-box diagonal. Far below any
/// triangle of a real scan (samba's smallest is ~1e-7 of the squared diagonal).
pub const ZERO_AREA_REL: f32 = 1e-14;

/// Everything `cgv info` says about the connectivity of a sequence.
#[derive(Debug, Clone, serde::Serialize)]
pub struct TopologyReport {
    pub vertices: usize,
    pub faces: usize,
    pub edges: usize,
    pub euler_characteristic: i64,
    pub components: usize,
    pub boundary_loops: usize,
    pub boundary_edges: usize,
    /// Genus, when the surface is a connected manifold.
    pub genus: Option<i64>,
    pub non_manifold_edges: usize,
    pub inconsistent_edges: usize,
    pub non_manifold_vertices: usize,
    pub unused_vertices: usize,
    pub degenerate_faces: usize,
    pub zero_area_faces: usize,
    pub duplicate_faces: usize,
    /// All problems found, the most fundamental first.
    #[serde(serialize_with = "serialize_problems")]
    pub problems: Vec<MeshProblem>,
}

fn serialize_problems<S: serde::Serializer>(p: &[MeshProblem], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(p.iter().map(|p| p.to_string()))
}

impl TopologyReport {
    /// Whether the surface is closed, connected, manifold and genus 0.
    pub fn is_sphere(&self) -> bool {
        self.problems.is_empty()
    }

    /// The problems other than holes (which `fill_holes` can mend).
    pub fn problems_except_holes(&self) -> impl Iterator<Item = &MeshProblem> {
        self.problems.iter().filter(|p| !matches!(p, MeshProblem::Holes { .. }))
    }

    /// [`require_sphere`](Self::require_sphere) of the connectivity alone:
    /// faces without area are a matter for the parameterization.
    pub fn require_sphere_topology(&self) -> Result<(), MeshProblem> {
        match self.problems.iter().find(|p| !matches!(p, MeshProblem::ZeroAreaFace { .. })) {
            Some(p) => Err(p.clone()),
            None => Ok(()),
        }
    }

    pub fn require_sphere(&self) -> Result<(), MeshProblem> {
        match self.problems.first() {
            Some(p) => Err(p.clone()),
            None => Ok(()),
        }
    }
}

/// Disjoint sets over 0..n (union by smaller root, path halving).
pub(crate) struct Dsu(Vec<u32>);
impl Dsu {
    pub(crate) fn new(n: usize) -> Self {
        Dsu((0..n as u32).collect())
    }
    pub(crate) fn find(&mut self, mut x: u32) -> u32 {
        while self.0[x as usize] != x {
            let p = self.0[self.0[x as usize] as usize];
            self.0[x as usize] = p;
            x = p;
        }
        x
    }
    pub(crate) fn union(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            self.0[a.max(b) as usize] = a.min(b);
        }
    }
}

/// Boundary loops as lists of boundary half-edges (each runs along a hole's
/// rim with the surface on its left). Requires manifold vertices.
pub fn boundary_loops(faces: &[[u32; 3]], adj: &Adjacency) -> Vec<Vec<u32>> {
    let mut outgoing: std::collections::HashMap<u32, u32> = std::collections::HashMap::new();
    for (h, &o) in adj.opposite.iter().enumerate() {
        if o == NONE {
            outgoing.insert(origin(faces, h as u32), h as u32);
        }
    }
    let mut seen = std::collections::HashSet::new();
    let mut loops = Vec::new();
    let mut starts: Vec<u32> = outgoing.values().copied().collect();
    starts.sort_unstable();
    for start in starts {
        if seen.contains(&start) {
            continue;
        }
        let mut lp = Vec::new();
        let mut h = start;
        loop {
            if !seen.insert(h) {
                break;
            }
            lp.push(h);
            match outgoing.get(&target(faces, h)) {
                Some(&n) => h = n,
                None => break,
            }
        }
        loops.push(lp);
    }
    loops
}

/// Counts degenerate (repeated-vertex) and zero-area faces, reporting the first of each.
fn count_bad_faces(faces: &[[u32; 3]], first: &[Vec3], problems: &mut Vec<MeshProblem>) -> (usize, usize) {
    let diag2 = Bounds::of(first).diagonal().powi(2);
    let mut degenerate_faces = 0;
    let mut zero_area_faces = 0;
    for (fi, f) in faces.iter().enumerate() {
        let repeated = if f[0] == f[1] || f[0] == f[2] {
            Some(f[0])
        } else if f[1] == f[2] {
            Some(f[1])
        } else {
            None
        };
        if let Some(v) = repeated {
            if degenerate_faces == 0 {
                problems.push(MeshProblem::DegenerateFace { face: fi, vertex: v });
            }
            degenerate_faces += 1;
        } else {
            let [a, b, c] = f.map(|i| first[i as usize]);
            if triangle_area_vector(a, b, c).length() <= ZERO_AREA_REL * diag2 {
                if zero_area_faces == 0 {
                    problems.push(MeshProblem::ZeroAreaFace { face: fi });
                }
                zero_area_faces += 1;
            }
        }
    }
    (degenerate_faces, zero_area_faces)
}

/// Counts faces on the same vertex set as another, reporting the first pair.
fn count_duplicate_faces(faces: &[[u32; 3]], problems: &mut Vec<MeshProblem>) -> usize {
    let mut sorted: Vec<([u32; 3], usize)> = faces
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let mut s = *f;
            s.sort_unstable();
            (s, i)
        })
        .collect();
    sorted.sort_unstable();
    let mut duplicate_faces = 0;
    for w in sorted.windows(2) {
        if w[0].0 == w[1].0 {
            if duplicate_faces == 0 {
                problems.push(MeshProblem::DuplicateFace { first: w[0].1.min(w[1].1), second: w[0].1.max(w[1].1) });
            }
            duplicate_faces += 1;
        }
    }
    duplicate_faces
}

/// The number of fans around each vertex (0 where unused): more than one makes it non-manifold.
fn count_fans(faces: &[[u32; 3]], adj: &Adjacency, nv: usize) -> Vec<usize> {
    // Fans: corners (outgoing half-edges) around a vertex joined across its edges.
    let mut corners = Dsu::new(faces.len() * 3);
    for (h, &o) in adj.opposite.iter().enumerate() {
        if o != NONE && (h as u32) < o {
            corners.union(h as u32, next(o));
            corners.union(next(h as u32), o);
        }
    }
    let mut fan_root: Vec<u32> = vec![NONE; nv];
    let mut fans: Vec<usize> = vec![0; nv];
    let mut extra_roots: std::collections::HashSet<(u32, u32)> = std::collections::HashSet::new();
    for h in 0..(faces.len() * 3) as u32 {
        let v = origin(faces, h) as usize;
        let r = corners.find(h);
        if fan_root[v] == NONE {
            fan_root[v] = r;
            fans[v] = 1;
        } else if fan_root[v] != r && extra_roots.insert((v as u32, r)) {
            fans[v] += 1;
        }
    }
    fans
}

/// Counts non-manifold and unused vertices from their fan counts, reporting the first of each.
fn count_bad_vertices(fans: &[usize], problems: &mut Vec<MeshProblem>) -> (usize, usize) {
    let mut non_manifold_vertices = 0;
    let mut unused_vertices = 0;
    for (v, &fan_count) in fans.iter().enumerate() {
        if fan_count > 1 {
            if non_manifold_vertices == 0 {
                problems.push(MeshProblem::NonManifoldVertex { vertex: v as u32, fans: fan_count });
            }
            non_manifold_vertices += 1;
        } else if fan_count == 0 {
            if unused_vertices == 0 {
                problems.push(MeshProblem::UnusedVertex { vertex: v as u32 });
            }
            unused_vertices += 1;
        }
    }
    (non_manifold_vertices, unused_vertices)
}

/// The number of connected components among the faces' vertices.
fn count_components(faces: &[[u32; 3]], nv: usize) -> usize {
    let mut comps = Dsu::new(nv);
    for f in faces {
        comps.union(f[0], f[1]);
        comps.union(f[0], f[2]);
    }
    let mut roots = std::collections::HashSet::new();
    for f in faces {
        roots.insert(comps.find(f[0]));
    }
    roots.len()
}

/// Measures the topology of `topology` with the positions of its first frame.
pub fn analyze(topology: &Topology, first: &[Vec3]) -> TopologyReport {
    let faces = &topology.faces;
    let nv = topology.vertex_count;
    let mut problems = Vec::new();
    if faces.is_empty() {
        problems.push(MeshProblem::NoFaces);
    }
    let (degenerate_faces, zero_area_faces) = count_bad_faces(faces, first, &mut problems);
    let duplicate_faces = count_duplicate_faces(faces, &mut problems);

    let adj = Adjacency::build(faces);
    if let Some(&(a, b, count)) = adj.non_manifold_edges.first() {
        problems.push(MeshProblem::NonManifoldEdge { a, b, count });
    }
    if let Some(&(a, b)) = adj.inconsistent_edges.first() {
        problems.push(MeshProblem::InconsistentOrientation { a, b });
    }
    let fans = count_fans(faces, &adj, nv);
    let (non_manifold_vertices, unused_vertices) = count_bad_vertices(&fans, &mut problems);
    let components = count_components(faces, nv);
    if components > 1 {
        problems.push(MeshProblem::Components { count: components });
    }

    let boundary_edges = adj.opposite.iter().filter(|&&o| o == NONE).count();
    let manifold = adj.is_manifold() && non_manifold_vertices == 0;
    let boundary_loops = if manifold { boundary_loops(faces, &adj).len() } else { 0 };
    if boundary_edges > 0 && manifold {
        problems.push(MeshProblem::Holes { loops: boundary_loops, edges: boundary_edges });
    }
    let used = nv - unused_vertices;
    let euler = used as i64 - adj.edge_count as i64 + faces.len() as i64;
    let genus = (manifold && components == 1).then(|| (2 - boundary_loops as i64 - euler) / 2);
    if let Some(g) = genus {
        if g != 0 {
            problems.push(MeshProblem::Genus { genus: g });
        }
    }
    TopologyReport {
        vertices: nv,
        faces: faces.len(),
        edges: adj.edge_count,
        euler_characteristic: euler,
        components,
        boundary_loops,
        boundary_edges,
        genus,
        non_manifold_edges: adj.non_manifold_edges.len(),
        inconsistent_edges: adj.inconsistent_edges.len(),
        non_manifold_vertices,
        unused_vertices,
        degenerate_faces,
        zero_area_faces,
        duplicate_faces,
        problems,
    }
}

/// How holes are closed: each boundary loop gets a new vertex at the mean of
/// its rim (recomputed every frame) joined to every rim edge.
#[derive(Debug, Clone)]
pub struct HoleFill {
    /// Rim vertices of each hole, in order.
    pub loops: Vec<Vec<u32>>,
    /// The connectivity with the fans added; new vertices are appended.
    pub topology: Topology,
}

impl HoleFill {
    pub fn plan(topology: &Topology) -> HoleFill {
        let adj = Adjacency::build(&topology.faces);
        let loops = boundary_loops(&topology.faces, &adj);
        let mut faces = topology.faces.clone();
        let mut rims = Vec::new();
        for (k, lp) in loops.iter().enumerate() {
            let c = (topology.vertex_count + k) as u32;
            let mut rim = Vec::new();
            for &h in lp {
                let (a, b) = (origin(&topology.faces, h), target(&topology.faces, h));
                // The rim edge runs a -> b with the surface on its left; the new
                // face must run it b -> a to stay consistently oriented.
                faces.push([b, a, c]);
                rim.push(a);
            }
            rims.push(rim);
        }
        HoleFill { loops: rims, topology: Topology { vertex_count: topology.vertex_count + loops.len(), faces } }
    }

    /// Appends the hole centres to a frame of the original connectivity.
    pub fn apply(&self, frame: &mut Vec<Vec3>) {
        for rim in &self.loops {
            let sum: Vec3 = rim.iter().map(|&v| frame[v as usize]).sum();
            frame.push(sum / rim.len() as f32);
        }
    }
}

/// `faces` without the faces past the first two on any edge: a fin (a
/// simplifier pinches them out of two rims that meet), which the carrier
/// would detach as a part of its own.
pub fn without_fins(faces: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut seen = std::collections::HashMap::<(u32, u32), usize>::new();
    let mut count = |f: &[u32; 3]| {
        (0..3)
            .map(|k| {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                let n = seen.entry((a.min(b), a.max(b))).or_default();
                *n += 1;
                *n
            })
            .max()
            .unwrap_or(0)
    };
    let over: Vec<bool> = faces.iter().map(|f| count(f) > 2).collect();
    faces.iter().zip(over).filter(|(_, o)| !o).map(|(f, _)| *f).collect()
}

/// Whether each of `n` vertices is used by one of `faces` (an index at
/// or past `n` is ignored).
pub fn used_by(faces: &[[u32; 3]], n: usize) -> Vec<bool> {
    let mut used = vec![false; n];
    for &v in faces.iter().flatten() {
        if let Some(u) = used.get_mut(v as usize) {
            *u = true;
        }
    }
    used
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The faces past the second on an edge go; a manifold mesh keeps all.
    #[test]
    fn fins_are_left_out_and_nothing_else() {
        let tetra = vec![[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]];
        assert_eq!(without_fins(&tetra), tetra);
        let mut finned = tetra.clone();
        finned.push([1, 0, 4]);
        assert_eq!(without_fins(&finned), tetra);
    }
}

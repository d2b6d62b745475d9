//! The carrier: a closed, connected genus-0 surface made around any input
//! mesh, so that every input can be parameterized onto the seamless grid.
//!
//! The octahedral geometry image (Praun & Hoppe 2003) needs a sphere; the
//! meshes people bring have parts, holes, handles and non-manifold joints.
//! Instead of refusing them, the encoder parameterizes a surface that
//! contains the input's faces and closes it up with faces of its own:
//!
//! 1. faces that repeat a vertex, or repeat another face, are left out;
//!    faces are flipped where that makes a part consistently oriented;
//! 2. non-manifold vertices and edges are split into manifold fans (each
//!    fan gets its own copy of the vertex);
//! 3. parts with holes are joined rim to rim by strips (bridges, see
//!    [`super::bridge`]): a neck as wide as the holes, where a part cut
//!    from another meets it again;
//! 4. each boundary loop left is closed by a fan around a new vertex at the
//!    mean of its rim (so holes cost samples, not refusals);
//! 5. each part of genus g > 0 is cut open along the 2g loops of a
//!    tree-cotree cut graph (Eppstein 2003, "Dynamic generators of
//!    topologically embedded graphs"; the cut of Gu, Gortler & Hoppe 2002,
//!    "Geometry images") and the one loop the cut leaves is closed as in 4;
//! 6. the parts still apart are joined into one by tubes: one face is taken
//!    out of each of two parts (a closing face where there is one) and the
//!    two triangles are joined by six faces (a connected sum, which keeps
//!    genus 0).
//!
//! Before all that, parts of at most [`LOOSE_MAX_VERTICES`] vertices
//! (other than the largest part) are left out: their vertices are coded
//! as themselves (format version 11's loose vertices) rather than joined
//! to the rest by a tube.
//!
//! The input's own mesh is what a file carries and the decoder writes
//! (format v6's source mesh): each input vertex is rebuilt from the grid at
//! its first copy's place, and the input's faces join the rebuilt
//! vertices, so no cut or added face can open a crack in it. Samples that
//! land on the added faces are coded like the others and cost bits; they
//! are left out of the surface-error metrics ([`Carrier::real`]).

use super::adjacency::{next, origin, target, Adjacency, NONE};
use super::topology::{boundary_loops, Dsu};
use super::{analyze, Topology};
use crate::error::{Error, MeshProblem, Result};
use glam::Vec3;
use std::collections::{HashMap, HashSet, VecDeque};

/// A closed genus-0 surface around an input mesh.
#[derive(Debug, Clone)]
pub struct Carrier {
    /// Vertices of the input mesh.
    pub source_vertices: usize,
    /// The closed surface, over carrier vertices.
    pub topology: Topology,
    /// Where each carrier vertex's position comes from, as an index into
    /// the extended frame of [`Carrier::extend`]: an input vertex below
    /// `source_vertices`, `source_vertices + k` for `means[k]`.
    pub ext: Vec<u32>,
    /// Added vertices: each the mean of the extended-frame entries it
    /// lists (all of them earlier ones).
    pub means: Vec<Vec<u32>>,
    /// Whether each carrier face is one of the input's.
    pub real: Vec<bool>,
    /// Each input vertex's first carrier vertex ([`NONE`] when no face uses it).
    pub carrier_of: Vec<u32>,
    /// The input vertices of the tiny parts left out of the carrier, in
    /// increasing order: coded as themselves (loose vertices).
    pub loose: Vec<u32>,
    pub report: CarrierReport,
}

/// What closing the input took.
#[derive(Debug, Clone, Default, serde::Serialize, PartialEq, Eq)]
pub struct CarrierReport {
    /// Faces that repeat a vertex or another face (left out of the carrier).
    pub dropped_faces: usize,
    /// Faces flipped to orient their part consistently.
    pub flipped_faces: usize,
    /// Vertex copies made by splitting non-manifold fans and cutting handles.
    pub split_vertices: usize,
    /// Boundary loops closed (the input's holes and the handles' cuts).
    pub closed_loops: usize,
    /// Handles cut (the sum of the parts' genera).
    pub handles: usize,
    /// Connected parts joined into one (by bridges or tubes).
    pub parts: usize,
    /// Joins made by bridging two parts' holes rim to rim.
    pub bridges: usize,
    /// Tiny parts left out of the carrier, coded as their own vertices.
    pub loose_parts: usize,
    /// Their vertices.
    pub loose_vertices: usize,
}

/// Largest part (in vertices) coded as its own vertices rather than on the
/// grid, unless it is the input's largest: scraps and detached triangles,
/// which cost little as themselves and can leave no room for the cone
/// paths on the grid. Larger parts measured better on the grid: wolf's
/// 180-vertex part coded loose took 5 bits a vertex a frame and left the
/// file 5-20 % larger at equal surface error (docs/RESULTS.md, "Loose
/// parts"); `cgv encode --loose-parts` raises it.
pub const LOOSE_MAX_VERTICES: usize = 16;

impl Carrier {
    /// The carrier of the mesh `topology`, whose first frame is `reference`.
    /// Only a mesh without faces (or with too few vertices to map) is
    /// refused; anything else is closed up.
    pub fn build(label: &std::path::Path, topology: &Topology, reference: &[Vec3]) -> Result<Carrier> {
        Carrier::build_with(label, topology, reference, LOOSE_MAX_VERTICES)
    }

    /// [`Carrier::build`], leaving out parts of at most `loose_max`
    /// vertices (other than the largest) as loose vertices; 0 leaves none out.
    pub fn build_with(
        label: &std::path::Path,
        topology: &Topology,
        reference: &[Vec3],
        loose_max: usize,
    ) -> Result<Carrier> {
        let nv = topology.vertex_count;
        let mut report = CarrierReport::default();
        let (faces, _) = clean_faces(&topology.faces, &mut report);
        if faces.is_empty() {
            return Err(Error::mesh(label, MeshProblem::NoFaces));
        }
        let (faces, loose) = leave_out_tiny_parts(faces, nv, loose_max, &mut report);
        let real = vec![true; faces.len()];
        let mut c = Carrier {
            source_vertices: nv,
            topology: Topology { vertex_count: nv, faces },
            ext: (0..nv as u32).collect(),
            means: Vec::new(),
            real,
            carrier_of: Vec::new(),
            loose,
            report,
        };
        c.report.flipped_faces = orient(&mut c.topology.faces);
        c.split(&HashSet::new());
        c.zip_slits();
        // Zipping can join fans again where a soup of faces meets itself.
        c.split(&HashSet::new());
        c.drop_unused();
        c.bridge_parts(reference);
        c.close_loops();
        c.cut_handles();
        c.join_parts(reference);
        c.grow();
        c.carrier_of = first_copies(&c.ext, nv);
        let positions = c.positions(reference);
        if let Err(problem) = analyze(&c.topology, &positions).require_sphere_topology() {
            return Err(Error::Numerical(format!(
                "{}: the surface made to carry the mesh still {problem} (a bug: please report it)",
                label.display()
            )));
        }
        Ok(c)
    }

    /// Splits faces at their centres until the carrier has the five
    /// vertices a map to the square needs (four cones and a corner): a
    /// lone triangle closes up as a tetrahedron of four.
    fn grow(&mut self) {
        while self.topology.vertex_count < 5 {
            let [a, b, c] = self.topology.faces[0];
            let m = self.add_mean([a, b, c].iter().map(|&v| self.ext[v as usize]).collect());
            self.topology.faces[0] = [a, b, m];
            self.topology.faces.extend([[b, c, m], [c, a, m]]);
            let real = self.real[0];
            self.real.extend([real, real]);
        }
    }

    /// Splits every face into four at its edges' midpoints (new vertices,
    /// the means of the edges' ends): a mesh too coarse for the four cone
    /// paths to be cut apart gets room for them.
    pub fn subdivide(&mut self) {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let faces = std::mem::take(&mut self.topology.faces);
        let real = std::mem::take(&mut self.real);
        for (f, r) in faces.iter().zip(real) {
            let [a, b, c] = *f;
            let [ab, bc, ca] = [(a, b), (b, c), (c, a)].map(|(x, y)| {
                *mid.entry((x.min(y), x.max(y)))
                    .or_insert_with(|| self.add_mean(vec![self.ext[x as usize], self.ext[y as usize]]))
            });
            self.topology.faces.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
            self.real.extend([r; 4]);
        }
    }

    /// The input `topology` without its loose parts' faces: what the grid
    /// carries.
    pub fn on_grid(&self, topology: &Topology) -> Topology {
        let loose = |f: &&[u32; 3]| self.loose.binary_search(&f[0]).is_ok();
        Topology {
            vertex_count: topology.vertex_count,
            faces: topology.faces.iter().filter(|f| !loose(f)).copied().collect(),
        }
    }

    /// Whether the carrier is the input itself (a closed genus-0 manifold).
    pub fn is_input(&self) -> bool {
        self.means.is_empty() && self.topology.vertex_count == self.source_vertices && self.real.iter().all(|&r| r)
    }

    /// An input frame followed by the added vertices' positions.
    pub fn extend(&self, frame: &[Vec3], out: &mut Vec<Vec3>) {
        extend_frame(&self.means, frame, out);
    }

    /// A new carrier vertex at the mean of `members` (extended-frame entries).
    fn add_mean(&mut self, members: Vec<u32>) -> u32 {
        self.ext.push((self.source_vertices + self.means.len()) as u32);
        self.means.push(members);
        self.add_vertex()
    }

    /// A new carrier vertex at the same place as carrier vertex `v`.
    fn add_copy(&mut self, v: u32) -> u32 {
        self.ext.push(self.ext[v as usize]);
        self.add_vertex()
    }

    /// Counts the vertex whose `ext` entry was just pushed.
    fn add_vertex(&mut self) -> u32 {
        self.topology.vertex_count += 1;
        (self.topology.vertex_count - 1) as u32
    }

    /// The carrier's vertex positions for an input frame.
    pub fn positions(&self, frame: &[Vec3]) -> Vec<Vec3> {
        let mut ext = Vec::new();
        self.extend(frame, &mut ext);
        self.ext.iter().map(|&e| ext[e as usize]).collect()
    }

    /// Splits every vertex into one copy per fan of faces around it; fans
    /// are separated by boundary, non-manifold and inconsistent edges and by
    /// the `cuts` (undirected carrier edges, smaller index first). Repeats
    /// until every edge is manifold.
    fn split(&mut self, cuts: &HashSet<(u32, u32)>) {
        for round in 0..6 {
            let before = self.topology.vertex_count;
            split_fans(self, cuts);
            let adj = Adjacency::build(&self.topology.faces);
            if !adj.is_manifold() && (self.topology.vertex_count == before || round >= 3) {
                // Fans joined around both ends: the faces past two on such
                // an edge become triangles of their own.
                self.detach(&adj);
            }
            self.report.split_vertices += self.topology.vertex_count - before;
            if Adjacency::build(&self.topology.faces).is_manifold() {
                return;
            }
        }
    }

    /// Gives every face but the first two of each non-manifold edge (and
    /// the second of each inconsistent one) its own copies of its vertices.
    fn detach(&mut self, adj: &Adjacency) {
        let bad: HashSet<(u32, u32)> = adj
            .non_manifold_edges
            .iter()
            .map(|&(a, b, _)| (a, b))
            .chain(adj.inconsistent_edges.iter().copied())
            .collect();
        let mut seen: HashMap<(u32, u32), usize> = HashMap::new();
        for f in 0..self.topology.faces.len() {
            let face = self.topology.faces[f];
            let keys = [0, 1, 2].map(|k| {
                let (a, b) = (face[k], face[(k + 1) % 3]);
                (a.min(b), a.max(b))
            });
            let mut counts = keys.iter().filter(|k| bad.contains(k)).map(|k| {
                let n = seen.entry(*k).or_insert(0);
                *n += 1;
                *n
            });
            let limit = |k: &(u32, u32)| if adj.inconsistent_edges.contains(k) { 1 } else { 2 };
            let over = keys.iter().filter(|k| bad.contains(k)).zip(counts.by_ref()).any(|(k, n)| n > limit(k));
            if over {
                for k in 0..3 {
                    self.topology.faces[f][k] = self.add_copy(self.topology.faces[f][k]);
                }
            }
        }
    }

    /// Glues back the two sides of each slit the split opened: boundary
    /// edges of one part that run between copies of the same two input
    /// vertices in opposite directions (two cubes that shared an edge
    /// come apart as two closed cubes, not as two cubes with a slit, whose
    /// closing fan would have no area).
    fn zip_slits(&mut self) {
        let faces = &self.topology.faces;
        let adj = Adjacency::build(faces);
        let mut part = Dsu::new(self.topology.vertex_count);
        for f in faces {
            part.union(f[0], f[1]);
            part.union(f[0], f[2]);
        }
        let mut open: HashMap<(u32, u32, u32), Vec<u32>> = HashMap::new();
        let boundary: Vec<u32> = (0..adj.opposite.len() as u32).filter(|&h| adj.opposite[h as usize] == NONE).collect();
        for &h in &boundary {
            let (a, b) = (origin(faces, h), target(faces, h));
            open.entry((part.find(a), self.ext[a as usize], self.ext[b as usize])).or_default().push(h);
        }
        let mut glue = Dsu::new(self.topology.vertex_count);
        let mut used = HashSet::new();
        for &h in &boundary {
            let (a, b) = (origin(faces, h), target(faces, h));
            let key = (part.find(a), self.ext[b as usize], self.ext[a as usize]);
            if used.contains(&h) {
                continue;
            }
            let Some(g) = open.get(&key).and_then(|l| l.iter().find(|g| !used.contains(*g) && **g != h)).copied()
            else {
                continue;
            };
            used.extend([h, g]);
            glue.union(origin(faces, g), b);
            glue.union(target(faces, g), a);
        }
        if used.is_empty() {
            return;
        }
        for v in self.topology.faces.iter_mut().flatten() {
            *v = glue.find(*v);
        }
    }

    /// Renumbers the carrier vertices so that every one is used by a face.
    fn drop_unused(&mut self) {
        let used = super::topology::used_by(&self.topology.faces, self.topology.vertex_count);
        let mut new_index = vec![NONE; used.len()];
        let mut ext = Vec::with_capacity(used.len());
        for (v, _) in used.iter().enumerate().filter(|(_, &u)| u) {
            new_index[v] = ext.len() as u32;
            ext.push(self.ext[v]);
        }
        for v in self.topology.faces.iter_mut().flatten() {
            *v = new_index[*v as usize];
        }
        self.topology.vertex_count = ext.len();
        self.ext = ext;
    }

    /// Joins parts that have holes rim to rim by strips ([`super::bridge`]):
    /// pairs of rims on different parts, closest centres first, each rim
    /// bridged at most once and never two rims of parts already joined (that
    /// would make a handle), as Kruskal's spanning tree takes edges. Parts
    /// left apart are joined by [`Carrier::join_parts`]'s tubes.
    fn bridge_parts(&mut self, reference: &[Vec3]) {
        let faces = &self.topology.faces;
        let parts = face_parts(faces, self.topology.vertex_count);
        self.report.parts = parts.len();
        if parts.len() < 2 {
            return;
        }
        let mut part_of = vec![0; faces.len()];
        for (k, part) in parts.iter().enumerate() {
            part.iter().for_each(|&f| part_of[f as usize] = k as u32);
        }
        let adj = Adjacency::build(faces);
        let pos = self.positions(reference);
        let closed_simple = |lp: &Vec<u32>| {
            let mut v: Vec<u32> = lp.iter().map(|&h| origin(faces, h)).collect();
            let closes = lp.last().is_some_and(|&h| target(faces, h) == v[0]);
            v.sort_unstable();
            v.dedup();
            closes && v.len() == lp.len() && v.len() >= 3
        };
        let mut rims: Vec<Rim> = boundary_loops(faces, &adj)
            .into_iter()
            .filter(closed_simple)
            .map(|lp| {
                let vertices: Vec<u32> = lp.iter().map(|&h| origin(faces, h)).collect();
                let centre = vertices.iter().map(|&v| pos[v as usize]).sum::<Vec3>() / vertices.len() as f32;
                Rim { part: part_of[(lp[0] / 3) as usize], vertices, centre }
            })
            .collect();
        // The longest rims only, so that the pairs stay few on a mesh with
        // holes everywhere.
        rims.sort_by_key(|r| std::cmp::Reverse(r.vertices.len()));
        rims.truncate(MAX_BRIDGED_RIMS);
        let mut pairs: Vec<(f32, usize, usize)> = Vec::new();
        for i in 0..rims.len() {
            for j in (i + 1..rims.len()).filter(|&j| rims[j].part != rims[i].part) {
                pairs.push((rims[i].centre.distance_squared(rims[j].centre), i, j));
            }
        }
        pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut joined = Dsu::new(parts.len());
        let mut used = vec![false; rims.len()];
        for (_, i, j) in pairs {
            if used[i] || used[j] || joined.find(rims[i].part) == joined.find(rims[j].part) {
                continue;
            }
            // The larger part's rim leads the strip, as when growing the
            // largest part (the strip's greedy walk is not symmetric).
            let size = |r: &Rim| parts[r.part as usize].len();
            let (a, b) = if size(&rims[i]) >= size(&rims[j]) { (i, j) } else { (j, i) };
            let strip = super::bridge::strip(&rims[a].vertices, &rims[b].vertices, &pos);
            self.real.extend(strip.iter().map(|_| false));
            self.topology.faces.extend(strip);
            joined.union(rims[i].part, rims[j].part);
            (used[i], used[j]) = (true, true);
            self.report.bridges += 1;
        }
    }

    /// Closes every boundary loop with a fan around a new vertex at the
    /// mean of its rim.
    fn close_loops(&mut self) {
        let adj = Adjacency::build(&self.topology.faces);
        for lp in boundary_loops(&self.topology.faces, &adj) {
            let faces = &self.topology.faces;
            let rim: Vec<(u32, u32)> = lp.iter().map(|&h| (origin(faces, h), target(faces, h))).collect();
            let centre = self.add_mean(rim.iter().map(|&(a, _)| self.ext[a as usize]).collect());
            for (a, b) in rim {
                // The rim runs a -> b with the surface on its left.
                self.topology.faces.push([b, a, centre]);
                self.real.push(false);
            }
            self.report.closed_loops += 1;
        }
    }

    /// Cuts every part of genus above 0 open along its cut graph and closes
    /// the loop that leaves.
    fn cut_handles(&mut self) {
        let adj = Adjacency::build(&self.topology.faces);
        let parts = face_parts(&self.topology.faces, self.topology.vertex_count);
        let mut cuts = HashSet::new();
        for part in &parts {
            let genus = part_genus(&self.topology.faces, part);
            if genus > 0 {
                self.report.handles += genus as usize;
                cuts.extend(cut_graph(&self.topology.faces, &adj, self.topology.vertex_count, part[0]));
            }
        }
        if cuts.is_empty() {
            return;
        }
        self.split(&cuts);
        self.close_loops();
    }

    /// Joins the closed parts into one surface by tubes, the largest part
    /// first, each other part to the nearest face of those joined so far.
    fn join_parts(&mut self, reference: &[Vec3]) {
        let mut parts = face_parts(&self.topology.faces, self.topology.vertex_count);
        if parts.len() < 2 {
            return;
        }
        parts.sort_by_key(|p| std::cmp::Reverse(p.len()));
        let pos = self.positions(reference);
        let centre = |f: &[u32; 3]| f.iter().map(|&v| pos[v as usize]).sum::<Vec3>() / 3.0;
        let centres: Vec<Vec3> = self.topology.faces.iter().map(centre).collect();
        let mut removed = vec![false; self.topology.faces.len()];
        let mut joined: Vec<u32> = parts[0].clone();
        for part in &parts[1..] {
            let (pa, pb) = (self.tube_ends(&joined, &removed), self.tube_ends(part, &removed));
            let (fa, fb) = nearest_pair(&pa, &pb, &centres);
            removed[fa as usize] = true;
            removed[fb as usize] = true;
            let (a, b) = (self.topology.faces[fa as usize], self.topology.faces[fb as usize]);
            for i in 0..3 {
                let (b0, b1) = (b[(3 - i) % 3], b[(5 - i) % 3]);
                self.topology.faces.push([a[i], a[(i + 1) % 3], b1]);
                self.topology.faces.push([a[i], b1, b0]);
                self.real.extend([false, false]);
            }
            joined.extend_from_slice(part);
        }
        // The tubes' faces come after every removed one.
        let kept = |f: usize| !removed.get(f).copied().unwrap_or(false);
        let faces = std::mem::take(&mut self.topology.faces);
        let real = std::mem::take(&mut self.real);
        (self.topology.faces, self.real) =
            faces.into_iter().zip(real).enumerate().filter(|(f, _)| kept(*f)).map(|(_, x)| x).unzip();
    }

    /// The faces of `part` a tube may start from: its added ones where it
    /// has some (so no input face is taken out), else all of them.
    fn tube_ends(&self, part: &[u32], removed: &[bool]) -> Vec<u32> {
        let free: Vec<u32> = part.iter().copied().filter(|&f| !removed[f as usize]).collect();
        let added: Vec<u32> = free.iter().copied().filter(|&f| !self.real[f as usize]).collect();
        if added.is_empty() {
            free
        } else {
            added
        }
    }
}

/// A boundary loop of the carrier before closing: its part, its vertices
/// as the surface runs them, and their mean on the reference frame.
struct Rim {
    part: u32,
    vertices: Vec<u32>,
    centre: Vec3,
}

/// See [`Carrier::bridge_parts`].
const MAX_BRIDGED_RIMS: usize = 1024;

/// A close pair of faces, one from each list: the closest pair of up to
/// [`PAIR_SAMPLES`] faces of each, then each end moved to the face of its
/// list nearest to the other end.
fn nearest_pair(a: &[u32], b: &[u32], centres: &[Vec3]) -> (u32, u32) {
    let sample = |l: &[u32]| -> Vec<u32> { l.iter().step_by(l.len().div_ceil(PAIR_SAMPLES).max(1)).copied().collect() };
    let d = |x: u32, y: u32| centres[x as usize].distance_squared(centres[y as usize]);
    let nearest = |l: &[u32], y: u32| l.iter().copied().min_by(|&p, &q| d(p, y).total_cmp(&d(q, y))).unwrap_or(y);
    let (sa, sb) = (sample(a), sample(b));
    let mut best = (f32::INFINITY, a[0], b[0]);
    for &x in &sa {
        let y = nearest(&sb, x);
        if d(x, y) < best.0 {
            best = (d(x, y), x, y);
        }
    }
    let fa = nearest(a, best.2);
    (fa, nearest(b, fa))
}

/// See [`nearest_pair`].
const PAIR_SAMPLES: usize = 512;

/// The input's faces less those that repeat a vertex or another face (kept
/// in the source mesh, left out of the carrier).
/// Splits `faces` (over `nv` vertices) into those of the carrier and the
/// vertices of the tiny parts left out (see [`LOOSE_MAX_VERTICES`]).
fn leave_out_tiny_parts(
    faces: Vec<[u32; 3]>,
    nv: usize,
    loose_max: usize,
    report: &mut CarrierReport,
) -> (Vec<[u32; 3]>, Vec<u32>) {
    let parts = face_parts(&faces, nv);
    let vertices: Vec<Vec<u32>> = parts
        .iter()
        .map(|p| {
            let mut v: Vec<u32> = p.iter().flat_map(|&f| faces[f as usize]).collect();
            v.sort_unstable();
            v.dedup();
            v
        })
        .collect();
    // The largest part (the one with the lowest vertex among equals, for
    // determinism) always stays.
    let largest = (0..parts.len()).max_by_key(|&k| (vertices[k].len(), std::cmp::Reverse(vertices[k][0])));
    let tiny: Vec<usize> = (0..parts.len()).filter(|&k| vertices[k].len() <= loose_max && Some(k) != largest).collect();
    if tiny.is_empty() {
        return (faces, Vec::new());
    }
    let mut left_out = vec![false; faces.len()];
    tiny.iter().flat_map(|&k| &parts[k]).for_each(|&f| left_out[f as usize] = true);
    let mut loose: Vec<u32> = tiny.iter().flat_map(|&k| vertices[k].iter().copied()).collect();
    loose.sort_unstable();
    report.loose_parts = tiny.len();
    report.loose_vertices = loose.len();
    let kept = faces.into_iter().zip(left_out).filter(|(_, out)| !out).map(|(f, _)| f).collect();
    (kept, loose)
}

fn clean_faces(faces: &[[u32; 3]], report: &mut CarrierReport) -> (Vec<[u32; 3]>, Vec<bool>) {
    let mut seen = HashSet::new();
    let mut kept = Vec::with_capacity(faces.len());
    for f in faces {
        let mut key = *f;
        key.sort_unstable();
        if key[0] == key[1] || key[1] == key[2] || !seen.insert(key) {
            report.dropped_faces += 1;
        } else {
            kept.push(*f);
        }
    }
    let real = vec![true; kept.len()];
    (kept, real)
}

/// Flips faces so that each part runs its shared edges in opposite
/// directions where it can (a non-orientable part keeps its conflicts,
/// which the fan split then cuts). Returns the number flipped.
fn orient(faces: &mut [[u32; 3]]) -> usize {
    let mut by_edge: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (f, face) in faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (face[k], face[(k + 1) % 3]);
            by_edge.entry((a.min(b), a.max(b))).or_default().push(f as u32);
        }
    }
    let runs = |face: &[u32; 3], a: u32, b: u32| (0..3).any(|k| face[k] == a && face[(k + 1) % 3] == b);
    let mut done = vec![false; faces.len()];
    let mut flipped = 0;
    for start in 0..faces.len() {
        if done[start] {
            continue;
        }
        done[start] = true;
        let mut queue = VecDeque::from([start as u32]);
        while let Some(f) = queue.pop_front() {
            let face = faces[f as usize];
            for k in 0..3 {
                let (a, b) = (face[k], face[(k + 1) % 3]);
                let Some(list) = by_edge.get(&(a.min(b), a.max(b))) else { continue };
                if list.len() != 2 {
                    continue;
                }
                let g = if list[0] == f { list[1] } else { list[0] };
                if done[g as usize] {
                    continue;
                }
                done[g as usize] = true;
                if runs(&faces[g as usize], a, b) {
                    faces[g as usize].swap(1, 2);
                    flipped += 1;
                }
                queue.push_back(g);
            }
        }
    }
    flipped
}

/// One carrier vertex per fan of faces around each vertex (see
/// [`Carrier::split`]); the first fan met keeps the vertex's index.
fn split_fans(c: &mut Carrier, cuts: &HashSet<(u32, u32)>) {
    let mut faces = std::mem::take(&mut c.topology.faces);
    let adj = Adjacency::build(&faces);
    let mut corners = Dsu::new(faces.len() * 3);
    for (h, &o) in adj.opposite.iter().enumerate() {
        let (a, b) = (origin(&faces, h as u32), target(&faces, h as u32));
        if o != NONE && (h as u32) < o && !cuts.contains(&(a.min(b), a.max(b))) {
            corners.union(h as u32, next(o));
            corners.union(next(h as u32), o);
        }
    }
    let mut first_root = vec![NONE; c.topology.vertex_count];
    let mut copies: HashMap<(u32, u32), u32> = HashMap::new();
    for h in 0..(faces.len() * 3) as u32 {
        let v = origin(&faces, h);
        let root = corners.find(h);
        let slot = &mut faces[(h / 3) as usize][(h % 3) as usize];
        if first_root[v as usize] == NONE {
            first_root[v as usize] = root;
        } else if first_root[v as usize] != root {
            *slot = *copies.entry((v, root)).or_insert_with(|| c.add_copy(v));
        }
    }
    c.topology.faces = faces;
}

/// The faces of each connected part (joined through shared vertices).
fn face_parts(faces: &[[u32; 3]], nv: usize) -> Vec<Vec<u32>> {
    let mut dsu = Dsu::new(nv);
    for f in faces {
        dsu.union(f[0], f[1]);
        dsu.union(f[0], f[2]);
    }
    let mut index: HashMap<u32, usize> = HashMap::new();
    let mut parts: Vec<Vec<u32>> = Vec::new();
    for (i, f) in faces.iter().enumerate() {
        let root = dsu.find(f[0]);
        let k = *index.entry(root).or_insert_with(|| {
            parts.push(Vec::new());
            parts.len() - 1
        });
        parts[k].push(i as u32);
    }
    parts
}

/// The genus of a closed part: (2 - V + E - F) / 2.
fn part_genus(faces: &[[u32; 3]], part: &[u32]) -> i64 {
    let mut vertices = HashSet::new();
    let mut edges = HashSet::new();
    for &f in part {
        let face = faces[f as usize];
        for k in 0..3 {
            vertices.insert(face[k]);
            let (a, b) = (face[k], face[(k + 1) % 3]);
            edges.insert((a.min(b), a.max(b)));
        }
    }
    let euler = vertices.len() as i64 - edges.len() as i64 + part.len() as i64;
    ((2 - euler) / 2).max(0)
}

/// The cut graph of the closed part that holds face `start`: a spanning
/// tree of its vertices, a spanning tree of its faces across the edges
/// not in the first, and the 2g edges in neither, less the tree branches
/// that lead nowhere (Eppstein's tree-cotree decomposition). Cutting along
/// it opens the part into a disk.
fn cut_graph(faces: &[[u32; 3]], adj: &Adjacency, nv: usize, start: u32) -> Vec<(u32, u32)> {
    let key = |h: u32| {
        let (a, b) = (origin(faces, h), target(faces, h));
        (a.min(b), a.max(b))
    };
    let mut outgoing: Vec<Vec<u32>> = vec![Vec::new(); nv];
    for h in 0..(faces.len() * 3) as u32 {
        outgoing[origin(faces, h) as usize].push(h);
    }
    // The vertex tree.
    let root = faces[start as usize][0];
    let mut in_tree = HashSet::new();
    let mut seen = vec![false; nv];
    seen[root as usize] = true;
    let mut queue = VecDeque::from([root]);
    while let Some(v) = queue.pop_front() {
        for &h in &outgoing[v as usize] {
            let t = target(faces, h);
            if !seen[t as usize] {
                seen[t as usize] = true;
                in_tree.insert(key(h));
                queue.push_back(t);
            }
        }
    }
    // The face tree across the other edges; what is left are the generators.
    let mut face_seen = vec![false; faces.len()];
    face_seen[start as usize] = true;
    let mut in_cotree = HashSet::new();
    let mut queue = VecDeque::from([start]);
    while let Some(f) = queue.pop_front() {
        for h in 3 * f..3 * f + 3 {
            let o = adj.opposite[h as usize];
            if o == NONE || in_tree.contains(&key(h)) || face_seen[(o / 3) as usize] {
                continue;
            }
            face_seen[(o / 3) as usize] = true;
            in_cotree.insert(key(h));
            queue.push_back(o / 3);
        }
    }
    let mut cut: HashSet<(u32, u32)> = in_tree.clone();
    for f in (0..faces.len() as u32).filter(|&f| face_seen[f as usize]) {
        for h in 3 * f..3 * f + 3 {
            if !in_tree.contains(&key(h)) && !in_cotree.contains(&key(h)) {
                cut.insert(key(h));
            }
        }
    }
    prune(cut)
}

/// Removes the edges of a graph that lead to a dead end, until none does.
fn prune(mut edges: HashSet<(u32, u32)>) -> Vec<(u32, u32)> {
    let mut at: HashMap<u32, Vec<(u32, u32)>> = HashMap::new();
    for &(a, b) in &edges {
        at.entry(a).or_default().push((a, b));
        at.entry(b).or_default().push((a, b));
    }
    let mut degree: HashMap<u32, usize> = at.iter().map(|(&v, l)| (v, l.len())).collect();
    let mut leaves: Vec<u32> = degree.iter().filter(|&(_, &d)| d == 1).map(|(&v, _)| v).collect();
    while let Some(v) = leaves.pop() {
        let Some(e) = at.get(&v).and_then(|l| l.iter().find(|e| edges.contains(e)).copied()) else { continue };
        edges.remove(&e);
        for end in [e.0, e.1] {
            if let Some(d) = degree.get_mut(&end) {
                *d -= 1;
                if *d == 1 {
                    leaves.push(end);
                }
            }
        }
    }
    let mut out: Vec<(u32, u32)> = edges.into_iter().collect();
    out.sort_unstable();
    out
}

/// `frame` (input vertices) followed by the mean of each of `means`, in
/// order, into `out`: how every frame's added vertices are placed, by the
/// carrier and by the sample map alike.
pub fn extend_frame(means: &[Vec<u32>], frame: &[Vec3], out: &mut Vec<Vec3>) {
    out.clear();
    out.extend_from_slice(frame);
    for m in means {
        let sum: Vec3 = m.iter().map(|&i| out[i as usize]).sum();
        out.push(sum / m.len().max(1) as f32);
    }
}

/// Each input vertex's first carrier vertex.
fn first_copies(ext: &[u32], nv: usize) -> Vec<u32> {
    let mut first = vec![NONE; nv];
    for (c, &e) in ext.iter().enumerate() {
        if (e as usize) < nv && first[e as usize] == NONE {
            first[e as usize] = c as u32;
        }
    }
    first
}

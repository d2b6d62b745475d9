//! Cone points and the cut that opens a sphere-like mesh onto the square
//! orbifold of [`crate::grid`].
//!
//! Four cone vertices (placed on the extremities by farthest-point sampling
//! of geodesic distance, so that the cones' extra sampling lands on limbs) are
//! joined to a fifth vertex `P` by four disjoint shortest paths. Cutting along
//! this star opens the surface into a disk whose boundary maps onto the
//! square's border: `P` to the four corners, each cone to the middle of one
//! side. Instead of duplicating the boundary vertices, every face corner
//! carries the isometry of the orbifold (a half-turn about a cone, or a
//! composition of them) that takes its vertex's single unknown to the copy
//! that face sees; this is the one-unknown-per-vertex form of Aigerman &
//! Lipman, "Orbifold Tutte Embeddings", ACM TOG 34(6), 2015.

use crate::error::{Error, Result};
use crate::mesh::adjacency::{origin, prev, target, Adjacency};
use glam::{DVec2, DVec3};
use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

/// An isometry of the square orbifold: `u -> s u + t` with `s = ±1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Iso {
    pub s: f64,
    pub t: DVec2,
}

impl Iso {
    pub const IDENTITY: Iso = Iso { s: 1.0, t: DVec2::ZERO };
    /// The half-turn about `m`.
    pub fn half_turn(m: DVec2) -> Iso {
        Iso { s: -1.0, t: 2.0 * m }
    }
    pub fn apply(&self, u: DVec2) -> DVec2 {
        self.s * u + self.t
    }
    /// `self ∘ other`.
    pub fn then_after(&self, other: &Iso) -> Iso {
        Iso { s: self.s * other.s, t: self.s * other.t + self.t }
    }
}

/// The cone positions in the square [-1, 1]²: the middles of its top, right,
/// bottom and left sides, in that order.
pub const CONE_UV: [DVec2; 4] =
    [DVec2::new(0.0, 1.0), DVec2::new(1.0, 0.0), DVec2::new(0.0, -1.0), DVec2::new(-1.0, 0.0)];

/// The cut of a mesh and the per-corner isometries it implies.
#[derive(Debug, Clone)]
pub struct Cut {
    /// Cone vertices, in the order of [`CONE_UV`].
    pub cones: [u32; 4],
    /// The vertex that maps to the square's corners.
    pub corner: u32,
    /// The path from `corner` to `cones[k]`, both ends included.
    pub paths: [Vec<u32>; 4],
    /// For each face, the isometry of each of its corners.
    pub corner_iso: Vec<[Iso; 3]>,
}

/// Vertex neighbours with edge lengths, in compressed rows.
pub struct Graph {
    start: Vec<usize>,
    nbr: Vec<(u32, f64)>,
}

impl Graph {
    /// The number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.start.len().saturating_sub(1)
    }

    /// The number of neighbours of `v`.
    pub fn degree(&self, v: u32) -> usize {
        self.start.get(v as usize + 1).zip(self.start.get(v as usize)).map_or(0, |(b, a)| b - a)
    }

    pub fn new(nv: usize, faces: &[[u32; 3]], pos: &[DVec3]) -> Graph {
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(faces.len() * 6);
        for f in faces {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                pairs.push((a, b));
                pairs.push((b, a));
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        let mut start = vec![0; nv + 1];
        for &(a, _) in &pairs {
            start[a as usize + 1] += 1;
        }
        for i in 0..nv {
            start[i + 1] += start[i];
        }
        let nbr = pairs.iter().map(|&(a, b)| (b, pos[a as usize].distance(pos[b as usize]))).collect();
        Graph { start, nbr }
    }

    pub fn neighbours(&self, v: u32) -> &[(u32, f64)] {
        &self.nbr[self.start[v as usize]..self.start[v as usize + 1]]
    }

    /// Shortest-path distances from `source` over edges, never entering a
    /// `blocked` vertex; returns distances and predecessors.
    pub fn dijkstra(&self, source: u32, blocked: &[bool]) -> (Vec<f64>, Vec<u32>) {
        self.dijkstra_scaled(source, blocked, None)
    }

    /// [`dijkstra`](Self::dijkstra) with each edge's length times the mean
    /// of its ends' `scale` (a [`Guide`]'s pull), where given.
    pub fn dijkstra_scaled(&self, source: u32, blocked: &[bool], scale: Option<&[f64]>) -> (Vec<f64>, Vec<u32>) {
        #[derive(PartialEq)]
        struct Item(f64, u32);
        impl Eq for Item {}
        impl PartialOrd for Item {
            fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
                Some(self.cmp(o))
            }
        }
        impl Ord for Item {
            fn cmp(&self, o: &Self) -> Ordering {
                o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
            }
        }
        let n = self.start.len() - 1;
        let mut dist = vec![f64::INFINITY; n];
        let mut pred = vec![u32::MAX; n];
        let mut heap = BinaryHeap::new();
        dist[source as usize] = 0.0;
        heap.push(Item(0.0, source));
        while let Some(Item(d, v)) = heap.pop() {
            if d > dist[v as usize] {
                continue;
            }
            for &(w, len) in self.neighbours(v) {
                if blocked[w as usize] {
                    continue;
                }
                let len = scale.map_or(len, |f| len * 0.5 * (f[v as usize] + f[w as usize]));
                let nd = d + len;
                if nd < dist[w as usize] {
                    dist[w as usize] = nd;
                    pred[w as usize] = v;
                    heap.push(Item(nd, w));
                }
            }
        }
        (dist, pred)
    }
}

fn argmax(values: impl Iterator<Item = f64>) -> u32 {
    let mut best = (f64::NEG_INFINITY, 0u32);
    for (i, v) in values.enumerate() {
        if v > best.0 {
            best = (v, i as u32);
        }
    }
    best.1
}

/// The first `k` extremities by farthest-point sampling of geodesic
/// distance (the seed, the point farthest from vertex 0, left out).
pub fn extremities(graph: &Graph, nv: usize, k: usize) -> Vec<u32> {
    let free = vec![false; nv];
    let d0 = graph.dijkstra(0, &free).0;
    let mut picks = vec![argmax(d0.iter().copied())];
    let mut min_d = vec![f64::INFINITY; nv];
    while picks.len() < k + 1 {
        let d = graph.dijkstra(*picks.last().unwrap_or(&0), &free).0;
        for (m, x) in min_d.iter_mut().zip(d) {
            *m = m.min(x);
        }
        picks.push(argmax(min_d.iter().copied()));
    }
    picks.split_off(1)
}

/// The vertex farthest from all of `cones`.
pub fn corner_for(graph: &Graph, nv: usize, cones: &[u32]) -> u32 {
    let free = vec![false; nv];
    let mut min_d = vec![f64::INFINITY; nv];
    for &c in cones {
        let d = graph.dijkstra(c, &free).0;
        for (m, x) in min_d.iter_mut().zip(d) {
            *m = m.min(x);
        }
    }
    // Four paths leave the corner by four different edges: a vertex of
    // fewer neighbours (a coarse mesh has some) cannot be it.
    let roomy = (0..nv as u32).any(|v| graph.degree(v) >= 4 && !cones.contains(&v));
    argmax(min_d.iter().enumerate().map(|(v, &d)| if roomy && graph.degree(v as u32) < 4 { -1.0 } else { d }))
}

/// Picks four cones on the extremities (farthest-point sampling of geodesic
/// distance) and the corner vertex farthest from all of them.
pub fn choose_cones(graph: &Graph, nv: usize) -> ([u32; 4], u32) {
    let e = extremities(graph, nv, 4);
    let cones = [e[0], e[1], e[2], e[3]];
    (cones, corner_for(graph, nv, &cones))
}

/// Checks that the cones and the corner are five distinct vertices of the mesh.
fn check_cone_vertices(nv: usize, cones: [u32; 4], corner: u32) -> Result<()> {
    let mut distinct = cones.to_vec();
    distinct.push(corner);
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.len() != 5 || distinct.iter().any(|&v| v as usize >= nv) {
        return Err(Error::Argument(format!("cones {cones:?} and corner {corner} must be five distinct vertices")));
    }
    Ok(())
}

/// Where each cone's cut path should run: near an earlier cut's (the
/// previous frame's, in a capture without correspondence). Two shortest
/// paths between the same cones can go different ways round a body, and
/// the map changes with them (another homotopy class of the cut gives
/// another orbifold map), so a path pays for leaving its guide, and the
/// cones keep their order round the corner.
#[derive(Debug, Clone)]
pub struct CutGuide {
    /// Per cone (in the order the cut is asked for), each vertex's
    /// distance from that cone's earlier path, in diagonals (how far is
    /// the caller's measure).
    pub away: [Vec<f64>; 4],
    /// The cones (by that order) on the square's sides (top, right,
    /// bottom, left) in the earlier cut: the order a cut keeps, up to a turn.
    pub sides: [usize; 4],
}

/// A [`CutGuide`] as the cut uses it.
pub struct Guide {
    /// Per cone, each vertex's factor on the lengths of its edges.
    scale: [Vec<f64>; 4],
    sides: [usize; 4],
}

/// A path [`Guide`]d `GUIDE_WIDTH` of the diagonal away from its guide pays
/// `1 + GUIDE_PULL` times an edge's length, four widths away and beyond
/// `1 + 16 GUIDE_PULL`: enough to keep it on its side of a limb or torso
/// (a few widths across), not so much that it follows every kink of the
/// earlier path.
pub const GUIDE_WIDTH: f64 = 0.03;
const GUIDE_PULL: f64 = 1.0;

impl Guide {
    pub fn new(guide: &CutGuide) -> Guide {
        let scale = guide.away.each_ref().map(|a| {
            a.iter()
                .map(|d| {
                    let r = (d / GUIDE_WIDTH).min(4.0);
                    1.0 + GUIDE_PULL * if r.is_nan() { 16.0 } else { r * r }
                })
                .collect()
        });
        Guide { scale, sides: guide.sides }
    }

    /// Whether `cut` (asked for with `cones`) puts the cones on the sides
    /// in the guide's order, up to a turn.
    fn kept_by(&self, cut: &Cut, cones: &[u32; 4]) -> bool {
        let at = cut.cones.map(|v| cones.iter().position(|&c| c == v));
        (0..4).any(|r| (0..4).all(|i| at[(i + r) % 4] == Some(self.sides[i])))
    }
}

/// Four paths from `corner` to the `cones` (in their order) that share no
/// vertex but the corner and pass through no other cone, if there are any:
/// a maximum flow of 4 (Edmonds and Karp 1972) through the graph with each
/// vertex split into an in and an out node joined by one unit of capacity
/// (Menger's theorem). Not the shortest paths, so only the last resort.
fn disjoint_paths(graph: &Graph, nv: usize, cones: [u32; 4], corner: u32) -> Option<Vec<Vec<u32>>> {
    let mut flow = UnitFlow::new(2 * nv + 1);
    let (node_in, node_out, sink) = (|v: u32| 2 * v as usize, |v: u32| 2 * v as usize + 1, 2 * nv);
    for v in 0..nv as u32 {
        if !cones.contains(&v) && v != corner {
            flow.edge(node_in(v), node_out(v));
        }
        for &(w, _) in graph.neighbours(v) {
            flow.edge(node_out(v), node_in(w));
        }
    }
    for &c in &cones {
        flow.edge(node_in(c), sink);
    }
    let source = node_out(corner);
    if (0..4).any(|_| !flow.augment(source, sink)) {
        return None;
    }
    let mut paths = vec![Vec::new(); 4];
    for _ in 0..4 {
        let mut path = vec![corner];
        let mut at = source;
        while at != sink {
            at = flow.take_unit(at)?;
            let v = (at / 2) as u32;
            if at != sink && path.last() != Some(&v) {
                path.push(v);
            }
        }
        let k = cones.iter().position(|c| path.last() == Some(c))?;
        paths[k] = path;
    }
    Some(paths)
}

/// A flow network of unit capacities: the residual graph as edge lists.
struct UnitFlow {
    /// Per node, the indices of its edges in `to`/`cap`.
    out: Vec<Vec<usize>>,
    to: Vec<usize>,
    cap: Vec<u8>,
    /// Whether an edge is one of the network's (not a residual reverse).
    forward: Vec<bool>,
}

impl UnitFlow {
    fn new(nodes: usize) -> UnitFlow {
        UnitFlow { out: vec![Vec::new(); nodes], to: Vec::new(), cap: Vec::new(), forward: Vec::new() }
    }

    /// A unit edge a -> b and its reverse (edge e's reverse is e ^ 1).
    fn edge(&mut self, a: usize, b: usize) {
        for (from, to, cap, forward) in [(a, b, 1, true), (b, a, 0, false)] {
            self.out[from].push(self.to.len());
            self.to.push(to);
            self.cap.push(cap);
            self.forward.push(forward);
        }
    }

    /// Pushes one unit along a shortest augmenting path; false if none.
    fn augment(&mut self, source: usize, sink: usize) -> bool {
        let mut via = vec![usize::MAX; self.out.len()];
        let mut queue = std::collections::VecDeque::from([source]);
        let mut seen = vec![false; self.out.len()];
        seen[source] = true;
        while let Some(a) = queue.pop_front() {
            for &e in &self.out[a] {
                let b = self.to[e];
                if self.cap[e] > 0 && !seen[b] {
                    (seen[b], via[b]) = (true, e);
                    queue.push_back(b);
                }
            }
        }
        if !seen[sink] {
            return false;
        }
        let mut at = sink;
        while at != source {
            let e = via[at];
            self.cap[e] -= 1;
            self.cap[e ^ 1] += 1;
            at = self.to[e ^ 1];
        }
        true
    }

    /// Follows and uses up one unit of flow leaving `a` along a network
    /// edge; returns the node it reaches.
    fn take_unit(&mut self, a: usize) -> Option<usize> {
        let e = *self.out[a].iter().find(|&&e| self.forward[e] && self.cap[e] == 0 && self.cap[e ^ 1] > 0)?;
        self.cap[e ^ 1] -= 1;
        Some(self.to[e])
    }
}

/// The 24 orders of four cones, the given one first.
const ORDERS: [[usize; 4]; 24] = {
    let mut out = [[0; 4]; 24];
    let mut n = 0;
    let mut a = 0;
    while a < 4 {
        let mut b = 0;
        while b < 4 {
            let mut c = 0;
            while c < 4 {
                if a != b && b != c && a != c {
                    out[n] = [a, b, c, 6 - a - b - c];
                    n += 1;
                }
                c += 1;
            }
            b += 1;
        }
        a += 1;
    }
    out
};

/// Shortest paths from `corner` to each of `cones` (each pulled towards
/// its `guide`'s path, if given), both ends included, in the order of
/// `cones`; found one after the other in the order `order`, each avoiding
/// those found before. Errs with the first cone walled off.
fn cut_paths_in_order(
    graph: &Graph,
    nv: usize,
    cones: [u32; 4],
    order: [usize; 4],
    corner: u32,
    guide: Option<&Guide>,
) -> Result<Vec<Vec<u32>>> {
    // Four disjoint paths from the corner, each avoiding the others and the other cones.
    let mut blocked = vec![false; nv];
    for &c in &cones {
        blocked[c as usize] = true;
    }
    let mut paths: Vec<Vec<u32>> = vec![Vec::new(); 4];
    for k in order {
        let cone = cones[k];
        blocked[cone as usize] = false;
        let (dist, pred) = graph.dijkstra_scaled(corner, &blocked, guide.map(|g| &g.scale[k][..]));
        if !dist[cone as usize].is_finite() {
            return Err(Error::Numerical(format!(
                "cannot cut the surface: no path from vertex {corner} to cone {cone} avoids the other cuts"
            )));
        }
        let mut path = vec![cone];
        while *path.last().unwrap_or(&corner) != corner {
            path.push(pred[*path.last().unwrap_or(&corner) as usize]);
        }
        path.reverse();
        for &v in &path[1..] {
            blocked[v as usize] = true;
        }
        paths[k] = path;
    }
    Ok(paths)
}

/// Reorders the cones and their paths so that `cones[i]` sits at `CONE_UV[i]`.
fn order_by_side(cones: [u32; 4], paths: &[Vec<u32>], cone_uv: &[DVec2; 4]) -> ([u32; 4], [Vec<u32>; 4]) {
    let mut ordered = [0u32; 4];
    let mut ordered_paths: [Vec<u32>; 4] = Default::default();
    for k in 0..4 {
        let side = CONE_UV.iter().position(|&m| m == cone_uv[k]).unwrap_or(k);
        ordered[side] = cones[k];
        ordered_paths[side] = paths[k].clone();
    }
    (ordered, ordered_paths)
}

/// The fans of a mesh's vertices, walked with respect to the cut paths.
struct CutFans<'a> {
    faces: &'a [[u32; 3]],
    adj: &'a Adjacency,
    /// Cut edges (as sorted vertex pairs), labelled by their path.
    cut_edge: HashMap<(u32, u32), usize>,
    /// A half-edge leaving each vertex.
    out_he: Vec<u32>,
}

impl<'a> CutFans<'a> {
    /// Labels the edges of `paths` and finds a half-edge leaving each vertex.
    fn new(faces: &'a [[u32; 3]], adj: &'a Adjacency, nv: usize, paths: &[Vec<u32>]) -> CutFans<'a> {
        // Cut edges, labelled by their path.
        let mut cut_edge: HashMap<(u32, u32), usize> = HashMap::new();
        for (k, p) in paths.iter().enumerate() {
            for w in p.windows(2) {
                cut_edge.insert((w[0].min(w[1]), w[0].max(w[1])), k);
            }
        }
        let mut out_he = vec![u32::MAX; nv];
        for h in 0..(faces.len() * 3) as u32 {
            out_he[origin(faces, h) as usize] = h;
        }
        CutFans { faces, adj, cut_edge, out_he }
    }

    /// The path edge `a`-`b` lies on, if it is a cut edge.
    fn is_cut(&self, a: u32, b: u32) -> Option<usize> {
        self.cut_edge.get(&(a.min(b), a.max(b))).copied()
    }

    /// Walks the fan of `v` counter-clockwise from just after a cut edge and
    /// returns (corner half-edge, number of cut edges crossed before it), and
    /// the paths crossed in order (the first is the one the walk starts after).
    fn walk(&self, v: u32) -> (Vec<(u32, usize)>, Vec<usize>) {
        let (faces, adj) = (self.faces, self.adj);
        let any = self.out_he[v as usize];
        let start = adj.fan(any).find(|&h| self.is_cut(v, target(faces, h)).is_some()).unwrap_or(any);
        let mut crossed = vec![self.is_cut(v, target(faces, start)).unwrap_or(0)];
        let mut comp = 0;
        let mut corners = Vec::new();
        for h in adj.fan(start) {
            corners.push((h, comp));
            let b = origin(faces, prev(h));
            if let Some(k) = self.is_cut(v, b) {
                comp += 1;
                crossed.push(k);
            }
        }
        (corners, crossed)
    }

    /// Sets the isometries of the corners around the corner vertex and returns each path's cone position.
    fn around_corner(&self, corner: u32, mirror: bool, corner_iso: &mut [[Iso; 3]]) -> Result<[DVec2; 4]> {
        let mut cone_uv = [DVec2::ZERO; 4];
        // Around the corner vertex: the paths in rotational order get the
        // square's sides top, right, bottom, left (or the mirror order).
        let (corners, crossed) = self.walk(corner);
        if crossed.len() != 5 {
            return Err(Error::Numerical(format!(
                "cut around vertex {corner} crosses {} paths, expected 4",
                crossed.len() - 1
            )));
        }
        let sides: [usize; 4] = if mirror { [1, 0, 3, 2] } else { [0, 1, 2, 3] };
        for (i, &k) in crossed[..4].iter().enumerate() {
            cone_uv[k] = CONE_UV[sides[i]];
        }
        let mut comp_iso = [Iso::IDENTITY; 4];
        for c in 1..4 {
            comp_iso[c] = Iso::half_turn(cone_uv[crossed[c]]).then_after(&comp_iso[c - 1]);
        }
        for (h, comp) in corners {
            corner_iso[(h / 3) as usize][(h % 3) as usize] = comp_iso[comp.min(3)];
        }
        Ok(cone_uv)
    }

    /// Sets the isometries of the corners on one side of each path's inner vertices.
    fn along_paths(&self, paths: &[Vec<u32>], cone_uv: &[DVec2; 4], corner_iso: &mut [[Iso; 3]]) -> Result<()> {
        // Along each path: the two sides differ by the half-turn about its cone.
        for (k, p) in paths.iter().enumerate() {
            let ht = Iso::half_turn(cone_uv[k]);
            for &v in &p[1..p.len() - 1] {
                let (corners, crossed) = self.walk(v);
                if crossed.len() != 3 {
                    return Err(Error::Numerical(format!("cut path meets itself at vertex {v}")));
                }
                for (h, comp) in corners {
                    if comp == 1 {
                        corner_iso[(h / 3) as usize][(h % 3) as usize] = ht;
                    }
                }
            }
        }
        Ok(())
    }
}

impl Cut {
    /// Builds the cut for the given cones and corner vertex. `mirror` assigns
    /// the cones to the square's sides in the opposite rotational order (for
    /// meshes whose faces turn clockwise seen from outside); `guide` pulls
    /// the paths towards an earlier cut's and keeps its cones' order.
    ///
    /// The paths are found one after the other, so an early one can wall a
    /// later cone off (on coarse meshes), or leave the corner on the wrong
    /// side of another; then the other orders are tried, and last any four
    /// vertex-disjoint paths ([`disjoint_paths`]), which exist whenever a
    /// cut does. A guide's order that no order of the paths keeps is let go.
    pub fn new(
        faces: &[[u32; 3]],
        adj: &Adjacency,
        graph: &Graph,
        cones: [u32; 4],
        corner: u32,
        mirror: bool,
        guide: Option<&Guide>,
    ) -> Result<Cut> {
        let nv = graph.vertex_count();
        check_cone_vertices(nv, cones, corner)?;
        let mut first: Option<Result<Cut>> = None;
        for order in ORDERS {
            let cut = cut_paths_in_order(graph, nv, cones, order, corner, guide)
                .and_then(|paths| Cut::along(faces, adj, nv, cones, corner, mirror, paths));
            let kept = |c: &Result<Cut>| c.as_ref().is_ok_and(|c| guide.is_none_or(|g| g.kept_by(c, &cones)));
            if kept(&cut) {
                return cut;
            }
            if first.as_ref().is_none_or(|f| f.is_err() && cut.is_ok()) {
                first = Some(cut);
            }
        }
        match first {
            Some(Ok(cut)) => Ok(cut),
            first => match disjoint_paths(graph, nv, cones, corner) {
                Some(paths) => Cut::along(faces, adj, nv, cones, corner, mirror, paths),
                None => first.unwrap_or_else(|| Err(Error::Numerical("no cut".into()))),
            },
        }
    }

    /// The cut along `paths` (from `corner` to each of `cones`).
    fn along(
        faces: &[[u32; 3]],
        adj: &Adjacency,
        nv: usize,
        cones: [u32; 4],
        corner: u32,
        mirror: bool,
        paths: Vec<Vec<u32>>,
    ) -> Result<Cut> {
        let fans = CutFans::new(faces, adj, nv, &paths);
        let mut corner_iso = vec![[Iso::IDENTITY; 3]; faces.len()];
        let cone_uv = fans.around_corner(corner, mirror, &mut corner_iso)?;
        fans.along_paths(&paths, &cone_uv, &mut corner_iso)?;
        let (ordered, ordered_paths) = order_by_side(cones, &paths, &cone_uv);
        Ok(Cut { cones: ordered, corner, paths: ordered_paths, corner_iso })
    }
}

//! Version 12: the source mesh's faces coded as a walk over the mesh, the
//! way meshoptimizer's index codec does (Kapoulkine, `encodeIndexBuffer`,
//! itself after Hoppe's vertex caches): a face that shares an edge with a
//! recent face names that edge in a cache of the last [`EDGES`] edges and
//! adds its third vertex; a vertex is the lowest index no face used yet,
//! one of the last [`VERTICES`] vertices used, or, rarely, its difference
//! from a vertex of the face. In a connected order nine faces in ten find
//! their edge (samba's traversal: 96 %), so a face costs its op byte and
//! one vertex reference before deflate.
//!
//! Each face keeps its vertices and their order (the op says which of its
//! three edges was found); the faces themselves are coded either in the
//! input's order or in a depth-first walk over shared edges, whichever
//! deflates smaller ([`Order`]): a scan's faces often come in no order
//! at all (samba), an exported mesh's in one already (face-poses).
//!
//! Layout, for `faces` faces: one op byte a face (`3 e + r`: the face's
//! edge `r`, from vertex `r` to `r + 1`, is the reverse of cached edge `e`;
//! [`MISS`]: no cached edge, the three vertices follow), then one
//! reference byte for each vertex the ops leave to name (0: the lowest
//! unused index; `1 + k`: the vertex cache's entry `k`; [`EXPLICIT`]: a
//! zigzag LEB128 difference from the face's vertex before it, in the
//! third part), then those differences.
//!
//! Version 20 (the header's `source_mesh.around`) names vertices two more
//! ways, which an input's own vertex order makes common: reference 0 is
//! the first index not used yet *after the last new vertex* (wrapping to
//! the lowest), since an exporter numbers a part's vertices in runs (wolf:
//! 68 % of its new vertices, against 3 % for the lowest unused index); and
//! reference [`AROUND`] + k is the k-th neighbour of the face's known
//! vertices (a named edge's two, else the vertex named before), their
//! lists one after the other, each in the order the coded faces first
//! made them neighbours: a fan closing on a vertex met long ago. A vertex
//! is new from when it is named (the next one in a face may be the one
//! after it), and keeps its first [`MAX_NEIGHBOURS`] neighbours.

use super::leb128;

/// Edges of recent faces a face may name.
pub const EDGES: usize = 16;
/// Vertices of recent faces a reference may name.
pub const VERTICES: usize = 16;
/// The op of a face that names no cached edge.
pub const MISS: u8 = (3 * EDGES) as u8;
/// The reference of a vertex given by its difference.
pub const EXPLICIT: u8 = VERTICES as u8 + 1;
/// Version 20: the first reference of a vertex given as a neighbour's
/// (those up to `AROUND + 2 MAX_NEIGHBOURS - 1` name the rest).
pub const AROUND: u8 = VERTICES as u8 + 2;
/// Version 20: most neighbours a vertex keeps (so that no vertex's list,
/// on any input, grows past a few searches).
pub const MAX_NEIGHBOURS: usize = 64;

/// The order the faces are coded in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    /// The input's own.
    Input = 0,
    /// Depth first over shared edges ([`walk_order`]).
    Walk = 1,
}

/// Move-to-front caches of edges and vertices, and the lowest index not
/// used yet: the state the coder and the decoder keep alike.
struct State {
    edges: Vec<[u32; 2]>,
    vertices: Vec<u32>,
    used: Vec<bool>,
    next: u32,
    /// Version 20's rules (none: version 12's).
    around: Option<Around20>,
}

/// Version 20: the indices not named yet, the last new vertex, the
/// neighbours (by vertex, only of vertices the faces use: a file that
/// declares many vertices and few faces holds little).
struct Around20 {
    unused: Unused,
    named: Vec<bool>,
    last_new: Option<u32>,
    neighbours: std::collections::HashMap<u32, Vec<u32>>,
}

impl State {
    fn new(vertex_count: usize, around: bool) -> State {
        let around = around.then(|| Around20 {
            unused: Unused::new(vertex_count),
            named: vec![false; vertex_count],
            last_new: None,
            neighbours: std::collections::HashMap::new(),
        });
        State { edges: Vec::new(), vertices: Vec::new(), used: vec![false; vertex_count], next: 0, around }
    }

    /// The vertex reference 0 names.
    fn next_new(&self) -> Option<u32> {
        match &self.around {
            None => Some(self.next),
            Some(a) => a.last_new.and_then(|l| a.unused.first_from(l + 1)).or_else(|| a.unused.first_from(0)),
        }
    }

    /// Version 20: the neighbours of `near` (the second only where it is
    /// not the first), one list after the other.
    fn neighbours(&self, near: [u32; 2]) -> impl Iterator<Item = u32> + '_ {
        let lists = self.around.as_ref().map(|a| &a.neighbours);
        let list = move |v: u32| lists.and_then(|l| l.get(&v)).into_iter().flatten().copied();
        list(near[0]).chain(list(near[1]).filter(move |_| near[1] != near[0]))
    }

    /// Version 20: a vertex is new until it is named.
    fn name(&mut self, v: u32) {
        if let Some(a) = &mut self.around {
            if a.named.get(v as usize) == Some(&false) {
                a.named[v as usize] = true;
                a.unused.remove(v);
                a.last_new = Some(v);
            }
        }
    }

    /// Records a coded face: its edges and vertices to the caches' fronts.
    fn push(&mut self, f: [u32; 3]) {
        for k in [2, 1, 0] {
            let e = [f[k], f[(k + 1) % 3]];
            to_front(&mut self.edges, e, EDGES);
        }
        if let Some(a) = &mut self.around {
            for (x, y) in [(0, 1), (1, 2), (2, 0), (1, 0), (2, 1), (0, 2)] {
                let list = a.neighbours.entry(f[x]).or_default();
                if f[x] != f[y] && list.len() < MAX_NEIGHBOURS && !list.contains(&f[y]) {
                    list.push(f[y]);
                }
            }
        }
        for &v in f.iter().rev() {
            to_front(&mut self.vertices, v, VERTICES);
            self.used[v as usize] = true;
        }
        while self.used.get(self.next as usize) == Some(&true) {
            self.next += 1;
        }
    }
}

/// The indices not used yet, as a Fenwick tree of ones (Fenwick 1994):
/// the first at or after an index in O(log n).
struct Unused {
    tree: Vec<u32>,
}

impl Unused {
    fn new(n: usize) -> Unused {
        let mut tree = vec![0u32; n + 1];
        for i in 1..=n {
            tree[i] += 1;
            let j = i + (i & i.wrapping_neg());
            if j <= n {
                tree[j] += tree[i];
            }
        }
        Unused { tree }
    }

    fn remove(&mut self, v: u32) {
        let mut i = v as usize + 1;
        while i < self.tree.len() {
            self.tree[i] -= 1;
            i += i & i.wrapping_neg();
        }
    }

    /// How many unused indices lie below `v`.
    fn before(&self, v: usize) -> u32 {
        let (mut i, mut sum) = (v.min(self.tree.len() - 1), 0);
        while i > 0 {
            sum += self.tree[i];
            i -= i & i.wrapping_neg();
        }
        sum
    }

    /// The first unused index at or after `v`.
    fn first_from(&self, v: u32) -> Option<u32> {
        // The (before + 1)-th unused index, found by descending the tree.
        let mut want = self.before(v as usize) + 1;
        let (mut at, mut step) = (0usize, (self.tree.len()).next_power_of_two());
        while step > 0 {
            if at + step < self.tree.len() && self.tree[at + step] < want {
                at += step;
                want -= self.tree[at];
            }
            step /= 2;
        }
        (at + 1 < self.tree.len()).then_some(at as u32)
    }
}

fn to_front<T: PartialEq + Copy>(cache: &mut Vec<T>, x: T, size: usize) {
    if let Some(i) = cache.iter().position(|&c| c == x) {
        cache.remove(i);
    }
    cache.insert(0, x);
    cache.truncate(size);
}

fn zigzag(d: i64) -> u64 {
    ((d << 1) ^ (d >> 63)) as u64
}

fn unzigzag(z: u64) -> i64 {
    (z >> 1) as i64 ^ -((z & 1) as i64)
}

/// The coded faces (ops, references, differences), in `order` of `faces`;
/// every index below `vertex_count`.
pub fn encode(faces: &[[u32; 3]], vertex_count: usize, around: bool) -> Vec<u8> {
    let mut s = State::new(vertex_count, around);
    let (mut ops, mut refs, mut diffs) = (Vec::with_capacity(faces.len()), Vec::new(), Vec::new());
    let mut name = |s: &mut State, v: u32, near: [u32; 2], refs: &mut Vec<u8>| {
        let from = near[0];
        if Some(v) == s.next_new() {
            refs.push(0);
        } else if let Some(k) = s.vertices.iter().position(|&c| c == v) {
            refs.push(1 + k as u8);
        } else if let Some(k) = s.neighbours(near).position(|n| n == v) {
            refs.push(AROUND + k as u8);
        } else {
            refs.push(EXPLICIT);
            leb128::write(&mut diffs, zigzag(v as i64 - from as i64));
        }
        s.name(v);
    };
    let mut last = 0;
    for &f in faces {
        let hit = (0..3).find_map(|r| {
            let reverse = [f[(r + 1) % 3], f[r]];
            s.edges.iter().position(|&e| e == reverse).map(|e| (e, r))
        });
        match hit {
            Some((e, r)) => {
                ops.push((3 * e + r) as u8);
                name(&mut s, f[(r + 2) % 3], [f[r], f[(r + 1) % 3]], &mut refs);
            }
            None => {
                ops.push(MISS);
                let mut from = last;
                for &v in &f {
                    name(&mut s, v, [from, from], &mut refs);
                    from = v;
                }
            }
        }
        last = f[2];
        s.push(f);
    }
    [ops, refs, diffs].concat()
}

/// Reads `faces` coded faces of indices below `vertices` from `raw` at
/// `at`, advancing it; an error says what is wrong.
pub fn decode(raw: &[u8], at: &mut usize, faces: u32, vertices: u32, around: bool) -> Result<Vec<[u32; 3]>, String> {
    let n = faces as usize;
    let ops = raw.get(*at..*at + n).ok_or("the faces' ops are cut short")?;
    let named: usize = ops.iter().map(|&op| if op == MISS { 3 } else { 1 }).sum();
    let refs = raw.get(*at + n..*at + n + named).ok_or("the faces' vertex references are cut short")?;
    let mut diff_at = *at + n + named;
    let mut s = State::new(vertices as usize, around);
    let mut refs = refs.iter();
    let mut out = Vec::with_capacity(n);
    let mut last = 0u32;
    for (i, &op) in ops.iter().enumerate() {
        let mut vertex = |s: &mut State, near: [u32; 2]| -> Result<u32, String> {
            let (r, from) = (*refs.next().ok_or("the faces' vertex references are cut short")?, near[0]);
            let v = match r {
                0 => i64::from(s.next_new().ok_or_else(|| format!("face {i} names a new vertex, but none is left"))?),
                k if k >= AROUND && s.around.is_some() => {
                    let n = s.neighbours(near).nth(usize::from(k - AROUND));
                    i64::from(n.ok_or_else(|| format!("face {i}: neighbour {} past the known", k - AROUND))?)
                }
                EXPLICIT => {
                    let z = leb128::read(raw, &mut diff_at, 5)
                        .ok_or_else(|| format!("face {i}: its index is cut short"))?;
                    i64::from(from) + unzigzag(z)
                }
                k if (k as usize) <= s.vertices.len() => i64::from(s.vertices[k as usize - 1]),
                k => return Err(format!("face {i}: vertex reference {k} past the {} cached", s.vertices.len())),
            };
            let v = u32::try_from(v)
                .ok()
                .filter(|&v| v < vertices)
                .ok_or_else(|| format!("face {i} uses vertex {v}, but there are {vertices}"))?;
            s.name(v);
            Ok(v)
        };
        let f = if op == MISS {
            let a = vertex(&mut s, [last; 2])?;
            let b = vertex(&mut s, [a; 2])?;
            [a, b, vertex(&mut s, [b; 2])?]
        } else {
            let (e, r) = (op as usize / 3, op as usize % 3);
            let [q, p] = *s.edges.get(e).ok_or_else(|| format!("face {i} names edge {e}, past the cached"))?;
            let mut f = [0; 3];
            (f[r], f[(r + 1) % 3], f[(r + 2) % 3]) = (p, q, vertex(&mut s, [p, q])?);
            f
        };
        last = f[2];
        s.push(f);
        out.push(f);
    }
    *at = diff_at;
    Ok(out)
}

/// The faces around each vertex (the faces' indices, in order).
pub struct Around {
    start: Vec<u32>,
    faces: Vec<u32>,
}

impl Around {
    pub fn new(faces: &[[u32; 3]], vertex_count: usize) -> Around {
        let mut start = vec![0u32; vertex_count + 1];
        for &v in faces.iter().flatten() {
            start[v as usize + 1] += 1;
        }
        for i in 0..vertex_count {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut around = vec![0u32; faces.len() * 3];
        for (i, f) in faces.iter().enumerate() {
            for &v in f {
                around[fill[v as usize] as usize] = i as u32;
                fill[v as usize] += 1;
            }
        }
        Around { start, faces: around }
    }

    /// The faces around vertex `v`, in index order (a face with `v` twice
    /// is listed twice).
    pub fn of(&self, v: u32) -> impl DoubleEndedIterator<Item = usize> + '_ {
        self.list(v).iter().map(|&i| i as usize)
    }

    /// The faces around vertex `v` before face `i`, the nearest first.
    pub fn before(&self, v: u32, i: usize) -> impl Iterator<Item = usize> + '_ {
        let list = self.list(v);
        list[..list.partition_point(|&j| (j as usize) < i)].iter().rev().map(|&j| j as usize)
    }

    fn list(&self, v: u32) -> &[u32] {
        &self.faces[self.start[v as usize] as usize..self.start[v as usize + 1] as usize]
    }
}

/// Whether face `g` has the directed edge (a, b).
pub fn has_edge(g: &[u32; 3], a: u32, b: u32) -> bool {
    (0..3).any(|m| g[m] == a && g[(m + 1) % 3] == b)
}

/// The faces' indices in a depth-first walk over shared edges, each part
/// from its first face in the input's order.
pub fn walk_order(faces: &[[u32; 3]], vertex_count: usize) -> Vec<usize> {
    let around = Around::new(faces, vertex_count);
    let (mut seen, mut order, mut stack) = (vec![false; faces.len()], Vec::with_capacity(faces.len()), Vec::new());
    for first in 0..faces.len() {
        stack.push(first);
        while let Some(i) = stack.pop() {
            if std::mem::replace(&mut seen[i], true) {
                continue;
            }
            order.push(i);
            let f = faces[i];
            // Pushed last, popped first: the face across edge 0 (a, b),
            // whose reverse the coder's edge cache holds at its front.
            for k in [2, 1, 0] {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                stack.extend(around.of(a).filter(|&j| !seen[j] && has_edge(&faces[j], b, a)));
            }
        }
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The faces back, coded by version 12's rules and by version 20's.
    fn round_trip(faces: &[[u32; 3]], vertices: u32) -> Vec<[u32; 3]> {
        let back = [false, true].map(|around| {
            let raw = encode(faces, vertices as usize, around);
            let mut at = 0;
            let back = decode(&raw, &mut at, faces.len() as u32, vertices, around).unwrap();
            assert_eq!(at, raw.len());
            back
        });
        assert_eq!(back[0], back[1]);
        back[0].clone()
    }

    /// A grid of `n` x `n` quads, two faces each, in a shuffled order.
    fn sheet(n: u32) -> Vec<[u32; 3]> {
        let mut faces = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let v = j * (n + 1) + i;
                faces.push([v, v + 1, v + n + 2]);
                faces.push([v, v + n + 2, v + n + 1]);
            }
        }
        // A fixed shuffle (an LCG), so a scan's unordered faces are tried.
        let mut x = 12345u64;
        for i in (1..faces.len()).rev() {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            faces.swap(i, (x >> 33) as usize % (i + 1));
        }
        faces
    }

    #[test]
    fn faces_come_back_as_coded_in_either_order() {
        let faces = sheet(20);
        let v = 21 * 21;
        assert_eq!(round_trip(&faces, v), faces);
        let walked: Vec<[u32; 3]> = walk_order(&faces, v as usize).into_iter().map(|i| faces[i]).collect();
        assert_eq!(round_trip(&walked, v), walked);
        let mut sorted = walked.clone();
        sorted.sort();
        let mut all = faces.clone();
        all.sort();
        assert_eq!(sorted, all, "the walk visits every face once");
        // The walk finds nearly every face by a cached edge; the shuffle almost none.
        let hits = |f: &[[u32; 3]]| encode(f, v as usize, false)[..f.len()].iter().filter(|&&op| op != MISS).count();
        assert!(hits(&walked) * 10 > walked.len() * 9 && hits(&faces) * 4 < faces.len(), "{}", hits(&walked));
    }

    #[test]
    fn odd_faces_and_parts_round_trip() {
        // Degenerate and repeated faces, a lone triangle far up the index
        // range, both orientations of an edge, and unused vertices.
        let faces = vec![[0, 1, 2], [2, 1, 0], [5, 5, 6], [0, 1, 2], [999, 3, 500], [6, 2, 1], [1, 6, 999]];
        assert_eq!(round_trip(&faces, 1000), faces);
        let walked: Vec<[u32; 3]> = walk_order(&faces, 1000).into_iter().map(|i| faces[i]).collect();
        assert_eq!(round_trip(&walked, 1000), walked);
    }

    /// Version 20's references: a mesh whose faces come part by part, each
    /// part's vertices numbered in a run of their own but the parts in
    /// another order (the first part's faces use the last indices), and
    /// whose faces come back to vertices met a row before, costs less than
    /// by version 12's rules, and comes back the same.
    #[test]
    fn new_vertices_in_runs_and_neighbours_cost_less() {
        let rows = |n: u32, base: u32| -> Vec<[u32; 3]> {
            let mut faces = Vec::new();
            for j in 0..n {
                for i in 0..n {
                    let v = base + j * (n + 1) + i;
                    faces.push([v, v + 1, v + n + 2]);
                    faces.push([v, v + n + 2, v + n + 1]);
                }
            }
            faces
        };
        let faces: Vec<[u32; 3]> = rows(12, 169).into_iter().chain(rows(12, 0)).collect();
        assert_eq!(round_trip(&faces, 338), faces);
        let size = |around| miniz_oxide::deflate::compress_to_vec(&encode(&faces, 338, around), 9).len();
        assert!(size(true) * 10 < size(false) * 9, "{} bytes against {}", size(true), size(false));
    }

    #[test]
    fn the_unused_indices_find_the_next_one() {
        let mut u = Unused::new(10);
        assert_eq!((u.first_from(0), u.first_from(9), u.first_from(10)), (Some(0), Some(9), None));
        for v in [0, 1, 2, 5, 9] {
            u.remove(v);
        }
        assert_eq!(
            (u.first_from(0), u.first_from(4), u.first_from(5), u.first_from(9)),
            (Some(3), Some(4), Some(6), None)
        );
    }

    #[test]
    fn bad_codes_are_errors() {
        for around in [false, true] {
            bad_codes_are_errors_by(around);
        }
    }

    fn bad_codes_are_errors_by(around: bool) {
        let faces = sheet(4);
        let raw = encode(&faces, 25, around);
        let n = faces.len() as u32;
        let err = |raw: &[u8], vertices: u32| decode(raw, &mut 0, n, vertices, around).unwrap_err();
        assert!(err(&raw[..raw.len() / 2], 25).contains("cut short"));
        assert!(err(&raw, 10).contains("but there are 10"));
        // The first face names a cached edge when none is cached.
        let mut bad = raw.clone();
        bad[0] = 0;
        assert!(err(&bad, 25).contains("past the cached"));
        // Every truncation and every single-byte change is an error or a
        // mesh in range, never a panic.
        for cut in 0..raw.len() {
            let _ = decode(&raw[..cut], &mut 0, n, 25, around);
        }
        for i in 0..raw.len() {
            for b in [0u8, 1, 17, 18, 47, 48, 49, 0x80, 0xff] {
                let mut c = raw.clone();
                c[i] = b;
                if let Ok(f) = decode(&c, &mut 0, n, 25, around) {
                    assert!(f.iter().flatten().all(|&v| v < 25));
                }
            }
        }
    }
}

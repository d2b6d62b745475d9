//! Half-edge adjacency of a triangle mesh. Half-edge `h = 3 f + k` runs from
//! corner `k` of face `f` to corner `k + 1`; `opposite[h]` is the half-edge
//! running the other way along the same edge, or [`NONE`] on a boundary.

pub const NONE: u32 = u32::MAX;

#[derive(Debug, Clone)]
pub struct Adjacency {
    pub opposite: Vec<u32>,
    /// Edges met by more than two faces, as (a, b, number of faces).
    pub non_manifold_edges: Vec<(u32, u32, usize)>,
    /// Edges whose two faces run them in the same direction.
    pub inconsistent_edges: Vec<(u32, u32)>,
    /// Number of distinct undirected edges.
    pub edge_count: usize,
}

#[inline]
pub fn origin(faces: &[[u32; 3]], h: u32) -> u32 {
    faces[(h / 3) as usize][(h % 3) as usize]
}

#[inline]
pub fn target(faces: &[[u32; 3]], h: u32) -> u32 {
    faces[(h / 3) as usize][((h % 3 + 1) % 3) as usize]
}

/// The half-edge before `h` in its face (it ends where `h` starts).
#[inline]
pub fn prev(h: u32) -> u32 {
    h - h % 3 + (h % 3 + 2) % 3
}

/// The half-edge after `h` in its face.
#[inline]
pub fn next(h: u32) -> u32 {
    h - h % 3 + (h % 3 + 1) % 3
}

impl Adjacency {
    pub fn build(faces: &[[u32; 3]]) -> Adjacency {
        let mut keyed: Vec<(u32, u32, u32)> = Vec::with_capacity(faces.len() * 3);
        for h in 0..(faces.len() * 3) as u32 {
            let (a, b) = (origin(faces, h), target(faces, h));
            keyed.push((a.min(b), a.max(b), h));
        }
        keyed.sort_unstable();
        let mut opposite = vec![NONE; faces.len() * 3];
        let mut non_manifold_edges = Vec::new();
        let mut inconsistent_edges = Vec::new();
        let mut edge_count = 0;
        let mut i = 0;
        while i < keyed.len() {
            let mut j = i + 1;
            while j < keyed.len() && keyed[j].0 == keyed[i].0 && keyed[j].1 == keyed[i].1 {
                j += 1;
            }
            edge_count += 1;
            let (a, b) = (keyed[i].0, keyed[i].1);
            match j - i {
                1 => {}
                2 => {
                    let (h0, h1) = (keyed[i].2, keyed[i + 1].2);
                    if origin(faces, h0) == origin(faces, h1) {
                        inconsistent_edges.push((a, b));
                    } else {
                        opposite[h0 as usize] = h1;
                        opposite[h1 as usize] = h0;
                    }
                }
                n => non_manifold_edges.push((a, b, n)),
            }
            i = j;
        }
        Adjacency { opposite, non_manifold_edges, inconsistent_edges, edge_count }
    }

    pub fn is_manifold(&self) -> bool {
        self.non_manifold_edges.is_empty() && self.inconsistent_edges.is_empty()
    }

    /// The corners around vertex `v` in counter-clockwise order, starting at
    /// the half-edge `start` leaving `v`; stops at a boundary. Each item is an
    /// outgoing half-edge (its face and corner index are `h / 3`, `h % 3`).
    pub fn fan(&self, start: u32) -> impl Iterator<Item = u32> + '_ {
        let mut h = Some(start);
        let mut first = true;
        std::iter::from_fn(move || {
            let cur = h?;
            if !first && cur == start {
                return None;
            }
            first = false;
            // The face after (v, a, b) counter-clockwise is the one across edge (v, b):
            // the opposite of the half-edge b -> v, which leaves v.
            let o = self.opposite[prev(cur) as usize];
            h = if o == NONE { None } else { Some(o) };
            Some(cur)
        })
    }
}

//! Resampling a mesh sequence onto the grid: every sample of the square is
//! located once, in the reference frame's parameterization, as a triangle and
//! barycentric coordinates; every frame is then resampled through the same
//! triangles and weights, so all grid meshes share one connectivity and a
//! sample follows the same material point through the motion.

use crate::error::{Error, Result};
use crate::format::source_mesh::{place, quantize_place};
use crate::grid::Grid;
use crate::mesh::carrier::Carrier;
use crate::param::Parameterization;
use glam::{DVec2, Vec3};

/// Barycentric tolerance when testing whether a sample lies in a triangle;
/// samples on shared edges are claimed by the triangle that contains them
/// most deeply.
const INSIDE_EPS: f64 = 1e-9;

/// Where each grid sample lies on the input surface (on its carrier,
/// [`Carrier`], where the input is not a closed genus-0 manifold).
#[derive(Debug, Clone)]
pub struct SampleMap {
    pub grid: Grid,
    /// The carrier face containing each sample.
    pub face: Vec<u32>,
    /// The face's three vertices as entries of the extended frame
    /// ([`Carrier::extend`]: input vertices, then the carrier's added ones).
    pub corners: Vec<[u32; 3]>,
    pub bary: Vec<[f32; 3]>,
    /// The carrier's added vertices (empty for a closed genus-0 input).
    pub means: Vec<Vec<u32>>,
    /// Whether each sample lies on one of the input's faces (not on a face
    /// the carrier added).
    pub on_input: Vec<bool>,
    /// Whether each face of [`Grid::topology`] lies on the input's faces
    /// ([`faces_on_input`]); empty where all do.
    pub face_on_input: Vec<bool>,
    /// Samples that fell in no face (where the map folds), located at a
    /// neighbour's point instead ([`fill_from_neighbours`]).
    pub unlocated: usize,
}

impl SampleMap {
    /// Locates every grid sample in the parameterization of the carrier.
    pub fn on_carrier(grid: Grid, carrier: &Carrier, param: &Parameterization) -> Result<SampleMap> {
        let mut map = SampleMap::build(grid, &carrier.topology.faces, param)?;
        for (c, &f) in map.corners.iter_mut().zip(&map.face) {
            *c = carrier.topology.faces[f as usize].map(|v| carrier.ext[v as usize]);
        }
        map.on_input = map.face.iter().map(|&f| carrier.real[f as usize]).collect();
        if carrier.real.iter().any(|&r| !r) {
            map.face_on_input = faces_on_input(grid, &carrier.topology.faces, &carrier.real, param, &map.on_input);
        }
        map.means = carrier.means.clone();
        Ok(map)
    }

    /// Locates every grid sample in the parameterization of `faces` (a
    /// closed genus-0 input, its own carrier).
    pub fn build(grid: Grid, faces: &[[u32; 3]], param: &Parameterization) -> Result<SampleMap> {
        let mut best: Vec<(f64, u32, [f64; 3])> = vec![(f64::NEG_INFINITY, u32::MAX, [0.0; 3]); grid.len()];
        for f in 0..faces.len() {
            raster(grid, param.face_uv(faces, f), |idx, w, depth| {
                if depth > best[idx].0 {
                    best[idx] = (depth, f as u32, w);
                }
            });
        }
        let unlocated = fill_from_neighbours(grid, &mut best);
        if unlocated == best.len() {
            return Err(Error::Numerical("no grid sample falls in a triangle of the parameterization".into()));
        }
        let mut map = SampleMap {
            grid,
            face: Vec::new(),
            corners: Vec::new(),
            bary: Vec::new(),
            means: Vec::new(),
            on_input: vec![true; best.len()],
            face_on_input: Vec::new(),
            unlocated,
        };
        for (_, f, w) in best {
            let w = w.map(|x| x.max(0.0));
            let s = w[0] + w[1] + w[2];
            map.face.push(f);
            map.corners.push(faces[f as usize]);
            map.bary.push(w.map(|x| (x / s) as f32));
        }
        Ok(map)
    }

    /// The map of a motion already on `grid`'s own mesh ([`Grid::topology`]):
    /// each sample is its own vertex, resampled by nothing.
    pub fn identity(grid: Grid) -> SampleMap {
        let faces = grid.topology().faces;
        let mut face = vec![u32::MAX; grid.len()];
        for (f, tri) in faces.iter().enumerate() {
            for &v in tri {
                if face[v as usize] == u32::MAX {
                    face[v as usize] = f as u32;
                }
            }
        }
        SampleMap {
            grid,
            corners: face.iter().map(|&f| faces[f as usize]).collect(),
            bary: face
                .iter()
                .enumerate()
                .map(|(v, &f)| faces[f as usize].map(|c| if c as usize == v { 1.0 } else { 0.0 }))
                .collect(),
            face,
            means: Vec::new(),
            on_input: vec![true; grid.len()],
            face_on_input: Vec::new(),
            unlocated: 0,
        }
    }

    /// [`identity`](Self::identity) for an input that is part of the
    /// grid's mesh (`faces`, a subset of the grid's in its order: an open
    /// capture's grid without the faces over its holes): only those faces,
    /// and the samples they use, lie on the input, so the encoder's error
    /// figures leave the rest out.
    pub fn identity_on(grid: Grid, faces: &[[u32; 3]]) -> SampleMap {
        let mut map = SampleMap::identity(grid);
        let all = grid.topology().faces;
        if faces.len() == all.len() {
            return map;
        }
        let mut kept = faces.iter().peekable();
        map.face_on_input = all.iter().map(|f| kept.next_if(|g| *g == f).is_some()).collect();
        map.on_input = crate::mesh::topology::used_by(faces, grid.len());
        map
    }

    /// The grid mesh's triangles whose three samples lie on the input's
    /// faces: the decoded surface that the surface-error metrics compare
    /// with the input (all of them for a closed genus-0 input).
    pub fn surface_faces(&self) -> Vec<[u32; 3]> {
        let faces = self.grid.topology().faces;
        if self.on_input.iter().all(|&x| x) && self.face_on_input.iter().all(|&x| x) {
            return faces;
        }
        let on = |k: usize| self.face_on_input.get(k).copied().unwrap_or(true);
        faces
            .into_iter()
            .enumerate()
            .filter(|&(k, f)| on(k) && f.iter().all(|&s| self.on_input[s as usize]))
            .map(|(_, f)| f)
            .collect()
    }

    /// Resamples one frame of the input sequence onto the grid.
    pub fn apply(&self, frame: &[Vec3]) -> Vec<Vec3> {
        let mut out = Vec::with_capacity(self.corners.len());
        self.apply_into(frame, &mut out);
        out
    }

    /// Like [`SampleMap::apply`], reusing `out`'s allocation.
    pub fn apply_into(&self, frame: &[Vec3], out: &mut Vec<Vec3>) {
        let mut extended = Vec::new();
        let frame = if self.means.is_empty() {
            frame
        } else {
            crate::mesh::carrier::extend_frame(&self.means, frame, &mut extended);
            &extended
        };
        out.clear();
        out.extend(
            self.corners
                .iter()
                .zip(&self.bary)
                .map(|(c, w)| frame[c[0] as usize] * w[0] + frame[c[1] as usize] * w[1] + frame[c[2] as usize] * w[2]),
        );
    }
}

/// Gives each sample that no face covered (`u32::MAX`: where the map
/// folds, faces overlap and leave gaps) the point of its nearest located
/// sample along the grid, breadth first, so that the grid mesh bridges the
/// fold instead of the encode failing. Returns how many there were. A map
/// without folds covers every sample, so this changes nothing there.
fn fill_from_neighbours(grid: Grid, best: &mut [(f64, u32, [f64; 3])]) -> usize {
    let mut queue: std::collections::VecDeque<u32> =
        (0..best.len() as u32).filter(|&i| best[i as usize].1 != u32::MAX).collect();
    let unlocated = best.len() - queue.len();
    if unlocated == 0 || queue.is_empty() {
        return unlocated;
    }
    while let Some(i) = queue.pop_front() {
        for j in grid.stencil(i) {
            if best[j as usize].1 == u32::MAX {
                best[j as usize] = best[i as usize];
                queue.push_back(j);
            }
        }
    }
    unlocated
}

/// Calls `visit(sample, barycentric weights, depth)` for each sample of
/// `grid` in or on the triangle `q` of the plane (depth: the least weight,
/// at least `-INSIDE_EPS`), its point on the extended lattice folded into
/// the square. A triangle reversed or without area has no samples.
fn raster(grid: Grid, q: [DVec2; 3], mut visit: impl FnMut(usize, [f64; 3], f64)) {
    let n = grid.n as f64;
    let to_index = |x: f64| (x + 1.0) * n / 2.0 - 0.5;
    let det = (q[1] - q[0]).perp_dot(q[2] - q[0]);
    if det <= 0.0 {
        return;
    }
    let lo = q[0].min(q[1]).min(q[2]);
    let hi = q[0].max(q[1]).max(q[2]);
    let (a0, a1) = (to_index(lo.x).ceil() as i64, to_index(hi.x).floor() as i64);
    let (b0, b1) = (to_index(lo.y).ceil() as i64, to_index(hi.y).floor() as i64);
    for b in b0..=b1 {
        for a in a0..=a1 {
            let p = grid.uv(a, b);
            let bary = |x: DVec2, y: DVec2| (y - x).perp_dot(p - x) / det;
            let w = [bary(q[1], q[2]), bary(q[2], q[0]), bary(q[0], q[1])];
            let depth = w[0].min(w[1]).min(w[2]);
            if depth >= -INSIDE_EPS {
                visit(grid.canonical_index(a, b) as usize, w, depth);
            }
        }
    }
}

/// Fine samples a grid spacing in [`faces_on_input`]; odd, so that each
/// grid sample is a fine one (sample a is fine sample `FINE a + FINE / 2`).
const FINE: i64 = 3;

/// Which faces of [`Grid::topology`] lie on the input: their three samples
/// do, and so does every sample of a grid [`FINE`] times finer in them. A
/// carrier face narrower than a grid spacing (a bridge, a tube, a small
/// hole's fan) can pass between the samples; the grid face across it
/// stands in the gap, not on the input, and the surface metrics must not
/// take it for the input's surface.
fn faces_on_input(
    grid: Grid,
    faces: &[[u32; 3]],
    real: &[bool],
    param: &Parameterization,
    on_input: &[bool],
) -> Vec<bool> {
    let fine = Grid { n: grid.n * FINE as usize };
    let mut off = vec![false; fine.len()];
    for f in (0..faces.len()).filter(|&f| !real[f]) {
        // Strictly inside: a fine sample on a rim is on the input too.
        raster(fine, param.face_uv(faces, f), |idx, _, depth| off[idx] |= depth > INSIDE_EPS);
    }
    let mut keep = Vec::with_capacity(2 * grid.len());
    for ((a, b), q) in grid.cells() {
        let clear = |lower: bool| {
            let (a, b) = (FINE * a + FINE / 2, FINE * b + FINE / 2);
            let pairs = (0..=FINE).flat_map(|i| (0..=FINE).map(move |j| (i, j)));
            // The split along the (0, 2) diagonal: below it (j <= i), the
            // face (0, 1, 2); above it, (0, 2, 3).
            let mut inside = pairs.filter(|&(i, j)| if lower { j <= i } else { j >= i });
            inside.all(|(i, j)| !off[fine.canonical_index(a + i, b + j) as usize])
        };
        let on = |c: [usize; 3]| c.iter().all(|&k| on_input[q[k] as usize]);
        keep.extend([on([0, 1, 2]) && clear(true), on([0, 2, 3]) && clear(false)]);
    }
    keep
}

/// Each input vertex's place in the parameterization of its carrier (its
/// first copy's), folded into the square and quantized as format version
/// 6 stores it (so the rebuilt vertices are the decoder's). A vertex that
/// no face uses takes the first carrier vertex's place.
pub fn carrier_places(carrier: &Carrier, param: &Parameterization) -> Vec<[u32; 2]> {
    let at = |c: &u32| param.uv.get(*c as usize).or(param.uv.first()).copied().unwrap_or_default();
    carrier.carrier_of.iter().map(at).map(quantized_place).collect()
}

/// [`carrier_places`] of a closed genus-0 input, its own carrier.
pub fn places(param: &Parameterization) -> Vec<[u32; 2]> {
    param.uv.iter().copied().map(quantized_place).collect()
}

/// Low bits of a stored place that the encoder leaves zero: 16 bits a
/// coordinate are 256 steps a grid cell at N = 256, and the vertex offsets
/// take up what the rounding moves on the reference frame; the zero bytes
/// deflate to nearly nothing (samba's source mesh: 183 -> 157 KB).
const PLACE_ZERO_BITS: u32 = 16;

/// The stored place coordinate `q` moved by `by` steps of the quantizer
/// (a multiple of the coarse step, so the low bits stay zero), or `None`
/// past the square's edge (a place there would need folding).
pub fn shifted_place(q: u32, by: i64) -> Option<u32> {
    let top = i64::from(u32::MAX >> PLACE_ZERO_BITS) << PLACE_ZERO_BITS;
    let by = by >> PLACE_ZERO_BITS << PLACE_ZERO_BITS;
    let moved = i64::from(q) + by;
    (0..=top).contains(&moved).then_some(moved as u32)
}

/// The place of sample `s` of `grid`, as [`carrier_places`] stores places.
pub fn sample_place(grid: Grid, s: u32) -> [u32; 2] {
    let n = grid.n as f64;
    let at = |k: usize| (k as f64 + 0.5) * 2.0 / n - 1.0;
    quantized_place(DVec2::new(at(s as usize % grid.n), at(s as usize / grid.n)))
}

/// A stored place coordinate rounded to leave its low `zero_bits` bits
/// zero (at least [`PLACE_ZERO_BITS`]), the square's far edge included.
pub fn coarser_place(q: u32, zero_bits: u32) -> u32 {
    let bits = zero_bits.clamp(PLACE_ZERO_BITS, 31);
    let top = u64::from(u32::MAX >> bits) << bits;
    (((u64::from(q) + (1u64 << (bits - 1))) >> bits) << bits).min(top) as u32
}

/// The stored place of `uv` (any copy on the extended lattice): inside
/// the square, on the coarse steps a file keeps.
pub fn quantized_place(uv: DVec2) -> [u32; 2] {
    // Any copy of a vertex on the extended lattice is the same place; the
    // one inside the square is what fits the quantizer's range.
    let uv = Grid::canonical_uv(uv);
    // Rounded to the coarse steps, the square's far edge included (to the
    // last step below 2^32), so that every place leaves the bits zero.
    let coarse = |q: u32| {
        let half = 1u64 << (PLACE_ZERO_BITS - 1);
        let top = u64::from(u32::MAX >> PLACE_ZERO_BITS) << PLACE_ZERO_BITS;
        (((u64::from(q) + half) >> PLACE_ZERO_BITS) << PLACE_ZERO_BITS).min(top) as u32
    };
    [coarse(quantize_place(uv.x)), coarse(quantize_place(uv.y))]
}

/// Where each input vertex lies on the grid mesh: the inverse direction of
/// [`SampleMap`]. A vertex's place in the parameterization falls in one
/// grid quad (read on the grid's extended lattice, so a quad across the
/// folded border is the same one the seam rule glues), split along its
/// (0, 2) diagonal as [`Grid::topology`] splits it; the vertex is that
/// triangle's barycentric combination of three grid samples. So the
/// vertices rebuilt from a grid frame lie on its grid mesh, the surface
/// the decoder shows.
///
/// Format version 7 adds each vertex's offset from that point, in the
/// frame of its grid triangle ([`triangle_frame`]), so that what the grid
/// cut off comes back and turns with the surface.
#[derive(Debug, Clone)]
pub struct SourcePoints {
    pub corners: Vec<[u32; 3]>,
    pub bary: Vec<[f32; 3]>,
    /// Each vertex's offset (tangent, bitangent, normal), or empty.
    pub offsets: Vec<Vec3>,
}

/// The grid triangle (its samples) and barycentric weights of the stored
/// place `q`: the quad it falls in, split along its (0, 2) diagonal.
pub fn locate(grid: Grid, q: [u32; 2]) -> ([u32; 3], [f32; 3]) {
    let n = grid.n as f64;
    let (u, v) = (place(q[0]), place(q[1]));
    // Lattice coordinates: sample (a, b) sits at a = (u + 1) N / 2 - 1/2.
    let (x, y) = ((u + 1.0) * n / 2.0 - 0.5, (v + 1.0) * n / 2.0 - 0.5);
    let (a, b) = (x.floor() as i64, y.floor() as i64);
    let (s, t) = (x - a as f64, y - b as f64);
    let q = [(a, b), (a + 1, b), (a + 1, b + 1), (a, b + 1)].map(|(i, j)| grid.canonical_index(i, j));
    let (corners, w) =
        if s >= t { ([q[0], q[1], q[2]], [1.0 - s, s - t, t]) } else { ([q[0], q[2], q[3]], [1.0 - t, s, t - s]) };
    (corners, w.map(|w| w as f32))
}

/// Where the place (`corners`, `bary`) with `offset` (in its triangle's
/// frame) rebuilds a vertex on the grid frame `grid_positions`: the
/// decoder's rule, one vertex.
pub fn rebuild(grid_positions: &[Vec3], corners: [u32; 3], bary: [f32; 3], offset: Vec3) -> Vec3 {
    let p = corners.map(|i| grid_positions[i as usize]);
    let f = triangle_frame(p);
    p[0] * bary[0] + p[1] * bary[1] + p[2] * bary[2] + f[0] * offset.x + f[1] * offset.y + f[2] * offset.z
}

/// The offset (in the triangle's frame) that takes the place (`corners`,
/// `bary`) on `grid_positions` to `vertex`.
pub fn offset_to(grid_positions: &[Vec3], corners: [u32; 3], bary: [f32; 3], vertex: Vec3) -> Vec3 {
    let p = corners.map(|i| grid_positions[i as usize]);
    let f = triangle_frame(p);
    let d = vertex - (p[0] * bary[0] + p[1] * bary[1] + p[2] * bary[2]);
    Vec3::new(d.dot(f[0]), d.dot(f[1]), d.dot(f[2]))
}

/// The frame of a grid triangle: the unit direction of its first edge,
/// the unit normal crossed with it, and the unit normal (the identity for
/// a triangle without area).
pub fn triangle_frame(p: [Vec3; 3]) -> [Vec3; 3] {
    let e = p[1] - p[0];
    let n = e.cross(p[2] - p[0]).normalize_or_zero();
    let t = e.normalize_or_zero();
    if n == Vec3::ZERO || t == Vec3::ZERO {
        return [Vec3::X, Vec3::Y, Vec3::Z];
    }
    [t, n.cross(t), n]
}

impl SourcePoints {
    /// The points of a closed genus-0 input, its own carrier, at its
    /// places in `param` (an input on a carrier: [`carrier_places`] and
    /// [`SourcePoints::from_places`]).
    pub fn build(grid: Grid, param: &Parameterization) -> SourcePoints {
        SourcePoints::from_places(grid, &places(param))
    }

    /// The vertices at quantized `places` (format version 6's source mesh).
    pub fn from_places(grid: Grid, places: &[[u32; 2]]) -> SourcePoints {
        let (corners, bary) = places.iter().map(|q| locate(grid, *q)).unzip();
        SourcePoints { corners, bary, offsets: Vec::new() }
    }

    /// The same points with version 7's offsets (`offsets.get(v)`).
    pub fn with_offsets(mut self, offsets: Option<&crate::format::Offsets>) -> SourcePoints {
        self.offsets = match offsets {
            Some(o) => (0..self.corners.len()).map(|v| Vec3::from(o.get(v))).collect(),
            None => Vec::new(),
        };
        self
    }

    /// The input's vertices rebuilt from one grid frame.
    pub fn apply(&self, grid_positions: &[Vec3]) -> Vec<Vec3> {
        (0..self.corners.len())
            .map(|v| {
                let offset = self.offsets.get(v).copied().unwrap_or(Vec3::ZERO);
                rebuild(grid_positions, self.corners[v], self.bary[v], offset)
            })
            .collect()
    }

    /// The offsets (in each triangle's frame) that take the points on the
    /// grid frame `grid_positions` to `vertices`.
    pub fn offsets_to(&self, grid_positions: &[Vec3], vertices: &[Vec3]) -> Vec<[f32; 3]> {
        (0..self.corners.len())
            .map(|v| match vertices.get(v) {
                Some(&x) => offset_to(grid_positions, self.corners[v], self.bary[v], x).to_array(),
                None => [0.0; 3],
            })
            .collect()
    }
}

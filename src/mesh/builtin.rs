//! The embedded default motion: a walking figure built in code, so the demo
//! and the fast tests need no download.
//!
//! A box-modelled cage (torso, head, two two-segment arms and legs, made by
//! extruding faces of a box) is smoothed by three levels of Catmull–Clark
//! subdivision (Catmull & Clark 1978) into a closed genus-0 surface of about
//! six thousand vertices, then animated by linear blend skinning with a small
//! skeleton of ten bones.

use super::{InMemory, Topology};
use glam::{Mat4, Vec3};
use std::collections::HashMap;

/// The name under which the built-in motion is opened.
pub const NAME: &str = "builtin:walk";

/// The same motion with texture coordinates and a small procedural
/// texture ([`textured_motion`]): a textured input for fast tests.
pub const TEXTURED_NAME: &str = "builtin:walk-textured";

/// Frames in the default motion (2.4 s at 30 fps: two gait cycles).
pub const FRAMES: usize = 72;
pub const FPS: f32 = 30.0;

struct QuadMesh {
    verts: Vec<Vec3>,
    quads: Vec<[u32; 4]>,
}

impl QuadMesh {
    /// A box split into nx * ny * nz cells, outward-facing quads.
    fn lattice_box(min: Vec3, size: Vec3, n: [u32; 3]) -> QuadMesh {
        let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
        let mut m = QuadMesh { verts: Vec::new(), quads: Vec::new() };
        let mut id = |m: &mut QuadMesh, p: [u32; 3]| {
            *ids.entry(p).or_insert_with(|| {
                let t = Vec3::new(p[0] as f32 / n[0] as f32, p[1] as f32 / n[1] as f32, p[2] as f32 / n[2] as f32);
                m.verts.push(min + t * size);
                (m.verts.len() - 1) as u32
            })
        };
        // For each axis, the two faces normal to it, with corner orders that
        // are counter-clockwise seen from outside.
        for axis in 0..3 {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for side in [0, n[axis]] {
                for a in 0..n[u] {
                    for b in 0..n[v] {
                        let mut c = [[0u32; 3]; 4];
                        for (k, (du, dv)) in [(0, 0), (1, 0), (1, 1), (0, 1)].into_iter().enumerate() {
                            c[k][axis] = side;
                            c[k][u] = a + du;
                            c[k][v] = b + dv;
                        }
                        if side == 0 {
                            c.reverse();
                        }
                        let q = c.map(|p| id(&mut m, p));
                        m.quads.push(q);
                    }
                }
            }
        }
        m
    }

    fn centroid(&self, q: usize) -> Vec3 {
        self.quads[q].iter().map(|&i| self.verts[i as usize]).sum::<Vec3>() / 4.0
    }

    /// Extrudes quad `q` by `len` along `dir`, scaling the new cap by `scale`
    /// about its centre. The quad stays the cap, so it can be extruded again.
    fn extrude(&mut self, q: usize, dir: Vec3, len: f32, scale: f32) {
        let c = self.centroid(q) + dir * len;
        let old = self.quads[q];
        let new: Vec<u32> = old
            .iter()
            .map(|&i| {
                let p = self.verts[i as usize] + dir * len;
                self.verts.push(c + (p - c) * scale);
                (self.verts.len() - 1) as u32
            })
            .collect();
        for k in 0..4 {
            let (a, b) = (old[k], old[(k + 1) % 4]);
            let (a2, b2) = (new[k], new[(k + 1) % 4]);
            self.quads.push([a, b, b2, a2]);
        }
        self.quads[q] = [new[0], new[1], new[2], new[3]];
    }

    fn find_quad(&self, centre: Vec3) -> usize {
        (0..self.quads.len())
            .min_by(|&a, &b| self.centroid(a).distance(centre).total_cmp(&self.centroid(b).distance(centre)))
            .unwrap_or(0)
    }

    /// One level of Catmull–Clark subdivision of a closed quad mesh.
    fn catmull_clark(&self) -> QuadMesh {
        let nv = self.verts.len();
        let face_pts: Vec<Vec3> = (0..self.quads.len()).map(|q| self.centroid(q)).collect();
        let mut edges: HashMap<(u32, u32), (u32, Vec<usize>)> = HashMap::new();
        for (f, q) in self.quads.iter().enumerate() {
            for k in 0..4 {
                let (a, b) = (q[k], q[(k + 1) % 4]);
                let n = edges.len() as u32;
                edges.entry((a.min(b), a.max(b))).or_insert((n, Vec::new())).1.push(f);
            }
        }
        let mut verts = vec![Vec3::ZERO; nv + self.quads.len() + edges.len()];
        let mut f_sum = vec![Vec3::ZERO; nv];
        let mut r_sum = vec![Vec3::ZERO; nv];
        let mut valence = vec![0f32; nv];
        // In creation order: summing in the map's (random) order would make
        // the motion differ in the last bit from run to run.
        let mut ordered: Vec<_> = edges.iter().collect();
        ordered.sort_unstable_by_key(|e| e.1 .0);
        for (&(a, b), (id, fs)) in ordered {
            let (pa, pb) = (self.verts[a as usize], self.verts[b as usize]);
            let fp: Vec3 = fs.iter().map(|&f| face_pts[f]).sum::<Vec3>() / fs.len() as f32;
            verts[nv + self.quads.len() + *id as usize] = (pa + pb + 2.0 * fp) / 4.0;
            for v in [a, b] {
                r_sum[v as usize] += (pa + pb) / 2.0;
                valence[v as usize] += 1.0;
            }
        }
        for (f, q) in self.quads.iter().enumerate() {
            verts[nv + f] = face_pts[f];
            for &v in q {
                f_sum[v as usize] += face_pts[f];
            }
        }
        for v in 0..nv {
            let n = valence[v];
            verts[v] = (f_sum[v] / n + 2.0 * r_sum[v] / n + (n - 3.0) * self.verts[v]) / n;
        }
        let edge_id = |a: u32, b: u32| (nv + self.quads.len()) as u32 + edges[&(a.min(b), a.max(b))].0;
        let mut quads = Vec::with_capacity(self.quads.len() * 4);
        for (f, q) in self.quads.iter().enumerate() {
            let fp = (nv + f) as u32;
            for k in 0..4 {
                let (prev, cur, next) = (q[(k + 3) % 4], q[k], q[(k + 1) % 4]);
                quads.push([cur, edge_id(cur, next), fp, edge_id(prev, cur)]);
            }
        }
        QuadMesh { verts, quads }
    }
}

/// A bone: a segment in the rest pose, rotating about `pivot`.
struct Bone {
    parent: Option<usize>,
    pivot: Vec3,
    tip: Vec3,
}

fn skeleton() -> Vec<Bone> {
    let b = |parent, pivot: [f32; 3], tip: [f32; 3]| Bone { parent, pivot: Vec3::from(pivot), tip: Vec3::from(tip) };
    vec![
        b(None, [0.0, 0.92, 0.0], [0.0, 1.52, 0.0]),         // 0 torso
        b(Some(0), [0.0, 1.52, 0.0], [0.0, 1.84, 0.0]),      // 1 head
        b(Some(0), [-0.25, 1.37, 0.0], [-0.53, 1.37, 0.0]),  // 2 left upper arm
        b(Some(2), [-0.53, 1.37, 0.0], [-0.88, 1.37, 0.0]),  // 3 left forearm
        b(Some(0), [0.25, 1.37, 0.0], [0.53, 1.37, 0.0]),    // 4 right upper arm
        b(Some(4), [0.53, 1.37, 0.0], [0.88, 1.37, 0.0]),    // 5 right forearm
        b(Some(0), [-0.14, 0.86, 0.0], [-0.14, 0.44, 0.0]),  // 6 left thigh
        b(Some(6), [-0.14, 0.44, 0.0], [-0.14, -0.02, 0.0]), // 7 left shin
        b(Some(0), [0.14, 0.86, 0.0], [0.14, 0.44, 0.0]),    // 8 right thigh
        b(Some(8), [0.14, 0.44, 0.0], [0.14, -0.02, 0.0]),   // 9 right shin
    ]
}

fn segment_distance(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    p.distance(a + ab * t)
}

/// The rest-pose surface of the figure (T-pose, metres, y up, facing +z).
pub fn rest_mesh() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut m = QuadMesh::lattice_box(Vec3::new(-0.21, 0.9, -0.12), Vec3::new(0.42, 0.62, 0.24), [3, 2, 1]);
    let head = m.find_quad(Vec3::new(0.0, 1.52, 0.0));
    for (len, scale) in [(0.06, 0.8), (0.2, 1.45), (0.08, 0.55)] {
        m.extrude(head, Vec3::Y, len, scale);
    }
    for side in [-1.0f32, 1.0] {
        let arm = m.find_quad(Vec3::new(0.21 * side, 1.365, 0.0));
        for (len, scale) in [(0.05, 0.55), (0.26, 0.9), (0.25, 0.85), (0.1, 0.75)] {
            m.extrude(arm, Vec3::X * side, len, scale);
        }
        let leg = m.find_quad(Vec3::new(0.14 * side, 0.9, 0.0));
        for (len, scale) in [(0.06, 1.0), (0.38, 0.85), (0.4, 0.8), (0.06, 0.8)] {
            m.extrude(leg, -Vec3::Y, len, scale);
        }
    }
    for _ in 0..3 {
        m = m.catmull_clark();
    }
    let faces = m.quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    (m.verts, faces)
}

/// Local rotation of each bone at time `t` (seconds), as a matrix about its pivot.
fn pose(bones: &[Bone], t: f32) -> Vec<Mat4> {
    let phase = std::f32::consts::TAU * t / 1.2; // one gait cycle every 1.2 s
    let (s, c) = phase.sin_cos();
    let mut local = vec![Mat4::IDENTITY; bones.len()];
    let rot = |m: Mat4, pivot: Vec3| Mat4::from_translation(pivot) * m * Mat4::from_translation(-pivot);
    local[0] = Mat4::from_translation(Vec3::new(0.0, 0.02 * (2.0 * phase).sin(), 0.36 * t))
        * rot(Mat4::from_rotation_y(0.15 * s), bones[0].pivot);
    local[1] = rot(Mat4::from_rotation_x(0.12 * (2.0 * phase).sin()), bones[1].pivot);
    for (upper, side) in [(2usize, -1.0f32), (4, 1.0)] {
        let swing = 0.5 * s * side;
        local[upper] = rot(Mat4::from_rotation_x(swing) * Mat4::from_rotation_z(-side * 1.05), bones[upper].pivot);
        let bend = 0.45 + 0.25 * (s * side).max(0.0);
        local[upper + 1] = rot(Mat4::from_rotation_y(-side * bend), bones[upper + 1].pivot);
    }
    for (thigh, side) in [(6usize, -1.0f32), (8, 1.0)] {
        local[thigh] = rot(Mat4::from_rotation_x(-0.45 * s * side), bones[thigh].pivot);
        let knee = 0.7 * (c * side).max(0.0);
        local[thigh + 1] = rot(Mat4::from_rotation_x(knee), bones[thigh + 1].pivot);
    }
    let mut global = vec![Mat4::IDENTITY; bones.len()];
    for (i, b) in bones.iter().enumerate() {
        global[i] = match b.parent {
            Some(p) => global[p] * local[i],
            None => local[i],
        };
    }
    global
}

/// The default motion with `frames` frames at [`FPS`].
pub fn motion(frames: usize) -> InMemory {
    let (rest, faces) = rest_mesh();
    let bones = skeleton();
    // Skinning weights fall off with the fourth power of the distance to each bone.
    let weights: Vec<Vec<f32>> = rest
        .iter()
        .map(|&p| {
            let w: Vec<f32> =
                bones.iter().map(|b| 1.0 / (segment_distance(p, b.pivot, b.tip).powi(4) + 1e-7)).collect();
            let sum: f32 = w.iter().sum();
            w.into_iter().map(|x| x / sum).collect()
        })
        .collect();
    let frames = (0..frames)
        .map(|f| {
            let g = pose(&bones, f as f32 / FPS);
            rest.iter()
                .zip(&weights)
                .map(|(&p, w)| w.iter().zip(&g).map(|(&wi, m)| m.transform_point3(p) * wi).sum())
                .collect()
        })
        .collect();
    InMemory { label: NAME.into(), fps: FPS, topology: Topology { vertex_count: rest.len(), faces }, frames }
}

/// The default motion: [`FRAMES`] frames at [`FPS`].
pub fn default_motion() -> InMemory {
    motion(FRAMES)
}

/// The default motion with an appearance: cylindrical texture coordinates
/// about the vertical axis (the seam at the back, where faces that cross it
/// take copies of their vertices one turn on) and a 64 x 64 PNG of orange
/// and cream checks, so that a test sees at once whether a texture is drawn.
pub fn textured_motion(frames: usize) -> Textured {
    let motion = motion(frames);
    let (rest, faces) = rest_mesh();
    let (lo, hi) = rest.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), p| (a.min(p.y), b.max(p.y)));
    let uv = |p: Vec3| [0.5 + p.x.atan2(p.z) / std::f32::consts::TAU, (hi - p.y) / (hi - lo)];
    let mut uvs: Vec<[f32; 2]> = rest.iter().map(|&p| uv(p)).collect();
    let mut welded: Vec<u32> = (0..rest.len() as u32).collect();
    let mut turned: HashMap<u32, u32> = HashMap::new();
    let faces = faces
        .iter()
        .map(|f| {
            let us = f.map(|v| uvs[v as usize][0]);
            if us.iter().fold(0f32, |m, &u| m.max(u)) - us.iter().fold(1f32, |m, &u| m.min(u)) <= 0.5 {
                return *f;
            }
            // Across the seam: the vertices near u = 0 go one turn on.
            f.map(|v| match uvs[v as usize][0] < 0.5 {
                false => v,
                true => *turned.entry(v).or_insert_with(|| {
                    uvs.push([uvs[v as usize][0] + 1.0, uvs[v as usize][1]]);
                    welded.push(v);
                    (uvs.len() - 1) as u32
                }),
            })
        })
        .collect();
    let look =
        crate::format::Appearance { uvs, base_color: [1.0; 4], texture: Some(("image/png".into(), checks_png())) };
    let mut motion = motion;
    motion.label = TEXTURED_NAME.into();
    Textured { motion, appearance: super::Appearance { welded, faces, look } }
}

/// A 64 x 64 RGB PNG of 8 x 8 orange and cream checks.
fn checks_png() -> Vec<u8> {
    let texels: Vec<u8> = (0..64 * 64)
        .flat_map(|i| match ((i % 64) / 8 + (i / 64) / 8) % 2 {
            0 => [230, 120, 30],
            _ => [245, 235, 210],
        })
        .collect();
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, 64, 64);
    enc.set_color(png::ColorType::Rgb);
    // Writing into memory cannot fail.
    if let Ok(mut w) = enc.write_header() {
        let _ = w.write_image_data(&texels);
    }
    out
}

/// The built-in motion with texture coordinates and a texture.
pub struct Textured {
    pub motion: InMemory,
    pub appearance: super::Appearance,
}

impl super::FrameSource for Textured {
    fn label(&self) -> &std::path::Path {
        self.motion.label()
    }
    fn frame_count(&self) -> usize {
        self.motion.frame_count()
    }
    fn fps(&self) -> f32 {
        self.motion.fps()
    }
    fn topology(&self) -> &Topology {
        self.motion.topology()
    }
    fn read_frame(&self, i: usize) -> crate::error::Result<super::Frame> {
        self.motion.read_frame(i)
    }
    fn kind(&self) -> &'static str {
        "built-in motion, textured"
    }
    fn appearance(&self) -> Option<&super::Appearance> {
        Some(&self.appearance)
    }
}

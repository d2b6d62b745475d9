//! Shared test helpers: small meshes, a glTF builder, temp folders, and the
//! real sequences unpacked from ../shared/data.
#![allow(dead_code)]

pub mod stress;

use base64::Engine;
use glam::Vec3;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// A fresh empty folder under the target directory.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

pub fn tetrahedron() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let p = vec![
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(1.0, -1.0, -1.0),
        Vec3::new(-1.0, 1.0, -1.0),
        Vec3::new(-1.0, -1.0, 1.0),
    ];
    (p, vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
}

/// An icosphere of radius 1 with `levels` subdivisions (12, 42, 162, 642, ... vertices).
pub fn icosphere(levels: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut p: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|a| Vec3::from(*a).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut nf = Vec::new();
        for tri in &f {
            let mut m = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                m[k] = *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    p.push(((p[a as usize] + p[b as usize]) / 2.0).normalize());
                    (p.len() - 1) as u32
                });
            }
            nf.push([tri[0], m[0], m[2]]);
            nf.push([tri[1], m[1], m[0]]);
            nf.push([tri[2], m[2], m[1]]);
            nf.push(m);
        }
        f = nf;
    }
    (p, f)
}

pub fn write_obj(path: &Path, p: &[Vec3], f: &[[u32; 3]]) {
    std::fs::write(path, cgv::mesh::obj::format_obj(p, f)).unwrap();
}

/// Builds glTF documents with an embedded base64 buffer.
#[derive(Default)]
pub struct GltfBuilder {
    pub bin: Vec<u8>,
    pub views: Vec<Value>,
    pub accessors: Vec<Value>,
}

impl GltfBuilder {
    fn push(
        &mut self,
        bytes: &[u8],
        count: usize,
        ty: &str,
        component: u32,
        minmax: Option<(Vec<f32>, Vec<f32>)>,
    ) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        self.views.push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        let mut acc =
            json!({"bufferView": self.views.len() - 1, "componentType": component, "count": count, "type": ty});
        if let Some((lo, hi)) = minmax {
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }
    pub fn vec3(&mut self, v: &[Vec3]) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|p| p.to_array()).flat_map(f32::to_le_bytes).collect();
        let b = cgv::mesh::Bounds::of(v);
        self.push(&bytes, v.len(), "VEC3", 5126, Some((b.min.to_array().to_vec(), b.max.to_array().to_vec())))
    }
    pub fn floats(&mut self, v: &[f32], ty: &str, per: usize) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        let mm = if ty == "SCALAR" {
            Some((
                vec![v.iter().copied().fold(f32::INFINITY, f32::min)],
                vec![v.iter().copied().fold(f32::NEG_INFINITY, f32::max)],
            ))
        } else {
            None
        };
        self.push(&bytes, v.len() / per, ty, 5126, mm)
    }
    pub fn indices(&mut self, f: &[[u32; 3]]) -> usize {
        let bytes: Vec<u8> = f.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
        self.push(&bytes, f.len() * 3, "SCALAR", 5125, None)
    }
    pub fn joints(&mut self, j: &[[u16; 4]]) -> usize {
        let bytes: Vec<u8> = j.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
        self.push(&bytes, j.len(), "VEC4", 5123, None)
    }
    /// Completes `doc` with the buffer, views and accessors and writes it.
    pub fn write(&self, mut doc: Value, path: &Path) {
        doc["asset"] = json!({"version": "2.0"});
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.bin)
        );
        doc["buffers"] = json!([{"uri": uri, "byteLength": self.bin.len()}]);
        doc["bufferViews"] = json!(self.views);
        doc["accessors"] = json!(self.accessors);
        std::fs::write(path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
    }
}

/// Unpacks a real sequence from ../shared/data (once per test binary run) and
/// returns its folder. Panics with a clear message when the data is missing:
/// these tests must not pass silently without it.
pub fn real_sequence(name: &str) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let archive = root.join("../shared/data").join(format!("{name}.tar.xz"));
    assert!(
        archive.exists(),
        "{} is missing: the real-data tests need ../shared/data beside the checkout",
        archive.display()
    );
    let dest = Path::new(env!("CARGO_TARGET_TMPDIR")).join("data");
    let dir = dest.join(name);
    let done = dest.join(format!("{name}.unpacked"));
    if !done.exists() {
        std::fs::create_dir_all(&dest).unwrap();
        let st = std::process::Command::new("tar").arg("xJf").arg(&archive).arg("-C").arg(&dest).status().unwrap();
        assert!(st.success(), "unpacking {} failed", archive.display());
        std::fs::write(&done, b"").unwrap();
    }
    dir
}

/// Decodes a PNG: its samples and the number of channels per pixel.
pub fn decode_png(bytes: &[u8]) -> (Vec<u8>, usize) {
    let mut r = png::Decoder::new(std::io::Cursor::new(bytes)).read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size().unwrap()];
    let info = r.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    (buf, info.color_type.samples())
}

/// An open square sheet of (k + 1)² vertices in the z = 0 plane, side 2.
pub fn sheet(k: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut p = Vec::new();
    for j in 0..=k {
        for i in 0..=k {
            p.push(Vec3::new(2.0 * i as f32 / k as f32 - 1.0, 2.0 * j as f32 / k as f32 - 1.0, 0.0));
        }
    }
    let at = |i: usize, j: usize| (j * (k + 1) + i) as u32;
    let mut f = Vec::new();
    for j in 0..k {
        for i in 0..k {
            f.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            f.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    (p, f)
}

/// A tube (`closed`: false, an annulus) or torus (`closed`: true) of
/// `around` x `along` vertices: radius 0.3 around a circle of radius 1 for
/// the torus, a straight tube of radius 0.5 and length 2 otherwise.
pub fn tube(around: usize, along: usize, closed: bool) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut p = Vec::new();
    let rows = if closed { along } else { along + 1 };
    for j in 0..rows {
        for i in 0..around {
            let a = std::f32::consts::TAU * i as f32 / around as f32;
            if closed {
                let b = std::f32::consts::TAU * j as f32 / along as f32;
                let r = 1.0 + 0.3 * a.cos();
                p.push(Vec3::new(r * b.cos(), r * b.sin(), 0.3 * a.sin()));
            } else {
                p.push(Vec3::new(0.5 * a.cos(), 0.5 * a.sin(), 2.0 * j as f32 / along as f32 - 1.0));
            }
        }
    }
    let at = |i: usize, j: usize| ((j % rows) * around + i % around) as u32;
    let mut f = Vec::new();
    for j in 0..along {
        for i in 0..around {
            f.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            f.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    (p, f)
}

/// A subdivided cube (6 k² quads, split) of side 2 centred at `c`.
pub fn cube(k: usize, c: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    // An icosphere-free closed box: weld the six sheets' shared border vertices.
    let (sp, sf) = sheet(k);
    let mut p: Vec<Vec3> = Vec::new();
    let mut f = Vec::new();
    let mut index = std::collections::HashMap::new();
    let faces: [fn(Vec3) -> Vec3; 6] = [
        |v| Vec3::new(v.x, v.y, 1.0),
        |v| Vec3::new(v.y, v.x, -1.0),
        |v| Vec3::new(1.0, v.x, v.y),
        |v| Vec3::new(-1.0, v.y, v.x),
        |v| Vec3::new(v.y, 1.0, v.x),
        |v| Vec3::new(v.x, -1.0, v.y),
    ];
    for map in faces {
        let ids: Vec<u32> = sp
            .iter()
            .map(|&v| {
                let q = map(v);
                let key = (q * 1000.0).round().as_ivec3().to_array();
                *index.entry(key).or_insert_with(|| {
                    p.push(q + c);
                    (p.len() - 1) as u32
                })
            })
            .collect();
        f.extend(sf.iter().map(|t| t.map(|i| ids[i as usize])));
    }
    (p, f)
}

/// Concatenates meshes (the parts of a multi-part mesh).
pub fn parts(meshes: &[(Vec<Vec3>, Vec<[u32; 3]>)]) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (mut p, mut f) = (Vec::new(), Vec::new());
    for (mp, mf) in meshes {
        let base = p.len() as u32;
        p.extend_from_slice(mp);
        f.extend(mf.iter().map(|t| t.map(|i| i + base)));
    }
    (p, f)
}

/// `faces` in a canonical order, each face as it is: a decoded source mesh
/// (format v12) gives back the input's faces, perhaps in another order.
pub fn sorted_faces(faces: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut f = faces.to_vec();
    f.sort();
    f
}

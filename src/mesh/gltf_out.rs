//! Output of mesh sequences: glTF 2.0 binary (`.glb`) with the motion as a
//! morph-target animation that any glTF viewer plays (frame 0 is the base
//! mesh, frame k > 0 is morph target k - 1, and a LINEAR weights animation
//! blends from each frame to the next; each frame has its vertex normals,
//! recomputed, as morph targets too), and folders of numbered OBJ files.
//! Both are written frame by frame and appear only once complete.

use super::{vertex_normals, Frame, Topology};
use crate::error::{Error, Result};
use crate::output::AtomicFile;
use glam::Vec3;
use serde_json::json;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;

/// Removes a scratch file when dropped.
struct Scratch(PathBuf);
impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// What the binary chunk holds, in order: the indices; for every frame its
/// positions and then its vertex normals (frame 0 as they are, later
/// frames as displacements from frame 0's: morph targets); and with more
/// than one frame the animation's times and weights.
struct BinLayout {
    faces: usize,
    vertices: usize,
    frames: usize,
    /// Per frame, the bounds of what its accessor holds.
    bounds: Vec<(Vec3, Vec3)>,
    fps: f32,
}

impl BinLayout {
    fn index_bytes(&self) -> usize {
        self.faces * 12
    }
    /// Positions and normals of every frame.
    fn frames_bytes(&self) -> usize {
        self.frames * self.vertices * 24
    }
    fn targets(&self) -> usize {
        self.frames - 1
    }
    fn len(&self) -> usize {
        let animation = if self.targets() > 0 { self.frames * 4 + self.frames * self.targets() * 4 } else { 0 };
        self.index_bytes() + self.frames_bytes() + animation
    }
}

fn write_vec3(bin: &mut impl Write, v: Vec3) -> std::io::Result<()> {
    for c in v.to_array() {
        bin.write_all(&c.to_le_bytes())?;
    }
    Ok(())
}

/// Writes the binary chunk to `bin`, reading the frames one at a time.
fn write_bin(
    bin: &mut impl Write,
    werr: &dyn Fn(std::io::Error) -> Error,
    topology: &Topology,
    frame_count: usize,
    fps: f32,
    frame: &mut dyn FnMut(usize) -> Result<Frame>,
) -> Result<BinLayout> {
    let nv = topology.vertex_count;
    for i in topology.faces.iter().flatten() {
        bin.write_all(&i.to_le_bytes()).map_err(werr)?;
    }
    let mut bounds: Vec<(Vec3, Vec3)> = Vec::with_capacity(frame_count);
    // Frame 0's positions and normals, which the targets are relative to.
    let mut base: Vec<(Vec3, Vec3)> = Vec::new();
    for k in 0..frame_count {
        let positions = frame(k)?;
        if positions.len() != nv {
            return Err(Error::Argument(format!("frame {k} has {} vertices, expected {nv}", positions.len())));
        }
        let normals = vertex_normals(&positions, &topology.faces);
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for (i, p) in positions.iter().enumerate() {
            let v = if k == 0 { *p } else { *p - base[i].0 };
            lo = lo.min(v);
            hi = hi.max(v);
            write_vec3(bin, v).map_err(werr)?;
        }
        for (i, n) in normals.iter().enumerate() {
            write_vec3(bin, if k == 0 { *n } else { *n - base[i].1 }).map_err(werr)?;
        }
        bounds.push((lo, hi));
        if k == 0 {
            base = positions.into_iter().zip(normals).collect();
        }
    }
    let layout = BinLayout { faces: topology.faces.len(), vertices: nv, frames: frame_count, bounds, fps };
    let targets = layout.targets();
    if targets > 0 {
        for k in 0..frame_count {
            bin.write_all(&(k as f32 / fps).to_le_bytes()).map_err(werr)?;
        }
        for k in 0..frame_count {
            for j in 0..targets {
                let w: f32 = if k >= 1 && j == k - 1 { 1.0 } else { 0.0 };
                bin.write_all(&w.to_le_bytes()).map_err(werr)?;
            }
        }
    }
    bin.flush().map_err(werr)?;
    Ok(layout)
}

/// The glTF document for a binary chunk laid out as `l`. The frames'
/// accessors share one buffer view, which therefore states its stride (as
/// glTF requires of a view that several vertex accessors read). Accessor
/// 1 + 2k is frame k's positions, 2 + 2k its normals.
fn gltf_json(l: &BinLayout, name: &str) -> serde_json::Value {
    let (index_bytes, frames_bytes, targets, nv) = (l.index_bytes(), l.frames_bytes(), l.targets(), l.vertices);
    let mut accessors = vec![json!({
        "bufferView": 0, "componentType": UNSIGNED_INT, "count": l.faces * 3, "type": "SCALAR"
    })];
    for (k, (lo, hi)) in l.bounds.iter().enumerate() {
        accessors.push(json!({
            "bufferView": 1, "byteOffset": k * nv * 24, "componentType": FLOAT, "count": nv, "type": "VEC3",
            "min": lo.to_array(), "max": hi.to_array()
        }));
        accessors.push(json!({
            "bufferView": 1, "byteOffset": k * nv * 24 + nv * 12, "componentType": FLOAT, "count": nv, "type": "VEC3"
        }));
    }
    let mut buffer_views = vec![
        json!({"buffer": 0, "byteOffset": 0, "byteLength": index_bytes, "target": ELEMENT_ARRAY_BUFFER}),
        json!({"buffer": 0, "byteOffset": index_bytes, "byteLength": frames_bytes, "byteStride": 12,
            "target": ARRAY_BUFFER}),
    ];
    let mut primitive = json!({"attributes": {"POSITION": 1, "NORMAL": 2}, "indices": 0, "mode": 4});
    let mut mesh = json!({"name": name});
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": concat!("cgv ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": name}],
        "buffers": [{"byteLength": l.len()}],
    });
    if targets > 0 {
        primitive["targets"] = (1..=targets).map(|k| json!({"POSITION": 1 + 2 * k, "NORMAL": 2 + 2 * k})).collect();
        mesh["weights"] = vec![0.0; targets].into();
        mesh["extras"] = json!({"targetNames": (1..l.frames).map(|k| format!("frame {k}")).collect::<Vec<_>>()});
        let t_off = index_bytes + frames_bytes;
        buffer_views.push(json!({"buffer": 0, "byteOffset": t_off, "byteLength": l.frames * 4}));
        buffer_views
            .push(json!({"buffer": 0, "byteOffset": t_off + l.frames * 4, "byteLength": l.frames * targets * 4}));
        let input = accessors.len();
        accessors.push(json!({"bufferView": 2, "componentType": FLOAT, "count": l.frames, "type": "SCALAR",
            "min": [0.0], "max": [(l.frames - 1) as f32 / l.fps]}));
        accessors.push(json!({"bufferView": 3, "componentType": FLOAT, "count": l.frames * targets, "type": "SCALAR"}));
        doc["animations"] = json!([{
            "name": "motion",
            "channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}}],
            "samplers": [{"input": input, "output": input + 1, "interpolation": "LINEAR"}]
        }]);
    }
    mesh["primitives"] = json!([primitive]);
    doc["meshes"] = json!([mesh]);
    doc["accessors"] = accessors.into();
    doc["bufferViews"] = buffer_views.into();
    doc
}

/// Writes the GLB container: header, JSON chunk, and the binary chunk
/// read from `bin` (`bin_len` bytes), padded to 4 bytes.
pub(crate) fn write_container(path: &Path, doc: &serde_json::Value, bin: &mut dyn Read, bin_len: usize) -> Result<()> {
    let mut json_bytes = serde_json::to_vec(doc).map_err(|e| Error::Numerical(e.to_string()))?;
    while json_bytes.len() % 4 != 0 {
        json_bytes.push(b' ');
    }
    let bin_padded = bin_len.div_ceil(4) * 4;
    let total = 12 + 8 + json_bytes.len() + 8 + bin_padded;
    if total > u32::MAX as usize {
        return Err(Error::Argument(format!(
            "the sequence needs {total} bytes, more than a GLB file can hold (4 GiB); write an OBJ folder or fewer frames"
        )));
    }
    let mut out = AtomicFile::create(path)?;
    out.write_all(b"glTF")?;
    out.write_all(&2u32.to_le_bytes())?;
    out.write_all(&(total as u32).to_le_bytes())?;
    out.write_all(&(json_bytes.len() as u32).to_le_bytes())?;
    out.write_all(b"JSON")?;
    out.write_all(&json_bytes)?;
    out.write_all(&(bin_padded as u32).to_le_bytes())?;
    out.write_all(b"BIN\0")?;
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = bin.read(&mut buf).map_err(|e| Error::io(path, e))?;
        if n == 0 {
            break;
        }
        out.write_all(&buf[..n])?;
    }
    out.write_all(&vec![0u8; bin_padded - bin_len])?;
    out.commit()
}

/// Writes `frame_count` frames, produced one at a time by `frame(i)`, as a
/// morph-target animated GLB at `path`. The binary chunk goes to a scratch
/// file first: its size is known only after the last frame.
pub fn write_glb(
    path: &Path,
    topology: &Topology,
    frame_count: usize,
    fps: f32,
    name: &str,
    look: Option<&crate::format::Appearance>,
    mut frame: impl FnMut(usize) -> Result<Frame>,
) -> Result<()> {
    if frame_count == 0 {
        return Err(Error::Argument("cannot write a sequence of zero frames".into()));
    }
    crate::output::check_output_folder(path)?;
    let mut scratch_name = std::ffi::OsString::from(".");
    scratch_name.push(path.file_name().unwrap_or_default());
    scratch_name.push(format!(".{}.bin.partial", std::process::id()));
    let scratch = Scratch(path.with_file_name(scratch_name));
    let werr = |e: std::io::Error| Error::io(path, e);
    let file = std::fs::File::create(&scratch.0).map_err(werr)?;
    let mut bin = std::io::BufWriter::new(file);
    let layout = write_bin(&mut bin, &werr, topology, frame_count, fps, &mut frame)?;
    let mut doc = gltf_json(&layout, name);
    let mut len = layout.len();
    if let Some(look) = look.filter(|l| l.uvs.len() == topology.vertex_count) {
        len += write_look(&mut bin, look).map_err(werr)?;
        add_look(&mut doc, layout.len(), look);
        doc["buffers"][0]["byteLength"] = json!(len);
    }
    bin.flush().map_err(werr)?;
    drop(bin);
    let mut bin = std::fs::File::open(&scratch.0).map_err(|e| Error::io(&scratch.0, e))?;
    write_container(path, &doc, &mut bin, len)
}

/// Appends the texture coordinates and the texture image (padded to 4
/// bytes) to the binary chunk; returns the bytes written.
fn write_look(bin: &mut impl Write, look: &crate::format::Appearance) -> std::io::Result<usize> {
    for c in look.uvs.iter().flatten() {
        bin.write_all(&c.to_le_bytes())?;
    }
    let mut n = look.uvs.len() * 8;
    if let Some((_, image)) = &look.texture {
        bin.write_all(image)?;
        let pad = image.len().div_ceil(4) * 4 - image.len();
        bin.write_all(&vec![0u8; pad])?;
        n += image.len() + pad;
    }
    Ok(n)
}

/// The glTF of [`write_look`]'s data at byte `offset`: TEXCOORD_0 and a
/// material with the base colour (and its texture, embedded).
fn add_look(doc: &mut serde_json::Value, offset: usize, look: &crate::format::Appearance) {
    let nv = look.uvs.len();
    let views = doc["bufferViews"].as_array().map_or(0, Vec::len);
    let accessors = doc["accessors"].as_array().map_or(0, Vec::len);
    let mut new_views = vec![json!({"buffer": 0, "byteOffset": offset, "byteLength": nv * 8, "target": ARRAY_BUFFER})];
    let mut pbr = json!({"baseColorFactor": look.base_color, "metallicFactor": 0.0});
    if let Some((mime, image)) = &look.texture {
        new_views.push(json!({"buffer": 0, "byteOffset": offset + nv * 8, "byteLength": image.len()}));
        doc["images"] = json!([{"bufferView": views + 1, "mimeType": mime}]);
        doc["samplers"] = json!([{}]);
        doc["textures"] = json!([{"source": 0, "sampler": 0}]);
        pbr["baseColorTexture"] = json!({"index": 0});
    }
    if let Some(v) = doc["bufferViews"].as_array_mut() {
        v.extend(new_views);
    }
    if let Some(a) = doc["accessors"].as_array_mut() {
        a.push(json!({"bufferView": views, "componentType": FLOAT, "count": nv, "type": "VEC2"}));
    }
    doc["materials"] = json!([{"name": "input", "pbrMetallicRoughness": pbr}]);
    let primitive = &mut doc["meshes"][0]["primitives"][0];
    primitive["attributes"]["TEXCOORD_0"] = json!(accessors);
    primitive["material"] = json!(0);
}

/// `material.mtl` and the texture image (`texture.png` or `.jpg`) in `dir`.
fn write_material(dir: &Path, look: &crate::format::Appearance) -> Result<()> {
    let texture = look.texture.as_ref().map(|(mime, bytes)| {
        let name = if mime == "image/png" { "texture.png" } else { "texture.jpg" };
        (name, bytes)
    });
    if let Some((name, bytes)) = texture {
        let p = dir.join(name);
        std::fs::write(&p, bytes).map_err(|e| Error::io(&p, e))?;
    }
    let p = dir.join("material.mtl");
    std::fs::write(&p, super::obj::format_mtl(look.base_color, texture.map(|t| t.0))).map_err(|e| Error::io(&p, e))
}

/// Writes frames as `DIR/frame_0000.obj`, ... The folder must not exist or
/// be empty; it is filled under a temporary name and renamed when complete.
pub fn write_obj_folder(
    dir: &Path,
    topology: &Topology,
    frame_count: usize,
    look: Option<&crate::format::Appearance>,
    mut frame: impl FnMut(usize) -> Result<Frame>,
) -> Result<()> {
    let look = look.filter(|l| l.uvs.len() == topology.vertex_count);
    let material = |tmp: &Path| look.map_or(Ok(()), |l| write_material(tmp, l));
    write_folder(dir, frame_count, material, |k| {
        let positions = frame(k)?;
        Ok(match look {
            Some(l) => super::obj::format_textured_obj(&positions, &topology.faces, &l.uvs),
            None => super::obj::format_obj(&positions, &topology.faces),
        })
    })
}

/// [`write_obj_folder`] for frames that each have their own faces (a
/// capture's, format version 16's frame meshes): `frame(k)` gives frame
/// k's vertices and faces.
pub fn write_obj_folder_own_faces(
    dir: &Path,
    frame_count: usize,
    mut frame: impl FnMut(usize) -> Result<(Frame, Vec<[u32; 3]>)>,
) -> Result<()> {
    write_folder(
        dir,
        frame_count,
        |_| Ok(()),
        |k| {
            let (positions, faces) = frame(k)?;
            Ok(super::obj::format_obj(&positions, &faces))
        },
    )
}

/// Fills the empty or new folder `dir` under a temporary name (`first`
/// writes what all frames share, `text(k)` frame k's OBJ) and renames it
/// when complete; removes it on an error.
fn write_folder(
    dir: &Path,
    frame_count: usize,
    first: impl FnOnce(&Path) -> Result<()>,
    mut text: impl FnMut(usize) -> Result<String>,
) -> Result<()> {
    if dir.exists() {
        let mut entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
        if entries.next().is_some() {
            return Err(Error::Argument(format!("{}: output folder exists and is not empty", dir.display())));
        }
    }
    let name = dir.file_name().ok_or_else(|| Error::Argument(format!("{} is not a folder path", dir.display())))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".{}.partial", std::process::id()));
    let tmp = dir.with_file_name(tmp_name);
    std::fs::create_dir_all(&tmp).map_err(|e| Error::io(&tmp, e))?;
    let result = (|| {
        first(&tmp)?;
        let digits = (frame_count.max(1) - 1).to_string().len().max(4);
        for k in 0..frame_count {
            let p = tmp.join(format!("frame_{k:0digits$}.obj"));
            std::fs::write(&p, text(k)?).map_err(|e| Error::io(&p, e))?;
        }
        if dir.exists() {
            std::fs::remove_dir(dir).map_err(|e| Error::io(dir, e))?;
        }
        std::fs::rename(&tmp, dir).map_err(|e| Error::io(dir, e))
    })();
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&tmp);
    }
    result
}

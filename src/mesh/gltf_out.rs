//! Output of mesh sequences: glTF 2.0 binary (`.glb`) with the motion as a
//! morph-target animation that any glTF viewer plays (frame 0 is the base
//! mesh, frame k > 0 is morph target k - 1, and a LINEAR weights animation
//! blends from each frame to the next), and folders of numbered OBJ files.
//! Both are written frame by frame and appear only once complete.

use super::{Frame, Topology};
use crate::error::{Error, Result};
use crate::fsutil::AtomicFile;
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

/// Writes `frame_count` frames, produced one at a time by `frame(i)`, as a
/// morph-target animated GLB at `path`.
pub fn write_glb(
    path: &Path,
    topology: &Topology,
    frame_count: usize,
    fps: f32,
    name: &str,
    mut frame: impl FnMut(usize) -> Result<Frame>,
) -> Result<()> {
    if frame_count == 0 {
        return Err(Error::Argument("cannot write a sequence of zero frames".into()));
    }
    let nv = topology.vertex_count;
    let mut scratch_name = std::ffi::OsString::from(".");
    scratch_name.push(path.file_name().unwrap_or_default());
    scratch_name.push(format!(".{}.bin.partial", std::process::id()));
    let scratch = Scratch(path.with_file_name(scratch_name));
    let mut bin = std::io::BufWriter::new(std::fs::File::create(&scratch.0).map_err(|e| Error::io(&scratch.0, e))?);
    let werr = |e: std::io::Error| Error::io(&scratch.0, e);

    for f in &topology.faces {
        for i in f {
            bin.write_all(&i.to_le_bytes()).map_err(werr)?;
        }
    }
    let index_bytes = topology.faces.len() * 12;
    let mut bounds: Vec<(Vec3, Vec3)> = Vec::with_capacity(frame_count);
    let mut base: Vec<Vec3> = Vec::new();
    for k in 0..frame_count {
        let positions = frame(k)?;
        if positions.len() != nv {
            return Err(Error::Argument(format!("frame {k} has {} vertices, expected {nv}", positions.len())));
        }
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for (i, p) in positions.iter().enumerate() {
            let v = if k == 0 { *p } else { *p - base[i] };
            lo = lo.min(v);
            hi = hi.max(v);
            for c in v.to_array() {
                bin.write_all(&c.to_le_bytes()).map_err(werr)?;
            }
        }
        bounds.push((lo, hi));
        if k == 0 {
            base = positions;
        }
    }
    let positions_bytes = frame_count * nv * 12;
    let times: Vec<f32> = (0..frame_count).map(|k| k as f32 / fps).collect();
    let targets = frame_count - 1;
    if targets > 0 {
        for t in &times {
            bin.write_all(&t.to_le_bytes()).map_err(werr)?;
        }
        for k in 0..frame_count {
            for j in 0..targets {
                let w: f32 = if k >= 1 && j == k - 1 { 1.0 } else { 0.0 };
                bin.write_all(&w.to_le_bytes()).map_err(werr)?;
            }
        }
    }
    bin.flush().map_err(werr)?;
    drop(bin);
    let bin_len =
        index_bytes + positions_bytes + if targets > 0 { frame_count * 4 + frame_count * targets * 4 } else { 0 };

    let mut accessors = vec![json!({
        "bufferView": 0, "componentType": UNSIGNED_INT, "count": topology.faces.len() * 3, "type": "SCALAR"
    })];
    for (k, (lo, hi)) in bounds.iter().enumerate() {
        accessors.push(json!({
            "bufferView": 1, "byteOffset": k * nv * 12, "componentType": FLOAT, "count": nv, "type": "VEC3",
            "min": lo.to_array(), "max": hi.to_array()
        }));
    }
    let mut buffer_views = vec![
        json!({"buffer": 0, "byteOffset": 0, "byteLength": index_bytes, "target": ELEMENT_ARRAY_BUFFER}),
        json!({"buffer": 0, "byteOffset": index_bytes, "byteLength": positions_bytes, "target": ARRAY_BUFFER}),
    ];
    let mut primitive = json!({"attributes": {"POSITION": 1}, "indices": 0, "mode": 4});
    let mut mesh = json!({"name": name});
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": concat!("cgv ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": name}],
        "buffers": [{"byteLength": bin_len}],
    });
    if targets > 0 {
        primitive["targets"] = (0..targets).map(|j| json!({"POSITION": j + 2})).collect();
        mesh["weights"] = vec![0.0; targets].into();
        mesh["extras"] = json!({"targetNames": (1..frame_count).map(|k| format!("frame {k}")).collect::<Vec<_>>()});
        let t_off = index_bytes + positions_bytes;
        buffer_views.push(json!({"buffer": 0, "byteOffset": t_off, "byteLength": frame_count * 4}));
        buffer_views
            .push(json!({"buffer": 0, "byteOffset": t_off + frame_count * 4, "byteLength": frame_count * targets * 4}));
        let input = accessors.len();
        accessors.push(json!({"bufferView": 2, "componentType": FLOAT, "count": frame_count, "type": "SCALAR",
            "min": [times[0]], "max": [times[frame_count - 1]]}));
        accessors
            .push(json!({"bufferView": 3, "componentType": FLOAT, "count": frame_count * targets, "type": "SCALAR"}));
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

    let mut json_bytes = serde_json::to_vec(&doc).map_err(|e| Error::Numerical(e.to_string()))?;
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
    let mut f = std::fs::File::open(&scratch.0).map_err(|e| Error::io(&scratch.0, e))?;
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = f.read(&mut buf).map_err(|e| Error::io(&scratch.0, e))?;
        if n == 0 {
            break;
        }
        out.write_all(&buf[..n])?;
    }
    out.write_all(&vec![0u8; bin_padded - bin_len])?;
    out.commit()
}

/// Writes frames as `DIR/frame_0000.obj`, ... The folder must not exist or
/// be empty; it is filled under a temporary name and renamed when complete.
pub fn write_obj_folder(
    dir: &Path,
    topology: &Topology,
    frame_count: usize,
    mut frame: impl FnMut(usize) -> Result<Frame>,
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
        let digits = (frame_count.max(1) - 1).to_string().len().max(4);
        for k in 0..frame_count {
            let positions = frame(k)?;
            let p = tmp.join(format!("frame_{k:0digits$}.obj"));
            std::fs::write(&p, super::obj::format_obj(&positions, &topology.faces)).map_err(|e| Error::io(&p, e))?;
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

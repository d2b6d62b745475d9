//! A skinning as a standard glTF 2.0 skin (`.glb`): the rest mesh with
//! `JOINTS_0`/`WEIGHTS_0`, one joint node per bone under a common root,
//! each animated by LINEAR translation and rotation tracks at the frames'
//! times, and identity inverse bind matrices (the rest pose is the bind
//! pose). three.js, Babylon.js and every engine play it on the GPU.

use super::residual::MorphTargets;
use super::{Skinning, INFLUENCES};
use crate::error::{Error, Result};
use glam::{Quat, Vec3};
use serde_json::json;
use std::path::Path;

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const UNSIGNED_SHORT: u32 = 5123;

/// The binary chunk, built section by section, and the JSON's views and
/// accessors over it.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<serde_json::Value>,
    accessors: Vec<serde_json::Value>,
}

impl Bin {
    /// Appends `data` (4-byte aligned) as a buffer view of `target` and
    /// `accessor` over it; returns the accessor's index.
    fn push(&mut self, data: &[u8], target: Option<u32>, accessor: serde_json::Value) -> usize {
        while self.bytes.len() % 4 != 0 {
            self.bytes.push(0);
        }
        let mut view = json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len()});
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.bytes.extend_from_slice(data);
        let mut accessor = accessor;
        accessor["bufferView"] = json!(self.views.len());
        self.views.push(view);
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// Floats as an accessor of `kind`; `vertex`: a vertex attribute (its
    /// view targets the array buffer).
    fn floats(
        &mut self,
        v: &[f32],
        (kind, count): (&str, usize),
        minmax: Option<(Vec<f32>, Vec<f32>)>,
        vertex: bool,
    ) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        let mut a = json!({"componentType": FLOAT, "count": count, "type": kind});
        if let Some((lo, hi)) = minmax {
            (a["min"], a["max"]) = (json!(lo), json!(hi));
        }
        self.push(&bytes, vertex.then_some(ARRAY_BUFFER), a)
    }
}

/// Each vertex's four joints and weights as glTF wants them: the weights
/// summing to one in f32, and the unused slots on distinct joints of
/// weight zero (the validator refuses a joint repeated in one vertex).
fn joints_and_weights(skin: &Skinning) -> (Vec<u16>, Vec<f32>) {
    let (mut joints, mut weights) = (Vec::new(), Vec::new());
    for inf in &skin.influences {
        let used: Vec<u16> = inf.iter().filter(|i| i.1 > 0.0).map(|i| i.0).collect();
        let mut spare = (0..skin.bones as u16).filter(|b| !used.contains(b));
        let mut w: Vec<f32> = inf.iter().map(|i| i.1.max(0.0)).collect();
        let total: f32 = w.iter().sum();
        w.iter_mut().for_each(|x| *x /= total.max(f32::MIN_POSITIVE));
        // The largest weight takes what rounding leaves of one.
        let top = (0..INFLUENCES).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0);
        w[top] = 1.0 - (0..INFLUENCES).filter(|&k| k != top).map(|k| w[k]).sum::<f32>();
        for (k, i) in inf.iter().enumerate() {
            let j = if w[k] > 0.0 { i.0 } else { spare.next().unwrap_or(i.0) };
            joints.push(j);
            weights.push(w[k]);
        }
    }
    (joints, weights)
}

/// Writes `skin` over `faces` at `fps` as a skinned, animated GLB at `path`
/// (atomically). Needs at least [`INFLUENCES`] bones, so that each vertex
/// has four distinct joints.
pub fn write_skinned_glb(path: &Path, skin: &Skinning, faces: &[[u32; 3]], fps: f32, name: &str) -> Result<()> {
    write_skinned_glb_with(path, skin, None, faces, fps, name)
}

/// [`write_skinned_glb`] with the residual's morph targets (`morph`), which
/// the mesh carries as targets and the animation weighs every frame.
pub fn write_skinned_glb_with(
    path: &Path,
    skin: &Skinning,
    morph: Option<&MorphTargets>,
    faces: &[[u32; 3]],
    fps: f32,
    name: &str,
) -> Result<()> {
    if skin.bones < INFLUENCES || skin.frames() == 0 {
        return Err(Error::Argument(format!(
            "a skinned glTF needs at least {INFLUENCES} bones and one frame ({} bones, {} frames)",
            skin.bones,
            skin.frames()
        )));
    }
    let sheared = |m: &glam::Mat3| !(m.transpose() * *m).abs_diff_eq(glam::Mat3::IDENTITY, 1e-3);
    if skin.transforms.iter().flatten().any(|t| sheared(&t.linear)) {
        return Err(Error::Argument("affine bones: glTF joints rotate and translate, they cannot shear".into()));
    }
    crate::output::check_output_folder(path)?;
    let mut bin = Bin::default();
    let nv = skin.rest.len();
    let pos: Vec<f32> = skin.rest.iter().flat_map(|p| p.to_array()).collect();
    let (lo, hi) = skin.rest.iter().fold((Vec3::MAX, Vec3::MIN), |(l, h), p| (l.min(*p), h.max(*p)));
    let position = bin.floats(&pos, ("VEC3", nv), Some((lo.to_array().to_vec(), hi.to_array().to_vec())), true);
    let (joints, weights) = joints_and_weights(skin);
    let joint_bytes: Vec<u8> = joints.iter().flat_map(|j| j.to_le_bytes()).collect();
    let joints_acc = bin.push(
        &joint_bytes,
        Some(ARRAY_BUFFER),
        json!({"componentType": UNSIGNED_SHORT, "count": nv, "type": "VEC4"}),
    );
    let weights_acc = bin.floats(&weights, ("VEC4", nv), None, true);
    let index_bytes: Vec<u8> = faces.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
    let indices = bin.push(
        &index_bytes,
        Some(ELEMENT_ARRAY_BUFFER),
        json!({"componentType": UNSIGNED_INT, "count": faces.len() * 3, "type": "SCALAR"}),
    );
    let identity: Vec<f32> = (0..skin.bones).flat_map(|_| glam::Mat4::IDENTITY.to_cols_array()).collect();
    let ibm = bin.floats(&identity, ("MAT4", skin.bones), None, false);
    let (nodes, mut animation) = joints_animated(&mut bin, skin, fps);
    let mut primitive =
        json!({"attributes": attributes_of(position, joints_acc, weights_acc), "indices": indices, "mode": 4});
    let mut mesh = json!({"name": name});
    if let Some(m) = morph {
        primitive["targets"] = json!(morph_targets(&mut bin, m));
        mesh["weights"] = json!(vec![0.0; m.targets.len()]);
        morph_animated(&mut bin, m, &mut animation);
    }
    mesh["primitives"] = json!([primitive]);
    let root = skin.bones + 1;
    let mut all_nodes = vec![json!({"name": name, "mesh": 0, "skin": 0})];
    all_nodes.extend(nodes);
    all_nodes.push(json!({"name": "skeleton", "children": (1..=skin.bones).collect::<Vec<_>>()}));
    let doc = json!({
        "asset": {"version": "2.0", "generator": "cgv skin"},
        "scene": 0,
        "scenes": [{"nodes": [0, root]}],
        "nodes": all_nodes,
        "meshes": [mesh],
        "skins": [{"joints": (1..=skin.bones).collect::<Vec<_>>(), "inverseBindMatrices": ibm, "skeleton": root}],
        "animations": [animation],
        "buffers": [{"byteLength": bin.bytes.len()}],
        "bufferViews": bin.views,
        "accessors": bin.accessors,
    });
    let len = bin.bytes.len();
    crate::mesh::gltf_out::write_container(path, &doc, &mut bin.bytes.as_slice(), len)
}

fn attributes_of(position: usize, joints: usize, weights: usize) -> serde_json::Value {
    json!({"POSITION": position, "JOINTS_0": joints, "WEIGHTS_0": weights})
}

/// The morph targets' position accessors (each with the bounds glTF asks
/// of a target's positions).
fn morph_targets(bin: &mut Bin, m: &MorphTargets) -> Vec<serde_json::Value> {
    m.targets
        .iter()
        .map(|t| {
            let (lo, hi) = t.iter().fold((Vec3::MAX, Vec3::MIN), |(l, h), p| (l.min(*p), h.max(*p)));
            let data: Vec<f32> = t.iter().flat_map(|p| p.to_array()).collect();
            let bounds = Some((lo.to_array().to_vec(), hi.to_array().to_vec()));
            json!({"POSITION": bin.floats(&data, ("VEC3", t.len()), bounds, true)})
        })
        .collect()
}

/// The morph weights' track on the mesh's node (node 0), on the joints'
/// times (the animation's first sampler's input).
fn morph_animated(bin: &mut Bin, m: &MorphTargets, animation: &mut serde_json::Value) {
    let input = animation["samplers"][0]["input"].clone();
    let data: Vec<f32> = m.weights.iter().flatten().copied().collect();
    let output = bin.floats(&data, ("SCALAR", data.len()), None, false);
    if let (Some(samplers), Some(channels)) =
        (animation["samplers"].as_array().map(Vec::len), animation["channels"].as_array_mut())
    {
        channels.push(json!({"sampler": samplers, "target": {"node": 0, "path": "weights"}}));
    }
    if let Some(s) = animation["samplers"].as_array_mut() {
        s.push(json!({"input": input, "output": output, "interpolation": "LINEAR"}));
    }
}

/// The joint nodes (frame 0's pose) and the animation that moves them:
/// one shared time accessor, a translation and a rotation track per bone.
fn joints_animated(bin: &mut Bin, skin: &Skinning, fps: f32) -> (Vec<serde_json::Value>, serde_json::Value) {
    let frames = skin.frames();
    let times: Vec<f32> = (0..frames).map(|t| t as f32 / fps).collect();
    let last = times.last().copied().unwrap_or(0.0);
    let input = bin.floats(&times, ("SCALAR", frames), Some((vec![0.0], vec![last])), false);
    let (mut nodes, mut samplers, mut channels) = (Vec::new(), Vec::new(), Vec::new());
    for b in 0..skin.bones {
        let mut prev = Quat::IDENTITY;
        let (mut tr, mut rot) = (Vec::new(), Vec::new());
        for m in skin.transforms.iter().map(|f| f[b]) {
            let mut q = Quat::from_mat3(&m.linear).normalize();
            // The same hemisphere as the frame before: no spin the long way.
            if q.dot(prev) < 0.0 {
                q = -q;
            }
            prev = q;
            tr.extend(m.translation.to_array());
            rot.extend(q.to_array());
        }
        nodes.push(json!({"name": format!("bone {b}"), "translation": &tr[..3], "rotation": &rot[..4]}));
        for (path, data, kind) in [("translation", tr, "VEC3"), ("rotation", rot, "VEC4")] {
            let output = bin.floats(&data, (kind, frames), None, false);
            channels.push(json!({"sampler": samplers.len(), "target": {"node": b + 1, "path": path}}));
            samplers.push(json!({"input": input, "output": output, "interpolation": "LINEAR"}));
        }
    }
    (nodes, json!({"name": "motion", "samplers": samplers, "channels": channels}))
}

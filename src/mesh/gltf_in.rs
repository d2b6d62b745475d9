//! glTF 2.0 input (`.gltf` with external or embedded buffers, `.glb`): the
//! triangle meshes of the default scene, with morph targets and skinning,
//! baked to frames at a chosen rate by sampling one animation (linear, step
//! and cubic-spline interpolation, glTF 2.0 spec section 3.11). Vertices that
//! share a position in the first frame (split at UV seams, say) are welded, so
//! a character exported with seams still reads as one closed surface.

use super::source::check_frame;
use super::{Frame, FrameSource, Topology};
use crate::error::{Error, Result};
use base64::Engine;
use glam::{Mat4, Quat, Vec3};
use gltf::animation::{Interpolation, Property};
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy)]
struct Trs {
    t: Vec3,
    r: Quat,
    s: Vec3,
}

#[derive(Debug, Clone)]
struct Channel {
    node: usize,
    property: Property,
    interpolation: Interpolation,
    inputs: Vec<f32>,
    /// Flat outputs: `width` values per key (three times that for cubic splines).
    outputs: Vec<f32>,
    width: usize,
}

#[derive(Debug, Clone)]
struct Primitive {
    node: usize,
    positions: Vec<Vec3>,
    targets: Vec<Vec<Vec3>>,
    skin: Option<(Vec<usize>, Vec<Mat4>)>,
    joints: Vec<[u16; 4]>,
    weights: Vec<[f32; 4]>,
    /// TEXCOORD_0 (None where the primitive has none).
    uvs: Option<Vec<[f32; 2]>>,
    material: Option<usize>,
}

/// A glTF animation baked frame by frame.
pub struct GltfSource {
    label: PathBuf,
    fps: f32,
    topology: Topology,
    rest: Vec<Trs>,
    parents: Vec<Option<usize>>,
    node_weights: Vec<Vec<f32>>,
    channels: Vec<Channel>,
    prims: Vec<Primitive>,
    start: f32,
    frames: usize,
    /// For each output vertex, the raw (unwelded) vertex it copies.
    weld: Vec<u32>,
    /// The raw vertices, their UVs and the material's base colour.
    appearance: Option<super::Appearance>,
}

fn err(path: &Path, msg: impl Into<String>) -> Error {
    Error::Gltf { path: path.to_path_buf(), msg: msg.into() }
}

fn load_buffers(path: &Path, doc: &gltf::Document, blob: Option<Vec<u8>>) -> Result<Vec<Vec<u8>>> {
    let mut blob = blob;
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => {
                blob.take().ok_or_else(|| err(path, "buffer refers to a missing GLB BIN chunk"))?
            }
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, data) = rest.split_once(";base64,").ok_or_else(|| err(path, "data URI is not base64"))?;
                    base64::engine::general_purpose::STANDARD
                        .decode(data)
                        .map_err(|e| err(path, format!("bad base64 buffer: {e}")))?
                } else {
                    if uri.contains("://") || uri.starts_with('/') || uri.contains("..") {
                        return Err(err(path, format!("buffer URI '{uri}' is not a relative file name")));
                    }
                    let file = path.with_file_name(uri);
                    std::fs::read(&file).map_err(|e| Error::io(&file, e))?
                }
            }
        };
        if data.len() < buffer.length() {
            return Err(err(
                path,
                format!("buffer {} holds {} bytes, {} declared", buffer.index(), data.len(), buffer.length()),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

fn hermite(p0: f32, m0: f32, p1: f32, m1: f32, s: f32, dt: f32) -> f32 {
    let (s2, s3) = (s * s, s * s * s);
    (2.0 * s3 - 3.0 * s2 + 1.0) * p0 + (s3 - 2.0 * s2 + s) * dt * m0 + (-2.0 * s3 + 3.0 * s2) * p1 + (s3 - s2) * dt * m1
}

impl Channel {
    /// Samples the channel at time `t` into `out` (`width` values).
    fn sample(&self, t: f32, out: &mut [f32]) {
        let w = self.width;
        let n = self.inputs.len();
        let cubic = self.interpolation == Interpolation::CubicSpline;
        // Value of key k: for cubic splines the middle of (in-tangent, value, out-tangent).
        let value = |k: usize, c: usize| {
            if cubic {
                self.outputs[(3 * k + 1) * w + c]
            } else {
                self.outputs[k * w + c]
            }
        };
        let k = self.inputs.partition_point(|&x| x <= t);
        if k == 0 || n == 1 {
            (0..w).for_each(|c| out[c] = value(0, c));
        } else if k >= n {
            (0..w).for_each(|c| out[c] = value(n - 1, c));
        } else {
            let (t0, t1) = (self.inputs[k - 1], self.inputs[k]);
            let dt = (t1 - t0).max(f32::MIN_POSITIVE);
            let s = ((t - t0) / dt).clamp(0.0, 1.0);
            match self.interpolation {
                Interpolation::Step => (0..w).for_each(|c| out[c] = value(k - 1, c)),
                Interpolation::Linear if self.property == Property::Rotation => {
                    let q0 = Quat::from_slice(&self.outputs[(k - 1) * 4..k * 4]);
                    let q1 = Quat::from_slice(&self.outputs[k * 4..k * 4 + 4]);
                    let q = q0.normalize().slerp(q1.normalize(), s);
                    out[..4].copy_from_slice(&q.to_array());
                }
                Interpolation::Linear => (0..w).for_each(|c| out[c] = value(k - 1, c) * (1.0 - s) + value(k, c) * s),
                Interpolation::CubicSpline => {
                    for (c, o) in out.iter_mut().enumerate().take(w) {
                        let out_tan = self.outputs[(3 * (k - 1) + 2) * w + c];
                        let in_tan = self.outputs[(3 * k) * w + c];
                        *o = hermite(value(k - 1, c), out_tan, value(k, c), in_tan, s, dt);
                    }
                    if self.property == Property::Rotation {
                        let q = Quat::from_slice(&out[..4]).normalize();
                        out[..4].copy_from_slice(&q.to_array());
                    }
                }
            }
        }
    }
}

/// Each node's parent, rest transform and default morph weights (its own, else its mesh's).
fn read_nodes(doc: &gltf::Document) -> (Vec<Option<usize>>, Vec<Trs>, Vec<Vec<f32>>) {
    let n_nodes = doc.nodes().count();
    let mut parents = vec![None; n_nodes];
    let mut rest = Vec::with_capacity(n_nodes);
    let mut node_weights = Vec::with_capacity(n_nodes);
    for node in doc.nodes() {
        for child in node.children() {
            parents[child.index()] = Some(node.index());
        }
        let (t, r, s) = node.transform().decomposed();
        rest.push(Trs { t: Vec3::from(t), r: Quat::from_array(r), s: Vec3::from(s) });
        let w =
            node.weights().or_else(|| node.mesh().and_then(|m| m.weights())).map(|w| w.to_vec()).unwrap_or_default();
        node_weights.push(w);
    }
    (parents, rest, node_weights)
}

/// The triangle primitives of the default scene (or the first) and their faces, indexed across all primitives.
fn read_meshes(path: &Path, doc: &gltf::Document, buffers: &[Vec<u8>]) -> Result<(Vec<Primitive>, Vec<[u32; 3]>)> {
    let scene = doc.default_scene().or_else(|| doc.scenes().next()).ok_or_else(|| err(path, "no scene"))?;
    let mut stack: Vec<gltf::Node> = scene.nodes().collect();
    let mut prims = Vec::new();
    let mut raw_faces: Vec<[u32; 3]> = Vec::new();
    let mut visited = vec![false; doc.nodes().count()];
    while let Some(node) = stack.pop() {
        if std::mem::replace(&mut visited[node.index()], true) {
            return Err(err(path, "the node hierarchy has a cycle"));
        }
        stack.extend(node.children());
        let Some(mesh) = node.mesh() else { continue };
        let skin = match node.skin() {
            Some(skin) => Some(read_skin(path, buffers, &skin)?),
            None => None,
        };
        for prim in mesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                continue;
            }
            let (primitive, indices) = read_primitive(path, buffers, &prim, mesh.index(), node.index(), &skin)?;
            let base = prims.iter().map(|p: &Primitive| p.positions.len()).sum::<usize>() as u32;
            prims.push(primitive);
            raw_faces.extend(indices.chunks(3).map(|c| [c[0] + base, c[1] + base, c[2] + base]));
        }
    }
    if prims.is_empty() {
        return Err(err(path, "the scene has no triangle mesh"));
    }
    Ok((prims, raw_faces))
}

/// A skin's joint nodes and inverse bind matrices (identities when it has none).
fn read_skin(path: &Path, buffers: &[Vec<u8>], skin: &gltf::Skin) -> Result<(Vec<usize>, Vec<Mat4>)> {
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|v| v.as_slice());
    let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
    let ibm: Vec<Mat4> = match skin.reader(get).read_inverse_bind_matrices() {
        Some(m) => m.map(|m| Mat4::from_cols_array_2d(&m)).collect(),
        None => vec![Mat4::IDENTITY; joints.len()],
    };
    if ibm.len() != joints.len() {
        return Err(err(path, "skin has fewer inverse bind matrices than joints"));
    }
    Ok((joints, ibm))
}

/// One triangle primitive of mesh `mesh` on node `node`, and its triangle indices (local to it).
fn read_primitive(
    path: &Path,
    buffers: &[Vec<u8>],
    prim: &gltf::Primitive,
    mesh: usize,
    node: usize,
    skin: &Option<(Vec<usize>, Vec<Mat4>)>,
) -> Result<(Primitive, Vec<u32>)> {
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|v| v.as_slice());
    let reader = prim.reader(get);
    let positions: Vec<Vec3> = reader
        .read_positions()
        .ok_or_else(|| err(path, format!("mesh {mesh} has a primitive without positions")))?
        .map(Vec3::from)
        .collect();
    let targets: Vec<Vec<Vec3>> = reader
        .read_morph_targets()
        .map(|(p, _, _)| match p {
            Some(p) => p.map(Vec3::from).collect(),
            None => vec![Vec3::ZERO; positions.len()],
        })
        .collect();
    if targets.iter().any(|t| t.len() != positions.len()) {
        return Err(err(path, "a morph target's length differs from its primitive's"));
    }
    let (joints, weights) = if skin.is_some() {
        let j: Vec<[u16; 4]> =
            reader.read_joints(0).ok_or_else(|| err(path, "skinned primitive without JOINTS_0"))?.into_u16().collect();
        let w: Vec<[f32; 4]> = reader
            .read_weights(0)
            .ok_or_else(|| err(path, "skinned primitive without WEIGHTS_0"))?
            .into_f32()
            .collect();
        let nj = skin.as_ref().map_or(0, |s| s.0.len());
        if j.len() != positions.len() || w.len() != positions.len() || j.iter().flatten().any(|&x| x as usize >= nj) {
            return Err(err(path, "bad JOINTS_0/WEIGHTS_0 (length or joint index)"));
        }
        (j, w)
    } else {
        (Vec::new(), Vec::new())
    };
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..positions.len() as u32).collect(),
    };
    if indices.len() % 3 != 0 || indices.iter().any(|&i| i as usize >= positions.len()) {
        return Err(err(path, format!("mesh {mesh} has bad triangle indices")));
    }
    let uvs: Option<Vec<[f32; 2]>> = reader.read_tex_coords(0).map(|t| t.into_f32().collect());
    if uvs.as_ref().is_some_and(|u| u.len() != positions.len() || u.iter().flatten().any(|x| !x.is_finite())) {
        return Err(err(path, format!("mesh {mesh} has bad TEXCOORD_0 (length or a non-finite value)")));
    }
    let material = prim.material().index();
    Ok((Primitive { node, positions, targets, skin: skin.clone(), joints, weights, uvs, material }, indices))
}

/// The stored vertices' UVs and the first material's base colour, when a
/// primitive has UVs or a material (else None: the welded mesh is all).
fn read_appearance(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    prims: &[Primitive],
    welded: Vec<u32>,
    faces: Vec<[u32; 3]>,
) -> Result<Option<super::Appearance>> {
    let material = prims.iter().find_map(|p| p.material).and_then(|m| doc.materials().nth(m));
    if material.is_none() && prims.iter().all(|p| p.uvs.is_none()) {
        return Ok(None);
    }
    let uvs = prims.iter().flat_map(|p| p.uvs.clone().unwrap_or_else(|| vec![[0.0; 2]; p.positions.len()])).collect();
    let pbr = material.as_ref().map(|m| m.pbr_metallic_roughness());
    let base_color = pbr.as_ref().map_or([1.0; 4], |p| p.base_color_factor()).map(|c| c.clamp(0.0, 1.0));
    let texture = match pbr.and_then(|p| p.base_color_texture()) {
        Some(info) => Some(read_image(path, buffers, &info.texture().source())?),
        None => None,
    };
    Ok(Some(super::Appearance { welded, faces, look: crate::format::Appearance { uvs, base_color, texture } }))
}

/// An image's MIME type and bytes: from a buffer view, a data URI or a file beside the glTF.
fn read_image(path: &Path, buffers: &[Vec<u8>], image: &gltf::Image) -> Result<(String, Vec<u8>)> {
    let (mime, bytes) = match image.source() {
        gltf::image::Source::View { view, mime_type } => {
            let buffer = buffers.get(view.buffer().index()).map(Vec::as_slice).unwrap_or_default();
            let bytes = buffer.get(view.offset()..view.offset() + view.length());
            (mime_type.to_string(), bytes.ok_or_else(|| err(path, "an image's buffer view is out of range"))?.to_vec())
        }
        gltf::image::Source::Uri { uri, mime_type } => match uri.strip_prefix("data:") {
            Some(rest) => {
                let (mime, data) =
                    rest.split_once(";base64,").ok_or_else(|| err(path, "image data URI is not base64"))?;
                let bytes = base64::engine::general_purpose::STANDARD
                    .decode(data)
                    .map_err(|e| err(path, format!("bad base64 image: {e}")))?;
                (mime_type.unwrap_or(mime).to_string(), bytes)
            }
            None => {
                if uri.contains("://") || uri.starts_with('/') || uri.contains("..") {
                    return Err(err(path, format!("image URI '{uri}' is not a relative file name")));
                }
                let file = path.with_file_name(uri);
                let png = uri.to_ascii_lowercase().ends_with(".png");
                let mime = mime_type.unwrap_or(if png { "image/png" } else { "image/jpeg" });
                (mime.to_string(), std::fs::read(&file).map_err(|e| Error::io(&file, e))?)
            }
        },
    };
    if !crate::format::appearance::TEXTURE_MIME.contains(&mime.as_str()) {
        return Err(err(path, format!("base colour texture of type '{mime}' (PNG or JPEG expected)")));
    }
    Ok((mime, bytes))
}

/// The channels of the animation to bake: the one named or numbered `animation`, else the first (if any).
fn read_animation(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    animation: Option<&str>,
) -> Result<Vec<Channel>> {
    let anim = match animation {
        None => doc.animations().next(),
        Some(sel) => Some(
            doc.animations()
                .find(|a| a.name() == Some(sel) || sel.parse::<usize>().ok() == Some(a.index()))
                .ok_or_else(|| err(path, format!("no animation named or numbered '{sel}'")))?,
        ),
    };
    let mut channels = Vec::new();
    if let Some(anim) = anim {
        for ch in anim.channels() {
            channels.push(read_channel(path, buffers, &ch)?);
        }
    }
    Ok(channels)
}

/// One animation channel, with its key times and output width checked.
fn read_channel(path: &Path, buffers: &[Vec<u8>], ch: &gltf::animation::Channel) -> Result<Channel> {
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|v| v.as_slice());
    let r = ch.reader(get);
    let inputs: Vec<f32> = r.read_inputs().ok_or_else(|| err(path, "channel without inputs"))?.collect();
    let outputs: Vec<f32> = match r.read_outputs().ok_or_else(|| err(path, "channel without outputs"))? {
        gltf::animation::util::ReadOutputs::Translations(i) => i.flatten().collect(),
        gltf::animation::util::ReadOutputs::Scales(i) => i.flatten().collect(),
        gltf::animation::util::ReadOutputs::Rotations(i) => i.into_f32().flatten().collect(),
        gltf::animation::util::ReadOutputs::MorphTargetWeights(i) => i.into_f32().collect(),
    };
    let interpolation = ch.sampler().interpolation();
    let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
    if inputs.is_empty() || outputs.len() % (inputs.len() * per_key) != 0 {
        return Err(err(path, "animation sampler outputs do not match its inputs"));
    }
    if inputs.windows(2).any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
        || inputs.iter().any(|t| !t.is_finite())
    {
        return Err(err(path, "animation sampler times are not strictly increasing"));
    }
    let width = outputs.len() / (inputs.len() * per_key);
    let property = ch.target().property();
    let expected = match property {
        Property::Translation | Property::Scale => Some(3),
        Property::Rotation => Some(4),
        Property::MorphTargetWeights => None,
    };
    if expected.is_some_and(|e| e != width) {
        return Err(err(path, "animation output has the wrong number of components"));
    }
    Ok(Channel { node: ch.target().node().index(), property, interpolation, inputs, outputs, width })
}

/// The first key time and the number of frames the channels bake to at `fps` (one still frame without any).
fn frame_span(path: &Path, channels: &[Channel], fps: f32) -> Result<(f32, usize)> {
    let start = channels.iter().map(|c| c.inputs[0]).fold(f32::INFINITY, f32::min);
    let end = channels.iter().map(|c| *c.inputs.last().unwrap_or(&0.0)).fold(f32::NEG_INFINITY, f32::max);
    let (start, frames) =
        if channels.is_empty() { (0.0, 1) } else { (start, ((end - start) * fps + 1e-3).floor() as usize + 1) };
    if frames > 1_000_000 {
        return Err(err(path, format!("the animation would bake to {frames} frames")));
    }
    Ok((start, frames))
}

impl GltfSource {
    pub fn open(path: &Path, fps: f32, animation: Option<&str>) -> Result<GltfSource> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let gltf = gltf::Gltf::from_slice(&bytes).map_err(|e| err(path, e.to_string()))?;
        let doc = gltf.document;
        let buffers = load_buffers(path, &doc, gltf.blob)?;
        let (parents, rest, node_weights) = read_nodes(&doc);
        let (prims, raw_faces) = read_meshes(path, &doc, &buffers)?;
        let channels = read_animation(path, &doc, &buffers, animation)?;
        let (start, frames) = frame_span(path, &channels, fps)?;
        let mut src = GltfSource {
            label: path.to_path_buf(),
            fps,
            topology: Topology { vertex_count: 0, faces: Vec::new() },
            rest,
            parents,
            node_weights,
            channels,
            prims,
            start,
            frames,
            weld: Vec::new(),
            appearance: None,
        };
        let remap = src.weld_first_frame(&raw_faces);
        src.appearance = read_appearance(path, &doc, &buffers, &src.prims, remap, raw_faces)?;
        Ok(src)
    }

    /// Welds the raw vertices that coincide in the first frame, setting
    /// `weld` and the welded `topology`; returns each raw vertex's welded one.
    fn weld_first_frame(&mut self, raw_faces: &[[u32; 3]]) -> Vec<u32> {
        let first = self.bake_raw(self.start);
        let mut map = std::collections::HashMap::new();
        let mut remap = Vec::with_capacity(first.len());
        for (i, p) in first.iter().enumerate() {
            let key = p.to_array().map(f32::to_bits);
            let next = map.len() as u32;
            let id = *map.entry(key).or_insert_with(|| {
                self.weld.push(i as u32);
                next
            });
            remap.push(id);
        }
        self.topology = Topology {
            vertex_count: self.weld.len(),
            faces: raw_faces.iter().map(|f| f.map(|i| remap[i as usize])).collect(),
        };
        remap
    }

    fn globals(&self, t: f32) -> (Vec<Mat4>, Vec<Vec<f32>>) {
        let mut local = self.rest.clone();
        let mut weights = self.node_weights.clone();
        let mut buf = Vec::new();
        for ch in &self.channels {
            buf.resize(ch.width, 0.0);
            ch.sample(t, &mut buf);
            let trs = &mut local[ch.node];
            match ch.property {
                Property::Translation => trs.t = Vec3::from_slice(&buf),
                Property::Scale => trs.s = Vec3::from_slice(&buf),
                Property::Rotation => trs.r = Quat::from_slice(&buf).normalize(),
                Property::MorphTargetWeights => weights[ch.node] = buf.clone(),
            }
        }
        let mut global: Vec<Option<Mat4>> = vec![None; local.len()];
        for n in 0..local.len() {
            // Walk up to the first computed ancestor, then down again.
            let mut chain = vec![n];
            while let Some(p) = self.parents[*chain.last().unwrap_or(&n)] {
                if global[p].is_some() {
                    break;
                }
                chain.push(p);
                if chain.len() > local.len() {
                    break;
                }
            }
            for &c in chain.iter().rev() {
                if global[c].is_some() {
                    continue;
                }
                let l = Mat4::from_scale_rotation_translation(local[c].s, local[c].r, local[c].t);
                global[c] = Some(match self.parents[c].and_then(|p| global[p]) {
                    Some(pm) => pm * l,
                    None => l,
                });
            }
        }
        (global.into_iter().map(|m| m.unwrap_or(Mat4::IDENTITY)).collect(), weights)
    }

    fn bake_raw(&self, t: f32) -> Vec<Vec3> {
        let (global, weights) = self.globals(t);
        let mut out = Vec::new();
        for p in &self.prims {
            let w = &weights[p.node];
            let skin_mats: Option<Vec<Mat4>> =
                p.skin.as_ref().map(|(joints, ibm)| joints.iter().zip(ibm).map(|(&j, m)| global[j] * *m).collect());
            for (i, &base) in p.positions.iter().enumerate() {
                let mut pos = base;
                for (k, target) in p.targets.iter().enumerate() {
                    pos += target[i] * w.get(k).copied().unwrap_or(0.0);
                }
                let pos = match &skin_mats {
                    // A skinned mesh ignores its node's transform (glTF 2.0, 3.7.3).
                    Some(m) => {
                        let (j, wt) = (p.joints[i], p.weights[i]);
                        let mut acc = Vec3::ZERO;
                        for c in 0..4 {
                            if wt[c] != 0.0 {
                                acc += m[j[c] as usize].transform_point3(pos) * wt[c];
                            }
                        }
                        let sum: f32 = wt.iter().sum();
                        if sum > 0.0 {
                            acc / sum
                        } else {
                            pos
                        }
                    }
                    None => global[p.node].transform_point3(pos),
                };
                out.push(pos);
            }
        }
        out
    }
}

impl FrameSource for GltfSource {
    fn label(&self) -> &Path {
        &self.label
    }
    fn frame_count(&self) -> usize {
        self.frames
    }
    fn fps(&self) -> f32 {
        self.fps
    }
    fn topology(&self) -> &Topology {
        &self.topology
    }
    fn kind(&self) -> &'static str {
        "glTF animation"
    }
    fn appearance(&self) -> Option<&super::Appearance> {
        self.appearance.as_ref()
    }
    fn read_frame(&self, i: usize) -> Result<Frame> {
        if i >= self.frames {
            return Err(Error::Argument(format!("frame {i} is past the last frame {}", self.frames - 1)));
        }
        let raw = self.bake_raw(self.start + i as f32 / self.fps);
        let frame: Frame = self.weld.iter().map(|&r| raw[r as usize]).collect();
        check_frame(&self.label, &self.topology, &frame, None)?;
        Ok(frame)
    }
}

//! glTF 2.0 input: skinning, morph targets, and the three interpolations,
//! on small files built here.
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

mod common;

use cgv::mesh::{open_sequence, OpenOptions};
use common::{temp_dir, tetrahedron, GltfBuilder};
use glam::{Mat4, Vec3};
use serde_json::json;

fn open(path: &std::path::Path, fps: f32) -> Box<dyn cgv::mesh::FrameSource> {
    open_sequence(path.to_str().unwrap(), &OpenOptions { fps, ..Default::default() }).unwrap()
}

fn close(a: Vec3, b: Vec3) -> bool {
    a.distance(b) < 1e-5
}

#[test]
fn skinned_mesh_follows_its_joints() {
    // A tetrahedron whose top vertex (0, 2, 0) hangs on joint 1 at (0, 1, 0);
    // joint 1 turns 90° about z over one second.
    let mut p = tetrahedron().0;
    p[0] = Vec3::new(0.0, 2.0, 0.0);
    let f = tetrahedron().1;
    let mut b = GltfBuilder::default();
    let pos = b.vec3(&p);
    let idx = b.indices(&f);
    let joints = b.joints(&[[1, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]]);
    let weights = b.floats(&[1., 0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0.], "VEC4", 4);
    let ibm: Vec<f32> = [Mat4::IDENTITY, Mat4::from_translation(Vec3::new(0.0, -1.0, 0.0))]
        .iter()
        .flat_map(|m| m.to_cols_array())
        .collect();
    let ibm = b.floats(&ibm, "MAT4", 16);
    let times = b.floats(&[0.0, 1.0], "SCALAR", 1);
    let q = glam::Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    let rots = b.floats(&[0.0, 0.0, 0.0, 1.0, q.x, q.y, q.z, q.w], "VEC4", 4);
    let doc = json!({
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0, "skin": 0, "translation": [100.0, 0.0, 0.0]},
            {"name": "root", "children": [2]},
            {"name": "j1", "translation": [0.0, 1.0, 0.0]}
        ],
        "skins": [{"joints": [1, 2], "inverseBindMatrices": ibm}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos, "JOINTS_0": joints, "WEIGHTS_0": weights}, "indices": idx}]}],
        "animations": [{"channels": [{"sampler": 0, "target": {"node": 2, "path": "rotation"}}],
                        "samplers": [{"input": times, "output": rots, "interpolation": "LINEAR"}]}]
    });
    let dir = temp_dir("skin");
    let path = dir.join("skin.gltf");
    b.write(doc, &path);
    let src = open(&path, 2.0);
    assert_eq!(src.frame_count(), 3);
    let f0 = src.read_frame(0).unwrap();
    // The skinned mesh ignores its node's translation (glTF 2.0, 3.7.3).
    assert!(close(f0[0], Vec3::new(0.0, 2.0, 0.0)), "{:?}", f0[0]);
    assert!(close(f0[1], p[1]));
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let f1 = src.read_frame(1).unwrap();
    assert!(close(f1[0], Vec3::new(-s, 1.0 + s, 0.0)), "{:?}", f1[0]);
    let f2 = src.read_frame(2).unwrap();
    assert!(close(f2[0], Vec3::new(-1.0, 1.0, 0.0)), "{:?}", f2[0]);
    assert!(close(f2[3], p[3]));
}

fn morph_file(interp: &str, name: &str) -> std::path::PathBuf {
    let (p, f) = tetrahedron();
    let mut b = GltfBuilder::default();
    let pos = b.vec3(&p);
    let idx = b.indices(&f);
    let delta = b.vec3(&[Vec3::X, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO]);
    let times = b.floats(&[0.0, 1.0], "SCALAR", 1);
    // Cubic splines store (in-tangent, value, out-tangent) per key.
    let values: Vec<f32> = if interp == "CUBICSPLINE" { vec![0.0, 0.0, 2.0, 0.0, 1.0, 0.0] } else { vec![0.0, 1.0] };
    let w = b.floats(&values, "SCALAR", 1);
    let doc = json!({
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "translation": [0.0, 0.0, 10.0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "indices": idx, "targets": [{"POSITION": delta}]}], "weights": [0.0]}],
        "animations": [{"channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}}],
                        "samplers": [{"input": times, "output": w, "interpolation": interp}]}]
    });
    let path = temp_dir(name).join("morph.gltf");
    b.write(doc, &path);
    path
}

#[test]
fn morph_targets_with_linear_step_and_cubic_spline() {
    let base = tetrahedron().0[0] + Vec3::new(0.0, 0.0, 10.0);
    let x_at = |interp: &str, name: &str| -> Vec<f32> {
        let src = open(&morph_file(interp, name), 4.0);
        assert_eq!(src.frame_count(), 5);
        (0..5).map(|i| src.read_frame(i).unwrap()[0].x - base.x).collect()
    };
    let lin = x_at("LINEAR", "lin");
    assert!(lin.iter().zip([0.0, 0.25, 0.5, 0.75, 1.0]).all(|(a, b)| (a - b).abs() < 1e-6), "{lin:?}");
    let step = x_at("STEP", "step");
    assert_eq!(step, vec![0.0, 0.0, 0.0, 0.0, 1.0]);
    // Hermite with out-tangent 2 at key 0 and in-tangent 0 at key 1: at s = 1/2,
    // h10 * 2 + h01 * 1 = 0.125 * 2 + 0.5 = 0.75.
    let cubic = x_at("CUBICSPLINE", "cubic");
    assert!((cubic[2] - 0.75).abs() < 1e-6 && cubic[4] == 1.0, "{cubic:?}");
}

#[test]
fn animations_are_chosen_by_name_or_index_and_bad_files_are_errors() {
    let path = morph_file("LINEAR", "choose");
    let opts = |a: &str| OpenOptions { fps: 4.0, animation: Some(a.into()), ..Default::default() };
    assert!(open_sequence(path.to_str().unwrap(), &opts("0")).is_ok());
    let e = open_sequence(path.to_str().unwrap(), &opts("walk")).err().unwrap();
    assert!(e.to_string().contains("no animation named"), "{e}");
    let dir = temp_dir("badgltf");
    let bad = dir.join("bad.gltf");
    std::fs::write(&bad, b"{ not json").unwrap();
    let e = open_sequence(bad.to_str().unwrap(), &OpenOptions::default()).err().unwrap();
    assert!(matches!(e, cgv::Error::Gltf { .. }) && e.to_string().contains("bad.gltf"), "{e}");
    let glb = dir.join("bad.glb");
    std::fs::write(&glb, b"glTF\x02\0\0\0\x10\0\0\0").unwrap();
    assert!(open_sequence(glb.to_str().unwrap(), &OpenOptions::default()).is_err());
}

#[test]
fn uvs_split_vertices_and_the_base_colour_are_kept_beside_the_welded_mesh() {
    // A tetrahedron whose vertex 0 is stored twice (a UV seam): 5 stored
    // vertices, 4 welded; a material with a base colour factor.
    let (mut p, mut f) = tetrahedron();
    p.push(p[0]);
    f[2][0] = 4;
    let uvs: Vec<f32> = vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.25, 0.75];
    let mut b = GltfBuilder::default();
    let (pos, idx, uv) = (b.vec3(&p), b.indices(&f), b.floats(&uvs, "VEC2", 2));
    let doc = json!({
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 1.0, 1.0]}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "indices": idx, "material": 0}]}]
    });
    let path = temp_dir("gltf-uvs").join("seam.gltf");
    b.write(doc, &path);
    let src = open(&path, 30.0);
    assert_eq!(src.topology().vertex_count, 4);
    let a = src.appearance().expect("UVs and a material");
    assert_eq!(a.welded, vec![0, 1, 2, 3, 0]);
    assert_eq!(a.faces, f);
    assert_eq!(a.look.uvs[4], [0.25, 0.75]);
    assert_eq!(a.look.base_color, [0.5, 0.25, 1.0, 1.0]);
    assert!(a.look.texture.is_none());
    // The encoded file's own mesh is the stored one, seam and all.
    let opts = cgv::codec::EncodeOptions { grid: 16, ..Default::default() };
    let (bytes, _) = cgv::codec::encode(src.as_ref(), &opts, &mut |_, _, _| {}).unwrap();
    let file = cgv::format::read(&bytes).unwrap();
    assert_eq!(file.source_mesh.as_ref().map(|m| m.places.len()), Some(5));
    assert_eq!(file.source_mesh.as_ref().map(|m| m.places[4]), file.source_mesh.as_ref().map(|m| m.places[0]));
    assert_eq!(file.appearance.map(|l| l.uvs), Some(a.look.uvs.clone()));
}

//! The skinning decomposition (src/skin/): a motion made by skinning a mesh
//! with known bones and weights is recovered, and the skinned glTF it
//! writes reads back with its joints, weights and animation.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use cgv::skin::{decompose, gltf::write_skinned_glb, Rigid, SkinOptions, Skinning};
use glam::{Mat3, Vec3};

/// A tube along x (radius 0.3, length 4) in four segments, each a bone
/// bending about z at the joint before it, weights blended over a fifth of
/// a segment on each side of each joint: `frames` frames of a wave.
fn bending_arm(frames: usize) -> (Skinning, Vec<[u32; 3]>) {
    let (mut p, f) = common::tube(12, 40, false);
    // common::tube runs along z from -1 to 1 with radius 0.5: make it an arm along x.
    for q in &mut p {
        *q = Vec3::new(2.0 * q.z + 2.0, 0.6 * q.x, 0.6 * q.y);
    }
    let bones = 4;
    let influences = p
        .iter()
        .map(|q| {
            let s = q.x.clamp(0.0, 3.999);
            let (b, frac) = (s.floor() as u16, s.fract());
            let mut inf = [(0u16, 0.0f32); 4];
            // Near the joint at the start of segment b, share with b - 1.
            if b > 0 && frac < 0.2 {
                let w = 0.5 + 2.5 * frac;
                inf[0] = (b, w);
                inf[1] = (b - 1, 1.0 - w);
            } else {
                inf[0] = (b, 1.0);
            }
            inf
        })
        .collect();
    let transforms = (0..frames)
        .map(|t| {
            // Each joint bends by its own wave; the chain composes them.
            let mut chain = Rigid::default();
            (0..bones)
                .map(|b| {
                    let angle = 0.5 * ((t as f32) * 0.4 + b as f32).sin();
                    let joint = Vec3::new(b as f32, 0.0, 0.0);
                    let rot = Mat3::from_rotation_z(angle);
                    // Rotate about the joint, after the parent's motion.
                    let local = Rigid { rotation: rot, translation: joint - rot * joint };
                    chain = Rigid {
                        rotation: chain.rotation * local.rotation,
                        translation: chain.rotation * local.translation + chain.translation,
                    };
                    chain
                })
                .collect()
        })
        .collect();
    (Skinning { rest: p, bones, influences, transforms }, f)
}

#[test]
fn a_skinned_motion_is_recovered() {
    let (truth, faces) = bending_arm(24);
    let frames: Vec<Vec<Vec3>> = (0..truth.frames()).map(|t| truth.frame(t)).collect();
    let diag = cgv::mesh::Bounds::of(&frames[0]).diagonal() as f64;
    let opts = SkinOptions { bones: 4, iterations: 20, rest: 0 };
    let mut history = Vec::new();
    let skin = decompose(&frames, &faces, &opts, &mut |_, rms| history.push(rms)).unwrap();
    let rms = cgv::skin::ssdr::rms(&frames, &skin) / diag;
    eprintln!("recovered 4 bones: vertex RMS {:.5} % of the diagonal; by iteration {history:?}", 100.0 * rms);
    // Rigid bones and blended weights are the model the motion was made
    // with: the fit comes within 0.2 % of the diagonal (measured 0.06 %,
    // still falling after 20 alternations).
    assert!(rms < 0.002, "vertex RMS {rms} of the diagonal");
    for inf in &skin.influences {
        let sum: f32 = inf.iter().map(|i| i.1).sum();
        assert!((sum - 1.0).abs() < 1e-4 && inf.iter().all(|i| i.1 >= 0.0), "{inf:?}");
    }
    // One bone cannot follow a bending arm: the fit is no constant.
    let one = decompose(&frames, &faces, &SkinOptions { bones: 1, iterations: 2, rest: 0 }, &mut |_, _| {}).unwrap();
    assert!(cgv::skin::ssdr::rms(&frames, &one) / diag > 10.0 * rms);
}

#[test]
fn the_skinned_gltf_reads_back_with_joints_weights_and_animation() {
    let (truth, faces) = bending_arm(6);
    let dir = common::temp_dir("skin-gltf");
    let path = dir.join("arm.glb");
    write_skinned_glb(&path, &truth, &faces, 30.0, "arm").unwrap();
    let g = gltf::Gltf::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let (doc, blob) = (&g.document, g.blob.as_deref().unwrap());
    let skin = doc.skins().next().expect("a skin");
    assert_eq!(skin.joints().count(), 4);
    let prim = doc.meshes().next().unwrap().primitives().next().unwrap();
    let reader = prim.reader(|_| Some(blob));
    let joints: Vec<[u16; 4]> = reader.read_joints(0).unwrap().into_u16().collect();
    let weights: Vec<[f32; 4]> = reader.read_weights(0).unwrap().into_f32().collect();
    assert_eq!((joints.len(), weights.len()), (truth.rest.len(), truth.rest.len()));
    for (v, (j, w)) in joints.iter().zip(&weights).enumerate() {
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        // The glTF's weights are the skinning's, joint for joint.
        for &(b, x) in truth.influences[v].iter().filter(|i| i.1 > 0.0) {
            let k = j.iter().position(|&jj| jj == b).unwrap();
            assert!((w[k] - x).abs() < 1e-6, "vertex {v}");
        }
    }
    let anim = doc.animations().next().expect("an animation");
    assert_eq!(anim.channels().count(), 2 * 4);
    // Bone 2's translation at frame 5 is the skinning's.
    let ch = anim
        .channels()
        .find(|c| c.target().node().index() == 3 && c.target().property() == gltf::animation::Property::Translation)
        .unwrap();
    let out: Vec<[f32; 3]> = match ch.reader(|_| Some(blob)).read_outputs().unwrap() {
        gltf::animation::util::ReadOutputs::Translations(t) => t.collect(),
        _ => panic!("not translations"),
    };
    assert!(Vec3::from(out[5]).abs_diff_eq(truth.transforms[5][2].translation, 1e-6));
}

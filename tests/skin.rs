//! The skinning decomposition (src/skin/): a motion made by skinning a mesh
//! with known bones and weights is recovered, and the skinned glTF it
//! writes reads back with its joints, weights and animation.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use cgv::skin::{decompose, gltf::write_skinned_glb, BoneTransform, SkinOptions, Skinning};
use glam::{Mat3, Vec3};

/// A tube along x (radius 0.3, length 4) in four segments, each a bone
/// bending about z at the joint before it, weights blended over a fifth of
/// a segment on each side of each joint: `frames` frames of a wave.
fn bending_arm(frames: usize) -> (Skinning, Vec<[u32; 3]>) {
    bending_arm_of(frames, common::tube(12, 40, false))
}

/// [`bending_arm`] on a tube of `common::tube`'s.
fn bending_arm_of(frames: usize, (mut p, f): (Vec<Vec3>, Vec<[u32; 3]>)) -> (Skinning, Vec<[u32; 3]>) {
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
            let mut chain = BoneTransform::default();
            (0..bones)
                .map(|b| {
                    let angle = 0.5 * ((t as f32) * 0.4 + b as f32).sin();
                    let joint = Vec3::new(b as f32, 0.0, 0.0);
                    let rot = Mat3::from_rotation_z(angle);
                    // Rotate about the joint, after the parent's motion.
                    let local = BoneTransform { linear: rot, translation: joint - rot * joint };
                    chain = BoneTransform {
                        linear: chain.linear * local.linear,
                        translation: chain.linear * local.translation + chain.translation,
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
    let opts = SkinOptions { bones: 4, iterations: 20, rest: 0, affine: false };
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
    let one =
        decompose(&frames, &faces, &SkinOptions { bones: 1, iterations: 2, rest: 0, affine: false }, &mut |_, _| {})
            .unwrap();
    assert!(cgv::skin::ssdr::rms(&frames, &one) / diag > 10.0 * rms);
}

/// The bending arm with each bone also stretching along the arm and
/// shearing: affine bones (the published decompositions' kind) made it.
fn stretching_arm(frames: usize) -> (Skinning, Vec<[u32; 3]>) {
    let (mut skin, faces) = bending_arm(frames);
    for (t, m) in skin.transforms.iter_mut().enumerate() {
        for (b, bone) in m.iter_mut().enumerate() {
            let s = 1.0 + 0.15 * ((t as f32) * 0.3 + b as f32).cos();
            let shear = Mat3::from_cols(Vec3::new(s, 0.1 * (t as f32 * 0.2).sin(), 0.0), Vec3::Y, Vec3::Z);
            let joint = Vec3::new(b as f32, 0.0, 0.0);
            // Stretch about the bone's joint, then move as before.
            *bone = BoneTransform {
                linear: bone.linear * shear,
                translation: bone.linear * (joint - shear * joint) + bone.translation,
            };
        }
    }
    (skin, faces)
}

#[test]
fn affine_bones_recover_a_stretching_motion_that_rigid_ones_cannot() {
    let (truth, faces) = stretching_arm(24);
    let frames: Vec<Vec<Vec3>> = (0..truth.frames()).map(|t| truth.frame(t)).collect();
    let diag = cgv::mesh::Bounds::of(&frames[0]).diagonal() as f64;
    let fit = |affine: bool| {
        let opts = SkinOptions { bones: 4, iterations: 20, rest: 0, affine };
        let skin = decompose(&frames, &faces, &opts, &mut |_, _| {}).unwrap();
        cgv::skin::ssdr::rms(&frames, &skin) / diag
    };
    let (affine, rigid) = (fit(true), fit(false));
    eprintln!("stretching arm, 4 bones: affine {:.4} %, rigid {:.4} % of the diagonal", 100.0 * affine, 100.0 * rigid);
    // The model it was made with: within 0.2 % (as the rigid arm's bound);
    // rigid bones cannot stretch, and are several times further off.
    assert!(affine < 0.002, "affine vertex RMS {affine}");
    assert!(rigid > 3.0 * affine, "rigid {rigid} against affine {affine}");
    // glTF joints cannot shear: the writer refuses affine bones, no file.
    let opts = SkinOptions { bones: 4, iterations: 4, rest: 0, affine: true };
    let skin = decompose(&frames, &faces, &opts, &mut |_, _| {}).unwrap();
    let path = common::temp_dir("skin-affine").join("affine.glb");
    let err = write_skinned_glb(&path, &skin, &faces, 30.0, "arm").unwrap_err();
    assert!(err.to_string().contains("shear") && !path.exists(), "{err}");
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

/// Encodes `src` at N = 32, QP `qp`, motion corrections, with `bones`
/// bones, and returns the file, its size less its source mesh, the decoded
/// input vertices' RMS error over all frames relative to the diagonal,
/// and the share of frames the bones predicted.
fn closed_loop_with_bones(src: &cgv::mesh::InMemory, qp: u8, bones: u16) -> (Vec<u8>, usize, f64, f64) {
    use cgv::codec::{encode, h264::VideoSettings, EncodeOptions};
    use cgv::format::CorrectionMode;
    let video = VideoSettings { qp, ..Default::default() };
    let opts = EncodeOptions {
        grid: 32,
        video,
        corrections: CorrectionMode::Motion,
        bones: Some(bones),
        ..Default::default()
    };
    let (bytes, report) = encode(src, &opts, &mut |_, _, _| {}).unwrap();
    let file = cgv::format::read(&bytes).unwrap();
    let skinned = file.frames.iter().filter(|f| f.predictor.extrapolation.is_skinned()).count();
    let size = bytes.len() - report.source_mesh_bytes;
    let n = src.frames.len() as f64;
    (bytes.clone(), size, decoded_error(file, src), skinned as f64 / n)
}

/// The RMS over all frames of `file`'s decoded source vertices' error
/// against `src`, relative to the diagonal.
fn decoded_error(file: cgv::format::CgvFile, src: &cgv::mesh::InMemory) -> f64 {
    let mut dec = cgv::codec::FileDecoder::new(file, cgv::solve::SolverKind::Predictive).unwrap();
    let mesh = dec.source_mesh().unwrap();
    let diag = cgv::mesh::Bounds::of(&src.frames[0]).diagonal() as f64;
    let mut sum = 0.0;
    for frame in &src.frames {
        let (grid, _) = dec.next_frame().unwrap();
        let (rms, _) = cgv::metrics::vertex_error(&mesh.vertices(&grid, dec.loose(), dec.at_vertices()), frame);
        sum += (rms / diag).powi(2);
    }
    (sum / src.frames.len() as f64).sqrt()
}

fn in_memory(name: &str, frames: Vec<Vec<Vec3>>, faces: Vec<[u32; 3]>) -> cgv::mesh::InMemory {
    let vertex_count = frames[0].len();
    cgv::mesh::InMemory { label: name.into(), fps: 30.0, topology: cgv::mesh::Topology { vertex_count, faces }, frames }
}

/// Bones as the closed loop's predictor (format version 13): on a motion
/// made by skinning, the encoder predicts nearly every frame by the bones
/// and its files come much closer than without them at less than twice
/// the size; on a motion that is not articulated (a tube breathing in a
/// travelling wave) the files still decode.
#[test]
fn bones_predict_an_articulated_motion_in_the_closed_loop() {
    let (truth, faces) = bending_arm(30);
    let arm = in_memory("arm", (0..truth.frames()).map(|t| truth.frame(t)).collect(), faces);
    for qp in [30, 44] {
        let (_, b0, e0, s0) = closed_loop_with_bones(&arm, qp, 0);
        let (file, b4, e4, s4) = closed_loop_with_bones(&arm, qp, 4);
        eprintln!(
            "arm QP {qp}: no bones {b0} bytes {:.4} %, 4 bones {b4} bytes {:.4} % ({:.0} % skinned)",
            100.0 * e0,
            100.0 * e4,
            100.0 * s4
        );
        assert!(cgv::format::read(&file).unwrap().header.skin.is_some());
        // Measured: QP 30 1.51 % in 6.0 KB without, 0.30 % in 11.3 KB with
        // (the weights of 1,024 samples among them); QP 44 4.64 % in
        // 4.3 KB, 0.40 % in 7.1 KB. All but the first frame are skinned.
        assert!(s0 == 0.0 && s4 > 0.9, "{s0} {s4}");
        assert!(e4 < 0.3 * e0 && b4 < 2 * b0, "{e4} {e0} {b4} {b0}");
    }
    let (p, f) = common::tube(12, 40, false);
    let breathing: Vec<Vec<Vec3>> = (0..30)
        .map(|t| {
            p.iter()
                .map(|q| {
                    let r = 1.0 + 0.2 * (3.0 * q.z - 0.4 * t as f32).sin();
                    Vec3::new(r * q.x, r * q.y, q.z)
                })
                .collect()
        })
        .collect();
    let tube = in_memory("breathing", breathing, f);
    // Bones are kept only where they cut the corrections' energy 4x
    // (BONE_GAIN); where they are, a file with them decodes closer at the
    // same QP (measured with the gain at 3/4, which kept them: QP 30 1.03 %
    // in 5.3 KB without, 0.27 % in 20.6 KB with; QP 44 2.99 % in 4.1 KB,
    // 0.70 % in 11.9 KB, the motion corrections' range narrower, so their
    // steps finer); where they are not, the file is the one without.
    for qp in [30, 44] {
        let (without, b0, e0, _) = closed_loop_with_bones(&tube, qp, 0);
        let (with, b4, e4, _) = closed_loop_with_bones(&tube, qp, 4);
        match cgv::format::read(&with).unwrap().header.skin {
            Some(_) => assert!(e4 < e0 && b4 < 5 * b0, "QP {qp}: {e4} {e0} {b4} {b0}"),
            None => assert!(with == without, "bones left out change nothing"),
        }
    }
}

/// Encodes `src` with the skinned codec (format version 17: `bones` bones
/// on its own vertices, what they miss as x, y, z on a 32² grid) at QP
/// `qp`; returns the file, its size less the source mesh line (faces,
/// places, rest pose) and the decoded vertices' RMS error over all frames
/// relative to the diagonal.
fn skinned_codec(src: &cgv::mesh::InMemory, qp: u8, bones: u16) -> (Vec<u8>, usize, f64) {
    use cgv::codec::{encode, h264::VideoSettings, EncodeOptions};
    let video = VideoSettings { qp, ..Default::default() };
    let opts = EncodeOptions {
        grid: 32,
        video,
        representation: cgv::format::Representation::Skinned,
        bones: Some(bones),
        ..Default::default()
    };
    let (bytes, report) = encode(src, &opts, &mut |_, _, _| {}).unwrap();
    assert!(report.rest_pose_bytes > 0 && report.source_mesh_bytes > report.rest_pose_bytes);
    let file = cgv::format::read(&bytes).unwrap();
    assert_eq!(file.header.representation(), cgv::format::Representation::Skinned);
    assert!(file.frames.iter().all(|f| f.bones.as_ref().is_some_and(|b| !b.is_empty())), "every frame has its bones");
    let size = bytes.len() - report.source_mesh_bytes;
    (bytes.clone(), size, decoded_error(file, src))
}

/// The skinned codec (bones on the vertices, format version 17) on a
/// motion made by skinning: the arm comes back within the bones'
/// quantization at the coarsest QP, in a file within a few times the
/// bones' own compact bits, and closer than the closed loop with the
/// grid's bones at the same QP. On a motion bones cannot make (the
/// breathing tube) the residual video carries it: closer at a finer QP.
#[test]
fn the_skinned_codec_recovers_a_skinned_motion_at_about_the_bones_size() {
    let (truth, faces) = bending_arm(30);
    let compact = (truth.compact_bits() / 8) as usize;
    let arm = in_memory("arm", (0..truth.frames()).map(|t| truth.frame(t)).collect(), faces);
    for qp in [30, 51] {
        let (_, size, err) = skinned_codec(&arm, qp, 4);
        let (_, grid_size, grid_err, _) = closed_loop_with_bones(&arm, qp, 4);
        eprintln!(
            "arm QP {qp}: skinned {size} bytes {:.4} % (bones' compact form {compact} bytes); \
             grid bones {grid_size} bytes {:.4} %",
            100.0 * err,
            100.0 * grid_err
        );
        // Measured: QP 30 0.040 % in 8.8 KB, QP 51 0.080 % in 4.1 KB
        // (compact form 6.8 KB); the grid's bones 0.305 % and 0.767 %.
        assert!(err < 0.0015 && size < compact * 3 / 2, "{err} {size} {compact}");
        assert!(err < 0.3 * grid_err, "{err} {grid_err}");
    }
    let (p, f) = common::tube(12, 40, false);
    let breathing: Vec<Vec<Vec3>> = (0..30)
        .map(|t| {
            let wave = |q: &Vec3| 1.0 + 0.2 * (3.0 * q.z - 0.4 * t as f32).sin();
            p.iter().map(|q| Vec3::new(wave(q) * q.x, wave(q) * q.y, q.z)).collect()
        })
        .collect();
    let tube = in_memory("breathing", breathing, f);
    let (_, fine_size, fine) = skinned_codec(&tube, 20, 4);
    let (_, coarse_size, coarse) = skinned_codec(&tube, 44, 4);
    eprintln!(
        "breathing: QP 20 {fine_size} bytes {:.4} %, QP 44 {coarse_size} bytes {:.4} %",
        100.0 * fine,
        100.0 * coarse
    );
    // Measured: QP 20 0.185 % in 22.4 KB, QP 44 0.802 % in 6.5 KB.
    assert!(fine < 0.3 * coarse && fine < 0.003 && fine_size > coarse_size, "{fine} {coarse}");
}

/// A mesh tens of thousands of diagonals from the origin keeps a rest pose
/// in the skinned codec's 32-bit steps (coarser ones, not numbers clamped
/// to i32, which would put it 16 units, four diagonals, off): it decodes
/// about as close as float32 positions there allow, as the closed loop does.
#[test]
fn the_skinned_codec_keeps_a_rest_pose_far_from_the_origin() {
    let (truth, faces) = bending_arm(24);
    let far = Vec3::new(1.0e5, -2.0e4, 3.0e4);
    let frames: Vec<Vec<Vec3>> =
        (0..truth.frames()).map(|t| truth.frame(t).iter().map(|p| *p + far).collect()).collect();
    let arm = in_memory("far arm", frames, faces);
    let (file, _, err) = skinned_codec(&arm, 30, 4);
    let (_, _, grid_err, _) = closed_loop_with_bones(&arm, 30, 0);
    eprintln!("far arm: skinned {err}, closed loop {grid_err}");
    let step = cgv::format::read(&file).unwrap().header.skin.unwrap().rest_step.unwrap();
    // float32 at 1e5 resolves 0.008 units, the diagonal is about 4.1.
    // Measured: 2.4 % for the skinned codec, 1.5 % for the closed loop
    // (0.04 % and 0.3 % at the origin).
    assert!(step > 4.1e-5 && err < 0.05 && err < 3.0 * grid_err, "step {step}, error {err}, closed loop {grid_err}");
}

/// `auto` under a budget or a target error: the skinned codec where its
/// file can be made within the budget, the closed loop (with the reason in
/// the report) where the budget is below the skinned file's smallest; a
/// target error is measured on the mesh the skinned file decodes to, and
/// met there.
#[test]
fn auto_takes_the_skinned_codec_for_a_budget_or_target_it_can_meet() {
    use cgv::codec::{CodecChoice, EncodeRequest, Made};
    use cgv::format::Representation;
    // pcow's first 24 frames: the skinned file's weights and rest pose make
    // its smallest file the larger (a tube bent by bones has cheap weights).
    let dir = common::real_sequence("pcow");
    let full = cgv::mesh::open_sequence(dir.to_str().unwrap(), &Default::default()).unwrap();
    let arm = in_memory("pcow", (0..24).map(|f| full.read_frame(f).unwrap()).collect(), full.topology().faces.clone());
    let request = |codec: CodecChoice, qp: u8, kbps: Option<f32>, target_error: Option<f64>| {
        let mut base = cgv::codec::EncodeOptions { bones: Some(16), ..Default::default() };
        (base.video.qp, base.video.kbps) = (qp, kbps);
        let grid = cgv::codec::GridChoice::Size(64);
        let r = EncodeRequest { base, codec, target_error, grid, ..Default::default() };
        r.encode(&arm, &mut || Ok(Vec::new()), &mut |_, _, _| {}).unwrap()
    };
    let smallest = |r: Representation| request(CodecChoice::Named(r), 51, None, None).report.bytes;
    // At QP 51 the skinned file's weights are coarse (`--weights auto`).
    let fine = {
        let mut base = cgv::codec::EncodeOptions { bones: Some(16), coarse_weights: Some(false), ..Default::default() };
        base.video.qp = 51;
        let (codec, grid) = (CodecChoice::Named(Representation::Skinned), cgv::codec::GridChoice::Size(64));
        let r = EncodeRequest { base, codec, grid, ..Default::default() };
        r.encode(&arm, &mut || Ok(Vec::new()), &mut |_, _, _| {}).unwrap().report
    };
    let (skinned, normal) = (smallest(Representation::Skinned), smallest(Representation::Normal));
    let kbps = |bytes: usize| (bytes as f64 * 8.0 / 1000.0 / (24.0 / 30.0)) as f32;
    eprintln!("smallest files: skinned {skinned} bytes (fine weights {}), normal {normal}", fine.bytes);
    assert!(skinned + fine.skin_bytes / 3 < fine.bytes, "coarse weights save a third of the weights' bytes");
    assert!(normal * 10 < skinned * 9, "the closed loop's smallest file is the smaller: {normal} {skinned}");
    let low = request(CodecChoice::Auto, 20, Some(kbps((normal + skinned) / 2)), None);
    assert_ne!(low.report.codec, Representation::Skinned);
    assert!(low.report.auto_passed_over.as_deref().is_some_and(|w| w.starts_with("skinned")));
    let ample = request(CodecChoice::Auto, 20, Some(kbps(3 * skinned)), None);
    assert_eq!(ample.report.codec, Representation::Skinned);
    assert!(ample.report.auto_passed_over.is_none() && ample.report.budget_miss.is_some_and(|m| m.abs() <= 0.05));
    // A target the skinned file meets above its smallest: kept, its error
    // measured on the arm's own mesh as decoded.
    let tight = request(CodecChoice::Auto, 20, None, Some(0.1));
    let t = tight.target.as_ref().unwrap();
    assert_eq!(tight.report.codec, Representation::Skinned);
    let Made::Bytes(bytes) = &tight.file else { panic!("a target error is encoded in memory") };
    let err = decoded_error(cgv::format::read(bytes).unwrap(), &arm);
    eprintln!("target 0.1 %: QP {}, surface RMS {:.4} %, vertex RMS {:.4} %", t.qp, 100.0 * t.surface_rms, 100.0 * err);
    // Measured: QP 32, surface RMS 0.097 %, vertex RMS 0.244 % (pcow's
    // vertex errors run 2-3x its surface errors).
    assert!(t.surface_rms <= 0.001 && t.qp < 51 && err < 0.003, "{} {err}", t.surface_rms);
    // A target the skinned file meets at its smallest, which the closed
    // loop meets in a smaller one.
    let loose = request(CodecChoice::Auto, 20, None, Some(2.0));
    assert_ne!(loose.report.codec, Representation::Skinned);
    assert!(loose.report.bytes < skinned && loose.target.is_some_and(|t| t.surface_rms <= 0.02));
    assert!(loose.report.auto_passed_over.as_deref().is_some_and(|w| w.contains("only at its smallest")));
}

/// The vertex residual (format versions 18 and 19, `--vertex-residual P`): below
/// the grid's resampling floor at the mesh's own vertices, to about P % of
/// the diagonal, over the skinned codec and the closed loop alike; codecs
/// whose decoded grid the encoder does not know refuse it.
#[test]
fn the_vertex_residual_takes_the_vertices_below_the_grids_floor() {
    use cgv::codec::{encode, h264::VideoSettings, EncodeOptions};
    use cgv::format::Representation;
    let src = cgv::mesh::builtin::motion(6);
    let video = VideoSettings { qp: 40, ..Default::default() };
    for (representation, bones) in [(Representation::Skinned, Some(8)), (Representation::Normal, None)] {
        let opts = EncodeOptions { representation, grid: 16, video, bones, ..Default::default() };
        let (plain, _) = encode(&src, &opts, &mut |_, _, _| {}).unwrap();
        let before = decoded_error(cgv::format::read(&plain).unwrap(), &src);
        // A quarter of what the grid reaches.
        let asked = before / 4.0;
        let opts = EncodeOptions { vertex_residual: Some(100.0 * asked as f32), ..opts };
        let (bytes, report) = encode(&src, &opts, &mut |_, _, _| {}).unwrap();
        let file = cgv::format::read(&bytes).unwrap();
        let r = file.header.vertex_residual.expect("a residual");
        assert_eq!((file.header.min_version(), r.spatial, r.sparse, r.contexts), (20, true, true, true));
        let after = decoded_error(file, &src);
        eprintln!(
            "{representation:?}: {:.4} % -> {:.4} % for {} residual bytes",
            100.0 * before,
            100.0 * after,
            report.vertex_residual_bytes
        );
        assert!(before > 0.0005, "{representation:?}: the grid alone is {before} off: no floor to go below");
        assert!(after <= asked * 1.05, "{representation:?}: {after} with a residual of {asked}");
        assert!(report.vertex_residual_bytes > 0 && bytes.len() > plain.len());
    }
    let opts =
        EncodeOptions { representation: Representation::Conformal, vertex_residual: Some(0.05), ..Default::default() };
    let err = encode(&src, &opts, &mut |_, _, _| {}).unwrap_err().to_string();
    assert!(err.contains("vertex residual"), "{err}");
    // A target error a third of the grid's vertex RMS at QP 0 is met with
    // a vertex residual, measured on the decoded mesh.
    let opts =
        EncodeOptions { representation: Representation::Skinned, grid: 16, bones: Some(8), ..Default::default() };
    let image = cgv::codec::prepare(&src, &opts).unwrap();
    let skinned = cgv::codec::CodecChoice::Named(Representation::Skinned);
    let at_qp0 = EncodeOptions { video: VideoSettings { qp: 0, ..Default::default() }, ..opts.clone() };
    let (floor, _) = encode(&src, &at_qp0, &mut |_, _, _| {}).unwrap();
    let floor = decoded_error(cgv::format::read(&floor).unwrap(), &src);
    let target = floor / 3.0;
    let (bytes, _, t) = cgv::codec::encode_to_error(&src, &opts, skinned, &image, target, &mut |_, _, _| {}).unwrap();
    let got = decoded_error(cgv::format::read(&bytes).unwrap(), &src);
    eprintln!("target {target:.6} (a third of QP 0's vertex RMS {floor:.6}): {t:?}, vertex RMS {got:.6}");
    assert!(t.vertex_residual.is_some() && t.surface_rms <= target, "{t:?}");
}

/// A large `--kbps` budget (at least `RESIDUAL_BUDGET_BITS` a vertex a
/// frame) tries a vertex residual under the same budget and keeps the file
/// with the lower vertex RMS on the input's vertices, both within the
/// budget; a small one does not try it.
#[test]
fn a_large_budget_tries_the_vertex_residual_and_keeps_the_closer_file() {
    use cgv::codec::{encode, EncodeOptions};
    use cgv::format::Representation;
    let src = cgv::mesh::builtin::motion(12);
    let bits = |kbps: f32| f64::from(kbps) * 1000.0 / 30.0 / src.topology.vertex_count as f64;
    let mut opts =
        EncodeOptions { representation: Representation::Skinned, grid: 16, bones: Some(8), ..Default::default() };
    opts.video.kbps = Some(1800.0);
    assert!(bits(1800.0) >= cgv::codec::RESIDUAL_BUDGET_BITS);
    let (bytes, report) = encode(&src, &opts, &mut |_, _, _| {}).unwrap();
    let tried = report.budget_residual.expect("a residual tried");
    eprintln!("{tried:?}, {} bytes, {:+.2} %", bytes.len(), 100.0 * report.budget_miss.unwrap());
    assert!(report.budget_miss.is_some_and(|m| m.abs() <= cgv::codec::BUDGET_TOLERANCE));
    let file = cgv::format::read(&bytes).unwrap();
    assert_eq!(file.header.vertex_residual.is_some(), tried.kept);
    let without = tried.vertex_rms_without.expect("a file without a residual within the budget");
    assert_eq!(tried.kept, tried.vertex_rms_with < without);
    // The error measured on the sampled frames is the kept file's own.
    let kept = if tried.kept { tried.vertex_rms_with } else { without };
    let all = decoded_error(file, &src);
    assert!((all / kept - 1.0).abs() < 0.25, "{all} on every frame, {kept} on the sampled ones");
    // Past the plain file's largest (about 2,000 kbit/s here), only the
    // residual fills the budget, and it goes below the 16² grid's floor.
    let mut ample = opts.clone();
    ample.video.kbps = Some(2400.0);
    let (_, report) = encode(&src, &ample, &mut |_, _, _| {}).unwrap();
    let t = report.budget_residual.expect("a residual tried");
    assert!(t.kept && t.vertex_rms_without.is_none() && t.vertex_rms_with < 0.5 * without, "{t:?}");
    // The closed loop's file keeps the input's mesh too: both files are
    // measured on its vertices, not only the one with a residual.
    let mut normal = EncodeOptions { representation: Representation::Normal, grid: 64, bones: Some(0), ..opts.clone() };
    normal.video.kbps = Some(650.0);
    let (_, report) = encode(&cgv::mesh::builtin::motion(48), &normal, &mut |_, _, _| {}).unwrap();
    let t = report.budget_residual.expect("a residual tried");
    eprintln!("normal: {t:?}");
    let without = t.vertex_rms_without.expect("the plain file within the budget");
    assert!(without.is_finite() && t.vertex_rms_with.is_finite(), "{t:?}");
    assert_eq!(t.kept, t.vertex_rms_with < without, "{t:?}");
    // Below: not tried (a longer motion, whose weights and rest pose the
    // smaller budget affords).
    let src = cgv::mesh::builtin::motion(72);
    opts.video.kbps = Some(540.0);
    assert!(bits(540.0) < cgv::codec::RESIDUAL_BUDGET_BITS);
    let (_, report) = encode(&src, &opts, &mut |_, _, _| {}).unwrap();
    assert!(report.budget_residual.is_none() && report.budget_miss.is_some());
}

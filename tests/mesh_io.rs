//! Reading and writing mesh sequences: OBJ folders in numeric order, single
//! OBJ files, frame consistency errors, GLB and OBJ output.
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

mod common;

use cgv::mesh::{open_sequence, OpenOptions};
use cgv::{Error, MeshProblem};
use common::{temp_dir, tetrahedron, write_obj};
use glam::Vec3;

fn open(p: &std::path::Path) -> cgv::Result<Box<dyn cgv::mesh::FrameSource>> {
    open_sequence(p.to_str().unwrap(), &OpenOptions::default())
}

#[test]
fn obj_folder_is_ordered_by_frame_number() {
    let dir = temp_dir("order");
    let (p, f) = tetrahedron();
    for k in [10u32, 2, 1, 33] {
        let moved: Vec<Vec3> = p.iter().map(|v| *v + Vec3::X * k as f32).collect();
        write_obj(&dir.join(format!("{k}.obj")), &moved, &f);
    }
    std::fs::write(dir.join("notes.txt"), "not a frame").unwrap();
    let src = open(&dir).unwrap();
    assert_eq!(src.frame_count(), 4);
    let xs: Vec<f32> = (0..4).map(|i| src.read_frame(i).unwrap()[0].x - 1.0).collect();
    assert_eq!(xs, vec![1.0, 2.0, 10.0, 33.0]);
}

#[test]
fn zero_padded_names_and_single_files() {
    let dir = temp_dir("padded");
    let (p, f) = tetrahedron();
    write_obj(&dir.join("mesh_0001.obj"), &p, &f);
    write_obj(&dir.join("mesh_0000.obj"), &p, &f);
    assert_eq!(open(&dir).unwrap().frame_count(), 2);
    let single = open(&dir.join("mesh_0001.obj")).unwrap();
    assert_eq!(single.frame_count(), 1);
    assert_eq!(single.read_frame(0).unwrap(), p);
}

#[test]
fn frames_that_disagree_with_the_first_are_rejected_naming_the_file() {
    let (p, f) = tetrahedron();
    // Vertex count.
    let dir = temp_dir("count");
    write_obj(&dir.join("0.obj"), &p, &f);
    let mut more = p.clone();
    more.push(Vec3::ZERO);
    write_obj(&dir.join("1.obj"), &more, &f);
    let e = open(&dir).unwrap().read_frame(1).unwrap_err();
    assert!(
        matches!(&e, Error::Mesh { problem: MeshProblem::VertexCountMismatch { expected: 4, found: 5 }, path } if path.ends_with("1.obj")),
        "{e}"
    );
    // Faces.
    let dir = temp_dir("faces");
    write_obj(&dir.join("0.obj"), &p, &f);
    let mut g = f.clone();
    g[2] = [0, 3, 2];
    write_obj(&dir.join("1.obj"), &p, &g);
    let e = open(&dir).unwrap().read_frame(1).unwrap_err();
    assert!(matches!(e, Error::Mesh { problem: MeshProblem::FacesDiffer { face: 2 }, .. }), "{e}");
    // Non-finite coordinates.
    let dir = temp_dir("nan");
    write_obj(&dir.join("0.obj"), &p, &f);
    std::fs::write(dir.join("1.obj"), "v 0 0 0\nv 1 0 0\nv 0 nan 0\nv 0 0 1\nf 1 2 3\nf 1 4 2\nf 1 3 4\nf 2 4 3\n")
        .unwrap();
    let e = open(&dir).unwrap().read_frame(1).unwrap_err();
    assert!(matches!(e, Error::Mesh { problem: MeshProblem::NonFinite { vertex: 2 }, .. }), "{e}");
    assert!(e.to_string().contains("1.obj"), "{e}");
}

#[test]
fn missing_and_unknown_inputs_are_clear_errors() {
    let e = open_sequence("/nonexistent/cgv/motion", &OpenOptions::default()).err().unwrap();
    assert!(matches!(e, Error::Io { .. }) && e.to_string().contains("/nonexistent/cgv/motion"), "{e}");
    let dir = temp_dir("unknown");
    std::fs::write(dir.join("x.ply"), "ply").unwrap();
    let e = open(&dir.join("x.ply")).err().unwrap();
    assert!(matches!(e, Error::Argument(_)), "{e}");
    let e = open(&dir).err().unwrap();
    assert!(e.to_string().contains("no .obj files"), "{e}");
}

#[test]
fn glb_and_obj_output_round_trip() {
    let src = cgv::mesh::builtin::motion(5);
    let dir = temp_dir("roundtrip");
    let glb = dir.join("walk.glb");
    cgv::mesh::gltf_out::write_glb(&glb, &src.topology, 5, 30.0, "walk", None, |i| Ok(src.frames[i].clone())).unwrap();
    let back = open(&glb).unwrap();
    assert_eq!(back.frame_count(), 5);
    assert_eq!(back.topology().faces, src.topology.faces);
    for i in 0..5 {
        let f = back.read_frame(i).unwrap();
        let (rms, max) = cgv::metrics::vertex_error(&f, &src.frames[i]);
        assert!(max < 1e-5, "frame {i}: rms {rms} max {max}");
    }
    let objs = dir.join("frames");
    cgv::mesh::gltf_out::write_obj_folder(&objs, &src.topology, 5, None, |i| Ok(src.frames[i].clone())).unwrap();
    let back = open(&objs).unwrap();
    assert_eq!(back.frame_count(), 5);
    assert_eq!(back.read_frame(3).unwrap(), src.frames[3]);
    // A failing writer leaves neither the file nor a partial one behind.
    let bad = dir.join("bad.glb");
    let r = cgv::mesh::gltf_out::write_glb(&bad, &src.topology, 5, 30.0, "walk", None, |i| {
        if i < 3 {
            Ok(src.frames[i].clone())
        } else {
            Err(Error::Argument("boom".into()))
        }
    });
    assert!(r.is_err());
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left.len(), 2, "leftovers: {left:?}");
    // A temporary a killed process left (no such process) goes when the file
    // is next written; one of a live process (this one) stays.
    if std::path::Path::new("/proc/self").exists() {
        let orphan = dir.join(".bad.glb.4294967295-0.partial");
        let live = dir.join(format!(".bad.glb.{}-999999.partial", std::process::id()));
        std::fs::write(&orphan, b"half").unwrap();
        std::fs::write(&live, b"being written").unwrap();
        cgv::output::write_atomic(&bad, b"whole").unwrap();
        assert!(!orphan.exists() && live.exists() && std::fs::read(&bad).unwrap() == b"whole");
        std::fs::remove_file(&live).unwrap();
    }
}

#[test]
fn frame_selections_parse_and_slice() {
    use cgv::mesh::FrameSelection;
    let p = |s: &str| s.parse::<FrameSelection>();
    assert_eq!(p("2..5"), Ok(FrameSelection { start: 2, end: Some(5) }));
    assert_eq!(p("2..=5"), Ok(FrameSelection { start: 2, end: Some(6) }));
    assert_eq!(p("..5"), Ok(FrameSelection { start: 0, end: Some(5) }));
    assert_eq!(p("7.."), Ok(FrameSelection { start: 7, end: None }));
    for bad in ["", "5", "a..b", "5..2", "3..3", "-1..2"] {
        assert!(p(bad).is_err(), "{bad}");
    }
    let opts = |f: &str| cgv::mesh::OpenOptions { frames: Some(p(f).unwrap()), ..Default::default() };
    let all = cgv::mesh::open_sequence("builtin:walk", &Default::default()).unwrap();
    let some = cgv::mesh::open_sequence("builtin:walk", &opts("10..13")).unwrap();
    assert_eq!(some.frame_count(), 3);
    let same = |a: usize, b: usize| some.read_frame(a).unwrap() == all.read_frame(b).unwrap();
    assert!(same(0, 10) && same(1, 11) && same(2, 12) && !same(1, 1));
    assert!(some.read_frame(3).is_err());
    let e = cgv::mesh::open_sequence("builtin:walk", &opts("70..80")).err().unwrap();
    assert!(e.to_string().contains("frames 70..80 are not inside its 72 frames"), "{e}");
    // A range starting past the end is refused the same way (it once underflowed).
    let e = cgv::mesh::open_sequence("builtin:walk", &opts("500..")).err().unwrap();
    assert!(e.to_string().contains("frames 500..72 are not inside"), "{e}");
}

//! Each topology problem is found and named.
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

mod common;

use cgv::mesh::topology::HoleFill;
use cgv::mesh::{analyze, open_sequence, OpenOptions, Topology};
use cgv::MeshProblem;
use common::{icosphere, temp_dir, tetrahedron, write_obj};
use glam::Vec3;

fn problems(p: &[Vec3], f: &[[u32; 3]]) -> Vec<MeshProblem> {
    analyze(&Topology { vertex_count: p.len(), faces: f.to_vec() }, p).problems
}

fn has(ps: &[MeshProblem], pred: impl Fn(&MeshProblem) -> bool) -> bool {
    ps.iter().any(pred)
}

#[test]
fn clean_spheres_pass() {
    let (p, f) = icosphere(2);
    let r = analyze(&Topology { vertex_count: p.len(), faces: f.clone() }, &p);
    assert!(r.is_sphere(), "{:?}", r.problems);
    assert_eq!((r.genus, r.components, r.boundary_loops, r.euler_characteristic), (Some(0), 1, 0, 2));
    let (p, f) = tetrahedron();
    assert!(problems(&p, &f).is_empty());
}

#[test]
fn degenerate_zero_area_and_duplicate_faces() {
    let (mut p, mut f) = tetrahedron();
    f.push([0, 0, 1]);
    assert!(has(&problems(&p, &f), |x| matches!(x, MeshProblem::DegenerateFace { face: 4, vertex: 0 })));
    let (_, mut f) = tetrahedron();
    p.push((p[0] + p[1]) / 2.0);
    f.push([0, 4, 1]);
    assert!(has(&problems(&p, &f), |x| matches!(x, MeshProblem::ZeroAreaFace { face: 4 })));
    let (p, mut f) = tetrahedron();
    f.push([1, 2, 0]);
    assert!(has(&problems(&p, &f), |x| matches!(x, MeshProblem::DuplicateFace { first: 0, second: 4 })));
}

#[test]
fn non_manifold_edges_vertices_and_orientation() {
    let (mut p, mut f) = tetrahedron();
    p.push(Vec3::new(3.0, 0.0, 0.0));
    f.push([0, 1, 4]);
    assert!(has(&problems(&p, &f), |x| matches!(x, MeshProblem::NonManifoldEdge { a: 0, b: 1, count: 3 })));

    let (p, mut f) = tetrahedron();
    f[3] = [2, 3, 1];
    assert!(has(&problems(&p, &f), |x| matches!(x, MeshProblem::InconsistentOrientation { .. })));

    // Two tetrahedra sharing vertex 0 only.
    let (mut p, mut f) = tetrahedron();
    let (q, g) = tetrahedron();
    p.extend(q[1..].iter().map(|v| *v + Vec3::new(0.0, 0.0, 4.0)));
    f.extend(g.iter().map(|t| t.map(|i| if i == 0 { 0 } else { i + 3 })));
    let ps = problems(&p, &f);
    assert!(has(&ps, |x| matches!(x, MeshProblem::NonManifoldVertex { vertex: 0, fans: 2 })), "{ps:?}");
}

#[test]
fn unused_vertices_components_holes_and_genus() {
    let (mut p, f) = tetrahedron();
    p.push(Vec3::ZERO);
    assert!(has(&problems(&p, &f), |x| matches!(x, MeshProblem::UnusedVertex { vertex: 4 })));

    let (mut p, mut f) = tetrahedron();
    let (q, g) = tetrahedron();
    p.extend(q.iter().map(|v| *v + Vec3::X * 5.0));
    f.extend(g.iter().map(|t| t.map(|i| i + 4)));
    assert!(has(&problems(&p, &f), |x| matches!(x, MeshProblem::Components { count: 2 })));

    let (p, mut f) = tetrahedron();
    f.pop();
    let ps = problems(&p, &f);
    assert!(has(&ps, |x| matches!(x, MeshProblem::Holes { loops: 1, edges: 3 })), "{ps:?}");
    assert!(ps.iter().all(|x| matches!(x, MeshProblem::Holes { .. })), "only the hole: {ps:?}");

    // A torus: 8 x 6 quads.
    let (n, m) = (8u32, 6u32);
    let mut p = Vec::new();
    let mut f = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (a, b) = (i as f32 / n as f32 * std::f32::consts::TAU, j as f32 / m as f32 * std::f32::consts::TAU);
            p.push(Vec3::new((2.0 + b.cos()) * a.cos(), (2.0 + b.cos()) * a.sin(), b.sin()));
            let id = |i: u32, j: u32| (i % n) * m + (j % m);
            f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let r = analyze(&Topology { vertex_count: p.len(), faces: f }, &p);
    assert_eq!(r.genus, Some(1));
    assert!(has(&r.problems, |x| matches!(x, MeshProblem::Genus { genus: 1 })));
}

#[test]
fn fill_holes_closes_boundary_loops() {
    let (mut p, mut f) = icosphere(1);
    // Cut two holes: remove the faces around vertices 0 and 3.
    f.retain(|t| !t.contains(&0) && !t.contains(&3));
    let topo = Topology { vertex_count: p.len(), faces: f.clone() };
    let r = analyze(&topo, &p);
    assert_eq!(r.boundary_loops, 2);
    let plan = HoleFill::plan(&topo);
    assert_eq!(plan.loops.len(), 2);
    plan.apply(&mut p);
    // Vertices 0 and 3 are now unused; every other problem is gone.
    let r = analyze(&plan.topology, &p);
    assert!(r.problems.iter().all(|x| matches!(x, MeshProblem::UnusedVertex { .. })), "{:?}", r.problems);
    assert_eq!(r.boundary_loops, 0);

    // Through the reader: an OBJ with a hole opens closed with --fill-holes.
    let dir = temp_dir("fill");
    let (p, mut f) = icosphere(1);
    f.retain(|t| !t.contains(&5));
    let keep: Vec<u32> = (0..p.len() as u32).filter(|&v| v != 5).collect();
    let remap = |i: u32| keep.iter().position(|&k| k == i).unwrap() as u32;
    let q: Vec<Vec3> = keep.iter().map(|&v| p[v as usize]).collect();
    let g: Vec<[u32; 3]> = f.iter().map(|t| t.map(remap)).collect();
    write_obj(&dir.join("holey.obj"), &q, &g);
    let path = dir.join("holey.obj");
    let open =
        |fill| open_sequence(path.to_str().unwrap(), &OpenOptions { fill_holes: fill, ..Default::default() }).unwrap();
    let plain = open(false);
    assert!(!analyze(plain.topology(), &plain.read_frame(0).unwrap()).is_sphere());
    let filled = open(true);
    let r = analyze(filled.topology(), &filled.read_frame(0).unwrap());
    assert!(r.is_sphere(), "{:?}", r.problems);
    assert_eq!(filled.topology().vertex_count, q.len() + 1);
}

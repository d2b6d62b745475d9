//! The seamless grid, the parameterization and resampling.
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

mod common;

use cgv::grid::Grid;
use cgv::mesh::{analyze, Topology};
use cgv::param::{cut::CONE_UV, parameterize, ParamOptions};
use cgv::resample::SampleMap;
use common::icosphere;

#[test]
fn seam_rule_is_symmetric_and_closes_the_grid() {
    for n in [4usize, 6, 16, 64] {
        let g = Grid::new(n).unwrap();
        let mut three = 0;
        for a in 0..g.len() as u32 {
            let s = g.stencil(a);
            assert!(!s.contains(&a), "n={n}: sample {a} is its own neighbour");
            for &b in &s {
                let back = g.stencil(b).iter().filter(|&&x| x == a).count();
                let fwd = s.iter().filter(|&&x| x == b).count();
                assert_eq!(back, fwd, "n={n}: {a} -> {b} is not mirrored");
            }
            match g.neighbours(a).len() {
                4 => {}
                3 => three += 1,
                k => panic!("n={n}: sample {a} has {k} distinct neighbours"),
            }
        }
        // Two samples beside each of the four cones have three distinct neighbours.
        assert_eq!(three, 8, "n={n}");
        // Gluing is idempotent and respects the half-turns.
        let ni = n as i64;
        for (a, b) in [(-1, 0), (ni, 3), (2, -1), (1, ni), (-1, -1), (ni, ni), (3 * ni + 1, -2 * ni - 3)] {
            let (i, j) = g.canonical(a, b);
            assert_eq!(g.canonical(i as i64, j as i64), (i, j));
        }
        assert_eq!(g.canonical(ni, 0), (n - 1, n - 1));
        assert_eq!(g.canonical(0, ni), (n - 1, n - 1));
        let t = g.topology();
        assert_eq!(t.faces.len(), 2 * n * n - 4, "n={n}");
    }
    assert!(Grid::new(7).is_err() && Grid::new(2).is_err() && Grid::new(1 << 20).is_err());
}

#[test]
fn sphere_maps_bijectively_and_its_grid_mesh_is_a_closed_manifold() {
    let (p, f) = icosphere(3);
    let topo = Topology { vertex_count: p.len(), faces: f.clone() };
    for opts in [ParamOptions { area_correction: 0.0, ..Default::default() }, ParamOptions::default()] {
        let param = parameterize(&topo, &p, &opts).unwrap();
        assert_eq!(param.distortion.flipped_faces, 0);
        // The face images tile one copy of the square: total area 4.
        let area: f64 = (0..f.len())
            .map(|i| {
                let q = param.face_uv(&f, i);
                0.5 * (q[1] - q[0]).perp_dot(q[2] - q[0])
            })
            .sum();
        assert!((area - 4.0).abs() < 1e-9, "area {area}");
        for (k, &c) in param.cones.iter().enumerate() {
            assert_eq!(param.uv[c as usize], CONE_UV[k]);
        }
        // The harmonic map is conformal onto the square only when the cones sit
        // in a "square" conformal configuration; farthest-point cones on a
        // sphere sit near a tetrahedron's, which leaves a nearly uniform
        // anisotropy (measured sigma1/sigma2 = 1.65 mean, 1.87 p95).
        assert!(param.conformal.conformal_mean < 1.8 && param.conformal.conformal_p95 < 2.0, "{:?}", param.conformal);

        let grid = Grid::new(32).unwrap();
        let map = SampleMap::build(grid, &f, &param).unwrap();
        let g = map.apply(&p);
        let gt = grid.topology();
        let report = analyze(&gt, &g);
        assert!(report.is_sphere(), "{:?}", report.problems);
        // Samples lie on the icosphere's triangles: within its chord error of the sphere.
        assert!(g.iter().all(|x| (x.length() - 1.0).abs() < 0.02));
    }
}

/// A map turned a quarter puts every grid sample where the grid turned a
/// quarter has it (the same points, each quad split the other way across
/// the surface), its cones on the sides they turn to; four turns give the
/// map back.
#[test]
fn a_map_turned_a_quarter_turns_its_grid() {
    let (p, f) = icosphere(3);
    let topo = Topology { vertex_count: p.len(), faces: f.clone() };
    let param = parameterize(&topo, &p, &ParamOptions::default()).unwrap();
    let turned = param.turned_quarter();
    for (k, &c) in turned.cones.iter().enumerate() {
        assert_eq!(turned.uv[c as usize], CONE_UV[k]);
    }
    let grid = Grid::new(32).unwrap();
    let g = SampleMap::build(grid, &f, &param).unwrap().apply(&p);
    let h = SampleMap::build(grid, &f, &turned).unwrap().apply(&p);
    let quarter = cgv::features::symmetry::apply_symmetry(grid, &g, cgv::features::symmetry::TURNS[1]);
    let off = h.iter().zip(&quarter).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
    assert!(off < 1e-5, "a sample {off} from the turned grid's");
    let back = turned.turned_quarter().turned_quarter().turned_quarter();
    let same = back.uv.iter().zip(&param.uv).all(|(a, b)| a.distance(*b) < 1e-12);
    assert!(same && back.cones == param.cones && back.cut_paths == param.cut_paths);
}

#[test]
fn default_motion_resamples_closely_and_deterministically() {
    let m = cgv::mesh::builtin::motion(8);
    let a = parameterize(&m.topology, &m.frames[0], &ParamOptions::default()).unwrap();
    let b = parameterize(&m.topology, &m.frames[0], &ParamOptions::default()).unwrap();
    assert_eq!(a.uv, b.uv, "parameterization is not deterministic");
    assert_eq!(a.distortion.flipped_faces, 0);
    let grid = Grid::new(64).unwrap();
    let map = SampleMap::build(grid, &m.topology.faces, &a).unwrap();
    let gt = grid.topology();
    for (i, frame) in m.frames.iter().enumerate() {
        let g = map.apply(frame);
        let d = cgv::metrics::surface::symmetric(frame, &m.topology.faces, &g, &gt.faces).unwrap();
        let diag = cgv::mesh::Bounds::of(frame).diagonal() as f64;
        // Measured 0.30 % RMS and 2.9 % max at N = 64; bounds leave a margin.
        assert!(d.rms / diag < 0.006 && d.max / diag < 0.05, "frame {i}: rms {} max {}", d.rms / diag, d.max / diag);
    }
}

#[test]
fn parameterize_rejects_surfaces_that_are_not_spheres() {
    let (p, mut f) = icosphere(1);
    f.pop();
    let e = parameterize(&Topology { vertex_count: p.len(), faces: f }, &p, &ParamOptions::default()).unwrap_err();
    assert!(matches!(e, cgv::Error::Argument(_)) && e.to_string().contains("boundary loop"), "{e}");
    let (p, f) = icosphere(1);
    let opts = ParamOptions { area_correction: 5.0, ..Default::default() };
    assert!(parameterize(&Topology { vertex_count: p.len(), faces: f }, &p, &opts).is_err());
}

/// An icosphere made to have many obtuse triangles: stretched `stretch`
/// times along x, and each vertex slid along the surface by a
/// deterministic jitter of up to `jitter` of the mean edge length.
fn obtuse_sphere(levels: usize, stretch: f32, jitter: f32) -> (Vec<glam::Vec3>, Vec<[u32; 3]>) {
    let (mut p, f) = icosphere(levels);
    let edge = 2.0 / (1 << levels) as f32;
    let mut seed = 12345u32;
    let mut rand = move || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        (seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
    };
    for x in &mut p {
        let d = glam::Vec3::new(rand(), rand(), rand()) * jitter * edge;
        *x = (*x + d - *x * x.dot(d)).normalize();
        x.x *= stretch;
    }
    (p, f)
}

/// Fraction of the mesh's edges whose cotangent weight is negative.
fn negative_cotangent_share(p: &[glam::Vec3], f: &[[u32; 3]]) -> f64 {
    let pos: Vec<glam::DVec3> = p.iter().map(|x| x.as_dvec3()).collect();
    let cot = cgv::param::orbifold::half_cotangents(f, &pos);
    let adj = cgv::mesh::Adjacency::build(f);
    let half = |h: usize| cot[h / 3][(h % 3 + 2) % 3];
    let (mut neg, mut all) = (0, 0);
    for h in 0..f.len() * 3 {
        let o = adj.opposite[h] as usize;
        if o > h {
            all += 1;
            neg += usize::from(half(h) + half(o) < 0.0);
        }
    }
    neg as f64 / all as f64
}

#[test]
fn meshes_with_many_obtuse_triangles_parameterize_without_folds() {
    for (stretch, jitter) in [(1.0, 0.45), (8.0, 0.0), (8.0, 0.45), (30.0, 0.3)] {
        let (p, f) = obtuse_sphere(4, stretch, jitter);
        let share = negative_cotangent_share(&p, &f);
        let topology = Topology { vertex_count: p.len(), faces: f };
        let report = analyze(&topology, &p);
        assert!(report.is_sphere(), "stretch {stretch}, jitter {jitter}: {:?}", report.problems);
        let result = cgv::geometry_image::GeometryImage::build(
            std::path::Path::new("obtuse"),
            &topology,
            &p,
            Grid::new(32).unwrap(),
            &ParamOptions::default(),
        );
        // Measured 20.8, 28.5, 25.4 and 28.6 % of the edges (and up to
        // 33 % on 41k-vertex versions, which map without a fold too).
        assert!(share > 0.2, "stretch {stretch}, jitter {jitter}: {:.1} % negative", 100.0 * share);
        let image = result.unwrap_or_else(|e| panic!("stretch {stretch}, jitter {jitter}: {e}"));
        assert_eq!(image.param.distortion.flipped_faces, 0);
    }
}

#[test]
fn input_vertices_are_rebuilt_from_the_grid_where_they_lie() {
    use cgv::resample::SourcePoints;
    // The default motion at N = 64: every input vertex, rebuilt from its
    // uncompressed grid frame, lies close to where it was (the grid mesh's
    // chord error), frame after frame through one map.
    let m = cgv::mesh::builtin::motion(8);
    let grid = Grid::new(64).unwrap();
    let param = parameterize(&m.topology, &m.frames[0], &ParamOptions::default()).unwrap();
    let map = SampleMap::build(grid, &m.topology.faces, &param).unwrap();
    let points = SourcePoints::build(grid, &param);
    assert_eq!(points.corners.len(), m.topology.vertex_count);
    for w in &points.bary {
        assert!(w.iter().all(|&x| (-1e-6..=1.0 + 1e-6).contains(&x)) && (w.iter().sum::<f32>() - 1.0).abs() < 1e-5);
    }
    for (i, frame) in m.frames.iter().enumerate() {
        let rebuilt = points.apply(&map.apply(frame));
        let (rms, max) = cgv::metrics::vertex_error(&rebuilt, frame);
        let diag = cgv::mesh::Bounds::of(frame).diagonal() as f64;
        // Measured 0.23-0.24 % RMS, 3.4-3.5 % max; bounds leave a margin.
        assert!(rms / diag < 0.005 && max / diag < 0.05, "frame {i}: rms {} max {}", rms / diag, max / diag);
    }
    // A grid that is a constant moves every rebuilt vertex to it.
    let c = glam::Vec3::new(1.0, 2.0, 3.0);
    assert!(points.apply(&vec![c; grid.len()]).iter().all(|p| p.distance(c) < 1e-5));
}

#[test]
fn a_plane_point_folds_to_the_sample_it_is_glued_to() {
    // The continuous fold agrees with the lattice's: every sample centre of
    // the extended lattice folds onto its canonical sample's centre.
    let g = Grid::new(16).unwrap();
    for b in -40..40i64 {
        for a in -40..40i64 {
            let (i, j) = g.canonical(a, b);
            let folded = Grid::canonical_uv(g.uv(a, b));
            assert!(folded.distance(g.uv(i as i64, j as i64)) < 1e-9, "({a}, {b}) -> {folded}");
        }
    }
}

/// The maps are ranked on a subsample of the grid's quads, but the floor the
/// encoder reports (`param.score`, and what `--grid auto` decides by) is
/// the kept map's symmetric RMS measured whole.
#[test]
fn the_kept_maps_score_is_its_whole_surface_distance() {
    let m = cgv::mesh::builtin::motion(2);
    let grid = Grid::new(64).unwrap();
    let image = cgv::geometry_image::GeometryImage::build(
        std::path::Path::new("walk"),
        &m.topology,
        &m.frames[0],
        grid,
        &ParamOptions::default(),
    )
    .unwrap();
    let score = image.param.score.expect("a scored map");
    let g = image.map.apply(&m.frames[0]);
    let d = cgv::metrics::surface::symmetric(&g, &image.map.surface_faces(), &m.frames[0], &m.topology.faces).unwrap();
    assert!((score - d.rms).abs() <= 1e-9 * d.rms, "score {score}, whole RMS {}", d.rms);
}

/// A racer scores only the pass counts the race compares at; the maps of
/// the counts it defers (and those before `score_from`) are scored when it
/// finishes, so the winner still keeps the best of all its maps.
#[test]
fn deferred_pass_counts_are_scored_when_the_passes_finish() {
    use cgv::param::area::AreaPasses;
    let m = cgv::mesh::builtin::motion(1);
    let opts = ParamOptions::default();
    let passes = AreaPasses::start_with(&m.topology, &m.frames[0], None, &opts).unwrap();
    let mut r = passes.score_from(10).defer(&[15]);
    let seen = std::cell::RefCell::new(Vec::new());
    // A score that falls with the passes, so that none gives up.
    let score = |p: &cgv::param::Parameterization, _: f64| {
        seen.borrow_mut().push(p.area_passes);
        Ok(1.0 / (1.0 + p.area_passes as f64))
    };
    r.advance(20, Some(&mut { score })).unwrap();
    assert_eq!(*seen.borrow(), [10, 20], "while racing");
    seen.borrow_mut().clear();
    let p = r.finish(Some(&mut { score })).unwrap();
    let at_finish = seen.borrow().clone();
    assert_eq!(&at_finish[at_finish.len() - 2..], [5, 15], "at the finish: {at_finish:?}");
    assert!(p.area_passes >= 20, "the best map is kept: {}", p.area_passes);
}

/// Deferred maps can be taken out, scored elsewhere (beside the passes) and
/// offered back; the best of all is kept.
#[test]
fn deferred_maps_scored_elsewhere_are_kept_when_best() {
    use cgv::param::area::AreaPasses;
    let m = cgv::mesh::builtin::motion(1);
    let passes = AreaPasses::start_with(&m.topology, &m.frames[0], None, &ParamOptions::default()).unwrap();
    let mut r = passes.score_from(10).defer(&[15]);
    let score = |p: &cgv::param::Parameterization, _: f64| Ok(1.0 / (1.0 + p.area_passes as f64));
    r.advance(20, Some(&mut { score })).unwrap();
    let deferred = r.take_deferred();
    assert_eq!(deferred.iter().map(|p| p.area_passes).collect::<Vec<_>>(), [5, 15]);
    // The 5-pass map, said to score below every other: it is the one kept.
    let five = deferred.into_iter().next().unwrap();
    r.offer(five, 0.0);
    let p = r.finish(Some(&mut { score })).unwrap();
    assert_eq!((p.area_passes, p.score), (5, Some(0.0)));
}

/// The race runs each placement's passes a few at a time, interleaved with
/// the others' (`advance_all`): passes run in segments must give the map
/// and the scores that running them at once gives.
#[test]
fn passes_run_in_segments_give_the_same_map_as_at_once() {
    use cgv::param::area::AreaPasses;
    let m = cgv::mesh::builtin::motion(1);
    let start = || AreaPasses::start_with(&m.topology, &m.frames[0], None, &ParamOptions::default()).unwrap();
    let score = |p: &cgv::param::Parameterization, _: f64| Ok(p.uv.iter().map(|q| q.x.abs()).sum::<f64>());
    let mut whole = start();
    whole.advance(45, Some(&mut { score })).unwrap();
    let mut pieces = start();
    for until in [7, 10, 20, 33, 45] {
        pieces.advance(until, Some(&mut { score })).unwrap();
        assert_eq!(pieces.passes(), until.min(whole.passes()), "stops where asked");
    }
    assert_eq!((pieces.passes(), pieces.stopped()), (whole.passes(), whole.stopped()));
    assert_eq!(pieces.score(), whole.score());
    let (a, b) = (whole.finish(None).unwrap(), pieces.finish(None).unwrap());
    assert_eq!((a.area_passes, &a.uv), (b.area_passes, &b.uv));
}

/// A motion on part of the grid's own mesh (a registered open capture,
/// its faces over holes left out) is its own geometry image, as the whole
/// grid mesh is: nothing mapped, each sample its own place; faces that are
/// not the grid's, or not in its order, are mapped as any mesh.
#[test]
fn part_of_the_grid_mesh_is_its_own_image() {
    use cgv::geometry_image::GeometryImage;
    use cgv::resample::sample_place;
    let grid = Grid::new(16).unwrap();
    let whole = grid.topology();
    // The grid on a bumpy sheet (the positions do not matter to the test).
    let positions: Vec<glam::Vec3> = (0..grid.len())
        .map(|s| glam::Vec3::new((s % 16) as f32, (s / 16) as f32, ((s * 5) % 3) as f32 * 0.1))
        .collect();
    let part: Vec<[u32; 3]> =
        whole.faces.iter().copied().enumerate().filter(|(k, _)| k % 7 != 3).map(|(_, f)| f).collect();
    let topology = Topology { vertex_count: grid.len(), faces: part.clone() };
    let label = std::path::Path::new("part");
    let image = GeometryImage::build(label, &topology, &positions, grid, &ParamOptions::default()).unwrap();
    let own: Vec<[u32; 2]> = (0..grid.len() as u32).map(|s| sample_place(grid, s)).collect();
    // Its surface (what the encoder's error figures measure) is the part.
    assert_eq!(image.surface_faces(&topology), part);
    assert_eq!((image.places, image.param.area_passes), (own, 0));
    let mut reordered = part;
    reordered.swap(0, 1);
    assert!(!is_own(&GeometryImage::build(
        label,
        &Topology { faces: reordered, ..topology },
        &positions,
        grid,
        &ParamOptions::default()
    )));
}

/// Whether an image (or the error building it) is a grid mesh's own.
fn is_own(image: &cgv::error::Result<cgv::geometry_image::GeometryImage>) -> bool {
    image.as_ref().is_ok_and(|i| i.param.corner_iso.is_empty() && i.param.score == Some(0.0))
}

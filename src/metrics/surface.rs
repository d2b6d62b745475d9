//! Symmetric point-to-surface distance between two triangle meshes, using
//! parry3d's BVH-accelerated point projection.
//!
//! Each one-sided distance from A to B integrates d(x, B)² over A's surface
//! with the three-point rule at barycentrics (2/3, 1/6, 1/6) (exact for
//! quadratics, which a chord's distance to a curved surface is), weighted by
//! area; its maximum is taken over those points and the vertices of A's
//! faces (a vertex no face uses is no part of the surface: a grid sample
//! on a face the carrier added, a loose vertex). The
//! symmetric figures are the larger of the two one-sided ones (as Metro does).

use super::lbvh::Lbvh;
use crate::error::{Error, Result};
use glam::Vec3;
use parry3d::query::PointQuery;
use parry3d::shape::{TriMesh, Triangle};

#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct SurfaceDistance {
    pub rms: f64,
    pub max: f64,
    pub rms_a_to_b: f64,
    pub rms_b_to_a: f64,
    pub max_a_to_b: f64,
    pub max_b_to_a: f64,
}

/// A triangle mesh prepared for distance queries.
pub struct Target {
    mesh: TriMesh,
}

impl Target {
    pub fn new(positions: &[Vec3], faces: &[[u32; 3]]) -> Result<Target> {
        let mesh = TriMesh::new(positions.to_vec(), faces.to_vec())
            .map_err(|e| Error::Numerical(format!("cannot build a distance query mesh: {e:?}")))?;
        Ok(Target { mesh })
    }

    pub fn distance(&self, p: Vec3) -> f64 {
        let proj = self.mesh.project_local_point(p, false);
        p.distance(proj.point) as f64
    }

    /// The point of this mesh nearest `p`.
    pub fn nearest_point(&self, p: Vec3) -> Vec3 {
        self.mesh.project_local_point(p, false).point
    }

    /// [`distance`](Self::distance), given a triangle of this mesh near
    /// `p`: its distance bounds the search, so the tree is walked only
    /// where something is as near (the same figure, found sooner).
    pub fn distance_near(&self, p: Vec3, near: [Vec3; 3]) -> f64 {
        let d = p.distance(Triangle::new(near[0], near[1], near[2]).project_local_point(p, false).point);
        // A little slack: the near triangle itself must fall within the bound.
        match self.mesh.project_local_point_with_max_dist(p, false, d * (1.0 + 1e-4) + 1e-12) {
            Some(proj) => p.distance(proj.point) as f64,
            None => self.distance(p),
        }
    }
}

/// What [`face_rms`] measures against: a mesh's distance from a point.
trait Nearest: Sync {
    fn distance(&self, p: Vec3) -> f64;

    /// The same, given a triangle of the mesh near `p` (a hint that may
    /// speed the search).
    fn distance_near(&self, p: Vec3, _near: [Vec3; 3]) -> f64 {
        self.distance(p)
    }
}

impl Nearest for Target {
    fn distance(&self, p: Vec3) -> f64 {
        Target::distance(self, p)
    }

    fn distance_near(&self, p: Vec3, near: [Vec3; 3]) -> f64 {
        Target::distance_near(self, p, near)
    }
}

impl Nearest for Lbvh {
    fn distance(&self, p: Vec3) -> f64 {
        Lbvh::distance(self, p)
    }
}

/// (RMS, max) of the distance from surface A to `target`.
pub fn one_sided(positions: &[Vec3], faces: &[[u32; 3]], target: &Target) -> (f64, f64) {
    use rayon::prelude::*;
    let (rms, max) = face_rms(positions, faces, target, &|_| None, (f64::INFINITY, 1)).unwrap_or((f64::INFINITY, 0.0));
    let used = crate::mesh::topology::used_by(faces, positions.len());
    let max = (positions, &used[..])
        .into_par_iter()
        .filter(|(_, &u)| u)
        .map(|(p, _)| target.distance(*p))
        .reduce(|| max, f64::max);
    (rms, max)
}

/// (RMS, max) of the distance from A's faces' quadrature points to
/// `target` (each face's `near` triangles of it, one for the point by each
/// corner, if any, speeding the search), over every `every`-th pair of
/// faces (1: all of them), or none once the RMS is certainly above
/// `above`: the squares summed over some of the faces, over all of A's
/// area, bound it from below. Faces are split among threads (rayon); the sums are combined in
/// a fixed order, so the result does not depend on the thread count beyond
/// rounding.
fn face_rms(
    positions: &[Vec3],
    faces: &[[u32; 3]],
    target: &dyn Nearest,
    near: &(dyn Fn(usize) -> Option<[[Vec3; 3]; 3]> + Sync),
    (above, every): (f64, usize),
) -> Option<(f64, f64)> {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
    const CHUNK: usize = 4096;
    let weight = |f: &[u32; 3]| {
        let [a, b, c] = f.map(|i| positions[i as usize]);
        0.5 * (b - a).cross(c - a).length() as f64 / 3.0
    };
    // Only every `every`-th pair of faces (a grid mesh's quad) is measured.
    let picked = |f: usize| (f / 2) % every.max(1) == 0;
    // The squares the measured area may sum to (a hair more, so rounding
    // cannot stop a map that is exactly at the bound; no pass over the
    // faces without a bound), and the squares so far, shared by the threads.
    let limit = if above.is_finite() {
        let area: f64 = faces.iter().enumerate().filter(|(f, _)| picked(*f)).map(|(_, f)| weight(f)).sum();
        above * above * 3.0 * area * (1.0 + 1e-9)
    } else {
        f64::INFINITY
    };
    let (so_far, over) = (AtomicU64::new(0f64.to_bits()), AtomicBool::new(false));
    let parts: Option<Vec<(f64, f64, f64)>> = faces
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            if over.load(Relaxed) {
                return None;
            }
            let (mut sum, mut area, mut max) = (0.0, 0.0, 0.0f64);
            for (k, f) in chunk.iter().enumerate() {
                if !picked(c * CHUNK + k) {
                    continue;
                }
                let hint = near(c * CHUNK + k);
                let [a, b, c] = f.map(|i| positions[i as usize]);
                let w = weight(f);
                for (k, (x, y, z)) in [(a, b, c), (b, c, a), (c, a, b)].into_iter().enumerate() {
                    let p = x * (2.0 / 3.0) + y * (1.0 / 6.0) + z * (1.0 / 6.0);
                    let d = match hint {
                        Some(t) => target.distance_near(p, t[k]),
                        None => target.distance(p),
                    };
                    sum += w * d * d;
                    area += w;
                    max = max.max(d);
                }
            }
            let added = |s: u64| Some((f64::from_bits(s) + sum).to_bits());
            let before = so_far.fetch_update(Relaxed, Relaxed, added).unwrap_or_default();
            if f64::from_bits(before) + sum > limit {
                over.store(true, Relaxed);
            }
            Some((sum, area, max))
        })
        .collect();
    let (mut sum, mut area, mut max) = (0.0, 0.0, 0.0f64);
    for (s, a, m) in parts? {
        sum += s;
        area += a;
        max = max.max(m);
    }
    Some(((sum / area.max(f64::MIN_POSITIVE)).sqrt(), max))
}

/// [`symmetric_to`]'s RMS alone, for ranking many maps of one surface:
/// the same figure, without the vertices' queries that only its maxima use
/// (a seventh of them at N = 256 on samba), or infinity once it is
/// certainly above `above` (a map that cannot be kept is not measured
/// through). A is a new surface each time, so its query tree is one that
/// builds fast ([`Lbvh`]). `a_on_b` may name, for each of A's faces, a
/// triangle of B near each of its corners, which speeds its queries up
/// ([`Target::distance_near`]) without changing the figure. With `every`
/// above 1, each side is measured on every `every`-th pair of its faces
/// only (an estimate: a grid mesh's faces come in pairs, one quad each).
pub fn symmetric_rms_to(
    (a, a_faces): (&[Vec3], &[[u32; 3]]),
    a_on_b: &(dyn Fn(usize) -> Option<[[Vec3; 3]; 3]> + Sync),
    (b, b_faces): (&[Vec3], &[[u32; 3]]),
    b_target: &Target,
    (above, every): (f64, usize),
) -> Result<f64> {
    // A's side first: a map that cannot be kept is often known from it
    // alone, and then needs no query tree.
    let Some((a_to_b, _)) = face_rms(a, a_faces, b_target, a_on_b, (above, every)) else { return Ok(f64::INFINITY) };
    let ta = Lbvh::new(a, a_faces)?;
    let Some((b_to_a, _)) = face_rms(b, b_faces, &ta, &|_| None, (above, every)) else { return Ok(f64::INFINITY) };
    Ok(a_to_b.max(b_to_a))
}

/// [`symmetric`]'s RMS alone, with both query trees of the kind that
/// builds fast ([`Lbvh`]) and no vertex queries (only the maxima use
/// them): for a pair of surfaces measured once, as a capture frame's grid
/// against the frame. The same figure as [`symmetric`]'s `rms`.
pub fn symmetric_rms(a: &[Vec3], a_faces: &[[u32; 3]], b: &[Vec3], b_faces: &[[u32; 3]]) -> Result<f64> {
    let all = (f64::INFINITY, 1);
    let a_to_b = face_rms(a, a_faces, &Lbvh::new(b, b_faces)?, &|_| None, all).map_or(f64::INFINITY, |d| d.0);
    let b_to_a = face_rms(b, b_faces, &Lbvh::new(a, a_faces)?, &|_| None, all).map_or(f64::INFINITY, |d| d.0);
    Ok(a_to_b.max(b_to_a))
}

/// Symmetric distance between surfaces A and B.
pub fn symmetric(a: &[Vec3], a_faces: &[[u32; 3]], b: &[Vec3], b_faces: &[[u32; 3]]) -> Result<SurfaceDistance> {
    symmetric_to(a, a_faces, b, b_faces, &Target::new(b, b_faces)?)
}

/// [`symmetric`] with B's query mesh already built (`b_target`), for
/// measuring many surfaces against one.
pub fn symmetric_to(
    a: &[Vec3],
    a_faces: &[[u32; 3]],
    b: &[Vec3],
    b_faces: &[[u32; 3]],
    b_target: &Target,
) -> Result<SurfaceDistance> {
    let ta = Target::new(a, a_faces)?;
    let tb = b_target;
    let (rms_a_to_b, max_a_to_b) = one_sided(a, a_faces, tb);
    let (rms_b_to_a, max_b_to_a) = one_sided(b, b_faces, &ta);
    Ok(SurfaceDistance {
        rms: rms_a_to_b.max(rms_b_to_a),
        max: max_a_to_b.max(max_b_to_a),
        rms_a_to_b,
        rms_b_to_a,
        max_a_to_b,
        max_b_to_a,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let p = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)].map(|(x, y)| Vec3::new(x, y, z));
        (p.to_vec(), vec![[0, 1, 2], [0, 2, 3]])
    }

    #[test]
    fn the_maximum_is_over_the_surface_not_over_unused_vertices() {
        let (a, fa) = square(0.0);
        let (mut b, fb) = square(0.1);
        let d = symmetric(&a, &fa, &b, &fb).unwrap();
        assert!((d.max - 0.1).abs() < 1e-6 && (d.rms - 0.1).abs() < 1e-6, "{d:?}");
        assert_eq!(symmetric_rms(&a, &fa, &b, &fb).unwrap(), d.rms);
        // A vertex no face uses (a sample on a filler face, a loose vertex)
        // far away is not part of B's surface.
        b.push(Vec3::new(0.5, 0.5, 10.0));
        let e = symmetric(&a, &fa, &b, &fb).unwrap();
        assert!((e.max - d.max).abs() < 1e-9, "{e:?}");
        // The same vertex in a face is.
        let fc = [fb.clone(), vec![[0, 1, 4]]].concat();
        assert!(symmetric(&a, &fa, &b, &fc).unwrap().max > 5.0);
    }

    /// A height field z = f(x, y) over [0, 1]², `n` x `m` quads.
    fn field(n: usize, m: usize, f: impl Fn(f32, f32) -> f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for j in 0..=m {
            for i in 0..=n {
                let (x, y) = (i as f32 / n as f32, j as f32 / m as f32);
                p.push(Vec3::new(x, y, f(x, y)));
            }
        }
        let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let faces = (0..m)
            .flat_map(|j| {
                (0..n).flat_map(move |i| {
                    [[at(i, j), at(i + 1, j), at(i + 1, j + 1)], [at(i, j), at(i + 1, j + 1), at(i, j + 1)]]
                })
            })
            .collect();
        (p, faces)
    }

    #[test]
    fn the_rms_alone_is_the_symmetric_distance_rms() {
        // Two triangulations of nearby bumps: every query lands somewhere
        // different, so the two kinds of query tree are compared on many.
        let (a, fa) = field(23, 17, |x, y| 0.2 * (6.0 * x).sin() * (5.0 * y).cos());
        let (b, fb) = field(31, 29, |x, y| 0.2 * (6.0 * x + 0.1).sin() * (5.0 * y).cos() + 0.01);
        let d = symmetric(&a, &fa, &b, &fb).unwrap();
        assert!(d.rms > 0.01 && d.rms_a_to_b != d.rms_b_to_a, "{d:?}");
        let rms = symmetric_rms(&a, &fa, &b, &fb).unwrap();
        assert!((rms - d.rms).abs() <= 1e-12 * d.rms, "{rms} against {}", d.rms);
        let to = symmetric_rms_to((&a, &fa), &|_| None, (&b, &fb), &Target::new(&b, &fb).unwrap(), (f64::INFINITY, 1));
        assert!((to.unwrap() - d.rms).abs() <= 1e-12 * d.rms);
    }
}

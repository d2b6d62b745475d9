//! Meshes that stress a parameterization (tests/fold_free.rs): slivers,
//! caps and needles, uneven sampling, long thin parts.

use glam::Vec3;

/// Positions and faces.
pub type Mesh = (Vec<Vec3>, Vec<[u32; 3]>);

/// Each face of an icosphere split at a point just inside its first edge:
/// a cap (an angle near 180°) and two needles per face.
pub fn capped_sphere(levels: usize, inset: f32) -> Mesh {
    let (mut p, f) = super::icosphere(levels);
    let mut faces = Vec::with_capacity(3 * f.len());
    for [a, b, c] in f {
        let (pa, pb, pc) = (p[a as usize], p[b as usize], p[c as usize]);
        p.push((pa + pb) * 0.5 * (1.0 - inset) + pc * inset);
        let m = (p.len() - 1) as u32;
        faces.extend([[a, m, c], [m, b, c], [a, b, m]]);
    }
    (p, faces)
}

/// A latitude-longitude sphere of `rings` rings of `segments` vertices,
/// the rings spaced geometrically towards the north pole (`ratio` between
/// the last and first spacing): needles at the poles, a dense cap beside a
/// sparse one.
pub fn uneven_sphere(rings: usize, segments: usize, ratio: f32) -> Mesh {
    let mut p = vec![Vec3::Y, -Vec3::Y];
    let q = ratio.powf(1.0 / rings as f32);
    let total: f32 = (0..=rings).map(|k| q.powi(k as i32)).sum();
    let mut theta = 0.0;
    for r in 0..rings {
        theta += std::f32::consts::PI * q.powi(r as i32) / total;
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            p.push(Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()));
        }
    }
    let at = |r: usize, s: usize| (2 + r * segments + s % segments) as u32;
    let mut f = Vec::new();
    for s in 0..segments {
        f.push([0, at(0, s + 1), at(0, s)]);
        f.push([1, at(rings - 1, s), at(rings - 1, s + 1)]);
        for r in 0..rings - 1 {
            f.push([at(r, s), at(r, s + 1), at(r + 1, s + 1)]);
            f.push([at(r, s), at(r + 1, s + 1), at(r + 1, s)]);
        }
    }
    (p, f)
}

/// A closed capsule: a tube of radius `r` and length `len` along x,
/// `around` vertices a ring, capped by a fan at each end.
pub fn capsule(r: f32, len: f32, around: usize, along: usize, at: Vec3) -> Mesh {
    let mut p = vec![at + Vec3::new(-r, 0.0, 0.0), at + Vec3::new(len + r, 0.0, 0.0)];
    for j in 0..=along {
        for i in 0..around {
            let a = std::f32::consts::TAU * i as f32 / around as f32;
            p.push(at + Vec3::new(len * j as f32 / along as f32, r * a.cos(), r * a.sin()));
        }
    }
    let v = |i: usize, j: usize| (2 + j * around + i % around) as u32;
    let mut f = Vec::new();
    for i in 0..around {
        f.push([0, v(i, 0), v(i + 1, 0)]);
        f.push([1, v(i + 1, along), v(i, along)]);
        for j in 0..along {
            f.push([v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
            f.push([v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
        }
    }
    (p, f)
}

/// A body (an icosphere) with `limbs` long thin capsules welded to it at
/// the icosphere's first vertices: an elephant's trunk and legs, which the
/// conformal map shrinks exponentially along their length.
pub fn body_with_limbs(limbs: usize, aspect: f32) -> Mesh {
    let (p, f) = super::icosphere(3);
    let mut parts = vec![(p.clone(), f)];
    // Limbs as separate closed parts touching the body: the carrier joins
    // them by tubes, the thinnest necks a user's mesh can have.
    for k in 0..limbs {
        let dir = p[k * 7 % p.len()];
        let r = 0.08;
        let (lp, lf) = capsule(r, aspect * r, 8, 48, Vec3::ZERO);
        let rot = glam::Quat::from_rotation_arc(Vec3::X, dir);
        parts.push((lp.iter().map(|&q| rot * q + dir).collect(), lf));
    }
    super::parts(&parts)
}

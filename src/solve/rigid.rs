//! The rigid motion that best maps one point set onto another, by Horn's
//! closed-form quaternion method (B. K. P. Horn, "Closed-form solution of
//! absolute orientation using unit quaternions", JOSA A 4(4), 1987): the
//! rotation is the eigenvector of the largest eigenvalue of a symmetric 4x4
//! matrix built from the cross-covariance, found here by Jacobi rotations.

use glam::{DMat3, DQuat, DVec3, Vec3};

/// A rotation followed by a translation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rigid {
    pub rotation: DQuat,
    pub translation: DVec3,
}

impl Rigid {
    pub const IDENTITY: Rigid = Rigid { rotation: DQuat::IDENTITY, translation: DVec3::ZERO };

    pub fn apply(&self, p: Vec3) -> Vec3 {
        (self.rotation * p.as_dvec3() + self.translation).as_vec3()
    }
}

fn jacobi_eigen4(mut a: [[f64; 4]; 4]) -> ([f64; 4], [[f64; 4]; 4]) {
    let mut v = [[0.0; 4]; 4];
    for (i, row) in v.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for _ in 0..64 {
        let mut off = 0.0;
        for i in 0..4 {
            for j in i + 1..4 {
                off += a[i][j] * a[i][j];
            }
        }
        if off < 1e-30 {
            break;
        }
        for p in 0..4 {
            for q in p + 1..4 {
                if a[p][q].abs() < 1e-300 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..4 {
                    let (akp, akq) = (a[k][p], a[k][q]);
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for k in 0..4 {
                    let (apk, aqk) = (a[p][k], a[q][k]);
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for row in v.iter_mut() {
                    let (vkp, vkq) = (row[p], row[q]);
                    row[p] = c * vkp - s * vkq;
                    row[q] = s * vkp + c * vkq;
                }
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2], a[3][3]], v)
}

/// The rigid motion minimizing Σ |R from[i] + t − to[i]|².
pub fn fit(from: &[Vec3], to: &[Vec3]) -> Rigid {
    let n = from.len().min(to.len());
    if n == 0 {
        return Rigid::IDENTITY;
    }
    let cf = from[..n].iter().map(|p| p.as_dvec3()).sum::<DVec3>() / n as f64;
    let ct = to[..n].iter().map(|p| p.as_dvec3()).sum::<DVec3>() / n as f64;
    let mut s = DMat3::ZERO;
    for i in 0..n {
        let (a, b) = (from[i].as_dvec3() - cf, to[i].as_dvec3() - ct);
        // s[r][c] = Σ a_r b_c
        s += DMat3::from_cols(a * b.x, a * b.y, a * b.z);
    }
    let m = |r: usize, c: usize| s.col(c)[r];
    let (sxx, sxy, sxz, syx, syy, syz, szx, szy, szz) =
        (m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2));
    let nm = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ];
    let (vals, vecs) = jacobi_eigen4(nm);
    let k = (0..4).max_by(|&a, &b| vals[a].total_cmp(&vals[b])).unwrap_or(0);
    let q = DQuat::from_xyzw(vecs[1][k], vecs[2][k], vecs[3][k], vecs[0][k]).normalize();
    let rotation = if q.is_finite() { q } else { DQuat::IDENTITY };
    Rigid { rotation, translation: ct - rotation * cf }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_known_motion() {
        let pts =
            [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 0.0, 3.0)];
        let r = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 2.0);
        let t = DVec3::new(0.5, -1.0, 2.0);
        let moved: Vec<Vec3> = pts.iter().map(|p| (r * p.as_dvec3() + t).as_vec3()).collect();
        let fitted = fit(&pts, &moved);
        for (p, q) in pts.iter().zip(&moved) {
            assert!(fitted.apply(*p).distance(*q) < 1e-5);
        }
    }
}

//! The weighted rigid fit of SSDR's transform update (Le and Deng 2012,
//! section 4.2): the rotation R and translation T minimizing
//! `Σ_v ‖q_v − w_v (R r_v + T)‖²`. T is eliminated in closed form
//! (T = q̄ − R p̄ with p̄ = Σ w² r / Σ w², q̄ = Σ w q / Σ w²), which leaves the
//! orthogonal Procrustes problem between w_v (r_v − p̄) and q_v − w_v q̄,
//! solved by a 3 x 3 SVD (Kabsch 1976), reflections excluded.

use glam::{DMat3, DVec3, Mat3, Vec3};

/// A bone's transform in a frame: x ↦ M x + T, M a rotation for rigid
/// bones ([`fit`]), any linear map for affine ones ([`fit_affine`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoneTransform {
    pub linear: Mat3,
    pub translation: Vec3,
}

impl Default for BoneTransform {
    fn default() -> Self {
        BoneTransform { linear: Mat3::IDENTITY, translation: Vec3::ZERO }
    }
}

impl BoneTransform {
    pub fn apply(&self, x: Vec3) -> Vec3 {
        self.linear * x + self.translation
    }
}

/// The centres that eliminate T from both fits: p̄ = Σ w² r / Σ w² and
/// q̄ = Σ w q / Σ w² (none where the weights are all zero or a sum is not
/// finite).
fn centres(points: impl Iterator<Item = (Vec3, Vec3, f32)>) -> Option<(DVec3, DVec3)> {
    let (mut w2, mut wr, mut wq) = (0.0, DVec3::ZERO, DVec3::ZERO);
    for (r, q, w) in points {
        let w = w as f64;
        w2 += w * w;
        wr += w * w * r.as_dvec3();
        wq += w * q.as_dvec3();
    }
    (w2 > 1e-300 && wr.is_finite() && wq.is_finite()).then(|| (wr / w2, wq / w2))
}

/// The rigid transform minimizing `Σ ‖q − w (R r + T)‖²` over the triples
/// `(r, q, w)`; the identity where the weights are all zero.
pub fn fit(points: impl Iterator<Item = (Vec3, Vec3, f32)> + Clone) -> BoneTransform {
    let Some((p_bar, q_bar)) = centres(points.clone()) else { return BoneTransform::default() };
    // H = Σ (q − w q̄)(w (r − p̄))ᵀ: R maximizes tr(Rᵀ H).
    let mut h = DMat3::ZERO;
    for (r, q, w) in points {
        let w = w as f64;
        let x = w * (r.as_dvec3() - p_bar);
        let y = q.as_dvec3() - w * q_bar;
        h += DMat3::from_cols(y * x.x, y * x.y, y * x.z);
    }
    let rotation = nearest_rotation(h);
    let translation = q_bar - rotation * p_bar;
    BoneTransform { linear: rotation.as_mat3(), translation: translation.as_vec3() }
}

/// The affine transform (any 3 x 3 M, and T) minimizing
/// `Σ ‖q − w (M r + T)‖² + μ ‖M − R‖²`, R the rigid fit's rotation: T is
/// eliminated as in [`fit`], then M = (H + μ R)(S + μ I)⁻¹ with S the
/// points' weighted scatter. μ (a thousandth of S's mean eigenvalue) keeps
/// a bone whose points lie near a plane or a line from folding space; M is
/// the rigid fit where the system is singular anyway.
pub fn fit_affine(points: impl Iterator<Item = (Vec3, Vec3, f32)> + Clone) -> BoneTransform {
    let Some((p_bar, q_bar)) = centres(points.clone()) else { return BoneTransform::default() };
    let (mut h, mut s) = (DMat3::ZERO, DMat3::ZERO);
    for (r, q, w) in points {
        let w = w as f64;
        let x = w * (r.as_dvec3() - p_bar);
        let y = q.as_dvec3() - w * q_bar;
        h += DMat3::from_cols(y * x.x, y * x.y, y * x.z);
        s += DMat3::from_cols(x * x.x, x * x.y, x * x.z);
    }
    let rotation = nearest_rotation(h);
    let mu = 1e-3 * (s.x_axis.x + s.y_axis.y + s.z_axis.z) / 3.0;
    let a = s + DMat3::from_diagonal(DVec3::splat(mu));
    let m = if a.determinant().abs() > 1e-300 { (h + rotation * mu) * a.inverse() } else { rotation };
    let m = if m.is_finite() { m } else { rotation };
    let translation = q_bar - m * p_bar;
    BoneTransform { linear: m.as_mat3(), translation: translation.as_vec3() }
}

/// The rotation R maximizing tr(Rᵀ H): U diag(1, 1, det(U Vᵀ)) Vᵀ of H's SVD.
fn nearest_rotation(h: DMat3) -> DMat3 {
    let m = faer::Mat::<f64>::from_fn(3, 3, |i, j| h.col(j)[i]);
    let Ok(svd) = m.svd() else { return DMat3::IDENTITY };
    let (u, v) = (svd.U(), svd.V());
    let to = |a: faer::MatRef<'_, f64>| DMat3::from_cols_array(&std::array::from_fn(|k| a[(k % 3, k / 3)]));
    let (u, v) = (to(u), to(v));
    let d = (u * v.transpose()).determinant().signum();
    u * DMat3::from_diagonal(DVec3::new(1.0, 1.0, d)) * v.transpose()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn a_weighted_rigid_motion_is_recovered() {
        let rot = Mat3::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.9);
        let t = Vec3::new(0.3, -1.0, 2.0);
        let pts: Vec<(Vec3, Vec3, f32)> = (0..20)
            .map(|i| {
                let r = Vec3::new((i as f32 * 0.7).sin(), (i as f32 * 1.3).cos(), i as f32 * 0.1);
                let w = 0.2 + 0.04 * i as f32;
                (r, w * (rot * r + t), w)
            })
            .collect();
        let m = fit(pts.iter().copied());
        assert!((m.linear - rot).abs_diff_eq(Mat3::ZERO, 1e-4), "{:?}", m.linear);
        assert!(m.translation.abs_diff_eq(t, 1e-4), "{:?}", m.translation);
        // A mirror image is not a rotation: the fit stays proper.
        let mirrored: Vec<(Vec3, Vec3, f32)> =
            pts.iter().map(|&(r, q, w)| (r, q * Vec3::new(-1.0, 1.0, 1.0), w)).collect();
        assert!(fit(mirrored.into_iter()).linear.determinant() > 0.99);
    }

    #[test]
    fn a_weighted_affine_map_is_recovered_and_a_flat_bone_stays_put() {
        let m = Mat3::from_cols(Vec3::new(1.2, 0.1, 0.0), Vec3::new(-0.2, 0.9, 0.3), Vec3::new(0.0, 0.1, 1.1));
        let t = Vec3::new(0.3, -1.0, 2.0);
        let pts: Vec<(Vec3, Vec3, f32)> = (0..30)
            .map(|i| {
                let r = Vec3::new((i as f32 * 0.7).sin(), (i as f32 * 1.3).cos(), (i as f32 * 0.37).sin());
                let w = 0.2 + 0.03 * i as f32;
                (r, w * (m * r + t), w)
            })
            .collect();
        let a = fit_affine(pts.iter().copied());
        // μ pulls M a thousandth of the way towards the rotation.
        assert!((a.linear - m).abs_diff_eq(Mat3::ZERO, 5e-3), "{:?}", a.linear);
        assert!(a.translation.abs_diff_eq(t, 5e-3), "{:?}", a.translation);
        // Points on a line: the affine part across it is the rotation's, finite.
        let line: Vec<(Vec3, Vec3, f32)> = (0..10).map(|i| (Vec3::X * i as f32, Vec3::X * i as f32, 1.0)).collect();
        let a = fit_affine(line.into_iter());
        assert!(a.linear.is_finite() && a.linear.abs_diff_eq(Mat3::IDENTITY, 1e-3), "{:?}", a.linear);
    }
}

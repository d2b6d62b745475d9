//! What a skinning misses, as a few morph targets: the residual of every
//! frame, taken back to the bind pose through each vertex's blended bone
//! matrix, reduced to its `k` principal components (the skinned-PCA split
//! of dynamic-mesh compression: MPEG-4 FAMC codes the residual of a
//! skinning, Mamou, Zaharia and Prêteux 2009; Alexa and Müller 2000 code a
//! motion by PCA). A glTF plays it as the same mesh's morph targets, which
//! three.js and every engine apply before the skin:
//!
//! x_t(v) = Σ_b w_vb M_bt (r_v + Σ_k c_tk B_k(v)),
//!
//! exact for linear blend skinning, since the blend is linear in the
//! point. The components are the eigenvectors of the frames' Gram matrix
//! (T x T, T the frames), so the work grows with the frames, not the
//! vertices squared.

use super::Skinning;
use crate::error::{Error, Result};
use glam::{Mat3, Vec3};

/// Morph targets of a skinning's residual and their weights every frame.
#[derive(Debug, Clone, PartialEq)]
pub struct MorphTargets {
    /// `targets[k][v]`: target k's displacement of vertex v in the bind pose.
    pub targets: Vec<Vec<Vec3>>,
    /// `weights[t][k]`: target k's weight in frame t.
    pub weights: Vec<Vec<f32>>,
}

impl MorphTargets {
    /// Frame `t` of `skin` with these targets applied before the skin.
    pub fn frame(&self, skin: &Skinning, t: usize) -> Vec<Vec3> {
        let morphed: Vec<Vec3> = (0..skin.rest.len())
            .map(|v| skin.rest[v] + self.targets.iter().zip(&self.weights[t]).map(|(b, &c)| c * b[v]).sum::<Vec3>())
            .collect();
        let m = &skin.transforms[t];
        morphed
            .iter()
            .zip(&skin.influences)
            .map(|(&r, inf)| inf.iter().map(|&(b, w)| w * m[b as usize].apply(r)).sum())
            .collect()
    }
}

/// Each vertex's blended bone matrix Σ_b w_vb M_bt in frame `t`.
fn blended(skin: &Skinning, t: usize) -> Vec<Mat3> {
    let m = &skin.transforms[t];
    skin.influences.iter().map(|inf| inf.iter().map(|&(b, w)| m[b as usize].linear * w).sum()).collect()
}

/// The `k` principal components of `skin`'s residual against `frames` (the
/// frames it was fitted to), in the bind pose.
pub fn fit(skin: &Skinning, frames: &[Vec<Vec3>], k: usize) -> Result<MorphTargets> {
    let (t_count, nv) = (frames.len(), skin.rest.len());
    if t_count != skin.frames() || frames.iter().any(|f| f.len() != nv) {
        return Err(Error::Argument("morph targets of frames the skinning was not fitted to".into()));
    }
    if k == 0 || k > t_count {
        return Err(Error::Argument(format!("{k} morph targets of {t_count} frames: 1 to the frame count")));
    }
    // Each frame's residual in the bind pose (a blend that is singular, as
    // two opposed bones can make it, leaves that vertex's residual out).
    let residual: Vec<Vec<f32>> = (0..t_count)
        .map(|t| {
            let (skinned, a) = (skin.frame(t), blended(skin, t));
            (0..nv)
                .flat_map(|v| {
                    let inv = a[v].inverse();
                    let d = if inv.is_finite() { inv * (frames[t][v] - skinned[v]) } else { Vec3::ZERO };
                    d.to_array()
                })
                .collect()
        })
        .collect();
    let gram = faer::Mat::<f64>::from_fn(t_count, t_count, |i, j| {
        residual[i].iter().zip(&residual[j]).map(|(&a, &b)| f64::from(a) * f64::from(b)).sum()
    });
    let svd = gram.svd().map_err(|e| Error::Numerical(format!("the residual's components: {e:?}")))?;
    let (u, s) = (svd.U(), svd.S().column_vector());
    let mut targets = Vec::with_capacity(k);
    let mut weights = vec![Vec::with_capacity(k); t_count];
    for c in 0..k {
        let sigma = s[c].max(0.0).sqrt();
        // B_c = Dᵀ u_c / σ_c (unit length), c_tc = σ_c u_tc.
        let mut b = vec![0.0f64; 3 * nv];
        for (t, r) in residual.iter().enumerate() {
            let w = u[(t, c)] / sigma.max(f64::MIN_POSITIVE);
            b.iter_mut().zip(r).for_each(|(x, &y)| *x += w * f64::from(y));
        }
        targets.push(b.chunks_exact(3).map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32)).collect());
        for (t, w) in weights.iter_mut().enumerate() {
            w.push((sigma * u[(t, c)]) as f32);
        }
    }
    Ok(MorphTargets { targets, weights })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::skin::BoneTransform;

    /// One bone turning a strip of points that also bulges in one fixed
    /// shape: the bulge is the residual, and one target gives it back.
    #[test]
    fn a_residual_of_one_shape_is_one_target() {
        let rest: Vec<Vec3> = (0..20).map(|i| Vec3::new(i as f32 * 0.1, (i % 3) as f32 * 0.05, 0.0)).collect();
        let bulge: Vec<Vec3> = (0..20).map(|i| Vec3::Z * ((i as f32 * 0.3).sin() * 0.02)).collect();
        let transforms: Vec<Vec<BoneTransform>> = (0..8)
            .map(|t| {
                let linear = Mat3::from_rotation_y(t as f32 * 0.1);
                vec![BoneTransform { linear, translation: Vec3::new(0.0, t as f32 * 0.01, 0.0) }]
            })
            .collect();
        let skin = Skinning {
            rest: rest.clone(),
            bones: 1,
            influences: vec![[(0, 1.0), (0, 0.0), (0, 0.0), (0, 0.0)]; 20],
            transforms,
        };
        let frames: Vec<Vec<Vec3>> = (0..8)
            .map(|t| {
                let s = (t as f32 * 0.7).cos();
                (0..20).map(|v| skin.transforms[t][0].apply(rest[v] + s * bulge[v])).collect()
            })
            .collect();
        let morph = fit(&skin, &frames, 1).unwrap();
        for (t, f) in frames.iter().enumerate() {
            let worst = morph.frame(&skin, t).iter().zip(f).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
            assert!(worst < 1e-5, "frame {t}: {worst}");
        }
        assert!(fit(&skin, &frames, 9).is_err() && fit(&skin, &frames, 0).is_err());
        assert!(fit(&skin, &frames[..3], 1).is_err());
    }
}

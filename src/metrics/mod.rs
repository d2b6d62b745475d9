//! Error measures between surfaces and between sequences.

#[cfg(not(target_arch = "wasm32"))]
mod lbvh;
#[cfg(not(target_arch = "wasm32"))]
pub mod surface;

use glam::Vec3;

/// Root-mean-square and maximum distance between corresponding points.
pub fn vertex_error(a: &[Vec3], b: &[Vec3]) -> (f64, f64) {
    assert_eq!(a.len(), b.len(), "vertex_error needs corresponding points");
    let mut sum = 0.0;
    let mut max: f64 = 0.0;
    for (p, q) in a.iter().zip(b) {
        let d = p.distance(*q) as f64;
        sum += d * d;
        max = max.max(d);
    }
    ((sum / a.len().max(1) as f64).sqrt(), max)
}

/// The paper's smoothness metric, before normalization:
/// sqrt(mean over grid samples of |Δv − Δv'|²), Δ the uniform grid
/// Laplacian, v the uncompressed grid and v' the decoded one. A rigid
/// translation of the whole grid gives 0; the paper's Table 2 divides it by
/// the bounding-box diagonal and reports units of 1e-4.
pub fn smoothness(st: &crate::grid::stencil::Stencils, v: &[Vec3], decoded: &[Vec3]) -> f64 {
    assert_eq!(v.len(), decoded.len(), "smoothness needs two grids of one size");
    let n = v.len().max(1);
    let sum: f64 = (0..v.len()).map(|i| (st.laplacian(v, i) - st.laplacian(decoded, i)).length_squared() as f64).sum();
    (sum / n as f64).sqrt()
}

/// How far the decoded grid's samples have slid along the surface, as the
/// change of their spacing: sqrt(mean over grid samples of (λ'/λ − 1)²),
/// λ the mean length of a sample's four grid edges (the paper's conformal
/// factor) in the uncompressed grid and λ' in the decoded one. 0.1 is a
/// spacing 10 % off: a texture carried by the grid would swim that much.
/// Samples whose λ is zero (none on a valid grid), and those `on_surface`
/// marks false (on faces a carrier added to close the input up), are left
/// out.
pub fn spacing_drift(st: &crate::grid::stencil::Stencils, v: &[Vec3], decoded: &[Vec3], on_surface: &[bool]) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for i in 0..v.len().min(decoded.len()) {
        let l = st.lambda(v, i);
        if l > 0.0 && on_surface.get(i).copied().unwrap_or(true) {
            sum += (st.lambda(decoded, i) as f64 / l as f64 - 1.0).powi(2);
            n += 1;
        }
    }
    (sum / n.max(1) as f64).sqrt()
}

/// The KG error of Karni & Gotsman (2004), "Compression of soft-body
/// animation sequences": 100 ‖A − A'‖_F / ‖A − E(A)‖_F, A the 3V x F matrix
/// of a sequence's coordinates and A' the decoded one. Two definitions of
/// E(A) are in use, and both are kept: each frame's centroid repeated over
/// its vertices ([`value`](Self::value), Karni & Gotsman's own, which the
/// dynamic-mesh-compression literature reports), and each vertex's mean
/// position over the sequence ([`temporal`](Self::temporal)). Fed one frame
/// at a time; the second keeps each vertex's running mean and squared
/// spread (Welford's update, which does not cancel far from the origin).
#[derive(Debug, Clone, Default)]
pub struct KgError {
    diff: f64,
    spread: f64,
    frames: usize,
    /// Per vertex: the mean of its positions so far.
    mean: Vec<glam::DVec3>,
    /// The sum over vertices of squared distances to their running means.
    temporal_spread: f64,
}

impl KgError {
    pub fn add_frame(&mut self, original: &[Vec3], decoded: &[Vec3]) {
        assert_eq!(original.len(), decoded.len(), "KG error needs corresponding points");
        let c = original.iter().map(|p| p.as_dvec3()).sum::<glam::DVec3>() / original.len().max(1) as f64;
        if self.mean.is_empty() {
            self.mean = vec![glam::DVec3::ZERO; original.len()];
        }
        let k = (self.frames + 1) as f64;
        for (v, (p, q)) in original.iter().zip(decoded).enumerate() {
            let p = p.as_dvec3();
            self.diff += (p - q.as_dvec3()).length_squared();
            self.spread += (p - c).length_squared();
            if let Some(m) = self.mean.get_mut(v) {
                let delta = p - *m;
                *m += delta / k;
                self.temporal_spread += delta.dot(p - *m);
            }
        }
        self.frames += 1;
    }

    /// The error in percent against each frame's centroid (0 for identical
    /// sequences).
    pub fn value(&self) -> f64 {
        Self::percent(self.diff, self.spread)
    }

    /// The error in percent against each vertex's mean over time.
    pub fn temporal(&self) -> f64 {
        Self::percent(self.diff, self.temporal_spread)
    }

    fn percent(diff: f64, spread: f64) -> f64 {
        if spread > 0.0 {
            100.0 * (diff / spread).sqrt()
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod spacing_tests {
    use super::spacing_drift;
    use crate::grid::{stencil::Stencils, Grid};
    use glam::Vec3;

    #[test]
    fn spacing_drift_is_the_change_of_lambda() {
        let grid = Grid::new(16).unwrap();
        let st = Stencils::new(grid);
        let v: Vec<Vec3> =
            (0..grid.len()).map(|i| Vec3::new((i % 16) as f32, (i / 16) as f32, (i % 5) as f32)).collect();
        let all = vec![true; v.len()];
        assert_eq!(spacing_drift(&st, &v, &v, &all), 0.0);
        // Scaled by 1.1 about any point: every spacing 10 % longer.
        let big: Vec<Vec3> = v.iter().map(|p| *p * 1.1 + Vec3::ONE).collect();
        assert!((spacing_drift(&st, &v, &big, &all) - 0.1).abs() < 1e-5);
        // A translation slides nothing.
        let moved: Vec<Vec3> = v.iter().map(|p| *p + Vec3::X).collect();
        assert!(spacing_drift(&st, &v, &moved, &all) < 1e-6);
        // One sample stretched, then left out.
        let mut one = v.clone();
        one[40] += Vec3::Z * 3.0;
        let mut mask = all.clone();
        assert!(spacing_drift(&st, &v, &one, &all) > 0.0);
        for i in std::iter::once(40).chain(grid.neighbours(40).into_iter().map(|s| s as usize)) {
            mask[i] = false;
        }
        assert!(spacing_drift(&st, &v, &one, &mask) < 1e-6);
    }
}

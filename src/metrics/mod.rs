//! Error measures between surfaces and between sequences.

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

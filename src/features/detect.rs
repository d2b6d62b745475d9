//! Feature points of one frame, as the seed paper finds them (section 4.1):
//! the local maxima of the heat kernel signature at a short diffusion time
//! ([`hks`](super::hks)), which sit on a body's extremities (fingertips,
//! feet, head, tail). Each carries a descriptor, its signature at a few
//! times, by which [`track`](super::track) matches it in the next frame.

use super::hks::Spectrum;
use super::nearest::nearest_vertices;
use crate::error::Result;
use glam::Vec3;

/// Laplacian eigenpairs the signature is built from.
pub const EIGENPAIRS: usize = 32;
/// Diffusion times, as fractions of the range [4 ln 10 / λ_max, 4 ln 10 /
/// λ_1] of Sun et al. (log-spaced between its ends): the descriptor reads
/// all of them, detection the second (a short time: sharp maxima on the
/// extremities, few elsewhere).
pub const TIMES: usize = 5;
const DETECT_TIME: usize = 1;
/// Maxima closer than this (in units of the square root of the surface
/// area) to a stronger one are one feature; the weaker are kept as
/// [`Feature::weak`] candidates.
pub const SEPARATION: f32 = 0.15;

/// A feature point.
#[derive(Debug, Clone, PartialEq)]
pub struct Feature {
    /// The vertex of the frame's mesh it lies on.
    pub vertex: u32,
    pub position: Vec3,
    /// log of the signature at [`TIMES`] times, each relative to the
    /// surface's mean signature at that time (the scaled HKS of Sun et al.).
    pub descriptor: [f32; TIMES],
    /// A maximum within [`SEPARATION`] of a stronger one: no feature of its
    /// own, but a track that finds nothing else close by in this frame may
    /// take it (a new maximum beside a foot can outgrow the foot's for a
    /// frame or two; pcow's and samba's cones missed 4-12 % of frames so).
    pub weak: bool,
}

/// The features of a frame (`faces` over `positions`), strongest first,
/// then the weak candidates.
pub fn features(faces: &[[u32; 3]], positions: &[Vec3]) -> Result<Vec<Feature>> {
    Ok(features_near(faces, positions, None)?.0)
}

/// A frame's positions and the Laplacian eigenpairs found on them.
pub type Found<'a> = (&'a [Vec3], &'a Spectrum);

/// [`features`], the eigenpairs started from those of a nearby frame
/// (`last`; carried to this frame's vertices by their nearest vertex
/// there), and the eigenpairs for the next frame.
pub fn features_near(faces: &[[u32; 3]], positions: &[Vec3], last: Option<Found>) -> Result<(Vec<Feature>, Spectrum)> {
    let k = EIGENPAIRS.min(positions.len().saturating_sub(2));
    let guess: Option<Vec<Vec<f64>>> = last.map(|(at, s)| {
        let near = nearest_vertices(positions, at);
        s.vectors.iter().map(|v| near.iter().map(|&i| v.get(i as usize).copied().unwrap_or(0.0)).collect()).collect()
    });
    let spectrum = Spectrum::near(faces, positions, k, guess.as_deref())?;
    Ok((maxima(faces, positions, &spectrum), spectrum))
}

/// The signature's local maxima at the detection time, a feature each:
/// the strong first (each the strongest within [`SEPARATION`]), then the
/// weak, each strongest first.
fn maxima(faces: &[[u32; 3]], positions: &[Vec3], spectrum: &Spectrum) -> Vec<Feature> {
    let times = diffusion_times(&spectrum.values);
    let hks: Vec<Vec<f64>> = times.iter().map(|&t| spectrum.hks(t)).collect();
    let detect = &hks[DETECT_TIME];
    let neighbours = one_rings(faces, positions.len());
    let mut maxima: Vec<u32> = (0..positions.len() as u32)
        .filter(|&v| !neighbours[v as usize].is_empty())
        .filter(|&v| neighbours[v as usize].iter().all(|&u| detect[v as usize] > detect[u as usize]))
        .collect();
    maxima.sort_by(|&a, &b| detect[b as usize].total_cmp(&detect[a as usize]));
    let radius = SEPARATION * surface_area(faces, positions).sqrt();
    let (mut kept, mut weak): (Vec<u32>, Vec<u32>) = (Vec::new(), Vec::new());
    for v in maxima {
        let p = positions[v as usize];
        if kept.iter().all(|&k| positions[k as usize].distance(p) > radius) {
            kept.push(v);
        } else {
            weak.push(v);
        }
    }
    let means: Vec<f64> = hks.iter().map(|h| h.iter().sum::<f64>() / h.len().max(1) as f64).collect();
    let feature = |v: u32, weak: bool| Feature {
        vertex: v,
        position: positions[v as usize],
        descriptor: std::array::from_fn(|k| (hks[k][v as usize] / means[k].max(f64::MIN_POSITIVE)).ln() as f32),
        weak,
    };
    kept.into_iter().map(|v| feature(v, false)).chain(weak.into_iter().map(|v| feature(v, true))).collect()
}

/// [`TIMES`] log-spaced times over Sun et al.'s range for these eigenvalues.
fn diffusion_times(values: &[f64]) -> [f64; TIMES] {
    let first = values.iter().copied().find(|&l| l > 1e-9).unwrap_or(1.0);
    let last = values.last().copied().unwrap_or(first).max(first * 1.0001);
    let (lo, hi) = ((4.0 * 10f64.ln() / last).ln(), (4.0 * 10f64.ln() / first).ln());
    std::array::from_fn(|k| (lo + (hi - lo) * k as f64 / (TIMES - 1) as f64).exp())
}

fn one_rings(faces: &[[u32; 3]], n: usize) -> Vec<Vec<u32>> {
    let mut rings = vec![Vec::new(); n];
    for f in faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            rings[a as usize].push(b);
            rings[b as usize].push(a);
        }
    }
    for r in &mut rings {
        r.sort_unstable();
        r.dedup();
    }
    rings
}

pub(super) fn surface_area(faces: &[[u32; 3]], p: &[Vec3]) -> f32 {
    faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| p[i as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

#[cfg(test)]
mod probe {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// `CGV_PROBE=/tmp/data/samba cargo test --release --lib features::detect -- --ignored --nocapture`
    #[test]
    #[ignore]
    fn features_of_a_real_frame() {
        let dir = std::env::var("CGV_PROBE").unwrap();
        let src = crate::mesh::open_sequence(&dir, &Default::default()).unwrap();
        for f in [0, src.frame_count() / 2] {
            let p = src.read_frame(f).unwrap();
            let t0 = std::time::Instant::now();
            let feats = features(&src.topology().faces, &p).unwrap();
            eprintln!(
                "{dir} frame {f}: {} vertices, {} features in {:.2} s",
                p.len(),
                feats.len(),
                t0.elapsed().as_secs_f64()
            );
            for x in feats.iter().take(12) {
                eprintln!("  v {} at {:?} {:?}", x.vertex, x.position, x.descriptor);
            }
        }
    }
}

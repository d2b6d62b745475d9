//! Each point's nearest vertex of another frame, through a uniform grid of
//! buckets (about one vertex a bucket): how a frame's eigenvectors are
//! carried to the next frame's own vertices, as LOBPCG's start
//! ([`super::hks::Spectrum::near`]). A start needs only be close, so a
//! point takes the nearest vertex in the first ring of buckets that has
//! any: within a bucket's diagonal of the nearest.

use glam::{IVec3, Vec3};
use std::collections::HashMap;

/// For each of `points`, a vertex of `vertices` near it (0 where there are
/// none).
pub fn nearest_vertices(points: &[Vec3], vertices: &[Vec3]) -> Vec<u32> {
    let Some(first) = vertices.first() else { return vec![0; points.len()] };
    let (lo, hi) = vertices.iter().fold((*first, *first), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let size = ((hi - lo).max_element() / (vertices.len() as f32).cbrt()).max(f32::MIN_POSITIVE);
    let cell = |p: Vec3| ((p - lo) / size).floor().as_ivec3();
    let mut buckets: HashMap<IVec3, Vec<u32>> = HashMap::new();
    for (i, p) in vertices.iter().enumerate() {
        buckets.entry(cell(*p)).or_default().push(i as u32);
    }
    let top = cell(hi);
    points
        .iter()
        .map(|p| {
            let c = cell(*p);
            // The ring that holds the farthest bucket ends the search.
            let last = c.abs().max((c - top).abs()).max_element();
            let Some(hit) = (0..=last).find(|&r| !ring(&buckets, c, r).is_empty()) else { return 0 };
            let d = |i: &&u32| p.distance_squared(vertices[**i as usize]);
            ring(&buckets, c, hit).into_iter().min_by(|a, b| d(&a).total_cmp(&d(&b))).unwrap_or(0)
        })
        .collect()
}

/// The vertices in the buckets at Chebyshev distance `r` from bucket `c`.
fn ring(buckets: &HashMap<IVec3, Vec<u32>>, c: IVec3, r: i32) -> Vec<u32> {
    let mut out = Vec::new();
    for x in -r..=r {
        for y in -r..=r {
            for z in -r..=r {
                let d = IVec3::new(x, y, z);
                if d.abs().max_element() == r {
                    out.extend(buckets.get(&(c + d)).into_iter().flatten());
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_find_their_near_vertices() {
        let vertices: Vec<Vec3> =
            (0..1000).map(|i| Vec3::new((i % 10) as f32, (i / 10 % 10) as f32, (i / 100) as f32)).collect();
        let points = [Vec3::new(3.1, 4.2, 5.4), Vec3::new(-7.0, 0.0, 0.0), Vec3::new(9.0, 9.0, 20.0)];
        let near = nearest_vertices(&points, &vertices);
        // Buckets of 0.9 (1,000 vertices over 9 units): (3, 4, 5) or, in
        // the point's own bucket, (3, 4, 6).
        assert!(near[0] == 543 || near[0] == 643, "{near:?}");
        assert_eq!(&near[1..], &[0, 999]);
        assert_eq!(nearest_vertices(&points, &[]), vec![0, 0, 0]);
    }
}

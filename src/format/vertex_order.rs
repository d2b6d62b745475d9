//! Version 19: the order in which a spatially predicted vertex residual
//! visits the source mesh's vertices, and each vertex's prediction from
//! the vertices visited before it. The parallelogram rule is Touma and
//! Gotsman's ("Triangle mesh compression", Graphics Interface 1998), the
//! one Draco predicts positions with: across an edge (p, q) of a face
//! already walked whose third vertex is r, the new vertex is p + q − r.
//! A residual that varies smoothly over the surface (what a coarse grid
//! or the last frame leaves of a smooth motion) is then coded as what the
//! rule misses, near zero, rather than as itself.
//!
//! The walk and its guesses are the source mesh's places' own
//! (`super::places::Walk`, the same rule in the parameter plane): the faces
//! in the source mesh's order, each vertex at its first face, guessed from
//! the face's two other corners (across an earlier face's edge, their mean,
//! or the one known) or else as the vertex visited last (zero for the
//! first); vertices no face uses last, in index order. Integers only; each
//! guess and each rebuilt value saturates at ±2²⁴, so that a chain of
//! guesses cannot overflow whatever a file holds.

use super::places::Walk;

/// What a guess and a rebuilt value saturate at.
pub const SATURATE: i64 = 1 << 24;

fn saturate(x: i64) -> i64 {
    x.clamp(-SATURATE, SATURATE)
}

/// The walk over a mesh's vertices that spatial units follow.
#[derive(Debug, Clone)]
pub struct VertexOrder {
    walk: Walk,
}

impl VertexOrder {
    /// The walk over `vertices` vertices by `faces` (faces naming a vertex
    /// past `vertices` are passed over: the reader refuses them anyway).
    pub fn new(faces: &[[u32; 3]], vertices: usize) -> VertexOrder {
        let inside: Vec<[u32; 3]> =
            faces.iter().copied().filter(|f| f.iter().all(|&v| (v as usize) < vertices)).collect();
        VertexOrder { walk: Walk::new(&inside, vertices) }
    }

    /// How many vertices the walk visits.
    pub fn len(&self) -> usize {
        self.walk.len()
    }

    pub fn is_empty(&self) -> bool {
        self.walk.is_empty()
    }

    /// The encoder: the coded values (three a vertex, in the walk's order)
    /// that bring each vertex's rebuilt integers to `wanted` (three a
    /// vertex, in vertex order) as near as values within ±`max` can, and
    /// those rebuilt integers, in vertex order: what [`Self::rebuild`]
    /// gives back from the values.
    pub fn code(&self, wanted: &[[i32; 3]], max: i32) -> (Vec<i32>, Vec<[i32; 3]>) {
        let mut rebuilt = vec![[0i32; 3]; self.len()];
        let mut values = Vec::with_capacity(3 * self.len());
        let max = i64::from(max);
        let visited = self.walk.run([0; 3], &saturate, &mut |v, guess| {
            let want = wanted.get(v as usize).copied().unwrap_or_default();
            let e: [i64; 3] = std::array::from_fn(|k| (i64::from(want[k]) - guess[k]).clamp(-max, max));
            values.extend(e.map(|x| x as i32));
            let out = std::array::from_fn(|k| saturate(guess[k] + e[k]));
            rebuilt[v as usize] = out.map(|x| x as i32);
            Ok(out)
        });
        debug_assert!(visited.is_ok(), "the coder's visit never fails");
        (values, rebuilt)
    }

    /// The decoder: each vertex's integers (in vertex order) from the coded
    /// values (three a vertex, in the walk's order; the caller checked
    /// their count).
    pub fn rebuild(&self, values: &[i32]) -> Vec<[i32; 3]> {
        let mut rebuilt = vec![[0i32; 3]; self.len()];
        let mut next = values.chunks_exact(3);
        let visited = self.walk.run([0; 3], &saturate, &mut |v, guess| {
            let e = next.next().unwrap_or(&[0, 0, 0]);
            let out = std::array::from_fn(|k| saturate(guess[k] + i64::from(e[k])));
            rebuilt[v as usize] = out.map(|x| x as i32);
            Ok(out)
        });
        debug_assert!(visited.is_ok(), "the decoder's visit never fails");
        rebuilt
    }
}

#[cfg(test)]
mod tests {
    use super::VertexOrder;

    /// A regular grid of w x h vertices, two triangles a cell.
    fn sheet(w: u32, h: u32) -> Vec<[u32; 3]> {
        let mut faces = Vec::new();
        for y in 0..h - 1 {
            for x in 0..w - 1 {
                let v = y * w + x;
                faces.push([v, v + 1, v + w]);
                faces.push([v + 1, v + w + 1, v + w]);
            }
        }
        faces
    }

    #[test]
    fn a_linear_field_costs_nothing_past_the_first_face_and_rebuilds_exactly() {
        let (w, h) = (12, 9);
        let order = VertexOrder::new(&sheet(w, h), (w * h + 2) as usize);
        assert_eq!(order.len(), (w * h + 2) as usize, "the two vertices no face uses come last");
        // A field linear in the grid's coordinates: the parallelogram rule
        // predicts it exactly.
        let wanted: Vec<[i32; 3]> =
            (0..w * h + 2).map(|v| [(v % w) as i32 * 7 + 300, (v / w) as i32 * -5, 40]).collect();
        let (values, rebuilt) = order.code(&wanted, 1023);
        assert_eq!(rebuilt, wanted);
        assert_eq!(order.rebuild(&values), wanted);
        let nonzero = values.iter().filter(|&&e| e != 0).count();
        assert!(nonzero <= 3 * 3 + 2 * 3, "{nonzero} values off zero");
    }

    #[test]
    fn clamped_values_keep_encoder_and_decoder_together() {
        let order = VertexOrder::new(&sheet(6, 6), 36);
        let wanted: Vec<[i32; 3]> = (0..36).map(|v| [v * 997 % 5000 - 2500, 3, -(v * v)]).collect();
        let (values, rebuilt) = order.code(&wanted, 50);
        assert!(values.iter().all(|e| e.abs() <= 50));
        assert_eq!(order.rebuild(&values), rebuilt);
        assert_ne!(rebuilt, wanted, "values within ±50 cannot reach these");
        // Whatever a broken file holds saturates rather than overflows.
        let wild = vec![i32::MAX; 3 * 36];
        assert!(order.rebuild(&wild).iter().flatten().all(|x| i64::from(*x).abs() <= super::SATURATE));
    }
}

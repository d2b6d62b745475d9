//! Version 12: each source vertex's place in the parameterization coded
//! as its difference from a prediction, the parallelogram rule of Touma
//! and Gotsman ("Triangle mesh compression", 1998) applied in the
//! parameter plane instead of space: a vertex across the edge (x, y) from
//! a known vertex o lies near x + y - o, since the map is smooth. Vertices
//! are visited in the order the faces (as coded) first use them, then the
//! vertices no face uses, in index order.

use super::connectivity::{has_edge, Around};

/// Faces around a vertex searched for the one across an edge: more than
/// any manifold vertex of a real mesh has.
const SCAN: usize = 64;

/// A place in `shift`-ed units: `(u >> shift, v >> shift)`.
pub type Place = [i64; 2];

/// Visits every one of `vertices` vertices once, in the walk's order,
/// with the prediction of its place from those visited before; `visit`
/// gives back the vertex's place (the coder's own, or the decoder's
/// prediction plus what it read), which later predictions use. `max` is
/// the largest place a coordinate may have; predictions are clamped to
/// `0..=max`.
pub fn walk(
    faces: &[[u32; 3]],
    vertices: usize,
    max: i64,
    visit: &mut dyn FnMut(u32, Place) -> Result<Place, String>,
) -> Result<(), String> {
    let mut known: Vec<Option<Place>> = vec![None; vertices];
    let around = Around::new(faces, vertices);
    // The third vertex of an earlier face with the directed edge (a, b),
    // among the last SCAN faces around a (a file's fan of a million faces
    // must not cost a million squared).
    let opposite = |i: usize, a: u32, b: u32| -> Option<u32> {
        let g = &faces[around.before(a, i).take(SCAN).find(|&j| has_edge(&faces[j], a, b))?];
        (0..3).find(|&m| g[m] == a && g[(m + 1) % 3] == b).map(|m| g[(m + 2) % 3])
    };
    let mut last: Place = [max / 2, max / 2];
    let clamp = |p: Place| p.map(|x| x.clamp(0, max));
    for (i, f) in faces.iter().enumerate() {
        for k in 0..3 {
            let (v, x, y) = (f[k], f[(k + 1) % 3], f[(k + 2) % 3]);
            if known[v as usize].is_some() {
                continue;
            }
            let (px, py) = (known[x as usize], known[y as usize]);
            let across = opposite(i, y, x).and_then(|o| known[o as usize]);
            let guess = match (px, py, across) {
                (Some(a), Some(b), Some(o)) => [a[0] + b[0] - o[0], a[1] + b[1] - o[1]],
                (Some(a), Some(b), None) => [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2],
                (Some(a), None, _) | (None, Some(a), _) => a,
                (None, None, _) => last,
            };
            let p = visit(v, clamp(guess))?;
            known[v as usize] = Some(p);
            last = p;
        }
    }
    for v in 0..vertices {
        if known[v].is_none() {
            last = visit(v as u32, last)?;
            known[v] = Some(last);
        }
    }
    Ok(())
}

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
    Walk::new(faces, vertices).run([max / 2; 2], &|x| x.clamp(0, max), visit)
}

/// How a vertex is guessed from the vertices visited before it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Guess {
    /// x + y − o: across the edge (x, y) from an earlier face's o.
    Parallelogram(u32, u32, u32),
    /// (x + y) / 2, rounded toward zero.
    Mean(u32, u32),
    Copy(u32),
    /// The vertex visited last (the start for the first).
    Last,
}

/// The walk's order and each vertex's guess, which depend on the faces
/// alone: made once, run on any values (a place's two coordinates, a
/// vertex residual's three: `super::vertex_order`).
#[derive(Debug, Clone)]
pub struct Walk {
    visits: Vec<(u32, Guess)>,
}

impl Walk {
    /// The walk over `vertices` vertices by `faces` (each index below
    /// `vertices`: the caller's to check).
    pub fn new(faces: &[[u32; 3]], vertices: usize) -> Walk {
        let mut known = vec![false; vertices];
        let around = Around::new(faces, vertices);
        // The third vertex of an earlier face with the directed edge (a, b),
        // among the last SCAN faces around a (a file's fan of a million faces
        // must not cost a million squared).
        let opposite = |i: usize, a: u32, b: u32| -> Option<u32> {
            let g = &faces[around.before(a, i).take(SCAN).find(|&j| has_edge(&faces[j], a, b))?];
            (0..3).find(|&m| g[m] == a && g[(m + 1) % 3] == b).map(|m| g[(m + 2) % 3])
        };
        let mut visits = Vec::with_capacity(vertices);
        for (i, f) in faces.iter().enumerate() {
            for k in 0..3 {
                let (v, x, y) = (f[k], f[(k + 1) % 3], f[(k + 2) % 3]);
                if known[v as usize] {
                    continue;
                }
                let (kx, ky) = (known[x as usize], known[y as usize]);
                let across = opposite(i, y, x).filter(|&o| known[o as usize]);
                let guess = match (kx, ky, across) {
                    (true, true, Some(o)) => Guess::Parallelogram(x, y, o),
                    (true, true, None) => Guess::Mean(x, y),
                    (true, false, _) => Guess::Copy(x),
                    (false, true, _) => Guess::Copy(y),
                    (false, false, _) => Guess::Last,
                };
                known[v as usize] = true;
                visits.push((v, guess));
            }
        }
        visits.extend((0..vertices as u32).filter(|&v| !known[v as usize]).map(|v| (v, Guess::Last)));
        Walk { visits }
    }

    /// How many vertices the walk visits.
    pub fn len(&self) -> usize {
        self.visits.len()
    }

    pub fn is_empty(&self) -> bool {
        self.visits.is_empty()
    }

    /// Visits the vertices in order with their guesses, each coordinate
    /// passed through `clamp` (a vertex no face uses is guessed as the one
    /// visited last, unclamped); `visit` gives back the vertex's value,
    /// which later guesses use. `start`: the first vertex's guess.
    pub fn run<const D: usize>(
        &self,
        start: [i64; D],
        clamp: &dyn Fn(i64) -> i64,
        visit: &mut dyn FnMut(u32, [i64; D]) -> Result<[i64; D], String>,
    ) -> Result<(), String> {
        let mut known = vec![[0i64; D]; self.visits.len()];
        let mut last = start;
        for &(v, guess) in &self.visits {
            let at = |u: u32| known[u as usize];
            let g = match guess {
                Guess::Parallelogram(x, y, o) => {
                    let (a, b, o) = (at(x), at(y), at(o));
                    std::array::from_fn(|c| clamp(a[c] + b[c] - o[c]))
                }
                Guess::Mean(x, y) => {
                    let (a, b) = (at(x), at(y));
                    std::array::from_fn(|c| clamp((a[c] + b[c]) / 2))
                }
                Guess::Copy(x) => at(x).map(clamp),
                Guess::Last => last,
            };
            last = visit(v, g)?;
            known[v as usize] = last;
        }
        Ok(())
    }
}

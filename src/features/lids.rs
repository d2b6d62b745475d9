//! The grid faces over a capture's holes, left out of the grid mesh the
//! capture comes back as. A frame is mapped on its closed surface
//! ([`crate::mesh::carrier`]): its own faces, lids over its holes and
//! tubes between its parts. The grid covers all of it, so an open capture
//! (a face mask, a tube) came back with membranes over its holes that no
//! frame has, and its floor (the grid against each frame's own mesh)
//! counted them: face-poses' capture lay 3.2 % of the diagonal from its
//! frames.
//!
//! Each frame's map says which samples lie on the frame's own faces
//! ([`crate::resample::SampleMap::on_input`]). A grid face whose samples
//! are all off them in most of a piece's frames is over a hole there, and
//! one over a hole in every piece is left out: a file has one grid mesh.

use super::capture::Capture;
use super::outliers::resampling_error;
use super::store::FrameStore;
use crate::error::Result;
use crate::grid::Grid;
use crate::mesh::topology::used_by;
use crate::metrics::surface::Target;
use glam::Vec3;
use rayon::prelude::*;

/// For one piece of a capture (one map), 1 for each face of `grid` that
/// lies over a hole in more than half of its frames (`on_input`: each
/// frame's samples, whether each lies on the frame's own faces), 0 for the
/// others; no frames, no list. A face lies over a hole where its three
/// samples lie off the frame's faces. (A face with one or two samples off,
/// at a hole's rim, stays: with the faces counted over all frames at once,
/// leaving those out too left face-poses' capture 0.474 % of the diagonal
/// from its frames, keeping them 0.465 %.)
pub fn over_holes(grid: Grid, on_input: &[Vec<bool>]) -> Vec<u32> {
    if on_input.is_empty() {
        return Vec::new();
    }
    let faces = grid.topology().faces;
    let mut frames = vec![0usize; faces.len()];
    for frame in on_input.iter().filter(|o| !o.iter().all(|&x| x)) {
        let off = |s: &u32| !frame.get(*s as usize).copied().unwrap_or(true);
        for (n, f) in frames.iter_mut().zip(&faces) {
            *n += f.iter().all(off) as usize;
        }
    }
    frames.iter().map(|&n| (2 * n > on_input.len()) as u32).collect()
}

/// Two pieces' [`over_holes`] added up (an empty list counts nothing).
pub fn added(a: &[u32], b: &[u32]) -> Vec<u32> {
    match (a.is_empty(), b.is_empty()) {
        (true, _) => b.to_vec(),
        (_, true) => a.to_vec(),
        _ => a.iter().zip(b).map(|(x, y)| x + y).collect(),
    }
}

/// The faces of `grid` to keep: all but those over a hole in every one of
/// the capture's `pieces` ([`over_holes`], added up). Each piece has a map
/// of its own, which may put a hole elsewhere on the grid; a face over a
/// hole in one piece may be on the surface in another's frames.
pub fn kept_faces(grid: Grid, votes: &[u32], pieces: u32) -> Vec<[u32; 3]> {
    let faces = grid.topology().faces;
    let over = |f: usize| pieces > 0 && votes.get(f).copied().unwrap_or(0) >= pieces;
    (0..faces.len()).filter(|&f| !over(f)).map(|f| faces[f]).collect()
}

/// Each frame's grid in `store` with the samples of `faces` moved onto
/// the frame's own mesh (to its nearest point), and how far (symmetric
/// surface RMS) the grid on `faces` then lies from that mesh; a run of
/// frames at a time. A face kept at a hole's rim has samples on the lid
/// past the rim: face-poses' rim faces hung over its holes, and half its
/// frames' squared distance to the grid lay within 0.5 % of the diagonal
/// of their rims. On the mesh those samples land on the rim, so the grid
/// mesh's edge follows the hole's. The other samples of `faces` lie on
/// the mesh already and barely move.
pub fn onto_own_meshes(capture: &dyn Capture, store: &mut dyn FrameStore, faces: &[[u32; 3]]) -> Result<Vec<f64>> {
    let n = capture.len();
    let used = used_by(faces, store.grid(0).map_or(0, |g| g.len()));
    let run = (4 * rayon::current_num_threads()).max(1);
    let mut errors = Vec::with_capacity(n);
    for a in (0..n).step_by(run) {
        let frames = capture.frames(a..n.min(a + run))?;
        let grids = (a..a + frames.len()).map(|t| store.grid(t).map(|g| g.into_owned())).collect::<Result<Vec<_>>>()?;
        let moved: Vec<(Vec<Vec3>, f64)> = frames
            .par_iter()
            .zip(grids)
            .map(|(f, mut g)| {
                let own = Target::new(&f.positions, &f.faces)?;
                for (p, _) in g.iter_mut().zip(&used).filter(|(_, &u)| u) {
                    *p = own.nearest_point(*p);
                }
                let e = resampling_error(f, &g, faces)?;
                Ok((g, e))
            })
            .collect::<Result<_>>()?;
        for (t, (g, e)) in (a..).zip(moved) {
            store.replace_grid(t, g)?;
            errors.push(e);
        }
    }
    Ok(errors)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::features::capture::CaptureFrame;
    use crate::features::store::Registered;

    /// The samples of the kept faces land on the frame's own mesh (here a
    /// sheet over the square [0, 1]² at z = 0, the grid's samples 0.3 above
    /// it and past its edge); a sample no kept face uses stays where it was.
    #[test]
    fn kept_faces_samples_land_on_the_frames_own_mesh() {
        let grid = Grid::new(4).unwrap();
        let sheet = CaptureFrame {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            faces: vec![[0, 1, 2], [0, 2, 3]],
        };
        let frames = vec![sheet.clone(), sheet];
        let lifted: Vec<Vec3> = (0..16).map(|s| Vec3::new((s % 4) as f32 * 0.5, (s / 4) as f32 * 0.5, 0.3)).collect();
        let mut store = Registered::empty(std::path::Path::new("sheet"), 30.0, grid);
        for f in &frames {
            store.push(lifted.clone(), f.mesh()).unwrap();
        }
        // Every face but those with sample 15 (the corner at (1.5, 1.5)).
        let kept: Vec<[u32; 3]> = grid.topology().faces.into_iter().filter(|f| !f.contains(&15)).collect();
        let errors = onto_own_meshes(&frames.as_slice(), &mut store, &kept).unwrap();
        assert_eq!(errors.len(), 2);
        for t in 0..2 {
            let g = store.grid(t).unwrap();
            for (s, p) in g.iter().enumerate().take(15) {
                let x = lifted[s].truncate().clamp(glam::Vec2::ZERO, glam::Vec2::ONE);
                assert!(p.distance(x.extend(0.0)) < 1e-5, "sample {s} at {p}");
            }
            assert_eq!(g[15], lifted[15]);
        }
    }

    /// A face whose samples are off the frame's faces in most of a
    /// piece's frames is over a hole there; one over a hole in every piece
    /// goes, one over a hole in some pieces only stays; a closed capture
    /// keeps all.
    #[test]
    fn faces_over_a_hole_in_every_piece_are_left_out() {
        let grid = Grid::new(4).unwrap();
        let faces = grid.topology().faces;
        // The middle quad's four samples off.
        let middle = [5u32, 6, 9, 10];
        let hole: Vec<bool> = (0..16).map(|s| !middle.contains(&s)).collect();
        let closed = vec![true; 16];
        let inside = |f: &[u32; 3]| f.iter().all(|s| middle.contains(s));
        assert_eq!(faces.iter().filter(|f| inside(f)).count(), 2);
        let two_of_three = over_holes(grid, &[hole.clone(), hole.clone(), closed.clone()]);
        for (v, f) in two_of_three.iter().zip(&faces) {
            assert_eq!(*v, inside(f) as u32, "{f:?}");
        }
        let kept = kept_faces(grid, &two_of_three, 1);
        assert_eq!(kept, faces.iter().copied().filter(|f| !inside(f)).collect::<Vec<_>>());
        // Over a hole in half the frames: not over one.
        let half = over_holes(grid, &[hole.clone(), closed.clone()]);
        assert!(half.iter().all(|&v| v == 0));
        // Pieces add up: over a hole in one piece of two, every face stays.
        assert_eq!(kept_faces(grid, &added(&two_of_three, &half), 2), faces);
        assert_eq!(kept_faces(grid, &added(&two_of_three, &two_of_three), 2), kept);
        assert_eq!(added(&[], &half), half);
        assert!(over_holes(grid, &[]).is_empty());
        assert_eq!(kept_faces(grid, &over_holes(grid, &[closed]), 1), faces);
        assert_eq!(kept_faces(grid, &[], 0), faces);
    }
}

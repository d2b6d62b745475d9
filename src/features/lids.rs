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
//! are all off them in most frames is over a hole, decided once for the
//! capture, since a file has one grid mesh.

use super::capture::Capture;
use super::outliers::resampling_error;
use super::store::FrameStore;
use crate::error::Result;
use crate::grid::Grid;
use rayon::prelude::*;

/// For each face of `grid`, in how many of the frames (`on_input`: each
/// frame's samples, whether each lies on the frame's own faces) its three
/// samples lie off them. (A face with one or two samples off, at a hole's
/// rim, stays: leaving those out too left face-poses' capture 0.474 % of
/// the diagonal from its frames, keeping them 0.465 %.)
pub fn votes(grid: Grid, on_input: &[Vec<bool>]) -> Vec<u32> {
    let faces = grid.topology().faces;
    let mut votes = vec![0u32; faces.len()];
    for frame in on_input.iter().filter(|o| !o.iter().all(|&x| x)) {
        for (v, f) in votes.iter_mut().zip(&faces) {
            *v += f.iter().all(|&s| !frame.get(s as usize).copied().unwrap_or(true)) as u32;
        }
    }
    votes
}

/// Two pieces' [`votes`] added up (an empty list counts no frame).
pub fn added(a: &[u32], b: &[u32]) -> Vec<u32> {
    match (a.is_empty(), b.is_empty()) {
        (true, _) => b.to_vec(),
        (_, true) => a.to_vec(),
        _ => a.iter().zip(b).map(|(x, y)| x + y).collect(),
    }
}

/// The faces of `grid` to keep: all but those over a hole ([`votes`]) in
/// more than half of the capture's `frames`.
pub fn kept_faces(grid: Grid, votes: &[u32], frames: usize) -> Vec<[u32; 3]> {
    let faces = grid.topology().faces;
    let over = |f: usize| 2 * votes.get(f).copied().unwrap_or(0) as usize > frames;
    (0..faces.len()).filter(|&f| !over(f)).map(|f| faces[f]).collect()
}

/// How far (symmetric surface RMS) each frame's grid, on `faces`, lies
/// from the frame's own mesh, read a run of frames at a time.
pub fn errors_on(capture: &dyn Capture, store: &dyn FrameStore, faces: &[[u32; 3]]) -> Result<Vec<f64>> {
    let n = capture.len();
    let run = (4 * rayon::current_num_threads()).max(1);
    let mut errors = Vec::with_capacity(n);
    for a in (0..n).step_by(run) {
        let frames = capture.frames(a..n.min(a + run))?;
        let grids = (a..a + frames.len()).map(|t| store.grid(t)).collect::<Result<Vec<_>>>()?;
        let e: Vec<f64> =
            frames.par_iter().zip(&grids).map(|(f, g)| resampling_error(f, g, faces)).collect::<Result<_>>()?;
        errors.extend(e);
    }
    Ok(errors)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A face whose samples are off the frame's faces in most frames goes;
    /// one off in half of them or fewer stays; a closed capture keeps all.
    #[test]
    fn faces_over_a_hole_in_most_frames_are_left_out() {
        let grid = Grid::new(4).unwrap();
        let faces = grid.topology().faces;
        // The middle quad's four samples off.
        let middle = [5u32, 6, 9, 10];
        let hole: Vec<bool> = (0..16).map(|s| !middle.contains(&s)).collect();
        let closed = vec![true; 16];
        let three = votes(grid, &[hole.clone(), hole.clone(), closed.clone()]);
        let inside = |f: &[u32; 3]| f.iter().all(|s| middle.contains(s));
        for (v, f) in three.iter().zip(&faces) {
            assert_eq!(*v, if inside(f) { 2 } else { 0 }, "{f:?}");
        }
        assert_eq!(faces.iter().filter(|f| inside(f)).count(), 2);
        let kept = kept_faces(grid, &three, 3);
        assert_eq!(kept, faces.iter().copied().filter(|f| !inside(f)).collect::<Vec<_>>());
        assert!(kept.len() < faces.len());
        // Pieces add up; over a hole in two frames of four, a face stays.
        let four = added(&three, &votes(grid, std::slice::from_ref(&closed)));
        assert_eq!(kept_faces(grid, &four, 4), faces);
        assert_eq!(added(&[], &three), three);
        assert_eq!(kept_faces(grid, &votes(grid, &[closed]), 1), faces);
    }
}

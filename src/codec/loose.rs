//! Loose vertices (format version 11, `crate::format::loose`): a tiny
//! part's vertices coded as themselves, in the same closed loop as the
//! grid. Each frame predicts every loose vertex from what was decoded, and
//! codes what the prediction missed on the frame's step:
//!
//! - where the encoder knows the decoded grid (GV and the closed loop,
//!   [`Header::loose_follow_grid`]), a vertex follows its anchor, a grid
//!   sample the file names (the encoder's: the one nearest it on the
//!   reference frame): it keeps its last offset from the anchor,
//!   `g_a(t) + x(t-1) - g_a(t-1)`. An eye moves with the head around it,
//!   which a vertex's own velocity does not foresee when the head turns;
//! - else (the paper's solver) with constant velocity, `2 x(t-1) - x(t-2)`
//!   (`x(t-1)` one frame after a random-access point).
//!
//! At a random-access point a vertex is predicted by the vertex before it
//! in the same frame (a part's vertices come in mesh order, neighbours
//! mostly), the first by the origin.
//!
//! [`LooseVertices`] is the decoder's state; the encoder runs the same
//! state on what it codes ([`LooseVertices::code`]), so both sides predict
//! from the same decoded values. A decoder that runs another solver than
//! the file's (the paper's on a closed-loop file) follows its own grid:
//! its loose vertices are then as far off as its grid is.

use crate::error::{Error, Result};
use crate::format::{Header, LooseFrame};
use glam::Vec3;

/// The decoded loose vertices' past.
#[derive(Debug, Clone, Default)]
pub struct LooseVertices {
    count: usize,
    follow: bool,
    /// Each vertex's anchor sample (the file's; set before the first frame
    /// when following the grid).
    anchors: Vec<u32>,
    /// Decoded positions at t - 1 and t - 2 (empty before them).
    last: Vec<Vec3>,
    before: Vec<Vec3>,
    /// Each vertex's offset from its anchor at t - 1 (when following the
    /// grid; empty before the first frame since a random-access point).
    offsets: Vec<Vec3>,
}

impl LooseVertices {
    /// The state for a file with this header.
    pub fn for_header(h: &Header) -> LooseVertices {
        LooseVertices {
            count: h.loose_vertices().unwrap_or(0) as usize,
            follow: h.loose_follow_grid(),
            ..Default::default()
        }
    }

    /// Sets the anchors the file names (its source mesh's), each below
    /// `samples`, the grid's.
    pub fn set_anchors(&mut self, anchors: &[u32], samples: usize) -> Result<()> {
        if anchors.len() != self.count || anchors.iter().any(|&a| a as usize >= samples) {
            return Err(Error::Argument(format!(
                "{} loose-vertex anchors for {} loose vertices, each below {samples}",
                anchors.len(),
                self.count
            )));
        }
        self.anchors = anchors.to_vec();
        Ok(())
    }

    /// Forgets the past: the next frame is a random-access point.
    pub fn reset(&mut self) {
        self.last.clear();
        self.before.clear();
        self.offsets.clear();
    }

    /// The last frame's decoded positions (empty before the first).
    pub fn positions(&self) -> &[Vec3] {
        &self.last
    }

    /// Vertex `v`'s prediction on the decoded grid frame `grid`, given the
    /// vertices of this frame decoded so far (`now`, those before `v`).
    fn predict(&self, v: usize, now: &[Vec3], grid: &[Vec3]) -> Vec3 {
        if let (Some(&a), Some(&o)) = (self.anchors.get(v), self.offsets.get(v)) {
            if let Some(&g) = grid.get(a as usize) {
                return g + o;
            }
        }
        match (self.last.get(v), self.before.get(v)) {
            (Some(&a), Some(&b)) => 2.0 * a - b,
            (Some(&a), None) => a,
            _ => now.last().copied().unwrap_or(Vec3::ZERO),
        }
    }

    /// Decodes a frame's residuals on its decoded grid frame and makes
    /// them the last frame.
    pub fn decode(&mut self, frame: &LooseFrame, grid: &[Vec3]) -> Result<&[Vec3]> {
        if frame.residuals.len() != self.count {
            return Err(Error::Argument(format!(
                "{} loose vertices in a frame, {} in the file",
                frame.residuals.len(),
                self.count
            )));
        }
        if self.follow && self.anchors.len() != self.count {
            return Err(Error::Argument("the loose vertices' anchors (in the source mesh) have not arrived".into()));
        }
        let mut now = Vec::with_capacity(self.count);
        for (v, r) in frame.residuals.iter().enumerate() {
            let p = self.predict(v, &now, grid) + Vec3::from(r.map(|x| x as f32)) * frame.step;
            if !p.is_finite() {
                return Err(Error::Argument(format!("loose vertex {v} decodes to a non-finite position")));
            }
            now.push(p);
        }
        self.commit(now, grid);
        Ok(&self.last)
    }

    /// The encoder's side: quantizes `truth` against the prediction on
    /// `step` (what the decoder will rebuild, vertex after vertex), then
    /// decodes it as the decoder will, on the decoded grid frame `grid`.
    pub fn code(&mut self, truth: &[Vec3], step: f32, grid: &[Vec3]) -> LooseFrame {
        let mut now = Vec::with_capacity(self.count);
        let mut residuals = Vec::with_capacity(self.count);
        for (v, t) in truth.iter().enumerate().take(self.count) {
            let p = self.predict(v, &now, grid);
            let r = ((*t - p) / step).round().to_array().map(|x| x.clamp(i32::MIN as f32, i32::MAX as f32) as i32);
            now.push(p + Vec3::from(r.map(|x| x as f32)) * step);
            residuals.push(r);
        }
        self.commit(now, grid);
        LooseFrame { step, residuals }
    }

    fn commit(&mut self, now: Vec<Vec3>, grid: &[Vec3]) {
        if self.follow && !grid.is_empty() {
            let at = |a: u32| grid.get(a as usize).copied().unwrap_or_default();
            self.offsets = now.iter().zip(&self.anchors).map(|(x, &a)| *x - at(a)).collect();
        }
        self.before = std::mem::replace(&mut self.last, now);
    }
}

/// The step the encoder codes a frame's loose vertices on: their error
/// along any one direction (a uniform quantizer's, `step / sqrt(12)`)
/// matches the decoded grid's typical error along the surface's normal at
/// that frame, `normal_error`, about its surface distance; between 1e-6
/// and 1e-2 of the diagonal.
pub fn step_for(normal_error: f64, diagonal: f64) -> f32 {
    (12f64.sqrt() * normal_error).clamp(1e-6 * diagonal, 1e-2 * diagonal).max(f64::from(f32::MIN_POSITIVE)) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(count: usize, follow: bool) -> LooseVertices {
        let mut s = LooseVertices { count, follow, ..Default::default() };
        if follow {
            s.set_anchors(&[0, 2, 4, 6, 8], 9).unwrap();
        }
        s
    }

    #[test]
    fn the_decoder_rebuilds_what_the_encoder_coded() {
        let frames: Vec<Vec<Vec3>> = (0..6)
            .map(|t| (0..5).map(|v| Vec3::new(v as f32, (t * t) as f32 * 0.1, (v * t) as f32 * 0.03)).collect())
            .collect();
        let grid: Vec<Vec<Vec3>> =
            (0..6).map(|t| (0..9).map(|s| Vec3::new(s as f32 * 0.5, (t * t) as f32 * 0.1, 1.0)).collect()).collect();
        for follow in [false, true] {
            let (mut enc, mut dec) = (state(5, follow), state(5, follow));
            for (t, truth) in frames.iter().enumerate() {
                if t == 3 {
                    enc.reset();
                    dec.reset();
                }
                let coded = enc.code(truth, 0.01, &grid[t]);
                let parsed = LooseFrame::parse(&coded.to_bytes(), 5, 0).unwrap();
                let x = dec.decode(&parsed, &grid[t]).unwrap().to_vec();
                assert_eq!(x, enc.positions(), "frame {t}");
                for (a, b) in x.iter().zip(truth) {
                    assert!(a.distance(*b) <= 0.01 * 0.87, "frame {t}: {a} vs {b}");
                }
                if follow && t >= 4 {
                    // The grid moves as the vertices do along y (by 0.7
                    // and 0.9 here): following it leaves only their own
                    // drift along z to code.
                    assert!(coded.residuals.iter().all(|r| r[0] == 0 && r[1] == 0), "{:?}", coded.residuals);
                }
            }
            assert!(dec.decode(&LooseFrame { step: 1.0, residuals: vec![[0; 3]] }, &grid[0]).is_err());
        }
    }

    #[test]
    fn anchors_are_checked() {
        let mut s = LooseVertices { count: 2, follow: true, ..Default::default() };
        assert!(
            s.decode(&LooseFrame { step: 1.0, residuals: vec![[0; 3]; 2] }, &[Vec3::ZERO; 9]).is_err(),
            "no anchors"
        );
        assert!(s.set_anchors(&[0, 9], 9).is_err(), "past the grid");
        assert!(s.set_anchors(&[0], 9).is_err(), "one short");
        assert!(s.set_anchors(&[8, 0], 9).is_ok());
    }
}

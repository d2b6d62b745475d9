//! The predictive decoder: each frame predicted from the decoded past,
//! refined by the mean curvature H, then corrected.
//!
//! Why not a per-frame nonlinear solve (measured, docs/RESULTS.md):
//! Gauss–Newton on Δx − (a x_u + b x_v) − H n(x) with the anchors was exact
//! on exact data, but took seconds per frame at N = 64, fell into local
//! minima from an 8-bit first guess, drifted on pcow (0.06 % → 1.2 % of the
//! diagonal in 4 frames), and needed a, b every frame, which cost 15–30x the
//! bits of H. Lagging the normals instead (solve Δx = H n(x_k) + …, update
//! n, repeat) diverges: a perturbation of wavenumber k turns the normals by
//! about k δ and Δ⁻¹ scales that by 1/k², so long modes grow.
//!
//! So each frame is *predicted* from what the decoder already has:
//!
//! 1. an extrapolation of the decoded past — the previous frame moved by the
//!    rigid motion of its anchors onto this frame's (Horn 1987; the paper's
//!    own warm start, section 5.3), constant velocity 2 x₋₁ − x₋₂,
//!    constant velocity smoothed over the grid, or the smoothed velocity of
//!    `lag` frames ago, x₋₁ + S(x₋ₗ − x₋ₗ₋₁), for motion that repeats (a
//!    gait or a looped animation: long-term prediction, as in speech coding
//!    and H.264's long-term reference pictures) ([`Extrapolation`]);
//! 2. zero to [`MAX_STEPS`] mean-curvature steps: with the normals and
//!    tangents of the current guess, the tangential coefficients a, b of the
//!    previous decoded frame (no bits), this frame's decoded H and anchors,
//!    solve the linear least-squares problem
//!    `min |L x − (H n + a x_u + b x_v)|² + w |P x − A|²`, L the uniform grid
//!    Laplacian, whose normal matrix `LᵀL + w PᵀP` is factored once per
//!    sequence (the grid's connectivity never changes; compare Lipman,
//!    Sorkine, Levin & Cohen-Or 2005). More steps are the lagged fixed point
//!    above, so they help only while the guess is close;
//!
//! and the encoder, which runs this same code on the same decoded data,
//! chooses per frame the predictor that lands closest to the true frame,
//! records it in the frame chunk, and codes the remaining error as three
//! correction streams (closed-loop, like a video codec's motion-compensated
//! prediction). The decoder adds the decoded correction, so the error is
//! what the correction streams fail to code. Two ways to code them
//! ([`crate::format::CorrectionMode`]): *scaled*, each frame's error over
//! its largest value, flat at usual QPs, but when H.264 discards most of a
//! correction (pcow at QP 49) the error left over is extrapolated too, and
//! grows; or *motion*, the running sum of the errors at a fixed scale, so
//! that where the prediction was right the picture repeats the previous one
//! and H.264 skips the block almost for free, as it does for a geometry
//! video's still parts (docs/RESULTS.md compares the two).

use crate::error::{Error, Result};
pub use crate::format::{Extrapolation, PredictorCode, MAX_STEPS};
use crate::grid::stencil::Stencils;
use crate::solve::rigid;
use crate::solve::skinned::SkinnedPredictor;
use crate::sparse::Cholesky;
use glam::Vec3;

/// Weight of the anchor rows relative to the Laplacian rows (coefficients
/// about 1): large enough that the anchors hold to about 1e-4 of the step's
/// right-hand side, small enough that `LᵀL + w PᵀP` stays well conditioned.
pub const ANCHOR_WEIGHT: f64 = 1e4;
/// Fewer anchors than this cannot fix a rigid motion; the step then pulls
/// every sample towards the current guess with [`GUESS_WEIGHT`] (small
/// against the Laplacian rows, so it only removes the null space).
pub const MIN_ANCHORS: usize = 4;
pub const GUESS_WEIGHT: f64 = 1e-4;

/// Every extrapolation, for [`Predictor::closest`] (the skinned ones only
/// where the file has bones); rigid first, see [`MOTION_EXTRAPOLATIONS`].
pub const ALL_EXTRAPOLATIONS: [Extrapolation; 7] = [
    Extrapolation::Rigid,
    Extrapolation::Velocity,
    Extrapolation::SmoothVelocity,
    Extrapolation::Cycle,
    Extrapolation::Skinned,
    Extrapolation::SkinnedVelocity,
    Extrapolation::SkinnedSmoothVelocity,
];
/// The extrapolations that keep motion-mode correction streams (see
/// [`crate::format::CorrectionMode::Motion`]) within a range: those
/// streams carry the running sum of the corrections, which telescopes to a
/// change of velocity after velocity predictions but adds up whole
/// displacements after rigid ones (no anchors: the previous frame); the
/// range grew 1.3-2.3x on horse-gallop when rigid was allowed.
/// A cycle prediction keeps the running sum bounded too: it adds
/// v − v₋ₗ, a difference of two velocities; so does a skinned one, whose
/// running sum is what the bones leave of the motion since the last
/// random-access point. So: every extrapolation but rigid.
pub const MOTION_EXTRAPOLATIONS: &[Extrapolation] = ALL_EXTRAPOLATIONS.split_at(1).1;

/// The encoder's default longest lag: 2 s at 30 fps, enough for a gait or a
/// gallop cycle (the default motion's is 36 frames, horse-gallop's 24). A
/// file may ask for up to 255 (its FRAM byte); a decoder keeps the header's
/// `max_lag` smoothed velocities: at N = 256 and a lag of 60, 60 fields of
/// 786 KB.
pub const DEFAULT_MAX_LAG: u8 = 60;

/// Averaging passes that smooth the velocity field (each halves a sample's
/// own weight against its four neighbours' mean). Chosen by measurement on
/// the default motion; the encoder picks rigid, velocity or smoothed per frame.
pub const SMOOTHING_PASSES: usize = 8;

/// The decoder state shared by the encoder's closed loop and the decoder.
pub struct Predictor {
    st: Stencils,
    anchors: Vec<u32>,
    /// `LᵀL + w PᵀP`, factored when the first H step is asked for.
    chol: Option<Cholesky>,
    /// The last two decoded frames, newest first (`past[0]` is x₋₁).
    past: std::collections::VecDeque<Vec<Vec3>>,
    /// With `max_lag` > 0: the smoothed velocities S(x₋ₖ − x₋ₖ₋₁) of the
    /// decoded frames, newest (k = 1) first, at most `max_lag` of them.
    velocities: std::collections::VecDeque<Vec<Vec3>>,
    /// The anchors of x₋₁.
    prev_anchors: Vec<Vec3>,
    max_lag: u8,
    /// Tangential coefficients of the previous decoded frame (or the seed).
    a: Vec<f32>,
    b: Vec<f32>,
    /// Version 13: the file's bones.
    skin: Option<SkinnedPredictor>,
}

impl Predictor {
    pub fn new(st: Stencils, anchors: Vec<u32>) -> Predictor {
        Predictor {
            st,
            anchors,
            chol: None,
            past: Default::default(),
            velocities: Default::default(),
            prev_anchors: Vec::new(),
            max_lag: 0,
            a: Vec::new(),
            b: Vec::new(),
            skin: None,
        }
    }

    /// Allows skinned predictions with these bones (format version 13).
    pub fn with_skin(mut self, skin: Option<SkinnedPredictor>) -> Predictor {
        self.set_skin(skin);
        self
    }

    /// See [`with_skin`](Self::with_skin).
    pub fn set_skin(&mut self, skin: Option<SkinnedPredictor>) {
        self.skin = skin;
    }

    /// The bones, where skinned predictions have them.
    pub fn skin_mut(&mut self) -> Option<&mut SkinnedPredictor> {
        self.skin.as_mut()
    }

    /// Whether skinned predictions have their bones.
    pub fn has_skin(&self) -> bool {
        self.skin.is_some()
    }

    /// The decoder, at every frame of a file with bones: the bones'
    /// transforms from the frame's unit.
    pub fn decode_bones(&mut self, unit: &[u8]) -> Result<()> {
        let skin = self.skin.as_mut().ok_or_else(|| Error::Argument("bones in a file without a skin".into()))?;
        skin.decode(unit)
    }

    /// The encoder, at every frame of a file with bones, before the
    /// prediction: the bones' transforms fitted to `truth`, as the frame's
    /// unit (`None` without bones).
    pub fn encode_bones(&mut self, truth: &[Vec3]) -> Option<Vec<u8>> {
        self.skin.as_mut().map(|s| s.encode(truth))
    }

    /// Allows cycle predictions with lags up to `max_lag` (the header's
    /// `max_lag`): the predictor then keeps that many smoothed velocities.
    pub fn with_max_lag(mut self, max_lag: u8) -> Predictor {
        self.max_lag = max_lag;
        self
    }

    /// Forgets the decoded past, as at frame 0 (a random-access point); the
    /// factorization, which depends on the grid and anchors only, is kept.
    pub fn reset(&mut self) {
        self.past.clear();
        self.velocities.clear();
        self.prev_anchors.clear();
        self.a.clear();
        self.b.clear();
        if let Some(s) = &mut self.skin {
            s.reset();
        }
    }

    /// x₋₁ + S(x₋ₗ − x₋ₗ₋₁), if that far a past has been decoded.
    fn cycle(&self, lag: u8) -> Result<Vec<Vec3>> {
        match (self.past.front(), self.velocities.get((lag as usize).wrapping_sub(1))) {
            (Some(p), Some(v)) if lag >= 2 && lag <= self.max_lag => {
                Ok(p.iter().zip(v).map(|(p, d)| *p + *d).collect())
            }
            _ => Err(Error::Argument(format!(
                "a cycle prediction with lag {lag} after {} decoded frames (the file allows lags up to {})",
                self.velocities.len() + 1,
                self.max_lag
            ))),
        }
    }

    fn factor(&mut self) -> Result<&Cholesky> {
        if self.chol.is_none() {
            let n = self.st.grid.len();
            let mut entries = Vec::with_capacity(n * 25 + self.anchors.len());
            for v in 0..n {
                let s = self.st.nbr[v];
                let row = [(v as u32, 1.0), (s[0], -0.25), (s[1], -0.25), (s[2], -0.25), (s[3], -0.25)];
                for &(i, a) in &row {
                    for &(j, b) in &row {
                        if i >= j {
                            entries.push((i, j, a * b));
                        }
                    }
                }
            }
            for &a in &self.anchors {
                entries.push((a, a, ANCHOR_WEIGHT));
            }
            if self.anchors.len() < MIN_ANCHORS {
                // Too few anchors to fix the translation (and rotation):
                // pull gently towards the current guess instead.
                for v in 0..n as u32 {
                    entries.push((v, v, GUESS_WEIGHT));
                }
            }
            self.chol = Some(Cholesky::factor(n, &entries)?);
        }
        self.chol.as_ref().ok_or_else(|| Error::Numerical("no factorization".into()))
    }

    /// Step 1: the extrapolated guess. Frame 0 starts from `seed`.
    fn extrapolate(&self, code: PredictorCode, seed: Option<&[Vec3]>, anchors: &[Vec3]) -> Result<Vec<Vec3>> {
        let (prev, prev2) = (self.past.front(), self.past.get(1));
        match (prev, prev2, code.extrapolation) {
            (None, _, _) => seed.map(<[Vec3]>::to_vec).ok_or_else(|| Error::Argument("frame 0 needs the seed".into())),
            (Some(_), _, Extrapolation::Cycle) => self.cycle(code.lag),
            (Some(p), p2, e) if e.is_skinned() => self.skinned(e, p, p2),
            (Some(p), Some(p2), Extrapolation::Velocity) => Ok(p.iter().zip(p2).map(|(a, b)| *a * 2.0 - *b).collect()),
            (Some(p), Some(p2), Extrapolation::SmoothVelocity) => {
                // The same numbers as the stored velocity, when there is one.
                let v = match self.velocities.front() {
                    Some(v) => v.clone(),
                    None => self.smooth(p.iter().zip(p2).map(|(a, b)| *a - *b).collect()),
                };
                Ok(p.iter().zip(&v).map(|(a, d)| *a + *d).collect())
            }
            (Some(p), _, _) if self.anchors.len() < 3 => Ok(p.clone()),
            (Some(p), _, _) => {
                let m = rigid::fit(&self.prev_anchors, anchors);
                Ok(p.iter().map(|&q| m.apply(q)).collect())
            }
        }
    }

    /// A skinned extrapolation from x₋₁ = `p` and x₋₂ = `p2`.
    fn skinned(&self, e: Extrapolation, p: &[Vec3], p2: Option<&Vec<Vec3>>) -> Result<Vec<Vec3>> {
        let skin = self.skin.as_ref().ok_or_else(|| Error::Argument("a skinned prediction without bones".into()))?;
        let mut x: Vec<Vec3> = p.iter().zip(skin.motion()?).map(|(p, d)| *p + d).collect();
        if e != Extrapolation::Skinned {
            let (Some(p2), Some(m1)) = (p2, skin.previous_motion()) else {
                return Err(Error::Argument("a skinned velocity without two frames since the point".into()));
            };
            // What the bones missed of the last frame's motion.
            let missed: Vec<Vec3> = p.iter().zip(p2).zip(&m1).map(|((a, b), m)| *a - *b - *m).collect();
            let missed = if e == Extrapolation::SkinnedSmoothVelocity { self.smooth(missed) } else { missed };
            x.iter_mut().zip(&missed).for_each(|(x, d)| *x += *d);
        }
        Ok(x)
    }

    /// A velocity field after [`SMOOTHING_PASSES`] averaging passes.
    fn smooth(&self, v: Vec<Vec3>) -> Vec<Vec3> {
        self.st.smooth(v, SMOOTHING_PASSES)
    }

    /// Step 2: one mean-curvature step from `x`.
    fn step(&mut self, x: &mut [Vec3], h: &[f32], anchors: &[Vec3]) -> Result<()> {
        let n = self.st.grid.len();
        if self.a.len() != n {
            // The last decoded frame's tangential coefficients, taken here
            // rather than at each commit since only H steps use them; at
            // frame 0, the seed's own.
            let f = self.st.features(self.past.front().map_or(&*x, Vec::as_slice));
            (self.a, self.b) = (f.a, f.b);
        }
        let mut rhs = vec![0.0f64; 3 * n];
        for v in 0..n {
            let (xu, xv) = self.st.tangents(x, v);
            let d = xu.cross(xv).normalize_or_zero() * h[v] + xu * self.a[v] + xv * self.b[v];
            let s = self.st.nbr[v];
            for c in 0..3 {
                let dc = d[c] as f64;
                rhs[c * n + v] += dc;
                for &u in &s {
                    rhs[c * n + u as usize] -= 0.25 * dc;
                }
            }
        }
        for (&i, p) in self.anchors.iter().zip(anchors) {
            for c in 0..3 {
                rhs[c * n + i as usize] += ANCHOR_WEIGHT * p[c] as f64;
            }
        }
        if self.anchors.len() < MIN_ANCHORS {
            for (v, p) in x.iter().enumerate() {
                for c in 0..3 {
                    rhs[c * n + v] += GUESS_WEIGHT * p[c] as f64;
                }
            }
        }
        self.factor()?.solve(&mut rhs, 3)?;
        for (v, p) in x.iter_mut().enumerate() {
            *p = Vec3::new(rhs[v] as f32, rhs[n + v] as f32, rhs[2 * n + v] as f32);
        }
        if x.iter().any(|p| !p.is_finite()) {
            return Err(Error::Numerical("mean-curvature step produced a non-finite position".into()));
        }
        Ok(())
    }

    fn check(&self, h: Option<&[f32]>, anchors: &[Vec3]) -> Result<()> {
        if h.is_some_and(|h| h.len() != self.st.grid.len()) || anchors.len() != self.anchors.len() {
            return Err(Error::Argument("frame data does not match the grid or the anchors".into()));
        }
        Ok(())
    }

    /// The prediction of the next frame with predictor `code`. `h` may be
    /// absent (motion-corrected files leave it out) when `code` takes no
    /// mean-curvature step.
    pub fn predict(
        &mut self,
        code: PredictorCode,
        seed: Option<&[Vec3]>,
        h: Option<&[f32]>,
        anchors: &[Vec3],
    ) -> Result<Vec<Vec3>> {
        self.check(h, anchors)?;
        let mut x = self.extrapolate(code, seed, anchors)?;
        if code.steps > 0 {
            let h = h.ok_or_else(|| Error::Argument("a mean-curvature step without H".into()))?;
            for _ in 0..code.steps {
                self.step(&mut x, h, anchors)?;
            }
        }
        Ok(x)
    }

    /// The prediction closest to `truth`, what the encoder predicts a frame
    /// with, among: every extrapolation in `allowed` (rigid alone while
    /// there are fewer than two past frames; a cycle with every lag the
    /// decoded past and `max_lag` allow), then, with `h`,
    /// 1..=`max_steps` H steps from the extrapolation closest to `truth`
    /// (steps cost a sparse solve each; from the other extrapolations they
    /// were never measured to win). On a tie the earlier candidate wins.
    #[allow(clippy::too_many_arguments)]
    pub fn closest(
        &mut self,
        allowed: &[Extrapolation],
        max_steps: u8,
        seed: Option<&[Vec3]>,
        h: Option<&[f32]>,
        anchors: &[Vec3],
        truth: &[Vec3],
    ) -> Result<(PredictorCode, Vec<Vec3>)> {
        use Extrapolation::*;
        self.check(h, anchors)?;
        // Without two past frames every extrapolation is the rigid one,
        // but for the bones, which need one.
        let extrapolations: &[Extrapolation] =
            if self.past.len() >= 2 && !allowed.is_empty() { allowed } else { &[Rigid, Skinned] };
        let mut best: Option<(f64, PredictorCode, Vec<Vec3>)> = None;
        for &extrapolation in extrapolations {
            let code = match extrapolation {
                e if e.is_skinned() => match &self.skin {
                    Some(skin) if allowed.contains(&e) && skin.ready() => {
                        if e != Skinned && !skin.has_previous_motion() {
                            continue;
                        }
                        PredictorCode::plain(e)
                    }
                    _ => continue,
                },
                // The lag is found without building each prediction.
                Cycle => match self.closest_lag(truth) {
                    Some(lag) => PredictorCode { lag, ..PredictorCode::plain(Cycle) },
                    None => continue,
                },
                _ => PredictorCode::plain(extrapolation),
            };
            let x = self.extrapolate(code, seed, anchors)?;
            let e = squared_distance(&x, truth);
            if best.as_ref().is_none_or(|b| e < b.0) {
                best = Some((e, code, x));
            }
        }
        let (mut error, mut code, mut x) = best.ok_or_else(|| Error::Numerical("no prediction".into()))?;
        if let Some(h) = h {
            let base = code;
            let mut y = x.clone();
            for steps in 1..=max_steps.min(MAX_STEPS) {
                self.step(&mut y, h, anchors)?;
                let e = squared_distance(&y, truth);
                if e < error {
                    (error, code, x) = (e, PredictorCode { steps, ..base }, y.clone());
                }
            }
        }
        Ok((code, x))
    }

    /// The lag whose cycle prediction lands closest to `truth` (the
    /// shortest on a tie), if the decoded past allows any.
    fn closest_lag(&self, truth: &[Vec3]) -> Option<u8> {
        let p = self.past.front()?;
        let longest = (self.max_lag as usize).min(self.velocities.len());
        let mut best: Option<(f64, u8)> = None;
        for l in 2..=longest {
            let bound = best.map_or(f64::INFINITY, |b| b.0);
            match lag_error_below(truth, p, &self.velocities[l - 1], bound) {
                Some(e) if best.is_none_or(|b| e < b.0) => best = Some((e, l as u8)),
                _ => {}
            }
        }
        best.map(|b| b.1)
    }

    /// Records the decoded frame (prediction plus correction).
    pub fn commit(&mut self, x: Vec<Vec3>, anchors: &[Vec3]) {
        // Its a, b are taken when a step first needs them.
        self.a.clear();
        self.b.clear();
        if let (true, Some(p)) = (self.max_lag > 0, self.past.front()) {
            let v = self.smooth(x.iter().zip(p).map(|(a, b)| *a - *b).collect());
            self.velocities.push_front(v);
            self.velocities.truncate(self.max_lag as usize);
        }
        if let Some(s) = &mut self.skin {
            s.commit(&x);
        }
        self.past.push_front(x);
        self.past.truncate(2);
        self.prev_anchors = anchors.to_vec();
    }
}

/// The squared distance of `p + v` to `truth`, if it is below `bound`.
/// The sum only grows, so a lag is dropped as soon as a block of samples
/// takes it past the best so far (most lags are, early); the sum kept is the
/// one a single pass gives, so the same lag wins.
fn lag_error_below(truth: &[Vec3], p: &[Vec3], v: &[Vec3], bound: f64) -> Option<f64> {
    const BLOCK: usize = 2048;
    let mut e = 0.0f64;
    for ((t, p), v) in truth.chunks(BLOCK).zip(p.chunks(BLOCK)).zip(v.chunks(BLOCK)) {
        e = t.iter().zip(p.iter().zip(v)).fold(e, |e, (t, (p, v))| e + (*p + *v).distance_squared(*t) as f64);
        if e >= bound {
            return None;
        }
    }
    Some(e)
}

/// Sum of squared distances between corresponding points.
pub fn squared_distance(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter().zip(b).map(|(p, q)| p.distance_squared(*q) as f64).sum()
}

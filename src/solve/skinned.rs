//! The skinned extrapolation (format version 13): linear blend skinning as
//! the closed loop's motion predictor, as MPEG-4 FAMC predicts a mesh's
//! motion by its skinning and codes the residual (Mamou, Zaharia and
//! Prêteux 2009). Each bone has a weight field on the grid (the `SKIN`
//! chunk's coarse weights expanded bilinearly, the four largest kept) and,
//! every frame, a rigid transform M_b from the segment's rest pose (the
//! decoded frame at its random-access point) about the bone's weighted
//! centroid c_b there. Skinning gives L_t = Σ_b w_vb M_bt(r_v), and the
//! prediction is
//!
//! x̂_t = x₋₁ + L_t − L_{t−1},
//!
//! the previous decoded frame moved as the bones move (`Extrapolation::Skinned`;
//! `SkinnedVelocity` and `SkinnedSmoothVelocity` add what the bones missed
//! of the last frame's motion, as the velocity predictors do): with no correction
//! at all the decoded motion is the skinning itself (an error bounded by
//! the decomposition's), and the motion corrections' running sum is what
//! the bones leave, x − L, bounded too. The encoder fits the bones'
//! transforms to the true frame by SSDR's transform update (Le and Deng
//! 2012: each bone's weighted rigid fit, Kabsch 1976, to what the others
//! leave), quantizes them in the header's steps, and every frame of the
//! file carries them (a frame predicted otherwise still needs L_t for the
//! next one).
//!
//! Version 17 puts the same bones on the source mesh's vertices
//! ([`SkinnedPredictor::on_vertices`]): the rest pose is the file's, fixed
//! across random-access points, and L_t itself is the prediction, to which
//! the grid's residual adds (`crate::codec::SourceMeshDecoder::vertices`).

use crate::error::{Error, Result};
use crate::format::skin::{coarse_side, Motion, INFLUENCES, MOTION_PARAMS};
use crate::format::{BoneMotions, SkinInfo, SkinWeights};
use crate::grid::{coarse, Grid};
use crate::skin::{procrustes, BoneTransform};
use glam::{Mat3, Quat, Vec3};

/// Sweeps of the encoder's transform fit over the bones. On samba (N =
/// 128, 32 bones, the bones alone): 2 sweeps 0.447 % vertex RMS, 6 0.346 %,
/// 12 0.340 %.
pub const FIT_SWEEPS: usize = 6;
/// The fit reads every this many samples each way on grids of 64 and up.
pub const FIT_STRIDE: usize = 2;

/// The decoder's bones: weights on the grid, the segment's rest pose, and
/// the transforms of the last frames.
#[derive(Clone)]
pub struct SkinnedPredictor {
    info: SkinInfo,
    /// Each grid sample's bones and weights (summing to one).
    influences: Vec<[(u16, f32); INFLUENCES]>,
    /// The samples the encoder's fit reads, and each bone's among them
    /// with their weights.
    fitted: Vec<u32>,
    members: Vec<Vec<(u32, f32)>>,
    /// The segment's rest pose and its bones' centroids (none until the
    /// random-access point's frame is decoded).
    rest: Option<(Vec<Vec3>, Vec<Vec3>)>,
    /// The transforms of the two frames before this one (identity at the
    /// random-access point): a frame's unit codes the difference from
    /// their linear extrapolation.
    history: [Vec<Motion>; 2],
    /// L of the two frames before this one (newest first), and of this one
    /// once its transforms are known.
    last_skinned: std::collections::VecDeque<Vec<Vec3>>,
    skinned: Option<Vec<Vec3>>,
    /// Version 17: the rest pose is the file's (bones on the vertices),
    /// kept across random-access points.
    fixed_rest: bool,
    /// Version 21: the grid the weights are on, and the `SKIN` chunk's
    /// influences, which a random-access point without weights of its own
    /// goes back to (none unless the header's `point_weights`).
    coarse: Grid,
    chunk_influences: Option<Vec<[(u16, f32); INFLUENCES]>>,
    /// The encoder's version 21 units, one per random-access point in
    /// order (empty: the `SKIN` chunk's weights), and the next one's index.
    point_units: Vec<Vec<u8>>,
    next_point: usize,
}

impl SkinnedPredictor {
    /// The bones of a file with `info` and `weights` on grid `grid`.
    pub fn new(grid: Grid, info: &SkinInfo, weights: &SkinWeights) -> Result<SkinnedPredictor> {
        let side = info.check(grid.n as u32).map_err(Error::Argument)?;
        if weights.influences.len() != side * side || coarse_side(grid.n, info.shrink) != Some(side) {
            return Err(Error::Argument(format!("{} skin weights for a {side}² grid", weights.influences.len())));
        }
        let influences = expand(Grid { n: side }, info, weights);
        // The fit reads every FIT_STRIDE-th sample each way: 6 unknowns a
        // bone need no more, and it is 4x faster.
        let stride = if grid.n >= 64 { FIT_STRIDE } else { 1 };
        let fitted: Vec<u32> = (0..grid.len() as u32)
            .filter(|&v| (v as usize % grid.n) % stride == 0 && (v as usize / grid.n) % stride == 0)
            .collect();
        let mut p = SkinnedPredictor::with(info, influences, fitted, false)?;
        p.coarse = Grid { n: side };
        p.chunk_influences = info.point_weights.then(|| p.influences.clone());
        Ok(p)
    }

    /// Version 21, the encoder: the unit each random-access point will
    /// carry, in order (empty: the `SKIN` chunk's weights; else packed
    /// weights, [`SkinWeights::to_bytes`]). Each is read back as a decoder
    /// reads it.
    pub fn set_point_units(&mut self, units: Vec<Vec<u8>>) -> Result<()> {
        for unit in units.iter().filter(|u| !u.is_empty()) {
            self.point_influences(unit)?;
        }
        (self.point_units, self.next_point) = (units, 0);
        Ok(())
    }

    /// A random-access point's weights unit as the grid's influences.
    fn point_influences(&self, unit: &[u8]) -> Result<Vec<[(u16, f32); INFLUENCES]>> {
        if !self.info.point_weights {
            return Err(Error::Argument("a bones unit at a random-access point of a file without its weights".into()));
        }
        let weights = SkinWeights::parse(unit, &self.info, self.coarse.len(), 0)
            .map_err(|e| Error::Argument(format!("a random-access point's {e}")))?;
        Ok(expand(self.coarse, &self.info, &weights))
    }

    /// Takes `influences` as every sample's bones and weights.
    fn use_influences(&mut self, influences: Vec<[(u16, f32); INFLUENCES]>) -> Result<()> {
        self.members = members(&self.info, &influences, &self.fitted)?;
        self.influences = influences;
        Ok(())
    }

    /// Version 17: bones on the source mesh's vertices, `weights` holding
    /// each vertex's bones and rest position. The rest pose is fixed, so
    /// every frame's unit codes its transforms from it.
    pub fn on_vertices(info: &SkinInfo, weights: &SkinWeights) -> Result<SkinnedPredictor> {
        let step = info.rest_step.ok_or_else(|| Error::Argument("bones on the grid, not on the vertices".into()))?;
        let n = weights.influences.len();
        if weights.rest.len() != n || n == 0 {
            return Err(Error::Argument(format!("{} rest positions for {n} skinned vertices", weights.rest.len())));
        }
        let influences: Vec<[(u16, f32); INFLUENCES]> = weights.influences.iter().map(normalized).collect();
        let rest: Vec<Vec3> = weights.rest.iter().map(|p| Vec3::from(p.map(|x| x as f32)) * step).collect();
        let mut p = SkinnedPredictor::with(info, influences, (0..n as u32).collect(), true)?;
        let c = p.centroids(&rest);
        p.rest = Some((rest, c));
        Ok(p)
    }

    /// The bones of `info` with each sample's `influences`, the fit reading
    /// the `fitted` samples; no rest pose yet.
    fn with(
        info: &SkinInfo,
        influences: Vec<[(u16, f32); INFLUENCES]>,
        fitted: Vec<u32>,
        fixed_rest: bool,
    ) -> Result<SkinnedPredictor> {
        let members = members(info, &influences, &fitted)?;
        let identity = vec![[0; MOTION_PARAMS]; info.bones as usize];
        Ok(SkinnedPredictor {
            info: *info,
            influences,
            fitted,
            members,
            rest: None,
            history: [identity.clone(), identity],
            last_skinned: Default::default(),
            skinned: None,
            fixed_rest,
            coarse: Grid { n: 0 },
            chunk_influences: None,
            point_units: Vec::new(),
            next_point: 0,
        })
    }

    pub fn bones(&self) -> usize {
        self.info.bones as usize
    }

    /// Forgets the segment (a random-access point), and its own weights
    /// (version 21) for the `SKIN` chunk's.
    pub fn reset(&mut self) {
        if !self.fixed_rest {
            self.rest = None;
        }
        if let Some(chunk) = self.chunk_influences.as_ref().filter(|c| **c != self.influences) {
            self.members = members(&self.info, chunk, &self.fitted).unwrap_or_default();
            self.influences = chunk.clone();
        }
        self.last_skinned.clear();
        self.history.iter_mut().flatten().for_each(|m| *m = [0; MOTION_PARAMS]);
        self.skinned = None;
    }

    /// Each bone's weighted centroid in `x` (the origin for a bone no
    /// sample follows).
    fn centroids(&self, x: &[Vec3]) -> Vec<Vec3> {
        let mut sum = vec![(Vec3::ZERO, 0.0f32); self.bones()];
        for (p, inf) in x.iter().zip(&self.influences) {
            for &(b, w) in inf {
                let s = &mut sum[b as usize];
                (s.0, s.1) = (s.0 + w * *p, s.1 + w);
            }
        }
        sum.into_iter().map(|(p, w)| if w > 0.0 { p / w } else { Vec3::ZERO }).collect()
    }

    /// The encoder: the quantized transforms whose skinning of the rest
    /// pose lands closest to `truth`, by SSDR's transform update (Le and
    /// Deng 2012, section 4.2: each bone's weighted rigid fit to what the
    /// other bones leave), [`FIT_SWEEPS`] sweeps from the last frame's
    /// transforms; `None` at the random-access point itself.
    fn fit(&self, truth: &[Vec3], start: Option<&[BoneTransform]>) -> Option<Vec<Motion>> {
        let (rest, c) = self.rest.as_ref()?;
        // Each bone's transform as x ↦ R (x − c) + T, from `start` (maps of
        // space, x ↦ R x + t) or the last frame's.
        let mut m: Vec<BoneTransform> = match start.filter(|s| s.len() == c.len()) {
            Some(s) => s
                .iter()
                .zip(c)
                .map(|(s, &cb)| BoneTransform { linear: s.linear, translation: s.linear * cb + s.translation })
                .collect(),
            None => self.history[0]
                .iter()
                .zip(c)
                .map(|(q, &cb)| {
                    let (r, t) = self.dequantize(q);
                    BoneTransform { linear: r, translation: cb + t }
                })
                .collect(),
        };
        let apply = |m: &BoneTransform, v: usize, b: usize| m.apply(rest[v] - c[b]);
        // Only the fitted samples' residuals are read.
        let mut residual: Vec<Vec3> = truth.to_vec();
        for &v in &self.fitted {
            let v = v as usize;
            for &(b, w) in &self.influences[v] {
                residual[v] -= w * apply(&m[b as usize], v, b as usize);
            }
        }
        for _ in 0..FIT_SWEEPS {
            for (b, group) in self.members.iter().enumerate().filter(|(_, g)| !g.is_empty()) {
                let old = m[b];
                let q = |&(v, w): &(u32, f32)| {
                    let v = v as usize;
                    (rest[v] - c[b], residual[v] + w * apply(&old, v, b), w)
                };
                m[b] = procrustes::fit(group.iter().map(q));
                for &(v, w) in group {
                    let v = v as usize;
                    residual[v] += w * (apply(&old, v, b) - apply(&m[b], v, b));
                }
            }
        }
        Some(m.iter().zip(c).map(|(m, &cb)| self.quantize(m, cb)).collect())
    }

    /// A transform about centroid `cb` in the header's steps: rotation
    /// vector and translation.
    fn quantize(&self, m: &BoneTransform, cb: Vec3) -> Motion {
        let q = |v: f32| v.round().clamp(-1e9, 1e9) as i32;
        let r = Quat::from_mat3(&m.linear).to_scaled_axis() / self.info.rotation_step;
        let t = (m.translation - cb) / self.info.translation_step;
        [q(r.x), q(r.y), q(r.z), q(t.x), q(t.y), q(t.z)]
    }

    /// A transform's rotation and translation (about the bone's centroid).
    fn dequantize(&self, m: &Motion) -> (Mat3, Vec3) {
        let axis = Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32) * self.info.rotation_step;
        let t = Vec3::new(m[3] as f32, m[4] as f32, m[5] as f32) * self.info.translation_step;
        (Mat3::from_quat(Quat::from_scaled_axis(axis)), t)
    }

    /// The transforms' prediction: 2 M₋₁ − M₋₂, parameter by parameter.
    fn expected(&self) -> Vec<Motion> {
        let [m1, m2] = &self.history;
        m1.iter().zip(m2).map(|(a, b)| std::array::from_fn(|k| a[k].saturating_mul(2).saturating_sub(b[k]))).collect()
    }

    /// The encoder, at every frame: fits this frame's transforms to `truth`
    /// and returns its bones unit (at a random-access point: empty, or
    /// version 21's weights of its own).
    pub fn encode(&mut self, truth: &[Vec3]) -> Vec<u8> {
        self.encode_from(truth, None)
    }

    /// [`encode`](Self::encode) with the fit starting from `start` (each
    /// bone's map of space, a decomposition's) rather than the last
    /// frame's transforms: a whole-motion fit's transforms are closer than
    /// a few sweeps from the last frame reach where the bones pull on each
    /// other (pcow, 24 bones: 0.72 % vertex RMS from the last frame's).
    pub fn encode_from(&mut self, truth: &[Vec3], start: Option<&[BoneTransform]>) -> Vec<u8> {
        match self.fit(truth, start) {
            Some(m) => {
                let unit = BoneMotions::to_bytes(&m, &self.expected(), self.info.packed);
                self.set(m);
                unit
            }
            None => {
                // A random-access point: its weights, if it has its own
                // (checked by `set_point_units`).
                let unit = self.point_units.get(self.next_point).cloned().unwrap_or_default();
                self.next_point += 1;
                match self.decode(&unit) {
                    Ok(()) => unit,
                    Err(_) => Vec::new(),
                }
            }
        }
    }

    /// The decoder, at every frame: this frame's transforms from its unit,
    /// or at a random-access point its weights (version 21) if any.
    pub fn decode(&mut self, unit: &[u8]) -> Result<()> {
        match (self.rest.is_some(), unit.is_empty()) {
            (false, true) => Ok(()),
            (false, false) if self.info.point_weights => {
                let influences = self.point_influences(unit)?;
                self.use_influences(influences)
            }
            (true, false) => {
                let m = BoneMotions::parse(unit, &self.expected(), 0, self.info.packed)
                    .map_err(|e| Error::Argument(e.to_string()))?;
                self.set(m);
                Ok(())
            }
            _ => Err(Error::Argument("a bones unit where the segment has none, or none where it needs one".into())),
        }
    }

    /// Takes `m` as this frame's transforms: skins the rest pose with them.
    fn set(&mut self, m: Vec<Motion>) {
        self.skinned = self.skin_with(&m);
        self.history.swap(0, 1);
        self.history[0] = m;
    }

    /// The rest pose skinned by `m` (one motion a bone; none before the
    /// rest pose is known): the one rule the decoder and the encoder's
    /// residual both use.
    pub fn skin_with(&self, m: &[Motion]) -> Option<Vec<Vec3>> {
        let (rest, c) = self.rest.as_ref()?;
        let moves: Vec<(Mat3, Vec3, Vec3)> = m
            .iter()
            .zip(c)
            .map(|(m, &cb)| {
                let (r, t) = self.dequantize(m);
                (r, cb, cb + t)
            })
            .collect();
        Some(
            rest.iter()
                .zip(&self.influences)
                .map(|(&p, inf)| {
                    inf.iter()
                        .filter_map(|&(b, w)| moves.get(b as usize).map(|(r, from, to)| w * (*r * (p - *from) + *to)))
                        .sum()
                })
                .collect(),
        )
    }

    /// This frame's motions, as its unit coded them (identity at a
    /// random-access point of a segment's own rest pose).
    pub fn motions(&self) -> &[Motion] {
        &self.history[0]
    }

    /// This frame's transforms as maps of space (x ↦ M (x − c) + c + t),
    /// once known.
    pub fn transforms(&self) -> Option<Vec<BoneTransform>> {
        let (_, c) = self.rest.as_ref()?;
        self.skinned.as_ref()?;
        Some(
            self.history[0]
                .iter()
                .zip(c)
                .map(|(m, &cb)| {
                    let (linear, t) = self.dequantize(m);
                    BoneTransform { linear, translation: cb + t - linear * cb }
                })
                .collect(),
        )
    }

    /// The rest pose the bones move (the segment's, or version 17's file's).
    pub fn rest(&self) -> Option<&[Vec3]> {
        self.rest.as_ref().map(|r| &r.0[..])
    }

    /// Each grid sample's (or version 17's vertex's) bones and weights.
    pub fn influences(&self) -> &[[(u16, f32); INFLUENCES]] {
        &self.influences
    }

    /// This frame's skinning L_t on the grid, once its transforms are known.
    pub fn skinned(&self) -> Option<&[Vec3]> {
        self.skinned.as_deref()
    }

    /// Whether this frame's transforms are known (not at a random-access
    /// point).
    pub fn ready(&self) -> bool {
        self.skinned.is_some()
    }

    /// How the bones move from the previous frame to this one, L_t − L_{t−1},
    /// once this frame's transforms are known.
    pub fn motion(&self) -> Result<Vec<Vec3>> {
        match (&self.skinned, self.last_skinned.front()) {
            (Some(l), Some(l1)) => Ok(l.iter().zip(l1).map(|(a, b)| *a - *b).collect()),
            _ => Err(Error::Argument("a skinned prediction before the frame's bones".into())),
        }
    }

    /// Whether [`previous_motion`](Self::previous_motion) has one.
    pub fn has_previous_motion(&self) -> bool {
        self.last_skinned.len() >= 2
    }

    /// How the bones moved into the previous frame, L_{t−1} − L_{t−2}, if
    /// that frame was not the random-access point.
    pub fn previous_motion(&self) -> Option<Vec<Vec3>> {
        match (self.last_skinned.front(), self.last_skinned.get(1)) {
            (Some(a), Some(b)) => Some(a.iter().zip(b).map(|(a, b)| *a - *b).collect()),
            _ => None,
        }
    }

    /// Records the decoded frame: the rest pose at a random-access point,
    /// else this frame's L as the previous one's.
    pub fn commit(&mut self, x: &[Vec3]) {
        match (&self.rest, self.skinned.take()) {
            (None, _) => {
                self.rest = Some((x.to_vec(), self.centroids(x)));
                self.last_skinned = [x.to_vec()].into();
            }
            (Some(_), Some(l)) => {
                self.last_skinned.push_front(l);
                self.last_skinned.truncate(2);
            }
            (Some(_), None) => {}
        }
    }
}

/// Each bone's `fitted` samples with their weights.
fn members(info: &SkinInfo, influences: &[[(u16, f32); INFLUENCES]], fitted: &[u32]) -> Result<Vec<Vec<(u32, f32)>>> {
    let mut members = vec![Vec::new(); info.bones as usize];
    for &v in fitted {
        for &(b, w) in influences[v as usize].iter().filter(|i| i.1 > 0.0) {
            let group = members.get_mut(b as usize);
            group.ok_or_else(|| Error::Argument(format!("sample {v} names bone {b} of {}", info.bones)))?.push((v, w));
        }
    }
    Ok(members)
}

/// A sample's byte weights out of their sum.
fn normalized(inf: &[(u8, u8); INFLUENCES]) -> [(u16, f32); INFLUENCES] {
    let total: f32 = inf.iter().map(|p| f32::from(p.1)).sum();
    inf.map(|(b, w)| (u16::from(b), if total > 0.0 { f32::from(w) / total } else { 0.0 }))
}

/// The coarse weights on the full grid: each bone's field expanded
/// bilinearly (`grid::coarse`), each sample's four largest kept and
/// scaled to sum to one.
fn expand(coarse_grid: Grid, info: &SkinInfo, weights: &SkinWeights) -> Vec<[(u16, f32); INFLUENCES]> {
    // Each coarse sample's weights out of their sum.
    let coarse_weights: Vec<[(u16, f32); INFLUENCES]> = weights.influences.iter().map(normalized).collect();
    // One bone's field at a time (a file may have 255 bones on a large
    // grid), each sample keeping its four largest (ties: the lower bone).
    let n = (coarse_grid.n << info.shrink).pow(2);
    let mut best = vec![[(0u16, 0.0f32); INFLUENCES]; n];
    for b in 0..info.bones {
        let field: Vec<f32> =
            coarse_weights.iter().map(|inf| inf.iter().filter(|p| p.0 == b && p.1 > 0.0).map(|p| p.1).sum()).collect();
        for (top, &w) in best.iter_mut().zip(&coarse::expand(coarse_grid, &field, info.shrink)) {
            if let Some(k) = top.iter().position(|p| w > p.1) {
                top[k..].rotate_right(1);
                top[k] = (b, w);
            }
        }
    }
    best.into_iter()
        .map(|top| {
            let total: f32 = top.iter().map(|p| p.1).sum();
            top.map(|(b, w)| (b, if total > 0.0 { w / total } else { 0.0 }))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// Two bones with weights on the grid halved twice, packed.
    fn two_bones(point_weights: bool) -> SkinInfo {
        SkinInfo {
            bones: 2,
            shrink: 2,
            rotation_step: 1e-4,
            translation_step: 1e-4,
            packed: true,
            rest_step: None,
            point_weights,
        }
    }

    /// Two bones, left and right halves of a grid of points: a frame where
    /// the right half turns is predicted within the quantizer's reach, and
    /// the decoder gets the same transforms from the unit.
    #[test]
    fn a_two_bone_motion_is_fitted_and_replayed() {
        let grid = Grid::new(16).unwrap();
        let info = two_bones(false);
        let side = 4;
        let influences = (0..side * side).map(|k| [((k % side >= 2) as u8, 255), (0, 0), (0, 0), (0, 0)]).collect();
        let weights = SkinWeights { influences, ..Default::default() };
        let mut enc = SkinnedPredictor::new(grid, &info, &weights).unwrap();
        let mut dec = enc.clone();
        let rest: Vec<Vec3> =
            (0..256).map(|k| Vec3::new((k % 16) as f32 / 16.0, (k / 16) as f32 / 16.0, 0.0)).collect();
        // Bone 0 still, bone 1 turned and moved: a skinning with the
        // predictor's own weights.
        let turn = Mat3::from_rotation_z(0.1);
        let moved = |b: u16, p: Vec3| if b == 1 { turn * p + Vec3::new(0.0, 0.05, 0.0) } else { p };
        let truth: Vec<Vec3> =
            rest.iter().zip(&enc.influences).map(|(&p, inf)| inf.iter().map(|&(b, w)| w * moved(b, p)).sum()).collect();
        for s in [&mut enc, &mut dec] {
            s.commit(&rest);
        }
        let unit = enc.encode(&truth);
        dec.decode(&unit).unwrap();
        // The transforms as maps of space give the skinning back.
        let (t, l) = (enc.transforms().unwrap(), enc.skinned().unwrap());
        for (v, inf) in enc.influences().iter().enumerate() {
            let p: Vec3 = inf.iter().map(|&(b, w)| w * t[b as usize].apply(rest[v])).sum();
            assert!(p.distance(l[v]) < 1e-5, "{p} against {}", l[v]);
        }
        let (m, n) = (enc.motion().unwrap(), dec.motion().unwrap());
        assert_eq!(m, n);
        let x: Vec<Vec3> = rest.iter().zip(&m).map(|(p, d)| *p + *d).collect();
        // Within the quantizer's reach (1e-4 rad and units) of the truth.
        let worst = x.iter().zip(&truth).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
        assert!(worst < 1e-3, "{worst}");
        assert!(dec.decode(&[]).is_err(), "a frame after the rest needs its bones");
    }

    /// Version 21: a random-access point's own weights replace the `SKIN`
    /// chunk's for its segment, in the encoder as in the decoder that
    /// reads its unit; the next point without weights of its own goes back
    /// to the chunk's; a file without `point_weights` refuses such a unit.
    #[test]
    fn a_points_own_weights_hold_for_its_segment() {
        let grid = Grid::new(16).unwrap();
        let info = two_bones(true);
        let halves = |right: u8| SkinWeights {
            influences: (0..16).map(|k| [(u8::from(k % 4 >= 2) ^ right, 255), (0, 0), (0, 0), (0, 0)]).collect(),
            ..Default::default()
        };
        let (chunk, own) = (halves(0), halves(1).to_bytes(&info));
        let mut enc = SkinnedPredictor::new(grid, &info, &chunk).unwrap();
        let mut dec = enc.clone();
        enc.set_point_units(vec![Vec::new(), own.clone(), Vec::new()]).unwrap();
        let first = enc.influences().to_vec();
        let rest: Vec<Vec3> = (0..256).map(|k| Vec3::new((k % 16) as f32, (k / 16) as f32, 0.0)).collect();
        for point in 0..3 {
            for s in [&mut enc, &mut dec] {
                s.reset();
            }
            let unit = enc.encode(&rest);
            assert_eq!(unit.is_empty(), point != 1, "point {point}");
            dec.decode(&unit).unwrap();
            assert_eq!(enc.influences(), dec.influences(), "point {point}");
            assert_eq!(enc.influences() == first, point != 1, "point {point}");
            // Sample 0 is on the left half: bone 0 of the chunk's, 1 of the point's.
            assert_eq!(enc.influences()[0][0].0, u16::from(point == 1));
        }
        let plain = SkinInfo { point_weights: false, ..info };
        let mut old = SkinnedPredictor::new(grid, &plain, &chunk).unwrap();
        assert!(old.decode(&own).is_err() && old.set_point_units(vec![own]).is_err());
        assert!(dec.decode(&[1, 2, 3]).is_err(), "a unit that is no weights");
    }

    /// Version 17: bones on vertices keep the file's rest pose through a
    /// random-access point; every frame, that one too, has its unit, and
    /// the decoder's skinning is the encoder's.
    #[test]
    fn bones_on_vertices_keep_their_rest_pose() {
        let info = SkinInfo {
            bones: 2,
            shrink: 0,
            rotation_step: 1e-4,
            translation_step: 1e-4,
            packed: true,
            rest_step: Some(1e-3),
            point_weights: false,
        };
        let rest: Vec<[i32; 3]> = (0..64).map(|k| [(k % 8) * 100, (k / 8) * 100, 0]).collect();
        let influences = (0..64).map(|k| [((k % 8 >= 4) as u8, 255), (0, 0), (0, 0), (0, 0)]).collect();
        let weights = SkinWeights { influences, rest };
        let mut enc = SkinnedPredictor::on_vertices(&info, &weights).unwrap();
        let mut dec = enc.clone();
        assert!(SkinnedPredictor::on_vertices(&SkinInfo { rest_step: None, ..info }, &weights).is_err());
        let turn = Mat3::from_rotation_z(0.2);
        let truth: Vec<Vec3> = weights
            .rest
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let x = Vec3::from(p.map(|c| c as f32)) * 1e-3;
                if k % 8 >= 4 {
                    turn * x + Vec3::Y * 0.1
                } else {
                    x
                }
            })
            .collect();
        for _ in 0..2 {
            let unit = enc.encode(&truth);
            assert!(!unit.is_empty());
            dec.decode(&unit).unwrap();
            assert_eq!(enc.skinned(), dec.skinned());
            let worst = dec.skinned().unwrap().iter().zip(&truth).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
            assert!(worst < 1e-3, "{worst}");
            // A random-access point: the rest pose stays, the history goes.
            enc.reset();
            dec.reset();
        }
        assert!(dec.decode(&[]).is_err(), "every frame has its bones");
    }
}

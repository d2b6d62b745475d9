//! Area correction, as passes that can be paused and resumed: the stretch
//! minimization of Yoshizawa, Belyaev & Seidel ("A fast and simple
//! stretch-minimizing mesh parameterization", SMI 2004) with area stretch in
//! place of their L2 stretch (see the [module overview](super), step 2).
//!
//! Each pass divides every half-edge weight by the area stretch at its far
//! vertex to the power η and re-solves the orbifold Tutte system; the passes
//! stop once the mean |ln area ratio| stops falling, a face flips, or the
//! pass budget is spent. With a score (lower is better) the map is rated
//! after the passes in [`SCORED_PASSES`] and the best one kept; the passes
//! give up once a score is [`SCORE_GIVE_UP`] times the best.
//!
//! [`AreaPasses::advance`] runs them up to a pass count and returns, so that
//! [`choose`](super::choose) can race several cone placements and finish
//! only the one that leads.

use super::cut::{self, Cut, Graph};
use super::distortion;
use super::orbifold::{self, OrbifoldSystem};
use super::{ParamOptions, Parameterization, Score, SCORED_PASSES, SCORE_GIVE_UP, STRETCH_CAP};
use crate::error::{Error, Result};
use crate::mesh::{Adjacency, Topology};
use glam::{DVec2, DVec3, Vec3};
use std::sync::Arc;

/// What [`AreaPasses::start_with`] refuses: too few vertices, positions
/// that do not match, an area correction out of range, a surface that is
/// not a closed genus-0 manifold. Faces without area are allowed (a user's
/// mesh may have slivers that collapse, and so may a carrier's closing
/// fans); they weigh nothing in the distortion and get bounded weights.
fn check_input(topology: &Topology, positions: &[Vec3], opts: &ParamOptions) -> Result<()> {
    let nv = topology.vertex_count;
    if nv < 5 || positions.len() != nv {
        return Err(Error::Argument(format!(
            "cannot parameterize a mesh of {nv} vertices ({} positions)",
            positions.len()
        )));
    }
    if !(opts.area_correction.is_finite() && (0.0..=2.0).contains(&opts.area_correction)) {
        return Err(Error::Argument(format!("area correction {} is not in [0, 2]", opts.area_correction)));
    }
    if opts.cut_guide.as_ref().is_some_and(|g| g.away.iter().any(|a| a.len() != nv) || g.sides.iter().any(|&k| k > 3)) {
        return Err(Error::Argument(format!("a cut guide that is not of the mesh's {nv} vertices")));
    }
    if let Err(problem) = crate::mesh::analyze(topology, positions).require_sphere_topology() {
        return Err(Error::Argument(format!("cannot parameterize: the surface {problem}")));
    }
    Ok(())
}

/// A parameterization in progress: the conformal map, then as many area
/// passes as [`advance`](Self::advance) has run.
pub struct AreaPasses {
    /// The surface's faces (owned, so that a map in progress can be
    /// handed on while its surface is kept elsewhere).
    faces: Arc<[[u32; 3]]>,
    pos: Vec<DVec3>,
    /// The input's own faces (all of them, unless the surface is a
    /// carrier with faces of its own: see [`AreaPasses::start_with`]) and
    /// their indices in `faces`: what the reported distortion measures.
    real_faces: Vec<[u32; 3]>,
    real_index: Vec<usize>,
    /// 3D area of each face.
    area3: Vec<f64>,
    system: OrbifoldSystem,
    /// The conformal map's half-edge weights (cotangent, symmetric) ...
    w0: Vec<f64>,
    /// ... and each vertex's factor on the weights into it after the
    /// passes so far: half-edge h weighs `w0[h] · c[target(h)]`.
    c: Vec<f64>,
    /// The map after the passes so far.
    p: Parameterization,
    /// Faces `p` reverses and its mean |ln area ratio|: a pass must
    /// reverse fewer faces, or as few (none) with a lower mean ...
    folds: usize,
    area_log_mean: f64,
    /// ... and `p`'s area ratios, which the next pass starts from.
    ratios: Vec<f64>,
    /// The best-scored map so far: (score, map, passes).
    kept: Option<(f64, Vec<DVec2>, usize)>,
    /// Passes after which the last score was taken.
    scored_at: Option<usize>,
    /// No more passes will run.
    done: bool,
    /// These scored pass counts, and those below `score_from`, are scored
    /// only by [`finish`](Self::finish) (see [`Self::defer`],
    /// [`Self::score_from`]) ...
    deferred: &'static [usize],
    score_from: usize,
    /// ... which scores these maps (passes, map) then.
    early: Vec<(usize, Vec<DVec2>)>,
}

impl AreaPasses {
    /// Cuts the surface, solves the conformal map (step 1) and readies the
    /// passes. Errors when the surface is not a closed genus-0 manifold, the
    /// options are out of range, or the cones cannot be cut apart.
    pub fn start(topology: &Topology, positions: &[Vec3], opts: &ParamOptions) -> Result<AreaPasses> {
        AreaPasses::start_with(topology, positions, None, opts)
    }

    /// [`start`](Self::start) on a carrier surface ([`crate::mesh::carrier`]):
    /// the faces not `real` are the carrier's own, left out of the
    /// distortion reported. (The passes still give them their share of
    /// area: leaving them out of the passes, or weighting them as
    /// equilateral triangles, was measured worse: an open sheet at N = 64
    /// came back at 5.6 % of the diagonal RMS instead of under 1 %, as
    /// the closing fan then took what area the harmonic map gave it.
    /// Giving them a tenth of their 3D area's share instead moved the
    /// resampling floors by -10 % to +17 % (face-poses, wolf at N = 128:
    /// surface or vertices better, the other worse), so they keep it.)
    pub fn start_with(
        topology: &Topology,
        positions: &[Vec3],
        real: Option<&[bool]>,
        opts: &ParamOptions,
    ) -> Result<AreaPasses> {
        check_input(topology, positions, opts)?;
        let faces = &topology.faces;
        let shared: Arc<[[u32; 3]]> = faces.as_slice().into();
        let nv = topology.vertex_count;
        let pos: Vec<DVec3> = positions.iter().map(|p| p.as_dvec3()).collect();
        let adj = Adjacency::build(faces);
        let graph = Graph::new(nv, faces, &pos);
        let (cones, corner) = match opts.cones {
            Some(c) => c,
            None => cut::choose_cones(&graph, nv),
        };
        let guide = opts.cut_guide.as_deref().map(cut::Guide::new);
        let is_real = |f: usize| real.is_none_or(|r| r.get(f).copied().unwrap_or(true));
        let weights = orbifold::cotangent_weights(faces, &adj, &pos);
        let real_index: Vec<usize> = (0..faces.len()).filter(|&f| is_real(f)).collect();
        let real_faces: Vec<[u32; 3]> = real_index.iter().map(|&f| faces[f]).collect();
        // The cones' order around the square decides the map's orientation;
        // the mirrored order is tried when the first one comes out reversed.
        for mirror in [false, true] {
            let cut = Cut::new(faces, &adj, &graph, cones, corner, mirror, guide.as_ref())?;
            let mut system = OrbifoldSystem::new(Arc::clone(&shared), nv, &cut);
            let uv = system.solve_symmetric(&weights)?;
            let mut p = Parameterization {
                cones: cut.cones,
                corner,
                cut_paths: cut.paths,
                uv,
                corner_iso: cut.corner_iso,
                conformal: distortion::Distortion::default(),
                distortion: distortion::Distortion::default(),
                area_passes: 0,
                score: None,
                options: opts.clone(),
            };
            let image_area: f64 = (0..faces.len()).map(|f| distortion::signed_area(p.face_uv(faces, f))).sum();
            if image_area < 0.0 {
                continue;
            }
            p.conformal = distortion::measure(&real_faces, &pos, |i| p.face_uv(faces, real_index[i]));
            let area3: Vec<f64> = faces.iter().map(|f| distortion::surface_area(&pos, f)).collect();
            let ratios = distortion::area_ratios(&area3, |f| p.face_uv(faces, f));
            let summary = distortion::area_summary(&area3, &ratios, |f| p.face_uv(faces, f));
            return Ok(AreaPasses {
                faces: shared,
                pos,
                real_faces,
                real_index,
                area3,
                system,
                c: vec![1.0; nv],
                w0: weights,
                p,
                folds: summary.flipped_faces,
                area_log_mean: summary.area_log_mean,
                ratios,
                kept: None,
                scored_at: None,
                done: false,
                score_from: 0,
                deferred: &[],
                early: Vec::new(),
            });
        }
        Err(Error::Numerical("the map reverses orientation in both cone orders".into()))
    }

    /// Scores the maps of fewer than `passes` passes only in
    /// [`finish`](Self::finish): a race that compares placements from that
    /// count on needs no early scores of the placements that lose (on
    /// samba's reference frame at N = 256 the maps of 5 to 15 passes scored
    /// 1.1 to 19 times those of 20, and their 15 scores took 3 s of its
    /// 13 s parameterization), but the winner's early maps may be its best
    /// (the cylinder's and face-poses' are at 5 passes).
    pub fn score_from(mut self, passes: usize) -> Self {
        self.score_from = passes;
        self
    }

    /// Leaves the maps of these pass counts, too, to [`finish`](Self::finish)
    /// (a race that compares placements at fewer counts than it scores).
    pub fn defer(mut self, passes: &'static [usize]) -> Self {
        self.deferred = passes;
        self
    }

    /// Half-edge h's weight after the passes so far.
    fn weight(&self, h: usize) -> f64 {
        self.w0[h] * self.c[crate::mesh::adjacency::target(&self.faces, h as u32) as usize]
    }

    /// The map after the passes so far: its cut (cones, corner, paths) is
    /// the finished map's.
    pub fn current(&self) -> &Parameterization {
        &self.p
    }

    /// Passes run so far.
    pub fn passes(&self) -> usize {
        self.p.area_passes
    }

    /// Whether the passes have stopped (no call runs more of them).
    pub fn stopped(&self) -> bool {
        self.done
    }

    /// The best score so far (None before the first, or without a score).
    pub fn score(&self) -> Option<f64> {
        self.kept.as_ref().map(|k| k.0)
    }

    /// Runs passes until `until` of them have run or they stop. When they
    /// stop, the last map is scored if it was not yet.
    pub fn advance(&mut self, until: usize, mut score: Option<Score>) -> Result<()> {
        self.run(until, &mut score)
    }

    fn run(&mut self, until: usize, score: &mut Option<Score>) -> Result<()> {
        let opts = &self.p.options;
        let budget = if opts.area_correction > 0.0 { opts.area_passes } else { 0 };
        let eta = opts.area_correction;
        let (shared, nv) = (Arc::clone(&self.faces), self.pos.len());
        let faces = &shared[..];
        while !self.done && self.p.area_passes < until {
            if self.p.area_passes >= budget {
                return self.stop(score);
            }
            // Local area stretch at each vertex: area-weighted RMS over its faces.
            let fs = distortion::face_stretch(&self.ratios);
            let mut num = vec![0.0; nv];
            let mut den = vec![0.0; nv];
            for (f, face) in faces.iter().enumerate().filter(|(f, _)| self.area3[*f] > 0.0) {
                let s = fs[f].min(STRETCH_CAP);
                for &v in face {
                    num[v as usize] += self.area3[f] * s * s;
                    den[v as usize] += self.area3[f];
                }
            }
            // Every weight into vertex j is divided by its stretch: one
            // factor per vertex (which is what lets the system be solved by
            // Cholesky, `solve_scaled`).
            for (j, c) in self.c.iter_mut().enumerate() {
                let sigma = (num[j] / den[j].max(1e-300)).sqrt().clamp(1e-12, STRETCH_CAP);
                *c /= sigma.powf(eta);
            }
            // Keep the weights in a sane range: only their ratios matter.
            let mean = (0..self.w0.len()).map(|h| self.weight(h)).sum::<f64>() / self.w0.len() as f64;
            self.c.iter_mut().for_each(|x| *x /= mean);
            // The trial map in place of the last one (which comes back if
            // the trial is refused).
            let last = std::mem::replace(&mut self.p.uv, self.system.solve_scaled(&self.w0, &self.c)?);
            let ratios = distortion::area_ratios(&self.area3, |f| self.p.face_uv(faces, f));
            let d = distortion::area_summary(&self.area3, &ratios, |f| self.p.face_uv(faces, f));
            let better = match d.flipped_faces.cmp(&self.folds) {
                std::cmp::Ordering::Less => true,
                std::cmp::Ordering::Equal => d.area_log_mean < self.area_log_mean,
                std::cmp::Ordering::Greater => false,
            };
            if !better {
                self.p.uv = last;
                return self.stop(score);
            }
            (self.folds, self.area_log_mean, self.ratios) = (d.flipped_faces, d.area_log_mean, ratios);
            self.p.area_passes += 1;
            if SCORED_PASSES.contains(&self.p.area_passes) {
                if self.folds > 0 {
                    // Not a candidate (see `rate`).
                } else if self.p.area_passes < self.score_from || self.deferred.contains(&self.p.area_passes) {
                    self.early.push((self.p.area_passes, self.p.uv.clone()));
                } else if self.rate(score)? {
                    self.done = true;
                }
            }
        }
        if self.p.area_passes >= budget {
            return self.stop(score);
        }
        Ok(())
    }

    /// Runs the remaining passes and returns the kept map.
    pub fn finish(mut self, mut score: Option<Score>) -> Result<Parameterization> {
        self.run(usize::MAX, &mut score)?;
        self.rate_early(&mut score)?;
        let mut p = self.p.clone();
        if let Some((s, uv, passes)) = self.kept.take() {
            (p.uv, p.area_passes, p.score) = (uv, passes, Some(s));
        }
        p.distortion = self.measure(&p);
        // Positive weights make every map a bijection in exact arithmetic,
        // and the passes keep no folded map; what folds is a region the
        // conformal map shrank below what f64 places resolve (the
        // elephant's trunk: faces of 1e-29 of the square) that the passes
        // ran out of budget before unfolding. The map that folds least is
        // kept, and the sample map resamples through its folds from their
        // neighbours (`crate::resample`); `distortion` says how much of
        // the surface that is.
        Ok(p)
    }

    /// The maps left for [`finish`](Self::finish) to score (see
    /// [`Self::score_from`], [`Self::defer`]), taken out: a caller may score
    /// them itself, beside the passes, and [`offer`](Self::offer) them back.
    pub fn take_deferred(&mut self) -> Vec<Parameterization> {
        let maps = std::mem::take(&mut self.early);
        maps.into_iter().map(|(passes, uv)| Parameterization { uv, area_passes: passes, ..self.p.clone() }).collect()
    }

    /// A map of these passes scored `s` elsewhere: kept if it beats the
    /// kept one (ties to fewer passes, as when scored in pass order).
    pub fn offer(&mut self, p: Parameterization, s: f64) {
        if self.kept.as_ref().is_none_or(|k| s < k.0 || (s == k.0 && p.area_passes < k.2)) {
            self.kept = Some((s, p.uv, p.area_passes));
        }
    }

    /// Scores the maps left for [`finish`](Self::finish), keeping the best.
    fn rate_early(&mut self, score: &mut Option<Score>) -> Result<()> {
        let Some(score) = score.as_mut() else { return Ok(()) };
        for (passes, uv) in std::mem::take(&mut self.early) {
            let map = Parameterization { uv, area_passes: passes, ..self.p.clone() };
            let s = score(&map, self.kept.as_ref().map_or(f64::INFINITY, |k| k.0))?;
            // Ties go to the earlier map, as when it was scored first.
            if self.kept.as_ref().is_none_or(|k| s <= k.0) {
                self.kept = Some((s, map.uv, passes));
            }
        }
        Ok(())
    }

    /// The distortion of the real faces, with the folds of all faces.
    fn measure(&self, p: &Parameterization) -> distortion::Distortion {
        let faces = &self.faces[..];
        let mut d = distortion::measure(&self.real_faces, &self.pos, |i| p.face_uv(faces, self.real_index[i]));
        let folded: Vec<usize> =
            (0..faces.len()).filter(|&f| distortion::signed_area(p.face_uv(faces, f)) <= 0.0).collect();
        d.flipped_faces = folded.len();
        d.flipped_area =
            folded.iter().map(|&f| self.area3[f]).sum::<f64>() / self.area3.iter().sum::<f64>().max(1e-300);
        d
    }

    /// No more passes: scores the last map if it was not yet.
    fn stop(&mut self, score: &mut Option<Score>) -> Result<()> {
        self.done = true;
        if self.scored_at != Some(self.p.area_passes) {
            self.rate(score)?;
        }
        Ok(())
    }

    /// Scores the current map, keeping it if it is the best so far; true
    /// when the passes are past their use (the score is SCORE_GIVE_UP times
    /// the kept one).
    fn rate(&mut self, score: &mut Option<Score>) -> Result<bool> {
        let Some(score) = score.as_mut() else { return Ok(false) };
        self.scored_at = Some(self.p.area_passes);
        if self.folds > 0 {
            // Not a candidate: the passes are still unfolding it.
            return Ok(false);
        }
        // Past SCORE_GIVE_UP times the kept score, only that it is past counts.
        let s = score(&self.p, self.kept.as_ref().map_or(f64::INFINITY, |k| SCORE_GIVE_UP * k.0))?;
        self.scored_at = Some(self.p.area_passes);
        match &self.kept {
            Some(k) if s >= k.0 => Ok(s > SCORE_GIVE_UP * k.0),
            _ => {
                self.kept = Some((s, self.p.uv.clone(), self.p.area_passes));
                Ok(false)
            }
        }
    }
}

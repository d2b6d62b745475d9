//! The `skinned-residual` entry of `cgv eval`: a rate point's size met by
//! the vertex residual's step (format v18), the video at the fixed QP
//! `--target-error` pairs with a residual ([`crate::codec::RESIDUAL_QP`]).
//! The file's size falls as the step grows, so the step is searched as the
//! QP is for the other codecs: secant steps on log(size) against log(step)
//! inside a shrinking bracket.

use super::{miss, Ctx, EvalCodec, Found, Try};
use crate::error::{Error, Result};

/// The residual's range searched, percent of the diagonal.
const FINEST: f64 = 0.005;
const COARSEST: f64 = 5.0;
/// Encodes at most.
const TRIES: usize = 10;

/// A try's log(step) and log(size).
type LogPoint = (f64, f64);

impl Ctx<'_> {
    /// The encode whose size is nearest `target` (within the tolerance, or
    /// the nearest tried).
    pub(super) fn search_residual(&self, codec: EvalCodec, target: usize) -> Result<Found> {
        let tol = self.opts.tolerance;
        let qp = crate::codec::residual_qp_of(crate::format::Representation::Skinned);
        let interval = self.opts.base.correction_interval;
        let mut best: Option<Try> = None;
        // (log step, log size) of the coarsest step whose file is still too
        // large and the finest whose file is too small.
        let (mut lo, mut hi): (Option<LogPoint>, Option<LogPoint>) = (None, None);
        let (mut p, mut tries) = (0.1f64, 0);
        while tries < TRIES {
            tries += 1;
            let t = self.encode_with_residual(codec, (interval, qp, 1), None, Some(p as f32))?;
            let (x, y, goal) = (p.ln(), (t.size.max(1) as f64).ln(), (target.max(1) as f64).ln());
            let size = t.size;
            if best.as_ref().is_none_or(|b| miss(size, target, tol) < miss(b.size, target, tol)) {
                best = Some(t);
            }
            if (size as f64 / target as f64 - 1.0).abs() <= tol {
                return best.map(|b| (b, true, tries)).ok_or_else(|| Error::Numerical("no encode kept".into()));
            }
            if size > target {
                lo = Some((x, y));
            } else {
                hi = Some((x, y));
            }
            let next = match (lo, hi) {
                // Between the bracket's ends, on the line through them.
                (Some(l), Some(h)) if (h.0 - l.0).abs() > 1e-3 => l.0 + (goal - l.1) * (h.0 - l.0) / (h.1 - l.1),
                (Some(_), Some(_)) => break,
                // Outward: bits fall about one per halving of the step.
                (Some(_), None) => x + (y - goal).max(0.35) * 2.0,
                (None, _) => x - (goal - y).max(0.35) * 2.0,
            };
            p = next.exp().clamp(FINEST, COARSEST);
            if (p.ln() - x).abs() < 1e-3 {
                break;
            }
        }
        let b = best.ok_or_else(|| Error::Argument("no encode was made".into()))?;
        let hit = (b.size as f64 / target as f64 - 1.0).abs() <= tol;
        Ok((b, hit, tries))
    }
}

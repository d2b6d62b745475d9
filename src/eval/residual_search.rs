//! The `skinned-residual` entry of `cgv eval`: a rate point's size met by
//! the vertex residual's step (format v18), the video at the fixed QP
//! `--target-error` pairs with a residual ([`crate::codec::RESIDUAL_QP`]);
//! and the `vertices` entry (format v20), whose file is that residual
//! alone. The file's size falls as the step grows, so the step is searched
//! (`crate::codec::residual_step`) as the QP is for the other codecs.

use super::{miss, Ctx, EvalCodec, Found, Try};
use crate::codec::residual_step::search_step;
use crate::error::{Error, Result};

impl Ctx<'_> {
    /// The encode whose size is nearest `target` (within the tolerance, or
    /// the nearest tried).
    pub(super) fn search_residual(&self, codec: EvalCodec, target: usize) -> Result<Found> {
        let tol = self.opts.tolerance;
        let qp = crate::codec::residual_qp_of(crate::format::Representation::Skinned);
        // The vertices codec holds no step finer than its values reach.
        let finest = match codec.vertices() {
            true => crate::codec::finest_vertex_percent(self.src)?,
            false => 0.0,
        };
        let interval = self.opts.base.correction_interval;
        let mut best: Option<Try> = None;
        let tries = search_step(target, tol, &mut |p| {
            let p = p.max(finest);
            let t = self.encode_with_residual(codec, (interval, qp, 1), None, Some(p as f32))?;
            let size = t.size;
            if best.as_ref().is_none_or(|b| miss(size, target, tol) < miss(b.size, target, tol)) {
                best = Some(t);
            }
            Ok(size)
        })?;
        let b = best.ok_or_else(|| Error::Argument("no encode was made".into()))?;
        let hit = (b.size as f64 / target as f64 - 1.0).abs() <= tol;
        Ok((b, hit, tries))
    }
}

//! Step 2: every frame resampled on the grid once, for each stream's range
//! (the corrections are ranged by the simulation or scaled per frame
//! instead), and the anchors chosen on the first grid frame.

use super::plan::Plan;
use crate::codec::choose_anchors;
use crate::error::Result;
use crate::format::quant::Range;
use crate::format::stream::SEED;
use crate::format::{CodecKind, StreamName};
use crate::grid::{Features, Stencils};
use crate::mesh::{Bounds, FrameSource};
use crate::resample::SampleMap;
use glam::Vec3;

pub(super) struct Analysis {
    /// Per layer-1 stream, in the plan's order.
    pub ranges: Vec<Range>,
    pub anchors: Vec<u32>,
}

/// The values stream `name` codes for a grid frame `g` with features `f`
/// and seed origin `origin` (`scratch` holds a coordinate's values).
pub(super) fn values<'a>(
    name: StreamName,
    (f, g): (&'a Features, &[Vec3]),
    origin: Option<[f32; 3]>,
    scratch: &'a mut Vec<f32>,
) -> &'a [f32] {
    match (name.axis(), name) {
        (Some(c), _) => {
            let o = if SEED.contains(&name) { origin.map_or(0.0, |o| o[c]) } else { 0.0 };
            scratch.clear();
            scratch.extend(g.iter().map(|p| p[c] - o));
            scratch
        }
        (None, StreamName::H) => &f.h,
        (None, StreamName::Lambda) => &f.lambda,
        (None, StreamName::A) => &f.a,
        (None, _) => &f.b,
    }
}

/// Frame `f`'s seed origin: at a random-access point of a file that has
/// them and a seed, the centre of the grid frame's bounding box (so the
/// seed streams' range spans the body, wherever it is), else none.
pub(super) fn seed_origin(plan: &Plan, f: usize, g: &[Vec3]) -> Option<[f32; 3]> {
    let seeded = plan.names.iter().any(|(n, _)| SEED.contains(n));
    (seeded && plan.random_access.is_some() && plan.is_rap(f)).then(|| {
        let b = Bounds::of(g);
        ((b.min + b.max) * 0.5).to_array()
    })
}

/// The features of grid frame `g` if the plan codes any, else none.
pub(super) fn features(plan: &Plan, st: &Stencils, g: &[Vec3]) -> Features {
    if plan.needs_features() {
        st.features(g)
    } else {
        Features::default()
    }
}

pub(super) fn analyse(
    src: &dyn FrameSource,
    plan: &Plan,
    map: &SampleMap,
    st: &Stencils,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<Analysis> {
    let mut ranges = vec![Range::default(); plan.names.len()];
    let mut first_grid = Vec::new();
    let mut scratch = Vec::new();
    for fi in 0..plan.frames {
        let g = map.apply(&src.read_frame(fi)?);
        let feats = features(plan, st, &g);
        let (key, rap) = (plan.is_key(fi), plan.is_rap(fi));
        let origin = seed_origin(plan, fi, &g);
        for (k, &(name, coverage)) in plan.names.iter().enumerate() {
            if coverage.has(key, rap) && !name.is_correction() {
                ranges[k].add(values(name, (&feats, &g), origin, &mut scratch));
            }
        }
        if fi == 0 {
            first_grid = g;
        }
        progress("analysing", fi + 1, plan.frames);
    }
    let anchors =
        if plan.codec == CodecKind::Cgv { choose_anchors(&first_grid, plan.anchor_count) } else { Vec::new() };
    Ok(Analysis { ranges, anchors })
}

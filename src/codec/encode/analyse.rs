//! Step 2: every frame resampled on the grid once, for each stream's range
//! (the corrections are ranged by the simulation or scaled per frame
//! instead), and the anchors chosen on the first grid frame.

use super::plan::Plan;
use crate::codec::choose_anchors;
use crate::error::Result;
use crate::format::quant::Range;
use crate::format::{CodecKind, StreamName};
use crate::grid::{Features, Stencils};
use crate::mesh::FrameSource;
use crate::resample::SampleMap;
use glam::Vec3;

pub(super) struct Analysis {
    /// Per layer-1 stream, in the plan's order.
    pub ranges: Vec<Range>,
    pub anchors: Vec<u32>,
}

/// The values stream `name` codes for a grid frame `g` with features `f`
/// (`scratch` holds a coordinate's values).
pub(super) fn values<'a>(name: StreamName, f: &'a Features, g: &[Vec3], scratch: &'a mut Vec<f32>) -> &'a [f32] {
    match (name.axis(), name) {
        (Some(c), _) => {
            scratch.clear();
            scratch.extend(g.iter().map(|p| p[c]));
            scratch
        }
        (None, StreamName::H) => &f.h,
        (None, StreamName::Lambda) => &f.lambda,
        (None, StreamName::A) => &f.a,
        (None, _) => &f.b,
    }
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
        for (k, &(name, coverage)) in plan.names.iter().enumerate() {
            if coverage.has(key, rap) && !name.is_correction() {
                ranges[k].add(values(name, &feats, &g, &mut scratch));
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

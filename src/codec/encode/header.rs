//! Step 4: the file's header, from the plan (step 1) and what the analysis
//! (step 2) and the simulation (step 3) measured of the motion. Apart from
//! the plan so that the plan, which the later steps read, needs none of
//! them.

use super::analyse::Analysis;
use super::plan::Plan;
use super::simulate::Simulation;
use super::EncodeOptions;
use crate::format::quant::Quantizer;
use crate::format::{self, CorrectionMode, Coverage, Header, Settings, SourceInfo, SourceMeshInfo, StreamInfo};
use crate::mesh::FrameSource;

/// The streams: layer 1 for each name, then the layer-2 refinements.
fn streams(plan: &Plan, opts: &EncodeOptions, analysis: &Analysis, simulation: &Simulation) -> Vec<StreamInfo> {
    let mut infos: Vec<StreamInfo> = plan
        .names
        .iter()
        .zip(&analysis.ranges)
        .map(|(&(name, coverage), r)| StreamInfo {
            name,
            layer: 1,
            refines: None,
            quant: match (name.is_correction(), name.axis()) {
                (true, c) if plan.motion => simulation.motion_quant[c.unwrap_or(3)],
                (true, _) => Quantizer::new(-1.0, 1.0),
                _ => r.quantizer(),
            },
            coverage,
            scaled: name.is_correction() && !plan.motion,
            shrink: if name.is_correction() && name.axis().is_some() { plan.layout.shrink } else { 0 },
        })
        .collect();
    if opts.layers == 2 {
        for (k, &(name, coverage)) in plan.names.iter().enumerate() {
            if coverage != Coverage::First {
                let quant = infos[k].quant.residual(opts.residual_steps);
                let refines = Some(k as u16);
                infos.push(StreamInfo { name, layer: 2, refines, quant, coverage, scaled: false, shrink: 0 });
            }
        }
    }
    infos
}

/// The file's header.
pub(super) fn header(
    plan: &Plan,
    src: &dyn FrameSource,
    opts: &EncodeOptions,
    (analysis, simulation): (&Analysis, &Simulation),
    diagonal: f32,
    source_mesh: Option<SourceMeshInfo>,
) -> Header {
    let topology = src.topology();
    Header {
        grid: plan.grid.n as u32,
        seam: format::SEAM_RULE.into(),
        frames: plan.frames as u32,
        fps: src.fps(),
        codec: opts.codec(),
        streams: streams(plan, opts, analysis, simulation),
        key_frames: plan.key_frames.clone(),
        anchors: analysis.anchors.clone(),
        solver: opts.solver,
        settings: Settings {
            qp: opts.video.qp,
            kbps: opts.video.kbps,
            gop: opts.video.gop,
            cabac: opts.video.cabac,
            layers: opts.layers,
            residual_steps: if opts.layers == 2 { opts.residual_steps } else { 0.0 },
        },
        source: SourceInfo {
            label: src.label().display().to_string(),
            vertices: topology.vertex_count as u32,
            faces: topology.faces.len() as u32,
            diagonal,
        },
        corrections: if plan.motion { CorrectionMode::Motion } else { CorrectionMode::Scaled },
        max_lag: simulation.max_lag,
        source_mesh,
        appearance: None,
        random_access: plan.random_access,
        skin: None,
        segments: plan.segments.clone(),
        frame_meshes: opts.frame_meshes,
        vertex_residual: None,
    }
}

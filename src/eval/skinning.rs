//! A skinning decomposition as a peer of `cgv eval` (`--skin-bones`): what
//! users ship as "a skinned mesh fitted to the motion", measured on the
//! same frames with the same metrics as Draco and gltfpack, and joined to
//! their report so that it lands on the same tables and chart.
//!
//! Two curves: the skinned glTF as written (its real bytes; like the peers,
//! it gives back the input's own mesh), and the compact form the skinning
//! literature counts (16-bit 3 x 4 matrices a frame, four 8-bit bone and
//! weight pairs a vertex; the rest mesh not counted).

use super::peers::{PeerCurve, PeerPoint, PeerReport};
use crate::error::Result;
use crate::mesh::{Bounds, FrameSource};
use crate::skin::{decompose, gltf::write_skinned_glb, SkinOptions, Skinning};
use glam::Vec3;

/// The skinning curves for `bones` (each a decomposition of the whole
/// motion), surface distances on every `surface_every`-th frame, added to
/// `peers` (or a report of their own when there is none).
pub fn add_skinning(
    src: &dyn FrameSource,
    bones: &[usize],
    surface_every: usize,
    peers: Option<PeerReport>,
) -> Result<PeerReport> {
    let frames = (0..src.frame_count()).map(|i| src.read_frame(i)).collect::<Result<Vec<_>>>()?;
    let faces = &src.topology().faces;
    let mut report = peers.unwrap_or_else(|| own_report(src, &frames, surface_every));
    let (mut glb, mut compact) = (Vec::new(), Vec::new());
    for &b in bones {
        let skin = decompose(&frames, faces, &SkinOptions { bones: b, ..Default::default() }, &mut |_, _| {})?;
        let dir = tempfile::tempdir().map_err(|e| crate::Error::io(std::path::Path::new("(temp)"), e))?;
        let path = dir.path().join("skin.glb");
        write_skinned_glb(&path, &skin, faces, src.fps(), "skin")?;
        let bytes = std::fs::metadata(&path).map_err(|e| crate::Error::io(&path, e))?.len() as usize;
        let point = |bytes: usize| measure(&frames, faces, &skin, surface_every, (format!("{b} bones"), bytes));
        glb.push(point(bytes)?);
        compact.push(point((skin.compact_bits() / 8) as usize)?);
    }
    report.curves.push(PeerCurve {
        name: "skinned glTF".into(),
        description: "SSDR rigid bones, 4 weights a vertex, as a glTF skin (cgv skin)".into(),
        points: glb,
    });
    report.curves.push(PeerCurve {
        name: "skinning, compact".into(),
        description: "the same bones at 16 bits a matrix entry a frame, 8-bit weights, rest mesh not counted".into(),
        points: compact,
    });
    Ok(report)
}

/// A report for the skinning alone, describing the input as the peers'
/// reports do.
fn own_report(src: &dyn FrameSource, frames: &[Vec<Vec3>], surface_every: usize) -> PeerReport {
    let first = &frames[0];
    let c = first.iter().map(|p| p.as_dvec3()).sum::<glam::DVec3>() / first.len().max(1) as f64;
    PeerReport {
        input: src.label().display().to_string(),
        frames: frames.len(),
        input_vertices: first.len(),
        diagonal: Bounds::of(first).diagonal() as f64,
        first_frame_centroid: Some(c.to_array()),
        surface_every,
        curves: Vec::new(),
    }
}

/// One point: the skinning's errors against the frames, relative to the
/// first frame's diagonal as the peers' are, and its size.
fn measure(
    frames: &[Vec<Vec3>],
    faces: &[[u32; 3]],
    skin: &Skinning,
    surface_every: usize,
    (setting, bytes): (String, usize),
) -> Result<PeerPoint> {
    let diag = Bounds::of(&frames[0]).diagonal() as f64;
    let e = crate::skin::errors::measure(frames, faces, skin, surface_every, &|_| diag)?;
    let (n, nv) = (frames.len(), skin.rest.len());
    Ok(PeerPoint {
        setting,
        bytes,
        kbps_30fps: bytes as f64 * 8.0 / 1000.0 * 30.0 / n as f64,
        bits_per_input_vertex: bytes as f64 * 8.0 / (n * nv) as f64,
        vertex_rms: e.vertex_rms,
        vertex_max: e.vertex_max,
        surface_rms: e.surface_rms,
        surface_max: e.surface_max,
        kg: Some(e.kg),
    })
}

//! What users ship today beside our codec: the report `python -m cgv.peers`
//! writes (Draco on every frame, gltfpack morph targets; measured on the
//! same frames with the same surface distance), checked against the
//! evaluation it joins, and how many bits our codec needs where each peer
//! point is.
//!
//! Our codec is read two ways: as a file without the input's mesh, whose
//! decoder shows the grid mesh (the sizes of [`Report`]), and as the file a
//! user ships to get their own mesh back, with it (connectivity and each
//! vertex's place on the grid: [`Report::source_mesh_bytes`] more). The
//! peers give back the input's mesh, so the second is the like-for-like
//! figure; the surface RMS is the grid mesh's in both.

use super::{bdrate, CodecResult, EvalCodec, Report};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The whole report of `python -m cgv.peers` (the fields `cgv eval` uses).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PeerReport {
    pub input: String,
    pub frames: usize,
    pub input_vertices: usize,
    pub diagonal: f64,
    /// The mean of the first frame's vertices (absent in reports made
    /// before it was written; then only the counts and diagonal are checked).
    #[serde(default)]
    pub first_frame_centroid: Option<[f64; 3]>,
    pub surface_every: usize,
    pub curves: Vec<PeerCurve>,
}

/// One tool at several settings.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PeerCurve {
    pub name: String,
    pub description: String,
    pub points: Vec<PeerPoint>,
}

/// One setting of a tool, errors relative to the diagonal as ours.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PeerPoint {
    pub setting: String,
    pub bytes: usize,
    pub kbps_30fps: f64,
    pub bits_per_input_vertex: f64,
    pub vertex_rms: f64,
    pub vertex_max: f64,
    pub surface_rms: Option<f64>,
    pub surface_max: Option<f64>,
    /// KG error (%, each frame's centroid), where the peer's report has it
    /// (the skinning's; `python -m cgv.peers` does not write it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kg: Option<f64>,
}

/// Where one peer point is on our curve.
#[derive(Debug, Clone, Serialize)]
pub struct PeerComparison {
    pub peer: String,
    pub setting: String,
    pub peer_bits_per_input_vertex: f64,
    pub surface_rms: Option<f64>,
    pub vertex_rms: f64,
    /// Our bits per input vertex per frame at the peer's surface RMS,
    /// without the input's mesh (the grid mesh out).
    pub grid_at_surface_rms: Reach,
    /// The same with the input's mesh (the user's mesh out).
    pub ours_at_surface_rms: Reach,
    /// The same at the peer's vertex RMSE, ours measured on the input's own
    /// vertices rebuilt from the decoded grid.
    pub ours_at_vertex_rms: Reach,
}

/// Our bits at an error, read off our curve.
#[derive(Debug, Clone, Copy, Serialize)]
#[serde(tag = "reach", rename_all = "snake_case")]
pub enum Reach {
    /// Interpolated between two of our points (log–log).
    At { bits: f64 },
    /// Our cheapest point is already at least as good: at most these bits.
    AtMost { bits: f64 },
    /// Below the lowest error we reached (`best`, at `bits`).
    Beyond { best: f64, bits: f64 },
    /// No figure (the peer or our codec has no such measure).
    Unknown,
}

/// A BD-rate of our codec against one peer on surface RMS.
#[derive(Debug, Clone, Serialize)]
pub struct PeerBdRate {
    pub peer: String,
    /// With the input's mesh in our files.
    pub percent: Option<f64>,
    pub percent_pchip: Option<f64>,
    /// Without it (the grid mesh out).
    pub grid_percent: Option<f64>,
    pub grid_percent_pchip: Option<f64>,
}

/// The peers joined to an evaluation.
#[derive(Debug, Clone, Serialize)]
pub struct Peers {
    pub report: PeerReport,
    /// The codec whose curve the BD-rates and the chart take: the first
    /// of `codecs`.
    pub codec: EvalCodec,
    /// Our codecs the evaluation ran (the baselines GV and conformal only
    /// when nothing else ran): at each peer point, the fewest bits of them.
    pub codecs: Vec<EvalCodec>,
    pub comparisons: Vec<PeerComparison>,
    pub bd_rates: Vec<PeerBdRate>,
}

fn bad(path: &Path, msg: String) -> Error {
    Error::Parse { path: path.to_path_buf(), line: 0, msg }
}

impl PeerReport {
    /// Reads a peers report (JSON), refusing one whose figures cannot be
    /// plotted (an empty file, a negative or non-finite size or error).
    pub fn parse(path: &Path, text: &str) -> Result<PeerReport> {
        let r: PeerReport = serde_json::from_str(text).map_err(|e| Error::Parse {
            path: path.to_path_buf(),
            line: e.line(),
            msg: e.to_string(),
        })?;
        for c in &r.curves {
            for p in &c.points {
                let finite = [p.kbps_30fps, p.bits_per_input_vertex, p.vertex_rms, p.vertex_max]
                    .into_iter()
                    .chain(p.surface_rms)
                    .chain(p.surface_max)
                    .all(|x| x.is_finite() && x >= 0.0);
                if !finite || p.bytes == 0 {
                    return Err(bad(
                        path,
                        format!(
                            "{} {}: a size is zero, or a size or an error is negative or not a number",
                            c.name, p.setting
                        ),
                    ));
                }
            }
        }
        Ok(r)
    }

    /// Refuses a report made on other frames than the evaluation's.
    pub fn check(&self, path: &Path, input: &[glam::Vec3], frames: usize, surface_every: usize) -> Result<()> {
        let vertices = input.len();
        let diagonal = crate::mesh::Bounds::of(input).diagonal() as f64;
        let mut problems = Vec::new();
        if let Some(c) = self.first_frame_centroid {
            let ours = input.iter().map(|p| p.as_dvec3()).sum::<glam::DVec3>() / vertices.max(1) as f64;
            if ours.distance(glam::DVec3::from(c)) > 1e-5 * diagonal {
                problems.push(format!("a first frame centred at {c:?} where the input's is at {:?}", ours.to_array()));
            }
        }
        if (self.diagonal - diagonal).abs() > 1e-5 * diagonal.abs() {
            problems.push(format!("a first frame of diagonal {} where the input's is {diagonal}", self.diagonal));
        }
        if self.frames != frames {
            problems.push(format!("{} frames where the evaluation has {frames}", self.frames));
        }
        if self.input_vertices != vertices {
            problems.push(format!("{} vertices where the input has {vertices}", self.input_vertices));
        }
        if self.surface_every != surface_every {
            problems.push(format!(
                "surface distances on every {} frame(s) where the evaluation measures every {surface_every}",
                self.surface_every
            ));
        }
        match problems.is_empty() {
            true => Ok(()),
            false => Err(bad(path, format!("made on other frames than this evaluation's: {}", problems.join("; ")))),
        }
    }
}

/// Our codecs the report holds, the one BD-rates and the chart take
/// first; the baselines (GV, conformal) only when nothing else ran.
fn our_codecs(r: &Report) -> Vec<EvalCodec> {
    let ran: Vec<EvalCodec> = [
        EvalCodec::VERTICES,
        EvalCodec::SKINNED_RESIDUAL,
        EvalCodec::SKINNED,
        EvalCodec::NORMAL,
        EvalCodec::PREDICTIVE,
        EvalCodec::NORMAL_MOTION,
        EvalCodec::NORMAL_SCALED,
        EvalCodec::PREDICTIVE_MOTION,
        EvalCodec::PREDICTIVE_SCALED,
        EvalCodec::CONFORMAL,
        EvalCodec::GV,
    ]
    .into_iter()
    .filter(|c| r.points.iter().any(|p| p.results.iter().any(|x| x.codec == *c)))
    .collect();
    // The baselines are ours only when nothing else ran.
    let own: Vec<EvalCodec> =
        ran.iter().copied().filter(|c| ![EvalCodec::GV, EvalCodec::CONFORMAL].contains(c)).collect();
    if own.is_empty() {
        ran.into_iter().take(1).collect()
    } else {
        own
    }
}

/// One codec's (bits, error) curves: surface RMS with the input's mesh and
/// without it, vertex RMS on the input's vertices.
struct Curves {
    surface: Vec<(f64, f64)>,
    grid: Vec<(f64, f64)>,
    vertex: Vec<(f64, f64)>,
}

impl Curves {
    fn of(r: &Report, codec: EvalCodec) -> Curves {
        let ours: Vec<&CodecResult> = r.points.iter().flat_map(|p| &p.results).filter(|c| c.codec == codec).collect();
        Curves {
            surface: ours.iter().filter_map(|c| c.surface_rms.map(|e| (shipped_bits(r, c), e))).collect(),
            grid: ours.iter().filter_map(|c| c.surface_rms.map(|e| (c.bits_per_input_vertex, e))).collect(),
            vertex: ours.iter().map(|c| (shipped_bits(r, c), c.source.vertex_rms)).collect(),
        }
    }
}

/// The fewest bits of several codecs' reaches: a reached error before one
/// beyond a curve, the lower error of two beyond.
fn fewest(reaches: impl Iterator<Item = Reach>) -> Reach {
    let rank = |r: &Reach| match *r {
        Reach::At { bits } | Reach::AtMost { bits } => (0, bits),
        Reach::Beyond { best, .. } => (1, best),
        Reach::Unknown => (2, 0.0),
    };
    reaches.min_by(|a, b| rank(a).partial_cmp(&rank(b)).unwrap_or(std::cmp::Ordering::Equal)).unwrap_or(Reach::Unknown)
}

/// Our whole file's bits per input vertex per frame: the motion and the
/// mesh (the codec's own mesh line where its files carry one).
pub fn shipped_bits(r: &Report, c: &CodecResult) -> f64 {
    shipped_bytes(r, c) as f64 * 8.0 / (r.frames * r.input_vertices).max(1) as f64
}

/// Our kbit/s at 30 fps for the whole file (the chart's peer panel).
pub fn shipped_kbps_30fps(r: &Report, c: &CodecResult) -> f64 {
    shipped_bytes(r, c) as f64 * 8.0 / 1000.0 * 30.0 / r.frames.max(1) as f64
}

fn shipped_bytes(r: &Report, c: &CodecResult) -> usize {
    c.bytes + c.own_mesh_bytes.unwrap_or(r.source_mesh_bytes)
}

/// The fewest bits at which a curve of (bits, error) points reaches
/// `error`, interpolating in log–log between neighbours in bits.
pub fn bits_at(curve: &[(f64, f64)], error: f64) -> Reach {
    let mut pts: Vec<(f64, f64)> =
        curve.iter().copied().filter(|(b, e)| b.is_finite() && *b > 0.0 && e.is_finite() && *e > 0.0).collect();
    if pts.is_empty() || !(error.is_finite() && error > 0.0) {
        return Reach::Unknown;
    }
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    if pts[0].1 <= error {
        return Reach::AtMost { bits: pts[0].0 };
    }
    for w in pts.windows(2) {
        let ((b0, e0), (b1, e1)) = (w[0], w[1]);
        if e1 <= error {
            // e0 > error >= e1: the crossing lies between them.
            let t = (e0.ln() - error.ln()) / (e0.ln() - e1.ln());
            return Reach::At { bits: (b0.ln() + t * (b1.ln() - b0.ln())).exp() };
        }
    }
    let (bits, best) = pts.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap_or(pts[0]);
    Reach::Beyond { best, bits }
}

/// Joins `peers` to the report: where each peer point is on our curve, and
/// BD-rates on surface RMS against each peer.
pub fn compare(r: &Report, peers: PeerReport) -> Option<Peers> {
    let codecs = our_codecs(r);
    let codec = *codecs.first()?;
    let curves: Vec<Curves> = codecs.iter().map(|&c| Curves::of(r, c)).collect();
    let at = |e: Option<f64>, curve: &dyn Fn(&Curves) -> &[(f64, f64)]| match e {
        Some(e) => fewest(curves.iter().map(|c| bits_at(curve(c), e))),
        None => Reach::Unknown,
    };
    let ours: Vec<&CodecResult> = r.points.iter().flat_map(|p| &p.results).filter(|c| c.codec == codec).collect();
    let comparisons = peers
        .curves
        .iter()
        .flat_map(|c| c.points.iter().map(move |p| (c, p)))
        .map(|(c, p)| PeerComparison {
            peer: c.name.clone(),
            setting: p.setting.clone(),
            peer_bits_per_input_vertex: p.bits_per_input_vertex,
            surface_rms: p.surface_rms,
            vertex_rms: p.vertex_rms,
            grid_at_surface_rms: at(p.surface_rms, &|c| &c.grid),
            ours_at_surface_rms: at(p.surface_rms, &|c| &c.surface),
            ours_at_vertex_rms: at(Some(p.vertex_rms), &|c| &c.vertex),
        })
        .collect();
    let ours_kbps: Vec<(f64, f64)> =
        ours.iter().filter_map(|c| c.surface_rms.map(|e| (shipped_kbps_30fps(r, c), e))).collect();
    let grid_kbps: Vec<(f64, f64)> = ours.iter().filter_map(|c| c.surface_rms.map(|e| (c.kbps_30fps, e))).collect();
    let bd_rates = peers
        .curves
        .iter()
        .map(|c| {
            let reference: Vec<(f64, f64)> =
                c.points.iter().filter_map(|p| p.surface_rms.map(|e| (p.kbps_30fps, e))).collect();
            PeerBdRate {
                peer: c.name.clone(),
                percent: bdrate::bd_rate(&reference, &ours_kbps),
                percent_pchip: bdrate::bd_rate_pchip(&reference, &ours_kbps),
                grid_percent: bdrate::bd_rate(&reference, &grid_kbps),
                grid_percent_pchip: bdrate::bd_rate_pchip(&reference, &grid_kbps),
            }
        })
        .collect();
    Some(Peers { report: peers, codec, codecs, comparisons, bd_rates })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_at_reads_the_curve() {
        let curve = [(1.0, 1e-2), (4.0, 1e-3), (16.0, 5e-4)];
        let Reach::At { bits } = bits_at(&curve, 1e-3) else { panic!("on a point") };
        assert!((bits - 4.0).abs() < 1e-9);
        // Halfway in log error between the first two points: halfway in log bits.
        let Reach::At { bits } = bits_at(&curve, (1e-2f64 * 1e-3).sqrt()) else { panic!("between") };
        assert!((bits - 2.0).abs() < 1e-9, "{bits}");
        assert!(matches!(bits_at(&curve, 0.1), Reach::AtMost { bits } if bits == 1.0));
        assert!(matches!(bits_at(&curve, 1e-4), Reach::Beyond { best, bits } if best == 5e-4 && bits == 16.0));
        assert!(matches!(bits_at(&[], 1e-3), Reach::Unknown));
        // A point that does worse with more bits does not hide a crossing.
        let bumpy = [(1.0, 1e-2), (2.0, 2e-2), (4.0, 1e-3)];
        assert!(matches!(bits_at(&bumpy, 5e-3), Reach::At { bits } if bits > 2.0 && bits < 4.0));
    }

    #[test]
    fn the_fewest_bits_of_several_codecs_are_ours() {
        // One codec cheap at high errors, one that reaches low ones.
        let (cheap, fine) = ([(1.0, 1e-2), (4.0, 2e-3)], [(2.0, 1e-2), (6.0, 2e-4)]);
        let both = |e: f64| fewest([bits_at(&cheap, e), bits_at(&fine, e)].into_iter());
        assert!(matches!(both(1e-2), Reach::AtMost { bits } if bits == 1.0));
        // At 2e-3 both reach it, the fine one in fewer bits (2 * 3^0.41).
        let Reach::At { bits: fine_bits } = bits_at(&fine, 2e-3) else { panic!("reached") };
        assert!(fine_bits < 4.0 && matches!(both(2e-3), Reach::At { bits } if bits == fine_bits));
        // Beyond the cheap one's curve, the fine one reads it.
        assert!(matches!(both(1e-3), Reach::At { bits } if bits > fine_bits && bits < 6.0));
        assert!(matches!(both(1e-4), Reach::Beyond { best, .. } if best == 2e-4));
        assert!(matches!(fewest(std::iter::empty()), Reach::Unknown));
    }

    #[test]
    fn a_report_on_other_frames_is_refused() {
        let text = r#"{"input": "x", "frames": 10, "input_vertices": 100, "diagonal": 1.0, "surface_every": 1,
            "curves": [{"name": "draco", "description": "d", "points": [{"setting": "q=8", "bytes": 1000,
            "kbps_30fps": 24.0, "bits_per_input_vertex": 8.0, "vertex_rms": 0.001, "vertex_max": 0.002,
            "surface_rms": 0.0005, "surface_max": 0.002}]}]}"#;
        let p = Path::new("peers.json");
        let r = PeerReport::parse(p, text).expect("a valid report");
        // 100 vertices on a segment of length 1 (the diagonal), centred at (0.5, 0, 0).
        let input: Vec<glam::Vec3> = (0..100).map(|i| glam::Vec3::new(i as f32 / 99.0, 0.0, 0.0)).collect();
        assert!(r.check(p, &input, 10, 1).is_ok());
        let e = r.check(p, &input, 12, 1).expect_err("other frames").to_string();
        assert!(e.contains("peers.json") && e.contains("10 frames where the evaluation has 12"), "{e}");
        let e = PeerReport::parse(p, &text.replace("1000,", "0,")).expect_err("empty file").to_string();
        assert!(e.contains("draco q=8"), "{e}");
        assert!(PeerReport::parse(p, "{").is_err());
        // With the first frame's centroid written, another first frame is caught.
        let moved = PeerReport { first_frame_centroid: Some([0.6, 0.0, 0.0]), ..r.clone() };
        let e = moved.check(p, &input, 10, 1).expect_err("another first frame").to_string();
        assert!(e.contains("centred at"), "{e}");
        let same = PeerReport { first_frame_centroid: Some([0.5, 0.0, 0.0]), ..r };
        assert!(same.check(p, &input, 10, 1).is_ok());
    }
}

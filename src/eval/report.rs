//! The Markdown form of an evaluation report (the JSON form is its serde
//! serialization).

use super::{EvalCodec, Report};
use crate::format::CorrectionMode;
use std::fmt::Write;

fn pct(x: f64) -> String {
    format!("{:.4} %", 100.0 * x)
}

fn opt_pct(x: Option<f64>) -> String {
    x.map_or("–".into(), pct)
}

/// "motion", "scaled", "motion, corrections every 2 frames".
fn variant_label(corrections: Option<CorrectionMode>, interval: Option<u32>) -> String {
    let mode = match corrections {
        Some(CorrectionMode::Motion) => "motion",
        Some(CorrectionMode::Scaled) => "scaled",
        None => "no corrections",
    };
    match interval {
        Some(k) if k > 1 => format!("{mode}, corrections every {k} frames"),
        _ => mode.into(),
    }
}

/// Tables like the paper's 1 and 2, and the figures it did not report.
pub fn markdown(r: &Report) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# `cgv eval` of {}\n", r.input);
    let _ = writeln!(
        s,
        "{} frames at {} fps, {} input vertices, grid N = {}, bounding-box diagonal {:.4}. \
         Surface distances on every {} frame(s). Took {:.0} s.\n",
        r.frames, r.fps, r.input_vertices, r.grid, r.diagonal, r.surface_every, r.seconds
    );
    let _ = writeln!(s, "Normalization: {}.\n", r.normalization);
    bitrates(&mut s, r);
    quality(&mut s, r);
    source(&mut s, r);
    variants(&mut s, r);
    bd_rates(&mut s, r);
    peers(&mut s, r);
    s
}

/// "2.40x fewer", "1.30x more", or what our curve says instead.
fn reach_cell(reach: super::peers::Reach, peer_bits: f64) -> (String, String) {
    use super::peers::Reach;
    // `at_most`: our bits are at most `bits`, so "fewer" is at least and
    // "more" at most what it says.
    let ratio = |bits: f64, at_most: bool| match peer_bits / bits {
        q if q >= 1.0 => format!("{}{q:.2}x fewer", if at_most { "≥ " } else { "" }),
        q => format!("{}{:.2}x more", if at_most { "≤ " } else { "" }, 1.0 / q),
    };
    match reach {
        Reach::At { bits } => (format!("{bits:.2}"), ratio(bits, false)),
        Reach::AtMost { bits } => (format!("≤ {bits:.2}"), ratio(bits, true)),
        Reach::Beyond { best, bits } => (format!("not reached (best {} at {bits:.2})", pct(best)), "–".into()),
        Reach::Unknown => ("–".into(), "–".into()),
    }
}

/// Draco and gltfpack (`cgv eval --peers`), and our bits where they are.
fn peers(s: &mut String, r: &Report) {
    let Some(p) = &r.peers else { return };
    let _ = writeln!(s, "\n## Against what users ship (`cgv eval --peers`)\n");
    for c in &p.report.curves {
        let _ = writeln!(s, "- **{}**: {}.", c.name, c.description);
    }
    let per_vertex = r.source_mesh_bytes as f64 * 8.0 / (r.frames * r.input_vertices).max(1) as f64;
    let names: Vec<String> = p.codecs.iter().map(|c| c.to_string()).collect();
    let ours = match &names[..] {
        [one] => format!("Our codec ({one})"),
        _ => format!("Our codecs (at each peer point the fewer bits of {}; BD-rates: {})", names.join(", "), p.codec),
    };
    let _ = writeln!(
        s,
        "\n{ours} read two ways: a file without the input's mesh, whose decoder shows the grid mesh \
         (the sizes above), and the file that gives the user's own mesh back, with it ({} bytes, {per_vertex:.2} \
         bits per input vertex per frame over these {} frames). Both peers give back the input's mesh, so the \
         second is the like-for-like figure. Errors: the same frames, the same surface distance (to the grid \
         mesh for ours), the same diagonal; the peers' vertex RMSE is on each input vertex's decoded vertex of \
         nearest trajectory, ours on the input's vertices rebuilt from the decoded grid. Our bits at a peer's \
         error are read off our curve, log–log between neighbouring points; a codec whose files always carry \
         the mesh (skinned, vertices) counts its own mesh line in \"with your mesh\", and \"grid mesh out\" \
         leaves that line out (a vertices file has no grid: that column is not a file it can make).\n",
        r.source_mesh_bytes, r.frames
    );
    let _ = writeln!(s, "| peer | setting | bits per input vertex per frame | kbit/s @30 fps | vertex RMSE | surface RMS | surface max | KG error (%) | ours at its surface RMS, grid mesh out | with your mesh | we need | ours at its vertex RMSE, your mesh | we need |");
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let points = p.report.curves.iter().flat_map(|c| c.points.iter());
    for (q, cmp) in points.zip(&p.comparisons) {
        let (gb, _) = reach_cell(cmp.grid_at_surface_rms, q.bits_per_input_vertex);
        let (sb, sr) = reach_cell(cmp.ours_at_surface_rms, q.bits_per_input_vertex);
        let (vb, vr) = reach_cell(cmp.ours_at_vertex_rms, q.bits_per_input_vertex);
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} | {:.1} | {} | {} | {} | {} | {gb} | {sb} | {sr} | {vb} | {vr} |",
            cmp.peer,
            cmp.setting,
            q.bits_per_input_vertex,
            q.kbps_30fps,
            pct(q.vertex_rms),
            opt_pct(q.surface_rms),
            opt_pct(q.surface_max),
            q.kg.map_or("–".into(), |k| format!("{k:.3}")),
        );
    }
    let _ = writeln!(
        s,
        "\nBD-rate of {} on surface RMS against each peer (cubic / piecewise cubic; negative: fewer bits):\n",
        p.codec
    );
    let _ = writeln!(s, "| against | with your mesh | grid mesh out |");
    let _ = writeln!(s, "|---|---|---|");
    let f = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => format!("{a:+.1} % / {b:+.1} %"),
        _ => "– (too little overlap in quality)".into(),
    };
    for b in &p.bd_rates {
        let _ = writeln!(
            s,
            "| {} | {} | {} |",
            b.peer,
            f(b.percent, b.percent_pchip),
            f(b.grid_percent, b.grid_percent_pchip)
        );
    }
}

/// The bitrates table (like the paper's Table 1).
fn bitrates(s: &mut String, r: &Report) {
    let _ = writeln!(s, "## Bitrates (like the paper's Table 1)\n");
    let _ = writeln!(s, "| rate point | target kbit/s @30 fps | codec | kbit/s @30 fps | kbit/s @{} fps | matched | QP / layers | bytes | bits per input vertex per frame | bits per grid sample per frame |", r.fps);
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    for p in &r.points {
        for c in &p.results {
            let _ = writeln!(
                s,
                "| {} | {:.1} | {}{} | {:.1} | {:.1} | {} | {}{} / {} | {} | {:.3} | {:.3} |",
                p.name,
                p.target_kbps_30fps,
                c.codec,
                match (c.codec, c.correction_interval) {
                    (codec, _) if codec.variants(false).is_some() => {
                        format!(" ({})", variant_label(c.corrections, c.correction_interval))
                    }
                    (_, Some(k)) if k > 1 => format!(" (corrections every {k} frames)"),
                    _ => c.vertex_residual.map_or(String::new(), |v| format!(" (a {v:.4} % vertex residual)")),
                },
                c.kbps_30fps,
                c.kbps,
                if c.matched { "yes" } else { "**no**" },
                c.qp,
                c.rate_control_kbps.map_or(String::new(), |_| " (rate control)".into()),
                c.layers,
                c.bytes,
                c.bits_per_input_vertex,
                c.bits_per_grid_sample
            );
        }
    }
}

/// The quality table (like the paper's Table 2, and beyond).
fn quality(s: &mut String, r: &Report) {
    let _ = writeln!(s, "\n## Quality (like the paper's Table 2, and beyond)\n");
    let _ = writeln!(s, "| rate point | codec | smoothness (1e-4 of diag.) | vertex RMS | vertex max | surface RMS | surface max | worst frame / mean | sample spacing drift, worst frame | KG error (%) | encode ms/frame | H.264 decode ms/frame | reconstruction ms/frame |");
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for p in &r.points {
        for c in &p.results {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {:.2} | {} | {:.3} | {:.1} | {:.2} | {:.2} |",
                p.name,
                c.codec,
                // A codec without a grid (vertices) has no samples to be smooth.
                Some(c.smoothness * 1e4).filter(|x| x.is_finite()).map_or("–".into(), |x| format!("{x:.2}")),
                pct(c.vertex_rms),
                pct(c.vertex_max),
                opt_pct(c.surface_rms),
                opt_pct(c.surface_max),
                c.worst_over_mean,
                pct(c.spacing_drift_worst),
                c.kg,
                c.encode_ms_per_frame,
                c.video_decode_ms_per_frame,
                c.reconstruct_ms_per_frame
            );
        }
    }
}

/// The errors on the input's own vertices.
fn source(s: &mut String, r: &Report) {
    let _ = writeln!(s, "\n## On the input's own vertices\n");
    let f = &r.source_floor;
    let _ = writeln!(
        s,
        "Each input vertex rebuilt from the decoded grid, where it lies on the grid mesh, against the input \
         frame: vertex RMS (mean over frames) and max relative to the diagonal, and the KG error by both \
         definitions (each frame's centroid, as Karni & Gotsman and most of the literature; each vertex's mean \
         over time). The uncompressed grid's own, the floor of every codec here: vertex RMS {}, max {}, KG {:.3} \
         / {:.3}. A decoder rebuilds these vertices from a file that carries the input's mesh (format version \
         6); for this input that adds {} bytes ({:.3} bits per input vertex per frame), which the sizes above \
         leave out.\n",
        pct(f.vertex_rms),
        pct(f.vertex_max),
        f.kg,
        f.kg_temporal,
        r.source_mesh_bytes,
        r.source_mesh_bytes as f64 * 8.0 / (r.frames * r.input_vertices).max(1) as f64
    );
    let _ = writeln!(
        s,
        "| rate point | codec | vertex RMS | vertex max | KG, frame centroid (%) | KG, temporal mean (%) |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for p in &r.points {
        for c in &p.results {
            let e = &c.source;
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {:.3} | {:.3} |",
                p.name,
                c.codec,
                pct(e.vertex_rms),
                pct(e.vertex_max),
                e.kg,
                e.kg_temporal
            );
        }
    }
}

/// The `cgv` entry's variants that were measured and not kept.
fn variants(s: &mut String, r: &Report) {
    if r.points.iter().any(|p| p.results.iter().any(|c| !c.passed_over.is_empty())) {
        let _ = writeln!(s, "\n## The `cgv` entry's variants not kept\n");
        let _ = writeln!(
            s,
            "At each point the `cgv` entry keeps, of its variants no larger than the target allows, the one with \
             the lowest surface RMS (vertex RMS when surface distances are off). These are the others.\n"
        );
        let _ = writeln!(s, "| rate point | variant | QP / layers | bytes | smoothness (1e-4 of diag.) | vertex RMS | surface RMS | worst frame / mean |");
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
        for p in &r.points {
            for c in &p.results {
                for v in &c.passed_over {
                    let _ = writeln!(
                        s,
                        "| {} | {} | {} / {} | {} | {:.2} | {} | {} | {:.2} |",
                        p.name,
                        variant_label(v.corrections, v.correction_interval),
                        v.qp,
                        v.layers,
                        v.bytes,
                        v.smoothness * 1e4,
                        pct(v.vertex_rms),
                        opt_pct(v.surface_rms),
                        v.worst_over_mean
                    );
                }
            }
        }
    }
}

/// BD-rates against GV.
fn bd_rates(s: &mut String, r: &Report) {
    if !r.bd_rates.is_empty() {
        let _ = writeln!(s, "\n## BD-rate against GV (negative: fewer bits for the same quality)\n");
        let _ = writeln!(
            s,
            "Each cell: one least-squares cubic per curve (Bjøntegaard 2001) / monotone piecewise cubic \
             (VCEG-AL22; steadier where a curve flattens at the grid's floor).\n"
        );
        let _ = writeln!(s, "| codec | surface RMS | vertex RMS | smoothness |");
        let _ = writeln!(s, "|---|---|---|---|");
        let mut codecs: Vec<EvalCodec> = r.bd_rates.iter().map(|b| b.codec).collect();
        codecs.dedup();
        for c in codecs {
            let get = |m: &str| {
                r.bd_rates
                    .iter()
                    .find(|b| b.codec == c && b.metric == m)
                    .and_then(|b| Some((b.percent?, b.percent_pchip?)))
                    .map_or("– (needs 4+ undominated points overlapping in quality)".into(), |(v, w)| {
                        format!("{v:+.1} % / {w:+.1} %")
                    })
            };
            let _ = writeln!(s, "| {c} | {} | {} | {} |", get("surface_rms"), get("vertex_rms"), get("smoothness"));
        }
    }
}

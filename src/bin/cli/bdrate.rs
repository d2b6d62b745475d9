//! `cgv bdrate`: the BD-rate between two `cgv eval --json` reports, for
//! comparing one codec's settings with another's (say the corrections on
//! the world axes and on the surface's), with the same fits `cgv eval`
//! uses against GV.

use anyhow::{bail, Context, Result};
use cgv::eval::bdrate::{bd_rate, bd_rate_pchip};
use cgv::eval::EvalCodec;
use serde_json::Value;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The reference: a `cgv eval --json` report.
    reference: PathBuf,
    /// The report whose codec is measured against the reference's.
    test: PathBuf,
    /// The codec whose curves are compared, in both reports (`cgv eval
    /// --codecs`; reports made before the codecs were renamed are read by
    /// the old names too: cgv is predictive, paper conformal).
    #[arg(long, default_value = "predictive")]
    codec: EvalCodec,
    /// The reference's codec, when it is another one (default: --codec).
    #[arg(long)]
    reference_codec: Option<EvalCodec>,
}

const METRICS: [&str; 4] = ["surface_rms", "vertex_rms", "source_vertex_rms", "smoothness"];

/// The (kbit/s at 30 fps, error) points of one codec and metric.
fn curve(report: &Value, codec: EvalCodec, metric: &str) -> Vec<(f64, f64)> {
    let points = report["points"].as_array().map(Vec::as_slice).unwrap_or_default();
    points
        .iter()
        .flat_map(|p| p["results"].as_array().into_iter().flatten())
        .filter(|r| r["codec"].as_str().and_then(|c| c.parse::<EvalCodec>().ok()) == Some(codec))
        .filter_map(|r| {
            // The error on the input's own vertices sits in the result's `source`.
            let error = match metric {
                "source_vertex_rms" => r["source"]["vertex_rms"].as_f64(),
                m => r[m].as_f64(),
            };
            Some((r["kbps_30fps"].as_f64()?, error?))
        })
        .collect()
}

fn read(path: &PathBuf) -> Result<Value> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let v: Value = serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    if !v["points"].is_array() {
        bail!("{}: not a `cgv eval --json` report (no rate points)", path.display());
    }
    Ok(v)
}

pub fn run(args: Args) -> Result<()> {
    let (reference, test) = (read(&args.reference)?, read(&args.test)?);
    let ref_codec = args.reference_codec.unwrap_or(args.codec);
    let fmt = |p: Option<f64>| p.map_or("n/a".to_string(), |p| format!("{p:+.1} %"));
    println!(
        "BD-rate of {} ({}) against {} ({}):",
        args.codec,
        args.test.display(),
        ref_codec,
        args.reference.display()
    );
    println!("  {:<18} {:>10} {:>10}   points", "metric", "cubic", "pchip");
    let mut any = false;
    for m in METRICS {
        let (r, t) = (curve(&reference, ref_codec, m), curve(&test, args.codec, m));
        if r.is_empty() || t.is_empty() {
            continue;
        }
        any = true;
        println!(
            "  {m:<18} {:>10} {:>10}   {} / {}",
            fmt(bd_rate(&r, &t)),
            fmt(bd_rate_pchip(&r, &t)),
            r.len(),
            t.len()
        );
    }
    if !any {
        bail!("no rate points of codec '{}' in both reports", args.codec);
    }
    println!("(negative: fewer bits for the same error; n/a: fewer than 4 undominated points or no overlap)");
    Ok(())
}

//! `cgv remesh`: parameterize the reference frame onto the seamless square,
//! resample every frame onto the N x N grid, write the grid sequence (GLB or
//! OBJ folder) and a PNG of the first geometry image, and report distortion
//! and resampling error.

use super::InputArgs;
use anyhow::{bail, Context, Result};
use cgv::grid::Grid;
use cgv::mesh::{analyze, Bounds};
use cgv::metrics::surface;
use cgv::param::{choose::parameterize_for_grid, ParamOptions};
use cgv::resample::SampleMap;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Output: a .glb file (morph-target animation) or a folder (one OBJ per frame).
    #[arg(short, long)]
    output: PathBuf,
    /// Grid size N (even): each frame becomes N x N samples.
    #[arg(long, default_value_t = 128)]
    grid: usize,
    /// Where to write the first frame's geometry image (x, y, z as 16-bit r, g, b).
    /// Default: the output path with a .png extension.
    #[arg(long)]
    png: Option<PathBuf>,
    /// The frame whose surface is parameterized.
    #[arg(long, default_value_t = 0)]
    reference: usize,
    /// Area correction exponent per pass: 0 keeps the map conformal; larger
    /// values give shrunken parts (heads, limbs) more samples at some cost in angles.
    #[arg(long, default_value_t = ParamOptions::default().area_correction)]
    area_correction: f64,
    /// Most area-correction passes. Of the maps they go through, the one
    /// whose grid lies closest to the reference frame's surface is kept.
    #[arg(long, default_value_t = ParamOptions::default().area_passes)]
    area_passes: usize,
    /// Measure the resampling error on every K-th frame (0: not at all).
    #[arg(long, default_value_t = 1)]
    error_stride: usize,
    /// Print the report as JSON (progress bars are hidden).
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
struct FrameError {
    frame: usize,
    diagonal: f32,
    rms: f64,
    max: f64,
}

pub fn run(args: Args) -> Result<()> {
    let grid = Grid::new(args.grid)?;
    let src = args.input.open()?;
    let n_frames = src.frame_count();
    if args.reference >= n_frames {
        bail!("--reference {} is past the last frame {}", args.reference, n_frames - 1);
    }
    let topology = src.topology().clone();
    let reference = src.read_frame(args.reference)?;
    let topo = analyze(&topology, &reference);
    if let Err(problem) = topo.require_sphere() {
        bail!("{}: {problem}", src.label().display());
    }

    let t = Instant::now();
    let opts = ParamOptions { area_correction: args.area_correction, area_passes: args.area_passes, cones: None };
    let param =
        parameterize_for_grid(&topology, &reference, grid, &opts).context("parameterizing the reference frame")?;
    let param_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let map = SampleMap::build(grid, &topology.faces, &param)?;
    let locate_s = t.elapsed().as_secs_f64();
    let grid_topo = grid.topology();

    // Resampling error, in parallel over frames.
    let mut errors: Vec<FrameError> = Vec::new();
    if args.error_stride > 0 {
        let frames: Vec<usize> = (0..n_frames).step_by(args.error_stride).collect();
        let pb = super::progress(frames.len(), "measuring", args.json);
        let results: Vec<cgv::Result<FrameError>> = frames
            .par_iter()
            .map(|&i| {
                let f = src.read_frame(i)?;
                let g = map.apply(&f);
                let d = surface::symmetric(&f, &topology.faces, &g, &grid_topo.faces)?;
                let diagonal = Bounds::of(&f).diagonal();
                pb.inc(1);
                Ok(FrameError { frame: i, diagonal, rms: d.rms / diagonal as f64, max: d.max / diagonal as f64 })
            })
            .collect();
        pb.finish_and_clear();
        errors = results.into_iter().collect::<cgv::Result<_>>()?;
    }

    // Output, frame by frame.
    let pb = super::progress(n_frames, "writing", args.json);
    let mut resample_s = 0.0;
    let mut first_grid = None;
    let mut next = |i: usize| -> cgv::Result<Vec<glam::Vec3>> {
        let f = src.read_frame(i)?;
        let t = Instant::now();
        let g = map.apply(&f);
        resample_s += t.elapsed().as_secs_f64();
        if i == 0 {
            first_grid = Some(g.clone());
        }
        pb.inc(1);
        Ok(g)
    };
    let out = &args.output;
    let name = src.label().file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "motion".into());
    super::write_sequence(out, &grid_topo, n_frames, src.fps(), &name, &mut next)?;
    pb.finish_and_clear();
    let png = args.png.clone().unwrap_or_else(|| {
        if super::is_glb(out) {
            out.with_extension("png")
        } else {
            let mut s = out.clone().into_os_string();
            s.push(".png");
            PathBuf::from(s)
        }
    });
    if let Some(g) = &first_grid {
        cgv::fsutil::write_atomic(&png, &cgv::image::geometry_image_png(&grid, g)?)?;
    }

    let mean = |f: &dyn Fn(&FrameError) -> f64| errors.iter().map(f).sum::<f64>() / errors.len().max(1) as f64;
    let rms_mean = mean(&|e| e.rms);
    let max_mean = mean(&|e| e.max);
    let max_max = errors.iter().map(|e| e.max).fold(0.0, f64::max);
    let fps_resample = n_frames as f64 / resample_s.max(1e-9);
    if args.json {
        let report = serde_json::json!({
            "input": src.label(),
            "frames": n_frames,
            "input_vertices": topology.vertex_count,
            "grid": grid.n,
            "grid_vertices": grid.len(),
            "grid_faces": grid_topo.faces.len(),
            "reference_frame": args.reference,
            "parameterization": param,
            "seconds": {"parameterize": param_s, "locate_samples": locate_s, "resample_total": resample_s},
            "resample_frames_per_second": fps_resample,
            "error": {
                "relative_to": "bounding-box diagonal of each original frame",
                "frames_measured": errors.len(),
                "rms_mean": rms_mean, "max_mean": max_mean, "max_max": max_max,
                "per_frame": errors,
            },
            "output": out, "png": png,
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        let c = &param.conformal;
        let d = &param.distortion;
        println!("{} -> {} ({} frames, grid {}x{})", src.label().display(), out.display(), n_frames, grid.n, grid.n);
        println!(
            "  parameterization  {:.2} s (cones at vertices {:?}, corner {}; {} area-correction passes kept)",
            param_s, param.cones, param.corner, param.area_passes
        );
        println!(
            "  angle distortion  sigma1/sigma2 mean {:.3}, p95 {:.3} (conformal map: mean {:.3}, p95 {:.3})",
            d.conformal_mean, d.conformal_p95, c.conformal_mean, c.conformal_p95
        );
        println!(
            "  area distortion   mean |ln area ratio| {:.3}, p1..p99 {:.3}..{:.3} (conformal map: {:.3}, {:.4}..{:.3})",
            d.area_log_mean, d.area_p01, d.area_p99, c.area_log_mean, c.area_p01, c.area_p99
        );
        println!(
            "  locate samples    {:.3} s; resample {:.0} frames/s (excluding file reading)",
            locate_s, fps_resample
        );
        if !errors.is_empty() {
            println!(
                "  resampling error  RMS {:.4} %, max {:.4} % of the bounding-box diagonal (mean over {} frames; worst max {:.4} %)",
                100.0 * rms_mean,
                100.0 * max_mean,
                errors.len(),
                100.0 * max_max
            );
        }
        println!("  wrote {} and {}", out.display(), png.display());
    }
    Ok(())
}

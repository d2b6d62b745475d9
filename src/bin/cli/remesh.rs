//! `cgv remesh`: parameterize the reference frame onto the seamless square,
//! resample every frame onto the N x N grid, write the grid sequence (GLB or
//! OBJ folder) and a PNG of the first geometry image, and report distortion
//! and resampling error.

use super::InputArgs;
use anyhow::{bail, Context, Result};
use cgv::geometry_image::{surface_vertices, GeometryImage};
use cgv::grid::Grid;
use cgv::mesh::Bounds;
use cgv::mesh::FrameSource;
use cgv::metrics::surface;
use cgv::param::ParamOptions;
use cgv::resample::SampleMap;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
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
    /// Parts of at most this many vertices (all but the largest part) are
    /// coded as their own vertices every frame instead of joining the grid
    /// by a tube: by default scraps and detached triangles. Larger parts (an
    /// eye, a button) can be coded so too, but measured costlier than on the
    /// grid (docs/RESULTS.md, "Loose parts"). 0: every part on the grid.
    #[arg(long, value_name = "VERTICES", default_value_t = ParamOptions::default().loose_max_vertices)]
    loose_parts: usize,
    /// Move input vertices' places where a nearby one follows the motion
    /// better before measuring them, as `cgv encode --fit-places` does.
    #[arg(long)]
    fit_places: bool,
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
    /// Symmetric surface distance between the frame and its grid mesh.
    rms: f64,
    max: f64,
    /// The input's own vertices rebuilt from the grid (as a decoder of a
    /// file carrying the source mesh does) against the input's.
    vertex_rms: f64,
    vertex_max: f64,
}

/// The resampling error of every `stride`-th frame, in parallel.
fn measure(src: &dyn FrameSource, image: &GeometryImage, stride: usize, quiet: bool) -> Result<Vec<FrameError>> {
    if stride == 0 {
        return Ok(Vec::new());
    }
    let (topology, map) = (src.topology(), &image.map);
    let faces = image.surface_faces(topology);
    let points = image.source_points();
    let loose_of = image.loose_of(topology.vertex_count);
    let frames: Vec<usize> = (0..src.frame_count()).step_by(stride).collect();
    let pb = super::progress(frames.len(), "measuring", quiet);
    let results: Vec<cgv::Result<FrameError>> = frames
        .par_iter()
        .map(|&i| {
            let f = src.read_frame(i)?;
            let g = map.apply(&f);
            // Uncoded, the loose vertices are exact.
            let loose: Vec<glam::Vec3> = image.carrier.loose.iter().map(|&v| f[v as usize]).collect();
            let d = surface::symmetric(&f, &topology.faces, &surface_vertices(&g, &loose), &faces)?;
            let mut rebuilt = points.apply(&g);
            cgv::codec::place_loose(&mut rebuilt, &loose_of, &loose);
            let (vertex_rms, vertex_max) = cgv::metrics::vertex_error(&rebuilt, &f);
            let diagonal = Bounds::of(&f).diagonal() as f64;
            pb.inc(1);
            Ok(FrameError {
                frame: i,
                diagonal: diagonal as f32,
                rms: d.rms / diagonal,
                max: d.max / diagonal,
                vertex_rms: vertex_rms / diagonal,
                vertex_max: vertex_max / diagonal,
            })
        })
        .collect();
    pb.finish_and_clear();
    Ok(results.into_iter().collect::<cgv::Result<_>>()?)
}

/// Writes the grid sequence to `out` and the first geometry image to
/// `png`, frame by frame; returns the seconds spent resampling.
fn write_output(
    src: &dyn FrameSource,
    map: &SampleMap,
    grid: Grid,
    out: &Path,
    png: &Path,
    quiet: bool,
) -> Result<f64> {
    let pb = super::progress(src.frame_count(), "writing", quiet);
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
    let name = src.label().file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "motion".into());
    super::write_sequence(out, &grid.topology(), src.frame_count(), src.fps(), &name, None, &mut next)?;
    pb.finish_and_clear();
    if let Some(g) = &first_grid {
        cgv::output::write_atomic(png, &cgv::geometry_png::geometry_image_png(&grid, g)?)?;
    }
    Ok(resample_s)
}

/// Where the first geometry image goes: `--png`, else beside the output
/// (`walk.glb` -> `walk.png`, folder `frames` -> `frames.png`).
fn png_path(args: &Args) -> PathBuf {
    let out = &args.output;
    args.png.clone().unwrap_or_else(|| {
        if super::is_glb(out) {
            out.with_extension("png")
        } else {
            let mut s = out.clone().into_os_string();
            s.push(".png");
            PathBuf::from(s)
        }
    })
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
    let opts = ParamOptions {
        area_correction: args.area_correction,
        area_passes: args.area_passes,
        loose_max_vertices: args.loose_parts,
        ..Default::default()
    };
    let mut image = GeometryImage::build(src.label(), &topology, &reference, grid, &opts)
        .context("parameterizing the reference frame")?;
    if args.fit_places {
        image.fit_places(src.as_ref(), args.reference).context("choosing the input vertices' places")?;
    }
    let errors = measure(src.as_ref(), &image, args.error_stride, args.json)?;
    let png = png_path(&args);
    let resample_s = write_output(src.as_ref(), &image.map, grid, &args.output, &png, args.json)?;
    let report = Report { args: &args, src: src.as_ref(), grid, image: &image, errors, resample_s, png };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report.json())?);
    } else {
        report.print();
    }
    Ok(())
}

/// What `cgv remesh` found.
struct Report<'a> {
    args: &'a Args,
    src: &'a dyn FrameSource,
    grid: Grid,
    image: &'a GeometryImage,
    errors: Vec<FrameError>,
    resample_s: f64,
    png: PathBuf,
}

impl Report<'_> {
    fn mean(&self, f: &dyn Fn(&FrameError) -> f64) -> f64 {
        self.errors.iter().map(f).sum::<f64>() / self.errors.len().max(1) as f64
    }

    fn max_max(&self) -> f64 {
        self.errors.iter().map(|e| e.max).fold(0.0, f64::max)
    }

    fn vertex_max(&self) -> f64 {
        self.errors.iter().map(|e| e.vertex_max).fold(0.0, f64::max)
    }

    fn fps_resample(&self) -> f64 {
        self.src.frame_count() as f64 / self.resample_s.max(1e-9)
    }

    fn json(&self) -> serde_json::Value {
        let (src, grid, image) = (self.src, self.grid, self.image);
        serde_json::json!({
            "input": src.label(),
            "frames": src.frame_count(),
            "input_vertices": src.topology().vertex_count,
            "grid": grid.n,
            "grid_vertices": grid.len(),
            "grid_faces": grid.topology().faces.len(),
            "reference_frame": self.args.reference,
            "parameterization": image.param,
            "seconds": {"parameterize": image.seconds_parameterize, "locate_samples": image.seconds_locate,
                "resample_total": self.resample_s},
            "resample_frames_per_second": self.fps_resample(),
            "places_moved": image.places_moved,
            "error": {
                "relative_to": "bounding-box diagonal of each original frame",
                "frames_measured": self.errors.len(),
                "rms_mean": self.mean(&|e| e.rms), "max_mean": self.mean(&|e| e.max), "max_max": self.max_max(),
                "vertex_rms_mean": self.mean(&|e| e.vertex_rms), "vertex_max_max": self.vertex_max(),
                "per_frame": self.errors,
            },
            "output": self.args.output, "png": self.png,
        })
    }

    fn print(&self) {
        let (src, grid, param) = (self.src, self.grid, &self.image.param);
        let (c, d, out) = (&param.conformal, &param.distortion, &self.args.output);
        println!(
            "{} -> {} ({} frames, grid {}x{})",
            src.label().display(),
            out.display(),
            src.frame_count(),
            grid.n,
            grid.n
        );
        println!(
            "  parameterization  {:.2} s (cones at vertices {:?}, corner {}; {} area-correction passes kept)",
            self.image.seconds_parameterize, param.cones, param.corner, param.area_passes
        );
        super::warn_folds(d);
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
            self.image.seconds_locate,
            self.fps_resample()
        );
        if !self.errors.is_empty() {
            println!(
                "  resampling error  RMS {:.4} %, max {:.4} % of the bounding-box diagonal (mean over {} frames; worst max {:.4} %)",
                100.0 * self.mean(&|e| e.rms),
                100.0 * self.mean(&|e| e.max),
                self.errors.len(),
                100.0 * self.max_max()
            );
            println!(
                "  input vertices    rebuilt from the grid: RMS {:.4} % (mean over frames), max {:.4} % of the diagonal ({} of {} moved to a nearby place)",
                100.0 * self.mean(&|e| e.vertex_rms),
                100.0 * self.vertex_max(),
                self.image.places_moved,
                src.topology().vertex_count
            );
        }
        println!("  wrote {} and {}", out.display(), self.png.display());
    }
}

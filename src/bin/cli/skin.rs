//! `cgv skin`: a skinning decomposition of a motion (a few bones and four
//! weights per vertex, `cgv::skin::ssdr`), written as a standard skinned
//! glTF that three.js and every engine play natively, with its error and
//! its size.

use super::InputArgs;
use anyhow::{bail, Context, Result};
use cgv::mesh::Bounds;
use cgv::skin::residual::MorphTargets;
use cgv::skin::SkinOptions;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Output skinned glTF (.glb): the first frame as the rest mesh, one
    /// joint per bone animated by translation and rotation tracks.
    #[arg(short, long, required_unless_present = "affine", conflicts_with = "affine")]
    output: Option<PathBuf>,
    /// Fit affine bones (any 3 x 3 matrix a bone a frame, as the skinning
    /// literature's published decompositions are) and report their error
    /// and compact size only: glTF joints cannot shear, so no GLB is
    /// written.
    #[arg(long)]
    affine: bool,
    /// Also write what the bones miss as this many morph targets (the
    /// principal components of the residual, in the bind pose), weighed
    /// every frame: three.js plays them with the skin. Each costs 3 numbers
    /// a vertex once and one a frame.
    #[arg(long, value_name = "K", default_value_t = 0)]
    morph_targets: usize,
    /// Bones (4 to 255). More bones, less error, more bits: 16 to 32 suit
    /// a body, a few more a body with a face or hands.
    #[arg(long, default_value_t = SkinOptions::default().bones)]
    bones: usize,
    /// Instead of --bones: the fewest bones (of 8, 12, 16, 24, 32, 48, 64,
    /// each fitted in turn) whose vertex RMS is at most this percentage of
    /// the diagonal (0.3 for 0.3 %); if none is, the fit with the most bones
    /// tried is written and the report says the target was not met (the
    /// exit status stays 0: the file is whole).
    #[arg(long, value_name = "PERCENT", conflicts_with = "bones")]
    target_error: Option<f64>,
    /// Alternations of the weights' and the transforms' fits after the
    /// clustering (each lowers the error less than the one before).
    #[arg(long, default_value_t = SkinOptions::default().iterations)]
    iterations: usize,
    /// Measure the surface distance on every K-th frame too (0: not at all;
    /// it is the slow part of the report).
    #[arg(long, value_name = "K", default_value_t = 10)]
    surface_every: usize,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

/// What `cgv skin` reports.
#[derive(serde::Serialize)]
struct Report {
    frames: usize,
    vertices: usize,
    bones: usize,
    /// Vertex RMS and max over frames, relative to each frame's diagonal.
    vertex_rms: f64,
    vertex_max: f64,
    /// Surface RMS on the measured frames, relative to each frame's diagonal.
    surface_rms: Option<f64>,
    /// KG error (%, each frame's centroid).
    kg: f64,
    /// Bits per vertex per frame: the compact form (16-bit 3 x 4 matrices,
    /// 8-bit bone and weight pairs; rest mesh not counted), and the GLB.
    compact_bits_per_vertex_frame: f64,
    /// The GLB's size (none with --affine: no GLB).
    glb_bytes: Option<u64>,
    glb_bits_per_vertex_frame: Option<f64>,
    /// Affine bones instead of rigid ones.
    affine: bool,
    /// Morph targets of the residual (counted in the compact bits at 16
    /// bits a number: 3 a vertex each, once, and a weight a frame).
    morph_targets: usize,
    seconds_decompose: f64,
    /// With --target-error: each bone count fitted, and whether one met it.
    #[serde(skip_serializing_if = "Option::is_none")]
    target: Option<Target>,
}

#[derive(serde::Serialize)]
struct Target {
    /// The target, a fraction of the diagonal.
    vertex_rms_at_most: f64,
    met: bool,
    tried: Vec<cgv::skin::count::Tried>,
}

/// The arguments checked before any work.
fn check(args: &Args) -> Result<()> {
    if let Some(output) = &args.output {
        if !super::is_glb(output) {
            bail!("{}: the output should end in .glb", output.display());
        }
        cgv::output::check_output_folder(output)?;
    }
    if !(4..=255).contains(&args.bones) {
        bail!("--bones {}: a skinned glTF needs 4 to 255 bones", args.bones);
    }
    Ok(())
}

pub fn run(args: Args) -> Result<()> {
    check(&args)?;
    let src = args.input.open()?;
    let frames = (0..src.frame_count()).map(|i| src.read_frame(i)).collect::<cgv::Result<Vec<_>>>()?;
    let faces = &src.topology().faces;
    let opts = SkinOptions { bones: args.bones, iterations: args.iterations, rest: 0, affine: args.affine };
    let t = std::time::Instant::now();
    let (skin, target) = match args.target_error {
        None => (
            fit(&frames, faces, &opts, args.json).with_context(|| format!("decomposing {}", src.label().display()))?,
            None,
        ),
        Some(percent) => {
            let (skin, target) = fit_to_error(&frames, faces, &opts, percent, args.json)
                .with_context(|| format!("decomposing {}", src.label().display()))?;
            (skin, Some(target))
        }
    };
    let morph = (args.morph_targets > 0)
        .then(|| cgv::skin::residual::fit(&skin, &frames, args.morph_targets))
        .transpose()
        .context("--morph-targets")?;
    let seconds_decompose = t.elapsed().as_secs_f64();
    let name = src.label().file_stem().and_then(|s| s.to_str()).unwrap_or("motion").to_string();
    let glb_bytes = write_glb(&args, (&skin, morph.as_ref()), faces, src.fps(), &name)?;
    let played = (&skin, morph.as_ref());
    let mut report = measure(&frames, faces, played, args.surface_every, (glb_bytes, seconds_decompose))?;
    report.affine = args.affine;
    report.target = target;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    let to = args.output.as_ref().map_or("no GLB: affine bones".into(), |o| o.display().to_string());
    let kind = if args.affine { "affine" } else { "rigid" };
    println!(
        "{} -> {to} ({} frames, {} vertices, {} {kind} bones)",
        src.label().display(),
        report.frames,
        report.vertices,
        report.bones
    );
    println!(
        "  vertex error   RMS {:.4} %, max {:.4} % of the diagonal (mean over frames); KG {:.3}",
        100.0 * report.vertex_rms,
        100.0 * report.vertex_max,
        report.kg
    );
    if let Some(s) = report.surface_rms {
        println!("  surface RMS    {:.4} % of the diagonal (every {} frames)", 100.0 * s, args.surface_every);
    }
    let glb = match (report.glb_bytes, report.glb_bits_per_vertex_frame) {
        (Some(b), Some(bits)) => format!(", GLB {b} bytes ({bits:.3} bits/vertex/frame)"),
        _ => String::new(),
    };
    println!(
        "  size           {:.3} bits/vertex/frame compact (16-bit matrices, 8-bit weights{}; rest mesh not counted){glb}",
        report.compact_bits_per_vertex_frame,
        match report.morph_targets {
            0 => String::new(),
            k => format!(", {k} morph targets at 16 bits"),
        }
    );
    if let Some(t) = &report.target {
        let tried: Vec<String> = t.tried.iter().map(|c| format!("{} {:.4} %", c.bones, 100.0 * c.vertex_rms)).collect();
        let verdict = if t.met { "met" } else { "NOT met: the most bones tried were written" };
        println!(
            "  target         vertex RMS at most {:.4} %: {verdict} (bones tried: {})",
            100.0 * t.vertex_rms_at_most,
            tried.join(", ")
        );
    }
    println!("  time           {:.2} s to fit", report.seconds_decompose);
    Ok(())
}

/// The decomposition with `opts.bones` bones, with a progress bar.
fn fit(
    frames: &[Vec<glam::Vec3>],
    faces: &[[u32; 3]],
    opts: &SkinOptions,
    quiet: bool,
) -> cgv::Result<cgv::skin::Skinning> {
    let pb = super::progress(opts.iterations, "fitting bones", quiet);
    let skin = cgv::skin::decompose(frames, faces, opts, &mut |it, _| pb.set_position(it as u64));
    pb.finish_and_clear();
    skin
}

/// The fewest bones within `percent` of the diagonal (`cgv::skin::count`),
/// a progress bar over the counts.
fn fit_to_error(
    frames: &[Vec<glam::Vec3>],
    faces: &[[u32; 3]],
    opts: &SkinOptions,
    percent: f64,
    quiet: bool,
) -> Result<(cgv::skin::Skinning, Target)> {
    use cgv::skin::count::{fewest_bones_within, LADDER};
    if !(percent.is_finite() && percent > 0.0) {
        bail!("--target-error {percent}: give a positive percentage of the diagonal (0.3 for 0.3 %)");
    }
    let counts = LADDER.iter().filter(|&&b| b <= frames.first().map_or(0, Vec::len)).count();
    let pb = super::progress(counts, "fitting bone counts", quiet);
    let diagonal = |t: usize| Bounds::of(&frames[t]).diagonal() as f64;
    let fitted = fewest_bones_within(frames, faces, percent / 100.0, opts, &diagonal, &mut |_| pb.inc(1));
    pb.finish_and_clear();
    let (skin, tried, met) = fitted?;
    Ok((skin, Target { vertex_rms_at_most: percent / 100.0, met, tried }))
}

/// The GLB at `-o`, if asked for, and its size.
fn write_glb(
    args: &Args,
    (skin, morph): (&cgv::skin::Skinning, Option<&MorphTargets>),
    faces: &[[u32; 3]],
    fps: f32,
    name: &str,
) -> Result<Option<u64>> {
    let Some(output) = &args.output else { return Ok(None) };
    cgv::skin::gltf::write_skinned_glb_with(output, skin, morph, faces, fps, name)?;
    Ok(Some(std::fs::metadata(output)?.len()))
}

/// The skinning's errors against the frames (each frame's diagonal), with
/// its residual's morph targets if any, and its sizes.
fn measure(
    frames: &[Vec<glam::Vec3>],
    faces: &[[u32; 3]],
    (skin, morph): (&cgv::skin::Skinning, Option<&MorphTargets>),
    surface_every: usize,
    (glb_bytes, seconds_decompose): (Option<u64>, f64),
) -> Result<Report> {
    let diagonal = |t: usize| Bounds::of(&frames[t]).diagonal() as f64;
    let played = |t: usize| morph.map_or_else(|| skin.frame(t), |m| m.frame(skin, t));
    let e = cgv::skin::errors::measure_frames(frames, faces, &played, surface_every, &diagonal)?;
    let (n, nv) = (frames.len(), skin.rest.len());
    let per = |bits: f64| bits / (n * nv) as f64;
    // A target: 3 numbers a vertex once and a weight a frame, 16 bits each.
    let targets = morph.map_or(0, |m| m.targets.len()) as u64;
    let morph_bits = targets * 16 * (3 * nv as u64 + n as u64);
    Ok(Report {
        frames: n,
        vertices: nv,
        bones: skin.bones,
        vertex_rms: e.vertex_rms,
        vertex_max: e.vertex_max,
        surface_rms: e.surface_rms,
        kg: e.kg,
        compact_bits_per_vertex_frame: per((skin.compact_bits() + morph_bits) as f64),
        morph_targets: targets as usize,
        glb_bytes,
        glb_bits_per_vertex_frame: glb_bytes.map(|b| per(b as f64 * 8.0)),
        affine: false,
        seconds_decompose,
        target: None,
    })
}

//! `cgv unregister`: a registered motion made into a capture without
//! correspondence (every frame simplified on its own to a different size,
//! its vertices shuffled; or, with `--stable`, in runs of frames that share
//! one mesh): test data for `--unregistered`, whose truth is the input.

use super::InputArgs;
use anyhow::{bail, Context, Result};
use cgv::mesh::unregister::{keep_for, Remesh};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Output folder: one OBJ a frame (0.obj, 1.obj, ...), each its own mesh.
    #[arg(short, long)]
    output: PathBuf,
    /// Fewest faces a frame keeps, as a fraction of the input's.
    #[arg(long, default_value_t = 0.5)]
    keep_min: f32,
    /// Most faces a frame keeps (each frame draws its own between the two).
    #[arg(long, default_value_t = 0.8)]
    keep_max: f32,
    /// The draw and the vertex shuffle: the same seed makes the same folder.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Frames that share one mesh: each run of this many frames keeps its
    /// first frame's simplification, its vertices moving with the motion
    /// (a capture in "stabilized segments", as volumetric-video vendors
    /// ship them). 1: every frame its own mesh.
    #[arg(long, default_value_t = 1, value_name = "FRAMES", value_parser = clap::value_parser!(u32).range(1..))]
    stable: u32,
}

pub fn run(args: Args) -> Result<()> {
    if !(0.0 < args.keep_min && args.keep_min <= args.keep_max && args.keep_max <= 1.0) {
        bail!(
            "--keep-min and --keep-max: fractions with 0 < min <= max <= 1 (got {} and {})",
            args.keep_min,
            args.keep_max
        );
    }
    let src = args.input.open()?;
    cgv::output::check_output_folder(&args.output)?;
    // Written beside the output and renamed into place when whole: an
    // interrupted run leaves no folder that looks finished.
    let parent = args.output.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
    let partial = tempfile::Builder::new().prefix(".cgv-unregister-").tempdir_in(parent)?;
    let faces = &src.topology().faces;
    let pb = super::progress(src.frame_count(), "remeshing each frame", false);
    let (mut lo, mut hi) = (usize::MAX, 0);
    let mut remesh: Option<Remesh> = None;
    for t in 0..src.frame_count() {
        let frame = src.read_frame(t)?;
        // A run's first frame draws its own simplification; the rest share it.
        if t % args.stable as usize == 0 || remesh.is_none() {
            let keep = keep_for(t, args.keep_min, args.keep_max, args.seed);
            remesh = Some(Remesh::of(&frame, faces, keep, args.seed.wrapping_add(t as u64)));
        }
        let Some(r) = remesh.as_ref() else { continue };
        let p = r.positions(&frame);
        (lo, hi) = (lo.min(p.len()), hi.max(p.len()));
        let topology = cgv::mesh::Topology { vertex_count: p.len(), faces: r.faces.clone() };
        cgv::mesh::obj::write_obj(&partial.path().join(format!("{t}.obj")), &p, &topology)?;
        pb.inc(1);
    }
    pb.finish_and_clear();
    std::fs::rename(partial.keep(), &args.output).with_context(|| {
        format!("{}: could not be replaced (an existing folder must be empty)", args.output.display())
    })?;
    println!(
        "{}: {} frames, {lo} to {hi} vertices each (the input: {})",
        args.output.display(),
        src.frame_count(),
        src.topology().vertex_count
    );
    Ok(())
}

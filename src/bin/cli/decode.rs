//! `cgv decode`: a `.cgv` file back into a mesh sequence (GLB or OBJ folder).

use anyhow::Result;
use cgv::codec::{h264, SequenceDecoder};
use cgv::solve::SolverKind;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The .cgv file.
    input: PathBuf,
    /// Output: a .glb file (morph-target animation) or a folder (one OBJ per frame).
    #[arg(short, long)]
    output: PathBuf,
    /// Decoder for CGV files: cgv (the project's) or paper (Eq. 1 as written).
    /// Default: the one recorded in the file.
    #[arg(long)]
    solver: Option<SolverKind>,
    /// Print statistics as JSON.
    #[arg(long)]
    json: bool,
}

pub fn read_cgv(path: &std::path::Path) -> Result<cgv::container::CgvFile> {
    let bytes = std::fs::read(path).map_err(|e| cgv::Error::io(path, e))?;
    Ok(cgv::container::read(&bytes).map_err(|e| cgv::Error::Container { path: path.into(), source: e })?)
}

pub fn run(args: Args) -> Result<()> {
    let file = read_cgv(&args.input)?;
    let solver = match args.solver {
        Some(s) => s,
        None => file.header.solver.parse().unwrap_or_default(),
    };
    let grid = cgv::grid::Grid::new(file.header.grid as usize)?;
    let topo = grid.topology();
    let frames = file.header.frames as usize;
    let fps = file.header.fps;
    let mut dec = SequenceDecoder::new(file, solver, h264::Decoder::new)?;
    let pb = super::progress(frames, "decoding", args.json);
    let mut stats = Vec::with_capacity(frames);
    let mut next = |_i: usize| -> cgv::Result<Vec<glam::Vec3>> {
        let (x, s) = dec.next_frame()?;
        stats.push(s);
        pb.inc(1);
        Ok(x)
    };
    let out = &args.output;
    super::write_sequence(out, &topo, frames, fps, "cgv", &mut next)?;
    pb.finish_and_clear();
    let video: f64 = stats.iter().map(|s| s.video_seconds).sum();
    let solve: f64 = stats.iter().map(|s| s.solve_seconds).sum();
    let unconverged = stats.iter().filter(|s| s.solve.iterations > 0 && !s.solve.converged).count();
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "output": out, "frames": frames, "solver": solver.to_string(),
                "seconds_video": video, "seconds_solve": solve,
                "unconverged_frames": unconverged, "per_frame": stats,
            }))?
        );
    } else {
        println!("{} -> {} ({} frames, solver {})", args.input.display(), out.display(), frames, solver);
        println!(
            "  H.264 decode {:.1} ms/frame, reconstruction {:.1} ms/frame; {} frames did not converge",
            1000.0 * video / frames as f64,
            1000.0 * solve / frames as f64,
            unconverged
        );
    }
    Ok(())
}

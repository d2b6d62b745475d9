//! The native CLI. Each subcommand is one file; this one parses arguments,
//! reports errors, and holds what the subcommands share.

mod bdrate;
mod decode;
mod encode;
mod eval;
mod info;
mod manifest;
mod remesh;
#[cfg(feature = "render")]
mod render;
mod serve;
mod skin;
mod unregister;

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "cgv",
    version,
    about = "Conformal geometry videos: compact 3D motion, stored as video",
    long_about = "Conformal geometry videos: compact 3D motion, stored as video.\n\n\
        An INPUT is a folder of OBJ files (one frame each, ordered by the number in the name), \
        a single .obj, a glTF 2.0 animation (.gltf/.glb, baked at --fps), or `builtin:walk`, \
        the embedded default motion. Any triangle mesh is accepted: parts, open edges, handles and \
        non-manifold joints are closed up for the grid, and decoding gives the input's own mesh back.",
    after_help = "Examples:\n  cgv info builtin:walk\n  cgv info data/samba --json\n  \
        cgv remesh data/samba -o samba.glb --grid 256 --png samba.png\n  \
        cgv encode data/wolf -o wolf.cgv && cgv decode wolf.cgv -o wolf.glb"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Describe a mesh sequence (frames, size, bounds, topology checks) or a .cgv file.
    Info(info::Args),
    /// Parameterize the reference frame and resample every frame onto a seamless N x N grid.
    Remesh(remesh::Args),
    /// Encode a motion as a .cgv file (CGV or the GV baseline) with H.264.
    Encode(encode::Args),
    /// Decode a .cgv file into a mesh sequence (GLB or a folder of OBJ files).
    Decode(decode::Args),
    /// Compare GV, the paper's CGV and the project's CGV at matched bitrates (tables, JSON, plots).
    Eval(eval::Args),
    /// The BD-rate between two `cgv eval --json` reports (one codec's settings against another's).
    Bdrate(bdrate::Args),
    /// Draw one decoded frame to a PNG with the viewer's renderer (no GPU needed: lavapipe works).
    #[cfg(feature = "render")]
    Render(render::Args),
    /// Serve a folder (the web viewer in www/) on 127.0.0.1.
    Serve(serve::Args),
    /// Fit a few bones and four weights per vertex to a motion (a skinning decomposition) and write
    /// a skinned glTF that three.js and game engines play natively, with its error and size.
    Skin(skin::Args),
    /// Make a registered motion into a capture without correspondence (each frame simplified on
    /// its own and its vertices shuffled): test data for `encode --unregistered`.
    Unregister(unregister::Args),
}

/// Options shared by the commands that read a mesh sequence.
#[derive(clap::Args, Debug, Clone)]
pub struct InputArgs {
    /// Folder of OBJ frames, .obj, .gltf, .glb, builtin:walk (the embedded default motion), or
    /// builtin:walk-textured (the same with texture coordinates and a small procedural texture).
    pub input: String,
    /// Make the holes part of the mesh: each boundary loop gets a vertex at its centre and
    /// faces that decoding gives back (without it, holes are closed for the grid only and
    /// stay open in the decoded mesh).
    #[arg(long)]
    pub fill_holes: bool,
    /// Frame rate: given to OBJ sequences, and the rate at which glTF animations are baked.
    #[arg(long, default_value_t = 30.0)]
    pub fps: f32,
    /// glTF: the animation to bake, by index or name (default: the first).
    #[arg(long)]
    pub animation: Option<String>,
    /// Use only these frames: A..B (B excluded), A.., ..B or A..=B, counted from 0.
    #[arg(long, value_name = "A..B")]
    pub frames: Option<cgv::mesh::FrameSelection>,
}

impl InputArgs {
    pub fn open(&self) -> cgv::Result<Box<dyn cgv::mesh::FrameSource>> {
        cgv::mesh::open_sequence(
            &self.input,
            &cgv::mesh::OpenOptions {
                fps: self.fps,
                animation: self.animation.clone(),
                fill_holes: self.fill_holes,
                frames: self.frames,
            },
        )
    }
}

/// Whether `path` names a `.glb` file.
/// Says on stderr where the map still folds after every remedy (see
/// `cgv::param::area`): the grid resamples those faces from their
/// neighbours, and the user should know how much of the surface that is.
pub fn warn_folds(d: &cgv::param::distortion::Distortion) {
    if d.flipped_faces > 0 {
        eprintln!(
            "warning: the parameterization still folds over {} faces ({:.4} % of the surface area); \
             the grid resamples them from their neighbouring samples",
            d.flipped_faces,
            100.0 * d.flipped_area
        );
    }
}

pub fn is_glb(path: &std::path::Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb"))
}

/// Writes `frames` frames from `next` to `out`: a `.glb` (morph-target
/// animation) or a folder of numbered OBJ files.
pub fn write_sequence(
    out: &std::path::Path,
    topology: &cgv::mesh::Topology,
    frames: usize,
    fps: f32,
    name: &str,
    look: Option<&cgv::format::Appearance>,
    next: impl FnMut(usize) -> cgv::Result<Vec<glam::Vec3>>,
) -> anyhow::Result<()> {
    if is_glb(out) {
        cgv::mesh::gltf_out::write_glb(out, topology, frames, fps, name, look, next)?;
    } else if out.extension().is_none() || out.is_dir() {
        cgv::mesh::gltf_out::write_obj_folder(out, topology, frames, look, next)?;
    } else {
        anyhow::bail!("{}: output must be a .glb file or a folder", out.display());
    }
    Ok(())
}

/// A progress bar on stderr, hidden when `quiet` or stderr is not a terminal.
pub fn progress(len: usize, msg: &'static str, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    // Cleared when dropped too: an error returned past the bar leaves
    // no half-drawn bar above its message.
    let pb = ProgressBar::new(len as u64).with_finish(indicatif::ProgressFinish::AndClear);
    pb.set_style(
        ProgressStyle::with_template("{msg:>12} [{bar:30}] {pos}/{len} frames, {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(msg);
    pb
}

pub fn main() -> ExitCode {
    let argv: Vec<String> = std::env::args().collect();
    // `cgv encode --manifest JOBS.json [OPTIONS]` has no INPUT or -o, which
    // a single encode requires; each job is parsed as one instead.
    if let Some(path) = manifest::requested(&argv) {
        return report(manifest::run(&path, &argv));
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Info(a) => info::run(a),
        Command::Remesh(a) => remesh::run(a),
        Command::Encode(a) => encode::run(a),
        Command::Decode(a) => decode::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Bdrate(a) => bdrate::run(a),
        #[cfg(feature = "render")]
        Command::Render(a) => render::run(a),
        Command::Serve(a) => serve::run(a),
        Command::Skin(a) => skin::run(a),
        Command::Unregister(a) => unregister::run(a),
    };
    report(result)
}

/// The exit status of a command, its error printed.
fn report(result: anyhow::Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_text(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes, each said once: the library's errors already
/// end in their source's text (`file: problem`), so a cause whose text is
/// already there is not repeated.
pub(crate) fn error_text(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !text.contains(&c) {
            text = format!("{text}: {c}");
        }
    }
    text
}

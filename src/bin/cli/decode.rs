//! `cgv decode`: a `.cgv` file back into a mesh sequence (GLB or OBJ folder).

use anyhow::{Context, Result};
use cgv::codec::FileDecoder;
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
    /// Which mesh to write: `source` (the input's own vertices and faces,
    /// rebuilt on each decoded frame; files from format version 6 carry
    /// it), `grid` (the N x N grid mesh the file codes), or `auto` (source
    /// when the file carries it, else grid). Of an input that is not one
    /// closed genus-0 surface the grid mesh is the whole carrier: the
    /// faces that close holes and join parts included (the file does not
    /// say which samples lie on them), so only `source` has the input's
    /// own holes and parts. A file with frame meshes (`cgv encode
    /// --unregistered --mesh frames`) gives each frame's own mesh with
    /// `auto` or `source`, one OBJ a frame in the output folder.
    #[arg(long, value_enum, default_value = "auto")]
    mesh: MeshChoice,
    /// Decode only these frames: A..B (B excluded), A.., ..B or A..=B. The
    /// decoder starts at the random-access point at or before A (format
    /// version 10: one every 2 s by default; older files: frame 0) and
    /// reports how long reaching A took.
    #[arg(long)]
    frames: Option<cgv::mesh::FrameSelection>,
    #[command(flatten)]
    memory: MemoryArgs,
    /// Write a skinned glTF instead of one morph target a frame: bones and
    /// four weights per vertex fitted to the decoded motion (`cgv skin`'s
    /// decomposition), which three.js and game engines play natively; a
    /// skinned file (`--codec skinned`) gives its own bones as they are,
    /// without a fit (--bones does not apply). The decoded frames are held
    /// in memory.
    #[arg(long)]
    skinned: bool,
    /// With --skinned: the number of bones (4 to 255).
    #[arg(long, default_value_t = cgv::skin::SkinOptions::default().bones, requires = "skinned")]
    bones: usize,
    /// With --skinned: also what the bones miss of the decoded motion, as
    /// this many morph targets weighed every frame (`cgv skin
    /// --morph-targets`).
    #[arg(long, value_name = "K", default_value_t = 0, requires = "skinned")]
    morph_targets: usize,
    /// Print statistics as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, PartialEq, Debug, clap::ValueEnum)]
pub enum MeshChoice {
    Auto,
    Source,
    Grid,
}

/// The decoder's memory limit, for files from elsewhere.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct MemoryArgs {
    /// Refuse a file whose decoding would need more than this many MiB
    /// (what its header asks for: grid size, frames held, streams).
    #[arg(long, value_name = "MIB", default_value_t = 1024, value_parser = clap::value_parser!(u64).range(1..))]
    pub memory_limit: u64,
}

pub fn read_cgv(path: &std::path::Path) -> Result<cgv::format::CgvFile> {
    let bytes = std::fs::read(path).map_err(|e| cgv::Error::io(path, e))?;
    Ok(cgv::format::read(&bytes).map_err(|e| cgv::Error::Container { path: path.into(), source: e })?)
}

/// Reads `path` and starts decoding it with `solver` (default: the file's).
pub fn open_decoder(
    path: &std::path::Path,
    solver: Option<SolverKind>,
    memory: MemoryArgs,
) -> Result<(FileDecoder, SolverKind)> {
    let file = read_cgv(path)?;
    let solver = solver.unwrap_or(file.header.solver);
    let dec = FileDecoder::with_memory_limit(file, solver, memory.memory_limit.saturating_mul(1 << 20))
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok((dec, solver))
}

/// The input's mesh to rebuild, as `choice` asks: None for the grid.
pub fn source_mesh(
    path: &std::path::Path,
    dec: &FileDecoder,
    choice: MeshChoice,
) -> Result<Option<cgv::codec::SourceMeshDecoder>> {
    let skinned = dec.file.header.representation() == cgv::format::Representation::Skinned;
    Ok(match (choice, dec.source_mesh()) {
        (MeshChoice::Grid, _) if skinned => anyhow::bail!(
            "{}: the skinned codec's grid is what its bones miss, not a surface: use --mesh source (or auto)",
            path.display()
        ),
        (MeshChoice::Grid, _) if dec.file.header.representation() == cgv::format::Representation::Vertices => {
            anyhow::bail!(
                "{}: a vertices file has no grid, only your mesh: use --mesh source (or auto)",
                path.display()
            )
        }
        (MeshChoice::Grid, _) => None,
        (_, Some(s)) => Some(s),
        (MeshChoice::Source, None) => anyhow::bail!(
            "{}: the file carries no source mesh (format version {}; only version 6 files written with it do): \
             use --mesh grid",
            path.display(),
            dec.file.version
        ),
        (MeshChoice::Auto, None) => None,
    })
}

pub fn run(args: Args) -> Result<()> {
    check_skinned(&args)?;
    let (mut dec, solver) = open_decoder(&args.input, args.solver, args.memory)?;
    if dec.file.header.frame_meshes && args.mesh != MeshChoice::Grid {
        return write_frame_meshes(&args, dec, solver);
    }
    let source = source_mesh(&args.input, &dec, args.mesh)?;
    // The input's texture coordinates and material go with its own mesh.
    let look = if source.is_some() { dec.file.appearance.clone() } else { None };
    let topo = source.as_ref().map_or_else(|| dec.grid.topology(), |s| s.topology.clone());
    let mesh_name = if source.is_some() { "source" } else { "grid" };
    let (start, frames) = selected(&args, dec.frame_count())?;
    let t = std::time::Instant::now();
    let skipped = dec.seek(start as u32)?;
    let seek_seconds = t.elapsed().as_secs_f64();
    let fps = dec.file.header.fps;
    let pb = super::progress(frames, "decoding", args.json);
    let mut stats = Vec::with_capacity(frames);
    if args.skinned {
        let (decoded, own) = decode_with_bones(&mut dec, source.as_ref(), frames, &pb)?;
        return write_skinned(&args, &decoded, &topo.faces, fps, own);
    }
    let mut next = |_i: usize| -> cgv::Result<Vec<glam::Vec3>> {
        let (x, s) = next_vertices(&mut dec, source.as_ref())?;
        stats.push(s);
        pb.inc(1);
        Ok(x)
    };
    let out = &args.output;
    super::write_sequence(out, &topo, frames, fps, "cgv", look.as_ref(), &mut next)?;
    pb.finish_and_clear();
    let video: f64 = stats.iter().map(|s| s.video_seconds).sum();
    let solve: f64 = stats.iter().map(|s| s.solve_seconds).sum();
    let unconverged = stats.iter().filter(|s| s.solve.iterations > 0 && !s.solve.converged).count();
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "output": out, "frames": frames, "solver": solver.to_string(),
                "mesh": mesh_name, "vertices": topo.vertex_count, "faces": topo.faces.len(),
                "seconds_video": video, "seconds_solve": solve,
                "unconverged_frames": unconverged, "per_frame": stats,
                "first_frame": start, "seek": {"from": start as u32 - skipped, "frames_decoded": skipped,
                "seconds": seek_seconds},
            }))?
        );
    } else {
        println!(
            "{} -> {} ({} frames, solver {}, the {mesh_name} mesh: {} vertices, {} faces)",
            args.input.display(),
            out.display(),
            frames,
            solver,
            topo.vertex_count,
            topo.faces.len()
        );
        println!(
            "  H.264 decode {:.1} ms/frame, reconstruction {:.1} ms/frame; {} frames did not converge",
            1000.0 * video / frames as f64,
            1000.0 * solve / frames as f64,
            unconverged
        );
        if start > 0 {
            println!(
                "  frames {start}..{}: started at frame {} (the random-access point before it), {skipped} frames \
                 decoded to reach frame {start} in {:.1} ms",
                start + frames,
                start as u32 - skipped,
                1000.0 * seek_seconds
            );
        }
    }
    Ok(())
}

/// A file with frame meshes (format version 16): each decoded frame's own
/// vertices and faces, one OBJ a frame (their faces differ, which neither
/// morph targets nor a skin can hold).
fn write_frame_meshes(args: &Args, mut dec: FileDecoder, solver: cgv::format::SolverKind) -> Result<()> {
    let out = &args.output;
    if super::is_glb(out) || args.skinned {
        anyhow::bail!(
            "{}: every frame has its own mesh (an unregistered capture's, --mesh frames), which a glTF animation \
             cannot hold: give a folder for one OBJ a frame, or --mesh grid for the grid mesh",
            args.input.display()
        );
    }
    let (start, frames) = selected(args, dec.frame_count())?;
    dec.seek(start as u32)?;
    let pb = super::progress(frames, "decoding", args.json);
    let (mut vertices, mut faces) = (0, 0);
    cgv::mesh::gltf_out::write_obj_folder_own_faces(out, frames, |k| {
        let (x, _) = dec.next_frame()?;
        let f = (start + k) as u32;
        let mesh = dec.frame_mesh(f, &x)?;
        let mesh = mesh.ok_or_else(|| cgv::Error::Argument(format!("frame {f} has no mesh of its own")))?;
        (vertices, faces) = (vertices + mesh.0.len(), faces + mesh.1.len());
        pb.inc(1);
        Ok(mesh)
    })?;
    pb.finish_and_clear();
    let (v, f) = (vertices / frames.max(1), faces / frames.max(1));
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "output": out, "frames": frames, "solver": solver.to_string(), "mesh": "frames",
                "mean_vertices": v, "mean_faces": f, "first_frame": start,
            }))?
        );
    } else {
        println!(
            "{} -> {} ({frames} frames, solver {solver}, each frame's own mesh: {v} vertices, {f} faces on average)",
            args.input.display(),
            out.display()
        );
    }
    Ok(())
}

/// The first frame and the frame count `--frames` selects of `total`.
fn selected(args: &Args, total: usize) -> Result<(usize, usize)> {
    let Some(sel) = args.frames else { return Ok((0, total)) };
    sel.resolve(total).map_err(|m| anyhow::anyhow!("{}: --{m}", args.input.display()))
}

/// `--skinned` writes a .glb with 4 to 255 bones.
fn check_skinned(args: &Args) -> Result<()> {
    if args.skinned && !(super::is_glb(&args.output) && (4..=255).contains(&args.bones)) {
        anyhow::bail!(
            "--skinned writes a .glb with 4 to 255 --bones ({}, {} bones)",
            args.output.display(),
            args.bones
        );
    }
    Ok(())
}

/// The next frame's vertices: the input's own rebuilt on it with `source`,
/// else the grid's.
fn next_vertices(
    dec: &mut FileDecoder,
    source: Option<&cgv::codec::SourceMeshDecoder>,
) -> cgv::Result<(Vec<glam::Vec3>, cgv::codec::FrameStats)> {
    let (x, s) = dec.next_frame()?;
    let v = match source {
        Some(m) => m.vertices(&x, dec.loose(), dec.at_vertices()),
        None => x,
    };
    Ok((v, s))
}

/// `frames` frames' vertices and, of a skinned file, its own bones, each
/// frame's as decoded (none in other files).
fn decode_with_bones(
    dec: &mut FileDecoder,
    source: Option<&cgv::codec::SourceMeshDecoder>,
    frames: usize,
    pb: &indicatif::ProgressBar,
) -> Result<(Vec<Vec<glam::Vec3>>, Option<cgv::skin::Skinning>)> {
    let (mut own, mut decoded) = (None, Vec::with_capacity(frames));
    for _ in 0..frames {
        decoded.push(next_vertices(dec, source)?.0);
        own = file_bones(own, dec.vertex_bones());
        pb.inc(1);
    }
    pb.finish_and_clear();
    Ok((decoded, own))
}

/// `own` with the frame just decoded by `bones` (a skinned file's) added:
/// its rest pose and weights once, each frame's transforms.
fn file_bones(
    own: Option<cgv::skin::Skinning>,
    bones: Option<&cgv::solve::skinned::SkinnedPredictor>,
) -> Option<cgv::skin::Skinning> {
    let b = bones?;
    let mut skin = own.or_else(|| {
        let rest = b.rest()?.to_vec();
        Some(cgv::skin::Skinning { rest, bones: b.bones(), influences: b.influences().to_vec(), transforms: vec![] })
    })?;
    skin.transforms.push(b.transforms()?);
    Some(skin)
}

/// `--skinned`: a skinned file's own bones (`own`), or bones fitted to the
/// decoded frames, written as a skinned glTF, with how far the skinning is
/// from what the file decodes to.
fn write_skinned(
    args: &Args,
    decoded: &[Vec<glam::Vec3>],
    faces: &[[u32; 3]],
    fps: f32,
    own: Option<cgv::skin::Skinning>,
) -> Result<()> {
    let skin = match own {
        Some(s) => s,
        None => {
            let opts = cgv::skin::SkinOptions { bones: args.bones, ..Default::default() };
            let pb = super::progress(opts.iterations, "fitting bones", args.json);
            let skin = cgv::skin::decompose(decoded, faces, &opts, &mut |it, _| pb.set_position(it as u64))?;
            pb.finish_and_clear();
            skin
        }
    };
    let morph = (args.morph_targets > 0)
        .then(|| cgv::skin::residual::fit(&skin, decoded, args.morph_targets))
        .transpose()
        .context("--morph-targets")?;
    cgv::skin::gltf::write_skinned_glb_with(&args.output, &skin, morph.as_ref(), faces, fps, "cgv")?;
    let diagonal = |t: usize| cgv::mesh::Bounds::of(&decoded[t]).diagonal() as f64;
    let played = |t: usize| morph.as_ref().map_or_else(|| skin.frame(t), |m| m.frame(&skin, t));
    let rms = cgv::skin::errors::measure_frames(decoded, faces, &played, 0, &diagonal)?.vertex_rms;
    let bytes = std::fs::metadata(&args.output)?.len();
    if args.json {
        let report = serde_json::json!({"output": &args.output, "frames": decoded.len(), "bones": skin.bones,
            "morph_targets": args.morph_targets, "skin_vertex_rms_of_decoded": rms, "bytes": bytes});
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{} -> {} ({} frames as {} bones: {bytes} bytes; the skinning is {:.4} % of the diagonal from the decoded frames, RMS)",
            args.input.display(),
            args.output.display(),
            decoded.len(),
            skin.bones,
            100.0 * rms
        );
    }
    Ok(())
}

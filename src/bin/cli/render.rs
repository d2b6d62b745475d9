//! `cgv render`: one decoded frame drawn offscreen by the same renderer as
//! the web viewer, saved as PNG. Works without a GPU on lavapipe.

use anyhow::{bail, Context, Result};
use cgv::render::{camera::OrbitCamera, offscreen::Offscreen, ColorMode, Renderer};
use cgv::solve::SolverKind;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
#[command(after_help = "Examples:\n  cgv render walk.cgv --frame 30 -o walk-30.png\n  \
    cgv render walk.cgv --frame 30 --mode h -o walk-h.png\n  \
    cgv render walk-cgv.cgv --mode error --reference walk-gv.cgv -o error.png")]
pub struct Args {
    /// The .cgv file.
    input: PathBuf,
    /// Output PNG file.
    #[arg(short, long)]
    output: PathBuf,
    /// Frame to draw (counted from 0; earlier frames are decoded first).
    #[arg(long, default_value_t = 0)]
    frame: usize,
    /// Colour: shaded, lambda (conformal factor), h (mean curvature), error (distance to --reference).
    #[arg(long, default_value = "shaded")]
    mode: ColorMode,
    /// Another .cgv file of the same motion and grid, for --mode error.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "800x800")]
    size: String,
    /// Camera yaw and pitch in degrees (0, 9: the front, slightly from above).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    yaw: f32,
    #[arg(long, default_value_t = 9.0, allow_hyphen_values = true)]
    pitch: f32,
    /// Decoder for CGV files (default: the one recorded in the file).
    #[arg(long)]
    solver: Option<SolverKind>,
    /// The surface drawn: `source` (the input's own mesh, rebuilt from the
    /// grid; version-6 files carry it), `grid`, or `auto` (source when the
    /// file carries it and --mode is shaded, else grid: λ, H and the error
    /// map are the grid's).
    #[arg(long, value_enum, default_value = "auto")]
    mesh: super::decode::MeshChoice,
    #[command(flatten)]
    memory: super::decode::MemoryArgs,
}

/// The input's mesh and its vertices at one decoded frame.
type SourceFrame = (cgv::codec::SourceMeshDecoder, Vec<glam::Vec3>);

/// Decodes frames 0..=`frame` of `path` and returns the grid size, the
/// last frame, and the input's mesh when `mesh` asks for it with its
/// vertices at that frame.
fn decode_frame(
    path: &Path,
    frame: usize,
    solver: Option<SolverKind>,
    memory: super::decode::MemoryArgs,
    mesh: super::decode::MeshChoice,
) -> Result<(usize, Vec<glam::Vec3>, Option<SourceFrame>)> {
    let (mut dec, _) = super::decode::open_decoder(path, solver, memory)?;
    let source = super::decode::source_mesh(path, &dec, mesh)?;
    let frames = dec.frame_count();
    if frame >= frames {
        bail!("{}: frame {frame} asked for, but the file has {frames} (0..={})", path.display(), frames - 1);
    }
    let grid = dec.grid.n;
    let pb = super::progress(frame + 1, "decoding", frame < 10);
    let mut x = Vec::new();
    for _ in 0..=frame {
        x = dec.next_frame().with_context(|| format!("decoding {}", path.display()))?.0;
        pb.inc(1);
    }
    pb.finish_and_clear();
    let source = source.map(|s| {
        let vertices = s.vertices(&x, dec.loose(), dec.at_vertices());
        (s, vertices)
    });
    Ok((grid, x, source))
}

/// The renderer's material for a file's appearance: its PNG texture decoded
/// (a JPEG one is drawn by the browser's decoder only: the base colour here).
fn textured(gpu: &Offscreen, look: &cgv::format::Appearance) -> Result<cgv::render::Look> {
    let view = match &look.texture {
        Some((mime, bytes)) if mime == "image/png" => {
            let (rgba, w, h) = decode_png_rgba(bytes).context("decoding the file's texture")?;
            Some(cgv::render::texture::upload(&gpu.device, &gpu.queue, &rgba, w, h)?)
        }
        _ => None,
    };
    Ok(cgv::render::Look { uvs: look.uvs.clone(), base_color: look.base_color, view })
}

/// A PNG as 8-bit RGBA texels, with its width and height.
fn decode_png_rgba(bytes: &[u8]) -> Result<(Vec<u8>, u32, u32)> {
    let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
    dec.set_transformations(
        png::Transformations::EXPAND | png::Transformations::STRIP_16 | png::Transformations::ALPHA,
    );
    let mut reader = dec.read_info()?;
    let mut buf = vec![0; reader.output_buffer_size().context("the texture is too large")?];
    let info = reader.next_frame(&mut buf)?;
    buf.truncate(info.buffer_size());
    let rgba = match info.color_type {
        png::ColorType::Rgba => buf,
        png::ColorType::GrayscaleAlpha => buf.chunks_exact(2).flat_map(|c| [c[0], c[0], c[0], c[1]]).collect(),
        other => bail!("a texture of colour type {other:?}"),
    };
    Ok((rgba, info.width, info.height))
}

pub fn run(args: Args) -> Result<()> {
    if args.output.extension().is_none_or(|e| !e.eq_ignore_ascii_case("png")) {
        bail!("{}: the output should end in .png", args.output.display());
    }
    let (w, h) = args
        .size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|&(w, h)| (16..=8192).contains(&w) && (16..=8192).contains(&h))
        .with_context(|| format!("--size {}: expected WIDTHxHEIGHT, each 16..=8192", args.size))?;
    if args.mode == ColorMode::Error && args.reference.is_none() {
        bail!("--mode error needs --reference OTHER.cgv (the same motion and grid)");
    }
    use super::decode::MeshChoice;
    let mesh = match args.mesh {
        MeshChoice::Auto if args.mode != ColorMode::Shaded => MeshChoice::Grid,
        m => m,
    };
    let (n, x, source) = decode_frame(&args.input, args.frame, args.solver, args.memory, mesh)?;
    let look = if source.is_some() { super::decode::read_cgv(&args.input)?.appearance } else { None };
    let reference = match &args.reference {
        Some(r) => {
            let (rn, rx, _) = decode_frame(r, args.frame, None, args.memory, MeshChoice::Grid)?;
            if rn != n {
                bail!("{}: grid {rn} differs from {}'s grid {n}", r.display(), args.input.display());
            }
            Some(rx)
        }
        None => None,
    };
    let gpu = Offscreen::new()?;
    let mut renderer = Renderer::new(&gpu.device, &gpu.queue, cgv::render::offscreen::FORMAT, cgv::grid::Grid::new(n)?);
    let surface = if source.is_some() { "source mesh" } else { "grid" };
    let x = match source {
        Some((s, vertices)) if reference.is_none() => {
            renderer.set_mesh(&gpu.device, Some(s.topology.clone()))?;
            if let Some(look) = &look {
                renderer.set_texture(&gpu.device, Some(textured(&gpu, look)?))?;
            }
            vertices
        }
        Some(_) => bail!("--mode error compares grids: draw it with --mesh grid"),
        None => x,
    };
    renderer.set_frame(&gpu.queue, &x, args.mode, reference.as_deref())?;
    let (lo, hi) = renderer.bounds();
    let mut camera = OrbitCamera::framing(lo, hi);
    camera.yaw = args.yaw.to_radians();
    camera.pitch = args.pitch.to_radians();
    let rgba = gpu.render(&mut renderer, w, h, &camera)?;
    let mut png_bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut png_bytes, w, h);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let mut wr = enc.write_header()?;
        wr.write_image_data(&rgba)?;
    }
    cgv::output::write_atomic(&args.output, &png_bytes)?;
    println!(
        "{} frame {} -> {} ({w}x{h}, the {surface}, {:?}, {})",
        args.input.display(),
        args.frame,
        args.output.display(),
        args.mode,
        gpu.adapter
    );
    Ok(())
}

//! The renderer shared by `cgv render` (offscreen, natively) and the web
//! viewer (a canvas, WebGPU or WebGL2): the decoded grid as a shaded
//! surface with per-frame normals, or coloured by λ, H, or the distance to
//! a reference frame.
//!
//! Capability tiers: the pipeline uses only what WebGL2 also has (one
//! uniform buffer, vertex and index buffers, a depth buffer; no compute,
//! no storage buffers), so one code path serves every backend.

pub mod camera;
#[cfg(not(target_arch = "wasm32"))]
pub mod offscreen;
pub mod texture;

use crate::error::{Error, Result};
use crate::grid::stencil::Stencils;
use crate::grid::Grid;
use camera::OrbitCamera;
use glam::Vec3;
use wgpu::util::DeviceExt;

/// The material of a mesh drawn by the renderer: per-vertex texture
/// coordinates, the base colour, and the texture ([`texture::upload`]).
pub struct Look {
    pub uvs: Vec<[f32; 2]>,
    pub base_color: [f32; 4],
    pub view: Option<wgpu::TextureView>,
}

/// What colours the surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColorMode {
    /// Grey, shaded.
    #[default]
    Shaded,
    /// The conformal factor λ (mean grid edge length at a sample).
    Lambda,
    /// The mean curvature H = Δv·n.
    H,
    /// Distance to a reference frame at each sample.
    Error,
}

impl std::str::FromStr for ColorMode {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "shaded" => Ok(ColorMode::Shaded),
            "lambda" => Ok(ColorMode::Lambda),
            "h" | "H" => Ok(ColorMode::H),
            "error" => Ok(ColorMode::Error),
            _ => Err(format!("unknown colour mode '{s}' (expected shaded, lambda, h or error)")),
        }
    }
}

#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    position: [f32; 3],
    normal: [f32; 3],
    value: f32,
    uv: [f32; 2],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Uniforms {
    view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    scalar: [f32; 4],
    /// The input's base colour; w: 1 when it and its texture colour the surface.
    tint: [f32; 4],
}

/// The depth format; every backend, WebGL2 included, has it.
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Draws one grid surface, or a mesh of its own (the input's, rebuilt from
/// the grid: [`Renderer::set_mesh`]).
pub struct Renderer {
    st: Stencils,
    /// The mesh drawn instead of the grid, when there is one, and its
    /// vertices' texture coordinates (empty: none).
    mesh: Option<crate::mesh::Topology>,
    uvs: Vec<[f32; 2]>,
    /// The base colour (factor) of the mesh's material, when it has one.
    base_color: Option<[f32; 4]>,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    white: wgpu::TextureView,
    pipeline: wgpu::RenderPipeline,
    uniforms: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    depth: Option<(wgpu::TextureView, (u32, u32))>,
    scalar: [f32; 4],
    bounds: (Vec3, Vec3),
}

/// The surface's render pipeline: the shader of `shader.wgsl`, one vertex
/// buffer of [`Vertex`], depth tested, drawing into `format`.
fn surface_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("cgv surface"),
        source: wgpu::ShaderSource::Wgsl(include_str!("shader.wgsl").into()),
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("cgv surface"),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32, 3 => Float32x2];
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("cgv surface"),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &shader,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &attributes,
            })],
        },
        primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &shader,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

impl Renderer {
    /// A renderer for `grid`, drawing into targets of `format`.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, format: wgpu::TextureFormat, grid: Grid) -> Renderer {
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cgv uniforms"),
            size: std::mem::size_of::<Uniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let layout = texture::layout(device);
        let sampler = texture::sampler(device);
        let white = texture::white(device, queue);
        let bind_group = texture::bind_group(device, &layout, &uniforms, &white, &sampler);
        let pipeline = surface_pipeline(device, &layout, format);
        let index_data: Vec<u32> = grid.topology().faces.iter().flatten().copied().collect();
        let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cgv indices"),
            contents: bytemuck::cast_slice(&index_data),
            usage: wgpu::BufferUsages::INDEX,
        });
        let vertices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cgv vertices"),
            size: (grid.len() * std::mem::size_of::<Vertex>()) as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Renderer {
            st: Stencils::new(grid),
            mesh: None,
            uvs: Vec::new(),
            base_color: None,
            layout,
            sampler,
            white,
            pipeline,
            uniforms,
            bind_group,
            vertices,
            indices,
            index_count: index_data.len() as u32,
            depth: None,
            scalar: [0.0; 4],
            bounds: (Vec3::splat(-1.0), Vec3::splat(1.0)),
        }
    }

    /// Draws `mesh` (its vertices given to [`set_frame`](Self::set_frame))
    /// instead of the grid, or the grid again with `None`; without a
    /// texture ([`set_texture`](Self::set_texture)).
    pub fn set_mesh(&mut self, device: &wgpu::Device, mesh: Option<crate::mesh::Topology>) -> Result<()> {
        let (faces, count) = match &mesh {
            Some(m) => (m.faces.clone(), m.vertex_count),
            None => (self.st.grid.topology().faces, self.st.grid.len()),
        };
        if let Some(bad) = faces.iter().flatten().find(|&&v| v as usize >= count) {
            return Err(Error::Render(format!("a face uses vertex {bad} of a mesh of {count}")));
        }
        let index_data: Vec<u32> = faces.iter().flatten().copied().collect();
        self.indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cgv indices"),
            contents: bytemuck::cast_slice(&index_data),
            usage: wgpu::BufferUsages::INDEX,
        });
        self.vertices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cgv vertices"),
            size: (count.max(1) * std::mem::size_of::<Vertex>()) as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.index_count = index_data.len() as u32;
        self.mesh = mesh;
        self.set_texture(device, None)
    }

    /// Colours the mesh of [`set_mesh`](Self::set_mesh) by its material:
    /// `look`'s texture coordinates (one per mesh vertex), its base colour
    /// and, when given, its base colour texture as RGBA8 texels (width,
    /// height); `None` goes back to grey.
    pub fn set_texture(&mut self, device: &wgpu::Device, look: Option<Look>) -> Result<()> {
        let count = self.mesh.as_ref().map_or(0, |m| m.vertex_count);
        let look = match look {
            Some(l) if l.uvs.len() != count => {
                return Err(Error::Render(format!("{} texture coordinates for a mesh of {count}", l.uvs.len())));
            }
            other => other,
        };
        let view = match look.as_ref().and_then(|l| l.view.as_ref()) {
            Some(view) => view,
            None => &self.white,
        };
        self.bind_group = texture::bind_group(device, &self.layout, &self.uniforms, view, &self.sampler);
        self.base_color = look.as_ref().map(|l| l.base_color);
        self.uvs = look.map(|l| l.uvs).unwrap_or_default();
        Ok(())
    }

    /// Uploads a frame: grid positions (or the mesh's vertices, after
    /// [`set_mesh`](Self::set_mesh)), and for [`ColorMode::Error`] the
    /// reference positions to measure against.
    pub fn set_frame(
        &mut self,
        queue: &wgpu::Queue,
        x: &[Vec3],
        mode: ColorMode,
        reference: Option<&[Vec3]>,
    ) -> Result<()> {
        let n = self.mesh.as_ref().map_or(self.st.grid.len(), |m| m.vertex_count);
        if x.len() != n || reference.is_some_and(|r| r.len() != n) {
            return Err(Error::Render(format!("a frame of {} points for a surface of {n}", x.len())));
        }
        let normals = match &self.mesh {
            Some(m) => crate::mesh::vertex_normals(x, &m.faces),
            None => (0..n).map(|v| normal(&self.st, x, v)).collect(),
        };
        if self.mesh.is_some() && matches!(mode, ColorMode::Lambda | ColorMode::H) {
            return Err(Error::Render("λ and H are the grid's: draw the grid to see them".into()));
        }
        let values: Vec<f32> = match (mode, reference) {
            (ColorMode::Shaded, _) => vec![0.0; n],
            (ColorMode::Lambda, _) => (0..n).map(|v| self.st.lambda(x, v)).collect(),
            (ColorMode::H, _) => (0..n).map(|v| self.st.laplacian(x, v).dot(normal(&self.st, x, v))).collect(),
            (ColorMode::Error, Some(r)) => x.iter().zip(r).map(|(p, q)| p.distance(*q)).collect(),
            (ColorMode::Error, None) => return Err(Error::Render("the error map needs a reference".into())),
        };
        let vertices: Vec<Vertex> = (0..n)
            .map(|v| Vertex {
                position: x[v].to_array(),
                normal: normals[v].to_array(),
                value: values[v],
                uv: self.uvs.get(v).copied().unwrap_or_default(),
            })
            .collect();
        queue.write_buffer(&self.vertices, 0, bytemuck::cast_slice(&vertices));
        self.bounds = x
            .iter()
            .fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        self.scalar = match mode {
            ColorMode::Shaded => [0.0, 1.0, 0.0, 0.0],
            ColorMode::H => {
                // Symmetric about 0, so white means flat.
                let m = percentile(values.iter().map(|v| v.abs()), 0.98).max(1e-12);
                [-m, m, 1.0, 0.0]
            }
            ColorMode::Error => [0.0, percentile(values.iter().copied(), 0.98).max(1e-12), 1.0, 0.0],
            ColorMode::Lambda => {
                [percentile(values.iter().copied(), 0.02), percentile(values.iter().copied(), 0.98), 1.0, 0.0]
            }
        };
        Ok(())
    }

    /// Bounds of the last frame set.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// Draws the last frame into `target` (of the renderer's format).
    pub fn draw(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target: &wgpu::TextureView,
        size: (u32, u32),
        camera: &OrbitCamera,
    ) {
        let depth = match self.depth.take() {
            Some(d) if d.1 == size => d,
            _ => {
                let tex = device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("cgv depth"),
                    size: wgpu::Extent3d { width: size.0.max(1), height: size.1.max(1), depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: DEPTH,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                    view_formats: &[],
                });
                (tex.create_view(&Default::default()), size)
            }
        };
        let u = Uniforms {
            view_proj: camera.view_proj(size.0 as f32 / size.1.max(1) as f32).to_cols_array_2d(),
            eye: camera.eye().extend(1.0).to_array(),
            scalar: self.scalar,
            tint: match self.base_color {
                Some([r, g, b, _]) if self.scalar[2] < 0.5 => [r, g, b, 1.0],
                _ => [1.0, 1.0, 1.0, 0.0],
            },
        };
        queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let depth = &depth.0;
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("cgv surface"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color { r: 0.07, g: 0.08, b: 0.10, a: 1.0 }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: depth,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.set_vertex_buffer(0, self.vertices.slice(..));
            pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..self.index_count, 0, 0..1);
        }
        queue.submit([enc.finish()]);
        self.depth = Some(depth);
    }
}

/// The unit normal x_u × x_v at a sample, as the codec defines it.
fn normal(st: &Stencils, x: &[Vec3], v: usize) -> Vec3 {
    let (xu, xv) = st.tangents(x, v);
    xu.cross(xv).normalize_or_zero()
}

fn percentile(values: impl Iterator<Item = f32>, q: f32) -> f32 {
    let mut v: Vec<f32> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    let k = ((v.len() - 1) as f32 * q).round() as usize;
    *v.select_nth_unstable_by(k, f32::total_cmp).1
}

/// The background colour, for tests that look for the figure.
pub const BACKGROUND: [u8; 3] = [18, 20, 26];

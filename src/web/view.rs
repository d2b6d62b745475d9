//! A canvas drawing one decoded grid, or the input's mesh rebuilt from it,
//! with the shared renderer.

use super::{js, positions};
use crate::grid::Grid;
use crate::render::{camera::OrbitCamera, ColorMode, Renderer};
use glam::Vec3;
use wasm_bindgen::prelude::*;

/// A canvas showing one decoded grid, with an orbit camera.
#[wasm_bindgen]
pub struct View {
    surface: wgpu::Surface<'static>,
    device: wgpu::Device,
    queue: wgpu::Queue,
    config: wgpu::SurfaceConfiguration,
    renderer: Renderer,
    camera: OrbitCamera,
    home: OrbitCamera,
    backend: String,
    reference: Option<Vec<Vec3>>,
    last: Option<(Vec<Vec3>, ColorMode)>,
}

#[wasm_bindgen]
impl View {
    /// Starts the GPU on `canvas` for an N x N grid: WebGPU when the browser
    /// has an adapter, else WebGL2 (`force_webgl` skips WebGPU, for tests
    /// and comparisons).
    pub async fn create(
        canvas: web_sys::HtmlCanvasElement,
        grid: u32,
        force_webgl: bool,
    ) -> std::result::Result<View, JsError> {
        let grid = Grid::new(grid as usize).map_err(js)?;
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends =
            if force_webgl { wgpu::Backends::GL } else { wgpu::Backends::BROWSER_WEBGPU | wgpu::Backends::GL };
        // Detection: BROWSER_WEBGPU alone would hide the GL fallback when
        // navigator.gpu exists but gives no adapter.
        let instance = wgpu::util::new_instance_with_webgpu_detection(desc).await;
        let (w, h) = (canvas.width().max(1), canvas.height().max(1));
        // The GL backend finds an adapter only through a surface: make it first.
        let surface = instance.create_surface(wgpu::SurfaceTarget::Canvas(canvas)).map_err(js)?;
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: Some(&surface),
                apply_limit_buckets: false,
            })
            .await
            .map_err(|e| JsError::new(&format!("no WebGPU or WebGL2 adapter: {e}")))?;
        let info = adapter.get_info();
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("cgv viewer"),
                required_limits: wgpu::Limits::downlevel_webgl2_defaults().using_resolution(adapter.limits()),
                ..Default::default()
            })
            .await
            .map_err(js)?;
        let caps = surface.get_capabilities(&adapter);
        // WebGL2 canvases default to sRGB, WebGPU to plain 8-bit: prefer the
        // plain one so both backends (and `cgv render`) show the same colours.
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| !f.is_srgb())
            .or(caps.formats.first().copied())
            .ok_or_else(|| JsError::new("the canvas offers no format"))?;
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width: w,
            height: h,
            present_mode: wgpu::PresentMode::Fifo,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
        };
        surface.configure(&device, &config);
        let renderer = Renderer::new(&device, &queue, format, grid);
        let backend = match info.backend {
            wgpu::Backend::BrowserWebGpu => "WebGPU".to_string(),
            wgpu::Backend::Gl => "WebGL2".to_string(),
            other => format!("{other:?}"),
        };
        let camera = OrbitCamera::framing(Vec3::splat(-1.0), Vec3::splat(1.0));
        Ok(View {
            surface,
            device,
            queue,
            config,
            renderer,
            camera,
            home: camera,
            backend,
            reference: None,
            last: None,
        })
    }

    /// "WebGPU" or "WebGL2".
    pub fn backend(&self) -> String {
        self.backend.clone()
    }

    /// Shows a frame (x, y, z per sample) coloured by `mode` (shaded,
    /// lambda, h, error). The first frame also frames the camera.
    pub fn set_frame(&mut self, flat: &[f32], mode: &str) -> std::result::Result<(), JsError> {
        let mut mode: ColorMode = mode.parse().map_err(|e: String| JsError::new(&e))?;
        if mode == ColorMode::Error && self.reference.is_none() {
            mode = ColorMode::Shaded;
        }
        let x = positions(flat);
        self.renderer.set_frame(&self.queue, &x, mode, self.reference.as_deref()).map_err(js)?;
        if self.last.is_none() {
            let (lo, hi) = self.renderer.bounds();
            self.home = OrbitCamera::framing(lo, hi);
            self.camera = self.home;
        }
        self.last = Some((x, mode));
        Ok(())
    }

    /// Draws a mesh of its own instead of the grid: `faces` (three vertex
    /// indices each, as `Player.source_faces()` gives them) over
    /// `vertex_count` vertices, whose positions `set_frame` then takes
    /// (`Player.source_vertices(gridFrame)`). Empty `faces` draws the grid
    /// again.
    pub fn set_mesh(&mut self, faces: &[u32], vertex_count: u32) -> std::result::Result<(), JsError> {
        if faces.len() % 3 != 0 {
            return Err(JsError::new(&format!("{} face indices: not a multiple of 3", faces.len())));
        }
        let mesh = (!faces.is_empty()).then(|| crate::mesh::Topology {
            vertex_count: vertex_count as usize,
            faces: faces.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        });
        self.renderer.set_mesh(&self.device, mesh).map_err(js)
    }

    /// Colours the mesh of [`set_mesh`](Self::set_mesh) by the input's
    /// material: `uvs` (u, v per vertex: `Player.source_uvs()`), the base
    /// colour (r, g, b, a: `header.appearance.base_color`) and, when
    /// `width` > 0, its texture as RGBA8 texels (the page decodes the image
    /// from `Player.texture_bytes()`). Empty `uvs` goes back to grey.
    pub fn set_texture(
        &mut self,
        uvs: &[f32],
        base_color: &[f32],
        rgba: &[u8],
        width: u32,
        height: u32,
    ) -> std::result::Result<(), JsError> {
        if uvs.is_empty() {
            return self.renderer.set_texture(&self.device, None).map_err(js);
        }
        let base_color = match base_color {
            [r, g, b, a] => [*r, *g, *b, *a],
            _ => return Err(JsError::new("the base colour is four numbers (r, g, b, a)")),
        };
        let view = match width {
            0 => None,
            _ => Some(crate::render::texture::upload(&self.device, &self.queue, rgba, width, height).map_err(js)?),
        };
        let uvs = uvs.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
        self.renderer.set_texture(&self.device, Some(crate::render::Look { uvs, base_color, view })).map_err(js)
    }

    /// Frames the camera on the next frame set (a new motion in the same view).
    pub fn reframe(&mut self) {
        self.last = None;
    }

    /// The frame the error map measures against (empty to clear).
    pub fn set_reference(&mut self, flat: &[f32]) {
        self.reference = if flat.is_empty() { None } else { Some(positions(flat)) };
    }

    pub fn drag(&mut self, dx: f32, dy: f32) {
        self.camera.drag(dx, dy);
    }

    pub fn zoom(&mut self, factor: f32) {
        self.camera.zoom(factor);
    }

    pub fn reset(&mut self) {
        self.camera = self.home;
    }

    /// [target x, y, z, distance, yaw, pitch], to synchronize two views.
    pub fn camera_state(&self) -> Vec<f32> {
        let c = &self.camera;
        vec![c.target.x, c.target.y, c.target.z, c.distance, c.yaw, c.pitch]
    }

    pub fn set_camera_state(&mut self, s: &[f32]) {
        if let [x, y, z, d, yaw, pitch] = *s {
            self.camera = OrbitCamera { target: Vec3::new(x, y, z), distance: d, yaw, pitch, ..self.camera };
        }
    }

    /// Follows a canvas resize (device pixels).
    pub fn resize(&mut self, width: u32, height: u32) {
        if width > 0 && height > 0 && (width, height) != (self.config.width, self.config.height) {
            self.config.width = width;
            self.config.height = height;
            self.surface.configure(&self.device, &self.config);
        }
    }

    /// Draws the current frame.
    pub fn draw(&mut self) -> std::result::Result<(), JsError> {
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            _ => {
                // Lost, outdated or timed out: configure again and skip this frame.
                self.surface.configure(&self.device, &self.config);
                return Ok(());
            }
        };
        let view = frame.texture.create_view(&Default::default());
        self.renderer.draw(&self.device, &self.queue, &view, (self.config.width, self.config.height), &self.camera);
        self.queue.present(frame);
        Ok(())
    }
}

//! Offscreen rendering for `cgv render`: a headless device (Vulkan, which
//! lavapipe provides without a GPU; GL as a fallback), one frame drawn into
//! a texture and read back as RGBA.

use super::camera::OrbitCamera;
use super::Renderer;
use crate::error::{Error, Result};

/// The target format: plain 8-bit RGBA, as a WebGPU canvas gives, so native
/// and web pictures match.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// A headless GPU device.
pub struct Offscreen {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// The adapter's name and backend, for reports.
    pub adapter: String,
}

impl Offscreen {
    pub fn new() -> Result<Offscreen> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12 | wgpu::Backends::GL;
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            apply_limit_buckets: false,
        }))
        .map_err(|e| {
            Error::Render(format!(
                "no GPU adapter ({e}); on Debian, `apt-get install mesa-vulkan-drivers` gives a software one (lavapipe)"
            ))
        })?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("cgv offscreen"),
            required_limits: wgpu::Limits::downlevel_webgl2_defaults().using_resolution(adapter.limits()),
            ..Default::default()
        }))
        .map_err(|e| Error::Render(format!("device request failed: {e}")))?;
        Ok(Offscreen { device, queue, adapter: format!("{} ({:?})", info.name, info.backend) })
    }

    /// Draws `renderer`'s current frame at `width` x `height` and returns
    /// the pixels, RGBA, row by row.
    pub fn render(&self, renderer: &mut Renderer, width: u32, height: u32, camera: &OrbitCamera) -> Result<Vec<u8>> {
        if width == 0 || height == 0 || width > 8192 || height > 8192 {
            return Err(Error::Argument(format!("image size {width}x{height} is not in 1..=8192")));
        }
        let tex = self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("cgv offscreen"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = tex.create_view(&Default::default());
        renderer.draw(&self.device, &self.queue, &view, (width, height), camera);
        // Rows are padded to 256 bytes for the copy.
        let row = width * 4;
        let padded = row.div_ceil(256) * 256;
        let buf = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cgv read-back"),
            size: (padded * height) as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &tex,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buf,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded), rows_per_image: None },
            },
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        );
        self.queue.submit([enc.finish()]);
        let slice = buf.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::Wait { submission_index: None, timeout: None })
            .map_err(|e| Error::Render(format!("waiting for the GPU: {e}")))?;
        rx.recv()
            .map_err(|_| Error::Render("read-back never finished".into()))?
            .map_err(|e| Error::Render(format!("read-back failed: {e}")))?;
        let data = slice.get_mapped_range().map_err(|e| Error::Render(format!("read-back mapping: {e}")))?;
        let mut out = Vec::with_capacity((row * height) as usize);
        for y in 0..height {
            let start = (y * padded) as usize;
            out.extend_from_slice(&data[start..start + row as usize]);
        }
        Ok(out)
    }
}

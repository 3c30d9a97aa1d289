//! Reading the drawn image back, and tonemapping it to 8-bit sRGB on the GPU
//! (`shaders/draw/tonemap.wgsl`): into a buffer to read, or into a display texture.

use super::{DISPLAY, GpuDraw, ToneParams};
use crate::shade::PassTime;
use crate::{GpuContext, GpuError, shaders};
use glam::Vec3;
use std::time::Instant;

impl GpuDraw {
    /// The last drawn image, linear: row-major pixels (row 0 at the top) and whether an
    /// object covers each.
    pub fn read_linear(&self) -> Result<(Vec<Vec3>, Vec<bool>), GpuError> {
        let t = self.target.as_ref().ok_or_else(|| GpuError::Scene("nothing drawn yet".into()))?;
        let n = t.width as usize * t.height as usize;
        let (mut pixels, mut covered) = (Vec::with_capacity(n), Vec::with_capacity(n));
        let staging = t.readback.get_or_init(|| self.ctx.readback_buffer("image readback", staging_size(&t.color, 16)));
        self.read_texture(&t.color, 16, staging, |row| {
            for p in row.chunks_exact(16) {
                let f = |i: usize| f32::from_le_bytes([p[i], p[i + 1], p[i + 2], p[i + 3]]);
                pixels.push(Vec3::new(f(0), f(4), f(8)));
                covered.push(f(12) > 0.5);
            }
        })?;
        Ok((pixels, covered))
    }

    /// Tonemaps the last drawn image at `exposure` on the GPU and reads it back as
    /// interleaved 8-bit sRGB.
    pub fn tonemap(&mut self, exposure: f32) -> Result<(Vec<u8>, PassTime), GpuError> {
        let t = self.target.as_ref().ok_or_else(|| GpuError::Scene("nothing drawn yet".into()))?;
        let (encoded, size) = (t.encoded.clone(), u64::from(t.width) * u64::from(t.height) * 4);
        let staging = t.tone_readback.get_or_init(|| self.ctx.readback_buffer("tonemap readback", size)).clone();
        let start = Instant::now();
        self.run_tonemap(
            "tonemap",
            exposure,
            false,
            wgpu::BindingResource::Buffer(encoded.as_entire_buffer_binding()),
        )?;
        let mut enc =
            self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("tonemap readback") });
        enc.copy_buffer_to_buffer(&encoded, 0, &staging, 0, size);
        self.ctx.queue.submit([enc.finish()]);
        let rgb = self.ctx.read_mapped(&staging, |words| {
            let mut rgb = Vec::with_capacity(words.len() / 4 * 3);
            rgb.extend(words.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]));
            rgb
        })?;
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok((rgb, PassTime { gpu_ms: None, wall_ms, antialias_ms: None, antialias_gpu_ms: None }))
    }

    /// Runs a tonemap pass over the last drawn image at `exposure`, writing to `output`
    /// (binding 2): the read-back buffer, or with `texture` a display texture.
    fn run_tonemap(
        &mut self,
        operation: &'static str,
        exposure: f32,
        texture: bool,
        output: wgpu::BindingResource<'_>,
    ) -> Result<(), GpuError> {
        self.ctx.check_alive()?;
        let t = self.target.as_ref().ok_or_else(|| GpuError::Scene("nothing drawn yet".into()))?;
        let params = ToneParams { exposure, width: t.width, height: t.height, pad: 0 };
        self.ctx.queue.write_buffer(&self.tone_params, 0, bytemuck::bytes_of(&params));
        let view = t.color.create_view(&wgpu::TextureViewDescriptor::default());
        let (layout, pipeline) = if texture {
            (&self.tone_texture_layout, &self.tonemap_texture)
        } else {
            (&self.tone_layout, &self.tonemap)
        };
        let bind = self.ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(operation),
            layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.tone_params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&view) },
                wgpu::BindGroupEntry { binding: 2, resource: output },
            ],
        });
        let scope = self.ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut enc =
            self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(operation) });
        {
            let mut pass =
                enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(operation), timestamp_writes: None });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(t.width.div_ceil(8), t.height.div_ceil(8), 1);
        }
        self.ctx.queue.submit([enc.finish()]);
        match pollster::block_on(scope.pop()) {
            Some(e) => Err(GpuError::Operation { operation, message: e.to_string() }),
            None => Ok(()),
        }
    }

    /// The size of the last drawn image, if any.
    pub fn size(&self) -> Option<(u32, u32)> {
        self.target.as_ref().map(|t| (t.width, t.height))
    }

    /// A texture the size of the last drawn image that [`GpuDraw::tonemap_into`] can write
    /// and a shader can sample ([`DISPLAY`], storage and texture binding, copy source).
    pub fn display_texture(&self) -> Result<wgpu::Texture, GpuError> {
        let (width, height) = self.size().ok_or_else(|| GpuError::Scene("nothing drawn yet".into()))?;
        Ok(self.ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("display image"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DISPLAY,
            usage: wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[wgpu::TextureFormat::Rgba8UnormSrgb],
        }))
    }

    /// Tonemaps the last drawn image at `exposure` into `target` (a [`DISPLAY`] storage
    /// texture of the image's size, such as [`GpuDraw::display_texture`]), on the GPU with no
    /// readback: the same 8-bit sRGB values [`GpuDraw::tonemap`] returns, alpha 1.
    pub fn tonemap_into(&mut self, exposure: f32, target: &wgpu::Texture) -> Result<PassTime, GpuError> {
        let (width, height) = self.size().ok_or_else(|| GpuError::Scene("nothing drawn yet".into()))?;
        if target.format() != DISPLAY || (target.width(), target.height()) != (width, height) {
            return Err(GpuError::Scene(format!(
                "tonemap target is {:?} {}×{}; the image needs {DISPLAY:?} {width}×{height}",
                target.format(),
                target.width(),
                target.height(),
            )));
        }
        let out = target.create_view(&wgpu::TextureViewDescriptor::default());
        let start = Instant::now();
        self.run_tonemap("tonemap into a texture", exposure, true, wgpu::BindingResource::TextureView(&out))?;
        Ok(PassTime {
            gpu_ms: None,
            wall_ms: start.elapsed().as_secs_f64() * 1e3,
            antialias_ms: None,
            antialias_gpu_ms: None,
        })
    }

    /// Reads a [`DISPLAY`] texture back as interleaved 8-bit RGB (for tests and screenshots).
    pub fn read_display(&self, texture: &wgpu::Texture) -> Result<Vec<u8>, GpuError> {
        let mut rgb = Vec::with_capacity(texture.width() as usize * texture.height() as usize * 3);
        let staging = self.ctx.readback_buffer("display readback", staging_size(texture, 4));
        self.read_texture(texture, 4, &staging, |row| {
            rgb.extend(row.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]));
        })?;
        Ok(rgb)
    }

    /// Copies a 2D texture of `texel` bytes per texel into `staging` (a readback buffer of
    /// [`staging_size`]) and hands `row` each of its rows in turn (row 0 first, without the
    /// copy's row padding).
    fn read_texture(
        &self,
        texture: &wgpu::Texture,
        texel: u64,
        staging: &wgpu::Buffer,
        mut row: impl FnMut(&[u8]),
    ) -> Result<(), GpuError> {
        let (w, h) = (texture.width(), texture.height());
        let bytes = u64::from(w) * texel;
        let padded = bytes.next_multiple_of(u64::from(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT));
        let mut enc =
            self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded as u32),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        self.ctx.queue.submit([enc.finish()]);
        self.ctx.read_mapped(staging, |mapped| {
            for r in mapped.chunks_exact(padded as usize) {
                row(&r[..bytes as usize]);
            }
        })
    }
}

/// The bytes of a readback buffer for a 2D texture of `texel` bytes per texel: its rows
/// padded to the copy's alignment.
fn staging_size(texture: &wgpu::Texture, texel: u64) -> u64 {
    let padded = (u64::from(texture.width()) * texel).next_multiple_of(u64::from(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT));
    padded * u64::from(texture.height())
}

/// A binding of a compute pass's bind group layout.
pub(super) fn compute_entry(binding: u32, ty: wgpu::BindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry { binding, visibility: wgpu::ShaderStages::COMPUTE, ty, count: None }
}

/// The bind group layout and compute pipeline of a tonemap pass: parameters (0), the
/// linear image (1) and `output` (2).
pub(super) fn tone_pipeline(
    ctx: &GpuContext,
    shader: &shaders::Shader,
    output: wgpu::BindingType,
) -> Result<(wgpu::BindGroupLayout, wgpu::ComputePipeline), GpuError> {
    let layout = ctx.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(shader.name),
        entries: &[
            compute_entry(
                0,
                wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
            ),
            compute_entry(
                1,
                wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
            ),
            compute_entry(2, output),
        ],
    });
    let pipeline_layout = ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(shader.name),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = ctx.compute_pipeline_with_layout(shader, &[], Some(&pipeline_layout))?;
    Ok((layout, pipeline))
}

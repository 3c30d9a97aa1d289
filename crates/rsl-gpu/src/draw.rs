//! The draw pass (Xu et al. 2006, §5.2: "shade vertices, then draw with the result"):
//! the environment behind (`shaders/draw/background.wgsl`), the objects' triangles coloured
//! by the shading pass's vertex radiance and depth-tested (`shaders/draw/objects.wgsl`),
//! headless into a linear RGBA32F texture (alpha = covered by an object), then tonemapping
//! to 8-bit sRGB (`shaders/draw/tonemap.wgsl`); both can be read back.

use crate::lobes::{LobeObject, LobeParams, pack_environment, pack_objects};
use crate::shade::{GpuShading, PassTime, PixelLayout, columns, shading_constants};
use crate::{GpuContext, GpuError, shaders};
use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Vec3};
use rsl_scene::Camera;
use std::sync::Arc;
use std::time::Instant;

mod antialias;
mod readback;
pub use antialias::AaParams;
use readback::{compute_entry, tone_pipeline};

/// Mirrors WGSL `DrawParams` in `shaders/common/draw.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct DrawParams {
    /// Clip from world (reversed depth, infinite far plane), columns.
    pub clip_from_world: [[f32; 4]; 4],
    /// Camera right, up, back in world space.
    pub world_from_camera: [[f32; 4]; 3],
    /// Environment from world.
    pub env_from_world: [[f32; 4]; 3],
    /// tan(fov/2)·aspect, tan(fov/2), width, height.
    pub lens: [f32; 4],
    /// Constant radiance (rgb) and intensity (w).
    pub constant: [f32; 4],
    /// Map width (0: constant environment).
    pub map_width: u32,
    /// Map height.
    pub map_height: u32,
    /// Where the pass samples each pixel, as a shift of the image in pixels (x right, y
    /// down): `0.5 − o` for the sample at offset `o` in the pixel's square; 0 at the centre.
    pub shift: [f32; 2],
}

/// Mirrors WGSL `ToneParams` in `shaders/draw/tonemap.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct ToneParams {
    /// Exposure multiplier.
    pub exposure: f32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Padding.
    pub pad: u32,
}

/// Mirrors WGSL `PixelParams` in `shaders/draw/pixels.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct PixelParams {
    /// xyz: the eye; w: θ_max of isotropic tables.
    pub eye: [f32; 4],
    /// Vertices of all objects.
    pub vertex_count: u32,
    /// Objects.
    pub object_count: u32,
    /// RSLs.
    pub light_count: u32,
    /// Bit 0: self visibility; bit 1: occluders.
    pub terms: u32,
    /// Rays per traced light at a pixel.
    pub pixel_rays: u32,
    /// Directions stored per traced light.
    pub rays_per_light: u32,
    /// Where they start in the frame buffer.
    pub rays_at: u32,
    /// Rays' lift off the surface.
    pub lift: f32,
    /// Where the objects' flags start in the frame buffer.
    pub objects_at: u32,
    /// Padding.
    pub pad0: u32,
    /// Padding.
    pub pad1: u32,
    /// Padding.
    pub pad2: u32,
}

/// The environment behind the objects.
#[derive(Clone, Debug)]
pub enum Backdrop<'a> {
    /// A lat-long map (`width × height` texels, row 0 at the top) and its intensity.
    Map {
        /// Map width.
        width: u32,
        /// Map height.
        height: u32,
        /// Texels, row-major.
        texels: &'a [Vec3],
        /// Intensity.
        intensity: f32,
    },
    /// A constant radiance (intensity included).
    Constant(Vec3),
}

const COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// The most triangles the RSL sum per pixel draws: the draw pass records each pixel's
/// triangle as an f32, exact below 2^24.
const MAX_PIXEL_TRIANGLES: u32 = 1 << 24;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// The format of display images ([`GpuDraw::tonemap_into`]): 8-bit, holding sRGB-encoded
/// values (sample it through an `Rgba8UnormSrgb` view or as-is where the consumer expects
/// encoded values).
pub const DISPLAY: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

struct Target {
    width: u32,
    height: u32,
    color: wgpu::Texture,
    /// A copy of `color` that the RSL sum per pixel's shading reads while it writes `color`.
    seen: wgpu::Texture,
    depth: wgpu::Texture,
    encoded: wgpu::Buffer,
    /// Where the linear image and the encoded one are copied to be read, made on the first
    /// read and kept for the next frames of this size.
    readback: std::sync::OnceLock<wgpu::Buffer>,
    tone_readback: std::sync::OnceLock<wgpu::Buffer>,
}

/// Pipelines and targets of the draw pass.
pub struct GpuDraw {
    ctx: Arc<GpuContext>,
    background: wgpu::RenderPipeline,
    objects: wgpu::RenderPipeline,
    /// The objects again, where their depth equals what is stored (no depth writes).
    objects_again: wgpu::RenderPipeline,
    tonemap: wgpu::ComputePipeline,
    tone_layout: wgpu::BindGroupLayout,
    tonemap_texture: wgpu::ComputePipeline,
    tone_texture_layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    tone_params: wgpu::Buffer,
    texels: wgpu::Buffer,
    map_size: (u32, u32),
    constant: Vec3,
    intensity: f32,
    target: Option<Target>,
    timestamps: Option<(wgpu::QuerySet, wgpu::Buffer)>,
    lobes: Option<LobePass>,
    /// The RSL sum per pixel's pipeline and parameters ([`GpuDraw::draw_pixels`]), made on
    /// first use.
    pixels: Option<PixelPass>,
    /// Vertices shaded elsewhere ([`GpuDraw::draw_meshes`]): positions, then radiance, one
    /// vec4 each; and their indices.
    meshes: (wgpu::Buffer, wgpu::Buffer),
    /// The environment behind the objects as last drawn, for the parameters and environment
    /// upload ([`GpuDraw::set_backdrop`] count) it was drawn with: a frame that changes
    /// neither copies it instead of looking the environment up at every pixel again.
    behind: Option<(DrawParams, u64, wgpu::Texture)>,
    /// Environment uploads so far.
    backdrops: u64,
    /// Draw passes that drew the environment, and that copied it.
    backdrop_draws: (u64, u64),
    /// The parameters of the last whole drawing of meshes, whose depths are kept for
    /// [`GpuDraw::redraw_meshes`]; `None` after any other pass.
    redrawable: Option<(DrawParams, u64)>,
    /// Samples per pixel ([`GpuDraw::set_antialias`]).
    aa: u32,
    /// The antialiasing pipelines and buffers, made on first use.
    aa_pass: Option<antialias::AaPass>,
}

/// The lobe path's pipeline and buffers ([`GpuDraw::draw_lobes`]), made on first use.
struct LobePass {
    pipeline: wgpu::RenderPipeline,
    /// Shades the pixels the drawing marked.
    shade: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    levels: wgpu::Buffer,
    texels: wgpu::Buffer,
    level_count: u32,
    materials: wgpu::Buffer,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
}

/// The RSL sum per pixel's pipelines and parameters ([`GpuDraw::draw_pixels`]): the draw
/// pass records what each pixel sees, a compute pass shades it.
struct PixelPass {
    pipeline: wgpu::RenderPipeline,
    /// Lists the pixels the drawing marked, sizes the shading dispatch, shades them.
    find: wgpu::ComputePipeline,
    size: wgpu::ComputePipeline,
    shade: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    /// The list of pixels to shade for an image of the size given (`Work` in
    /// `shaders/draw/pixels.wgsl`).
    work: Option<((u32, u32), wgpu::Buffer)>,
    /// The shading dispatch's size, written by a pass before it.
    groups: wgpu::Buffer,
}

/// The objects of one draw pass.
enum Objects<'a> {
    /// The shading pass's vertices, their radiance interpolated.
    Shaded(&'a GpuShading),
    /// The lobe path per pixel, from the buffers [`GpuDraw::draw_lobes`] filled (their index
    /// count), and the objects the RSL sum per pixel draws beside them (their ranges in the
    /// shading pass's index buffer).
    Lobes(u32, Option<(&'a GpuShading, Vec<std::ops::Range<u32>>)>),
    /// The RSL sum per pixel over the shading pass's covers ([`GpuDraw::draw_pixels`]).
    Pixels(&'a GpuShading),
    /// Vertices shaded elsewhere, from the buffers [`GpuDraw::draw_meshes`] filled: the
    /// vertex count and the index count.
    Meshes(u32, u32),
    /// The same, drawn over the last image where their depth is the stored one
    /// ([`GpuDraw::redraw_meshes`]).
    MeshesAgain(u32, u32),
}

impl GpuDraw {
    /// Builds the pipelines (an adapter that cannot render to RGBA32F is an error).
    pub fn new(ctx: Arc<GpuContext>) -> Result<Self, GpuError> {
        ctx.check_alive()?;
        let usages = ctx.adapter.get_texture_format_features(COLOR).allowed_usages;
        if !usages.contains(wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING) {
            return Err(GpuError::Scene(format!("{} cannot render to {COLOR:?}", ctx.info.name)));
        }
        let d = &ctx.device;
        let background = render_pipeline(&ctx, &shaders::DRAW_BACKGROUND, &[], false)?;
        let position = [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x4, offset: 0, shader_location: 0 }];
        let radiance = [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x4, offset: 0, shader_location: 1 }];
        let buffers = [
            wgpu::VertexBufferLayout {
                array_stride: 16,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &position,
            },
            wgpu::VertexBufferLayout {
                array_stride: 16,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &radiance,
            },
        ];
        let objects = render_pipeline(&ctx, &shaders::DRAW_OBJECTS, &buffers, true)?;
        let objects_again = render_pipeline_full(
            &ctx,
            &shaders::DRAW_OBJECTS,
            &buffers,
            false,
            wgpu::CompareFunction::Equal,
            &[],
            true,
        )?;
        // Both tonemap passes read the parameters and the linear image; they differ in
        // where the encoded pixels go (a storage buffer read back, or a storage texture).
        let (tone_layout, tonemap) = tone_pipeline(
            &ctx,
            &shaders::TONEMAP,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: false },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
        )?;
        let (tone_texture_layout, tonemap_texture) = tone_pipeline(
            &ctx,
            &shaders::TONEMAP_TEXTURE,
            wgpu::BindingType::StorageTexture {
                access: wgpu::StorageTextureAccess::WriteOnly,
                format: DISPLAY,
                view_dimension: wgpu::TextureViewDimension::D2,
            },
        )?;
        let buffer = |label, size, usage| {
            d.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
        };
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let params = buffer("draw params", std::mem::size_of::<DrawParams>() as u64, uniform);
        let tone_params = buffer("tone params", std::mem::size_of::<ToneParams>() as u64, uniform);
        let texels = buffer("environment texels", 16, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST);
        let timestamps = ctx.pass_timer("draw timestamps");
        Ok(Self {
            background,
            objects,
            objects_again,
            tonemap,
            tone_layout,
            tonemap_texture,
            tone_texture_layout,
            params,
            tone_params,
            texels,
            map_size: (0, 0),
            constant: Vec3::ZERO,
            intensity: 1.0,
            target: None,
            timestamps,
            lobes: None,
            pixels: None,
            meshes: (
                buffer("shaded meshes", 32, wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST),
                buffer("shaded mesh indices", 4, wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST),
            ),
            behind: None,
            backdrops: 0,
            backdrop_draws: (0, 0),
            redrawable: None,
            aa: 1,
            aa_pass: None,
            ctx,
        })
    }

    /// The device context.
    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// Sets the prefiltered environment the lobe path reads ([`GpuDraw::draw_lobes`]); the
    /// first call builds the lobe pipeline.
    pub fn set_lobe_environment(&mut self, env: &rsl_lobe::PackedEnvironment) -> Result<(), GpuError> {
        self.ctx.check_alive()?;
        if env.levels.is_empty() {
            return Err(GpuError::Scene("a prefiltered environment without levels".into()));
        }
        let (levels, texels) = pack_environment(env);
        let limit = self.ctx.device.limits().max_storage_buffer_binding_size;
        let bytes = (texels.len() * 16) as u64;
        if bytes > limit {
            return Err(GpuError::TooLarge { what: "the prefiltered environment".into(), bytes, limit });
        }
        self.lobe_pass()?;
        let level_bytes: Vec<u8> = bytemuck::cast_slice(&levels).to_vec();
        let texel_bytes: Vec<u8> = bytemuck::cast_slice(&texels).to_vec();
        let (ctx, lobes) = (self.ctx.clone(), self.lobes.as_mut().expect("just made"));
        upload(&ctx, &mut lobes.levels, &level_bytes, "prefiltered levels");
        upload(&ctx, &mut lobes.texels, &texel_bytes, "prefiltered texels");
        lobes.level_count = levels.len() as u32;
        Ok(())
    }

    /// Builds the lobe path's pipeline and buffers on first use (no environment yet: objects
    /// without lobes can be drawn before one is set).
    fn lobe_pass(&mut self) -> Result<(), GpuError> {
        if self.lobes.is_some() {
            return Ok(());
        }
        let pipeline = render_pipeline(&self.ctx, &shaders::DRAW_LOBES, &[], true)?;
        let shade = self.ctx.compute_pipeline(&shaders::DRAW_LOBES_SHADE, &[])?;
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        self.lobes = Some(LobePass {
            pipeline,
            shade,
            params: self.buffer(
                "lobe params",
                std::mem::size_of::<LobeParams>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            levels: self.buffer("prefiltered levels", 16, storage),
            texels: self.buffer("prefiltered texels", 16, storage),
            level_count: 0,
            materials: self.buffer("material lobes", 16, storage),
            vertices: self.buffer("lobe vertices", 48, storage),
            indices: self.buffer("lobe indices", 4, storage),
        });
        Ok(())
    }

    /// Draws `objects` per pixel through the lobe path (`shaders/draw/lobes.wgsl`: each
    /// pixel's own normal and view, one prefiltered lookup per lobe, times its interpolated
    /// visibility ratio; objects without a material interpolate their radiance), with the
    /// environment behind, into the linear image; waits for it. `eye` is the camera's eye and
    /// `intensity` the environment's. Objects with lobes need [`GpuDraw::set_lobe_environment`]
    /// first.
    pub fn draw_lobes(
        &mut self,
        objects: &[LobeObject<'_>],
        camera: &Camera,
        env_from_world: Mat3,
        eye: Vec3,
        intensity: f32,
    ) -> Result<PassTime, GpuError> {
        self.draw_lobes_and_pixels(objects, None, camera, env_from_world, (eye, intensity))
    }

    /// [`GpuDraw::draw_lobes`] in one pass with [`GpuDraw::draw_pixels`]: the objects
    /// `pixels` selects drawn by the RSL sum per pixel over what `shading`'s last
    /// [`GpuShading::shade_covers`] kept (give them no triangles in `objects`), the others
    /// through the lobe path.
    pub fn draw_lobes_and_pixels(
        &mut self,
        objects: &[LobeObject<'_>],
        pixels: Option<(&GpuShading, &[bool])>,
        camera: &Camera,
        env_from_world: Mat3,
        (eye, intensity): (Vec3, f32),
    ) -> Result<PassTime, GpuError> {
        self.ctx.check_alive()?;
        let pixels = match pixels {
            None => None,
            Some((shading, which)) => {
                self.prepare_pixels(shading)?;
                let ranges = (0..which.len())
                    .filter(|&i| which[i])
                    .map(|i| {
                        shading.object_indices(i).ok_or_else(|| GpuError::Scene(format!("object {i} is not loaded")))
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                Some((shading, ranges))
            }
        };
        let (vertices, indices, materials) = pack_objects(objects).map_err(GpuError::Scene)?;
        check_pixel_triangles("the lobe path per pixel", (indices.len() / 3) as u64)?;
        let limit = self.ctx.device.limits().max_storage_buffer_binding_size;
        let bytes = (materials.len() * 16) as u64;
        if bytes > limit {
            return Err(GpuError::TooLarge { what: "the material lobes".into(), bytes, limit });
        }
        if objects.iter().any(|o| o.material.is_some()) && self.lobes.as_ref().is_none_or(|l| l.level_count == 0) {
            return Err(GpuError::Scene("draw_lobes before set_lobe_environment".into()));
        }
        self.lobe_pass()?;
        let ctx = self.ctx.clone();
        let lobes = self.lobes.as_mut().expect("just made");
        let params =
            LobeParams { eye: eye.extend(intensity).to_array(), levels: lobes.level_count, ..Default::default() };
        ctx.queue.write_buffer(&lobes.params, 0, bytemuck::bytes_of(&params));
        upload(&ctx, &mut lobes.materials, bytemuck::cast_slice(&materials), "material lobes");
        upload(&ctx, &mut lobes.vertices, bytemuck::cast_slice(&vertices), "lobe vertices");
        upload(&ctx, &mut lobes.indices, bytemuck::cast_slice(&indices), "lobe indices");
        self.pass(Objects::Lobes(indices.len() as u32, pixels), camera, env_from_world)
    }

    fn buffer(&self, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage,
            mapped_at_creation: false,
        })
    }

    /// Draw passes so far that looked the environment up behind the objects, and that
    /// copied it from the pass before (same camera, orientation and environment).
    pub fn backdrop_draws(&self) -> (u64, u64) {
        self.backdrop_draws
    }

    /// Sets the environment behind the objects (a map is uploaded once, here).
    pub fn set_backdrop(&mut self, backdrop: &Backdrop<'_>) -> Result<(), GpuError> {
        self.ctx.check_alive()?;
        self.backdrops += 1;
        match backdrop {
            Backdrop::Map { width, height, texels, intensity } => {
                if texels.len() != (*width as usize) * (*height as usize) || *width == 0 || *height == 0 {
                    return Err(GpuError::Scene(format!(
                        "environment map of {width}×{height} has {} texels",
                        texels.len()
                    )));
                }
                let data: Vec<[f32; 4]> = texels.iter().map(|t| t.extend(0.0).to_array()).collect();
                let bytes: &[u8] = bytemuck::cast_slice(&data);
                let limit = self.ctx.device.limits().max_storage_buffer_binding_size;
                if bytes.len() as u64 > limit {
                    return Err(GpuError::TooLarge {
                        what: "the environment map".into(),
                        bytes: bytes.len() as u64,
                        limit,
                    });
                }
                if self.texels.size() < bytes.len() as u64 {
                    self.texels = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("environment texels"),
                        size: bytes.len() as u64,
                        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    });
                }
                self.ctx.queue.write_buffer(&self.texels, 0, bytes);
                self.map_size = (*width, *height);
                self.intensity = *intensity;
            }
            Backdrop::Constant(c) => {
                self.map_size = (0, 0);
                self.constant = *c;
                self.intensity = 1.0;
            }
        }
        Ok(())
    }

    fn target(&mut self, width: u32, height: u32) -> Result<&Target, GpuError> {
        let max = self.ctx.device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(GpuError::Scene(format!("image size {width}×{height} (the GPU allows 1 to {max} per side)")));
        }
        if self.target.as_ref().is_none_or(|t| (t.width, t.height) != (width, height)) {
            let d = &self.ctx.device;
            let texture = |label, format, usage| {
                d.create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage,
                    view_formats: &[],
                })
            };
            let color = texture(
                "image",
                COLOR,
                wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::COPY_DST
                    | wgpu::TextureUsages::STORAGE_BINDING,
            );
            let seen =
                texture("image seen", COLOR, wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST);
            let depth =
                texture("depth", DEPTH, wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING);
            let encoded = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("encoded image"),
                size: u64::from(width) * u64::from(height) * 4,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let (readback, tone_readback) = Default::default();
            self.target = Some(Target { width, height, color, seen, depth, encoded, readback, tone_readback });
        }
        Ok(self.target.as_ref().expect("just created"))
    }

    /// Draws the shaded vertices of `shading` seen by `camera`, with the environment (seen
    /// through `env_from_world`) behind them, into the linear image; waits for it.
    pub fn draw(&mut self, shading: &GpuShading, camera: &Camera, env_from_world: Mat3) -> Result<PassTime, GpuError> {
        self.pass(Objects::Shaded(shading), camera, env_from_world)
    }

    /// Draws the objects of `shading` per pixel by the RSL sum (`shaders/draw/pixels.wgsl`,
    /// rsl-shade's `point_radiance`) over what its last [`GpuShading::shade_covers`] kept,
    /// seen by `camera` (the eye that pass shaded for), with the environment behind, into the
    /// linear image; waits for it. Objects not drawn per pixel interpolate their vertices.
    pub fn draw_pixels(
        &mut self,
        shading: &GpuShading,
        camera: &Camera,
        env_from_world: Mat3,
    ) -> Result<PassTime, GpuError> {
        self.prepare_pixels(shading)?;
        self.pass(Objects::Pixels(shading), camera, env_from_world)
    }

    /// Builds the per-pixel pipeline on first use and writes its parameters from what
    /// `shading`'s last [`GpuShading::shade_covers`] put where.
    fn prepare_pixels(&mut self, shading: &GpuShading) -> Result<(), GpuError> {
        let Some(layout) = shading.pixel_layout() else {
            return Err(GpuError::Scene("draw_pixels needs the covers of shade_covers first".into()));
        };
        let limit = self.ctx.device.limits().max_storage_buffers_per_shader_stage;
        if limit < 11 {
            return Err(GpuError::Scene(format!(
                "{} binds {limit} storage buffers per shader stage; the RSL sum per pixel needs 11 (use the CPU)",
                self.ctx.info.name
            )));
        }
        check_pixel_triangles("the RSL sum per pixel", u64::from(shading.index_buffer().1 / 3))?;
        if self.pixels.is_none() {
            let pipeline = render_pipeline_full(
                &self.ctx,
                &shaders::DRAW_PIXELS,
                &[],
                true,
                wgpu::CompareFunction::Greater,
                &shading_constants()[1..],
                true,
            )?;
            let params = self.buffer(
                "pixel params",
                std::mem::size_of::<PixelParams>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            );
            let compute = |shader| self.ctx.compute_pipeline(shader, &shading_constants()[1..]);
            let (find, size) = (compute(&shaders::DRAW_PIXELS_FIND)?, compute(&shaders::DRAW_PIXELS_SIZE)?);
            let shade = compute(&shaders::DRAW_PIXELS_SHADE)?;
            let groups =
                self.buffer("shading dispatch", 12, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT);
            self.pixels = Some(PixelPass { pipeline, find, size, shade, params, work: None, groups });
        }
        let params = pixel_params(&layout, shading.vertex_count());
        let pass = self.pixels.as_ref().expect("just made");
        self.ctx.queue.write_buffer(&pass.params, 0, bytemuck::bytes_of(&params));
        Ok(())
    }

    /// Draws meshes whose vertices were shaded elsewhere (the CPU path: world positions and
    /// radiance per vertex) seen by `camera`, with the environment behind, into the linear
    /// image, as [`GpuDraw::draw`] draws the shading pass's vertices; waits for it. A mesh
    /// whose radiance does not match its positions, or whose indices point past them, is an
    /// error.
    pub fn draw_meshes(
        &mut self,
        meshes: &[rsl_frame::RasterMesh<'_>],
        camera: &Camera,
        env_from_world: Mat3,
    ) -> Result<PassTime, GpuError> {
        let (vertices, indices) = self.upload_meshes(meshes.iter().enumerate())?;
        self.pass(Objects::Meshes(vertices, indices), camera, env_from_world)
    }

    /// Draws again, over the last image, the meshes whose `changed` flag is set, where their
    /// depth equals the last drawing's: what changed is their radiance alone (a material
    /// edit), not their place, the camera or the environment. Nothing else is drawn: no
    /// environment lookup, no other object. Where the last pass was not a
    /// [`GpuDraw::draw_meshes`] of the same view (camera, image size, environment), this
    /// draws everything as [`GpuDraw::draw_meshes`] does. `meshes` are all the meshes, as
    /// drawn then (only the changed ones are uploaded).
    pub fn redraw_meshes(
        &mut self,
        meshes: &[rsl_frame::RasterMesh<'_>],
        changed: &[bool],
        camera: &Camera,
        env_from_world: Mat3,
    ) -> Result<PassTime, GpuError> {
        let params = self.params(camera, env_from_world);
        if self.redrawable != Some((params, self.backdrops)) || changed.len() != meshes.len() {
            return self.draw_meshes(meshes, camera, env_from_world);
        }
        let (vertices, indices) =
            self.upload_meshes(meshes.iter().enumerate().zip(changed).filter(|(_, c)| **c).map(|(m, _)| m))?;
        self.pass(Objects::MeshesAgain(vertices, indices), camera, env_from_world)
    }

    /// Packs and uploads meshes (each with its index among all the drawing's meshes) for a
    /// drawing: the vertex and index counts.
    fn upload_meshes<'a>(
        &mut self,
        meshes: impl Iterator<Item = (usize, &'a rsl_frame::RasterMesh<'a>)> + Clone,
    ) -> Result<(u32, u32), GpuError> {
        self.ctx.check_alive()?;
        let vertices: usize = meshes.clone().map(|(_, m)| m.positions.len()).sum();
        let index_count: usize = meshes.clone().map(|(_, m)| m.indices.len()).sum();
        let limit = self.ctx.device.limits().max_buffer_size;
        let bytes = (vertices as u64) * 32;
        if bytes > limit || u32::try_from(vertices).is_err() || u32::try_from(index_count).is_err() {
            return Err(GpuError::TooLarge { what: format!("{vertices} shaded vertices"), bytes, limit });
        }
        let mut data: Vec<[f32; 4]> = Vec::with_capacity(2 * vertices);
        let mut indices: Vec<u32> = Vec::with_capacity(index_count);
        for (i, m) in meshes.clone() {
            let n = m.positions.len();
            if m.radiance.len() != n {
                return Err(GpuError::Scene(format!(
                    "mesh {i} has {n} positions and {} radiance values",
                    m.radiance.len()
                )));
            }
            if m.indices.len() % 3 != 0 {
                return Err(GpuError::Scene(format!("mesh {i} has {} indices, not whole triangles", m.indices.len())));
            }
            let base = data.len() as u32;
            for &k in m.indices {
                if k as usize >= n {
                    return Err(GpuError::Scene(format!("mesh {i} has index {k} for {n} vertices")));
                }
                indices.push(base + k);
            }
            // w: the mesh's index + 1, the pixels' alpha.
            data.extend(m.positions.iter().map(|p| p.extend((i + 1) as f32).to_array()));
        }
        // Radiance after every position: the two vertex buffers are the halves.
        data.extend(meshes.flat_map(|(_, m)| m.radiance.iter().map(|r| r.extend(1.0).to_array())));
        let ctx = self.ctx.clone();
        upload(&ctx, &mut self.meshes.0, bytemuck::cast_slice(&data), "shaded meshes");
        upload(&ctx, &mut self.meshes.1, bytemuck::cast_slice(&indices), "shaded mesh indices");
        Ok((vertices as u32, indices.len() as u32))
    }

    /// The per-pixel pipeline and its bind group over `shading`'s buffers.
    fn pixel_bind(&self, shading: &GpuShading) -> Result<Binding, GpuError> {
        let Some(PixelPass { pipeline, .. }) = &self.pixels else {
            return Err(GpuError::Scene("the per-pixel pass is not set up".into()));
        };
        // What the vertex and fragment stages read (the layout is the shader's): the draw
        // parameters, then of the shading pass's buffers (bindings 2 on) the vertices, the
        // shaded positions and the indices.
        let mut entries = vec![wgpu::BindGroupEntry { binding: 0, resource: self.params.as_entire_binding() }];
        entries.extend(
            shading
                .pixel_buffers()
                .into_iter()
                .enumerate()
                .map(|(k, b)| (2 + k as u32, b))
                .filter(|(binding, _)| [4, 8, 10].contains(binding))
                .map(|(binding, b)| wgpu::BindGroupEntry { binding, resource: b.as_entire_binding() }),
        );
        let bind = self.ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("draw pixels"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        Ok((pipeline.clone(), bind))
    }

    /// The RSL sum per pixel's shading passes bound to `shading`'s buffers and the image
    /// ([`GpuDraw::target`] first).
    fn pixel_shade_bind(&mut self, shading: &GpuShading) -> Result<PixelShade, GpuError> {
        let (Some(pass), Some(target)) = (&mut self.pixels, &self.target) else {
            return Err(GpuError::Scene("the per-pixel pass is not set up".into()));
        };
        let d = self.ctx.device.clone();
        let size = (target.width, target.height);
        if pass.work.as_ref().is_none_or(|(s, _)| *s != size) {
            let bytes = 4 + 4 * u64::from(size.0) * u64::from(size.1);
            let limit = d.limits().max_storage_buffer_binding_size;
            if bytes > limit {
                return Err(GpuError::TooLarge {
                    what: format!("the list of pixels of a {}×{} image", size.0, size.1),
                    bytes,
                    limit,
                });
            }
            let buffer = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pixels to shade"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            pass.work = Some((size, buffer));
        }
        let work = pass.work.as_ref().expect("just made").1.clone();
        let seen = target.seen.create_view(&wgpu::TextureViewDescriptor::default());
        let color = target.color.create_view(&wgpu::TextureViewDescriptor::default());
        let bind = |pipeline: &wgpu::ComputePipeline, entries: &[wgpu::BindGroupEntry<'_>]| {
            d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("shade pixels"),
                layout: &pipeline.get_bind_group_layout(0),
                entries,
            })
        };
        let seen_entry = wgpu::BindGroupEntry { binding: 12, resource: wgpu::BindingResource::TextureView(&seen) };
        let work_entry = wgpu::BindGroupEntry { binding: 14, resource: work.as_entire_binding() };
        let mut entries = vec![wgpu::BindGroupEntry { binding: 1, resource: pass.params.as_entire_binding() }];
        entries.extend(
            shading
                .pixel_buffers()
                .into_iter()
                .enumerate()
                .map(|(k, b)| wgpu::BindGroupEntry { binding: 2 + k as u32, resource: b.as_entire_binding() }),
        );
        entries.push(seen_entry.clone());
        entries.push(wgpu::BindGroupEntry { binding: 13, resource: wgpu::BindingResource::TextureView(&color) });
        entries.push(work_entry.clone());
        Ok(PixelShade {
            find: (pass.find.clone(), bind(&pass.find, &[seen_entry, work_entry.clone()])),
            size: (
                pass.size.clone(),
                bind(
                    &pass.size,
                    &[work_entry, wgpu::BindGroupEntry { binding: 15, resource: pass.groups.as_entire_binding() }],
                ),
            ),
            groups: pass.groups.clone(),
            shade: (pass.shade.clone(), bind(&pass.shade, &entries)),
            work,
        })
    }

    /// The lobe path's shading pass bound to its buffers and the image ([`GpuDraw::target`]
    /// first).
    fn lobe_shade_bind(&self) -> Result<(wgpu::ComputePipeline, wgpu::BindGroup), GpuError> {
        let (Some(l), Some(target)) = (&self.lobes, &self.target) else {
            return Err(GpuError::Scene("the lobe pass is not set up".into()));
        };
        let seen = target.seen.create_view(&wgpu::TextureViewDescriptor::default());
        let color = target.color.create_view(&wgpu::TextureViewDescriptor::default());
        let bind = self.ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shade lobes"),
            layout: &l.shade.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: l.params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: l.levels.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: l.texels.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: l.materials.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 5, resource: l.vertices.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 6, resource: l.indices.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 12, resource: wgpu::BindingResource::TextureView(&seen) },
                wgpu::BindGroupEntry { binding: 13, resource: wgpu::BindingResource::TextureView(&color) },
            ],
        });
        Ok((l.shade.clone(), bind))
    }

    /// What draws `objects`: their pipelines bound to this pass's parameters and buffers.
    fn bind_objects(&self, objects: &Objects<'_>) -> Result<Bound, GpuError> {
        let again = matches!(objects, Objects::MeshesAgain(..));
        let d = &self.ctx.device;
        let (pipeline, bind) = match (objects, &self.lobes) {
            (Objects::Shaded(_) | Objects::Meshes(..) | Objects::MeshesAgain(..), _) => {
                let pipeline = if again { self.objects_again.clone() } else { self.objects.clone() };
                let bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("draw objects"),
                    layout: &pipeline.get_bind_group_layout(0),
                    entries: &[wgpu::BindGroupEntry { binding: 0, resource: self.params.as_entire_binding() }],
                });
                (pipeline, bind)
            }
            (Objects::Lobes(..), Some(l)) => (
                l.pipeline.clone(),
                d.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("draw lobes"),
                    layout: &l.pipeline.get_bind_group_layout(0),
                    // What the vertex and fragment stages read: the triangles.
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: self.params.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 5, resource: l.vertices.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 6, resource: l.indices.as_entire_binding() },
                    ],
                }),
            ),
            (Objects::Lobes(..), None) => return Err(GpuError::Scene("the lobe pass is not set up".into())),
            (Objects::Pixels(shading), _) => self.pixel_bind(shading)?,
        };
        // The RSL sum per pixel beside the lobes.
        let beside = match objects {
            Objects::Lobes(_, Some((shading, ranges))) => Some((self.pixel_bind(shading)?, ranges.clone())),
            _ => None,
        };
        Ok(Bound { pipeline, bind, beside, shade: None, mesh_buffers: self.meshes.clone() })
    }

    /// One draw pass: the background, then `objects`.
    /// The draw parameters of `camera` and `env_from_world` with the environment held.
    fn params(&self, camera: &Camera, env_from_world: Mat3) -> DrawParams {
        let (width, height) = (camera.width, camera.height);
        let t = (0.5 * camera.fov_y).tan();
        let aspect = width as f32 / height as f32;
        let view = camera.camera_from_world();
        // WebGPU: NDC depth in [0, 1], y up.
        let proj = glam::camera::rh::proj::directx::perspective_infinite_reverse(camera.fov_y, aspect, camera.near());
        let world_from_camera = Mat3::from_mat4(view.inverse());
        DrawParams {
            clip_from_world: (proj * view).to_cols_array_2d(),
            world_from_camera: columns(world_from_camera),
            env_from_world: columns(env_from_world),
            lens: [t * aspect, t, width as f32, height as f32],
            constant: self.constant.extend(self.intensity).to_array(),
            map_width: self.map_size.0,
            map_height: self.map_size.1,
            ..Default::default()
        }
    }

    fn pass(&mut self, objects: Objects<'_>, camera: &Camera, env_from_world: Mat3) -> Result<PassTime, GpuError> {
        self.ctx.check_alive()?;
        let (width, height) = (camera.width, camera.height);
        let params = self.params(camera, env_from_world);
        self.ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        // A redraw keeps the last image and its depths; every other pass starts afresh and
        // keeps its depths only when it drew meshes.
        let again = matches!(objects, Objects::MeshesAgain(..));
        self.redrawable = None;
        let d = self.ctx.device.clone();
        let bg_bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("draw background"),
            layout: &self.background.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: self.texels.as_entire_binding() },
            ],
        });
        let mut bound = self.bind_objects(&objects)?;
        // Antialiased where asked, but for a redraw (over an image already antialiased or
        // not), whose depths would no longer be the first drawing's after.
        let antialiased = self.aa > 1 && !again;
        if antialiased {
            self.prepare_antialias(width, height)?;
        }
        let keeps = !antialiased && matches!(objects, Objects::Meshes(..) | Objects::MeshesAgain(..));
        let background = self.background.clone();
        let timestamps = self.timestamps.as_ref().map(|(s, r)| (s.clone(), r.clone()));
        // The environment behind: looked up again only when the camera, its orientation or
        // the environment changed; else the last one is copied.
        let same = again
            || self.behind.as_ref().is_some_and(|(p, n, t)| {
                *p == params && *n == self.backdrops && (t.width(), t.height()) == (width, height)
            });
        let scope = d.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("draw") });
        let depth = self.target(width, height)?.depth.create_view(&wgpu::TextureViewDescriptor::default());
        if again {
            // The last image stays: nothing is drawn behind.
        } else if same {
            self.backdrop_draws.1 += 1;
        } else {
            self.backdrop_draws.0 += 1;
            let texture = d.create_texture(&wgpu::TextureDescriptor {
                label: Some("environment behind"),
                size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: COLOR,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            });
            let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("draw the environment behind"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&background);
            pass.set_bind_group(0, &bg_bind, &[]);
            pass.draw(0..3, 0..1);
            drop(pass);
            self.behind = Some((params, self.backdrops, texture));
        }
        let behind = self.behind.as_ref().map(|b| b.2.clone());
        let (pixels, lobes) = match &objects {
            Objects::Pixels(shading) => (Some(self.pixel_shade_bind(shading)?), None),
            Objects::Lobes(_, pixels) => (
                pixels.as_ref().map(|(shading, _)| self.pixel_shade_bind(shading)).transpose()?,
                Some(self.lobe_shade_bind()?),
            ),
            _ => (None, None),
        };
        if pixels.is_some() || lobes.is_some() {
            let t = self.target.as_ref().expect("made with the depth above");
            bound.shade = Some(Shading {
                pixels,
                lobes,
                color: t.color.clone(),
                seen: t.seen.clone(),
                size: (t.width, t.height),
            });
        }
        let target = self.target(width, height)?;
        let color = target.color.create_view(&wgpu::TextureViewDescriptor::default());
        if let (false, Some(behind)) = (again, behind) {
            enc.copy_texture_to_texture(
                behind.as_image_copy(),
                target.color.as_image_copy(),
                wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            );
        }
        {
            let load = if again { wgpu::LoadOp::Load } else { wgpu::LoadOp::Clear(0.0) };
            // The timestamps bracket the drawing and, where there is one, the shading after it.
            let shades = bound.shade.is_some();
            let stamps = timestamps.as_ref().map(|(set, _)| wgpu::RenderPassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: (!shades).then_some(1),
            });
            let mut pass = image_pass(&mut enc, "draw", (&color, &depth), load, stamps);
            bound.record(&mut pass, &objects);
            drop(pass);
            let end = timestamps.as_ref().filter(|_| shades).map(|(set, _)| wgpu::ComputePassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: None,
                end_of_pass_write_index: Some(1),
            });
            bound.shade_pixels(&mut enc, end);
        }
        if let Some((set, resolve)) = &timestamps {
            enc.resolve_query_set(set, 0..2, resolve, 0);
        }
        let wait = |operation| {
            d.poll(wgpu::PollType::wait_indefinitely())
                .map_err(|e| GpuError::Operation { operation, message: e.to_string() })
        };
        let start = Instant::now();
        self.ctx.queue.submit([enc.finish()]);
        wait("draw")?;
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        // The antialiasing rounds, timed apart from the centres' pass.
        let (antialias_ms, timed) = if antialiased {
            let start = Instant::now();
            let timed = self.antialias_image(&bound, &objects, camera, &params);
            wait("antialias")?;
            (Some(start.elapsed().as_secs_f64() * 1e3), timed)
        } else {
            (None, false)
        };
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Operation { operation: "draw pass", message: e.to_string() });
        }
        if keeps {
            self.redrawable = Some((params, self.backdrops));
        }
        self.ctx.check_alive()?;
        // The timestamps bracket the centres' pass alone.
        let gpu_ms = match &timestamps {
            Some((_, resolve)) => Some(self.ctx.pass_ms(resolve)?),
            _ => None,
        };
        let antialias_gpu_ms = if timed { self.antialias_gpu_ms()? } else { None };
        Ok(PassTime { gpu_ms, wall_ms, antialias_ms, antialias_gpu_ms })
    }
}

/// A pipeline and its bind group.
type Binding = (wgpu::RenderPipeline, wgpu::BindGroup);

/// The pipelines, bind groups and buffers that draw one pass's objects
/// ([`GpuDraw::bind_objects`]).
struct Bound {
    pipeline: wgpu::RenderPipeline,
    bind: wgpu::BindGroup,
    /// The RSL sum per pixel beside the lobes: its pipeline and bind group, and the ranges of
    /// the shading pass's indices it draws.
    beside: Option<(Binding, Vec<std::ops::Range<u32>>)>,
    mesh_buffers: (wgpu::Buffer, wgpu::Buffer),
    /// The shading after each drawing, where the RSL sum per pixel or the lobes draw objects.
    shade: Option<Shading>,
}

/// The compute passes that shade what a drawing marked: the RSL sum per pixel's, the lobe
/// path's, or both (for disjoint pixels of the same image, read from one copy of it).
struct Shading {
    pixels: Option<PixelShade>,
    lobes: Option<(wgpu::ComputePipeline, wgpu::BindGroup)>,
    color: wgpu::Texture,
    seen: wgpu::Texture,
    size: (u32, u32),
}

/// The RSL sum per pixel's compute passes bound to one image: the pixels to shade listed,
/// the dispatch sized, the pixels shaded.
struct PixelShade {
    find: (wgpu::ComputePipeline, wgpu::BindGroup),
    size: (wgpu::ComputePipeline, wgpu::BindGroup),
    shade: (wgpu::ComputePipeline, wgpu::BindGroup),
    work: wgpu::Buffer,
    groups: wgpu::Buffer,
}

impl Bound {
    /// Shades the pixels the drawing just recorded in `enc` marked (none without objects
    /// drawn by the RSL sum per pixel or the lobes): the image copied; the RSL sum's pixels
    /// listed and each shaded by one invocation; the lobes' pixels shaded where they lie;
    /// each writing its radiance into the image.
    fn shade_pixels(
        &self,
        enc: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let Some(s) = &self.shade else {
            return;
        };
        let (width, height) = s.size;
        enc.copy_texture_to_texture(
            s.color.as_image_copy(),
            s.seen.as_image_copy(),
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        );
        if let Some(p) = &s.pixels {
            enc.clear_buffer(&p.work, 0, Some(4));
        }
        let mut pass =
            enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("shade pixels"), timestamp_writes });
        if let Some(p) = &s.pixels {
            pass.set_pipeline(&p.find.0);
            pass.set_bind_group(0, &p.find.1, &[]);
            pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
            pass.set_pipeline(&p.size.0);
            pass.set_bind_group(0, &p.size.1, &[]);
            pass.dispatch_workgroups(1, 1, 1);
            pass.set_pipeline(&p.shade.0);
            pass.set_bind_group(0, &p.shade.1, &[]);
            pass.dispatch_workgroups_indirect(&p.groups, 0);
        }
        if let Some((pipeline, bind)) = &s.lobes {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind, &[]);
            pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
        }
    }

    /// Draws `objects` into `pass`.
    fn record(&self, pass: &mut wgpu::RenderPass<'_>, objects: &Objects<'_>) {
        match *objects {
            Objects::Shaded(shading) => {
                let (indices, count) = shading.index_buffer();
                let n = u64::from(shading.vertex_count()) * 16;
                if count > 0 {
                    pass.set_pipeline(&self.pipeline);
                    pass.set_bind_group(0, &self.bind, &[]);
                    pass.set_vertex_buffer(0, shading.shaded_buffer().slice(0..n));
                    pass.set_vertex_buffer(1, shading.shaded_buffer().slice(n..2 * n));
                    pass.set_index_buffer(indices.slice(..u64::from(count) * 4), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..count, 0, 0..1);
                }
            }
            Objects::Meshes(vertices, count) | Objects::MeshesAgain(vertices, count) => {
                if count > 0 {
                    let n = u64::from(vertices) * 16;
                    pass.set_pipeline(&self.pipeline);
                    pass.set_bind_group(0, &self.bind, &[]);
                    pass.set_vertex_buffer(0, self.mesh_buffers.0.slice(0..n));
                    pass.set_vertex_buffer(1, self.mesh_buffers.0.slice(n..2 * n));
                    pass.set_index_buffer(self.mesh_buffers.1.slice(..u64::from(count) * 4), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..count, 0, 0..1);
                }
            }
            Objects::Pixels(shading) => {
                let (_, count) = shading.index_buffer();
                if count > 0 {
                    pass.set_pipeline(&self.pipeline);
                    pass.set_bind_group(0, &self.bind, &[]);
                    pass.draw(0..count, 0..1);
                }
            }
            Objects::Lobes(count, _) => {
                if count > 0 {
                    pass.set_pipeline(&self.pipeline);
                    pass.set_bind_group(0, &self.bind, &[]);
                    pass.draw(0..count, 0..1);
                }
                if let Some(((pipeline, bind), ranges)) = &self.beside {
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(0, bind, &[]);
                    for r in ranges.iter().filter(|r| !r.is_empty()) {
                        pass.draw(r.clone(), 0..1);
                    }
                }
            }
        }
    }
}

/// A render pass drawing into the image over its depths (`depth_load`: kept, or cleared).
fn image_pass<'e>(
    enc: &'e mut wgpu::CommandEncoder,
    label: &str,
    (color, depth): (&wgpu::TextureView, &wgpu::TextureView),
    depth_load: wgpu::LoadOp<f32>,
    timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
) -> wgpu::RenderPass<'e> {
    enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: color,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: depth,
            depth_ops: Some(wgpu::Operations { load: depth_load, store: wgpu::StoreOp::Store }),
            stencil_ops: None,
        }),
        timestamp_writes,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// A render pipeline of a registered shader (entry points: vertex, fragment) drawing into
/// the RGBA32F image with reversed depth; `depth_test` off draws behind everything.
fn render_pipeline(
    ctx: &GpuContext,
    shader: &shaders::Shader,
    buffers: &[wgpu::VertexBufferLayout<'_>],
    depth_test: bool,
) -> Result<wgpu::RenderPipeline, GpuError> {
    let compare = if depth_test { wgpu::CompareFunction::Greater } else { wgpu::CompareFunction::Always };
    render_pipeline_full(ctx, shader, buffers, depth_test, compare, &[], true)
}

/// A render pipeline writing depth or not, with depth comparison `compare`, drawing into
/// the image (`color`) or into the depth alone.
fn render_pipeline_full(
    ctx: &GpuContext,
    shader: &shaders::Shader,
    buffers: &[wgpu::VertexBufferLayout<'_>],
    depth_write: bool,
    compare: wgpu::CompareFunction,
    constants: &[(&str, f64)],
    color: bool,
) -> Result<wgpu::RenderPipeline, GpuError> {
    let [vertex, fragment] = shader.entry_points else {
        return Err(GpuError::Shader { name: shader.name, message: "needs a vertex and a fragment entry".into() });
    };
    let d = &ctx.device;
    let scope = d.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(shader.name),
        source: wgpu::ShaderSource::Wgsl(shader.source().into()),
    });
    let pipeline = d.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(shader.name),
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some(vertex),
            compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
            buffers: &buffers.iter().cloned().map(Some).collect::<Vec<_>>(),
        },
        primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH,
            depth_write_enabled: Some(depth_write),
            depth_compare: Some(compare),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some(fragment),
            compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
            targets: if color {
                &[Some(wgpu::ColorTargetState { format: COLOR, blend: None, write_mask: wgpu::ColorWrites::ALL })]
            } else {
                &[]
            },
        }),
        multiview_mask: None,
        cache: None,
    });
    match pollster::block_on(scope.pop()) {
        Some(e) => Err(GpuError::Shader { name: shader.name, message: e.to_string() }),
        None => Ok(pipeline),
    }
}

/// Refuses a drawing per pixel (`what`) of more triangles than its fragments can name
/// ([`MAX_PIXEL_TRIANGLES`]).
fn check_pixel_triangles(what: &str, triangles: u64) -> Result<(), GpuError> {
    if triangles > u64::from(MAX_PIXEL_TRIANGLES) {
        return Err(GpuError::TooLarge {
            what: format!("{what} over {triangles} triangles (at most {MAX_PIXEL_TRIANGLES})"),
            bytes: triangles * 12,
            limit: u64::from(MAX_PIXEL_TRIANGLES) * 12,
        });
    }
    Ok(())
}

/// The per-pixel pass's parameters from where the shading pass put its data.
fn pixel_params(layout: &PixelLayout, vertex_count: u32) -> PixelParams {
    PixelParams {
        eye: layout.eye,
        vertex_count,
        object_count: layout.object_count,
        light_count: layout.light_count,
        terms: layout.terms,
        pixel_rays: layout.pixel_rays,
        rays_per_light: layout.rays_per_light,
        rays_at: layout.rays_at,
        lift: layout.lift,
        objects_at: layout.objects_at,
        ..Default::default()
    }
}

/// Writes `bytes` into `buffer`, growing it (to the next power of two) when too small.
fn upload(ctx: &GpuContext, buffer: &mut wgpu::Buffer, bytes: &[u8], label: &str) {
    if bytes.is_empty() {
        return;
    }
    if buffer.size() < bytes.len() as u64 {
        *buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: (bytes.len() as u64).next_power_of_two(),
            usage: buffer.usage(),
            mapped_at_creation: false,
        });
    }
    ctx.queue.write_buffer(buffer, 0, bytes);
}

//! The GPU path of the engine: the same prepared scene shaded by wgpu compute
//! (`rsl_gpu::shade`), returning the same [`ShadedFrame`] as the CPU path.
//!
//! Resources follow the engine's data: geometry and visibility fields are uploaded when the
//! set of meshes or fields changes, BRDF tables when a material changes, and only poses and
//! lights per frame.

use crate::engine::EnvRadiance;
use crate::engine::{Engine, ShadedFrame};
use anyhow::{Context, Result};
use glam::Mat3;
use rsl_gpu::draw::{Backdrop, GpuDraw};
use rsl_gpu::shade::{GpuShading, PassTime, PixelFrame, Uploads};
use rsl_gpu::{GpuContext, GpuError};
use rsl_scene::Scene;
use rsl_shade::Image;
use rsl_shade::{FrameStats, Pose, Terms};
use std::sync::Arc;
use std::time::Instant;

/// Identity of what is loaded: per object, the content keys of its geometry and fields
/// (or of its table). Equal keys mean equal data, so an item evicted from the engine and
/// rebuilt matches what is uploaded, and a different item never does.
type Key = Vec<u64>;

fn geometry_key(engine: &Engine) -> Key {
    (0..engine.object_count())
        .flat_map(|i| {
            let k = engine.keys(i);
            [k.mesh, k.frames, k.svdf, k.ovdf]
        })
        .collect()
}

fn table_key(engine: &Engine) -> Key {
    (0..engine.object_count()).map(|i| engine.keys(i).table).collect()
}

/// The environment as the GPU draw pass shows it behind the objects.
pub fn backdrop(engine: &Engine) -> Backdrop<'_> {
    match engine.environment() {
        EnvRadiance::Map(m) => Backdrop::Map {
            width: m.width() as u32,
            height: m.height() as u32,
            texels: m.texels(),
            intensity: engine.intensity(),
        },
        EnvRadiance::Constant(c) => Backdrop::Constant(*c * engine.intensity()),
    }
}

/// Shades an engine's scene on the GPU and draws it.
pub struct GpuRenderer {
    shading: GpuShading,
    draw: GpuDraw,
    geometry: Option<Key>,
    tables: Option<Key>,
    /// The environment (content key, intensity bits) the draw pass holds.
    backdrop: Option<(u64, u32)>,
    last: PassTime,
}

/// A frame drawn on the GPU.
#[derive(Clone, Debug)]
pub struct GpuImage {
    /// The linear image (alpha: coverage), read back.
    pub image: Image,
    /// 8-bit sRGB, tonemapped on the GPU at `exposure`.
    pub rgb: Vec<u8>,
    /// The exposure used.
    pub exposure: f32,
    /// Per pass.
    pub timings: GpuTimings,
}

/// What each pass of a GPU frame cost, ms (GPU timestamps where the adapter has them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpuTimings {
    /// The shading compute pass.
    pub shade: PassTime,
    /// The draw pass.
    pub draw: PassTime,
    /// Reading the linear image back.
    pub readback_ms: f64,
    /// Tonemapping (with its readback).
    pub tonemap: PassTime,
}

impl GpuRenderer {
    /// The draw pass (its targets feed a viewer).
    pub fn draw(&self) -> &GpuDraw {
        &self.draw
    }

    /// The draw pass, to tonemap into a texture.
    pub fn draw_mut(&mut self) -> &mut GpuDraw {
        &mut self.draw
    }

    /// Opens the best adapter and builds the shading pipeline.
    pub fn new() -> Result<Self, GpuError> {
        Self::with_context(Arc::new(GpuContext::new()?))
    }

    /// The renderer on an existing context.
    pub fn with_context(ctx: Arc<GpuContext>) -> Result<Self, GpuError> {
        Ok(Self {
            shading: GpuShading::new(ctx.clone())?,
            draw: GpuDraw::new(ctx)?,
            geometry: None,
            tables: None,
            backdrop: None,
            last: PassTime::default(),
        })
    }

    /// Whether the adapter is a software rasteriser (such as Mesa's llvmpipe).
    pub fn is_software(&self) -> bool {
        self.shading.context().info.device_type == rsl_gpu::wgpu::DeviceType::Cpu
    }

    /// Shades and draws `scene` at time `t`: the linear image (read back) and its
    /// tonemapped 8-bit form at `exposure` (`None`: automatic, from the linear image),
    /// antialiased as `engine`'s quality asks. Per pixel, the RSL sum is evaluated at every pixel (the CPU's `pixel` drawing,
    /// `shaders/draw/pixels.wgsl`) over every light's cover kept at the vertices; else the
    /// vertices' radiance is interpolated.
    pub fn render(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        t: f32,
        per_pixel: bool,
        (exposure, auto_exposure): (Option<f32>, impl Fn(&Image) -> f32),
    ) -> Result<GpuImage> {
        self.draw.set_antialias(engine.antialias())?;
        let (shade, draw) = if per_pixel {
            let shade = self.dispatch_covers(engine, scene, t, Terms::default())?;
            self.set_backdrop(engine)?;
            let env_from_world = Mat3::from_quat(scene.at(t).world_from_env.inverse());
            (shade, self.draw.draw_pixels(&self.shading, &scene.camera, env_from_world)?)
        } else {
            let shade = self.dispatch(engine, scene, t, Terms::default())?;
            (shade, self.draw_shaded(engine, scene, t)?)
        };
        let start = Instant::now();
        let (pixels, covered) = self.draw.read_linear()?;
        let readback_ms = start.elapsed().as_secs_f64() * 1e3;
        let image = Image { width: scene.camera.width, height: scene.camera.height, pixels, covered };
        let exposure = exposure.unwrap_or_else(|| auto_exposure(&image));
        let (rgb, tonemap) = self.draw.tonemap(exposure)?;
        Ok(GpuImage { image, rgb, exposure, timings: GpuTimings { shade, draw, readback_ms, tonemap } })
    }

    /// Uploads `engine`'s environment for the draw pass's backdrop, if it is not the one
    /// held.
    pub fn set_backdrop(&mut self, engine: &Engine) -> Result<()> {
        let env = (engine.environment_key(), engine.intensity().to_bits());
        if self.backdrop != Some(env) {
            self.backdrop = None;
            self.draw.set_backdrop(&backdrop(engine)).context("uploading the environment map")?;
            self.backdrop = Some(env);
        }
        Ok(())
    }

    /// Draws the vertices the last shading pass left on the GPU ([`GpuRenderer::dispatch`]
    /// of `scene` at `t`), with the environment behind, into the draw pass's linear image;
    /// nothing is read back.
    pub fn draw_shaded(&mut self, engine: &Engine, scene: &Scene, t: f32) -> Result<PassTime> {
        self.set_backdrop(engine)?;
        let state = scene.at(t);
        let env_from_world = Mat3::from_quat(state.world_from_env.inverse());
        Ok(self.draw.draw(&self.shading, &scene.camera, env_from_world)?)
    }

    /// Draws `objects` through the lobe path with the environment behind, the objects
    /// `pixels` selects by the RSL sum per pixel over the last
    /// [`GpuRenderer::dispatch_covers`] in the same pass
    /// ([`rsl_gpu::draw::GpuDraw::draw_lobes_and_pixels`]); `(eye, intensity)`: the camera's
    /// eye and the environment's intensity.
    pub fn draw_lobes_and_pixels(
        &mut self,
        objects: &[rsl_gpu::lobes::LobeObject<'_>],
        pixels: Option<&[bool]>,
        camera: &rsl_scene::Camera,
        env_from_world: Mat3,
        view: (glam::Vec3, f32),
    ) -> Result<PassTime> {
        let pixels = pixels.map(|p| (&self.shading, p));
        Ok(self.draw.draw_lobes_and_pixels(objects, pixels, camera, env_from_world, view)?)
    }

    /// The adapter, in words.
    pub fn describe(&self) -> String {
        self.shading.context().describe()
    }

    /// Bytes uploaded so far, by kind.
    pub fn uploads(&self) -> Uploads {
        self.shading.uploads()
    }

    /// The last shading pass's time.
    pub fn last_pass(&self) -> PassTime {
        self.last
    }

    /// The shading pass (its buffers feed the draw pass).
    pub fn shading(&self) -> &GpuShading {
        &self.shading
    }

    /// Shades every vertex of `scene` at time `t` (seen from the camera) on the GPU, loading
    /// whatever changed since the last frame, and reads the result back.
    pub fn shade(&mut self, engine: &Engine, scene: &Scene, t: f32) -> Result<ShadedFrame> {
        self.shade_with(engine, scene, t, Terms::default())
    }

    /// [`GpuRenderer::shade`] with a choice of terms.
    pub fn shade_with(&mut self, engine: &Engine, scene: &Scene, t: f32, terms: Terms) -> Result<ShadedFrame> {
        self.dispatch(engine, scene, t, terms)?;
        self.read_frame(engine, scene, t)
    }

    /// The last shading pass's result (of `scene` at time `t`) read back, without shading
    /// again: world positions and radiance from the GPU, world normals from the poses.
    pub fn read_frame(&self, engine: &Engine, scene: &Scene, t: f32) -> Result<ShadedFrame> {
        let state = scene.at(t);
        let rsl_gpu::shade::ShadedVertices { positions, radiance } =
            self.shading.read_vertices().context("reading the shaded vertices back")?;
        let normals = engine
            .objects(scene, &state)?
            .iter()
            .map(|o| {
                let pose = Pose::new(&o.transform);
                o.mesh.normals.iter().map(|&n| pose.normal(n)).collect()
            })
            .collect();
        let shade_ms = self.last.gpu_ms.unwrap_or(self.last.wall_ms);
        let stats = FrameStats { vertices: radiance.iter().map(|r| r.len() as u64).sum(), ..FrameStats::default() };
        Ok(ShadedFrame { state, positions, normals, radiance, stats, shade_ms })
    }

    /// Loads what changed and runs the shading pass for `scene` at `t`, leaving the result on
    /// the GPU (for the draw pass); returns the pass time.
    pub fn dispatch(&mut self, engine: &Engine, scene: &Scene, t: f32, terms: Terms) -> Result<PassTime> {
        self.dispatch_with(engine, scene, t, terms, false)
    }

    /// [`GpuRenderer::dispatch`] keeping every light's cover at every vertex, and what the
    /// RSL sum per pixel reads besides ([`rsl_gpu::shade::GpuShading::shade_covers`]): which
    /// objects are drawn per pixel (as the CPU's `pixel` drawing chooses,
    /// [`rsl_shade::drawn_per_pixel`]) and the traced lights' rays.
    pub fn dispatch_covers(&mut self, engine: &Engine, scene: &Scene, t: f32, terms: Terms) -> Result<PassTime> {
        self.dispatch_with(engine, scene, t, terms, true)
    }

    fn dispatch_with(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        t: f32,
        terms: Terms,
        covers: bool,
    ) -> Result<PassTime> {
        let state = scene.at(t);
        // Traced lights' shadow rays run on the CPU (the engine's own frame setup); the
        // shader reads their covers.
        let setup = engine.setup(scene, &state, scene.camera.eye, terms)?;
        self.dispatch_setup(engine, scene, &state, &setup, covers)
    }

    /// [`GpuRenderer::dispatch_covers`] of the frame `setup` (of `scene` at `state`, seen
    /// from the camera) already set up on the CPU, its traced lights' rays traced: nothing
    /// is set up again.
    pub fn dispatch_covers_of(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        state: &rsl_scene::SceneState,
        setup: &rsl_shade::FrameSetup<'_>,
    ) -> Result<PassTime> {
        self.dispatch_setup(engine, scene, state, setup, true)
    }

    fn dispatch_setup(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        state: &rsl_scene::SceneState,
        setup: &rsl_shade::FrameSetup<'_>,
        covers: bool,
    ) -> Result<PassTime> {
        let (terms, eye) = (setup.terms(), setup.eye());
        let objects = engine.objects(scene, state)?;
        let g = geometry_key(engine);
        if self.geometry.as_ref() != Some(&g) {
            let start = Instant::now();
            self.geometry = None;
            self.shading.load_geometry(&objects).context("uploading geometry and visibility fields")?;
            tracing::info!("GPU: geometry and fields uploaded in {:.1} ms", start.elapsed().as_secs_f64() * 1e3);
            self.geometry = Some(g);
        }
        let k = table_key(engine);
        if self.tables.as_ref() != Some(&k) {
            self.tables = None;
            self.shading.load_tables(&objects).context("uploading BRDF tables")?;
            self.tables = Some(k);
        }
        let lights = engine.lights(state);
        let traced = setup.traced_covers();
        self.last = if covers {
            let per_pixel: Vec<bool> = (0..objects.len())
                .map(|i| rsl_shade::drawn_per_pixel(setup, !engine.brdf(i).is_lambertian()))
                .collect();
            crate::lobe::check_covers_size(engine, setup, &vec![true; objects.len()])?;
            let pixel = PixelFrame {
                per_pixel,
                rays: (0..lights.len()).map(|l| setup.traced_rays(l).to_vec()).collect(),
                pixel_rays: rsl_shade::PIXEL_RAYS as u32,
                lift: setup.traced_lift(),
            };
            self.shading.shade_covers(&objects, &lights, eye, terms, &traced, &pixel)?
        } else {
            self.shading.shade(&objects, &lights, eye, terms, &traced)?
        };
        Ok(self.last)
    }
}

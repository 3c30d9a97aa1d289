//! The 3D view drawn with wgpu on the window's own device: eframe's (or the headless
//! renderer's) device and queue, shared with rsl-gpu. On a software adapter (llvmpipe) the
//! vertices are shaded by the engine's CPU path (only what changed); on a hardware GPU by
//! rsl-gpu's shading pass (every vertex, every frame that changed anything). rsl-gpu's draw
//! pass rasterises them with the environment behind and tonemaps into a texture that egui
//! samples where it lays out the view (`register_native_texture`), with no readback of the
//! image. The linear image is read back only when something asks for it: the first frame's
//! exposure, the error readout against the truth, a screenshot, a test.

use anyhow::{Context, Result, anyhow};
use eframe::egui_wgpu::{self, wgpu};
use glam::Mat3;
use rsl_engine::scene::{Camera, Scene, SceneState};
use rsl_engine::{Engine, GpuRenderer, ShadedFrame};
use rsl_gpu::GpuContext;
use std::sync::Arc;
use std::time::Instant;

/// What a device must offer for the view to be drawn with rsl-gpu on it: the draw pass's
/// storage buffers (the environment map; the lobe pass binds four) on a backend rsl-gpu
/// runs on (Vulkan, Metal, DX12; not GL).
pub fn supports_rsl(adapter: &wgpu::Adapter) -> bool {
    let info = adapter.get_info();
    matches!(info.backend, wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12)
        && adapter.limits().max_storage_buffers_per_shader_stage >= 8
}

/// The device a window (or the headless renderer) asks for: what rsl-gpu needs
/// ([`rsl_gpu::device_descriptor`]) where the adapter has it, else egui's own request (the
/// view is then drawn on the CPU).
pub fn device_descriptor(adapter: &wgpu::Adapter) -> wgpu::DeviceDescriptor<'static> {
    if supports_rsl(adapter) {
        let mut d = rsl_gpu::device_descriptor(adapter);
        // egui draws the window with a depth buffer up to 4K and beyond.
        d.required_limits.max_texture_dimension_2d = d.required_limits.max_texture_dimension_2d.max(8192);
        d
    } else {
        (egui_wgpu::WgpuSetupCreateNew::without_display_handle().device_descriptor)(adapter)
    }
}

/// `setup` asking for [`device_descriptor`]'s device.
pub fn with_rsl_device(setup: egui_wgpu::WgpuSetup) -> egui_wgpu::WgpuSetup {
    match setup {
        egui_wgpu::WgpuSetup::CreateNew(mut s) => {
            s.device_descriptor = Arc::new(device_descriptor);
            egui_wgpu::WgpuSetup::CreateNew(s)
        }
        existing => existing,
    }
}

/// A render state for drawing the UI headless (the screenshot, the tests): egui's test
/// renderer's setup (a software adapter preferred, for reproducible images), on a device
/// that rsl-gpu can share. No adapter is an error, not a panic.
pub fn headless_render_state() -> Result<egui_wgpu::RenderState> {
    let setup = with_rsl_device(egui_kittest::wgpu::default_wgpu_setup());
    let instance = pollster::block_on(setup.new_instance());
    let config = egui_wgpu::WgpuConfiguration { wgpu_setup: setup, ..Default::default() };
    pollster::block_on(egui_wgpu::RenderState::create(
        &config,
        &instance,
        None,
        egui_wgpu::RendererOptions::PREDICTABLE,
    ))
    .map_err(|e| {
        anyhow!(
            "no wgpu adapter to draw the viewer with ({e}); install a Vulkan driver (for example Mesa's `mesa-vulkan-drivers`)"
        )
    })
}

/// The view's drawing on a shared device.
pub(crate) struct WgpuView {
    /// rsl-gpu's shading and draw passes on the shared device.
    gpu: GpuRenderer,
    renderer: Arc<egui::mutex::RwLock<egui_wgpu::Renderer>>,
    /// The tonemapped image egui samples, and its id in egui's renderer.
    display: Option<(wgpu::Texture, egui::TextureId)>,
    adapter: String,
    /// Whether rsl-gpu shades the vertices (a hardware adapter), or the CPU path does.
    pub shades: bool,
}

/// What one wgpu drawing cost, ms, and the linear image when it was read back.
pub(crate) struct Drawn {
    pub draw_ms: f64,
    pub tonemap_ms: f64,
    pub linear: Option<rsl_shade::Image>,
}

impl WgpuView {
    /// rsl-gpu's draw pass on `state`'s device; an error where the device cannot take it.
    pub fn new(state: &egui_wgpu::RenderState) -> Result<Self> {
        if !supports_rsl(&state.adapter) {
            let i = state.adapter.get_info();
            return Err(anyhow!("{} ({:?}) cannot run rsl-gpu's draw pass", i.name, i.backend));
        }
        let ctx = GpuContext::from_device(state.adapter.clone(), state.device.clone(), state.queue.clone());
        let adapter = ctx.describe();
        let gpu =
            GpuRenderer::with_context(Arc::new(ctx)).context("building rsl-gpu's passes on the window's device")?;
        let shades = !gpu.is_software();
        Ok(Self { gpu, renderer: state.renderer.clone(), display: None, adapter, shades })
    }

    /// The window's device, as rsl-gpu holds it.
    pub fn context(&self) -> Arc<GpuContext> {
        self.gpu.shading().context().clone()
    }

    /// The adapter, in words.
    pub fn adapter(&self) -> &str {
        &self.adapter
    }

    /// The texture egui shows, and its size.
    pub fn texture(&self) -> Option<(egui::TextureId, [usize; 2])> {
        self.display.as_ref().map(|(t, id)| (*id, [t.width() as usize, t.height() as usize]))
    }

    /// Draws `meshes` (shaded on the CPU) over the environment and tonemaps them at
    /// `exposure` into the texture egui shows; without an exposure yet, reads the linear
    /// image back and sets it from that. With `changed` (only those meshes' radiance changed
    /// since the last drawing), only they are drawn again, over the last image.
    pub fn draw(
        &mut self,
        engine: &Engine,
        state: &SceneState,
        camera: &Camera,
        meshes: &[rsl_shade::RasterMesh<'_>],
        changed: Option<&[bool]>,
        exposure: &mut Option<f32>,
    ) -> Result<Drawn> {
        let t0 = Instant::now();
        self.gpu.set_backdrop(engine)?;
        let env_from_world = Mat3::from_quat(state.world_from_env.inverse());
        let draw = self.gpu.draw_mut();
        match changed {
            Some(changed) => draw.redraw_meshes(meshes, changed, camera, env_from_world),
            None => draw.draw_meshes(meshes, camera, env_from_world),
        }
        .context("drawing the view with wgpu")?;
        self.finish(camera, exposure, t0)
    }

    /// Shades every vertex of `scene` at time `t` with rsl-gpu's shading pass and reads the
    /// vertices back (the viewer keeps each object's radiance; a few megabytes).
    pub fn shade(&mut self, engine: &Engine, scene: &Scene, t: f32) -> Result<ShadedFrame> {
        self.gpu.dispatch(engine, scene, t, rsl_shade::Terms::default())?;
        self.gpu.read_frame(engine, scene, t)
    }

    /// Draws what [`WgpuView::shade`] left on the GPU, as [`WgpuView::draw`] does.
    pub fn draw_shaded(&mut self, engine: &Engine, scene: &Scene, t: f32, exposure: &mut Option<f32>) -> Result<Drawn> {
        let t0 = Instant::now();
        self.gpu.draw_shaded(engine, scene, t).context("drawing the view with wgpu")?;
        self.finish(&scene.camera, exposure, t0)
    }

    /// The exposure (from the image read back, the first time), and the image tonemapped
    /// into the texture egui shows.
    fn finish(&mut self, camera: &Camera, exposure: &mut Option<f32>, t0: Instant) -> Result<Drawn> {
        let linear = match exposure {
            Some(_) => None,
            None => {
                let image = self.read_linear(camera)?;
                *exposure = Some(rsl_engine::method::exposure_for(&image));
                Some(image)
            }
        };
        let draw_ms = t0.elapsed().as_secs_f64() * 1e3;
        let t1 = Instant::now();
        let size = (camera.width, camera.height);
        let fits = self.display.as_ref().is_some_and(|(t, _)| (t.width(), t.height()) == size);
        if !fits {
            let texture = self.gpu.draw().display_texture()?;
            let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
            let device = &self.gpu.draw().context().device;
            let mut renderer = self.renderer.write();
            let id = match &self.display {
                Some((_, id)) => {
                    renderer.update_egui_texture_from_wgpu_texture(device, &view, wgpu::FilterMode::Linear, *id);
                    *id
                }
                None => renderer.register_native_texture(device, &view, wgpu::FilterMode::Linear),
            };
            self.display = Some((texture, id));
        }
        let (texture, _) = self.display.as_ref().expect("set above");
        self.gpu.draw_mut().tonemap_into(exposure.unwrap_or(1.0), texture).context("tonemapping the view")?;
        Ok(Drawn { draw_ms, tonemap_ms: t1.elapsed().as_secs_f64() * 1e3, linear })
    }

    /// The last drawn image, linear (read back).
    pub fn read_linear(&self, camera: &Camera) -> Result<rsl_shade::Image> {
        let (pixels, covered) = self.gpu.draw().read_linear().context("reading the view back")?;
        Ok(rsl_shade::Image { width: camera.width, height: camera.height, pixels, covered })
    }

    /// The texture egui shows, read back.
    pub fn read_display(&self) -> Result<egui::ColorImage> {
        let (texture, _) = self.display.as_ref().context("nothing drawn with wgpu yet")?;
        let rgb = self.gpu.draw().read_display(texture).context("reading the view back")?;
        let pixels = rgb.chunks_exact(3).map(|p| egui::Color32::from_rgb(p[0], p[1], p[2])).collect();
        Ok(egui::ColorImage::new([texture.width() as usize, texture.height() as usize], pixels))
    }
}

impl Drop for WgpuView {
    fn drop(&mut self) {
        if let Some((_, id)) = &self.display {
            self.renderer.write().free_texture(id);
        }
    }
}

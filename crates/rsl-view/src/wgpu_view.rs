//! The 3D view drawn with wgpu on the window's own device: eframe's (or the headless
//! renderer's) device and queue, shared with rsl-gpu's draw pass. The vertices are shaded
//! by the engine's CPU path; rsl-gpu rasterises them with the environment behind and
//! tonemaps into a texture that egui samples where it lays out the view
//! (`register_native_texture`), with no readback. The linear image is read back only when
//! something asks for it: the first frame's exposure, the error readout against the
//! truth, a screenshot, a test.

use anyhow::{Context, Result, anyhow};
use eframe::egui_wgpu::{self, wgpu};
use glam::Mat3;
use rsl_engine::Engine;
use rsl_engine::scene::{Camera, SceneState};
use rsl_gpu::GpuContext;
use rsl_gpu::draw::GpuDraw;
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
    draw: GpuDraw,
    renderer: Arc<egui::mutex::RwLock<egui_wgpu::Renderer>>,
    /// The tonemapped image egui samples, and its id in egui's renderer.
    display: Option<(wgpu::Texture, egui::TextureId)>,
    /// The environment uploaded for the backdrop: (environment key, intensity bits).
    backdrop: Option<(u64, u32)>,
    adapter: String,
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
        let draw = GpuDraw::new(Arc::new(ctx)).context("building the draw pass on the window's device")?;
        Ok(Self { draw, renderer: state.renderer.clone(), display: None, backdrop: None, adapter })
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
    /// image back and sets it from that.
    pub fn draw(
        &mut self,
        engine: &Engine,
        state: &SceneState,
        camera: &Camera,
        meshes: &[rsl_shade::RasterMesh<'_>],
        exposure: &mut Option<f32>,
    ) -> Result<Drawn> {
        let t0 = Instant::now();
        let key = (engine.environment_key(), engine.intensity().to_bits());
        if self.backdrop != Some(key) {
            self.backdrop = None;
            self.draw.set_backdrop(&rsl_engine::gpu::backdrop(engine)).context("uploading the environment")?;
            self.backdrop = Some(key);
        }
        let env_from_world = Mat3::from_quat(state.world_from_env.inverse());
        self.draw.draw_meshes(meshes, camera, env_from_world).context("drawing the view with wgpu")?;
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
            let texture = self.draw.display_texture()?;
            let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
            let device = &self.draw.context().device;
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
        self.draw.tonemap_into(exposure.unwrap_or(1.0), texture).context("tonemapping the view")?;
        Ok(Drawn { draw_ms, tonemap_ms: t1.elapsed().as_secs_f64() * 1e3, linear })
    }

    /// The last drawn image, linear (read back).
    pub fn read_linear(&self, camera: &Camera) -> Result<rsl_shade::Image> {
        let (pixels, covered) = self.draw.read_linear().context("reading the view back")?;
        Ok(rsl_shade::Image { width: camera.width, height: camera.height, pixels, covered })
    }

    /// The texture egui shows, read back.
    pub fn read_display(&self) -> Result<egui::ColorImage> {
        let (texture, _) = self.display.as_ref().context("nothing drawn with wgpu yet")?;
        let rgb = self.draw.read_display(texture).context("reading the view back")?;
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

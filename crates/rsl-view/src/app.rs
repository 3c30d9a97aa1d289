//! The eframe app, the window, and the headless screenshot.

use super::*;

/// The eframe application around a [`Viewer`].
pub struct ViewerApp(pub Viewer);

impl eframe::App for ViewerApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.0.ui(ui);
    }
}

/// Opens a window on `viewer` (blocks until it is closed). The window's wgpu device is
/// opened with what rsl-gpu needs where the adapter has it, and the view is drawn on it
/// ([`Viewer::attach_wgpu`]); elsewhere the CPU draws the view.
pub fn run(viewer: Viewer, title: &str) -> Result<()> {
    let wgpu_setup = with_rsl_device(eframe::egui_wgpu::WgpuSetup::CreateNew(
        eframe::egui_wgpu::WgpuSetupCreateNew::without_display_handle(),
    ));
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default().with_inner_size([1200.0, 760.0]).with_title(title),
        renderer: eframe::Renderer::Wgpu,
        wgpu_options: eframe::egui_wgpu::WgpuConfiguration { wgpu_setup, ..Default::default() },
        ..Default::default()
    };
    let mut viewer = viewer;
    eframe::run_native(
        title,
        options,
        Box::new(|cc| {
            if let Some(state) = &cc.wgpu_render_state
                && let Err(e) = viewer.attach_wgpu(state)
            {
                eprintln!("rsl view: the view is drawn on the CPU: {e:#}");
            }
            Ok(Box::new(ViewerApp(viewer)))
        }),
    )
        .map_err(|e| anyhow!("cannot open the viewer's window: {e} (without a display, `--screenshot FILE.png` renders the viewer headless)"))
}

/// The UI size of the headless screenshot, points.
pub const SCREENSHOT_SIZE: [f32; 2] = [1200.0, 760.0];

/// Renders the whole UI of `viewer` headless (no display: egui's wgpu renderer on any
/// adapter, llvmpipe included) after waiting for its preparation and drawing `frames`
/// frames, and returns the RGBA image.
pub fn screenshot(viewer: Viewer, frames: usize) -> Result<image_rgba::Rgba> {
    let mut viewer = viewer;
    viewer.wait_prepared()?;
    let state = headless_render_state()?;
    if let Err(e) = viewer.attach_wgpu(&state) {
        eprintln!("rsl view: the view is drawn on the CPU: {e:#}");
    }
    let mut harness = egui_kittest::Harness::builder()
        .with_size(egui::vec2(SCREENSHOT_SIZE[0], SCREENSHOT_SIZE[1]))
        .renderer(egui_kittest::wgpu::WgpuTestRenderer::from_render_state(state))
        .build_ui_state(|ui, v: &mut Viewer| v.ui(ui), viewer);
    for _ in 0..frames.max(1) {
        harness.step();
        // A drawing prepares on a worker (the lobes prefiltered, say): the next frame draws with it.
        harness.state_mut().wait_drawing();
    }
    // The view as it is once it has rested: drawn per pixel where the drawing is, not
    // interpolated as while edits come.
    if harness.state_mut().settle_pixels(true) {
        harness.step();
        harness.state_mut().wait_drawing();
        harness.step();
    }
    if let Some(e) = harness.state().error() {
        return Err(anyhow!("{e}"));
    }
    let img = harness.render().map_err(|e| anyhow!("cannot render the UI: {e}"))?;
    Ok(image_rgba::Rgba { width: img.width(), height: img.height(), pixels: img.into_raw() })
}

/// A rendered RGBA image.
pub mod image_rgba {
    /// 8-bit RGBA pixels, row-major.
    #[derive(Clone, Debug)]
    pub struct Rgba {
        /// Width in pixels.
        pub width: u32,
        /// Height in pixels.
        pub height: u32,
        /// `4 × width × height` bytes.
        pub pixels: Vec<u8>,
    }

    impl Rgba {
        /// The RGB bytes (alpha dropped).
        pub fn rgb(&self) -> Vec<u8> {
            self.pixels.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect()
        }
    }
}

//! `rsl view`: the interactive viewer (egui/eframe on wgpu).
//!
//! [`Viewer`] holds an edited [`Scene`], the [`Engine`] prepared for it and the render
//! [`Session`] it draws through, and draws one egui frame at a time ([`Viewer::ui`]): the 3D
//! view (its drawing's vertices while edits come, rasterised on the CPU into a texture that
//! egui draws with wgpu, and the drawing's own frame once the view rests), and panels to pick
//! and move objects, rotate the environment, change the RSL count, the quality preset and
//! materials, play the scene's motion, and read what each stage cost.
//!
//! In a window (and in [`screenshot`]) the view is drawn with wgpu on the window's own
//! device, shared with rsl-gpu ([`Viewer::attach_wgpu`]): the CPU path shades the vertices,
//! rsl-gpu's draw pass rasterises and tonemaps them into a texture egui samples in place.
//! Without such a device the CPU rasteriser draws the view and egui uploads its image.
//!
//! - **Never blocks**: the engine is prepared on a worker thread ([`Viewer::is_preparing`]);
//!   the UI keeps drawing the last frame, with a progress bar.
//! - **Only what changed is reshaded** ([`Counters`]; the session finds it by content): a
//!   material edit reshades that object alone (the others' radiance does not depend on
//!   it); moving an object reshades it and the objects its shadow can reach (its occluder
//!   field's reach, and the traced lights' cones) at the old and new pose; moving the
//!   camera or the environment reshades every object; a frame in which nothing changed
//!   costs no shading and no rasterising.
//! - [`screenshot`] renders the whole UI headless (egui's wgpu test renderer, any adapter
//!   including llvmpipe) to a PNG.

use anyhow::{Context, Result, anyhow};
use egui::{Color32, ColorImage, TextureHandle, TextureOptions};
use glam::{Quat, Vec3};
use rayon::prelude::*;
use rsl_engine::registry::ImageKind;
use rsl_engine::scene::{Brdf, Preset, Quality, Scene};
use rsl_engine::{Engine, EngineOptions, Event, Incremental, MethodId, Progress, Session, method::exposure_for};
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

mod app;
mod edits;
mod gizmo;
mod panels;
mod refresh;
mod state;
mod truth;
mod wgpu_view;

pub use app::{SCREENSHOT_SIZE, ViewerApp, image_rgba, run, screenshot};
pub use wgpu_view::{device_descriptor, headless_render_state, supports_rsl, with_rsl_device};

/// How the viewer prepares its engine.
#[derive(Clone, Debug, Default)]
pub struct ViewerOptions {
    /// The disk cache folder (`None`: memory only).
    pub cache_dir: Option<PathBuf>,
    /// Quality preset instead of the scene's.
    pub quality: Option<Preset>,
}

/// What the viewer has done, for tests and the timings panel: shading is counted per
/// object, so that "only what changed is reshaded" can be checked.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// egui frames drawn.
    pub frames: u64,
    /// Frames drawn by a refresh, each shading what changed since the last (nothing, when
    /// only the drawing or the device changed).
    pub shaded_frames: u64,
    /// Objects shaded, summed over frames.
    pub objects_shaded: u64,
    /// Vertices shaded, summed over frames.
    pub vertices_shaded: u64,
    /// Images rasterised.
    pub rasterised: u64,
    /// Images drawn by the drawing's own method (per pixel), edits and rests together.
    pub pixel_frames: u64,
    /// Engines prepared (on the worker thread).
    pub prepared: u64,
}

/// What one reshaded frame cost, ms.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameCost {
    /// Bringing the engine in line with the scene (a material edit builds a BRDF table).
    pub sync_ms: f64,
    /// Shading the vertices that changed.
    pub shade_ms: f64,
    /// Rasterising the image (on the CPU, or with wgpu: [`FrameCost::on_gpu`]).
    pub raster_ms: f64,
    /// Tonemapping and uploading the texture (on the CPU), or tonemapping into the texture
    /// egui shows (with wgpu).
    pub upload_ms: f64,
    /// From the first edit of the frame to the texture uploaded.
    pub total_ms: f64,
    /// Whether the image was drawn with wgpu (rsl-gpu's draw pass on the window's device).
    pub on_gpu: bool,
}

/// The worker thread preparing an engine.
struct Worker {
    handle: JoinHandle<Result<Engine>>,
    /// The task being done and its fraction done.
    progress: Arc<Mutex<(String, f32)>>,
}

/// An orbit camera about a target.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Orbit {
    target: Vec3,
    yaw: f32,
    pitch: f32,
    distance: f32,
}

impl Orbit {
    fn of(eye: Vec3, target: Vec3) -> Self {
        let d = eye - target;
        let distance = d.length().max(1e-3);
        Self { target, yaw: d.x.atan2(d.z), pitch: (d.y / distance).clamp(-1.0, 1.0).asin(), distance }
    }

    fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        self.target + self.distance * Vec3::new(cp * sy, sp, cp * cy)
    }
}

/// Environment rotation as the viewer edits it: degrees about the world's up axis, after
/// the scene's own rotation.
pub(crate) fn yaw_rotation(degrees: f32) -> Quat {
    Quat::from_rotation_y(degrees.to_radians())
}

/// The interactive viewer's state: the edited scene, its engine and the last frame.
pub struct Viewer {
    scene: Scene,
    options: ViewerOptions,
    engine: Option<Engine>,
    worker: Option<Worker>,
    error: Option<String>,
    /// Scene time, seconds.
    time: f32,
    playing: bool,
    last_tick: Option<Instant>,
    orbit: Orbit,
    selected: usize,
    /// The scene's environment rotation as loaded; the slider turns it about +Y.
    env_base: Quat,
    env_degrees: f32,
    rsl_count: usize,
    preset: Preset,
    /// The methods the view is drawn with, and what changed since each one's last frame.
    session: Session,
    /// Whether the next refresh draws even if the scene did not change (a new drawing, a
    /// new device, a rested edit).
    redraw: bool,
    positions: Vec<Vec<Vec3>>,
    radiance: Vec<Vec<Vec3>>,
    exposure: Option<f32>,
    rgba: Option<ColorImage>,
    background: Option<Background>,
    texture: Option<TextureHandle>,
    /// Time spent on edits in the current frame (engine syncs).
    pending_sync_ms: f64,
    edit_started: Option<Instant>,
    counters: Counters,
    history: VecDeque<FrameCost>,
    /// The last material edit: which object, when.
    last_material_edit: Option<(usize, Instant)>,
    /// The object shown with a preview table while its slider moves.
    previewing: Option<usize>,
    /// Where "save scene" writes.
    save_path: String,
    /// Where "screenshot" writes.
    image_path: String,
    /// The last thing saved, for the panel.
    notice: Option<String>,
    /// Whether the progressive truth runs (and the error readout shows).
    truth_on: bool,
    /// Whether the view shows the truth instead of the RSL image.
    show_truth: bool,
    truth: Option<TruthRun>,
    /// The RSL image last drawn, linear.
    linear: Option<rsl_shade::Image>,
    /// The truth's image, tonemapped, when it is shown.
    truth_rgba: Option<ColorImage>,
    /// Whether the texture must be uploaded again.
    texture_stale: bool,
    /// Whether the image shown is the clay preview drawn before the first engine was ready.
    clay: bool,
    /// The environment thumbnail with its RSLs, for (environment key, RSL count).
    thumbnail: Option<((u64, usize), TextureHandle)>,
    readout: Option<ErrorReadout>,
    /// How the view is drawn once it rests (a method of the registry).
    drawing: MethodId,
    /// The next refresh draws per pixel (set on the toggle, and once edits rest).
    force_pixels: bool,
    /// When an edit was last drawn interpolated while drawing per pixel is on.
    pixels_pending: Option<Instant>,
    /// The longest frame of the drawing per pixel, ms, at which edits are drawn per pixel
    /// too ([`Viewer::set_live_budget`]).
    live_budget_ms: f64,
    /// What the last frame drawn per pixel took, ms (`None`: none since the drawing or its
    /// device changed).
    pixels_ms: Option<f64>,
    /// The gizmo handle a drag in the view holds, if it started on one.
    gizmo_drag: Option<GizmoPart>,
    /// Where the view's image was last laid out: its screen rectangle, and screen points per
    /// image pixel.
    view_area: Option<(egui::Rect, f32)>,
    /// The view's drawing with wgpu on the window's device, when attached.
    wgpu: Option<wgpu_view::WgpuView>,
    /// Whether the view's last image is the one drawn with wgpu (not read back unless asked).
    on_gpu: bool,
}

/// The selected object's gizmo, in image pixels: drawn over the view, dragged to move the
/// object along a world axis or turn it about +Y ([`Viewer::gizmo`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Gizmo {
    /// The object's place (its transform's translation at the current time).
    pub centre: (f32, f32),
    /// The tips of its move arrows along world +X, +Y and +Z.
    pub tips: [(f32, f32); 3],
    /// The turn handle: a circle about +Y through the object's place, as a closed polyline.
    pub ring: Vec<(f32, f32)>,
    /// The world length of each arrow.
    pub length: f32,
}

/// A handle of the [`Gizmo`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GizmoPart {
    /// The move arrow along world axis 0 (X), 1 (Y) or 2 (Z).
    Axis(usize),
    /// The turn ring about +Y.
    Ring,
}

/// Screen length of the gizmo's arrows, image pixels.
const GIZMO_PIXELS: f32 = 70.0;
/// How near a pointer must come to a handle to take it, image pixels.
const GIZMO_REACH: f32 = 6.0;

/// The drop-down's label of a drawing: the method's name (what it is shows on hover).
pub fn label(drawing: MethodId) -> String {
    drawing.name().to_string()
}

/// The drawings the viewer offers: every registered method it can redraw on edits.
pub fn drawings() -> Vec<MethodId> {
    MethodId::all().into_iter().filter(|m| m.capabilities().interactive).collect()
}

/// The RSL sum per pixel, the drawing `--per-pixel` asks for.
pub(crate) fn per_pixel_drawing() -> MethodId {
    drawings()
        .into_iter()
        .find(|m| m.capabilities().incremental == Incremental::PixelCovers)
        .expect("the registry holds the RSL sum per pixel")
}

/// Frames kept in the timings graph.
const HISTORY: usize = 120;

/// How long a material slider must rest before the edited object's real BRDF table
/// replaces the preview shown while it moved.
pub const PREVIEW_REST: std::time::Duration = std::time::Duration::from_millis(250);

/// The longest frame of a drawing per pixel at which the view is drawn per pixel while
/// edits come (a drag, a slider) too: 20 frames a second. Slower, edits are drawn from the
/// vertices and the view per pixel once they rest ([`PREVIEW_REST`]).
pub const LIVE_BUDGET_MS: f64 = 50.0;

/// Passes after which the progressive truth stops refining (4,096 spp).
const MAX_TRUTH_PASSES: u32 = 4096 / TRUTH_PASS_SPP;

/// Samples per pixel of one pass of the progressive truth (at least 2, so that each pass
/// estimates its own noise).
pub const TRUTH_PASS_SPP: u32 = 4;

/// The progressive Monte Carlo truth: passes of [`TRUTH_PASS_SPP`] samples per pixel
/// averaged as they come, on a worker thread, until the scene changes.
#[derive(Clone, Debug, Default)]
pub struct TruthImage {
    /// Passes averaged.
    pub passes: u32,
    /// Per pixel: the mean radiance over the passes.
    pub mean: Vec<Vec3>,
    /// Per pixel: the standard error of `mean`.
    pub std_error: Vec<Vec3>,
    /// Per pixel: whether an object covers it.
    pub covered: Vec<bool>,
    /// Why the truth stopped, if it failed.
    pub error: Option<String>,
}

impl TruthImage {
    fn add(&mut self, est: &[rsl_truth::Estimate], covered: Vec<bool>) {
        let p = self.passes as f32;
        if self.passes == 0 {
            self.mean = est.iter().map(|e| e.mean).collect();
            self.std_error = est.iter().map(|e| e.std_error).collect();
            self.covered = covered;
        } else {
            // Running mean; the standard error of a mean of P independent passes is
            // √(Σ se²)/P.
            for ((m, s), e) in self.mean.iter_mut().zip(&mut self.std_error).zip(est) {
                *m = (*m * p + e.mean) / (p + 1.0);
                *s = ((*s * p) * (*s * p) + e.std_error * e.std_error).powf(0.5) / (p + 1.0);
            }
        }
        self.passes += 1;
    }

    /// `‖standard error‖₂ / ‖mean‖₂` over the covered pixels: the truth's own noise.
    pub fn noise(&self) -> f64 {
        let (mut se, mut m) = (0.0f64, 0.0f64);
        for ((s, x), c) in self.std_error.iter().zip(&self.mean).zip(&self.covered) {
            if *c {
                se += f64::from(s.length_squared());
                m += f64::from(x.length_squared());
            }
        }
        if m > 0.0 { (se / m).sqrt() } else { 0.0 }
    }
}

/// The worker thread refining a [`TruthImage`].
struct TruthRun {
    stop: Arc<std::sync::atomic::AtomicBool>,
    image: Arc<Mutex<TruthImage>>,
    handle: Option<JoinHandle<()>>,
    /// Passes already turned into the readout.
    seen: u32,
}

impl Drop for TruthRun {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// The RSL image against the progressive truth, over the pixels both cover.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorReadout {
    /// Relative L2 of the RSL image against the truth's mean.
    pub relative_l2: f64,
    /// The truth's own noise (relative L2 of its standard error).
    pub truth_noise: f64,
    /// Passes of the truth so far.
    pub passes: u32,
    /// Samples per pixel so far.
    pub spp: u32,
}

/// The environment behind the objects, for one camera and environment orientation.
struct Background {
    key: (rsl_engine::scene::Camera, Quat, u64),
    /// Linear radiance per pixel.
    pixels: Vec<Vec3>,
    /// Tonemapped at `exposure`.
    encoded: Vec<Color32>,
    exposure: f32,
}

/// A radiance tonemapped for display (the command line's curve).
pub(crate) fn colour(c: Vec3, exposure: f32) -> Color32 {
    let [r, g, b] = rsl_shade::tonemap::encode(c, exposure);
    Color32::from_rgb(r, g, b)
}

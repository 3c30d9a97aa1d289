//! `rsl view`: the interactive viewer (egui/eframe on wgpu).
//!
//! [`Viewer`] holds an edited [`Scene`] and the [`Engine`] prepared for it, and draws one
//! egui frame at a time ([`Viewer::ui`]): the 3D view (shaded by the engine's CPU RSL path
//! and rasterised on the CPU into a texture that egui draws with wgpu), and panels to pick
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
//! - **Only what changed is reshaded** ([`Counters`]): a material edit reshades that object
//!   alone (the others' radiance does not depend on it); moving an object reshades it and
//!   the objects its shadow can reach (its occluder field's reach, and the traced lights'
//!   cones) at the old and new pose; moving the camera or the environment reshades every
//!   object; a frame in which nothing changed costs no shading and no rasterising.
//! - [`screenshot`] renders the whole UI headless (egui's wgpu test renderer, any adapter
//!   including llvmpipe) to a PNG.

use anyhow::{Context, Result, anyhow};
use egui::{Color32, ColorImage, TextureHandle, TextureOptions};
use glam::{Quat, Vec3};
use rayon::prelude::*;
use rsl_engine::scene::{Material, Preset, Quality, Scene};
use rsl_engine::{Engine, EngineOptions, Event, Incremental, MethodId, Progress, method::exposure_for};
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

mod wgpu_view;
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
    /// Frames in which anything was shaded.
    pub shaded_frames: u64,
    /// Objects shaded, summed over frames.
    pub objects_shaded: u64,
    /// Vertices shaded, summed over frames.
    pub vertices_shaded: u64,
    /// Images rasterised.
    pub rasterised: u64,
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
fn yaw_rotation(degrees: f32) -> Quat {
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
    /// Per object: whether its radiance must be recomputed.
    dirty: Vec<bool>,
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
    /// Whether anything moved (objects, camera, environment, time, lights) since the last
    /// image: if not, only the changed objects' pixels are redrawn.
    moved: bool,
    /// The environment thumbnail with its RSLs, for (environment key, RSL count).
    thumbnail: Option<((u64, usize), TextureHandle)>,
    readout: Option<ErrorReadout>,
    /// How the view is drawn once it rests (a method of the registry).
    drawing: MethodId,
    /// The methods drawn in whole frames, built from the registry when first chosen and kept
    /// with what they prepared (a prefiltered environment, material lobes).
    methods: Vec<(MethodId, Box<dyn rsl_engine::Method>)>,
    /// The drawing's preparation ([`rsl_engine::Method::preparation`]) running on a worker
    /// thread (seconds): frames are drawn from the vertices meanwhile.
    lobe_job: Option<(MethodId, std::thread::JoinHandle<rsl_engine::method::Prepared>)>,
    /// The next refresh draws per pixel (set on the toggle, and once edits rest).
    force_pixels: bool,
    /// When an edit was last drawn interpolated while drawing per pixel is on.
    pixels_pending: Option<Instant>,
    /// Per object drawn per pixel: every light's cover at its vertices.
    covers: Vec<Option<rsl_shade::Covers>>,
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
fn per_pixel_drawing() -> MethodId {
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
fn colour(c: Vec3, exposure: f32) -> Color32 {
    let [r, g, b] = rsl_shade::tonemap::encode(c, exposure);
    Color32::from_rgb(r, g, b)
}

impl Viewer {
    /// A viewer of the scene file `path`; starts preparing it on a worker thread.
    pub fn open(path: &Path, options: ViewerOptions) -> Result<Self> {
        let scene = Scene::load(path).with_context(|| format!("cannot open {}", path.display()))?;
        Ok(Self::new(scene, options))
    }

    /// A viewer of `scene`; starts preparing it on a worker thread.
    pub fn new(scene: Scene, options: ViewerOptions) -> Self {
        let mut scene = scene;
        let preset = options.quality.unwrap_or(scene.quality.preset);
        if preset != scene.quality.preset {
            scene.quality = Quality::from_preset(preset);
        }
        let n = scene.objects.len();
        let stem = scene.path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        let mut v = Self {
            orbit: Orbit::of(scene.camera.eye, scene.camera.target),
            env_base: scene.environment.rotation,
            rsl_count: scene.environment.rsl_count as usize,
            scene,
            options,
            engine: None,
            worker: None,
            error: None,
            time: 0.0,
            playing: false,
            last_tick: None,
            selected: 0,
            env_degrees: 0.0,
            preset,
            dirty: vec![true; n],
            positions: vec![Vec::new(); n],
            radiance: vec![Vec::new(); n],
            exposure: None,
            rgba: None,
            background: None,
            texture: None,
            pending_sync_ms: 0.0,
            edit_started: None,
            counters: Counters::default(),
            history: VecDeque::with_capacity(HISTORY),
            last_material_edit: None,
            previewing: None,
            save_path: format!("{stem}-edited.toml"),
            image_path: format!("{stem}-view.png"),
            notice: None,
            truth_on: false,
            show_truth: false,
            truth: None,
            linear: None,
            truth_rgba: None,
            texture_stale: false,
            moved: true,
            thumbnail: None,
            readout: None,
            drawing: MethodId::RSL,
            methods: Vec::new(),
            lobe_job: None,
            force_pixels: false,
            pixels_pending: None,
            gizmo_drag: None,
            view_area: None,
            covers: vec![None; n],
            wgpu: None,
            on_gpu: false,
        };
        v.prepare();
        v
    }

    /// Starts preparing the engine for the scene at the current preset on a worker thread
    /// (the UI keeps drawing the last frame meanwhile).
    fn prepare(&mut self) {
        let progress = Arc::new(Mutex::new(("starting".to_string(), 0.0f32)));
        let report = progress.clone();
        let mut scene = self.scene.clone();
        scene.environment.rsl_count = self.rsl_count as u32;
        let options = EngineOptions {
            cache_dir: self.options.cache_dir.clone(),
            quality: Some(self.preset),
            progress: Progress::new(move |e| {
                let mut p = report.lock().unwrap_or_else(|e| e.into_inner());
                match *e {
                    Event::Started { task } => *p = (task.to_string(), 0.0),
                    Event::Advanced { task, done, total } => {
                        *p = (task.to_string(), if total > 0 { done as f32 / total as f32 } else { 0.0 })
                    }
                    Event::Finished { task } => *p = (task.to_string(), 1.0),
                }
            }),
            ..Default::default()
        };
        let handle = std::thread::Builder::new()
            .name("rsl-view prepare".into())
            .spawn(move || Engine::new(&scene, options))
            .expect("the operating system refused a thread");
        self.worker = Some(Worker { handle, progress });
    }

    /// Whether the engine is being prepared on the worker thread.
    pub fn is_preparing(&self) -> bool {
        self.worker.is_some()
    }

    /// Waits for the worker thread (tests and the headless screenshot).
    pub fn wait_prepared(&mut self) -> Result<()> {
        if let Some(w) = self.worker.take() {
            self.finish(w);
        }
        match &self.error {
            Some(e) => Err(anyhow!("{e}")),
            None => Ok(()),
        }
    }

    fn poll_worker(&mut self) {
        if self.worker.as_ref().is_some_and(|w| w.handle.is_finished())
            && let Some(w) = self.worker.take()
        {
            self.finish(w);
        }
    }

    fn finish(&mut self, w: Worker) {
        match w.handle.join() {
            Ok(Ok(engine)) => {
                self.rsl_count = engine.rsl_count();
                self.engine = Some(engine);
                self.error = None;
                self.counters.prepared += 1;
                self.mark_all();
            }
            Ok(Err(e)) => self.error = Some(format!("{e:#}")),
            Err(_) => self.error = Some("the preparation thread panicked".into()),
        }
    }

    /// The edited scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The prepared engine (`None` while preparing).
    pub fn engine(&self) -> Option<&Engine> {
        self.engine.as_ref()
    }

    /// What the viewer has done so far.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// The costs of the most recent reshaded frames, oldest first.
    pub fn history(&self) -> impl Iterator<Item = &FrameCost> {
        self.history.iter()
    }

    /// The last error (a failed preparation or edit), if any.
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    /// The last image shown, as RGBA pixels (`None` before the first frame; when the view is
    /// drawn with wgpu, `None` until [`Viewer::read_back`]).
    pub fn image(&self) -> Option<&ColorImage> {
        self.rgba.as_ref()
    }

    /// Draws the view with wgpu on `state`'s device (a window's, or the headless
    /// renderer's), shared with rsl-gpu: from the next frame on, the CPU shades the vertices
    /// and rsl-gpu's draw pass rasterises and tonemaps them into a texture egui samples.
    /// Images drawn per pixel by the CPU methods are still uploaded. An error (a device
    /// rsl-gpu cannot use) leaves the view drawn on the CPU.
    pub fn attach_wgpu(&mut self, state: &eframe::egui_wgpu::RenderState) -> Result<()> {
        let view = wgpu_view::WgpuView::new(state)?;
        self.wgpu = Some(view);
        self.linear = None;
        self.background = None;
        self.mark_all();
        Ok(())
    }

    /// Whether rsl-gpu's shading pass shades the vertices (by default on a hardware adapter
    /// once [`Viewer::attach_wgpu`] has attached one), or the CPU path does.
    pub fn shading_on_gpu(&self) -> bool {
        self.wgpu.as_ref().is_some_and(|w| w.shades)
    }

    /// Shades on the GPU (every vertex of every changed frame, by rsl-gpu's shading pass on
    /// the attached device) or on the CPU (only what changed); an error before
    /// [`Viewer::attach_wgpu`].
    pub fn set_shading_on_gpu(&mut self, on: bool) -> Result<()> {
        let w = self.wgpu.as_mut().context("the view is not drawn with wgpu")?;
        if w.shades != on {
            w.shades = on;
            self.mark_all();
        }
        Ok(())
    }

    /// The adapter the view is drawn with, in words, when it is drawn with wgpu.
    pub fn wgpu_adapter(&self) -> Option<&str> {
        self.wgpu.as_ref().map(|w| w.adapter())
    }

    /// Whether the image shown was drawn with wgpu (and lives on the GPU).
    pub fn shown_on_gpu(&self) -> bool {
        self.on_gpu
    }

    /// Reads the view drawn with wgpu back into [`Viewer::image`] and
    /// [`Viewer::linear_image`] (nothing to do when the CPU drew it, or it was read already).
    pub fn read_back(&mut self) -> Result<()> {
        let Some(w) = self.wgpu.as_ref().filter(|_| self.on_gpu) else { return Ok(()) };
        if self.linear.is_none() {
            self.linear = Some(w.read_linear(&self.scene.camera)?);
        }
        if self.rgba.is_none() {
            self.rgba = Some(w.read_display()?);
        }
        Ok(())
    }

    /// The RSL image last drawn, linear radiance (`None` before the first frame; when the
    /// view is drawn with wgpu, see [`Viewer::read_back`]).
    pub fn linear_image(&self) -> Option<&rsl_shade::Image> {
        self.linear.as_ref()
    }

    /// Per object, per vertex: the radiance last shaded.
    pub fn radiance(&self) -> &[Vec<Vec3>] {
        &self.radiance
    }

    /// The RSL count in use.
    pub fn rsl_count(&self) -> usize {
        self.rsl_count
    }

    /// The environment's extra rotation about +Y, degrees.
    pub fn environment_degrees(&self) -> f32 {
        self.env_degrees
    }

    fn mark_all(&mut self) {
        self.dirty.iter_mut().for_each(|d| *d = true);
        self.moved = true;
    }

    /// Sets object `i`'s material: one BRDF table is built (milliseconds) and that object
    /// alone is reshaded. While a slider moves (edits of the same object less than
    /// [`PREVIEW_REST`] apart) the table is a preview at `rsl_engine::engine::PREVIEW_RESOLUTION`;
    /// the real table is built when the slider rests ([`Viewer::settle`]).
    pub fn set_material(&mut self, i: usize, material: Material) -> Result<()> {
        let o = self.scene.objects.get_mut(i).context("no such object")?;
        if o.material == material {
            return Ok(());
        }
        self.edit_started.get_or_insert_with(Instant::now);
        o.material = material;
        let now = Instant::now();
        let dragging = self.last_material_edit.is_some_and(|(j, t)| j == i && now.duration_since(t) < PREVIEW_REST);
        if let Some(engine) = &mut self.engine {
            let start = Instant::now();
            engine.sync_previewing(&self.scene, dragging.then_some(i))?;
            self.pending_sync_ms += start.elapsed().as_secs_f64() * 1e3;
        }
        self.previewing = if dragging { Some(i) } else { None };
        self.last_material_edit = Some((i, now));
        self.dirty[i] = true;
        Ok(())
    }

    /// Builds the real table of an object shown with a preview table once its slider has
    /// rested for [`PREVIEW_REST`] (or at once with `now`); `true` when it did.
    pub fn settle(&mut self, now: bool) -> Result<bool> {
        let Some(i) = self.previewing else { return Ok(false) };
        let rested = self.last_material_edit.is_none_or(|(_, t)| t.elapsed() >= PREVIEW_REST);
        if !(now || rested) {
            return Ok(false);
        }
        self.previewing = None;
        if let Some(engine) = &mut self.engine {
            self.edit_started.get_or_insert_with(Instant::now);
            let start = Instant::now();
            engine.sync(&self.scene)?;
            self.pending_sync_ms += start.elapsed().as_secs_f64() * 1e3;
            self.dirty[i] = true;
        }
        Ok(true)
    }

    /// Whether an object is shown with a preview table (a slider is moving).
    pub fn is_previewing(&self) -> bool {
        self.previewing.is_some()
    }

    /// Which objects object `j` can shadow at the current time (`None` without an engine).
    fn shadow_reach(&self, j: usize) -> Option<Vec<bool>> {
        let engine = self.engine.as_ref()?;
        engine.shadowed_by(&self.scene, &self.scene.at(self.time), j).ok()
    }

    /// Replaces object `j`'s base transform: `j` is reshaded, and every object it can
    /// shadow at the old or the new pose ([`Engine::shadowed_by`]); the rest keep their
    /// radiance.
    fn move_object(&mut self, j: usize, transform: rsl_engine::scene::Transform) {
        if self.scene.objects[j].transform == transform {
            return;
        }
        self.edit_started.get_or_insert_with(Instant::now);
        let before = self.shadow_reach(j);
        self.scene.objects[j].transform = transform;
        let after = self.shadow_reach(j);
        match (before, after) {
            (Some(b), Some(a)) => {
                for (i, d) in self.dirty.iter_mut().enumerate() {
                    *d |= i == j || b[i] || a[i];
                }
                self.moved = true;
            }
            _ => self.mark_all(),
        }
    }

    /// Moves object `i` to `translation` (its base transform, before motion): it is
    /// reshaded with the objects its shadow can reach.
    pub fn set_translation(&mut self, i: usize, translation: Vec3) -> Result<()> {
        let o = self.scene.objects.get(i).context("no such object")?;
        if !translation.is_finite() {
            return Err(anyhow!("object {}: translation must be finite", o.name));
        }
        let t = rsl_engine::scene::Transform { translation, ..o.transform };
        self.move_object(i, t);
        Ok(())
    }

    /// Sets object `i`'s rotation about +Y, degrees (replacing its base rotation).
    pub fn set_yaw(&mut self, i: usize, degrees: f32) -> Result<()> {
        let o = self.scene.objects.get(i).context("no such object")?;
        if !degrees.is_finite() {
            return Err(anyhow!("object {}: the turn must be finite", o.name));
        }
        let t = rsl_engine::scene::Transform { rotation: yaw_rotation(degrees), ..o.transform };
        self.move_object(i, t);
        Ok(())
    }

    /// Turns the environment by `degrees` about +Y after its own rotation: nothing is
    /// rebuilt (the lights rotate), every object is reshaded.
    pub fn set_environment_degrees(&mut self, degrees: f32) {
        if degrees != self.env_degrees {
            self.edit_started.get_or_insert_with(Instant::now);
            self.env_degrees = degrees;
            self.scene.environment.rotation = (yaw_rotation(degrees) * self.env_base).normalize();
            self.mark_all();
        }
    }

    /// Sets the RSL count: the merge tree already holds every count, so nothing is
    /// recomputed (the engine's cache counters do not move); every object is reshaded.
    pub fn set_rsl_count(&mut self, n: usize) -> Result<()> {
        if n == self.rsl_count {
            return Ok(());
        }
        if let Some(engine) = &mut self.engine {
            self.edit_started.get_or_insert_with(Instant::now);
            let start = Instant::now();
            engine.set_rsl_count(n)?;
            self.pending_sync_ms += start.elapsed().as_secs_f64() * 1e3;
            self.mark_all();
        }
        self.rsl_count = n;
        self.scene.environment.rsl_count = n as u32;
        Ok(())
    }

    /// Switches the quality preset: the engine is prepared again on the worker thread.
    pub fn set_preset(&mut self, preset: Preset) {
        if preset != self.preset && self.worker.is_none() {
            self.preset = preset;
            self.scene.quality = Quality::from_preset(preset);
            self.prepare();
        }
    }

    /// Saves the edited scene as a scene file that `rsl render` reproduces (atomically:
    /// nothing half-written is left).
    pub fn save(&self, path: &Path) -> Result<()> {
        let text = self.scene.to_toml(path).with_context(|| format!("cannot write the scene as {}", path.display()))?;
        rsl_engine::output::write_atomic(path, text.as_bytes())
    }

    /// Writes the image shown as a PNG (the 3D view alone, at the camera's resolution).
    pub fn save_image(&mut self, path: &Path) -> Result<()> {
        self.read_back()?;
        let img = self.rgba.as_ref().context("no image has been drawn yet")?;
        let rgb: Vec<u8> = img.pixels.iter().flat_map(|c| [c.r(), c.g(), c.b()]).collect();
        rsl_engine::output::write_png(path, img.size[0] as u32, img.size[1] as u32, rgb)
    }

    /// Sets the scene time (seconds).
    pub fn set_time(&mut self, t: f32) {
        if t != self.time && t.is_finite() {
            self.edit_started.get_or_insert_with(Instant::now);
            self.time = t;
            if self.scene.is_dynamic() {
                self.mark_all();
            }
        }
    }

    /// Orbits the camera by `dx`, `dy` radians and scales its distance by `zoom`.
    fn orbit_by(&mut self, dx: f32, dy: f32, zoom: f32) {
        self.edit_started.get_or_insert_with(Instant::now);
        self.orbit.yaw -= dx;
        self.orbit.pitch = (self.orbit.pitch + dy).clamp(-1.5, 1.5);
        self.orbit.distance = (self.orbit.distance * zoom).clamp(1e-2, 1e4);
        self.scene.camera.eye = self.orbit.eye();
        self.mark_all();
    }

    /// Turns the progressive truth (and the error readout against it) on or off.
    pub fn set_truth(&mut self, on: bool) {
        self.truth_on = on;
        if !on {
            self.truth = None;
            self.readout = None;
            self.show_truth = false;
        }
    }

    /// Shows the truth's image instead of the RSL image (while the truth runs).
    pub fn set_show_truth(&mut self, on: bool) {
        self.show_truth = on && self.truth_on;
        self.texture_stale = true;
        if let Some(t) = &mut self.truth {
            // The next poll redraws the truth's image from what it has.
            t.seen = 0;
        }
    }

    /// The RSL image against the truth so far (`None` before the truth's first pass).
    pub fn error_readout(&self) -> Option<ErrorReadout> {
        self.readout
    }

    /// A copy of the truth so far (`None` when it is off).
    pub fn truth_image(&self) -> Option<TruthImage> {
        let t = self.truth.as_ref()?;
        Some(t.image.lock().map(|i| i.clone()).unwrap_or_else(|e| e.into_inner().clone()))
    }

    /// Starts the truth over for the scene as it is now.
    fn restart_truth(&mut self) {
        self.truth = None;
        self.readout = None;
        self.truth_rgba = None;
        let Some(engine) = &self.engine else { return };
        let state = self.scene.at(self.time);
        let env = rsl_engine::method::env_light(engine);
        let ts = match rsl_engine::Truth::scene(engine, &self.scene, &state, env) {
            Ok(ts) => ts,
            Err(e) => {
                self.error = Some(format!("truth: {e:#}"));
                return;
            }
        };
        let camera = self.scene.camera;
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let image = Arc::new(Mutex::new(TruthImage::default()));
        let (stop2, image2) = (stop.clone(), image.clone());
        let handle = std::thread::Builder::new()
            .name("rsl-view truth".into())
            .spawn(move || {
                let mut pass = 0u64;
                while !stop2.load(std::sync::atomic::Ordering::Relaxed) && pass < u64::from(MAX_TRUTH_PASSES) {
                    pass += 1;
                    match ts.pixels(&camera, TRUTH_PASS_SPP, pass) {
                        Ok((est, covered, _)) => {
                            if stop2.load(std::sync::atomic::Ordering::Relaxed) {
                                break;
                            }
                            image2.lock().unwrap_or_else(|e| e.into_inner()).add(&est, covered);
                        }
                        Err(e) => {
                            image2.lock().unwrap_or_else(|e| e.into_inner()).error = Some(e.to_string());
                            break;
                        }
                    }
                }
            })
            .expect("the operating system refused a thread");
        self.truth = Some(TruthRun { stop, image, handle: Some(handle), seen: 0 });
    }

    /// Takes in the truth's new passes: the readout, and the view when it shows the truth.
    fn poll_truth(&mut self, ctx: &egui::Context) {
        if !self.truth_on || self.engine.is_none() {
            return;
        }
        if self.truth.is_none() {
            self.restart_truth();
        }
        let Some(t) = &mut self.truth else { return };
        ctx.request_repaint_after(std::time::Duration::from_millis(200));
        let img = t.image.lock().map(|i| i.clone()).unwrap_or_else(|e| e.into_inner().clone());
        if let Some(e) = &img.error {
            self.error = Some(format!("truth: {e}"));
        }
        if img.passes == t.seen {
            return;
        }
        t.seen = img.passes;
        if self.on_gpu && self.linear.is_none() {
            // The view lives on the GPU: read it back once for the readout.
            let r = self.read_back();
            self.report(r);
        }
        if let Some(rsl) = &self.linear {
            let mask: Vec<bool> = rsl.covered.iter().zip(&img.covered).map(|(a, b)| *a && *b).collect();
            if let Ok(m) = rsl_truth::metrics::compare(&rsl.pixels, &img.mean, Some(&mask)) {
                self.readout = Some(ErrorReadout {
                    relative_l2: m.relative_l2,
                    truth_noise: img.noise(),
                    passes: img.passes,
                    spp: img.passes * TRUTH_PASS_SPP,
                });
            }
        }
        if self.show_truth {
            let exposure = self.exposure.unwrap_or(1.0);
            let pixels = img.mean.par_iter().map(|&c| colour(c, exposure)).collect();
            let c = &self.scene.camera;
            self.truth_rgba = Some(ColorImage::new([c.width as usize, c.height as usize], pixels));
            self.texture_stale = true;
        }
    }

    /// Draws glossy objects per pixel (each pixel's own normal and view in the RSL sum, the
    /// visibility interpolated from the vertices, traced lights traced per pixel;
    /// `rsl_engine::CpuRslPixels` renders the same image) whenever the view rests
    /// ([`Viewer::settle_pixels`]), or interpolates every object's vertex radiance always.
    pub fn set_per_pixel(&mut self, on: bool) {
        self.set_drawing(if on { per_pixel_drawing() } else { MethodId::RSL });
    }

    /// How the view is drawn once it rests (a method of the registry); drawn that way at
    /// once.
    pub fn set_drawing(&mut self, drawing: MethodId) {
        if self.drawing != drawing {
            self.drawing = drawing;
            self.force_pixels = !self.vertices_only();
            self.pixels_pending = None;
            self.covers.iter_mut().for_each(|c| *c = None);
            self.mark_all();
        }
    }

    /// How the view is drawn once it rests.
    pub fn drawing(&self) -> MethodId {
        self.drawing
    }

    /// Whether the drawing is the vertices interpolated, always (nothing to settle).
    fn vertices_only(&self) -> bool {
        self.drawing.capabilities().incremental == Incremental::Vertices
    }

    /// Drawing per pixel costs hundreds of milliseconds a frame on 2 cores: while edits come
    /// (a slider, a drag, the camera), frames are interpolated, and the view is drawn per
    /// pixel again once it has rested for [`PREVIEW_REST`] (or at once with `now`); `true`
    /// when that was started.
    pub fn settle_pixels(&mut self, now: bool) -> bool {
        match self.pixels_pending {
            Some(t) if now || t.elapsed() >= PREVIEW_REST => {
                self.pixels_pending = None;
                self.force_pixels = true;
                // Every object again, with its covers (interpolated frames did not keep them).
                self.mark_all();
                true
            }
            _ => false,
        }
    }

    /// Whether glossy objects are drawn with the RSL sum per pixel.
    pub fn per_pixel(&self) -> bool {
        self.drawing.capabilities().incremental == Incremental::PixelCovers
    }

    /// Whether the drawing is prepared ([`rsl_engine::Method::preparation`]): if not, its
    /// preparation is started on a worker thread (once) and `false` comes back; a finished
    /// worker's result is given to its method.
    fn lobes_ready(&mut self) -> Result<bool> {
        if self.lobe_job.as_ref().is_some_and(|(_, h)| !h.is_finished()) {
            return Ok(false);
        }
        if let Some((id, h)) = self.lobe_job.take() {
            let p = h.join().map_err(|_| anyhow!("preparing the drawing {id} failed"))?;
            if let Some((_, m)) = self.methods.iter_mut().find(|(m, _)| *m == id) {
                m.install(p);
            }
        }
        if self.drawing.capabilities().incremental != Incremental::Frames {
            return Ok(true);
        }
        let id = self.drawing;
        let at = self.method()?;
        let Some(engine) = &self.engine else { return Ok(true) };
        match self.methods[at].1.preparation(engine)? {
            None => Ok(true),
            Some(job) => {
                let handle = std::thread::Builder::new()
                    .name("rsl-view prepare".into())
                    .spawn(move || job.run())
                    .context("starting the preparation thread")?;
                self.lobe_job = Some((id, handle));
                Ok(false)
            }
        }
    }

    /// Where the drawing's method is in `methods` (built from the registry, on the CPU, when
    /// first asked for).
    fn method(&mut self) -> Result<usize> {
        let id = self.drawing;
        let at = match self.methods.iter().position(|(m, _)| *m == id) {
            Some(at) => at,
            None => {
                let engine = self.engine.as_ref().ok_or_else(|| anyhow!("the scene is not prepared yet"))?;
                let options = rsl_engine::MethodOptions { device: rsl_engine::Device::Cpu, ..Default::default() };
                self.methods.push((id, id.create(engine, &options)?));
                self.methods.len() - 1
            }
        };
        Ok(at)
    }

    /// Waits for the environment being prefiltered for the lobes, if any (tests and the
    /// headless screenshot); the next refresh draws with them.
    pub fn wait_lobes(&mut self) {
        if let Some((_, h)) = &self.lobe_job {
            while !h.is_finished() {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
            self.mark_all();
        }
    }

    /// Whether the lobes' environment is being prefiltered on the worker thread.
    pub fn is_prefiltering(&self) -> bool {
        self.lobe_job.is_some()
    }

    /// [`Viewer::refresh`] through one of the lobe methods (or `auto`): the whole frame by
    /// the engine's method, as `rsl render --method` draws it.
    fn refresh_method(&mut self, start: Instant) -> Result<bool> {
        if self.engine.is_none() {
            return Ok(false);
        }
        let at = self.method()?;
        let Some(engine) = &self.engine else { return Ok(false) };
        let request = rsl_engine::Request { time: self.time, image: true, vertices: true, exposure: None };
        let frame = self.methods[at].1.render(engine, &self.scene, &request)?;
        let n = self.scene.objects.len();
        for (i, (p, r)) in frame.positions.into_iter().zip(frame.radiance).enumerate().take(n) {
            self.counters.vertices_shaded += r.len() as u64;
            self.counters.objects_shaded += 1;
            self.positions[i] = p;
            self.radiance[i] = r;
        }
        self.counters.shaded_frames += 1;
        self.counters.rasterised += 1;
        self.dirty.iter_mut().for_each(|d| *d = false);
        self.moved = false;
        let stages = &frame.timings.stages;
        let raster_ms: f64 = stages.iter().filter(|s| s.name.starts_with("draw")).map(|s| s.wall_ms).sum();
        let shade_ms: f64 = stages.iter().filter(|s| !s.name.starts_with("draw")).map(|s| s.wall_ms).sum();
        let image = frame.image.ok_or_else(|| anyhow::anyhow!("the method drew no image"))?;
        self.show_whole(image, start, shade_ms, raster_ms);
        Ok(true)
    }

    /// Shows a whole image drawn per pixel: tonemapped and uploaded.
    fn show_whole(&mut self, image: rsl_shade::Image, start: Instant, shade_ms: f64, raster_ms: f64) {
        let t2 = Instant::now();
        let exposure = *self.exposure.get_or_insert_with(|| exposure_for(&image));
        let pixels: Vec<Color32> = image.pixels.par_iter().map(|&c| colour(c, exposure)).collect();
        // The next interpolated frame starts afresh (its background may be stale).
        self.background = None;
        self.show(image, pixels, [start, t2], shade_ms, raster_ms);
    }

    /// [`Viewer::refresh`] per pixel: the dirty objects shaded at their vertices (glossy ones
    /// keeping every light's cover), then the whole image drawn.
    fn refresh_per_pixel(&mut self, start: Instant) -> Result<bool> {
        let Some(engine) = &self.engine else { return Ok(false) };
        let t0 = Instant::now();
        let state = self.scene.at(self.time);
        let setup = engine.setup(&self.scene, &state, self.scene.camera.eye, rsl_shade::Terms::default())?;
        let n = self.scene.objects.len();
        let per_pixel: Vec<bool> =
            (0..n).map(|i| rsl_shade::drawn_per_pixel(&setup, !engine.brdf(i).is_lambertian())).collect();
        let with_covers: Vec<bool> = (0..n).map(|i| self.dirty[i] && per_pixel[i]).collect();
        let plain: Vec<bool> = (0..n).map(|i| self.dirty[i] && !per_pixel[i]).collect();
        let (mut radiance, covers, _) = rsl_shade::shade_covers(&setup, &with_covers);
        let (plain_radiance, _) = rsl_shade::shade_objects(&setup, &plain);
        for (i, (c, r)) in covers.into_iter().zip(plain_radiance).enumerate() {
            if !self.dirty[i] {
                continue;
            }
            if plain[i] {
                radiance[i] = r;
            }
            self.counters.vertices_shaded += radiance[i].len() as u64;
            self.counters.objects_shaded += 1;
            self.positions[i] = (0..radiance[i].len()).map(|v| setup.position(i, v)).collect();
            self.radiance[i] = std::mem::take(&mut radiance[i]);
            self.covers[i] = c;
        }
        self.counters.shaded_frames += 1;
        self.dirty.iter_mut().for_each(|d| *d = false);
        self.moved = false;
        let shade_ms = t0.elapsed().as_secs_f64() * 1e3;
        let t1 = Instant::now();
        let (image, _) = rsl_shade::shade_image(&setup, &self.scene.camera, &self.covers, &self.radiance, |d| {
            engine.background(&state, d)
        });
        self.counters.rasterised += 1;
        let raster_ms = t1.elapsed().as_secs_f64() * 1e3;
        self.show_whole(image, start, shade_ms, raster_ms);
        Ok(true)
    }

    /// Shades what changed and rasterises a new image; `false` when nothing changed (no
    /// shading, no rasterising).
    pub fn refresh(&mut self) -> Result<bool> {
        if self.engine.is_none() || !self.dirty.iter().any(|&d| d) {
            return Ok(false);
        }
        let start = self.edit_started.take().unwrap_or_else(Instant::now);
        if !self.vertices_only() {
            if self.force_pixels && !self.lobes_ready()? {
                // Drawn from the vertices until the worker has prefiltered the environment
                // (`force_pixels` stays: the frame after it draws per pixel).
            } else if std::mem::take(&mut self.force_pixels) {
                return match self.drawing.capabilities().incremental {
                    Incremental::PixelCovers => self.refresh_per_pixel(start),
                    _ => self.refresh_method(start),
                };
            }
        }
        let Some(engine) = &self.engine else { return Ok(false) };
        // rsl-gpu's shading pass (a hardware adapter) shades every vertex.
        if self.wgpu.as_ref().is_some_and(|w| w.shades) {
            self.dirty.iter_mut().for_each(|d| *d = true);
        }
        let all = self.dirty.iter().all(|&d| d);
        // Only radiance changed (material edits): the image is redrawn where those objects
        // are, over the last one.
        let changed = self.dirty.clone();
        let still = !std::mem::take(&mut self.moved);
        let partial = still && self.linear.is_some();
        let t0 = Instant::now();
        let gpu_frame = match self.wgpu.as_mut().filter(|w| w.shades) {
            Some(w) => match w.shade(engine, &self.scene, self.time) {
                Ok(frame) => Some(frame),
                Err(e) => {
                    self.error =
                        Some(format!("shading with wgpu: {e:#}; the view is shaded and drawn on the CPU from now on"));
                    self.wgpu = None;
                    self.on_gpu = false;
                    None
                }
            },
            None => None,
        };
        let shaded_on_gpu = gpu_frame.is_some();
        let frame = match gpu_frame {
            Some(frame) => frame,
            None if all => engine.shade(&self.scene, self.time)?,
            None => engine.shade_objects(&self.scene, self.time, &self.dirty)?,
        };
        let shade_ms = t0.elapsed().as_secs_f64() * 1e3;
        let state = frame.state.clone();
        for (i, (p, r)) in frame.positions.into_iter().zip(frame.radiance).enumerate() {
            if self.dirty[i] {
                self.counters.vertices_shaded += r.len() as u64;
                self.counters.objects_shaded += 1;
                self.positions[i] = p;
                self.radiance[i] = r;
            }
        }
        self.counters.shaded_frames += 1;
        self.dirty.iter_mut().for_each(|d| *d = false);
        let meshes: Vec<rsl_shade::RasterMesh<'_>> = self
            .scene
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| rsl_shade::RasterMesh {
                positions: &self.positions[i],
                indices: &o.mesh.indices,
                radiance: &self.radiance[i],
            })
            .collect();
        if let Some(w) = self.wgpu.as_mut() {
            let drawn = if shaded_on_gpu {
                w.draw_shaded(engine, &self.scene, self.time, &mut self.exposure)
            } else {
                // Only radiance changed since the image shown, drawn with wgpu too: the changed
                // objects are drawn again over it.
                let redraw = (still && self.on_gpu).then_some(&changed[..]);
                w.draw(engine, &state, &self.scene.camera, &meshes, redraw, &mut self.exposure)
            };
            match drawn {
                Ok(drawn) => {
                    self.counters.rasterised += 1;
                    self.linear = drawn.linear;
                    self.rgba = None;
                    self.on_gpu = true;
                    self.record(start, shade_ms, drawn.draw_ms, drawn.tonemap_ms, true);
                    if !self.vertices_only() {
                        self.pixels_pending = Some(Instant::now());
                    }
                    return Ok(true);
                }
                Err(e) => {
                    // The window's device failed (lost, or out of memory): the CPU draws
                    // from now on, starting with this frame.
                    self.error = Some(format!("drawing with wgpu: {e:#}; the view is drawn on the CPU from now on"));
                    self.wgpu = None;
                    self.on_gpu = false;
                    self.linear = None;
                }
            }
        }
        let partial = partial && self.linear.is_some();
        let t1 = Instant::now();
        // The environment behind the objects is looked up (and tonemapped) again only when
        // the camera or the environment's orientation changed.
        let key = (self.scene.camera, state.world_from_env, engine.environment_key());
        let fresh = self.background.as_ref().is_none_or(|b| b.key != key);
        if fresh {
            let pixels = rsl_shade::background_image(&self.scene.camera, |d| engine.background(&state, d));
            self.background = Some(Background { key, pixels, encoded: Vec::new(), exposure: f32::NAN });
        }
        let bg = self.background.as_mut().expect("set above");
        let previous = if partial && !fresh { self.linear.take() } else { None };
        let image = match previous.clone() {
            Some(mut image) => {
                rsl_shade::rasterise_changed(&self.scene.camera, &meshes, &changed, &bg.pixels, &mut image);
                image
            }
            None => rsl_shade::rasterise_over(&self.scene.camera, &meshes, &bg.pixels),
        };
        self.counters.rasterised += 1;
        let raster_ms = t1.elapsed().as_secs_f64() * 1e3;
        let t2 = Instant::now();
        let exposure = *self.exposure.get_or_insert_with(|| exposure_for(&image));
        if bg.exposure != exposure {
            bg.encoded = bg.pixels.iter().map(|&c| colour(c, exposure)).collect();
            bg.exposure = exposure;
        }
        let pixels: Vec<Color32> = match (&previous, &self.rgba) {
            // Pixels whose radiance did not change keep their colour.
            (Some(prev), Some(rgba)) if rgba.pixels.len() == image.pixels.len() => image
                .pixels
                .par_iter()
                .zip(&prev.pixels)
                .zip(&rgba.pixels)
                .map(|((&c, &p), &old)| if c == p { old } else { colour(c, exposure) })
                .collect(),
            _ => image
                .pixels
                .par_iter()
                .zip(&image.covered)
                .zip(&bg.encoded)
                .map(|((&c, &covered), &b)| if covered { colour(c, exposure) } else { b })
                .collect(),
        };
        self.show(image, pixels, [start, t2], shade_ms, raster_ms);
        if !self.vertices_only() {
            // Per pixel again once the view has rested PREVIEW_REST after this frame (and,
            // while the worker prefilters, a check that often).
            self.pixels_pending = Some(Instant::now());
        }
        Ok(true)
    }

    /// Shows a new image (`pixels` its tonemapped colours), restarts the truth, and records
    /// the frame's cost: the edit began at `start`, the upload at `upload`.
    fn show(
        &mut self,
        image: rsl_shade::Image,
        pixels: Vec<Color32>,
        [start, upload]: [Instant; 2],
        shade_ms: f64,
        raster_ms: f64,
    ) {
        self.rgba = Some(ColorImage::new([image.width as usize, image.height as usize], pixels));
        self.linear = Some(image);
        self.texture_stale = true;
        self.on_gpu = false;
        let upload_ms = upload.elapsed().as_secs_f64() * 1e3;
        self.record(start, shade_ms, raster_ms, upload_ms, false);
    }

    /// Records a new image's cost (the edit began at `start`) and restarts the truth.
    fn record(&mut self, start: Instant, shade_ms: f64, raster_ms: f64, upload_ms: f64, on_gpu: bool) {
        if self.truth_on {
            // The scene changed: the truth starts over.
            self.restart_truth();
        }
        let cost = FrameCost {
            sync_ms: std::mem::take(&mut self.pending_sync_ms),
            shade_ms,
            raster_ms,
            upload_ms,
            total_ms: start.elapsed().as_secs_f64() * 1e3,
            on_gpu,
        };
        if self.history.len() == HISTORY {
            self.history.pop_front();
        }
        self.history.push_back(cost);
    }

    /// Draws one frame of the whole UI into `ui` (the eframe app and the headless
    /// screenshot both call it).
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        self.counters.frames += 1;
        self.poll_worker();
        if self.playing {
            let now = Instant::now();
            let dt = self.last_tick.map_or(0.0, |t| now.duration_since(t).as_secs_f32());
            self.last_tick = Some(now);
            self.set_time(self.time + dt);
            ui.ctx().request_repaint();
        } else {
            self.last_tick = None;
        }
        if self.worker.is_some() {
            ui.ctx().request_repaint_after(std::time::Duration::from_millis(100));
        }
        egui::Panel::left("controls").resizable(true).min_size(260.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.controls(ui));
        });
        egui::Panel::bottom("timings").show(ui, |ui| self.timings(ui));
        egui::CentralPanel::default().show(ui, |ui| self.view(ui));
    }

    fn report(&mut self, r: Result<()>) {
        if let Err(e) = r {
            self.error = Some(format!("{e:#}"));
        }
    }

    fn controls(&mut self, ui: &mut egui::Ui) {
        ui.heading("rsl view");
        if let Some(w) = &self.worker {
            let (task, f) = w.progress.lock().map(|p| p.clone()).unwrap_or_default();
            ui.label("preparing");
            ui.add(egui::ProgressBar::new(f).text(task).show_percentage());
        }
        if let Some(e) = &self.error {
            ui.colored_label(Color32::from_rgb(230, 90, 80), e.as_str());
        }
        ui.separator();
        // Quality preset (prepared again on the worker thread).
        let mut preset = self.preset;
        egui::ComboBox::from_label("quality").selected_text(preset.name()).show_ui(ui, |ui| {
            for p in Preset::ALL {
                ui.selectable_value(&mut preset, p, p.name());
            }
        });
        self.set_preset(preset);
        // RSL count: instant (the merge tree holds every count).
        if let Some(engine) = &self.engine {
            let max = engine.texel_count().min(300);
            let mut n = self.rsl_count;
            ui.add(egui::Slider::new(&mut n, 1..=max).text("RSLs"));
            let r = self.set_rsl_count(n);
            self.report(r);
        }
        let mut deg = self.env_degrees;
        ui.add(egui::Slider::new(&mut deg, -180.0..=180.0).text("environment °"));
        self.set_environment_degrees(deg);
        self.environment_thumbnail(ui);
        let mut drawing = self.drawing;
        egui::ComboBox::from_label("drawing")
            .selected_text(label(drawing))
            .show_ui(ui, |ui| {
                for d in drawings() {
                    ui.selectable_value(&mut drawing, d, label(d)).on_hover_text(d.summary());
                }
            })
            .response
            .on_hover_text(
                "How glossy objects are drawn once the view rests (per pixel: sharp highlights, slower); \
                 edits in between are drawn from the vertices",
            );
        self.set_drawing(drawing);
        if let Some(adapter) = self.wgpu_adapter().map(str::to_owned) {
            let mut on = self.shading_on_gpu();
            ui.checkbox(&mut on, "shade on the GPU").on_hover_text(format!(
                "The view is drawn with wgpu on {adapter}. Checked, rsl-gpu shades every vertex of each \
                 changed frame; unchecked, the CPU shades what changed (the default on a software adapter)"
            ));
            if on != self.shading_on_gpu() {
                let r = self.set_shading_on_gpu(on);
                self.report(r);
            }
        }
        let mut truth = self.truth_on;
        ui.checkbox(&mut truth, "progressive truth (error readout)");
        if truth != self.truth_on {
            self.set_truth(truth);
        }
        if self.truth_on {
            let mut show = self.show_truth;
            ui.horizontal(|ui| {
                ui.radio_value(&mut show, false, "show RSL");
                ui.radio_value(&mut show, true, "show truth");
            });
            if show != self.show_truth {
                self.set_show_truth(show);
            }
            match self.readout {
                Some(r) => ui.label(format!(
                    "RSL vs truth: {:.2} % per covered pixel (truth noise {:.2} %, {} spp)",
                    100.0 * r.relative_l2,
                    100.0 * r.truth_noise,
                    r.spp
                )),
                None => ui.label("truth: first pass…"),
            };
        }
        ui.horizontal(|ui| {
            let label = if self.playing { "pause" } else { "play" };
            if ui.button(label).clicked() {
                self.playing = !self.playing;
            }
            let mut t = self.time;
            ui.add(egui::Slider::new(&mut t, 0.0..=10.0).text("time s"));
            self.set_time(t);
        });
        ui.separator();
        ui.horizontal(|ui| {
            let button = ui.button("save scene");
            ui.text_edit_singleline(&mut self.save_path).labelled_by(button.id);
            if button.clicked() {
                let r = self.save(Path::new(&self.save_path));
                self.notice = r.as_ref().ok().map(|_| format!("saved {}", self.save_path));
                self.report(r);
            }
        });
        ui.horizontal(|ui| {
            let button = ui.button("screenshot");
            ui.text_edit_singleline(&mut self.image_path).labelled_by(button.id);
            if button.clicked() {
                let path = PathBuf::from(&self.image_path);
                let r = self.save_image(&path);
                self.notice = r.as_ref().ok().map(|_| format!("wrote {}", self.image_path));
                self.report(r);
            }
        });
        if let Some(n) = &self.notice {
            ui.label(n.as_str());
        }
        ui.separator();
        ui.label("objects");
        for (i, o) in self.scene.objects.iter().enumerate() {
            ui.selectable_value(&mut self.selected, i, o.name.as_str());
        }
        self.object_controls(ui);
    }

    /// The environment (in its own orientation) with the RSLs in use outlined, like Xu et
    /// al.'s figure 6; redrawn when the RSL count changes.
    fn environment_thumbnail(&mut self, ui: &mut egui::Ui) {
        let Some(engine) = &self.engine else { return };
        let (w, h) = (256usize, 128usize);
        let key = (engine.environment_key(), engine.rsl_count());
        if self.thumbnail.as_ref().is_none_or(|t| t.0 != key) {
            let mut rgb = match engine.environment() {
                rsl_engine::engine::EnvRadiance::Map(m) => rsl_engine::env::visualise::thumbnail(m, w, h),
                rsl_engine::engine::EnvRadiance::Constant(c) => {
                    let px = rsl_engine::env::visualise::tonemap(*c, 0.18 / c.max_element().max(1e-6));
                    px.repeat(w * h)
                }
            };
            rsl_engine::env::visualise::outline_squares(&mut rgb, w, h, engine.rsls(), [255, 40, 40]);
            let img = ColorImage::from_rgb([w, h], &rgb);
            let tex = ui.ctx().load_texture("rsl-view-environment", img, TextureOptions::LINEAR);
            self.thumbnail = Some((key, tex));
        }
        if let Some((_, tex)) = &self.thumbnail {
            ui.add(
                egui::Image::new((tex.id(), egui::vec2(w as f32, h as f32))).alt_text("the RSLs over the environment"),
            );
        }
    }

    /// The selected object's index.
    pub fn selected(&self) -> usize {
        self.selected
    }

    /// Selects object `i` (as clicking it in the list or the view does).
    pub fn select(&mut self, i: usize) {
        if i < self.scene.objects.len() {
            self.selected = i;
        }
    }

    fn object_controls(&mut self, ui: &mut egui::Ui) {
        let i = self.selected;
        let Some(o) = self.scene.objects.get(i) else { return };
        ui.separator();
        ui.label(format!("{}: position", o.name));
        let mut p = o.transform.translation;
        ui.horizontal(|ui| {
            ui.add(egui::DragValue::new(&mut p.x).speed(0.01).prefix("x "));
            ui.add(egui::DragValue::new(&mut p.y).speed(0.01).prefix("y "));
            ui.add(egui::DragValue::new(&mut p.z).speed(0.01).prefix("z "));
        });
        let r = self.set_translation(i, p);
        self.report(r);
        let (axis, angle) = self.scene.objects[i].transform.rotation.to_axis_angle();
        let mut yaw = (angle * axis.y.signum()).to_degrees();
        ui.add(egui::Slider::new(&mut yaw, -180.0..=180.0).text("turn °"));
        if (yaw - (angle * axis.y.signum()).to_degrees()).abs() > 1e-4 {
            let r = self.set_yaw(i, yaw);
            self.report(r);
        }
        ui.label("material");
        let mut m = self.scene.objects[i].material.clone();
        material_controls(ui, &mut m);
        let r = self.set_material(i, m);
        self.report(r);
    }

    fn timings(&mut self, ui: &mut egui::Ui) {
        let c = self.counters;
        match self.history.back() {
            Some(f) => ui.label(format!(
                "last reshade {:.1} ms: sync {:.1}, shade {:.1}, {} {:.1}, {} {:.1} · shaded frames {} of {}, objects {}",
                f.total_ms,
                f.sync_ms,
                f.shade_ms,
                if f.on_gpu { "draw (wgpu)" } else { "raster" },
                f.raster_ms,
                if f.on_gpu { "tonemap" } else { "upload" },
                f.upload_ms,
                c.shaded_frames,
                c.frames,
                c.objects_shaded
            )),
            None => ui.label("no frame yet"),
        };
        // A bar per recent reshaded frame: shade (blue) under raster (orange), 50 ms high.
        let (rect, _) = ui.allocate_exact_size(egui::vec2(ui.available_width(), 40.0), egui::Sense::hover());
        let painter = ui.painter_at(rect);
        let w = rect.width() / HISTORY as f32;
        let scale = rect.height() / 50.0;
        for (k, f) in self.history.iter().enumerate() {
            let x = rect.left() + k as f32 * w;
            let shade = (f.shade_ms + f.sync_ms) as f32 * scale;
            let raster = (f.raster_ms + f.upload_ms) as f32 * scale;
            let y0 = rect.bottom();
            painter.rect_filled(
                egui::Rect::from_min_max(egui::pos2(x, y0 - shade), egui::pos2(x + w * 0.8, y0)),
                0.0,
                Color32::from_rgb(90, 140, 230),
            );
            painter.rect_filled(
                egui::Rect::from_min_max(egui::pos2(x, y0 - shade - raster), egui::pos2(x + w * 0.8, y0 - shade)),
                0.0,
                Color32::from_rgb(230, 150, 60),
            );
        }
        let y33 = rect.bottom() - 33.0 * scale;
        painter.hline(rect.x_range(), y33, egui::Stroke::new(1.0, Color32::GRAY));
    }

    fn view(&mut self, ui: &mut egui::Ui) {
        if self.previewing.is_some() {
            ui.ctx().request_repaint_after(PREVIEW_REST);
            let r = self.settle(false).map(|_| ());
            self.report(r);
        }
        if self.pixels_pending.is_some() && self.previewing.is_none() {
            ui.ctx().request_repaint_after(PREVIEW_REST);
            self.settle_pixels(false);
        }
        let r = self.refresh().map(|_| ());
        self.report(r);
        self.poll_truth(ui.ctx());
        let truth_shown = self.show_truth && self.truth_rgba.is_some();
        let shown = if truth_shown { &self.truth_rgba } else { &self.rgba };
        if self.texture_stale
            && let Some(img) = shown
        {
            match &mut self.texture {
                Some(t) if t.size() == img.size => t.set(img.clone(), TextureOptions::LINEAR),
                _ => self.texture = Some(ui.ctx().load_texture("rsl-view", img.clone(), TextureOptions::LINEAR)),
            }
            self.texture_stale = false;
        }
        // The image drawn with wgpu is shown in place; the CPU's images are uploaded.
        let native = self.wgpu.as_ref().filter(|_| self.on_gpu && !truth_shown).and_then(|w| w.texture());
        let Some((id, size)) = native.or_else(|| self.texture.as_ref().map(|t| (t.id(), t.size()))) else {
            ui.centered_and_justified(|ui| ui.label("preparing the scene…"));
            return;
        };
        let avail = ui.available_size();
        let [w, h] = size.map(|s| s as f32);
        let s = (avail.x / w).min(avail.y / h).max(0.05);
        let response = ui.add(egui::Image::new((id, egui::vec2(w * s, h * s))).sense(egui::Sense::click_and_drag()));
        let to_pixel = |p: egui::Pos2| {
            let r = response.rect;
            ((p.x - r.left()) / s, (p.y - r.top()) / s)
        };
        if response.clicked()
            && let Some(p) = response.interact_pointer_pos()
        {
            let (x, y) = to_pixel(p);
            if let Some(i) = self.pick(x, y) {
                self.selected = i;
            }
        }
        self.view_area = Some((response.rect, s));
        if response.drag_started() {
            // Where the button went down (the drag starts once the pointer has moved).
            let origin = ui.input(|i| i.pointer.press_origin()).or(response.interact_pointer_pos());
            self.gizmo_drag = origin.and_then(|p| {
                let (x, y) = to_pixel(p);
                self.gizmo_hit(x, y)
            });
        }
        if response.drag_stopped() {
            self.gizmo_drag = None;
        }
        if let Some(g) = self.gizmo() {
            // The gizmo over the view: move arrows in the axes' usual colours, the turn ring.
            let painter = ui.painter_at(response.rect);
            let at = |(x, y): (f32, f32)| response.rect.min + egui::vec2(x * s, y * s);
            let ring: Vec<egui::Pos2> = g.ring.iter().map(|&p| at(p)).collect();
            let held = |part: GizmoPart| self.gizmo_drag == Some(part);
            let width = |part: GizmoPart| if held(part) { 3.5 } else { 2.0 };
            painter.add(egui::Shape::closed_line(
                ring,
                egui::Stroke::new(width(GizmoPart::Ring), Color32::from_rgb(230, 200, 60)),
            ));
            let colours =
                [Color32::from_rgb(230, 70, 70), Color32::from_rgb(80, 200, 80), Color32::from_rgb(80, 130, 240)];
            for (k, tip) in g.tips.iter().enumerate() {
                let (from, to) = (at(g.centre), at(*tip));
                painter.arrow(from, to - from, egui::Stroke::new(width(GizmoPart::Axis(k)), colours[k]));
            }
        }
        if response.dragged() {
            let d = response.drag_delta();
            if let (Some(part), Some(p)) = (self.gizmo_drag, response.interact_pointer_pos()) {
                let (x, y) = to_pixel(p);
                self.drag_gizmo(part, (x - d.x / s, y - d.y / s), (x, y));
            } else if ui.input(|i| i.modifiers.shift) {
                // Shift-drag moves the selected object on the ground plane, along the
                // camera's right and forward directions, by the distance the pointer covers
                // at the object's depth.
                self.drag_selected(d.x / s, d.y / s);
            } else {
                self.orbit_by(d.x * 0.01, d.y * 0.01, 1.0);
            }
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.orbit_by(0.0, 0.0, (-scroll * 0.002).exp());
            }
        }
    }
}

impl Viewer {
    /// The object seen through pixel `(x, y)` of the camera's image (fractional pixels),
    /// by the triangles last drawn; `None` where the view shows the environment.
    pub fn pick(&self, x: f32, y: f32) -> Option<usize> {
        let c = &self.scene.camera;
        if !(x >= 0.0 && y >= 0.0 && x < c.width as f32 && y < c.height as f32) {
            return None;
        }
        let d = rsl_shade::raster::pixel_ray(c, x as u32, y as u32);
        let mut best: Option<(f32, usize)> = None;
        for (i, o) in self.scene.objects.iter().enumerate() {
            let p = &self.positions[i];
            if p.len() != o.mesh.vertex_count() {
                continue;
            }
            for t in o.mesh.indices.chunks_exact(3) {
                let [a, b, cc] = [0, 1, 2].map(|k| p[t[k] as usize]);
                if let Some(dist) = ray_triangle(c.eye, d, a, b, cc)
                    && best.is_none_or(|(bd, _)| dist < bd)
                {
                    best = Some((dist, i));
                }
            }
        }
        best.map(|b| b.1)
    }

    /// The selected object's gizmo in image pixels (`None` while its place is behind the
    /// eye): arrows of a fixed screen length from its place along the world axes, and a ring
    /// about +Y of the same radius.
    pub fn gizmo(&self) -> Option<Gizmo> {
        let i = self.selected;
        self.scene.objects.get(i)?;
        let c = &self.scene.camera;
        let centre = self.scene.at(self.time).objects.get(i)?.translation;
        let forward = (c.target - c.eye).normalize_or_zero();
        let depth = (centre - c.eye).dot(forward);
        if depth <= c.near() {
            return None;
        }
        let length = GIZMO_PIXELS * world_per_pixel(c, depth);
        let project = |p: Vec3| rsl_shade::raster::image_point(c, p).map(|[x, y]| (x, y));
        let tips = [Vec3::X, Vec3::Y, Vec3::Z].map(|a| project(centre + a * length));
        let ring = (0..48)
            .map(|k| {
                let a = std::f32::consts::TAU * k as f32 / 48.0;
                project(centre + Vec3::new(a.cos(), 0.0, a.sin()) * length)
            })
            .collect::<Option<Vec<_>>>()?;
        Some(Gizmo { centre: project(centre)?, tips: [tips[0]?, tips[1]?, tips[2]?], ring, length })
    }

    /// The screen point of image point `(x, y)` (pixels) where the view was last laid out.
    pub fn screen_point(&self, x: f32, y: f32) -> Option<egui::Pos2> {
        self.view_area.map(|(r, s)| r.min + egui::vec2(x * s, y * s))
    }

    /// The gizmo handle within reach of image point `(x, y)`: an arrow, else the ring;
    /// nothing within twice the reach of the centre, which stays free for picking.
    pub fn gizmo_hit(&self, x: f32, y: f32) -> Option<GizmoPart> {
        let g = self.gizmo()?;
        if (x - g.centre.0).hypot(y - g.centre.1) < 2.0 * GIZMO_REACH {
            return None;
        }
        let near = |a: (f32, f32), b: (f32, f32)| segment_distance((x, y), a, b) <= GIZMO_REACH;
        if let Some(k) = (0..3).find(|&k| near(g.centre, g.tips[k])) {
            return Some(GizmoPart::Axis(k));
        }
        let n = g.ring.len();
        (0..n).any(|k| near(g.ring[k], g.ring[(k + 1) % n])).then_some(GizmoPart::Ring)
    }

    /// Drags gizmo handle `part` of the selected object from image point `from` to `to`: an
    /// arrow moves the object along its axis by the pointer's travel along the arrow on
    /// screen; the ring turns it about +Y by the angle the pointer sweeps about its place on
    /// the ring's plane.
    pub fn drag_gizmo(&mut self, part: GizmoPart, from: (f32, f32), to: (f32, f32)) {
        let i = self.selected;
        let Some(g) = self.gizmo() else { return };
        let Some(o) = self.scene.objects.get(i) else { return };
        let mut t = o.transform;
        match part {
            GizmoPart::Axis(k) => {
                let a = (g.tips[k].0 - g.centre.0, g.tips[k].1 - g.centre.1);
                let len2 = a.0 * a.0 + a.1 * a.1;
                if len2 < 1.0 {
                    return; // the axis points at the eye: no travel along it on screen
                }
                let along = ((to.0 - from.0) * a.0 + (to.1 - from.1) * a.1) / len2;
                t.translation += [Vec3::X, Vec3::Y, Vec3::Z][k] * (along * g.length);
            }
            GizmoPart::Ring => {
                // Where the pointer meets the ring's plane (horizontal, through the object's
                // place): the turn is the angle it sweeps there about +Y.
                let c = &self.scene.camera;
                let centre = self.scene.at(self.time).objects[i].translation;
                let on_plane = |(x, y): (f32, f32)| {
                    let d = rsl_shade::raster::image_ray(c, x, y);
                    let t = (centre.y - c.eye.y) / d.y;
                    (d.y.abs() > 1e-6 && t > 0.0).then(|| c.eye + d * t - centre)
                };
                let (Some(a), Some(b)) = (on_plane(from), on_plane(to)) else { return };
                // A turn by θ about +Y takes atan2(z, x) to atan2(z, x) − θ.
                let sweep = b.z.atan2(b.x) - a.z.atan2(a.x);
                let sweep = (sweep + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU) - std::f32::consts::PI;
                t.rotation = (yaw_rotation(-sweep.to_degrees()) * t.rotation).normalize();
            }
        }
        if t.translation.is_finite() && t.rotation.is_finite() {
            self.move_object(i, t);
        }
    }

    /// Moves the selected object by a pointer drag of `(dx, dy)` image pixels on the ground
    /// plane through it (shift-drag in the view): right with the camera's right, away with
    /// the camera's forward, scaled so that the object follows the pointer sideways.
    pub fn drag_selected(&mut self, dx: f32, dy: f32) {
        let i = self.selected;
        let Some(o) = self.scene.objects.get(i) else { return };
        let c = &self.scene.camera;
        let forward = (c.target - c.eye).normalize_or_zero();
        let right = forward.cross(c.up).normalize_or_zero();
        let ahead = Vec3::new(forward.x, 0.0, forward.z).normalize_or_zero();
        let p = o.transform.translation;
        let depth = (p - c.eye).dot(forward).max(1e-3);
        let moved = p + (right * dx - ahead * dy) * world_per_pixel(c, depth);
        let r = self.set_translation(i, moved);
        self.report(r);
    }
}

/// World units per image pixel of `c` at `depth` along its view direction.
fn world_per_pixel(c: &rsl_engine::scene::Camera, depth: f32) -> f32 {
    2.0 * depth * (0.5 * c.fov_y).tan() / c.height as f32
}

/// Distance from point `p` to the segment `ab`, in the plane.
fn segment_distance(p: (f32, f32), a: (f32, f32), b: (f32, f32)) -> f32 {
    let (ab, ap) = ((b.0 - a.0, b.1 - a.1), (p.0 - a.0, p.1 - a.1));
    let len2 = ab.0 * ab.0 + ab.1 * ab.1;
    let t = if len2 > 0.0 { ((ap.0 * ab.0 + ap.1 * ab.1) / len2).clamp(0.0, 1.0) } else { 0.0 };
    let (dx, dy) = (ap.0 - ab.0 * t, ap.1 - ab.1 * t);
    (dx * dx + dy * dy).sqrt()
}

/// Distance along the ray `o + t·d` to the triangle `abc` (Möller–Trumbore), if it is hit
/// in front of `o`.
fn ray_triangle(o: Vec3, d: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Option<f32> {
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > 0.0).then_some(t)
}

/// Sliders for a material's parameters (the model stays; its numbers change).
fn material_controls(ui: &mut egui::Ui, m: &mut Material) {
    fn rgb(ui: &mut egui::Ui, label: &str, c: &mut [f32; 3]) {
        ui.horizontal(|ui| {
            ui.label(label);
            ui.color_edit_button_rgb(c);
        });
    }
    match m {
        Material::Lambert { albedo } => rgb(ui, "albedo", albedo),
        Material::Phong { exponent, specular, diffuse } | Material::BlinnPhong { exponent, specular, diffuse } => {
            ui.add(egui::Slider::new(exponent, 1.0..=2000.0).logarithmic(true).text("exponent"));
            rgb(ui, "specular", specular);
            rgb(ui, "diffuse", diffuse);
        }
        Material::CookTorrance { alpha, specular, diffuse }
        | Material::Ggx { alpha, specular, diffuse }
        | Material::Beckmann { alpha, specular, diffuse } => {
            ui.add(egui::Slider::new(alpha, 0.02..=1.0).logarithmic(true).text("alpha"));
            rgb(ui, "specular", specular);
            rgb(ui, "diffuse", diffuse);
        }
        _ => {
            ui.label("(this model's parameters are edited in the scene file)");
        }
    }
}

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
        // A drawing with lobes prefilters on a worker: the next frame draws with them.
        harness.state_mut().wait_lobes();
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

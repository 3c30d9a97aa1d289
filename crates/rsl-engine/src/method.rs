//! One renderer interface: every way of computing a frame — the CPU RSL path, the GPU RSL
//! path, the Monte Carlo truth — takes the prepared scene and a frame request and returns
//! one [`Frame`] type.

use crate::engine::{Engine, ShadedFrame};
use crate::gpu::GpuRenderer;
use crate::progress::{Progress, Timings};
use anyhow::{Context, Result, bail};
use glam::Vec3;
use rsl_scene::{Scene, SceneState};
use rsl_shade::{Covers, FrameStats, Image, OracleParams, Oracles, RasterMesh, Terms, tonemap};
use rsl_truth::{EnvLight, Estimate, TruthObject, TruthScene};
use std::time::Instant;

/// What a frame should hold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Request {
    /// Scene time, seconds.
    pub time: f32,
    /// Draw an image through the scene's camera.
    pub image: bool,
    /// Per-vertex radiance (the RSL paths always have it; the truth estimates it only when
    /// asked, as it costs as much again).
    pub vertices: bool,
    /// Exposure for methods that tonemap on the device (`None`: automatic, from the image).
    pub exposure: Option<f32>,
}

impl Request {
    /// An image and the vertices at time `t`, automatic exposure.
    pub fn at(t: f32) -> Self {
        Self { time: t, image: true, vertices: true, exposure: None }
    }
}

/// The image tonemapped on the device, with the exposure used.
#[derive(Clone, Debug, PartialEq)]
pub struct Encoded {
    /// Interleaved 8-bit sRGB.
    pub rgb: Vec<u8>,
    /// The exposure it was made at.
    pub exposure: f32,
}

/// The error a Monte Carlo frame carries, as relative L2 (‖standard error‖₂ / ‖mean‖₂).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SelfError {
    /// Over the vertices, when they were estimated.
    pub vertices: Option<f64>,
    /// Over the pixels objects cover, when an image was made.
    pub pixels: Option<f64>,
}

/// One frame of any method.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Transforms and environment rotation.
    pub state: SceneState,
    /// Per object, per vertex: world position (empty when vertices were not asked for and
    /// the method did not make them).
    pub positions: Vec<Vec<Vec3>>,
    /// Per object, per vertex: world normal.
    pub normals: Vec<Vec<Vec3>>,
    /// Per object, per vertex: radiance toward the eye.
    pub radiance: Vec<Vec<Vec3>>,
    /// Per object, per vertex: the standard error of `radiance` (Monte Carlo methods).
    pub std_error: Option<Vec<Vec<Vec3>>>,
    /// The linear image with coverage, when asked for.
    pub image: Option<Image>,
    /// Per pixel of `image`: the standard error of its value (Monte Carlo methods).
    pub pixel_std_error: Option<Vec<Vec3>>,
    /// The image tonemapped on the device, where the method does that.
    pub encoded: Option<Encoded>,
    /// The method's own error, where it can estimate it (`None` inside: could not, such as
    /// with one sample).
    pub self_error: Option<SelfError>,
    /// Lookup counts (RSL paths; the truth fills in `vertices` only).
    pub stats: FrameStats,
    /// Shadow rays traced (Monte Carlo methods).
    pub shadow_rays: u64,
    /// What each stage cost.
    pub timings: Timings,
    /// Per object, every light's cover at its vertices where the drawing found them all
    /// (the RSL sum per pixel on the CPU, [`rsl_shade::shade_covers`], within `auto` or as
    /// method `pixel`, and the `rsl` method on the CPU; the last two only where the scene
    /// asks for bounces): `None` for the other objects, and empty for the other drawings.
    /// The interreflections read them instead of finding them again, and take them
    /// ([`crate::bounce::Bounced`]).
    pub covers: Vec<Option<rsl_shade::Covers>>,
}

impl Frame {
    /// A frame of an RSL path: its shaded vertices, and the image where one was made.
    fn rsl(f: ShadedFrame, image: Option<Image>, encoded: Option<Encoded>, timings: Timings) -> Self {
        Frame {
            state: f.state,
            positions: f.positions,
            normals: f.normals,
            radiance: f.radiance,
            std_error: None,
            image,
            pixel_std_error: None,
            encoded,
            self_error: None,
            stats: f.stats,
            shadow_rays: 0,
            timings,
            covers: Vec::new(),
        }
    }

    /// A frame of per-vertex radiance: each object's vertices and normals in world space at
    /// `state` (from `engine`'s meshes), `radiance` per object and vertex, and the CPU
    /// rasteriser's image of them when `image` is asked for (its time added to `timings` as
    /// "draw"). For methods that shade vertices by their own means.
    pub fn of_vertices(
        engine: &Engine,
        scene: &Scene,
        state: SceneState,
        radiance: Vec<Vec<Vec3>>,
        image: bool,
        mut timings: Timings,
    ) -> Result<Self> {
        engine.check(scene)?;
        anyhow::ensure!(
            radiance.len() == scene.objects.len(),
            "radiance for {} of {} objects",
            radiance.len(),
            scene.objects.len()
        );
        let mut positions = Vec::with_capacity(radiance.len());
        let mut normals = Vec::with_capacity(radiance.len());
        for (i, r) in radiance.iter().enumerate() {
            let pose = rsl_shade::Pose::new(&state.objects[i]);
            let mesh = engine.mesh(i);
            anyhow::ensure!(
                r.len() == mesh.vertex_count(),
                "radiance for {} of {} vertices",
                r.len(),
                mesh.vertex_count()
            );
            positions.push(mesh.positions.iter().map(|p| pose.position(*p)).collect::<Vec<_>>());
            normals.push(mesh.normals.iter().map(|n| pose.normal(*n)).collect::<Vec<_>>());
        }
        let image = image.then(|| timings.time("draw", || rasterise(engine, scene, &state, &positions, &radiance)));
        Ok(Frame {
            state,
            positions,
            normals,
            radiance,
            std_error: None,
            image,
            pixel_std_error: None,
            encoded: None,
            self_error: None,
            stats: FrameStats::default(),
            shadow_rays: 0,
            timings,
            covers: Vec::new(),
        })
    }

    /// Whether the frame holds per-vertex radiance.
    pub fn has_vertices(&self) -> bool {
        !self.radiance.is_empty()
    }
}

/// A way of computing frames from a prepared scene.
pub trait Method {
    /// What it is, in words (for logs and reports).
    fn describe(&self) -> String;

    /// Bytes the method holds beyond the engine's prepared data (the wavelet baseline's
    /// transport); 0 by default.
    fn bytes(&self) -> usize {
        0
    }

    /// How many items the method has built itself so far, rather than read from the disk
    /// cache or found held (the lobe path's transport lobes fitted, the wavelet baseline's
    /// transport): beside the engine's [`crate::cache::CacheStats::misses`], what a
    /// configuration built. 0 by default.
    fn built(&self) -> u64 {
        0
    }

    /// The frame of `scene` (which `engine` was last synced to) for `request`.
    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame>;

    /// What the method must still prepare for `scene` (which `engine` was last synced to)
    /// beyond the engine's own data (the lobe methods' prefiltered environment and transport
    /// lobes), as a job a front end may run on a worker thread and give back with
    /// [`Method::install`]; `None` when nothing is missing. Without it, [`Method::render`]
    /// prepares what it needs itself.
    fn preparation(&mut self, engine: &Engine, scene: &Scene) -> Result<Option<Preparation>> {
        let _ = (engine, scene);
        Ok(None)
    }

    /// Takes what a [`Preparation`] made (anything not of this method is ignored).
    fn install(&mut self, prepared: Prepared) {
        let _ = prepared;
    }

    /// The frame for `request` when, since the frame this method last drew in a
    /// [`crate::Session`], only the objects `changes` marks may look different; `kept` is
    /// what the method left there for itself then (`None` the first time, or after the front
    /// end drew by other means). A method that can reuse per-object results (the vertices'
    /// radiance, the covers) keeps them in `kept` and redraws only what changed; by default
    /// the whole frame is rendered.
    fn render_changed(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        request: &Request,
        changes: &Changes,
        kept: &mut Kept,
    ) -> Result<Frame> {
        let _ = (changes, kept);
        self.render(engine, scene, request)
    }

    /// How each object of `scene` is drawn, and why: one line per object (`rsl render
    /// --explain`).
    fn explain(&mut self, engine: &Engine, scene: &Scene) -> Result<Vec<String>> {
        engine.check(scene)?;
        let what = self.describe();
        Ok(scene.objects.iter().map(|o| format!("{}: {what}", o.name)).collect())
    }

    /// Whether it evaluates the objects' base-colour textures itself (the truth, at each
    /// sample); the others draw their materials' factors, and [`crate::textured`] mixes two
    /// of their frames into the textured one.
    fn draws_textures(&self) -> bool {
        false
    }
}

/// What changed since a method's last frame in a [`crate::Session`]
/// ([`Method::render_changed`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Changes {
    /// Per object: whether its radiance may differ (its material, its pose, or a shadow
    /// cast on it moved; everything, when the eye, the environment or the lights changed).
    pub objects: Vec<bool>,
    /// Whether anything moved (objects, the camera, the environment): if not, only the
    /// changed objects' pixels can differ.
    pub moved: bool,
}

impl Changes {
    /// Every one of `n` objects changed, and the view moved.
    pub fn all(n: usize) -> Self {
        Self { objects: vec![true; n], moved: true }
    }

    /// Whether every object changed.
    pub fn is_all(&self) -> bool {
        self.objects.iter().all(|&c| c)
    }

    /// Whether anything changed.
    pub fn any(&self) -> bool {
        self.moved || self.objects.iter().any(|&c| c)
    }

    /// How many objects changed.
    pub fn count(&self) -> usize {
        self.objects.iter().filter(|&&c| c).count()
    }
}

/// What a method keeps between its frames in a [`crate::Session`] ([`Method::render_changed`]).
pub type Kept = Option<Box<dyn std::any::Any + Send>>;

/// What a [`Preparation`] made, for [`Method::install`].
pub type Prepared = Box<dyn std::any::Any + Send>;

/// Work a method needs done before it draws without a long pause
/// ([`Method::preparation`]); runs on any thread.
pub struct Preparation(Box<dyn FnOnce() -> Prepared + Send>);

impl Preparation {
    /// The job `f`.
    pub fn new(f: impl FnOnce() -> Prepared + Send + 'static) -> Self {
        Self(Box::new(f))
    }

    /// Does the work.
    pub fn run(self) -> Prepared {
        (self.0)()
    }
}

impl std::fmt::Debug for Preparation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Preparation")
    }
}

/// The automatic exposure of an image: keyed on the pixels objects cover (the background
/// alone when none do).
pub fn exposure_for(image: &Image) -> f32 {
    let objects: Vec<_> = image.pixels.iter().zip(&image.covered).filter(|p| *p.1).map(|p| *p.0).collect();
    tonemap::auto_exposure(if objects.is_empty() { &image.pixels } else { &objects })
}

/// Rasterises per-vertex radiance with the environment behind it (the CPU rasteriser),
/// antialiased as the engine's quality asks.
pub fn rasterise(
    engine: &Engine,
    scene: &Scene,
    state: &SceneState,
    positions: &[Vec<Vec3>],
    radiance: &[Vec<Vec3>],
) -> Image {
    rasterise_over(engine, scene, positions, radiance, |d| engine.background(state, d))
}

/// [`rasterise`] over `background` (radiance toward each world direction) instead of the
/// environment.
pub fn rasterise_over(
    engine: &Engine,
    scene: &Scene,
    positions: &[Vec<Vec3>],
    radiance: &[Vec<Vec3>],
    background: impl Fn(Vec3) -> Vec3 + Sync,
) -> Image {
    let meshes: Vec<RasterMesh<'_>> = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| RasterMesh { positions: &positions[i], indices: &o.mesh.indices, radiance: &radiance[i] })
        .collect();
    rsl_shade::rasterise_antialiased(&scene.camera, &meshes, engine.antialias(), background)
}

/// The CPU RSL path: the rayon fast path of the multiple product approximation and the CPU
/// rasteriser.
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuRsl;

impl Method for CpuRsl {
    fn describe(&self) -> String {
        format!("RSL on the CPU ({} threads)", rayon::current_num_threads())
    }

    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        let (f, covers) = Self::shade_all(engine, scene, request.time)?;
        Ok(Self::drawn(engine, scene, request, f, covers))
    }

    /// Shades only the changed objects' vertices; the others keep theirs.
    fn render_changed(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        request: &Request,
        changes: &Changes,
        kept: &mut Kept,
    ) -> Result<Frame> {
        let (f, covers) = Self::shade_changed(engine, scene, request.time, changes, kept)?;
        Ok(Self::drawn(engine, scene, request, f, covers))
    }
}

/// What [`CpuRsl`] and [`CpuRslPixels`] keep between frames: the last frame's vertices, and
/// per object drawn per pixel (or, where the scene asks for interreflections, shaded by
/// [`CpuRsl`]) every light's cover at its vertices.
struct VertexKept {
    positions: Vec<Vec<Vec3>>,
    normals: Vec<Vec<Vec3>>,
    radiance: Vec<Vec<Vec3>>,
    covers: Vec<Option<Covers>>,
}

impl VertexKept {
    /// The kept vertices of `n` objects when `kept` holds them and `changes` leaves some to
    /// reuse; `None`: shade everything.
    fn reusable(kept: &mut Kept, changes: &Changes, n: usize) -> Option<Box<VertexKept>> {
        let k = kept.take()?.downcast::<VertexKept>().ok()?;
        (k.radiance.len() == n && changes.objects.len() == n && !changes.is_all()).then_some(k)
    }

    /// Takes object `i` of `f` (shaded this frame) in place of the kept one.
    fn replace(&mut self, f: &mut ShadedFrame, i: usize) {
        self.positions[i] = std::mem::take(&mut f.positions[i]);
        self.normals[i] = std::mem::take(&mut f.normals[i]);
        self.radiance[i] = std::mem::take(&mut f.radiance[i]);
    }

    /// The kept covers for the interreflections of `scene` (copied: they stay kept), or none
    /// where it asks for no bounces.
    fn covers_for(&self, scene: &Scene) -> Vec<Option<Covers>> {
        if crate::bounce::Bounced::asked(scene) { self.covers.clone() } else { Vec::new() }
    }

    /// The frame made of the kept vertices (copied: they stay kept).
    fn frame(&self, state: SceneState, stats: FrameStats, shade_ms: f64) -> ShadedFrame {
        ShadedFrame {
            state,
            positions: self.positions.clone(),
            normals: self.normals.clone(),
            radiance: self.radiance.clone(),
            stats,
            shade_ms,
        }
    }
}

impl CpuRsl {
    /// The frame of shaded vertices `f`, rasterised when `request` asks for an image, with
    /// the covers found at the vertices (empty: none).
    fn drawn(engine: &Engine, scene: &Scene, request: &Request, f: ShadedFrame, covers: Vec<Option<Covers>>) -> Frame {
        let mut timings = Timings::default();
        timings.add("shade", f.shade_ms, None);
        let image = request
            .image
            .then(|| timings.time("draw", || rasterise(engine, scene, &f.state, &f.positions, &f.radiance)));
        Frame { covers, ..Frame::rsl(f, image, None, timings) }
    }

    /// Every vertex of the frame at `time`, and where the scene asks for interreflections
    /// every light's cover at them: [`crate::bounce::Bounced`] reads those rather than
    /// find them again ([`Engine::shade_keeping_covers`]). Without bounces, no covers.
    fn shade_all(engine: &Engine, scene: &Scene, time: f32) -> Result<(ShadedFrame, Vec<Option<Covers>>)> {
        if !crate::bounce::Bounced::asked(scene) {
            return Ok((engine.shade(scene, time)?, Vec::new()));
        }
        let (f, covers) = engine.shade_keeping_covers(scene, time)?;
        Ok((f, covers.unwrap_or_default()))
    }

    /// The vertices of the frame at `time`: the objects `changes` marks shaded again, the
    /// others as kept; where the scene asks for interreflections, with every light's cover at
    /// them ([`CpuRsl::shade_all`]), those of the objects shaded again found with them and the
    /// others' kept (`None` for an object shaded while none were asked: the
    /// interreflections find those).
    fn shade_changed(
        engine: &Engine,
        scene: &Scene,
        time: f32,
        changes: &Changes,
        kept: &mut Kept,
    ) -> Result<(ShadedFrame, Vec<Option<Covers>>)> {
        let n = scene.objects.len();
        let Some(mut k) = VertexKept::reusable(kept, changes, n) else {
            let (f, covers) = Self::shade_all(engine, scene, time)?;
            let k = VertexKept {
                positions: f.positions.clone(),
                normals: f.normals.clone(),
                radiance: f.radiance.clone(),
                covers: if covers.len() == n { covers.clone() } else { vec![None; n] },
            };
            *kept = Some(Box::new(k));
            return Ok((f, covers));
        };
        let (mut f, covers) = if crate::bounce::Bounced::asked(scene) {
            engine.shade_objects_keeping_covers(scene, time, &changes.objects)?
        } else {
            (engine.shade_objects(scene, time, &changes.objects)?, None)
        };
        let mut covers = covers.unwrap_or_else(|| vec![None; n]);
        for i in (0..n).filter(|&i| changes.objects[i]) {
            k.replace(&mut f, i);
            k.covers[i] = covers[i].take();
        }
        let frame = k.frame(f.state, f.stats, f.shade_ms);
        let covers = k.covers_for(scene);
        *kept = Some(k);
        Ok((frame, covers))
    }
}

/// The CPU RSL path per pixel ([`rsl_shade::pixel`]): each glossy object's pixels get the RSL
/// sum for their own normal and view, from covers computed at its vertices and interpolated;
/// Lambertian objects, whose radiance varies no faster than their covers, are shaded at their
/// vertices and interpolated as by [`CpuRsl`]. The per-vertex radiance is the same as
/// [`CpuRsl`]'s.
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuRslPixels;

impl Method for CpuRslPixels {
    fn describe(&self) -> String {
        format!("RSL per pixel on the CPU ({} threads)", rayon::current_num_threads())
    }

    /// The whole frame: [`Method::render_changed`] with every object changed and nothing
    /// kept.
    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        let all = Changes::all(scene.objects.len());
        self.render_changed(engine, scene, request, &all, &mut None)
    }

    /// Shades only the changed objects at their vertices (those drawn per pixel keeping
    /// every light's cover), the others keep theirs; the image is drawn whole.
    fn render_changed(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        request: &Request,
        changes: &Changes,
        kept: &mut Kept,
    ) -> Result<Frame> {
        let n = scene.objects.len();
        let start = Instant::now();
        let state = scene.at(request.time);
        let setup = engine.setup(scene, &state, scene.camera.eye, Terms::default())?;
        let (mut k, changed) = match VertexKept::reusable(kept, changes, n) {
            Some(k) => (k, changes.objects.clone()),
            None => {
                let empty = vec![Vec::new(); n];
                let k = VertexKept {
                    positions: empty.clone(),
                    normals: empty.clone(),
                    radiance: empty,
                    covers: vec![None; n],
                };
                (Box::new(k), vec![true; n])
            }
        };
        let (radiance, covers, stats) = crate::compose::shade_for_pixels(engine, &setup, &changed)?;
        for (i, c) in covers.into_iter().enumerate() {
            if changed[i] {
                k.covers[i] = c;
            }
        }
        let mut f = ShadedFrame::of(&setup, state.clone(), radiance, stats, 0.0);
        for i in (0..n).filter(|&i| changed[i]) {
            k.replace(&mut f, i);
        }
        let mut timings = Timings::default();
        timings.add("shade", start.elapsed().as_secs_f64() * 1e3, None);
        let image = request.image.then(|| {
            timings.time("draw per pixel", || {
                let background = |d| engine.background(&state, d);
                rsl_shade::shade_image(&setup, &scene.camera, &k.covers, &k.radiance, engine.antialias(), background).0
            })
        });
        let f = k.frame(f.state, f.stats, 0.0);
        // The interreflections read the covers (those of the objects that did not change
        // are still theirs) instead of finding them again; the kept ones stay for the next
        // frame.
        let covers = k.covers_for(scene);
        *kept = Some(k);
        Ok(Frame { covers, ..Frame::rsl(f, image, None, timings) })
    }
}

/// The GPU RSL path: the wgpu compute pass and draw pass, drawing the vertices' radiance
/// interpolated (method `rsl`) or the RSL sum per pixel (method `pixel`: the shading pass
/// keeps every light's cover at the vertices, and the draw pass evaluates each pixel as
/// [`CpuRslPixels`] does, `shaders/draw/pixels.wgsl`, traced lights through the objects'
/// BVHs), antialiased as the quality asks (`rsl_gpu::draw`'s antialias module, the CPU's
/// samples).
pub struct GpuRsl {
    /// The renderer (uploads follow the engine's content keys).
    pub renderer: GpuRenderer,
    /// Whether the image is drawn per pixel.
    pub per_pixel: bool,
}

impl GpuRsl {
    /// The vertices interpolated (`rsl`) on `renderer`.
    pub fn vertices(renderer: GpuRenderer) -> Self {
        Self { renderer, per_pixel: false }
    }

    /// The RSL sum per pixel (`pixel`) on `renderer`.
    pub fn per_pixel(renderer: GpuRenderer) -> Self {
        Self { renderer, per_pixel: true }
    }
}

impl Method for GpuRsl {
    fn describe(&self) -> String {
        let drawing = if self.per_pixel { "RSL per pixel" } else { "RSL" };
        format!("{drawing} on the GPU ({})", self.renderer.describe())
    }

    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        let mut timings = Timings::default();
        let (image, encoded) = if request.image {
            let g =
                self.renderer.render(engine, scene, request.time, self.per_pixel, (request.exposure, exposure_for))?;
            let t = g.timings;
            timings.add("shade", t.shade.wall_ms, t.shade.gpu_ms);
            timings.add(if self.per_pixel { "draw per pixel" } else { "draw" }, t.draw.wall_ms, t.draw.gpu_ms);
            if let Some(ms) = t.draw.antialias_ms {
                timings.add("antialias", ms, t.draw.antialias_gpu_ms);
            }
            timings.add("image readback", t.readback_ms, None);
            timings.add("tonemap", t.tonemap.wall_ms, t.tonemap.gpu_ms);
            (Some(g.image), Some(Encoded { rgb: g.rgb, exposure: g.exposure }))
        } else {
            let terms = rsl_shade::Terms::default();
            let p = if self.per_pixel {
                self.renderer.dispatch_covers(engine, scene, request.time, terms)?
            } else {
                self.renderer.dispatch(engine, scene, request.time, terms)?
            };
            timings.add("shade", p.wall_ms, p.gpu_ms);
            (None, None)
        };
        let f = if request.vertices || !request.image {
            // The frame just shaded, read back (not shaded again).
            let start = Instant::now();
            let f = self.renderer.read_frame(engine, scene, request.time)?;
            timings.add("vertex readback", start.elapsed().as_secs_f64() * 1e3, None);
            f
        } else {
            ShadedFrame {
                state: scene.at(request.time),
                positions: Vec::new(),
                normals: Vec::new(),
                radiance: Vec::new(),
                stats: FrameStats::default(),
                shade_ms: 0.0,
            }
        };
        Ok(Frame::rsl(f, image, encoded, timings))
    }
}

/// The Monte Carlo ground truth (rsl-truth): multiple importance sampling of the environment
/// and the BRDF with shadow rays, on the same vertices, frames and views as the RSL path, and
/// per pixel through the camera. Needs only the engine's method-neutral layer.
pub struct Truth {
    /// Samples per vertex and per pixel.
    pub spp: u32,
    /// Seed (the result is deterministic for a seed).
    pub seed: u64,
    /// Where the estimation reports its progress.
    pub progress: Progress,
    /// Where a pixel's samples lie: over its square (the default, rsl's definition of a
    /// pixel), or at its centre (to measure an image drawn one point per pixel apart from its
    /// aliasing).
    pub filter: rsl_truth::PixelFilter,
    env: EnvLight,
    env_key: u64,
}

impl Truth {
    /// The truth of `engine`'s environment at `spp` samples (at least 1).
    pub fn new(engine: &Engine, spp: u32, seed: u64) -> Result<Self> {
        if spp == 0 {
            bail!("--spp must be at least 1");
        }
        Ok(Self {
            spp,
            seed,
            progress: Progress::none(),
            filter: rsl_truth::PixelFilter::Box,
            env: env_light(engine),
            env_key: engine.environment_key(),
        })
    }

    /// The truth scene (one BVH over every triangle) of `scene` at `state`, following the
    /// light through the scene's `bounces` (a quality knob).
    pub fn scene(engine: &Engine, scene: &Scene, state: &SceneState, env: EnvLight) -> Result<TruthScene> {
        engine.check(scene)?;
        let objects: Vec<TruthObject<'_>> = (0..engine.object_count())
            .map(|i| TruthObject {
                mesh: engine.mesh(i),
                frames: engine.frames(i),
                brdf: *engine.brdf(i),
                transform: state.objects[i],
                casts_shadows: scene.objects[i].casts_shadows,
                texture: scene.objects[i].texture.as_ref(),
                metallic_roughness: scene.objects[i].metallic_roughness.as_ref(),
            })
            .collect();
        Ok(TruthScene::new(&objects, env, state.world_from_env)?.with_bounces(scene.quality.settings.bounces))
    }
}

/// The environment of `engine` as a light to sample (shares the engine's map).
pub fn env_light(engine: &Engine) -> EnvLight {
    match engine.environment() {
        crate::engine::EnvRadiance::Map(m) => EnvLight::map(m.clone(), engine.intensity()),
        crate::engine::EnvRadiance::Constant(c) => EnvLight::Constant(*c * engine.intensity()),
    }
}

/// `‖standard error‖₂ / ‖mean‖₂` over the estimates: the relative L2 error they carry.
pub fn relative_std_error<'a>(est: impl Iterator<Item = &'a Estimate>) -> f64 {
    let (mut se, mut m) = (0.0f64, 0.0f64);
    for e in est {
        se += f64::from(e.std_error.length_squared());
        m += f64::from(e.mean.length_squared());
    }
    if m > 0.0 { (se / m).sqrt() } else { 0.0 }
}

impl Method for Truth {
    fn describe(&self) -> String {
        format!("Monte Carlo truth ({} spp, seed {})", self.spp, self.seed)
    }

    fn draws_textures(&self) -> bool {
        true
    }

    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        if engine.environment_key() != self.env_key {
            self.env = env_light(engine);
            self.env_key = engine.environment_key();
        }
        if scene.objects.is_empty() {
            bail!("{}: the scene has no objects; there is nothing to estimate", scene.path.display());
        }
        let state = scene.at(request.time);
        let mut timings = Timings::default();
        let ts = timings
            .time("scene", || Self::scene(engine, scene, &state, self.env.clone()))?
            .with_pixel_filter(self.filter);
        let estimable = self.spp >= 2;
        let mut self_error = SelfError::default();
        let mut stats = FrameStats::default();
        let mut shadow_rays = 0;
        let mut pixel_std_error = None;
        let image = if request.image {
            let task = format!("truth, {} spp, pixels", self.spp);
            let start = Instant::now();
            let (px, covered, s) = self
                .progress
                .task(&task, |report| ts.pixels_with_progress(&scene.camera, self.spp, self.seed, report))?;
            timings.add("pixels", start.elapsed().as_secs_f64() * 1e3, None);
            shadow_rays += s.shadow_rays;
            self_error.pixels =
                estimable.then(|| relative_std_error(px.iter().zip(&covered).filter(|(_, c)| **c).map(|(e, _)| e)));
            pixel_std_error = estimable.then(|| px.iter().map(|e| e.std_error).collect());
            Some(Image {
                width: scene.camera.width,
                height: scene.camera.height,
                pixels: px.iter().map(|e| e.mean).collect(),
                covered,
            })
        } else {
            None
        };
        let (mut positions, mut normals, mut radiance, mut std_error) = (Vec::new(), Vec::new(), Vec::new(), None);
        if request.vertices {
            let task = format!("truth, {} spp, vertices", self.spp);
            let start = Instant::now();
            let (est, s) = self
                .progress
                .task(&task, |report| ts.vertices_with_progress(scene.camera.eye, self.spp, self.seed, report))
                .context("estimating the vertices")?;
            timings.add("vertices", start.elapsed().as_secs_f64() * 1e3, None);
            shadow_rays += s.shadow_rays;
            stats.vertices = s.points;
            self_error.vertices = estimable.then(|| relative_std_error(est.iter().flatten()));
            let n = scene.objects.len();
            positions = (0..n).map(|i| ts.positions(i).to_vec()).collect();
            normals = (0..n).map(|i| (0..est[i].len()).map(|v| ts.frame(i, v).n).collect()).collect();
            radiance = est.iter().map(|o| o.iter().map(|e| e.mean).collect()).collect();
            std_error = Some(est.iter().map(|o| o.iter().map(|e| e.std_error).collect()).collect());
        }
        Ok(Frame {
            state,
            positions,
            normals,
            radiance,
            std_error,
            image,
            pixel_std_error,
            encoded: None,
            self_error: estimable.then_some(self_error),
            stats,
            shadow_rays,
            timings,
            covers: Vec::new(),
        })
    }
}

/// The RSL path with oracles (rsl-shade's `oracle`): some of its approximations replaced by
/// exact values, traced with the truth's shadow rays, to measure what each one costs.
pub struct Oracle {
    /// Which approximations are replaced.
    pub oracles: Oracles,
    /// How finely they integrate.
    pub params: OracleParams,
    /// Where the shading reports its progress.
    pub progress: Progress,
}

impl Oracle {
    /// The oracles `oracles` at their default resolutions. With the light oracle, call
    /// [`Oracle::prepare`] on the engine first.
    pub fn new(oracles: Oracles) -> Self {
        Self { oracles, params: OracleParams::default(), progress: Progress::none() }
    }

    /// Readies `engine` for `oracles`: the light oracle needs one RSL per texel of the
    /// environment grid (a cut of the same decomposition).
    pub fn prepare(engine: &mut Engine, oracles: Oracles) -> Result<()> {
        if oracles.light && engine.rsl_count() != engine.texel_count() {
            engine.set_rsl_count(engine.texel_count())?;
        }
        Ok(())
    }
}

impl Method for Oracle {
    fn describe(&self) -> String {
        format!("RSL on the CPU with oracles: {}", self.oracles.names())
    }

    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        if self.oracles.light && engine.rsl_count() != engine.texel_count() {
            bail!(
                "the light oracle needs one RSL per texel ({}); the engine holds {}: call Oracle::prepare first",
                engine.texel_count(),
                engine.rsl_count()
            );
        }
        let mut timings = Timings::default();
        // The light oracle alone is the plain path with the per-texel light set.
        let (f, rays) = if self.oracles.shading() {
            let state = scene.at(request.time);
            let setup = engine.setup(scene, &state, scene.camera.eye, Terms::default())?;
            let rays = timings.time("scene", || Truth::scene(engine, scene, &state, env_light(engine)))?;
            let task = format!("oracles ({})", self.oracles.names());
            let start = Instant::now();
            let (radiance, stats) = self
                .progress
                .task(&task, |report| rsl_shade::shade_oracle(&setup, self.oracles, &self.params, &rays, report));
            let ms = start.elapsed().as_secs_f64() * 1e3;
            (ShadedFrame::of(&setup, state, radiance, stats.lookups, ms), stats.rays)
        } else {
            (engine.shade(scene, request.time)?, 0)
        };
        timings.add("shade", f.shade_ms, None);
        let image = request
            .image
            .then(|| timings.time("draw", || rasterise(engine, scene, &f.state, &f.positions, &f.radiance)));
        Ok(Frame { shadow_rays: rays, ..Frame::rsl(f, image, None, timings) })
    }
}

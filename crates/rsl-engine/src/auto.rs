//! The per-object methods (`hybrid`, `lobe`, `auto`): rules that assign each object to a
//! drawing, the frame assembled by the compositor ([`crate::compose`]). `auto` draws each
//! object as its scene `method` asks, and for `method = "auto"` a glossy object with the
//! lobes or the RSL sum per pixel, whichever comes nearer the truth on a sample of its
//! pixels ([`Composite::auto_choice`]).

use crate::compose::{FrameContext, GpuImage, ObjectDrawing, PixelDrawing, VertexDrawing, compose};
use crate::engine::Engine;
use crate::lobe::{EnvironmentJob, GpuLobes, LobeDrawing, PreparedEnvironment};
use crate::method::{Frame, Method, Preparation, Prepared, Request};
use crate::progress::Timings;
use crate::registry::MethodId;
use anyhow::{Context, Result};
use glam::Vec3;
use rayon::prelude::*;
use rsl_brdf::Brdf;
use rsl_gpu::GpuContext;
use rsl_scene::{ObjectMethod, Scene};
use rsl_shade::{FrameStats, Terms};
use std::collections::HashMap;
use std::sync::Arc;

/// The per-object methods: each object drawn by the drawing a rule assigns it — the RSL path
/// at the vertices, the RSL sum per pixel, the hybrid's lobes or the lobe path's — and the
/// frame assembled by [`compose`]. The rules: `hybrid` and `lobe` draw every glossy object
/// with their lobes; `auto` ([`Composite::auto`]) draws each object as its scene `method`
/// asks, choosing for `method = "auto"` ([`Composite::auto_choice`]).
pub struct Composite {
    /// Draw per pixel: each pixel of a glossy object shaded for its own interpolated normal
    /// and view (else the vertices' radiance is interpolated).
    pub per_pixel: bool,
    rule: Rule,
    vertex: VertexDrawing,
    pixel: PixelDrawing,
    hybrid: LobeDrawing,
    lobe: LobeDrawing,
    /// The drawings of per-object methods a program registered, built when an object first
    /// asks for one.
    others: Vec<(MethodId, Box<dyn ObjectDrawing>)>,
    gpu: Option<GpuLobes>,
    /// `auto`'s estimator: the environment as a light to sample (by the engine's content
    /// key and intensity), and per object its last estimate with the key of what it measured.
    estimator: Option<((u64, u32), Arc<rsl_truth::EnvLight>)>,
    estimates: HashMap<usize, (u64, Option<AutoEstimate>)>,
}

/// Which objects a [`Composite`] draws how.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Rule {
    /// Glossy objects with the hybrid's lobes.
    Hybrid,
    /// Glossy objects with the lobe path's transport lobes.
    Lobe,
    /// As each object's scene `method` asks.
    PerObject,
}

impl Composite {
    fn with_rule(rule: Rule) -> Self {
        Self {
            per_pixel: true,
            rule,
            vertex: VertexDrawing,
            pixel: PixelDrawing,
            hybrid: LobeDrawing::new(false),
            lobe: LobeDrawing::new(true),
            others: Vec::new(),
            gpu: None,
            estimator: None,
            estimates: HashMap::new(),
        }
    }

    /// The hybrid (`--method hybrid`, variant (b)) with nothing prepared yet (the
    /// environment and the lobes are made on the first frame and kept), drawing glossy
    /// objects per pixel.
    pub fn hybrid() -> Self {
        Self::with_rule(Rule::Hybrid)
    }

    /// The lobe path with its own shadows (`--method lobe`, variant (a)): transport lobes,
    /// each shadowed by the other objects' fields over a square of its width, drawn per pixel.
    pub fn lobe() -> Self {
        Self::with_rule(Rule::Lobe)
    }

    /// Each object drawn as its scene `method` asks (`--method auto`), on the CPU.
    pub fn auto() -> Self {
        Self::with_rule(Rule::PerObject)
    }

    /// A hybrid whose images are drawn per pixel on the GPU of `ctx` (the fragment shader
    /// `shaders/draw/lobes.wgsl`); the vertices' RSL shading, the visibility ratio, stays on
    /// the CPU. Objects drawn with the RSL sum per pixel are shaded and drawn on the GPU
    /// (`shaders/draw/pixels.wgsl`), in the same pass.
    pub fn on_gpu(ctx: Arc<GpuContext>) -> Result<Self> {
        Ok(Self { gpu: Some(GpuLobes::new(ctx)?), ..Self::hybrid() })
    }

    /// `auto` ([`Composite::auto`]) with its images drawn on the GPU of `ctx`, as
    /// [`Composite::on_gpu`] draws them.
    pub fn auto_on_gpu(ctx: Arc<GpuContext>) -> Result<Self> {
        Ok(Self { rule: Rule::PerObject, ..Self::on_gpu(ctx)? })
    }

    /// This method with the transport lobes fitted as if the object did not shadow itself
    /// (`V_self = 1`), to measure what its own shadows are worth.
    pub fn without_self_shadows(mut self) -> Self {
        for d in [&mut self.hybrid, &mut self.lobe] {
            d.set_no_self_shadows();
        }
        self
    }

    /// This method with the visibility ratio of images drawn on the CPU interpolated from the
    /// vertices, as the GPU draw pass has it (to compare the two). Less accurate: a traced
    /// light's shadow edge across a triangle, and a light a corner cannot see, are smeared
    /// (a Suzanne under a low sun: 11.0 % per covered pixel against 4.2 % with the ratio at
    /// each pixel).
    pub fn with_vertex_ratios(mut self) -> Self {
        self.hybrid.set_vertex_ratios();
        self.lobe.set_vertex_ratios();
        self
    }

    /// How many objects' transport lobes are held (those the last frame drew).
    pub fn transport_held(&self) -> usize {
        self.lobe.transport_held()
    }

    /// This hybrid drawing glossy objects with the lobe path's transport lobes
    /// ([`Composite::lobe`]) when `fields`.
    pub fn with_fields(self, fields: bool) -> Self {
        Self { rule: if fields { Rule::Lobe } else { Rule::Hybrid }, ..self }
    }

    /// The GPU's adapter, in words, when the images are drawn there.
    pub fn gpu_adapter(&self) -> Option<String> {
        self.gpu.as_ref().map(GpuLobes::adapter)
    }

    /// Whether each object is drawn as its scene asks (`auto`).
    pub(crate) fn is_per_object(&self) -> bool {
        self.rule == Rule::PerObject
    }

    /// The width (radians) of object `i`'s sharpest single-lobe fit.
    pub(crate) fn sharpest_lobe(&mut self, engine: &Engine, i: usize) -> Result<f32> {
        let kappa = self.hybrid.lobes(engine.brdf(i))?.single_kappa_max();
        Ok(1.0 / kappa.max(1e-6).sqrt())
    }

    /// The drawing whose preparation runs ahead of frames: the lobe path's for `lobe`, else
    /// the hybrid's.
    fn prepared_drawing(&mut self) -> &mut LobeDrawing {
        if self.rule == Rule::Lobe { &mut self.lobe } else { &mut self.hybrid }
    }

    /// [`LobeDrawing::environment_job`] of the lobes this method prepares ahead, for `scene`
    /// (which `engine` was last synced to): the environment prefiltered, and the transport
    /// lobes of every glossy object the lobe path draws — all of them for `lobe`, those
    /// whose scene `method` is `"lobe"` for `auto`.
    pub fn environment_job(&mut self, engine: &Engine, scene: &Scene) -> Result<Option<EnvironmentJob>> {
        engine.check(scene)?;
        let mut job = self.prepared_drawing().environment_job(engine)?;
        if self.rule == Rule::PerObject {
            let which: Vec<bool> = (0..engine.object_count())
                .map(|i| {
                    let m = scene.objects[i].method;
                    m == ObjectMethod::LOBE && drawn_by(m, engine.brdf(i)).ok() == Some(MethodId::LOBE)
                })
                .collect();
            if let Some(more) = self.lobe.transport_jobs(engine, &which)? {
                job = Some(match job {
                    Some(j) => j.with(more),
                    None => more,
                });
            }
        }
        Ok(job)
    }

    /// Takes what an [`EnvironmentJob`] made.
    pub fn install(&mut self, p: PreparedEnvironment) {
        self.hybrid.install(p.clone());
        self.lobe.install(p);
    }

    /// Which per-object method draws each of `engine`'s objects at time `t`.
    fn drawn(&mut self, engine: &Engine, scene: &Scene, t: f32) -> Result<Vec<MethodId>> {
        let method = match self.rule {
            Rule::Hybrid => ObjectMethod::HYBRID,
            Rule::Lobe => ObjectMethod::LOBE,
            Rule::PerObject => {
                let mut drawn = Vec::with_capacity(scene.objects.len());
                // What measuring one object's choice builds, shared by the next.
                let mut scene_at = None;
                for (i, o) in scene.objects.iter().enumerate() {
                    drawn.push(match o.method {
                        ObjectMethod::AUTO => self.choice(engine, scene, t, i, &mut scene_at)?,
                        m => drawn_by(m, engine.brdf(i))?,
                    });
                }
                return Ok(drawn);
            }
        };
        (0..engine.object_count()).map(|i| drawn_by(method, engine.brdf(i))).collect()
    }

    /// The drawing of per-object method `id` (built from the registry on first use).
    fn drawing(&mut self, id: MethodId) -> Result<&mut dyn ObjectDrawing> {
        Ok(match id {
            MethodId::RSL => &mut self.vertex,
            MethodId::PIXEL => &mut self.pixel,
            MethodId::HYBRID => &mut self.hybrid,
            MethodId::LOBE => &mut self.lobe,
            _ => {
                if !self.others.iter().any(|(o, _)| *o == id) {
                    let make = id
                        .registration()
                        .drawing
                        .ok_or_else(|| anyhow::anyhow!("method `{id}` cannot draw single objects"))?;
                    self.others.push((id, make()));
                }
                let (_, d) = self.others.iter_mut().find(|(o, _)| *o == id).expect("built just above");
                d.as_mut()
            }
        })
    }

    /// A frame with each object drawn by the per-object method `drawn` names (one per
    /// object); with `per_pixel` false, the image interpolates every object's vertices.
    pub fn render_drawn(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        request: &Request,
        drawn: &[MethodId],
        per_pixel: bool,
    ) -> Result<Frame> {
        for &id in drawn {
            self.drawing(id)?;
        }
        let built_in = [MethodId::RSL, MethodId::PIXEL, MethodId::HYBRID, MethodId::LOBE];
        let ids: Vec<MethodId> = built_in.into_iter().chain(self.others.iter().map(|o| o.0)).collect();
        let assigned: Vec<usize> =
            drawn.iter().map(|id| ids.iter().position(|d| d == id).expect("every drawing built above")).collect();
        let mut drawings: Vec<&mut dyn ObjectDrawing> =
            vec![&mut self.vertex, &mut self.pixel, &mut self.hybrid, &mut self.lobe];
        drawings.extend(self.others.iter_mut().map(|(_, d)| d.as_mut() as &mut dyn ObjectDrawing));
        let gpu = self.gpu.as_mut().map(|g| g as &mut dyn GpuImage);
        compose((engine, scene, request), &assigned, &mut drawings, per_pixel, gpu)
    }
}

/// Why an anisotropic object is drawn with the RSL sum per pixel by the lobe methods.
pub(crate) const ANISOTROPIC: &str =
    "anisotropic: the lobes fit isotropic BRDFs only, so the RSL sum per pixel draws it";

/// Why a Lambertian object is drawn from its vertices (`rsl render --explain`).
pub(crate) const LAMBERTIAN: &str = "Lambertian: its radiance varies no faster than its visibility and its BRDF \
     term is exact (per pixel only where a traced light's shadow falls or another object's shadow edge crosses \
     its triangles)";

/// The per-object method that draws an object of `brdf` whose scene asks for `method`:
/// `auto` draws a glossy object per pixel ([`Composite::auto_choice`] may take the lobes);
/// the built-in methods never give a Lambertian object lobes (the RSL path's Lambertian term
/// is exact where a cosine-fitted lobe is not) and draw it per pixel only where that changes
/// something, for the shadows of traced lights and of other objects
/// ([`rsl_shade::drawn_per_pixel`]); an
/// anisotropic object, which the lobes cannot fit, gets the RSL sum per pixel; a method a
/// program registered draws whatever it is given.
pub fn drawn_by(method: ObjectMethod, brdf: &Brdf) -> Result<MethodId> {
    if !method.is_built_in() {
        let id: MethodId = method.name().parse().map_err(anyhow::Error::msg)?;
        anyhow::ensure!(id.registration().drawing.is_some(), "method `{id}` cannot draw single objects");
        return Ok(id);
    }
    if brdf.is_lambertian() {
        return Ok(if method == ObjectMethod::RSL { MethodId::RSL } else { MethodId::PIXEL });
    }
    if brdf.is_anisotropic() && (method == ObjectMethod::HYBRID || method == ObjectMethod::LOBE) {
        return Ok(MethodId::PIXEL);
    }
    Ok(match method {
        ObjectMethod::RSL => MethodId::RSL,
        ObjectMethod::HYBRID => MethodId::HYBRID,
        ObjectMethod::LOBE => MethodId::LOBE,
        _ => MethodId::PIXEL,
    })
}

impl Method for Composite {
    fn describe(&self) -> String {
        let threads = rayon::current_num_threads();
        let what = match self.rule {
            Rule::Hybrid => "vMF lobes × RSL visibility",
            Rule::Lobe => "vMF lobes shadowed by the fields",
            Rule::PerObject => "each object's own method",
        };
        match self.gpu_adapter() {
            Some(a) => format!(
                "{what}: the lobes' vertices on the CPU ({threads} threads), the RSL sum's vertices and the pixels on {a}"
            ),
            None => format!("{what} on the CPU ({threads} threads)"),
        }
    }

    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        engine.check(scene)?;
        let start = std::time::Instant::now();
        let drawn = self.drawn(engine, scene, request.time)?;
        let choose_ms = start.elapsed().as_secs_f64() * 1e3;
        let per_pixel = self.per_pixel;
        let mut frame = self.render_drawn(engine, scene, request, &drawn, per_pixel)?;
        if self.is_per_object() {
            frame.timings.add("choose", choose_ms, None);
        }
        Ok(frame)
    }

    fn explain(&mut self, engine: &Engine, scene: &Scene) -> Result<Vec<String>> {
        engine.check(scene)?;
        let drawn = self.drawn(engine, scene, 0.0)?;
        let mut lines = Vec::with_capacity(scene.objects.len());
        for (i, o) in scene.objects.iter().enumerate() {
            let brdf = engine.brdf(i);
            let why = self.why(engine, scene, i, o.method)?;
            let how = self.drawing(drawn[i])?.describe(brdf);
            lines.push(format!("{}: {how} ({}) — {why}", o.name, drawn[i]));
        }
        Ok(lines)
    }

    fn built(&self) -> u64 {
        self.hybrid.transport_fitted() + self.lobe.transport_fitted()
    }

    fn preparation(&mut self, engine: &Engine, scene: &Scene) -> Result<Option<Preparation>> {
        Ok(self.environment_job(engine, scene)?.map(|job| Preparation::new(move || Box::new(job.run()) as Prepared)))
    }

    fn install(&mut self, prepared: Prepared) {
        if let Ok(p) = prepared.downcast::<PreparedEnvironment>() {
            Composite::install(self, *p);
        }
    }
}

impl Composite {
    /// What `auto` draws object `i` with: a glossy object gets whichever of the hybrid's
    /// lobes and the RSL sum per pixel comes the closer to a Monte Carlo estimate of its
    /// light ([`Composite::auto_estimate`]). An object no pixel sees is chosen by its lobes'
    /// width against the squares' ([`LOBE_RATIO`]).
    pub fn auto_choice(&mut self, engine: &Engine, scene: &Scene, t: f32, i: usize) -> Result<MethodId> {
        self.choice(engine, scene, t, i, &mut None)
    }

    /// [`Composite::auto_choice`], measuring in `scene_at` (built on first need).
    fn choice<'e>(
        &mut self,
        engine: &'e Engine,
        scene: &Scene,
        t: f32,
        i: usize,
        scene_at: &mut Option<Measuring<'e>>,
    ) -> Result<MethodId> {
        let brdf = engine.brdf(i);
        if brdf.is_lambertian() || brdf.is_anisotropic() {
            return drawn_by(ObjectMethod::AUTO, brdf);
        }
        Ok(match self.estimate(engine, scene, t, i, scene_at)? {
            Some(e) if e.lobes_better => MethodId::HYBRID,
            Some(_) => MethodId::PIXEL,
            None => {
                let width = self.sharpest_lobe(engine, i)?;
                if width * LOBE_RATIO < typical_square(engine.rsls()) { MethodId::HYBRID } else { MethodId::PIXEL }
            }
        })
    }

    /// How far the RSL sum per pixel and the hybrid's lobes are from the truth on glossy
    /// object `i`'s pixels ([`AutoEstimate`]), measured at time `t` the first time it is
    /// asked for and kept while its mesh, material and fields, the other objects' meshes
    /// and fields, and the environment stay the same: one choice per object for a whole
    /// animation or a viewer's drags and turns. `None` when no pixel's centre sees the object.
    ///
    /// Measured on the camera's view [`AUTO_WIDTH`] pixels wide, at up to [`AUTO_PIXELS`] of
    /// the pixels whose centre sees the object, spread evenly over them: both drawings shade the object as a frame would (the RSL sum with
    /// every light's cover at the vertices; the lobes times the visibility ratio) and each
    /// pixel's centre is shaded by both, against the truth's estimate at the same centre
    /// ([`AUTO_SPP`] samples, shadow rays through every object).
    pub fn auto_estimate(&mut self, engine: &Engine, scene: &Scene, t: f32, i: usize) -> Result<Option<AutoEstimate>> {
        self.estimate(engine, scene, t, i, &mut None)
    }

    /// [`Composite::auto_estimate`], measuring in `scene_at` (built on first need).
    fn estimate<'e>(
        &mut self,
        engine: &'e Engine,
        scene: &Scene,
        t: f32,
        i: usize,
        scene_at: &mut Option<Measuring<'e>>,
    ) -> Result<Option<AutoEstimate>> {
        let env_key = (engine.environment_key(), engine.intensity().to_bits());
        // Kept in memory across views and times (a front end's camera moves): the figure
        // is for the object, not one view of it.
        let key = object_key(engine, scene, i).finish();
        if let Some((k, e)) = self.estimates.get(&i)
            && *k == key
        {
            return Ok(*e);
        }
        // Measured by an earlier run (the disk cache): the same objects, fields, materials,
        // environment, quality, camera and time give the same figures (the truth's samples
        // are seeded).
        let disk = disk_key(engine, scene, t, i);
        let file = engine.cache_dir().map(|d| d.join(format!("auto-{disk:016x}.bin")));
        if let Some((f, e)) = file.as_deref().and_then(|f| {
            let b = std::fs::read(f).ok()?;
            Some((f, estimate_from_bytes(&b, disk).ok()?))
        }) {
            crate::cache::used(f);
            self.estimates.insert(i, (key, e));
            return Ok(e);
        }
        let at = match scene_at.take() {
            Some(m) => m,
            None => {
                let light = match &self.estimator {
                    Some((k, l)) if *k == env_key => l.clone(),
                    _ => {
                        let l = Arc::new(crate::method::env_light(engine));
                        self.estimator = Some((env_key, l.clone()));
                        l
                    }
                };
                Measuring::new(engine, scene, t, &light)?
            }
        };
        let estimate = self.measure(engine, scene, &at, i);
        *scene_at = Some(at);
        let estimate = estimate?;
        if let Some(f) = &file {
            match crate::cache::write(f, &estimate_to_bytes(estimate, disk)) {
                Ok(()) => crate::cache::stored(f, engine.cache_limit()),
                Err(e) => tracing::warn!("auto's choice of object {i} is not cached: {e:#}"),
            }
        }
        self.estimates.insert(i, (key, estimate));
        Ok(estimate)
    }

    /// [`Composite::auto_estimate`] of object `i` measured now in `at`.
    fn measure(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        at: &Measuring<'_>,
        i: usize,
    ) -> Result<Option<AutoEstimate>> {
        let n = engine.object_count();
        let Measuring { t, state, camera, setup, positions, normals, frags, truth } = at;
        let seen: Vec<usize> = (0..frags.len()).filter(|&k| frags[k].is_some_and(|f| f.mesh as usize == i)).collect();
        let (false, Some(truth)) = (seen.is_empty(), truth) else {
            return Ok(None);
        };
        let pixels: Vec<usize> = (0..AUTO_PIXELS.min(seen.len()))
            .map(|k| seen[(k * seen.len() + seen.len() / 2) / AUTO_PIXELS.min(seen.len())])
            .collect();
        // Both drawings of object `i` alone, as a frame draws it per pixel.
        let request = Request { time: *t, image: true, vertices: false, exposure: None };
        let ctx = FrameContext {
            engine,
            scene,
            request: &request,
            state,
            setup,
            per_pixel: true,
            gpu: false,
            positions,
            normals,
        };
        let which: Vec<bool> = (0..n).map(|j| j == i).collect();
        let mut timings = Timings::default();
        let mut stats = FrameStats::default();
        self.hybrid.prepare(engine, &which, &mut timings)?;
        let mut shaders = Vec::with_capacity(2);
        for drawing in [&mut self.pixel as &mut dyn ObjectDrawing, &mut self.hybrid] {
            let part = drawing.shade(&ctx, &which, &mut stats)?.swap_remove(i);
            let part = part.context("a drawing gave the object nothing")?;
            let shader = part.pixels.context("a drawing did not shade the object per pixel")?;
            let frames = shader.frames();
            shaders.push((part.radiance, shader, frames));
        }
        let indices = &engine.mesh(i).indices;
        let lights = setup.light_count();
        // Per pixel: the RSL sum, the hybrid, and the truth's estimate at its centre.
        let per_pixel: Vec<(Vec3, Vec3, rsl_truth::Estimate)> = pixels
            .par_iter()
            .map_init(
                || vec![0.0f32; lights],
                |buf, &k| {
                    let f = frags[k].as_ref().expect("a pixel that sees the object");
                    let [rsl, lobes] = [0, 1].map(|d| {
                        let (radiance, shader, frames) = &shaders[d];
                        let mesh =
                            rsl_shade::PixelMesh { positions: &positions[i], indices, frames: Some(frames), radiance };
                        let point = rsl_shade::pixel_point(&mesh, f, camera.eye).expect("a mesh with frames");
                        shader.shade(&mesh, &point, buf)
                    });
                    let (x, y) = ((k % camera.width as usize) as u32, (k / camera.width as usize) as u32);
                    let mut rng = rsl_sphere::sampling::Pcg32::new(AUTO_SEED ^ k as u64);
                    let (e, _, _) = truth.pixel(camera, x, y, AUTO_SPP, &mut rng);
                    (rsl, lobes, e)
                },
            )
            .collect();
        Ok(Some(AutoEstimate::of(&per_pixel, *t)))
    }

    /// Why object `i`, whose scene asks for `method`, is drawn as this method draws it
    /// (`rsl render --explain`).
    pub(crate) fn why(&mut self, engine: &Engine, scene: &Scene, i: usize, method: ObjectMethod) -> Result<String> {
        let brdf = engine.brdf(i);
        let per_object = self.is_per_object();
        Ok(if brdf.is_lambertian() {
            LAMBERTIAN.to_string()
        } else if brdf.is_anisotropic() && !(per_object && method == ObjectMethod::RSL) {
            ANISOTROPIC.to_string()
        } else if !per_object {
            "glossy: the method's lobes".to_string()
        } else if method == ObjectMethod::AUTO {
            match self.auto_estimate(engine, scene, 0.0, i)? {
                Some(e) => format!(
                    "auto: against the truth at {} of its pixels (t = {} s, {AUTO_SPP} samples each, its noise \
                     {:.1} %), the RSL sum per pixel is {:.1} % off and the lobes {:.1} %; {}",
                    e.pixels,
                    e.time,
                    100.0 * e.noise,
                    100.0 * e.rsl,
                    100.0 * e.lobes,
                    if e.lobes_better {
                        "the lobes are nearer"
                    } else {
                        "the RSL sum, the lobes being not clearly nearer (half its error or less, beyond the truth's noise)"
                    }
                ),
                None => {
                    let square = typical_square(engine.rsls());
                    let width = self.sharpest_lobe(engine, i)?;
                    let ratio = square / width;
                    format!(
                        "auto: no pixel sees it; the typical square ({square:.4} rad) is {ratio:.1}× its \
                         sharpest lobe ({width:.4} rad), and auto takes the lobes from {LOBE_RATIO}×"
                    )
                }
            }
        } else {
            format!("the scene asks for method {method}")
        })
    }
}

/// What `auto` measures of a glossy object to choose its drawing: at a sample of its
/// pixels, how far the RSL sum per pixel and the hybrid (its lobes times the visibility
/// ratio) are from the truth at the pixels' centres: relative L2 over the pixels (RGB), the
/// truth's own variance taken out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutoEstimate {
    /// The RSL sum's relative error.
    pub rsl: f64,
    /// The lobes' relative error.
    pub lobes: f64,
    /// The Monte Carlo estimate's relative standard error.
    pub noise: f64,
    /// The pixels measured.
    pub pixels: usize,
    /// Whether the lobes came nearer than the RSL sum by more than the truth's noise can
    /// explain ([`AUTO_MARGIN`]) and by at least half ([`AUTO_FACTOR`]): what `auto`
    /// chooses by.
    pub lobes_better: bool,
    /// The scene time it was measured at.
    pub time: f32,
}

/// Magic number of a cached [`AutoEstimate`].
const AUTO_MAGIC: [u8; 8] = *b"RSLAUTO1";
/// Version of its format.
const AUTO_VERSION: u32 = 1;

/// The disk cache's key of object `i`'s estimate: what [`Composite::auto_estimate`] keeps it
/// by in memory, and what it measured from besides — the camera, the time, the quality
/// settings — in a key stable across runs.
/// What `auto`'s figure for object `i` depends on wherever it is seen from: the
/// environment and its light count, the measurement's size, the object's prepared data and
/// material, and what of the others can shadow it (their meshes and fields, not their
/// materials).
fn object_key(engine: &Engine, scene: &Scene, i: usize) -> rsl_sphere::key::KeyHasher {
    let k = engine.keys(i);
    let mut h = rsl_sphere::key::KeyHasher::default()
        .str("auto")
        .u64(engine.environment_key())
        .f32s(&[engine.intensity()])
        .u64(engine.rsls().len() as u64)
        .u64(AUTO_SPP as u64)
        .u64(AUTO_PIXELS as u64)
        .u64(i as u64)
        .u64(engine.brdf(i).key())
        .u64(k.mesh)
        .u64(k.frames)
        .u64(k.table)
        .u64(k.svdf)
        .u64(k.ovdf);
    for j in 0..engine.object_count() {
        h = h.u64(engine.keys(j).mesh).u64(engine.keys(j).ovdf).u64(u64::from(scene.objects[j].casts_shadows));
    }
    h
}

/// The disk cache's key of `auto`'s figure for object `i`: [`object_key`], and what one run's
/// measurement was taken at (the program's version, the quality, the camera, the time and
/// every object's pose).
fn disk_key(engine: &Engine, scene: &Scene, t: f32, i: usize) -> u64 {
    let c = &scene.camera;
    let mut h = object_key(engine, scene, i)
        .str(env!("CARGO_PKG_VERSION"))
        .str(&format!("{:?}", engine.settings()))
        .f32s(&[t])
        .f32s(&[c.eye.x, c.eye.y, c.eye.z, c.target.x, c.target.y, c.target.z, c.up.x, c.up.y, c.up.z, c.fov_y])
        .u64(u64::from(c.width) << 32 | u64::from(c.height));
    for tr in &scene.at(t).objects {
        h = h.f32s(&tr.translation.to_array()).f32s(&tr.rotation.to_array()).f32s(&tr.scale.to_array());
    }
    h.finish()
}

/// A measured estimate (or none: no pixel sees the object) as a cache file's bytes.
fn estimate_to_bytes(e: Option<AutoEstimate>, key: u64) -> Vec<u8> {
    let mut p = Vec::with_capacity(40);
    match e {
        None => p.push(0u8),
        Some(e) => {
            p.push(1);
            for v in [e.rsl, e.lobes, e.noise] {
                p.extend_from_slice(&v.to_le_bytes());
            }
            p.extend_from_slice(&(e.pixels as u64).to_le_bytes());
            p.push(u8::from(e.lobes_better));
            p.extend_from_slice(&e.time.to_le_bytes());
        }
    }
    rsl_sphere::framed::frame(&AUTO_MAGIC, AUTO_VERSION, key, &p)
}

/// Reads [`estimate_to_bytes`]'s bytes, verifying everything.
fn estimate_from_bytes(b: &[u8], key: u64) -> Result<Option<AutoEstimate>, String> {
    let p = rsl_sphere::framed::unframe(&AUTO_MAGIC, AUTO_VERSION, key, b).map_err(|e| e.to_string())?;
    match p {
        [0] => Ok(None),
        [1, rest @ ..] if rest.len() == 3 * 8 + 8 + 1 + 4 => {
            let f = |k: usize| f64::from_le_bytes(rest[8 * k..8 * k + 8].try_into().expect("8 bytes"));
            let pixels = u64::from_le_bytes(rest[24..32].try_into().expect("8 bytes")) as usize;
            let time = f32::from_le_bytes(rest[33..37].try_into().expect("4 bytes"));
            let e = AutoEstimate { rsl: f(0), lobes: f(1), noise: f(2), pixels, lobes_better: rest[32] == 1, time };
            let finite = [e.rsl, e.lobes, e.noise].iter().all(|v| v.is_finite()) && time.is_finite();
            if finite && rest[32] <= 1 { Ok(Some(e)) } else { Err("malformed values".into()) }
        }
        _ => Err(format!("a cached choice of {} bytes is malformed", p.len())),
    }
}

impl AutoEstimate {
    /// The figures of `(RSL sum, lobes, truth)` at the pixels measured at time `t`.
    fn of(values: &[(Vec3, Vec3, rsl_truth::Estimate)], t: f32) -> Self {
        let (mut rsl, mut lobes, mut norm, mut noise, mut apart) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
        let sq = |v: Vec3| f64::from(v.length_squared());
        for (r, l, e) in values {
            rsl += sq(*r - e.mean);
            lobes += sq(*l - e.mean);
            norm += sq(e.mean);
            noise += sq(e.std_error);
            // The difference of the two squared errors moves with the truth's noise as
            // 2 (r − l)·(noise): its variance, per channel.
            apart += 4.0 * f64::from(((*r - *l) * e.std_error).length_squared());
        }
        // Each squared error holds the estimate's own variance besides (E[e²] = d² + σ²).
        let rel = |e2: f64| if norm > 0.0 { ((e2 - noise).max(0.0) / norm).sqrt() } else { 0.0 };
        let (e_rsl, e_lobes) = (rel(rsl), rel(lobes));
        Self {
            rsl: e_rsl,
            lobes: e_lobes,
            noise: if norm > 0.0 { (noise / norm).sqrt() } else { 0.0 },
            pixels: values.len(),
            lobes_better: rsl - lobes > AUTO_MARGIN * apart.sqrt() && e_lobes <= AUTO_FACTOR * e_rsl,
            time: t,
        }
    }
}

/// What [`Composite::auto_estimate`] measures objects in, built once for all the objects of
/// one choice: the scene at time `t` seen through the camera at [`AUTO_WIDTH`] pixels wide
/// (every term set up, the pixels' fragments), and the truth's scene sampling its centres.
struct Measuring<'e> {
    t: f32,
    state: rsl_scene::SceneState,
    camera: rsl_scene::Camera,
    setup: rsl_shade::FrameSetup<'e>,
    positions: Vec<Vec<Vec3>>,
    normals: Vec<Vec<Vec3>>,
    frags: Vec<Option<rsl_shade::Fragment>>,
    /// `None` where no pixel sees any object.
    truth: Option<rsl_truth::TruthScene>,
}

impl<'e> Measuring<'e> {
    fn new(engine: &'e Engine, scene: &Scene, t: f32, light: &rsl_truth::EnvLight) -> Result<Self> {
        let n = engine.object_count();
        let state = scene.at(t);
        // The camera's view at a fixed size: the choice is the same for a preview and for
        // the final image.
        let aspect = f64::from(scene.camera.height) / f64::from(scene.camera.width.max(1));
        let camera = rsl_scene::Camera {
            width: AUTO_WIDTH,
            height: ((f64::from(AUTO_WIDTH) * aspect).round() as u32).clamp(1, 4 * AUTO_WIDTH),
            ..scene.camera
        };
        let setup = engine.setup(scene, &state, camera.eye, Terms::default())?;
        let positions: Vec<Vec<Vec3>> = (0..n).map(|j| setup.positions(j)).collect();
        let normals: Vec<Vec<Vec3>> = (0..n).map(|j| setup.normals(j)).collect();
        let geometry: Vec<(&[Vec3], &[u32])> =
            (0..n).map(|j| (&positions[j][..], &engine.mesh(j).indices[..])).collect();
        let frags = rsl_shade::fragments(&camera, &geometry);
        // Where no pixel sees an object, nothing is measured (and a scene of degenerate
        // triangles alone has no truth).
        let truth = if frags.iter().any(Option::is_some) {
            let truth = crate::method::Truth::scene(engine, scene, &state, light.clone())?;
            Some(truth.with_pixel_filter(rsl_truth::PixelFilter::Centre))
        } else {
            None
        };
        Ok(Self { t, state, camera, setup, positions, normals, frags, truth })
    }
}

/// The width of the image [`Composite::auto_estimate`] measures on (the camera's aspect kept).
pub const AUTO_WIDTH: u32 = 320;

/// The most pixels of an object [`Composite::auto_estimate`] measures.
pub const AUTO_PIXELS: usize = 256;

/// How many standard errors (of the truth's noise in the difference) the lobes' squared
/// error must be below the RSL sum's for `auto` to take them: a draw within the truth's
/// noise keeps the RSL sum, the better under suns on the bundled scenes.
pub const AUTO_MARGIN: f64 = 2.0;

/// At most this share of the RSL sum's error (the truth's noise taken out of both) must the
/// lobes' be for `auto` to take them: only a clear win changes the drawing, so that a
/// choice measured at one pose (the first frame's) holds at the next (a viewer's drag, an
/// animation) and near-draws never flip between a preview and a final render. Measured on
/// the bundled and accuracy scenes: the lobes win by 4.6–38× in the white furnace for lobes
/// up to α = 0.3, and come within 1.3× elsewhere (a GGX α = 0.05 torus of the bench scene,
/// 7.0 against 9.3 %; the default scene's ball at `draft`, 11.8 against 15.6 %).
pub const AUTO_FACTOR: f64 = 0.5;

/// Monte Carlo samples per pixel of [`Composite::auto_estimate`].
pub const AUTO_SPP: u32 = 128;

/// The seed of [`Composite::auto_estimate`]'s samples.
const AUTO_SEED: u64 = 0x5eed_a070;

/// How much narrower than the typical square a lobe must be for `auto` to draw it with the
/// lobes rather than the RSL sum, where no pixel sees the object to measure it.
pub const LOBE_RATIO: f32 = 8.0;

/// The energy-weighted mean half-diagonal of `rsls` (in the equal-area plane; about the
/// half-width of a square in radians): how large the squares that carry most of the light
/// are. A sun or a studio's lamps make it small, a uniform sky large.
pub fn typical_square(rsls: &[rsl_env::Rsl]) -> f32 {
    let (mut sum, mut energy) = (0.0f64, 0.0f64);
    for r in rsls {
        let e = f64::from(rsl_sphere::sampling::luminance(r.intensity).max(0.0) * r.solid_angle());
        sum += e * f64::from(r.half_diagonal);
        energy += e;
    }
    if energy > 0.0 { (sum / energy) as f32 } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cached_choice_reads_back_and_a_damaged_or_foreign_one_is_refused() {
        let e = AutoEstimate { rsl: 0.0123, lobes: 0.25, noise: 0.04, pixels: 256, lobes_better: true, time: 1.5 };
        for estimate in [Some(e), None] {
            let b = estimate_to_bytes(estimate, 7);
            assert_eq!(estimate_from_bytes(&b, 7).unwrap(), estimate);
            // Another key (another scene, camera, quality…): refused, measured again.
            assert!(estimate_from_bytes(&b, 8).is_err());
            // Any flipped byte or a truncated file is caught.
            for k in 0..b.len() {
                let mut d = b.clone();
                d[k] ^= 0x10;
                assert!(estimate_from_bytes(&d, 7).is_err(), "byte {k} flipped went unnoticed");
            }
            assert!(estimate_from_bytes(&b[..b.len() - 1], 7).is_err());
        }
    }
}

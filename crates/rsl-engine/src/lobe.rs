//! The hybrid of the lobe path and the RSL path (rsl-lobe; variant (b) of the lobe path): per
//! vertex, the unshadowed glossy radiance from the material's vMF lobes over the prefiltered
//! environment, times the RSL path's visibility ratio `Σ_i E_i·B̄_i·V̄_i / Σ_i E_i·B̄_i` (the
//! ratio estimator of Heitz et al. 2018, with RSL visibility in place of rays), per channel.
//!
//! Beside it, the lobe path with its own shadows (`method = "lobe"`, variant (a),
//! [`Drawn::LobeFields`]): transport lobes (Green et al. 2006) carry the object's own
//! shadows, and each lobe is shadowed by the other objects' occluder fields over a square of
//! its width.
//!
//! The lobes are meant to carry what a square light cannot, the environment's detail inside
//! a lobe narrower than the squares; the ratio carries the shadows, self and from other
//! objects, weighted as the RSL path weighs them. Measured (rsl-lobe README), the lobes do
//! not reproduce a microfacet lobe well enough to beat the RSL sum per pixel on the bundled
//! scenes; [`PerObject`] (`auto`) chooses per object, and picks the lobes only where their width is
//! well below the squares' (a near-mirror reflecting a sharp horizon).
//!
//! Prepared once and kept: the environment prefiltered up to the sharpest lobe the scene's
//! materials need (`κ` rounded up to a power of two, at most 4096), and each material's lobes
//! (refitted when its parameters change).
//!
//! Images ([`Hybrid::per_pixel`], the default): each pixel of a glossy object looks its lobes
//! up for its own interpolated normal and view (one prefiltered lookup per lobe), times the
//! ratio at the pixel: the RSL sum there, as `--method pixel` draws it (every light's cover
//! interpolated from the vertices, a traced light's traced from the pixel), over the same
//! sum unshadowed ([`rsl_shade::draw_pixels`]). With a GPU ([`Hybrid::on_gpu`]) its draw pass
//! (`shaders/draw/lobes.wgsl`) looks the lobes up per pixel and interpolates the ratio from
//! the vertices (the RSL sum per pixel has no GPU pass).

use crate::engine::{Engine, EnvRadiance, ShadedFrame, brdf_key};
use crate::method::{Frame, Method, Preparation, Prepared, Request, rasterise};
use crate::progress::Timings;
use anyhow::{Context, Result};
use glam::Vec3;
use rayon::prelude::*;
use rsl_brdf::Brdf;
use rsl_gpu::GpuContext;
use rsl_gpu::draw::GpuDraw;
use rsl_gpu::lobes::LobeObject;
use rsl_lobe::{
    FitParams, MaterialLobes, PackedEnvironment, PackedMaterial, PrefilterParams, Prefiltered, TransportLobes,
    TransportParams, WeightedLobe,
};
use rsl_scene::{ObjectMethod, Scene};
use rsl_shade::{FrameStats, PixelMesh, Pose, Terms};
use rsl_sphere::Frame as LocalFrame;
use rsl_sphere::latlong::LatLongMap;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

pub use crate::auto::{LOBE_RATIO, PerObject, typical_square};

/// The hybrid method, on every object with a specular lobe (Lambertian objects keep the RSL
/// path's value).
#[derive(Default)]
pub struct Hybrid {
    /// Draw glossy objects per pixel: each pixel's lobes from its own interpolated normal
    /// and view, times the visibility ratio at the pixel (else the vertices' radiance is
    /// interpolated).
    pub per_pixel: bool,
    /// In images drawn on the CPU, interpolate the visibility ratio from the vertices, as the
    /// GPU draw pass does, instead of forming it at each pixel ([`Hybrid::with_vertex_ratios`]).
    vertex_ratios: bool,
    /// Draw glossy objects with their transport lobes (their own shadows fitted in), each
    /// shadowed by the other objects' occluder fields over a square of its width (`method =
    /// "lobe"`, variant (a)), instead of the material lobes times the RSL path's
    /// visibility ratio (variant (b), the hybrid).
    pub fields: bool,
    env: Option<(u64, u32, Arc<Prefiltered>)>,
    materials: HashMap<u64, Arc<MaterialLobes>>,
    /// Fit the transport lobes with nothing of the object in the way (`V_self = 1`: the
    /// material lobes at the object-space views), to compare ([`Hybrid::without_self_shadows`]).
    no_self_shadows: bool,
    /// Transport lobes, for [`Drawn::LobeFields`].
    transport: HashMap<TransportKey, Arc<TransportLobes>>,
    gpu: Option<GpuLobes>,
}

/// The GPU draw pass of [`Hybrid::on_gpu`] and what it holds.
struct GpuLobes {
    draw: GpuDraw,
    /// The prefiltered environment uploaded: (content key, top κ).
    lobe_env: Option<(u64, u32)>,
    /// The backdrop uploaded: (content key, intensity bits).
    backdrop: Option<(u64, u32)>,
}

impl Hybrid {
    /// A hybrid with nothing prepared yet (the environment and the lobes are made on the first
    /// frame and kept), drawing glossy objects per pixel.
    pub fn new() -> Self {
        Self { per_pixel: true, ..Self::default() }
    }

    /// The lobe path with its own shadows (`--method lobe`, variant (a)): transport lobes,
    /// each shadowed by the other objects' fields over a square of its width, drawn per pixel.
    pub fn lobe() -> Self {
        Self { fields: true, ..Self::new() }
    }

    /// A hybrid whose images are drawn per pixel on the GPU of `ctx` (the fragment shader
    /// `shaders/draw/lobes.wgsl`); the vertices' RSL shading, the visibility ratio, stays on
    /// the CPU. Objects drawn with the RSL sum per pixel ([`Drawn::Pixel`]) are drawn on the
    /// CPU, as without a GPU.
    pub fn on_gpu(ctx: Arc<GpuContext>) -> Result<Self> {
        let draw = GpuDraw::new(ctx).context("building the GPU draw pass")?;
        Ok(Self { gpu: Some(GpuLobes { draw, lobe_env: None, backdrop: None }), ..Self::new() })
    }

    /// This method with the transport lobes fitted as if the object did not shadow itself
    /// (`V_self = 1`), to measure what its own shadows are worth.
    pub fn without_self_shadows(self) -> Self {
        Self { no_self_shadows: true, transport: HashMap::new(), ..self }
    }

    /// This hybrid with the visibility ratio of images drawn on the CPU interpolated from the
    /// vertices, as the GPU draw pass has it (to compare the two). Less accurate: a traced
    /// light's shadow edge across a triangle, and a light a corner cannot see, are smeared
    /// (a Suzanne under a low sun: 11.0 % per covered pixel against 4.2 % with the ratio at
    /// each pixel).
    pub fn with_vertex_ratios(self) -> Self {
        Self { vertex_ratios: true, ..self }
    }

    /// How many objects' transport lobes are held (those the last frame drew).
    pub fn transport_held(&self) -> usize {
        self.transport.len()
    }

    /// This hybrid with each lobe shadowed by the fields ([`Hybrid::lobe`]) when `fields`.
    pub fn with_fields(self, fields: bool) -> Self {
        Self { fields, ..self }
    }

    /// The GPU's adapter, in words, when the images are drawn there.
    pub fn gpu_adapter(&self) -> Option<String> {
        self.gpu.as_ref().map(|g| g.draw.context().describe())
    }

    /// The material lobes of `brdf` (fitted once per parameter set).
    pub(crate) fn lobes(&mut self, brdf: &Brdf) -> Result<Arc<MaterialLobes>> {
        let key = brdf_key(brdf);
        if let Some(l) = self.materials.get(&key) {
            return Ok(l.clone());
        }
        let l = Arc::new(MaterialLobes::fit(brdf, &FitParams::default()).map_err(anyhow::Error::msg)?);
        self.materials.insert(key, l.clone());
        Ok(l)
    }

    /// The transport lobes of object `i` (fitted once per mesh and material, here if no
    /// [`EnvironmentJob`] brought them).
    fn transport(&mut self, engine: &Engine, i: usize, material: &Arc<MaterialLobes>) -> Result<Arc<TransportLobes>> {
        match self.transport_job(engine, i, material)? {
            Err(t) => Ok(t),
            Ok(job) => {
                let t = job.run()?;
                self.transport.insert(job.key, t.clone());
                Ok(t)
            }
        }
    }

    /// The fit of object `i`'s transport lobes as a job, or the lobes held (`Err`); the
    /// memory they would take is checked first.
    fn transport_job(
        &self,
        engine: &Engine,
        i: usize,
        material: &Arc<MaterialLobes>,
    ) -> Result<Result<TransportJob, Arc<TransportLobes>>> {
        let key = (engine.keys(i).mesh, brdf_key(engine.brdf(i)), self.no_self_shadows);
        if let Some(t) = self.transport.get(&key) {
            return Ok(Err(t.clone()));
        }
        let mesh = engine.mesh(i);
        crate::engine::check_size(
            "the transport lobes (per vertex and view)",
            "the object's vertices, or draw it with method \"hybrid\"",
            (TransportLobes::bytes_per_vertex(material, &TransportParams::default()) * mesh.vertex_count()) as u64,
        )?;
        Ok(Ok(TransportJob {
            key,
            object: i,
            mesh: mesh.clone(),
            frames: engine.frames(i).clone(),
            material: material.clone(),
            progress: engine.progress().clone(),
        }))
    }

    /// The environment prefiltered up to `kappa_max` (rebuilt when the map or the need changes).
    fn environment(&mut self, engine: &Engine, kappa_max: f32) -> Arc<Prefiltered> {
        match self.environment_need(engine, kappa_max) {
            None => self.env.as_ref().expect("held").2.clone(),
            Some(need) => {
                let p = EnvironmentJob { env: Some(need), transport: Vec::new() }.run();
                let out = p.env.as_ref().expect("prefiltered").2.clone();
                self.install(p);
                out
            }
        }
    }

    /// The preparation the next frame of `engine`'s scene would do before drawing (every
    /// glossy object's lobes fitted, here): the environment prefiltered, and for the lobe
    /// path ([`Hybrid::lobe`]) the glossy objects' transport lobes, as a job to run on
    /// another thread and give back with [`Hybrid::install`]; `None` when what is held
    /// suffices. A viewer runs it on a worker so that its frames keep coming.
    pub fn environment_job(&mut self, engine: &Engine) -> Result<Option<EnvironmentJob>> {
        let mut kappa_max = 1.0f32;
        let mut transport = Vec::new();
        for i in 0..engine.object_count() {
            if !engine.brdf(i).is_lambertian() {
                let l = self.lobes(engine.brdf(i))?;
                kappa_max = l.lobes_per_view().map(|w| w.lobe.kappa).fold(kappa_max, f32::max);
                if self.fields
                    && let Ok(job) = self.transport_job(engine, i, &l)?
                {
                    transport.push(job);
                }
            }
        }
        let env = self.environment_need(engine, kappa_max);
        Ok((env.is_some() || !transport.is_empty()).then_some(EnvironmentJob { env, transport }))
    }

    /// The map to prefilter, its content key and top κ, if neither what is held nor what
    /// another method of this process holds ([`SHARED`]) serves `kappa_max`.
    fn environment_need(&mut self, engine: &Engine, kappa_max: f32) -> Option<(u64, u32, Arc<LatLongMap>)> {
        let top = kappa_max.clamp(1.0, 4096.0).log2().ceil().exp2() as u32;
        let key = engine.environment_key();
        if let Some((k, t, _)) = &self.env
            && *k == key
            && *t >= top
        {
            return None;
        }
        if let Some((t, p)) = shared(key, top) {
            self.env = Some((key, t, p));
            return None;
        }
        let map = match engine.environment() {
            EnvRadiance::Map(m) => m.clone(),
            EnvRadiance::Constant(c) => Arc::new(LatLongMap::from_fn(8, 4, |_| *c)),
        };
        Some((key, top, map))
    }

    /// Takes what an [`EnvironmentJob`] made: the prefiltered environment (kept when it
    /// serves the environment held now or a newer need) and transport lobes.
    pub fn install(&mut self, p: PreparedEnvironment) {
        if let Some((key, top, prefiltered)) = p.env {
            let keep = match &self.env {
                Some((k, t, _)) => *k != key || *t < top,
                None => true,
            };
            if keep {
                share(key, top, &prefiltered);
                self.env = Some((key, top, prefiltered));
            }
        }
        for (key, t) in p.transport {
            if key.2 == self.no_self_shadows {
                self.transport.insert(key, t);
            }
        }
    }
}

/// The prefiltered environments the lobe methods of this process hold, by the map's content
/// key and top κ: a method built later (the viewer's next drawing) takes one that serves it
/// instead of prefiltering again (seconds). Weak: an environment no method holds is freed.
static SHARED: std::sync::Mutex<Vec<(u64, u32, std::sync::Weak<Prefiltered>)>> = std::sync::Mutex::new(Vec::new());

/// A prefiltered environment of map `key` up to at least `top`, if a method holds one.
fn shared(key: u64, top: u32) -> Option<(u32, Arc<Prefiltered>)> {
    let held = SHARED.lock().unwrap_or_else(|e| e.into_inner());
    held.iter().filter(|(k, t, _)| *k == key && *t >= top).find_map(|(_, t, w)| Some((*t, w.upgrade()?)))
}

/// Offers `p` (map `key` up to `top`) to the lobe methods built later.
fn share(key: u64, top: u32, p: &Arc<Prefiltered>) {
    let mut held = SHARED.lock().unwrap_or_else(|e| e.into_inner());
    held.retain(|(_, _, w)| w.strong_count() > 0);
    held.push((key, top, Arc::downgrade(p)));
}

/// The transport lobes' key: mesh, material, fitted without self-shadows.
type TransportKey = (u64, u64, bool);

/// Fitting one object's transport lobes ([`rsl_lobe::transport`]): `Send`, to run anywhere.
#[derive(Clone)]
struct TransportJob {
    key: TransportKey,
    object: usize,
    mesh: Arc<rsl_sphere::mesh::TriMesh>,
    frames: Arc<rsl_shade::VertexFrames>,
    material: Arc<MaterialLobes>,
    progress: crate::progress::Progress,
}

impl std::fmt::Debug for TransportJob {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TransportJob")
            .field("object", &self.object)
            .field("vertices", &self.mesh.vertex_count())
            .finish()
    }
}

impl TransportJob {
    /// The material's lobes shadowed by the object itself, per vertex and per view in object
    /// space. Self-visibility is traced against the object's triangles from each vertex
    /// lifted along its normal (as the truth's rays start), times the face mask (as the RSL
    /// path's self-visibility); with `V_self = 1` when the key says so.
    fn run(&self) -> Result<Arc<TransportLobes>> {
        let mesh = &self.mesh;
        let occluder =
            rsl_vis::rays::Occluder::new(mesh).map_err(|e| anyhow::anyhow!("object {}: {e}", self.object))?;
        let faces = rsl_sphere::faces::IncidentFaces::of(mesh);
        let (_, radius) = mesh.bounding_sphere().unwrap_or_default();
        let lift = 1e-4 * radius.max(f32::MIN_POSITIVE);
        let frames = &self.frames.visibility;
        let no_self_shadows = self.key.2;
        let visible = |v: usize, d: Vec3| {
            if no_self_shadows {
                return 1.0;
            }
            let h = faces.mask(v, d);
            if h <= 0.0 || occluder.occluded(mesh.positions[v] + frames[v].n * lift, d, f32::INFINITY) {
                0.0
            } else {
                h
            }
        };
        let params = TransportParams::default();
        let task = format!(
            "transport lobes of object {} ({} vertices × {} views)",
            self.object,
            mesh.vertex_count(),
            rsl_lobe::transport::geodesic_views(params.frequency).len()
        );
        let fit =
            self.progress.task(&task, |report| TransportLobes::fit(&self.material, frames, &params, visible, report));
        Ok(Arc::new(fit))
    }
}

/// The preparation a [`Hybrid`] needs ([`Hybrid::environment_job`]): `Send`, to run anywhere.
#[derive(Clone, Debug)]
pub struct EnvironmentJob {
    env: Option<(u64, u32, Arc<LatLongMap>)>,
    transport: Vec<TransportJob>,
}

impl EnvironmentJob {
    /// Prefilters the map and fits the transport lobes (seconds each on 2 cores: a map with
    /// a sun; about 22 s per 10,000 vertices). An object whose fit fails is left out (its frame
    /// fits it again, and says why).
    pub fn run(self) -> PreparedEnvironment {
        let env = self.env.map(|(key, top, map)| {
            let params = PrefilterParams { kappa_max: top as f32, ..Default::default() };
            (key, top, Arc::new(Prefiltered::build(&map, &params)))
        });
        let transport = self.transport.iter().filter_map(|j| Some((j.key, j.run().ok()?))).collect();
        PreparedEnvironment { env, transport }
    }
}

/// What an [`EnvironmentJob`] made, for [`Hybrid::install`].
#[derive(Clone, Debug)]
pub struct PreparedEnvironment {
    env: Option<(u64, u32, Arc<Prefiltered>)>,
    transport: Vec<(TransportKey, Arc<TransportLobes>)>,
}

/// How one object is drawn by [`Hybrid::render_drawn`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Drawn {
    /// The RSL path at the vertices, interpolated.
    Vertex,
    /// The RSL sum per pixel ([`rsl_shade::pixel`]).
    Pixel,
    /// vMF lobes × the RSL visibility ratio (per pixel when the image is drawn per pixel).
    Lobes,
    /// Transport lobes (the material's lobes shadowed by the object itself, per vertex and
    /// view in object space; [`rsl_lobe::transport`]), each shadowed by the other objects'
    /// occluder fields over a square of its width ([`lobe_half_diagonal`]) at the vertices;
    /// drawn per pixel as [`Drawn::Lobes`], with the ratio of that to the unshadowed material
    /// lobes.
    LobeFields,
}

/// `shadowed / bare` per channel in `[0, 1]` (0 where nothing reaches unshadowed): the
/// visibility ratio the lobes are multiplied by.
fn visibility_ratio(shadowed: Vec3, bare: Vec3) -> Vec3 {
    Vec3::select(bare.cmpgt(Vec3::ZERO), shadowed / bare.max(Vec3::splat(f32::MIN_POSITIVE)), Vec3::ZERO)
        .clamp(Vec3::ZERO, Vec3::ONE)
}

/// The half-diagonal of the square a vMF lobe of concentration `kappa` is shadowed over
/// ([`Drawn::LobeFields`]): the square of the lobe's solid angle `2π/κ` (the inverse of its
/// peak density `κ/2π`, for `κ ≫ 1`), `4r² = 2π/κ`, at most a hemisphere (`4r² = 2π`).
pub fn lobe_half_diagonal(kappa: f32) -> f32 {
    let hemisphere = std::f32::consts::FRAC_PI_2.sqrt();
    if kappa.is_finite() && kappa > 1.0 { (std::f32::consts::FRAC_PI_2 / kappa).sqrt() } else { hemisphere }
}

/// Every light's cover at every vertex of the objects `which` marks (to draw them per
/// pixel): bounded before it is made.
pub(crate) fn check_covers_size(engine: &Engine, setup: &rsl_shade::FrameSetup<'_>, which: &[bool]) -> Result<()> {
    let covered: u64 = (0..which.len()).filter(|&i| which[i]).map(|i| engine.mesh(i).vertex_count() as u64).sum();
    crate::engine::check_size(
        "drawing per pixel (every light's cover at every vertex)",
        "the RSL count or the meshes' vertices, or draw those objects with method \"rsl\"",
        covered * (4 * setup.light_count() as u64 + 12),
    )
}

/// Why a Lambertian object is drawn from its vertices (`rsl render --explain`).
/// Why an anisotropic object is drawn with the RSL sum per pixel by the lobe methods.
pub(crate) const ANISOTROPIC: &str =
    "anisotropic: the lobes fit isotropic BRDFs only, so the RSL sum per pixel draws it";

pub(crate) const LAMBERTIAN: &str = "Lambertian: its radiance varies no faster than its visibility and its BRDF \
     term is exact (per pixel only where a traced light's shadow falls)";

impl Drawn {
    /// How an object of `brdf` drawn so is drawn, in words, with the method's name.
    pub fn describe(self, brdf: &Brdf) -> &'static str {
        match self {
            Drawn::Vertex => "RSL at the vertices, interpolated (rsl)",
            Drawn::Pixel if brdf.is_lambertian() => "RSL at the vertices, interpolated (pixel)",
            Drawn::Pixel => "the RSL sum per pixel (pixel)",
            Drawn::Lobes => "vMF lobes × RSL visibility (hybrid)",
            Drawn::LobeFields => "transport lobes shadowed by the fields (lobe)",
        }
    }

    /// What an object of `brdf` asking for `method` gets: `auto` draws a glossy object per
    /// pixel; a Lambertian object never gets lobes (the RSL path's Lambertian term is exact
    /// where a cosine-fitted lobe is not), and is drawn per pixel only where that changes
    /// something, for the shadows of traced lights ([`rsl_shade::drawn_per_pixel`]); an
    /// anisotropic one, which the lobes cannot fit, gets the RSL sum per pixel.
    pub fn of(method: ObjectMethod, brdf: &Brdf) -> Self {
        if brdf.is_lambertian() {
            // Per pixel only for the shadows of traced lights ([`Hybrid::render_drawn`]).
            return if method == ObjectMethod::Rsl { Drawn::Vertex } else { Drawn::Pixel };
        }
        if brdf.is_anisotropic() && matches!(method, ObjectMethod::Hybrid | ObjectMethod::Lobe) {
            return Drawn::Pixel;
        }
        match method {
            ObjectMethod::Auto | ObjectMethod::RslPixel => Drawn::Pixel,
            ObjectMethod::Rsl => Drawn::Vertex,
            ObjectMethod::Hybrid => Drawn::Lobes,
            ObjectMethod::Lobe => Drawn::LobeFields,
        }
    }
}

impl Hybrid {
    /// How it draws each of `engine`'s objects: the lobes for glossy ones, the RSL path for
    /// Lambertian ones (on the GPU from their vertices: the RSL sum per pixel, which would
    /// trace their shadows of the traced lights pixel by pixel, is CPU-only).
    fn drawn(&self, engine: &Engine) -> Vec<Drawn> {
        let method = if self.fields { ObjectMethod::Lobe } else { ObjectMethod::Hybrid };
        (0..engine.object_count())
            .map(|i| match Drawn::of(method, engine.brdf(i)) {
                Drawn::Pixel if self.gpu.is_some() => Drawn::Vertex,
                d => d,
            })
            .collect()
    }

    /// A frame with each object drawn as `drawn` says (one per object); with `per_pixel`
    /// false, the image interpolates every object's vertices.
    pub fn render_drawn(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        request: &Request,
        drawn: &[Drawn],
        per_pixel: bool,
    ) -> Result<Frame> {
        let mut timings = Timings::default();
        let n = engine.object_count();
        anyhow::ensure!(drawn.len() == n, "{} drawing choices for {n} objects", drawn.len());
        // The lobes of the objects drawn with them, and the environment prefiltered for them.
        let start = Instant::now();
        let mut lobes: Vec<Option<Arc<MaterialLobes>>> = Vec::with_capacity(n);
        for (i, d) in drawn.iter().enumerate() {
            let with_lobes = matches!(d, Drawn::Lobes | Drawn::LobeFields);
            lobes.push(if with_lobes { Some(self.lobes(engine.brdf(i))?) } else { None });
        }
        let kappa_max =
            lobes.iter().flatten().flat_map(|l| l.lobes_per_view().map(|w| w.lobe.kappa)).fold(1.0f32, f32::max);
        let env = if lobes.iter().any(Option::is_some) { Some(self.environment(engine, kappa_max)) } else { None };
        if env.is_some() {
            timings.add("lobes", start.elapsed().as_secs_f64() * 1e3, None);
        }
        let start = Instant::now();
        let mut transport: Vec<Option<Arc<TransportLobes>>> = vec![None; n];
        for (i, l) in lobes.iter().enumerate() {
            if let (Some(l), Drawn::LobeFields) = (l, drawn[i]) {
                transport[i] = Some(self.transport(engine, i, l)?);
            }
        }
        if transport.iter().any(Option::is_some) {
            timings.add("transport", start.elapsed().as_secs_f64() * 1e3, None);
            // Only what this scene draws is kept: a viewer's material edits would otherwise
            // pile up a fit per edit (megabytes each).
            let used: Vec<TransportKey> = (0..n)
                .filter(|&i| transport[i].is_some())
                .map(|i| (engine.keys(i).mesh, brdf_key(engine.brdf(i)), self.no_self_shadows))
                .collect();
            self.transport.retain(|k, _| used.contains(k));
        }

        // Every object's RSL radiance at its vertices, with the covers of those drawn per pixel.
        let start = Instant::now();
        let state = scene.at(request.time);
        let eye = scene.camera.eye;
        let setup = engine.setup(scene, &state, eye, Terms::default())?;
        let drawn: Vec<Drawn> = (0..n)
            .map(|i| match drawn[i] {
                Drawn::Pixel if !rsl_shade::drawn_per_pixel(&setup, !engine.brdf(i).is_lambertian()) => Drawn::Vertex,
                d => d,
            })
            .collect();
        // The GPU draws the image when it has one and no object is drawn by the RSL sum per
        // pixel (CPU-only); else the CPU forms the hybrid's ratio at each pixel, from the RSL
        // sum there over the same unshadowed: the traced lights traced from the pixel, the
        // others' sums interpolated from the vertices.
        let gpu_draws = self.gpu.is_some() && request.image && per_pixel && !drawn.contains(&Drawn::Pixel);
        let pixel_ratio = per_pixel && request.image && !gpu_draws && !self.vertex_ratios;
        let with_covers: Vec<bool> = drawn.iter().map(|d| *d == Drawn::Pixel).collect();
        check_covers_size(engine, &setup, &with_covers)?;
        let (mut radiance, covers, mut stats) = rsl_shade::shade_covers(&setup, &with_covers);
        let rest: Vec<bool> = with_covers.iter().map(|c| !c).collect();
        let (rest_radiance, rest_untraced, rest_stats) = rsl_shade::shade_objects_untraced(&setup, &rest);
        // For the ratio at each pixel: per vertex, the untraced lights' radiance, shadowed.
        let untraced_shadowed: Vec<Option<Vec<Vec3>>> = rest_untraced
            .into_iter()
            .enumerate()
            .map(|(i, u)| (pixel_ratio && drawn[i] == Drawn::Lobes).then_some(u))
            .collect();
        stats = stats.plus(rest_stats);
        for (i, r) in rest_radiance.into_iter().enumerate() {
            if rest[i] {
                radiance[i] = r;
            }
        }
        let full = ShadedFrame::of(&setup, state, radiance, stats, 0.0);
        let mut radiance = full.radiance.clone();

        // The lobes' objects: unshadowed lobe radiance × the RSL visibility ratio.
        let mut ratios: Vec<Option<Vec<Vec3>>> = vec![None; n];
        // For the ratio at each pixel: per vertex, the untraced lights' radiance unshadowed (as
        // the unshadowed shading gives it).
        let mut untraced_bare: Vec<Option<Vec<Vec3>>> = vec![None; n];
        if let Some(env) = &env {
            let bare_setup =
                engine.setup(scene, &full.state, eye, Terms { self_visibility: false, occluders: false })?;
            // The other objects' fields alone: the transport lobes hold the object's own shadows.
            let others = match drawn.contains(&Drawn::LobeFields) {
                true => {
                    Some(engine.setup(scene, &full.state, eye, Terms { self_visibility: false, occluders: true })?)
                }
                false => None,
            };
            let which: Vec<bool> = (0..n).map(|i| lobes[i].is_some() && drawn[i] == Drawn::Lobes).collect();
            let (bare, mut bare_untraced, bare_stats) = rsl_shade::shade_objects_untraced(&bare_setup, &which);
            stats = stats.plus(bare_stats);
            let env_from_world = full.state.world_from_env.inverse();
            let intensity = engine.intensity();
            for (i, l) in lobes.iter().enumerate() {
                let Some(l) = l else { continue };
                let (pos, nor) = (&full.positions[i], &full.normals[i]);
                if drawn[i] == Drawn::LobeFields {
                    // The transport lobes (the object's own shadows fitted in), each shadowed
                    // by the other objects' fields over a square of its width: the radiance,
                    // and its ratio to the unshadowed material lobes for the pixels.
                    let t = transport[i].as_ref().expect("fitted for every LobeFields object");
                    let others = others.as_ref().expect("made when an object is drawn so");
                    let pose = Pose::new(&full.state.objects[i]);
                    let to_world = |d: Vec3| (pose.linear_to_world * d).normalize_or(d);
                    let per_vertex: Vec<(Vec3, Vec3, FrameStats)> = (0..pos.len())
                        .into_par_iter()
                        .map_init(Vec::new, |lobes: &mut Vec<WeightedLobe>, v| {
                            let to_eye = (eye - pos[v]).normalize_or_zero();
                            let frame = LocalFrame::from_normal(nor[v]);
                            let mut st = FrameStats::default();
                            if frame.to_local(to_eye).z <= 0.0 {
                                st.back_facing += 1;
                                return (Vec3::ZERO, Vec3::ZERO, st);
                            }
                            t.lobes_at(v, pose.direction_to_object(to_eye), lobes);
                            let squares: Vec<(Vec3, f32)> = lobes
                                .iter()
                                .map(|w| (to_world(w.lobe.mean), lobe_half_diagonal(w.lobe.kappa)))
                                .collect();
                            let mut covers = vec![0.0f32; squares.len()];
                            others.square_covers(i, v, &squares, &mut covers, &mut st);
                            let mut shadowed = Vec3::ZERO;
                            for ((w, (d, _)), c) in lobes.iter().zip(&squares).zip(&covers) {
                                shadowed += w.weight * env.lookup(env_from_world * *d, w.lobe.kappa) * *c;
                            }
                            let bare = l.radiance(env, &frame, to_eye, |d| env_from_world * d);
                            (shadowed * intensity, visibility_ratio(shadowed, bare), st)
                        })
                        .collect();
                    let shaded = per_vertex.iter().map(|p| p.0).collect();
                    let ratio = per_vertex.iter().map(|p| p.1).collect();
                    let lobe_stats = per_vertex.iter().fold(FrameStats::default(), |a, p| a.plus(p.2));
                    stats = stats.plus(lobe_stats);
                    radiance[i] = shaded;
                    ratios[i] = Some(ratio);
                    continue;
                }
                let ratio: Vec<Vec3> =
                    full.radiance[i].iter().zip(&bare[i]).map(|(s, u)| visibility_ratio(*s, *u)).collect();
                radiance[i] = (0..pos.len())
                    .into_par_iter()
                    .map(|v| {
                        let frame = LocalFrame::from_normal(nor[v]);
                        let view = (eye - pos[v]).normalize_or_zero();
                        l.radiance(env, &frame, view, |d| env_from_world * d) * intensity * ratio[v]
                    })
                    .collect();
                ratios[i] = Some(ratio);
                if untraced_shadowed[i].is_some() {
                    untraced_bare[i] = Some(std::mem::take(&mut bare_untraced[i]));
                }
            }
        }
        timings.add("shade", start.elapsed().as_secs_f64() * 1e3, None);

        let gpu_image = match (&mut self.gpu, &env) {
            (Some(gpu), Some(env_p)) if gpu_draws => {
                let top = kappa_max.clamp(1.0, 4096.0).log2().ceil().exp2() as u32;
                let env_key = engine.environment_key();
                if gpu.lobe_env != Some((env_key, top)) {
                    gpu.lobe_env = None;
                    gpu.draw
                        .set_lobe_environment(&PackedEnvironment::new(env_p))
                        .context("uploading the prefiltered environment")?;
                    gpu.lobe_env = Some((env_key, top));
                }
                let backdrop = (env_key, engine.intensity().to_bits());
                if gpu.backdrop != Some(backdrop) {
                    gpu.backdrop = None;
                    gpu.draw.set_backdrop(&crate::gpu::backdrop(engine)).context("uploading the environment map")?;
                    gpu.backdrop = Some(backdrop);
                }
                let packed: Vec<Option<PackedMaterial>> =
                    lobes.iter().map(|l| l.as_deref().map(PackedMaterial::new)).collect();
                let objects: Vec<LobeObject<'_>> = (0..n)
                    .map(|i| LobeObject {
                        positions: &full.positions[i],
                        normals: &full.normals[i],
                        indices: &scene.objects[i].mesh.indices,
                        material: packed[i].as_ref(),
                        values: ratios[i].as_deref().unwrap_or(radiance[i].as_slice()),
                    })
                    .collect();
                let env_from_world = glam::Mat3::from_quat(full.state.world_from_env.inverse());
                let start = Instant::now();
                let pass = gpu.draw.draw_lobes(&objects, &scene.camera, env_from_world, eye, engine.intensity())?;
                let (pixels, covered) = gpu.draw.read_linear()?;
                timings.add("draw per pixel (GPU)", start.elapsed().as_secs_f64() * 1e3, pass.gpu_ms);
                Some(rsl_shade::Image { width: scene.camera.width, height: scene.camera.height, pixels, covered })
            }
            _ => None,
        };
        let image = gpu_image.or_else(|| {
            request.image.then(|| {
                if !per_pixel || drawn.iter().all(|d| *d == Drawn::Vertex) {
                    return timings.time("draw", || rasterise(engine, scene, &full.state, &full.positions, &radiance));
                }
                timings.time("draw per pixel", || {
                    let frames: Vec<Option<Vec<LocalFrame>>> = (0..n)
                        .map(|i| match drawn[i] {
                            Drawn::Vertex => None,
                            // The RSL sum reads its tables in the vertices' shading frames.
                            Drawn::Pixel => {
                                Some((0..full.positions[i].len()).map(|v| setup.shading_frame(i, v)).collect())
                            }
                            Drawn::Lobes | Drawn::LobeFields => {
                                Some(full.normals[i].iter().map(|&n| LocalFrame::from_normal(n)).collect())
                            }
                        })
                        .collect();
                    let meshes: Vec<PixelMesh<'_>> = scene
                        .objects
                        .iter()
                        .enumerate()
                        .map(|(i, o)| PixelMesh {
                            positions: &full.positions[i],
                            indices: &o.mesh.indices,
                            frames: frames[i].as_deref(),
                            radiance: &radiance[i],
                        })
                        .collect();
                    let env_from_world = full.state.world_from_env.inverse();
                    let intensity = engine.intensity();
                    let lights = setup.light_count();
                    rsl_shade::draw_pixels(
                        &scene.camera,
                        &meshes,
                        || vec![0.0f32; lights],
                        |p, buf| match (&covers[p.object], &lobes[p.object], &env, &ratios[p.object]) {
                            (Some(c), ..) => rsl_shade::point_radiance(
                                &setup,
                                c,
                                &meshes[p.object],
                                p,
                                buf,
                                &mut FrameStats::default(),
                            ),
                            (None, Some(l), Some(env), Some(ratio)) => {
                                let indices = meshes[p.object].indices;
                                let ratio = match (&untraced_shadowed[p.object], &untraced_bare[p.object]) {
                                    // The ratio at the pixel: the RSL sum there over the same
                                    // unshadowed, the traced lights traced and looked up at
                                    // the pixel, the others' sums interpolated from the
                                    // vertices.
                                    (Some(rest), Some(rest_bare)) => {
                                        let mut st = FrameStats::default();
                                        let (traced, traced_bare) =
                                            rsl_shade::traced_at_point(&setup, &meshes[p.object], p, buf, &mut st);
                                        visibility_ratio(
                                            p.fragment.interpolate(indices, rest) + traced,
                                            p.fragment.interpolate(indices, rest_bare) + traced_bare,
                                        )
                                    }
                                    _ => p.fragment.interpolate(indices, ratio),
                                };
                                let view = (eye - p.position).normalize_or_zero();
                                l.radiance(env, &p.frame, view, |d| env_from_world * d) * intensity * ratio
                            }
                            _ => Vec3::ZERO,
                        },
                        |d| engine.background(&full.state, d),
                    )
                })
            })
        });
        Ok(Frame {
            state: full.state,
            positions: full.positions,
            normals: full.normals,
            radiance,
            std_error: None,
            image,
            encoded: None,
            self_error: None,
            stats,
            shadow_rays: 0,
            timings,
        })
    }
}

impl Method for Hybrid {
    fn describe(&self) -> String {
        let threads = rayon::current_num_threads();
        let what = if self.fields { "vMF lobes shadowed by the fields" } else { "vMF lobes × RSL visibility" };
        match self.gpu_adapter() {
            Some(a) => format!("{what}: vertices on the CPU ({threads} threads), pixels on {a}"),
            None => format!("{what} on the CPU ({threads} threads)"),
        }
    }

    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        let drawn = self.drawn(engine);
        let per_pixel = self.per_pixel;
        self.render_drawn(engine, scene, request, &drawn, per_pixel)
    }

    fn explain(&mut self, engine: &Engine, scene: &Scene) -> Result<Vec<String>> {
        engine.check(scene)?;
        let drawn = self.drawn(engine);
        Ok(scene
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| {
                let brdf = engine.brdf(i);
                let why = if brdf.is_lambertian() {
                    LAMBERTIAN
                } else if brdf.is_anisotropic() {
                    ANISOTROPIC
                } else {
                    "glossy: the method's lobes"
                };
                format!("{}: {} — {why}", o.name, drawn[i].describe(brdf))
            })
            .collect())
    }

    fn preparation(&mut self, engine: &Engine) -> Result<Option<Preparation>> {
        Ok(self.environment_job(engine)?.map(|job| Preparation::new(move || Box::new(job.run()) as Prepared)))
    }

    fn install(&mut self, prepared: Prepared) {
        if let Ok(p) = prepared.downcast::<PreparedEnvironment>() {
            Hybrid::install(self, *p);
        }
    }
}

//! The hybrid of the lobe path and the RSL path (rsl-lobe; variant (b) of the lobe path): per
//! vertex, the unshadowed glossy radiance from the material's vMF lobes over the prefiltered
//! environment, times the RSL path's visibility ratio `Σ_i E_i·B̄_i·V̄_i / Σ_i E_i·B̄_i` (the
//! ratio estimator of Heitz et al. 2018, with RSL visibility in place of rays), per channel;
//! at the vertices, the lobes clipped by the vertex's face mask ([`rsl_lobe::vmf::mask_share`])
//! and the ratio formed without it.
//!
//! Beside it, the lobe path with its own shadows (`method = "lobe"`, variant (a),
//! [`LobeDrawing`] with fields): transport lobes (Green et al. 2006) carry the object's own
//! shadows, and each lobe is shadowed by the other objects' occluder fields over a square of
//! its width, but for the traced lights' (the suns') part of it, shadowed by their own rays.
//!
//! The lobes are meant to carry what a square light cannot, the environment's detail inside
//! a lobe narrower than the squares; the ratio carries the shadows, self and from other
//! objects, weighted as the RSL path weighs them. Measured (rsl-lobe README), the lobes do
//! not reproduce a microfacet lobe well enough to beat the RSL sum per pixel on the bundled
//! scenes under suns; they do where the light is smooth and the lobe narrower than the
//! squares (a white furnace, a near-mirror reflecting a sharp horizon). `auto`
//! ([`Composite::auto`]) chooses per object by measuring both against the truth on a sample
//! of the object's pixels ([`Composite::auto_estimate`]).
//!
//! Prepared once and kept: the environment prefiltered up to the sharpest lobe the scene's
//! materials need (`κ` rounded up to a power of two, at most 4096), and each material's lobes
//! (refitted when its parameters change). Each object's transport lobes are also kept in the
//! disk cache (`tlobe-<key>.bin`, [`crate::cache`]), keyed by its mesh, frames and material:
//! a later run, or another method instance, reads them back instead of fitting them again.
//!
//! Images ([`Composite::per_pixel`], the default): each pixel of a glossy object looks its lobes
//! up for its own interpolated normal and view (one prefiltered lookup per lobe), times the
//! ratio at the pixel: the RSL sum there, as `--method pixel` draws it (every light's cover
//! interpolated from the vertices, a traced light's traced from the pixel), over the same
//! sum unshadowed ([`rsl_shade::draw_pixels`]). With a GPU ([`Composite::on_gpu`]) its draw pass
//! (`shaders/draw/lobes.wgsl`) looks the lobes up per pixel and interpolates the ratio from
//! the vertices; the objects drawn by the RSL sum per pixel are shaded and drawn on the GPU
//! in the same pass (`shaders/draw/pixels.wgsl`).

use crate::compose::{FrameContext, GpuImage, GpuLobe, GpuObject, ObjectDrawing, Part, PixelShader};
use crate::engine::{Engine, EnvRadiance};
use crate::gpu::GpuRenderer;
use crate::progress::Timings;
use anyhow::{Context, Result};
use glam::Vec3;
use rayon::prelude::*;
use rsl_brdf::Brdf;
use rsl_gpu::GpuContext;
use rsl_gpu::lobes::LobeObject;
use rsl_lobe::{
    FitParams, MaterialLobes, PackedEnvironment, PackedMaterial, PrefilterParams, Prefiltered, TransportLobes,
    TransportParams, WeightedLobe,
};
use rsl_shade::{FrameStats, PixelMesh, PixelPoint, Pose, Terms};
use rsl_sphere::Frame as LocalFrame;
use rsl_sphere::faces::IncidentFaces;
use rsl_sphere::latlong::LatLongMap;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

pub use crate::auto::{Composite, LOBE_RATIO, drawn_by, typical_square};

/// The lobes as a drawing ([`ObjectDrawing`]): variant (b), the material's vMF lobes times
/// the RSL path's visibility ratio (method `hybrid`), or with `fields` variant (a), the
/// transport lobes shadowed by the other objects' fields (method `lobe`). It holds what it
/// prepared: the prefiltered environment, each material's lobes, each object's transport
/// lobes.
#[derive(Default)]
pub struct LobeDrawing {
    /// Transport lobes shadowed by the fields (variant (a)) instead of the material lobes
    /// times the ratio.
    fields: bool,
    /// In images drawn on the CPU, interpolate the visibility ratio from the vertices, as the
    /// GPU draw pass does, instead of forming it at each pixel.
    vertex_ratios: bool,
    env: Option<(u64, u32, Arc<Prefiltered>)>,
    materials: HashMap<u64, Arc<MaterialLobes>>,
    /// Fit the transport lobes with nothing of the object in the way (`V_self = 1`).
    no_self_shadows: bool,
    transport: HashMap<TransportKey, Arc<TransportLobes>>,
    /// Transport lobes fitted so far, here or by its jobs on other threads (not read from the
    /// disk cache).
    fitted: Arc<std::sync::atomic::AtomicU64>,
    /// Per mesh (its key), its vertices' incident faces: the face mask the hybrid's lobes
    /// are clipped by at the vertices.
    faces: HashMap<u64, Arc<IncidentFaces>>,
    /// What [`ObjectDrawing::prepare`] readied for the frame: per object its lobes and
    /// transport lobes.
    frame: PreparedFrame,
}

/// The lobes readied for one frame's objects.
#[derive(Default)]
struct PreparedFrame {
    lobes: Vec<Option<Arc<MaterialLobes>>>,
    transport: Vec<Option<Arc<TransportLobes>>>,
}

/// The GPU passes of [`Composite::on_gpu`] and what they hold: the shading pass (for the
/// objects drawn by the RSL sum per pixel) and the draw pass.
pub(crate) struct GpuLobes {
    renderer: GpuRenderer,
    /// The prefiltered environment uploaded: (content key, top κ).
    lobe_env: Option<(u64, u32)>,
}

impl LobeDrawing {
    /// The hybrid's lobes, or with `fields` the lobe path's; nothing prepared yet.
    pub fn new(fields: bool) -> Self {
        Self { fields, ..Self::default() }
    }

    /// Fits the transport lobes as if the object did not shadow itself (`V_self = 1`).
    pub fn set_no_self_shadows(&mut self) {
        self.no_self_shadows = true;
        self.transport.clear();
    }

    /// Interpolates the visibility ratio of images drawn on the CPU from the vertices.
    pub fn set_vertex_ratios(&mut self) {
        self.vertex_ratios = true;
    }

    /// How many objects' transport lobes are held.
    pub fn transport_held(&self) -> usize {
        self.transport.len()
    }

    /// How many objects' transport lobes it (or a job it made) has fitted so far, rather than
    /// read from the disk cache.
    pub fn transport_fitted(&self) -> u64 {
        self.fitted.load(std::sync::atomic::Ordering::Relaxed)
    }
    /// The material lobes of `brdf` (fitted once per parameter set).
    pub(crate) fn lobes(&mut self, brdf: &Brdf) -> Result<Arc<MaterialLobes>> {
        let key = brdf.key();
        if let Some(l) = self.materials.get(&key) {
            return Ok(l.clone());
        }
        let l = Arc::new(MaterialLobes::fit(brdf, &FitParams::default()).map_err(anyhow::Error::msg)?);
        self.materials.insert(key, l.clone());
        Ok(l)
    }

    /// Object `i`'s incident faces (found once per mesh).
    fn incident_faces(&mut self, engine: &Engine, i: usize) -> Arc<IncidentFaces> {
        let key = engine.keys(i).mesh;
        self.faces.entry(key).or_insert_with(|| Arc::new(IncidentFaces::of(engine.mesh(i)))).clone()
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
        let key = (engine.keys(i).mesh, engine.brdf(i).key(), self.no_self_shadows);
        if let Some(t) = self.transport.get(&key) {
            return Ok(Err(t.clone()));
        }
        let mesh = engine.mesh(i);
        crate::engine::check_size(
            "the transport lobes (per vertex and view)",
            "the object's vertices, or draw it with method \"hybrid\"",
            (TransportLobes::bytes_per_vertex(material, &TransportParams::default()) * mesh.vertex_count()) as u64,
        )?;
        let file = engine.cache_dir().map(|d| {
            let disk = transport_disk_key(engine, i, self.no_self_shadows);
            (d.join(format!("tlobe-{disk:016x}.bin")), disk)
        });
        Ok(Ok(TransportJob {
            key,
            file,
            cache_limit: engine.cache_limit(),
            fitted: self.fitted.clone(),
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
    /// path ([`Composite::lobe`]) the glossy objects' transport lobes, as a job to run on
    /// another thread and give back with [`LobeDrawing::install`]; `None` when what is held
    /// suffices. A viewer runs it on a worker so that its frames keep coming.
    pub fn environment_job(&mut self, engine: &Engine) -> Result<Option<EnvironmentJob>> {
        let mut kappa_max = 1.0f32;
        for i in 0..engine.object_count() {
            if !engine.brdf(i).is_lambertian() {
                let l = self.lobes(engine.brdf(i))?;
                kappa_max = l.lobes_per_view().map(|w| w.lobe.kappa).fold(kappa_max, f32::max);
            }
        }
        let env = self.environment_need(engine, kappa_max);
        let transport = match self.fields {
            true => self.transport_list(engine, &vec![true; engine.object_count()])?,
            false => Vec::new(),
        };
        Ok((env.is_some() || !transport.is_empty()).then_some(EnvironmentJob { env, transport }))
    }

    /// The fits of the transport lobes of the glossy objects `which` marks that the lobe
    /// path draws with them (not anisotropic ones) and that are not held yet, as a job
    /// ([`LobeDrawing::environment_job`] without the environment); `None` when every one is
    /// held.
    pub fn transport_jobs(&mut self, engine: &Engine, which: &[bool]) -> Result<Option<EnvironmentJob>> {
        let transport = self.transport_list(engine, which)?;
        Ok((!transport.is_empty()).then_some(EnvironmentJob { env: None, transport }))
    }

    /// [`LobeDrawing::transport_jobs`]'s jobs.
    fn transport_list(&mut self, engine: &Engine, which: &[bool]) -> Result<Vec<TransportJob>> {
        let mut transport = Vec::new();
        for i in (0..engine.object_count()).filter(|&i| which.get(i).copied().unwrap_or(false)) {
            let brdf = engine.brdf(i);
            if brdf.is_lambertian() || brdf.is_anisotropic() {
                continue;
            }
            let l = self.lobes(brdf)?;
            if let Ok(job) = self.transport_job(engine, i, &l)? {
                transport.push(job);
            }
        }
        Ok(transport)
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
            if self.fields && key.2 == self.no_self_shadows {
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

/// The disk cache's content key of object `i`'s transport lobes: its mesh and vertex frames
/// bit for bit, its material, the fits' parameters and versions, and whether it shadows itself.
fn transport_disk_key(engine: &Engine, i: usize, no_self_shadows: bool) -> u64 {
    let (t, m) = (TransportParams::default(), FitParams::default());
    let frames: Vec<u32> = engine
        .frames(i)
        .visibility
        .iter()
        .flat_map(|f| [f.t, f.b, f.n])
        .flat_map(|v| v.to_array().map(f32::to_bits))
        .collect();
    crate::cache::KeyHasher::default()
        .str("transport")
        .u64(u64::from(crate::cache::TRANSPORT_VERSION))
        .u64(u64::from(rsl_lobe::transport::FIT_VERSION))
        .u64(engine.keys(i).mesh)
        .words(&frames)
        .u64(engine.brdf(i).key())
        .u64(u64::from(no_self_shadows))
        .u64(u64::from(t.frequency))
        .u64(t.samples as u64)
        .u64(t.diffuse_samples as u64)
        .u64(m.views as u64)
        .u64(m.samples as u64)
        .finish()
}

/// Fitting one object's transport lobes ([`rsl_lobe::transport`]): `Send`, to run anywhere.
#[derive(Clone)]
struct TransportJob {
    key: TransportKey,
    /// The disk cache's file and content key ([`transport_disk_key`]), where there is a cache.
    file: Option<(std::path::PathBuf, u64)>,
    /// The cache folder's bound ([`Engine::cache_limit`]).
    cache_limit: u64,
    /// Counts the fits ([`LobeDrawing::transport_fitted`]).
    fitted: Arc<std::sync::atomic::AtomicU64>,
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
    /// Read from the disk cache where an earlier fit left them (a file that does not verify,
    /// or was fitted for another mesh, is reported, removed and fitted again), else fitted
    /// and written there.
    fn run(&self) -> Result<Arc<TransportLobes>> {
        if let Some((path, key)) = &self.file
            && path.exists()
        {
            let task = format!("reading the transport lobes of object {} from the cache", self.object);
            match self.progress.task(&task, |_| self.read(path, *key)) {
                Ok(t) => {
                    crate::cache::used(path);
                    return Ok(Arc::new(t));
                }
                Err(why) => {
                    tracing::warn!("cache file {} rejected ({why}); fitting again", path.display());
                    let _ = std::fs::remove_file(path);
                }
            }
        }
        let fit = self.fit()?;
        self.fitted.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        if let Some((path, key)) = &self.file {
            match crate::cache::write(path, &crate::cache::transport_to_bytes(&fit, *key)) {
                Ok(()) => crate::cache::stored(path, self.cache_limit),
                Err(e) => tracing::warn!("the transport lobes of object {} are not cached: {e:#}", self.object),
            }
        }
        Ok(Arc::new(fit))
    }

    /// The lobes in `path`, checked against `key` and against this object.
    fn read(&self, path: &std::path::Path, key: u64) -> Result<TransportLobes, String> {
        let bytes = rsl_sphere::io::read_bounded(path, rsl_sphere::io::MAX_DATA_BYTES).map_err(|e| e.to_string())?;
        let t = crate::cache::transport_from_bytes(&bytes, key)?;
        let per_view = if self.material.brdf().is_lambertian() { 0 } else { rsl_lobe::SPECULAR_LOBES };
        let views = rsl_lobe::transport::geodesic_views(TransportParams::default().frequency).len();
        if (t.vertex_count(), t.views().len(), t.specular_per_view()) != (self.mesh.vertex_count(), views, per_view) {
            return Err(format!(
                "fitted for {} vertices × {} views × {} lobes, the object has {} × {views} × {per_view}",
                t.vertex_count(),
                t.views().len(),
                t.specular_per_view(),
                self.mesh.vertex_count()
            ));
        }
        Ok(t)
    }

    /// Fits the lobes.
    fn fit(&self) -> Result<TransportLobes> {
        let mesh = &self.mesh;
        let occluder =
            rsl_vis::rays::Occluder::new(mesh).map_err(|e| anyhow::anyhow!("object {}: {e}", self.object))?;
        let faces = IncidentFaces::of(mesh);
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
        Ok(self.progress.task(&task, |report| TransportLobes::fit(&self.material, frames, &params, visible, report)))
    }
}

/// The preparation a [`LobeDrawing`] needs ([`LobeDrawing::environment_job`]): `Send`, to run anywhere.
#[derive(Clone, Debug)]
pub struct EnvironmentJob {
    env: Option<(u64, u32, Arc<LatLongMap>)>,
    transport: Vec<TransportJob>,
}

impl EnvironmentJob {
    /// This job and `other`'s transport fits (its environment too where this one has none).
    pub fn with(mut self, other: EnvironmentJob) -> Self {
        self.env = self.env.or(other.env);
        self.transport.extend(other.transport);
        self
    }

    /// How many objects' transport lobes it fits.
    pub fn transport_count(&self) -> usize {
        self.transport.len()
    }

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

/// What an [`EnvironmentJob`] made, for [`LobeDrawing::install`].
#[derive(Clone, Debug)]
pub struct PreparedEnvironment {
    env: Option<(u64, u32, Arc<Prefiltered>)>,
    transport: Vec<(TransportKey, Arc<TransportLobes>)>,
}

/// `shadowed / bare` per channel in `[0, 1]` (0 where nothing reaches unshadowed): the
/// visibility ratio the lobes are multiplied by.
fn visibility_ratio(shadowed: Vec3, bare: Vec3) -> Vec3 {
    Vec3::select(bare.cmpgt(Vec3::ZERO), shadowed / bare.max(Vec3::splat(f32::MIN_POSITIVE)), Vec3::ZERO)
        .clamp(Vec3::ZERO, Vec3::ONE)
}

/// What the RSL sums must see of the light the hybrid's lobes see at a vertex, relative to
/// it, for their visibility ratio to be taken: below, each lobe's own square's cover is
/// blended in ([`lobe_half_diagonal`]; `FrameSetup::square_covers`). Where the squares see
/// next to nothing of a lobe — one narrower than the squares, in a gap between them — their
/// ratio is one of far tails: a white furnace's Beckmann α = 0.05 vertex had 8·10⁻³⁵
/// shadowed over 8·10⁻³⁴ bare (the face mask's covers of squares far from the lobe), drawn at
/// 0.07 against the truth's 0.67.
pub const RATIO_FLOOR: f32 = 1e-4;

/// The RSL sums' ratio `shadowed / bare` for lobes that see `lobes` unshadowed, where the
/// squares see at least [`RATIO_FLOOR`] of it; below, blended toward `fallback` (called only
/// then) by the share they see, all of it where they see nothing.
fn floored_ratio(shadowed: Vec3, bare: Vec3, lobes: Vec3, fallback: impl FnOnce() -> Vec3) -> Vec3 {
    let ratio = visibility_ratio(shadowed, bare);
    let floor = RATIO_FLOOR * lobes;
    if !bare.cmplt(floor).any() {
        return ratio;
    }
    let seen = (bare / floor.max(Vec3::splat(f32::MIN_POSITIVE))).clamp(Vec3::ZERO, Vec3::ONE);
    ratio * seen + fallback() * (Vec3::ONE - seen)
}

/// The half-diagonal of the square a vMF lobe of concentration `kappa` is shadowed over
/// (the lobe path): the square of the lobe's solid angle `2π/κ` (the inverse of its
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

impl ObjectDrawing for LobeDrawing {
    fn describe(&self, _: &Brdf) -> String {
        if self.fields { "transport lobes shadowed by the fields" } else { "vMF lobes × RSL visibility" }.into()
    }

    fn on_gpu(&self) -> bool {
        true
    }

    /// Each object's lobes (its transport lobes for the lobe path) and the environment
    /// prefiltered for the sharpest.
    fn prepare(&mut self, engine: &Engine, which: &[bool], timings: &mut Timings) -> Result<()> {
        let start = Instant::now();
        let n = which.len();
        let mut lobes = Vec::with_capacity(n);
        for (i, &w) in which.iter().enumerate() {
            lobes.push(if w { Some(self.lobes(engine.brdf(i))?) } else { None });
        }
        let kappa_max =
            lobes.iter().flatten().flat_map(|l| l.lobes_per_view().map(|w| w.lobe.kappa)).fold(1.0f32, f32::max);
        if lobes.iter().any(Option::is_some) {
            self.environment(engine, kappa_max);
            timings.add("lobes", start.elapsed().as_secs_f64() * 1e3, None);
        }
        let start = Instant::now();
        let mut transport: Vec<Option<Arc<TransportLobes>>> = vec![None; n];
        if self.fields {
            for (i, l) in lobes.iter().enumerate() {
                if let Some(l) = l {
                    transport[i] = Some(self.transport(engine, i, l)?);
                }
            }
        }
        if transport.iter().any(Option::is_some) {
            timings.add("transport", start.elapsed().as_secs_f64() * 1e3, None);
            // Only what this scene draws is kept: a viewer's material edits would otherwise
            // pile up a fit per edit (megabytes each).
            let used: Vec<TransportKey> = (0..n)
                .filter(|&i| transport[i].is_some())
                .map(|i| (engine.keys(i).mesh, engine.brdf(i).key(), self.no_self_shadows))
                .collect();
            self.transport.retain(|k, _| used.contains(k));
        }
        self.frame = PreparedFrame { lobes, transport };
        Ok(())
    }

    /// The hybrid: unshadowed lobe radiance × the RSL visibility ratio at the vertices (and
    /// per pixel, the ratio formed at the pixel); the lobe path: the transport lobes, each
    /// shadowed by the other objects' fields.
    fn shade<'f>(
        &mut self,
        ctx: &FrameContext<'f>,
        which: &[bool],
        stats: &mut FrameStats,
    ) -> Result<Vec<Option<Part<'f>>>> {
        let n = which.len();
        let (engine, eye) = (ctx.engine, ctx.eye());
        let env = self.env.as_ref().map(|e| e.2.clone()).context("the lobes were not prepared")?;
        let env_key = (engine.environment_key(), self.env.as_ref().map_or(0, |e| e.1));
        let env_from_world = ctx.state.world_from_env.inverse();
        let intensity = engine.intensity();
        let mut parts: Vec<Option<Part<'f>>> = (0..n).map(|_| None).collect();
        let shader = |material, normals, ratio, untraced| LobeShader {
            setup: ctx.setup,
            view: (eye, env_from_world, intensity),
            env: (env.clone(), env_key),
            material,
            normals,
            ratio,
            untraced,
        };
        if self.fields {
            // The other objects' fields alone: the transport lobes hold the object's own shadows.
            let others = engine.setup(ctx.scene, ctx.state, eye, Terms { self_visibility: false, occluders: true })?;
            // The traced lights (the suns): each one's part of a lobe's lookup is shadowed by
            // its own rays, not by the lobe's square. A square half above another object's
            // horizon would otherwise let half of a sun below it through. Per light: its
            // index, direction, solid angle (4r²) and radiance in the map's units.
            let suns: Vec<(usize, Vec3, f64, Vec3)> = if intensity > 0.0 {
                others
                    .traced_lights()
                    .into_iter()
                    .map(|l| {
                        let light = others.light(l);
                        let r = f64::from(light.half_diagonal);
                        (l, light.dir, 4.0 * r * r, light.radiance / intensity)
                    })
                    .collect()
            } else {
                Vec::new()
            };
            for i in (0..n).filter(|&i| which[i]) {
                let l = self.frame.lobes[i].clone().context("the lobes were not prepared")?;
                let t = self.frame.transport[i].as_ref().context("the transport lobes were not prepared")?;
                let (pos, nor) = (&ctx.positions[i], &ctx.normals[i]);
                // The frames the transport lobes were fitted in (`TransportJob::run`).
                let fit_frames = &engine.frames(i).visibility;
                let pose = Pose::new(&ctx.state.objects[i]);
                let to_world = |d: Vec3| (pose.linear_to_world * d).normalize_or(d);
                // The transport lobes (the object's own shadows fitted in), each shadowed by
                // the other objects' fields over a square of its width: the radiance, and
                // its ratio to the unshadowed material lobes for the pixels.
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
                        t.lobes_following(&l, &fit_frames[v], v, pose.direction_to_object(to_eye), lobes);
                        let squares: Vec<(Vec3, f32)> =
                            lobes.iter().map(|w| (to_world(w.lobe.mean), lobe_half_diagonal(w.lobe.kappa))).collect();
                        let mut covers = vec![0.0f32; squares.len()];
                        others.square_covers(i, v, &squares, &mut covers, &mut st);
                        let sun_covers: Vec<f32> =
                            suns.iter().map(|s| others.traced_cover(i, v, s.0, &mut st.traced_rays)).collect();
                        let mut shadowed = Vec3::ZERO;
                        for ((w, (d, _)), c) in lobes.iter().zip(&squares).zip(&covers) {
                            let lookup = env.lookup(env_from_world * *d, w.lobe.kappa);
                            // Each sun's part of the lookup: its square under the lobe (at
                            // most its whole radiance), within what the lookup holds.
                            let (mut sun, mut sun_shadowed) = (Vec3::ZERO, Vec3::ZERO);
                            for ((_, dir, solid, radiance), cover) in suns.iter().zip(&sun_covers) {
                                let cos = f64::from(d.dot(*dir));
                                let share = (rsl_lobe::vmf::density_at(f64::from(w.lobe.kappa), cos) * solid).min(1.0);
                                let part = (*radiance * share as f32).min(lookup - sun).max(Vec3::ZERO);
                                sun += part;
                                sun_shadowed += part * *cover;
                            }
                            shadowed += w.weight * ((lookup - sun) * *c + sun_shadowed);
                        }
                        let bare = l.radiance(&env, &frame, to_eye, |d| env_from_world * d);
                        (shadowed * intensity, visibility_ratio(shadowed, bare), st)
                    })
                    .collect();
                *stats = per_vertex.iter().fold(*stats, |a, p| a.plus(p.2));
                let shader = shader(l, nor, per_vertex.iter().map(|p| p.1).collect(), None);
                let radiance = per_vertex.iter().map(|p| p.0).collect();
                parts[i] = Some(Part::per_pixel(radiance, Box::new(shader)));
            }
            return Ok(parts);
        }
        // The RSL sum with every term and without any: their ratio is the visibility the
        // lobes are multiplied by; per vertex, each with its untraced lights' part for the
        // ratio at each pixel. The lobes are clipped by the vertex's face mask at their own
        // scale at the vertices (below), so there the ratio is formed from the sums whose own
        // part leaves the mask out: a square straddling the horizon would take it again
        // (a near-mirror ball's vertices seen at 65–80° lost 2–7 % to it in a furnace). The
        // pixels' lobes are not clipped; their ratio keeps the mask.
        let rsl_shade::MaskedSums { untraced, unmasked, stats: full_stats, .. } =
            rsl_shade::shade_objects_masked_and_not(ctx.setup, which);
        let bare_setup = engine.setup(ctx.scene, ctx.state, eye, Terms { self_visibility: false, occluders: false })?;
        let (bare, bare_untraced, bare_stats) = rsl_shade::shade_objects_untraced(&bare_setup, which);
        *stats = stats.plus(full_stats).plus(bare_stats);
        let ratio_at_pixels = ctx.image_per_pixel() && !self.vertex_ratios;
        for (i, (untraced, bare_untraced)) in untraced.into_iter().zip(bare_untraced).enumerate() {
            if !which[i] {
                continue;
            }
            let l = self.frame.lobes[i].clone().context("the lobes were not prepared")?;
            let (pos, nor) = (&ctx.positions[i], &ctx.normals[i]);
            // The lobes clipped by the vertex's face mask, as the truth weighs a vertex's
            // directions ([`rsl_lobe::vmf::mask_share`]): a near-mirror seen at a grazing angle
            // reflects a direction within a few degrees of its plane, below some of its faces'
            // planes.
            let faces = self.incident_faces(engine, i);
            let pose = Pose::new(&ctx.state.objects[i]);
            let setup = ctx.setup;
            let (radiance, ratio): (Vec<Vec3>, Vec<Vec3>) = (0..pos.len())
                .into_par_iter()
                .map_init(Vec::new, |around: &mut Vec<(Vec3, f32)>, v| {
                    let frame = LocalFrame::from_normal(nor[v]);
                    let view = (eye - pos[v]).normalize_or_zero();
                    let to_env = |d| env_from_world * d;
                    around.clear();
                    around.extend(faces.faces(v).map(|(n, w)| (pose.normal(n), w)));
                    let share = |g: rsl_lobe::vmf::Vmf| rsl_lobe::vmf::mask_share(g.mean, g.kappa, nor[v], around);
                    let lobes = l.radiance_masked(&env, &frame, view, to_env, share) * intensity;
                    // Where the squares see next to nothing of what the lobes see, each
                    // lobe's own square instead (the lobe path's: its width, the fields and
                    // the face mask over it).
                    let own = || {
                        let cover = |g: rsl_lobe::vmf::Vmf| {
                            let (mut c, mut stats) = ([1.0f32], FrameStats::default());
                            setup.square_covers(i, v, &[(g.mean, lobe_half_diagonal(g.kappa))], &mut c, &mut stats);
                            f64::from(c[0])
                        };
                        visibility_ratio(l.radiance_masked(&env, &frame, view, to_env, cover) * intensity, lobes)
                    };
                    let ratio = floored_ratio(unmasked[i][v], bare[i][v], lobes, own);
                    (lobes * ratio, ratio)
                })
                .unzip();
            let shader = shader(l, nor, ratio, ratio_at_pixels.then_some((untraced, bare_untraced)));
            parts[i] = Some(Part::per_pixel(radiance, Box::new(shader)));
        }
        Ok(parts)
    }
}

/// A pixel shader of [`LobeDrawing`]: the pixel's lobes for its own interpolated normal and
/// view, times the visibility ratio — interpolated from the vertices, or formed at the pixel
/// (`untraced`: the RSL sum there over the same unshadowed, the traced lights traced and
/// looked up at the pixel, the others' sums interpolated from the vertices).
struct LobeShader<'f> {
    setup: &'f rsl_shade::FrameSetup<'f>,
    /// The eye, the environment's rotation from world space, its intensity.
    view: (Vec3, glam::Quat, f32),
    /// The prefiltered environment, its key and top κ.
    env: (Arc<Prefiltered>, (u64, u32)),
    material: Arc<MaterialLobes>,
    normals: &'f [Vec3],
    ratio: Vec<Vec3>,
    /// Per vertex, the untraced lights' radiance shadowed and unshadowed.
    untraced: Option<(Vec<Vec3>, Vec<Vec3>)>,
}

impl PixelShader for LobeShader<'_> {
    fn frames(&self) -> Vec<LocalFrame> {
        self.normals.iter().map(|&n| LocalFrame::from_normal(n)).collect()
    }

    fn shade(&self, mesh: &PixelMesh<'_>, p: &PixelPoint<'_>, buf: &mut [f32]) -> Vec3 {
        let indices = mesh.indices;
        let (eye, env_from_world, intensity) = self.view;
        let view = (eye - p.position).normalize_or_zero();
        let lobes = self.material.radiance(&self.env.0, &p.frame, view, |d| env_from_world * d) * intensity;
        let at_vertices = || p.fragment.interpolate(indices, &self.ratio);
        let ratio = match &self.untraced {
            Some((rest, rest_bare)) => {
                let mut st = FrameStats::default();
                let (traced, traced_bare) = rsl_shade::traced_at_point(self.setup, mesh, p, buf, &mut st);
                let shadowed = p.fragment.interpolate(indices, rest) + traced;
                // Where the squares see next to nothing of the lobes, the vertices' ratios
                // (their lobes' own squares blended in).
                floored_ratio(shadowed, p.fragment.interpolate(indices, rest_bare) + traced_bare, lobes, at_vertices)
            }
            None => at_vertices(),
        };
        lobes * ratio
    }

    fn gpu_lobes(&self) -> Option<GpuLobe<'_>> {
        Some(GpuLobe { material: &self.material, values: &self.ratio, env: (&*self.env.0, self.env.1) })
    }
}

impl GpuLobes {
    /// The draw pass on `ctx`.
    pub(crate) fn new(ctx: Arc<GpuContext>) -> Result<Self> {
        let renderer = GpuRenderer::with_context(ctx).context("building the GPU passes")?;
        Ok(Self { renderer, lobe_env: None })
    }

    /// The adapter, in words.
    pub(crate) fn adapter(&self) -> String {
        self.renderer.describe()
    }
}

impl GpuImage for GpuLobes {
    fn draw(
        &mut self,
        ctx: &FrameContext<'_>,
        objects: &[GpuObject<'_>],
        positions: &[Vec<Vec3>],
        normals: &[Vec<Vec3>],
        timings: &mut Timings,
    ) -> Result<(rsl_shade::Image, Vec<Option<Vec<Vec3>>>)> {
        let engine = ctx.engine;
        self.renderer.draw_mut().set_antialias(engine.antialias())?;
        // The environment the lobes were drawn with (prefiltered up to the sharpest of them).
        if let Some(GpuLobe { env: (prefiltered, key), .. }) = objects.iter().find_map(|o| o.lobes.as_ref())
            && self.lobe_env != Some(*key)
        {
            self.lobe_env = None;
            self.renderer
                .draw_mut()
                .set_lobe_environment(&PackedEnvironment::new(prefiltered))
                .context("uploading the prefiltered environment")?;
            self.lobe_env = Some(*key);
        }
        self.renderer.set_backdrop(engine)?;
        // The objects drawn by the RSL sum per pixel: shaded here, covers and all.
        let rsl_pixels: Vec<bool> = objects.iter().map(|o| o.rsl_pixels).collect();
        let mut radiance = vec![None; objects.len()];
        if rsl_pixels.contains(&true) {
            let time = ctx.request.time;
            // The frame the compositor set up (its traced lights' rays traced) shades here.
            let pass = self.renderer.dispatch_covers_of(engine, ctx.scene, ctx.state, ctx.setup)?;
            timings.add("shade (GPU)", pass.wall_ms, pass.gpu_ms);
            let start = Instant::now();
            let shaded = self.renderer.read_frame(engine, ctx.scene, time)?;
            timings.add("vertex readback", start.elapsed().as_secs_f64() * 1e3, None);
            for (i, r) in shaded.radiance.into_iter().enumerate() {
                if rsl_pixels[i] {
                    radiance[i] = Some(r);
                }
            }
        }
        let packed: Vec<Option<PackedMaterial>> =
            objects.iter().map(|o| o.lobes.as_ref().map(|l| PackedMaterial::new(l.material))).collect();
        // The lobe pass draws the others: the objects drawn per pixel by the RSL sum get no
        // triangles there.
        let lobe_objects: Vec<LobeObject<'_>> = (0..objects.len())
            .map(|i| match rsl_pixels[i] {
                true => LobeObject { positions: &[], normals: &[], indices: &[], material: None, values: &[] },
                false => LobeObject {
                    positions: &positions[i],
                    normals: &normals[i],
                    indices: &ctx.scene.objects[i].mesh.indices,
                    material: packed[i].as_ref(),
                    values: objects[i].values,
                },
            })
            .collect();
        let env_from_world = glam::Mat3::from_quat(ctx.state.world_from_env.inverse());
        let start = Instant::now();
        let camera = &ctx.scene.camera;
        let pixels = rsl_pixels.contains(&true).then_some(rsl_pixels.as_slice());
        let pass = self.renderer.draw_lobes_and_pixels(
            &lobe_objects,
            pixels,
            camera,
            env_from_world,
            (ctx.eye(), engine.intensity()),
        )?;
        // The centres' pass with what it took to prepare it; the antialiasing rounds apart.
        let antialias_ms = pass.antialias_ms.unwrap_or(0.0);
        timings.add("draw per pixel (GPU)", start.elapsed().as_secs_f64() * 1e3 - antialias_ms, pass.gpu_ms);
        if let Some(ms) = pass.antialias_ms {
            timings.add("antialias (GPU)", ms, pass.antialias_gpu_ms);
        }
        let start = Instant::now();
        let (pixels, covered) = self.renderer.draw_mut().read_linear()?;
        timings.add("image readback", start.elapsed().as_secs_f64() * 1e3, None);
        Ok((rsl_shade::Image { width: camera.width, height: camera.height, pixels, covered }, radiance))
    }
}

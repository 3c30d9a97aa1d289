//! The engine: a scene → its prepared data (RSLs, BRDF tables, visibility fields) → shaded
//! frames.
//!
//! Preparation builds only what the scene needs: no self-visibility field is stored for a
//! convex object (rsl-vis detects it before tracing), no occluder field for an object with
//! `casts_shadows = false`, no anisotropic table for an isotropic material, one table per
//! distinct material and one field per distinct mesh. Nothing depends on where objects are:
//! moving, rotating or scaling them never triggers precomputation, rotating the environment
//! never re-decomposes it, and changing a material rebuilds only its table
//! ([`Engine::sync`]).

use crate::cache::{self, CacheStats, KeyHasher};
use anyhow::{Context, Result, bail};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use rsl_brdf::{Brdf, BrdfTable, Resolution};
use rsl_env::{CubeEnv, Decomposition, Rsl};
use rsl_scene::{EnvironmentSource, Material, Preset, QualitySettings, Scene, SceneState};
use rsl_shade::{FrameSetup, FrameStats, Light, ShadeObject, Terms, VertexFrames};
use rsl_sphere::latlong::LatLongMap;
use rsl_sphere::mesh::TriMesh;
use rsl_vis::store::FieldFileError;
use rsl_vis::{Ovdf, OvdfParams, Svdf, SvdfParams};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// How the engine prepares a scene.
#[derive(Clone, Debug, Default)]
pub struct EngineOptions {
    /// Disk cache folder; `None`: memory only.
    pub cache_dir: Option<PathBuf>,
    /// Overrides the scene's RSL count.
    pub rsl_count: Option<u32>,
    /// Overrides the scene's quality preset (the scene's own knob overrides are dropped).
    pub quality: Option<Preset>,
    /// Show progress on standard error for steps longer than a second.
    pub progress: bool,
}

/// The scene material as the BRDF model it names.
pub fn brdf_of(m: &Material) -> Brdf {
    let v = Vec3::from_array;
    match *m {
        Material::Lambert { albedo } => Brdf::Lambert { albedo: v(albedo) },
        Material::Phong { exponent, specular, diffuse } => {
            Brdf::Phong { exponent, specular: v(specular), diffuse: v(diffuse) }
        }
        Material::BlinnPhong { exponent, specular, diffuse } => {
            Brdf::BlinnPhong { exponent, specular: v(specular), diffuse: v(diffuse) }
        }
        Material::CookTorrance { alpha, specular, diffuse } => {
            Brdf::CookTorrance { alpha, specular: v(specular), diffuse: v(diffuse) }
        }
        Material::Ward { alpha, alpha_x, alpha_y, specular, diffuse } => {
            // The scene file holds `alpha` or both of `alpha_x`, `alpha_y`; a missing value
            // would fail the table's parameter check by name.
            Brdf::Ward {
                alpha_x: alpha_x.or(alpha).unwrap_or(f32::NAN),
                alpha_y: alpha_y.or(alpha).unwrap_or(f32::NAN),
                specular: v(specular),
                diffuse: v(diffuse),
            }
        }
        Material::Ggx { alpha, specular, diffuse } => Brdf::Ggx { alpha, specular: v(specular), diffuse: v(diffuse) },
        Material::Beckmann { alpha, specular, diffuse } => {
            Brdf::Beckmann { alpha, specular: v(specular), diffuse: v(diffuse) }
        }
    }
}

/// The self-visibility resolution of a quality setting.
pub fn svdf_params(preset: Preset, q: &QualitySettings) -> SvdfParams {
    let base = match preset {
        Preset::Draft => SvdfParams::DRAFT,
        Preset::Paper => SvdfParams::PAPER,
        Preset::High => SvdfParams::HIGH,
    };
    SvdfParams {
        n: q.table_resolution as usize,
        clusters: q.cpca_clusters as usize,
        vectors: q.cpca_vectors as usize,
        ..base
    }
}

/// The occluder-field resolution of a quality setting.
pub fn ovdf_params(q: &QualitySettings) -> OvdfParams {
    OvdfParams {
        shells: q.ovdf_shells as usize,
        m: q.ovdf_directions as usize,
        n: q.table_resolution as usize,
        supersample: 2,
        vectors: q.ovdf_vectors as usize,
    }
}

/// The BRDF table resolution of a quality setting.
pub fn table_resolution(q: &QualitySettings) -> Resolution {
    Resolution { n: q.table_resolution as usize, views: (q.view_samples as usize).max(2) }
}

/// The environment's radiance, for backgrounds.
#[derive(Clone, Debug)]
enum Radiance {
    /// A lat-long map (before `intensity`).
    Map(Arc<LatLongMap>),
    /// A constant (before `intensity`).
    Constant(Vec3),
}

/// What the environment needs at run time.
struct PreparedEnv {
    radiance: Radiance,
    intensity: f32,
    /// The RSLs in environment space, before `intensity`.
    rsls: Arc<Vec<Rsl>>,
    /// Key of the radiance (file contents or constant) and grid: RSL sets key on it.
    key: u64,
}

/// One object's prepared data.
struct PreparedObject {
    mesh: Arc<TriMesh>,
    frames: Arc<VertexFrames>,
    material: Material,
    table: Arc<BrdfTable>,
    svdf: Arc<Svdf>,
    ovdf: Option<Arc<Ovdf>>,
}

/// Wall time spent preparing, by kind, in milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PrepareTimings {
    /// Loading the map, resampling and decomposing it (or reading the RSLs).
    pub environment_ms: f64,
    /// BRDF tables.
    pub tables_ms: f64,
    /// Self-visibility fields.
    pub svdf_ms: f64,
    /// Occluder fields.
    pub ovdf_ms: f64,
}

/// A shaded frame.
#[derive(Clone, Debug)]
pub struct ShadedFrame {
    /// Transforms and environment rotation.
    pub state: SceneState,
    /// Per object, per vertex: world position.
    pub positions: Vec<Vec<Vec3>>,
    /// Per object, per vertex: world normal.
    pub normals: Vec<Vec<Vec3>>,
    /// Per object, per vertex: radiance toward the eye.
    pub radiance: Vec<Vec<Vec3>>,
    /// Lookup counts.
    pub stats: FrameStats,
    /// Wall time of the shading, ms.
    pub shade_ms: f64,
}

/// The scene's prepared data and the cache it came from.
pub struct Engine {
    options: EngineOptions,
    preset: Preset,
    settings: QualitySettings,
    rsl_count: usize,
    env: PreparedEnv,
    objects: Vec<PreparedObject>,
    /// Mesh keys, by the mesh's allocation (the Arc is kept, so the address stays unique).
    mesh_keys: Vec<(Arc<TriMesh>, u64)>,
    svdfs: HashMap<u64, Arc<Svdf>>,
    ovdfs: HashMap<u64, Arc<Ovdf>>,
    tables: HashMap<u64, Arc<BrdfTable>>,
    frames: HashMap<(u64, bool), Arc<VertexFrames>>,
    rsl_sets: HashMap<u64, Arc<Vec<Rsl>>>,
    decompositions: HashMap<u64, Arc<Decomposition>>,
    stats: CacheStats,
    timings: PrepareTimings,
    id: u64,
}

static ENGINES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Format version of everything this engine caches (bump when any computation changes).
const CACHE_VERSION: u64 = 1;

fn spinner(show: bool, message: String) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new_spinner().with_message(message);
    bar.set_style(ProgressStyle::with_template("{spinner} {msg} [{elapsed}]").expect("valid template"));
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}

/// A progress bar with a percentage and time estimate on standard error (hidden when not
/// shown or when standard error is not a terminal).
pub fn progress_bar(show: bool, message: String) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(0).with_message(message);
    bar.set_style(
        ProgressStyle::with_template("{msg} {wide_bar} {percent:>3}% [{elapsed} / ~{duration}]")
            .expect("valid template"),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    bar
}

/// A `(done, total)` callback that moves `bar`.
pub fn report_to(bar: &ProgressBar) -> impl Fn(usize, usize) + Sync + '_ {
    |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    }
}

impl Engine {
    /// Prepares `scene`: from the caches where possible, computing the rest.
    pub fn new(scene: &Scene, options: EngineOptions) -> Result<Self> {
        let quality = match options.quality {
            Some(p) => rsl_scene::Quality::from_preset(p),
            None => scene.quality,
        };
        let rsl_count = options.rsl_count.unwrap_or(scene.environment.rsl_count) as usize;
        if rsl_count == 0 {
            bail!("the RSL count must be at least 1");
        }
        let mut engine = Self {
            options,
            preset: quality.preset,
            settings: quality.settings,
            rsl_count,
            env: PreparedEnv {
                radiance: Radiance::Constant(Vec3::ZERO),
                intensity: 1.0,
                rsls: Arc::new(Vec::new()),
                key: 0,
            },
            objects: Vec::new(),
            mesh_keys: Vec::new(),
            svdfs: HashMap::new(),
            ovdfs: HashMap::new(),
            tables: HashMap::new(),
            frames: HashMap::new(),
            rsl_sets: HashMap::new(),
            decompositions: HashMap::new(),
            stats: CacheStats::default(),
            timings: PrepareTimings::default(),
            id: ENGINES.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
        };
        engine.prepare_environment(scene)?;
        engine.sync(scene)?;
        Ok(engine)
    }

    /// The cache's counters.
    pub fn cache_stats(&self) -> CacheStats {
        self.stats
    }

    /// Time spent preparing so far.
    pub fn timings(&self) -> PrepareTimings {
        self.timings
    }

    /// The quality settings in use.
    pub fn settings(&self) -> (Preset, QualitySettings) {
        (self.preset, self.settings)
    }

    /// The RSLs in environment space (before intensity).
    pub fn rsls(&self) -> &[Rsl] {
        &self.env.rsls
    }

    /// The environment's radiance (with intensity) toward world direction `d` at `state`.
    pub fn background(&self, state: &SceneState, d: Vec3) -> Vec3 {
        let e = state.world_from_env.inverse() * d;
        let l = match &self.env.radiance {
            Radiance::Map(m) => m.lookup(e),
            Radiance::Constant(c) => *c,
        };
        l * self.env.intensity
    }

    /// The environment's radiance as the GPU draw pass shows it behind the objects.
    pub fn backdrop(&self) -> rsl_gpu::draw::Backdrop<'_> {
        match &self.env.radiance {
            Radiance::Map(m) => rsl_gpu::draw::Backdrop::Map {
                width: m.width() as u32,
                height: m.height() as u32,
                texels: m.texels(),
                intensity: self.env.intensity,
            },
            Radiance::Constant(c) => rsl_gpu::draw::Backdrop::Constant(*c * self.env.intensity),
        }
    }

    fn prepare_environment(&mut self, scene: &Scene) -> Result<()> {
        let start = Instant::now();
        let env = &scene.environment;
        let grid = self.settings.env_grid as usize;
        let (radiance, key) = match &env.source {
            EnvironmentSource::Map { written, path } => {
                let loaded = rsl_env::load_latlong(path).with_context(|| format!("environment map {written}"))?;
                if loaded.clamped_negative > 0 {
                    tracing::warn!(
                        "{}: {} negative values clamped to 0 (most negative {})",
                        path.display(),
                        loaded.clamped_negative,
                        loaded.most_negative
                    );
                }
                // Keyed by the decoded radiance (the file is read once).
                let m = &loaded.map;
                let key = m
                    .texels()
                    .iter()
                    .fold(KeyHasher::default().str("map").u64(m.width() as u64).u64(m.height() as u64), |h, t| {
                        h.f32s(&t.to_array())
                    })
                    .finish();
                (Radiance::Map(Arc::new(loaded.map)), key)
            }
            EnvironmentSource::Constant(c) => {
                (Radiance::Constant(*c), KeyHasher::default().str("constant").f32s(&c.to_array()).finish())
            }
        };
        let key = KeyHasher::default().u64(key).u64(grid as u64).u64(CACHE_VERSION).finish();
        self.env = PreparedEnv { radiance, intensity: env.intensity, rsls: Arc::new(Vec::new()), key };
        self.env.rsls = self.rsl_set(self.rsl_count)?;
        self.timings.environment_ms += start.elapsed().as_secs_f64() * 1e3;
        Ok(())
    }

    /// The RSL set of `n` lights for the prepared environment: memory, disk, or a
    /// decomposition (itself kept in memory, so other counts cost only the cut).
    fn rsl_set(&mut self, n: usize) -> Result<Arc<Vec<Rsl>>> {
        let key = KeyHasher::default().u64(self.env.key).str("rsl").u64(n as u64).finish();
        if let Some(s) = self.rsl_sets.get(&key) {
            self.stats.memory_hits += 1;
            return Ok(s.clone());
        }
        let file = self.options.cache_dir.as_ref().map(|d| d.join(format!("rsl-{key:016x}.bin")));
        if let Some(f) = &file
            && let Ok(bytes) = std::fs::read(f)
        {
            match cache::rsls_from_bytes(&bytes) {
                Ok(s) if s.len() <= n && !s.is_empty() => {
                    self.stats.disk_hits += 1;
                    let s = Arc::new(s);
                    self.rsl_sets.insert(key, s.clone());
                    return Ok(s);
                }
                Ok(_) => reject(&mut self.stats, f, "holds the wrong number of lights"),
                Err(e) => reject(&mut self.stats, f, &e),
            }
        }
        self.stats.misses += 1;
        let grid = self.settings.env_grid as usize;
        let decomposition = match self.decompositions.get(&self.env.key) {
            Some(d) => d.clone(),
            None => {
                let bar = spinner(self.options.progress, format!("decomposing the environment (6×{grid}×{grid})"));
                let cube = match &self.env.radiance {
                    Radiance::Map(m) => CubeEnv::from_latlong(m, grid),
                    Radiance::Constant(c) => CubeEnv::constant(grid, *c),
                };
                let d = Arc::new(Decomposition::new(&cube));
                bar.finish_and_clear();
                self.decompositions.insert(self.env.key, d.clone());
                d
            }
        };
        let n = n.min(decomposition.max_rsls());
        let set: Vec<Rsl> = decomposition.rsls(n)?.into_iter().map(|i| i.rsl).collect();
        if let Some(f) = &file
            && let Err(e) = cache::write(f, &cache::rsls_to_bytes(&set))
        {
            tracing::warn!("cannot cache the light set: {e}");
        }
        let set = Arc::new(set);
        self.rsl_sets.insert(key, set.clone());
        Ok(set)
    }

    /// Changes the number of RSLs (a cut of the same decomposition: no new decomposition).
    pub fn set_rsl_count(&mut self, n: usize) -> Result<()> {
        if n == 0 {
            bail!("the RSL count must be at least 1");
        }
        self.rsl_count = n;
        self.env.rsls = self.rsl_set(n)?;
        Ok(())
    }

    fn mesh_key(&mut self, mesh: &Arc<TriMesh>) -> u64 {
        if let Some((_, k)) = self.mesh_keys.iter().find(|(m, _)| Arc::ptr_eq(m, mesh)) {
            return *k;
        }
        let k = cache::mesh_key(mesh);
        self.mesh_keys.push((mesh.clone(), k));
        k
    }

    /// Brings the prepared data in line with `scene` (same environment; objects, materials
    /// and motion may have changed): every object's resources are looked up by key, and only
    /// what is missing is computed. Moving objects changes no key.
    pub fn sync(&mut self, scene: &Scene) -> Result<()> {
        let mut objects = Vec::with_capacity(scene.objects.len());
        for o in &scene.objects {
            let mesh_key = self.mesh_key(&o.mesh);
            let brdf = brdf_of(&o.material);
            let anisotropic = brdf.is_anisotropic();
            let frames = match self.frames.get(&(mesh_key, anisotropic)) {
                Some(f) => f.clone(),
                None => {
                    let f = Arc::new(VertexFrames::new(&o.mesh, anisotropic));
                    self.frames.insert((mesh_key, anisotropic), f.clone());
                    f
                }
            };
            let table = self.table(&o.name, &brdf)?;
            let svdf = self.svdf(&o.name, &o.mesh, mesh_key)?;
            let ovdf = if o.casts_shadows { Some(self.ovdf(&o.name, &o.mesh, mesh_key)?) } else { None };
            objects.push(PreparedObject {
                mesh: o.mesh.clone(),
                frames,
                material: o.material.clone(),
                table,
                svdf,
                ovdf,
            });
        }
        self.objects = objects;
        Ok(())
    }

    fn table(&mut self, name: &str, brdf: &Brdf) -> Result<Arc<BrdfTable>> {
        let res = table_resolution(&self.settings);
        let key = KeyHasher::default().str(&format!("{brdf:?}")).u64(res.n as u64).u64(res.views as u64).finish();
        if let Some(t) = self.tables.get(&key) {
            self.stats.memory_hits += 1;
            return Ok(t.clone());
        }
        self.stats.misses += 1;
        let start = Instant::now();
        let t = Arc::new(BrdfTable::build(brdf, res).with_context(|| format!("object {name}: material"))?);
        self.timings.tables_ms += start.elapsed().as_secs_f64() * 1e3;
        self.tables.insert(key, t.clone());
        Ok(t)
    }

    fn svdf(&mut self, name: &str, mesh: &TriMesh, mesh_key: u64) -> Result<Arc<Svdf>> {
        let p = svdf_params(self.preset, &self.settings);
        let key = field_key("svdf", mesh_key, &format!("{p:?}"));
        let vertices = mesh.vertex_count();
        let io = FieldIo {
            prefix: "svdf",
            load: rsl_vis::store::load_svdf,
            save: rsl_vis::store::save_svdf,
            check: &|f: &Svdf| {
                (field_vertices(f) == vertices).then_some(()).ok_or("vertex count differs from the mesh")
            },
            build: &|report| {
                Svdf::build_with_progress(mesh, &p, report)
                    .with_context(|| format!("object {name}: self-visibility field"))
            },
            message: format!("self-visibility of {name} ({vertices} vertices, {}×{} per vertex)", p.n, p.n),
        };
        let dir = self.options.cache_dir.clone();
        cached(
            &mut self.svdfs,
            &mut self.stats,
            &mut self.timings.svdf_ms,
            dir.as_deref(),
            key,
            io,
            self.options.progress,
        )
    }

    fn ovdf(&mut self, name: &str, mesh: &TriMesh, mesh_key: u64) -> Result<Arc<Ovdf>> {
        let p = ovdf_params(&self.settings);
        p.check().map_err(anyhow::Error::msg).context("quality settings")?;
        let key = field_key("ovdf", mesh_key, &format!("{p:?}"));
        let io = FieldIo {
            prefix: "ovdf",
            load: rsl_vis::store::load_ovdf,
            save: rsl_vis::store::save_ovdf,
            check: &|f: &Ovdf| (f.params() == &p).then_some(()).ok_or("resolution differs"),
            build: &|report| {
                Ovdf::build_with_progress(mesh, &p, report).with_context(|| format!("object {name}: occluder field"))
            },
            message: format!("occluder field of {name} ({} shells × 6×{}×{} samples)", p.shells, p.m, p.m),
        };
        let dir = self.options.cache_dir.clone();
        cached(
            &mut self.ovdfs,
            &mut self.stats,
            &mut self.timings.ovdf_ms,
            dir.as_deref(),
            key,
            io,
            self.options.progress,
        )
    }

    /// The RSLs at `state`, in world space, with the environment's intensity.
    pub fn lights(&self, state: &SceneState) -> Vec<Light> {
        self.env
            .rsls
            .iter()
            .map(|r| Light {
                dir: (state.world_from_env * r.centre).normalize(),
                half_diagonal: r.half_diagonal,
                radiance: r.intensity * self.env.intensity,
            })
            .collect()
    }

    fn check(&self, scene: &Scene) -> Result<()> {
        if scene.objects.len() != self.objects.len()
            || scene
                .objects
                .iter()
                .zip(&self.objects)
                .any(|(o, p)| !Arc::ptr_eq(&o.mesh, &p.mesh) || o.material != p.material)
        {
            bail!("the scene changed since it was prepared: call Engine::sync first");
        }
        Ok(())
    }

    /// The prepared objects of `scene` at `state` (what any shading path evaluates).
    pub fn objects(&self, scene: &Scene, state: &SceneState) -> Result<Vec<ShadeObject<'_>>> {
        self.check(scene)?;
        Ok(self
            .objects
            .iter()
            .zip(&state.objects)
            .map(|(p, &transform)| ShadeObject {
                mesh: &p.mesh,
                frames: &p.frames,
                table: &p.table,
                svdf: &p.svdf,
                ovdf: p.ovdf.as_deref(),
                transform,
            })
            .collect())
    }

    /// The shading inputs of `scene` at `state`, seen from `eye`.
    pub fn setup(&self, scene: &Scene, state: &SceneState, eye: Vec3, terms: Terms) -> Result<FrameSetup<'_>> {
        let objects = self.objects(scene, state)?;
        Ok(FrameSetup::new(&objects, &self.lights(state), eye, terms))
    }

    /// A number no other engine of this process has: GPU resources loaded from one engine
    /// are keyed by it.
    pub fn id(&self) -> u64 {
        self.id
    }

    /// Shades every vertex of `scene` at time `t` (the fast path), seen from the camera.
    pub fn shade(&self, scene: &Scene, t: f32) -> Result<ShadedFrame> {
        let state = scene.at(t);
        let setup = self.setup(scene, &state, scene.camera.eye, Terms::default())?;
        let start = Instant::now();
        let (radiance, stats) = rsl_shade::shade(&setup);
        let shade_ms = start.elapsed().as_secs_f64() * 1e3;
        let positions =
            (0..self.objects.len()).map(|i| (0..radiance[i].len()).map(|v| setup.position(i, v)).collect()).collect();
        let normals =
            (0..self.objects.len()).map(|i| (0..radiance[i].len()).map(|v| setup.normal(i, v)).collect()).collect();
        Ok(ShadedFrame { state, positions, normals, radiance, stats, shade_ms })
    }
}

/// Counts a rejected cache file, says why, and removes it.
fn reject(stats: &mut CacheStats, file: &Path, why: &str) {
    stats.rejected += 1;
    tracing::warn!("cache file {} rejected ({why}); recomputing", file.display());
    let _ = std::fs::remove_file(file);
}

/// The key of a visibility field of a mesh at some parameters.
fn field_key(kind: &str, mesh_key: u64, params: &str) -> u64 {
    KeyHasher::default()
        .str(kind)
        .u64(mesh_key)
        .u64(CACHE_VERSION)
        .u64(rsl_vis::store::VERSION.into())
        .str(params)
        .finish()
}

/// A progress callback: `(done, total)`.
type Progress<'p> = dyn Fn(usize, usize) + Sync + 'p;

/// How to read, check, build and write one kind of visibility field.
struct FieldIo<'a, T> {
    /// File name prefix (`<prefix>-<key>.bin`).
    prefix: &'static str,
    load: fn(&Path) -> Result<T, FieldFileError>,
    save: fn(&T, &Path) -> Result<(), FieldFileError>,
    /// Whether a loaded field fits what is asked for (and why not).
    check: &'a dyn Fn(&T) -> Result<(), &'static str>,
    /// Builds the field, reporting `(done, total)`.
    build: &'a dyn Fn(&Progress<'_>) -> Result<T>,
    /// What the progress display says while building.
    message: String,
}

/// A field from memory, else from disk (checked; a bad file is rejected), else built (and
/// written to disk). `ms` accumulates the build time.
fn cached<T>(
    memory: &mut HashMap<u64, Arc<T>>,
    stats: &mut CacheStats,
    ms: &mut f64,
    dir: Option<&Path>,
    key: u64,
    io: FieldIo<'_, T>,
    progress: bool,
) -> Result<Arc<T>> {
    if let Some(f) = memory.get(&key) {
        stats.memory_hits += 1;
        return Ok(f.clone());
    }
    let file = dir.map(|d| d.join(format!("{}-{key:016x}.bin", io.prefix)));
    if let Some(path) = &file
        && path.exists()
    {
        match (io.load)(path).map_err(|e| e.to_string()).and_then(|f| (io.check)(&f).map(|()| f).map_err(String::from))
        {
            Ok(f) => {
                stats.disk_hits += 1;
                let f = Arc::new(f);
                memory.insert(key, f.clone());
                return Ok(f);
            }
            Err(why) => reject(stats, path, &why),
        }
    }
    stats.misses += 1;
    let start = Instant::now();
    let bar = progress_bar(progress, io.message.clone());
    let f = (io.build)(&report_to(&bar))?;
    bar.finish_and_clear();
    *ms += start.elapsed().as_secs_f64() * 1e3;
    if let Some(path) = &file
        && let Err(e) = std::fs::create_dir_all(path.parent().unwrap_or(path))
            .map_err(|e| e.to_string())
            .and_then(|()| (io.save)(&f, path).map_err(|e| e.to_string()))
    {
        tracing::warn!("cannot cache {}: {e}", io.message);
    }
    let f = Arc::new(f);
    memory.insert(key, f.clone());
    Ok(f)
}

fn field_vertices(f: &Svdf) -> usize {
    match f {
        Svdf::Convex { vertices } => *vertices,
        Svdf::Field { cpca, .. } => cpca.assignment.len(),
    }
}

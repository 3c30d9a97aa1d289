//! The engine: a scene → its prepared data → what every method shades frames from.
//!
//! Prepared data comes in two layers under content keys ([`crate::cache::KeyHasher`]: the
//! values that define a result, never addresses or debug text):
//!
//! - the **method-neutral layer**: meshes (keyed by their contents), per-vertex frames,
//!   BRDF descriptions, the environment's radiance;
//! - the **RSL layer** ([`Layers::rsl`]): the light set (a cut of the environment's merge
//!   tree), one BRDF table per distinct material, and the visibility fields — the
//!   self-visibility field per distinct non-convex mesh and the occluder field per distinct
//!   mesh that casts shadows.
//!
//! Preparation builds only what the scene needs. Nothing depends on where objects are:
//! moving, rotating or scaling them never triggers precomputation, rotating the environment
//! never re-decomposes it, and changing a material rebuilds only its table
//! ([`Engine::sync`]). Everything prepared is held in a memory [`Store`] under a byte budget
//! with least-recently-used eviction (what the current scene uses is never evicted), and the
//! visibility fields and light sets also in the disk cache.

use crate::cache::{self, CacheStats, KeyHasher};
use crate::progress::{Progress, Timings};
use crate::store::{DEFAULT_BUDGET, Store};
use anyhow::{Context, Result, bail};
use glam::Vec3;
use rsl_brdf::{Brdf, BrdfTable, Resolution};
use rsl_env::{CubeEnv, Decomposition, Rsl};
use rsl_scene::{EnvironmentSource, Preset, QualitySettings, Scene, SceneState};
use rsl_shade::{Covers, FrameSetup, FrameStats, Light, ShadeObject, Terms, Traced, VertexFrames};
use rsl_sphere::latlong::LatLongMap;
use rsl_sphere::mesh::TriMesh;
use rsl_vis::rays::Occluder;
use rsl_vis::{FaceMask, Ovdf, Svdf};
use std::sync::Arc;
use std::time::Instant;

mod items;

use crate::field_io::{FieldIo, field_key, field_vertices, frames_bytes, reject, rsl_bytes};
pub(crate) use crate::options::check_size;
pub use crate::options::{
    DEFAULT_PREPARE_LIMIT, EngineOptions, Layers, PREPARE_LIMIT_ENV, PREVIEW_RESOLUTION, ovdf_params, prepare_limit,
    svdf_params, table_resolution,
};

/// The environment's radiance, before its intensity.
#[derive(Clone, Debug)]
pub enum EnvRadiance {
    /// A lat-long map.
    Map(Arc<LatLongMap>),
    /// A constant.
    Constant(Vec3),
}

/// What the environment needs at run time.
struct PreparedEnv {
    radiance: EnvRadiance,
    intensity: f32,
    /// The RSLs in environment space, before `intensity` (RSL layer; empty without it).
    rsls: Arc<Vec<Rsl>>,
    /// Key of the radiance (decoded texels or constant) and grid: RSL sets key on it.
    key: u64,
    /// Key of the light set in use.
    rsl_key: u64,
}

/// The RSL layer of one object.
struct RslObject {
    table: Arc<BrdfTable>,
    table_key: u64,
    svdf: Arc<Svdf>,
    svdf_key: u64,
    /// The face-averaged vertex mask (from the mesh alone).
    mask: Arc<FaceMask>,
    ovdf: Option<(Arc<Ovdf>, u64)>,
    /// The triangles in a BVH, for traced shadows (when the object casts shadows and the
    /// quality traces lights).
    bvh: Option<Arc<Occluder>>,
}

/// One object's prepared data.
struct PreparedObject {
    mesh: Arc<TriMesh>,
    mesh_key: u64,
    frames: Arc<VertexFrames>,
    frames_key: u64,
    brdf: Brdf,
    rsl: Option<RslObject>,
}

/// The content keys of one object's prepared data: equal keys, equal data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ObjectKeys {
    /// The mesh's contents.
    pub mesh: u64,
    /// The vertex frames.
    pub frames: u64,
    /// The BRDF table (0 without the RSL layer).
    pub table: u64,
    /// The self-visibility field (0 without the RSL layer).
    pub svdf: u64,
    /// The occluder field (0 when the object casts no shadow or without the RSL layer).
    pub ovdf: u64,
}

/// Memory the engine holds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryStats {
    /// Bytes of prepared data held (in use or cached for reuse).
    pub resident_bytes: usize,
    /// The budget for data not in use.
    pub budget_bytes: usize,
    /// Items evicted so far.
    pub evictions: u64,
    /// Items held.
    pub items: usize,
}

/// A shaded frame of the CPU RSL path: per object, per vertex.
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

impl ShadedFrame {
    /// The frame of `radiance` shaded from `setup` at `state`, with the vertices' world
    /// positions and normals.
    pub fn of(
        setup: &FrameSetup<'_>,
        state: SceneState,
        radiance: Vec<Vec<Vec3>>,
        stats: FrameStats,
        shade_ms: f64,
    ) -> Self {
        let n = radiance.len();
        // An object left out of `radiance` (empty) has no vertices in the frame either.
        let shaded =
            |i: usize, all: &dyn Fn(usize) -> Vec<Vec3>| if radiance[i].is_empty() { Vec::new() } else { all(i) };
        let positions = (0..n).map(|i| shaded(i, &|i| setup.positions(i))).collect();
        let normals = (0..n).map(|i| shaded(i, &|i| setup.normals(i))).collect();
        Self { state, positions, normals, radiance, stats, shade_ms }
    }
}

/// The scene's prepared data and the caches it came from.
pub struct Engine {
    options: EngineOptions,
    preset: Preset,
    settings: QualitySettings,
    rsl_count: usize,
    env: PreparedEnv,
    objects: Vec<PreparedObject>,
    store: Store,
    stats: CacheStats,
    timings: Timings,
}

/// Format version of everything this engine caches (bump when any computation changes).
pub(crate) const CACHE_VERSION: u64 = 2;

/// Stage names of [`Engine::timings`].
pub mod stage {
    /// Loading the map, resampling and decomposing it (or reading the RSLs).
    pub const ENVIRONMENT: &str = "environment";
    /// BRDF tables.
    pub const TABLES: &str = "BRDF tables";
    /// Self-visibility fields.
    pub const SVDF: &str = "self-visibility";
    /// Occluder fields.
    pub const OVDF: &str = "occluder fields";
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
        let grid = quality.settings.env_grid as usize;
        if options.layers.rsl && rsl_count > 6 * grid * grid {
            bail!(
                "the RSL count {rsl_count} is more than the {} texels of the 6×{grid}×{grid} environment grid (one RSL \
                 per texel at most; raise env_grid for more)",
                6 * grid * grid
            );
        }
        let budget = options.memory_budget.unwrap_or(DEFAULT_BUDGET);
        let mut options = options;
        if options.cache_limit.is_none() && options.cache_dir.is_some() {
            options.cache_limit = Some(cache::max_bytes_from_env()?);
        }
        let mut engine = Self {
            options,
            preset: quality.preset,
            settings: quality.settings,
            rsl_count,
            env: PreparedEnv {
                radiance: EnvRadiance::Constant(Vec3::ZERO),
                intensity: 1.0,
                rsls: Arc::new(Vec::new()),
                key: 0,
                rsl_key: 0,
            },
            objects: Vec::new(),
            store: Store::new(budget),
            stats: CacheStats::default(),
            timings: Timings::default(),
        };
        engine.prepare_environment(scene)?;
        engine.sync(scene)?;
        Ok(engine)
    }

    /// The cache's counters.
    pub fn cache_stats(&self) -> CacheStats {
        self.stats
    }

    /// Memory held by prepared data.
    pub fn memory(&self) -> MemoryStats {
        MemoryStats {
            resident_bytes: self.store.resident_bytes(),
            budget_bytes: self.store.budget(),
            evictions: self.store.evictions(),
            items: self.store.len(),
        }
    }

    /// Where long steps report their progress ([`EngineOptions::progress`]).
    pub fn progress(&self) -> &Progress {
        &self.options.progress
    }

    /// Time spent preparing so far, by stage ([`stage`]).
    pub fn timings(&self) -> &Timings {
        &self.timings
    }

    /// The disk cache's folder (`None`: no disk cache).
    pub fn cache_dir(&self) -> Option<&std::path::Path> {
        self.options.cache_dir.as_deref()
    }

    /// The bytes rsl's files in the cache folder may take ([`EngineOptions::cache_limit`]).
    pub fn cache_limit(&self) -> u64 {
        self.options.cache_limit.unwrap_or(cache::DEFAULT_MAX_MB << 20)
    }

    /// The quality preset and settings the engine prepares with.
    pub fn settings(&self) -> (Preset, QualitySettings) {
        (self.preset, self.settings)
    }

    /// Samples per pixel where one is not enough (the `aa` quality knob; 1: none).
    pub fn antialias(&self) -> u32 {
        self.settings.aa
    }

    /// Sets the samples per pixel where one is not enough (a square in 1..=64; nothing is
    /// prepared again: antialiasing costs only drawing).
    pub fn set_antialias(&mut self, aa: u32) -> Result<()> {
        self.settings.set("aa", i64::from(aa)).map_err(|m| anyhow::anyhow!("aa {m}"))
    }

    /// The layers this engine prepares.
    pub fn layers(&self) -> Layers {
        self.options.layers
    }

    /// The RSLs in environment space (before intensity); empty without the RSL layer.
    pub fn rsls(&self) -> &[Rsl] {
        &self.env.rsls
    }

    /// The environment's radiance (before intensity).
    pub fn environment(&self) -> &EnvRadiance {
        &self.env.radiance
    }

    /// The environment's intensity multiplier.
    pub fn intensity(&self) -> f32 {
        self.env.intensity
    }

    /// The environment's radiance (with intensity) toward world direction `d` at `state`.
    pub fn background(&self, state: &SceneState, d: Vec3) -> Vec3 {
        let e = state.world_from_env.inverse() * d;
        let l = match &self.env.radiance {
            EnvRadiance::Map(m) => m.lookup(e),
            EnvRadiance::Constant(c) => *c,
        };
        l * self.env.intensity
    }

    /// The content key of the environment's radiance and resampling grid.
    pub fn environment_key(&self) -> u64 {
        self.env.key
    }

    fn prepare_environment(&mut self, scene: &Scene) -> Result<()> {
        let start = Instant::now();
        let env = &scene.environment;
        let grid = self.settings.env_grid as usize;
        let (radiance, key) = match (load_map(&env.source)?, &env.source) {
            (Some(map), _) => map_radiance(map),
            (None, EnvironmentSource::Constant(c)) => {
                (EnvRadiance::Constant(*c), KeyHasher::default().str("constant").f32s(&c.to_array()).finish())
            }
            (None, _) => unreachable!("every source but a constant is a map"),
        };
        let brightest = match &radiance {
            EnvRadiance::Map(m) => m.texels().iter().map(|t| t.max_element()).fold(0.0, f32::max),
            EnvRadiance::Constant(c) => c.max_element(),
        } * env.intensity;
        if brightest.is_nan() || brightest > rsl_env::load::MAX_RADIANCE {
            bail!(
                "{}: environment.intensity {} makes the brightest radiance {brightest:e}, beyond the {:e} that \
                 shading can sum without overflowing f32",
                scene.path.display(),
                env.intensity,
                rsl_env::load::MAX_RADIANCE
            );
        }
        let key = KeyHasher::default().u64(key).u64(grid as u64).u64(CACHE_VERSION).finish();
        self.env = PreparedEnv { radiance, intensity: env.intensity, rsls: Arc::new(Vec::new()), key, rsl_key: 0 };
        if self.options.layers.rsl {
            let (rsls, rsl_key) = self.rsl_set(self.rsl_count)?;
            self.env.rsls = rsls;
            self.env.rsl_key = rsl_key;
        }
        self.timings.add(stage::ENVIRONMENT, start.elapsed().as_secs_f64() * 1e3, None);
        Ok(())
    }

    fn decomposition_key(&self) -> u64 {
        KeyHasher::default()
            .u64(self.env.key)
            .str("decomposition")
            .u64(u64::from(rsl_env::decompose::ALGORITHM_VERSION))
            .finish()
    }

    /// The RSL set of `n` lights for the prepared environment and its key: memory, disk, or
    /// a decomposition (itself kept in memory, so other counts cost only the cut).
    fn rsl_set(&mut self, n: usize) -> Result<(Arc<Vec<Rsl>>, u64)> {
        let key = KeyHasher::default()
            .u64(self.env.key)
            .str("rsl")
            .u64(u64::from(rsl_env::decompose::ALGORITHM_VERSION))
            .u64(n as u64)
            .finish();
        if let Some(s) = self.store.get::<Vec<Rsl>>(key) {
            self.stats.memory_hits += 1;
            return Ok((s, key));
        }
        let file = self.options.cache_dir.as_ref().map(|d| d.join(format!("rsl-{key:016x}.bin")));
        if let Some(f) = &file
            && f.exists()
        {
            let read = rsl_sphere::io::read_bounded(f, rsl_sphere::io::MAX_DATA_BYTES).map_err(|e| e.to_string());
            match read.and_then(|bytes| cache::rsls_from_bytes(&bytes, key)) {
                Ok(s) if s.len() <= n && !s.is_empty() => {
                    cache::used(f);
                    self.stats.disk_hits += 1;
                    let s = Arc::new(s);
                    self.store.insert(key, s.clone(), rsl_bytes(&s));
                    return Ok((s, key));
                }
                Ok(_) => reject(&mut self.stats, f, "holds the wrong number of lights"),
                Err(e) => reject(&mut self.stats, f, &e),
            }
        }
        self.stats.misses += 1;
        let grid = self.settings.env_grid as usize;
        let dkey = self.decomposition_key();
        let decomposition = match self.store.get::<Decomposition>(dkey) {
            Some(d) => d,
            None => {
                let task = format!("decomposing the environment (6×{grid}×{grid})");
                let radiance = self.env.radiance.clone();
                let d = Arc::new(self.options.progress.task(&task, |_| {
                    let cube = match &radiance {
                        EnvRadiance::Map(m) => CubeEnv::from_latlong(m, grid),
                        EnvRadiance::Constant(c) => CubeEnv::constant(grid, *c),
                    };
                    Decomposition::new(&cube)
                }));
                self.store.insert(dkey, d.clone(), d.bytes());
                d
            }
        };
        let n = n.min(decomposition.max_rsls());
        let set: Vec<Rsl> = decomposition.rsls(n)?.into_iter().map(|i| i.rsl).collect();
        if let Some(f) = &file {
            match cache::write(f, &cache::rsls_to_bytes(&set, key)) {
                Ok(()) => cache::stored(f, self.cache_limit()),
                Err(e) => tracing::warn!("cannot cache the light set: {e:#}"),
            }
        }
        let set = Arc::new(set);
        self.store.insert(key, set.clone(), rsl_bytes(&set));
        Ok((set, key))
    }

    /// Texels of the environment grid: the most RSLs a decomposition holds (one per texel,
    /// what the light oracle uses).
    pub fn texel_count(&self) -> usize {
        let g = self.settings.env_grid as usize;
        6 * g * g
    }

    /// The current number of RSLs.
    pub fn rsl_count(&self) -> usize {
        self.env.rsls.len()
    }

    /// Changes the number of RSLs (a cut of the same decomposition: no new decomposition).
    pub fn set_rsl_count(&mut self, n: usize) -> Result<()> {
        if n == 0 {
            bail!("the RSL count must be at least 1");
        }
        if n > self.texel_count() {
            bail!(
                "the RSL count {n} is more than the {} texels of the environment grid (one RSL per texel at most)",
                self.texel_count()
            );
        }
        if !self.options.layers.rsl {
            bail!("this engine prepares no RSL layer");
        }
        self.rsl_count = n;
        self.store.pin_more([self.decomposition_key()]);
        let (rsls, key) = self.rsl_set(n)?;
        self.env.rsls = rsls;
        self.env.rsl_key = key;
        self.pin_in_use();
        Ok(())
    }

    /// Brings the prepared data in line with `scene` (same environment; objects, materials
    /// and motion may have changed): every object's resources are looked up by content key,
    /// and only what is missing is computed. Moving objects changes no key.
    pub fn sync(&mut self, scene: &Scene) -> Result<()> {
        self.sync_previewing(scene, None)
    }

    /// [`Engine::sync`], with object `preview`'s BRDF table built at
    /// [`PREVIEW_RESOLUTION`] instead of its own: what a front end uses while a material
    /// slider moves (a table in about a millisecond), before a plain `sync` builds the
    /// object's real table once the slider rests.
    pub fn sync_previewing(&mut self, scene: &Scene, preview: Option<usize>) -> Result<()> {
        let mut objects = Vec::with_capacity(scene.objects.len());
        // What the scene needs stays while the rest is built.
        self.store.pin_more([self.env.rsl_key, self.decomposition_key()]);
        // An object alone in its scene shadows nothing: it needs no occluder field (minutes
        // at the paper preset) and no BVH for other objects' shadow rays.
        let has_others = scene.objects.len() > 1;
        for (index, o) in scene.objects.iter().enumerate() {
            // The key is the mesh's contents; a mesh the engine already holds (the same
            // shared, immutable allocation) is not hashed again on every edit.
            let mesh_key = match self.objects.iter().find(|p| Arc::ptr_eq(&p.mesh, &o.mesh)) {
                Some(p) => p.mesh_key,
                None => cache::mesh_key(&o.mesh),
            };
            let brdf = o.material;
            let anisotropic = brdf.is_anisotropic();
            let frames_key = KeyHasher::default().str("frames").u64(mesh_key).u64(u64::from(anisotropic)).finish();
            let frames = match self.store.get::<VertexFrames>(frames_key) {
                Some(f) => f,
                None => {
                    let f = Arc::new(VertexFrames::new(&o.mesh, anisotropic));
                    self.store.insert(frames_key, f.clone(), frames_bytes(&f));
                    f
                }
            };
            self.store.pin_more([frames_key]);
            let rsl = if self.options.layers.rsl {
                let mut res = table_resolution(&self.settings, &brdf);
                if preview == Some(index) {
                    res.n = res.n.min(PREVIEW_RESOLUTION);
                }
                let (table, table_key) = self.table(&o.name, &brdf, res, preview != Some(index))?;
                let (svdf, svdf_key) = self.svdf(&o.name, &o.mesh, mesh_key)?;
                let mask = self.face_mask(&o.mesh, mesh_key);
                let ovdf =
                    if o.casts_shadows && has_others { Some(self.ovdf(&o.name, &o.mesh, mesh_key)?) } else { None };
                let shadows_itself = matches!(*svdf, Svdf::Field { .. });
                let traced = self.traced().lights > 0 && self.traced().rays > 0;
                let bvh = if ((o.casts_shadows && has_others) || shadows_itself) && traced {
                    Some(self.bvh(&o.name, &o.mesh, mesh_key)?)
                } else {
                    None
                };
                Some(RslObject { table, table_key, svdf, svdf_key, mask, ovdf, bvh })
            } else {
                None
            };
            objects.push(PreparedObject { mesh: o.mesh.clone(), mesh_key, frames, frames_key, brdf, rsl });
        }
        self.objects = objects;
        self.pin_in_use();
        Ok(())
    }

    /// Pins exactly what the current scene uses; the rest becomes evictable.
    fn pin_in_use(&mut self) {
        let mut keys = vec![self.env.rsl_key, self.decomposition_key()];
        for o in &self.objects {
            let k = o.keys();
            keys.extend([k.frames, k.table, k.svdf, k.ovdf]);
        }
        self.store.pin(keys);
    }

    /// The traced lights of the quality settings.
    pub fn traced(&self) -> Traced {
        Traced { lights: self.settings.traced_lights as usize, rays: self.settings.shadow_rays as usize }
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

    /// Fails unless `scene` has the objects and materials this engine was last synced to.
    pub fn check(&self, scene: &Scene) -> Result<()> {
        if scene.objects.len() != self.objects.len()
            || scene
                .objects
                .iter()
                .zip(&self.objects)
                .any(|(o, p)| !(Arc::ptr_eq(&o.mesh, &p.mesh) || *o.mesh == *p.mesh) || o.material != p.brdf)
        {
            bail!("the scene changed since it was prepared: call Engine::sync first");
        }
        Ok(())
    }

    /// The number of prepared objects.
    pub fn object_count(&self) -> usize {
        self.objects.len()
    }

    /// Object `i`'s mesh (object space).
    pub fn mesh(&self, i: usize) -> &Arc<TriMesh> {
        &self.objects[i].mesh
    }

    /// Object `i`'s per-vertex frames (object space).
    pub fn frames(&self, i: usize) -> &Arc<VertexFrames> {
        &self.objects[i].frames
    }

    /// Object `i`'s BRDF.
    pub fn brdf(&self, i: usize) -> &Brdf {
        &self.objects[i].brdf
    }

    /// Object `i`'s content keys.
    pub fn keys(&self, i: usize) -> ObjectKeys {
        self.objects[i].keys()
    }

    /// The prepared objects of `scene` at `state` (what the RSL path evaluates).
    pub fn objects(&self, scene: &Scene, state: &SceneState) -> Result<Vec<ShadeObject<'_>>> {
        self.check(scene)?;
        self.objects
            .iter()
            .zip(&state.objects)
            .map(|(p, &transform)| {
                let r = p.rsl.as_ref().context("this engine prepares no RSL layer (tables and fields)")?;
                Ok(ShadeObject {
                    mesh: &p.mesh,
                    frames: &p.frames,
                    table: &r.table,
                    svdf: &r.svdf,
                    mask: &r.mask,
                    ovdf: r.ovdf.as_ref().map(|(f, _)| &**f),
                    occluder: r.bvh.as_deref(),
                    transform,
                })
            })
            .collect()
    }

    /// The shading inputs of `scene` at `state`, seen from `eye`.
    pub fn setup(&self, scene: &Scene, state: &SceneState, eye: Vec3, terms: Terms) -> Result<FrameSetup<'_>> {
        let objects = self.objects(scene, state)?;
        Ok(FrameSetup::new(&objects, &self.lights(state), eye, terms).with_traced(self.traced(), state.world_from_env))
    }

    /// Shades every vertex of `scene` at time `t` (the CPU fast path), seen from the camera.
    pub fn shade(&self, scene: &Scene, t: f32) -> Result<ShadedFrame> {
        self.shade_with(scene, t, Terms::default())
    }

    /// [`Engine::shade`] keeping every light's cover at every vertex
    /// ([`rsl_shade::shade_covers`]), for the interreflections to read rather than find
    /// again ([`crate::bounce::interreflections`]'s `known`): the radiance is
    /// [`Engine::shade`]'s to float rounding (the lights are summed in another order). `None`
    /// for the covers where they would pass the memory bound of
    /// [`crate::engine::check_size`]: the radiance alone, as [`Engine::shade`].
    pub fn shade_keeping_covers(&self, scene: &Scene, t: f32) -> Result<(ShadedFrame, Option<Vec<Option<Covers>>>)> {
        self.shade_objects_keeping_covers(scene, t, &vec![true; scene.objects.len()])
    }

    /// [`Engine::shade_keeping_covers`] for the objects `which` selects (one flag per
    /// object), as [`Engine::shade_objects`]: the others' radiance, positions, normals and
    /// covers come back empty. An object's radiance and covers are those of the whole frame.
    /// The memory bound is the whole frame's covers, since a front end keeps those of the
    /// objects not shaded again.
    pub fn shade_objects_keeping_covers(
        &self,
        scene: &Scene,
        t: f32,
        which: &[bool],
    ) -> Result<(ShadedFrame, Option<Vec<Option<Covers>>>)> {
        let state = scene.at(t);
        let setup = self.setup(scene, &state, scene.camera.eye, Terms::default())?;
        let keep = crate::lobe::check_covers_size(self, &setup, &vec![true; which.len()]).is_ok();
        let start = Instant::now();
        let (radiance, covers, stats) = if keep {
            let (radiance, covers, stats) = rsl_shade::shade_covers(&setup, which);
            (radiance, Some(covers), stats)
        } else {
            let (radiance, stats) = rsl_shade::shade_objects(&setup, which);
            (radiance, None, stats)
        };
        let shade_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok((ShadedFrame::of(&setup, state, radiance, stats, shade_ms), covers))
    }

    /// [`Engine::shade`] for the objects `which` selects (one flag per object): the others'
    /// radiance, positions and normals come back empty. A material edit changes one
    /// object's radiance and nothing else's; the viewer reshades that object alone.
    pub fn shade_objects(&self, scene: &Scene, t: f32, which: &[bool]) -> Result<ShadedFrame> {
        let state = scene.at(t);
        let setup = self.setup(scene, &state, scene.camera.eye, Terms::default())?;
        let start = Instant::now();
        let (radiance, stats) = rsl_shade::shade_objects(&setup, which);
        let shade_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(ShadedFrame::of(&setup, state, radiance, stats, shade_ms))
    }

    /// Per object, whether object `j` can shadow it at `state` ([`FrameSetup::may_shadow`]):
    /// what must be reshaded, beside `j` itself, when `j` moves to or from this pose.
    pub fn shadowed_by(&self, scene: &Scene, state: &SceneState, j: usize) -> Result<Vec<bool>> {
        let setup = self.setup(scene, state, scene.camera.eye, Terms::default())?;
        Ok((0..scene.objects.len()).map(|i| setup.may_shadow(j, i)).collect())
    }

    /// Per object, whether any object `movers` marks can shadow it at `state` (one frame
    /// set up for all of them; [`Engine::shadowed_by`] for each).
    pub fn shadowed_by_any(&self, scene: &Scene, state: &SceneState, movers: &[bool]) -> Result<Vec<bool>> {
        let setup = self.setup(scene, state, scene.camera.eye, Terms::default())?;
        let n = scene.objects.len();
        Ok((0..n).map(|i| (0..n).any(|j| movers.get(j).copied().unwrap_or(false) && setup.may_shadow(j, i))).collect())
    }

    /// [`Engine::shade`] with a choice of terms.
    pub fn shade_with(&self, scene: &Scene, t: f32, terms: Terms) -> Result<ShadedFrame> {
        let state = scene.at(t);
        let setup = self.setup(scene, &state, scene.camera.eye, terms)?;
        let start = Instant::now();
        let (radiance, stats) = rsl_shade::shade(&setup);
        let shade_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(ShadedFrame::of(&setup, state, radiance, stats, shade_ms))
    }
}

impl PreparedObject {
    fn keys(&self) -> ObjectKeys {
        let r = self.rsl.as_ref();
        ObjectKeys {
            mesh: self.mesh_key,
            frames: self.frames_key,
            table: r.map_or(0, |r| r.table_key),
            svdf: r.map_or(0, |r| r.svdf_key),
            ovdf: r.and_then(|r| r.ovdf.as_ref()).map_or(0, |(_, k)| *k),
        }
    }
}

/// A map as the environment's radiance, keyed by its decoded texels (a map file and the
/// bundled copy of the same map share their caches).
/// The lat-long map `source` names (a file or a bundled map), read; `None` for a constant.
/// (Negative texels clamped to 0 are reported by the loader, once.)
pub(crate) fn load_map(source: &EnvironmentSource) -> Result<Option<LatLongMap>> {
    Ok(match source {
        EnvironmentSource::Map { written, path } => {
            Some(rsl_env::load_latlong(path).with_context(|| format!("environment map {written}"))?.map)
        }
        EnvironmentSource::Constant(_) => None,
        EnvironmentSource::Bundled(name) => {
            Some(rsl_env::load_bundled(name).with_context(|| format!("bundled environment map {name}"))?.map)
        }
    })
}

fn map_radiance(m: LatLongMap) -> (EnvRadiance, u64) {
    let key = m
        .texels()
        .iter()
        .fold(KeyHasher::default().str("map").u64(m.width() as u64).u64(m.height() as u64), |h, t| {
            h.f32s(&t.to_array())
        })
        .finish();
    (EnvRadiance::Map(Arc::new(m)), key)
}

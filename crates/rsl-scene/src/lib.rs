//! Scene description: the scene file (TOML), glTF import, primitives, materials, cameras
//! and motion.
//!
//! This crate describes a scene; it evaluates nothing. Paths in a scene file are relative
//! to the file. Scene time is in seconds; angles are degrees in the file and radians here.
//!
//! ```toml
//! quality = "draft"                       # or [quality] preset = "paper", table_resolution = 64
//! [environment]
//! map = "../hdri/studio.exr"              # lat-long OpenEXR or Radiance .hdr; or constant = [r, g, b]
//! intensity = 1.0
//! rotation = { axis = [0.0, 1.0, 0.0], degrees = 30.0 }     # world-from-environment
//! rsl_count = 30
//! motion = { spin = { axis = [0.0, 1.0, 0.0], degrees_per_second = 10.0 } }
//! [camera]
//! eye = [0.0, 1.2, 4.0]
//! target = [0.0, 0.4, 0.0]
//! [[objects]]
//! name = "bunny"
//! mesh = "../models/bunny.glb"            # or primitive = { kind = "sphere", radius = 0.5 }
//! translation = [0.0, 0.9, 0.0]
//! rotation = { axis = [0.0, 1.0, 0.0], degrees = 45.0 }
//! scale = 1.0                             # or [sx, sy, sz]
//! material = { model = "ggx", alpha = 0.2 }
//! motion = { spin = { axis = [0.0, 1.0, 0.0], degrees_per_second = 45.0 } }
//! ```

pub mod build;
mod error;
pub mod gltf_import;
mod gltf_scene;
pub mod material;
pub mod motion;
pub mod primitive;
pub mod quality;
mod raw;
pub mod texture;
mod write;

pub use error::SceneError;
pub use material::default_material;
pub use motion::{Keyframe, Motion, Orbit, Spin, Transform};
pub use primitive::Primitive;
pub use quality::{Preset, Quality, QualitySettings};
pub use rsl_brdf::Brdf;

/// The most pixels a camera may have (8192×4096): the renderers hold about 40 bytes per pixel
/// (radiance, depth, coverage, display colour).
pub const MAX_PIXELS: u64 = 1 << 25;

use glam::{Mat4, Quat, Vec3};
use rsl_sphere::mesh::TriMesh;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where an environment's radiance comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum EnvironmentSource {
    /// A lat-long map file.
    Map {
        /// As written in the scene file.
        written: String,
        /// Resolved against the scene file's folder.
        path: PathBuf,
    },
    /// The same radiance in every direction.
    Constant(Vec3),
    /// A map compiled into the program, by name (`rsl_env::BUNDLED_NAMES`): what a glTF
    /// file opened without `--env` is lit by.
    Bundled(String),
}

/// The environment light.
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// The radiance source.
    pub source: EnvironmentSource,
    /// Scale applied to the map or constant.
    pub intensity: f32,
    /// World-from-environment rotation at time 0.
    pub rotation: Quat,
    /// Rotation over time, applied after `rotation`.
    pub spin: Option<Spin>,
    /// Number of rotatable square lights to decompose the map into.
    pub rsl_count: u32,
}

/// Default number of RSLs (Xu et al.: 20–40 usually suffice).
pub const DEFAULT_RSL_COUNT: u32 = 30;

/// A pinhole camera with a vertical field of view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up direction (not parallel to the view).
    pub up: Vec3,
    /// Vertical field of view in radians.
    pub fov_y: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Camera {
    /// Right-handed view matrix (`camera_from_world`).
    pub fn camera_from_world(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.up)
    }

    /// Distance of the near clipping plane from the eye: `1e-4` of the distance to the
    /// target, so that a scene a millionth of a unit across is drawn as one a unit across
    /// (a fixed plane clipped it away whole).
    pub fn near(&self) -> f32 {
        (1e-4 * self.eye.distance(self.target)).max(f32::MIN_POSITIVE)
    }
}

/// Where an object's mesh came from.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshSource {
    /// A glTF file.
    File {
        /// As written in the scene file.
        written: String,
        /// Resolved path.
        path: PathBuf,
    },
    /// One primitive of one mesh of a glTF file, in the mesh's own space (an object of a
    /// scene opened from a glTF file).
    GltfPart {
        /// As written in the scene file (the file's name when opened from it).
        written: String,
        /// Resolved path.
        path: PathBuf,
        /// The mesh's index in the file.
        mesh: usize,
        /// The primitive's index in the mesh.
        primitive: usize,
    },
    /// The triangles of a glTF node whose transform has shear or a mirror, moved into world
    /// space on import (a scene file cannot hold them: saving such a scene is refused).
    GltfMoved {
        /// The file's name.
        written: String,
        /// Resolved path.
        path: PathBuf,
    },
    /// A generated primitive.
    Primitive(Primitive),
}

/// An object of the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Name (unique in the scene).
    pub name: String,
    /// Where the mesh came from.
    pub source: MeshSource,
    /// The mesh in object space (shared: precomputation keys on it).
    pub mesh: Arc<TriMesh>,
    /// Transform at time 0 (before motion).
    pub transform: Transform,
    /// The material.
    pub material: Brdf,
    /// Motion over time.
    pub motion: Motion,
    /// Whether the object shadows others.
    pub casts_shadows: bool,
    /// How its radiance reaches the image (`method = "..."`; honoured by `--method auto`).
    pub method: ObjectMethod,
    /// Its base-colour texture, for a glTF material that has one (its `base_color` is the
    /// factor the texture multiplies). Scene files do not hold textures.
    pub texture: Option<texture::ObjectTexture>,
    /// Its metallic-roughness texture, for a glTF material that has one (`material` holds
    /// its means; the truth evaluates it per sample).
    pub metallic_roughness: Option<texture::MetallicRoughnessTexture>,
}

/// How an object's radiance reaches the image, per object: `method = "auto"` (the default)
/// or the name of a per-object method of `rsl_engine`'s registry — `rsl`, `pixel` (also read
/// as `rsl_pixel`), `hybrid`, `lobe`, or one a program registered ([`register_method_name`]).
/// For a glossy object `auto` takes `pixel` or `hybrid`, whichever a sample of its pixels
/// finds nearer the truth (`rsl_engine::lobe::Composite::auto_choice`). A Lambertian object is shaded at its
/// vertices by the RSL path and interpolated by the built-in methods: its radiance varies no
/// faster than its visibility, and its BRDF term is exact.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ObjectMethod(&'static str);

/// The per-object method names besides the built-in ones, as programs registered them.
static REGISTERED_METHODS: std::sync::RwLock<Vec<&'static str>> = std::sync::RwLock::new(Vec::new());

/// Lets scene files name the per-object method `name` (rsl-engine's registry calls it for a
/// method registered with per-object use).
pub fn register_method_name(name: &'static str) {
    let mut w = REGISTERED_METHODS.write().unwrap_or_else(|e| e.into_inner());
    if !w.contains(&name) {
        w.push(name);
    }
}

impl ObjectMethod {
    /// `auto`'s rule (the default).
    pub const AUTO: ObjectMethod = ObjectMethod("auto");
    /// The RSL path at the vertices, interpolated across triangles (the fastest).
    pub const RSL: ObjectMethod = ObjectMethod("rsl");
    /// The RSL sum per pixel, with the visibility interpolated from the vertices.
    pub const PIXEL: ObjectMethod = ObjectMethod("pixel");
    /// vMF lobes over the prefiltered environment per pixel, times the RSL path's visibility
    /// ratio (at each pixel on the CPU: the traced lights traced there, the others'
    /// interpolated from the vertices; on the GPU interpolated from the vertices).
    pub const HYBRID: ObjectMethod = ObjectMethod("hybrid");
    /// Transport lobes (the material's lobes shadowed by the object itself, per vertex and
    /// object-space view), each shadowed by the other objects' occluder fields over a square
    /// of its own width; drawn per pixel with the material lobes times that shadow as a ratio
    /// interpolated across the triangle.
    pub const LOBE: ObjectMethod = ObjectMethod("lobe");
    const BUILT_IN: [ObjectMethod; 5] = [Self::AUTO, Self::RSL, Self::PIXEL, Self::HYBRID, Self::LOBE];

    /// Whether it is one of the scene file's own choices (not a method a program registered).
    pub fn is_built_in(self) -> bool {
        Self::BUILT_IN.contains(&self)
    }

    /// The method named `name` (`rsl_pixel` is `pixel`), if scene files may name it.
    pub fn named(name: &str) -> Option<Self> {
        let name = if name == "rsl_pixel" { "pixel" } else { name };
        Self::BUILT_IN.into_iter().find(|m| m.0 == name).or_else(|| {
            let r = REGISTERED_METHODS.read().unwrap_or_else(|e| e.into_inner());
            r.iter().find(|&&n| n == name).map(|&n| ObjectMethod(n))
        })
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        self.0
    }

    /// Every name a scene file may give, built-in ones first.
    pub fn names() -> Vec<&'static str> {
        let r = REGISTERED_METHODS.read().unwrap_or_else(|e| e.into_inner());
        Self::BUILT_IN.iter().map(|m| m.0).chain(r.iter().copied()).collect()
    }
}

impl Default for ObjectMethod {
    fn default() -> Self {
        Self::AUTO
    }
}

impl std::fmt::Display for ObjectMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.0)
    }
}

impl serde::Serialize for ObjectMethod {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.0)
    }
}

impl<'de> serde::Deserialize<'de> for ObjectMethod {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        ObjectMethod::named(&name).ok_or_else(|| {
            serde::de::Error::custom(format!(
                "unknown method `{name}`, expected one of {}",
                ObjectMethod::names().iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ")
            ))
        })
    }
}

/// A loaded, validated scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The scene file.
    pub path: PathBuf,
    /// The environment light.
    pub environment: Environment,
    /// The camera.
    pub camera: Camera,
    /// The objects, in file order.
    pub objects: Vec<Object>,
    /// Precomputation quality.
    pub quality: Quality,
}

/// World transforms and environment rotation at one time.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneState {
    /// Time in seconds.
    pub time: f32,
    /// World-from-environment rotation.
    pub world_from_env: Quat,
    /// Per object, in scene order.
    pub objects: Vec<Transform>,
}

impl SceneState {
    /// `world_from_object` matrix of object `i`.
    pub fn world_from_object(&self, i: usize) -> Mat4 {
        self.objects[i].matrix()
    }
}

impl Scene {
    /// Reads, parses and validates a scene file, importing or generating every mesh.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        Self::load_with_camera(path, None)
    }

    /// [`Scene::load`], a glTF file seen through its perspective camera number `camera`
    /// where it is given ([`Scene::from_gltf_camera`]); a scene file refuses one.
    pub fn load_with_camera(path: impl AsRef<Path>, camera: Option<usize>) -> Result<Self, SceneError> {
        let path = path.as_ref();
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        if matches!(ext.as_deref(), Some("glb" | "gltf")) {
            return Self::from_gltf_camera(path, camera);
        }
        if camera.is_some() {
            return Err(SceneError::file(path, "--camera chooses a glTF file's camera; this is a scene file"));
        }
        let text = rsl_sphere::io::read_text_bounded(path, rsl_sphere::io::MAX_SCENE_BYTES)
            .map_err(|e| SceneError::file(path, format!("cannot read scene file: {e}")))?;
        Self::from_toml_str(&text, path)
    }

    /// Parses scene text as if read from `path` (which locates relative files and errors).
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Self, SceneError> {
        raw::parse(text, path)
    }

    /// World transforms and environment rotation at time `t` (seconds).
    pub fn at(&self, t: f32) -> SceneState {
        let env = &self.environment;
        let world_from_env = match &env.spin {
            Some(s) => (s.at(t) * env.rotation).normalize(),
            None => env.rotation,
        };
        SceneState {
            time: t,
            world_from_env,
            objects: self.objects.iter().map(|o| o.motion.at(&o.transform, t)).collect(),
        }
    }

    /// Whether anything moves over time.
    pub fn is_dynamic(&self) -> bool {
        self.environment.spin.is_some() || self.objects.iter().any(|o| !o.motion.is_static())
    }

    /// The files the scene was read from: the scene file, its environment map and its
    /// meshes (each once).
    pub fn input_files(&self) -> Vec<&Path> {
        let mut files = vec![self.path.as_path()];
        if let EnvironmentSource::Map { path, .. } = &self.environment.source {
            files.push(path);
        }
        for o in &self.objects {
            if let MeshSource::File { path, .. }
            | MeshSource::GltfPart { path, .. }
            | MeshSource::GltfMoved { path, .. } = &o.source
                && !files.contains(&path.as_path())
            {
                files.push(path);
            }
        }
        files
    }

    /// Total vertex and triangle counts.
    pub fn counts(&self) -> (usize, usize) {
        self.objects.iter().fold((0, 0), |(v, t), o| (v + o.mesh.vertex_count(), t + o.mesh.triangle_count()))
    }

    /// A human-readable summary of the scene.
    pub fn summary(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let env = &self.environment;
        let _ = writeln!(s, "scene {}", self.path.display());
        match &env.source {
            EnvironmentSource::Map { written, path } => {
                let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
                let _ = writeln!(s, "  environment  map {written} ({size} bytes) × {}", env.intensity);
            }
            EnvironmentSource::Constant(c) => {
                let _ = writeln!(s, "  environment  constant [{}, {}, {}] × {}", c.x, c.y, c.z, env.intensity);
            }
            EnvironmentSource::Bundled(name) => {
                let _ = writeln!(s, "  environment  bundled map {name} × {}", env.intensity);
            }
        }
        let (axis, angle) = env.rotation.to_axis_angle();
        let _ = write!(
            s,
            "               rotation {:.1}° about {}, {} RSLs",
            angle.to_degrees(),
            fmt_vec(axis),
            env.rsl_count
        );
        if let Some(sp) = &env.spin {
            let _ = write!(s, ", spinning {:.1}°/s about {}", sp.radians_per_second.to_degrees(), fmt_vec(sp.axis));
        }
        s.push('\n');
        let c = &self.camera;
        let _ = writeln!(
            s,
            "  camera       eye {} target {} fov {:.1}° {}×{}",
            fmt_vec(c.eye),
            fmt_vec(c.target),
            c.fov_y.to_degrees(),
            c.width,
            c.height
        );
        let q = &self.quality;
        let knobs: Vec<String> = q.settings.knobs().iter().map(|(k, v)| format!("{k}={v}")).collect();
        let _ = writeln!(s, "  quality      {} ({})", q.preset.name(), knobs.join(" "));
        let (nv, nt) = self.counts();
        let _ = writeln!(s, "  objects      {} ({nv} vertices, {nt} triangles)", self.objects.len());
        for o in &self.objects {
            let src = match &o.source {
                MeshSource::File { written, .. } => written.clone(),
                MeshSource::GltfPart { written, mesh, primitive, .. } => {
                    format!("{written} (mesh {mesh} primitive {primitive})")
                }
                MeshSource::GltfMoved { written, .. } => format!("{written} (a sheared or mirrored node)"),
                MeshSource::Primitive(p) => p.describe(),
            };
            let radius = o.mesh.bounding_sphere().map_or(0.0, |(_, r)| r) * o.transform.scale.max_element();
            let _ = writeln!(
                s,
                "    {:<12} {src}: {} vertices, {} triangles, bounding radius {:.3} (world)",
                o.name,
                o.mesh.vertex_count(),
                o.mesh.triangle_count(),
                radius
            );
            let _ = writeln!(
                s,
                "                 at {} scale {}",
                fmt_vec(o.transform.translation),
                fmt_vec(o.transform.scale)
            );
            let _ = writeln!(s, "                 material {}", o.material);
            if let Some(t) = &o.texture {
                let t = &t.texture;
                let _ = writeln!(s, "                 base-colour texture {}: {}×{} texels", t.name, t.width, t.height);
            }
            if let Some(t) = &o.metallic_roughness {
                let t = &t.map.texture;
                let _ = writeln!(
                    s,
                    "                 metallic-roughness texture {}: {}×{} texels (drawn as its means)",
                    t.name, t.width, t.height
                );
            }
            let mut moves = Vec::new();
            if let Some(sp) = &o.motion.spin {
                moves.push(format!("spin {:.1}°/s about {}", sp.radians_per_second.to_degrees(), fmt_vec(sp.axis)));
            }
            if let Some(or) = &o.motion.orbit {
                moves.push(format!(
                    "orbit {:.1}°/s about {} through {}",
                    or.spin.radians_per_second.to_degrees(),
                    fmt_vec(or.spin.axis),
                    fmt_vec(or.centre)
                ));
            }
            if !o.motion.keyframes.is_empty() {
                let k = &o.motion.keyframes;
                moves.push(format!("{} keyframes from {} s to {} s", k.len(), k[0].time, k[k.len() - 1].time));
            }
            if !moves.is_empty() {
                let _ = writeln!(s, "                 motion {}", moves.join(", "));
            }
            if !o.casts_shadows {
                let _ = writeln!(s, "                 casts no shadows");
            }
        }
        s
    }
}

fn fmt_vec(v: Vec3) -> String {
    format!("[{:.3}, {:.3}, {:.3}]", v.x, v.y, v.z)
}

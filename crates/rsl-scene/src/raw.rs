//! The scene file as written (serde structs) and its validation into a [`Scene`].

use crate::material::{MaterialFile, default_material};
use crate::motion::{Keyframe, Motion, Orbit, Spin, Transform};
use crate::primitive::Primitive;
use crate::quality::{Preset, Quality};
use crate::{Camera, Environment, EnvironmentSource, MeshSource, Object, Scene, SceneError};
use glam::{Quat, Vec3};
use rsl_sphere::mesh::TriMesh;
use serde::Deserialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    environment: RawEnvironment,
    camera: RawCamera,
    #[serde(default)]
    objects: Vec<RawObject>,
    quality: Option<toml::Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEnvironment {
    map: Option<String>,
    constant: Option<[f32; 3]>,
    bundled: Option<String>,
    #[serde(default = "one")]
    intensity: f32,
    rotation: Option<RawRotation>,
    rsl_count: Option<i64>,
    motion: Option<RawEnvMotion>,
}

fn one() -> f32 {
    1.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEnvMotion {
    spin: Option<RawSpin>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct RawRotation {
    axis: Option<[f32; 3]>,
    degrees: Option<f32>,
    /// `[x, y, z, w]`, a unit quaternion (what `rsl view` writes: exact round trips).
    quaternion: Option<[f32; 4]>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct RawSpin {
    axis: [f32; 3],
    degrees_per_second: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOrbit {
    #[serde(default)]
    centre: [f32; 3],
    axis: [f32; 3],
    degrees_per_second: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKeyframe {
    time: f32,
    translation: Option<[f32; 3]>,
    rotation: Option<RawRotation>,
    scale: Option<RawScale>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMotion {
    spin: Option<RawSpin>,
    orbit: Option<RawOrbit>,
    keyframes: Option<Vec<RawKeyframe>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    eye: [f32; 3],
    target: [f32; 3],
    #[serde(default = "up")]
    up: [f32; 3],
    #[serde(default = "fov")]
    fov_y_degrees: f32,
    #[serde(default = "width")]
    width: i64,
    #[serde(default = "height")]
    height: i64,
}

fn up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}
fn fov() -> f32 {
    40.0
}
fn width() -> i64 {
    640
}
fn height() -> i64 {
    480
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObject {
    name: Option<String>,
    mesh: Option<String>,
    /// With `mesh`: one primitive of one glTF mesh, in the mesh's own space (what a scene
    /// opened from a glTF file writes), rather than the whole file merged.
    gltf_mesh: Option<usize>,
    /// With `gltf_mesh`: the primitive (default 0).
    gltf_primitive: Option<usize>,
    /// With `gltf_mesh`: the primitive's base-colour texture multiplies the material's base
    /// colour (a `gltf` material).
    #[serde(default)]
    gltf_texture: bool,
    primitive: Option<Primitive>,
    #[serde(default)]
    translation: [f32; 3],
    rotation: Option<RawRotation>,
    scale: Option<RawScale>,
    material: Option<MaterialFile>,
    motion: Option<RawMotion>,
    #[serde(default = "yes")]
    casts_shadows: bool,
    #[serde(default)]
    method: crate::ObjectMethod,
}

fn yes() -> bool {
    true
}

/// A scale written as one number or as `[sx, sy, sz]`.
#[derive(Clone, Copy)]
struct RawScale([f32; 3]);

impl<'de> Deserialize<'de> for RawScale {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = RawScale;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number or an array of three numbers")
            }
            fn visit_f64<E>(self, v: f64) -> Result<RawScale, E> {
                Ok(RawScale([v as f32; 3]))
            }
            fn visit_i64<E>(self, v: i64) -> Result<RawScale, E> {
                Ok(RawScale([v as f32; 3]))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<RawScale, A::Error> {
                let mut out = [0.0f32; 3];
                for (k, o) in out.iter_mut().enumerate() {
                    *o = seq.next_element()?.ok_or_else(|| serde::de::Error::invalid_length(k, &self))?;
                }
                if seq.next_element::<f32>()?.is_some() {
                    return Err(serde::de::Error::invalid_length(4, &self));
                }
                Ok(RawScale(out))
            }
        }
        d.deserialize_any(V)
    }
}

/// Validation context: the scene file, for errors and relative paths.
struct Ctx<'a> {
    file: &'a Path,
}

impl Ctx<'_> {
    fn err(&self, field: &str, msg: impl Into<String>) -> SceneError {
        SceneError::field(self.file, field, msg)
    }

    fn finite(&self, field: &str, v: f32) -> Result<f32, SceneError> {
        if v.is_finite() { Ok(v) } else { Err(self.err(field, format!("must be a finite number, got {v}"))) }
    }

    fn vec3(&self, field: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        if v.iter().all(|c| c.is_finite()) {
            Ok(Vec3::from(v))
        } else {
            Err(self.err(field, format!("must be finite numbers, got {v:?}")))
        }
    }

    fn axis(&self, field: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        let a = self.vec3(field, v)?;
        // Scaled first: the squared length of [1e30, 1e30, 0] overflows.
        let m = a.abs().max_element();
        rsl_sphere::frame::try_normalize(if m > 0.0 { a / m } else { a })
            .ok_or_else(|| self.err(field, "axis is zero; it needs a direction"))
    }

    fn rotation(&self, field: &str, r: RawRotation) -> Result<Quat, SceneError> {
        match (r.axis, r.degrees, r.quaternion) {
            (Some(axis), Some(degrees), None) => {
                let axis = self.axis(&format!("{field}.axis"), axis)?;
                let deg = self.finite(&format!("{field}.degrees"), degrees)?;
                Ok(Quat::from_axis_angle(axis, deg.to_radians()))
            }
            (None, None, Some(q)) => {
                let f = format!("{field}.quaternion");
                let q = Quat::from_array(q);
                if !q.is_finite() || (q.length_squared() - 1.0).abs() > 1e-3 {
                    return Err(self.err(&f, format!("must be a unit quaternion [x, y, z, w], got {:?}", q.to_array())));
                }
                // A quaternion written by rsl is unit to rounding: kept bit for bit.
                Ok(if (q.length_squared() - 1.0).abs() <= 1e-6 { q } else { q.normalize() })
            }
            _ => Err(self.err(field, "needs `axis` and `degrees`, or `quaternion` alone")),
        }
    }

    fn spin(&self, field: &str, s: RawSpin) -> Result<Spin, SceneError> {
        Ok(Spin {
            axis: self.axis(&format!("{field}.axis"), s.axis)?,
            radians_per_second: self.finite(&format!("{field}.degrees_per_second"), s.degrees_per_second)?.to_radians(),
        })
    }

    fn scale(&self, field: &str, s: RawScale) -> Result<Vec3, SceneError> {
        let v = self.vec3(field, s.0)?;
        if v.min_element() > 0.0 { Ok(v) } else { Err(self.err(field, format!("must be > 0, got {:?}", s.0))) }
    }

    /// Resolves a path written in the scene file; errors if the file does not exist.
    fn existing_file(&self, field: &str, written: &str) -> Result<PathBuf, SceneError> {
        let dir = self.file.parent().unwrap_or(Path::new(""));
        let path = dir.join(written);
        if !path.is_file() {
            let shown = std::path::absolute(&path).unwrap_or_else(|_| path.clone());
            return Err(self.err(field, format!("file not found: \"{written}\" (resolved to {})", shown.display())));
        }
        Ok(path)
    }
}

pub(crate) fn parse(text: &str, file: &Path) -> Result<Scene, SceneError> {
    let raw: RawScene = toml::from_str(text).map_err(|e| SceneError::toml(file, text, &e))?;
    let cx = Ctx { file };
    let environment = environment(&cx, raw.environment)?;
    let camera = camera(&cx, raw.camera)?;
    let quality = quality(&cx, raw.quality)?;
    let mut objects = Vec::with_capacity(raw.objects.len());
    let mut meshes = Meshes::default();
    for (i, o) in raw.objects.into_iter().enumerate() {
        let obj = object(&cx, i, o, &mut meshes)?;
        if let Some(prev) = objects.iter().position(|p: &Object| p.name == obj.name) {
            return Err(cx.err(
                &format!("objects[{i}].name"),
                format!("\"{}\" is already the name of objects[{prev}]", obj.name),
            ));
        }
        objects.push(obj);
    }
    Ok(Scene { path: file.to_path_buf(), environment, camera, objects, quality })
}

fn environment(cx: &Ctx, e: RawEnvironment) -> Result<Environment, SceneError> {
    let source = match (e.map, e.constant, e.bundled) {
        (None, None, None) => {
            return Err(
                cx.err("environment", "needs `map = \"file.exr\"`, `constant = [r, g, b]` or `bundled = \"studio\"`")
            );
        }
        (Some(written), None, None) => {
            let lower = written.to_ascii_lowercase();
            if !(lower.ends_with(".exr") || lower.ends_with(".hdr")) {
                return Err(cx.err(
                    "environment.map",
                    format!("\"{written}\": expected a lat-long OpenEXR (.exr) or Radiance (.hdr) file"),
                ));
            }
            let path = cx.existing_file("environment.map", &written)?;
            EnvironmentSource::Map { written, path }
        }
        (None, Some(c), None) => {
            let c = cx.vec3("environment.constant", c)?;
            if c.min_element() < 0.0 {
                return Err(cx.err("environment.constant", format!("radiance must be ≥ 0, got {c:?}")));
            }
            EnvironmentSource::Constant(c)
        }
        (None, None, Some(name)) => {
            if !rsl_env::BUNDLED_NAMES.contains(&name.as_str()) {
                return Err(cx.err(
                    "environment.bundled",
                    format!("no bundled map is called \"{name}\"; there is {}", rsl_env::BUNDLED_NAMES.join(", ")),
                ));
            }
            EnvironmentSource::Bundled(name)
        }
        _ => return Err(cx.err("environment", "give one of `map`, `constant` and `bundled`, not several")),
    };
    let intensity = cx.finite("environment.intensity", e.intensity)?;
    if intensity < 0.0 {
        return Err(cx.err("environment.intensity", format!("must be ≥ 0, got {intensity}")));
    }
    let rotation = match e.rotation {
        Some(r) => cx.rotation("environment.rotation", r)?,
        None => Quat::IDENTITY,
    };
    let spin = match e.motion.and_then(|m| m.spin) {
        Some(s) => Some(cx.spin("environment.motion.spin", s)?),
        None => None,
    };
    let rsl_count = match e.rsl_count {
        None => crate::DEFAULT_RSL_COUNT,
        Some(n) if (1..=1_000_000).contains(&n) => n as u32,
        Some(n) => return Err(cx.err("environment.rsl_count", format!("must be in 1..=1000000, got {n}"))),
    };
    Ok(Environment { source, intensity, rotation, spin, rsl_count })
}

fn camera(cx: &Ctx, c: RawCamera) -> Result<Camera, SceneError> {
    let eye = cx.vec3("camera.eye", c.eye)?;
    let target = cx.vec3("camera.target", c.target)?;
    let up = cx.axis("camera.up", c.up)?;
    let view = rsl_sphere::frame::try_normalize(target - eye)
        .ok_or_else(|| cx.err("camera.target", "equals camera.eye; the camera needs a direction"))?;
    if view.cross(up).length() < 1e-4 {
        return Err(cx.err("camera.up", "is parallel to the view direction"));
    }
    let fov = cx.finite("camera.fov_y_degrees", c.fov_y_degrees)?;
    if !(fov > 0.0 && fov < 180.0) {
        return Err(cx.err("camera.fov_y_degrees", format!("must be between 0 and 180, got {fov}")));
    }
    let dim = |field: &str, v: i64| -> Result<u32, SceneError> {
        if (1..=16384).contains(&v) {
            Ok(v as u32)
        } else {
            Err(cx.err(field, format!("must be in 1..=16384 pixels, got {v}")))
        }
    };
    let (width, height) = (dim("camera.width", c.width)?, dim("camera.height", c.height)?);
    let pixels = u64::from(width) * u64::from(height);
    if pixels > crate::MAX_PIXELS {
        return Err(cx.err(
            "camera.width",
            format!(
                "{width}×{height} is {pixels} pixels, more than the limit of {} (8192×4096): a frame holds about 40 \
                 bytes per pixel",
                crate::MAX_PIXELS
            ),
        ));
    }
    Ok(Camera { eye, target, up, fov_y: fov.to_radians(), width, height })
}

fn quality(cx: &Ctx, q: Option<toml::Value>) -> Result<Quality, SceneError> {
    let preset_of = |field: &str, name: &str| {
        Preset::from_name(name)
            .ok_or_else(|| cx.err(field, format!("unknown preset \"{name}\"; known: draft, standard, paper, high")))
    };
    match q {
        None => Ok(Quality::default()),
        Some(toml::Value::String(name)) => Ok(Quality::from_preset(preset_of("quality", &name)?)),
        Some(toml::Value::Table(t)) => {
            let preset = match t.get("preset") {
                None => Preset::default(),
                Some(toml::Value::String(name)) => preset_of("quality.preset", name)?,
                Some(other) => return Err(cx.err("quality.preset", format!("must be a preset name, got {other}"))),
            };
            let mut q = Quality::from_preset(preset);
            // table_resolution first: it sets both table knobs, and a knob given beside it by
            // name wins (the table's keys come sorted, which put it last).
            let mut knobs: Vec<_> = t.iter().collect();
            knobs.sort_by_key(|(k, _)| *k != "table_resolution");
            for (k, v) in knobs {
                if k == "preset" {
                    continue;
                }
                let field = format!("quality.{k}");
                if !crate::quality::QualitySettings::names().contains(&k.as_str()) {
                    return Err(cx.err(
                        &field,
                        format!(
                            "unknown quality setting; known: preset, {}",
                            crate::quality::QualitySettings::names().join(", ")
                        ),
                    ));
                }
                let n = match v {
                    toml::Value::Integer(n) => crate::quality::QualitySettings::parse_value(k, &n.to_string())
                        .map_err(|m| cx.err(&field, m))?,
                    toml::Value::String(t) => {
                        crate::quality::QualitySettings::parse_value(k, t).map_err(|m| cx.err(&field, m))?
                    }
                    _ => return Err(cx.err(&field, format!("must be an integer, got {v}"))),
                };
                q.settings.set(k, n).map_err(|m| cx.err(&field, m))?;
            }
            Ok(q)
        }
        Some(other) => Err(cx.err("quality", format!("must be a preset name or a table, got {other}"))),
    }
}

/// A mesh read from a file: the file, and the glTF mesh and primitive where it is one part.
type MeshKey = (PathBuf, Option<(usize, usize)>);

/// The meshes a scene file's objects read, by file and part, and the glTF files whose parts
/// they name (each read once, however many of its parts the scene names).
#[derive(Default)]
struct Meshes {
    read: HashMap<MeshKey, Arc<TriMesh>>,
    files: HashMap<PathBuf, crate::gltf_import::GltfFile>,
}

/// A mesh read from the glTF file `path` (whole, or one part), checked: valid, its triangles
/// rewound to follow their normals (with a warning), its skipped primitives said.
pub(crate) fn checked_mesh(
    path: &Path,
    (mut m, report): (TriMesh, crate::gltf_import::ImportReport),
) -> Result<TriMesh, SceneError> {
    m.validate().map_err(|e| SceneError::file(path, e.to_string()))?;
    let (_, faces) = m.faces_against_normals();
    let against = m.rewind_to_normals();
    if against > 0 {
        tracing::warn!(
            "{}: the normals of {against} of its {faces} triangles point against their winding; \
             those triangles are rewound to follow their normals, which say the side rsl shades \
             (if that is the inside, flip the file's normals)",
            path.display()
        );
    }
    if report.skipped_non_triangle > 0 {
        tracing::warn!(
            "{}: {} primitive(s) are not triangle lists (points, lines, strips or fans) and were left out",
            path.display(),
            report.skipped_non_triangle
        );
    }
    Ok(m)
}

fn object(cx: &Ctx, i: usize, o: RawObject, meshes: &mut Meshes) -> Result<Object, SceneError> {
    let name = match o.name {
        Some(n) if n.trim().is_empty() => return Err(cx.err(&format!("objects[{i}].name"), "is empty")),
        Some(n) if n.chars().any(char::is_control) => {
            return Err(cx.err(
                &format!("objects[{i}].name"),
                format!("{n:?} holds a control character (a line break, a tab…): names go into reports and CSV files"),
            ));
        }
        Some(n) => n,
        None => format!("object{i}"),
    };
    let f = |field: &str| format!("objects[{i}] \"{name}\".{field}");
    let material = match o.material {
        Some(m) => m.into_brdf().map_err(|(field, msg)| cx.err(&f(&format!("material.{field}")), msg))?,
        None => default_material(),
    };

    let mut texture = None;
    let (source, mut mesh) = match (o.mesh, o.primitive) {
        (Some(_), Some(_)) => return Err(cx.err(&f("mesh"), "give either `mesh` or `primitive`, not both")),
        (None, None) => return Err(cx.err(&f("mesh"), "needs `mesh = \"file.glb\"` or `primitive = { kind = ... }`")),
        (Some(written), None) => {
            let lower = written.to_ascii_lowercase();
            if !(lower.ends_with(".glb") || lower.ends_with(".gltf")) {
                return Err(cx.err(&f("mesh"), format!("\"{written}\": expected a glTF file (.glb or .gltf)")));
            }
            let path = cx.existing_file(&f("mesh"), &written)?;
            let part = match (o.gltf_mesh, o.gltf_primitive) {
                (Some(m), p) => Some((m, p.unwrap_or(0))),
                (None, Some(_)) => {
                    return Err(cx.err(&f("gltf_primitive"), "needs `gltf_mesh`, the mesh it is part of"));
                }
                (None, None) => None,
            };
            let key = (path.clone(), part);
            let mesh = match meshes.read.get(&key) {
                Some(m) => Arc::clone(m),
                None => {
                    let read = match part {
                        None => crate::gltf_import::import(&path),
                        Some((m, p)) => {
                            if !meshes.files.contains_key(&path) {
                                let file = crate::gltf_import::GltfFile::open(&path)
                                    .map_err(|msg| SceneError::file(&path, msg))?;
                                meshes.files.insert(path.clone(), file);
                            }
                            meshes.files[&path].part(m, p)
                        }
                    };
                    let m = Arc::new(checked_mesh(&path, read.map_err(|msg| SceneError::file(&path, msg))?)?);
                    meshes.read.insert(key, Arc::clone(&m));
                    m
                }
            };
            if o.gltf_texture {
                let Some((m, p)) = part else {
                    return Err(
                        cx.err(&f("gltf_texture"), "needs `gltf_mesh`, the mesh whose primitive's texture it is")
                    );
                };
                if !matches!(material, crate::Brdf::Gltf { .. }) {
                    return Err(cx.err(
                        &f("gltf_texture"),
                        "a base-colour texture multiplies a `gltf` material's base colour; this material is another model",
                    ));
                }
                if !meshes.files.contains_key(&path) {
                    let file = crate::gltf_import::GltfFile::open(&path).map_err(|msg| SceneError::file(&path, msg))?;
                    meshes.files.insert(path.clone(), file);
                }
                texture = match meshes.files[&path].part_texture(m, p).map_err(|msg| SceneError::file(&path, msg))? {
                    Some(t) => Some(t),
                    None => {
                        return Err(cx.err(
                            &f("gltf_texture"),
                            format!("mesh {m} primitive {p}'s material has no base-colour texture"),
                        ));
                    }
                };
            }
            match part {
                None => (MeshSource::File { written, path }, mesh),
                Some((mesh_index, primitive)) => {
                    (MeshSource::GltfPart { written, path, mesh: mesh_index, primitive }, mesh)
                }
            }
        }
        (None, Some(p)) => {
            if o.gltf_mesh.is_some() || o.gltf_primitive.is_some() || o.gltf_texture {
                return Err(cx.err(&f("gltf_mesh"), "goes with `mesh = \"file.glb\"`, not with `primitive`"));
            }
            p.validate().map_err(|(field, msg)| cx.err(&f(&format!("primitive.{field}")), msg))?;
            let mesh = p.mesh();
            mesh.validate().map_err(|e| cx.err(&f("primitive"), e.to_string()))?;
            (MeshSource::Primitive(p), Arc::new(mesh))
        }
    };
    if material.is_anisotropic() && mesh.tangents.is_none() {
        let mut m = (*mesh).clone();
        m.compute_tangents_from_axis();
        mesh = Arc::new(m);
    }

    let transform = Transform {
        translation: cx.vec3(&f("translation"), o.translation)?,
        rotation: match o.rotation {
            Some(r) => cx.rotation(&f("rotation"), r)?,
            None => Quat::IDENTITY,
        },
        scale: match o.scale {
            Some(s) => cx.scale(&f("scale"), s)?,
            None => Vec3::ONE,
        },
    };
    let motion = match o.motion {
        None => Motion::default(),
        Some(m) => motion(cx, &f("motion"), m, &transform)?,
    };
    reach(cx, &f, &mesh, &transform, &motion)?;
    Ok(Object {
        name,
        source,
        mesh,
        transform,
        material,
        motion,
        casts_shadows: o.casts_shadows,
        method: o.method,
        texture,
        metallic_roughness: None,
    })
}

/// Fails when the object, placed at its transform or anywhere its motion takes it, reaches
/// beyond [`rsl_sphere::mesh::MAX_COORDINATE`] from the origin (naming the scale when the
/// object itself is that large, else the translation or motion).
fn reach(
    cx: &Ctx,
    f: &dyn Fn(&str) -> String,
    mesh: &TriMesh,
    base: &Transform,
    motion: &Motion,
) -> Result<(), SceneError> {
    let limit = rsl_sphere::mesh::MAX_COORDINATE;
    let (c, r) = mesh.bounding_sphere().unwrap_or((Vec3::ZERO, 0.0));
    let size = |t: &Transform| (c.length() + r) * t.scale.max_element();
    let check = |field: &str, t: &Transform, centre: f32| {
        let extent = centre + size(t);
        if extent.is_finite() && extent <= limit {
            return Ok(());
        }
        let field = if size(t) > 0.5 * limit || !size(t).is_finite() { f("scale") } else { field.to_string() };
        Err(cx.err(
            &field,
            format!(
                "places the object {extent:.3e} scene units from the origin; the limit is {limit:e} (f32 \
                 geometry loses its precision beyond it): scale the scene down"
            ),
        ))
    };
    check(&f("translation"), base, base.translation.length())?;
    if let Some(o) = &motion.orbit {
        check(&f("motion.orbit"), base, o.centre.length() + (base.translation - o.centre).length())?;
    }
    for (k, key) in motion.keyframes.iter().enumerate() {
        check(&f(&format!("motion.keyframes[{k}]")), &key.transform, key.transform.translation.length())?;
    }
    Ok(())
}

fn motion(cx: &Ctx, field: &str, m: RawMotion, base: &Transform) -> Result<Motion, SceneError> {
    let spin = match m.spin {
        Some(s) => Some(cx.spin(&format!("{field}.spin"), s)?),
        None => None,
    };
    let orbit = match m.orbit {
        Some(o) => Some(Orbit {
            centre: cx.vec3(&format!("{field}.orbit.centre"), o.centre)?,
            spin: cx
                .spin(&format!("{field}.orbit"), RawSpin { axis: o.axis, degrees_per_second: o.degrees_per_second })?,
        }),
        None => None,
    };
    let mut keyframes = Vec::new();
    if let Some(keys) = m.keyframes {
        if spin.is_some() || orbit.is_some() {
            return Err(cx.err(&format!("{field}.keyframes"), "cannot be combined with spin or orbit"));
        }
        if keys.is_empty() {
            return Err(cx.err(&format!("{field}.keyframes"), "is empty"));
        }
        for (k, key) in keys.into_iter().enumerate() {
            let kf = format!("{field}.keyframes[{k}]");
            let time = cx.finite(&format!("{kf}.time"), key.time)?;
            if let Some(prev) = keyframes.last().map(|p: &Keyframe| p.time)
                && time <= prev
            {
                return Err(cx.err(&format!("{kf}.time"), format!("{time} s is not after the previous key ({prev} s)")));
            }
            let transform = Transform {
                translation: match key.translation {
                    Some(t) => cx.vec3(&format!("{kf}.translation"), t)?,
                    None => base.translation,
                },
                rotation: match key.rotation {
                    Some(r) => cx.rotation(&format!("{kf}.rotation"), r)?,
                    None => base.rotation,
                },
                scale: match key.scale {
                    Some(s) => cx.scale(&format!("{kf}.scale"), s)?,
                    None => base.scale,
                },
            };
            keyframes.push(Keyframe { time, transform });
        }
    }
    Ok(Motion { spin, orbit, keyframes })
}

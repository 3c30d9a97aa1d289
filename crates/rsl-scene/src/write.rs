//! Writing a scene back as a scene file ([`Scene::to_toml`]): what `rsl view` saves after
//! edits, read back by [`Scene::load`] to the same scene.
//!
//! Numbers are written as the `f32` they hold (TOML floats are `f64`, and every `f32` is
//! exact in one), rotations as unit quaternions, so that loading the file gives the same
//! transforms bit for bit; spins keep their degrees per second (a rounding at most).

use crate::motion::{Motion, Spin, Transform};
use crate::quality::QualitySettings;
use crate::{EnvironmentSource, MeshSource, Scene};
use glam::{Quat, Vec3};
use std::path::{Path, PathBuf};
use toml::{Table, Value};

pub(crate) fn num(v: f32) -> Value {
    Value::Float(f64::from(v))
}

pub(crate) fn vec3(v: Vec3) -> Value {
    Value::Array(v.to_array().map(num).to_vec())
}

fn table(pairs: impl IntoIterator<Item = (&'static str, Value)>) -> Value {
    Value::Table(pairs.into_iter().map(|(k, v)| (k.to_string(), v)).collect())
}

fn rotation(q: Quat) -> Value {
    table([("quaternion", Value::Array(q.to_array().map(num).to_vec()))])
}

fn spin(s: &Spin) -> Value {
    table([("axis", vec3(s.axis)), ("degrees_per_second", num(s.radians_per_second.to_degrees()))])
}

fn transform_into(t: &mut Table, x: &Transform) {
    t.insert("translation".into(), vec3(x.translation));
    t.insert("rotation".into(), rotation(x.rotation));
    t.insert("scale".into(), vec3(x.scale));
}

/// An object's `motion` table (`None` for a static object).
pub(crate) fn motion(m: &Motion) -> Option<Value> {
    if m.is_static() {
        return None;
    }
    let mut motion = Table::new();
    if let Some(s) = &m.spin {
        motion.insert("spin".into(), spin(s));
    }
    if let Some(orbit) = &m.orbit {
        let mut ot = Table::new();
        ot.insert("centre".into(), vec3(orbit.centre));
        ot.insert("axis".into(), vec3(orbit.spin.axis));
        ot.insert("degrees_per_second".into(), num(orbit.spin.radians_per_second.to_degrees()));
        motion.insert("orbit".into(), Value::Table(ot));
    }
    if !m.keyframes.is_empty() {
        let keys = m
            .keyframes
            .iter()
            .map(|k| {
                let mut kt = Table::new();
                kt.insert("time".into(), num(k.time));
                transform_into(&mut kt, &k.transform);
                Value::Table(kt)
            })
            .collect();
        motion.insert("keyframes".into(), Value::Array(keys));
    }
    Some(Value::Table(motion))
}

/// How a path read from `from` (a scene file) is written in a file saved at `to`: as
/// written when both files are in the same folder, else the resolved path made absolute.
fn path_for(written: &str, resolved: &Path, from: &Path, to: &Path) -> String {
    let dir = |p: &Path| p.parent().map(|d| std::path::absolute(d).unwrap_or_else(|_| d.to_path_buf()));
    if dir(from) == dir(to) {
        return written.to_string();
    }
    let abs: PathBuf = std::path::absolute(resolved).unwrap_or_else(|_| resolved.to_path_buf());
    abs.to_string_lossy().into_owned()
}

impl Scene {
    /// The scene as a scene file to be saved at `to` (paths to maps and meshes rewritten
    /// to resolve from there). Loading it gives this scene: the same objects, transforms,
    /// materials, motion, environment, camera and quality.
    pub fn to_toml(&self, to: &Path) -> Result<String, toml::ser::Error> {
        let mut root = Table::new();
        let q = &self.quality;
        let base = QualitySettings::preset(q.preset);
        let mut quality = Table::new();
        quality.insert("preset".into(), Value::String(q.preset.name().into()));
        for ((name, v), (_, b)) in q.settings.knobs().into_iter().zip(base.knobs()) {
            if v != b {
                let value = if name == "brdf_resolution" && v == crate::quality::AUTO {
                    Value::String("auto".into())
                } else {
                    Value::Integer(i64::from(v))
                };
                quality.insert(name.into(), value);
            }
        }
        root.insert("quality".into(), Value::Table(quality));

        let e = &self.environment;
        let mut env = Table::new();
        match &e.source {
            EnvironmentSource::Map { written, path } => {
                env.insert("map".into(), Value::String(path_for(written, path, &self.path, to)));
            }
            EnvironmentSource::Constant(c) => {
                env.insert("constant".into(), vec3(*c));
            }
            EnvironmentSource::Bundled(name) => {
                env.insert("bundled".into(), Value::String(name.clone()));
            }
        }
        env.insert("intensity".into(), num(e.intensity));
        env.insert("rotation".into(), rotation(e.rotation));
        env.insert("rsl_count".into(), Value::Integer(i64::from(e.rsl_count)));
        if let Some(s) = &e.spin {
            env.insert("motion".into(), table([("spin", spin(s))]));
        }
        root.insert("environment".into(), Value::Table(env));

        let c = &self.camera;
        root.insert(
            "camera".into(),
            table([
                ("eye", vec3(c.eye)),
                ("target", vec3(c.target)),
                ("up", vec3(c.up)),
                ("fov_y_degrees", num(c.fov_y.to_degrees())),
                ("width", Value::Integer(i64::from(c.width))),
                ("height", Value::Integer(i64::from(c.height))),
            ]),
        );

        let mut objects = Vec::new();
        for o in &self.objects {
            let mut t = Table::new();
            t.insert("name".into(), Value::String(o.name.clone()));
            match &o.source {
                MeshSource::File { written, path } => {
                    t.insert("mesh".into(), Value::String(path_for(written, path, &self.path, to)));
                }
                MeshSource::GltfPart { written, path, mesh, primitive } => {
                    t.insert("mesh".into(), Value::String(path_for(written, path, &self.path, to)));
                    t.insert("gltf_mesh".into(), Value::Integer(*mesh as i64));
                    t.insert("gltf_primitive".into(), Value::Integer(*primitive as i64));
                    if o.texture.is_some() {
                        t.insert("gltf_texture".into(), Value::Boolean(true));
                    }
                }
                MeshSource::GltfMoved { written, .. } => {
                    return Err(serde::ser::Error::custom(format!(
                        "object \"{}\" is a node of {written} whose transform has shear or a mirror, which a \
                         scene file cannot hold",
                        o.name
                    )));
                }
                MeshSource::Primitive(p) => {
                    t.insert("primitive".into(), Value::try_from(p)?);
                }
            }
            transform_into(&mut t, &o.transform);
            t.insert("material".into(), Value::try_from(crate::material::MaterialFile::of(&o.material))?);
            if let Some(m) = motion(&o.motion) {
                t.insert("motion".into(), m);
            }
            if !o.casts_shadows {
                t.insert("casts_shadows".into(), Value::Boolean(false));
            }
            if o.method != crate::ObjectMethod::default() {
                t.insert("method".into(), Value::try_from(o.method)?);
            }
            objects.push(Value::Table(t));
        }
        root.insert("objects".into(), Value::Array(objects));
        let body = toml::to_string(&root)?;
        Ok(format!("# Written by rsl from {}.\n\n{body}", self.path.display()))
    }
}

//! A glTF file opened as a scene (`rsl render model.glb`, `rsl view model.glb`): each
//! triangle primitive of each node with a mesh an object ([`crate::gltf_import::import_scene`]),
//! named from the file, with its node's transform and its material as rsl's `gltf` model;
//! instances of a mesh share its triangles, so its fields are built once. The camera is the
//! file's first perspective camera, else one framed on the objects' bounds; the
//! environment the bundled studio map until `--env` names another; the `standard` preset.

use crate::gltf_import::{ImportedCamera, import_scene};
use crate::quality::{Preset, Quality};
use crate::{Camera, Environment, EnvironmentSource, MeshSource, Motion, Object, ObjectMethod, Scene, SceneError};
use glam::Vec3;
use std::path::Path;

/// Image size of a scene opened from a glTF file (its height; the width follows the
/// camera's aspect ratio where the file gives one).
const HEIGHT: u32 = 480;

/// Vertical field of view of a camera framed on the scene (degrees).
const FRAMED_FOV_DEGREES: f32 = 40.0;

impl Scene {
    /// Lights the scene by the map `path` (`.exr` or `.hdr`, read when the scene is
    /// prepared) in place of its environment's source (`--env`); its intensity, rotation and
    /// RSL count stay.
    pub fn set_environment_map(&mut self, path: &Path) -> Result<(), SceneError> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        if !matches!(ext.as_deref(), Some("exr" | "hdr")) {
            return Err(SceneError::file(path, "an environment map must be an .exr or .hdr file"));
        }
        if !path.is_file() {
            return Err(SceneError::file(path, "no such environment map"));
        }
        self.environment.source =
            EnvironmentSource::Map { written: path.display().to_string(), path: path.to_path_buf() };
        Ok(())
    }

    /// Opens the glTF file `path` as a scene (see the module's documentation). What the
    /// import leaves out (textures, extensions, transparency…) is said once each as a
    /// warning.
    pub fn from_gltf(path: &Path) -> Result<Scene, SceneError> {
        Self::from_gltf_camera(path, None)
    }

    /// [`Scene::from_gltf`] seen through the file's perspective camera number `camera`
    /// (0 for the first, in node order; `rsl render --camera`), where it is given.
    pub fn from_gltf_camera(path: &Path, camera: Option<usize>) -> Result<Scene, SceneError> {
        let imported = import_scene(path).map_err(|msg| SceneError::file(path, msg))?;
        for notice in &imported.notices {
            tracing::warn!("{}: {notice}", path.display());
        }
        if imported.objects.is_empty() {
            return Err(SceneError::file(path, "its scene has no node with a triangle mesh"));
        }
        let written = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into());
        let mut checked = std::collections::HashMap::new();
        let mut objects: Vec<Object> = Vec::with_capacity(imported.objects.len());
        for o in imported.objects {
            // Instances share one mesh: checked (and rewound) once.
            let key = std::sync::Arc::as_ptr(&o.mesh);
            let mesh = match checked.get(&key) {
                Some(m) => std::sync::Arc::clone(m),
                None => {
                    let report = crate::gltf_import::ImportReport::default();
                    let m = std::sync::Arc::new(crate::raw::checked_mesh(path, ((*o.mesh).clone(), report))?);
                    checked.insert(key, std::sync::Arc::clone(&m));
                    m
                }
            };
            let source = match o.part {
                Some((mesh, primitive)) => {
                    MeshSource::GltfPart { written: written.clone(), path: path.to_path_buf(), mesh, primitive }
                }
                // Triangles moved into world space (a sheared or mirrored node).
                None => MeshSource::GltfMoved { written: written.clone(), path: path.to_path_buf() },
            };
            if let Some(t) = &o.texture {
                t.check(&mesh).map_err(|msg| SceneError::file(path, format!("{}: {msg}", o.name)))?;
            }
            let mut name = o.name.clone();
            let mut k = 2;
            while objects.iter().any(|p| p.name == name) {
                name = format!("{}#{k}", o.name);
                k += 1;
            }
            objects.push(Object {
                name,
                source,
                mesh,
                transform: o.transform,
                material: o.material,
                motion: Motion::default(),
                casts_shadows: true,
                method: ObjectMethod::default(),
                texture: o.texture,
                metallic_roughness: o.metallic_roughness,
            });
        }
        let camera = match (camera, imported.cameras.as_slice()) {
            (None, []) => framed_camera(&objects),
            (None, [first, ..]) => file_camera(first, &objects),
            (Some(k), cameras) => match cameras.get(k) {
                Some(c) => file_camera(c, &objects),
                None => {
                    return Err(SceneError::file(
                        path,
                        format!(
                            "camera {k} was asked for, but the file has {} perspective camera{} (numbered from 0)",
                            cameras.len(),
                            if cameras.len() == 1 { "" } else { "s" }
                        ),
                    ));
                }
            },
        };
        Ok(Scene {
            path: path.to_path_buf(),
            environment: Environment {
                source: EnvironmentSource::Bundled("studio".into()),
                intensity: 1.0,
                rotation: glam::Quat::IDENTITY,
                spin: None,
                rsl_count: crate::DEFAULT_RSL_COUNT,
            },
            camera,
            objects,
            quality: Quality::from_preset(Preset::Standard),
        })
    }
}

/// The objects' world-space bounds.
fn bounds(objects: &[Object]) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for o in objects {
        let m = o.transform.matrix();
        for p in &o.mesh.positions {
            let w = m.transform_point3(*p);
            lo = lo.min(w);
            hi = hi.max(w);
        }
    }
    (lo, hi)
}

/// The file's camera, looking at the point of the objects' bounds nearest its axis.
fn file_camera(c: &ImportedCamera, objects: &[Object]) -> Camera {
    let (lo, hi) = bounds(objects);
    let centre = 0.5 * (lo + hi);
    let forward = c.forward.normalize();
    let depth = (centre - c.eye).dot(forward).max(1e-3 * (hi - lo).length().max(1e-6));
    let aspect = c.aspect.filter(|a| a.is_finite() && *a > 0.0).unwrap_or(4.0 / 3.0);
    Camera {
        eye: c.eye,
        target: c.eye + forward * depth,
        up: c.up,
        fov_y: c.fov_y,
        width: ((HEIGHT as f32 * aspect).round() as u32).clamp(16, 8192),
        height: HEIGHT,
    }
}

/// A camera looking at the objects' bounds from the front (+Z) and a little above, far
/// enough for their bounding sphere to fill the view's height.
fn framed_camera(objects: &[Object]) -> Camera {
    let (lo, hi) = bounds(objects);
    let centre = 0.5 * (lo + hi);
    let radius = (0.5 * (hi - lo).length()).max(1e-6);
    let fov_y = FRAMED_FOV_DEGREES.to_radians();
    let distance = radius / (0.5 * fov_y).sin();
    Camera {
        eye: centre + Vec3::new(0.0, 0.3, 1.0).normalize() * distance,
        target: centre,
        up: Vec3::Y,
        fov_y,
        width: HEIGHT * 4 / 3,
        height: HEIGHT,
    }
}

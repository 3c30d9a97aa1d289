//! Scenes built in code: what tests and programs write instead of scene-file text.
//!
//! A [`SceneBuilder`] writes the scene file's table, in the file's own units (degrees,
//! colours, preset names), and reads it back through the file's validation: a built scene
//! is the scene the equivalent file gives, with the same errors naming the same fields.
//!
//! ```
//! use glam::Vec3;
//! use rsl_scene::build::{ObjectBuilder, SceneBuilder};
//! use rsl_scene::{Brdf, Preset};
//!
//! let scene = SceneBuilder::new()
//!     .preset(Preset::Draft)
//!     .constant(Vec3::ONE)
//!     .camera(Vec3::new(0.0, 2.0, 5.0), Vec3::ZERO)
//!     .object(ObjectBuilder::plane("floor", 4.0, 8).material(Brdf::Lambert { albedo: Vec3::splat(0.5) }).no_shadows())
//!     .object(ObjectBuilder::sphere("ball", 0.5, 16).translation(Vec3::new(0.0, 0.5, 0.0)))
//!     .build("scene.toml")
//!     .unwrap();
//! assert_eq!(scene.objects.len(), 2);
//! ```

use crate::error::SceneError;
use crate::motion::Motion;
use crate::write::{num, vec3};
use crate::{Brdf, ObjectMethod, Preset, Primitive};
use glam::Vec3;
use std::path::{Path, PathBuf};
use toml::{Table, Value};

fn axis_degrees(axis: Vec3, degrees: f32) -> Value {
    let mut t = Table::new();
    t.insert("axis".into(), vec3(axis));
    t.insert("degrees".into(), num(degrees));
    Value::Table(t)
}

/// A scene under construction; [`SceneBuilder::build`] validates it. Unset, the
/// environment is a constant white, the camera looks from `(0, 0, 5)` at the origin, and
/// the quality is the default preset.
#[derive(Clone, Debug)]
pub struct SceneBuilder {
    quality: Table,
    environment: Table,
    camera: Table,
    objects: Vec<Value>,
}

impl Default for SceneBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl SceneBuilder {
    /// An empty scene: no objects, a constant white environment, the default camera and
    /// quality.
    pub fn new() -> Self {
        Self { quality: Table::new(), environment: Table::new(), camera: Table::new(), objects: Vec::new() }
            .constant(Vec3::ONE)
            .camera(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO)
    }

    /// Starts the quality from preset `p` (`quality.preset`).
    pub fn preset(mut self, p: Preset) -> Self {
        self.quality.insert("preset".into(), Value::String(p.name().into()));
        self
    }

    /// Sets quality knob `name` (`quality.<name>`: `env_grid`, `aa`, `table_resolution`, …).
    pub fn knob(mut self, name: &str, value: i64) -> Self {
        self.quality.insert(name.into(), Value::Integer(value));
        self
    }

    /// The same radiance in every direction (`environment.constant`; replaces a map).
    pub fn constant(mut self, radiance: Vec3) -> Self {
        self.environment.remove("map");
        self.environment.insert("constant".into(), vec3(radiance));
        self
    }

    /// A lat-long map (`environment.map`), as a scene file would write it: relative paths
    /// resolve from the folder of the path given to [`SceneBuilder::build`].
    pub fn map(mut self, path: impl AsRef<Path>) -> Self {
        self.environment.remove("constant");
        self.environment.insert("map".into(), Value::String(path.as_ref().to_string_lossy().into_owned()));
        self
    }

    /// Scale of the map or constant (`environment.intensity`).
    pub fn intensity(mut self, k: f32) -> Self {
        self.environment.insert("intensity".into(), num(k));
        self
    }

    /// The environment turned by `degrees` about `axis` (`environment.rotation`).
    pub fn environment_rotation(mut self, axis: Vec3, degrees: f32) -> Self {
        self.environment.insert("rotation".into(), axis_degrees(axis, degrees));
        self
    }

    /// Number of rotatable square lights (`environment.rsl_count`).
    pub fn rsl_count(mut self, n: u32) -> Self {
        self.environment.insert("rsl_count".into(), Value::Integer(i64::from(n)));
        self
    }

    /// Where the camera is and what it looks at (`camera.eye`, `camera.target`).
    pub fn camera(mut self, eye: Vec3, target: Vec3) -> Self {
        self.camera.insert("eye".into(), vec3(eye));
        self.camera.insert("target".into(), vec3(target));
        self
    }

    /// The image's size in pixels (`camera.width`, `camera.height`).
    pub fn image(mut self, width: u32, height: u32) -> Self {
        self.camera.insert("width".into(), Value::Integer(i64::from(width)));
        self.camera.insert("height".into(), Value::Integer(i64::from(height)));
        self
    }

    /// The vertical field of view (`camera.fov_y_degrees`).
    pub fn fov_y_degrees(mut self, degrees: f32) -> Self {
        self.camera.insert("fov_y_degrees".into(), num(degrees));
        self
    }

    /// Adds an object (after those added before).
    pub fn object(mut self, o: ObjectBuilder) -> Self {
        self.objects.push(Value::Table(o.table));
        self
    }

    /// The scene file this builder describes.
    pub fn to_toml(&self) -> String {
        let mut root = Table::new();
        if !self.quality.is_empty() {
            root.insert("quality".into(), Value::Table(self.quality.clone()));
        }
        root.insert("environment".into(), Value::Table(self.environment.clone()));
        root.insert("camera".into(), Value::Table(self.camera.clone()));
        root.insert("objects".into(), Value::Array(self.objects.clone()));
        toml::to_string(&root).expect("a table of numbers, strings and tables serialises")
    }

    /// The scene, validated as if read from a file at `path` (which locates relative maps
    /// and meshes, and names the file in errors; nothing is read from or written to it).
    pub fn build(&self, path: impl AsRef<Path>) -> Result<crate::Scene, SceneError> {
        crate::Scene::from_toml_str(&self.to_toml(), path.as_ref())
    }

    /// Writes the scene file to `path` (a whole file or none: written beside it, then
    /// renamed) and gives `path` back.
    pub fn write(&self, path: impl AsRef<Path>) -> std::io::Result<PathBuf> {
        let path = path.as_ref();
        rsl_sphere::io::write_atomic(path, self.to_toml().as_bytes())?;
        Ok(path.to_path_buf())
    }
}

/// An object under construction (the keys of one `[[objects]]` table).
#[derive(Clone, Debug)]
pub struct ObjectBuilder {
    table: Table,
}

impl ObjectBuilder {
    fn named(name: &str) -> Self {
        let mut table = Table::new();
        table.insert("name".into(), Value::String(name.into()));
        Self { table }
    }

    /// An object named `name` with a generated mesh (`primitive`).
    pub fn primitive(name: &str, p: Primitive) -> Self {
        let mut o = Self::named(name);
        o.table.insert("primitive".into(), Value::try_from(p).expect("a primitive serialises"));
        o
    }

    /// A sphere of `radius` with `resolution` rings, centred at the object's origin.
    pub fn sphere(name: &str, radius: f32, resolution: u32) -> Self {
        Self::primitive(name, Primitive::Sphere { radius, resolution })
    }

    /// A `size × size` square in the XZ plane of `resolution²` quads, facing +Y.
    pub fn plane(name: &str, size: f32, resolution: u32) -> Self {
        Self::primitive(name, Primitive::Plane { size, resolution })
    }

    /// An object whose mesh is a glTF file (`mesh`), as a scene file would write it.
    pub fn mesh(name: &str, path: impl AsRef<Path>) -> Self {
        let mut o = Self::named(name);
        o.table.insert("mesh".into(), Value::String(path.as_ref().to_string_lossy().into_owned()));
        o
    }

    /// Its material (`material`; Lambert white when not set).
    pub fn material(mut self, m: Brdf) -> Self {
        let file = crate::material::MaterialFile::of(&m);
        self.table.insert("material".into(), Value::try_from(file).expect("a material serialises"));
        self
    }

    /// Where its origin is (`translation`).
    pub fn translation(mut self, t: Vec3) -> Self {
        self.table.insert("translation".into(), vec3(t));
        self
    }

    /// Turned by `degrees` about `axis` (`rotation`).
    pub fn rotation(mut self, axis: Vec3, degrees: f32) -> Self {
        self.table.insert("rotation".into(), axis_degrees(axis, degrees));
        self
    }

    /// Scaled per axis (`scale`).
    pub fn scale(mut self, s: Vec3) -> Self {
        self.table.insert("scale".into(), vec3(s));
        self
    }

    /// Casts no shadow on the other objects (`casts_shadows = false`).
    pub fn no_shadows(mut self) -> Self {
        self.table.insert("casts_shadows".into(), Value::Boolean(false));
        self
    }

    /// How `auto` draws it (`method`).
    pub fn method(mut self, m: ObjectMethod) -> Self {
        self.table.insert("method".into(), Value::String(m.name().into()));
        self
    }

    /// Spins about its origin at `degrees_per_second` around `axis` (`motion.spin`).
    pub fn spin(self, axis: Vec3, degrees_per_second: f32) -> Self {
        self.motion_entry("spin", [("axis", vec3(axis)), ("degrees_per_second", num(degrees_per_second))])
    }

    /// Its origin orbits `axis` through `centre` at `degrees_per_second` (`motion.orbit`).
    pub fn orbit(self, centre: Vec3, axis: Vec3, degrees_per_second: f32) -> Self {
        self.motion_entry(
            "orbit",
            [("centre", vec3(centre)), ("axis", vec3(axis)), ("degrees_per_second", num(degrees_per_second))],
        )
    }

    /// Moves as `m` says (`motion`, written as [`crate::Scene::to_toml`] writes it).
    pub fn motion(mut self, m: &Motion) -> Self {
        match crate::write::motion(m) {
            Some(v) => self.table.insert("motion".into(), v),
            None => self.table.remove("motion"),
        };
        self
    }

    fn motion_entry<const N: usize>(mut self, key: &str, pairs: [(&str, Value); N]) -> Self {
        let entry = Value::Table(pairs.into_iter().map(|(k, v)| (k.to_string(), v)).collect());
        let motion = self.table.entry("motion").or_insert_with(|| Value::Table(Table::new()));
        if let Value::Table(t) = motion {
            t.insert(key.into(), entry);
        }
        self
    }
}

/// A GLB file of the glTF JSON `json` (whose one buffer has no `uri`: the binary chunk) and
/// the binary chunk `bin` (glTF 2.0, "GLB File Format Specification"): the JSON padded with
/// spaces and the binary with zeros to multiples of 4 bytes.
pub fn pack_glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = json.as_bytes().to_vec();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let padded = bin.len().next_multiple_of(4);
    let total = 12 + 8 + json.len() + 8 + padded;
    let mut glb = Vec::with_capacity(total);
    for v in [0x4654_6C67u32, 2, total as u32, json.len() as u32, 0x4E4F_534A] {
        glb.extend_from_slice(&v.to_le_bytes());
    }
    glb.extend_from_slice(&json);
    for v in [padded as u32, 0x004E_4942] {
        glb.extend_from_slice(&v.to_le_bytes());
    }
    glb.extend_from_slice(bin);
    glb.resize(total, 0);
    glb
}

/// Writes a small glTF scene (`sample.gltf` and its `sample.bin`) into `dir` and returns the
/// `.gltf` path, for tests and examples of opening glTF files as scenes: a tetrahedron mesh
/// instanced by two nodes named `Tet` (at x = 1, and at x = −1 scaled twice), a mesh of two
/// triangles (two primitives: a red dielectric of roughness 0.005 with a base-colour
/// texture, the file `checker.png` beside it, and no material) under a node `Parent` at y = 1 as its child `Quad` at z = 1, a
/// perspective camera `Cam` at z = 5 (vertical field 0.7 rad, aspect 1.5), a gold metal of
/// roughness 0.4 on the tetrahedra, and the extension `KHR_materials_emissive_strength`
/// listed as used.
pub fn write_sample_gltf(dir: &Path) -> std::io::Result<PathBuf> {
    let f = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let tet = f(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
    let tet_idx: Vec<u8> = [0u16, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3].iter().flat_map(|i| i.to_le_bytes()).collect();
    let tri_a = f(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let tri_b = f(&[1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0]);
    let uv_a = f(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]);
    let mut bin = Vec::new();
    let mut views = Vec::new();
    for (bytes, target) in [(&tet, 34962), (&tet_idx, 34963), (&tri_a, 34962), (&tri_b, 34962), (&uv_a, 34962)] {
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{},"byteLength":{},"target":{target}}}"#,
            bin.len(),
            bytes.len()
        ));
        bin.extend_from_slice(bytes);
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
    }
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_materials_emissive_strength"],
  "scene": 0,
  "scenes": [{{"nodes": [0, 1, 2, 4]}}],
  "nodes": [
    {{"name": "Tet", "mesh": 0, "translation": [1, 0, 0]}},
    {{"name": "Tet", "mesh": 0, "translation": [-1, 0, 0], "scale": [2, 2, 2]}},
    {{"name": "Parent", "translation": [0, 1, 0], "children": [3]}},
    {{"name": "Quad", "mesh": 1, "translation": [0, 0, 1]}},
    {{"name": "Cam", "camera": 0, "translation": [0, 0, 5]}}
  ],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.7, "aspectRatio": 1.5, "znear": 0.01}}}}],
  "meshes": [
    {{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}},
    {{"primitives": [{{"attributes": {{"POSITION": 2, "TEXCOORD_0": 4}}, "material": 1}}, {{"attributes": {{"POSITION": 3}}}}]}}
  ],
  "materials": [
    {{"name": "gold", "pbrMetallicRoughness": {{"baseColorFactor": [1.0, 0.78, 0.34, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.4}}}},
    {{"name": "red", "pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.1, 0.1, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.005, "baseColorTexture": {{"index": 0}}}}}}
  ],
  "textures": [{{"source": 0}}],
  "images": [{{"uri": "checker.png"}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 1]}},
    {{"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}},
    {{"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 4, "componentType": 5126, "count": 3, "type": "VEC2"}}
  ],
  "bufferViews": [{}],
  "buffers": [{{"uri": "sample.bin", "byteLength": {}}}]
}}"#,
        views.join(", "),
        bin.len()
    );
    std::fs::write(dir.join("checker.png"), checker_png(4, 4, CHECKER_COLOURS[0], CHECKER_COLOURS[1]))?;
    std::fs::write(dir.join("sample.bin"), &bin)?;
    let path = dir.join("sample.gltf");
    std::fs::write(&path, json)?;
    Ok(path)
}

/// A PNG image of `cells × cells` squares of `texels × texels` texels each, alternating the
/// 8-bit sRGB colours `a` (the top-left square) and `b`.
pub fn checker_png(cells: u32, texels: u32, a: [u8; 3], b: [u8; 3]) -> Vec<u8> {
    let n = cells * texels;
    let image = image::RgbImage::from_fn(n, n, |x, y| {
        image::Rgb(if (x / texels + y / texels).is_multiple_of(2) { a } else { b })
    });
    let mut out = std::io::Cursor::new(Vec::new());
    image.write_to(&mut out, image::ImageFormat::Png).expect("a PNG is encoded into memory");
    out.into_inner()
}

/// The colours of [`write_textured_sample`]'s checker (sRGB): a light grey and a blue.
pub const CHECKER_COLOURS: [[u8; 3]; 2] = [[230, 230, 230], [40, 90, 200]];

/// Writes `textured.glb` into `dir` and returns its path: a textured scene for tests and
/// examples. A 4 × 4 floor (16 × 16 quads, normal +Y) of a white dielectric of roughness
/// 0.7 whose base colour is an 8 × 8 checker of [`CHECKER_COLOURS`] (64 × 64 texels,
/// nearest filtering, repeated twice each way by `KHR_texture_transform`: 16 squares across,
/// each 0.25 wide, the first at the floor's −X −Z corner); on it a 0.8 cube (its bottom at
/// y = 0) of a gold-tinted metal of roughness 0.35 with the same image (bilinear filtering,
/// mirrored) across each face; a perspective camera at `(0, 2.2, 3.2)` looking at the
/// origin. The image is embedded in the binary chunk.
pub fn write_textured_sample(dir: &Path) -> std::io::Result<PathBuf> {
    let floor = Primitive::Plane { size: 4.0, resolution: 16 }.mesh();
    let floor_uv: Vec<f32> = floor.positions.iter().flat_map(|p| [p.x / 4.0 + 0.5, p.z / 4.0 + 0.5]).collect();
    let cube = Primitive::Box { size: [0.8; 3], resolution: 2 }.mesh();
    // Each face's own two axes, from 0 to 1 across it.
    let cube_uv: Vec<f32> = cube
        .positions
        .iter()
        .zip(&cube.normals)
        .flat_map(|(p, n)| {
            let q = *p / 0.8 + Vec3::splat(0.5);
            let a = n.abs();
            if a.x > 0.5 {
                [q.z, 1.0 - q.y]
            } else if a.y > 0.5 {
                [q.x, q.z]
            } else {
                [q.x, 1.0 - q.y]
            }
        })
        .collect();
    let png = checker_png(8, 8, CHECKER_COLOURS[0], CHECKER_COLOURS[1]);
    let f = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let u = |v: &[u32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let v3 = |v: &[Vec3]| f(&v.iter().flat_map(|p| p.to_array()).collect::<Vec<f32>>());
    let mut bin = Vec::new();
    let mut views = Vec::new();
    for (bytes, target) in [
        (v3(&floor.positions), Some(34962)),
        (v3(&floor.normals), Some(34962)),
        (f(&floor_uv), Some(34962)),
        (u(&floor.indices), Some(34963)),
        (v3(&cube.positions), Some(34962)),
        (v3(&cube.normals), Some(34962)),
        (f(&cube_uv), Some(34962)),
        (u(&cube.indices), Some(34963)),
        (png, None),
    ] {
        let target = target.map_or(String::new(), |t| format!(r#","target":{t}"#));
        views.push(format!(r#"{{"buffer":0,"byteOffset":{},"byteLength":{}{target}}}"#, bin.len(), bytes.len()));
        bin.extend_from_slice(&bytes);
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
    }
    let (nf, nc) = (floor.positions.len(), cube.positions.len());
    let (fi, ci) = (floor.indices.len(), cube.indices.len());
    // The camera's node turned down toward the origin: about X by −atan(2.2/3.2).
    let half = -(2.2f32 / 3.2).atan() / 2.0;
    let (qx, qw) = (half.sin(), half.cos());
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0", "generator": "rsl_scene::build::write_textured_sample"}},
  "extensionsUsed": ["KHR_texture_transform"],
  "scene": 0,
  "scenes": [{{"nodes": [0, 1, 2]}}],
  "nodes": [
    {{"name": "Floor", "mesh": 0}},
    {{"name": "Cube", "mesh": 1, "translation": [0, 0.4, 0]}},
    {{"name": "Camera", "camera": 0, "translation": [0, 2.2, 3.2], "rotation": [{qx}, 0, 0, {qw}]}}
  ],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.75, "aspectRatio": 1.3333, "znear": 0.01}}}}],
  "meshes": [
    {{"name": "floor", "primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 3, "material": 0}}]}},
    {{"name": "cube", "primitives": [{{"attributes": {{"POSITION": 4, "NORMAL": 5, "TEXCOORD_0": 6}}, "indices": 7, "material": 1}}]}}
  ],
  "materials": [
    {{"name": "checker", "pbrMetallicRoughness": {{"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.7,
      "baseColorTexture": {{"index": 0, "extensions": {{"KHR_texture_transform": {{"scale": [2.0, 2.0]}}}}}}}}}},
    {{"name": "gilded", "pbrMetallicRoughness": {{"baseColorFactor": [1.0, 0.85, 0.6, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.35,
      "baseColorTexture": {{"index": 1}}}}}}
  ],
  "samplers": [{{"magFilter": 9728, "minFilter": 9728}}, {{"magFilter": 9729, "wrapS": 33648, "wrapT": 33648}}],
  "textures": [{{"sampler": 0, "source": 0}}, {{"sampler": 1, "source": 0}}],
  "images": [{{"bufferView": 8, "mimeType": "image/png", "name": "checker"}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": {nf}, "type": "VEC3", "min": [-2, 0, -2], "max": [2, 0, 2]}},
    {{"bufferView": 1, "componentType": 5126, "count": {nf}, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5126, "count": {nf}, "type": "VEC2"}},
    {{"bufferView": 3, "componentType": 5125, "count": {fi}, "type": "SCALAR"}},
    {{"bufferView": 4, "componentType": 5126, "count": {nc}, "type": "VEC3", "min": [-0.4, -0.4, -0.4], "max": [0.4, 0.4, 0.4]}},
    {{"bufferView": 5, "componentType": 5126, "count": {nc}, "type": "VEC3"}},
    {{"bufferView": 6, "componentType": 5126, "count": {nc}, "type": "VEC2"}},
    {{"bufferView": 7, "componentType": 5125, "count": {ci}, "type": "SCALAR"}}
  ],
  "bufferViews": [{}],
  "buffers": [{{"byteLength": {}}}]
}}"#,
        views.join(", "),
        bin.len()
    );
    let path = dir.join("textured.glb");
    std::fs::write(&path, pack_glb(&json, &bin))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scene;

    #[test]
    fn a_built_scene_is_the_scene_its_file_gives() {
        let b = SceneBuilder::new()
            .preset(Preset::Draft)
            .knob("env_grid", 8)
            .constant(Vec3::new(0.5, 1.0, 2.0))
            .rsl_count(12)
            .camera(Vec3::new(0.0, 3.0, 0.5), Vec3::ZERO)
            .image(64, 48)
            .object(
                ObjectBuilder::plane("ground", 3.0, 6)
                    .material(Brdf::Lambert { albedo: Vec3::splat(0.5) })
                    .no_shadows()
                    .method(ObjectMethod::RSL),
            )
            .object(
                ObjectBuilder::sphere("ball", 0.4, 8)
                    .translation(Vec3::new(0.0, 0.8, 0.0))
                    .rotation(Vec3::Y, 30.0)
                    .orbit(Vec3::ZERO, Vec3::Y, 45.0)
                    .spin(Vec3::X, 10.0),
            );
        let path = Path::new("built.toml");
        let built = b.build(path).unwrap();
        let text = r#"
            [quality]
            preset = "draft"
            env_grid = 8
            [environment]
            constant = [0.5, 1.0, 2.0]
            rsl_count = 12
            [camera]
            eye = [0.0, 3.0, 0.5]
            target = [0.0, 0.0, 0.0]
            width = 64
            height = 48
            [[objects]]
            name = "ground"
            primitive = { kind = "plane", size = 3.0, resolution = 6 }
            material = { model = "lambert", albedo = [0.5, 0.5, 0.5] }
            casts_shadows = false
            method = "rsl"
            [[objects]]
            name = "ball"
            primitive = { kind = "sphere", radius = 0.4, resolution = 8 }
            translation = [0.0, 0.8, 0.0]
            rotation = { axis = [0.0, 1.0, 0.0], degrees = 30.0 }
            motion = { orbit = { centre = [0.0, 0.0, 0.0], axis = [0.0, 1.0, 0.0], degrees_per_second = 45.0 }, spin = { axis = [1.0, 0.0, 0.0], degrees_per_second = 10.0 } }
        "#;
        assert_eq!(built, Scene::from_toml_str(text, path).unwrap());
        // Motion given as a value is written as the scene writer writes it.
        let m = built.objects[1].motion.clone();
        let again = SceneBuilder::new().object(ObjectBuilder::sphere("ball", 0.4, 8).motion(&m)).build(path).unwrap();
        assert_eq!(again.objects[0].motion.orbit, m.orbit);
    }

    #[test]
    fn a_bad_built_scene_is_refused_naming_the_field() {
        let e = SceneBuilder::new().knob("aa", 3).build("bad.toml").unwrap_err().to_string();
        assert!(e.contains("bad.toml") && e.contains("quality.aa"), "{e}");
        let e = SceneBuilder::new()
            .object(ObjectBuilder::sphere("ball", -1.0, 8))
            .build("bad.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("objects[0]") && e.contains("radius"), "{e}");
    }
}

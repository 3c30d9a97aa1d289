//! glTF 2.0 import: every triangle primitive of the file, node transforms applied, merged
//! into one mesh ([`import`], a scene object's `mesh`); or the file's scene, each primitive
//! of each node an object with its transform and material, and its cameras
//! ([`import_scene`], `rsl render model.glb`).
//!
//! Buffers and images may be the GLB binary chunk, files next to the glTF, or embedded
//! base64 `data:` URIs; base-colour textures are read with their texture coordinates,
//! sampler and `KHR_texture_transform`. Missing normals are computed (area-weighted); vertex normals are
//! renormalised. Non-triangle primitives (points, lines) are skipped and counted.

use crate::texture::{Filter, MAX_TEXELS, MetallicRoughnessTexture, ObjectTexture, Texture, UvTransform, Wrap};
use glam::{Mat4, Vec2, Vec3, Vec4};
use gltf::mesh::Mode;
use rsl_brdf::Brdf;
use rsl_brdf::model::MIN_ROUGHNESS;
use rsl_sphere::mesh::TriMesh;
use std::path::Path;

/// What an import produced besides the mesh.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ImportReport {
    /// Triangle primitives imported (one per mesh instance and primitive).
    pub primitives: usize,
    /// Primitives skipped because they are not triangles.
    pub skipped_non_triangle: usize,
    /// Primitives that had no normals (computed from faces).
    pub computed_normals: usize,
}

/// Where a buffer's relative URI points: inside the glTF file's folder `base`, or an error (an
/// absolute path, a scheme, or a path that climbs out with `..` would read files the scene
/// does not own). Percent-escapes are decoded.
fn buffer_path(base: &Path, uri: &str) -> Result<std::path::PathBuf, String> {
    let decoded = percent_decode(uri)?;
    let rel = Path::new(&decoded);
    if uri.contains(':') || rel.is_absolute() || decoded.starts_with('/') || decoded.starts_with('\\') {
        return Err("only relative paths inside the glTF file's folder are read".into());
    }
    let mut depth = 0i32;
    for c in rel.components() {
        match c {
            std::path::Component::Normal(_) => depth += 1,
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir => {
                depth -= 1;
                if depth < 0 {
                    return Err("points outside the glTF file's folder".into());
                }
            }
            _ => return Err("only relative paths inside the glTF file's folder are read".into()),
        }
    }
    Ok(base.join(rel))
}

/// The bytes of a `data:` URI (`data:[<media type>];base64,<data>`, as glTF writes
/// embedded buffers).
fn data_uri(uri: &str) -> Result<Vec<u8>, String> {
    let rest = uri.strip_prefix("data:").ok_or("not a data: URI")?;
    let (header, data) = rest.split_once(',').ok_or("has no ',' before its data")?;
    if !header.ends_with(";base64") {
        return Err("is not base64-encoded (glTF embeds buffers as `data:…;base64,…`)".into());
    }
    base64_decode(data)
}

/// Decodes standard base64 (RFC 4648 §4: `A–Z a–z 0–9 + /`, `=` padding; whitespace is not
/// allowed).
fn base64_decode(text: &str) -> Result<Vec<u8>, String> {
    let value = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    };
    let body = text.trim_end_matches('=');
    let padding = text.len() - body.len();
    if padding > 2 || (padding > 0 && !text.len().is_multiple_of(4)) || body.len() % 4 == 1 {
        return Err("its base64 has a wrong length or padding".into());
    }
    let mut out = Vec::with_capacity(body.len() / 4 * 3 + 2);
    for (n, chunk) in body.as_bytes().chunks(4).enumerate() {
        let mut bits = 0u32;
        for (k, &c) in chunk.iter().enumerate() {
            let v = value(c)
                .ok_or_else(|| format!("its base64 has a character {:?} at position {}", c as char, 4 * n + k))?;
            bits |= v << (18 - 6 * k);
        }
        let bytes = bits.to_be_bytes();
        out.extend_from_slice(&bytes[1..chunk.len()]);
    }
    Ok(out)
}

/// Decodes `%XX` escapes of a URI.
fn percent_decode(uri: &str) -> Result<String, String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut k = 0;
    while k < b.len() {
        if b[k] == b'%' {
            let hex = b.get(k + 1..k + 3).and_then(|h| std::str::from_utf8(h).ok());
            let v = hex.and_then(|h| u8::from_str_radix(h, 16).ok()).ok_or("a malformed %-escape")?;
            out.push(v);
            k += 3;
        } else {
            out.push(b[k]);
            k += 1;
        }
    }
    String::from_utf8(out).map_err(|_| "not UTF-8 after %-decoding".to_string())
}

/// A glTF file read, parsed and validated, with its buffers: read once, imported any of the
/// ways below (a scene naming several parts of one file reads it once).
pub struct GltfFile {
    gltf: gltf::Gltf,
    buffers: Vec<Vec<u8>>,
    /// The folder external images are read from.
    base: std::path::PathBuf,
}

impl GltfFile {
    /// Reads `path` (`.glb` or `.gltf`) and the buffers it names beside it. Errors are plain
    /// messages; the caller adds the file.
    pub fn open(path: &Path) -> Result<Self, String> {
        let bytes = rsl_sphere::io::read_bounded(path, rsl_sphere::io::MAX_DATA_BYTES)
            .map_err(|e| format!("cannot read: {e}"))?;
        Self::from_bytes(&bytes, path.parent().unwrap_or(Path::new(".")))
    }

    /// A file's bytes, its external buffers read from the folder `base`.
    pub fn from_bytes(bytes: &[u8], base: &Path) -> Result<Self, String> {
        let gltf = parse(bytes).map_err(|e| format!("not a valid glTF file: {e}"))?;
        let buffers = load_buffers(&gltf, base)?;
        Ok(Self { gltf, buffers, base: base.to_path_buf() })
    }
}

/// Imports `path` (`.glb` or `.gltf`). Errors are plain messages; the caller adds the file.
pub fn import(path: &Path) -> Result<(TriMesh, ImportReport), String> {
    GltfFile::open(path)?.merged()
}

/// Parses and validates a glTF or GLB file. The gltf crate's validation lets through
/// accessors its readers then panic on (found by fuzzing: a POSITION that names no accessor,
/// indices of floats); every accessor this importer reads is checked first — it exists, has
/// the component type and shape the glTF specification requires, at least one element, and
/// no sparse storage (not supported here).
fn parse(bytes: &[u8]) -> Result<gltf::Gltf, String> {
    use gltf::json::accessor::{ComponentType as C, GenericComponentType, Type};
    use gltf::json::validation::Checked;
    let unchecked = gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| e.to_string())?;
    let blob = unchecked.blob;
    let json = unchecked.document.into_json();
    let check = |what: &str, index: usize, kinds: &[C], shape: Type| -> Result<(), String> {
        let a = json
            .accessors
            .get(index)
            .ok_or_else(|| format!("{what} names accessor {index}, but there are {}", json.accessors.len()))?;
        let kind_ok = matches!(a.component_type, Checked::Valid(GenericComponentType(k)) if kinds.contains(&k));
        let shape_ok = matches!(a.type_, Checked::Valid(t) if t == shape);
        if !(kind_ok && shape_ok) {
            return Err(format!("{what}: accessor {index} is not of the type the glTF specification requires"));
        }
        if a.count.0 == 0 {
            return Err(format!("{what}: accessor {index} has no elements"));
        }
        if a.sparse.is_some() {
            return Err(format!("{what}: accessor {index} is sparse, which this importer does not read"));
        }
        Ok(())
    };
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let at = |name: &str| format!("mesh {m} primitive {p} {name}");
            if let Some(i) = &prim.indices {
                check(&at("indices"), i.value(), &[C::U8, C::U16, C::U32], Type::Scalar)?;
            }
            for (semantic, name, shape) in [
                (gltf::Semantic::Positions, "POSITION", Type::Vec3),
                (gltf::Semantic::Normals, "NORMAL", Type::Vec3),
                (gltf::Semantic::Tangents, "TANGENT", Type::Vec4),
            ] {
                if let Some(i) = prim.attributes.get(&Checked::Valid(semantic)) {
                    check(&at(name), i.value(), &[C::F32], shape)?;
                }
            }
            for (semantic, i) in &prim.attributes {
                if let Checked::Valid(gltf::Semantic::TexCoords(set)) = semantic {
                    check(&at(&format!("TEXCOORD_{set}")), i.value(), &[C::F32, C::U8, C::U16], Type::Vec2)?;
                }
            }
        }
    }
    // The gltf crate's image source panics on an image with neither a buffer view nor a
    // URI, or a buffer view without a MIME type (found by fuzzing).
    for (i, image) in json.images.iter().enumerate() {
        match (&image.buffer_view, &image.uri, &image.mime_type) {
            (Some(_), _, None) => return Err(format!("image {i} is in a buffer view but has no mimeType")),
            (None, None, _) => return Err(format!("image {i} has neither a bufferView nor a uri")),
            _ => {}
        }
    }
    let document = gltf::Document::from_json(json).map_err(|e| e.to_string())?;
    Ok(gltf::Gltf { document, blob })
}

/// Reads every buffer of `gltf`: the GLB binary chunk, or files in the folder `base`.
fn load_buffers(gltf: &gltf::Gltf, base: &Path) -> Result<Vec<Vec<u8>>, String> {
    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for buffer in gltf.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => {
                gltf.blob.clone().ok_or("buffer refers to the GLB binary chunk, but there is none")?
            }
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                data_uri(uri).map_err(|e| format!("buffer {} (a data: URI): {e}", buffer.index()))?
            }
            gltf::buffer::Source::Uri(uri) => {
                let p =
                    buffer_path(base, uri).map_err(|e| format!("buffer {} (uri \"{uri}\"): {e}", buffer.index()))?;
                rsl_sphere::io::read_bounded(&p, rsl_sphere::io::MAX_DATA_BYTES)
                    .map_err(|e| format!("buffer {} ({}): {e}", buffer.index(), p.display()))?
            }
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "buffer {} is truncated: {} bytes, {} declared",
                buffer.index(),
                data.len(),
                buffer.length()
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// The triangles of one primitive in its mesh's own space (normals repaired or computed,
/// counted in `report`); `None` for a primitive that is not a triangle list.
fn read_primitive(
    m: &gltf::Mesh,
    prim: &gltf::Primitive,
    buffers: &[Vec<u8>],
    report: &mut ImportReport,
) -> Result<Option<TriMesh>, String> {
    if prim.mode() != Mode::Triangles {
        report.skipped_non_triangle += 1;
        return Ok(None);
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
    let where_ = || format!("mesh {} primitive {}", m.index(), prim.index());
    let Some(read) = reader.read_positions() else {
        return Err(match prim.get(&gltf::Semantic::Positions) {
            None => format!("{}: no POSITION attribute", where_()),
            Some(a) => format!(
                "{}: POSITION accessor {} ({} elements) cannot be read: its buffer view is missing or reaches \
                 beyond its buffer",
                where_(),
                a.index(),
                a.count()
            ),
        });
    };
    let positions: Vec<Vec3> = read.map(Vec3::from).collect();
    if let Some(a) = prim.get(&gltf::Semantic::Positions)
        && positions.len() != a.count()
    {
        return Err(format!(
            "{}: POSITION accessor {} declares {} elements, its buffer holds {}",
            where_(),
            a.index(),
            a.count(),
            positions.len()
        ));
    }
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..positions.len() as u32).collect(),
    };
    let mut part = TriMesh { positions, normals: Vec::new(), tangents: None, indices };
    if let Some(n) = reader.read_normals() {
        part.normals = n.map(Vec3::from).collect();
    }
    if let Some(t) = reader.read_tangents() {
        part.tangents = Some(t.map(Vec4::from).collect());
    }
    if let Some(bad) = part.indices.iter().find(|&&i| i as usize >= part.positions.len()) {
        return Err(format!("{}: index {bad} out of range ({} vertices)", where_(), part.positions.len()));
    }
    // Checked per primitive: two ragged ones summing to a multiple of 3 made a
    // triangle of two primitives' vertices.
    if !part.indices.len().is_multiple_of(3) {
        return Err(format!(
            "{}: {} {} is not a multiple of 3 (triangles)",
            where_(),
            part.indices.len(),
            if prim.indices().is_some() { "indices" } else { "vertices (no index accessor)" }
        ));
    }
    if part.normals.len() != part.positions.len() {
        report.computed_normals += 1;
        part.normals.clear();
    }
    if let Some(t) = &part.tangents
        && t.len() != part.positions.len()
    {
        part.tangents = None;
    }
    part.repair_normals();
    report.primitives += 1;
    Ok(Some(part))
}

/// Every node of the file's scene (its default one, else its first) with its world matrix
/// (the hierarchy's transforms multiplied down), in the order met; without a scene, every
/// mesh once at the origin as a node of no index.
/// A node (none for a file without a scene), its mesh and its world matrix.
type Placed<'a> = (Option<gltf::Node<'a>>, Option<gltf::Mesh<'a>>, Mat4);

fn nodes_with_world(gltf: &gltf::Gltf) -> Result<Vec<Placed<'_>>, String> {
    let mut out = Vec::new();
    match gltf.default_scene().or_else(|| gltf.scenes().next()) {
        Some(scene) => {
            let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
            stack.reverse();
            let mut visited = 0usize;
            while let Some((node, parent)) = stack.pop() {
                visited += 1;
                if visited > 1_000_000 {
                    return Err("node hierarchy is cyclic or too deep".into());
                }
                let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
                let children: Vec<_> = node.children().map(|c| (c, world)).collect();
                out.push((Some(node.clone()), node.mesh(), world));
                stack.extend(children.into_iter().rev());
            }
        }
        None => out.extend(gltf.meshes().map(|m| (None, Some(m), Mat4::IDENTITY))),
    }
    Ok(out)
}

/// Imports a glTF file's bytes, reading external buffers from the folder `base`.
pub fn import_bytes(bytes: &[u8], base: &Path) -> Result<(TriMesh, ImportReport), String> {
    GltfFile::from_bytes(bytes, base)?.merged()
}

impl GltfFile {
    /// Every triangle primitive of the file, node transforms applied, merged into one mesh.
    pub fn merged(&self) -> Result<(TriMesh, ImportReport), String> {
        let mut mesh = TriMesh::default();
        let mut report = ImportReport::default();
        for (_, m, world) in nodes_with_world(&self.gltf)? {
            let Some(m) = m else { continue };
            for prim in m.primitives() {
                if let Some(mut part) = read_primitive(&m, &prim, &self.buffers, &mut report)? {
                    part.transform(&world);
                    mesh.append(&part);
                }
            }
        }
        Ok((mesh, report))
    }
}

/// One triangle primitive of a glTF mesh as a scene object: its triangles in the mesh's own
/// space (shared by every node that instances the mesh), its node's world transform, the
/// file's material.
#[derive(Clone, Debug)]
pub struct ImportedObject {
    /// The node's name, else `node<index>`; with `/<primitive>` when its mesh has several.
    pub name: String,
    /// The triangles, shared between instances of the same mesh and primitive.
    pub mesh: std::sync::Arc<TriMesh>,
    /// The node's world transform; the identity where the triangles were moved instead (a
    /// world matrix with shear or a mirror, which a translation, rotation and per-axis
    /// scale cannot hold).
    pub transform: crate::Transform,
    /// The primitive's material as rsl's `gltf` model (glTF's default material where it
    /// names none).
    pub material: Brdf,
    /// Where it came from: `(mesh, primitive)` indices, `None` where its triangles were
    /// moved into world space.
    pub part: Option<(usize, usize)>,
    /// Its material's base-colour texture and its texture coordinates.
    pub texture: Option<ObjectTexture>,
    /// Its material's metallic-roughness texture (`material` holds its means).
    pub metallic_roughness: Option<MetallicRoughnessTexture>,
}

/// A perspective camera of the file, placed by its node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImportedCamera {
    /// The node's position.
    pub eye: Vec3,
    /// Its view direction (the node's −Z).
    pub forward: Vec3,
    /// Its up direction (the node's +Y).
    pub up: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Width over height, where the file gives it.
    pub aspect: Option<f32>,
}

/// A glTF file's scene: its objects, its perspective cameras in node order, what the import
/// left out or changed (one line each), and its counts.
#[derive(Clone, Debug, Default)]
pub struct ImportedScene {
    /// Every triangle primitive of every node with a mesh.
    pub objects: Vec<ImportedObject>,
    /// The perspective cameras, in node order.
    pub cameras: Vec<ImportedCamera>,
    /// What was left out or changed: extensions, textures, transparency, emission, clamped
    /// roughness, orthographic cameras (each once).
    pub notices: Vec<String>,
    /// Primitives read, skipped, given computed normals.
    pub report: ImportReport,
}

/// Decoded images by glTF texture and colour space (sRGB or linear).
type TextureCache = std::collections::HashMap<(usize, bool), std::sync::Arc<Texture>>;

/// A texture a material names: the glTF texture, the texture-coordinate set it reads and
/// the `KHR_texture_transform` applied to them.
#[derive(Clone, Copy, Debug, PartialEq)]
struct TextureRef {
    texture: usize,
    set: u32,
    transform: UvTransform,
}

impl TextureRef {
    fn of(info: &gltf::texture::Info) -> Self {
        let (mut set, mut transform) = (info.tex_coord(), UvTransform::default());
        if let Some(t) = info.texture_transform() {
            set = t.tex_coord().unwrap_or(set);
            transform = UvTransform { offset: t.offset().into(), rotation: t.rotation(), scale: t.scale().into() };
        }
        Self { texture: info.texture().index(), set, transform }
    }
}

/// rsl's `gltf` material for glTF material `m`: its metallic-roughness factors (the default
/// material's where the primitive names none), and its base-colour and metallic-roughness
/// textures. Transparency, emission and a roughness below [`MIN_ROUGHNESS`] are noted in
/// `notices` (once per material).
fn material_of(
    m: &gltf::Material,
    notices: &mut Vec<String>,
) -> Result<(Brdf, Option<TextureRef>, Option<TextureRef>), String> {
    let pbr = m.pbr_metallic_roughness();
    let name = match (m.index(), m.name()) {
        (Some(i), Some(n)) => format!("material {i} (\"{n}\")"),
        (Some(i), None) => format!("material {i}"),
        (None, _) => "the default material".to_string(),
    };
    let [r, g, b, a] = pbr.base_color_factor();
    let mut note = |what: String| {
        let line = format!("{name}: {what}");
        if !notices.contains(&line) {
            notices.push(line);
        }
    };
    if m.normal_texture().is_some() || m.occlusion_texture().is_some() || m.emissive_texture().is_some() {
        note("its normal, occlusion and emissive textures are not read".into());
    }
    if a < 1.0 || m.alpha_mode() != gltf::material::AlphaMode::Opaque {
        note("transparency is not drawn; it is opaque".into());
    }
    if m.emissive_factor() != [0.0; 3] {
        note("emission is not drawn".into());
    }
    let mut roughness = pbr.roughness_factor();
    if roughness < MIN_ROUGHNESS {
        note(format!("roughness {roughness} is drawn as {MIN_ROUGHNESS}, the narrowest lobe rsl tabulates"));
        roughness = MIN_ROUGHNESS;
    }
    let brdf = Brdf::Gltf { base_color: Vec3::new(r, g, b), metallic: pbr.metallic_factor(), roughness };
    brdf.validate().map_err(|e| format!("{name}.pbrMetallicRoughness: {}: {}", e.parameter, e.problem))?;
    let base = pbr.base_color_texture().map(|i| TextureRef::of(&i));
    let metallic_roughness = pbr.metallic_roughness_texture().map(|i| TextureRef::of(&i));
    Ok((brdf, base, metallic_roughness))
}

/// The bytes of image `image`: a buffer view, an embedded `data:` URI, or a file in the
/// folder `base`.
fn image_bytes<'b>(
    image: &gltf::Image,
    buffers: &'b [Vec<u8>],
    base: &Path,
) -> Result<std::borrow::Cow<'b, [u8]>, String> {
    match image.source() {
        gltf::image::Source::View { view, .. } => {
            let buffer = &buffers[view.buffer().index()];
            let end = view.offset().checked_add(view.length()).filter(|&e| e <= buffer.len()).ok_or_else(|| {
                format!("its buffer view {} reaches beyond buffer {}", view.index(), view.buffer().index())
            })?;
            Ok(std::borrow::Cow::Borrowed(&buffer[view.offset()..end]))
        }
        gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => {
            data_uri(uri).map(std::borrow::Cow::Owned).map_err(|e| format!("its data: URI {e}"))
        }
        gltf::image::Source::Uri { uri, .. } => {
            let p = buffer_path(base, uri).map_err(|e| format!("uri \"{uri}\": {e}"))?;
            rsl_sphere::io::read_bounded(&p, rsl_sphere::io::MAX_DATA_BYTES)
                .map(std::borrow::Cow::Owned)
                .map_err(|e| format!("{}: {e}", p.display()))
        }
    }
}

/// glTF texture `index` decoded (PNG or JPEG, as glTF allows), with its sampler's wrap
/// modes and magnification filter; `srgb` for a colour texture.
fn load_texture(
    gltf: &gltf::Gltf,
    buffers: &[Vec<u8>],
    base: &Path,
    index: usize,
    srgb: bool,
) -> Result<Texture, String> {
    let t = gltf.textures().nth(index).ok_or_else(|| format!("texture {index} does not exist"))?;
    let image = t.source();
    let name = match image.name() {
        Some(n) => format!("texture {index} (image {} \"{n}\")", image.index()),
        None => format!("texture {index} (image {})", image.index()),
    };
    let bytes = image_bytes(&image, buffers, base).map_err(|e| format!("{name}: {e}"))?;
    let reader = image::ImageReader::new(std::io::Cursor::new(&bytes[..]))
        .with_guessed_format()
        .map_err(|e| format!("{name}: {e}"))?;
    if !matches!(reader.format(), Some(image::ImageFormat::Png | image::ImageFormat::Jpeg)) {
        return Err(format!("{name}: not a PNG or JPEG image (the formats glTF allows)"));
    }
    let (w, h) = reader.into_dimensions().map_err(|e| format!("{name}: {e}"))?;
    if u64::from(w) * u64::from(h) > MAX_TEXELS {
        return Err(format!("{name}: {w}×{h} texels is more than the {MAX_TEXELS} a texture may have"));
    }
    let decoded = image::load_from_memory(&bytes).map_err(|e| format!("{name}: {e}"))?.to_rgb8();
    let texels = decoded.pixels().map(|p| p.0).collect();
    let mut texture = Texture::new(name, w, h, texels, srgb)?;
    let sampler = t.sampler();
    let wrap = |m: gltf::texture::WrappingMode| match m {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    };
    texture.wrap = [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())];
    texture.filter = match sampler.mag_filter() {
        Some(gltf::texture::MagFilter::Nearest) => Filter::Nearest,
        _ => Filter::Linear,
    };
    Ok(texture)
}

/// Texture-coordinate set `set` of a primitive, transformed by `transform`.
fn read_uvs(
    m: &gltf::Mesh,
    prim: &gltf::Primitive,
    buffers: &[Vec<u8>],
    set: u32,
    transform: &UvTransform,
    vertices: usize,
) -> Result<Vec<Vec2>, String> {
    let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
    let where_ = format!("mesh {} primitive {} TEXCOORD_{set}", m.index(), prim.index());
    let uvs: Vec<Vec2> = reader
        .read_tex_coords(set)
        .ok_or_else(|| {
            format!("{where_}: its material's texture reads it, but the primitive has none that can be read")
        })?
        .into_f32()
        .map(|uv| transform.apply(Vec2::from(uv)))
        .collect();
    if uvs.len() != vertices {
        return Err(format!("{where_}: {} coordinates for {vertices} vertices", uvs.len()));
    }
    Ok(uvs)
}

/// The world matrix as a translation, rotation and per-axis scale, where it is one (no
/// shear, no mirror, no zero scale).
fn decompose(world: &Mat4) -> Option<crate::Transform> {
    let (scale, rotation, translation) = world.to_scale_rotation_translation();
    if !(scale.min_element() > 0.0 && scale.is_finite() && rotation.is_finite() && translation.is_finite()) {
        return None;
    }
    let back = Mat4::from_scale_rotation_translation(scale, rotation, translation);
    let size = world.to_cols_array().iter().fold(1.0f32, |m, v| m.max(v.abs()));
    let off = (back - *world).to_cols_array().iter().fold(0.0f32, |m, v| m.max(v.abs()));
    (off <= 1e-5 * size).then_some(crate::Transform { translation, rotation: rotation.normalize(), scale })
}

/// Imports `path`'s scene (`.glb` or `.gltf`): each triangle primitive of each node with a
/// mesh becomes an object, instances of a mesh sharing its triangles; the file's
/// materials and perspective cameras. Errors are plain messages; the caller adds the file.
pub fn import_scene(path: &Path) -> Result<ImportedScene, String> {
    GltfFile::open(path)?.scene()
}

/// [`import_scene`] of a file's bytes, reading external buffers from the folder `base`.
pub fn import_scene_bytes(bytes: &[u8], base: &Path) -> Result<ImportedScene, String> {
    GltfFile::from_bytes(bytes, base)?.scene()
}

impl GltfFile {
    /// The file's scene, as [`import_scene`] describes it.
    pub fn scene(&self) -> Result<ImportedScene, String> {
        let (gltf, buffers) = (&self.gltf, &self.buffers);
        let mut out = ImportedScene::default();
        for ext in gltf.extensions_used().filter(|e| *e != "KHR_texture_transform") {
            out.notices.push(format!("extension {ext} is not read"));
        }
        let mut textures = TextureCache::default();
        let mut shared: std::collections::HashMap<(usize, usize), std::sync::Arc<TriMesh>> = Default::default();
        for (node, m, world) in nodes_with_world(gltf)? {
            let node_name = match &node {
                Some(n) => n.name().map_or_else(|| format!("node{}", n.index()), str::to_string),
                None => m.as_ref().map_or_else(String::new, |m| format!("mesh{}", m.index())),
            };
            if let Some(camera) = node.as_ref().and_then(|n| n.camera()) {
                match camera.projection() {
                    gltf::camera::Projection::Perspective(p)
                        if !(p.yfov() > 0.0 && p.yfov() < std::f32::consts::PI) =>
                    {
                        out.notices.push(format!(
                            "{node_name}: a camera's yfov {} is not in (0, π); it is not read",
                            p.yfov()
                        ));
                    }
                    gltf::camera::Projection::Perspective(p) => {
                        let (_, rotation, translation) = world.to_scale_rotation_translation();
                        let rotation = rotation.normalize();
                        out.cameras.push(ImportedCamera {
                            eye: translation,
                            forward: rotation * Vec3::NEG_Z,
                            up: rotation * Vec3::Y,
                            fov_y: p.yfov(),
                            aspect: p.aspect_ratio(),
                        });
                    }
                    gltf::camera::Projection::Orthographic(_) => {
                        out.notices.push(format!("{node_name}: an orthographic camera is not read"));
                    }
                }
            }
            let Some(m) = m else { continue };
            let several = m.primitives().len() > 1;
            for prim in m.primitives() {
                let key = (m.index(), prim.index());
                let mesh = match shared.get(&key) {
                    Some(mesh) => Some(mesh.clone()),
                    None => read_primitive(&m, &prim, buffers, &mut out.report)?.map(std::sync::Arc::new),
                };
                let Some(mesh) = mesh else { continue };
                shared.insert(key, mesh.clone());
                let name = if several { format!("{node_name}/{}", prim.index()) } else { node_name.clone() };
                let (mut material, base_ref, mr_ref) = material_of(&prim.material(), &mut out.notices)?;
                let material_name =
                    prim.material().index().map_or("the default material".to_string(), |i| format!("material {i}"));
                let mut metallic_roughness = None;
                if let Some(r) = mr_ref {
                    // Metalness (blue) and roughness (green) vary across the material; it is
                    // drawn with their means: one BRDF table per material.
                    let map = self.object_texture(&m, &prim, &r, false, mesh.positions.len(), &mut textures)?;
                    let mean = map.texture.mean();
                    if let Brdf::Gltf { metallic, roughness, .. } = &mut material {
                        metallic_roughness =
                            Some(MetallicRoughnessTexture { map, metallic: *metallic, roughness: *roughness });
                        *metallic *= mean.z;
                        *roughness = (*roughness * mean.y).max(MIN_ROUGHNESS);
                    }
                    let line = format!(
                        "{material_name}: its metallic-roughness texture is drawn as its mean (metallic {:.3}, roughness {:.3})",
                        mean.z, mean.y
                    );
                    if !out.notices.contains(&line) {
                        out.notices.push(line);
                    }
                }
                let texture = match base_ref {
                    None => None,
                    Some(r) => Some(self.object_texture(&m, &prim, &r, true, mesh.positions.len(), &mut textures)?),
                };
                let (mesh, transform, part) = match decompose(&world) {
                    Some(t) => (mesh, t, Some(key)),
                    None => {
                        let mut moved = (*mesh).clone();
                        moved.transform(&world);
                        (std::sync::Arc::new(moved), crate::Transform::default(), None)
                    }
                };
                out.objects.push(ImportedObject { name, mesh, transform, material, part, texture, metallic_roughness });
            }
        }
        match out.report.skipped_non_triangle {
            0 => {}
            n => out.notices.push(format!(
                "{n} primitive{} of points or lines {} not drawn (rsl draws triangles)",
                if n == 1 { "" } else { "s" },
                if n == 1 { "is" } else { "are" }
            )),
        }
        Ok(out)
    }
}

impl GltfFile {
    /// The base-colour texture of primitive `primitive` of mesh `mesh`'s material, with the
    /// primitive's texture coordinates (what a scene file's `gltf_texture = true` reads);
    /// `None` where its material has none.
    pub fn part_texture(&self, mesh: usize, primitive: usize) -> Result<Option<ObjectTexture>, String> {
        let gltf = &self.gltf;
        let m = gltf
            .meshes()
            .nth(mesh)
            .ok_or_else(|| format!("mesh {mesh}: the file has {} meshes", gltf.meshes().len()))?;
        let prim = m.primitives().nth(primitive).ok_or_else(|| format!("mesh {mesh} has no primitive {primitive}"))?;
        let Some(r) = prim.material().pbr_metallic_roughness().base_color_texture().map(|i| TextureRef::of(&i)) else {
            return Ok(None);
        };
        let vertices = prim.get(&gltf::Semantic::Positions).map_or(0, |a| a.count());
        self.object_texture(&m, &prim, &r, true, vertices, &mut Default::default()).map(Some)
    }

    /// The texture `r` names as primitive `prim` of mesh `m` maps it (its coordinates read
    /// for its `vertices`); the image decoded once per texture and colour space in `cache`.
    fn object_texture(
        &self,
        m: &gltf::Mesh,
        prim: &gltf::Primitive,
        r: &TextureRef,
        srgb: bool,
        vertices: usize,
        cache: &mut TextureCache,
    ) -> Result<ObjectTexture, String> {
        let texture = match cache.get(&(r.texture, srgb)) {
            Some(t) => t.clone(),
            None => {
                let t = std::sync::Arc::new(load_texture(&self.gltf, &self.buffers, &self.base, r.texture, srgb)?);
                cache.insert((r.texture, srgb), t.clone());
                t
            }
        };
        let uvs = read_uvs(m, prim, &self.buffers, r.set, &r.transform, vertices)?;
        Ok(ObjectTexture::new(texture, std::sync::Arc::new(uvs)))
    }

    /// The triangles of primitive `primitive` of mesh `mesh`, in the mesh's own space (what a
    /// scene file's `gltf_mesh` and `gltf_primitive` name).
    pub fn part(&self, mesh: usize, primitive: usize) -> Result<(TriMesh, ImportReport), String> {
        let (gltf, buffers) = (&self.gltf, &self.buffers);
        let meshes = gltf.meshes().len();
        let m = gltf.meshes().nth(mesh).ok_or_else(|| format!("mesh {mesh}: the file has {meshes} meshes"))?;
        let count = m.primitives().len();
        let prim = m
            .primitives()
            .nth(primitive)
            .ok_or_else(|| format!("mesh {mesh} has {count} primitives, not {}", primitive + 1))?;
        let mut report = ImportReport::default();
        let part = read_primitive(&m, &prim, buffers, &mut report)?
            .ok_or_else(|| format!("mesh {mesh} primitive {primitive} is not a triangle list"))?;
        Ok((part, report))
    }
}

//! glTF 2.0 import: every triangle primitive of the file, node transforms applied, merged
//! into one mesh.
//!
//! Buffers may be the GLB binary chunk or files next to the glTF; embedded `data:` URIs are
//! not supported. Missing normals are computed (area-weighted); vertex normals are
//! renormalised. Non-triangle primitives (points, lines) are skipped and counted.

use glam::{Mat4, Vec3, Vec4};
use gltf::mesh::Mode;
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

/// Imports `path` (`.glb` or `.gltf`). Errors are plain messages; the caller adds the file.
pub fn import(path: &Path) -> Result<(TriMesh, ImportReport), String> {
    let bytes =
        rsl_sphere::io::read_bounded(path, rsl_sphere::io::MAX_DATA_BYTES).map_err(|e| format!("cannot read: {e}"))?;
    import_bytes(&bytes, path.parent().unwrap_or(Path::new(".")))
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
        }
    }
    let document = gltf::Document::from_json(json).map_err(|e| e.to_string())?;
    Ok(gltf::Gltf { document, blob })
}

/// Imports a glTF file's bytes, reading external buffers from the folder `base`.
pub fn import_bytes(bytes: &[u8], base: &Path) -> Result<(TriMesh, ImportReport), String> {
    let gltf = parse(bytes).map_err(|e| format!("not a valid glTF file: {e}"))?;
    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for buffer in gltf.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => {
                gltf.blob.clone().ok_or("buffer refers to the GLB binary chunk, but there is none")?
            }
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                return Err(format!("buffer {}: embedded data URIs are not supported", buffer.index()));
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

    let mut mesh = TriMesh::default();
    let mut report = ImportReport::default();
    let mut instances: Vec<(gltf::Mesh, Mat4)> = Vec::new();
    let scene = gltf.default_scene().or_else(|| gltf.scenes().next());
    match scene {
        Some(scene) => {
            let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
            let mut visited = 0usize;
            while let Some((node, parent)) = stack.pop() {
                visited += 1;
                if visited > 1_000_000 {
                    return Err("node hierarchy is cyclic or too deep".into());
                }
                let local = Mat4::from_cols_array_2d(&node.transform().matrix());
                let world = parent * local;
                if let Some(m) = node.mesh() {
                    instances.push((m, world));
                }
                stack.extend(node.children().map(|c| (c, world)));
            }
        }
        None => instances.extend(gltf.meshes().map(|m| (m, Mat4::IDENTITY))),
    }

    for (m, world) in instances {
        for prim in m.primitives() {
            if prim.mode() != Mode::Triangles {
                report.skipped_non_triangle += 1;
                continue;
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
            part.transform(&world);
            mesh.append(&part);
            report.primitives += 1;
        }
    }
    Ok((mesh, report))
}

//! Writes a large glTF asset for timing the import and the first frame: a sphere
//! tessellated into about `TRIANGLES` triangles (positions, normals, 32-bit indices, a glTF
//! gold material at roughness 0.4) standing on a white floor of two triangles, with a
//! camera.
//!
//! `cargo run --release --example large_gltf -- 1000000 rsl-examples/large.glb`, then
//! `rsl render rsl-examples/large.glb --out large.png` (docs/guide.md, "Large glTF files").

use anyhow::{Context, Result, bail};
use std::f32::consts::PI;
use std::path::PathBuf;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let triangles: usize = match args.next() {
        Some(t) => t.parse().with_context(|| format!("the triangle count {t:?} is not a number"))?,
        None => 1_000_000,
    };
    if !(8..=50_000_000).contains(&triangles) {
        bail!("the triangle count must be in 8..=50000000, got {triangles}");
    }
    let out = PathBuf::from(args.next().unwrap_or_else(|| "rsl-examples/large.glb".into()));
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    // A UV sphere of `rings` × `2·rings` quads has 4·rings² triangles (less the poles').
    let rings = ((triangles as f64 / 4.0).sqrt().round() as usize).max(2);
    let segments = 2 * rings;
    let mut positions: Vec<f32> = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    for r in 0..=rings {
        let theta = PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = 2.0 * PI * s as f32 / segments as f32;
            positions.extend([theta.sin() * phi.cos(), theta.cos() + 1.0, theta.sin() * phi.sin()]);
        }
    }
    let row = (segments + 1) as u32;
    for r in 0..rings as u32 {
        for s in 0..segments as u32 {
            let (a, b, c, d) = (r * row + s, r * row + s + 1, (r + 1) * row + s, (r + 1) * row + s + 1);
            if r > 0 {
                indices.extend([a, b, c]);
            }
            if r + 1 < rings as u32 {
                indices.extend([b, d, c]);
            }
        }
    }
    // The unit sphere's normals are its positions less its centre (0, 1, 0).
    let normals: Vec<f32> = positions.chunks(3).flat_map(|p| [p[0], p[1] - 1.0, p[2]]).collect();
    let floor: [f32; 12] = [-4.0, 0.0, -4.0, -4.0, 0.0, 4.0, 4.0, 0.0, 4.0, 4.0, 0.0, -4.0];
    let floor_normals: [f32; 12] = [0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0];
    let floor_indices: [u32; 6] = [0, 1, 2, 0, 2, 3];

    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut push = |bytes: Vec<u8>, target: u32| {
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{},"byteLength":{},"target":{target}}}"#,
            bin.len(),
            bytes.len()
        ));
        bin.extend_from_slice(&bytes);
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
    };
    let f = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let u = |v: &[u32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    push(f(&positions), 34962);
    push(f(&normals), 34962);
    push(u(&indices), 34963);
    push(f(&floor), 34962);
    push(f(&floor_normals), 34962);
    push(u(&floor_indices), 34963);
    let vertices = positions.len() / 3;
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0", "generator": "rsl examples/large_gltf.rs"}},
  "scene": 0,
  "scenes": [{{"nodes": [0, 1, 2]}}],
  "nodes": [
    {{"name": "Sphere", "mesh": 0}},
    {{"name": "Floor", "mesh": 1}},
    {{"name": "Camera", "camera": 0, "translation": [0, 1.6, 4.5], "rotation": [-0.0998, 0, 0, 0.995]}}
  ],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.7, "aspectRatio": 1.3333, "znear": 0.01}}}}],
  "meshes": [
    {{"name": "sphere", "primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1}}, "indices": 2, "material": 0}}]}},
    {{"name": "floor", "primitives": [{{"attributes": {{"POSITION": 3, "NORMAL": 4}}, "indices": 5, "material": 1}}]}}
  ],
  "materials": [
    {{"name": "gold", "pbrMetallicRoughness": {{"baseColorFactor": [1.0, 0.78, 0.34, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.4}}}},
    {{"name": "floor", "pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": {vertices}, "type": "VEC3", "min": [-1, 0, -1], "max": [1, 2, 1]}},
    {{"bufferView": 1, "componentType": 5126, "count": {vertices}, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5125, "count": {}, "type": "SCALAR"}},
    {{"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-4, 0, -4], "max": [4, 0, 4]}},
    {{"bufferView": 4, "componentType": 5126, "count": 4, "type": "VEC3"}},
    {{"bufferView": 5, "componentType": 5125, "count": 6, "type": "SCALAR"}}
  ],
  "bufferViews": [{}],
  "buffers": [{{"byteLength": {}}}]
}}"#,
        indices.len(),
        views.join(", "),
        bin.len()
    );
    let glb = rsl_scene::build::pack_glb(&json, &bin);
    // Written beside and renamed into place: no half-written file under the name.
    let partial = out.with_extension("glb.partial");
    std::fs::write(&partial, &glb).with_context(|| format!("cannot write {}", partial.display()))?;
    std::fs::rename(&partial, &out).with_context(|| format!("cannot write {}", out.display()))?;
    println!(
        "wrote {} ({} triangles, {} vertices, {:.1} MB)",
        out.display(),
        indices.len() / 3 + 2,
        vertices + 4,
        glb.len() as f64 / 1e6
    );
    Ok(())
}

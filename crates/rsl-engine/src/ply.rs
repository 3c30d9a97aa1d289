//! Per-vertex export as binary little-endian PLY.
//!
//! `element vertex` with `float x y z nx ny nz r g b` (world space; `r g b` the outgoing
//! radiance toward the camera eye, whether or not the vertex is visible from it) and
//! `int object` (the object's index in the scene's `[[objects]]`), then `element face` with
//! `list uchar int vertex_indices`; all objects concatenated, indices offset accordingly.

use anyhow::{Result, bail};
use glam::Vec3;
use std::path::Path;

/// One object's vertices and triangles.
#[derive(Clone, Copy, Debug)]
pub struct PlyObject<'a> {
    /// World positions.
    pub positions: &'a [Vec3],
    /// World normals.
    pub normals: &'a [Vec3],
    /// Radiance toward the eye.
    pub radiance: &'a [Vec3],
    /// Triangles (indices into this object's vertices).
    pub indices: &'a [u32],
}

/// Encodes objects as one PLY file.
pub fn to_bytes(objects: &[PlyObject<'_>]) -> Result<Vec<u8>> {
    let vertices: usize = objects.iter().map(|o| o.positions.len()).sum();
    let faces: usize = objects.iter().map(|o| o.indices.len() / 3).sum();
    if vertices > i32::MAX as usize {
        bail!("{vertices} vertices do not fit PLY's int indices");
    }
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment rsl per-vertex radiance toward the camera eye\n\
         element vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         property float r\nproperty float g\nproperty float b\nproperty int object\n\
         element face {faces}\nproperty list uchar int vertex_indices\nend_header\n"
    );
    let mut out = Vec::with_capacity(header.len() + vertices * 40 + faces * 13);
    out.extend_from_slice(header.as_bytes());
    for (k, o) in objects.iter().enumerate() {
        if o.normals.len() != o.positions.len() || o.radiance.len() != o.positions.len() {
            bail!("object {k}: positions, normals and radiance differ in length");
        }
        for ((p, n), c) in o.positions.iter().zip(o.normals).zip(o.radiance) {
            for v in [p.x, p.y, p.z, n.x, n.y, n.z, c.x, c.y, c.z] {
                out.extend_from_slice(&v.to_le_bytes());
            }
            out.extend_from_slice(&(k as i32).to_le_bytes());
        }
    }
    let mut base = 0i32;
    for o in objects {
        for t in o.indices.chunks_exact(3) {
            out.push(3);
            for &i in t {
                out.extend_from_slice(&(base + i as i32).to_le_bytes());
            }
        }
        base += o.positions.len() as i32;
    }
    Ok(out)
}

/// Writes objects as one PLY file, atomically.
pub fn write(path: &Path, objects: &[PlyObject<'_>]) -> Result<()> {
    crate::output::write_atomic(path, &to_bytes(objects)?)
}

/// A PLY file read back: per vertex `[x y z nx ny nz r g b]` and object, and the triangles.
#[derive(Clone, Debug, PartialEq)]
pub struct PlyData {
    /// Per vertex: position, normal, radiance.
    pub vertices: Vec<[f32; 9]>,
    /// Per vertex: object index.
    pub objects: Vec<i32>,
    /// Triangles.
    pub faces: Vec<[u32; 3]>,
}

/// The vertex properties rsl reads, in [`PlyData::vertices`]' order then the object: each a
/// 4-byte float but `object`, a 4-byte int.
const VERTEX_PROPERTIES: [&str; 10] = ["x", "y", "z", "nx", "ny", "nz", "r", "g", "b", "object"];

/// Where each of [`VERTEX_PROPERTIES`] lies in a vertex's 40 bytes, as the header declares
/// them: any order, every one exactly once, nothing else (a file declaring `b g r` was read as
/// `r g b`, and unknown names as radiance).
fn vertex_layout(header: &str) -> Result<[usize; 10]> {
    let mut lines = header.lines().skip_while(|l| !l.starts_with("element vertex "));
    lines.next();
    let mut at = [usize::MAX; 10];
    for (k, line) in lines.take_while(|l| l.starts_with("property ")).enumerate() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let [_, ty, name] = words[..] else { bail!("PLY vertex property `{line}` is not `property TYPE NAME`") };
        let Some(j) = VERTEX_PROPERTIES.iter().position(|p| *p == name) else {
            bail!("PLY vertex property `{name}` is not one rsl reads (float x y z nx ny nz r g b, int object)");
        };
        let want: &[&str] = if name == "object" { &["int", "int32"] } else { &["float", "float32"] };
        if !want.contains(&ty) {
            bail!("PLY vertex property `{name}` is {ty}; rsl reads it as {}", want[0]);
        }
        if at[j] != usize::MAX {
            bail!("PLY vertex property `{name}` is declared twice");
        }
        at[j] = 4 * k;
    }
    if let Some(j) = at.iter().position(|&a| a == usize::MAX) {
        bail!("PLY vertex has no property `{}`", VERTEX_PROPERTIES[j]);
    }
    Ok(at)
}

/// Reads a file written by [`write`]: binary little-endian, the vertex properties in any
/// order the header declares ([`vertex_layout`]), triangles as written; anything else is an
/// error that says what differs.
pub fn read(bytes: &[u8]) -> Result<PlyData> {
    let end = bytes.windows(11).position(|w| w == b"end_header\n").map(|p| p + 11);
    let Some(end) = end else { bail!("not a PLY file: no end_header") };
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| anyhow::anyhow!("PLY header is not text"))?;
    if !header.starts_with("ply\nformat binary_little_endian 1.0\n") {
        bail!("PLY file is not binary little-endian 1.0");
    }
    let count = |name: &str| -> Result<usize> {
        let line = header
            .lines()
            .find(|l| l.starts_with(&format!("element {name} ")))
            .ok_or_else(|| anyhow::anyhow!("PLY header has no element {name}"))?;
        line.rsplit(' ').next().unwrap_or("").parse().map_err(|_| anyhow::anyhow!("bad count in `{line}`"))
    };
    let (nv, nf) = (count("vertex")?, count("face")?);
    let at = vertex_layout(header)?;
    let body = &bytes[end..];
    if body.len() != nv * 40 + nf * 13 {
        bail!("PLY body is {} bytes, expected {} for {nv} vertices and {nf} triangles", body.len(), nv * 40 + nf * 13);
    }
    let f = |k: usize| f32::from_le_bytes(body[k..k + 4].try_into().expect("4 bytes"));
    let i = |k: usize| i32::from_le_bytes(body[k..k + 4].try_into().expect("4 bytes"));
    let vertices = (0..nv).map(|v| std::array::from_fn(|c| f(v * 40 + at[c]))).collect();
    let objects = (0..nv).map(|v| i(v * 40 + at[9])).collect();
    let mut faces = Vec::with_capacity(nf);
    for t in 0..nf {
        let o = nv * 40 + t * 13;
        if body[o] != 3 {
            bail!("face {t} has {} vertices; only triangles are read", body[o]);
        }
        let tri = [i(o + 1), i(o + 5), i(o + 9)];
        if tri.iter().any(|&x| x < 0 || x as usize >= nv) {
            bail!("face {t} indexes past the {nv} vertices");
        }
        faces.push(tri.map(|x| x as u32));
    }
    Ok(PlyData { vertices, objects, faces })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn objects_concatenate_and_read_back() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let n = [Vec3::Z; 3];
        let c = [Vec3::new(1.0, 2.0, 3.0); 3];
        let a = PlyObject { positions: &p, normals: &n, radiance: &c, indices: &[0, 1, 2] };
        let bytes = to_bytes(&[a, a]).unwrap();
        let d = read(&bytes).unwrap();
        assert_eq!(d.vertices.len(), 6);
        assert_eq!(d.objects, vec![0, 0, 0, 1, 1, 1]);
        assert_eq!(d.faces, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(d.vertices[4], [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 2.0, 3.0]);
        assert!(read(&bytes[..bytes.len() - 1]).is_err());
        // Read by its header: a file declaring its colours `b g r` has them swapped.
        let header = |from: &str, to: &str| {
            let text = String::from_utf8_lossy(&bytes).replacen(from, to, 1);
            let mut b = bytes.clone();
            b[..text.find("end_header").unwrap()].copy_from_slice(&text.as_bytes()[..text.find("end_header").unwrap()]);
            b
        };
        let swapped =
            header("float r\nproperty float g\nproperty float b", "float b\nproperty float g\nproperty float r");
        assert_eq!(read(&swapped).unwrap().vertices[4][6..], [3.0, 2.0, 1.0]);
        for (from, to, says) in [
            ("float b\n", "float q\n", "`q` is not one rsl reads"),
            ("float g\n", "float r\n", "`r` is declared twice"),
            ("int object", "short objx", "`objx`"),
            ("float x\n", "uchar x\n", "`x` is uchar"),
        ] {
            let e = read(&header(from, to)).unwrap_err().to_string();
            assert!(e.contains(says), "{to}: {e}");
        }
    }
}

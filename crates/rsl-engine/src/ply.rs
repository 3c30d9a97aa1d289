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

/// Reads a file written by [`write`] (exactly this layout; anything else is an error that
/// says what differs).
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
    let body = &bytes[end..];
    if body.len() != nv * 40 + nf * 13 {
        bail!("PLY body is {} bytes, expected {} for {nv} vertices and {nf} triangles", body.len(), nv * 40 + nf * 13);
    }
    let f = |k: usize| f32::from_le_bytes(body[k..k + 4].try_into().expect("4 bytes"));
    let i = |k: usize| i32::from_le_bytes(body[k..k + 4].try_into().expect("4 bytes"));
    let vertices = (0..nv).map(|v| std::array::from_fn(|c| f(v * 40 + c * 4))).collect();
    let objects = (0..nv).map(|v| i(v * 40 + 36)).collect();
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
    }
}

//! Procedural meshes for the visibility benches and tests (tests include this file).
#![allow(dead_code)]

use glam::Vec3;
use rsl_sphere::mesh::TriMesh;

/// A torus (major radius 1, minor 0.4) with `u × v` vertices: concave, every vertex of its
/// inner side sees the other side.
pub fn torus(u: usize, v: usize) -> TriMesh {
    let mut m = TriMesh::default();
    for j in 0..v {
        for i in 0..u {
            let (a, b) = (std::f32::consts::TAU * i as f32 / u as f32, std::f32::consts::TAU * j as f32 / v as f32);
            let ring = Vec3::new(a.cos(), 0.0, a.sin());
            let n = ring * b.cos() + Vec3::Y * b.sin();
            m.positions.push(ring + n * 0.4);
            m.normals.push(n);
        }
    }
    let at = |i: usize, j: usize| ((j % v) * u + i % u) as u32;
    for j in 0..v {
        for i in 0..u {
            m.indices.extend([at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    // Wind every triangle outward (its face normal along its vertices' normals).
    for t in m.indices.chunks_exact_mut(3) {
        let [a, b, c] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
        if (b - a).cross(c - a).dot(m.normals[t[0] as usize]) < 0.0 {
            t.swap(1, 2);
        }
    }
    m
}

/// A UV sphere (`rings` rings × `2·rings` segments) of `radius` at `centre`, wound outward.
pub fn uv_sphere(centre: Vec3, radius: f32, rings: usize) -> TriMesh {
    let segs = 2 * rings;
    let mut m = TriMesh::default();
    for r in 0..=rings {
        let th = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segs {
            let ph = std::f32::consts::TAU * s as f32 / segs as f32;
            m.positions.push(centre + radius * Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()));
        }
    }
    let at = |r: usize, s: usize| (r * segs + s % segs) as u32;
    for r in 0..rings {
        for s in 0..segs {
            m.indices.extend([at(r, s), at(r, s + 1), at(r + 1, s + 1), at(r, s), at(r + 1, s + 1), at(r + 1, s)]);
        }
    }
    m.compute_normals();
    m
}

//! Generated meshes: sphere, plane, box and torus, each with a resolution knob.
//!
//! Normals are analytic (exact surface normals, not face averages); triangles are wound
//! counter-clockwise seen from the side the normals point to.

use glam::{Vec2, Vec3};
use rsl_sphere::mesh::TriMesh;
use serde::{Deserialize, Serialize};
use std::f32::consts::{PI, TAU};

/// A primitive as a scene file states it (`primitive = { kind = "sphere", ... }`).
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Primitive {
    /// A sphere of `radius` centred at the origin; `resolution` rings of latitude and twice
    /// as many segments of longitude.
    Sphere {
        /// Radius (> 0).
        radius: f32,
        /// Rings of latitude (≥ 3).
        #[serde(default = "default_sphere_resolution")]
        resolution: u32,
    },
    /// A `size × size` square in the XZ plane, normal +Y, centred at the origin, split into
    /// `resolution × resolution` quads.
    Plane {
        /// Side length (> 0).
        size: f32,
        /// Quads per side (≥ 1).
        #[serde(default = "default_plane_resolution")]
        resolution: u32,
    },
    /// An axis-aligned box centred at the origin, each face split into
    /// `resolution × resolution` quads (faces do not share vertices: edges stay sharp).
    Box {
        /// Edge lengths along X, Y, Z (each > 0).
        size: [f32; 3],
        /// Quads per face side (≥ 1).
        #[serde(default = "default_box_resolution")]
        resolution: u32,
    },
    /// A torus around the Y axis.
    Torus {
        /// Distance from the centre to the tube's centre (> minor_radius).
        major_radius: f32,
        /// Radius of the tube (> 0).
        minor_radius: f32,
        /// Segments around the tube; twice as many around the ring (≥ 3).
        #[serde(default = "default_torus_resolution")]
        resolution: u32,
    },
}

fn default_sphere_resolution() -> u32 {
    32
}
fn default_plane_resolution() -> u32 {
    16
}
fn default_box_resolution() -> u32 {
    8
}
fn default_torus_resolution() -> u32 {
    24
}

/// Largest resolution accepted: beyond it a primitive would have millions of vertices.
pub const MAX_RESOLUTION: u32 = 1024;

impl Primitive {
    /// Checks dimensions and resolution; returns `(field, problem)`.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let positive = |name: &str, v: f32| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err((name.to_string(), format!("must be finite and > 0, got {v}")))
            }
        };
        let res = |r: u32, min: u32| {
            if (min..=MAX_RESOLUTION).contains(&r) {
                Ok(())
            } else {
                Err(("resolution".to_string(), format!("must be in {min}..={MAX_RESOLUTION}, got {r}")))
            }
        };
        match *self {
            Primitive::Sphere { radius, resolution } => {
                positive("radius", radius)?;
                res(resolution, 3)
            }
            Primitive::Plane { size, resolution } => {
                positive("size", size)?;
                res(resolution, 1)
            }
            Primitive::Box { size, resolution } => {
                for v in size {
                    positive("size", v)?;
                }
                res(resolution, 1)
            }
            Primitive::Torus { major_radius, minor_radius, resolution } => {
                positive("major_radius", major_radius)?;
                positive("minor_radius", minor_radius)?;
                if minor_radius >= major_radius {
                    return Err((
                        "minor_radius".into(),
                        format!("must be smaller than major_radius ({major_radius}), got {minor_radius}"),
                    ));
                }
                res(resolution, 3)
            }
        }
    }

    /// Short description for summaries.
    pub fn describe(&self) -> String {
        match self {
            Primitive::Sphere { radius, .. } => format!("sphere r={radius}"),
            Primitive::Plane { size, .. } => format!("plane {size}×{size}"),
            Primitive::Box { size, .. } => format!("box {}×{}×{}", size[0], size[1], size[2]),
            Primitive::Torus { major_radius, minor_radius, .. } => format!("torus R={major_radius} r={minor_radius}"),
        }
    }

    /// Generates the mesh. Call [`Primitive::validate`] first.
    pub fn mesh(&self) -> TriMesh {
        let mut b = Builder::default();
        match *self {
            Primitive::Sphere { radius, resolution } => sphere(&mut b, radius, resolution as usize),
            Primitive::Plane { size, resolution } => {
                let h = 0.5 * size;
                b.grid(resolution as usize, resolution as usize, |uv| {
                    (Vec3::new(-h + size * uv.x, 0.0, -h + size * uv.y), Vec3::Y)
                });
            }
            Primitive::Box { size, resolution } => {
                let h = Vec3::from(size) * 0.5;
                for axis in 0..3 {
                    for sign in [-1.0f32, 1.0] {
                        let n = Vec3::AXES[axis] * sign;
                        let (u, v) = (Vec3::AXES[(axis + 1) % 3], Vec3::AXES[(axis + 2) % 3]);
                        b.grid(resolution as usize, resolution as usize, |uv| {
                            let p = n * h + u * h * (2.0 * uv.x - 1.0) + v * h * (2.0 * uv.y - 1.0);
                            (p, n)
                        });
                    }
                }
            }
            Primitive::Torus { major_radius, minor_radius, resolution } => {
                let (nu, nv) = (2 * resolution as usize, resolution as usize);
                b.wrapped_grid(nu, nv, |uv| {
                    let (phi, theta) = (TAU * uv.x, TAU * uv.y);
                    let ring = Vec3::new(phi.cos(), 0.0, phi.sin());
                    let n = ring * theta.cos() + Vec3::Y * theta.sin();
                    (ring * major_radius + n * minor_radius, n)
                });
            }
        }
        b.mesh
    }
}

/// Accumulates vertices and orients each triangle by its vertices' normals.
#[derive(Default)]
struct Builder {
    mesh: TriMesh,
}

impl Builder {
    fn vertex(&mut self, p: Vec3, n: Vec3) -> u32 {
        self.mesh.positions.push(p);
        self.mesh.normals.push(n);
        (self.mesh.positions.len() - 1) as u32
    }

    /// Adds a triangle wound so its face normal agrees with its vertex normals.
    fn triangle(&mut self, a: u32, b: u32, c: u32) {
        let p = |i: u32| self.mesh.positions[i as usize];
        let n = |i: u32| self.mesh.normals[i as usize];
        let face = (p(b) - p(a)).cross(p(c) - p(a));
        if face.dot(n(a) + n(b) + n(c)) >= 0.0 {
            self.mesh.indices.extend([a, b, c]);
        } else {
            self.mesh.indices.extend([a, c, b]);
        }
    }

    fn quad(&mut self, a: u32, b: u32, c: u32, d: u32) {
        self.triangle(a, b, c);
        self.triangle(a, c, d);
    }

    /// An open `nu × nv` grid of quads over `uv ∈ [0, 1]²`.
    fn grid(&mut self, nu: usize, nv: usize, f: impl Fn(Vec2) -> (Vec3, Vec3)) {
        let base = self.mesh.positions.len() as u32;
        for j in 0..=nv {
            for i in 0..=nu {
                let (p, n) = f(Vec2::new(i as f32 / nu as f32, j as f32 / nv as f32));
                self.vertex(p, n);
            }
        }
        let at = |i: usize, j: usize| base + (j * (nu + 1) + i) as u32;
        for j in 0..nv {
            for i in 0..nu {
                self.quad(at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            }
        }
    }

    /// A grid closed in both directions (a torus), without duplicated seam vertices.
    fn wrapped_grid(&mut self, nu: usize, nv: usize, f: impl Fn(Vec2) -> (Vec3, Vec3)) {
        let base = self.mesh.positions.len() as u32;
        for j in 0..nv {
            for i in 0..nu {
                let (p, n) = f(Vec2::new(i as f32 / nu as f32, j as f32 / nv as f32));
                self.vertex(p, n);
            }
        }
        let at = |i: usize, j: usize| base + ((j % nv) * nu + (i % nu)) as u32;
        for j in 0..nv {
            for i in 0..nu {
                self.quad(at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            }
        }
    }
}

/// A UV sphere with one vertex at each pole (no zero-area triangles) and `rings − 1` rings
/// of `2·rings` vertices.
fn sphere(b: &mut Builder, radius: f32, rings: usize) {
    let segs = 2 * rings;
    let top = b.vertex(Vec3::Y * radius, Vec3::Y);
    let first = b.mesh.positions.len() as u32;
    for r in 1..rings {
        let theta = PI * r as f32 / rings as f32;
        for s in 0..segs {
            let phi = TAU * s as f32 / segs as f32;
            let n = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            b.vertex(n * radius, n);
        }
    }
    let bottom = b.vertex(Vec3::NEG_Y * radius, Vec3::NEG_Y);
    let at = |r: usize, s: usize| first + ((r - 1) * segs + s % segs) as u32;
    for s in 0..segs {
        b.triangle(top, at(1, s), at(1, s + 1));
        b.triangle(bottom, at(rings - 1, s + 1), at(rings - 1, s));
    }
    for r in 1..rings - 1 {
        for s in 0..segs {
            b.quad(at(r, s), at(r, s + 1), at(r + 1, s + 1), at(r + 1, s));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rsl_sphere::approx::assert_close;

    fn all() -> Vec<Primitive> {
        vec![
            Primitive::Sphere { radius: 0.5, resolution: 32 },
            Primitive::Plane { size: 3.0, resolution: 4 },
            Primitive::Box { size: [1.0, 2.0, 0.5], resolution: 3 },
            Primitive::Torus { major_radius: 1.0, minor_radius: 0.25, resolution: 48 },
        ]
    }

    #[test]
    fn faces_agree_with_normals_and_meshes_validate() {
        for p in all() {
            p.validate().unwrap();
            let m = p.mesh();
            m.validate().unwrap();
            for t in m.indices.chunks_exact(3) {
                let [a, b, c] = [0, 1, 2].map(|k| t[k] as usize);
                let face = (m.positions[b] - m.positions[a]).cross(m.positions[c] - m.positions[a]);
                assert!(face.length() > 0.0, "{p:?}: zero-area triangle");
                for v in [a, b, c] {
                    assert!(face.normalize().dot(m.normals[v]) > 0.5, "{p:?}: face against normal");
                }
            }
        }
    }

    #[test]
    fn closed_primitives_enclose_their_analytic_volume() {
        // Polygonal approximations converge as O(1/resolution²): tolerances below fit 32–48
        // segments of a curved surface; the box is exact.
        let s = Primitive::Sphere { radius: 0.5, resolution: 32 }.mesh();
        assert_close("sphere volume", s.signed_volume(), 4.0 / 3.0 * std::f64::consts::PI * 0.125, 1e-2, 0.0);
        let b = Primitive::Box { size: [1.0, 2.0, 0.5], resolution: 3 }.mesh();
        assert_close("box volume", b.signed_volume(), 1.0, 1e-6, 0.0);
        let t = Primitive::Torus { major_radius: 1.0, minor_radius: 0.25, resolution: 48 }.mesh();
        let torus = 2.0 * std::f64::consts::PI.powi(2) * 1.0 * 0.0625;
        assert_close("torus volume", t.signed_volume(), torus, 1e-2, 0.0);
        let p = Primitive::Plane { size: 3.0, resolution: 4 }.mesh();
        assert_close("plane area", p.area(), 9.0, 1e-6, 0.0);
        assert!(p.normals.iter().all(|n| *n == Vec3::Y));
    }

    #[test]
    fn bad_dimensions_are_rejected() {
        assert!(Primitive::Sphere { radius: 0.0, resolution: 8 }.validate().is_err());
        assert!(Primitive::Sphere { radius: f32::NAN, resolution: 8 }.validate().is_err());
        assert!(Primitive::Sphere { radius: 1.0, resolution: 2 }.validate().is_err());
        assert!(Primitive::Torus { major_radius: 1.0, minor_radius: 1.5, resolution: 8 }.validate().is_err());
        assert!(Primitive::Box { size: [1.0, -1.0, 1.0], resolution: 1 }.validate().is_err());
        assert!(Primitive::Plane { size: 1.0, resolution: 100_000 }.validate().is_err());
    }
}

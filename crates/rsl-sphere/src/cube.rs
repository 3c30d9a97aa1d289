//! `6×R×R` cube grids over the sphere with exact texel solid angles.
//!
//! Face `f` has an outward axis `N_f` and in-face axes `U_f`, `V_f`; the unnormalised
//! direction of face coordinates `(u, v) ∈ [−1, 1]²` is `N_f + u·U_f + v·V_f`. Texel
//! `(i, j)` spans `u ∈ [−1 + i·h, −1 + (i+1)·h]`, `v` likewise with `j`, `h = 2/R`, and has
//! flat index `f·R² + j·R + i`.

use glam::{DVec3, Vec3};

/// Face axes `(N, U, V)` for faces +X, −X, +Y, −Y, +Z, −Z. Each is right-handed
/// (`U × V = N`), so texels seen from outside are not mirrored.
const FACES: [[[f64; 3]; 3]; 6] = [
    [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]],
    [[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]],
    [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
    [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
    [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
    [[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
];

/// Face `face`'s outward axis `N` and in-face axes `U`, `V` (module docs).
pub fn face_axes(face: usize) -> (DVec3, DVec3, DVec3) {
    let [n, u, v] = FACES[face];
    (DVec3::from(n), DVec3::from(u), DVec3::from(v))
}

/// Face index and face coordinates `(u, v)` of a direction (need not be unit).
/// A zero or non-finite direction maps to the centre of face +Y.
pub fn face_uv_from_dir(d: DVec3) -> (usize, f64, f64) {
    let a = d.abs();
    let face = if !d.is_finite() || a.max_element() <= 0.0 {
        return (2, 0.0, 0.0);
    } else if a.x >= a.y && a.x >= a.z {
        if d.x > 0.0 { 0 } else { 1 }
    } else if a.y >= a.z {
        if d.y > 0.0 { 2 } else { 3 }
    } else if d.z > 0.0 {
        4
    } else {
        5
    };
    let (n, u, v) = face_axes(face);
    let m = d.dot(n);
    (face, (d.dot(u) / m).clamp(-1.0, 1.0), (d.dot(v) / m).clamp(-1.0, 1.0))
}

/// Unit direction of face coordinates.
pub fn dir_from_face_uv(face: usize, u: f64, v: f64) -> DVec3 {
    let (n, ua, va) = face_axes(face);
    (n + ua * u + va * v).normalize()
}

/// Solid angle subtended by the face rectangle `[u0, u1] × [v0, v1]` of one face, exactly:
/// `Ω = A(u1,v1) − A(u0,v1) − A(u1,v0) + A(u0,v0)`, `A(x, y) = atan2(x·y, √(x²+y²+1))`.
pub fn face_rect_solid_angle(u0: f64, v0: f64, u1: f64, v1: f64) -> f64 {
    let a = |x: f64, y: f64| (x * y).atan2((x * x + y * y + 1.0).sqrt());
    a(u1, v1) - a(u0, v1) - a(u1, v0) + a(u0, v0)
}

/// A `6×R×R` cube grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CubeGrid {
    r: usize,
}

impl CubeGrid {
    /// A grid with `r×r` texels per face; `r` must be at least 1.
    pub fn new(r: usize) -> Self {
        assert!(r >= 1, "a cube grid needs at least one texel per face");
        Self { r }
    }

    /// Texels per face side.
    pub fn r(&self) -> usize {
        self.r
    }

    /// Number of texels, `6·R²`.
    pub fn len(&self) -> usize {
        6 * self.r * self.r
    }

    /// Always false.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Flat index of texel `(i, j)` on `face`.
    #[inline]
    pub fn index(&self, face: usize, i: usize, j: usize) -> usize {
        (face * self.r + j) * self.r + i
    }

    /// `(face, i, j)` of a flat index.
    #[inline]
    pub fn coords(&self, index: usize) -> (usize, usize, usize) {
        let rr = self.r * self.r;
        (index / rr, index % self.r, (index % rr) / self.r)
    }

    /// Face-coordinate rectangle `[u0, v0, u1, v1]` of a texel.
    pub fn texel_rect(&self, index: usize) -> [f64; 4] {
        let (_, i, j) = self.coords(index);
        let h = 2.0 / self.r as f64;
        [-1.0 + i as f64 * h, -1.0 + j as f64 * h, -1.0 + (i + 1) as f64 * h, -1.0 + (j + 1) as f64 * h]
    }

    /// Exact solid angle of a texel in steradians.
    pub fn texel_solid_angle(&self, index: usize) -> f64 {
        let [u0, v0, u1, v1] = self.texel_rect(index);
        face_rect_solid_angle(u0, v0, u1, v1)
    }

    /// Unit direction through a texel's centre.
    pub fn texel_dir(&self, index: usize) -> Vec3 {
        let (face, _, _) = self.coords(index);
        let [u0, v0, u1, v1] = self.texel_rect(index);
        dir_from_face_uv(face, 0.5 * (u0 + u1), 0.5 * (v0 + v1)).as_vec3()
    }

    /// The four texels whose centres surround direction `d` and their bilinear weights,
    /// stepping across face seams (a tap just outside the face is its neighbour there):
    /// corners `(i0, j0)`, `(i0 + 1, j0)`, `(i0, j0 + 1)`, `(i0 + 1, j0 + 1)`.
    pub fn bilinear(&self, d: DVec3) -> ([usize; 4], [f32; 4]) {
        let m = self.r;
        let (face, fu, fv) = face_uv_from_dir(d);
        let (gx, gy) = ((fu + 1.0) * 0.5 * m as f64 - 0.5, (fv + 1.0) * 0.5 * m as f64 - 0.5);
        let (i0, j0) = (gx.floor() as i64, gy.floor() as i64);
        let (fx, fy) = ((gx - i0 as f64) as f32, (gy - j0 as f64) as f32);
        let texel = |i: i64, j: i64| {
            let last = m as i64 - 1;
            let (ci, cj) = (i.clamp(0, last), j.clamp(0, last));
            let t = self.index(face, ci as usize, cj as usize);
            if (ci, cj) == (i, j) { t } else { self.neighbour(t, (i - ci) as i32, (j - cj) as i32) }
        };
        (
            [texel(i0, j0), texel(i0 + 1, j0), texel(i0, j0 + 1), texel(i0 + 1, j0 + 1)],
            [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy],
        )
    }

    /// Texel containing a direction.
    pub fn texel_of_dir(&self, d: Vec3) -> usize {
        let (face, u, v) = face_uv_from_dir(d.as_dvec3());
        let cell = |c: f64| (((c + 1.0) * 0.5 * self.r as f64) as usize).min(self.r - 1);
        self.index(face, cell(u), cell(v))
    }

    /// The texel one step of `(di, dj)` (each −1, 0 or 1) away, crossing face seams: the
    /// step is taken on the face's plane and the point re-projected onto the cube.
    pub fn neighbour(&self, index: usize, di: i32, dj: i32) -> usize {
        let (face, _, _) = self.coords(index);
        let [u0, v0, u1, v1] = self.texel_rect(index);
        let h = 2.0 / self.r as f64;
        let u = 0.5 * (u0 + u1) + di as f64 * h;
        let v = 0.5 * (v0 + v1) + dj as f64 * h;
        let (n, ua, va) = face_axes(face);
        self.texel_of_dir((n + ua * u + va * v).as_vec3())
    }

    /// The four edge neighbours of a texel (across seams where needed).
    pub fn neighbours4(&self, index: usize) -> [usize; 4] {
        [
            self.neighbour(index, 1, 0),
            self.neighbour(index, -1, 0),
            self.neighbour(index, 0, 1),
            self.neighbour(index, 0, -1),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::approx::assert_close;
    use crate::sampling::{Pcg32, uniform_sphere};
    use std::f64::consts::PI;

    #[test]
    fn texel_solid_angles_sum_to_4pi() {
        for r in [1, 2, 5, 16, 32, 64] {
            let g = CubeGrid::new(r);
            let total: f64 = (0..g.len()).map(|t| g.texel_solid_angle(t)).sum();
            assert_close(&format!("R={r}"), total, 4.0 * PI, 1e-9, 0.0);
        }
        assert_close("one face", face_rect_solid_angle(-1.0, -1.0, 1.0, 1.0), 4.0 * PI / 6.0, 1e-14, 0.0);
    }

    #[test]
    fn texel_solid_angle_matches_monte_carlo_counting() {
        let g = CubeGrid::new(4);
        let mut counts = vec![0usize; g.len()];
        let mut rng = Pcg32::new(3);
        let m = 2_000_000;
        for _ in 0..m {
            counts[g.texel_of_dir(uniform_sphere(rng.next_2d()))] += 1;
        }
        for (t, &c) in counts.iter().enumerate() {
            let expect = g.texel_solid_angle(t) / (4.0 * PI);
            let sigma = (expect * (1.0 - expect) / m as f64).sqrt();
            let got = c as f64 / m as f64;
            assert!((got - expect).abs() < 5.0 * sigma, "texel {t}: {got} vs {expect} (σ {sigma})");
        }
    }

    #[test]
    fn directions_round_trip_through_texels() {
        let g = CubeGrid::new(32);
        for t in 0..g.len() {
            assert_eq!(g.texel_of_dir(g.texel_dir(t)), t);
            let (f, i, j) = g.coords(t);
            assert_eq!(g.index(f, i, j), t);
        }
        let mut rng = Pcg32::new(9);
        for _ in 0..10_000 {
            let d = uniform_sphere(rng.next_2d()).as_dvec3().normalize();
            let (f, u, v) = face_uv_from_dir(d);
            assert!((dir_from_face_uv(f, u, v) - d).length() < 1e-12);
        }
    }

    #[test]
    fn neighbours_cross_seams_and_are_symmetric() {
        let g = CubeGrid::new(8);
        for t in 0..g.len() {
            let nb = g.neighbours4(t);
            for &n in &nb {
                assert_ne!(n, t);
                assert!(g.neighbours4(n).contains(&t), "{t} -> {n} not symmetric");
                // Neighbours are close on the sphere: under two texel widths apart.
                let ang = g.texel_dir(t).angle_between(g.texel_dir(n));
                assert!(ang < 2.0 * (PI as f32 / 2.0) / 8.0 * 1.01, "{t} -> {n}: {ang}");
            }
        }
        // An edge texel of +X has a neighbour on another face.
        let edge = g.index(0, 7, 3);
        let (f, _, _) = g.coords(g.neighbour(edge, 1, 0));
        assert_ne!(f, 0);
    }
}

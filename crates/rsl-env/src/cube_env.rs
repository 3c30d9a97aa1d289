//! Resampling a lat-long map onto a `6×R×R` cube grid by integrating texel footprints.

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use rsl_sphere::cube::CubeGrid;
use rsl_sphere::latlong::{LatLongMap, texel_solid_angle};
use std::f64::consts::PI;

/// An environment on a cube grid: per texel, its radiant energy `∫ L dω` (RGB, f64) and
/// mean radiance.
#[derive(Clone, Debug)]
pub struct CubeEnv {
    /// The grid.
    pub grid: CubeGrid,
    /// `∫ L dω` over each texel, RGB.
    pub energy: Vec<[f64; 3]>,
    /// Where a texel's light lies within it, from the map it was resampled from:
    /// `∫ Y(ω)·ω dω` (xyz) and `∫ Y dω` over the texel, `Y` the luminance. `None` for an
    /// environment known only per texel (light spread evenly over each).
    pub moments: Option<Vec<[f64; 4]>>,
}

impl CubeEnv {
    /// Resamples `map` onto a `6×r×r` grid. The map is taken as piecewise constant over its
    /// texels; each lat-long texel is split into `k×k` cells of equal solid angle (uniform in
    /// `φ` and `cos θ`) and each cell's energy goes to the cube texel containing its centre.
    /// Total energy is preserved exactly (up to rounding), and a sun smaller than a texel
    /// keeps all of its energy. `k` is chosen so cells are at most a quarter of a cube
    /// texel across.
    pub fn from_latlong(map: &LatLongMap, r: usize) -> Self {
        let grid = CubeGrid::new(r);
        let (w, h) = (map.width(), map.height());
        // A lat-long texel spans π/H in θ; a cube texel at least (π/2)/R·(1/√3)… use the face
        // centre's π/(2R) as the scale: k ≥ 4·(π/H)/(π/(2R)) = 8R/H.
        let k = (8 * r).div_ceil(h).max(2);
        let rows: Vec<Vec<(usize, [f64; 3], Vec3)>> = (0..h)
            .into_par_iter()
            .map(|j| {
                let omega = texel_solid_angle(w, h, j) / (k * k) as f64;
                let z0 = (PI * j as f64 / h as f64).cos();
                let z1 = (PI * (j + 1) as f64 / h as f64).cos();
                let mut out = Vec::with_capacity(w * k * k);
                for i in 0..w {
                    let l = map.texel(i, j).as_dvec3();
                    if l == DVec3::ZERO {
                        continue;
                    }
                    let e = [l.x * omega, l.y * omega, l.z * omega];
                    for a in 0..k {
                        let z = z0 + (z1 - z0) * (a as f64 + 0.5) / k as f64;
                        let st = (1.0 - z * z).max(0.0).sqrt();
                        for b in 0..k {
                            let phi = 2.0 * PI * (i as f64 + (b as f64 + 0.5) / k as f64) / w as f64;
                            let d = Vec3::new((st * phi.sin()) as f32, z as f32, (-st * phi.cos()) as f32);
                            out.push((grid.texel_of_dir(d), e, d));
                        }
                    }
                }
                out
            })
            .collect();
        let mut energy = vec![[0.0f64; 3]; grid.len()];
        let mut moments = vec![[0.0f64; 4]; grid.len()];
        for row in rows {
            for (t, e, d) in row {
                for c in 0..3 {
                    energy[t][c] += e[c];
                }
                let y = luminance_f64(e).max(0.0);
                let m = &mut moments[t];
                (m[0], m[1], m[2], m[3]) =
                    (m[0] + y * f64::from(d.x), m[1] + y * f64::from(d.y), m[2] + y * f64::from(d.z), m[3] + y);
            }
        }
        Self { grid, energy, moments: Some(moments) }
    }

    /// Where texel `t`'s light lies: the luminance-weighted mean direction (unit) and the
    /// half-diagonal of the square with the same spread about it (a uniform square of
    /// half-diagonal `r` has `E|p|² = r²/3` in the equal-area plane, where `|p|² ≈ |ω − c|²/2`
    /// near the centre `c`, and `E|ω − c|² = 2(1 − |E ω|)`). `None` without moments or light.
    pub fn light_within(&self, t: usize) -> Option<(Vec3, f32)> {
        let m = self.moments.as_ref()?.get(t)?;
        if m[3].is_nan() || m[3] <= 0.0 {
            return None;
        }
        let mean = glam::DVec3::new(m[0], m[1], m[2]) / m[3];
        let len = mean.length();
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        Some(((mean / len).as_vec3(), (3.0 * (1.0 - len.min(1.0))).sqrt() as f32))
    }

    /// A constant environment of radiance `l` (each texel's energy is `l·Ω`).
    pub fn constant(r: usize, l: Vec3) -> Self {
        let grid = CubeGrid::new(r);
        let energy = (0..grid.len())
            .map(|t| grid.texel_solid_angle(t))
            .map(|o| [l.x as f64 * o, l.y as f64 * o, l.z as f64 * o])
            .collect();
        Self { grid, energy, moments: None }
    }

    /// Total energy per channel.
    pub fn total_energy(&self) -> [f64; 3] {
        self.energy.iter().fold([0.0; 3], |a, e| [a[0] + e[0], a[1] + e[1], a[2] + e[2]])
    }

    /// Mean radiance of texel `t` (energy / solid angle).
    pub fn radiance(&self, t: usize) -> Vec3 {
        let o = self.grid.texel_solid_angle(t);
        let e = self.energy[t];
        Vec3::new((e[0] / o) as f32, (e[1] / o) as f32, (e[2] / o) as f32)
    }

    /// Luminance energy of texel `t` (Rec. 709 weights, as [`rsl_sphere::sampling::luminance`]).
    pub fn luminance_energy(&self, t: usize) -> f64 {
        luminance_f64(self.energy[t])
    }
}

/// Total energy of a lat-long map per channel (piecewise constant over texels).
pub fn latlong_energy(map: &LatLongMap) -> [f64; 3] {
    let mut e = [0.0f64; 3];
    for j in 0..map.height() {
        let o = map.texel_solid_angle(j);
        for i in 0..map.width() {
            let l = map.texel(i, j);
            e[0] += f64::from(l.x) * o;
            e[1] += f64::from(l.y) * o;
            e[2] += f64::from(l.z) * o;
        }
    }
    e
}

/// Rec. 709 luminance of an RGB triple in f64.
pub fn luminance_f64(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

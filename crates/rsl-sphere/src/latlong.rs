//! Lat-long (equirectangular) maps in Mitsuba 3's convention.
//!
//! `u = atan2(d.x, −d.z)/(2π)` wrapped to `[0, 1)`, `v = acos(d.y)/π`; texel `(i, j)` of a
//! `W×H` map is centred at `((i + ½)/W, (j + ½)/H)`. Lookups are bilinear between texel
//! centres, wrapping in `u` and clamping in `v`.

use glam::{Vec2, Vec3};
use std::f64::consts::PI;

/// `(u, v)` of a unit direction in environment space.
#[inline]
pub fn uv_from_dir(d: Vec3) -> Vec2 {
    let mut u = d.x.atan2(-d.z) * (0.5 * std::f32::consts::FRAC_1_PI);
    if u < 0.0 {
        u += 1.0;
    }
    if u >= 1.0 {
        u -= 1.0;
    }
    let v = d.y.clamp(-1.0, 1.0).acos() * std::f32::consts::FRAC_1_PI;
    Vec2::new(u, v)
}

/// Unit direction of `(u, v)`: `φ = 2πu`, `θ = πv`, `d = (sin θ sin φ, cos θ, −sin θ cos φ)`.
#[inline]
pub fn dir_from_uv(uv: Vec2) -> Vec3 {
    let phi = uv.x * std::f32::consts::TAU;
    let theta = uv.y * std::f32::consts::PI;
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new(st * sp, ct, -st * cp)
}

/// Exact solid angle of any texel in row `j` of a `W×H` map:
/// `(2π/W)·(cos(πj/H) − cos(π(j+1)/H))`.
pub fn texel_solid_angle(width: usize, height: usize, j: usize) -> f64 {
    let t0 = PI * j as f64 / height as f64;
    let t1 = PI * (j + 1) as f64 / height as f64;
    2.0 * PI / width as f64 * (t0.cos() - t1.cos())
}

/// An RGB lat-long map, rows from the top (+Y) down.
#[derive(Clone, Debug, PartialEq)]
pub struct LatLongMap {
    width: usize,
    height: usize,
    texels: Vec<Vec3>,
}

/// A map whose size and texel count disagree.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("lat-long map of {width}×{height} needs {} texels, got {got}", width * height)]
pub struct SizeError {
    /// Requested width.
    pub width: usize,
    /// Requested height.
    pub height: usize,
    /// Texels supplied.
    pub got: usize,
}

impl LatLongMap {
    /// A map from row-major texels; `width·height` must equal `texels.len()` and be non-zero.
    pub fn new(width: usize, height: usize, texels: Vec<Vec3>) -> Result<Self, SizeError> {
        if width == 0 || height == 0 || width.checked_mul(height) != Some(texels.len()) {
            return Err(SizeError { width, height, got: texels.len() });
        }
        Ok(Self { width, height, texels })
    }

    /// A map evaluated from a function of direction at each texel centre.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(Vec3) -> Vec3) -> Self {
        let mut texels = Vec::with_capacity(width * height);
        for j in 0..height {
            for i in 0..width {
                texels.push(f(Self::texel_dir_of(width, height, i, j)));
            }
        }
        Self { width, height, texels }
    }

    /// Width in texels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in texels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Row-major texels.
    pub fn texels(&self) -> &[Vec3] {
        &self.texels
    }

    /// Texel `(i, j)`.
    #[inline]
    pub fn texel(&self, i: usize, j: usize) -> Vec3 {
        self.texels[j * self.width + i]
    }

    fn texel_dir_of(width: usize, height: usize, i: usize, j: usize) -> Vec3 {
        dir_from_uv(Vec2::new((i as f32 + 0.5) / width as f32, (j as f32 + 0.5) / height as f32))
    }

    /// Direction through the centre of texel `(i, j)`.
    pub fn texel_dir(&self, i: usize, j: usize) -> Vec3 {
        Self::texel_dir_of(self.width, self.height, i, j)
    }

    /// Exact solid angle of a texel in row `j`.
    pub fn texel_solid_angle(&self, j: usize) -> f64 {
        texel_solid_angle(self.width, self.height, j)
    }

    /// Bilinear lookup at `(u, v)`, wrapping in `u`, clamping in `v`.
    pub fn lookup_uv(&self, uv: Vec2) -> Vec3 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = (uv.y * self.height as f32 - 0.5).clamp(0.0, (self.height - 1) as f32);
        let (xf, yf) = (x.floor(), y.floor());
        let (tx, ty) = (x - xf, y - yf);
        let w = self.width as i64;
        let i0 = (xf as i64).rem_euclid(w) as usize;
        let i1 = (i0 + 1) % self.width;
        let j0 = yf as usize;
        let j1 = (j0 + 1).min(self.height - 1);
        let top = self.texel(i0, j0) * (1.0 - tx) + self.texel(i1, j0) * tx;
        let bottom = self.texel(i0, j1) * (1.0 - tx) + self.texel(i1, j1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// Bilinear lookup in direction `d` (environment space).
    pub fn lookup(&self, d: Vec3) -> Vec3 {
        self.lookup_uv(uv_from_dir(d))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::approx::assert_close;

    #[test]
    fn fixed_points_follow_mitsuba() {
        let uv = |d: Vec3| uv_from_dir(d);
        assert!((uv(Vec3::X).x - 0.25).abs() < 1e-7);
        assert_eq!(uv(Vec3::NEG_Z).x, 0.0);
        assert!((uv(Vec3::Z).x - 0.5).abs() < 1e-7);
        assert!((uv(Vec3::NEG_X).x - 0.75).abs() < 1e-7);
        assert_eq!(uv(Vec3::Y).y, 0.0);
        assert!((uv(Vec3::NEG_Y).y - 1.0).abs() < 1e-7);
        assert!((uv(Vec3::X).y - 0.5).abs() < 1e-7);
        assert!((dir_from_uv(Vec2::new(0.25, 0.5)) - Vec3::X).length() < 1e-6);
        assert!((dir_from_uv(Vec2::new(0.0, 0.5)) - Vec3::NEG_Z).length() < 1e-6);
    }

    #[test]
    fn uv_round_trips() {
        for j in 1..50 {
            for i in 0..100 {
                let uv = Vec2::new(i as f32 / 100.0, j as f32 / 50.0);
                let back = uv_from_dir(dir_from_uv(uv));
                assert!((back - uv).length() < 1e-5, "{uv:?} -> {back:?}");
            }
        }
    }

    #[test]
    fn texel_solid_angles_sum_to_4pi() {
        let total: f64 = (0..64).map(|j| 128.0 * texel_solid_angle(128, 64, j)).sum();
        assert_close("lat-long", total, 4.0 * PI, 1e-12, 0.0);
    }

    #[test]
    fn bilinear_lookup_hits_centres_and_wraps() {
        let m = LatLongMap::from_fn(8, 4, |d| Vec3::splat(d.y) + Vec3::new(d.x, 0.0, 0.0));
        for j in 0..4 {
            for i in 0..8 {
                let d = m.texel_dir(i, j);
                assert!((m.lookup(d) - m.texel(i, j)).length() < 1e-5);
            }
        }
        // Halfway between the last and first column of a row: the mean of the two.
        let mid = m.lookup_uv(Vec2::new(0.0, 0.625));
        let expect = 0.5 * (m.texel(7, 2) + m.texel(0, 2));
        assert!((mid - expect).length() < 1e-6);
        // Above the first row's centres: clamped to the row.
        assert!((m.lookup_uv(Vec2::new(0.0625, 0.0)) - m.texel(0, 0)).length() < 1e-6);
        assert!(LatLongMap::new(2, 2, vec![Vec3::ZERO; 3]).is_err());
        assert!(LatLongMap::new(0, 0, vec![]).is_err());
    }
}

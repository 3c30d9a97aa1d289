//! Square integrals by direct quadrature: what a table approximates, computed without one.
//!
//! [`square_exact`] integrates `ρ(ω, v)·cos θ·w(ω)` over the same square a table lookup covers
//! (for isotropic BRDFs the square lies in the frame rotated so the view has azimuth 0, as
//! in [`crate::BrdfTable::square`]), with an optional weight `w` — a visibility function,
//! for the product oracle of the RSL path. The box is cut into sub-squares at most 1/32 of
//! the plane wide, each integrated by the tables' adaptive rule (split while wider than the
//! lobe and near its peak; 2×2 Gauss–Legendre points otherwise), so the result needs no
//! table resolution, no view interpolation and no spline.

use crate::model::Brdf;
use crate::table::adaptive_points;
use glam::{Vec2, Vec3};
use rsl_sphere::hemi::hemi_from_dir;

/// Widest sub-square of the base subdivision (plane units) of [`square_exact`].
pub const BASE_SIDE: f32 = 2.0 / 64.0;

/// Most base sub-squares per side.
const MAX_BASE: usize = 128;

/// How a view and a light are placed for a square query: the frame the square is axis-aligned
/// in (for isotropic BRDFs, the local frame rotated by `−φ_v`).
#[derive(Clone, Copy, Debug)]
struct Placement {
    /// `(cos φ, sin φ)` of the rotation back to the local frame.
    rot: (f32, f32),
    /// The view in the square's frame.
    view: Vec3,
}

impl Placement {
    fn new(brdf: &Brdf, view: Vec3) -> Self {
        if brdf.is_lambertian() || brdf.is_anisotropic() {
            return Self { rot: (1.0, 0.0), view };
        }
        let rxy = Vec2::new(view.x, view.y).length();
        let (c, s) = if rxy > 1e-12 { (view.x / rxy, view.y / rxy) } else { (1.0, 0.0) };
        Self { rot: (c, s), view: Vec3::new(rxy, 0.0, view.z) }
    }

    /// A direction of the square's frame in the local frame.
    fn square_to_local(self, d: Vec3) -> Vec3 {
        let (c, s) = self.rot;
        Vec3::new(c * d.x - s * d.y, s * d.x + c * d.y, d.z)
    }

    /// A local direction in the square's frame.
    fn local_to_square(self, d: Vec3) -> Vec3 {
        let (c, s) = self.rot;
        Vec3::new(c * d.x + s * d.y, -s * d.x + c * d.y, d.z)
    }
}

/// `∫ ρ(ω, v)·cos θ·w(ω) dω` over the square of half-diagonal `r` centred on `light`, the
/// square a table lookup `square(light, r, view)` covers (all directions unit, local frame;
/// `w` receives local directions above the horizon). Views at or below the horizon, and
/// non-finite inputs, give zero. Unlike a table, views beyond `θ_max` are not clamped.
pub fn square_exact(brdf: &Brdf, light: Vec3, r: f32, view: Vec3, w: &dyn Fn(Vec3) -> f32) -> Vec3 {
    square_exact_at(brdf, light, r, view, BASE_SIDE, w)
}

/// [`square_exact`] with base sub-squares at most `base_side` wide (coarser is cheaper where
/// every point of `w` costs a ray; the adaptive refinement near the lobe is the same).
pub fn square_exact_at(brdf: &Brdf, light: Vec3, r: f32, view: Vec3, base_side: f32, w: &dyn Fn(Vec3) -> f32) -> Vec3 {
    if view.z.is_nan() || view.z <= 0.0 || !light.is_finite() || !r.is_finite() || r <= 0.0 {
        return Vec3::ZERO;
    }
    let place = Placement::new(brdf, view.normalize());
    let p = hemi_from_dir(place.local_to_square(light.normalize()));
    let s = r / std::f32::consts::SQRT_2;
    let k = ((2.0 * s / base_side.max(1e-3)).ceil() as usize).clamp(1, MAX_BASE);
    let side = 2.0 * s / k as f32;
    let wo = place.view;
    let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
    let width = brdf.lobe_width().map(f64::from);
    let mut sum = [0.0f64; 3];
    for j in 0..k {
        for i in 0..k {
            let (x0, y0) = (p.x - s + i as f32 * side, p.y - s + j as f32 * side);
            adaptive_points(width, mirror, f64::from(x0), f64::from(y0), f64::from(side), &mut |d, weight| {
                let local = place.square_to_local(d);
                let f = brdf.eval_cos(local, view);
                if f == Vec3::ZERO {
                    return;
                }
                let v = f64::from(w(local)) * weight;
                for c in 0..3 {
                    sum[c] += f64::from(f[c]) * v;
                }
            });
        }
    }
    Vec3::new(sum[0] as f32, sum[1] as f32, sum[2] as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BrdfTable, Resolution};
    use rsl_sphere::hemi::dir_from_hemi;

    fn one(_: Vec3) -> f32 {
        1.0
    }

    #[test]
    fn lambert_over_the_whole_hemisphere_is_its_albedo() {
        let b = Brdf::Lambert { albedo: Vec3::new(0.2, 0.5, 0.8) };
        // A square of half-side 1 at the pole covers the unit disk: the whole hemisphere.
        let e = square_exact(&b, Vec3::Z, std::f32::consts::SQRT_2, Vec3::Z, &one);
        assert!((e - b_albedo(&b)).abs().max_element() < 2e-4, "{e}");
    }

    fn b_albedo(b: &Brdf) -> Vec3 {
        match b {
            Brdf::Lambert { albedo } => *albedo,
            _ => unreachable!(),
        }
    }

    #[test]
    fn a_weight_of_one_half_halves_the_integral() {
        let b = Brdf::Ggx { alpha: 0.1, specular: Vec3::ONE, diffuse: Vec3::ZERO };
        let view = Vec3::new(0.5, 0.2, 0.84).normalize();
        let light = Vec3::new(-0.5, -0.2, 0.84).normalize();
        let full = square_exact(&b, light, 0.3, view, &one);
        let half = square_exact(&b, light, 0.3, view, &|_| 0.5);
        assert!(full.x > 0.1 && (half * 2.0 - full).abs().max_element() < 1e-6 * full.x);
    }

    /// A fine midpoint sum over the square, written independently (rotation by the view's
    /// azimuth included).
    fn brute(b: &Brdf, light: Vec3, r: f32, view: Vec3, k: usize) -> Vec3 {
        let phi = view.y.atan2(view.x);
        let (c, s) = (phi.cos(), phi.sin());
        let rot = |d: Vec3, sign: f32| Vec3::new(c * d.x + sign * s * d.y, -sign * s * d.x + c * d.y, d.z);
        let p = hemi_from_dir(rot(light, 1.0));
        let half = r / std::f32::consts::SQRT_2;
        let h = 2.0 * half / k as f32;
        let mut sum = Vec3::ZERO;
        for j in 0..k {
            for i in 0..k {
                let q = Vec2::new(p.x - half + (i as f32 + 0.5) * h, p.y - half + (j as f32 + 0.5) * h);
                if q.length_squared() < 1.0 {
                    sum += b.eval_cos(rot(dir_from_hemi(q), -1.0), view) * (2.0 * h * h);
                }
            }
        }
        sum
    }

    #[test]
    fn agrees_with_a_fine_midpoint_sum_for_glossy_lobes() {
        let view = Vec3::new(0.3, -0.4, 0.866).normalize();
        for b in [
            Brdf::Ggx { alpha: 0.2, specular: Vec3::ONE, diffuse: Vec3::splat(0.1) },
            Brdf::Beckmann { alpha: 0.05, specular: Vec3::ONE, diffuse: Vec3::ZERO },
        ] {
            let mirror = Vec3::new(-view.x, -view.y, view.z);
            for (light, r) in [(mirror, 0.15), ((mirror + Vec3::new(0.1, 0.0, 0.0)).normalize(), 0.4), (Vec3::Z, 0.9)] {
                let e = square_exact(&b, light, r, view, &one);
                let m = brute(&b, light, r, view, 1500);
                assert!(
                    (e - m).abs().max_element() <= 2e-3 * m.max_element().max(1e-3),
                    "{b:?} {light} {r}: {e} vs {m}"
                );
            }
        }
    }

    #[test]
    fn a_fine_table_approaches_it_at_a_tabulated_view() {
        let b = Brdf::Ggx { alpha: 0.3, specular: Vec3::ONE, diffuse: Vec3::ZERO };
        let t = BrdfTable::build(&b, Resolution { n: 64, views: 16 }).unwrap();
        let Views::Isotropic(thetas) = t.views() else { panic!() };
        let th = thetas[8];
        let view = Vec3::new(th.sin(), 0.0, th.cos());
        let light = Vec3::new(-th.sin(), 0.1, th.cos()).normalize();
        let e = square_exact(&b, light, 0.3, view, &one);
        let a = t.square(light, 0.3, view).integral;
        assert!((e - a).abs().max_element() < 5e-3 * e.x, "{e} vs {a}");
    }

    use crate::Views;
}

//! Importance sampling of every BRDF model: a mixture of a cosine-weighted diffuse lobe and
//! the model's specular lobe, chosen with probabilities proportional to the luminance of
//! the diffuse and specular weights. Directions are in the local frame (normal +z);
//! densities are per steradian over the whole sphere.
//!
//! Specular lobes: Phong samples `cos^n` around the mirror direction (pdf
//! `(n+1)/(2π)·cos^n α`); Blinn–Phong, Beckmann/Cook–Torrance, GGX and Ward sample a half
//! vector `h` from `cos^n θh`, `D(h)·cos θh` or Ward's normalised lobe and reflect `wo` about
//! it (pdf `p(h)/(4|wo·h|)`). A sampled direction may lie below the horizon; the BRDF is zero
//! there, and the pdf still accounts for it. Half vectors facing away from `wo` give no
//! sample (`None`), so the density integrates to one minus the probability of `None`.

use crate::model::{Brdf, GLTF_DIELECTRIC_F0, beckmann_d, ggx_d, gltf_terms};
use glam::{Vec2, Vec3};
use rsl_sphere::Frame;
use rsl_sphere::sampling::{cosine_hemisphere, luminance};
use std::f32::consts::{FRAC_1_PI, PI};

/// Half vectors within `acos(10⁻³)` of perpendicular to `wo` are not used: the reflected
/// direction is then almost `−wo`, where the half vector cannot be recovered from `wi + wo`
/// in f32. [`Brdf::sample`] returns `None` for them and [`Brdf::pdf`] gives them no density,
/// so the two stay consistent (the density between the two thresholds that is never
/// sampled, and the lost probability, are far below 10⁻³ for these lobes).
const MIN_COS_OH: f32 = 1e-3;

/// The reflection of `wo` about the unit vector `h`.
fn reflect(wo: Vec3, h: Vec3) -> Vec3 {
    2.0 * wo.dot(h) * h - wo
}

/// A direction at polar angle `acos(cos_t)` and azimuth `phi` around +z.
fn spherical(cos_t: f32, phi: f32) -> Vec3 {
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}

impl Brdf {
    /// The GGX roughness α of a GGX or glTF material (0 for the other models).
    fn ggx_alpha(&self) -> f32 {
        match *self {
            Brdf::Ggx { alpha, .. } => alpha,
            Brdf::Gltf { roughness, .. } => roughness * roughness,
            _ => 0.0,
        }
    }

    /// Probability of sampling the diffuse lobe.
    pub fn diffuse_probability(&self) -> f32 {
        let (kd, ks) = match *self {
            Brdf::Lambert { .. } => return 1.0,
            Brdf::Phong { specular, diffuse, .. }
            | Brdf::BlinnPhong { specular, diffuse, .. }
            | Brdf::CookTorrance { specular, diffuse, .. }
            | Brdf::Ward { specular, diffuse, .. }
            | Brdf::Ggx { specular, diffuse, .. }
            | Brdf::Beckmann { specular, diffuse, .. } => (luminance(diffuse), luminance(specular)),
            Brdf::Gltf { base_color, metallic, roughness } => {
                // The Fresnel term's mean over the cosine-weighted hemisphere is
                // F0 + (1 − F0)·∫(1 − μ)⁵ 2μ dμ = F0 + (1 − F0)/21.
                let (f0, c_diff, _) = gltf_terms(base_color, metallic, roughness);
                let f = f0 + (Vec3::ONE - f0) / 21.0;
                let f_dielectric = GLTF_DIELECTRIC_F0 + (1.0 - GLTF_DIELECTRIC_F0) / 21.0;
                (luminance(c_diff * (1.0 - f_dielectric)), luminance(f))
            }
        };
        if kd + ks > 0.0 { kd / (kd + ks) } else { 1.0 }
    }

    /// Samples a light direction `wi` for the view `wo` (above the horizon) from two
    /// uniform numbers `u` and a third `s` that picks the lobe; `None` when the sample is
    /// degenerate (a half vector facing away from `wo`).
    pub fn sample(&self, wo: Vec3, u: Vec2, s: f32) -> Option<Vec3> {
        if s < self.diffuse_probability() {
            return Some(cosine_hemisphere(u));
        }
        let phi = 2.0 * PI * u.y;
        let h = match *self {
            Brdf::Lambert { .. } => return Some(cosine_hemisphere(u)),
            Brdf::Phong { exponent, .. } => {
                let r = Vec3::new(-wo.x, -wo.y, wo.z);
                let local = spherical(u.x.powf(1.0 / (exponent + 1.0)), phi);
                return Some(Frame::from_normal(r).to_world(local));
            }
            Brdf::BlinnPhong { exponent, .. } => spherical(u.x.powf(1.0 / (exponent + 1.0)), phi),
            Brdf::CookTorrance { alpha, .. } | Brdf::Beckmann { alpha, .. } => {
                let tan2 = -alpha * alpha * (1.0 - u.x).max(1e-30).ln();
                spherical(1.0 / (1.0 + tan2).sqrt(), phi)
            }
            Brdf::Ggx { .. } | Brdf::Gltf { .. } => {
                let alpha = self.ggx_alpha();
                let tan2 = alpha * alpha * u.x / (1.0 - u.x).max(1e-30);
                spherical(1.0 / (1.0 + tan2).sqrt(), phi)
            }
            Brdf::Ward { alpha_x, alpha_y, .. } => {
                let phi_h = (alpha_y * phi.sin()).atan2(alpha_x * phi.cos());
                let (c, s) = (phi_h.cos(), phi_h.sin());
                let tan2 = -(u.x.max(1e-30)).ln() / (c * c / (alpha_x * alpha_x) + s * s / (alpha_y * alpha_y));
                spherical(1.0 / (1.0 + tan2).sqrt(), phi_h)
            }
        };
        // Twice the threshold here: a sample's recomputed half vector then always passes the
        // density's test despite rounding.
        (wo.dot(h) > 2.0 * MIN_COS_OH).then(|| reflect(wo, h))
    }

    /// The density of [`Brdf::sample`] at `wi` for the view `wo` (per steradian).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let pd = self.diffuse_probability();
        let diffuse = if wi.z > 0.0 { wi.z * FRAC_1_PI } else { 0.0 };
        if pd >= 1.0 {
            return diffuse;
        }
        let specular = match *self {
            Brdf::Lambert { .. } => 0.0,
            Brdf::Phong { exponent, .. } => {
                let r = Vec3::new(-wo.x, -wo.y, wo.z);
                (exponent + 1.0) / (2.0 * PI) * r.dot(wi).max(0.0).powf(exponent)
            }
            _ => {
                let h = wi + wo;
                let len = h.length();
                if len <= 1e-12 {
                    return pd * diffuse;
                }
                let h = h / len;
                let oh = wo.dot(h);
                if oh <= MIN_COS_OH || h.z <= 0.0 {
                    return pd * diffuse;
                }
                let ph = match *self {
                    Brdf::BlinnPhong { exponent, .. } => (exponent + 1.0) / (2.0 * PI) * h.z.powf(exponent),
                    Brdf::CookTorrance { alpha, .. } | Brdf::Beckmann { alpha, .. } => beckmann_d(h, alpha) * h.z,
                    Brdf::Ggx { .. } | Brdf::Gltf { .. } => ggx_d(h, self.ggx_alpha()) * h.z,
                    Brdf::Ward { alpha_x, alpha_y, .. } => {
                        let e = ((h.x / alpha_x).powi(2) + (h.y / alpha_y).powi(2)) / (h.z * h.z);
                        (-e).exp() / (PI * alpha_x * alpha_y * h.z * h.z * h.z)
                    }
                    _ => 0.0,
                };
                ph / (4.0 * oh)
            }
        };
        pd * diffuse + (1.0 - pd) * specular
    }
}

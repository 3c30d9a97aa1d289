//! BRDF models. Directions are in the local frame (normal +z, tangent +x); `wi` points to
//! the light, `wo` to the viewer. Every model is one-sided: zero when either direction is
//! at or below the horizon. [`Brdf::eval`] is `ρ` (sr⁻¹, RGB); tables hold `ρ·cos θ_i`.

use glam::Vec3;
use rsl_sphere::key::KeyHasher;
use std::f32::consts::{FRAC_1_PI, PI};

/// A BRDF with its parameters. Colours are linear RGB weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Brdf {
    /// `ρ = albedo/π`.
    Lambert {
        /// Albedo.
        albedo: Vec3,
    },
    /// Energy-normalised Phong (Lafortune & Willems 1994):
    /// `ρ = ks·(n+2)/(2π)·max(0, r·wi)^n + kd/π`, `r` the mirror of `wo`.
    Phong {
        /// Exponent `n > 0`.
        exponent: f32,
        /// Specular weight.
        specular: Vec3,
        /// Lambertian albedo.
        diffuse: Vec3,
    },
    /// Energy-normalised Blinn–Phong in the form of Neumann et al. 1999:
    /// `ρ = ks·D(h)·(n·h)/(4·(wo·h)·max(cos θi, cos θo)) + kd/π` with
    /// `D(h) = (n+2)/(2π)·(n·h)^n`, whose directional albedo is at most `ks`.
    BlinnPhong {
        /// Exponent `n > 0`.
        exponent: f32,
        /// Specular weight.
        specular: Vec3,
        /// Lambertian albedo.
        diffuse: Vec3,
    },
    /// Cook–Torrance: Beckmann distribution, Schlick's Fresnel with `F0 = specular`, the
    /// V-cavity shadowing `G = min(1, 2(n·h)(n·wo)/(wo·h), 2(n·h)(n·wi)/(wo·h))`:
    /// `ρ = F·D·G/(4 cos θi cos θo) + kd/π`.
    CookTorrance {
        /// Beckmann roughness (RMS slope).
        alpha: f32,
        /// `F0` per channel.
        specular: Vec3,
        /// Lambertian albedo.
        diffuse: Vec3,
    },
    /// Ward 1992, anisotropic (`alpha_x` along the tangent, `alpha_y` along the bitangent;
    /// equal for isotropic): `ρ = ks·exp(−tan²θh(cos²φh/αx² + sin²φh/αy²)) /
    /// (4π αx αy √(cos θi cos θo)) + kd/π`. Reciprocal, but (as is well known) its albedo
    /// can exceed 1 at grazing angles.
    Ward {
        /// Roughness along the tangent.
        alpha_x: f32,
        /// Roughness along the bitangent.
        alpha_y: f32,
        /// Specular weight.
        specular: Vec3,
        /// Lambertian albedo.
        diffuse: Vec3,
    },
    /// GGX microfacet conductor (Walter et al. 2007) with Fresnel = 1 and separable Smith
    /// shadowing `G1(wi)·G1(wo)`: Mitsuba 3's `roughconductor` with material "none".
    Ggx {
        /// Roughness α.
        alpha: f32,
        /// Specular weight.
        specular: Vec3,
        /// Lambertian albedo.
        diffuse: Vec3,
    },
    /// Beckmann microfacet conductor (Walter et al. 2007), Fresnel = 1, separable Smith
    /// shadowing with Walter's rational `G1` (as Mitsuba 3).
    Beckmann {
        /// Roughness α.
        alpha: f32,
        /// Specular weight.
        specular: Vec3,
        /// Lambertian albedo.
        diffuse: Vec3,
    },
    /// glTF 2.0's metallic-roughness material as the specification's appendix B writes it,
    /// `mix(dielectric, metal, metallic)`: the GGX distribution with `α = roughness²`,
    /// separable Smith-GGX masking, Schlick's Fresnel at the half vector, the metal's with
    /// `F0 = base colour` and the dielectric's with `F0 = 0.04`, whose diffuse term keeps
    /// what its Fresnel term leaves. With `c_diff = base colour·(1 − metallic)`:
    /// `ρ = F·D·G1(wi)·G1(wo)/(4 cos θi cos θo) + (1 − F_d)·c_diff/π`, with
    /// `F = F0 + (1 − F0)(1 − wo·h)⁵`, `F0 = mix(0.04, base colour, metallic)` and `F_d`
    /// the same with `F0 = 0.04`. (The specification's sample implementation weights the
    /// diffuse term by `1 − F` instead; the two agree where `metallic` is 0 or 1.) `ρ` is
    /// affine in the base colour, channel by channel, at any metalness: a frame drawn with
    /// base colours 0 and 1 gives every base colour exactly, which is how textures are
    /// drawn. Fresnel makes the diffuse term depend on the view too, so the model has no
    /// view-independent Lambertian term: [`Brdf::diffuse`] is zero and tables hold the
    /// whole BRDF per view.
    Gltf {
        /// Base colour (linear RGB).
        base_color: Vec3,
        /// Metalness in `[0, 1]`.
        metallic: f32,
        /// Perceptual roughness in `[MIN_ROUGHNESS, 1]`; `α = roughness²`.
        roughness: f32,
    },
}

/// Fresnel reflectance at normal incidence of glTF's dielectric (an index of refraction of 1.5).
pub const GLTF_DIELECTRIC_F0: f32 = 0.04;

/// Smallest glTF roughness accepted: `α = 0.01² = MIN_ALPHA`.
pub const MIN_ROUGHNESS: f32 = 0.01;

/// glTF's metallic-roughness parameters as the BRDF uses them: `F0`, `c_diff` and `α`.
pub fn gltf_terms(base_color: Vec3, metallic: f32, roughness: f32) -> (Vec3, Vec3, f32) {
    let f0 = Vec3::splat(GLTF_DIELECTRIC_F0).lerp(base_color, metallic);
    (f0, base_color * (1.0 - metallic), roughness * roughness)
}

/// A parameter out of range.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("{model}.{parameter}: {problem}")]
pub struct ParamError {
    /// Model name.
    pub model: &'static str,
    /// Parameter name.
    pub parameter: &'static str,
    /// What is wrong.
    pub problem: String,
}

/// Smallest roughness accepted; narrower lobes than this cannot be tabulated meaningfully.
pub const MIN_ALPHA: f32 = 1e-4;
/// Largest Phong/Blinn–Phong exponent accepted.
pub const MAX_EXPONENT: f32 = 1e6;

impl Brdf {
    /// The model's name.
    pub fn name(&self) -> &'static str {
        match self {
            Brdf::Lambert { .. } => "lambert",
            Brdf::Phong { .. } => "phong",
            Brdf::BlinnPhong { .. } => "blinn_phong",
            Brdf::CookTorrance { .. } => "cook_torrance",
            Brdf::Ward { .. } => "ward",
            Brdf::Ggx { .. } => "ggx",
            Brdf::Beckmann { .. } => "beckmann",
            Brdf::Gltf { .. } => "gltf",
        }
    }

    /// Checks every parameter: colours in `[0, 1]` per channel, roughness in `[1e-4, 1]`,
    /// exponents in `(0, 1e6]` (the one validation of a material, wherever it comes from).
    pub fn validate(&self) -> Result<(), ParamError> {
        let model = self.name();
        let err = |parameter, problem: String| Err(ParamError { model, parameter, problem });
        let colour = |parameter, c: Vec3| {
            if c.to_array().iter().all(|v| (0.0..=1.0).contains(v)) {
                Ok(())
            } else {
                err(
                    parameter,
                    format!(
                        "must be in [0, 1] per channel (above 1 a surface reflects more light than it receives), got {:?}",
                        c.to_array()
                    ),
                )
            }
        };
        let alpha = |parameter, a: f32| {
            if a.is_finite() && (MIN_ALPHA..=1.0).contains(&a) {
                Ok(())
            } else {
                err(parameter, format!("must be in [{MIN_ALPHA}, 1], got {a}"))
            }
        };
        let exponent = |e: f32| {
            if e.is_finite() && e > 0.0 && e <= MAX_EXPONENT {
                Ok(())
            } else {
                err("exponent", format!("must be in (0, {MAX_EXPONENT}], got {e}"))
            }
        };
        match *self {
            Brdf::Lambert { albedo } => colour("albedo", albedo),
            Brdf::Phong { exponent: e, specular, diffuse } | Brdf::BlinnPhong { exponent: e, specular, diffuse } => {
                exponent(e)?;
                colour("specular", specular)?;
                colour("diffuse", diffuse)
            }
            Brdf::CookTorrance { alpha: a, specular, diffuse }
            | Brdf::Ggx { alpha: a, specular, diffuse }
            | Brdf::Beckmann { alpha: a, specular, diffuse } => {
                alpha("alpha", a)?;
                colour("specular", specular)?;
                colour("diffuse", diffuse)
            }
            Brdf::Ward { alpha_x, alpha_y, specular, diffuse } => {
                alpha("alpha_x", alpha_x)?;
                alpha("alpha_y", alpha_y)?;
                colour("specular", specular)?;
                colour("diffuse", diffuse)
            }
            Brdf::Gltf { base_color, metallic, roughness } => {
                colour("base_color", base_color)?;
                if !(metallic.is_finite() && (0.0..=1.0).contains(&metallic)) {
                    return err("metallic", format!("must be in [0, 1], got {metallic}"));
                }
                if roughness.is_finite() && roughness < MIN_ROUGHNESS {
                    return err(
                        "roughness",
                        format!(
                            "must be in [{MIN_ROUGHNESS}, 1] (below, the lobe is narrower than α = {MIN_ALPHA}, which \
                             cannot be tabulated), got {roughness}"
                        ),
                    );
                }
                if !(roughness.is_finite() && roughness <= 1.0) {
                    return err("roughness", format!("must be in [{MIN_ROUGHNESS}, 1], got {roughness}"));
                }
                Ok(())
            }
        }
    }

    /// The content key: the model and every parameter, bit for bit.
    pub fn key(&self) -> u64 {
        let h = KeyHasher::default().str("brdf").str(self.name());
        let v = |v: &Vec3| v.to_array();
        match self {
            Brdf::Lambert { albedo } => h.f32s(&v(albedo)),
            Brdf::Phong { exponent: p, specular, diffuse } | Brdf::BlinnPhong { exponent: p, specular, diffuse } => {
                h.f32s(&[*p]).f32s(&v(specular)).f32s(&v(diffuse))
            }
            Brdf::CookTorrance { alpha: p, specular, diffuse }
            | Brdf::Ggx { alpha: p, specular, diffuse }
            | Brdf::Beckmann { alpha: p, specular, diffuse } => h.f32s(&[*p]).f32s(&v(specular)).f32s(&v(diffuse)),
            Brdf::Ward { alpha_x, alpha_y, specular, diffuse } => {
                h.f32s(&[*alpha_x, *alpha_y]).f32s(&v(specular)).f32s(&v(diffuse))
            }
            // "mix": the diffuse term weighted by the dielectric's Fresnel term (tables cached
            // before it weighted it by the mixed one).
            Brdf::Gltf { base_color, metallic, roughness } => {
                h.str("mix").f32s(&v(base_color)).f32s(&[*metallic, *roughness])
            }
        }
        .finish()
    }

    /// Whether the BRDF depends on the azimuth about the normal.
    pub fn is_anisotropic(&self) -> bool {
        matches!(self, Brdf::Ward { alpha_x, alpha_y, .. } if alpha_x != alpha_y)
    }

    /// Whether the specular part is zero (only a Lambertian term): one view slice suffices.
    pub fn is_lambertian(&self) -> bool {
        match self {
            Brdf::Lambert { .. } => true,
            Brdf::Phong { specular, .. }
            | Brdf::BlinnPhong { specular, .. }
            | Brdf::CookTorrance { specular, .. }
            | Brdf::Ward { specular, .. }
            | Brdf::Ggx { specular, .. }
            | Brdf::Beckmann { specular, .. } => *specular == Vec3::ZERO,
            // F0 ≥ 0.04 for a dielectric, and Fresnel reflects at grazing whatever F0 is.
            Brdf::Gltf { .. } => false,
        }
    }

    /// The Lambertian albedo `kd` of the diffuse term (`albedo` for a Lambertian BRDF); zero
    /// for a glTF material, whose diffuse term depends on the view (its Fresnel weight).
    pub fn diffuse(&self) -> Vec3 {
        match *self {
            Brdf::Lambert { albedo } => albedo,
            Brdf::Phong { diffuse, .. }
            | Brdf::BlinnPhong { diffuse, .. }
            | Brdf::CookTorrance { diffuse, .. }
            | Brdf::Ward { diffuse, .. }
            | Brdf::Ggx { diffuse, .. }
            | Brdf::Beckmann { diffuse, .. } => diffuse,
            Brdf::Gltf { .. } => Vec3::ZERO,
        }
    }

    /// The same BRDF without its diffuse term (the specular part alone; a Lambertian BRDF
    /// becomes black): with [`Brdf::diffuse`]'s term it makes the whole BRDF again. A glTF
    /// material, whose diffuse term is not Lambertian, stays whole.
    pub fn specular_part(&self) -> Brdf {
        let mut out = *self;
        match &mut out {
            Brdf::Lambert { albedo } => *albedo = Vec3::ZERO,
            Brdf::Phong { diffuse, .. }
            | Brdf::BlinnPhong { diffuse, .. }
            | Brdf::CookTorrance { diffuse, .. }
            | Brdf::Ward { diffuse, .. }
            | Brdf::Ggx { diffuse, .. }
            | Brdf::Beckmann { diffuse, .. } => *diffuse = Vec3::ZERO,
            Brdf::Gltf { .. } => {}
        }
        out
    }

    /// The BRDF as a lobe and a Lambertian albedo, for paths that fit lobes to a BRDF and
    /// treat its diffuse term apart (the lobe path): [`Brdf::specular_part`] and
    /// [`Brdf::diffuse`], but for a glTF material, whose view-dependent diffuse term is not
    /// Lambertian: its specular term alone (`F·D·G1·G1/(4 cos θi cos θo)`, the same `F0`
    /// and roughness) and the albedo `c_diff·(1 − 0.04)` — the diffuse term with the
    /// Fresnel weight it has head on, exact there and too bright toward grazing half
    /// vectors, where `(1 − F_d)` falls.
    pub fn lambert_split(&self) -> (Brdf, Vec3) {
        match *self {
            Brdf::Gltf { base_color, metallic, roughness } => {
                let (f0, c_diff, _) = gltf_terms(base_color, metallic, roughness);
                (Brdf::Gltf { base_color: f0, metallic: 1.0, roughness }, c_diff * (1.0 - GLTF_DIELECTRIC_F0))
            }
            _ => (self.specular_part(), self.diffuse()),
        }
    }

    /// The power `e` of `1/cos θ_o` by which the specular part's size grows with the view's
    /// polar angle at a fixed lobe shape: ½ for Ward (`ρ·cos θ_i ∝ √(cos θ_i / cos θ_o)`,
    /// which is why its albedo exceeds 1 near grazing), 0 for the others, whose shadowing
    /// keeps the size bounded. Tables blend view slices scaled by `(cos θ_k / cos θ_o)^e`.
    pub fn view_amplitude_exponent(&self) -> f32 {
        match self {
            Brdf::Ward { .. } => 0.5,
            _ => 0.0,
        }
    }

    /// Angular width of the specular lobe in radians (about one standard deviation of the
    /// lobe around its peak), used to choose tabulation resolution and sub-cell sampling.
    /// `None` for a Lambertian BRDF.
    pub fn lobe_width(&self) -> Option<f32> {
        if self.is_lambertian() {
            return None;
        }
        Some(match *self {
            Brdf::Lambert { .. } => unreachable!("handled above"),
            // cos^n α ≈ exp(−nα²/2): σ = 1/√n; Blinn–Phong's half-vector lobe is twice as wide
            // in the light direction.
            Brdf::Phong { exponent, .. } => 1.0 / exponent.sqrt(),
            Brdf::BlinnPhong { exponent, .. } => 2.0 / exponent.sqrt(),
            // Microfacet lobes in the light direction are about twice the normal distribution's.
            Brdf::CookTorrance { alpha, .. } | Brdf::Ggx { alpha, .. } | Brdf::Beckmann { alpha, .. } => 2.0 * alpha,
            Brdf::Gltf { roughness, .. } => 2.0 * roughness * roughness,
            Brdf::Ward { alpha_x, alpha_y, .. } => 2.0 * alpha_x.min(alpha_y),
        })
    }

    /// `ρ(wi, wo)` in sr⁻¹ (RGB); zero unless both directions are above the horizon.
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        let (ci, co) = (wi.z, wo.z);
        if ci <= 0.0 || co <= 0.0 {
            return Vec3::ZERO;
        }
        match *self {
            Brdf::Lambert { albedo } => albedo * FRAC_1_PI,
            Brdf::Phong { exponent, specular, diffuse } => {
                let r = Vec3::new(-wo.x, -wo.y, wo.z);
                let c = r.dot(wi).max(0.0);
                specular * ((exponent + 2.0) / (2.0 * PI) * lobe_power(c, exponent)) + diffuse * FRAC_1_PI
            }
            Brdf::BlinnPhong { exponent, specular, diffuse } => {
                let Some(h) = half_vector(wi, wo) else { return diffuse * FRAC_1_PI };
                let d = (exponent + 2.0) / (2.0 * PI) * lobe_power(h.z, exponent);
                specular * (d * h.z / (4.0 * wo.dot(h).max(1e-12) * ci.max(co))) + diffuse * FRAC_1_PI
            }
            Brdf::CookTorrance { alpha, specular, diffuse } => {
                let Some(h) = half_vector(wi, wo) else { return diffuse * FRAC_1_PI };
                let d = beckmann_d(h, alpha);
                let oh = wo.dot(h).max(1e-12);
                let g = (2.0 * h.z * co / oh).min(2.0 * h.z * ci / oh).min(1.0);
                let f = specular + (Vec3::ONE - specular) * (1.0 - wi.dot(h).clamp(0.0, 1.0)).powi(5);
                f * (d * g / (4.0 * ci * co)) + diffuse * FRAC_1_PI
            }
            Brdf::Ward { alpha_x, alpha_y, specular, diffuse } => {
                // tan²θh·(cos²φh/αx² + sin²φh/αy²) = ((hx/αx)² + (hy/αy)²)/hz², unchanged by the
                // length of h: the unnormalised half vector will do.
                let h = wi + wo;
                let e = ((h.x / alpha_x).powi(2) + (h.y / alpha_y).powi(2)) / (h.z * h.z);
                specular * ((-e).exp() / (4.0 * PI * alpha_x * alpha_y * (ci * co).sqrt())) + diffuse * FRAC_1_PI
            }
            Brdf::Ggx { alpha, specular, diffuse } => {
                // D and G1's sign test only need the direction of h: no normalisation.
                let h = wi + wo;
                let v = ggx_d(h, alpha) * ggx_g1(wi, h, alpha) * ggx_g1(wo, h, alpha) / (4.0 * ci * co);
                specular * v + diffuse * FRAC_1_PI
            }
            Brdf::Beckmann { alpha, specular, diffuse } => {
                let h = wi + wo;
                let v = beckmann_d(h, alpha) * beckmann_g1(wi, h, alpha) * beckmann_g1(wo, h, alpha) / (4.0 * ci * co);
                specular * v + diffuse * FRAC_1_PI
            }
            Brdf::Gltf { base_color, metallic, roughness } => {
                let (f0, c_diff, alpha) = gltf_terms(base_color, metallic, roughness);
                // Both directions are above the horizon, so h = wi + wo is not zero.
                let h = wi + wo;
                let oh = (wo.dot(h) / h.length()).clamp(0.0, 1.0);
                let s = (1.0 - oh).powi(5);
                let f = f0 + (Vec3::ONE - f0) * s;
                // The diffuse term is the dielectric's: weighted by its own Fresnel term.
                let f_dielectric = GLTF_DIELECTRIC_F0 + (1.0 - GLTF_DIELECTRIC_F0) * s;
                let v = ggx_d(h, alpha) * ggx_g1(wi, h, alpha) * ggx_g1(wo, h, alpha) / (4.0 * ci * co);
                f * v + c_diff * ((1.0 - f_dielectric) * FRAC_1_PI)
            }
        }
    }

    /// `ρ(wi, wo)·cos θi`, the tabulated quantity.
    pub fn eval_cos(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        self.eval(wi, wo) * wi.z.max(0.0)
    }
}

/// `cⁿ` for `c ∈ [0, 1]`, returning 0 without a `powf` where `n(1 − c) > 28`: since
/// `ln c ≤ −(1 − c)`, the true value there is below `e⁻²⁸ ≈ 7·10⁻¹³`, far below what f32
/// keeps next to the lobe's peak.
#[inline]
fn lobe_power(c: f32, n: f32) -> f32 {
    if n * (1.0 - c) > 28.0 { 0.0 } else { c.powf(n) }
}

fn half_vector(wi: Vec3, wo: Vec3) -> Option<Vec3> {
    let h = wi + wo;
    let l = h.length();
    (l > 1e-12).then(|| h / l)
}

/// GGX normal distribution (Walter et al. 2007, eq. 33) of the half vector `m` (any length).
pub(crate) fn ggx_d(m: Vec3, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    // α²/(π cos⁴θ (α² + tan²θ)²) = α²/(π (α² cos²θ + sin²θ)²) = α²|m|⁴/(π (α² m_z² + m_x² + m_y²)²),
    // with sin²θ from the tangent components: no cancellation near the peak, even for tiny
    // α in f32.
    let l2 = m.length_squared();
    let t = a2 * m.z * m.z + (m.x * m.x + m.y * m.y);
    if t <= 0.0 {
        return 0.0;
    }
    a2 * l2 * l2 / (PI * t * t)
}

/// GGX Smith G1 (Walter et al. 2007, eq. 34): `2/(1 + √(1 + α² tan²θv))`, zero when `v·m`
/// and `v·n` disagree in sign.
fn ggx_g1(v: Vec3, m: Vec3, alpha: f32) -> f32 {
    if v.dot(m) * v.z <= 0.0 {
        return 0.0;
    }
    let tan2 = (v.x * v.x + v.y * v.y) / (v.z * v.z);
    2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// Beckmann normal distribution (Walter et al. 2007, eq. 25) of the half vector `m` (any
/// length): `cos²θ = m_z²/|m|²`, `tan²θ = (m_x² + m_y²)/m_z²`.
pub(crate) fn beckmann_d(m: Vec3, alpha: f32) -> f32 {
    if m.z <= 0.0 {
        return 0.0;
    }
    let c2 = m.z * m.z / m.length_squared();
    let tan2 = (m.x * m.x + m.y * m.y) / (m.z * m.z);
    (-tan2 / (alpha * alpha)).exp() / (PI * alpha * alpha * c2 * c2)
}

/// Beckmann Smith G1 with Walter et al.'s rational approximation (eq. 27), as Mitsuba 3.
fn beckmann_g1(v: Vec3, m: Vec3, alpha: f32) -> f32 {
    if v.dot(m) * v.z <= 0.0 {
        return 0.0;
    }
    let tan = (v.x * v.x + v.y * v.y).sqrt() / v.z;
    if tan == 0.0 {
        return 1.0;
    }
    let a = 1.0 / (alpha * tan);
    if a >= 1.6 { 1.0 } else { (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a) }
}

impl std::fmt::Display for Brdf {
    /// The model and its parameters as a scene file names them (`ggx alpha 0.2 specular
    /// [1.0, 1.0, 1.0] diffuse [0.0, 0.0, 0.0]`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = self.name();
        let rgb = |c: &Vec3| c.to_array();
        match self {
            Brdf::Lambert { albedo } => write!(f, "lambert albedo {:?}", rgb(albedo)),
            Brdf::Phong { exponent, specular, diffuse } | Brdf::BlinnPhong { exponent, specular, diffuse } => {
                write!(f, "{name} exponent {exponent} specular {:?} diffuse {:?}", rgb(specular), rgb(diffuse))
            }
            Brdf::CookTorrance { alpha, specular, diffuse }
            | Brdf::Ggx { alpha, specular, diffuse }
            | Brdf::Beckmann { alpha, specular, diffuse } => {
                write!(f, "{name} alpha {alpha} specular {:?} diffuse {:?}", rgb(specular), rgb(diffuse))
            }
            Brdf::Gltf { base_color, metallic, roughness } => {
                write!(f, "gltf base_color {:?} metallic {metallic} roughness {roughness}", rgb(base_color))
            }
            Brdf::Ward { alpha_x, alpha_y, specular, diffuse } if alpha_x == alpha_y => {
                write!(f, "ward alpha {alpha_x} specular {:?} diffuse {:?}", rgb(specular), rgb(diffuse))
            }
            Brdf::Ward { alpha_x, alpha_y, specular, diffuse } => write!(
                f,
                "ward alpha_x {alpha_x} alpha_y {alpha_y} specular {:?} diffuse {:?}",
                rgb(specular),
                rgb(diffuse)
            ),
        }
    }
}

//! Material descriptions: which BRDF model and its parameters, as the scene file states them.
//!
//! This is description only; evaluation and tabulation live in `rsl-brdf`. Colours are
//! linear RGB weights.

use serde::{Deserialize, Serialize};

/// The BRDF models a scene may name (the `model` key of `material`).
pub const MODEL_NAMES: [&str; 7] = ["lambert", "phong", "blinn_phong", "cook_torrance", "ward", "ggx", "beckmann"];

/// A material: a BRDF model and its parameters.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum Material {
    /// Lambertian: `ρ = albedo/π`.
    Lambert {
        /// Diffuse albedo in `[0, 1]` per channel.
        #[serde(default = "default_albedo")]
        albedo: [f32; 3],
    },
    /// Normalised Phong lobe around the mirror direction, plus a Lambertian term.
    Phong {
        /// Lobe exponent (> 0).
        exponent: f32,
        /// Specular weight.
        #[serde(default = "white")]
        specular: [f32; 3],
        /// Added Lambertian albedo.
        #[serde(default)]
        diffuse: [f32; 3],
    },
    /// Normalised Blinn–Phong lobe around the half vector, plus a Lambertian term.
    BlinnPhong {
        /// Lobe exponent (> 0).
        exponent: f32,
        /// Specular weight.
        #[serde(default = "white")]
        specular: [f32; 3],
        /// Added Lambertian albedo.
        #[serde(default)]
        diffuse: [f32; 3],
    },
    /// Cook–Torrance with a Beckmann distribution and Schlick's Fresnel.
    CookTorrance {
        /// Beckmann roughness (RMS slope, > 0).
        alpha: f32,
        /// Fresnel reflectance at normal incidence (F0), RGB.
        #[serde(default = "white")]
        specular: [f32; 3],
        /// Added Lambertian albedo.
        #[serde(default)]
        diffuse: [f32; 3],
    },
    /// Ward's model: isotropic with `alpha`, anisotropic with `alpha_x` and `alpha_y`
    /// (along the tangent and bitangent).
    Ward {
        /// Isotropic roughness.
        #[serde(skip_serializing_if = "Option::is_none")]
        alpha: Option<f32>,
        /// Roughness along the tangent.
        #[serde(skip_serializing_if = "Option::is_none")]
        alpha_x: Option<f32>,
        /// Roughness along the bitangent.
        #[serde(skip_serializing_if = "Option::is_none")]
        alpha_y: Option<f32>,
        /// Specular weight.
        #[serde(default = "white")]
        specular: [f32; 3],
        /// Added Lambertian albedo.
        #[serde(default)]
        diffuse: [f32; 3],
    },
    /// GGX microfacet conductor (Walter et al. 2007), Fresnel = 1, separable Smith shadowing.
    Ggx {
        /// GGX roughness α (> 0).
        alpha: f32,
        /// Specular weight.
        #[serde(default = "white")]
        specular: [f32; 3],
        /// Added Lambertian albedo.
        #[serde(default)]
        diffuse: [f32; 3],
    },
    /// Beckmann microfacet conductor (Walter et al. 2007), Fresnel = 1, separable Smith
    /// shadowing.
    Beckmann {
        /// Beckmann roughness α (> 0).
        alpha: f32,
        /// Specular weight.
        #[serde(default = "white")]
        specular: [f32; 3],
        /// Added Lambertian albedo.
        #[serde(default)]
        diffuse: [f32; 3],
    },
}

fn default_albedo() -> [f32; 3] {
    [0.8; 3]
}

fn white() -> [f32; 3] {
    [1.0; 3]
}

impl Default for Material {
    fn default() -> Self {
        Material::Lambert { albedo: default_albedo() }
    }
}

/// Smallest roughness accepted: below it lobes are narrower than any table can hold.
pub const MIN_ALPHA: f32 = 1e-4;

impl Material {
    /// The model's name as written in scene files.
    pub fn model_name(&self) -> &'static str {
        match self {
            Material::Lambert { .. } => "lambert",
            Material::Phong { .. } => "phong",
            Material::BlinnPhong { .. } => "blinn_phong",
            Material::CookTorrance { .. } => "cook_torrance",
            Material::Ward { .. } => "ward",
            Material::Ggx { .. } => "ggx",
            Material::Beckmann { .. } => "beckmann",
        }
    }

    /// Whether the BRDF depends on the azimuth around the normal (needs tangents and 4D
    /// tables).
    pub fn is_anisotropic(&self) -> bool {
        matches!(self, Material::Ward { alpha_x: Some(x), alpha_y: Some(y), .. } if x != y)
    }

    /// Checks ranges; returns `(field, problem)` for the first bad parameter.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let colour = |name: &str, c: &[f32; 3]| -> Result<(), (String, String)> {
            if c.iter().any(|v| !(0.0..=1.0).contains(v)) {
                return Err((
                    name.into(),
                    format!(
                        "must be in [0, 1] per channel (above 1 a surface reflects more light than it receives), got {c:?}"
                    ),
                ));
            }
            Ok(())
        };
        let alpha = |name: &str, a: f32| -> Result<(), (String, String)> {
            if !a.is_finite() || !(MIN_ALPHA..=1.0).contains(&a) {
                return Err((name.into(), format!("must be in [{MIN_ALPHA}, 1], got {a}")));
            }
            Ok(())
        };
        let exponent = |e: f32| -> Result<(), (String, String)> {
            if !(e.is_finite() && e > 0.0 && e <= 1e6) {
                return Err(("exponent".into(), format!("must be in (0, 1e6], got {e}")));
            }
            Ok(())
        };
        match self {
            Material::Lambert { albedo } => colour("albedo", albedo),
            Material::Phong { exponent: e, specular, diffuse }
            | Material::BlinnPhong { exponent: e, specular, diffuse } => {
                exponent(*e)?;
                colour("specular", specular)?;
                colour("diffuse", diffuse)
            }
            Material::CookTorrance { alpha: a, specular, diffuse }
            | Material::Ggx { alpha: a, specular, diffuse }
            | Material::Beckmann { alpha: a, specular, diffuse } => {
                alpha("alpha", *a)?;
                colour("specular", specular)?;
                colour("diffuse", diffuse)
            }
            Material::Ward { alpha: a, alpha_x, alpha_y, specular, diffuse } => {
                match (a, alpha_x, alpha_y) {
                    (Some(a), None, None) => alpha("alpha", *a)?,
                    (None, Some(x), Some(y)) => {
                        alpha("alpha_x", *x)?;
                        alpha("alpha_y", *y)?;
                    }
                    _ => {
                        return Err((
                            "alpha".into(),
                            "ward needs either `alpha` (isotropic) or both `alpha_x` and `alpha_y` (anisotropic)"
                                .into(),
                        ));
                    }
                }
                colour("specular", specular)?;
                colour("diffuse", diffuse)
            }
        }
    }
}

impl std::fmt::Display for Material {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Material::Lambert { albedo } => write!(f, "lambert albedo {albedo:?}"),
            Material::Phong { exponent, specular, diffuse } | Material::BlinnPhong { exponent, specular, diffuse } => {
                write!(f, "{} exponent {exponent} specular {specular:?} diffuse {diffuse:?}", self.model_name())
            }
            Material::CookTorrance { alpha, specular, diffuse }
            | Material::Ggx { alpha, specular, diffuse }
            | Material::Beckmann { alpha, specular, diffuse } => {
                write!(f, "{} alpha {alpha} specular {specular:?} diffuse {diffuse:?}", self.model_name())
            }
            Material::Ward { alpha, alpha_x, alpha_y, specular, diffuse } => match alpha {
                Some(a) => write!(f, "ward alpha {a} specular {specular:?} diffuse {diffuse:?}"),
                None => write!(
                    f,
                    "ward alpha_x {} alpha_y {} specular {specular:?} diffuse {diffuse:?}",
                    alpha_x.unwrap_or(f32::NAN),
                    alpha_y.unwrap_or(f32::NAN)
                ),
            },
        }
    }
}

//! Materials as the scene file writes them (`material = { model = "ggx", alpha = 0.2 }`):
//! the file's shape of rsl-brdf's [`Brdf`], the one material type, read into it
//! ([`MaterialFile::into_brdf`]: the file's defaults, Ward's `alpha` or `alpha_x` and
//! `alpha_y`, then [`Brdf::validate`]) and written from it. Colours are linear RGB weights.

use glam::Vec3;
use rsl_brdf::Brdf;
use serde::{Deserialize, Serialize};

/// The BRDF models a scene may name (the `model` key of `material`).
pub const MODEL_NAMES: [&str; 8] =
    ["lambert", "phong", "blinn_phong", "cook_torrance", "ward", "ggx", "beckmann", "gltf"];

/// A material as the scene file writes it: a BRDF model and its parameters.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub(crate) enum MaterialFile {
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
    /// glTF 2.0's metallic-roughness material (the specification's appendix B), with its
    /// defaults (`pbrMetallicRoughness`: white, metallic 1, roughness 1).
    Gltf {
        /// Base colour, linear RGB.
        #[serde(default = "white")]
        base_color: [f32; 3],
        /// Metalness in `[0, 1]`.
        #[serde(default = "one")]
        metallic: f32,
        /// Perceptual roughness in `[0.01, 1]` (`α = roughness²`).
        #[serde(default = "one")]
        roughness: f32,
    },
}

fn one() -> f32 {
    1.0
}

fn default_albedo() -> [f32; 3] {
    [0.8; 3]
}

fn white() -> [f32; 3] {
    [1.0; 3]
}

/// The material of an object whose scene gives none.
pub fn default_material() -> Brdf {
    Brdf::Lambert { albedo: Vec3::from_array(default_albedo()) }
}

impl MaterialFile {
    /// The material it describes, checked: `Err((field, problem))` for the first bad
    /// parameter.
    pub(crate) fn into_brdf(self) -> Result<Brdf, (String, String)> {
        let v = Vec3::from_array;
        let brdf = match self {
            MaterialFile::Lambert { albedo } => Brdf::Lambert { albedo: v(albedo) },
            MaterialFile::Phong { exponent, specular, diffuse } => {
                Brdf::Phong { exponent, specular: v(specular), diffuse: v(diffuse) }
            }
            MaterialFile::BlinnPhong { exponent, specular, diffuse } => {
                Brdf::BlinnPhong { exponent, specular: v(specular), diffuse: v(diffuse) }
            }
            MaterialFile::CookTorrance { alpha, specular, diffuse } => {
                Brdf::CookTorrance { alpha, specular: v(specular), diffuse: v(diffuse) }
            }
            MaterialFile::Ward { alpha, alpha_x, alpha_y, specular, diffuse } => {
                let (alpha_x, alpha_y) = match (alpha, alpha_x, alpha_y) {
                    (Some(a), None, None) => (a, a),
                    (None, Some(x), Some(y)) => (x, y),
                    _ => {
                        return Err((
                            "alpha".into(),
                            "ward needs either `alpha` (isotropic) or both `alpha_x` and `alpha_y` (anisotropic)"
                                .into(),
                        ));
                    }
                };
                Brdf::Ward { alpha_x, alpha_y, specular: v(specular), diffuse: v(diffuse) }
            }
            MaterialFile::Ggx { alpha, specular, diffuse } => {
                Brdf::Ggx { alpha, specular: v(specular), diffuse: v(diffuse) }
            }
            MaterialFile::Beckmann { alpha, specular, diffuse } => {
                Brdf::Beckmann { alpha, specular: v(specular), diffuse: v(diffuse) }
            }
            MaterialFile::Gltf { base_color, metallic, roughness } => {
                Brdf::Gltf { base_color: v(base_color), metallic, roughness }
            }
        };
        brdf.validate().map_err(|e| (e.parameter.to_string(), e.problem))?;
        Ok(brdf)
    }

    /// `brdf` as the file writes it (an isotropic Ward with `alpha`).
    pub(crate) fn of(brdf: &Brdf) -> Self {
        let a = |c: &Vec3| c.to_array();
        match brdf {
            Brdf::Lambert { albedo } => MaterialFile::Lambert { albedo: a(albedo) },
            Brdf::Phong { exponent, specular, diffuse } => {
                MaterialFile::Phong { exponent: *exponent, specular: a(specular), diffuse: a(diffuse) }
            }
            Brdf::BlinnPhong { exponent, specular, diffuse } => {
                MaterialFile::BlinnPhong { exponent: *exponent, specular: a(specular), diffuse: a(diffuse) }
            }
            Brdf::CookTorrance { alpha, specular, diffuse } => {
                MaterialFile::CookTorrance { alpha: *alpha, specular: a(specular), diffuse: a(diffuse) }
            }
            Brdf::Ward { alpha_x, alpha_y, specular, diffuse } => {
                let (alpha, alpha_x, alpha_y) = if alpha_x == alpha_y {
                    (Some(*alpha_x), None, None)
                } else {
                    (None, Some(*alpha_x), Some(*alpha_y))
                };
                MaterialFile::Ward { alpha, alpha_x, alpha_y, specular: a(specular), diffuse: a(diffuse) }
            }
            Brdf::Ggx { alpha, specular, diffuse } => {
                MaterialFile::Ggx { alpha: *alpha, specular: a(specular), diffuse: a(diffuse) }
            }
            Brdf::Beckmann { alpha, specular, diffuse } => {
                MaterialFile::Beckmann { alpha: *alpha, specular: a(specular), diffuse: a(diffuse) }
            }
            Brdf::Gltf { base_color, metallic, roughness } => {
                MaterialFile::Gltf { base_color: a(base_color), metallic: *metallic, roughness: *roughness }
            }
        }
    }
}

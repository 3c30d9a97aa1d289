//! The lobe path as flat tables, for a GPU draw pass (`shaders/draw/lobes.wgsl`) that
//! evaluates [`MaterialLobes::radiance`] per pixel with the same numbers as the CPU.
//!
//! - [`PackedEnvironment`]: every level of a [`Prefiltered`] environment, each cube face
//!   stored with a one-texel border copied from the neighbouring faces (the texels
//!   [`rsl_sphere::cube::CubeGrid::bilinear`] steps to across a seam), so that a bilinear
//!   lookup needs no seam logic.
//! - [`PackedMaterial`]: a material's lobes per tabulated view.

use crate::material::{MaterialLobes, SPECULAR_LOBES};
use crate::prefilter::Prefiltered;
use glam::Vec3;

/// One level of a [`PackedEnvironment`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PackedLevel {
    /// The level's `κ`.
    pub kappa: f32,
    /// `R` of its `6×R×R` grid.
    pub r: u32,
    /// Index of its first texel in [`PackedEnvironment::texels`]; face `f`, bordered texel
    /// `(i, j)` for `i, j ∈ −1..=R` is at `offset + (f·(R+2) + j + 1)·(R+2) + i + 1`.
    pub offset: u32,
}

/// Every level of a prefiltered environment, faces bordered (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct PackedEnvironment {
    /// The levels, in increasing `κ`.
    pub levels: Vec<PackedLevel>,
    /// RGB values of every level.
    pub texels: Vec<Vec3>,
}

impl PackedEnvironment {
    /// Packs `env`.
    pub fn new(env: &Prefiltered) -> Self {
        let mut levels = Vec::with_capacity(env.levels().len());
        let mut texels = Vec::new();
        for level in env.levels() {
            let g = level.grid;
            let r = g.r();
            levels.push(PackedLevel { kappa: level.kappa, r: r as u32, offset: texels.len() as u32 });
            let last = r as i64 - 1;
            for face in 0..6 {
                for j in -1..=r as i64 {
                    for i in -1..=r as i64 {
                        let (ci, cj) = (i.clamp(0, last), j.clamp(0, last));
                        let t = g.index(face, ci as usize, cj as usize);
                        let t = if (ci, cj) == (i, j) { t } else { g.neighbour(t, (i - ci) as i32, (j - cj) as i32) };
                        texels.push(level.values[t]);
                    }
                }
            }
        }
        Self { levels, texels }
    }

    /// Bytes of the texels.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.texels.as_slice())
    }
}

/// One lobe of a [`PackedMaterial`] view: mean (in the frame where the view has azimuth 0),
/// `κ` and RGB weight; a weight of zero is no lobe.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PackedLobe {
    /// Unit mean direction.
    pub mean: Vec3,
    /// Concentration.
    pub kappa: f32,
    /// RGB weight.
    pub weight: Vec3,
}

/// A material's lobes: per tabulated polar view, [`SPECULAR_LOBES`] specular lobes (zero
/// weight where a view has none), then the diffuse lobe about the normal.
#[derive(Clone, Debug, PartialEq)]
pub struct PackedMaterial {
    /// Largest polar view angle fitted (radians).
    pub theta_max: f32,
    /// The exponent of the specular lobes' amplitude beyond `theta_max`
    /// ([`crate::MaterialLobes::beyond_last_view`]).
    pub amplitude_exponent: f32,
    /// Per view `k`, lobes `3k`, `3k + 1` and `3k + 2` ([`SPECULAR_LOBES`] per view).
    pub specular: Vec<PackedLobe>,
    /// Whether view `k` has lobes (a view without them takes its neighbour's, unblended).
    pub has_specular: Vec<bool>,
    /// The polar angle of view `k` (radians).
    pub thetas: Vec<f32>,
    /// The diffuse lobe (zero weight: none).
    pub diffuse: PackedLobe,
}

impl PackedMaterial {
    /// Packs `lobes`.
    pub fn new(lobes: &MaterialLobes) -> Self {
        let (theta_max, views, diffuse) = lobes.parts();
        let thetas = lobes.thetas().to_vec();
        let mut specular = Vec::with_capacity(SPECULAR_LOBES * views.len());
        let mut has_specular = Vec::with_capacity(views.len());
        for v in views {
            has_specular.push(v.is_some());
            for m in 0..SPECULAR_LOBES {
                specular.push(v.map_or(PackedLobe::default(), |v| PackedLobe {
                    mean: v[m].lobe.mean,
                    kappa: v[m].lobe.kappa,
                    weight: v[m].weight,
                }));
            }
        }
        let diffuse = diffuse.map_or(PackedLobe::default(), |d| PackedLobe {
            mean: d.lobe.mean,
            kappa: d.lobe.kappa,
            weight: d.weight,
        });
        let amplitude_exponent = lobes.brdf().view_amplitude_exponent();
        Self { theta_max, amplitude_exponent, specular, has_specular, thetas, diffuse }
    }

    /// Number of tabulated views.
    pub fn views(&self) -> usize {
        self.has_specular.len()
    }
}

//! Material lobes: `ρ(ω, v)·cos θ` of an isotropic BRDF, per view, as weighted vMF lobes
//! (Laurijssen & Dutré 2009, eq. 9 and 13–15).
//!
//! For each tabulated polar view angle `θ_k` (view in the local xz plane, normal +z), the
//! specular part is fitted first by one lobe from `S` stratified importance samples of the BRDF's
//! own sampling routine: with weights `w = f(ω)/pdf(ω)` (`f` the luminance of `ρ cos θ`),
//! the weighted mean direction `n = Σ w ω / Σ w` gives `μ = n/|n|` and, from `r = |n|`,
//! `κ = (3r − r³)/(1 − r²)` (eq. 13, the maximum-likelihood estimate for one lobe); the
//! weight is the sampled albedo `α = Σ (ρ cos θ / pdf) / S`, per channel (eq. 15). Eq. 13
//! matches the mean cosine, which a heavy tail drags down (a GGX lobe came out 50–70 % off
//! in L2 at α ≤ 0.1), so `κ` is then refined to the L2-best value for that `μ` and `α`
//! (golden-section search from eq. 13's estimate, the cross term from the same samples).
//! Where one lobe fits poorly (GGX's core and tail), a second about the same mean splits the
//! weight with it (`fit_view`). The diffuse term is one fixed lobe about the normal: a cosine
//! lobe has `r = 2/3`, so `κ = 46/15`, and weight `ρ_d`.
//!
//! A view between two tabulated angles interpolates the two fits lobe by lobe (Laurijssen
//! eq. 6): `μ` by a normalised blend, `κ` and `α` linearly. Rendering a lobe set under a prefiltered
//! environment is one lookup per lobe ([`MaterialLobes::radiance`]).

use crate::prefilter::Prefiltered;
use crate::vmf::Vmf;
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use rsl_brdf::Brdf;
use rsl_brdf::table::{polar_view_between, polar_views};
use rsl_sphere::Frame;
use rsl_sphere::sampling::luminance;

/// `κ` of the one-lobe fit of a clamped cosine: `r = 2/3` in eq. 13.
pub const COSINE_KAPPA: f32 = 46.0 / 15.0;

/// A lobe with an RGB weight: `weight · γ_{μ,κ}(ω)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightedLobe {
    /// `α`, per channel (the integral of the fitted function).
    pub weight: Vec3,
    /// The normalised lobe.
    pub lobe: Vmf,
}

/// How material lobes are fitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FitParams {
    /// Tabulated polar view angles (from 0 to 89.9°, denser toward grazing as the BRDF tables).
    pub views: usize,
    /// `S`, stratified samples per view (a square number is used: `⌈√S⌉²`).
    pub samples: usize,
}

impl Default for FitParams {
    fn default() -> Self {
        Self { views: 16, samples: 4096 }
    }
}

/// A material's lobes per tabulated view.
#[derive(Clone, Debug)]
pub struct MaterialLobes {
    brdf: Brdf,
    thetas: Vec<f32>,
    /// The specular lobes per view (in the frame where the view has azimuth 0), if the BRDF
    /// has a specular part.
    specular: Vec<Option<[WeightedLobe; 2]>>,
    /// Per view, `κ` of the best single lobe (what one lobe's width would be).
    single: Vec<f32>,
    /// The diffuse lobe (about the normal), if the BRDF has a diffuse term.
    diffuse: Option<WeightedLobe>,
}

/// Largest polar view angle fitted.
fn theta_max() -> f32 {
    89.9f32.to_radians()
}

/// The fit of `ρ cos θ` of `specular` (a BRDF without diffuse term) for view `wo`: two lobes
/// about one mean, the one with the larger weight first.
fn fit_view(specular: &Brdf, wo: Vec3, samples: usize) -> Option<ViewFit> {
    let k = (samples as f64).sqrt().ceil().max(1.0) as usize;
    // Per sample: its direction, f/pdf (luminance) and f (luminance) at it.
    let mut points: Vec<(DVec3, f64, f64)> = Vec::with_capacity(k * k);
    let mut albedo = DVec3::ZERO;
    for j in 0..k {
        for i in 0..k {
            // Stratified with a fixed jitter (the fit is deterministic).
            let jitter = |a: usize, b: usize| ((a * 7919 + b * 104_729) % 1000) as f32 / 1000.0;
            let u = Vec2::new((i as f32 + jitter(i, j)) / k as f32, (j as f32 + jitter(j, i)) / k as f32);
            let Some(wi) = specular.sample(wo, u, 1.0) else { continue };
            if wi.z <= 0.0 {
                continue;
            }
            let pdf = specular.pdf(wo, wi);
            if pdf.is_nan() || pdf <= 0.0 {
                continue;
            }
            let f = specular.eval_cos(wi, wo);
            albedo += (f / pdf).as_dvec3();
            let y = f64::from(luminance(f));
            points.push((wi.as_dvec3(), y / f64::from(pdf), y));
        }
    }
    let count = (k * k) as f64;
    let total: f64 = points.iter().map(|p| p.1).sum();
    if total.is_nan() || total <= 0.0 {
        return None;
    }
    // Eq. 13–14: the mean direction and the maximum-likelihood κ of one lobe.
    let n = points.iter().fold(DVec3::ZERO, |n, p| n + p.0 * p.1) / total;
    let r = n.length().min(1.0 - 1e-7);
    let mean = n / n.length().max(1e-300);
    let kappa_ml = (3.0 * r - r * r * r) / (1.0 - r * r);
    // Eq. 13 matches the mean cosine, which a heavy tail (GGX) drags down: the lobe comes
    // out too wide for its peak. Keep the weight (the albedo, so a furnace is exact) and the
    // mean, and take the κ that minimises the L2 distance `∫ (f − αγ_κ)²`, by golden-section
    // search in log κ around the estimate; `∫ f γ_κ` from the same samples, `∫ γ_κ²` in
    // closed form.
    let alpha = total / count;
    let l2 = |log_k: f64| {
        let kappa = log_k.exp();
        let cross = points.iter().map(|p| p.1 * crate::vmf::density_at(kappa, mean.dot(p.0))).sum::<f64>() / count;
        let g = Vmf { mean: mean.as_vec3(), kappa: kappa as f32 };
        alpha * alpha * g.product_integral(&g) - 2.0 * alpha * cross
    };
    let (mut a, mut b) = ((kappa_ml * 0.5).max(1e-3).ln(), (kappa_ml * 64.0).max(1.0).ln());
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (l2(c), l2(d));
    for _ in 0..40 {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = l2(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = l2(d);
        }
    }
    let kappa = (0.5 * (a + b)).exp();
    let weight = (albedo / count).as_vec3();
    // A second lobe about the same mean, for the core-and-tail shape of microfacet lobes: the
    // pair (κ₁, κ₂) from a ladder of octaves around κ, and the split `t` of the weight
    // (`tα` and `(1 − t)α`, so a furnace stays exact) that minimises the L2 distance in
    // closed form for each pair. One lobe (`t = 1`) is among the candidates.
    let ladder: Vec<f64> = (0..=10).map(|j| kappa * 2f64.powi(j - 5)).collect();
    let cross: Vec<f64> = ladder
        .iter()
        .map(|&k| points.iter().map(|p| p.1 * crate::vmf::density_at(k, mean.dot(p.0))).sum::<f64>() / count)
        .collect();
    let lobe = |k: f64| Vmf { mean: mean.as_vec3(), kappa: k as f32 };
    let gram = |i: usize, j: usize| lobe(ladder[i]).product_integral(&lobe(ladder[j]));
    // `∫ f²` from the same samples, so that errors compare as squared distances.
    let f2 = points.iter().map(|p| p.1 * p.2).sum::<f64>() / count;
    let mut best = (f64::INFINITY, 5, 5, 1.0);
    for i in 0..ladder.len() {
        for j in 0..=i {
            let (gii, gij, gjj) = (gram(i, i), gram(i, j), gram(j, j));
            let denominator = gii - 2.0 * gij + gjj;
            let t = if denominator > 1e-12 {
                (((cross[i] - cross[j]) / alpha + gjj - gij) / denominator).clamp(0.0, 1.0)
            } else {
                1.0
            };
            let e = alpha * alpha * (t * t * gii + 2.0 * t * (1.0 - t) * gij + (1.0 - t) * (1.0 - t) * gjj)
                - 2.0 * alpha * (t * cross[i] + (1.0 - t) * cross[j]);
            if e < best.0 {
                best = (e, i, j, t);
            }
        }
    }
    // Two lobes where they pay: a squared L2 distance lower than one lobe's by a fifth of it
    // and by 0.5 % of `∫ f²` (the sampled estimates are noisy near a perfect fit; a Phong
    // lobe, a vMF in all but name, keeps one). The caller decides for all views at once
    // ([`MaterialLobes::fit`]).
    let single = alpha * alpha * gram(5, 5) - 2.0 * alpha * cross[5] + f2;
    let gain = single - (best.0 + f2);
    let pays = gain > 0.2 * single.max(0.0) + 0.005 * f2;
    let pair_of = |(_, i, j, t): (f64, usize, usize, f64)| {
        // The first lobe is the main one (the larger share), the second the rest; a lobe
        // left without weight takes the main one's κ, so that no weightless κ is blended into
        // a neighbouring view's.
        let (main, rest, share) = if t >= 0.5 { (ladder[i], ladder[j], t) } else { (ladder[j], ladder[i], 1.0 - t) };
        let rest = if share >= 1.0 { main } else { rest };
        [
            WeightedLobe { weight: weight * share as f32, lobe: Vmf::new(mean.as_vec3(), main as f32) },
            WeightedLobe { weight: weight * (1.0 - share) as f32, lobe: Vmf::new(mean.as_vec3(), rest as f32) },
        ]
    };
    Some(ViewFit { pair: pair_of(best), single: pair_of((single, 5, 5, 1.0)), pays, kappa: kappa as f32 })
}

/// One view's fits ([`fit_view`]): the best pair of lobes, one lobe (as a pair with an empty
/// second), whether the pair pays for itself, and the single lobe's `κ`.
#[derive(Clone, Copy)]
struct ViewFit {
    pair: [WeightedLobe; 2],
    single: [WeightedLobe; 2],
    pays: bool,
    kappa: f32,
}

impl MaterialLobes {
    /// Fits `brdf` (isotropic; it must validate) at `params.views` polar views.
    pub fn fit(brdf: &Brdf, params: &FitParams) -> Result<Self, String> {
        brdf.validate().map_err(|e| e.to_string())?;
        if brdf.is_anisotropic() {
            return Err(format!("{}: material lobes are fitted for isotropic BRDFs only", brdf.name()));
        }
        let v = params.views.max(2);
        let thetas = polar_views(v, theta_max());
        let specular_part = brdf.specular_part();
        let has_specular = !brdf.is_lambertian();
        let fits: Vec<Option<ViewFit>> = thetas
            .par_iter()
            .map(|&t| {
                has_specular
                    .then(|| fit_view(&specular_part, Vec3::new(t.sin(), 0.0, t.cos()), params.samples))
                    .flatten()
            })
            .collect();
        // Two lobes at every view if they pay at any: views are interpolated lobe by lobe
        // (here between tabulated angles, and by transport lobes across object-space views),
        // and a view with one lobe beside a view with two blends unlike shapes (GGX α 0.05
        // at 60° between such views: 43 % off in L2, 38 % with two lobes at both).
        let pairs = fits.iter().flatten().any(|f| f.pays);
        let specular = fits.iter().map(|f| f.map(|f| if pairs { f.pair } else { f.single })).collect();
        let single = fits.iter().flatten().map(|f| f.kappa).collect();
        let d = brdf.diffuse();
        let diffuse = (d != Vec3::ZERO).then(|| WeightedLobe { weight: d, lobe: Vmf::new(Vec3::Z, COSINE_KAPPA) });
        Ok(Self { brdf: *brdf, thetas, specular, single, diffuse })
    }

    /// The fitted BRDF.
    pub fn brdf(&self) -> &Brdf {
        &self.brdf
    }

    /// The fitted specular lobes, one per tabulated view (in the frame where the view has
    /// azimuth 0), where the BRDF has a specular part.
    pub fn lobes_per_view(&self) -> impl Iterator<Item = &WeightedLobe> {
        self.specular.iter().flatten().flatten().filter(|l| l.weight != Vec3::ZERO)
    }

    /// The sharpest single lobe's `κ` over the tabulated views (0 without a specular part):
    /// the width `1/√κ` one lobe would have, whatever the fit split it into.
    pub fn single_kappa_max(&self) -> f32 {
        self.single.iter().copied().fold(0.0, f32::max)
    }

    /// The tabulated polar view angles.
    pub fn thetas(&self) -> &[f32] {
        &self.thetas
    }

    /// What [`crate::packed::PackedMaterial`] flattens: the largest polar view fitted, the
    /// specular lobes per tabulated view, the diffuse lobe.
    pub(crate) fn parts(&self) -> (f32, &[Option<[WeightedLobe; 2]>], Option<WeightedLobe>) {
        (theta_max(), &self.specular, self.diffuse)
    }

    /// The lobes for view `view` (unit, local frame: normal +z), in that frame: the specular
    /// lobe interpolated between the two nearest tabulated views and turned to the view's
    /// azimuth, then the diffuse lobe. Views at or below the horizon reflect nothing.
    pub fn lobes(&self, view: Vec3) -> Vec<WeightedLobe> {
        self.lobes_at(view).collect()
    }

    /// [`MaterialLobes::lobes`] without allocating.
    fn lobes_at(&self, view: Vec3) -> impl Iterator<Item = WeightedLobe> {
        let above = !(view.z.is_nan() || view.z <= 0.0);
        above.then(|| self.specular_at(view)).into_iter().flatten().chain(self.diffuse.filter(|_| above))
    }

    /// The specular lobes for a view above the horizon (see [`MaterialLobes::lobes`]).
    fn specular_at(&self, view: Vec3) -> impl Iterator<Item = WeightedLobe> {
        self.specular_pair(view).into_iter().flatten().filter(|l| l.weight != Vec3::ZERO)
    }

    /// The two specular lobes for `view` (unit, local frame, above the horizon), in that
    /// frame: interpolated between the two nearest tabulated views lobe by lobe and turned to
    /// the view's azimuth, the main lobe first (a lobe may have zero weight); `None` without
    /// a specular part.
    pub fn specular_pair(&self, view: Vec3) -> Option<[WeightedLobe; 2]> {
        let theta = view.z.clamp(-1.0, 1.0).acos().min(theta_max());
        let (k, f) = polar_view_between(theta, self.thetas.len(), theta_max());
        let rxy = Vec2::new(view.x, view.y).length();
        let (c, s) = if rxy > 1e-12 { (view.x / rxy, view.y / rxy) } else { (1.0, 0.0) };
        let turn = move |d: Vec3| Vec3::new(c * d.x - s * d.y, s * d.x + c * d.y, d.z);
        match (self.specular[k], self.specular[k + 1]) {
            (Some(a), Some(b)) => Some([0, 1].map(|m| {
                let (a, b) = (a[m], b[m]);
                let mean = (a.lobe.mean * (1.0 - f) + b.lobe.mean * f).normalize_or(a.lobe.mean);
                let kappa = a.lobe.kappa * (1.0 - f) + b.lobe.kappa * f;
                let weight = a.weight * (1.0 - f) + b.weight * f;
                WeightedLobe { weight, lobe: Vmf::new(turn(mean), kappa) }
            })),
            (Some(a), None) | (None, Some(a)) => {
                Some(a.map(|l| WeightedLobe { lobe: Vmf::new(turn(l.lobe.mean), l.lobe.kappa), ..l }))
            }
            (None, None) => None,
        }
    }

    /// The diffuse lobe (about the normal, local frame), if the BRDF has a diffuse term.
    pub fn diffuse_lobe(&self) -> Option<WeightedLobe> {
        self.diffuse
    }

    /// Unshadowed reflected radiance toward `view` at a point with shading frame `frame`
    /// (world space), under `env` whose environment-from-world rotation is applied by
    /// `to_env`: `Σ_j α_j P_{κ_j}(μ_j)`, one lookup per lobe.
    pub fn radiance(&self, env: &Prefiltered, frame: &Frame, view_world: Vec3, to_env: impl Fn(Vec3) -> Vec3) -> Vec3 {
        self.lobes_at(frame.to_local(view_world))
            .map(|l| l.weight * env.lookup(to_env(frame.to_world(l.lobe.mean)), l.lobe.kappa))
            .sum()
    }
}

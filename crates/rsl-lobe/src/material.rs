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
//! Where one lobe fits poorly (GGX's core and tail, stretched toward grazing views), up to
//! three lobes from candidates about the mean or turned within the plane of incidence split
//! the weight (`fit_view`, [`ViewProblem::best`]). The diffuse term is one fixed lobe about
//! the normal: a cosine lobe has `r = 2/3`, so `κ = 46/15`, and weight `ρ_d`.
//!
//! A view between two tabulated angles takes both views' lobes, each set turned within the
//! plane of incidence so that its reflection is the view's, weighted by the view's place
//! between them ([`MaterialLobes::specular_lobes`]; not Laurijssen's eq. 6 blend of the
//! parameters, since each view's lobes are its own best fit and need not correspond).
//! Rendering a lobe set under a prefiltered environment is one lookup per lobe
//! ([`MaterialLobes::radiance`]).

use crate::prefilter::Prefiltered;
use crate::vmf::{Vmf, product_integral};
use glam::{DQuat, DVec3, Quat, Vec2, Vec3};
use rayon::prelude::*;
use rsl_brdf::Brdf;
use rsl_brdf::table::{polar_view_between, polar_views};
use rsl_sphere::Frame;
use rsl_sphere::sampling::luminance;

/// `κ` of the one-lobe fit of a clamped cosine: `r = 2/3` in eq. 13.
pub const COSINE_KAPPA: f32 = 46.0 / 15.0;

/// Specular lobes per view: the material's `ρ cos θ` is fitted by up to this many (a lobe
/// may have zero weight).
pub const SPECULAR_LOBES: usize = 3;

/// A view's specular lobes (see [`MaterialLobes::specular_lobes`]).
pub type SpecularLobes = [WeightedLobe; SPECULAR_LOBES];

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
    specular: Vec<Option<SpecularLobes>>,
    /// Per view, `κ` of the best single lobe (what one lobe's width would be).
    single: Vec<f32>,
    /// The diffuse lobe (about the normal), if the BRDF has a diffuse term.
    diffuse: Option<WeightedLobe>,
}

/// Largest polar view angle fitted.
fn theta_max() -> f32 {
    89.9f32.to_radians()
}

/// `(cos θ_max / cos θ)^e` for a view whose polar cosine `cos_view` lies below the last fitted
/// view's ([`MaterialLobes::beyond_last_view`]), else 1.
pub fn view_amplitude(e: f32, cos_view: f32) -> f32 {
    let last = theta_max().cos();
    if e > 0.0 && cos_view < last { (last / cos_view.max(rsl_brdf::table::MIN_VIEW_COS)).powf(e) } else { 1.0 }
}

/// The problem of fitting `ρ cos θ` of `specular` (a BRDF without diffuse term) for view
/// `wo` by up to three lobes: the one-lobe fit and the candidates around it.
fn fit_view(specular: &Brdf, wo: Vec3, samples: usize) -> Option<ViewProblem> {
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
    let deficits: Vec<f64> = points.iter().map(|p| mean.dot(p.0).clamp(-1.0, 1.0) - 1.0).collect();
    let l2 = |log_k: f64| {
        let kappa = log_k.exp();
        let sum = points.iter().zip(&deficits).map(|(p, x)| p.1 * (kappa * x).exp()).sum::<f64>();
        let cross = crate::vmf::peak_density(kappa) * sum / count;
        alpha * alpha * product_integral((mean, kappa), (mean, kappa)) - 2.0 * alpha * cross
    };
    let (mut a, mut b) = ((kappa_ml * 0.5).max(1e-3).ln(), (kappa_ml * 64.0).max(1.0).ln());
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (l2(c), l2(d));
    // 24 steps narrow the search to 10⁻⁵ of its width in log κ.
    for _ in 0..24 {
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
    // Up to three lobes, for the core-and-tail shape of microfacet lobes and its stretch
    // toward grazing views: candidates from a ladder of octaves around κ, each about the mean
    // or turned within the plane of incidence by up to 1.5 widths (`1/√κ`) either way. The
    // caller picks three of them per view ([`ViewProblem::solve`]).
    let ladder: Vec<f64> = (0..LADDER).map(|j| kappa * 2f64.powi(j as i32 - (LADDER as i32 - 1) / 2)).collect();
    let width = 1.0 / kappa.max(1.0).sqrt();
    let means: Vec<DVec3> = (0..TURNS)
        .map(|m| {
            // Positive offsets turn the mean away from the normal (view in the xz plane,
            // reflection toward −x: a turn about y by −δ).
            let delta = (m as f64 - (TURNS as f64 - 1.0) / 2.0) * 0.5 * width;
            DQuat::from_rotation_y(-delta) * mean
        })
        .collect();
    // Candidate `m·LADDER + j`: mean `m`, κ `ladder[j]`. `∫ f γ` from the samples, each
    // mean's exponentials by squaring up the octave ladder (`e^{2κx} = (e^{κx})²`).
    let candidates = TURNS * LADDER;
    let mut cross = vec![0.0f64; candidates];
    let peaks: Vec<f64> = ladder.iter().map(|&k| crate::vmf::peak_density(k)).collect();
    for p in &points {
        for (m, mu) in means.iter().enumerate() {
            let mut e = (ladder[0] * (mu.dot(p.0).clamp(-1.0, 1.0) - 1.0)).exp();
            for j in 0..LADDER {
                cross[m * LADDER + j] += p.1 * peaks[j] * e;
                e *= e;
            }
        }
    }
    let lobe_of = |i: usize| (means[i / LADDER], ladder[i % LADDER]);
    let mut gram = vec![0.0f64; candidates * candidates];
    for i in 0..candidates {
        for j in 0..=i {
            let g = product_integral(lobe_of(i), lobe_of(j));
            gram[i * candidates + j] = g;
            gram[j * candidates + i] = g;
        }
    }
    // `∫ f²` from the same samples, so that errors compare as squared distances.
    let f2 = points.iter().map(|p| p.1 * p.2).sum::<f64>() / count;
    Some(ViewProblem {
        alpha,
        weight,
        f2,
        means,
        ladder,
        gram,
        c_hat: cross.iter().map(|c| c / count / alpha).collect(),
        kappa: kappa as f32,
    })
}

/// Candidate `κ`s per view: octaves around the one-lobe fit's.
const LADDER: usize = 11;
/// Candidate means per view: the one-lobe fit's and turns of ±0.5, ±1 and ±1.5 widths.
const TURNS: usize = 7;
/// The candidate of the one-lobe fit (its mean, its κ).
const CENTRE: usize = (TURNS / 2) * LADDER + (LADDER - 1) / 2;

/// One view's fitting problem ([`fit_view`]): candidate lobes and, for a weight split `u`
/// among them (`Σu = 1`, `u ≥ 0`, the lobes' weights `uα`), the squared L2 distance
/// `α²(uᵀGu − 2uᵀĉ) + ∫f²`, `G` the candidates' product integrals (closed form) and `ĉ` their
/// sampled `∫ f γ / α`.
#[derive(Clone)]
struct ViewProblem {
    alpha: f64,
    /// The sampled albedo, per channel.
    weight: Vec3,
    f2: f64,
    means: Vec<DVec3>,
    ladder: Vec<f64>,
    gram: Vec<f64>,
    c_hat: Vec<f64>,
    /// `κ` of the one-lobe fit.
    kappa: f32,
}

/// Three candidates (by index) and the shares of the weight each takes.
#[derive(Clone, Copy, Debug)]
struct Split {
    /// `uᵀGu − 2uᵀĉ`.
    error: f64,
    parts: [(usize, f64); SPECULAR_LOBES],
}

impl ViewProblem {
    fn g(&self, i: usize, j: usize) -> f64 {
        self.gram[i * TURNS * LADDER + j]
    }

    /// The one-lobe fit, as a split.
    fn single(&self) -> Split {
        let c = CENTRE;
        Split { error: self.g(c, c) - 2.0 * self.c_hat[c], parts: [(c, 1.0), (c, 0.0), (c, 0.0)] }
    }

    /// The best split among candidates `[i, j, k]` with every share positive, by the 2×2
    /// normal equations; `None` where it lies outside the triangle of weights.
    fn inside(&self, [i, j, k]: [usize; 3]) -> Option<Split> {
        let (g, c) = (|a, b| self.g(a, b), &self.c_hat);
        // u = e_k + t₁(e_i − e_k) + t₂(e_j − e_k).
        let a11 = g(i, i) - 2.0 * g(i, k) + g(k, k);
        let a12 = g(i, j) - g(i, k) - g(j, k) + g(k, k);
        let a22 = g(j, j) - 2.0 * g(j, k) + g(k, k);
        let r1 = c[i] - c[k] - g(i, k) + g(k, k);
        let r2 = c[j] - c[k] - g(j, k) + g(k, k);
        let det = a11 * a22 - a12 * a12;
        if det <= 1e-12 * (a11 * a22).max(1e-300) {
            return None;
        }
        let t1 = (r1 * a22 - r2 * a12) / det;
        let t2 = (a11 * r2 - a12 * r1) / det;
        (t1 > 0.0 && t2 > 0.0 && t1 + t2 < 1.0).then(|| {
            // At the optimum E = E(e_k) − tᵀr.
            let error = g(k, k) - 2.0 * c[k] - (t1 * r1 + t2 * r2);
            Split { error, parts: [(i, t1), (j, t2), (k, 1.0 - t1 - t2)] }
        })
    }

    /// The best split over every one, two and three candidates: singles and pairs in closed
    /// form (the weight split clamped to `[0, 1]`), triples inside their triangle of weights
    /// (a triple whose best lies on an edge is a pair).
    fn best(&self) -> Split {
        let n = TURNS * LADDER;
        let (g, c) = (|a, b| self.g(a, b), &self.c_hat);
        let mut best = self.single();
        for i in 0..n {
            let e = g(i, i) - 2.0 * c[i];
            if e < best.error {
                best = Split { error: e, parts: [(i, 1.0), (i, 0.0), (i, 0.0)] };
            }
            for j in 0..i {
                let d = g(i, i) - 2.0 * g(i, j) + g(j, j);
                if d > 1e-12 {
                    let t = ((c[i] - c[j]) + g(j, j) - g(i, j)) / d;
                    if t > 0.0 && t < 1.0 {
                        let e = t * t * g(i, i) + 2.0 * t * (1.0 - t) * g(i, j) + (1.0 - t) * (1.0 - t) * g(j, j)
                            - 2.0 * (t * c[i] + (1.0 - t) * c[j]);
                        if e < best.error {
                            best = Split { error: e, parts: [(i, t), (j, 1.0 - t), (j, 0.0)] };
                        }
                    }
                }
                for k in 0..j {
                    if let Some(s) = self.inside([i, j, k])
                        && s.error < best.error
                    {
                        best = s;
                    }
                }
            }
        }
        best
    }

    /// Squared L2 distance of `split`.
    fn squared(&self, split: &Split) -> f64 {
        self.alpha * self.alpha * split.error + self.f2
    }

    /// Whether `split` pays for its several lobes: a squared L2 distance lower than one
    /// lobe's by a fifth of it and by 0.5 % of `∫ f²` (the sampled estimates are noisy near
    /// a perfect fit; a Phong lobe, a vMF in all but name, keeps one).
    fn pays(&self, split: &Split) -> bool {
        let single = self.squared(&self.single());
        single - self.squared(split) > 0.2 * single.max(0.0) + 0.005 * self.f2
    }

    /// The lobes of `split`, in its order.
    fn lobes(&self, split: &Split) -> SpecularLobes {
        split.parts.map(|(i, t)| WeightedLobe {
            weight: self.weight * t as f32,
            lobe: Vmf::new(self.means[i / LADDER].as_vec3(), self.ladder[i % LADDER] as f32),
        })
    }
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
        // A glTF material's diffuse term (weighted by 1 − F) is not Lambertian: the lobes
        // take its specular term, the cosine lobe `c_diff·(1 − F0)` (`Brdf::lambert_split`).
        let (specular_part, d) = brdf.lambert_split();
        let has_specular = !brdf.is_lambertian();
        let problems: Vec<Option<ViewProblem>> = thetas
            .par_iter()
            .map(|&t| {
                has_specular
                    .then(|| fit_view(&specular_part, Vec3::new(t.sin(), 0.0, t.cos()), params.samples))
                    .flatten()
            })
            .collect();
        // Each view's best three: views are not blended lobe by lobe (see
        // [`MaterialLobes::specular_lobes`]), so they need not correspond.
        let splits: Vec<Option<Split>> = problems.par_iter().map(|p| p.as_ref().map(ViewProblem::best)).collect();
        // Several lobes at every view if they pay at any: a view with one lobe beside a view
        // with several blends unlike shapes (GGX α 0.05 at 60° between such views: 43 % off in
        // L2, 38 % with two lobes at both).
        let several =
            problems.iter().zip(&splits).any(|(p, s)| p.as_ref().zip(s.as_ref()).is_some_and(|(p, s)| p.pays(s)));
        let specular = problems
            .iter()
            .zip(&splits)
            .map(|(p, s)| {
                let p = p.as_ref()?;
                Some(if several { p.lobes(s.as_ref()?) } else { p.lobes(&p.single()) })
            })
            .collect();
        let single = problems.iter().flatten().map(|p| p.kappa).collect();
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
    pub(crate) fn parts(&self) -> (f32, &[Option<SpecularLobes>], Option<WeightedLobe>) {
        (theta_max(), &self.specular, self.diffuse)
    }

    /// The lobes for view `view` (unit, local frame: normal +z), in that frame: the specular
    /// lobes of the two nearest tabulated views, turned to follow the view's reflection and
    /// weighted by its place between them ([`MaterialLobes::specular_lobes`]), then the diffuse
    /// lobe. Views at or below the horizon reflect nothing.
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
        self.specular_lobes(view).into_iter().flatten().filter(|l| l.weight != Vec3::ZERO)
    }

    /// Where `view` (unit, local frame) falls: the lower tabulated view `k`, the fraction of
    /// the way to `k + 1`, its polar angle, and the turn to its azimuth.
    fn place(&self, view: Vec3) -> (usize, f32, f32, impl Fn(Vec3) -> Vec3 + use<>) {
        let theta = view.z.clamp(-1.0, 1.0).acos().min(theta_max());
        let (k, f) = polar_view_between(theta, self.thetas.len(), theta_max());
        let rxy = Vec2::new(view.x, view.y).length();
        let (c, s) = if rxy > 1e-12 { (view.x / rxy, view.y / rxy) } else { (1.0, 0.0) };
        (k, f, theta, move |d: Vec3| Vec3::new(c * d.x - s * d.y, s * d.x + c * d.y, d.z))
    }

    /// Tabulated view `j`'s lobes for a view at polar angle `theta`: turned within the plane of
    /// incidence by the difference of the angles (so that their reflection is the view's),
    /// then by `azimuth`, their weights times `share`.
    fn turned(&self, j: usize, theta: f32, share: f32, azimuth: &impl Fn(Vec3) -> Vec3) -> Option<SpecularLobes> {
        let shift = Quat::from_rotation_y(self.thetas[j] - theta);
        let lobes = self.specular[j]?;
        Some(lobes.map(|l| WeightedLobe {
            weight: l.weight * share,
            lobe: Vmf::new(azimuth(shift * l.lobe.mean), l.lobe.kappa),
        }))
    }

    /// The specular lobes for `view` (unit, local frame, above the horizon), in that frame:
    /// the lobes of the two tabulated views around it, each set turned within the plane of
    /// incidence so that its reflection is the view's and then to the view's azimuth, their
    /// weights blended by the view's place between the two (`1 − f` and `f`; a lobe may have
    /// zero weight); `None` without a specular part.
    ///
    /// Each view's lobes are its own best fit, so the lobes of two views need not correspond
    /// and are not blended lobe by lobe (Laurijssen's eq. 6): a blend of unlike lobes was
    /// 29–52 % off (GGX α = 0.02, 46–61°) between views fitted to 14–19 %. Turned and
    /// weighted, the views between are as close as the tabulated ones.
    pub fn specular_lobes(&self, view: Vec3) -> Option<[WeightedLobe; 2 * SPECULAR_LOBES]> {
        let (k, f, theta, azimuth) = self.place(view);
        let (fa, fb) = match (self.specular[k].is_some(), self.specular[k + 1].is_some()) {
            (true, true) => (1.0 - f, f),
            (true, false) => (1.0, 0.0),
            (false, true) => (0.0, 1.0),
            (false, false) => return None,
        };
        let beyond = self.beyond_last_view(view);
        let (fa, fb) = (fa * beyond, fb * beyond);
        let none = [WeightedLobe { weight: Vec3::ZERO, lobe: Vmf::new(Vec3::Z, 0.0) }; SPECULAR_LOBES];
        let a = self.turned(k, theta, fa, &azimuth).unwrap_or(none);
        let b = self.turned(k + 1, theta, fb, &azimuth).unwrap_or(none);
        Some(std::array::from_fn(|i| if i < SPECULAR_LOBES { a[i] } else { b[i - SPECULAR_LOBES] }))
    }

    /// The sum of the weights of [`MaterialLobes::specular_lobes`] at `view` (unit, local
    /// frame): the unshadowed specular lobes' share of a white environment's light toward the
    /// view; zero at or below the horizon and without a specular part.
    pub fn specular_weight(&self, view: Vec3) -> Vec3 {
        if view.z.is_nan() || view.z <= 0.0 {
            return Vec3::ZERO;
        }
        self.specular_lobes(view).map_or(Vec3::ZERO, |l| l.iter().map(|w| w.weight).sum())
    }

    /// The sum of the weights of [`MaterialLobes::nearest_specular_lobes`] at `view`: what a
    /// tabulation of views that takes those lobes (the transport lobes') holds there, before
    /// any shadow; zero without a specular part.
    pub fn nearest_specular_weight(&self, view: Vec3) -> Vec3 {
        self.nearest_specular_lobes(view).map_or(Vec3::ZERO, |l| l.iter().map(|w| w.weight).sum())
    }

    /// The specular lobes of the tabulated view nearest `view` (unit, local frame, above the
    /// horizon), turned to it as in [`MaterialLobes::specular_lobes`], whole (not blended
    /// with the next view's); `None` without a specular part. Lobe `m` of two views close
    /// enough to share their nearest tabulated view is the same lobe, turned. Beyond the last
    /// fitted view its lobes as they are, unscaled ([`MaterialLobes::beyond_last_view`]): what
    /// a tabulation of views (the transport lobes') interpolates between.
    pub fn nearest_specular_lobes(&self, view: Vec3) -> Option<SpecularLobes> {
        let (k, f, theta, azimuth) = self.place(view);
        let near = if f < 0.5 { [k, k + 1] } else { [k + 1, k] };
        near.iter().find_map(|&j| self.turned(j, theta, 1.0, &azimuth))
    }

    /// The specular lobes' amplitude for a view beyond the last fitted one (θ_max, 89.9°),
    /// which lends them its lobes: `(cos θ_max / cos θ)^e` for a BRDF whose value grows as
    /// `cos^−e` of the view angle near grazing ([`Brdf::view_amplitude_exponent`]: Ward's
    /// `1/√cos θ_o`, as the BRDF tables scale their views), `cos θ` kept from
    /// [`rsl_brdf::table::MIN_VIEW_COS`]; 1 for any other view or BRDF. A Ward α = 0.1 ball's vertex seen at
    /// 89.98° in a white furnace was drawn at half the truth (0.217 against 0.432).
    pub fn beyond_last_view(&self, view: Vec3) -> f32 {
        view_amplitude(self.brdf.view_amplitude_exponent(), view.z)
    }

    /// The diffuse lobe (about the normal, local frame), if the BRDF has a diffuse term.
    pub fn diffuse_lobe(&self) -> Option<WeightedLobe> {
        self.diffuse
    }

    /// Unshadowed reflected radiance toward `view` at a point with shading frame `frame`
    /// (world space), under `env` whose environment-from-world rotation is applied by
    /// `to_env`: `Σ_j α_j P_{κ_j}(μ_j)`, one lookup per lobe.
    pub fn radiance(&self, env: &Prefiltered, frame: &Frame, view_world: Vec3, to_env: impl Fn(Vec3) -> Vec3) -> Vec3 {
        self.radiance_masked(env, frame, view_world, to_env, |_| 1.0)
    }

    /// [`MaterialLobes::radiance`] with each lobe's term times `share` of the lobe (its mean
    /// in world space): the part of it a mask lets through, e.g. a vertex's face mask
    /// ([`crate::vmf::mask_share`]).
    pub fn radiance_masked(
        &self,
        env: &Prefiltered,
        frame: &Frame,
        view_world: Vec3,
        to_env: impl Fn(Vec3) -> Vec3,
        share: impl Fn(Vmf) -> f64,
    ) -> Vec3 {
        self.lobes_at(frame.to_local(view_world))
            .map(|l| {
                let mean = frame.to_world(l.lobe.mean);
                let through = share(Vmf { mean, kappa: l.lobe.kappa }) as f32;
                l.weight * through * env.lookup(to_env(mean), l.lobe.kappa)
            })
            .sum()
    }
}

//! Deterministic random numbers, direction sampling and piecewise-constant distributions.
//!
//! Every sampler maps a point of `[0, 1)²` to a direction and states its pdf in
//! **steradians⁻¹**, so estimators can combine them (multiple importance sampling).

use crate::latlong::{LatLongMap, texel_solid_angle};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI, TAU};

/// PCG32 (O'Neill 2014): small, fast, and the same sequence on every platform, so Monte
/// Carlo results are reproducible for a seed.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    const MUL: u64 = 6_364_136_223_846_793_005;

    /// A generator for `seed` on the default stream.
    pub fn new(seed: u64) -> Self {
        Self::with_stream(seed, 0xda3e_39cb_94b9_5bdb)
    }

    /// A generator for `seed` on stream `stream` (independent sequences per stream).
    pub fn with_stream(seed: u64, stream: u64) -> Self {
        let mut r = Self { state: 0, inc: (stream << 1) | 1 };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    /// Next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MUL).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in `[0, 1)` (24 bits, never 1.0).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Uniform in `[0, 1)` with 53 bits.
    pub fn next_f64(&mut self) -> f64 {
        let hi = u64::from(self.next_u32()) << 21;
        let lo = u64::from(self.next_u32() >> 11);
        (hi | lo) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }

    /// A point of `[0, 1)²`.
    pub fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }
}

/// Uniform direction on the sphere; pdf `1/(4π)`.
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (TAU * u.y).sin_cos();
    Vec3::new(r * c, r * s, z)
}

/// Pdf of [`uniform_sphere`].
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform direction on the upper (+z) hemisphere; pdf `1/(2π)`.
pub fn uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (TAU * u.y).sin_cos();
    Vec3::new(r * c, r * s, z)
}

/// Pdf of [`uniform_hemisphere`].
pub const UNIFORM_HEMISPHERE_PDF: f32 = 1.0 / (2.0 * PI);

/// Shirley–Chiu concentric map of `[0, 1)²` onto the unit disk (area-preserving).
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, (PI / 4.0) * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - (PI / 4.0) * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted direction on the upper (+z) hemisphere (Malley's method).
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    Vec3::new(d.x, d.y, (1.0 - d.length_squared()).max(0.0).sqrt())
}

/// Pdf of [`cosine_hemisphere`] at a direction with `cos θ = cos_theta`: `cos θ / π`
/// (zero below the horizon).
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// A piecewise-constant distribution on `[0, 1)` over `n` equal bins.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    func: Vec<f64>,
    cdf: Vec<f64>,
    integral: f64,
}

impl Distribution1D {
    /// From non-negative bin values. Negative or non-finite values count as zero; an
    /// all-zero function becomes uniform so sampling stays defined.
    pub fn new(values: &[f64]) -> Self {
        assert!(!values.is_empty(), "a distribution needs at least one bin");
        let n = values.len();
        let func: Vec<f64> = values.iter().map(|&v| if v.is_finite() && v > 0.0 { v } else { 0.0 }).collect();
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0);
        for (i, f) in func.iter().enumerate() {
            cdf.push(cdf[i] + f / n as f64);
        }
        let integral = cdf[n];
        if integral > 0.0 {
            for c in &mut cdf {
                *c /= integral;
            }
        } else {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f64 / n as f64;
            }
        }
        cdf[n] = 1.0;
        Self { func, cdf, integral }
    }

    /// Number of bins.
    pub fn len(&self) -> usize {
        self.func.len()
    }

    /// Always false.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Integral of the function over `[0, 1)`.
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// Probability of bin `i`.
    pub fn bin_probability(&self, i: usize) -> f64 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// Samples `x ∈ [0, 1)` for `u ∈ [0, 1)`; returns `(x, pdf(x), bin)`.
    pub fn sample(&self, u: f64) -> (f64, f64, usize) {
        let n = self.func.len();
        // Last bin whose cdf start is ≤ u, skipping zero-probability bins.
        let bin = self.cdf.partition_point(|&c| c <= u).saturating_sub(1).min(n - 1);
        let (c0, c1) = (self.cdf[bin], self.cdf[bin + 1]);
        let du = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.5 };
        let x = ((bin as f64 + du.clamp(0.0, 1.0)) / n as f64).min(1.0 - f64::EPSILON);
        (x, self.pdf_bin(bin), bin)
    }

    fn pdf_bin(&self, bin: usize) -> f64 {
        self.bin_probability(bin) * self.func.len() as f64
    }

    /// Density at `x ∈ [0, 1)` (zero outside).
    pub fn pdf(&self, x: f64) -> f64 {
        if !(0.0..1.0).contains(&x) {
            return 0.0;
        }
        self.pdf_bin(((x * self.func.len() as f64) as usize).min(self.func.len() - 1))
    }
}

/// A piecewise-constant distribution on `[0, 1)²` over a `nu×nv` grid (row `v` major).
#[derive(Clone, Debug)]
pub struct Distribution2D {
    conditional: Vec<Distribution1D>,
    marginal: Distribution1D,
}

impl Distribution2D {
    /// From `nu·nv` non-negative values, row-major (`values[j·nu + i]`).
    pub fn new(values: &[f64], nu: usize, nv: usize) -> Self {
        assert_eq!(values.len(), nu * nv, "distribution grid size mismatch");
        let conditional: Vec<Distribution1D> = values.chunks(nu).map(Distribution1D::new).collect();
        let marginal = Distribution1D::new(&conditional.iter().map(|c| c.integral()).collect::<Vec<_>>());
        Self { conditional, marginal }
    }

    /// Samples a point; returns `(uv, pdf(uv), (i, j))`.
    pub fn sample(&self, u: [f64; 2]) -> ([f64; 2], f64, (usize, usize)) {
        let (v, pv, j) = self.marginal.sample(u[1]);
        let (x, pu, i) = self.conditional[j].sample(u[0]);
        ([x, v], pu * pv, (i, j))
    }

    /// Density at a point of `[0, 1)²`.
    pub fn pdf(&self, uv: [f64; 2]) -> f64 {
        let pv = self.marginal.pdf(uv[1]);
        if pv == 0.0 {
            return 0.0;
        }
        let j = ((uv[1] * self.conditional.len() as f64) as usize).min(self.conditional.len() - 1);
        self.conditional[j].pdf(uv[0]) * pv
    }

    /// Probability of cell `(i, j)`.
    pub fn cell_probability(&self, i: usize, j: usize) -> f64 {
        self.marginal.bin_probability(j) * self.conditional[j].bin_probability(i)
    }
}

/// Importance sampling of a lat-long environment map, proportional to each texel's
/// luminance (Rec. 709 weights) times its exact solid angle. Within a texel, directions are
/// uniform in solid angle (uniform in `φ` and `cos θ`), so the pdf is piecewise constant in
/// steradians and finite at the poles: `pdf(ω) = P(texel) / Ω(texel)`.
#[derive(Clone, Debug)]
pub struct EnvironmentSampler {
    width: usize,
    height: usize,
    dist: Distribution2D,
}

/// Rec. 709 luminance of linear RGB.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl EnvironmentSampler {
    /// Builds the sampler for `map`. A black map samples uniformly over the sphere.
    pub fn new(map: &LatLongMap) -> Self {
        let (w, h) = (map.width(), map.height());
        let mut weights = Vec::with_capacity(w * h);
        for j in 0..h {
            let omega = texel_solid_angle(w, h, j);
            for i in 0..w {
                weights.push(f64::from(luminance(map.texel(i, j)).max(0.0)) * omega);
            }
        }
        if weights.iter().all(|&x| x <= 0.0) {
            for j in 0..h {
                let omega = texel_solid_angle(w, h, j);
                weights[j * w..(j + 1) * w].fill(omega);
            }
        }
        Self { width: w, height: h, dist: Distribution2D::new(&weights, w, h) }
    }

    /// Samples a direction; returns `(direction, pdf in sr⁻¹)`.
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        // Two stages: the row with u.y, the column with u.x; the position each lands at
        // inside its bin places the direction uniformly (in φ and cos θ) inside the texel.
        let (row_x, _, j) = self.dist.marginal.sample(f64::from(u.y));
        let fy = row_x * self.height as f64 - j as f64;
        let (col_x, _, i) = self.dist.conditional[j].sample(f64::from(u.x));
        let fx = col_x * self.width as f64 - i as f64;
        let phi = std::f64::consts::TAU * (i as f64 + fx.clamp(0.0, 1.0)) / self.width as f64;
        let z0 = (std::f64::consts::PI * j as f64 / self.height as f64).cos();
        let z1 = (std::f64::consts::PI * (j + 1) as f64 / self.height as f64).cos();
        let z = z0 + (z1 - z0) * fy.clamp(0.0, 1.0);
        let st = (1.0 - z * z).max(0.0).sqrt();
        let d = Vec3::new((st * phi.sin()) as f32, z as f32, (-st * phi.cos()) as f32);
        (d, self.texel_pdf(i, j))
    }

    fn texel_pdf(&self, i: usize, j: usize) -> f32 {
        (self.dist.cell_probability(i, j) / texel_solid_angle(self.width, self.height, j)) as f32
    }

    /// Pdf (sr⁻¹) of sampling direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let uv = crate::latlong::uv_from_dir(d);
        let i = ((uv.x * self.width as f32) as usize).min(self.width - 1);
        // Row by cos θ so the texel matches the sampler's exact row bounds.
        let j = ((uv.y * self.height as f32) as usize).min(self.height - 1);
        self.texel_pdf(i, j)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI as PI64;

    /// Wilson–Hilferty upper quantile of χ² with `k` degrees of freedom at significance
    /// 1e-4 (z = 3.719): a fixed-seed test fails only if the sampler and pdf disagree.
    fn chi2_critical(k: usize) -> f64 {
        let k = k as f64;
        let z = 3.719;
        k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3)
    }

    /// Draws `n` samples, bins them with `bin`, and compares with expected bin
    /// probabilities by a χ² test (bins expecting < 5 samples pooled).
    fn chi2_check(name: &str, sample: impl Fn(Vec2) -> Vec3, bin: impl Fn(Vec3) -> Option<usize>, expected_p: &[f64]) {
        let n = 400_000usize;
        let total: f64 = expected_p.iter().sum();
        assert!((total - 1.0).abs() < 2e-3, "{name}: pdf integrates to {total}");
        let mut counts = vec![0.0f64; expected_p.len()];
        let mut rng = Pcg32::new(42);
        for _ in 0..n {
            let d = sample(rng.next_2d());
            assert!(d.is_finite() && (d.length() - 1.0).abs() < 1e-4, "{name}: bad direction {d:?}");
            if let Some(b) = bin(d) {
                counts[b] += 1.0;
            }
        }
        let (mut chi2, mut dof, mut pool_o, mut pool_e) = (0.0, 0usize, 0.0, 0.0);
        for (o, p) in counts.iter().zip(expected_p) {
            let e = p * n as f64;
            if e < 5.0 {
                pool_o += o;
                pool_e += e;
            } else {
                chi2 += (o - e).powi(2) / e;
                dof += 1;
            }
        }
        if pool_e >= 5.0 {
            chi2 += (pool_o - pool_e).powi(2) / pool_e;
            dof += 1;
        } else {
            assert!(pool_o <= 5.0 + 3.0 * pool_e.sqrt() + 3.0, "{name}: {pool_o} samples where pdf expects {pool_e}");
        }
        let crit = chi2_critical(dof - 1);
        assert!(chi2 < crit, "{name}: χ² = {chi2:.1} ≥ {crit:.1} with {} dof", dof - 1);
    }

    /// χ² test of a sampler with a smooth pdf over 16×12 bins equal in (φ, cos θ) around +z
    /// (`hemi`: only z ≥ 0). Expected probabilities integrate `pdf` over each bin by a
    /// midpoint rule with `sub²` points; smooth pdfs make its error far below 2e-3.
    fn chi2_test(name: &str, sample: impl Fn(Vec2) -> Vec3, pdf: impl Fn(Vec3) -> f64, hemi: bool, sub: usize) {
        let (nphi, nz) = (16usize, 12usize);
        let z_lo = if hemi { 0.0 } else { -1.0 };
        let (dz, dphi) = ((1.0 - z_lo) / nz as f64, 2.0 * PI64 / nphi as f64);
        let bin = |d: Vec3| -> Option<usize> {
            let z = f64::from(d.z);
            if z < z_lo {
                return None;
            }
            let phi = f64::from(d.y).atan2(f64::from(d.x)).rem_euclid(2.0 * PI64);
            let bi = ((phi / dphi) as usize).min(nphi - 1);
            let bj = (((z - z_lo) / dz) as usize).min(nz - 1);
            Some(bj * nphi + bi)
        };
        let mut expected = vec![0.0f64; nphi * nz];
        for bj in 0..nz {
            for bi in 0..nphi {
                let mut acc = 0.0;
                for a in 0..sub {
                    for b in 0..sub {
                        let z = z_lo + dz * (bj as f64 + (a as f64 + 0.5) / sub as f64);
                        let phi = dphi * (bi as f64 + (b as f64 + 0.5) / sub as f64);
                        let r = (1.0 - z * z).max(0.0).sqrt();
                        acc += pdf(Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32));
                    }
                }
                // dω = dφ·dz: each sub-bin has solid angle dφ·dz/sub².
                expected[bj * nphi + bi] = acc * dz * dphi / (sub * sub) as f64;
            }
        }
        chi2_check(name, sample, bin, &expected);
    }

    #[test]
    fn uniform_sphere_matches_its_pdf() {
        chi2_test("uniform sphere", uniform_sphere, |_| f64::from(UNIFORM_SPHERE_PDF), false, 8);
    }

    #[test]
    fn uniform_hemisphere_matches_its_pdf() {
        chi2_test(
            "uniform hemisphere",
            uniform_hemisphere,
            |d| if d.z >= 0.0 { f64::from(UNIFORM_HEMISPHERE_PDF) } else { 0.0 },
            true,
            8,
        );
    }

    #[test]
    fn cosine_hemisphere_matches_its_pdf() {
        chi2_test("cosine hemisphere", cosine_hemisphere, |d| f64::from(cosine_hemisphere_pdf(d.z)), true, 16);
    }

    fn test_map() -> LatLongMap {
        // A smooth gradient, a bright small "sun" texel and a black region.
        LatLongMap::from_fn(32, 16, |d| {
            let sun = if d.dot(Vec3::new(0.3, 0.8, 0.52).normalize()) > 0.995 { 500.0 } else { 0.0 };
            let sky = if d.y > -0.2 { 1.0 + d.y } else { 0.0 };
            Vec3::new(sky + sun, 0.5 * sky + sun, 2.0 * sky + sun)
        })
    }

    #[test]
    fn environment_sampler_matches_its_pdf() {
        // Bins: each texel split 2×2 in (φ, cos θ), so the sampler's piecewise-constant pdf is
        // constant on every bin and the expected probability is exact: pdf at the bin's
        // centre (from `pdf()`, not from the sampling code) times its solid angle Δφ·Δcos θ.
        let map = test_map();
        let s = EnvironmentSampler::new(&map);
        let (w, h) = (map.width(), map.height());
        let (nu, nv) = (2 * w, 2 * h);
        let z_edge = |jj: usize| {
            let (j, half) = (jj / 2, (jj % 2) as f64);
            let z0 = (PI64 * j as f64 / h as f64).cos();
            let z1 = (PI64 * (j + 1) as f64 / h as f64).cos();
            z0 + (z1 - z0) * 0.5 * half
        };
        let mut expected = vec![0.0; nu * nv];
        for jj in 0..nv {
            let (za, zb) = (
                z_edge(jj),
                if jj % 2 == 0 { z_edge(jj + 1) } else { (PI64 * ((jj / 2) + 1) as f64 / h as f64).cos() },
            );
            for ii in 0..nu {
                let phi = 2.0 * PI64 * (ii as f64 + 0.5) / nu as f64;
                let z = 0.5 * (za + zb);
                let st = (1.0 - z * z).sqrt();
                let d = Vec3::new((st * phi.sin()) as f32, z as f32, (-st * phi.cos()) as f32);
                expected[jj * nu + ii] = f64::from(s.pdf(d)) * (za - zb) * 2.0 * PI64 / nu as f64;
            }
        }
        let bin = |d: Vec3| -> Option<usize> {
            let uv = crate::latlong::uv_from_dir(d);
            let i = ((uv.x * w as f32) as usize).min(w - 1);
            let j = ((uv.y * h as f32) as usize).min(h - 1);
            let phi = f64::from(uv.x) * 2.0 * PI64;
            let ii = 2 * i + usize::from(phi >= 2.0 * PI64 * (i as f64 + 0.5) / w as f64);
            let zmid = 0.5 * ((PI64 * j as f64 / h as f64).cos() + (PI64 * (j + 1) as f64 / h as f64).cos());
            let jj = 2 * j + usize::from(f64::from(d.y) < zmid);
            Some(jj * nu + ii)
        };
        chi2_check("environment", |u| s.sample(u).0, bin, &expected);
    }

    #[test]
    fn environment_pdf_is_proportional_to_luminance_and_consistent() {
        let map = test_map();
        let s = EnvironmentSampler::new(&map);
        let mut rng = Pcg32::new(5);
        let mut mismatched = 0;
        for _ in 0..10_000 {
            let (d, pdf) = s.sample(rng.next_2d());
            assert!(pdf > 0.0 && pdf.is_finite());
            // A direction on a texel border may round into the neighbour texel in f32.
            mismatched += usize::from((s.pdf(d) - pdf).abs() > 1e-4 * pdf);
            // Texels below y = −0.2 are black: never sampled (the row straddling −0.2 aside).
            assert!(d.y > -0.3, "sampled a black direction {d:?}");
        }
        assert!(mismatched < 20, "{mismatched} of 10000 samples disagree with pdf()");
        // The sun texel carries most of the energy: its pdf is far above the sky's.
        let sun = Vec3::new(0.3, 0.8, 0.52).normalize();
        assert!(s.pdf(sun) > 50.0 * s.pdf(Vec3::new(0.0, 0.5, -0.86).normalize()));
        // A black map: uniform, pdf = 1/(4π).
        let black = EnvironmentSampler::new(&LatLongMap::from_fn(8, 4, |_| Vec3::ZERO));
        let (_, pdf) = black.sample(Vec2::new(0.3, 0.7));
        assert!((pdf - UNIFORM_SPHERE_PDF).abs() < 1e-6);
    }

    #[test]
    fn distribution_1d_samples_its_bins() {
        let d = Distribution1D::new(&[0.0, 1.0, 3.0, 0.0]);
        assert_eq!(d.integral(), 1.0);
        let (x, pdf, bin) = d.sample(0.0);
        assert_eq!(bin, 1);
        assert!((0.25..0.5).contains(&x));
        assert_eq!(pdf, 1.0);
        let (x, pdf, bin) = d.sample(0.999_999);
        assert_eq!(bin, 2);
        assert!(x < 0.75);
        assert_eq!(pdf, 3.0);
        assert_eq!(d.pdf(0.1), 0.0);
        let z = Distribution1D::new(&[0.0, f64::NAN, -1.0]);
        assert_eq!(z.integral(), 0.0);
        assert!((z.pdf(0.5) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn pcg32_is_deterministic_and_in_range() {
        let mut a = Pcg32::new(11);
        let mut b = Pcg32::new(11);
        let mut c = Pcg32::new(12);
        let mut same = 0;
        for _ in 0..1000 {
            let x = a.next_f32();
            assert!((0.0..1.0).contains(&x));
            assert_eq!(x, b.next_f32());
            same += usize::from(x == c.next_f32());
        }
        assert!(same < 10);
    }
}

//! Von Mises–Fisher lobes on the sphere (Laurijssen & Dutré 2009, eq. 5).
//!
//! `γ(s) = c(κ)·e^{κ(μ·s)}` with `c(κ) = κ / (4π sinh κ)`, so that `∫ γ dω = 1`. Every
//! evaluation uses the form `κ / (2π (1 − e^{−2κ})) · e^{κ(μ·s − 1)}`, which neither overflows
//! for `κ` in the thousands (the exponent is at most 0) nor loses the normalisation as `κ → 0`
//! (`1 − e^{−2κ}` is formed with `expm1`; the limit is the uniform `1/4π`).

use glam::{DVec3, Vec3};
use rsl_sphere::Frame;
use std::f64::consts::PI;

/// A normalised vMF lobe: unit mean direction `mean` and concentration `kappa ≥ 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vmf {
    /// Unit mean direction.
    pub mean: Vec3,
    /// Concentration `κ` (0: uniform over the sphere).
    pub kappa: f32,
}

/// `κ / (2π (1 − e^{−2κ}))`, the density at the mean direction (`c(κ)·e^κ`), in f64.
pub fn peak_density(kappa: f64) -> f64 {
    if kappa < 1e-8 {
        // κ/(1 − e^{−2κ}) → 1/2 + κ/2.
        return (0.5 + 0.5 * kappa) / (2.0 * PI);
    }
    kappa / (2.0 * PI * -(-2.0 * kappa).exp_m1())
}

impl Vmf {
    /// The lobe with mean `mean` (normalised here) and concentration `kappa` (clamped to ≥ 0).
    pub fn new(mean: Vec3, kappa: f32) -> Self {
        Self { mean: mean.normalize_or(Vec3::Z), kappa: kappa.max(0.0) }
    }

    /// The density at unit direction `s` (per steradian).
    pub fn density(&self, s: Vec3) -> f64 {
        density_at(f64::from(self.kappa), f64::from(self.mean.dot(s)))
    }

    /// A direction drawn with density [`Vmf::density`] from two uniform numbers in `[0, 1)`:
    /// `cos θ = 1 + ln(1 − u(1 − e^{−2κ}))/κ` about the mean (Laurijssen eq. 10 in a form
    /// that keeps its precision for large `κ`), `φ = 2πv`.
    pub fn sample(&self, u: f32, v: f32) -> Vec3 {
        let k = f64::from(self.kappa);
        let u = f64::from(u).clamp(0.0, 1.0);
        let cos = if k < 1e-8 { 1.0 - 2.0 * u } else { 1.0 + (u * (-2.0 * k).exp_m1()).ln_1p() / k };
        let cos = cos.clamp(-1.0, 1.0);
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * PI * f64::from(v);
        let local = DVec3::new(sin * phi.cos(), sin * phi.sin(), cos).as_vec3();
        Frame::from_normal(self.mean).to_world(local).normalize_or(self.mean)
    }

    /// `∫ γ_a(s) γ_b(s) ds`, in closed form: `c_a c_b · 4π sinh(|κ_a μ_a + κ_b μ_b|) / |…|`,
    /// evaluated as exponentials of non-positive arguments.
    pub fn product_integral(&self, other: &Vmf) -> f64 {
        product_integral((self.mean.as_dvec3(), f64::from(self.kappa)), (other.mean.as_dvec3(), f64::from(other.kappa)))
    }
}

/// [`Vmf::product_integral`] of two lobes given in f64 as (unit mean, κ).
pub fn product_integral((ma, ka): (DVec3, f64), (mb, kb): (DVec3, f64)) -> f64 {
    let m = (ma * ka + mb * kb).length();
    // c(κ) = peak(κ)·e^{−κ}; 4π sinh(m)/m = 2π e^{m}(1 − e^{−2m})/m.
    let shell = if m < 1e-8 { 4.0 * PI } else { 2.0 * PI * -(-2.0 * m).exp_m1() / m };
    peak_density(ka) * peak_density(kb) * (m - ka - kb).exp() * shell
}

/// The density of a lobe of concentration `kappa` at `cos = μ·s`.
#[inline]
pub fn density_at(kappa: f64, cos: f64) -> f64 {
    peak_density(kappa) * (kappa * (cos.clamp(-1.0, 1.0) - 1.0)).exp()
}

/// `Φ(x)`, the standard normal distribution function, by the complementary error function of
/// Abramowitz & Stegun 7.1.26 (absolute error below 1.5·10⁻⁷).
pub fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly =
        t * (0.254_829_592 + t * (-0.284_496_736 + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let tail = 0.5 * poly * (-z * z).exp();
    if x >= 0.0 { 1.0 - tail } else { tail }
}

/// The share of a lobe's mass on the side of a plane through the origin that its unit normal
/// `m` points to, `P(ω·m > 0)`, in the tangent-plane form: seen from the lobe's mean, a plane
/// through the origin is a straight line at distance `tan e` in the gnomonic projection
/// (`sin e = μ·m`, the mean's elevation above the plane), and the lobe a normal distribution
/// of variance `1/κ` per axis there, so the share is `Φ(√κ · tan e)`. Exact as `κ → ∞`;
/// against the lobe's own integral by quadrature, 0.012 off at most from `κ = 16` up, where it
/// is worst (test `a_halfspaces_share_of_a_lobe_matches_quadrature`).
pub fn halfspace_share(mean: Vec3, kappa: f32, m: Vec3) -> f64 {
    let s = f64::from(mean.dot(m)).clamp(-1.0, 1.0);
    let c = (1.0 - s * s).sqrt();
    if c < 1e-12 {
        return if s > 0.0 { 1.0 } else { 0.0 };
    }
    normal_cdf(f64::from(kappa.max(0.0)).sqrt() * s / c)
}

/// How much of a lobe above a vertex's tangent plane (unit `normal`) the vertex's face mask
/// `h(ω) = Σ_f w_f [ω·n_f > 0]` (`faces`: unit normals and weights summing to one;
/// `rsl_sphere::faces`) lets through:
/// `Σ_f w_f P(ω·n_f > 0 ∧ ω·n > 0) / P(ω·n > 0)`, each joint share taken as the smaller of
/// the two ([`halfspace_share`]). Near the lobe the two planes' lines are within the face's
/// tilt of parallel (a few degrees on a tessellated surface), where the smaller is the joint
/// share. Where the lobe lies wholly below the normal's plane, the mask at the mean.
pub fn mask_share(mean: Vec3, kappa: f32, normal: Vec3, faces: &[(Vec3, f32)]) -> f64 {
    // The mean more than 5.5 widths above every plane (Φ(5.5) = 1 − 2·10⁻⁸): all through.
    let lowest = faces.iter().map(|(n, _)| n.dot(mean)).fold(normal.dot(mean), f32::min);
    if lowest > 0.0 && f64::from(kappa).sqrt() * f64::from(lowest) > 5.5 * f64::from(1.0 - lowest * lowest).sqrt() {
        return 1.0;
    }
    let above = halfspace_share(mean, kappa, normal);
    if above < 1e-9 {
        return faces.iter().filter(|(n, _)| n.dot(mean) > 0.0).map(|(_, w)| f64::from(*w)).sum();
    }
    let shares = faces.iter().map(|&(n, w)| (halfspace_share(mean, kappa, n).min(above), f64::from(w)));
    let (through, total) = shares.fold((0.0, 0.0), |(t, s), (p, w)| (t + w * p, s + w));
    if total <= 0.0 { 1.0 } else { (through / total / above).min(1.0) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rsl_sphere::sampling::Pcg32;

    /// `∫ f dω` by a fine midpoint rule in (cos θ, φ) about +z.
    fn integrate_about_z(f: impl Fn(Vec3) -> f64) -> f64 {
        let (nt, np) = (20_000, 64);
        let mut sum = 0.0;
        for a in 0..nt {
            let z = -1.0 + 2.0 * (a as f64 + 0.5) / nt as f64;
            let r = (1.0 - z * z).sqrt();
            for b in 0..np {
                let phi = 2.0 * PI * (b as f64 + 0.5) / np as f64;
                sum += f(DVec3::new(r * phi.cos(), r * phi.sin(), z).as_vec3());
            }
        }
        sum * 4.0 * PI / (nt * np) as f64
    }

    #[test]
    fn lobes_integrate_to_one_from_uniform_to_sharp() {
        for kappa in [0.0f32, 1e-6, 0.3, 1.0, 10.0, 100.0, 1000.0] {
            let g = Vmf::new(Vec3::Z, kappa);
            let total = integrate_about_z(|s| g.density(s));
            assert!((total - 1.0).abs() < 2e-3, "κ = {kappa}: ∫ = {total}");
        }
        // κ = 10⁴ is finite at the peak and needs no overflow: c(κ)e^κ = κ/2π.
        let g = Vmf::new(Vec3::Z, 1e4);
        assert!((g.density(Vec3::Z) - 1e4 / (2.0 * PI)).abs() < 1e-6 * 1e4);
        assert_eq!(g.density(-Vec3::Z), 0.0);
    }

    #[test]
    fn the_product_integral_matches_quadrature() {
        for (ka, kb, angle) in [(2.0f32, 5.0f32, 0.7f32), (40.0, 40.0, 0.1), (300.0, 80.0, 0.05), (0.0, 10.0, 1.0)] {
            let a = Vmf::new(Vec3::Z, ka);
            let b = Vmf::new(Vec3::new(angle.sin(), 0.0, angle.cos()), kb);
            let want = integrate_about_z(|s| a.density(s) * b.density(s));
            let got = a.product_integral(&b);
            assert!((got / want - 1.0).abs() < 5e-3, "κ {ka}, {kb} at {angle}: {got} against {want}");
        }
    }

    #[test]
    fn samples_follow_the_density() {
        // The mean cosine of a vMF is coth κ − 1/κ.
        for kappa in [0.5f32, 5.0, 50.0, 5000.0] {
            let g = Vmf::new(Vec3::new(1.0, 2.0, -0.5), kappa);
            let mut rng = Pcg32::new(9);
            let n = 200_000;
            let mean: f64 =
                (0..n).map(|_| f64::from(g.sample(rng.next_f32(), rng.next_f32()).dot(g.mean))).sum::<f64>() / n as f64;
            let k = f64::from(kappa);
            let want = 1.0 / k.tanh() - 1.0 / k;
            // Standard errors: below 1.3·10⁻³ in the mean, and 0.3 % in 1 − mean (whose
            // spread is about its size for large κ).
            assert!((mean - want).abs() < 5e-3, "κ = {kappa}: {mean} vs {want}");
            assert!(((1.0 - mean) / (1.0 - want) - 1.0).abs() < 0.02, "κ = {kappa}: 1 − {mean} vs 1 − {want}");
        }
    }

    /// `∫ γ(ω) g(ω) dω` for the lobe `γ` of concentration `kappa` about +z, by a midpoint
    /// rule over `θ` up to where the lobe has no mass left (40 widths, or π) and `φ`.
    fn integrate_lobe(kappa: f32, g: impl Fn(DVec3) -> f64) -> f64 {
        let k = f64::from(kappa);
        let top = (40.0 / k.sqrt()).min(PI);
        let (nt, np) = (4000, 1440);
        let mut sum = 0.0;
        for a in 0..nt {
            let theta = top * (a as f64 + 0.5) / nt as f64;
            let ring = density_at(k, theta.cos()) * theta.sin() * top / nt as f64 * 2.0 * PI / np as f64;
            for b in 0..np {
                let phi = 2.0 * PI * (b as f64 + 0.5) / np as f64;
                let d = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
                sum += ring * g(d);
            }
        }
        sum
    }

    #[test]
    fn the_normal_distribution_function_matches_its_tabulated_values() {
        for (x, want) in
            [(0.0, 0.5), (1.0, 0.841_344_746), (-2.0, 0.022_750_132), (3.0, 0.998_650_102), (-0.3, 0.382_088_578)]
        {
            assert!((normal_cdf(x) - want).abs() < 2e-7, "Φ({x}) = {} against {want}", normal_cdf(x));
        }
    }

    #[test]
    fn a_halfspaces_share_of_a_lobe_matches_quadrature() {
        // Planes through the origin whose normal is tilted so that the lobe's mean lies at
        // elevation e above them, from two widths below to two above and far off.
        for kappa in [16.0f32, 64.0, 256.0, 1024.0, 4096.0] {
            let width = 1.0 / f64::from(kappa).sqrt();
            for e in [-2.0 * width, -width, -0.3 * width, 0.0, 0.5 * width, width, 2.0 * width, 0.6, -1.2] {
                let m = DVec3::new(-e.cos(), 0.0, e.sin());
                let want = integrate_lobe(kappa, |d| f64::from(d.dot(m) > 0.0));
                let got = halfspace_share(Vec3::Z, kappa, m.as_vec3());
                assert!((got - want).abs() < 0.02, "κ = {kappa}, e = {e}: {got} against {want}");
            }
        }
    }

    #[test]
    fn a_vertexs_face_mask_share_of_a_lobe_matches_quadrature() {
        // A vertex on a ball of 32 segments: its faces tilt a few degrees from its normal
        // (+z here). Lobes near its horizon, toward a face and between two.
        let tilt = (PI / 32.0) as f32;
        let faces: Vec<(Vec3, f32)> = (0..6)
            .map(|k| {
                let a = k as f32 * std::f32::consts::PI / 3.0 + 0.2;
                (Vec3::new(tilt.sin() * a.cos(), tilt.sin() * a.sin(), tilt.cos()), 1.0 / 6.0)
            })
            .collect();
        let mask =
            |d: DVec3| faces.iter().filter(|(n, _)| n.as_dvec3().dot(d) > 0.0).map(|(_, w)| f64::from(*w)).sum::<f64>();
        for kappa in [16.0f32, 128.0, 1024.0, 4096.0] {
            for (elevation, azimuth) in [(0.02f32, 0.2f32), (0.05, 0.7), (0.1, 1.3), (0.005, 2.2), (0.3, 0.0)] {
                let mean = Vec3::new(elevation.cos() * azimuth.cos(), elevation.cos() * azimuth.sin(), elevation.sin());
                let frame = Frame::from_normal(mean);
                let to_world = |d: DVec3| frame.to_world(d.as_vec3()).as_dvec3();
                let above = integrate_lobe(kappa, |d| f64::from(to_world(d).z > 0.0));
                let through = integrate_lobe(kappa, |d| {
                    let w = to_world(d);
                    if w.z > 0.0 { mask(w) } else { 0.0 }
                });
                let want = through / above;
                let got = mask_share(mean, kappa, Vec3::Z, &faces);
                assert!(
                    (got - want).abs() < 0.01,
                    "κ = {kappa}, elevation {elevation}, azimuth {azimuth}: {got} against {want}"
                );
            }
        }
    }
}

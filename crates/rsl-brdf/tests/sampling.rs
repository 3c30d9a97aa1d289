//! Importance sampling: every model's density integrates to one over the sphere, and its
//! samples follow that density (the sampled estimate of the directional albedo agrees with
//! brute-force quadrature).

use glam::{Vec2, Vec3};
use rsl_brdf::Brdf;
use rsl_sphere::sampling::Pcg32;

fn models() -> Vec<Brdf> {
    let (ks, kd) = (Vec3::new(0.9, 0.7, 0.5), Vec3::new(0.2, 0.3, 0.1));
    vec![
        Brdf::Lambert { albedo: Vec3::splat(0.7) },
        Brdf::Phong { exponent: 40.0, specular: ks, diffuse: kd },
        Brdf::BlinnPhong { exponent: 60.0, specular: ks, diffuse: kd },
        Brdf::CookTorrance { alpha: 0.3, specular: ks, diffuse: kd },
        Brdf::Ward { alpha_x: 0.15, alpha_y: 0.4, specular: ks, diffuse: kd },
        Brdf::Ward { alpha_x: 0.25, alpha_y: 0.25, specular: ks, diffuse: Vec3::ZERO },
        Brdf::Ggx { alpha: 0.2, specular: ks, diffuse: kd },
        Brdf::Beckmann { alpha: 0.25, specular: ks, diffuse: Vec3::ZERO },
        Brdf::Gltf { base_color: Vec3::new(0.8, 0.4, 0.2), metallic: 0.0, roughness: 0.45 },
        Brdf::Gltf { base_color: Vec3::new(0.95, 0.64, 0.54), metallic: 1.0, roughness: 0.3 },
    ]
}

fn views() -> Vec<Vec3> {
    [0.0f32, 40.0, 75.0]
        .iter()
        .map(|d| {
            let t = d.to_radians();
            Vec3::new(t.sin() * 0.8, t.sin() * 0.6, t.cos())
        })
        .collect()
}

/// `∫ g(ω) dω` over the sphere with `n×2n` midpoints in (z, φ): `dω = dz dφ`.
fn sphere_integral(n: usize, g: impl Fn(Vec3) -> f64) -> f64 {
    let mut sum = 0.0;
    for i in 0..n {
        let z = -1.0 + (i as f64 + 0.5) * 2.0 / n as f64;
        let r = (1.0 - z * z).max(0.0).sqrt();
        for j in 0..2 * n {
            let phi = (j as f64 + 0.5) * std::f64::consts::PI / n as f64;
            sum += g(Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32));
        }
    }
    sum * (2.0 / n as f64) * (std::f64::consts::PI / n as f64)
}

#[test]
fn densities_integrate_to_one_less_the_rejected_samples() {
    let mut rng = Pcg32::new(9);
    for b in models() {
        for wo in views() {
            let total = sphere_integral(1500, |wi| f64::from(b.pdf(wo, wi)));
            // The probability that sampling gives no direction (a half vector facing away).
            let n = 200_000;
            let none = (0..n)
                .filter(|_| b.sample(wo, Vec2::new(rng.next_f32(), rng.next_f32()), rng.next_f32()).is_none())
                .count() as f64
                / n as f64;
            let se = (none * (1.0 - none) / n as f64).sqrt();
            assert!(
                (total + none - 1.0).abs() < 3e-3 + 4.0 * se,
                "{}: ∫pdf = {total}, P(no sample) = {none} at view {wo}",
                b.name()
            );
        }
    }
}

#[test]
fn samples_follow_their_density() {
    let mut rng = Pcg32::new(5);
    for b in models() {
        for wo in views() {
            // Green channel's directional albedo, by quadrature and by sampling.
            let exact = sphere_integral(1500, |wi| f64::from(b.eval_cos(wi, wo).y));
            let n = 200_000;
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                let v = match b.sample(wo, u, rng.next_f32()) {
                    Some(wi) => {
                        let pdf = b.pdf(wo, wi);
                        assert!(pdf > 0.0 && pdf.is_finite(), "{}: sampled {wi} for {wo} of density {pdf}", b.name());
                        f64::from(b.eval_cos(wi, wo).y / pdf)
                    }
                    None => 0.0,
                };
                sum += v;
                sum2 += v * v;
            }
            let mean = sum / n as f64;
            let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
            assert!(
                (mean - exact).abs() < 4.0 * se + 1e-3 * exact,
                "{} view {wo}: sampled albedo {mean} ± {se}, quadrature {exact}",
                b.name()
            );
        }
    }
}

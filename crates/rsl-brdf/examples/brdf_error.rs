//! Measures the accuracy a table resolution buys: for each model and N ∈ {16, 32, 64, 128},
//! the worst relative error of square integrals (2 to 8 cells of the paper's N = 32 grid,
//! random centres) against direct integration, at four tabulated polar views, and at views
//! halfway between tabulated ones. Prints a Markdown table.
//!
//! `cargo run --release -p rsl-brdf --example brdf_error`

use glam::{DVec3, Vec2, Vec3};
use rsl_brdf::{Brdf, BrdfTable, Resolution, Views};
use rsl_sphere::hemi::dir_from_hemi;
use rsl_sphere::sampling::Pcg32;

/// `∫ ρ cos θ dω` over the box `[p − s, p + s]²` ∩ unit disk by an `m×m` midpoint rule.
fn direct(brdf: &Brdf, p: Vec2, s: f32, wo: Vec3, m: usize) -> DVec3 {
    let step = 2.0 * f64::from(s) / m as f64;
    let mut sum = DVec3::ZERO;
    for a in 0..m {
        for b in 0..m {
            let q = Vec2::new(
                (f64::from(p.x - s) + (a as f64 + 0.5) * step) as f32,
                (f64::from(p.y - s) + (b as f64 + 0.5) * step) as f32,
            );
            if q.length_squared() < 1.0 && q.x.abs() <= 1.0 && q.y.abs() <= 1.0 {
                sum += brdf.eval_cos(dir_from_hemi(q), wo).as_dvec3();
            }
        }
    }
    sum * 2.0 * step * step
}

fn main() {
    let g = Vec3::splat;
    let models = [
        Brdf::Lambert { albedo: g(0.8) },
        Brdf::Phong { exponent: 20.0, specular: g(0.7), diffuse: g(0.2) },
        Brdf::BlinnPhong { exponent: 50.0, specular: g(0.7), diffuse: g(0.2) },
        Brdf::CookTorrance { alpha: 0.3, specular: g(0.9), diffuse: g(0.1) },
        Brdf::Ward { alpha_x: 0.3, alpha_y: 0.3, specular: g(0.5), diffuse: g(0.2) },
        Brdf::Ggx { alpha: 0.3, specular: g(1.0), diffuse: g(0.0) },
        Brdf::Ggx { alpha: 0.1, specular: g(1.0), diffuse: g(0.0) },
        Brdf::Beckmann { alpha: 0.3, specular: g(1.0), diffuse: g(0.1) },
        Brdf::Gltf { base_color: Vec3::new(0.8, 0.3, 0.1), metallic: 0.0, roughness: 0.5 },
    ];
    let mut rng = Pcg32::new(17);
    let cell = 2.0 / 32.0;
    let squares: Vec<(Vec2, f32)> = (0..24)
        .map(|k| {
            let p = loop {
                let q = Vec2::new(rng.next_f32() * 1.6 - 0.8, rng.next_f32() * 1.6 - 0.8);
                if q.length() < 0.8 {
                    break q;
                }
            };
            (p, cell * (1.0 + 3.0 * k as f32 / 23.0))
        })
        .collect();
    println!("| model | N | at tabulated views | between views |");
    println!("|---|---|---|---|");
    for brdf in &models {
        for n in [16, 32, 64, 128] {
            let t = BrdfTable::build(brdf, Resolution { n, views: 32 }).expect("valid model");
            let thetas: Vec<f32> = match t.views() {
                Views::Isotropic(th) => th.clone(),
                _ => (0..32).map(|k| k as f32 * 0.05).collect(),
            };
            let mut worst = [0.0f64; 2];
            for (kind, k) in [3usize, 12, 20, 28].iter().flat_map(|&k| [(0, k), (1, k)]) {
                let theta = if kind == 0 { thetas[k] } else { 0.5 * (thetas[k] + thetas[k + 1]) };
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                for &(p, s) in &squares {
                    let got = t.square(dir_from_hemi(p), s * std::f32::consts::SQRT_2, wo).integral.as_dvec3();
                    let want = direct(brdf, p, s, wo, 256);
                    // Relative to the value, floored at 10⁻³ of the largest a square can hold.
                    let scale = want
                        .max_element()
                        .max(1e-3 * f64::from(t.max_density().max_element()) * 4.0 * f64::from(s * s));
                    worst[kind] = worst[kind].max((got - want).abs().max_element() / scale);
                }
            }
            let name = match brdf {
                Brdf::Phong { exponent, .. } | Brdf::BlinnPhong { exponent, .. } => {
                    format!("{} n={exponent}", brdf.name())
                }
                Brdf::CookTorrance { alpha, .. } | Brdf::Ggx { alpha, .. } | Brdf::Beckmann { alpha, .. } => {
                    format!("{} α={alpha}", brdf.name())
                }
                Brdf::Ward { alpha_x, .. } => format!("{} α={alpha_x}", brdf.name()),
                Brdf::Gltf { metallic, roughness, .. } => {
                    format!("{} metallic {metallic} roughness {roughness}", brdf.name())
                }
                Brdf::Lambert { .. } => brdf.name().to_string(),
            };
            println!("| {name} | {n} | {:.1e} | {:.1e} |", worst[0], worst[1]);
        }
    }
}

//! How well the fitted vMF lobes (plus a cosine lobe for the diffuse term) reproduce `ρ cos θ`:
//! relative L2 over the sphere of the luminance, per model, roughness and view, and the
//! fitting time per material.
//!
//! `cargo run --release -p rsl-lobe --example lobe_fit`; `LOBE_FIT_ANGLES=0,22.4,41.6` sets the
//! view angles (degrees) and `LOBE_FIT_ONLY=ggx` keeps the materials whose name holds it.

use glam::Vec3;
use rsl_brdf::Brdf;
use rsl_lobe::{FitParams, MaterialLobes};
use rsl_sphere::Frame;
use rsl_sphere::sampling::luminance;

/// Relative L2 of the fit against `ρ cos θ` for view `wo`, by a polar grid about the fitted
/// specular lobe's mean (geometric in `1 − cos`, so sharp lobes are resolved).
fn fit_error(brdf: &Brdf, lobes: &MaterialLobes, wo: Vec3) -> f64 {
    let fitted = lobes.lobes(wo);
    let axis = fitted.first().map_or(Vec3::Z, |l| l.lobe.mean);
    let frame = Frame::from_normal(axis);
    let (nt, np) = (1500, 256);
    let (t_min, t_max) = (1e-8f64, 2.0f64);
    let ratio = (t_max / t_min).ln();
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for a in 0..nt {
        // t = 1 − cos about the axis, log-spaced; dω = dt dφ.
        let (t0, t1) =
            (t_min * (ratio * a as f64 / nt as f64).exp(), t_min * (ratio * (a + 1) as f64 / nt as f64).exp());
        let t = 0.5 * (t0 + t1);
        let c = 1.0 - t;
        let s = (1.0 - c * c).max(0.0).sqrt();
        for b in 0..np {
            let phi = std::f64::consts::TAU * (b as f64 + 0.5) / np as f64;
            let d = frame.to_world(Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, c as f32));
            let f = if d.z > 0.0 { f64::from(luminance(brdf.eval_cos(d, wo))) } else { 0.0 };
            let g: f64 = fitted.iter().map(|l| f64::from(luminance(l.weight)) * l.lobe.density(d)).sum();
            let w = (t1 - t0) * std::f64::consts::TAU / np as f64;
            num += (f - g).powi(2) * w;
            den += f * f * w;
        }
    }
    (num / den).sqrt()
}

fn main() {
    let spec = Vec3::new(0.9, 0.8, 0.7);
    let d = Vec3::splat(0.05);
    let mut models: Vec<(String, Brdf)> = Vec::new();
    for a in [0.02f32, 0.05, 0.1, 0.3] {
        models.push((format!("ggx α={a}"), Brdf::Ggx { alpha: a, specular: spec, diffuse: d }));
        models.push((format!("beckmann α={a}"), Brdf::Beckmann { alpha: a, specular: spec, diffuse: d }));
    }
    for n in [20.0f32, 200.0, 2000.0] {
        models.push((format!("phong n={n}"), Brdf::Phong { exponent: n, specular: spec, diffuse: d }));
    }
    let angles: Vec<f32> = match std::env::var("LOBE_FIT_ANGLES") {
        Ok(a) => a.split(',').map(|x| x.parse().expect("angle")).collect(),
        Err(_) => vec![0.0f32, 30.0, 45.0, 60.0, 75.0, 85.0],
    };
    if let Ok(m) = std::env::var("LOBE_FIT_ONLY") {
        models.retain(|(n, _)| n.contains(&m));
    }
    println!("| material | fit ms | {} |", angles.iter().map(|a| format!("θ = {a}°")).collect::<Vec<_>>().join(" | "));
    println!("|---|---|{}", "---|".repeat(angles.len()));
    for (name, brdf) in &models {
        let t = std::time::Instant::now();
        let lobes = MaterialLobes::fit(brdf, &FitParams::default()).expect("a valid BRDF");
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let errors: Vec<String> = angles
            .iter()
            .map(|&a| {
                let r = a.to_radians();
                format!("{:.1} %", 100.0 * fit_error(brdf, &lobes, Vec3::new(r.sin(), 0.0, r.cos())))
            })
            .collect();
        println!("| {name} | {ms:.1} | {} |", errors.join(" | "));
    }
}

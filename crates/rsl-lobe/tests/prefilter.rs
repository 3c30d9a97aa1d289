//! The prefiltered environment against independent answers: a constant map (a normalised
//! lobe returns the constant), and a single bright texel (the lobe's integral over the
//! texel, by fine quadrature).

use glam::Vec3;
use rsl_lobe::vmf::density_at;
use rsl_lobe::{PrefilterParams, Prefiltered};
use rsl_sphere::latlong::{LatLongMap, dir_from_uv};
use rsl_sphere::sampling::Pcg32;

fn random_dir(rng: &mut Pcg32) -> Vec3 {
    let z = 2.0 * rng.next_f32() - 1.0;
    let phi = std::f32::consts::TAU * rng.next_f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[test]
fn a_constant_environment_comes_back_for_every_lobe() {
    let l = Vec3::new(0.7, 1.3, 2.0);
    let map = LatLongMap::from_fn(64, 32, |_| l);
    let params = PrefilterParams { kappa_max: 1024.0, max_resolution: 64, ..Default::default() };
    let p = Prefiltered::build(&map, &params);
    let mut rng = Pcg32::new(3);
    let mut worst = 0.0f32;
    for _ in 0..500 {
        let d = random_dir(&mut rng);
        let kappa = 2f32.powf(rng.next_f32() * 11.0) - 1.0;
        let got = p.lookup(d, kappa);
        worst = worst.max(((got - l) / l).abs().max_element());
    }
    eprintln!("furnace: worst relative error {worst:.2e} over 500 lobes, κ ∈ [0, 2047]");
    assert!(worst < 2e-3, "worst {worst}");
}

/// `∫ over lat-long texel (i, j) of a W×H map of γ_κ(μ·s) ds`, by a 200×200 midpoint rule in
/// (φ, cos θ) (equal solid angle per cell).
fn texel_convolution(w: usize, h: usize, i: usize, j: usize, mean: Vec3, kappa: f32) -> f64 {
    let n = 200;
    let z0 = (std::f64::consts::PI * j as f64 / h as f64).cos();
    let z1 = (std::f64::consts::PI * (j + 1) as f64 / h as f64).cos();
    let omega = (z0 - z1) * 2.0 * std::f64::consts::PI / w as f64;
    let mut sum = 0.0;
    for a in 0..n {
        for b in 0..n {
            let u = (i as f64 + (b as f64 + 0.5) / n as f64) / w as f64;
            let z = z0 + (z1 - z0) * (a as f64 + 0.5) / n as f64;
            let v = z.clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
            let s = dir_from_uv(glam::Vec2::new(u as f32, v as f32)).as_dvec3();
            sum += density_at(f64::from(kappa), mean.as_dvec3().dot(s));
        }
    }
    sum * omega / (n * n) as f64
}

#[test]
fn one_bright_texel_gives_the_analytic_convolution() {
    // A sun of radiance 20,000 in one texel of a 512×256 map (0.7° across), nothing else.
    let (w, h, si, sj) = (512usize, 256usize, 300usize, 90usize);
    let sun = 20_000.0f32;
    let mut texels = vec![Vec3::ZERO; w * h];
    texels[sj * w + si] = Vec3::splat(sun);
    let map = LatLongMap::new(w, h, texels).unwrap();
    let centre = dir_from_uv(glam::Vec2::new((si as f32 + 0.5) / w as f32, (sj as f32 + 0.5) / h as f32));
    let params = PrefilterParams { kappa_max: 4096.0, max_resolution: 128, ..Default::default() };
    let t = std::time::Instant::now();
    let p = Prefiltered::build(&map, &params);
    eprintln!("built {} levels in {:.0} ms, {} bytes", p.levels().len(), t.elapsed().as_secs_f64() * 1e3, p.bytes());
    let mut rng = Pcg32::new(5);
    for level in p.levels().iter().skip(1) {
        let kappa = level.kappa;
        // At the level's own texel centres within two lobe widths of the sun: the sum itself.
        let (mut num, mut den, mut count) = (0.0f64, 0.0f64, 0);
        for (t, v) in level.values.iter().enumerate() {
            let d = level.grid.texel_dir(t).normalize();
            if f64::from(kappa) * (1.0 - f64::from(d.dot(centre))) > 2.0 {
                continue;
            }
            let want = f64::from(sun) * texel_convolution(w, h, si, sj, d, kappa);
            num += (f64::from(v.x) - want).powi(2);
            den += want * want;
            count += 1;
        }
        assert!(count > 0, "κ = {kappa}: no texel within the lobe");
        let at_centres = (num / den).sqrt();
        // Anywhere within the lobe (lookups interpolate between texel centres and levels).
        let (mut num, mut den) = (0.0f64, 0.0f64);
        let f = Vec3::new(1.0, 0.0, 0.0).cross(centre).normalize();
        let g = centre.cross(f);
        for _ in 0..200 {
            let r = (2.0 * rng.next_f32() / kappa).sqrt();
            let phi = std::f32::consts::TAU * rng.next_f32();
            let d = (centre + (f * phi.cos() + g * phi.sin()) * r).normalize();
            let want = f64::from(sun) * texel_convolution(w, h, si, sj, d, kappa);
            let got = f64::from(p.lookup(d, kappa).x);
            num += (got - want).powi(2);
            den += want * want;
        }
        let anywhere = (num / den).sqrt();
        eprintln!(
            "κ = {kappa:6}: level {0}×{1}×{1}, relative L2 {at_centres:.1e} at texel centres ({count}), {anywhere:.1e} at 200 lookups",
            6,
            level.grid.r()
        );
        assert!(at_centres < 1e-2, "κ = {kappa}: {at_centres} at texel centres");
        assert!(anywhere < 0.12, "κ = {kappa}: {anywhere} between them");
    }
}

//! Live editing: rebuilding a material's table from scratch (cell integrals + summed-area
//! tables) at the paper's resolution: isotropic N = 32, V = 32 (3D) and anisotropic N = 32,
//! V = 32×32 (4D).

use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec3;
use rsl_brdf::{Brdf, BrdfTable, Resolution};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("sat_build");
    g.sample_size(20);
    let iso = [
        ("lambert", Brdf::Lambert { albedo: Vec3::splat(0.8) }),
        ("ggx a=0.2", Brdf::Ggx { alpha: 0.2, specular: Vec3::ONE, diffuse: Vec3::splat(0.1) }),
        ("phong n=100", Brdf::Phong { exponent: 100.0, specular: Vec3::ONE, diffuse: Vec3::ZERO }),
    ];
    for (name, brdf) in iso {
        g.bench_function(format!("isotropic N=32 V=32 {name}"), |b| {
            b.iter(|| BrdfTable::build(black_box(&brdf), Resolution::PAPER).unwrap())
        });
    }
    // The presets' automatic resolution (N from the lobe width, here 128; V = 32).
    let auto = [
        ("ggx a=0.05", Brdf::Ggx { alpha: 0.05, specular: Vec3::ONE, diffuse: Vec3::splat(0.1) }),
        ("beckmann a=0.1", Brdf::Beckmann { alpha: 0.1, specular: Vec3::ONE, diffuse: Vec3::splat(0.1) }),
        ("ggx a=0.2", Brdf::Ggx { alpha: 0.2, specular: Vec3::ONE, diffuse: Vec3::splat(0.1) }),
    ];
    for (name, brdf) in auto {
        let res = Resolution::auto(&brdf);
        g.bench_function(format!("auto N={} V={} {name}", res.n, res.views), |b| {
            b.iter(|| BrdfTable::build(black_box(&brdf), res).unwrap())
        });
    }
    let aniso = Brdf::Ward { alpha_x: 0.1, alpha_y: 0.3, specular: Vec3::ONE, diffuse: Vec3::ZERO };
    g.sample_size(10);
    g.bench_function("anisotropic N=32 V=32x32 ward 0.1/0.3", |b| {
        b.iter(|| BrdfTable::build(black_box(&aniso), Resolution::PAPER).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

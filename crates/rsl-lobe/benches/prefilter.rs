//! Prefiltering a real map (sky.exr, 512×256 with a 20,000× sun) at the default ladder
//! (κ = 0, 1, 2, …, 4096), and lookups at random lobes.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec3;
use rsl_env::load_latlong;
use rsl_lobe::{PrefilterParams, Prefiltered};
use rsl_sphere::sampling::Pcg32;
use std::hint::black_box;
use std::path::Path;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/hdri/sky.exr");
    let map = load_latlong(&path).expect("bundled sky.exr").map;
    let mut g = c.benchmark_group("prefilter");
    g.sample_size(10);
    let params = PrefilterParams::default();
    g.bench_function("build sky.exr, kappa 0..4096", |b| b.iter(|| Prefiltered::build(black_box(&map), &params)));
    let p = Prefiltered::build(&map, &params);
    let mut rng = Pcg32::new(1);
    let lobes: Vec<(Vec3, f32)> = (0..1024)
        .map(|_| {
            let d = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize_or(Vec3::Y);
            (d, 2f32.powf(rng.next_f32() * 12.0))
        })
        .collect();
    g.bench_function("1024 lookups", |b| {
        b.iter(|| lobes.iter().fold(Vec3::ZERO, |acc, &(d, k)| acc + p.lookup(black_box(d), k)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! Shadow-ray throughput: visibility maps (N = 32, 2×2 sub-samples: 4,096 rays each) at
//! points on a plane under a 36,864-triangle sphere, so about half the rays hit.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use rsl_sphere::Frame;
use rsl_vis::{Occluder, VisibilityMap};

mod common;

fn bench(c: &mut Criterion) {
    let occ = Occluder::new(&common::uv_sphere(Vec3::new(0.0, 1.5, 0.0), 1.0, 96)).expect("valid sphere");
    let frame = Frame::from_normal(Vec3::Y);
    let points: Vec<Vec3> = (0..16).map(|k| Vec3::new(-0.8 + 0.1 * k as f32, 0.0, 0.3)).collect();
    let mut g = c.benchmark_group("rays");
    g.sample_size(10);
    g.throughput(Throughput::Elements((points.len() * 32 * 32 * 4) as u64));
    g.bench_function("16 visibility maps N=32 s=2 (shadow rays)", |b| {
        b.iter(|| {
            points.iter().map(|&p| VisibilityMap::trace(&occ, p, &frame, 1e-4, 100.0, 32, 2).values()[0]).sum::<f32>()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

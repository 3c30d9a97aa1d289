//! Occluder field build per object: tracing every sample's map, its VDT, and PCA per segment.

use criterion::{Criterion, criterion_group, criterion_main};
use rsl_vis::{Ovdf, OvdfParams};
use std::hint::black_box;

mod common;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("ovdf");
    g.sample_size(10);
    let object = common::torus(100, 100);
    g.bench_function("draft, torus 20k triangles", |b| {
        b.iter(|| Ovdf::build(black_box(&object), &OvdfParams::DRAFT).unwrap())
    });
    g.bench_function("paper, torus 20k triangles (16 shells x 6x32x32, 32x32 tables)", |b| {
        b.iter(|| Ovdf::build(black_box(&object), &OvdfParams::PAPER).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

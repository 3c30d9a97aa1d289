//! Self-visibility field build: tracing every vertex's map, its VDT, and CPCA.

use criterion::{Criterion, criterion_group, criterion_main};
use rsl_vis::{Svdf, SvdfParams};
use std::hint::black_box;

mod common;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("svdf");
    g.sample_size(10);
    let small = common::torus(100, 100);
    g.bench_function("draft, torus 10k vertices", |b| {
        b.iter(|| Svdf::build(black_box(&small), &SvdfParams::DRAFT).unwrap())
    });
    let big = common::torus(200, 200);
    g.bench_function("paper, torus 40k vertices (1024 rays each, 256 clusters x 8)", |b| {
        b.iter(|| Svdf::build(black_box(&big), &SvdfParams::PAPER).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

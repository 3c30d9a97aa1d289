//! Fitting transport lobes (92 views, three specular lobes and a diffuse one) for a torus of
//! about 10,000 vertices, its self-visibility traced against its own triangles (the
//! engine's `method = "lobe"` precompute).

use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec3;
use rsl_brdf::Brdf;
use rsl_lobe::{FitParams, MaterialLobes, TransportLobes, TransportParams};
use rsl_scene::Primitive;
use rsl_sphere::Frame;
use rsl_sphere::faces::IncidentFaces;
use rsl_vis::rays::Occluder;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let mesh = Primitive::Torus { major_radius: 1.0, minor_radius: 0.4, resolution: 70 }.mesh();
    let brdf = Brdf::Ggx { alpha: 0.2, specular: Vec3::splat(0.8), diffuse: Vec3::splat(0.2) };
    let material = MaterialLobes::fit(&brdf, &FitParams::default()).expect("valid BRDF");
    let frames: Vec<Frame> = mesh.normals.iter().map(|&n| Frame::from_normal(n)).collect();
    let occluder = Occluder::new(&mesh).expect("valid mesh");
    let faces = IncidentFaces::of(&mesh);
    let visible = |v: usize, d: Vec3| {
        let h = faces.mask(v, d);
        if h <= 0.0 || occluder.occluded(mesh.positions[v] + frames[v].n * 1.4e-4, d, f32::INFINITY) { 0.0 } else { h }
    };
    let mut g = c.benchmark_group("transport");
    g.sample_size(10);
    let name = format!("fit, {}-vertex torus, traced", mesh.vertex_count());
    g.bench_function(name, |b| {
        b.iter(|| TransportLobes::fit(&material, black_box(&frames), &TransportParams::default(), visible, &|_, _| {}))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

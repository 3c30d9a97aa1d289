//! Shadow-ray throughput: visibility maps (N = 32, 2×2 sub-samples: 4,096 rays each) at
//! points on a plane under a 36,864-triangle sphere, so about half the rays hit.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use rsl_sphere::Frame;
use rsl_sphere::mesh::TriMesh;
use rsl_vis::{Occluder, VisibilityMap};

fn sphere(centre: Vec3, radius: f32, rings: usize) -> TriMesh {
    let segs = 2 * rings;
    let mut m = TriMesh::default();
    for r in 0..=rings {
        let th = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segs {
            let ph = std::f32::consts::TAU * s as f32 / segs as f32;
            m.positions.push(centre + radius * Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()));
        }
    }
    let at = |r: usize, s: usize| (r * segs + s % segs) as u32;
    for r in 0..rings {
        for s in 0..segs {
            m.indices.extend([at(r, s), at(r, s + 1), at(r + 1, s + 1), at(r, s), at(r + 1, s + 1), at(r + 1, s)]);
        }
    }
    m.compute_normals();
    m
}

fn bench(c: &mut Criterion) {
    let occ = Occluder::new(&sphere(Vec3::new(0.0, 1.5, 0.0), 1.0, 96)).expect("valid sphere");
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

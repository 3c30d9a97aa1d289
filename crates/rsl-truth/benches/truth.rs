//! `truth`: the Monte Carlo reference at 256 samples per vertex on a glossy torus over a
//! plane with a sphere beside it (12,002 triangles) under a sky with a small sun.
//! Criterion reports shadow rays per second (`rays`) and vertices per second (`vertices`).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{Quat, Vec2, Vec3};
use rsl_brdf::Brdf;
use rsl_frame::VertexFrames;
use rsl_scene::{Primitive, Transform};
use rsl_sphere::latlong::{LatLongMap, dir_from_uv};
use rsl_truth::{EnvLight, TruthObject, TruthScene};
use std::hint::black_box;
use std::sync::Arc;

fn bench(c: &mut Criterion) {
    let (w, h) = (512, 256);
    let sun = Vec3::new(0.4, 0.7, 0.3).normalize();
    let texels = (0..w * h)
        .map(|k| {
            let d = dir_from_uv(Vec2::new(((k % w) as f32 + 0.5) / w as f32, ((k / w) as f32 + 0.5) / h as f32));
            let sky = Vec3::new(0.3, 0.5, 0.9) * d.y.max(0.0) + Vec3::splat(0.05);
            sky + if d.dot(sun) > 0.9995 { Vec3::splat(20_000.0) } else { Vec3::ZERO }
        })
        .collect();
    let env = EnvLight::map(Arc::new(LatLongMap::new(w, h, texels).unwrap()), 1.0);
    let meshes = [
        Primitive::Torus { major_radius: 0.6, minor_radius: 0.25, resolution: 40 }.mesh(),
        Primitive::Plane { size: 6.0, resolution: 40 }.mesh(),
        Primitive::Sphere { radius: 0.4, resolution: 32 }.mesh(),
    ];
    let frames: Vec<VertexFrames> = meshes.iter().map(|m| VertexFrames::new(m, false)).collect();
    let ggx = Brdf::Ggx { alpha: 0.2, specular: Vec3::new(0.9, 0.8, 0.6), diffuse: Vec3::splat(0.05) };
    let lambert = Brdf::Lambert { albedo: Vec3::splat(0.6) };
    let at = |x: f32, y: f32, z: f32| Transform { translation: Vec3::new(x, y, z), ..Default::default() };
    let objects = [
        TruthObject {
            mesh: &meshes[0],
            frames: &frames[0],
            brdf: ggx,
            transform: at(0.0, 0.7, 0.0),
            casts_shadows: true,
            texture: None,
            metallic_roughness: None,
        },
        TruthObject {
            mesh: &meshes[1],
            frames: &frames[1],
            brdf: lambert,
            transform: at(0.0, 0.0, 0.0),
            casts_shadows: true,
            texture: None,
            metallic_roughness: None,
        },
        TruthObject {
            mesh: &meshes[2],
            frames: &frames[2],
            brdf: ggx,
            transform: at(1.3, 0.4, 0.2),
            casts_shadows: true,
            texture: None,
            metallic_roughness: None,
        },
    ];
    let scene = TruthScene::new(&objects, env, Quat::IDENTITY).unwrap();
    let eye = Vec3::new(0.0, 2.0, 4.0);
    let spp = 256;
    let (_, stats) = scene.vertices(eye, spp, 1).unwrap();
    eprintln!("{} vertices at {spp} spp: {} shadow rays", stats.points, stats.shadow_rays);
    let mut g = c.benchmark_group("truth");
    g.sample_size(10);
    g.throughput(Throughput::Elements(stats.shadow_rays));
    g.bench_function("rays", |b| b.iter(|| black_box(scene.vertices(eye, spp, 1).unwrap())));
    g.throughput(Throughput::Elements(stats.points));
    g.bench_function("vertices", |b| b.iter(|| black_box(scene.vertices(eye, spp, 1).unwrap())));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

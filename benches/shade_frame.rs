//! `shade_frame`: one CPU frame of the benchmark scene (data/scenes/bench.toml: 59,551
//! vertices in 12 objects, 30 RSLs, paper preset), and the same frame with terms left out
//! for a breakdown: BRDF lookups alone, BRDF + self-visibility, everything (the preset's two
//! brightest lights with traced shadows), and everything from the occluder fields alone.
//!
//! Precomputation comes from the disk cache (`RSL_CACHE_DIR`, else the user cache folder);
//! the first run builds the paper-resolution fields (about a minute and a half on 2 cores).

use criterion::{Criterion, criterion_group, criterion_main};
use rsl_engine::scene::Scene;
use rsl_engine::{Engine, EngineOptions};
use rsl_shade::{Terms, Traced};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/scenes/bench.toml");
    let scene = Scene::load(&path).expect("bench scene");
    let options = EngineOptions {
        cache_dir: rsl_engine::cache::default_dir(),
        progress: rsl::progress::bars(),
        ..Default::default()
    };
    let engine = Engine::new(&scene, options).expect("prepared");
    let (vertices, _) = scene.counts();
    let t = 1.0;
    let state = scene.at(t);
    let eye = scene.camera.eye;
    let full = rsl_shade::shade(&engine.setup(&scene, &state, eye, Terms::default()).unwrap()).1;
    eprintln!("{vertices} vertices, {} objects, {} RSLs: {full:?}", scene.objects.len(), engine.rsls().len());
    let mut g = c.benchmark_group("shade_frame");
    g.sample_size(20);
    let variants = [
        ("brdf_only", Terms { self_visibility: false, occluders: false }),
        ("brdf_self", Terms { self_visibility: true, occluders: false }),
        ("full", Terms::default()),
    ];
    for (name, terms) in variants {
        g.bench_function(name, |b| {
            b.iter(|| {
                let setup = engine.setup(&scene, &state, eye, terms).unwrap();
                black_box(rsl_shade::shade(&setup))
            })
        });
    }
    g.bench_function("full_fields", |b| {
        b.iter(|| {
            let setup = engine
                .setup(&scene, &state, eye, Terms::default())
                .unwrap()
                .with_traced(Traced::default(), state.world_from_env);
            black_box(rsl_shade::shade(&setup))
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

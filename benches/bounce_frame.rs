//! `bounce_frame`: what interreflections cost a frame on the CPU (`bounces` 0 and 1, the
//! preset's `bounce_rays`): the default scene's whole frame (data/scenes/default.toml,
//! 640×480, standard preset, 30 RSLs, `auto`, its shading and its antialiased image), and
//! the bench scene's vertices (data/scenes/bench.toml, 59,551 vertices, its `paper` preset,
//! `rsl`, shading alone, as `shade_frame` measures it).
//!
//! Precomputation comes from the disk cache (`RSL_CACHE_DIR`, else the user cache folder).

use criterion::{Criterion, criterion_group, criterion_main};
use rsl_engine::method::Request;
use rsl_engine::registry::{Device, MethodId, MethodOptions};
use rsl_engine::scene::Scene;
use rsl_engine::{Engine, EngineOptions};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut g = c.benchmark_group("bounce_frame");
    g.sample_size(10);
    let cases = [
        ("default_auto", "data/scenes/default.toml", MethodId::AUTO, Request::at(1.0)),
        (
            "bench_rsl_vertices",
            "data/scenes/bench.toml",
            MethodId::RSL,
            Request { time: 1.0, image: false, vertices: true, exposure: None },
        ),
    ];
    for (name, path, id, request) in cases {
        let mut scene = Scene::load(root.join(path)).expect("the scene");
        let options = EngineOptions {
            cache_dir: rsl_engine::cache::default_dir(),
            progress: rsl::progress::bars(),
            ..Default::default()
        };
        let engine = Engine::new(&scene, options).expect("prepared");
        let mut method =
            id.create(&engine, &MethodOptions { device: Device::Cpu, ..Default::default() }).expect("the method");
        for bounces in [0, 1] {
            scene.quality.settings.bounces = bounces;
            method.render(&engine, &scene, &request).expect("a frame");
            g.bench_function(format!("{name}_bounces{bounces}"), |b| {
                b.iter(|| black_box(method.render(&engine, &scene, &request).expect("a frame")))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

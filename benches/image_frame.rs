//! `image_frame`: one whole frame on the CPU — shading and the image — of the default scene
//! (data/scenes/default.toml, 640×480, standard preset, 30 RSLs) by each method that draws
//! per pixel and by the vertices interpolated, with antialiasing off (`aa = 1`), at
//! `aa = 16` (4 samples in the pixels that need them, 16 more in a few) and at the preset's
//! `aa = 36` (and a 6×6 grid in the few a glint still spans): what antialiasing costs.
//!
//! Precomputation comes from the disk cache (`RSL_CACHE_DIR`, else the user cache folder).

use criterion::{Criterion, criterion_group, criterion_main};
use rsl_engine::method::Request;
use rsl_engine::registry::{Device, MethodId, MethodOptions};
use rsl_engine::scene::Scene;
use rsl_engine::{Engine, EngineOptions};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/scenes/default.toml");
    let mut g = c.benchmark_group("image_frame");
    g.sample_size(10);
    for aa in [1, 16, 36] {
        let mut scene = Scene::load(&path).expect("default scene");
        scene.quality.settings.set("aa", aa).expect("a valid aa");
        let options = EngineOptions {
            cache_dir: rsl_engine::cache::default_dir(),
            progress: rsl::progress::bars(),
            ..Default::default()
        };
        let engine = Engine::new(&scene, options).expect("prepared");
        let options = MethodOptions { device: Device::Cpu, ..Default::default() };
        for name in ["rsl", "pixel", "hybrid", "auto"] {
            let id: MethodId = name.parse().expect("a registered method");
            let mut method = id.create(&engine, &options).expect("the method");
            let request = Request::at(1.0);
            method.render(&engine, &scene, &request).expect("a frame");
            g.bench_function(format!("{name}_aa{aa}"), |b| {
                b.iter(|| black_box(method.render(&engine, &scene, &request).expect("a frame")))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

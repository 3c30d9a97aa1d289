//! `gpu_frame`: one GPU frame of the benchmark scene of `shade_frame` (data/scenes/bench.toml:
//! 59,551 vertices in 12 objects, 30 RSLs, paper preset): the shading compute pass (per-frame
//! uploads, dispatch, wait) with terms left out for a breakdown, the draw pass, and the RSL
//! sum per pixel (the shading pass keeping every light's cover, the per-pixel pass). Prints
//! the GPU's own timestamps per pass where the adapter has them. Skips (with a message)
//! without an adapter.
//!
//! Precomputation comes from the disk cache (`RSL_CACHE_DIR`, else the user cache folder).

use criterion::{Criterion, criterion_group, criterion_main};
use rsl_engine::GpuRenderer;
use rsl_engine::scene::Scene;
use rsl_engine::{Engine, EngineOptions};
use rsl_shade::Terms;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let mut gpu = match GpuRenderer::new() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("gpu_frame: skipped: no adapter ({e})");
            return;
        }
    };
    eprintln!("gpu_frame: adapter {}", gpu.describe());
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
    eprintln!("{vertices} vertices, {} objects, {} RSLs", scene.objects.len(), engine.rsls().len());
    let variants = [
        ("brdf_only", Terms { self_visibility: false, occluders: false }),
        ("brdf_self", Terms { self_visibility: true, occluders: false }),
        ("full", Terms::default()),
    ];
    // GPU timestamps, median of 20 passes each.
    for (name, terms) in variants {
        let mut ms: Vec<f64> = (0..20)
            .map(|_| {
                let p = gpu.dispatch(&engine, &scene, t, terms).expect("shading pass");
                p.gpu_ms.unwrap_or(p.wall_ms)
            })
            .collect();
        ms.sort_by(f64::total_cmp);
        let kind = if gpu.last_pass().gpu_ms.is_some() { "GPU timestamps" } else { "wall" };
        eprintln!("gpu_frame/{name}: shading pass {:.3} ms median ({kind})", ms[ms.len() / 2]);
    }
    for per_pixel in [false, true] {
        let frame = gpu.render(&engine, &scene, t, per_pixel, (Some(1.0), |_: &_| 1.0)).expect("frame");
        let t = frame.timings;
        eprintln!(
            "gpu_frame (per pixel: {per_pixel}): shading pass {:?}, draw pass {:?}, tonemap {:?}",
            t.shade, t.draw, t.tonemap
        );
    }
    let mut g = c.benchmark_group("gpu_frame");
    g.sample_size(20);
    for (name, terms) in variants {
        g.bench_function(name, |b| {
            b.iter(|| black_box(gpu.dispatch(&engine, &scene, t, terms).expect("shading pass")))
        });
    }
    for (name, per_pixel) in [("shade_and_draw", false), ("shade_and_draw_per_pixel", true)] {
        g.bench_function(name, |b| {
            b.iter(|| black_box(gpu.render(&engine, &scene, t, per_pixel, (Some(1.0), |_: &_| 1.0)).expect("frame")))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

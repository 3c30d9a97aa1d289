//! Prepared data stays under the memory budget while a material is dragged through many
//! values, and the GPU path renders the right table after it was evicted and rebuilt.

use glam::Vec3;
use rsl_engine::engine::table_resolution;
use rsl_engine::scene::{Brdf, Scene};
use rsl_engine::{Engine, EngineOptions, GpuRenderer};
use std::path::PathBuf;
use std::sync::Arc;

fn default_scene() -> Scene {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    Scene::load(root.join("data/scenes/default.toml")).expect("the default scene loads")
}

fn ggx(alpha: f32) -> Brdf {
    Brdf::Ggx { alpha, specular: glam::Vec3::new(0.95, 0.75, 0.4), diffuse: glam::Vec3::new(0.05, 0.04, 0.02) }
}

/// Every vertex of the GPU frame within 1e-3 relative (1e-5 absolute) of the CPU's.
fn agree(what: &str, cpu: &[Vec<Vec3>], gpu: &[Vec<Vec3>]) {
    for (i, (c, g)) in cpu.iter().zip(gpu).enumerate() {
        for (v, (a, b)) in c.iter().zip(g).enumerate() {
            let diff = (*a - *b).abs().max_element();
            assert!(diff <= 1e-5 || diff <= 1e-3 * a.abs().max_element(), "{what}: object {i} vertex {v}: {a} vs {b}");
        }
    }
}

#[test]
fn dragging_a_material_through_200_values_stays_under_the_budget() {
    let mut s = default_scene();
    let cache = rsl_engine::sphere::scratch::Scratch::new("budget-test");
    let options = EngineOptions { cache_dir: Some(cache.to_path_buf()), ..Default::default() };
    // What the scene itself holds, and one table of the dragged material.
    let probe = Engine::new(&s, options.clone()).unwrap();
    let in_use = probe.memory().resident_bytes;
    let b = ggx(0.3);
    let table = rsl_brdf::BrdfTable::build(&b, table_resolution(&probe.settings().1, &b)).unwrap().bytes();
    drop(probe);
    // Room for the scene and five more tables.
    let budget = in_use + 5 * table;
    let mut engine = Engine::new(&s, EngineOptions { memory_budget: Some(budget), ..options.clone() }).unwrap();
    let mut gpu = rsl_gpu::testing::context_or_skip("dragging_a_material_through_200_values_stays_under_the_budget")
        .map(|ctx| GpuRenderer::with_context(Arc::new(ctx)).expect("pipelines build"));
    // α in [0.05, 0.35]: every value's automatic table has the same size (128×128, the
    // size measured above), so the budget holds five of them and each new value evicts one.
    let alpha = |k: usize| 0.05 + 0.3 * k as f32 / 199.0;
    let mut peak = 0;
    for k in 0..200 {
        s.objects[1].material = ggx(alpha(k));
        engine.sync(&s).unwrap();
        let m = engine.memory();
        peak = peak.max(m.resident_bytes);
        assert!(m.resident_bytes <= budget, "value {k}: {} bytes held, budget {budget}", m.resident_bytes);
        if k % 66 == 0
            && let Some(g) = gpu.as_mut()
        {
            agree(
                &format!("alpha {}", alpha(k)),
                &engine.shade(&s, 1.0).unwrap().radiance,
                &g.shade(&engine, &s, 1.0).unwrap().radiance,
            );
        }
    }
    let m = engine.memory();
    eprintln!("200 values: peak {peak} bytes held (budget {budget}, one table {table}), {} evictions", m.evictions);
    assert!(m.evictions >= 190, "{m:?}");
    // The first value's table was evicted: going back rebuilds it (one miss), and the GPU,
    // which last drew the 199th value, renders the rebuilt table.
    let misses = engine.cache_stats().misses;
    s.objects[1].material = ggx(alpha(0));
    engine.sync(&s).unwrap();
    assert_eq!(engine.cache_stats().misses, misses + 1, "the evicted table is rebuilt");
    let cpu = engine.shade(&s, 1.0).unwrap();
    if let Some(g) = gpu.as_mut() {
        agree("after eviction and rebuild", &cpu.radiance, &g.shade(&engine, &s, 1.0).unwrap().radiance);
    }
    // And the rebuilt table is the table: the same radiance as an engine that never evicted.
    let fresh = Engine::new(&s, options).unwrap().shade(&s, 1.0).unwrap();
    assert_eq!(cpu.radiance, fresh.radiance);
}

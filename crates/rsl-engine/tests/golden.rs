//! Golden output: per-vertex radiance of the bundled default scene at two times (every 8th
//! vertex), compared with the file `tests/golden/default.bin`.
//!
//! A missing or mismatched file fails. The file is rewritten only on request:
//! `RSL_WRITE_GOLDEN=1 cargo test --release -p rsl-engine --test golden` writes it and then
//! fails on purpose, so a rewrite never passes unnoticed; run the test again to check it.

use rsl_engine::scene::Scene;
use rsl_engine::{Engine, EngineOptions};
use std::path::PathBuf;

const TIMES: [f32; 2] = [0.0, 2.5];
const STRIDE: usize = 8;
const HEADER: &str =
    "rsl golden per-vertex radiance v1: data/scenes/default.toml, t = 0 and 2.5 s, every 8th vertex, RGB f32 LE\n";
/// Mean relative difference allowed (float differences between lookup kernels are ~1e-6).
const MEAN: f64 = 1e-4;
/// 99th-percentile relative difference allowed.
const P99: f64 = 1e-3;

fn manifest() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn current() -> Vec<f32> {
    let s = Scene::load(manifest().join("../../data/scenes/default.toml")).expect("the default scene loads");
    let cache = rsl_engine::sphere::scratch::Scratch::new("golden-test");
    let engine = Engine::new(&s, EngineOptions { cache_dir: Some(cache.to_path_buf()), ..Default::default() }).unwrap();
    TIMES
        .iter()
        .flat_map(|&t| {
            let f = engine.shade(&s, t).unwrap();
            f.radiance.concat().into_iter().step_by(STRIDE).flat_map(|c| c.to_array()).collect::<Vec<f32>>()
        })
        .collect()
}

#[test]
fn default_scene_matches_its_golden_output() {
    let path = manifest().join("tests/golden/default.bin");
    let now = current();
    if std::env::var_os("RSL_WRITE_GOLDEN").is_some() {
        let mut bytes = HEADER.as_bytes().to_vec();
        bytes.extend(now.iter().flat_map(|v| v.to_le_bytes()));
        std::fs::write(&path, bytes).unwrap();
        panic!(
            "wrote {} ({} values); run the test again without RSL_WRITE_GOLDEN to check it",
            path.display(),
            now.len()
        );
    }
    let bytes = std::fs::read(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; write it with RSL_WRITE_GOLDEN=1 cargo test --release -p rsl-engine --test golden",
            path.display()
        )
    });
    assert!(
        bytes.starts_with(HEADER.as_bytes()),
        "{}: not a golden file of this test (header differs)",
        path.display()
    );
    let golden: Vec<f32> =
        bytes[HEADER.len()..].chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
    assert_eq!(golden.len(), now.len(), "the golden file holds {} values, the scene gives {}", golden.len(), now.len());
    // Per vertex: the largest channel difference relative to the vertex's largest channel,
    // with a floor of 1e-3 of the mean so black vertices do not divide by zero.
    let mean_level = golden.iter().map(|v| f64::from(v.abs())).sum::<f64>() / golden.len() as f64;
    let mut rel: Vec<f64> = golden
        .chunks_exact(3)
        .zip(now.chunks_exact(3))
        .map(|(g, n)| {
            let diff = g.iter().zip(n).map(|(a, b)| f64::from((a - b).abs())).fold(0.0, f64::max);
            let scale = g.iter().map(|a| f64::from(a.abs())).fold(1e-3 * mean_level, f64::max);
            diff / scale
        })
        .collect();
    rel.sort_by(f64::total_cmp);
    let mean = rel.iter().sum::<f64>() / rel.len() as f64;
    let p99 = rel[(rel.len() * 99) / 100];
    eprintln!("golden: {} vertices, mean relative difference {mean:.2e}, 99th percentile {p99:.2e}", rel.len());
    assert!(mean <= MEAN, "mean relative difference {mean:.3e} > {MEAN}");
    assert!(p99 <= P99, "99th-percentile relative difference {p99:.3e} > {P99}");
}

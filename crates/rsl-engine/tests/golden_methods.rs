//! Golden output of every method: the bundled default scene at draft quality, drawn at
//! 96×72 at t = 1 s, per vertex (every 8th vertex) and per pixel, compared with
//! `tests/golden/methods/<method>.bin` (mean relative difference ≤ 1e-4, 99th percentile
//! ≤ 1e-3, per vertex and per pixel separately).
//!
//! A missing or mismatched file fails. The files are rewritten only on request:
//! `RSL_WRITE_GOLDEN=1 cargo test --release -p rsl-engine --test golden_methods` writes them
//! and then fails on purpose, so a rewrite never passes unnoticed; run the test again to
//! check them. The GPU methods need an adapter (Mesa's llvmpipe in CI): without one they
//! are skipped, and fail under `RSL_REQUIRE_GPU=1`.

use glam::Vec3;
use rsl_engine::method::{Method, Request};
use rsl_engine::scene::Scene;
use rsl_engine::{Device, Engine, EngineOptions, Layers, MethodId, MethodOptions};
use std::sync::OnceLock;

mod common;
use common::root;

const TIME: f32 = 1.0;
const STRIDE: usize = 8;
const WIDTH: u32 = 96;
const HEIGHT: u32 = 72;
const HEADER: &str = "rsl golden method output v1: data/scenes/default.toml, draft, 96x72, t = 1 s, \
                      every 8th vertex then every pixel, RGB f32 LE\n";
/// Mean relative difference allowed (float differences between lookup kernels are ~1e-6).
const MEAN: f64 = 1e-4;
/// 99th-percentile relative difference allowed.
const P99: f64 = 1e-3;

fn golden_scene() -> Scene {
    let mut s = Scene::load(root().join("data/scenes/default.toml")).expect("the default scene loads");
    s.camera.width = WIDTH;
    s.camera.height = HEIGHT;
    s
}

/// The golden scene's engine, with the RSL layer (`rsl`) or without: built once and shared by
/// the tests, each of which draws it with its own method.
fn engine(scene: &Scene, rsl: bool) -> &'static Engine {
    static WITH: OnceLock<Engine> = OnceLock::new();
    static WITHOUT: OnceLock<Engine> = OnceLock::new();
    let cell = if rsl { &WITH } else { &WITHOUT };
    cell.get_or_init(|| {
        let cache = rsl_engine::sphere::scratch::run_dir(&format!("golden-methods-{rsl}"));
        let options = EngineOptions {
            cache_dir: Some(cache),
            quality: Some(rsl_engine::scene::Preset::Draft),
            layers: Layers { rsl },
            ..Default::default()
        };
        Engine::new(scene, options).expect("engine")
    })
}

/// Every 8th vertex's radiance, then the image's pixels.
fn output(method: &mut dyn Method, engine: &Engine, scene: &Scene) -> (Vec<Vec3>, Vec<Vec3>) {
    let request = Request { time: TIME, image: true, vertices: true, exposure: None };
    let f = method.render(engine, scene, &request).expect("frame");
    let vertices: Vec<Vec3> = f.radiance.concat().into_iter().step_by(STRIDE).collect();
    let image = f.image.expect("an image was asked for");
    assert_eq!((image.width, image.height), (WIDTH, HEIGHT));
    (vertices, image.pixels)
}

/// Mean and 99th percentile of the per-element difference relative to the element's
/// largest channel, with a floor of 1e-3 of the mean level so black elements do not
/// divide by zero.
fn differences(golden: &[Vec3], now: &[Vec3]) -> (f64, f64) {
    let mean_level = golden.iter().map(|v| f64::from(v.abs().element_sum())).sum::<f64>() / (3 * golden.len()) as f64;
    let mut rel: Vec<f64> = golden
        .iter()
        .zip(now)
        .map(|(g, n)| {
            let diff = f64::from((*g - *n).abs().max_element());
            diff / f64::from(g.abs().max_element()).max(1e-3 * mean_level)
        })
        .collect();
    rel.sort_by(f64::total_cmp);
    let mean = rel.iter().sum::<f64>() / rel.len().max(1) as f64;
    let p99 = rel.get((rel.len() * 99) / 100).copied().unwrap_or(0.0);
    (mean, p99)
}

fn check(name: &str, (vertices, pixels): (Vec<Vec3>, Vec<Vec3>)) {
    let path = root().join(format!("crates/rsl-engine/tests/golden/methods/{name}.bin"));
    let values = |v: &[Vec3]| v.iter().flat_map(|c| c.to_array()).collect::<Vec<f32>>();
    if std::env::var_os("RSL_WRITE_GOLDEN").is_some() {
        let mut bytes = HEADER.as_bytes().to_vec();
        bytes.extend((vertices.len() as u64).to_le_bytes());
        bytes.extend(values(&vertices).iter().chain(&values(&pixels)).flat_map(|v| v.to_le_bytes()));
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, bytes).unwrap();
        panic!("wrote {}; run the test again without RSL_WRITE_GOLDEN to check it", path.display());
    }
    let bytes = std::fs::read(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; write it with RSL_WRITE_GOLDEN=1 cargo test --release -p rsl-engine --test golden_methods",
            path.display()
        )
    });
    assert!(bytes.starts_with(HEADER.as_bytes()), "{}: not a golden file of this test", path.display());
    let rest = &bytes[HEADER.len()..];
    let n = u64::from_le_bytes(rest[..8].try_into().unwrap()) as usize;
    let all: Vec<Vec3> = rest[8..]
        .chunks_exact(12)
        .map(|b| {
            let f = |k: usize| f32::from_le_bytes(b[4 * k..4 * k + 4].try_into().unwrap());
            Vec3::new(f(0), f(1), f(2))
        })
        .collect();
    assert_eq!(n, vertices.len(), "{name}: {n} golden vertices, {} now", vertices.len());
    assert_eq!(all.len() - n, pixels.len(), "{name}: {} golden pixels, {} now", all.len() - n, pixels.len());
    for (what, golden, now) in [("vertices", &all[..n], &vertices[..]), ("pixels", &all[n..], &pixels[..])] {
        let (mean, p99) = differences(golden, now);
        eprintln!("{name} {what}: mean relative difference {mean:.2e}, 99th percentile {p99:.2e}");
        assert!(mean <= MEAN, "{name} {what}: mean relative difference {mean:.3e} > {MEAN}");
        assert!(p99 <= P99, "{name} {what}: 99th-percentile relative difference {p99:.3e} > {P99}");
    }
}

/// The method `name` (`<method>-gpu`: on the GPU) from the registry (`None` for the GPU
/// ones without an adapter).
fn method(name: &str, engine: &Engine, test: &str) -> Option<Box<dyn Method>> {
    let (id, gpu) = match name.strip_suffix("-gpu") {
        Some(id) => (id, Some(std::sync::Arc::new(rsl_gpu::testing::context_or_skip(test)?))),
        None => (name, None),
    };
    let device = if gpu.is_some() { Device::Gpu } else { Device::Cpu };
    let options = MethodOptions { device, spp: 4, seed: 7, gpu, ..Default::default() };
    Some(id.parse::<MethodId>().expect("a registered method").create(engine, &options).expect("the method builds"))
}

fn golden(name: &str) {
    // The lobe path on either device fits the same transport lobes into the engine's disk
    // cache: one test fits them while the other waits, then reads them back.
    static LOBES: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _fitting = name.starts_with("lobe").then(|| LOBES.lock().unwrap_or_else(std::sync::PoisonError::into_inner));
    let scene = golden_scene();
    let engine = engine(&scene, name != "truth");
    let Some(mut m) = method(name, engine, name) else { return };
    check(name, output(m.as_mut(), engine, &scene));
}

/// The RSL path with the oracles `list` (rsl-shade's `oracle`, as the bench's error budget
/// runs it), per vertex and rasterised; golden file `oracle-<list>` (`+` for commas).
fn golden_oracle(list: &str) {
    let scene = golden_scene();
    let engine = engine(&scene, true);
    let mut m = rsl_engine::method::Oracle::new(rsl_shade::Oracles::parse(list).expect("oracle names"));
    check(&format!("oracle-{}", list.replace(',', "+")), output(&mut m, engine, &scene));
}

#[test]
fn oracle_brdf_self() {
    golden_oracle("brdf,self");
}

#[test]
fn oracle_occluders() {
    golden_oracle("occluders");
}

#[test]
fn oracle_product() {
    golden_oracle("product");
}

#[test]
fn rsl() {
    golden("rsl");
}

#[test]
fn pixel() {
    golden("pixel");
}

#[test]
fn hybrid() {
    golden("hybrid");
}

#[test]
fn lobe() {
    golden("lobe");
}

#[test]
fn auto() {
    golden("auto");
}

#[test]
fn truth() {
    golden("truth");
}

#[test]
fn rsl_gpu() {
    golden("rsl-gpu");
}

#[test]
fn hybrid_gpu() {
    golden("hybrid-gpu");
}

#[test]
fn lobe_gpu() {
    golden("lobe-gpu");
}

#[test]
fn pixel_gpu() {
    golden("pixel-gpu");
}

#[test]
fn auto_gpu() {
    golden("auto-gpu");
}

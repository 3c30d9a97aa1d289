//! `rsl render --device gpu` writes the same outputs as the CPU path. Runs on any adapter
//! (Mesa's llvmpipe in CI); without one the test prints "skipped: no adapter", and fails
//! under RSL_REQUIRE_GPU=1.

use std::path::PathBuf;

mod common;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn run(args: &[&str]) -> anyhow::Result<()> {
    use clap::Parser;
    rsl::cli::run(rsl::cli::Cli::try_parse_from(std::iter::once("rsl").chain(args.iter().copied()))?)
}

#[test]
fn render_on_the_gpu_writes_the_same_outputs() {
    if rsl_gpu::testing::context_or_skip("render_on_the_gpu_writes_the_same_outputs").is_none() {
        return;
    }
    let dir = rsl_engine::sphere::scratch::Scratch::new("gpu-cli");
    let out = |n: &str| dir.join(n).to_str().unwrap().to_string();
    let scene = root().join("data/scenes/default.toml");
    let scene = scene.to_str().unwrap();
    let cache = dir.join("cache");
    let cache = cache.to_str().unwrap();
    let common = ["--time", "1.0", "--cache", cache, "--timings"];
    let gpu = ["render", scene, "--device", "gpu", "--method", "rsl"];
    run(&[&gpu[..], &["--out", &out("g.exr"), "--vertex-out", &out("g.ply")], &common[..]].concat()).unwrap();
    run(&[&gpu[..], &["--out", &out("g.png")], &common[..]].concat()).unwrap();
    // The same method on both devices.
    run(&[
        &["render", scene, "--device", "cpu", "--method", "rsl", "--out", &out("c.exr"), "--vertex-out", &out("c.ply")],
        &common[..],
    ]
    .concat())
    .unwrap();
    let img = image::open(dir.join("g.png")).unwrap();
    assert_eq!((img.width(), img.height()), (640, 480));
    // Per-vertex radiance of the two devices' PLY files agrees (as in the tests above).
    let g = rsl_engine::ply::read(&std::fs::read(dir.join("g.ply")).unwrap()).unwrap();
    let c = rsl_engine::ply::read(&std::fs::read(dir.join("c.ply")).unwrap()).unwrap();
    assert_eq!((g.vertices.len(), g.faces.len()), (c.vertices.len(), c.faces.len()));
    for (a, b) in g.vertices.iter().zip(&c.vertices) {
        for k in 0..9 {
            assert!((a[k] - b[k]).abs() <= 1e-3 * b[k].abs().max(1e-2), "{a:?} vs {b:?}");
        }
    }
    // The EXR files: same size, coverage alpha, finite.
    let (gw, gh, gp, gm) = rsl_engine::output::read_exr(&dir.join("g.exr")).unwrap();
    let (cw, ch, _, cm) = rsl_engine::output::read_exr(&dir.join("c.exr")).unwrap();
    assert_eq!((gw, gh), (cw, ch));
    assert!(gp.iter().all(|p| p.is_finite()));
    let (gm, cm) = (gm.expect("coverage alpha"), cm.expect("coverage alpha"));
    assert!(gm.iter().zip(&cm).filter(|(a, b)| a != b).count() * 1000 <= gm.len());
    // The Monte Carlo truth has no GPU path: asking for one is a clear error.
    let e = run(&["render", scene, "--method", "truth", "--device", "gpu", "--out", &out("t.png")]).unwrap_err();
    assert!(e.to_string().contains("CPU only"), "{e}");
    assert!(!dir.join("t.png").exists());
}

#[test]
fn the_largest_exposures_saturate_to_white_on_both_devices() {
    if rsl_gpu::testing::context_or_skip("the_largest_exposures_saturate_to_white_on_both_devices").is_none() {
        return;
    }
    // A grey ball under a unit constant light: every pixel's radiance is at least 0.5.
    let dir = std::env::temp_dir().join(format!("rsl-gpu-exposure-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = common::ball_scene(&dir, "s.toml", |b| b.constant(glam::Vec3::ONE));
    let cache = dir.join("cache");
    for device in ["cpu", "gpu"] {
        for exposure in ["1e20", "1e38"] {
            let png = dir.join(format!("{device}-{exposure}.png"));
            let args = ["render", scene.to_str().unwrap(), "--device", device, "--exposure", exposure, "--out"];
            run(&[&args[..], &[png.to_str().unwrap(), "--cache", cache.to_str().unwrap()]].concat()).unwrap();
            let img = image::open(&png).unwrap().to_rgb8();
            let dark = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
            assert_eq!(dark, 0, "{device}, exposure {exposure}: {dark} pixels not white");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

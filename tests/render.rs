//! The command line end to end: `rsl render` writes images, vertices and animations from
//! the engine's methods, and bad arguments are clear errors that write nothing.

use glam::Vec3;
use rsl_engine::scene::Scene;
use rsl_engine::{Engine, EngineOptions};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn memory_only() -> EngineOptions {
    EngineOptions::default()
}

/// A folder of this test, removed with it.
fn cache_dir(name: &str) -> rsl_engine::sphere::scratch::Scratch {
    rsl_engine::sphere::scratch::Scratch::new(&format!("render-test-{name}"))
}

fn run(args: &[&str]) -> anyhow::Result<()> {
    use clap::Parser;
    rsl::cli::run(rsl::cli::Cli::try_parse_from(std::iter::once("rsl").chain(args.iter().copied()))?)
}

#[test]
fn render_writes_images_vertices_and_animations() {
    let dir = cache_dir("render");
    let scene = root().join("data/scenes/default.toml");
    let scene = scene.to_str().unwrap();
    let cache = dir.join("cache");
    let cache = cache.to_str().unwrap();
    let out = |n: &str| dir.join(n).to_str().unwrap().to_string();
    // The RSL path on the CPU, so that the PLY holds exactly the engine's CPU radiance.
    let args = ["--device", "cpu", "--method", "rsl", "--cache", cache];
    run(&[&["render", scene, "--time", "1.0", "--out", &out("a.png"), "--vertex-out", &out("a.ply")], &args[..]]
        .concat())
    .unwrap();
    let img = image::open(dir.join("a.png")).unwrap();
    assert_eq!((img.width(), img.height()), (640, 480));
    let ply = rsl_engine::ply::read(&std::fs::read(dir.join("a.ply")).unwrap()).unwrap();
    let s = Scene::load(Path::new(scene)).unwrap();
    let (vertices, triangles) = s.counts();
    assert_eq!((ply.vertices.len(), ply.faces.len()), (vertices, triangles));
    assert_eq!(*ply.objects.last().unwrap() as usize, s.objects.len() - 1);
    // The PLY's radiance is the engine's, in world space toward the eye.
    let engine = Engine::new(&s, EngineOptions { cache_dir: Some(cache.into()), ..memory_only() }).unwrap();
    let frame = engine.shade(&s, 1.0).unwrap();
    let flat: Vec<Vec3> = frame.radiance.concat();
    for (v, row) in ply.vertices.iter().enumerate() {
        assert_eq!(Vec3::new(row[6], row[7], row[8]), flat[v]);
    }

    run(&["render", scene, "--time", "0.5", "--out", &out("b.exr"), "--cache", cache]).unwrap();
    let exr = image::open(dir.join("b.exr")).unwrap().into_rgb32f();
    assert!(exr.pixels().all(|p| p.0.iter().all(|c| c.is_finite() && *c >= 0.0)));

    run(&["render", scene, "--frames", "2..5", "--fps", "10", "--out", &out("anim.png"), "--cache", cache]).unwrap();
    for k in 2..5 {
        assert!(dir.join(format!("anim_{k:04}.png")).exists());
    }
    assert!(!dir.join("anim_0005.png").exists());
    let gif = std::fs::read(dir.join("anim.gif")).unwrap();
    assert!(gif.starts_with(b"GIF89a"));
}

#[test]
fn bad_render_arguments_are_clear_errors_and_write_nothing() {
    let dir = cache_dir("bad");
    let scene = root().join("data/scenes/default.toml");
    let scene = scene.to_str().unwrap();
    let msg = |args: &[&str]| format!("{:#}", run(args).unwrap_err());
    let jpg = dir.join("x.jpg");
    assert!(msg(&["render", scene, "--out", jpg.to_str().unwrap()]).contains(".png or .exr"));
    let missing = dir.join("no/such/folder/x.png");
    assert!(msg(&["render", scene, "--out", missing.to_str().unwrap()]).contains("does not exist"));
    let png = dir.join("x.png");
    assert!(msg(&["render", scene, "--out", png.to_str().unwrap(), "--frames", "5..5"]).contains("holds no frame"));
    assert!(
        msg(&["render", scene, "--out", png.to_str().unwrap(), "--quality", "ultra"])
            .contains("draft, standard, paper, high")
    );
    assert!(msg(&["render", scene, "--out", png.to_str().unwrap(), "--rsl", "0", "--no-cache"]).contains("at least 1"));
    assert!(msg(&["render", "no-such-scene.toml", "--out", png.to_str().unwrap()]).contains("no-such-scene.toml"));
    assert!(std::fs::read_dir(&dir).unwrap().next().is_none(), "something was written");
}

#[test]
fn truth_renders_and_compares_like_the_rsl_path() {
    let dir = cache_dir("truth-cli");
    let scene = root().join("data/scenes/default.toml");
    let scene = scene.to_str().unwrap();
    let cache = dir.join("cache");
    let cache = cache.to_str().unwrap();
    let out = |n: &str| dir.join(n).to_str().unwrap().to_string();
    run(&["render", scene, "--time", "1", "--out", &out("rsl.exr"), "--vertex-out", &out("rsl.ply"), "--cache", cache])
        .unwrap();
    run(&[
        "render",
        scene,
        "--time",
        "1",
        "--method",
        "truth",
        "--spp",
        "4",
        "--out",
        &out("truth.exr"),
        "--vertex-out",
        &out("truth.ply"),
    ])
    .unwrap();
    // Same vertices in both PLY files.
    let (a, b) = (
        rsl_engine::ply::read(&std::fs::read(dir.join("rsl.ply")).unwrap()).unwrap(),
        rsl_engine::ply::read(&std::fs::read(dir.join("truth.ply")).unwrap()).unwrap(),
    );
    assert_eq!(a.faces, b.faces);
    for (x, y) in a.vertices.iter().zip(&b.vertices) {
        assert!((0..6).all(|k| (x[k] - y[k]).abs() < 1e-5), "{x:?} vs {y:?}");
    }
    // The EXR alpha marks the pixels objects cover.
    let (_, _, _, mask) = rsl_engine::output::read_exr(&dir.join("truth.exr")).unwrap();
    let mask = mask.unwrap();
    assert!(mask.iter().any(|&m| m) && mask.iter().any(|&m| !m));
    run(&["compare", &out("rsl.ply"), &out("truth.ply"), "--heatmap", &out("heat.png"), "--scene", scene]).unwrap();
    run(&["compare", &out("rsl.exr"), &out("truth.exr"), "--heatmap", &out("heatpx.png")]).unwrap();
    run(&["compare", &out("rsl.ply"), &out("truth.ply"), "--scene", scene, "--breakdown"]).unwrap();
    let heat = image::open(dir.join("heat.png")).unwrap();
    assert_eq!((heat.width(), heat.height()), (640, 480 + 40));
    // Bad inputs.
    let msg = |args: &[&str]| format!("{:#}", run(args).unwrap_err());
    assert!(msg(&["render", scene, "--method", "truth", "--spp", "0", "--out", &out("x.png")]).contains("--spp"));
    assert!(msg(&["compare", &out("rsl.ply"), &out("truth.exr")]).contains("two .ply or two .exr"));
    assert!(msg(&["compare", &out("missing.ply"), &out("truth.ply")]).contains("missing.ply"));
    assert!(msg(&["compare", &out("rsl.ply"), &out("truth.ply"), "--breakdown"]).contains("--scene"));
    let empty = dir.join("empty.toml");
    std::fs::write(
        &empty,
        "[environment]\nconstant = [1.0, 1.0, 1.0]\n[camera]\neye = [0.0, 0.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n",
    )
    .unwrap();
    assert!(
        msg(&["render", empty.to_str().unwrap(), "--method", "truth", "--out", &out("e.png")]).contains("no objects")
    );
    assert!(
        msg(&["render", scene, "--method", "truth", "--out", dir.join("nowhere/x.exr").to_str().unwrap()])
            .contains("does not exist")
    );
}

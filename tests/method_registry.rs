//! A method registered by a program appears in every front end without edits there:
//! `examples/normals_method.rs` registers `normals` and runs the `rsl` command line, which
//! then lists and renders it (`rsl render --method`), measures it (`rsl bench --sweep
//! method=`) and offers it in the viewer (`rsl view --drawing`, the drop-down's choices).
//!
//! The example is built by `cargo test` (all targets); `cargo test --test method_registry`
//! alone does not build it: build it first with `cargo build --release --example
//! normals_method`.

use rsl_scene::build::{ObjectBuilder, SceneBuilder};
use rsl_scene::{Brdf, ObjectMethod};
use std::path::PathBuf;
use std::process::Command;

fn example() -> Command {
    let exe = PathBuf::from(env!("CARGO_BIN_EXE_rsl"))
        .parent()
        .expect("the binary's folder")
        .join("examples")
        .join(format!("normals_method{}", std::env::consts::EXE_SUFFIX));
    assert!(
        exe.is_file(),
        "{} is missing: build it with `cargo build --release --example normals_method`",
        exe.display()
    );
    let mut c = Command::new(exe);
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

fn out_dir(name: &str) -> rsl_engine::sphere::scratch::Scratch {
    rsl_engine::sphere::scratch::Scratch::new(&format!("registry-{name}"))
}

fn run(c: &mut Command) -> (bool, String) {
    let o = c.output().unwrap();
    (o.status.success(), format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr)))
}

#[test]
fn an_example_method_is_listed_rendered_and_refused_where_it_cannot_run() {
    let (ok, help) = run(example().args(["render", "--help"]));
    assert!(ok, "{help}");
    for name in ["rsl", "pixel", "hybrid", "lobe", "auto", "truth", "wavelet", "normals"] {
        assert!(
            help.contains(&format!("{name}:")) || help.contains(&format!("- {name}")),
            "--help lacks {name}:\n{help}"
        );
    }
    let dir = out_dir("render");
    let exr = dir.join("n.exr");
    // At draft quality, whose pixels are their centres (antialiased, a silhouette pixel
    // would average a normal's colour with the background).
    let (ok, log) = run(example()
        .args(["render", "data/scenes/default.toml", "--method", "normals", "--quality", "draft", "--out"])
        .arg(&exr));
    assert!(ok, "{log}");
    let (w, h, pixels, covered) = rsl_engine::output::read_exr(&exr).unwrap();
    assert_eq!((w, h), (640, 480));
    let covered = covered.expect("coverage alpha");
    // Every covered pixel is a normal's colour: each channel in [0, 1], and
    // |2c − 1| a unit vector up to interpolation (which shortens it).
    let mut n = 0;
    for (p, c) in pixels.iter().zip(&covered) {
        if *c {
            let v = *p * 2.0 - glam::Vec3::ONE;
            assert!(v.length() <= 1.0 + 1e-3 && v.length() > 0.5, "not a normal's colour: {p:?}");
            n += 1;
        }
    }
    assert!(n > 10_000, "{n} covered pixels");
    // It runs on the CPU only, as it registered: asking for a GPU is an error before any work.
    let png = dir.join("g.png");
    let (ok, log) = run(example()
        .args(["render", "data/scenes/default.toml", "--method", "normals", "--device", "gpu", "--out"])
        .arg(&png));
    assert!(!ok && log.contains("CPU only"), "{log}");
    assert!(!png.exists());
    // The plain `rsl` does not know it: the registry is the program's.
    let o = Command::new(env!("CARGO_BIN_EXE_rsl"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["render", "data/scenes/default.toml", "--method", "normals", "--out"])
        .arg(&png)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && log.contains("unknown method `normals`"), "{log}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_example_method_is_measured_by_the_bench() {
    let dir = out_dir("bench");
    let (ok, log) = run(example()
        .args(["bench", "data/scenes/default.toml", "--out"])
        .arg(&dir)
        .args(["--sweep", "method=normals", "--truth-spp", "2", "--grid-spp", "0", "--frames", "1"])
        .args(["--no-wavelet", "--no-budget", "--times", "0"]));
    assert!(ok, "{log}");
    let csv = std::fs::read_to_string(dir.join("results.csv")).unwrap();
    assert_eq!(csv.lines().count(), 2, "{csv}");
    assert!(csv.lines().nth(1).unwrap().contains("method=normals"), "{csv}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_scene_file_gives_an_example_method_to_one_object() {
    let dir = out_dir("per-object");
    let scene = dir.join("two.toml");
    let ball = |name: &str, x: f32| {
        ObjectBuilder::sphere(name, 0.5, 16).translation(glam::Vec3::new(x, 0.0, 0.0)).material(Brdf::Ggx {
            alpha: 0.3,
            specular: glam::Vec3::ONE,
            diffuse: glam::Vec3::ZERO,
        })
    };
    // The example registers `normals` in its own process; this one only writes the file.
    rsl_scene::register_method_name("normals");
    let normals = ObjectMethod::named("normals").unwrap();
    SceneBuilder::new()
        .camera(glam::Vec3::new(0.0, 0.0, 3.0), glam::Vec3::ZERO)
        .image(64, 48)
        .object(ball("shown", 0.0).method(normals))
        .object(ball("other", 1.2))
        .write(&scene)
        .unwrap();
    let exr = dir.join("two.exr");
    let (ok, log) = run(example()
        .arg("render")
        .arg(&scene)
        .args(["--method", "auto", "--explain", "--quality", "draft", "--out"])
        .arg(&exr));
    assert!(ok, "{log}");
    assert!(log.contains("shown: its world normals as colours (normals)"), "{log}");
    assert!(log.contains("other: the RSL sum per pixel (pixel)"), "{log}");
    // The ball given `normals` faces the camera at the image's centre: its normal there is +Z.
    let (w, _, pixels, _) = rsl_engine::output::read_exr(&exr).unwrap();
    let centre = pixels[(24 * w + 32) as usize];
    assert!((centre - glam::Vec3::new(0.5, 0.5, 1.0)).length() < 0.05, "centre {centre}");
    // The plain `rsl` does not know the name: the scene file is refused, naming it.
    let o = Command::new(env!("CARGO_BIN_EXE_rsl"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .arg("render")
        .arg(&scene)
        .arg("--out")
        .arg(dir.join("plain.exr"))
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && log.contains("unknown method `normals`"), "{log}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_example_method_is_a_drawing_of_the_viewer() {
    if rsl_gpu::testing::context_or_skip("an_example_method_is_a_drawing_of_the_viewer").is_none() {
        return;
    }
    let dir = out_dir("view");
    let png = dir.join("shot.png");
    let (ok, log) = run(example()
        .args(["view", "data/scenes/default.toml", "--drawing", "normals", "--screenshot"])
        .arg(&png)
        .args(["--quality", "draft"]));
    assert!(ok, "{log}");
    // The view shows normals: the floor (normal +Y) green, where the default drawing shows
    // it grey under the studio map.
    let green = |png: &std::path::Path| {
        let shot = image::open(png).unwrap().to_rgb8();
        shot.pixels().filter(|p| p[1] > p[0].saturating_add(40) && p[1] > p[2].saturating_add(40)).count()
    };
    assert!(green(&png) > 20_000, "{} green pixels: the view does not show the normals", green(&png));
    let plain = dir.join("rsl.png");
    let (ok, log) = run(example()
        .args(["view", "data/scenes/default.toml", "--drawing", "rsl", "--screenshot"])
        .arg(&plain)
        .args(["--quality", "draft"]));
    assert!(ok, "{log}");
    assert!(green(&plain) < 1_000, "{} green pixels in the default drawing", green(&plain));
    // A method the viewer cannot redraw on edits is refused by name, with the choices.
    let (ok, log) = run(example()
        .args(["view", "data/scenes/default.toml", "--drawing", "truth", "--screenshot"])
        .arg(dir.join("t.png")));
    assert!(!ok && log.contains("--drawing truth") && log.contains("normals"), "{log}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_readmes_table_of_methods_is_the_registrys() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).unwrap();
    let table = rsl_engine::registry::markdown_table();
    assert!(readme.contains(&table), "README.md's table of methods is not `rsl methods`'s; it prints:\n{table}");
}

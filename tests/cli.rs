//! End-to-end tests of the `rsl` command line.

use std::path::{Path, PathBuf};
use std::process::Command;

fn rsl() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rsl"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rsl-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(c: &mut Command) -> (bool, String, String) {
    let o = c.output().unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn scene_prints_the_default_scene_summary() {
    let (ok, out, err) = run(rsl().args(["scene", "data/scenes/default.toml", "--time", "1.5"]));
    assert!(ok, "{err}");
    for part in ["scene data/scenes/default.toml", "bunny", "suzanne", "sphere", "floor", "studio.exr", "at t = 1.5 s"]
    {
        assert!(out.contains(part), "summary lacks {part}:\n{out}");
    }
}

#[test]
fn scene_errors_are_reported_not_panicked() {
    let dir = out_dir("scene-errors");
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "[environment]\nconstant = [1.0, 1.0, 1.0]\n[camera]\neye = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 1.0]\n",
    )
    .unwrap();
    let (ok, _, err) = run(rsl().arg("scene").arg(&bad));
    assert!(!ok);
    assert!(err.contains("bad.toml") && err.contains("camera.target") && !err.contains("panicked"), "{err}");
}

#[test]
fn decompose_writes_json_and_png() {
    let dir = out_dir("decompose");
    let (json, png) = (dir.join("sky.json"), dir.join("sky.png"));
    let (ok, out, err) = run(rsl()
        .args(["decompose", "data/hdri/sky.exr", "--rsl", "30", "--grid", "16"])
        .arg("--json")
        .arg(&json)
        .arg("--png")
        .arg(&png));
    assert!(ok, "{err}");
    assert!(out.contains("30 RSLs from 6×16×16") && out.contains("energy error"), "{out}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let rsls = v["rsls"].as_array().unwrap();
    assert_eq!(rsls.len(), 30);
    for key in ["centre", "half_diagonal", "intensity", "energy", "solid_angle", "texels", "fit_error"] {
        assert!(rsls[0].get(key).is_some(), "RSL lacks {key}");
    }
    for c in 0..3 {
        assert!(v["energy_relative_error"][c].as_f64().unwrap() < 1e-6);
    }
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (512, 512));
    // Nothing but the two outputs: no temporary files left.
    let mut names: Vec<_> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    names.sort();
    assert_eq!(names, ["sky.json", "sky.png"]);
}

#[test]
fn decompose_rejects_bad_arguments_clearly() {
    let cases: [(&[&str], &str); 4] = [
        (&["decompose", "data/hdri/sky.exr", "--rsl", "0"], "--rsl must be between 1 and 6144"),
        (&["decompose", "data/hdri/sky.exr", "--rsl", "7000"], "--rsl must be between 1 and 6144"),
        (&["decompose", "data/hdri/sky.exr", "--grid", "0"], "--grid must be between 1 and 256"),
        (&["decompose", "data/hdri/nothere.exr"], "nothere.exr: cannot read environment map"),
    ];
    for (args, expect) in cases {
        let (ok, _, err) = run(rsl().args(args));
        assert!(!ok && err.contains(expect) && !err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn unwritable_outputs_are_errors_and_leave_nothing() {
    let dir = out_dir("unwritable");
    let blocker = dir.join("file");
    std::fs::write(&blocker, b"x").unwrap();
    let target = blocker.join("out.json");
    let (ok, _, err) = run(rsl().args(["decompose", "data/hdri/city.exr", "--grid", "8", "--json"]).arg(&target));
    assert!(!ok && err.contains("cannot write") && err.contains("out.json"), "{err}");
    assert!(!Path::new(&target).exists());
}

/// A small scene: one sphere in a constant environment.
fn small_scene(dir: &Path) -> PathBuf {
    let path = dir.join("small.toml");
    std::fs::write(
        &path,
        "[environment]\nconstant = [1.0, 1.0, 1.0]\n[camera]\neye = [0.0, 0.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n\
         width = 64\nheight = 48\n[[objects]]\nname = \"ball\"\nprimitive = { kind = \"sphere\", radius = 1.0, resolution = 8 }\n\
         material = { model = \"lambert\", albedo = [0.5, 0.5, 0.5] }\n",
    )
    .unwrap();
    path
}

#[test]
fn the_truth_with_one_sample_says_it_cannot_estimate_its_error() {
    let dir = out_dir("truth-spp1");
    let scene = small_scene(&dir);
    let args = |spp: &str, out: &str| {
        let (scene, out) = (scene.to_str().unwrap().to_string(), dir.join(out).to_str().unwrap().to_string());
        [
            "render",
            &scene,
            "--method",
            "truth",
            "--spp",
            spp,
            "--out",
            &out,
            "--vertex-out",
            &out.replace(".png", ".ply"),
        ]
        .map(String::from)
    };
    let (ok, _, err) = run(rsl().args(args("1", "one.png")));
    assert!(ok, "{err}");
    assert!(err.contains("standard error not estimated"), "{err}");
    assert!(!err.contains("0.000%"), "{err}");
    let (ok, _, err) = run(rsl().args(args("4", "four.png")));
    assert!(ok, "{err}");
    assert!(err.contains("per-pixel standard error") && err.contains("per-vertex standard error"), "{err}");
}

#[test]
fn a_run_that_works_prints_no_error_without_a_runtime_dir() {
    // Probing for a GPU loads the Vulkan driver, which complains on stderr when
    // XDG_RUNTIME_DIR is missing; a successful run must not show the word "error".
    let dir = out_dir("no-runtime-dir");
    let scene = small_scene(&dir);
    let out = dir.join("x.png");
    let (ok, _, err) = run(rsl().env_remove("XDG_RUNTIME_DIR").args([
        "render",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-cache",
    ]));
    assert!(ok, "{err}");
    assert!(!err.to_lowercase().contains("error"), "{err}");
}

//! End-to-end tests of the `rsl` command line.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;

fn rsl() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rsl"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

fn out_dir(name: &str) -> rsl_engine::sphere::scratch::Scratch {
    rsl_engine::sphere::scratch::Scratch::new(&format!("cli-{name}"))
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
fn objects_too_large_for_f32_geometry_are_errors_not_panics() {
    // A sphere 10²⁰ across passed the scene check and then panicked in the BVH builder; a
    // scale of 10³⁰, or a motion that carries an object that far, is the same.
    let dir = out_dir("huge-objects");
    let head = "[environment]\nconstant = [1.0, 1.0, 1.0]\nrsl_count = 4\n[camera]\neye = [0.0, 0.0, 5.0]\n\
                target = [0.0, 0.0, 0.0]\nwidth = 16\nheight = 12\n[[objects]]\nname = \"ball\"\n";
    let cases = [
        ("primitive = { kind = \"sphere\", radius = 1e20 }\n", "primitive", "beyond ±1e9"),
        ("primitive = { kind = \"sphere\", radius = 1.0 }\nscale = 1e30\n", "scale", "limit is 1e9"),
        ("primitive = { kind = \"sphere\", radius = 1.0 }\ntranslation = [3e9, 0.0, 0.0]\n", "translation", "1e9"),
        (
            "primitive = { kind = \"sphere\", radius = 1.0 }\n\
             motion = { orbit = { centre = [2e9, 0.0, 0.0], axis = [0.0, 1.0, 0.0], degrees_per_second = 1.0 } }\n",
            "motion.orbit",
            "1e9",
        ),
    ];
    for (k, (object, field, expect)) in cases.into_iter().enumerate() {
        let path = dir.join(format!("huge{k}.toml"));
        std::fs::write(&path, format!("{head}{object}")).unwrap();
        for command in ["scene", "render"] {
            let mut c = rsl();
            c.arg(command).arg(&path);
            if command == "render" {
                c.arg("--out").arg(dir.join(format!("huge{k}.png")));
            }
            let (ok, _, err) = run(&mut c);
            assert!(!ok, "{command} {object}: accepted");
            assert!(
                err.contains(&format!("huge{k}.toml")) && err.contains(field) && err.contains(expect),
                "{command} {object}: {err}"
            );
            assert!(!err.contains("panicked"), "{err}");
        }
    }
}

#[test]
fn a_speck_scaled_by_1e_minus_30_renders_finite_radiance() {
    // The other extreme of scale: a torus 10⁻³⁰ across (fields, BVH, shading) beside a ball.
    let dir = out_dir("tiny-scale");
    let scene = dir.join("speck.toml");
    std::fs::write(
        &scene,
        "[environment]\nconstant = [1.0, 1.0, 1.0]\nrsl_count = 4\n[camera]\neye = [0.0, 0.0, 5.0]\n\
         target = [0.0, 0.0, 0.0]\nwidth = 16\nheight = 12\n[[objects]]\nname = \"speck\"\n\
         primitive = { kind = \"torus\", major_radius = 0.5, minor_radius = 0.2, resolution = 6 }\nscale = 1e-30\n\
         [[objects]]\nname = \"ball\"\nprimitive = { kind = \"sphere\", radius = 1.0, resolution = 6 }\n\
         translation = [0.0, 0.0, -2.0]\n",
    )
    .unwrap();
    let ply = dir.join("speck.ply");
    let (ok, _, err) = run(rsl().arg("render").arg(&scene).arg("--no-cache").arg("--vertex-out").arg(&ply));
    assert!(ok, "{err}");
    // `compare` refuses a file with a non-finite value, naming it (below).
    let (ok, out, err) = run(rsl().arg("compare").arg(&ply).arg(&ply));
    assert!(ok && out.contains("relative L2 0.000000"), "{out}{err}");
}

#[test]
fn compare_names_the_file_and_vertex_that_is_not_finite() {
    let dir = out_dir("nan-ply");
    let positions = [glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y];
    let normals = [glam::Vec3::Z; 3];
    let write = |name: &str, middle: f32| {
        let radiance = [glam::Vec3::ONE, glam::Vec3::splat(middle), glam::Vec3::ONE];
        let object = rsl_engine::ply::PlyObject {
            positions: &positions,
            normals: &normals,
            radiance: &radiance,
            indices: &[0, 1, 2],
        };
        let p = dir.join(name);
        rsl_engine::ply::write(&p, &[object]).unwrap();
        p
    };
    let (good, bad) = (write("good.ply", 1.0), write("bad.ply", f32::NAN));
    let (ok, _, err) = run(rsl().arg("compare").arg(&bad).arg(&good));
    assert!(!ok && err.contains("bad.ply") && err.contains("vertex 1") && err.contains("not finite"), "{err}");
    let (ok, _, err) = run(rsl().arg("compare").arg(&good).arg(&bad));
    assert!(!ok && err.contains("bad.ply") && err.contains("vertex 1"), "{err}");
    // A black reference has no relative error (it printed "inf dB" and exited 0).
    let black = dir.join("black.ply");
    let radiance = [glam::Vec3::ZERO; 3];
    let object = rsl_engine::ply::PlyObject {
        positions: &positions,
        normals: &normals,
        radiance: &radiance,
        indices: &[0, 1, 2],
    };
    rsl_engine::ply::write(&black, &[object]).unwrap();
    let (ok, _, err) = run(rsl().arg("compare").arg(&good).arg(&black));
    assert!(!ok && err.contains("black.ply") && err.contains("black"), "{err}");
    // Another scene's vertices are refused, not broken down by its objects.
    let scene = common::small_scene(&dir);
    let (ok, _, err) = run(rsl().arg("compare").arg(&good).arg(&good).arg("--breakdown").arg("--scene").arg(&scene));
    assert!(!ok && err.contains("not this scene's vertices") && err.contains("small.toml"), "{err}");
}

#[test]
fn warnings_show_by_default_once_without_colour_and_quiet_hides_them() {
    // A cache "folder" that is a file: every field and light set "cannot be cached", which
    // used to be said only with RUST_LOG set.
    let dir = out_dir("warnings");
    let not_a_folder = dir.join("cache-file");
    std::fs::write(&not_a_folder, b"not a folder").unwrap();
    let scene = dir.join("s.toml");
    std::fs::write(
        &scene,
        "[environment]\nconstant = [1.0, 1.0, 1.0]\nrsl_count = 4\n[camera]\neye = [0.0, 1.0, 3.0]\n\
         target = [0.0, 0.0, 0.0]\nwidth = 16\nheight = 12\n[[objects]]\nname = \"torus\"\n\
         primitive = { kind = \"torus\", major_radius = 0.5, minor_radius = 0.2, resolution = 8 }\n",
    )
    .unwrap();
    let render = |quiet: bool| {
        let mut c = rsl();
        c.env_remove("RUST_LOG").arg("render").arg(&scene).arg("--out").arg(dir.join("s.png"));
        c.arg("--cache").arg(&not_a_folder);
        if quiet {
            c.arg("--quiet");
        }
        run(&mut c)
    };
    let (ok, _, err) = render(false);
    assert!(ok, "{err}");
    let warnings: Vec<&str> = err.lines().filter(|l| l.contains("WARN") && l.contains("cannot cache")).collect();
    assert!(!warnings.is_empty(), "no warning shown: {err}");
    assert!(!err.contains('\u{1b}'), "colour codes in a pipe: {err:?}");
    let mut unique = warnings.clone();
    unique.sort();
    unique.dedup();
    assert_eq!(unique.len(), warnings.len(), "a warning printed twice: {warnings:?}");
    let (ok, _, err) = render(true);
    assert!(ok, "{err}");
    assert!(!err.contains("WARN"), "--quiet still warns: {err}");
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

#[test]
fn inputs_that_would_run_away_are_refused_before_any_work() {
    let dir = out_dir("bounded");
    let scene = common::small_scene(&dir);
    let fails = |c: &mut Command, expect: &[&str]| {
        let (ok, _, err) = run(c);
        assert!(!ok, "accepted: {c:?}");
        for e in expect {
            assert!(err.contains(e), "{c:?}: no \"{e}\" in {err}");
        }
        assert!(!err.contains("panicked"), "{err}");
    };
    // Samples per point that would size buffers by billions.
    let png = dir.join("p.png");
    fails(
        rsl().arg("render").arg(&scene).args(["--method", "truth", "--spp", "4294967295", "--out"]).arg(&png),
        &["--spp", "65536"],
    );
    // An animation whose GIF has a folder in its way: found before the first frame, and no
    // numbered frame is left behind.
    let anim = dir.join("anim");
    std::fs::create_dir_all(anim.join("f.gif")).unwrap();
    fails(
        rsl().arg("render").arg(&scene).args(["--frames", "0..100000", "--out"]).arg(anim.join("f.png")),
        &["f.gif", "folder is in the way"],
    );
    assert_eq!(std::fs::read_dir(&anim).unwrap().count(), 1, "only the folder in the way");
    // An animation of billions of frames.
    fails(
        rsl().arg("render").arg(&scene).args(["--frames", "0..4294967295", "--out"]).arg(dir.join("g.png")),
        &["--frames", "4294967295 frames", "100000"],
    );
    // Outputs that would carry PNG bytes under another format's name.
    fails(
        rsl().args(["compare", "a.exr", "b.exr", "--heatmap"]).arg(dir.join("h.jpg")),
        &["--heatmap", "h.jpg", ".png"],
    );
    fails(rsl().args(["decompose", "data/hdri/city.exr", "--grid", "8", "--png"]).arg(dir.join("fig.exr")), &[".png"]);
    assert!(!png.exists());
    // More RSLs than the environment grid has texels: an error, not a silent cap.
    fails(rsl().arg("render").arg(&scene).args(["--rsl", "100000", "--out"]).arg(&png), &["100000", "texels"]);
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let head = "[camera]\neye = [0.0, 0.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n";
    let ball = "[[objects]]\nname = \"ball\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\n\
                material = { model = \"ggx\", alpha = 0.2 }\n";
    // A frame of 16384² pixels.
    let huge = write(
        "huge.toml",
        &format!("[environment]\nconstant = [1.0, 1.0, 1.0]\n{head}width = 16384\nheight = 16384\n{ball}"),
    );
    fails(rsl().arg("scene").arg(&huge), &["huge.toml", "camera.width", "33554432"]);
    // An anisotropic BRDF table of 512² cells and 128×128 views (17 GB): an error naming the
    // knobs, before allocating.
    let tables = write(
        "tables.toml",
        &format!(
            "[quality]\npreset = \"draft\"\nbrdf_resolution = 512\nview_samples = 128\n\
             [environment]\nconstant = [1.0, 1.0, 1.0]\nrsl_count = 4\n{head}[[objects]]\nname = \"brushed\"\n\
             primitive = {{ kind = \"sphere\", radius = 1.0 }}\n\
             material = {{ model = \"ward\", alpha_x = 0.1, alpha_y = 0.3 }}\n"
        ),
    );
    fails(
        rsl().arg("render").arg(&tables).arg("--no-cache").arg("--out").arg(&png),
        &["BRDF table", "GB", "RSL_MAX_PREPARE_BYTES", "brdf_resolution or view_samples"],
    );
    // Drawing per pixel keeps every light's cover at every vertex: bounded like a table (a
    // 40,962-vertex ball and 1,500 RSLs is 0.25 GB; the limit lowered to 0.1 GB for the test).
    let dense = write(
        "dense.toml",
        &format!(
            "[quality]\npreset = \"draft\"\nenv_grid = 16\n[environment]\nconstant = [1.0, 1.0, 1.0]\nrsl_count = 1500\n\
             {head}[[objects]]\nname = \"ball\"\nprimitive = {{ kind = \"sphere\", radius = 1.0, resolution = 143 }}\n\
             material = {{ model = \"ggx\", alpha = 0.2 }}\n"
        ),
    );
    // So are the transport lobes of `--method lobe` (5.2 KB per vertex: 0.21 GB here).
    for (method, what, instead) in
        [("pixel", "drawing per pixel", "method \"rsl\""), ("lobe", "transport lobes", "method \"hybrid\"")]
    {
        fails(
            rsl()
                .env("RSL_MAX_PREPARE_BYTES", "100000000")
                .arg("render")
                .arg(&dense)
                .arg("--no-cache")
                .arg("--method")
                .arg(method)
                .arg("--out")
                .arg(&png),
            &[what, "GB", "RSL_MAX_PREPARE_BYTES", instead],
        );
    }
    // Radiance that would overflow f32 once summed: an error naming the input at fault.
    let bright = write(
        "bright.toml",
        &format!("[environment]\nconstant = [1.0, 1.0, 1.0]\nintensity = 1e38\nrsl_count = 4\n{head}{ball}"),
    );
    fails(rsl().arg("render").arg(&bright).arg("--no-cache").arg("--out").arg(&png), &["environment.intensity"]);
    // A TOML type error names its field, not only its line.
    let typed =
        write("typed.toml", &format!("[environment]\nconstant = [1.0, 1.0, 1.0]\nrsl_count = \"thirty\"\n{head}"));
    fails(rsl().arg("scene").arg(&typed), &["typed.toml:3", "environment.rsl_count"]);
    // A scene file that is a device or a folder.
    #[cfg(unix)]
    fails(rsl().args(["scene", "/dev/zero"]), &["/dev/zero", "not a regular file"]);
    fails(rsl().arg("scene").arg(&dir), &["is a folder"]);
    assert!(!png.exists(), "nothing was written");
}

#[test]
fn a_lobe_narrower_than_its_tables_cells_is_a_warning_not_a_silent_blur() {
    // α = 10⁻⁴, the smallest accepted: a lobe of 2·10⁻⁴ rad against cells of 0.03 rad.
    let dir = out_dir("narrow-lobe");
    let scene = dir.join("mirror.toml");
    std::fs::write(
        &scene,
        "[environment]\nconstant = [1.0, 1.0, 1.0]\nrsl_count = 4\n[camera]\neye = [0.0, 0.0, 3.0]\n\
         target = [0.0, 0.0, 0.0]\nwidth = 16\nheight = 12\n[[objects]]\nname = \"mirror\"\n\
         primitive = { kind = \"sphere\", radius = 1.0, resolution = 8 }\n\
         material = { model = \"ggx\", alpha = 1e-4, specular = [0.9, 0.9, 0.9] }\n",
    )
    .unwrap();
    let (ok, _, err) = run(rsl()
        .env_remove("RUST_LOG")
        .arg("render")
        .arg(&scene)
        .arg("--no-cache")
        .arg("--out")
        .arg(dir.join("m.png")));
    assert!(ok, "{err}");
    assert!(err.contains("object mirror") && err.contains("narrower than one cell"), "{err}");
    assert_eq!(err.matches("narrower than one cell").count(), 1, "once: {err}");
}

#[test]
fn the_truth_with_one_sample_says_it_cannot_estimate_its_error() {
    let dir = out_dir("truth-spp1");
    let scene = common::small_scene(&dir);
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
    let scene = common::small_scene(&dir);
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

#[test]
fn the_default_method_is_auto_on_the_cpu_and_on_a_gpu() {
    let dir = out_dir("default-method");
    let scene = common::small_scene(&dir);
    let (ok, _, err) = run(rsl().arg("render").arg(&scene).args(["--device", "cpu", "--out"]).arg(dir.join("a.png")));
    assert!(ok, "{err}");
    assert!(err.contains("drawing with each object's own method on the CPU"), "auto draws by default:\n{err}");
    // With --oracle the default is the RSL path whose parts it replaces.
    let (ok, _, err) = run(rsl()
        .arg("render")
        .arg(&scene)
        .args(["--device", "cpu", "--oracle", "brdf", "--out"])
        .arg(dir.join("o.png")));
    assert!(ok, "{err}");
    // Where a GPU is asked for, auto runs there: the RSL sum per pixel shaded and drawn on it.
    if rsl_gpu::testing::context_or_skip("the_default_method_is_auto_on_the_cpu_and_on_a_gpu").is_some() {
        let (ok, _, err) =
            run(rsl().arg("render").arg(&scene).args(["--device", "gpu", "--out"]).arg(dir.join("g.png")));
        assert!(ok, "--device gpu without --method: {err}");
        assert!(err.contains("each object's own method: the lobes' vertices on the CPU"), "auto on the GPU:\n{err}");
    }
}

#[test]
fn explain_says_how_each_object_is_drawn_and_why_for_every_per_object_method() {
    // The default scene: a Lambert floor, and three glossy objects.
    let glossy = ["bunny", "suzanne", "sphere"];
    let dir = out_dir("explain");
    // (`lobe` explains through the hybrid's code; its transport fit would add half a minute.)
    for (method, glossy_how) in [("auto", "per pixel"), ("hybrid", "vMF lobes")] {
        let out = dir.join(format!("{method}.png"));
        let (ok, _, err) = run(rsl()
            .args(["render", "data/scenes/default.toml", "--quality", "draft", "--device", "cpu", "--method", method])
            .args(["--explain", "--out"])
            .arg(&out));
        assert!(ok, "{method}: {err}");
        let line = |name: &str| {
            err.lines()
                .find(|l| l.starts_with(&format!("{name}: ")))
                .unwrap_or_else(|| panic!("{method}: no line for {name}:\n{err}"))
                .to_string()
        };
        let floor = line("floor");
        assert!(floor.contains("RSL at the vertices") && floor.contains("Lambertian"), "{method}: {floor}");
        for name in glossy {
            let l = line(name);
            assert!(l.contains(" — ") && !l.contains("Lambertian"), "{method}: {l}");
            if method != "auto" {
                assert!(l.contains(glossy_how), "{method}: {l}");
            }
        }
        if method == "auto" {
            // auto gives its measurement of both drawings for each glossy object, and draws
            // one of them (at least) per pixel or with lobes.
            assert!(glossy.iter().all(|n| line(n).contains("the RSL sum per pixel is")), "{err}");
            assert!(glossy.iter().all(|n| line(n).contains("the lobes")), "{err}");
            assert!(glossy.iter().any(|n| line(n).contains(glossy_how) || line(n).contains("lobes")), "{err}");
        }
    }
}

#[test]
fn size_replaces_the_cameras_and_bad_sizes_are_refused_by_name() {
    let dir = out_dir("size");
    let scene = common::small_scene(&dir);
    let png = dir.join("s.png");
    let (ok, _, err) = run(rsl().arg("render").arg(&scene).args(["--size", "40x30", "--out"]).arg(&png));
    assert!(ok, "{err}");
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (40, 30));
    for (bad, says) in [("40", "WIDTHxHEIGHT"), ("0x30", "`0`"), ("16384x16384", "more than the limit")] {
        let (ok, _, err) = run(rsl().arg("render").arg(&scene).args(["--size", bad, "--out"]).arg(&png));
        assert!(!ok && err.contains("--size") && err.contains(says), "{bad}: {err}");
    }
}

#[test]
fn no_output_overwrites_an_input_or_another_output() {
    let dir = out_dir("inputs");
    let map = dir.join("m.exr");
    std::fs::copy("data/hdri/sky.exr", &map).unwrap();
    let before = std::fs::read(&map).unwrap();
    let scene = common::ball_scene(&dir, "s.toml", |b| b.map("m.exr"));
    let refused = |c: &mut Command, says: &[&str]| {
        let (ok, _, err) = run(c);
        assert!(!ok, "accepted: {c:?}");
        for s in says {
            assert!(err.contains(s), "{c:?}: no \"{s}\" in {err}");
        }
    };
    // The scene's own map as the image, by another spelling of its path.
    let over = dir.join(".").join("m.exr");
    refused(rsl().arg("render").arg(&scene).arg("--out").arg(&over), &["--out", "does not write over its inputs"]);
    refused(rsl().arg("decompose").arg(&map).arg("--json").arg(&map), &["--json", "the map to decompose"]);
    let f = dir.join("f.png");
    refused(rsl().arg("decompose").arg(&map).arg("--json").arg(&f).arg("--png").arg(&f), &["both name"]);
    assert_eq!(std::fs::read(&map).unwrap(), before, "the map is untouched");
    assert!(!f.exists());
    // A screenshot into a folder that does not exist is refused as an image is, not made.
    let missing = dir.join("missing");
    refused(rsl().arg("view").arg(&scene).arg("--screenshot").arg(missing.join("v.png")), &["does not exist"]);
    assert!(!missing.exists());
}

#[test]
fn an_anisotropic_object_is_drawn_by_every_per_pixel_method_which_says_how() {
    // The lobes fit isotropic BRDFs only: these methods failed, naming no object.
    let dir = out_dir("anisotropic");
    let scene = dir.join("a.toml");
    let map = std::path::absolute("data/hdri/sky.exr").unwrap();
    std::fs::write(
        &scene,
        format!(
            "[environment]\nmap = {map:?}\n[camera]\neye = [0.0, 0.5, 3.0]\ntarget = [0.0, 0.0, 0.0]\n\
             width = 48\nheight = 36\n[[objects]]\nname = \"brushed\"\n\
             primitive = {{ kind = \"sphere\", radius = 0.8, resolution = 10 }}\n\
             material = {{ model = \"ward\", alpha_x = 0.08, alpha_y = 0.4, specular = [0.5, 0.5, 0.5] }}\n"
        ),
    )
    .unwrap();
    for method in ["auto", "hybrid", "lobe"] {
        let png = dir.join(format!("{method}.png"));
        let (ok, _, err) =
            run(rsl().arg("render").arg(&scene).args(["--method", method, "--explain", "--out"]).arg(&png));
        assert!(ok, "{method}: {err}");
        assert!(err.contains("brushed: the RSL sum per pixel (pixel) — anisotropic"), "{method}: {err}");
    }
}

#[test]
fn a_mesh_whose_normals_point_against_its_winding_is_a_warning() {
    // One triangle winding toward +z whose file normals point to −z (a ball of such
    // triangles rendered 470 % off its own truth, and black, with no word said).
    let dir = out_dir("inward");
    let mut bin = Vec::new();
    for v in
        [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, -1.0], [0.0, 0.0, -1.0]]
    {
        bin.extend(v.iter().flat_map(|c| c.to_le_bytes()));
    }
    std::fs::write(dir.join("t.bin"), &bin).unwrap();
    std::fs::write(
        dir.join("t.gltf"),
        r#"{"asset":{"version":"2.0"},"buffers":[{"uri":"t.bin","byteLength":72}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":72}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":0,"byteOffset":36,"componentType":5126,"count":3,"type":"VEC3"}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1},"mode":4}]}],
"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0}"#,
    )
    .unwrap();
    let scene = dir.join("s.toml");
    std::fs::write(
        &scene,
        "[environment]\nconstant = [1.0, 1.0, 1.0]\n[camera]\neye = [0.0, 0.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n\
         [[objects]]\nname = \"t\"\nmesh = \"t.gltf\"\n",
    )
    .unwrap();
    let (ok, _, err) = run(rsl().env_remove("RUST_LOG").arg("scene").arg(&scene));
    assert!(ok, "{err}");
    assert!(
        err.contains("t.gltf")
            && err.contains("1 of its 1 triangles point against their winding; those triangles are rewound"),
        "{err}"
    );
}

#[test]
fn quiet_prints_nothing_but_errors() {
    let dir = out_dir("quiet");
    let scene = common::small_scene(&dir);
    let (ok, _, err) = run(rsl().arg("-q").arg("render").arg(&scene).arg("--out").arg(dir.join("q.png")));
    assert!(ok, "{err}");
    assert!(err.trim().is_empty(), "--quiet printed: {err}");
    let (ok, _, err) = run(rsl().arg("render").arg(&scene).arg("--out").arg(dir.join("q.png")));
    assert!(ok && err.contains("wrote"), "{err}");
}

#[test]
fn flat_occluders_are_not_held_to_the_size_of_a_field_they_never_build() {
    // Two planes, one above the other, with occluder fields of 3.2 GB each as tables: a
    // flat occluder is its closed form, so the limit (here 64 MB) does not apply to it.
    let dir = out_dir("flat-ovdf");
    let scene = dir.join("f.toml");
    std::fs::write(
        &scene,
        "[quality]\npreset = \"draft\"\novdf_directions = 256\n[environment]\nconstant = [1.0, 1.0, 1.0]\n\
         [camera]\neye = [0.0, 3.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nwidth = 32\nheight = 24\n\
         [[objects]]\nname = \"floor\"\nprimitive = { kind = \"plane\", size = 4.0, resolution = 4 }\n\
         [[objects]]\nname = \"roof\"\nprimitive = { kind = \"plane\", size = 1.0, resolution = 2 }\ntranslation = [0.0, 1.0, 0.0]\n",
    )
    .unwrap();
    let (ok, _, err) = run(rsl()
        .env("RSL_MAX_PREPARE_BYTES", "64000000")
        .arg("render")
        .arg(&scene)
        .arg("--no-cache")
        .arg("--out")
        .arg(dir.join("f.png")));
    assert!(ok, "{err}");
}

#[test]
fn the_truth_follows_the_bounces_asked_for() {
    let dir = out_dir("bounces");
    // The ball over a white floor: each sees the other.
    let scene = common::ball_scene(&dir, "floor.toml", |b| {
        b.constant(glam::Vec3::ONE).object(
            rsl_scene::build::ObjectBuilder::plane("floor", 4.0, 8)
                .translation(glam::Vec3::new(0.0, -1.0, 0.0))
                .material(rsl_scene::Brdf::Lambert { albedo: glam::Vec3::splat(0.8) }),
        )
    });
    let mean = |method: &str, bounces: &str| {
        let ply = dir.join(format!("{method}{bounces}.ply"));
        let (ok, _, err) = run(rsl()
            .arg("render")
            .arg(&scene)
            .args(["--method", method, "--spp", "16", "--bounces", bounces, "--vertex-out"])
            .arg(&ply));
        assert!(ok, "{err}");
        let data = rsl_engine::ply::read(&std::fs::read(&ply).unwrap()).unwrap();
        data.vertices.iter().map(|v| f64::from(v[6] + v[7] + v[8])).sum::<f64>()
    };
    // Light one bounce off the other surfaces only adds, in the truth and in the default
    // method alike, and by about as much.
    let (direct, bounced) = (mean("truth", "0"), mean("truth", "1"));
    assert!(bounced > direct, "{bounced} against {direct}");
    let (drawn, gathered) = (mean("auto", "0"), mean("auto", "1"));
    assert!(gathered > drawn, "{gathered} against {drawn}");
    let (truth_gain, gain) = (bounced - direct, gathered - drawn);
    assert!((gain - truth_gain).abs() < 0.25 * truth_gain, "gathered {gain}, the truth's bounce {truth_gain}");
    let (ok, _, err) = run(rsl().arg("render").arg(&scene).args(["--method", "truth", "--bounces", "9"]));
    assert!(!ok && err.contains("--bounces"), "{err}");
}

#[test]
fn precompute_shards_take_every_nth_scene_into_one_cache() {
    let dir = out_dir("precompute-shard");
    let a = common::ball_scene(&dir, "a.toml", |b| b.constant(glam::Vec3::ONE));
    let b = common::ball_scene(&dir, "b.toml", |b| b.constant(glam::Vec3::splat(0.5)));
    let cache = dir.join("cache");
    for (k, scene) in [(0, &a), (1, &b)] {
        let (ok, _, err) =
            run(rsl().arg("precompute").arg(&a).arg(&b).args(["--shard", &format!("{k}/2"), "--cache"]).arg(&cache));
        assert!(ok, "{err}");
        assert!(err.contains("prepares 1 of 2 scene(s)"), "{err}");
        assert!(err.contains(&scene.display().to_string()), "shard {k} prepared another scene: {err}");
    }
    let (ok, _, err) = run(rsl().arg("precompute").arg(&a).args(["--shard", "0/2", "--no-cache"]));
    assert!(!ok && err.contains("--shard"), "{err}");
}

/// `rsl precompute` makes what the method draws with beyond the engine's data: for a glossy
/// ball the scene draws by the lobe path, its transport lobes, into the cache (and says how
/// each object will be drawn); `rsl render` then reads them instead of fitting them, and
/// `--method lobe` asks for them whatever the scene's methods.
#[test]
#[cfg(unix)]
fn precompute_fits_the_transport_lobes_the_render_then_reads() {
    use rsl_scene::build::{ObjectBuilder, SceneBuilder};
    let dir = out_dir("precompute-lobes");
    let glossy = rsl_scene::Brdf::Ggx { alpha: 0.2, specular: glam::Vec3::splat(0.8), diffuse: glam::Vec3::ZERO };
    let scene = SceneBuilder::new()
        .preset(rsl_scene::Preset::Draft)
        .constant(glam::Vec3::ONE)
        .rsl_count(8)
        .camera(glam::Vec3::new(0.0, 0.0, 3.0), glam::Vec3::ZERO)
        .image(32, 24)
        .object(ObjectBuilder::sphere("ball", 1.0, 8).material(glossy).method(rsl_scene::ObjectMethod::LOBE))
        .write(dir.join("lobes.toml"))
        .unwrap();
    let cache = dir.join("cache");
    let _ = std::fs::remove_dir_all(&cache);
    // Each file with its inode: written again (atomically, by a rename), a file gets a new
    // one; read, it keeps it (a read sets its modification time, for the cache's bound).
    let tlobes = || -> Vec<(std::path::PathBuf, u64)> {
        use std::os::unix::fs::MetadataExt;
        let mut v: Vec<_> = std::fs::read_dir(&cache)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with("tlobe-"))
            .map(|p| {
                let ino = std::fs::metadata(&p).unwrap().ino();
                (p, ino)
            })
            .collect();
        v.sort();
        v
    };
    let (ok, _, err) = run(rsl().arg("precompute").arg(&scene).arg("--cache").arg(&cache));
    assert!(ok, "{err}");
    assert!(err.contains("prepared for --method auto"), "{err}");
    assert!(err.contains("ball: transport lobes shadowed by the fields (lobe)"), "{err}");
    let fitted = tlobes();
    assert_eq!(fitted.len(), 1, "{fitted:?}");
    let png = dir.join("lobes.png");
    let (ok, _, err) =
        run(rsl().arg("render").arg(&scene).arg("--cache").arg(&cache).args(["--device", "cpu", "--out"]).arg(&png));
    assert!(ok, "{err}");
    assert_eq!(tlobes(), fitted, "the render fitted the transport lobes again (their file was written anew)");
    let (ok, _, err) = run(rsl().arg("precompute").arg(&scene).args(["--method", "lobe", "--cache"]).arg(&cache));
    assert!(ok, "{err}");
    assert!(err.contains("prepared for --method lobe"), "{err}");
    assert_eq!(tlobes(), fitted, "--method lobe fitted the held lobes again");
    let (ok, _, err) = run(rsl().arg("precompute").arg(&scene).args(["--method", "nosuch", "--no-cache"]));
    assert!(!ok && err.contains("nosuch"), "{err}");
}

/// The cache folder stays within `$RSL_CACHE_MAX_MB`: a run that writes past it removes the
/// least recently used of rsl's files (not its own, not another program's) and says so; a
/// bound that is not a number is an error naming the variable.
#[test]
fn the_cache_folder_stays_within_its_bound() {
    let dir = out_dir("cache-bound");
    let a = common::ball_scene(&dir, "a.toml", |b| b.constant(glam::Vec3::ONE).rsl_count(8));
    let b = common::ball_scene(&dir, "b.toml", |b| b.constant(glam::Vec3::splat(0.5)).rsl_count(8));
    let cache = dir.join("cache");
    let _ = std::fs::remove_dir_all(&cache);
    std::fs::create_dir_all(&cache).unwrap();
    let foreign = cache.join("notes.txt");
    std::fs::write(&foreign, "not rsl's").unwrap();
    let files = || -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(&cache).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    };
    let (ok, _, err) = run(rsl().arg("precompute").arg(&a).arg("--cache").arg(&cache).env("RSL_CACHE_MAX_MB", "2"));
    assert!(ok, "{err}");
    assert!(err.contains("2 file(s)") && err.contains("(of its 2 MB bound, $RSL_CACHE_MAX_MB)"), "{err}");
    let first = files();
    assert_eq!(first.len(), 3, "a light set and the ball's (empty) self-visibility beside the foreign file: {first:?}");
    // The second scene's light set (about 270 bytes) and the ball's field it shares (44)
    // fit 419 bytes; with the first's light set they do not.
    let (ok, _, err) =
        run(rsl().arg("precompute").arg(&b).arg("--cache").arg(&cache).env("RSL_CACHE_MAX_MB", "0.0004"));
    assert!(ok, "{err}");
    assert!(err.contains("removed the 1 least recently used file(s)") && err.contains("RSL_CACHE_MAX_MB"), "{err}");
    let second = files();
    assert_eq!(second.len(), 3, "{second:?}");
    assert!(foreign.exists());
    assert!(first.iter().filter(|f| f.starts_with("rsl-")).all(|f| !second.contains(f)), "{first:?} → {second:?}");
    // Without a bound the first comes back beside it.
    let (ok, _, err) = run(rsl().arg("precompute").arg(&a).arg("--cache").arg(&cache).env("RSL_CACHE_MAX_MB", "0"));
    assert!(ok, "{err}");
    assert!(err.contains("3 file(s)") && err.contains("(no bound)"), "{err}");
    assert_eq!(files().len(), 4, "{:?}", files());
    let (ok, _, err) = run(rsl().arg("precompute").arg(&a).arg("--cache").arg(&cache).env("RSL_CACHE_MAX_MB", "lots"));
    assert!(!ok && err.contains("RSL_CACHE_MAX_MB") && err.contains("lots"), "{err}");
}

/// `rsl render model.gltf` opens a glTF file as a scene: its objects, materials and camera,
/// lit by `--env`'s map or else the bundled one; what the import leaves out is said once
/// each; `rsl scene` lists the objects; a missing map and a missing camera are named.
#[test]
fn a_gltf_file_renders_as_a_scene_with_its_camera_and_an_environment_map() {
    let dir = out_dir("gltf-scene");
    let model = rsl_scene::build::write_sample_gltf(&dir).unwrap();
    let png = dir.join("model.png");
    let (ok, _, err) = run(rsl()
        .args(["render"])
        .arg(&model)
        .args(["--env", "data/hdri/studio.exr", "--size", "48x32"])
        .args(["--device", "cpu", "--out"])
        .arg(&png));
    assert!(ok, "{err}");
    assert!(png.is_file());
    assert_eq!(err.matches("KHR_materials_emissive_strength is not read").count(), 1, "{err}");
    let (ok, out, err) = run(rsl().arg("scene").arg(&model));
    assert!(ok, "{err}");
    for part in ["Tet#2", "Quad/1", "sample.gltf (mesh 1 primitive 0)"] {
        assert!(out.contains(part), "summary lacks {part}:\n{out}");
    }
    assert!(out.contains("environment  bundled map studio"), "{out}");
    let (ok, _, err) = run(rsl().args(["render"]).arg(&model).args(["--env", "no/such/map.exr", "--out"]).arg(&png));
    assert!(!ok && err.contains("no/such/map.exr") && err.contains("no such environment map"), "{err}");
    // Without --env, the bundled map lights it; --camera numbers the file's cameras.
    let bundled = dir.join("bundled.png");
    let (ok, _, err) = run(rsl()
        .args(["render"])
        .arg(&model)
        .args(["--camera", "0", "--size", "48x32", "--device", "cpu", "--out"])
        .arg(&bundled));
    assert!(ok && bundled.is_file(), "{err}");
    let (ok, _, err) = run(rsl().args(["render"]).arg(&model).args(["--camera", "3", "--out"]).arg(&png));
    assert!(!ok && err.contains("camera 3 was asked for, but the file has 1 perspective camera"), "{err}");
    // A textured asset (a checker floor, a textured metal cube, a camera), rendered and
    // screenshotted as a user opens it: the checker's two colours both show on the floor.
    let textured = rsl_scene::build::write_textured_sample(&dir).unwrap();
    let exr = dir.join("textured.exr");
    let (ok, _, err) =
        run(rsl().arg("render").arg(&textured).args(["--size", "64x48", "--device", "cpu", "--out"]).arg(&exr));
    assert!(ok, "{err}");
    let image = image::open(&exr).expect("an EXR").into_rgb32f();
    // The floor fills the image's lower third: grey squares (blue ≈ red) and blue ones.
    let (mut grey, mut blue) = (0, 0);
    for y in 36..48 {
        for x in 0..64 {
            let [r, _, b] = image.get_pixel(x, y).0;
            // The studio map is a little cool: its grey squares' blue is up to 1.4 × their red;
            // the blue squares' is 27 × (sRGB 40 and 200).
            grey += usize::from(r > 0.0 && b < 2.0 * r);
            blue += usize::from(b > 5.0 * r.max(1e-6));
        }
    }
    assert!(grey > 150 && blue > 150, "grey {grey}, blue {blue} of 768 floor pixels");
    // The viewer's headless screenshot of each generated asset (the one with instancing, an
    // external texture and a gold metal; the textured one) and of a bundled model.
    for (model, name) in
        [(&textured, "textured"), (&model, "sample"), (&PathBuf::from("data/models/bunny.glb"), "bunny")]
    {
        let shot = dir.join(format!("{name}-view.png"));
        let (ok, _, err) = run(rsl().arg("view").arg(model).arg("--screenshot").arg(&shot));
        assert!(ok && shot.is_file(), "{name}: {err}");
    }
    // The sample with instancing as linear radiance too.
    let exr = dir.join("sample.exr");
    let (ok, _, err) =
        run(rsl().arg("render").arg(&model).args(["--size", "48x32", "--device", "cpu", "--out"]).arg(&exr));
    assert!(ok && image::open(&exr).is_ok(), "{err}");
    // A bundled model as a user opens it: no scene file, no map, linear radiance out.
    let exr = dir.join("bunny.exr");
    let (ok, _, err) =
        run(rsl().args(["render", "data/models/bunny.glb", "--size", "40x30", "--device", "cpu", "--out"]).arg(&exr));
    assert!(ok, "{err}");
    let image = image::open(&exr).expect("an EXR").into_rgb32f();
    assert_eq!(image.dimensions(), (40, 30));
    // The framed camera sees the bunny in the middle, lit (not the background's black).
    assert!(image.get_pixel(20, 15).0.iter().all(|&c| c > 0.0 && c.is_finite()), "{:?}", image.get_pixel(20, 15));
    std::fs::remove_dir_all(&dir).unwrap();
}

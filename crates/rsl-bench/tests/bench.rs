//! The study end to end on a small scene: results, reuse of the truth, resuming.

use glam::Vec3;
use rsl_bench::config::{Sweep, configs};
use rsl_bench::{BenchOptions, Row, run};
use rsl_scene::build::{ObjectBuilder, SceneBuilder};
use rsl_scene::{Brdf, Preset, Primitive};
use std::path::PathBuf;

fn dir(name: &str) -> rsl_sphere::scratch::Scratch {
    rsl_sphere::scratch::Scratch::new(&format!("bench-test-{name}"))
}

/// A ball over a plane under the bundled studio map, at draft quality.
fn scene(dir: &std::path::Path) -> PathBuf {
    ball_scene(&dir.join("small.toml"), 0.3)
}

/// [`scene`] with the ball's GGX roughness `alpha`, written to `path`.
fn ball_scene(path: &std::path::Path, alpha: f32) -> PathBuf {
    write_scene(
        path,
        Vec3::new(0.0, 2.0, 3.0),
        [
            ObjectBuilder::plane("floor", 3.0, 12).material(Brdf::Lambert { albedo: Vec3::splat(0.6) }).no_shadows(),
            ObjectBuilder::sphere("ball", 0.4, 12).translation(Vec3::new(0.0, 0.5, 0.0)).material(Brdf::Ggx {
                alpha,
                specular: Vec3::splat(0.9),
                diffuse: Vec3::splat(0.2),
            }),
        ],
    )
}

/// A small draft scene under studio.exr, 64×48, seen from `eye`, with `objects`, written to
/// `path`.
fn write_scene(path: &std::path::Path, eye: Vec3, objects: impl IntoIterator<Item = ObjectBuilder>) -> PathBuf {
    let map = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/hdri/studio.exr");
    let b = SceneBuilder::new().preset(Preset::Draft).map(map).camera(eye, Vec3::ZERO).image(64, 48);
    objects.into_iter().fold(b, SceneBuilder::object).write(path).unwrap()
}

fn image_size(path: &std::path::Path) -> (u32, u32) {
    // PNG: the IHDR chunk holds width and height at bytes 16..24.
    let b = std::fs::read(path).unwrap();
    (u32::from_be_bytes(b[16..20].try_into().unwrap()), u32::from_be_bytes(b[20..24].try_into().unwrap()))
}

fn options(scene: PathBuf, out: PathBuf, cache: PathBuf, sweeps: &[&str]) -> BenchOptions {
    let sweeps: Vec<Sweep> = sweeps.iter().map(|s| s.parse().unwrap()).collect();
    BenchOptions {
        scenes: vec![scene],
        out,
        configs: configs(&sweeps).unwrap(),
        truth_spp: 64,
        seed: 3,
        times: vec![0.0],
        frames: 2,
        grid_spp: 8,
        grid_full: false,
        truth_noise: None,
        cache_dir: Some(cache),
        progress: Default::default(),
        budget_rsl: None,
        command: String::new(),
        shard: None,
        merge_only: false,
        fresh: false,
    }
}

#[test]
fn a_bench_measures_reuses_its_truth_and_resumes() {
    let d = dir("resume");
    let (scene, out, cache) = (scene(&d), d.join("out"), d.join("cache"));
    let first = run(&options(scene.clone(), out.clone(), cache.clone(), &["rsl=2,8"])).unwrap();
    // Two truths: per vertex, and per pixel for the images.
    assert_eq!((first.measured, first.reused, first.truths_estimated, first.truths_reused), (2, 0, 2, 0));
    for f in [
        "results.csv",
        "objects.csv",
        "report.md",
        "small_error_vs_ms.svg",
        "small_error_vs_rsl.svg",
        "small_precompute_vs_error.svg",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let rows = &first.rows;
    assert!(rows.iter().all(|r| r.relative_l2.is_finite() && r.relative_l2 > 0.0 && r.ms_per_frame > 0.0));
    assert!(rows.iter().all(|r| r.truth_noise > 0.0 && r.objects.len() == 2));
    assert!(rows.iter().all(|r| r.pixel_l2.is_some_and(|(e, n)| e.is_finite() && e > 0.0 && n > 0.0)), "{rows:?}");
    // Per object over the pixels each covers, with the truth's noise there.
    let names = |o: &[(String, f64, f64)]| o.iter().map(|o| o.0.clone()).collect::<Vec<_>>();
    assert!(
        rows.iter().all(|r| names(&r.pixel_objects) == names(&r.objects)
            && r.pixel_objects.iter().all(|&(_, e, n)| e.is_finite() && e > 0.0 && n > 0.0)),
        "{rows:?}"
    );
    // Each image's frame timed: the whole frame with its image (shading and drawing).
    assert!(out.join("small_pixel_error_vs_ms.svg").exists());
    assert!(rows.iter().all(|r| r.image_ms.is_some_and(|ms| ms.is_finite() && ms > 0.0)), "{rows:?}");
    let grid = image_size(&out.join("small_grid_t0.png"));
    assert_eq!(grid, (2 * 32 + 12, 3 * (24 + 16 + 4) + 4 + 40), "truth row, two configuration rows, legend");
    // Two lights are further from the truth than its noise (8.2 % against 7.3 %): a Monte
    // Carlo estimate of equal error and its time exist. (Eight lights are within the
    // truth's noise on this small scene: there is none for them.)
    let two = rows.iter().find(|r| r.rsl == 2).expect("a two-light row");
    assert!(two.mc_spp.is_some_and(|s| s > 0.0) && two.mc_ms.is_some_and(|m| m > 0.0), "{rows:?}");
    // Run again: nothing is measured, and nothing is estimated (the images are drawn again
    // from the cached per-pixel truth).
    let again = run(&options(scene.clone(), out.clone(), cache.clone(), &["rsl=2,8"])).unwrap();
    assert_eq!((again.measured, again.reused, again.truths_estimated, again.truths_reused), (0, 2, 0, 1));
    // The images are drawn, and so timed, again: all else is what was kept.
    let untimed = |rows: &[Row]| rows.iter().map(|r| Row { image_ms: None, ..r.clone() }).collect::<Vec<_>>();
    assert_eq!(untimed(&again.rows), untimed(&first.rows));
    assert!(again.rows.iter().all(|r| r.image_ms.is_some()));
    // Asked to measure afresh, it measures both again and replaces their rows (no row twice),
    // against the cached truths.
    let fresh =
        run(&BenchOptions { fresh: true, ..options(scene.clone(), out.clone(), cache.clone(), &["rsl=2,8"]) }).unwrap();
    assert_eq!((fresh.measured, fresh.reused, fresh.truths_estimated, fresh.truths_reused), (2, 0, 0, 2));
    let kept = std::fs::read_to_string(out.join("results.csv")).unwrap();
    assert_eq!(kept.lines().count(), 3, "a header and one row per configuration:\n{kept}");
    for (a, b) in fresh.rows.iter().zip(&first.rows) {
        assert_eq!((a.rsl, a.config.as_str()), (b.rsl, b.config.as_str()));
        assert!((a.relative_l2 - b.relative_l2).abs() < 1e-9, "the same configuration measures the same error");
    }
    // A bench cut short after its first configuration resumes with the second; a new
    // configuration reuses the cached truth.
    let text = std::fs::read_to_string(out.join("results.csv")).unwrap();
    let cut: Vec<&str> = text.lines().take(2).collect();
    std::fs::write(out.join("results.csv"), cut.join("\n") + "\n").unwrap();
    let resumed = run(&options(scene, out, cache, &["rsl=2,8,32"])).unwrap();
    assert_eq!((resumed.measured, resumed.reused, resumed.truths_estimated, resumed.truths_reused), (2, 1, 0, 2));
    assert_eq!(resumed.rows.len(), 3);
    let eight = |rows: &[rsl_bench::Row]| rows.iter().find(|r| r.rsl == 8).unwrap().relative_l2;
    assert!((eight(&resumed.rows) - eight(&first.rows)).abs() < 1e-9, "the same configuration measures the same error");
    // The images at the camera's own resolution: a truth of their own, and a grid twice the
    // size.
    let mut full = options(d.join("small.toml"), d.join("full"), d.join("cache"), &["rsl=2"]);
    full.grid_full = true;
    let s = run(&full).unwrap();
    assert_eq!((s.truths_estimated, s.truths_reused), (1, 1), "the vertex truth reused, the pixels' estimated");
    assert_eq!(image_size(&d.join("full/small_grid_t0.png")), (2 * 64 + 12, 2 * (48 + 16 + 4) + 4 + 40));
    let md = std::fs::read_to_string(d.join("full/report.md")).unwrap();
    assert!(md.contains("Per covered pixel, at the camera's resolution"), "{md}");
}

#[test]
fn bad_options_are_clear_errors() {
    let d = dir("bad");
    let scene = scene(&d);
    let mut o = options(scene, d.join("out"), d.join("cache"), &["rsl=2"]);
    o.truth_spp = 1;
    assert!(run(&o).unwrap_err().to_string().contains("truth-spp"));
    o.truth_spp = 4;
    o.scenes = vec![d.join("missing.toml")];
    assert!(format!("{:#}", run(&o).unwrap_err()).contains("missing.toml"));
}

#[test]
fn a_noise_target_chooses_each_truths_samples() {
    // The samples for a target from a pilot's noise: as its square, in multiples of the
    // pilot's, within the pilot's and the largest count.
    use rsl_bench::{PILOT_SPP, samples_for_noise};
    assert_eq!(samples_for_noise(0.1, 0.05, 1 << 20), 4 * PILOT_SPP);
    assert_eq!(samples_for_noise(0.1, 0.03, 1 << 20), 12 * PILOT_SPP, "(0.1 / 0.03)² = 11.1, rounded up");
    assert_eq!(samples_for_noise(0.01, 0.05, 1 << 20), PILOT_SPP, "never below the pilot");
    assert_eq!(samples_for_noise(0.1, 1e-4, 4096), 4096, "never above the largest");
    assert_eq!(samples_for_noise(f64::NAN, 0.05, 4096), 4096);
    let d = dir("noise");
    let mut o = options(scene(&d), d.join("out"), d.join("cache"), &["rsl=4"]);
    o.frames = 1;
    o.truth_noise = Some(0.02);
    let s = run(&o).unwrap();
    let r = &s.rows[0];
    // On this scene 64 samples per vertex leave about 7 % noise: 2 % takes about 13× as many
    // (896; measured: 1.4 % — the pilot's own estimate of its noise runs high).
    assert!(r.truth_spp > 8 * PILOT_SPP && r.truth_spp.is_multiple_of(PILOT_SPP), "{r:?}");
    assert!(r.truth_noise <= 0.02 * 1.1 && r.truth_noise > 0.02 * 0.5, "{r:?}");
    let (_, pixel_noise) = r.pixel_l2.unwrap();
    assert!(pixel_noise <= 0.02 * 1.1 && pixel_noise > 0.02 * 0.5, "{r:?}");
    // Two pilots and two truths estimated; again, all four come from the cache.
    assert_eq!((s.truths_estimated, s.truths_reused), (4, 0));
    let again = run(&o).unwrap();
    assert_eq!((again.measured, again.truths_estimated, again.truths_reused), (0, 0, 3));
}

#[test]
fn a_second_bench_into_a_folder_in_use_is_refused_before_any_work() {
    let d = dir("lock");
    let mut o = options(scene(&d), d.join("out"), d.join("cache"), &["rsl=2"]);
    (o.grid_spp, o.truth_spp, o.frames) = (0, 16, 1);
    // Two benches at once on two threads, into one folder: one measures, the other is
    // refused (before, both reported success and one's rows were lost).
    let (a, b) = std::thread::scope(|s| {
        let (a, b) = (s.spawn(|| run(&o)), s.spawn(|| run(&o)));
        (a.join().unwrap(), b.join().unwrap())
    });
    let (done, refused): (Vec<_>, Vec<_>) = [a, b].into_iter().partition(Result::is_ok);
    // The threads may also run one after the other: then the second reuses the first's row.
    if refused.len() == 1 {
        let e = format!("{:#}", refused.into_iter().next().unwrap().unwrap_err());
        assert!(e.contains("another bench") && e.contains("writing into this folder"), "{e}");
        assert_eq!(done[0].as_ref().unwrap().measured, 1);
    } else {
        assert_eq!(done.iter().map(|r| r.as_ref().unwrap().measured).sum::<usize>(), 1);
    }
    // A folder held by another bench (here: this test holding its lock) is refused, with
    // nothing measured; the lock goes with the bench that held it.
    let held = std::fs::File::create(d.join("out").join(rsl_bench::LOCK_FILE)).unwrap();
    held.lock().unwrap();
    o.configs = configs(&["rsl=4".parse().unwrap()]).unwrap();
    assert!(format!("{:#}", run(&o).unwrap_err()).contains("another bench is writing into this folder"));
    drop(held);
    assert_eq!(run(&o).unwrap().measured, 1);
    assert!(!d.join("out").join(rsl_bench::LOCK_FILE).exists(), "the lock is removed when the bench ends");
}

#[test]
fn scenes_whose_outputs_would_collide_are_refused_before_any_work() {
    let d = dir("stems");
    let scene = scene(&d);
    std::fs::create_dir_all(d.join("other")).unwrap();
    let twin = ball_scene(&d.join("other/small.toml"), 0.5);
    let mut o = options(scene.clone(), d.join("out"), d.join("cache"), &["rsl=2"]);
    o.scenes = vec![scene.clone(), twin.clone()];
    let e = format!("{:#}", run(&o).unwrap_err());
    assert!(e.contains("share the file stem `small`") && e.contains("other"), "{e}");
    o.scenes = vec![scene.clone(), scene.clone()];
    assert!(format!("{:#}", run(&o).unwrap_err()).contains("given twice"));
    assert!(!d.join("out/results.csv").exists(), "nothing measured");
    // A scene of that stem already measured into the folder counts too.
    (o.grid_spp, o.truth_spp, o.frames) = (0, 16, 1);
    o.scenes = vec![scene];
    assert_eq!(run(&o).unwrap().measured, 1);
    o.scenes = vec![twin];
    let e = format!("{:#}", run(&o).unwrap_err());
    assert!(e.contains("share the file stem"), "{e}");
}

/// Rewrites a CSV file as written before rows carried their truth's key: its last `columns`
/// (the key, and in `results.csv` the per-object pixel errors and the image's frame time
/// that came after it) dropped.
fn unkey(file: &std::path::Path, columns: usize) {
    let text = std::fs::read_to_string(file).unwrap();
    let unkeyed: Vec<String> = text
        .lines()
        .map(|l| l.rsplitn(columns + 1, ',').nth(columns).expect("a truth_key column").to_string())
        .collect();
    std::fs::write(file, unkeyed.join("\n") + "\n").unwrap();
}

#[test]
fn rows_measured_against_another_truth_or_scene_are_measured_again() {
    let d = dir("rekey");
    let scene = scene(&d);
    let mut o = options(scene.clone(), d.join("out"), d.join("cache"), &["rsl=4"]);
    (o.grid_spp, o.truth_spp, o.frames) = (0, 16, 1);
    assert_eq!(run(&o).unwrap().measured, 1);
    assert_eq!(run(&o).unwrap().measured, 0, "the same truth: the row is kept");
    // Another number of samples: another truth, and the row is replaced.
    o.truth_spp = 32;
    let s = run(&o).unwrap();
    assert_eq!((s.measured, s.rows.len(), s.rows[0].truth_spp), (1, 1, 32));
    // The scene's file changed (the ball's roughness): measured again.
    ball_scene(&scene, 0.5);
    assert_eq!(run(&o).unwrap().measured, 1, "another scene: measured again");
    // Results written before rows carried their truth's key are read, and measured again.
    unkey(&d.join("out/results.csv"), 3);
    assert_eq!(run(&o).unwrap().measured, 1, "an unkeyed row: measured again");
    assert_eq!(run(&o).unwrap().measured, 0);
}

#[test]
fn the_wavelet_baseline_joins_the_study() {
    let d = dir("wavelet");
    let mut o = options(scene(&d), d.join("out"), d.join("cache"), &["rsl=8"]);
    // What `rsl bench --wavelet-terms 64,4` adds: the baseline as a configuration per count,
    // the largest first.
    let sweeps: Vec<Sweep> = ["method=wavelet", "wavelet_terms=64,4"].iter().map(|s| s.parse().unwrap()).collect();
    o.configs.extend(configs(&sweeps).unwrap());
    o.grid_spp = 0;
    let s = run(&o).unwrap();
    assert_eq!(s.measured, 3);
    let mut errors = Vec::new();
    for k in [4u32, 64] {
        let r = s.rows.iter().find(|r| r.config == format!("method=wavelet wavelet_terms={k}")).unwrap();
        // No square lights: the baseline's rows hold no RSL count.
        assert_eq!((r.method.as_str(), r.rsl), ("wavelet", 0));
        assert!(r.relative_l2.is_finite() && r.ms_per_frame > 0.0 && r.prepare_bytes > 0);
        errors.push(r.relative_l2);
    }
    assert!(errors[1] < errors[0], "64 terms closer to the truth than 4: {errors:?}");
    // Resumed: nothing is measured again.
    assert_eq!(run(&o).unwrap().measured, 0);
}

#[test]
fn an_error_budget_measures_every_oracle_once_and_all_of_them_approach_the_truth() {
    let d = dir("budget");
    let (scene, out, cache) = (scene(&d), d.join("out"), d.join("cache"));
    let mut o = options(scene, out.clone(), cache, &["rsl=2,8"]);
    o.grid_spp = 0;
    o.truth_spp = 1024;
    o.budget_rsl = Some(2);
    let first = run(&o).unwrap();
    assert_eq!(first.budget_measured, 7, "none, five oracles, all — for the one configuration with 2 RSLs");
    let rows = rsl_bench::budget::read_rows(&out.join("budget.csv")).unwrap();
    let err = |name: &str| rows.iter().find(|r| r.oracle == name).unwrap().relative_l2;
    // The plain path with 2 lights is far from the truth; with every approximation exact, only
    // the draft environment grid (6×16×16) and the truth's noise are left.
    let noise = rows[0].truth_noise;
    eprintln!("none {} all {} noise {noise}", err("none"), err("all"));
    assert!(err("all") < 0.5 * err("none"), "all {} vs none {}", err("all"), err("none"));
    assert!((err("none") - first.rows.iter().find(|r| r.rsl == 2).unwrap().relative_l2).abs() < 1e-9);
    assert!(
        rows.iter().filter(|r| r.oracle != "none" && r.oracle != "light").all(|r| r.rays > 0 || r.oracle == "brdf")
    );
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("## Error budgets") && md.contains("| all |"), "{md}");
    // Run again: nothing is measured twice.
    let again = run(&o).unwrap();
    assert_eq!(again.budget_measured, 0);
    // Another truth (fewer samples): every oracle is measured again, each row replaced.
    o.truth_spp = 256;
    assert_eq!(run(&o).unwrap().budget_measured, 7);
    let rekeyed = rsl_bench::budget::read_rows(&out.join("budget.csv")).unwrap();
    assert_eq!(rekeyed.len(), 7);
    assert!(rekeyed.iter().all(|r| r.truth_key.is_some() && r.truth_key != rows[0].truth_key));
    // A budget written before rows carried their truth's key is read, and measured again.
    unkey(&out.join("budget.csv"), 1);
    assert_eq!(run(&o).unwrap().budget_measured, 7, "unkeyed rows: measured again");
    assert_eq!(run(&o).unwrap().budget_measured, 0);
}

#[test]
fn raising_any_single_knob_never_raises_the_error_beyond_the_truths_noise() {
    let d = dir("monotone");
    let (scene, out, cache) = (scene(&d), d.join("out"), d.join("cache"));
    // A torus has a stored self-visibility field, for the CPCA knobs (the ball is convex).
    let torus = write_scene(
        &d.join("torus.toml"),
        Vec3::new(0.0, 2.0, 2.0),
        [ObjectBuilder::primitive("torus", Primitive::Torus { major_radius: 0.5, minor_radius: 0.2, resolution: 12 })
            .rotation(Vec3::X, 60.0)
            .material(Brdf::Lambert { albedo: Vec3::splat(0.7) })],
    );
    // From a coarse base, each knob alone at a low and a higher value.
    let base = "quality=draft";
    let pairs: [(&str, &str, &str, &PathBuf); 12] = [
        ("rsl", "4", "32", &scene),
        ("brdf_resolution", "16", "64", &scene),
        ("view_samples", "4", "16", &scene),
        ("visibility_resolution", "8", "32", &scene),
        ("ovdf_vectors", "1", "8", &scene),
        ("ovdf_directions", "4", "16", &scene),
        ("ovdf_shells", "2", "8", &scene),
        ("env_grid", "8", "16", &scene),
        ("cpca_clusters", "1", "16", &torus),
        ("cpca_vectors", "1", "6", &torus),
        ("traced_lights", "0", "2", &scene),
        ("shadow_rays", "1", "16", &scene),
    ];
    for (knob, low, high, scene) in pairs {
        let sweep = format!("{knob}={low},{high}");
        let mut o = options(scene.clone(), out.join(knob), cache.clone(), &[base, &sweep]);
        o.grid_spp = 0;
        o.truth_spp = 1024;
        let s = run(&o).unwrap();
        let err = |v: &str| s.rows.iter().find(|r| r.config.contains(&format!("{knob}={v}"))).unwrap();
        let (lo, hi) = (err(low), err(high));
        eprintln!(
            "{knob}: {low} → {:.4}, {high} → {:.4} (noise {:.4})",
            lo.relative_l2, hi.relative_l2, hi.truth_noise
        );
        assert!(
            hi.relative_l2 <= lo.relative_l2 + hi.truth_noise,
            "{knob}: {} then {}",
            lo.relative_l2,
            hi.relative_l2
        );
    }
}

#[test]
fn each_count_of_bounces_is_measured_against_a_truth_that_follows_as_many() {
    let d = dir("bounces");
    let mut o = options(scene(&d), d.join("out"), d.join("cache"), &["rsl=8", "bounces=0,1"]);
    (o.truth_spp, o.frames) = (32, 1);
    let s = run(&o).unwrap();
    assert_eq!(s.measured, 2);
    // Per count of bounces a truth per vertex and one per pixel.
    assert_eq!(s.truths_estimated, 4);
    let row = |b: &str| s.rows.iter().find(|r| r.config.contains(&format!("bounces={b}"))).unwrap();
    let (direct, bounced) = (row("0"), row("1"));
    assert_ne!(direct.truth_key, bounced.truth_key);
    // The same drawing (no method draws interreflections yet) against two truths.
    assert_ne!(direct.relative_l2, bounced.relative_l2);
    assert_ne!(direct.pixel_l2, bounced.pixel_l2);
    // The direct light's truth is the one a scene without the knob has: its key is kept.
    let mut plain = options(scene(&d), d.join("plain"), d.join("cache"), &["rsl=8"]);
    (plain.truth_spp, plain.frames) = (32, 1);
    let p = run(&plain).unwrap();
    assert_eq!((p.truths_estimated, p.truths_reused), (0, 2));
    assert_eq!(p.rows[0].truth_key, direct.truth_key);
    assert_eq!(run(&o).unwrap().measured, 0, "both rows kept");
}

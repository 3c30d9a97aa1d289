//! `rsl bench` from the command line: its error is what `rsl compare` says of the same
//! renders, and its files are written.

use std::path::{Path, PathBuf};
use std::process::Command;

fn rsl(args: &[&str]) -> (String, String) {
    let o =
        Command::new(env!("CARGO_BIN_EXE_rsl")).current_dir(env!("CARGO_MANIFEST_DIR")).args(args).output().unwrap();
    let (out, err) = (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned());
    assert!(o.status.success(), "rsl {args:?} failed:\n{err}");
    (out, err)
}

fn small_scene(dir: &Path) -> PathBuf {
    let map = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/hdri/studio.exr");
    let path = dir.join("small.toml");
    std::fs::write(
        &path,
        format!(
            "quality = \"draft\"\n[environment]\nmap = \"{}\"\n[camera]\neye = [0.0, 2.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n\
             width = 64\nheight = 48\n[[objects]]\nname = \"floor\"\nprimitive = {{ kind = \"plane\", size = 3.0, resolution = 12 }}\n\
             material = {{ model = \"lambert\", albedo = [0.6, 0.6, 0.6] }}\n[[objects]]\nname = \"ball\"\n\
             primitive = {{ kind = \"sphere\", radius = 0.4, resolution = 12 }}\ntranslation = [0.0, 0.5, 0.0]\n\
             material = {{ model = \"ggx\", alpha = 0.3, specular = [0.9, 0.9, 0.9] }}\n",
            map.display()
        ),
    )
    .unwrap();
    path
}

#[test]
fn the_bench_error_is_what_compare_says_of_the_same_renders() {
    let dir = std::env::temp_dir().join(format!("rsl-bench-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = small_scene(&dir);
    let (scene, cache) = (scene.to_str().unwrap(), dir.join("cache"));
    let cache = cache.to_str().unwrap();
    let p = |n: &str| dir.join(n).to_str().unwrap().to_string();
    rsl(&[
        "bench",
        scene,
        "--out",
        &p("bench"),
        "--sweep",
        "rsl=8",
        "--truth-spp",
        "16",
        "--times",
        "0.5",
        "--frames",
        "1",
        "--cache",
        cache,
    ]);
    for f in [
        "results.csv",
        "objects.csv",
        "report.md",
        "small_error_vs_ms.svg",
        "small_error_vs_rsl.svg",
        "small_precompute_vs_error.svg",
    ] {
        assert!(dir.join("bench").join(f).exists(), "{f} missing");
    }
    let csv = std::fs::read_to_string(dir.join("bench/results.csv")).unwrap();
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    let bench_l2: f64 = row[10].parse().unwrap();
    // The same configuration and the same truth, rendered and compared by hand.
    let common = ["--time", "0.5", "--device", "cpu", "--cache", cache];
    rsl(&[
        &["render", scene, "--method", "rsl", "--rsl", "8", "--out", &p("a.exr"), "--vertex-out", &p("a.ply")],
        &common[..],
    ]
    .concat());
    rsl(&[
        &["render", scene, "--method", "truth", "--spp", "16", "--out", &p("t.exr"), "--vertex-out", &p("t.ply")],
        &common[..],
    ]
    .concat());
    let (out, _) = rsl(&["compare", &p("a.ply"), &p("t.ply")]);
    let compare_l2: f64 = out
        .split("relative L2")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no relative L2 in {out}"));
    assert!((bench_l2 - compare_l2).abs() <= 1e-6, "bench {bench_l2} against compare {compare_l2}");
}

#[test]
fn a_target_error_pick_meets_the_target_when_measured_afresh() {
    let dir = std::env::temp_dir().join(format!("rsl-bench-target-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene_path = small_scene(&dir);
    let scene = scene_path.to_str().unwrap();
    let p = |n: &str| dir.join(n).to_str().unwrap().to_string();
    let sweep = ["--sweep", "rsl=1,30", "--truth-spp", "32", "--times", "0", "--frames", "1"];
    rsl(&[&["bench", scene, "--out", &p("a"), "--cache", &p("cache-a")], &sweep[..]].concat());
    let errors: Vec<f64> = std::fs::read_to_string(dir.join("a/results.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(10).unwrap().parse().unwrap())
        .collect();
    let (one, thirty) = (errors[0], errors[1]);
    assert!(one > 1.5 * thirty, "one light {one}, thirty {thirty}");
    let target = (one + thirty) / 2.0;
    let (out, _) = rsl(&[
        &["bench", scene, "--out", &p("a"), "--cache", &p("cache-a"), "--target-error", &target.to_string()],
        &sweep[..],
    ]
    .concat());
    assert!(out.contains("method=cpu rsl=30"), "{out}");
    let fragment = std::fs::read_to_string(dir.join("a/small_target.toml")).unwrap();
    assert!(fragment.contains("rsl_count = 30") && fragment.contains("[quality]\npreset = \"draft\""), "{fragment}");
    // The scene with the picked settings, measured afresh (another cache, another seed of
    // the truth): it meets the target.
    let text = std::fs::read_to_string(&scene_path).unwrap().replace("quality = \"draft\"\n", "");
    let picked = dir.join("picked.toml");
    std::fs::write(
        &picked,
        format!("{}{fragment}", text.replace("[environment]\n", "[environment]\nrsl_count = 30\n")),
    )
    .unwrap();
    rsl(&[
        "bench",
        picked.to_str().unwrap(),
        "--out",
        &p("b"),
        "--cache",
        &p("cache-b"),
        "--seed",
        "2",
        "--sweep",
        "method=cpu",
        "--truth-spp",
        "32",
        "--times",
        "0",
        "--frames",
        "1",
    ]);
    let again: f64 = std::fs::read_to_string(dir.join("b/results.csv"))
        .unwrap()
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .nth(10)
        .unwrap()
        .parse()
        .unwrap();
    assert!(again <= target, "re-measured {again} against the target {target}");
    // Nothing meets an impossible target: a clear error.
    let o = Command::new(env!("CARGO_BIN_EXE_rsl"))
        .args(
            [&["bench", scene, "--out", &p("a"), "--cache", &p("cache-a"), "--target-error", "0.01%"], &sweep[..]]
                .concat(),
        )
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("no configuration meets"));
}

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
    let dir = rsl_engine::sphere::scratch::Scratch::new("bench-cli");
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
    let dir = rsl_engine::sphere::scratch::Scratch::new("bench-target");
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

/// The rows of a results or budget file by their identity (all fields before `value`,
/// less the timings), each with its measured error and truth key.
fn measured(file: &Path, identity: &[usize], value: usize, key: usize) -> Vec<(String, String)> {
    let mut rows: Vec<(String, String)> = std::fs::read_to_string(file)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let id: Vec<&str> = identity.iter().map(|&i| f[i]).collect();
            (id.join(","), format!("{} {}", f[value], f[key]))
        })
        .collect();
    rows.sort();
    rows
}

#[test]
fn shards_in_separate_processes_joined_give_the_rows_of_one_bench_and_a_killed_shard_resumes() {
    let dir = rsl_engine::sphere::scratch::Scratch::new("bench-shard");
    let scene = small_scene(&dir);
    let scene = scene.to_str().unwrap();
    let p = |n: &str| dir.join(n).to_str().unwrap().to_string();
    let cache = p("cache");
    let work = [
        "--sweep",
        "rsl=2,4,8",
        "--times",
        "0,0.5",
        "--truth-spp",
        "16",
        "--frames",
        "1",
        "--grid-spp",
        "0",
        "--no-wavelet",
        "--budget",
        "2",
        "--cache",
        &cache,
    ];
    let bench = |out: &str, extra: &[&str]| -> Vec<String> {
        ["bench", scene, "--out", out].iter().chain(&work).chain(extra).map(|s| s.to_string()).collect()
    };
    let rsl = |args: Vec<String>| rsl(&args.iter().map(String::as_str).collect::<Vec<_>>());
    rsl(bench(&p("whole"), &[]));
    // Three shards at once, as three elements of a job array, into one folder.
    let shards: Vec<_> = (0..3)
        .map(|k| {
            let shard = format!("{k}/3");
            Command::new(env!("CARGO_BIN_EXE_rsl"))
                .args(bench(&p("sharded"), &["--shard", &shard]))
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for child in shards {
        let o = child.wait_with_output().unwrap();
        assert!(o.status.success(), "a shard failed:\n{}", String::from_utf8_lossy(&o.stderr));
    }
    let sharded = dir.join("sharded");
    for k in 0..3 {
        assert!(sharded.join(format!("results-shard-{k}-of-3.csv")).exists(), "shard {k} wrote no rows");
    }
    assert!(!sharded.join("results.csv").exists() && !sharded.join("report.md").exists());
    let (out, err) = rsl(bench(&p("sharded"), &["--merge"]));
    assert!(err.contains("joined the rows of shard(s) 0/3, 1/3, 2/3"), "{err}");
    assert!(out.contains("# rsl bench"), "the report is printed");
    for k in 0..3 {
        assert!(!sharded.join(format!("results-shard-{k}-of-3.csv")).exists(), "shard {k}'s file is left");
    }
    // The same rows: scene, configuration, time; their error and truth key (timings aside).
    let results = |out: &str| measured(&dir.join(out).join("results.csv"), &[0, 1, 5], 10, 20);
    let whole = results("whole");
    assert_eq!(whole.len(), 6);
    assert_eq!(results("sharded"), whole);
    let budget = |out: &str| measured(&dir.join(out).join("budget.csv"), &[0, 1, 2, 3], 4, 9);
    assert!(!budget("whole").is_empty());
    assert_eq!(budget("sharded"), budget("whole"));
    // A shard killed after its first row: its rerun measures only the rest.
    rsl(bench(&p("killed"), &["--shard", "0/2", "--no-budget"]));
    let file = dir.join("killed/results-shard-0-of-2.csv");
    let text = std::fs::read_to_string(&file).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 4, "shard 0 of 2 takes 3 of the 6 configurations and times");
    std::fs::write(&file, format!("{}\n", lines[..2].join("\n"))).unwrap();
    let (_, err) = rsl(bench(&p("killed"), &["--shard", "0/2", "--no-budget"]));
    assert!(err.contains("2 measured, 1 already in"), "{err}");
    assert_eq!(std::fs::read_to_string(&file).unwrap().lines().count(), 4);
    // Another split into the same folder is refused.
    let o = Command::new(env!("CARGO_BIN_EXE_rsl"))
        .args(bench(&p("killed"), &["--shard", "0/3", "--no-budget"]))
        .output()
        .unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("of another split"));
}

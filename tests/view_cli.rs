//! `rsl view --screenshot`: the whole viewer UI rendered headless to a PNG, and its
//! argument checks. The screenshot runs on any adapter (Mesa's llvmpipe in CI); without one
//! it prints "skipped: no adapter", and fails under RSL_REQUIRE_GPU=1.

use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn run(args: &[&str]) -> anyhow::Result<()> {
    use clap::Parser;
    rsl::cli::run(rsl::cli::Cli::try_parse_from(std::iter::once("rsl").chain(args.iter().copied()))?)
}

fn scene() -> String {
    root().join("data/scenes/default.toml").to_str().unwrap().to_string()
}

#[test]
fn bad_screenshot_arguments_are_errors_before_any_work() {
    let dir = std::env::temp_dir().join(format!("rsl-view-cli-args-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let jpg = dir.join("shot.jpg");
    let e = run(&["view", &scene(), "--screenshot", jpg.to_str().unwrap()]).unwrap_err();
    assert!(format!("{e:#}").contains("--screenshot"), "{e:#}");
    let png = dir.join("shot.png");
    let e = run(&["view", &scene(), "--screenshot", png.to_str().unwrap(), "--frames", "0"]).unwrap_err();
    assert!(format!("{e:#}").contains("--frames"), "{e:#}");
    let missing = dir.join("nothing.toml");
    let e = run(&["view", missing.to_str().unwrap(), "--screenshot", png.to_str().unwrap()]).unwrap_err();
    assert!(format!("{e:#}").contains("nothing.toml"), "{e:#}");
    assert!(!png.exists(), "a failed screenshot left a file");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_headless_screenshot_shows_the_whole_viewer() {
    if rsl_gpu::testing::context_or_skip("a_headless_screenshot_shows_the_whole_viewer").is_none() {
        return;
    }
    let dir = std::env::temp_dir().join(format!("rsl-view-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("viewer.png");
    let cache = std::env::temp_dir().join("rsl-view-cli-cache");
    let args = ["view", &scene(), "--quality", "draft", "--cache", cache.to_str().unwrap()];
    run(&[&args[..], &["--screenshot", png.to_str().unwrap(), "--frames", "2"]].concat()).unwrap();
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), (1200, 760));
    // The 3D view (right of the side panel) holds the lit scene: many distinct colours.
    let mut colours: Vec<[u8; 3]> = img.enumerate_pixels().filter(|(x, _, _)| *x > 400).map(|(_, _, p)| p.0).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() > 1000, "only {} colours in the view", colours.len());
    // `--per-pixel` (and `--drawing lobe`) start with glossy objects drawn per pixel: other
    // images of the view, the side panel (but for its drop-down and the timings line) the same.
    for how in [&["--per-pixel"][..], &["--drawing", "lobe"][..]] {
        let per_pixel = dir.join("per-pixel.png");
        run(&[&args[..], how, &["--screenshot", per_pixel.to_str().unwrap(), "--frames", "2"]].concat()).unwrap();
        let other = image::open(&per_pixel).unwrap().to_rgb8();
        let changed = img.enumerate_pixels().filter(|(x, y, p)| *x > 400 && other.get_pixel(*x, *y) != *p).count();
        assert!(changed > 5000, "{how:?}: only {changed} pixels of the view changed");
    }
    // The two ways of choosing cannot be mixed.
    let e = run(&[&args[..], &["--per-pixel", "--drawing", "hybrid"]].concat()).unwrap_err();
    assert!(format!("{e:#}").contains("cannot be used with"), "{e:#}");
    std::fs::remove_dir_all(&dir).unwrap();
}

//! Scene files the command-line tests write into their own folders.

#![allow(dead_code)] // Each test binary uses some of these.

use std::path::{Path, PathBuf};

/// `name` in `dir`: one grey Lambert ball of radius 1 seen from 3 units away, 64×48 pixels,
/// under `environment` (the body of the `[environment]` table, e.g.
/// `constant = [1.0, 1.0, 1.0]` or `map = "m.exr"`).
pub fn ball_scene(dir: &Path, name: &str, environment: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(
        &path,
        format!(
            "[environment]\n{environment}\n[camera]\neye = [0.0, 0.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n\
             width = 64\nheight = 48\n[[objects]]\nname = \"ball\"\n\
             primitive = {{ kind = \"sphere\", radius = 1.0, resolution = 8 }}\n\
             material = {{ model = \"lambert\", albedo = [0.5, 0.5, 0.5] }}\n"
        ),
    )
    .unwrap();
    path
}

/// `small.toml` in `dir`: the ball under a unit constant light.
pub fn small_scene(dir: &Path) -> PathBuf {
    ball_scene(dir, "small.toml", "constant = [1.0, 1.0, 1.0]")
}

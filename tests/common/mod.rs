//! Scene files the command-line tests write into their own folders.

#![allow(dead_code)] // Each test binary uses some of these.

use glam::Vec3;
use rsl_scene::build::{ObjectBuilder, SceneBuilder};
use std::path::{Path, PathBuf};

/// `name` in `dir`: one grey Lambert ball of radius 1 seen from 3 units away, 64×48 pixels,
/// under the environment `environment` sets (a constant white unless it sets another).
pub fn ball_scene(dir: &Path, name: &str, environment: impl FnOnce(SceneBuilder) -> SceneBuilder) -> PathBuf {
    let b = SceneBuilder::new()
        .camera(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO)
        .image(64, 48)
        .object(ObjectBuilder::sphere("ball", 1.0, 8).material(rsl_scene::Brdf::Lambert { albedo: Vec3::splat(0.5) }));
    environment(b).write(dir.join(name)).unwrap()
}

/// `small.toml` in `dir`: the ball under a unit constant light.
pub fn small_scene(dir: &Path) -> PathBuf {
    ball_scene(dir, "small.toml", |b| b.constant(Vec3::ONE))
}

//! Rotates the environment of the bundled default scene through a full turn in 8 frames:
//! the light set turns with it, nothing is precomputed again (the cache counts no miss after
//! the first frame), and each frame is written as a PNG.
//!
//! `cargo run --release --example rotate_environment` writes
//! `rsl-examples/rotate_environment/frame_0.png` … `frame_7.png`.

use anyhow::{Context, Result, ensure};
use glam::{Quat, Vec3};
use rsl_engine::method::{CpuRsl, Method, Request, exposure_for};
use rsl_engine::scene::Scene;
use rsl_engine::{Engine, EngineOptions, output};
use std::path::Path;

fn main() -> Result<()> {
    let out = Path::new("rsl-examples/rotate_environment");
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut scene = Scene::load("data/scenes/default.toml").context("run the example from the repository root")?;
    scene.environment.spin = None;
    let options = EngineOptions { cache_dir: rsl_engine::cache::default_dir(), ..Default::default() };
    let mut engine = Engine::new(&scene, options)?;
    let misses = engine.cache_stats().misses;
    let base = scene.environment.rotation;
    let mut exposure = None;
    for k in 0..8 {
        scene.environment.rotation = Quat::from_axis_angle(Vec3::Y, k as f32 * 45f32.to_radians()) * base;
        engine.sync(&scene)?;
        let frame = CpuRsl.render(&engine, &scene, &Request::at(0.0))?;
        let image = frame.image.context("an image was asked for")?;
        let e = *exposure.get_or_insert_with(|| exposure_for(&image));
        let path = out.join(format!("frame_{k}.png"));
        output::write_png(&path, image.width, image.height, rsl_shade::tonemap::encode_all(&image.pixels, e))?;
        println!("{:>4}°: shaded in {:.1} ms, wrote {}", k * 45, frame.timings.ms("shade"), path.display());
    }
    ensure!(engine.cache_stats().misses == misses, "rotating the environment recomputed something");
    println!("8 rotations, nothing recomputed (cache misses stayed at {misses})");
    Ok(())
}

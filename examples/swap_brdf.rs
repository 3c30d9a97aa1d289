//! Swaps the bunny's material halfway through an animation of the bundled default scene:
//! the swap builds exactly one BRDF table, and every frame is written as a PNG with an
//! animated GIF beside them.
//!
//! `cargo run --release --example swap_brdf` writes `rsl-examples/swap_brdf/frame_00.png`
//! … `frame_11.png` and `swap_brdf.gif`.

use anyhow::{Context, Result, ensure};
use rsl_engine::method::{CpuRsl, Method, Request, exposure_for};
use rsl_engine::scene::{Brdf, Scene};
use rsl_engine::{Engine, EngineOptions, output};
use std::path::Path;
use std::time::Instant;

fn main() -> Result<()> {
    let out = Path::new("rsl-examples/swap_brdf");
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut scene = Scene::load("data/scenes/default.toml").context("run the example from the repository root")?;
    let options = EngineOptions { cache_dir: rsl_engine::cache::default_dir(), ..Default::default() };
    let mut engine = Engine::new(&scene, options)?;
    let (frames, fps) = (12, 6.0);
    let mut exposure = None;
    let mut gif = Vec::new();
    for k in 0..frames {
        if k == frames / 2 {
            let misses = engine.cache_stats().misses;
            let start = Instant::now();
            scene.objects[1].material = Brdf::Phong {
                exponent: 200.0,
                specular: glam::Vec3::new(0.6, 0.6, 0.6),
                diffuse: glam::Vec3::new(0.1, 0.3, 0.6),
            };
            engine.sync(&scene)?;
            let built = engine.cache_stats().misses - misses;
            ensure!(built == 1, "the swap built {built} items; one table was expected");
            println!(
                "frame {k}: {} is now blue Phong (one table built, sync {:.1} ms)",
                scene.objects[1].name,
                start.elapsed().as_secs_f64() * 1e3
            );
        }
        let frame = CpuRsl.render(&engine, &scene, &Request::at(k as f32 / fps))?;
        let image = frame.image.context("an image was asked for")?;
        let e = *exposure.get_or_insert_with(|| exposure_for(&image));
        let rgb = rsl_shade::tonemap::encode_all(&image.pixels, e);
        output::write_png(&out.join(format!("frame_{k:02}.png")), image.width, image.height, rgb.clone())?;
        gif.push(rgb);
    }
    let path = out.join("swap_brdf.gif");
    output::write_gif(&path, scene.camera.width, scene.camera.height, &gif, fps)?;
    println!("wrote {frames} frames and {}", path.display());
    Ok(())
}

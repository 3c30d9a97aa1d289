//! Sweeps the RSL count of the bundled default scene against the Monte Carlo truth: per
//! count, the shading time and the relative L2 error per vertex against the truth, with the
//! truth's own noise beside it. Prints the table and writes it as CSV.
//!
//! `cargo run --release --example rsl_sweep` writes `rsl-examples/rsl_sweep.csv`.

use anyhow::{Context, Result};
use rsl_engine::method::{CpuRsl, Method, Request, Truth};
use rsl_engine::scene::Scene;
use rsl_engine::{Engine, EngineOptions, Layers, output};

const SPP: u32 = 64;
const TIME: f32 = 1.0;

fn main() -> Result<()> {
    std::fs::create_dir_all("rsl-examples").context("cannot create rsl-examples")?;
    let scene = Scene::load("data/scenes/default.toml").context("run the example from the repository root")?;
    let cache = rsl_engine::cache::default_dir();
    // The truth needs only the method-neutral layer.
    let neutral = Engine::new(
        &scene,
        EngineOptions { cache_dir: cache.clone(), layers: Layers { rsl: false }, ..Default::default() },
    )?;
    let request = Request { time: TIME, image: false, vertices: true, exposure: None };
    let truth = Truth::new(&neutral, SPP, 1)?.render(&neutral, &scene, &request)?;
    let noise = truth.self_error.and_then(|e| e.vertices).context("the truth estimates its error")?;
    let reference = truth.radiance.concat();
    println!(
        "truth: {SPP} spp, {:.1} s, its own noise {:.2}% (relative L2 of the standard error)",
        truth.timings.stages.iter().map(|s| s.wall_ms).sum::<f64>() / 1e3,
        100.0 * noise
    );
    let mut engine = Engine::new(&scene, EngineOptions { cache_dir: cache, ..Default::default() })?;
    let mut csv = String::from("rsl_count,shade_ms,relative_l2,truth_spp,truth_noise\n");
    println!("{:>6} {:>10} {:>12}", "RSLs", "shade ms", "rel. L2");
    for n in [1, 3, 10, 30, 60, 100, 300] {
        engine.set_rsl_count(n)?;
        let frame = CpuRsl.render(&engine, &scene, &request)?;
        let err = rsl_truth::compare(&frame.radiance.concat(), &reference, None)?.relative_l2;
        let ms = frame.timings.ms("shade");
        println!("{:>6} {ms:>10.1} {:>11.2}%", engine.rsls().len(), 100.0 * err);
        csv.push_str(&format!("{},{ms:.3},{err:.6},{SPP},{noise:.6}\n", engine.rsls().len()));
    }
    output::write_atomic(std::path::Path::new("rsl-examples/rsl_sweep.csv"), csv.as_bytes())?;
    println!("wrote rsl-examples/rsl_sweep.csv");
    Ok(())
}

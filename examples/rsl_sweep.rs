//! Sweeps the RSL count of the bundled default scene against the Monte Carlo truth: per
//! count, the shading time and the relative L2 error per vertex against the truth — for the
//! scene and per object — with the truth's own noise beside it. Prints the table and writes
//! it as CSV.
//!
//! `cargo run --release --example rsl_sweep` writes `rsl-examples/rsl_sweep.csv`.

use anyhow::{Context, Result};
use rsl_engine::method::{CpuRsl, Method, Request, Truth};
use rsl_engine::scene::Scene;
use rsl_engine::{Engine, EngineOptions, Layers, output};

const SPP: u32 = 256;
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
    let std_error = truth.std_error.as_ref().context("the truth has standard errors")?;
    // The truth's own noise per object: ‖standard error‖₂ / ‖mean‖₂ over its vertices.
    let object_noise: Vec<f64> = (0..scene.objects.len())
        .map(|i| {
            let se: f64 = std_error[i].iter().map(|e| f64::from(e.length_squared())).sum();
            let m: f64 = truth.radiance[i].iter().map(|r| f64::from(r.length_squared())).sum();
            (se / m).sqrt()
        })
        .collect();
    println!(
        "truth: {SPP} spp, {:.1} s; its own noise {:.2}% for the scene ({})",
        truth.timings.stages.iter().map(|s| s.wall_ms).sum::<f64>() / 1e3,
        100.0 * noise,
        scene
            .objects
            .iter()
            .zip(&object_noise)
            .map(|(o, n)| format!("{} {:.2}%", o.name, 100.0 * n))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut engine = Engine::new(&scene, EngineOptions { cache_dir: cache, ..Default::default() })?;
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    let mut csv = format!("rsl_count,shade_ms,relative_l2,{},truth_spp,truth_noise\n", names.join(","));
    println!(
        "{:>5} {:>9} {:>8}  {}",
        "RSLs",
        "shade ms",
        "scene",
        names.iter().map(|n| format!("{n:>8}")).collect::<String>()
    );
    for n in [1, 3, 10, 30, 60, 100, 300] {
        engine.set_rsl_count(n)?;
        let frame = CpuRsl.render(&engine, &scene, &request)?;
        let err = rsl_truth::compare(&frame.radiance.concat(), &truth.radiance.concat(), None)?.relative_l2;
        let per_object = (0..names.len())
            .map(|i| Ok(rsl_truth::compare(&frame.radiance[i], &truth.radiance[i], None)?.relative_l2))
            .collect::<Result<Vec<f64>>>()?;
        let ms = frame.timings.ms("shade");
        println!(
            "{:>5} {ms:>9.1} {:>7.1}%  {}",
            engine.rsls().len(),
            100.0 * err,
            per_object.iter().map(|e| format!("{:>7.1}%", 100.0 * e)).collect::<String>()
        );
        let cols: Vec<String> = per_object.iter().map(|e| format!("{e:.6}")).collect();
        csv.push_str(&format!("{},{ms:.3},{err:.6},{},{SPP},{noise:.6}\n", engine.rsls().len(), cols.join(",")));
    }
    output::write_atomic(std::path::Path::new("rsl-examples/rsl_sweep.csv"), csv.as_bytes())?;
    println!("wrote rsl-examples/rsl_sweep.csv");
    Ok(())
}

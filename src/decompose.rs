//! `rsl decompose`: environment map → RSLs, with JSON and a figure.

use crate::cli::DecomposeArgs;
use anyhow::{Result, bail};
use rsl_env::{CubeEnv, Decomposition, LevelError, load_latlong};
use serde::Serialize;
use std::time::Instant;

/// Largest cube grid accepted (6×256×256 texels is already far beyond interactive).
pub const MAX_GRID: usize = 256;

#[derive(Serialize)]
struct RslJson {
    centre: [f32; 3],
    half_diagonal: f32,
    intensity: [f32; 3],
    energy: [f64; 3],
    solid_angle: f32,
    region_solid_angle: f64,
    texels: u32,
    fit_error: f64,
    penalised_error: f64,
    light_variance: f64,
}

#[derive(Serialize)]
struct Timings {
    load_ms: f64,
    resample_ms: f64,
    decompose_ms: f64,
}

#[derive(Serialize)]
struct Report {
    map: String,
    grid: usize,
    texels: usize,
    rsl_count: usize,
    clamped_negative_values: usize,
    map_energy: [f64; 3],
    rsl_energy: [f64; 3],
    energy_relative_error: [f64; 3],
    error: LevelError,
    timings: Timings,
    rsls: Vec<RslJson>,
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Runs `rsl decompose`.
pub fn run(args: &DecomposeArgs) -> Result<()> {
    if !(1..=MAX_GRID).contains(&args.grid) {
        bail!("--grid must be between 1 and {MAX_GRID}, got {}", args.grid);
    }
    let texels = 6 * args.grid * args.grid;
    if !(1..=texels).contains(&args.rsl) {
        bail!("--rsl must be between 1 and {texels} (the texels of a 6×{g}×{g} grid), got {}", args.rsl, g = args.grid);
    }
    let mut outputs = crate::outputs::Outputs::new().input(&args.map, "the map to decompose");
    if let Some(path) = &args.png {
        crate::render::check_png(path, "--png")?;
        outputs = outputs.output(path, "--png");
    }
    if let Some(path) = &args.json {
        outputs = outputs.output(path, "--json");
    }
    outputs.check()?;
    let t = Instant::now();
    let loaded = load_latlong(&args.map)?;
    let load_ms = ms(t);
    let t = Instant::now();
    let env = CubeEnv::from_latlong(&loaded.map, args.grid);
    let resample_ms = ms(t);
    let t = Instant::now();
    let d = Decomposition::new(&env);
    let rsls = d.rsls(args.rsl)?;
    let decompose_ms = ms(t);

    let map_energy = rsl_env::cube_env::latlong_energy(&loaded.map);
    let mut rsl_energy = [0.0f64; 3];
    for x in &rsls {
        let q = f64::from(x.rsl.solid_angle());
        for (c, e) in rsl_energy.iter_mut().enumerate() {
            *e += f64::from(x.rsl.intensity[c]) * q;
        }
    }
    let rel = |c: usize| {
        if map_energy[c] > 0.0 { (rsl_energy[c] - map_energy[c]).abs() / map_energy[c] } else { rsl_energy[c].abs() }
    };
    let energy_relative_error = [rel(0), rel(1), rel(2)];
    let error = d.error(args.rsl)?;
    let name =
        args.map.file_name().map_or_else(|| args.map.display().to_string(), |n| n.to_string_lossy().into_owned());
    println!(
        "{name}: {} RSLs from 6×{g}×{g} ({texels} texels): energy error {:.1e}, light variance {:.4} (relative), fit error {:.4e}; load {load_ms:.1} ms, resample {resample_ms:.1} ms, decompose {decompose_ms:.1} ms",
        args.rsl,
        energy_relative_error.iter().copied().fold(0.0, f64::max),
        error.relative_light_variance,
        error.fit_error,
        g = args.grid,
    );
    // Negative texels clamped to 0 are a warning of the loader's (on stderr, once).
    if let Some(path) = &args.json {
        let report = Report {
            map: args.map.display().to_string(),
            grid: args.grid,
            texels,
            rsl_count: args.rsl,
            clamped_negative_values: loaded.clamped_negative,
            map_energy,
            rsl_energy,
            energy_relative_error,
            error,
            timings: Timings { load_ms, resample_ms, decompose_ms },
            rsls: rsls
                .iter()
                .map(|x| RslJson {
                    centre: x.rsl.centre.to_array(),
                    half_diagonal: x.rsl.half_diagonal,
                    intensity: x.rsl.intensity.to_array(),
                    energy: x.energy,
                    solid_angle: x.rsl.solid_angle(),
                    region_solid_angle: x.region_solid_angle,
                    texels: x.texels,
                    fit_error: x.fit_error,
                    penalised_error: x.penalised_error,
                    light_variance: x.light_variance,
                })
                .collect(),
        };
        rsl_engine::output::write_atomic(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    if let Some(path) = &args.png {
        let (w, h, rgb) = rsl_env::visualise::render_figure(&loaded.map, &d, args.rsl)?;
        rsl_engine::output::write_png(path, w, h, rgb)?;
    }
    Ok(())
}

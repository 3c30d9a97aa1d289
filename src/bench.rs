//! `rsl bench`: the speed–accuracy study over rsl-bench.

use anyhow::{Result, bail};
use rsl_bench::config::{Sweep, configs, default_sweeps};
use rsl_bench::{BenchOptions, run};
use std::path::PathBuf;

/// Arguments of `rsl bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// The scene files (TOML).
    #[arg(required = true)]
    pub scenes: Vec<PathBuf>,
    /// Output folder: results.csv, objects.csv, report.md and SVG plots. Results already
    /// there are kept: a finished configuration is not measured again.
    #[arg(long)]
    pub out: PathBuf,
    /// A sweep `KEY=V1,V2,…` over `rsl`, `quality` (draft, paper, high), `method` (cpu, gpu)
    /// or a quality knob (table_resolution, view_samples, env_grid, ovdf_directions,
    /// ovdf_shells, ovdf_vectors, cpca_clusters, cpca_vectors); repeat for more. Default:
    /// rsl=10,30,60,100,300 and quality=draft,paper.
    #[arg(long = "sweep")]
    pub sweeps: Vec<Sweep>,
    /// Samples per vertex of the truth (at least 2, so it can measure its own noise).
    #[arg(long, default_value_t = 256)]
    pub truth_spp: u32,
    /// Seed of the truth.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Scene times in seconds, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1")]
    pub times: Vec<f32>,
    /// Frames timed per configuration (the median is reported).
    #[arg(long, default_value_t = 5)]
    pub frames: usize,
    /// Precomputation options (the cache also holds the truths).
    #[command(flatten)]
    pub prepare: crate::render::PrepareArgs,
}

/// Most scene times one bench may hold.
const MAX_TIMES: usize = 100;
/// Most frames timed per configuration.
const MAX_FRAMES: usize = 1000;
/// Most samples per vertex of the truth.
const MAX_SPP: u32 = 1 << 16;

/// `rsl bench`.
pub fn bench(args: &BenchArgs) -> Result<()> {
    if args.prepare.rsl.is_some() || args.prepare.quality.is_some() {
        bail!("rsl bench takes --sweep rsl=… and --sweep quality=… instead of --rsl and --quality");
    }
    if let Some(t) = args.times.iter().find(|t| !t.is_finite()) {
        bail!("--times: {t} is not a finite number of seconds");
    }
    if args.times.is_empty() || args.times.len() > MAX_TIMES {
        bail!("--times: give between 1 and {MAX_TIMES} times");
    }
    if !(1..=MAX_FRAMES).contains(&args.frames) {
        bail!("--frames must be in 1..={MAX_FRAMES}");
    }
    if !(2..=MAX_SPP).contains(&args.truth_spp) {
        bail!("--truth-spp must be in 2..={MAX_SPP} (one sample cannot measure the truth's noise)");
    }
    let sweeps = if args.sweeps.is_empty() { default_sweeps() } else { args.sweeps.clone() };
    let configs = configs(&sweeps)?;
    let options = BenchOptions {
        scenes: args.scenes.clone(),
        out: args.out.clone(),
        configs,
        truth_spp: args.truth_spp,
        seed: args.seed,
        times: args.times.clone(),
        frames: args.frames,
        cache_dir: args.prepare.options().cache_dir,
        progress: crate::progress::bars(),
    };
    eprintln!(
        "bench: {} scene(s) × {} configuration(s) × {} time(s); truth at {} spp",
        options.scenes.len(),
        options.configs.len(),
        options.times.len(),
        options.truth_spp
    );
    let s = run(&options)?;
    eprintln!(
        "bench: {} measured, {} already in {}; truths: {} estimated, {} from the cache",
        s.measured,
        s.reused,
        args.out.join("results.csv").display(),
        s.truths_estimated,
        s.truths_reused
    );
    println!("{}", std::fs::read_to_string(args.out.join("report.md"))?);
    Ok(())
}

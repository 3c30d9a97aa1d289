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
    /// A sweep `KEY=V1,V2,…` over `rsl`, `quality` (draft, standard, paper, high), `method`
    /// (any method `rsl render --method` takes; `cpu` and `gpu` are `rsl` on that device),
    /// `device` (cpu, gpu; default cpu)
    /// or a quality knob (table_resolution, view_samples, env_grid, ovdf_directions,
    /// ovdf_shells, ovdf_vectors, cpca_clusters, cpca_vectors, traced_lights, shadow_rays,
    /// aa, bounces: each count of bounces is measured against a truth that follows as many);
    /// repeat for more. Default:
    /// rsl=10,30,60,100,300 and quality=draft,paper.
    #[arg(long = "sweep")]
    pub sweeps: Vec<Sweep>,
    /// Samples per vertex of the truth (at least 2, so it can measure its own noise).
    #[arg(long, default_value_t = 256)]
    pub truth_spp: u32,
    /// The truths' own noise to reach, as a fraction (0.01) or a percentage (1%): each
    /// scene's truths (per vertex, and per pixel for the images) take the samples that
    /// reach it, from a pilot estimate at 64 samples (the noise falls as 1/√samples; at most
    /// the largest --truth-spp), in place of --truth-spp and --grid-spp. Errors near the
    /// noise cannot be told apart from it: aim below the errors you expect.
    #[arg(long, value_parser = parse_error)]
    pub truth_noise: Option<f64>,
    /// Seed of the truth.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Scene times in seconds, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1")]
    pub times: Vec<f32>,
    /// The error to meet, as a fraction (0.05) or a percentage (5%): the cheapest measured
    /// configuration (least frame time, then least preparation) whose relative L2 against
    /// the truth is at most this at every time is printed and written as
    /// `<scene>_target.toml`, a `[quality]` table the scene can use.
    #[arg(long, value_parser = parse_error)]
    pub target_error: Option<f64>,
    /// Term counts of the Haar wavelet baseline (Ng et al. 2003: the environment's largest
    /// area-weighted coefficients on the scene's cube grid, against transport with shadow
    /// rays precomputed for the scene at each time), measured beside the sweep's
    /// configurations: each is the configuration `method=wavelet wavelet_terms=K` (the same
    /// as sweeping `--sweep method=wavelet --sweep wavelet_terms=…` alone).
    #[arg(long, value_delimiter = ',', default_value = "20,30,100")]
    pub wavelet_terms: Vec<usize>,
    /// Leave the wavelet baseline out.
    #[arg(long)]
    pub no_wavelet: bool,
    /// Samples per pixel of the per-pixel truth behind the image grid and the per-pixel
    /// errors, at half the camera's resolution unless --grid-full (0: no images).
    #[arg(long, default_value_t = 256)]
    pub grid_spp: u32,
    /// The image grid and the per-pixel errors at the camera's own resolution (the truth
    /// costs 4× the default half resolution's).
    #[arg(long)]
    pub grid_full: bool,
    /// Error budgets: for the CPU configurations with this many RSLs, the error with each
    /// approximation replaced by its exact value (`rsl render --oracle`), one at a time and
    /// all together, written to budget.csv and the report. Oracles trace shadow rays: a
    /// budget costs several truths' time.
    #[arg(long, default_value_t = 30)]
    pub budget: u32,
    /// Leave the error budgets out.
    #[arg(long)]
    pub no_budget: bool,
    /// Frames timed per configuration (the median is reported).
    #[arg(long, default_value_t = 5)]
    pub frames: usize,
    /// Measure one slice of the work, `K/N` (K from 0 to N − 1, as job-array indices count:
    /// `$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT`, `$JOB_COMPLETION_INDEX/N`): every Nth
    /// (scene, configuration, time) from the Kth, into files of its own in --out
    /// (`results-shard-K-of-N.csv`), beside the other shards. No images, no report: the next
    /// bench into --out without --shard, or --merge, joins the shards' rows. A rerun of a
    /// shard measures only what it had not finished. Give every shard the same scenes,
    /// sweeps and times, and one shared --cache (the truths are computed once there).
    #[arg(long)]
    pub shard: Option<rsl_bench::shard::Shard>,
    /// Join the finished shards' rows in --out into results.csv and write the report,
    /// measuring nothing (a shard still running is left for a later run, and named).
    #[arg(long, conflicts_with = "shard")]
    pub merge: bool,
    /// Measure every configuration again, replacing its rows already in --out (kept rows are
    /// matched by scene, configuration, time and truth, not by the build that measured them:
    /// after a change to shading, measure a page afresh with this).
    #[arg(long, conflicts_with = "merge")]
    pub fresh: bool,
    /// Precomputation options (the cache also holds the truths).
    #[command(flatten)]
    pub prepare: crate::render::PrepareArgs,
}

fn parse_error(s: &str) -> Result<f64, String> {
    let (v, scale) = match s.trim().strip_suffix('%') {
        Some(p) => (p, 0.01),
        None => (s.trim(), 1.0),
    };
    let x: f64 = v.parse().map_err(|_| format!("`{s}` is not a relative error such as 0.05 or 5%"))?;
    let x = x * scale;
    if !(x.is_finite() && x > 0.0) {
        return Err(format!("`{s}`: must be positive"));
    }
    if scale == 1.0 && x >= 1.0 {
        // A bare 5 is far more likely "5 %" than 500 %: say which to write.
        return Err(format!(
            "`{s}` would be {}% (a fraction); write {s}% for {s} percent, or {} as a fraction",
            x * 100.0,
            x / 100.0
        ));
    }
    Ok(x)
}

/// Most scene times one bench may hold.
const MAX_TIMES: usize = 100;
/// Most frames timed per configuration.
const MAX_FRAMES: usize = 1000;
/// Most samples per vertex of the truth.
const MAX_SPP: u32 = rsl_truth::MAX_SPP;

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
    if args.wavelet_terms.iter().any(|&k| k == 0 || k > 6 * 512 * 512) {
        bail!("--wavelet-terms: each count must be in 1..={}", 6 * 512 * 512);
    }
    if args.grid_spp > MAX_SPP {
        bail!("--grid-spp must be at most {MAX_SPP}");
    }
    if args.budget == 0 {
        bail!("--budget: the RSL count must be at least 1");
    }
    if !(2..=MAX_SPP).contains(&args.truth_spp) {
        bail!("--truth-spp must be in 2..={MAX_SPP} (one sample cannot measure the truth's noise)");
    }
    if let (Some(s), Some(_)) = (args.shard, args.target_error) {
        bail!(
            "--target-error picks from every configuration's rows: run it with --merge once the shards ({s}) are done"
        );
    }
    let sweeps = if args.sweeps.is_empty() { default_sweeps() } else { args.sweeps.clone() };
    // The sweep's configurations (what --target-error picks from), then the baseline's.
    let configs = configs(&sweeps)?;
    let mut measured = configs.clone();
    if !args.no_wavelet {
        // The largest first: its transport serves the smaller counts.
        let mut terms = args.wavelet_terms.clone();
        terms.sort_unstable_by(|a, b| b.cmp(a));
        terms.dedup();
        let sweeps = [
            Sweep { key: "method".into(), values: vec![rsl_engine::MethodId::WAVELET.to_string()] },
            Sweep { key: "wavelet_terms".into(), values: terms.iter().map(|k| k.to_string()).collect() },
        ];
        measured.extend(rsl_bench::config::configs(&sweeps)?);
    }
    let options = BenchOptions {
        scenes: args.scenes.clone(),
        out: args.out.clone(),
        configs: measured,
        truth_spp: args.truth_spp,
        seed: args.seed,
        times: args.times.clone(),
        frames: args.frames,
        grid_spp: args.grid_spp,
        grid_full: args.grid_full,
        truth_noise: args.truth_noise,
        cache_dir: args.prepare.options().cache_dir,
        progress: crate::progress::bars(),
        budget_rsl: (!args.no_budget).then_some(args.budget),
        command: command_line(),
        shard: args.shard,
        merge_only: args.merge,
        fresh: args.fresh,
    };
    let truth = match options.truth_noise {
        Some(x) => format!("truths to {:.2}% noise", 100.0 * x),
        None => format!("truth at {} spp", options.truth_spp),
    };
    crate::status!(
        "bench: {} scene(s) × {} configuration(s) × {} time(s); {truth}",
        options.scenes.len(),
        options.configs.len(),
        options.times.len()
    );
    let s = run(&options)?;
    if !s.merged.joined.is_empty() {
        let shards: Vec<String> = s.merged.joined.iter().map(ToString::to_string).collect();
        crate::status!("bench: joined the rows of shard(s) {}", shards.join(", "));
    }
    if !s.merged.running.is_empty() {
        let shards: Vec<String> = s.merged.running.iter().map(ToString::to_string).collect();
        eprintln!("bench: shard(s) {} still running: their rows are joined by a later run", shards.join(", "));
    }
    if args.merge {
        println!("{}", std::fs::read_to_string(args.out.join("report.md"))?);
        return pick_targets(args, &configs, &s);
    }
    let results = rsl_bench::shard::results_file(&args.out, args.shard);
    crate::status!(
        "bench: {} measured, {} already in {}; truths: {} estimated, {} from the cache",
        s.measured,
        s.reused,
        results.display(),
        s.truths_estimated,
        s.truths_reused
    );
    if !args.no_budget {
        crate::status!("bench: {} oracle setting(s) measured for error budgets", s.budget_measured);
    }
    if let Some(shard) = args.shard {
        crate::status!(
            "bench: shard {shard} done; join the shards with rsl bench --merge (or the next bench into --out)"
        );
        return Ok(());
    }
    println!("{}", std::fs::read_to_string(args.out.join("report.md"))?);
    pick_targets(args, &configs, &s)
}

/// `--target-error`: per scene, the cheapest configuration of this sweep that meets it,
/// printed and written as `<scene>_target.toml`.
fn pick_targets(args: &BenchArgs, configs: &[rsl_bench::config::Config], s: &rsl_bench::Summary) -> Result<()> {
    if let Some(x) = args.target_error {
        for path in &args.scenes {
            let name = path.display().to_string();
            // Only this sweep's configurations (not the wavelet baseline beside it): their
            // settings are what a scene takes.
            let ids: Vec<String> = configs.iter().map(|c| c.id()).collect();
            let rows: Vec<_> = s.rows.iter().filter(|r| ids.contains(&r.config)).cloned().collect();
            let pick = rsl_bench::target::pick(&rows, &name, x)?;
            let config = configs.iter().find(|c| c.id() == pick.config).expect("picked from this sweep");
            let base = rsl_scene::Scene::load(path)?.quality;
            let spp = rows
                .iter()
                .find(|r| r.scene == name && r.config == pick.config)
                .map_or(args.truth_spp, |r| r.truth_spp);
            let text = rsl_bench::target::fragment(&pick, config, base, spp)?;
            let file = args.out.join(format!("{}_target.toml", rsl_bench::report::stem(&name)));
            rsl_engine::output::write_atomic(&file, text.as_bytes())?;
            println!(
                "target {:.2}% on {name}: {} ({:.1} ms/frame, {:.2}%); wrote {}",
                100.0 * x,
                pick.config,
                pick.ms_per_frame,
                100.0 * pick.error,
                file.display()
            );
        }
    }
    Ok(())
}

/// The command line as typed, the program named `rsl`, each argument quoted where a shell
/// would split it.
fn command_line() -> String {
    let quote = |a: String| {
        if !a.is_empty() && a.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=,:+%".contains(c)) {
            a
        } else {
            format!("'{}'", a.replace('\'', "'\\''"))
        }
    };
    std::iter::once("rsl".to_owned())
        .chain(std::env::args_os().skip(1).map(|a| quote(a.to_string_lossy().into_owned())))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::parse_error;

    #[test]
    fn a_target_error_is_a_fraction_or_a_percentage_and_a_bare_5_is_refused() {
        assert_eq!(parse_error("0.05"), Ok(0.05));
        assert!((parse_error("5%").unwrap() - 0.05).abs() < 1e-12);
        let e = parse_error("5").unwrap_err();
        assert!(e.contains("500%") && e.contains("5%") && e.contains("0.05"), "{e}");
        assert!(parse_error("0").is_err() && parse_error("-1%").is_err() && parse_error("NaN").is_err());
    }
}

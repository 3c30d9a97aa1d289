//! The `rsl` command line: argument types and the commands they run.

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// rsl: all-frequency environment lighting of dynamic scenes with rotatable square lights.
#[derive(Debug, Parser)]
#[command(name = "rsl", version, about)]
pub struct Cli {
    /// Print errors only: no warnings, status lines or progress (RUST_LOG, when set, decides
    /// on warnings instead); `--timings` and `--explain` still print.
    #[arg(long, short, global = true)]
    pub quiet: bool,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Load and validate a scene file and print its summary (objects, meshes, materials,
    /// motion, environment, camera, quality).
    Scene {
        /// The scene file (TOML).
        scene: PathBuf,
        /// Also print world transforms at this time (seconds).
        #[arg(long)]
        time: Option<f32>,
    },
    /// Decompose an environment map into rotatable square lights (Xu et al. 2006, §4.1) and
    /// print a one-line summary; optionally write every RSL as JSON and a figure as PNG.
    Decompose(DecomposeArgs),
    /// Precompute (or load from the cache) everything a scene needs: RSLs, BRDF tables,
    /// self-visibility and occluder fields, and what the method draws with beyond them (the
    /// lobe path's transport lobes, `auto`'s choice for each object).
    Precompute {
        /// The scene files (TOML).
        #[arg(required = true)]
        scenes: Vec<PathBuf>,
        /// Prepare only every Nth scene from the Kth (`K/N`, K from 0 to N − 1, as job-array
        /// indices count), into the shared --cache: one element of a job array.
        #[arg(long)]
        shard: Option<rsl_bench::shard::Shard>,
        /// The method whose own preparation to make as well, as `rsl render --method` names
        /// it (default: `auto`, as `rsl render` draws): `lobe` fits every glossy object's
        /// transport lobes, `auto` those of objects whose scene `method` is `"lobe"` and
        /// measures its choice for the others at time 0.
        #[arg(long)]
        method: Option<rsl_engine::MethodId>,
        /// Precomputation options.
        #[command(flatten)]
        prepare: crate::render::PrepareArgs,
    },
    /// Render a scene to an image (PNG or EXR) or an animation, optionally with its shaded
    /// vertices as PLY.
    Render(crate::render::RenderArgs),
    /// Render the bundled default scene as an animation (objects moving, the environment
    /// turning, a material swapped halfway) into a folder, and print timings.
    Demo(crate::render::DemoArgs),
    /// The speed–accuracy study: sweep configurations (RSL count, quality preset, method,
    /// any quality knob) over scenes against the Monte Carlo truth; writes CSV, a Markdown
    /// report and SVG plots, and resumes where an earlier run stopped.
    Bench(crate::bench::BenchArgs),
    /// Error metrics (relative L2, RMSE, max, PSNR) of A against the reference B: two PLY
    /// files (per vertex) or two EXR files (over the pixels objects cover), with an optional
    /// false-colour heatmap.
    Compare(crate::compare::CompareArgs),
    /// The interactive viewer: move objects, rotate the environment, edit materials, change
    /// the RSL count and preset, and see what each stage costs; `--screenshot` renders the
    /// whole UI headless to a PNG.
    View(crate::view::ViewArgs),
    /// List the methods `render --method`, `bench --sweep method=` and the viewer's drawing
    /// take: how each draws, where, and when to use it (a Markdown table).
    Methods,
}

/// Arguments of `rsl decompose`.
#[derive(Debug, clap::Args)]
pub struct DecomposeArgs {
    /// The lat-long environment map (OpenEXR or Radiance .hdr).
    pub map: PathBuf,
    /// Number of RSLs.
    #[arg(long = "rsl", default_value_t = 30)]
    pub rsl: usize,
    /// Cube grid resolution R of the 6×R×R grid the map is resampled to.
    #[arg(long, default_value_t = 32)]
    pub grid: usize,
    /// Write every RSL (centre, half-diagonal, RGB intensity, energy, solid angle, texel
    /// count, fitting error) and the totals as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write a figure like the paper's fig. 6: the map with region borders and fitted squares,
    /// and below it the RSLs alone.
    #[arg(long)]
    pub png: Option<PathBuf>,
}

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    crate::progress::set_quiet(cli.quiet);
    match cli.command {
        Command::Scene { scene, time } => scene_summary(&scene, time),
        Command::Decompose(args) => crate::decompose::run(&args),
        Command::Precompute { scenes, shard, method, prepare } => {
            crate::render::precompute(&scenes, shard, method, &prepare)
        }
        Command::Render(args) => crate::render::render(&args),
        Command::Demo(args) => crate::render::demo(&args),
        Command::Compare(args) => crate::compare::run(&args),
        Command::Bench(args) => crate::bench::bench(&args),
        Command::View(args) => crate::view::run(&args),
        Command::Methods => {
            print!("{}", rsl_engine::registry::markdown_table());
            Ok(())
        }
    }
}

fn scene_summary(path: &std::path::Path, time: Option<f32>) -> Result<()> {
    let start = std::time::Instant::now();
    let scene = rsl_scene::Scene::load(path)?;
    print!("{}", scene.summary());
    if let Some(t) = time {
        anyhow::ensure!(t.is_finite(), "--time must be a finite number of seconds, got {t}");
        let state = scene.at(t);
        let (axis, angle) = state.world_from_env.to_axis_angle();
        println!("at t = {t} s: environment rotated {:.1}° about {:.3?}", angle.to_degrees(), axis.to_array());
        for (o, tr) in scene.objects.iter().zip(&state.objects) {
            let (axis, angle) = tr.rotation.to_axis_angle();
            println!(
                "    {:<12} at {:.3?} rotated {:.1}° about {:.3?} scale {:.3?}",
                o.name,
                tr.translation.to_array(),
                angle.to_degrees(),
                axis.to_array(),
                tr.scale.to_array()
            );
        }
    }
    println!("loaded in {:.1} ms", start.elapsed().as_secs_f64() * 1e3);
    Ok(())
}

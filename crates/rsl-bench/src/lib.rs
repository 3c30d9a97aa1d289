//! rsl-bench: the speed–accuracy study. For every configuration of a sweep (method, quality
//! preset, RSL count, any quality knob) and every scene and time: what preparing it cost
//! (ms, bytes), what a frame costs (median ms over several frames), and its error against
//! the Monte Carlo truth per vertex — relative L2 for the scene and per object, the mean
//! and 95th percentile of the per-vertex relative error — with the truth's own noise beside
//! it. The truth is computed once per (scene contents, time, samples, seed) and cached;
//! finished configurations are kept in `results.csv` and not measured again (unless
//! [`BenchOptions::fresh`]), so an interrupted bench resumes. Reports: CSV, Markdown and
//! SVG plots ([`report`]).

pub mod budget;
pub mod config;
pub mod grid;
pub mod plot;
pub mod report;
pub mod shard;
pub mod target;
pub mod truth;
pub use rsl_engine::wavelet;

use anyhow::{Context, Result, bail};
use config::Config;
use glam::Vec3;
use rsl_engine::method::{Method, Oracle, Request};
use rsl_engine::{Device, MethodId, MethodOptions};
use rsl_engine::{Engine, EngineOptions, Progress};
use rsl_scene::Scene;
use std::path::PathBuf;
use std::time::Instant;

/// What to measure and where to write it.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// The scene files.
    pub scenes: Vec<PathBuf>,
    /// The output folder (created if missing; results already there are kept and reused).
    pub out: PathBuf,
    /// The configurations.
    pub configs: Vec<Config>,
    /// Samples per vertex of the truth.
    pub truth_spp: u32,
    /// Seed of the truth.
    pub seed: u64,
    /// Scene times, seconds.
    pub times: Vec<f32>,
    /// Frames timed per configuration and time (the median is reported).
    pub frames: usize,
    /// Samples per pixel of the per-pixel truth behind the image grids and per-pixel errors
    /// (0: no images).
    pub grid_spp: u32,
    /// The images at the camera's own resolution (else at half of it).
    pub grid_full: bool,
    /// A noise target for the truths (relative L2 of their standard errors): each scene's
    /// truths take the samples that reach it, from a pilot estimate of [`PILOT_SPP`]
    /// ([`samples_for_noise`]), in place of `truth_spp`, and of `grid_spp` unless that is 0
    /// (`None`: those counts).
    pub truth_noise: Option<f64>,
    /// Cache folder for prepared data and truths (`None`: memory only, nothing reused
    /// between runs but the results).
    pub cache_dir: Option<PathBuf>,
    /// Progress of long steps.
    pub progress: Progress,
    /// Error budgets (every oracle alone and all together) for the CPU configurations with
    /// this many RSLs (`None`: no budgets).
    pub budget_rsl: Option<u32>,
    /// The command that asked for the bench, written at the top of its report (empty: none).
    pub command: String,
    /// Measure only this slice of the work, into the shard's own files, with no images and
    /// no report ([`shard`]); `None`: all of it, after joining the finished shards' rows.
    pub shard: Option<shard::Shard>,
    /// Only join the finished shards' rows and write the report: measure nothing.
    pub merge_only: bool,
    /// Measure every configuration again, replacing its rows (and its error budgets) already
    /// in the output folder: kept rows are reused by scene, configuration, time and truth,
    /// not by the build that measured them, so after a change to shading a page is measured
    /// afresh with this.
    pub fresh: bool,
}

/// One measured point: a configuration of a scene at a time.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// The scene file, as given.
    pub scene: String,
    /// [`Config::id`].
    pub config: String,
    /// The configuration.
    pub method: String,
    /// Its quality preset (the preset the scene's quality starts from, when not swept).
    pub quality: String,
    /// RSLs in use (the count asked for, or fewer where the environment grid holds fewer).
    pub rsl: u32,
    /// Scene time, s.
    pub time: f32,
    /// Preparation wall time, ms, from an empty memory store (what the disk cache holds
    /// counts as its reading time: a bench with a cold cache measures the builds), with what
    /// a lobe method prepares on its first frame (prefiltering, transport lobes).
    pub prepare_ms: f64,
    /// Bytes of prepared data held.
    pub prepare_bytes: usize,
    /// Items (tables, fields, light sets, and what the method builds itself: transport lobes,
    /// the wavelet baseline's transport) built for it rather than read from the caches: a
    /// configuration whose fields were built first pays their whole cost in `prepare_ms`.
    pub prepare_built: u64,
    /// Median shading time per frame, ms.
    pub ms_per_frame: f64,
    /// Relative L2 against the truth over the scene's vertices.
    pub relative_l2: f64,
    /// Mean per-vertex relative error (vertices the truth sees lit).
    pub mean_relative: f64,
    /// 95th percentile of the per-vertex relative error.
    pub p95_relative: f64,
    /// The truth's own relative L2 noise (standard errors).
    pub truth_noise: f64,
    /// Samples per vertex of the truth.
    pub truth_spp: u32,
    /// Relative L2 per pixel against the per-pixel truth over the pixels objects cover, at
    /// the grid's resolution, and that truth's own noise (`None` without images).
    pub pixel_l2: Option<(f64, f64)>,
    /// The same per object (over the pixels whose centre sees it): name, relative L2, the
    /// truth's noise there (empty without images).
    pub pixel_objects: Vec<(String, f64, f64)>,
    /// Median wall time of a whole frame with its image at the grid's resolution, ms: the
    /// vertices' shading, the interreflections and the drawing, per pixel where the method
    /// draws so, antialiased as the quality asks ([`image_frame_ms`]; `None` without images).
    pub image_ms: Option<f64>,
    /// Samples per vertex a Monte Carlo estimate needs to be as far from the truth as this
    /// configuration ([`equal_error_spp`]); `None` where the configuration is within the
    /// truth's own noise and the two cannot be told apart.
    pub mc_spp: Option<f64>,
    /// The time such an estimate takes on this machine, ms (the truth's time per sample).
    pub mc_ms: Option<f64>,
    /// Per object: name, relative L2, the truth's noise.
    pub objects: Vec<(String, f64, f64)>,
    /// The content key of the truth it was measured against ([`truth::key`]: the scene's
    /// contents at its time, the samples, the seed); a row whose key is not the current
    /// truth's is measured again. `None` in results written before rows carried it.
    pub truth_key: Option<u64>,
}

/// What a run did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Summary {
    /// Every row of the results, old and new.
    pub rows: Vec<Row>,
    /// Rows measured in this run.
    pub measured: usize,
    /// Rows found in the results already (not measured again).
    pub reused: usize,
    /// Truths estimated in this run.
    pub truths_estimated: usize,
    /// Oracle settings measured for error budgets.
    pub budget_measured: usize,
    /// Truths read from the cache.
    pub truths_reused: usize,
    /// The shards whose rows this run joined, and those still running.
    pub merged: shard::Merged,
}

/// An engine of `scene`'s method-neutral layer (what the truth needs), from the bench's
/// cache.
fn neutral_engine(scene: &Scene, options: &BenchOptions) -> Result<Engine> {
    Engine::new(
        scene,
        EngineOptions {
            cache_dir: options.cache_dir.clone(),
            layers: rsl_engine::Layers { rsl: false },
            progress: options.progress.clone(),
            ..EngineOptions::default()
        },
    )
}

/// An engine of `scene` (its quality already the configuration's) with the configuration's
/// RSL count, from the bench's cache.
fn config_engine(scene: &Scene, options: &BenchOptions, config: &Config) -> Result<Engine> {
    Engine::new(
        scene,
        EngineOptions {
            cache_dir: options.cache_dir.clone(),
            rsl_count: config.rsl,
            progress: options.progress.clone(),
            layers: config.method.capabilities().layers,
            ..EngineOptions::default()
        },
    )
}

/// The row of a measured frame: its errors against the truth (scene, per object, per
/// vertex) and the Monte Carlo estimate of equal error.
#[allow(clippy::too_many_arguments)]
fn measured_row(
    name: &str,
    scene: &Scene,
    config: String,
    method: &str,
    rsl: u32,
    time: f32,
    (prepare_ms, prepare_bytes, prepare_built): (f64, usize, u64),
    ms_per_frame: f64,
    radiance: &[Vec<Vec3>],
    truth: &truth::VertexTruth,
) -> Result<Row> {
    let (relative_l2, mean_relative, p95_relative) = vertex_errors(&radiance.concat(), &truth.mean.concat())?;
    let objects = object_errors(scene, radiance, truth)?;
    let mc_spp = equal_error_spp(relative_l2, truth.noise(None), truth.spp);
    Ok(Row {
        scene: name.to_string(),
        config,
        method: method.into(),
        quality: scene.quality.preset.name().into(),
        rsl,
        time,
        prepare_ms,
        prepare_bytes,
        prepare_built,
        ms_per_frame,
        relative_l2,
        mean_relative,
        p95_relative,
        truth_noise: truth.noise(None),
        truth_spp: truth.spp,
        mc_spp,
        mc_ms: mc_spp.map(|s| s * truth.seconds * 1e3 / f64::from(truth.spp)),
        pixel_l2: None,
        pixel_objects: Vec::new(),
        image_ms: None,
        objects,
        truth_key: None,
    })
}

/// Per object: its name, the relative L2 of `radiance` against the truth, and the truth's
/// own noise there.
fn object_errors(scene: &Scene, radiance: &[Vec<Vec3>], truth: &truth::VertexTruth) -> Result<Vec<(String, f64, f64)>> {
    scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let e = rsl_truth::compare(&radiance[i], &truth.mean[i], None)?.relative_l2;
            Ok((o.name.clone(), e, truth.noise(Some(i))))
        })
        .collect()
}

/// Most configurations one grid shows.
pub const GRID_ROWS: usize = 24;

/// The image pass: per scene and time, the per-pixel truth (cached) at the grid's resolution
/// ([`grid::grid_scene`]); every configuration of the sweep rendered there (prepared data
/// comes from the cache); its per-pixel errors, over the scene and per object, filled into
/// its row; and the grid `<scene>_grid_t<time>.png` of the
/// first [`GRID_ROWS`] configurations.
fn images(options: &BenchOptions, summary: &mut Summary, methods: &mut Methods) -> Result<()> {
    for scene_path in &options.scenes {
        let name = scene_path.display().to_string();
        let full = Scene::load(scene_path)?;
        let base = full.quality;
        let mut scene = grid::grid_scene(&full, options.grid_full);
        let names: Vec<String> = scene.objects.iter().map(|o| o.name.clone()).collect();
        let neutral = neutral_engine(&scene, options)?;
        let truth_at = |scene: &Scene, t: f32, spp: u32| {
            let dir = options.cache_dir.as_deref();
            grid::truth_image(&neutral, scene, t, spp, options.seed, dir, &options.progress)
        };
        let spp = truth_samples(options, summary, options.grid_spp, |spp| {
            let (pilot, cached) = truth_at(&scene, options.times[0], spp)?;
            Ok((pilot.noise(|_| true), cached))
        })?;
        for &t in &options.times {
            // The scene's own truth first (the grid's top row), then one per other count of
            // bounces a configuration asks for.
            scene.quality = base;
            let (truth, cached) = truth_at(&scene, t, spp)?;
            summary.count_truth(cached);
            let mut others: Vec<(u32, grid::TruthImage)> = Vec::new();
            let mut renders = Vec::new();
            for config in &options.configs {
                scene.quality = config.quality(base)?;
                let b = scene.quality.settings.bounces;
                if b != base.settings.bounces && !others.iter().any(|o| o.0 == b) {
                    let (tr, cached) = truth_at(&scene, t, spp)?;
                    summary.count_truth(cached);
                    others.push((b, tr));
                }
                let against = others.iter().find(|o| o.0 == b).map_or(&truth, |o| &o.1);
                let mut engine = config_engine(&scene, options, config)?;
                let method = methods.get(config, &engine, options)?;
                let request = Request { time: t, image: true, vertices: false, exposure: None };
                // The whole frame with its image, timed as the vertices' shading is: the
                // median of `frames` frames.
                let (mut times, mut image) = (Vec::with_capacity(options.frames), None);
                for _ in 0..options.frames {
                    let start = Instant::now();
                    let frame = rsl_engine::textured::render_with(method, &mut engine, &scene, &request)?;
                    times.push(image_frame_ms(start.elapsed().as_secs_f64() * 1e3, &frame.timings));
                    image = Some(frame.image.context("an image was asked for")?);
                }
                let image = image.context("at least one frame")?;
                let err = grid::pixel_error(&image, against, &names)?;
                if let Some(r) =
                    summary.rows.iter_mut().find(|r| r.scene == name && r.config == config.id() && r.time == t)
                {
                    r.pixel_l2 = Some(err.scene);
                    r.pixel_objects = err.objects;
                    r.image_ms = Some(median(times));
                }
                renders.push((format!("{} {:.2}%", config.id(), 100.0 * err.scene.0), image));
            }
            let rows: Vec<grid::GridRow<'_>> = renders
                .iter()
                .take(GRID_ROWS)
                .map(|(label, image)| grid::GridRow { label: label.clone(), image })
                .collect();
            let label = format!("truth {spp} spp, noise {:.2}%", 100.0 * truth.noise(|_| true));
            let (rgb, w, h) = grid::grid(&truth.image, &label, &rows);
            let file = options.out.join(format!("{}_grid_t{t}.png", report::stem(&name)));
            rsl_engine::output::write_png(&file, w, h, rgb)?;
        }
    }
    Ok(())
}

/// The time of a frame with its image whose render took `wall_ms`: the render's wall time
/// less what it prepared for the frames after it ([`rsl_engine::Timings::preparation_ms`]:
/// the lobe methods' prefiltering and transport lobes, `auto`'s choice), which the row's
/// preparation counts.
pub fn image_frame_ms(wall_ms: f64, timings: &rsl_engine::Timings) -> f64 {
    (wall_ms - timings.preparation_ms()).max(0.0)
}

/// The methods a bench measures, built from the registry when first needed and kept (what
/// they prepare, such as the lobe methods' prefiltered environment, serves every
/// configuration after).
#[derive(Default)]
struct Methods(Vec<((MethodId, Device), Box<dyn Method>)>);

impl Methods {
    /// The method of `config`, for `engine`'s scene.
    fn get(&mut self, config: &Config, engine: &Engine, options: &BenchOptions) -> Result<&mut dyn Method> {
        let key = (config.method, config.device);
        let at = match self.0.iter().position(|(k, _)| *k == key) {
            Some(at) => at,
            None => {
                let o = MethodOptions {
                    device: config.device,
                    spp: options.truth_spp,
                    seed: options.seed,
                    progress: options.progress.clone(),
                    gpu: None,
                };
                let m = config
                    .method
                    .create(engine, &o)
                    .with_context(|| format!("--sweep method={}", config.method_name()))?;
                self.0.push((key, m));
                self.0.len() - 1
            }
        };
        Ok(self.0[at].1.as_mut())
    }
}

/// Samples per vertex a Monte Carlo estimate needs to be `error` (relative L2) from a truth
/// of `spp` samples whose own noise is `noise`, measured the same way: two independent
/// estimates differ by the root sum of their noises, and an estimate's noise falls as
/// 1/√samples (the truth's measured `noise` at `spp` sets the constant), so
/// `noise² · spp / s + noise² = error²`. `None` when `error` is within the truth's noise.
pub fn equal_error_spp(error: f64, noise: f64, spp: u32) -> Option<f64> {
    (error > noise * 1.000_001 && noise > 0.0).then(|| f64::from(spp) * noise * noise / (error * error - noise * noise))
}

/// Vertices darker than this fraction of the mean radiance of the lit vertices are left out
/// of the per-vertex relative errors: their relative error measures the truth's noise on
/// almost nothing (they still count, with their weight, in the relative L2).
pub const DARK: f32 = 0.01;

impl Summary {
    /// Counts a truth read from the cache or estimated.
    fn count_truth(&mut self, cached: bool) {
        if cached {
            self.truths_reused += 1;
        } else {
            self.truths_estimated += 1;
        }
    }
}

/// The error of `test` against the truth: relative L2 over all vertices, and the mean and
/// 95th percentile of the per-vertex relative error `|a − b|₂ / |b|₂` over the vertices the
/// truth sees lit, brighter than [`DARK`] times their mean.
pub fn vertex_errors(test: &[Vec3], truth: &[Vec3]) -> Result<(f64, f64, f64)> {
    let l2 = rsl_truth::compare(test, truth, None)?.relative_l2;
    let lit: Vec<f32> = truth.iter().map(|b| b.length()).filter(|&l| l > 0.0).collect();
    let floor = DARK * lit.iter().sum::<f32>() / lit.len().max(1) as f32;
    let mut rel: Vec<f64> = test
        .iter()
        .zip(truth)
        .filter(|(_, b)| b.length() > floor)
        .map(|(a, b)| f64::from((*a - *b).length() / b.length()))
        .collect();
    if rel.is_empty() {
        return Ok((l2, 0.0, 0.0));
    }
    rel.sort_by(f64::total_cmp);
    let mean = rel.iter().sum::<f64>() / rel.len() as f64;
    let p95 = rel[((rel.len() - 1) as f64 * 0.95).round() as usize];
    Ok((l2, mean, p95))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Each scene's plots, error grids and target scene are named after its file stem
/// ([`report::stem`]): two scenes of one folder's study (this run's and those of the rows
/// already there) must not share one, nor may a scene be given twice.
fn check_stems(options: &BenchOptions, rows: &[Row]) -> Result<()> {
    let given: Vec<String> = options.scenes.iter().map(|p| p.display().to_string()).collect();
    for (i, a) in given.iter().enumerate() {
        if given[..i].contains(a) {
            bail!("scene {a} is given twice");
        }
    }
    let mut names: Vec<&str> = given.iter().map(String::as_str).collect();
    for r in rows {
        if !names.contains(&r.scene.as_str()) {
            names.push(&r.scene);
        }
    }
    for (i, a) in names.iter().enumerate() {
        if let Some(b) = names[..i].iter().find(|b| report::stem(b) == report::stem(a)) {
            bail!(
                "scenes {b} and {a} share the file stem `{}`, after which each scene's plots, error grids and \
                 target scene in {} are named: rename one, or measure it into another --out",
                report::stem(a),
                options.out.display()
            );
        }
    }
    Ok(())
}

/// Samples per vertex or pixel of the pilot estimate behind a noise target
/// ([`BenchOptions::truth_noise`]).
pub const PILOT_SPP: u32 = 64;

/// The samples a Monte Carlo truth needs for its noise to come to `target`, where
/// [`PILOT_SPP`] samples gave `pilot` (the noise falls as 1/√samples): rounded up to a
/// multiple of the pilot's (so that nearby targets share a cached truth), within
/// `PILOT_SPP..=max`.
pub fn samples_for_noise(pilot: f64, target: f64, max: u32) -> u32 {
    if !(pilot.is_finite() && target > 0.0) {
        return max;
    }
    let k = (pilot / target).powi(2).ceil().max(1.0);
    (k * f64::from(PILOT_SPP)).min(f64::from(max)) as u32
}

/// The samples of a scene's truth: `fixed`, or with a noise target those that reach it from
/// `pilot(PILOT_SPP)` (its noise, and whether it came from the cache).
fn truth_samples(
    options: &BenchOptions,
    summary: &mut Summary,
    fixed: u32,
    pilot: impl FnOnce(u32) -> Result<(f64, bool)>,
) -> Result<u32> {
    let Some(target) = options.truth_noise else { return Ok(fixed) };
    let (noise, cached) = pilot(PILOT_SPP)?;
    summary.count_truth(cached);
    Ok(samples_for_noise(noise, target, rsl_truth::MAX_SPP))
}

/// The lock file a bench holds in its `--out` folder while it runs.
pub const LOCK_FILE: &str = "bench.lock";

/// A bench's hold on its `--out` folder: [`LOCK_FILE`], locked, removed when the bench ends.
struct OutLock {
    path: PathBuf,
    _file: std::fs::File,
}

impl Drop for OutLock {
    fn drop(&mut self) {
        // Removed while still locked; the lock goes with the file's closing just after.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Holds `out` for this bench: [`LOCK_FILE`] locked (an advisory lock the system releases
/// when the process ends, however it ends), with this process's id in it. Another bench
/// into the same folder would read the results, measure, and write them back over this
/// one's: it is refused before any work.
fn lock_out(out: &std::path::Path, shard: Option<shard::Shard>) -> Result<OutLock> {
    use std::io::{Read, Seek, Write};
    let path = shard::lock_file(out, shard);
    let mut file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(&path)
        .with_context(|| format!("cannot open {}", path.display()))?;
    match file.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => {
            let mut holder = String::new();
            let _ = file.read_to_string(&mut holder);
            let holder = holder.trim();
            let by = if holder.is_empty() { String::new() } else { format!(" (process {holder})") };
            let who = shard.map_or("another bench".into(), |s| format!("another process of shard {s}"));
            bail!(
                "{}: {who}{by} is writing into this folder; wait for it to finish, or give another --out",
                out.display()
            );
        }
        Err(std::fs::TryLockError::Error(e)) => {
            return Err(e).with_context(|| format!("cannot lock {}", path.display()));
        }
    }
    file.set_len(0)
        .and_then(|()| file.rewind())
        .and_then(|()| write!(file, "{}", std::process::id()))
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(OutLock { path, _file: file })
}

/// Runs the study: measures every (scene, configuration, time) not already in
/// `out/results.csv`, writing the results after each, then the reports.
/// One bench at a time per `out` ([`LOCK_FILE`]).
pub fn run(options: &BenchOptions) -> Result<Summary> {
    if options.scenes.is_empty() || options.configs.is_empty() || options.times.is_empty() {
        bail!("nothing to measure: give at least one scene, configuration and time");
    }
    if options.frames == 0 || options.truth_spp < 2 {
        bail!("--frames must be at least 1 and --truth-spp at least 2 (one sample cannot estimate its noise)");
    }
    std::fs::create_dir_all(&options.out).with_context(|| format!("cannot create {}", options.out.display()))?;
    if let Some(s) = options.shard {
        if options.merge_only {
            bail!("a shard ({s}) measures its slice; --merge joins the shards' rows afterwards, without --shard");
        }
        shard::check_count(&options.out, s)?;
    }
    let _lock = lock_out(&options.out, options.shard)?;
    let results = shard::results_file(&options.out, options.shard);
    let mut summary = Summary { rows: report::read_rows(&results)?, ..Summary::default() };
    let budget_file = shard::budget_file(&options.out, options.shard);
    let mut budget_rows = budget::read_rows(&budget_file)?;
    // A shard also takes the joined rows as measured (a rerun of a killed shard whose rows
    // were joined meanwhile); the whole bench joins the finished shards first.
    let (joined, joined_budget) = match options.shard {
        Some(_) => (
            report::read_rows(&shard::results_file(&options.out, None))?,
            budget::read_rows(&shard::budget_file(&options.out, None))?,
        ),
        None => {
            summary.merged = shard::merge(&options.out, &mut summary.rows, &mut budget_rows)?;
            (Vec::new(), Vec::new())
        }
    };
    check_stems(options, &summary.rows)?;
    if options.merge_only {
        report::write_reports(&options.out, &options.command, &summary.rows, &budget_rows, options.grid_full)?;
        return Ok(summary);
    }
    let mut methods = Methods::default();
    // The pieces of work counted over the whole bench, so that each shard takes its own.
    let mut item = 0;
    let mut budget_item = 0;
    for scene_path in &options.scenes {
        let name = scene_path.display().to_string();
        let mut scene = Scene::load(scene_path)?;
        let base = scene.quality;
        // The truths' keys, one per time: a row measured against another truth (other
        // samples or seed, or the scene's contents changed since) is measured again.
        let neutral = neutral_engine(&scene, options)?;
        let truth_at = |scene: &Scene, t: f32, spp: u32| {
            let dir = options.cache_dir.as_deref();
            truth::truth(&neutral, scene, t, spp, options.seed, dir, &options.progress)
        };
        let spp = truth_samples(options, &mut summary, options.truth_spp, |spp| {
            let (pilot, cached) = truth_at(&scene, options.times[0], spp)?;
            Ok((pilot.noise(None), cached))
        })?;
        // One truth per time and per count of bounces the configurations ask for (a quality
        // knob a sweep may vary): each is measured against a truth that follows as many.
        let bounce = |c: &Config| c.quality(base).map_or(base.settings.bounces, |q| q.settings.bounces);
        let mut counts: Vec<u32> = options.configs.iter().map(bounce).collect();
        counts.sort_unstable();
        counts.dedup();
        let at_bounces = |b: u32| {
            let mut s = scene.clone();
            s.quality.settings.bounces = b;
            s
        };
        let keys: Vec<(f32, u32, u64)> = options
            .times
            .iter()
            .flat_map(|&t| counts.iter().map(move |&b| (t, b)))
            .map(|(t, b)| (t, b, truth::key(&neutral, &at_bounces(b), t, spp, options.seed)))
            .collect();
        let key_at = |t: f32, b: u32| keys.iter().find(|k| k.0 == t && k.1 == b).map(|k| k.2);
        let first = item;
        item += options.configs.len() * options.times.len();
        let mine: Vec<(&Config, f32)> = options
            .configs
            .iter()
            .flat_map(|c| options.times.iter().map(move |&t| (c, t)))
            .enumerate()
            .filter(|(i, _)| options.shard.is_none_or(|s| s.takes(first + i)))
            .map(|(_, w)| w)
            .collect();
        let todo: Vec<(&Config, f32)> = mine
            .iter()
            .copied()
            .filter(|(c, t)| {
                options.fresh
                    || !summary.rows.iter().chain(&joined).any(|r| {
                        r.scene == name && r.config == c.id() && r.time == *t && r.truth_key == key_at(*t, bounce(c))
                    })
            })
            .collect();
        summary.reused += mine.len() - todo.len();
        // Every budget setting of this scene, then this run's: its shard's, not yet measured.
        let budget_all: Vec<(&Config, f32, &'static str, rsl_shade::Oracles)> = options
            .budget_rsl
            .map(|n| {
                options
                    .configs
                    .iter()
                    .filter(|c| c.method.capabilities().oracles && c.device == Device::Cpu)
                    .filter(|c| c.rsl.unwrap_or(scene.environment.rsl_count) == n)
                    .flat_map(|c| options.times.iter().map(move |&t| (c, t)))
                    .flat_map(|(c, t)| budget::oracle_settings().into_iter().map(move |(o, set)| (c, t, o, set)))
                    .collect()
            })
            .unwrap_or_default();
        let first_budget = budget_item;
        budget_item += budget_all.len();
        let budget_todo: Vec<(&Config, f32, &'static str, rsl_shade::Oracles)> = budget_all
            .into_iter()
            .enumerate()
            .filter(|(i, _)| options.shard.is_none_or(|s| s.takes(first_budget + i)))
            .map(|(_, w)| w)
            .filter(|(c, t, o, _)| {
                options.fresh
                    || !budget_rows.iter().chain(&joined_budget).any(|r| {
                        r.scene == name
                            && r.config == c.id()
                            && r.time == *t
                            && r.oracle == *o
                            && r.truth_key == key_at(*t, bounce(c))
                    })
            })
            .collect();
        if todo.is_empty() && budget_todo.is_empty() {
            continue;
        }
        // The truths, once per time and count of bounces: only the method-neutral layer is
        // needed for them.
        let mut truths = Vec::new();
        for &t in &options.times {
            for &b in &counts {
                let (tr, cached) = truth_at(&at_bounces(b), t, spp)?;
                summary.count_truth(cached);
                truths.push((t, b, tr));
            }
        }
        let task = format!("{name}: {} configuration(s) to measure", todo.len());
        let total = todo.len();
        options.progress.report(&rsl_engine::Event::Started { task: &task });
        for (done, (config, t)) in todo.into_iter().enumerate() {
            options.progress.report(&rsl_engine::Event::Advanced { task: &task, done, total });
            let b = bounce(config);
            let truth = &truths.iter().find(|k| k.0 == t && k.1 == b).expect("a truth per time and bounces").2;
            scene.quality = config.quality(base)?;
            let start = Instant::now();
            let mut engine =
                config_engine(&scene, options, config).with_context(|| format!("{name}: {}", config.id()))?;
            let prepare_ms = start.elapsed().as_secs_f64() * 1e3;
            let method = methods.get(config, &engine, options).with_context(|| format!("{name}: {}", config.id()))?;
            let built_before = method.built();
            let request = Request { time: t, image: false, vertices: true, exposure: None };
            let mut times = Vec::with_capacity(options.frames);
            let mut frame = None;
            let mut prepare_ms = prepare_ms;
            for k in 0..options.frames {
                let f = rsl_engine::textured::render_with(method, &mut engine, &scene, &request)?;
                // The vertices' shading, with the interreflections gathered at them.
                times.push(f.timings.ms("shade") + f.timings.ms("interreflections"));
                if k == 0 {
                    // What the methods prepare on their first frame (the lobe methods'
                    // prefiltered environment and transport lobes, the wavelet baseline's
                    // transport, `auto`'s choice) is preparation; kept by the method, the
                    // configuration that built it pays for it, as for fields.
                    prepare_ms += f.timings.preparation_ms();
                }
                frame = Some(f);
            }
            let frame = frame.expect("at least one frame");
            let row = measured_row(
                &name,
                &scene,
                config.id(),
                &config.method_name(),
                engine.rsls().len() as u32,
                t,
                (
                    prepare_ms,
                    engine.memory().resident_bytes + method.bytes(),
                    engine.cache_stats().misses + (method.built() - built_before),
                ),
                median(times),
                &frame.radiance,
                truth,
            )?;
            // It replaces a row measured against another truth.
            summary.rows.retain(|r| !(r.scene == name && r.config == row.config && r.time == t));
            summary.rows.push(Row { truth_key: key_at(t, b), ..row });
            summary.measured += 1;
            report::write_rows(&results, &summary.rows)?;
        }
        options.progress.report(&rsl_engine::Event::Finished { task: &task });
        // One engine per configuration, its light set switched between the fitted one and one
        // per texel (the light oracle) as the settings need.
        let mut prepared: Option<(String, Engine, usize)> = None;
        for (config, t, oracle, set) in budget_todo {
            let b = bounce(config);
            let truth = &truths.iter().find(|k| k.0 == t && k.1 == b).expect("a truth per time and bounces").2;
            scene.quality = config.quality(base)?;
            let what = format!("{name}: {} with oracle {oracle}", config.id());
            if prepared.as_ref().is_none_or(|(id, _, _)| *id != config.id()) {
                let engine = config_engine(&scene, options, config).with_context(|| what.clone())?;
                let fitted = engine.rsl_count();
                prepared = Some((config.id(), engine, fitted));
            }
            let (_, engine, fitted) = prepared.as_mut().expect("prepared just above");
            if set.light {
                Oracle::prepare(engine, set).with_context(|| what.clone())?;
            } else if engine.rsl_count() != *fitted {
                engine.set_rsl_count(*fitted).with_context(|| what.clone())?;
            }
            let mut method = Oracle::new(set);
            method.progress = options.progress.clone();
            let request = Request { time: t, image: false, vertices: true, exposure: None };
            let start = Instant::now();
            let frame = rsl_engine::textured::render_with(&mut method, engine, &scene, &request)
                .with_context(|| what.clone())?;
            let ms = start.elapsed().as_secs_f64() * 1e3;
            let relative_l2 = rsl_truth::compare(&frame.radiance.concat(), &truth.mean.concat(), None)?.relative_l2;
            let objects = object_errors(&scene, &frame.radiance, truth)?.into_iter().map(|(n, e, _)| (n, e)).collect();
            // It replaces a row measured against another truth.
            budget_rows.retain(|r| !(r.scene == name && r.config == config.id() && r.time == t && r.oracle == oracle));
            budget_rows.push(budget::BudgetRow {
                scene: name.clone(),
                config: config.id(),
                time: t,
                oracle: oracle.to_string(),
                relative_l2,
                truth_noise: truth.noise(None),
                ms,
                rays: frame.shadow_rays,
                objects,
                truth_key: key_at(t, b),
            });
            summary.budget_measured += 1;
            budget::write_rows(&budget_file, &budget_rows)?;
        }
        scene.quality = base;
    }
    if options.shard.is_some() {
        // The images and the report are the whole bench's, drawn once the shards are joined.
        return Ok(summary);
    }
    if options.grid_spp > 0 {
        images(options, &mut summary, &mut methods)?;
        report::write_rows(&results, &summary.rows)?;
    }
    report::write_reports(&options.out, &options.command, &summary.rows, &budget_rows, options.grid_full)?;
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_errors_leave_out_dark_vertices_from_the_relative_ones() {
        // Truth: three lit vertices of radiance 1, one nearly black, one black.
        let truth = [Vec3::X, Vec3::X, Vec3::X, Vec3::X * 1e-6, Vec3::ZERO];
        let test = [Vec3::X * 1.1, Vec3::X * 0.8, Vec3::X, Vec3::X * 1e-3, Vec3::ZERO];
        let (l2, mean, p95) = vertex_errors(&test, &truth).unwrap();
        let num = 0.01 + 0.04 + (1e-3f64 - 1e-6).powi(2);
        assert!((l2 - (num / (3.0 + 1e-12)).sqrt()).abs() < 1e-6, "{l2}");
        assert!((mean - 0.1).abs() < 1e-6, "mean of 0.1, 0.2 and 0: {mean}");
        assert!((p95 - 0.2).abs() < 1e-6, "{p95}");
    }

    #[test]
    fn equal_error_samples_follow_the_square_root_law() {
        // A truth of 256 samples with 4 % noise; an estimate 5 % away from it.
        let s = equal_error_spp(0.05, 0.04, 256).unwrap();
        // The estimate with s samples has noise 0.04·√(256/s) = 0.03, and √(0.03² + 0.04²) = 0.05.
        assert!((0.04 * (256.0 / s).sqrt() - 0.03).abs() < 1e-12, "{s}");
        assert_eq!(equal_error_spp(0.04, 0.04, 256), None);
        assert_eq!(equal_error_spp(0.01, 0.04, 256), None);
    }
}

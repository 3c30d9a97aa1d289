//! `rsl precompute`, `rsl render` and `rsl demo`: loops over rsl-engine's [`Method`]s.

use anyhow::{Context, Result, bail};
use rsl_engine::method::{Frame, Method, Oracle, Request, exposure_for};
use rsl_engine::registry::ImageKind;
use rsl_engine::{Device, Engine, EngineOptions, MethodId, MethodOptions, Session, output, ply};
use rsl_scene::{Brdf, Preset, Scene};
use rsl_shade::{Oracles, tonemap};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options shared by every command that prepares a scene.
#[derive(Clone, Debug, clap::Args)]
pub struct PrepareArgs {
    /// Number of RSLs (overrides the scene's `rsl_count`).
    #[arg(long = "rsl")]
    pub rsl: Option<u32>,
    /// Quality preset (overrides the scene's `quality`): draft, standard, paper or high.
    #[arg(long, value_parser = parse_preset)]
    pub quality: Option<Preset>,
    /// Cache folder for precomputed data (default: $RSL_CACHE_DIR, else
    /// $XDG_CACHE_HOME/rsl, else ~/.cache/rsl).
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Do not read or write the disk cache.
    #[arg(long, conflicts_with = "cache")]
    pub no_cache: bool,
}

fn parse_preset(s: &str) -> Result<Preset, String> {
    Preset::from_name(s).ok_or_else(|| format!("unknown quality preset `{s}`; known: draft, standard, paper, high"))
}

impl PrepareArgs {
    /// The engine options these arguments ask for (progress shown).
    pub fn options(&self) -> EngineOptions {
        EngineOptions {
            cache_dir: if self.no_cache { None } else { self.cache.clone().or_else(rsl_engine::cache::default_dir) },
            rsl_count: self.rsl,
            quality: self.quality,
            progress: crate::progress::bars(),
            ..EngineOptions::default()
        }
    }
}

/// The scene `rsl render` and `rsl view` are given: a scene file or a glTF file (seen
/// through its perspective camera `camera` where one is asked for), lit by the map `env`
/// where one is given.
pub(crate) fn open_scene(path: &Path, env: Option<&Path>, camera: Option<usize>) -> Result<Scene> {
    let mut scene = Scene::load_with_camera(path, camera)?;
    if let Some(env) = env {
        scene.set_environment_map(env)?;
    }
    Ok(scene)
}

/// Arguments of `rsl render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// The scene: a scene file (TOML), or a glTF file (.glb, .gltf) opened as a scene — each
    /// node's meshes objects with their glTF materials, the file's camera or one framed on
    /// it, the bundled studio map unless --env names another.
    pub scene: PathBuf,
    /// An environment map (.exr or .hdr) lighting the scene in place of its own.
    #[arg(long)]
    pub env: Option<PathBuf>,
    /// A glTF file's perspective camera to look through, numbered from 0 in node order
    /// (default: its first; a camera framed on the scene where it has none).
    #[arg(long)]
    pub camera: Option<usize>,
    /// Scene time in seconds of a single frame.
    #[arg(long, conflicts_with = "frames")]
    pub time: Option<f32>,
    /// An animation: frames A..B (B excluded) at time k/fps; writes numbered images and an
    /// animated GIF beside them.
    #[arg(long, value_parser = parse_range)]
    pub frames: Option<(u32, u32)>,
    /// Frames per second of an animation.
    #[arg(long, default_value_t = 24.0)]
    pub fps: f32,
    /// Image size WIDTHxHEIGHT in pixels, in place of the scene camera's (its vertical field
    /// of view kept), e.g. `1920x1080`.
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Where shading and drawing run: `auto` (a hardware GPU when there is one and the
    /// method runs there, else the CPU), `cpu` or `gpu` (software adapters included).
    #[arg(long, default_value_t = Device::Auto)]
    pub device: Device,
    /// Print the time of every pass of every frame (GPU timestamps where the adapter has
    /// them, wall time otherwise).
    #[arg(long)]
    pub timings: bool,
    /// How radiance is computed: any registered method (`rsl methods` lists them; `truth`
    /// is the Monte Carlo reference, per pixel through the camera and per vertex for
    /// --vertex-out). By default `auto` (each object by its most accurate drawing per
    /// pixel), on the CPU or the GPU.
    #[arg(long)]
    pub method: Option<MethodId>,
    /// Print which method draws each object, and why, before rendering.
    #[arg(long)]
    pub explain: bool,
    /// Samples per pixel and per vertex of `--method truth` (each sample traces up to two
    /// shadow rays: one toward the environment, one along the BRDF).
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    /// Seed of `--method truth` (the result is deterministic for a seed).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Bounces of light between surfaces (the scene's quality knob `bounces`, 0 to 8; 0:
    /// the environment's light alone): `--method truth` follows paths of up to N + 1
    /// segments; the other methods gather them at the vertices (`bounce_rays` directions
    /// each) and add them, interpolated, to their image.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=i64::from(rsl_scene::quality::MAX_BOUNCES)))]
    pub bounces: Option<u32>,
    /// Replace approximations of the RSL path by their exact values, to see what each
    /// costs: a comma-separated list of `light` (one RSL per environment texel), `brdf`
    /// (square integrals by quadrature), `self` and `occluders` (visibility by shadow rays),
    /// `product` (the whole product by quadrature with rays), or `all`. CPU only; slow.
    #[arg(long, value_parser = parse_oracles)]
    pub oracle: Option<Oracles>,
    /// Output image: .png (tonemapped) or .exr (linear radiance).
    #[arg(long, required_unless_present = "vertex_out")]
    pub out: Option<PathBuf>,
    /// Write the shaded vertices as PLY (alone, without --out, no image is rendered: for
    /// `--method truth` that skips the per-pixel estimate).
    #[arg(long)]
    pub vertex_out: Option<PathBuf>,
    /// Exposure multiplier for PNG output (default: automatic, from the objects in the first
    /// frame, then held for the whole animation).
    #[arg(long)]
    pub exposure: Option<f32>,
    /// Precomputation options.
    #[command(flatten)]
    pub prepare: PrepareArgs,
}

fn parse_oracles(s: &str) -> Result<Oracles, String> {
    Oracles::parse(s).map_err(|e| e.to_string())
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X', '×'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT in pixels (e.g. 1920x1080), got `{s}`"))?;
    let n = |x: &str| match x.trim().parse::<u32>() {
        Ok(v) if (1..=16384).contains(&v) => Ok(v),
        _ => Err(format!("`{x}` is not a side of 1..=16384 pixels")),
    };
    let (w, h) = (n(w)?, n(h)?);
    let pixels = u64::from(w) * u64::from(h);
    if pixels > rsl_engine::scene::MAX_PIXELS {
        return Err(format!(
            "{w}×{h} is {pixels} pixels, more than the limit of {} (8192×4096)",
            rsl_engine::scene::MAX_PIXELS
        ));
    }
    Ok((w, h))
}

fn parse_range(s: &str) -> Result<(u32, u32), String> {
    let (a, b) = s.split_once("..").ok_or_else(|| format!("expected A..B (frame numbers), got `{s}`"))?;
    let n = |x: &str| x.trim().parse::<u32>().map_err(|_| format!("`{x}` is not a frame number"));
    let (a, b) = (n(a)?, n(b)?);
    if b <= a {
        return Err(format!("the range {a}..{b} holds no frame (B is excluded)"));
    }
    if b - a > MAX_ANIMATION_FRAMES {
        return Err(format!(
            "{a}..{b} is {} frames, more than {MAX_ANIMATION_FRAMES} (over an hour at 24 fps) in one run; render it in parts",
            b - a
        ));
    }
    Ok((a, b))
}

/// Most frames one `rsl render --frames` draws (`0..4294967295` ran on for ever, unannounced).
const MAX_ANIMATION_FRAMES: u32 = 100_000;

/// Image formats by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Png,
    Exr,
}

fn format_of(path: &Path) -> Result<Format> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("png") => Ok(Format::Png),
        Some("exr") => Ok(Format::Exr),
        _ => bail!("--out {}: the file name must end in .png or .exr", path.display()),
    }
}

/// Checks that an output's folder exists, before any work is done.
pub(crate) fn check_writable(path: &Path, what: &str) -> Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !dir.is_dir() {
        bail!("{what} {}: cannot write: folder {} does not exist", path.display(), dir.display());
    }
    // Before any work: a folder in the way or a folder that takes no file is found now, not
    // after the render.
    output::check_writable(path).with_context(|| format!("{what} {}", path.display()))
}

/// Fails unless `path` ends in `.png` (the only format the option writes: PNG bytes under
/// another name would mislead every program that opens the file).
pub(crate) fn check_png(path: &Path, what: &str) -> Result<()> {
    if path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() != Some("png") {
        bail!("{what} {}: writes PNG images; the file name must end in .png", path.display());
    }
    Ok(())
}

/// `name.ext` → `name_0007.ext`.
fn numbered(path: &Path, k: u32) -> PathBuf {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = path.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    path.with_file_name(format!("{stem}_{k:04}{ext}"))
}

fn write_vertices(path: &Path, scene: &Scene, f: &Frame) -> Result<()> {
    let objects: Vec<ply::PlyObject<'_>> = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| ply::PlyObject {
            positions: &f.positions[i],
            normals: &f.normals[i],
            radiance: &f.radiance[i],
            indices: &o.mesh.indices,
        })
        .collect();
    ply::write(path, &objects)
}

fn print_preparation(engine: &Engine) {
    let t = engine.timings();
    let c = engine.cache_stats();
    let (preset, q) = engine.settings();
    let m = engine.memory();
    use rsl_engine::engine::stage;
    crate::status!(
        "prepared ({} quality, {} RSLs, BRDF tables {}, visibility {}×{}): environment {:.0} ms, BRDF tables {:.0} ms, \
         self-visibility {:.0} ms, occluder fields {:.0} ms; cache: {} hits ({} from disk), {} computed, {} rejected; \
         {:.1} MB in memory",
        preset.name(),
        engine.rsls().len(),
        if q.brdf_resolution == rsl_scene::quality::AUTO {
            "auto".to_string()
        } else {
            format!("{0}×{0}", q.brdf_resolution)
        },
        q.visibility_resolution,
        q.visibility_resolution,
        t.ms(stage::ENVIRONMENT),
        t.ms(stage::TABLES),
        t.ms(stage::SVDF),
        t.ms(stage::OVDF),
        c.hits(),
        c.disk_hits,
        c.misses,
        c.rejected,
        m.resident_bytes as f64 / 1e6
    );
}

/// The method `id` on `device` for `engine`, its Monte Carlo samples and seed where it takes
/// them, reporting progress as bars.
fn method_for(id: MethodId, device: Device, engine: &Engine, spp: u32, seed: u64) -> Result<Box<dyn Method>> {
    let options = MethodOptions { device, spp, seed, progress: crate::progress::bars(), gpu: None };
    let method = id.create(engine, &options)?;
    crate::status!("drawing with {}", method.describe());
    Ok(method)
}

/// Says what a Monte Carlo frame's own error is, or that one sample cannot tell.
fn print_self_error(frame: &Frame, spp: u32, secs: f64) {
    let rays = frame.shadow_rays;
    crate::status!("truth: {spp} spp, {rays} shadow rays in {secs:.1} s ({:.2} M rays/s)", rays as f64 / secs / 1e6);
    match frame.self_error {
        Some(e) => {
            if let Some(p) = e.pixels {
                crate::status!(
                    "truth: per-pixel standard error {:.3}% of the covered pixels' radiance (relative L2)",
                    100.0 * p
                );
            }
            if let Some(v) = e.vertices {
                crate::status!("truth: per-vertex standard error {:.3}% of the radiance (relative L2)", 100.0 * v);
            }
        }
        None => crate::status!(
            "truth: standard error not estimated: one sample per point cannot measure its own spread (use --spp 2 or more)"
        ),
    }
}

/// Encodes a frame's image for display at `exposure` (set from the first frame when `None`):
/// the device's encoding where it made one at that exposure, else the CPU tonemapper.
fn display_rgb(frame: &mut Frame, exposure: &mut Option<f32>) -> Result<Vec<u8>> {
    let image = frame.image.as_ref().context("the method made no image")?;
    let e = *exposure.get_or_insert_with(|| frame.encoded.as_ref().map_or_else(|| exposure_for(image), |x| x.exposure));
    Ok(match frame.encoded.take() {
        Some(enc) if enc.exposure == e => enc.rgb,
        _ => tonemap::encode_all(&image.pixels, e),
    })
}

/// `rsl precompute SCENE`.
pub fn precompute(
    scenes: &[PathBuf],
    shard: Option<rsl_bench::shard::Shard>,
    method: Option<MethodId>,
    prepare: &PrepareArgs,
) -> Result<()> {
    let id = method.unwrap_or_else(|| MethodId::default_on(Device::Cpu));
    if shard.is_some() && prepare.options().cache_dir.is_none() {
        bail!("--shard prepares into the cache the other shards share: drop --no-cache");
    }
    let mine: Vec<&PathBuf> =
        scenes.iter().enumerate().filter(|(i, _)| shard.is_none_or(|s| s.takes(*i))).map(|(_, p)| p).collect();
    if let Some(s) = shard {
        crate::status!("precompute: shard {s} prepares {} of {} scene(s)", mine.len(), scenes.len());
    }
    let mut cache = None;
    for path in mine {
        let scene = Scene::load(path)?;
        if scenes.len() > 1 {
            crate::status!("{}:", path.display());
        }
        let engine = Engine::new(&scene, prepare.options())?;
        print_preparation(&engine);
        prepare_method(&engine, &scene, id)?;
        // The folder and its bound (not the engine: its data is freed before the next).
        cache = engine.cache_dir().map(|d| (d.to_path_buf(), engine.cache_limit()));
    }
    if let Some((dir, limit)) = cache
        && let Ok((files, bytes)) = rsl_engine::cache::usage(&dir)
    {
        let bound = match limit {
            u64::MAX => "no bound".to_string(),
            b => format!("of its {:.0} MB bound, ${}", rsl_engine::cache::mb(b), rsl_engine::cache::MAX_ENV),
        };
        crate::status!("cache {}: {files} file(s), {:.1} MB ({bound})", dir.display(), rsl_engine::cache::mb(bytes));
    }
    Ok(())
}

/// Makes method `id`'s own preparation for `scene` ([`Method::preparation`]: the lobe
/// path's transport lobes, kept in the disk cache) and, through its explanation, `auto`'s
/// choice for each object (kept there too), saying what each object will be drawn with.
fn prepare_method(engine: &Engine, scene: &Scene, id: MethodId) -> Result<()> {
    let start = Instant::now();
    let options =
        MethodOptions { device: Device::Cpu, spp: 1, progress: crate::progress::bars(), ..MethodOptions::default() };
    let mut method = id.create(engine, &options)?;
    if let Some(job) = method.preparation(engine, scene)? {
        method.install(job.run());
    }
    let lines = method.explain(engine, scene)?;
    crate::status!("prepared for --method {id} in {:.0} ms:", start.elapsed().as_secs_f64() * 1e3);
    for line in lines {
        crate::status!("  {line}");
    }
    Ok(())
}

/// `rsl render`.
pub fn render(args: &RenderArgs) -> Result<()> {
    // The default: an oracle replaces parts of a method that has them; else the device's.
    let chosen = match (args.method, args.oracle) {
        (Some(m), _) => m,
        (None, Some(_)) => MethodId::all().into_iter().find(|m| m.capabilities().oracles).unwrap_or(MethodId::RSL),
        (None, None) => MethodId::default_on(args.device),
    };
    let format = args.out.as_deref().map(format_of).transpose()?;
    if let Some(out) = &args.out {
        check_writable(out, "--out")?;
    }
    if let Some(p) = &args.vertex_out {
        check_writable(p, "--vertex-out")?;
        if p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() != Some("ply") {
            bail!("--vertex-out {}: the file name must end in .ply", p.display());
        }
    }
    if !(args.fps.is_finite() && args.fps > 0.0) {
        bail!("--fps must be a positive number, got {}", args.fps);
    }
    if let Some(e) = args.exposure
        && !(e.is_finite() && e > 0.0)
    {
        bail!("--exposure must be a positive number, got {e}");
    }
    let capabilities = chosen.capabilities();
    if args.device == Device::Gpu && !capabilities.gpu {
        bail!("--method {chosen} runs on the CPU only; drop --device gpu");
    }
    if capabilities.monte_carlo && !(1..=rsl_truth::MAX_SPP).contains(&args.spp) {
        bail!("--spp must be in 1..={} samples per point, got {}", rsl_truth::MAX_SPP, args.spp);
    }
    if args.oracle.is_some() && (!capabilities.oracles || args.device == Device::Gpu) {
        bail!(
            "--oracle replaces parts of the RSL path on the CPU: use it with --method {} and without --device gpu",
            MethodId::all()
                .into_iter()
                .filter(|m| m.capabilities().oracles)
                .map(|m| m.name())
                .collect::<Vec<_>>()
                .join(" or ")
        );
    }
    let mut scene = crate::render::open_scene(&args.scene, args.env.as_deref(), args.camera)?;
    if let Some(b) = args.bounces {
        scene.quality.settings.bounces = b;
    }
    if let Some((width, height)) = args.size {
        scene.camera.width = width;
        scene.camera.height = height;
    }
    if capabilities.image == ImageKind::MonteCarlo && scene.objects.is_empty() {
        bail!("{}: the scene has no objects; there is nothing to estimate", args.scene.display());
    }
    // Frames are taken one at a time (a range of billions holds nothing up front); an
    // animation's GIF is written as its frames come.
    let (frames, single): (std::ops::Range<u32>, Option<f32>) = match (args.frames, args.time) {
        (Some((a, b)), _) => (a..b, None),
        (None, t) => {
            let t = t.unwrap_or(0.0);
            if !t.is_finite() {
                bail!("--time must be a finite number of seconds, got {t}");
            }
            (0..1, Some(t))
        }
    };
    let fps = args.fps;
    let times = frames.clone().map(move |k| match single {
        Some(t) => (None, t),
        None => (Some(k), k as f32 / fps),
    });
    let count = frames.len();
    let mut gif = None;
    if let (None, Some(out)) = (single, &args.out) {
        check_writable(&numbered(out, frames.start), "--out")?;
        let path = out.with_extension("gif");
        check_writable(&path, "the animation's GIF")?;
        if count > 1000 {
            crate::status!(
                "rendering {count} frames (about {:.0} s of animation at {fps} fps)",
                count as f64 / f64::from(fps)
            );
        }
        gif = Some(path);
    }
    // Nothing written over the scene's own files, nor one output over another.
    let (first, last) = (frames.start, frames.end - 1);
    let named: Vec<(PathBuf, &str)> = match single {
        Some(_) => [(&args.out, "--out"), (&args.vertex_out, "--vertex-out")]
            .into_iter()
            .filter_map(|(p, what)| p.clone().map(|p| (p, what)))
            .collect(),
        None => [(&args.out, "--out"), (&args.vertex_out, "--vertex-out")]
            .into_iter()
            .filter_map(|(p, what)| p.as_ref().map(|p| (p, what)))
            .flat_map(|(p, what)| {
                let ends = if first == last { vec![first] } else { vec![first, last] };
                ends.into_iter().map(move |k| (numbered(p, k), what))
            })
            .chain(gif.clone().map(|g| (g, "the animation's GIF")))
            .collect(),
    };
    let mut outputs = crate::outputs::Outputs::new().scene(&scene);
    for (path, what) in &named {
        outputs = outputs.output(path, *what);
    }
    outputs.check()?;
    let layers = capabilities.layers;
    let mut engine = Engine::new(&scene, EngineOptions { layers, ..args.prepare.options() })?;
    let method: Box<dyn Method> = match args.oracle {
        Some(oracles) => {
            Oracle::prepare(&mut engine, oracles)?;
            let mut o = Oracle::new(oracles);
            o.progress = crate::progress::bars();
            Box::new(o)
        }
        None => method_for(chosen, args.device, &engine, args.spp, args.seed)?,
    };
    // Frames through a render session: each draws again only what changed since the last.
    let id = chosen;
    let mut session = Session::new(MethodOptions::default());
    session.insert(id, method);
    if layers.rsl {
        print_preparation(&engine);
    }
    if args.explain {
        for line in session.method(&engine, id)?.explain(&engine, &scene)? {
            eprintln!("{line}");
        }
    }
    let mut exposure = args.exposure;
    let mut gif = match &gif {
        Some(path) => Some(output::GifWriter::create(path, scene.camera.width, scene.camera.height, fps)?),
        None => None,
    };
    let mut spent = rsl_engine::Timings::default();
    for (k, t) in times {
        let start = Instant::now();
        let request = Request { time: t, image: args.out.is_some(), vertices: args.vertex_out.is_some(), exposure };
        // Base-colour textures mix a frame drawn with them black into it (rsl_engine::textured).
        let mut frame = rsl_engine::textured::render(&mut session, &mut engine, &scene, id, &request)?.frame;
        for s in &frame.timings.stages {
            spent.add(s.name, s.wall_ms, s.gpu_ms);
        }
        if args.timings {
            eprintln!("t = {t:.3} s: {}", frame.timings.describe());
        }
        if capabilities.monte_carlo {
            print_self_error(&frame, args.spp, start.elapsed().as_secs_f64());
        }
        let mut written = Vec::new();
        if let (Some(out), Some(format)) = (&args.out, format) {
            let rgb = display_rgb(&mut frame, &mut exposure)?;
            let image = frame.image.as_ref().context("the method made no image")?;
            let out = k.map_or_else(|| out.clone(), |k| numbered(out, k));
            match format {
                Format::Png => output::write_png(&out, image.width, image.height, rgb.clone())?,
                Format::Exr => output::write_exr(&out, image.width, image.height, &image.pixels, &image.covered)?,
            }
            if let Some(g) = &mut gif {
                g.push(&rgb)?;
            }
            written.push(out);
        }
        if let Some(p) = &args.vertex_out {
            let p = k.map_or_else(|| p.clone(), |k| numbered(p, k));
            write_vertices(&p, &scene, &frame)?;
            written.push(p);
        }
        let names: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
        crate::status!("wrote {} (t = {t:.3} s, {:.1} ms)", names.join(", "), start.elapsed().as_secs_f64() * 1e3);
    }
    if let (Some(g), Some(out)) = (gif, &args.out) {
        g.finish()?;
        crate::status!("wrote {}", out.with_extension("gif").display());
    }
    let n = count as f64;
    let per_frame: Vec<String> =
        spent.stages.iter().map(|s| format!("{} {:.1} ms/frame", s.name, s.ms() / n)).collect();
    crate::status!("{count} frame(s) by {}: {}", session.method(&engine, id)?.describe(), per_frame.join(", "));
    Ok(())
}

/// Arguments of `rsl demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Output folder (created if missing).
    #[arg(long, default_value = "rsl-demo")]
    pub out: PathBuf,
    /// Seconds of animation.
    #[arg(long, default_value_t = 4.0)]
    pub seconds: f32,
    /// Frames per second.
    #[arg(long, default_value_t = 12.0)]
    pub fps: f32,
    /// The scene (default: the bundled default scene).
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Where shading and drawing run: `auto` (a hardware GPU when there is one and the
    /// method runs there, else the CPU), `cpu` or `gpu` (software adapters included).
    #[arg(long, default_value_t = Device::Auto)]
    pub device: Device,
    /// Precomputation options.
    #[command(flatten)]
    pub prepare: PrepareArgs,
}

/// The bundled default scene, relative to the working directory (the repository root).
pub const DEFAULT_SCENE: &str = "data/scenes/default.toml";

/// The material the demo swaps in halfway: brushed copper.
fn swapped_material() -> Brdf {
    Brdf::CookTorrance {
        alpha: 0.3,
        specular: glam::Vec3::new(0.95, 0.64, 0.54),
        diffuse: glam::Vec3::new(0.02, 0.01, 0.01),
    }
}

/// `rsl demo`: the default scene as an animation, the objects moving, the environment turning,
/// and the second object's material swapped halfway.
pub fn demo(args: &DemoArgs) -> Result<()> {
    let total = Instant::now();
    if !(args.fps.is_finite() && args.fps > 0.0 && args.seconds.is_finite() && args.seconds > 0.0) {
        bail!("--fps and --seconds must be positive numbers");
    }
    let path = args.scene.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_SCENE));
    if !path.exists() {
        bail!("scene {} not found (run the demo from the repository root, or pass --scene)", path.display());
    }
    let mut scene = Scene::load(&path)?;
    if scene.objects.len() < 2 {
        bail!("{}: the demo swaps the second object's material and needs at least two objects", path.display());
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let start = Instant::now();
    let mut engine = Engine::new(&scene, args.prepare.options())?;
    let prepare_ms = start.elapsed().as_secs_f64() * 1e3;
    print_preparation(&engine);
    let mut session = Session::new(MethodOptions::default());
    let id = MethodId::default_on(args.device);
    session.insert(id, method_for(id, args.device, &engine, 1, 1)?);
    let device = session.method(&engine, id)?.describe();
    let frames = (args.seconds * args.fps).round().max(1.0) as u32;
    let swap_at = frames / 2;
    let swapped = &scene.objects[1].name.clone();
    let bar = if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        indicatif::ProgressBar::new(u64::from(frames))
    } else {
        indicatif::ProgressBar::hidden()
    };
    let (mut shade, mut raster, mut encode, mut swap_ms) = (Vec::new(), 0.0, 0.0, 0.0);
    let mut exposure = None;
    let mut gif_frames = Vec::new();
    for k in 0..frames {
        if k == swap_at {
            let s = Instant::now();
            scene.objects[1].material = swapped_material();
            engine.sync(&scene)?;
            swap_ms = s.elapsed().as_secs_f64() * 1e3;
        }
        let t = k as f32 / args.fps;
        let request = Request { time: t, image: true, vertices: false, exposure };
        let mut frame = session.render(&engine, &scene, id, &request)?.frame;
        shade.push(frame.timings.ms("shade"));
        raster += frame.timings.stages.iter().filter(|s| s.is_image()).map(|s| s.wall_ms).sum::<f64>();
        let s = Instant::now();
        let rgb = display_rgb(&mut frame, &mut exposure)?;
        let image = frame.image.as_ref().context("the method made no image")?;
        output::write_png(&args.out.join(format!("frame_{k:04}.png")), image.width, image.height, rgb.clone())?;
        encode += s.elapsed().as_secs_f64() * 1e3;
        gif_frames.push(rgb);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let s = Instant::now();
    let gif = args.out.join("demo.gif");
    output::write_gif(&gif, scene.camera.width, scene.camera.height, &gif_frames, args.fps)?;
    let gif_ms = s.elapsed().as_secs_f64() * 1e3;
    let (vertices, _) = scene.counts();
    let mut sorted = shade.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let n = f64::from(frames);
    let c = engine.cache_stats();
    let summary = format!(
        "rsl demo: {} ({} objects, {vertices} vertices, {} RSLs, {} quality)\n\
         frames:        {frames} at {} fps ({} s), {}×{}; material of {swapped} swapped at frame {swap_at}\n\
         precompute:    {prepare_ms:.0} ms (cache: {} hits, {} from disk, {} computed)\n\
         material swap: {swap_ms:.1} ms (one BRDF table)\n\
         shading:       {median:.1} ms/frame median, {:.1} mean ({device})\n\
         drawing:       {:.1} ms/frame\n\
         PNG encoding:  {:.1} ms/frame; GIF {gif_ms:.0} ms\n\
         total:         {:.1} s; output in {}\n",
        path.display(),
        scene.objects.len(),
        engine.rsls().len(),
        engine.settings().0.name(),
        args.fps,
        args.seconds,
        scene.camera.width,
        scene.camera.height,
        c.hits(),
        c.disk_hits,
        c.misses,
        shade.iter().sum::<f64>() / n,
        raster / n,
        encode / n,
        total.elapsed().as_secs_f64(),
        args.out.display()
    );
    output::write_atomic(&args.out.join("summary.txt"), summary.as_bytes())?;
    print!("{summary}");
    Ok(())
}

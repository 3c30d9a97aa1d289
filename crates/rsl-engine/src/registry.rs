//! The method registry: every way of drawing a frame, named once.
//!
//! A [`MethodId`] is the one name of a method everywhere — `rsl render --method`, the
//! bench's `--sweep method=`, the viewer's drop-down, the docs. Each method is one
//! [`Registration`]: its name, what it is for, its [`Capabilities`] and its constructor. The
//! built-in methods are registered here; a program adds its own with [`register`] (see
//! `examples/normals_method.rs`), and every front end then lists and builds it like the
//! others. Front ends ask the registry what a method can do; they never branch on which
//! method it is.

use crate::compose::{ObjectDrawing, PixelDrawing, VertexDrawing};
use crate::engine::{Engine, Layers};
use crate::gpu::GpuRenderer;
use crate::lobe::{Composite, LobeDrawing};
use crate::method::{CpuRsl, CpuRslPixels, GpuRsl, Method, Truth};
use crate::progress::Progress;
use anyhow::{Context, Result, bail};
use rsl_gpu::GpuContext;
use std::fmt;
use std::sync::{Arc, LazyLock, RwLock};

/// Where a method is asked to run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, clap::ValueEnum)]
pub enum Device {
    /// A hardware GPU when there is one and the method runs there, else the CPU.
    #[default]
    Auto,
    /// The CPU.
    Cpu,
    /// A GPU, software adapters included (an error when there is none, or when the method
    /// does not run on a GPU).
    Gpu,
}

impl Device {
    /// Every device choice, in the order `--device` lists them.
    pub const ALL: [Device; 3] = [Device::Auto, Device::Cpu, Device::Gpu];

    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Device::Auto => "auto",
            Device::Cpu => "cpu",
            Device::Gpu => "gpu",
        }
    }
}

impl fmt::Display for Device {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Device {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Device::ALL
            .into_iter()
            .find(|d| d.name() == s)
            .ok_or_else(|| format!("unknown device `{s}`; known: auto, cpu, gpu"))
    }
}

/// How a method draws an image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageKind {
    /// The vertices' radiance interpolated across triangles.
    Vertices,
    /// Each pixel shaded for its own point, normal and view (where the method chooses to).
    PerPixel,
    /// Each pixel estimated by Monte Carlo.
    MonteCarlo,
}

/// What a method can do and what it needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Capabilities {
    /// How its images are drawn.
    pub image: ImageKind,
    /// It runs on the CPU.
    pub cpu: bool,
    /// It runs (or draws) on a GPU.
    pub gpu: bool,
    /// The prepared data it needs from the engine.
    pub layers: Layers,
    /// It is a Monte Carlo estimate: it takes samples per point and a seed, and reports its
    /// own error.
    pub monte_carlo: bool,
    /// It draws anisotropic materials (the lobe methods draw them with the RSL sum per pixel,
    /// as their lobes fit isotropic BRDFs only).
    pub anisotropic: bool,
    /// Scene files may ask for it per object (`method = "…"`).
    pub per_object: bool,
    /// The error budget's oracles replace its approximations (`rsl bench`'s budget).
    pub oracles: bool,
    /// The viewer may show it as its drawing (fast enough to redraw on edits).
    pub interactive: bool,
    /// What it draws again of a frame in a [`crate::Session`] when only some objects
    /// changed ([`Method::render_changed`]).
    pub incremental: Incremental,
    /// What bounds its error: how the method matrix (`crates/rsl-engine/tests/methods.rs`)
    /// holds it to analytic answers.
    pub error: ErrorModel,
}

/// What bounds a method's error against an analytic answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorModel {
    /// The RSL path's tables: a constant environment reproduced to 1 %, a visibility
    /// boundary placed to within half a cell of the hemisphere grid, the same numbers when
    /// the scene, the environment and the eye turn together (f32 rounding only).
    Tables,
    /// Its own standard error (Monte Carlo): within 5 σ per vertex.
    StandardError,
    /// None that can be checked (a baseline with its own truncation, or a view that is not
    /// radiance): its frames are complete and finite.
    Unbounded,
}

/// What a method draws again when only some objects changed since its last frame in a
/// [`crate::Session`] ([`Method::render_changed`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Incremental {
    /// The whole frame, whatever changed (the default `render_changed`).
    Frames,
    /// The changed objects' vertices; the others' are kept.
    Vertices,
    /// As `Vertices`, keeping every light's cover at the vertices of the objects drawn per
    /// pixel; the image is drawn whole from them.
    PixelCovers,
}

/// What a front end asks of a method beyond its name.
#[derive(Clone, Default)]
pub struct MethodOptions {
    /// Where it should run.
    pub device: Device,
    /// Samples per point (Monte Carlo methods).
    pub spp: u32,
    /// Seed (Monte Carlo methods; their result is deterministic for a seed).
    pub seed: u64,
    /// Where long work reports its progress.
    pub progress: Progress,
    /// A GPU device to run on instead of opening one (a window's device).
    pub gpu: Option<Arc<GpuContext>>,
}

impl fmt::Debug for MethodOptions {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MethodOptions")
            .field("device", &self.device)
            .field("spp", &self.spp)
            .field("seed", &self.seed)
            .field("gpu", &self.gpu.as_ref().map(|g| g.describe()))
            .finish()
    }
}

/// Builds a method for `engine`'s scene as `options` ask.
pub type Constructor = fn(&Engine, &MethodOptions) -> Result<Box<dyn Method>>;

/// One method of the registry.
#[derive(Clone, Copy, Debug)]
pub struct Registration {
    /// Its one name (lower case, letters, digits, `_` and `-`).
    pub name: &'static str,
    /// Older names it is still found by (saved bench results, scene files); each with the
    /// device it implies, if any.
    pub aliases: &'static [(&'static str, Option<Device>)],
    /// What it is, in one line.
    pub summary: &'static str,
    /// When to use it, in one line (the README's table of methods).
    pub when: &'static str,
    /// What it can do and what it needs.
    pub capabilities: Capabilities,
    /// How it is built.
    pub constructor: Constructor,
    /// How it draws the objects a scene file or a per-object method assigns it (one
    /// [`ObjectDrawing`] per per-object method, `Capabilities::per_object`; `None` for the
    /// others and for `auto`, a rule rather than a drawing).
    pub drawing: Option<DrawingConstructor>,
}

/// Builds a per-object method's drawing.
pub type DrawingConstructor = fn() -> Box<dyn ObjectDrawing>;

/// A registered method, by its one name.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MethodId(&'static str);

/// The registered methods: the built-in ones, then those [`register`]ed, in that order.
static REGISTRY: LazyLock<RwLock<Vec<&'static Registration>>> =
    LazyLock::new(|| RwLock::new(BUILT_IN.iter().collect()));

fn registry() -> std::sync::RwLockReadGuard<'static, Vec<&'static Registration>> {
    REGISTRY.read().unwrap_or_else(|e| e.into_inner())
}

/// Adds `method` to the registry (after the built-in methods, in the order registered); its
/// id. An error when its name or an alias is taken or malformed.
pub fn register(method: Registration) -> Result<MethodId> {
    let valid = |s: &str| {
        !s.is_empty() && s.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_' || c == '-')
    };
    for name in std::iter::once(method.name).chain(method.aliases.iter().map(|a| a.0)) {
        if !valid(name) {
            bail!("method name `{name}`: use lower-case letters, digits, `_` and `-`");
        }
        if lookup(name).is_some() {
            bail!("method name `{name}` is already registered");
        }
    }
    if method.capabilities.per_object != method.drawing.is_some() {
        bail!("method `{}`: a per-object method needs a drawing, and only one has it", method.name);
    }
    if method.capabilities.per_object {
        rsl_scene::register_method_name(method.name);
    }
    let mut w = REGISTRY.write().unwrap_or_else(|e| e.into_inner());
    w.push(Box::leak(Box::new(method)));
    Ok(MethodId(method.name))
}

/// The registration named `name` (or one of its aliases), with the device the alias implies.
fn lookup(name: &str) -> Option<(&'static Registration, Option<Device>)> {
    let r = registry();
    r.iter()
        .find(|m| m.name == name)
        .map(|m| (*m, None))
        .or_else(|| r.iter().find_map(|m| m.aliases.iter().find(|a| a.0 == name).map(|a| (*m, a.1))))
}

impl MethodId {
    /// The RSL path at the vertices, interpolated across triangles.
    pub const RSL: MethodId = MethodId("rsl");
    /// `auto`: each object drawn as its scene `method` says (by default its most accurate
    /// drawing per pixel).
    pub const AUTO: MethodId = MethodId("auto");
    /// The Monte Carlo ground truth.
    pub const TRUTH: MethodId = MethodId("truth");
    /// The RSL sum per pixel.
    pub const PIXEL: MethodId = MethodId("pixel");
    /// vMF lobes × the RSL path's visibility ratio.
    pub const HYBRID: MethodId = MethodId("hybrid");
    /// Transport lobes shadowed by the other objects' fields.
    pub const LOBE: MethodId = MethodId("lobe");
    /// The Haar wavelet baseline.
    pub const WAVELET: MethodId = MethodId("wavelet");

    /// The methods a front end draws with when none is named, best first: `auto` (each
    /// object by its most accurate drawing per pixel), then `rsl` (which runs everywhere).
    pub const DEFAULTS: [MethodId; 2] = [MethodId::AUTO, MethodId::RSL];

    /// The default method of `rsl render`, `rsl demo` and the viewer on `device`: the first
    /// of [`MethodId::DEFAULTS`] that runs there (`auto`, on the CPU and the GPU alike).
    pub fn default_on(device: Device) -> MethodId {
        let runs = |m: &MethodId| {
            let c = m.capabilities();
            match device {
                Device::Gpu => c.gpu,
                Device::Cpu | Device::Auto => c.cpu,
            }
        };
        Self::DEFAULTS.into_iter().find(runs).unwrap_or(MethodId::RSL)
    }

    /// Every registered method, built-in ones first.
    pub fn all() -> Vec<MethodId> {
        registry().iter().map(|m| MethodId(m.name)).collect()
    }

    /// Its one name.
    pub fn name(self) -> &'static str {
        self.0
    }

    /// Its registration.
    pub fn registration(self) -> &'static Registration {
        registry().iter().find(|m| m.name == self.0).copied().expect("a MethodId is made only for registered methods")
    }

    /// What it can do and what it needs.
    pub fn capabilities(self) -> Capabilities {
        self.registration().capabilities
    }

    /// What it is, in one line.
    pub fn summary(self) -> &'static str {
        self.registration().summary
    }

    /// Where it draws an image and on which devices, in words (`per pixel; CPU, GPU`).
    pub fn draws(self) -> String {
        let c = self.capabilities();
        let image = match c.image {
            ImageKind::Vertices => "vertices",
            ImageKind::PerPixel => "per pixel",
            ImageKind::MonteCarlo => "Monte Carlo",
        };
        let devices: Vec<&str> = [(c.cpu, "CPU"), (c.gpu, "GPU")].iter().filter(|d| d.0).map(|d| d.1).collect();
        format!("{image}; {}", devices.join(", "))
    }

    /// The method, for `engine`'s scene, as `options` ask: an error that names the method
    /// when it cannot run where asked.
    pub fn create(self, engine: &Engine, options: &MethodOptions) -> Result<Box<dyn Method>> {
        let c = self.capabilities();
        if options.device == Device::Gpu && !c.gpu {
            bail!("--method {self} runs on the CPU only; drop --device gpu");
        }
        if options.device == Device::Cpu && !c.cpu {
            bail!("--method {self} runs on a GPU only; drop --device cpu");
        }
        if c.layers.rsl && !engine.layers().rsl {
            bail!(
                "--method {self} needs the RSL layer (light set, tables, fields); the engine was prepared without it"
            );
        }
        let method = (self.registration().constructor)(engine, options).with_context(|| format!("method {self}"))?;
        // A Monte Carlo estimate follows the bounces itself; every other method gathers them.
        Ok(if c.monte_carlo { method } else { Box::new(crate::bounce::Bounced::new(method)) })
    }

    /// The name and device of `text`: a method's name, or an alias (which may imply a
    /// device, as the bench's `cpu` and `gpu` do for `rsl`).
    pub fn parse_with_device(text: &str) -> Result<(MethodId, Option<Device>), String> {
        lookup(text.trim()).map(|(m, d)| (MethodId(m.name), d)).ok_or_else(|| {
            format!(
                "unknown method `{}`; known: {}",
                text.trim(),
                MethodId::all().iter().map(|m| m.name()).collect::<Vec<_>>().join(", ")
            )
        })
    }

    /// Its name on `device` where an alias names that pair (so saved bench results keep
    /// their identities), else its own name.
    pub fn name_on(self, device: Device) -> &'static str {
        self.registration().aliases.iter().find(|a| a.1 == Some(device)).map_or(self.0, |a| a.0)
    }
}

/// Every registered method as a Markdown table: name, what it is, how it draws and where,
/// when to use it (`rsl methods`; the README's table is this output).
pub fn markdown_table() -> String {
    let mut t = String::from("| method | what it is | draws | when to use it |\n|---|---|---|---|\n");
    for m in MethodId::all() {
        t.push_str(&format!("| `{m}` | {} | {} | {} |\n", m.summary(), m.draws(), m.registration().when));
    }
    t
}

impl fmt::Display for MethodId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0)
    }
}

impl fmt::Debug for MethodId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "MethodId({})", self.0)
    }
}

impl std::str::FromStr for MethodId {
    type Err = String;

    /// A method by its name or an alias that implies no device.
    fn from_str(s: &str) -> Result<Self, String> {
        match MethodId::parse_with_device(s)? {
            (m, None) => Ok(m),
            (m, Some(d)) => Err(format!("`{s}` is method `{m}` on device {d}: name the method and the device apart")),
        }
    }
}

impl serde::Serialize for MethodId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.0)
    }
}

impl<'de> serde::Deserialize<'de> for MethodId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// Parses `--method` against the registry, listing every registered method in `--help` and
/// in errors.
#[derive(Clone, Copy, Debug, Default)]
pub struct MethodIdParser;

impl clap::builder::TypedValueParser for MethodIdParser {
    type Value = MethodId;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> std::result::Result<MethodId, clap::Error> {
        let text = value.to_str().ok_or_else(|| clap::Error::new(clap::error::ErrorKind::InvalidUtf8).with_cmd(cmd))?;
        text.parse().map_err(|e: String| {
            let name = arg.map_or_else(|| "--method".to_string(), |a| a.to_string());
            clap::Error::raw(clap::error::ErrorKind::InvalidValue, format!("invalid value for {name}: {e}\n"))
                .with_cmd(cmd)
        })
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = clap::builder::PossibleValue> + '_>> {
        Some(Box::new(
            MethodId::all().into_iter().map(|m| clap::builder::PossibleValue::new(m.name()).help(m.summary())),
        ))
    }
}

impl clap::builder::ValueParserFactory for MethodId {
    type Parser = MethodIdParser;

    fn value_parser() -> MethodIdParser {
        MethodIdParser
    }
}

/// The GPU `options` ask for, if any: the one given; on [`Device::Gpu`] any adapter (an
/// error when there is none); on [`Device::Auto`] a hardware adapter only (a notice and
/// `None` otherwise).
pub fn gpu_context(options: &MethodOptions) -> Result<Option<Arc<GpuContext>>> {
    if let Some(g) = &options.gpu {
        return Ok((options.device != Device::Cpu).then(|| g.clone()));
    }
    match options.device {
        Device::Cpu => Ok(None),
        Device::Gpu => Ok(Some(Arc::new(GpuContext::new().context("--device gpu")?))),
        Device::Auto => match GpuContext::new() {
            Ok(g) if g.info.device_type != rsl_gpu::wgpu::DeviceType::Cpu => Ok(Some(Arc::new(g))),
            Ok(g) => {
                tracing::info!(
                    "only a software GPU adapter ({}) was found; running on the CPU (--device gpu uses it anyway)",
                    g.describe()
                );
                Ok(None)
            }
            Err(e) => {
                tracing::info!("no usable GPU ({e}); running on the CPU");
                Ok(None)
            }
        },
    }
}

const CPU_RSL: Capabilities = Capabilities {
    image: ImageKind::Vertices,
    cpu: true,
    gpu: true,
    layers: Layers { rsl: true },
    monte_carlo: false,
    anisotropic: true,
    per_object: true,
    oracles: true,
    interactive: true,
    incremental: Incremental::Vertices,
    error: ErrorModel::Tables,
};

/// The lobe methods': per pixel, whole frames (an anisotropic object drawn by the RSL sum per
/// pixel, which they fall back to).
const LOBES: Capabilities =
    Capabilities { image: ImageKind::PerPixel, oracles: false, incremental: Incremental::Frames, ..CPU_RSL };

fn make_rsl(_: &Engine, o: &MethodOptions) -> Result<Box<dyn Method>> {
    Ok(match gpu_context(o)? {
        Some(ctx) => Box::new(GpuRsl::vertices(GpuRenderer::with_context(ctx)?)),
        None => Box::new(CpuRsl),
    })
}

fn make_pixel(_: &Engine, o: &MethodOptions) -> Result<Box<dyn Method>> {
    Ok(match gpu_context(o)? {
        Some(ctx) => Box::new(GpuRsl::per_pixel(GpuRenderer::with_context(ctx)?)),
        None => Box::new(CpuRslPixels),
    })
}

fn lobes_on(_: &Engine, o: &MethodOptions) -> Result<Composite> {
    Ok(match gpu_context(o)? {
        Some(ctx) => Composite::on_gpu(ctx)?,
        None => Composite::hybrid(),
    })
}

fn make_hybrid(engine: &Engine, o: &MethodOptions) -> Result<Box<dyn Method>> {
    Ok(Box::new(lobes_on(engine, o)?))
}

fn make_lobe(engine: &Engine, o: &MethodOptions) -> Result<Box<dyn Method>> {
    Ok(Box::new(lobes_on(engine, o)?.with_fields(true)))
}

fn make_auto(_: &Engine, o: &MethodOptions) -> Result<Box<dyn Method>> {
    Ok(Box::new(match gpu_context(o)? {
        Some(ctx) => Composite::auto_on_gpu(ctx)?,
        None => Composite::auto(),
    }))
}

fn make_truth(engine: &Engine, o: &MethodOptions) -> Result<Box<dyn Method>> {
    let mut t = Truth::new(engine, o.spp, o.seed)?;
    t.progress = o.progress.clone();
    Ok(Box::new(t))
}

fn make_wavelet(engine: &Engine, o: &MethodOptions) -> Result<Box<dyn Method>> {
    Ok(Box::new(crate::wavelet::WaveletMethod::new(engine, o)?))
}

/// The built-in methods, in the order they are listed.
static BUILT_IN: [Registration; 7] = [
    Registration {
        name: "rsl",
        aliases: &[("cpu", Some(Device::Cpu)), ("gpu", Some(Device::Gpu))],
        summary: "rotatable square lights at the vertices, interpolated across triangles",
        when: "previews, animations and sweeps: the fastest; a highlight or a shadow edge smaller than a triangle is smeared across it",
        capabilities: CPU_RSL,
        constructor: make_rsl,
        drawing: Some(|| Box::new(VertexDrawing)),
    },
    Registration {
        name: "pixel",
        aliases: &[("rsl_pixel", None)],
        summary: "the RSL sum per pixel for glossy objects, the visibility interpolated from the vertices, traced lights traced per pixel",
        when: "final images with glossy objects: the closest to the truth per pixel on the bundled accuracy scenes, at about 3× the cost of `rsl`",
        capabilities: Capabilities {
            image: ImageKind::PerPixel,
            oracles: false,
            incremental: Incremental::PixelCovers,
            ..CPU_RSL
        },
        constructor: make_pixel,
        drawing: Some(|| Box::new(PixelDrawing)),
    },
    Registration {
        name: "hybrid",
        aliases: &[],
        summary: "vMF lobes over the prefiltered environment per pixel × the RSL path's visibility ratio",
        when: "near-mirrors reflecting large uniform regions (a horizon), where the squares' outlines would show",
        capabilities: LOBES,
        constructor: make_hybrid,
        drawing: Some(|| Box::new(LobeDrawing::new(false))),
    },
    Registration {
        name: "lobe",
        aliases: &[],
        summary: "transport lobes (the object's own shadows fitted in), shadowed by the other objects' fields over each lobe; per pixel",
        when: "sharp lobes reflecting nearby objects with nothing traced per frame; its lobes take about 22 s per 10,000 vertices to fit",
        capabilities: LOBES,
        constructor: make_lobe,
        drawing: Some(|| Box::new(LobeDrawing::new(true))),
    },
    Registration {
        name: "auto",
        aliases: &[],
        summary: "each object as its scene `method` says (by default, for a glossy object, the RSL sum per pixel or the lobes, whichever a sample of its pixels finds nearer the truth)",
        when: "scenes that mix materials; `rsl render --explain` says what each object got and why",
        capabilities: Capabilities {
            image: ImageKind::PerPixel,
            oracles: false,
            incremental: Incremental::Frames,
            ..CPU_RSL
        },
        constructor: make_auto,
        drawing: None,
    },
    Registration {
        name: "truth",
        aliases: &[],
        summary: "the Monte Carlo ground truth: multiple importance sampling and shadow rays, with its own standard error",
        when: "the reference every other method is measured against (`--spp`, `--seed`)",
        capabilities: Capabilities {
            image: ImageKind::MonteCarlo,
            gpu: false,
            layers: Layers { rsl: false },
            monte_carlo: true,
            per_object: false,
            oracles: false,
            interactive: false,
            incremental: Incremental::Frames,
            error: ErrorModel::StandardError,
            ..CPU_RSL
        },
        constructor: make_truth,
        drawing: None,
    },
    Registration {
        name: "wavelet",
        aliases: &[],
        summary: "the Haar wavelet baseline (Ng et al. 2003): per-vertex transport precomputed for the scene as it stands, the lighting's largest terms",
        when: "comparing with the classic precomputed-transport baseline on a static scene: anything that moves precomputes it again",
        capabilities: Capabilities {
            gpu: false,
            layers: Layers { rsl: false },
            per_object: false,
            oracles: false,
            interactive: false,
            incremental: Incremental::Frames,
            error: ErrorModel::Unbounded,
            ..CPU_RSL
        },
        constructor: make_wavelet,
        drawing: None,
    },
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_method_is_found_by_its_name_and_printed_the_same() {
        for m in MethodId::all() {
            assert_eq!(m.name().parse::<MethodId>().unwrap(), m);
            assert_eq!(m.to_string(), m.name());
        }
        assert_eq!(MethodId::parse_with_device("gpu").unwrap(), (MethodId::RSL, Some(Device::Gpu)));
        assert_eq!("rsl_pixel".parse::<MethodId>().unwrap().name(), "pixel");
        assert_eq!(MethodId::RSL.name_on(Device::Cpu), "cpu");
        assert_eq!("pixel".parse::<MethodId>().unwrap().name_on(Device::Cpu), "pixel");
    }

    #[test]
    fn the_default_is_auto_on_every_device() {
        for device in Device::ALL {
            assert_eq!(MethodId::default_on(device), MethodId::AUTO, "{device}");
        }
        assert!(MethodId::AUTO.capabilities().gpu && MethodId::PIXEL.capabilities().gpu);
    }

    #[test]
    fn unknown_and_taken_names_are_clear_errors() {
        let e = "tpu".parse::<MethodId>().unwrap_err();
        assert!(e.contains("unknown method `tpu`") && e.contains("rsl, pixel"), "{e}");
        assert!("cpu".parse::<MethodId>().unwrap_err().contains("device"));
        let taken = Registration { name: "hybrid", ..BUILT_IN[0] };
        assert!(register(taken).unwrap_err().to_string().contains("already registered"));
        let bad = Registration { name: "Two Words", aliases: &[], ..BUILT_IN[0] };
        assert!(register(bad).unwrap_err().to_string().contains("lower-case"));
    }

    #[test]
    fn the_scene_files_per_object_methods_are_the_registrys() {
        for m in MethodId::all().into_iter().filter(|m| m.capabilities().per_object) {
            let toml = format!("method = \"{m}\"");
            #[derive(serde::Deserialize)]
            struct O {
                #[allow(dead_code)]
                method: rsl_scene::ObjectMethod,
            }
            assert!(toml::from_str::<O>(&toml).is_ok(), "scene files do not take method `{m}`");
        }
    }
}

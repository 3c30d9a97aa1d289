//! `rsl view`: the interactive viewer, or its headless screenshot.

use crate::render::PrepareArgs;
use anyhow::{Context, Result, bail};
use rsl_engine::MethodId;
use std::path::PathBuf;

/// Arguments of `rsl view`.
#[derive(Debug, clap::Args)]
pub struct ViewArgs {
    /// The scene: a scene file (TOML), or a glTF file (.glb, .gltf) opened as a scene (as
    /// `rsl render` opens it).
    pub scene: PathBuf,
    /// An environment map (.exr or .hdr) lighting the scene in place of its own.
    #[arg(long)]
    pub env: Option<PathBuf>,
    /// A glTF file's perspective camera to look through, numbered from 0 in node order
    /// (default: its first; a camera framed on the scene where it has none).
    #[arg(long)]
    pub camera: Option<usize>,
    /// Render the whole UI headless (no display needed) to this PNG and exit.
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
    /// UI frames to draw before the screenshot.
    #[arg(long, default_value_t = 3, requires = "screenshot")]
    pub frames: usize,
    /// Start with glossy objects drawn per pixel by the RSL sum (`--drawing pixel`).
    #[arg(long, conflicts_with = "drawing")]
    pub per_pixel: bool,
    /// How glossy objects are drawn once the view rests (the "drawing" drop-down): as
    /// `rsl render --method` draws them; by default `auto` (the vertices interpolated while
    /// edits come, each object's most accurate drawing once the view rests).
    #[arg(long)]
    pub drawing: Option<MethodId>,
    /// Precomputation options.
    #[command(flatten)]
    pub prepare: PrepareArgs,
}

/// Frames a screenshot may draw (each costs a UI pass and possibly a reshade).
const MAX_FRAMES: usize = 10_000;

/// Runs `rsl view`.
pub fn run(args: &ViewArgs) -> Result<()> {
    if let Some(png) = &args.screenshot {
        crate::render::check_png(png, "--screenshot")?;
        crate::render::check_writable(png, "--screenshot")?;
        if args.frames == 0 || args.frames > MAX_FRAMES {
            bail!("--frames must be in 1..={MAX_FRAMES}, got {}", args.frames);
        }
    }
    let mut scene = crate::render::open_scene(&args.scene, args.env.as_deref(), args.camera)?;
    if let Some(png) = &args.screenshot {
        crate::outputs::Outputs::new().scene(&scene).output(png, "--screenshot").check()?;
    }
    if let Some(n) = args.prepare.rsl {
        scene.environment.rsl_count = n;
    }
    let engine = args.prepare.options();
    let options = rsl_view::ViewerOptions { cache_dir: engine.cache_dir, quality: args.prepare.quality };
    let mut viewer = rsl_view::Viewer::new(scene, options);
    if args.per_pixel {
        viewer.set_per_pixel(true);
    }
    if let Some(d) = args.drawing {
        if !d.capabilities().interactive {
            bail!(
                "--drawing {d}: the viewer cannot redraw it on edits; it draws {}",
                rsl_view::drawings().iter().map(|m| m.name()).collect::<Vec<_>>().join(", ")
            );
        }
        viewer.set_drawing(d);
    }
    match &args.screenshot {
        Some(png) => {
            let img = rsl_view::screenshot(viewer, args.frames)?;
            rsl_engine::output::write_png(png, img.width, img.height, img.rgb())
                .with_context(|| format!("cannot write {}", png.display()))?;
            crate::status!("wrote {} ({}×{})", png.display(), img.width, img.height);
            Ok(())
        }
        None => rsl_view::run(viewer, &format!("rsl view — {}", args.scene.display())),
    }
}

//! `rsl compare A B`: error metrics of A against the reference B, over vertices (two PLY
//! files from `rsl render --vertex-out`) or over the pixels objects cover (two EXR files from
//! `rsl render`; their alpha marks coverage), with an optional false-colour heatmap.

use anyhow::{Context, Result, bail};
use glam::Vec3;
use rsl_engine::{output, ply};
use rsl_scene::Scene;
use rsl_truth::metrics::{self, false_colour, luminance_errors, with_legend};
use std::path::{Path, PathBuf};

/// Arguments of `rsl compare`.
#[derive(Debug, clap::Args)]
pub struct CompareArgs {
    /// The result to measure (.ply or .exr).
    pub a: PathBuf,
    /// The reference (same kind as A).
    pub b: PathBuf,
    /// Write a false-colour map of the per-vertex (or per-pixel) luminance error, with a
    /// legend, as PNG.
    #[arg(long)]
    pub heatmap: Option<PathBuf>,
    /// The scene whose camera views a per-vertex heatmap (needed with PLY inputs).
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Compare every pixel of EXR inputs, background included.
    #[arg(long)]
    pub all_pixels: bool,
}

fn kind(p: &Path) -> Option<&'static str> {
    match p.extension()?.to_str()?.to_ascii_lowercase().as_str() {
        "ply" => Some("ply"),
        "exr" => Some("exr"),
        _ => None,
    }
}

fn read_ply(p: &Path) -> Result<ply::PlyData> {
    let bytes = std::fs::read(p).with_context(|| format!("cannot read {}", p.display()))?;
    ply::read(&bytes).with_context(|| format!("{}", p.display()))
}

/// Runs `rsl compare`.
pub fn run(args: &CompareArgs) -> Result<()> {
    let (ka, kb) = (kind(&args.a), kind(&args.b));
    let Some(k) = ka.filter(|k| Some(*k) == kb) else {
        bail!("compare needs two .ply or two .exr files, got {} and {}", args.a.display(), args.b.display());
    };
    if let Some(h) = &args.heatmap {
        crate::render::check_writable(h, "--heatmap")?;
    }
    if k == "ply" {
        let (a, b) = (read_ply(&args.a)?, read_ply(&args.b)?);
        if a.vertices.len() != b.vertices.len() || a.objects != b.objects {
            bail!(
                "{} has {} vertices, {} has {}: they are not the same scene's vertices",
                args.a.display(),
                a.vertices.len(),
                args.b.display(),
                b.vertices.len()
            );
        }
        let rad = |d: &ply::PlyData| d.vertices.iter().map(|v| Vec3::new(v[6], v[7], v[8])).collect::<Vec<_>>();
        let (ra, rb) = (rad(&a), rad(&b));
        let m = metrics::compare(&ra, &rb, None)?;
        println!("vertices: {m}");
        if let Some(h) = &args.heatmap {
            let Some(scene) = &args.scene else { bail!("--heatmap with PLY inputs needs --scene for the camera") };
            let scene = Scene::load(scene)?;
            let err = luminance_errors(&ra, &rb);
            let max = err.iter().cloned().fold(0.0f32, f32::max).max(1e-30);
            let colours: Vec<Vec3> = err.iter().map(|e| false_colour(e / max)).collect();
            let positions: Vec<Vec3> = b.vertices.iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect();
            let indices: Vec<u32> = b.faces.iter().flatten().copied().collect();
            let mesh = rsl_shade::RasterMesh { positions: &positions, indices: &indices, radiance: &colours };
            let img = rsl_shade::rasterise(&scene.camera, &[mesh], |_| Vec3::splat(0.1));
            write_heatmap(h, img.width, img.height, &img.pixels, max)?;
        }
    } else {
        let (wa, ha, pa, _) = output::read_exr(&args.a)?;
        let (wb, hb, pb, mask) = output::read_exr(&args.b)?;
        if (wa, ha) != (wb, hb) {
            bail!("{} is {wa}×{ha}, {} is {wb}×{hb}", args.a.display(), args.b.display());
        }
        let mask = if args.all_pixels { None } else { mask };
        let m = metrics::compare(&pa, &pb, mask.as_deref())?;
        println!("{}: {m}", if mask.is_some() { "covered pixels" } else { "pixels" });
        if let Some(h) = &args.heatmap {
            let err = luminance_errors(&pa, &pb);
            let keep = |k: usize| mask.as_ref().is_none_or(|m| m[k]);
            let max =
                err.iter().enumerate().filter(|(k, _)| keep(*k)).map(|(_, e)| *e).fold(0.0f32, f32::max).max(1e-30);
            let px: Vec<Vec3> = err
                .iter()
                .enumerate()
                .map(|(k, e)| if keep(k) { false_colour(e / max) } else { Vec3::splat(0.1) })
                .collect();
            write_heatmap(h, wa, ha, &px, max)?;
        }
    }
    Ok(())
}

fn write_heatmap(path: &Path, w: u32, h: u32, px: &[Vec3], max: f32) -> Result<()> {
    let rgb: Vec<u8> = px.iter().flat_map(|c| c.to_array().map(|v| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)).collect();
    let (img, hh) = with_legend(&rgb, w, h, max);
    output::write_png(path, w, hh, img)?;
    println!("wrote {} (luminance error, 0 to {max:.3e})", path.display());
    Ok(())
}

//! Images: the per-pixel truth (cached), per-pixel errors, and the grid of renders, truth
//! and error heatmaps in the manner of Xu et al.'s figs. 9–10.

use crate::truth::key as vertex_key;
use anyhow::{Context, Result};
use rsl_engine::cache::KeyHasher;
use rsl_engine::method::{Method, Request, Truth, exposure_for};
use rsl_engine::{Engine, Progress};
use rsl_scene::Scene;
use rsl_shade::{Image, tonemap};
use rsl_truth::metrics::{draw_text, false_colour, luminance_errors, with_legend};
use std::path::Path;

/// The scene as the grid sees it: the camera at half the scene's resolution (at least
/// 16×12), so that a low-noise per-pixel truth stays affordable.
pub fn grid_scene(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    s.camera.width = (scene.camera.width / 2).max(16);
    s.camera.height = (scene.camera.height / 2).max(12);
    s
}

/// The per-pixel truth of `scene` (already at the grid's resolution) at `time`: from
/// `dir` when it is there (an EXR with coverage alpha), else estimated and written there.
/// Returns it, its own noise (relative L2 of its standard errors over the pixels objects
/// cover; kept beside it as `<file>.noise`) and whether it came from the cache.
pub fn truth_image(
    engine: &Engine,
    scene: &Scene,
    time: f32,
    spp: u32,
    seed: u64,
    dir: Option<&Path>,
    progress: &Progress,
) -> Result<(Image, f64, bool)> {
    let key = KeyHasher::default()
        .str("pixels, box-filtered")
        .u64(vertex_key(engine, scene, time, spp, seed))
        .f32s(&scene.camera.target.to_array())
        .f32s(&scene.camera.up.to_array())
        .f32s(&[scene.camera.fov_y])
        .u64(u64::from(scene.camera.width))
        .u64(u64::from(scene.camera.height))
        .finish();
    let file = dir.map(|d| d.join(format!("truth-pixels-{key:016x}.exr")));
    let noise_file = file.as_ref().map(|f| f.with_extension("noise"));
    if let (Some(f), Some(nf)) = (&file, &noise_file)
        && f.exists()
    {
        let noise = std::fs::read_to_string(nf).ok().and_then(|s| s.trim().parse::<f64>().ok());
        match (rsl_engine::output::read_exr(f), noise) {
            (Ok((w, h, pixels, Some(covered))), Some(noise))
                if (w, h) == (scene.camera.width, scene.camera.height)
                    && pixels.iter().all(|p| p.is_finite())
                    && noise.is_finite() =>
            {
                return Ok((Image { width: w, height: h, pixels, covered }, noise, true));
            }
            (Err(e), _) => tracing::warn!("{e:#}; estimating again"),
            _ => tracing::warn!("{}: not the truth this scene needs; estimating again", f.display()),
        }
    }
    let mut method = Truth::new(engine, spp, seed)?;
    method.progress = progress.clone();
    let frame = method.render(engine, scene, &Request { time, image: true, vertices: false, exposure: None })?;
    let noise = frame.self_error.and_then(|e| e.pixels).context("the truth estimates its noise (spp ≥ 2)")?;
    let image = frame.image.context("the truth draws an image")?;
    if let (Some(f), Some(nf)) = (&file, &noise_file) {
        if let Some(d) = f.parent() {
            std::fs::create_dir_all(d).with_context(|| format!("cannot create {}", d.display()))?;
        }
        rsl_engine::output::write_exr(f, image.width, image.height, &image.pixels, &image.covered)?;
        rsl_engine::output::write_atomic(nf, noise.to_string().as_bytes())?;
    }
    Ok((image, noise, false))
}

/// Relative L2 of `image` against the truth over the pixels the truth sees covered.
pub fn pixel_error(image: &Image, truth: &Image) -> Result<f64> {
    Ok(rsl_truth::compare(&image.pixels, &truth.pixels, Some(&truth.covered))?.relative_l2)
}

/// One row of the grid: a label, a render and its error against the truth.
pub struct GridRow<'a> {
    /// What the row shows.
    pub label: String,
    /// The render.
    pub image: &'a Image,
}

/// The grid as RGB8: a first row with the truth, then per configuration its render beside
/// its error heatmap (luminance error, one false-colour scale for the whole grid: 0 to the
/// 99th percentile of every row's errors, with its legend below). All images share the
/// truth's exposure. Returns the pixels and the size.
pub fn grid(truth: &Image, truth_label: &str, rows: &[GridRow<'_>]) -> (Vec<u8>, u32, u32) {
    let (w, h) = (truth.width, truth.height);
    const LABEL: u32 = 16;
    const GAP: u32 = 4;
    let exposure = exposure_for(truth);
    let errors: Vec<Vec<f32>> = rows
        .iter()
        .map(|r| {
            luminance_errors(&r.image.pixels, &truth.pixels)
                .into_iter()
                .zip(&truth.covered)
                .map(|(e, &c)| if c { e } else { 0.0 })
                .collect()
        })
        .collect();
    let mut all: Vec<f32> =
        errors.iter().flat_map(|e| e.iter().zip(&truth.covered).filter(|(_, c)| **c).map(|(v, _)| *v)).collect();
    all.sort_by(f32::total_cmp);
    let scale = all.get(all.len().saturating_sub(1) * 99 / 100).copied().unwrap_or(1.0).max(1e-12);
    let width = 2 * w + 3 * GAP;
    let height = (1 + rows.len() as u32) * (h + LABEL + GAP) + GAP;
    let mut out = vec![24u8; (width * height * 3) as usize];
    let blit = |out: &mut Vec<u8>, rgb: &[u8], x0: u32, y0: u32| {
        for y in 0..h {
            let src = (y * w * 3) as usize;
            let dst = (((y0 + y) * width + x0) * 3) as usize;
            out[dst..dst + (w * 3) as usize].copy_from_slice(&rgb[src..src + (w * 3) as usize]);
        }
    };
    let white = [235, 235, 235];
    draw_text(&mut out, (width, height), (GAP, GAP + 2), &truth_label.to_uppercase(), 2, white);
    blit(&mut out, &tonemap::encode_all(&truth.pixels, exposure), GAP, GAP + LABEL);
    for (k, (row, err)) in rows.iter().zip(&errors).enumerate() {
        let y0 = GAP + (k as u32 + 1) * (h + LABEL + GAP);
        draw_text(&mut out, (width, height), (GAP, y0 + 2), &row.label.to_uppercase(), 2, white);
        blit(&mut out, &tonemap::encode_all(&row.image.pixels, exposure), GAP, y0 + LABEL);
        let heat: Vec<u8> =
            err.iter()
                .zip(&truth.covered)
                .flat_map(|(e, &c)| {
                    if c { false_colour(e / scale).to_array().map(|v| (v * 255.0 + 0.5) as u8) } else { [0, 0, 0] }
                })
                .collect();
        blit(&mut out, &heat, 2 * GAP + w, y0 + LABEL);
    }
    let (out, height) = with_legend(&out, width, height, scale);
    (out, width, height)
}

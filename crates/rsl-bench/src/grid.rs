//! Images: the per-pixel truth (cached), per-pixel errors, and the grid of renders, truth
//! and error heatmaps in the manner of Xu et al.'s figs. 9–10.

use crate::truth::key as vertex_key;
use anyhow::{Context, Result};
use glam::Vec3;
use rsl_engine::cache::KeyHasher;
use rsl_engine::method::{Method, Request, Truth, exposure_for};
use rsl_engine::{Engine, Progress};
use rsl_scene::Scene;
use rsl_shade::{Image, tonemap};
use rsl_truth::metrics::{draw_text, false_colour, luminance_errors, with_legend};
use std::path::Path;

/// The scene as the grid sees it: the camera at the scene's own resolution with `full`,
/// else at half of it (at least 16×12), so that a low-noise per-pixel truth stays
/// affordable.
pub fn grid_scene(scene: &Scene, full: bool) -> Scene {
    let mut s = scene.clone();
    if !full {
        s.camera.width = (scene.camera.width / 2).max(16);
        s.camera.height = (scene.camera.height / 2).max(12);
    }
    s
}

/// The per-pixel truth of a scene: its image, each pixel's standard error, and what the
/// pixels' values are split by (the object each pixel's centre sees).
pub struct TruthImage {
    /// The box-filtered image, with the pixels objects cover.
    pub image: Image,
    /// Per pixel, the standard error of its value.
    pub std_error: Vec<Vec3>,
    /// Per pixel, the object its centre sees (by index).
    pub objects: Vec<Option<usize>>,
}

impl TruthImage {
    /// The truth's own noise, relative L2 of its standard errors over the covered pixels
    /// that `keep` selects.
    pub fn noise(&self, keep: impl Fn(usize) -> bool) -> f64 {
        let (mut se, mut m) = (0.0f64, 0.0f64);
        for k in (0..self.std_error.len()).filter(|&k| self.image.covered[k] && keep(k)) {
            se += f64::from(self.std_error[k].length_squared());
            m += f64::from(self.image.pixels[k].length_squared());
        }
        if m > 0.0 { (se / m).sqrt() } else { 0.0 }
    }
}

/// The per-pixel truth of `scene` (already at the grid's resolution) at `time`: from `dir`
/// when it is there (two EXRs with coverage alpha: the values and their standard errors),
/// else estimated and written there. Returns it and whether it came from the cache.
pub fn truth_image(
    engine: &Engine,
    scene: &Scene,
    time: f32,
    spp: u32,
    seed: u64,
    dir: Option<&Path>,
    progress: &Progress,
) -> Result<(TruthImage, bool)> {
    let key = KeyHasher::default()
        .str("pixels, box-filtered, with their standard errors")
        .u64(vertex_key(engine, scene, time, spp, seed))
        .f32s(&scene.camera.target.to_array())
        .f32s(&scene.camera.up.to_array())
        .f32s(&[scene.camera.fov_y])
        .u64(u64::from(scene.camera.width))
        .u64(u64::from(scene.camera.height))
        .finish();
    let objects = rsl_engine::compose::object_pixels(scene, time);
    let file = dir.map(|d| d.join(format!("truth-pixels-{key:016x}.exr")));
    let error_file = dir.map(|d| d.join(format!("truth-pixels-{key:016x}-error.exr")));
    if let (Some(f), Some(ef)) = (&file, &error_file)
        && f.exists()
    {
        let size = (scene.camera.width, scene.camera.height);
        let read = |path: &Path| match rsl_engine::output::read_exr(path) {
            Ok((w, h, pixels, Some(covered))) if (w, h) == size && pixels.iter().all(|p| p.is_finite()) => {
                Some((pixels, covered))
            }
            Ok(_) => {
                tracing::warn!("{}: not the truth this scene needs; estimating again", path.display());
                None
            }
            Err(e) => {
                tracing::warn!("{e:#}; estimating again");
                None
            }
        };
        if let Some((pixels, covered)) = read(f)
            && let Some((std_error, _)) = read(ef)
            && std_error.iter().all(|e| e.min_element() >= 0.0)
        {
            let image = Image { width: size.0, height: size.1, pixels, covered };
            return Ok((TruthImage { image, std_error, objects }, true));
        }
    }
    let mut method = Truth::new(engine, spp, seed)?;
    method.progress = progress.clone();
    let frame = method.render(engine, scene, &Request { time, image: true, vertices: false, exposure: None })?;
    let std_error = frame.pixel_std_error.context("the truth estimates its noise (spp ≥ 2)")?;
    let image = frame.image.context("the truth draws an image")?;
    if let (Some(f), Some(ef)) = (&file, &error_file) {
        if let Some(d) = f.parent() {
            std::fs::create_dir_all(d).with_context(|| format!("cannot create {}", d.display()))?;
        }
        // The errors first: a truth is read only where both files are.
        rsl_engine::output::write_exr(ef, image.width, image.height, &std_error, &image.covered)?;
        rsl_engine::output::write_exr(f, image.width, image.height, &image.pixels, &image.covered)?;
    }
    Ok((TruthImage { image, std_error, objects }, false))
}

/// An image's error against the truth over the pixels the truth sees covered: relative L2
/// over all of them, with the truth's noise there, and the same per object (over the
/// pixels whose centre sees it; `names` by index).
pub struct PixelError {
    /// Relative L2 over the covered pixels, and the truth's noise there.
    pub scene: (f64, f64),
    /// Per object: name, relative L2 over its pixels, the truth's noise there.
    pub objects: Vec<(String, f64, f64)>,
}

/// [`PixelError`] of `image` against `truth`; objects that cover no pixel, or that the truth
/// sees black (a relative error has no meaning there), are left out.
pub fn pixel_error(image: &Image, truth: &TruthImage, names: &[String]) -> Result<PixelError> {
    let covered = &truth.image.covered;
    let scene = rsl_truth::compare(&image.pixels, &truth.image.pixels, Some(covered))?.relative_l2;
    let mut objects = Vec::new();
    for (j, name) in names.iter().enumerate() {
        let mask: Vec<bool> = (0..covered.len()).map(|k| covered[k] && truth.objects[k] == Some(j)).collect();
        if !mask.contains(&true) {
            continue;
        }
        let e = rsl_truth::compare(&image.pixels, &truth.image.pixels, Some(&mask))?.relative_l2;
        if !e.is_finite() {
            continue;
        }
        objects.push((name.clone(), e, truth.noise(|k| truth.objects[k] == Some(j))));
    }
    Ok(PixelError { scene: (scene, truth.noise(|_| true)), objects })
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

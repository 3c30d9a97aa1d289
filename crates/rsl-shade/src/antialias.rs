//! Antialiasing: a pixel's value is the mean radiance over its square (docs/conventions.md,
//! "A pixel's value"). One sample at the centre is that mean wherever the radiance is smooth
//! across the square; where it is not — a silhouette, one object in front of another, a
//! shadow edge, a highlight smaller than a pixel — the centre alone aliases. An antialiased
//! image takes more samples (a grid over the square, averaged: a box filter) in the pixels
//! that the centre samples show to be such edges, and keeps the centre elsewhere: the cost
//! grows with the edges' length, not with the image's area. Samples are spent in rounds
//! ([`rounds`]): every edge pixel takes a 2×2 grid ([`FIRST_ROUND`]); a pixel whose four
//! samples span a wide range of luminance ([`sample_again`]: a sun's glint, a bright edge)
//! takes the `k×k` grid of `aa` samples besides — at most [`SECOND_ROUND`]; with `aa` beyond
//! that, a pixel whose samples so far still span many times the image's mean
//! ([`sample_glint`]: a glint's line thinner than a pixel, thousands of times brighter
//! than its surround) takes the grid of `aa` samples in a third round. Its value is the
//! mean of all its samples.
//!
//! A pixel is an edge when, against one of its four neighbours,
//! - what its centre sees differs: another object, the background, or the same object at a
//!   depth more than [`DEPTH_JUMP`] apart (a fold of the mesh in front of itself);
//! - or, on one surface with both neighbours along an axis, its value bends: the second
//!   difference of luminance exceeds [`CONTRAST`] of the largest of the three (plus a floor
//!   of [`FLOOR`] × the image's mean, so that the noise of near-black pixels is no edge).
//!   A value that changes linearly across the square averages to the centre's; a step (a
//!   shadow's edge) or a peak (a highlight smaller than a pixel) does not.

use crate::raster::Fragment;
use glam::Vec3;
use rayon::prelude::*;

/// The relative depth step between neighbouring pixels of one object taken for a fold.
pub const DEPTH_JUMP: f32 = 0.1;

/// The second difference of luminance across a pixel, relative to the largest of the three
/// values, taken for a shading edge.
pub const CONTRAST: f32 = 0.1;

/// The second difference of luminance below which no shading edge is taken, relative to the
/// image's mean.
pub const FLOOR: f32 = 0.01;

/// The most samples per pixel.
pub const MAX_SAMPLES: u32 = 64;

/// The most sub-pixel samples whose fragments are held at once (about 120 MB with their
/// depths): an image of any size with any share of edge pixels is sampled in pieces.
pub const SAMPLES_AT_ONCE: usize = 1 << 22;

/// The samples every edge pixel takes first (a 2×2 grid).
pub const FIRST_ROUND: u32 = 4;

/// The span of a pixel's first samples' luminance, relative to the image's mean, above
/// which it takes the second round ([`sample_again`]). On the default scene at 640×480
/// (`auto`, `aa = 16`) 4 sends 681 of 18,346 edge pixels to the second round, 1 sends
/// 2,774, each of every edge pixel (taking all 16 at once) 18,346; against the truth
/// (1,024 samples per pixel, box-filtered) they came to 2.51 %, 2.47 % and 2.48 % per covered
/// pixel, and 2.58 % with the first round alone. A rough glTF gold sphere's rim, where
/// Fresnel brightens steeply within a pixel, needs the lower span: on
/// `data/scenes/accuracy/gltf_spheres.toml` at 200×150 against the truth at 8,192 samples per
/// pixel, its error per covered pixel is 4.13 % at 4, 3.89 % at 2 and 2.46 % at 1 (1.35 %
/// in the rim's ring of pixels with 4×4 samples everywhere, 8.74 % at 4); the red dielectric
/// 3.83 %, 3.79 %, 3.59 %. The cost: the default scene's frame on the CPU (`cargo bench
/// --bench image_frame`, `auto_aa16`) 505 ms at 4, 588 ms at 1. At 0.5 (`aa = 36`) 4,071 of
/// the default scene's edge pixels take the second round (2,771 at 1), and no object of the
/// results pages at `standard` got worse by more than 0.02 points (two of the glTF page's
/// spheres drawn by the lobe methods alone, at 27–32 %, by 0.05 and 0.08) while a dark ball's
/// silhouette against a bright sky, whose span is under the image's mean, now takes it: in
/// the white furnace (`docs/bench/furnace`) GGX α = 1 3.14 → 2.34 %, Ward 2.13 → 1.82 %;
/// the Suzanne beside a near-mirror ball (`docs/bench/sharp_lobes`) 4.26 → 3.98 %; the
/// glTF blue sphere 2.74 → 2.10 %; the low-sun Suzanne against 8,192 samples per pixel
/// 4.07 → 3.84 %. The cost: about 7 % more samples shaded in the default scene's frame
/// (`auto_aa36` 805.4 → 852.1 ms in one criterion pair, no change detected in another).
pub const SPREAD: f32 = 0.5;

/// The samples of the second round at most: a 4×4 grid. With `aa` beyond it, the third
/// round takes the grid of `aa` samples in the pixels [`sample_glint`] picks.
pub const SECOND_ROUND: u32 = 16;

/// The span of a pixel's samples after the second round, relative to the image's mean
/// luminance (the same mean as [`sample_again`]'s), above which it takes the third round
/// ([`sample_glint`]). On `data/scenes/accuracy/lowsun_glossy.toml` (a Beckmann α = 0.1
/// Suzanne under a low sun, 480×360, `auto`, `standard` with `aa = 64`, against the truth
/// at 2,048 samples per pixel, its noise 2.20 %) 1, 2, 4 and 8 send 1,145, 800, 586 and 436
/// of the 1,145 second-round pixels on and all come to 4.21 % per covered pixel; 16 and 32
/// send 339 and 245 for 4.22 % and 4.25 %; `aa = 16` (no third round) is 5.10 %.
pub const GLINT: f32 = 8.0;

/// The samples each round takes in the pixels it picks, for `aa` samples per pixel: none
/// for `aa` ≤ 1; `aa` alone up to [`FIRST_ROUND`]; then [`FIRST_ROUND`] and `aa`, up to
/// [`SECOND_ROUND`]; beyond it [`FIRST_ROUND`], [`SECOND_ROUND`] and `aa`.
pub fn rounds(aa: u32) -> Vec<u32> {
    match aa {
        0 | 1 => Vec::new(),
        a if a <= FIRST_ROUND => vec![a],
        a if a <= SECOND_ROUND => vec![FIRST_ROUND, a],
        a => vec![FIRST_ROUND, SECOND_ROUND, a],
    }
}

/// Whether `aa` is a valid number of samples per pixel: a square in `1..=`[`MAX_SAMPLES`]
/// (1: the centre alone, no antialiasing).
pub fn valid_samples(aa: u32) -> bool {
    rsl_scene::quality::valid_aa(aa)
}

fn grid_side(aa: u32) -> u32 {
    (aa as f64).sqrt().round() as u32
}

/// The points of pixel `(0, 0)`'s square (`[0, 1)²`) that `aa` samples take: the centres of
/// a `k×k` grid (`aa = k²`).
pub fn sample_offsets(aa: u32) -> Vec<[f32; 2]> {
    let k = grid_side(aa).max(1);
    let step = 1.0 / k as f32;
    (0..k * k).map(|s| [((s % k) as f32 + 0.5) * step, ((s / k) as f32 + 0.5) * step]).collect()
}

/// Luminance (Rec. 709 weights).
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// The mean luminance of an image's `values` (negative values as 0, infinite ones left out).
pub fn mean_luminance(values: &[Vec3]) -> f32 {
    let (sum, n) = values
        .iter()
        .map(|&c| luminance(c).max(0.0))
        .filter(|l| l.is_finite())
        .fold((0.0f64, 0usize), |(s, n), l| (s + f64::from(l), n + 1));
    (sum / n.max(1) as f64) as f32
}

/// Whether a pixel whose first samples' luminances span `[lo, hi]` takes the second round,
/// in an image of mean luminance `mean`: where the span exceeds [`SPREAD`] × `mean`. The
/// pixels that weigh most in the image's error — a sun's glint against a dark surround, a
/// bright edge — and only those.
pub fn sample_again(lo: f32, hi: f32, mean: f32) -> bool {
    hi - lo > SPREAD * mean
}

/// Whether a pixel of the second round whose samples (the first round's and the second's)
/// span `[lo, hi]` takes the third, in an image of mean luminance `mean` (as
/// [`sample_again`]'s): where the span exceeds [`GLINT`] × `mean`. A glint's line a
/// fraction of a pixel wide falls on one row of a 4×4 grid or none, a quarter of the
/// samples or nothing, where it covers a tenth of the square: its pixels need the finer
/// grid, and they are few.
pub fn sample_glint(lo: f32, hi: f32, mean: f32) -> bool {
    hi - lo > GLINT * mean
}

/// The pixels of a `width`×`height` image that one sample at the centre does not resolve
/// (ascending), from what each centre sees (`frags`: the nearest fragment, `depth`: its
/// distance from the eye) and the value drawn there (`values`).
pub fn edge_pixels(
    width: usize,
    height: usize,
    frags: &[Option<Fragment>],
    depth: &[f32],
    values: &[Vec3],
) -> Vec<usize> {
    let n = width * height;
    assert!(frags.len() == n && depth.len() == n && values.len() == n, "buffers of another size");
    let lum: Vec<f32> = values.par_iter().map(|&c| luminance(c).max(0.0)).collect();
    let floor = FLOOR * mean_luminance(values);
    let same_surface = |a: usize, b: usize| -> bool {
        match (&frags[a], &frags[b]) {
            (None, None) => true,
            (Some(f), Some(g)) => {
                f.mesh == g.mesh && (depth[a] - depth[b]).abs() <= DEPTH_JUMP * depth[a].min(depth[b])
            }
            _ => false,
        }
    };
    (0..n)
        .into_par_iter()
        .filter(|&k| {
            let (x, y) = (k % width, k / width);
            let mut surfaces = false;
            let mut shading = false;
            // Along each axis: the neighbours on either side, where there are.
            for (before, after) in [
                ((x > 0).then(|| k - 1), (x + 1 < width).then(|| k + 1)),
                ((y > 0).then(|| k - width), (y + 1 < height).then(|| k + width)),
            ] {
                let sides = [before, after].map(|j| j.map(|j| (j, same_surface(k, j))));
                surfaces |= sides.iter().flatten().any(|&(_, same)| !same);
                // A value that bends across the pixel (a linear change averages to the
                // centre's value over the square; a step or a peak does not).
                if let [Some((a, true)), Some((b, true))] = sides {
                    let bend = (lum[a] + lum[b] - 2.0 * lum[k]).abs();
                    shading |= bend > CONTRAST * lum[a].max(lum[b]).max(lum[k]) + floor;
                }
            }
            surfaces || shading
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_samples_are_a_grid_over_the_square_centred_on_it() {
        for aa in [1, 4, 9, 16, 64] {
            let o = sample_offsets(aa);
            assert_eq!(o.len(), aa as usize);
            let mean = o.iter().fold([0.0, 0.0], |m, p| [m[0] + p[0] / aa as f32, m[1] + p[1] / aa as f32]);
            assert!((mean[0] - 0.5).abs() < 1e-6 && (mean[1] - 0.5).abs() < 1e-6, "{aa}: {mean:?}");
            assert!(o.iter().flatten().all(|&c| (0.0..1.0).contains(&c)));
        }
        assert_eq!(sample_offsets(1), vec![[0.5, 0.5]]);
        assert!([1, 4, 9, 16, 25, 36, 49, 64].into_iter().all(valid_samples));
        assert!([0, 2, 3, 8, 15, 81, 100].into_iter().all(|a| !valid_samples(a)));
    }

    #[test]
    fn the_rounds_take_four_then_at_most_sixteen_then_the_rest() {
        assert!(rounds(1).is_empty());
        assert_eq!(rounds(4), [4]);
        assert_eq!(rounds(9), [4, 9]);
        assert_eq!(rounds(16), [4, 16]);
        assert_eq!(rounds(36), [4, 16, 36]);
        assert_eq!(rounds(64), [4, 16, 64]);
        // A glint's span is GLINT × the mean, wherever the values sit; it exceeds the second
        // round's.
        const { assert!(GLINT > SPREAD) };
        let (below, above) = (0.97 * GLINT, 1.03 * GLINT);
        assert!(!sample_glint(0.0, below, 1.0) && sample_glint(0.0, above, 1.0));
        assert!(!sample_glint(50.0, 50.0 + 3.0 * below, 3.0) && sample_glint(50.0, 50.0 + 3.0 * above, 3.0));
    }

    #[test]
    fn a_pixel_is_sampled_again_where_its_span_outweighs_the_image() {
        // A span of SPREAD × the mean is the threshold, wherever the values sit.
        let (below, above) = (0.97 * SPREAD, 1.03 * SPREAD);
        assert!(!sample_again(0.0, below, 1.0) && sample_again(0.0, above, 1.0));
        assert!(!sample_again(100.0, 100.0 + 2.0 * below, 2.0) && sample_again(100.0, 100.0 + 2.0 * above, 2.0));
        let image = [Vec3::ONE, Vec3::ZERO, Vec3::splat(f32::INFINITY), Vec3::splat(-1.0)];
        assert!((mean_luminance(&image) - 1.0 / 3.0).abs() < 1e-6, "infinite pixels left out, negative ones as 0");
    }

    #[test]
    fn edges_are_where_objects_depths_or_values_change() {
        // A 6×4 image: object 0 on the left half at depth 1, the background on the right;
        // a value step inside the object between rows 1 and 2; a fold at (1, 3).
        let (w, h) = (6, 4);
        let frag = |mesh| Some(Fragment { mesh, triangle: 0, weights: Vec3::new(1.0, 0.0, 0.0) });
        let mut frags = vec![None; w * h];
        let mut depth = vec![f32::INFINITY; w * h];
        let mut values = vec![Vec3::splat(1.0); w * h];
        for y in 0..h {
            for x in 0..3 {
                frags[y * w + x] = frag(0);
                depth[y * w + x] = 1.0;
                values[y * w + x] = Vec3::splat(if y < 2 { 1.0 } else { 0.5 });
            }
        }
        depth[3 * w + 1] = 2.0;
        values[3 * w + 1] = Vec3::splat(0.5);
        let edges = edge_pixels(w, h, &frags, &depth, &values);
        let expect: Vec<usize> = (0..w * h)
            .filter(|&k| {
                let (x, y) = (k % w, k / w);
                // The object's border with the background, and the fold and its neighbours.
                let surfaces = x == 2 || x == 3 || [3 * w, 3 * w + 1, 3 * w + 2, 2 * w + 1].contains(&k);
                // Either side of the value step within the object.
                let shading = x < 3 && (y == 1 || y == 2);
                surfaces || shading
            })
            .collect();
        assert_eq!(edges, expect);
        // A value changing linearly is no edge; a peak is.
        let smooth: Vec<Vec3> = (0..w * h).map(|k| Vec3::splat(1.0 + 0.01 * k as f32)).collect();
        let none = vec![None; w * h];
        let far = vec![f32::INFINITY; w * h];
        assert!(edge_pixels(w, h, &none, &far, &smooth).is_empty());
        let mut peak = smooth;
        peak[2 * w + 2] *= 1.5;
        let found = edge_pixels(w, h, &none, &far, &peak);
        assert_eq!(found, [w + 2, 2 * w + 1, 2 * w + 2, 2 * w + 3]);
    }
}

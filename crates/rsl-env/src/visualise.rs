//! The decomposition drawn like Xu et al. 2006, figure 6: the tonemapped lat-long map with
//! region borders and the fitted squares on top, and below it the map the RSLs alone
//! reproduce.

use crate::decompose::{Decomposition, Rsl, RslInfo};
use glam::{Vec2, Vec3};
use rsl_sphere::frame::Frame;
use rsl_sphere::hemi::dir_from_hemi;
use rsl_sphere::latlong::{LatLongMap, dir_from_uv, uv_from_dir};
use rsl_sphere::sampling::luminance;

/// Exposure that maps the map's log-average luminance to 0.18 (Reinhard et al. 2002).
pub fn auto_exposure(map: &LatLongMap) -> f32 {
    let (mut sum, mut weight) = (0.0f64, 0.0f64);
    for j in 0..map.height() {
        let w = map.texel_solid_angle(j);
        for i in 0..map.width() {
            sum += w * f64::from(luminance(map.texel(i, j)) + 1e-4).ln();
            weight += w;
        }
    }
    let log_avg = (sum / weight).exp() as f32;
    if log_avg.is_finite() && log_avg > 0.0 { 0.18 / log_avg } else { 1.0 }
}

/// Tonemaps linear radiance to 8-bit sRGB: exposure, Reinhard's `x/(1+x)` on each channel,
/// then the sRGB transfer curve.
pub fn tonemap(c: Vec3, exposure: f32) -> [u8; 3] {
    let f = |x: f32| {
        let x = (x * exposure).max(0.0);
        let t = x / (1.0 + x);
        let s = if t <= 0.003_130_8 { 12.92 * t } else { 1.055 * t.powf(1.0 / 2.4) - 0.055 };
        (s * 255.0 + 0.5).clamp(0.0, 255.0) as u8
    };
    [f(c.x), f(c.y), f(c.z)]
}

const BORDER: [u8; 3] = [40, 255, 80];
const SQUARE: [u8; 3] = [255, 40, 40];

/// Renders the figure as RGB8 at the map's resolution: the top half is the map with region
/// borders (green) and each RSL's square at rotation 0 (red); the bottom half shows each
/// RSL's square filled with its intensity on black. Returns `(width, height, pixels)`.
pub fn render_figure(map: &LatLongMap, d: &Decomposition, n: usize) -> Result<(u32, u32, Vec<u8>), crate::EnvError> {
    let rsls = d.rsls(n)?;
    let regions = d.regions(n)?;
    let grid = d.grid();
    let (w, h) = (map.width(), map.height());
    let exposure = auto_exposure(map);
    let pixel_dir =
        |i: usize, j: usize| dir_from_uv(Vec2::new((i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32));
    let region_at: Vec<u32> = (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| regions[grid.texel_of_dir(pixel_dir(i, j))])
        .collect();
    let mut top = vec![0u8; w * h * 3];
    for j in 0..h {
        for i in 0..w {
            let k = j * w + i;
            let right = region_at[j * w + (i + 1) % w];
            let below = if j + 1 < h { region_at[(j + 1) * w + i] } else { region_at[k] };
            let px = if right != region_at[k] || below != region_at[k] {
                BORDER
            } else {
                tonemap(map.texel(i, j), exposure)
            };
            top[3 * k..3 * k + 3].copy_from_slice(&px);
        }
    }
    let mut bottom = vec![0u8; w * h * 3];
    // Fill: a pixel lies in an RSL's square if its direction, in the RSL's equal-area plane,
    // is inside the square (rotation 0 of the RSL's frame). Brighter RSLs are drawn last.
    let frames: Vec<(Frame, &RslInfo)> = rsls.iter().rev().map(|x| (Frame::from_normal(x.rsl.centre), x)).collect();
    for j in 0..h {
        for i in 0..w {
            let d_px = pixel_dir(i, j);
            for (f, x) in &frames {
                let l = f.to_local(d_px);
                if l.z <= 0.0 {
                    continue;
                }
                let p = rsl_sphere::hemi::hemi_from_dir(l);
                let s = x.rsl.half_diagonal / std::f32::consts::SQRT_2;
                if p.x.abs() <= s && p.y.abs() <= s {
                    let k = 3 * (j * w + i);
                    bottom[k..k + 3].copy_from_slice(&tonemap(x.rsl.intensity, exposure));
                }
            }
        }
    }
    // Outlines of the squares on the top half.
    let lights: Vec<Rsl> = rsls.iter().map(|x| x.rsl).collect();
    outline_squares(&mut top, w, h, &lights, SQUARE);
    top.extend_from_slice(&bottom);
    Ok((w as u32, 2 * h as u32, top))
}

/// Draws the outline of each light's square (rotation 0 of its frame) onto `rgb`, a
/// `w × h` RGB8 lat-long image of the environment (in the lights' space).
pub fn outline_squares(rgb: &mut [u8], w: usize, h: usize, lights: &[Rsl], colour: [u8; 3]) {
    assert_eq!(rgb.len(), 3 * w * h, "image of another size");
    for x in lights {
        let f = Frame::from_normal(x.centre);
        let s = x.half_diagonal / std::f32::consts::SQRT_2;
        let steps = 256;
        for e in 0..4 {
            for k in 0..steps {
                let t = -s + 2.0 * s * k as f32 / steps as f32;
                let p = match e {
                    0 => Vec2::new(t, -s),
                    1 => Vec2::new(s, t),
                    2 => Vec2::new(-t, s),
                    _ => Vec2::new(-s, -t),
                };
                let uv = uv_from_dir(f.to_world(dir_from_hemi(p)));
                let (pi, pj) = (((uv.x * w as f32) as usize).min(w - 1), ((uv.y * h as f32) as usize).min(h - 1));
                let k = 3 * (pj * w + pi);
                rgb[k..k + 3].copy_from_slice(&colour);
            }
        }
    }
}

/// The map tonemapped at `w × h` (nearest texel, [`auto_exposure`]), RGB8 lat-long.
pub fn thumbnail(map: &LatLongMap, w: usize, h: usize) -> Vec<u8> {
    let exposure = auto_exposure(map);
    let mut out = Vec::with_capacity(3 * w * h);
    for j in 0..h {
        for i in 0..w {
            let (u, v) = ((i * map.width()) / w, (j * map.height()) / h);
            out.extend_from_slice(&tonemap(map.texel(u, v), exposure));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_outline_lies_around_its_centre() {
        let (w, h) = (512, 256);
        let centre = Vec3::new(0.3, 0.5, -0.8).normalize();
        let light = Rsl { centre, half_diagonal: 0.3, intensity: Vec3::ONE };
        let mut rgb = vec![0u8; 3 * w * h];
        outline_squares(&mut rgb, w, h, &[light], [255, 0, 0]);
        let pixel_dir =
            |i: usize, j: usize| dir_from_uv(Vec2::new((i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32));
        let mut drawn = 0;
        for j in 0..h {
            for i in 0..w {
                if rgb[3 * (j * w + i)] == 255 {
                    drawn += 1;
                    // The square's edge lies between its inscribed circle (ρ = r/√2) and
                    // its corners (ρ = r) in the equal-area plane, where ρ = √2·sin(θ/2):
                    // θ from 0.300 to 0.427 rad; one pixel is 0.012 rad.
                    let angle = pixel_dir(i, j).dot(centre).clamp(-1.0, 1.0).acos();
                    assert!((0.285..0.44).contains(&angle), "pixel ({i}, {j}) at {angle} rad from the centre");
                }
            }
        }
        assert!(drawn > 50, "{drawn} pixels drawn");
    }
}

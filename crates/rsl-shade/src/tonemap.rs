//! Display encoding: exposure, a filmic curve and the sRGB transfer function.
//!
//! `display = srgb(filmic(exposure · L))` with Narkowicz's fit of the ACES filmic curve,
//! `f(x) = x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`, clamped to `[0, 1]`.

use glam::Vec3;
use rsl_sphere::sampling::luminance;

/// The filmic curve (ACES fit): 0 → 0, monotone, saturates toward 1.
pub fn filmic(x: f32) -> f32 {
    // The curve reaches 1 at x ≈ 7.24: limiting x to 8 first changes nothing and keeps x²
    // finite (at x ≈ 2e19 it overflowed, inf/inf, and showed black).
    let x = x.clamp(0.0, 8.0);
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

/// The sRGB transfer function (linear `[0, 1]` → encoded `[0, 1]`).
pub fn srgb_encode(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 }
}

/// One pixel, exposed, tonemapped and encoded to 8-bit sRGB. Non-finite values show black.
pub fn encode(c: Vec3, exposure: f32) -> [u8; 3] {
    let c = if c.is_finite() { c } else { Vec3::ZERO };
    let q = |v: f32| (srgb_encode(filmic(v * exposure)) * 255.0 + 0.5) as u8;
    [q(c.x), q(c.y), q(c.z)]
}

/// Every pixel encoded to interleaved 8-bit sRGB.
pub fn encode_all(pixels: &[Vec3], exposure: f32) -> Vec<u8> {
    pixels.iter().flat_map(|&c| encode(c, exposure)).collect()
}

/// An exposure that maps the log-average luminance of `pixels` to middle grey (0.18),
/// ignoring non-finite values; 1 for an empty or black image.
pub fn auto_exposure(pixels: &[Vec3]) -> f32 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for c in pixels.iter().filter(|c| c.is_finite()) {
        sum += f64::from(luminance(*c).max(0.0) + 1e-4).ln();
        n += 1;
    }
    if n == 0 {
        return 1.0;
    }
    let avg = (sum / n as f64).exp() as f32;
    if avg > 1e-3 { 0.18 / avg } else { 1.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curve_and_encoding_are_monotone_and_bounded() {
        assert_eq!(filmic(0.0), 0.0);
        let mut last = 0.0;
        for k in 1..2000 {
            let y = filmic(k as f32 * 0.01);
            assert!(y >= last && y <= 1.0);
            last = y;
        }
        assert!(filmic(1e6) > 0.99);
        // The sRGB curve's pieces meet at 0.0031308 and it maps 1 to 1.
        assert!((srgb_encode(0.003_130_8) - 0.040_45).abs() < 1e-4);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        // A non-finite pixel shows black; a huge one saturates.
        assert_eq!(encode(Vec3::new(f32::NAN, 0.0, 1.0), 1.0), [0, 0, 0]);
        assert_eq!(encode(Vec3::new(0.0, 0.0, 1e9), 1.0), [0, 0, 255]);
        // So does a pixel under an exposure that overflows x² (the largest `--exposure`s).
        for e in [1e20, 1e38, f32::MAX] {
            assert_eq!(encode(Vec3::new(0.0, 0.5, 3e38), e), [0, 255, 255], "exposure {e}");
        }
        // Up to where it saturates the curve is the formula unclamped.
        let x = 7.0f32;
        assert_eq!(filmic(x), (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14));
    }

    #[test]
    fn auto_exposure_maps_a_uniform_image_to_middle_grey() {
        let px = vec![Vec3::splat(4.0); 100];
        let e = auto_exposure(&px);
        assert!((e * 4.0 - 0.18).abs() < 1e-3);
        assert_eq!(auto_exposure(&[]), 1.0);
    }
}

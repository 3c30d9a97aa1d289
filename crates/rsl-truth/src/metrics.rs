//! Error metrics between a result and a reference, over vertices or pixels (optionally only
//! those a mask keeps), every channel counted:
//!
//! - relative L2: `‖L − L_ref‖₂ / ‖L_ref‖₂`;
//! - RMSE: `√(mean (L − L_ref)²)`;
//! - max: the largest absolute channel difference;
//! - PSNR: `20·log10(peak / RMSE)` dB with `peak` the largest reference channel value.
//!
//! And false-colour heatmaps of per-point error with a legend.

use glam::Vec3;
use rsl_sphere::sampling::luminance;

/// The four measures and how many points they cover.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    /// Points compared.
    pub points: usize,
    /// `‖L − L_ref‖₂ / ‖L_ref‖₂`.
    pub relative_l2: f64,
    /// Root mean squared error per channel value.
    pub rmse: f64,
    /// Largest absolute channel difference.
    pub max_abs: f64,
    /// Peak signal-to-noise ratio in dB (infinite for identical inputs).
    pub psnr_db: f64,
}

impl std::fmt::Display for Metrics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "points {}  relative L2 {:.6}  RMSE {:.6e}  max {:.6e}  PSNR {:.2} dB",
            self.points, self.relative_l2, self.rmse, self.max_abs, self.psnr_db
        )
    }
}

/// Why two sets of values cannot be compared.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CompareError {
    /// The two sets differ in length.
    #[error("{test} values against {reference} in the reference")]
    Length {
        /// Values tested.
        test: usize,
        /// Values in the reference.
        reference: usize,
    },
    /// The mask's length is not the values'.
    #[error("mask of {mask} for {values} values")]
    MaskLength {
        /// Entries in the mask.
        mask: usize,
        /// Values.
        values: usize,
    },
    /// A value is NaN or infinite.
    #[error("value {index} is not finite ({test} against {reference})")]
    NotFinite {
        /// Its index.
        index: usize,
        /// The tested value.
        test: Vec3,
        /// The reference value.
        reference: Vec3,
    },
    /// Nothing is left to compare.
    #[error("no values to compare (empty input or nothing covered)")]
    Empty,
}

/// Compares `test` with `reference` where `mask` (if any) is true.
pub fn compare(test: &[Vec3], reference: &[Vec3], mask: Option<&[bool]>) -> Result<Metrics, CompareError> {
    if test.len() != reference.len() {
        return Err(CompareError::Length { test: test.len(), reference: reference.len() });
    }
    if let Some(m) = mask
        && m.len() != reference.len()
    {
        return Err(CompareError::MaskLength { mask: m.len(), values: reference.len() });
    }
    let (mut diff2, mut ref2, mut max_abs, mut peak, mut points) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0usize);
    for (k, (a, b)) in test.iter().zip(reference).enumerate() {
        if mask.is_some_and(|m| !m[k]) {
            continue;
        }
        if !a.is_finite() || !b.is_finite() {
            return Err(CompareError::NotFinite { index: k, test: *a, reference: *b });
        }
        points += 1;
        for c in 0..3 {
            let (x, y) = (f64::from(a[c]), f64::from(b[c]));
            diff2 += (x - y) * (x - y);
            ref2 += y * y;
            max_abs = max_abs.max((x - y).abs());
            peak = peak.max(y);
        }
    }
    if points == 0 {
        return Err(CompareError::Empty);
    }
    let rmse = (diff2 / (3 * points) as f64).sqrt();
    Ok(Metrics {
        points,
        relative_l2: if ref2 > 0.0 {
            (diff2 / ref2).sqrt()
        } else if diff2 == 0.0 {
            0.0
        } else {
            f64::INFINITY
        },
        rmse,
        max_abs,
        psnr_db: if rmse > 0.0 { 20.0 * (peak / rmse).log10() } else { f64::INFINITY },
    })
}

/// Per point, the absolute error of the luminance.
pub fn luminance_errors(test: &[Vec3], reference: &[Vec3]) -> Vec<f32> {
    test.iter().zip(reference).map(|(a, b)| (luminance(*a) - luminance(*b)).abs()).collect()
}

/// A perceptually ordered false colour (viridis, piecewise linear through 5 of its stops)
/// for `t ∈ [0, 1]`, as linear-free display RGB in `[0, 1]`.
pub fn false_colour(t: f32) -> Vec3 {
    const STOPS: [[f32; 3]; 5] = [
        [0.267, 0.005, 0.329],
        [0.229, 0.322, 0.546],
        [0.128, 0.567, 0.551],
        [0.369, 0.789, 0.383],
        [0.993, 0.906, 0.144],
    ];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 1.0 };
    let x = t * 4.0;
    let i = (x as usize).min(3);
    let f = x - i as f32;
    Vec3::from(STOPS[i]).lerp(Vec3::from(STOPS[i + 1]), f)
}

/// 3×5 glyphs (rows top to bottom, bit 4 the left column) of digits, letters (lower case
/// drawn as upper case, but for the exponent's `e`) and the punctuation labels need; other
/// characters are blank.
fn glyph(c: char) -> [u8; 5] {
    let c = if c.is_ascii_lowercase() && c != 'e' { c.to_ascii_uppercase() } else { c };
    match c {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 1, 1],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '.' => [0, 0, 0, 0, 2],
        '-' => [0, 0, 7, 0, 0],
        '+' => [0, 2, 7, 2, 0],
        'e' => [0, 7, 7, 4, 7],
        'A' => [2, 5, 7, 5, 5],
        'B' => [6, 5, 6, 5, 6],
        'C' => [3, 4, 4, 4, 3],
        'D' => [6, 5, 5, 5, 6],
        'E' => [7, 4, 6, 4, 7],
        'F' => [7, 4, 6, 4, 4],
        'G' => [3, 4, 5, 5, 3],
        'H' => [5, 5, 7, 5, 5],
        'I' => [7, 2, 2, 2, 7],
        'J' => [1, 1, 1, 5, 2],
        'K' => [5, 5, 6, 5, 5],
        'L' => [4, 4, 4, 4, 7],
        'M' => [5, 7, 7, 5, 5],
        'N' => [6, 5, 5, 5, 5],
        'O' => [2, 5, 5, 5, 2],
        'P' => [6, 5, 6, 4, 4],
        'Q' => [2, 5, 5, 6, 3],
        'R' => [6, 5, 6, 5, 5],
        'S' => [3, 4, 2, 1, 6],
        'T' => [7, 2, 2, 2, 2],
        'U' => [5, 5, 5, 5, 7],
        'V' => [5, 5, 5, 5, 2],
        'W' => [5, 5, 7, 7, 5],
        'X' => [5, 5, 2, 5, 5],
        'Y' => [5, 5, 2, 2, 2],
        'Z' => [7, 1, 2, 4, 7],
        '=' => [0, 7, 0, 7, 0],
        ':' => [0, 2, 0, 2, 0],
        '%' => [5, 1, 2, 4, 5],
        '(' => [1, 2, 2, 2, 1],
        ')' => [4, 2, 2, 2, 4],
        ',' => [0, 0, 0, 2, 4],
        '/' => [1, 1, 2, 4, 4],
        '_' => [0, 0, 0, 0, 7],
        '×' => [0, 5, 2, 5, 0],
        _ => [0; 5],
    }
}

/// Draws `text` with its top left at `(x, y)` into an RGB8 image of `(width, height)`, each
/// glyph pixel `scale`² pixels.
pub fn draw_text(
    rgb: &mut [u8],
    (width, height): (u32, u32),
    (x, y): (u32, u32),
    text: &str,
    scale: u32,
    colour: [u8; 3],
) {
    for (k, c) in text.chars().enumerate() {
        let g = glyph(c);
        for (row, bits) in g.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let px = x + (k as u32 * 4 + col) * scale + dx;
                        let py = y + row as u32 * scale + dy;
                        if px < width && py < height {
                            let o = ((py * width + px) * 3) as usize;
                            rgb[o..o + 3].copy_from_slice(&colour);
                        }
                    }
                }
            }
        }
    }
}

/// Adds a legend strip below an RGB8 image: the colour bar from 0 to `max` with both ends
/// labelled. Returns the new image and its height.
pub fn with_legend(rgb: &[u8], width: u32, height: u32, max: f32) -> (Vec<u8>, u32) {
    let strip = 40;
    let h = height + strip;
    let mut out = vec![24u8; (width * h * 3) as usize];
    out[..rgb.len()].copy_from_slice(rgb);
    let (x0, x1) = (8, width.saturating_sub(8).max(9));
    for x in x0..x1 {
        let c = false_colour((x - x0) as f32 / (x1 - x0 - 1).max(1) as f32);
        let px = [c.x, c.y, c.z].map(|v| (v * 255.0 + 0.5) as u8);
        for y in height + 6..height + 20 {
            let o = ((y * width + x) * 3) as usize;
            out[o..o + 3].copy_from_slice(&px);
        }
    }
    let white = [235, 235, 235];
    draw_text(&mut out, (width, h), (x0, height + 24), "0", 2, white);
    let label = format!("{max:.2e}");
    let lw = label.chars().count() as u32 * 8;
    draw_text(&mut out, (width, h), (x1.saturating_sub(lw), height + 24), &label, 2, white);
    (out, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_of_known_differences() {
        let reference = vec![Vec3::new(1.0, 2.0, 2.0), Vec3::ZERO];
        let test = vec![Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO];
        let m = compare(&test, &reference, None).unwrap();
        // ‖d‖ = 1, ‖ref‖ = 3; 6 channel values, one off by 1.
        assert!((m.relative_l2 - 1.0 / 3.0).abs() < 1e-12);
        assert!((m.rmse - (1.0f64 / 6.0).sqrt()).abs() < 1e-12);
        assert_eq!(m.max_abs, 1.0);
        assert!((m.psnr_db - 20.0 * (2.0 / (1.0f64 / 6.0).sqrt()).log10()).abs() < 1e-9);
        // Masking out the differing point leaves a perfect match.
        let m = compare(&test, &reference, Some(&[false, true])).unwrap();
        assert_eq!((m.points, m.rmse, m.psnr_db), (1, 0.0, f64::INFINITY));
        assert!(compare(&test, &reference[..1], None).is_err());
        assert!(compare(&test, &reference, Some(&[false, false])).is_err());
        assert!(compare(&[Vec3::NAN], &[Vec3::ONE], None).is_err());
    }

    #[test]
    fn false_colour_runs_dark_to_bright_and_legends_draw() {
        let mut last = -1.0;
        for k in 0..=100 {
            let l = luminance(false_colour(k as f32 / 100.0));
            assert!(l > last);
            last = l;
        }
        let (img, h) = with_legend(&vec![0u8; 64 * 32 * 3], 64, 32, 0.5);
        assert_eq!(h, 72);
        assert_eq!(img.len(), 64 * 72 * 3);
        // Label pixels were drawn in the strip.
        assert!(img[(64 * 56 * 3) as usize..].chunks(3).any(|p| p == [235, 235, 235]));
    }

    #[test]
    fn every_letter_and_digit_has_its_own_glyph() {
        let chars: Vec<char> = ('A'..='Z').chain('0'..='9').chain("=:%()/,_×".chars()).collect();
        for (i, a) in chars.iter().enumerate() {
            assert_ne!(glyph(*a), [0; 5], "{a} is blank");
            for b in &chars[i + 1..] {
                assert_ne!(glyph(*a), glyph(*b), "{a} and {b} look the same");
            }
        }
        assert_eq!(glyph('q'), glyph('Q'));
    }
}

//! The visible fraction of a rotatable square from one distance lookup (Xu et al. 2006,
//! §4.3, eq. 9, derived anew).
//!
//! A square of half-diagonal `r` (half-side `s = r/√2`) whose centre lies at signed distance
//! `d` from a straight visibility boundary (positive on the visible side) is cut by the
//! boundary. For a square rotated by `θ` relative to the boundary, a point `x` of the square is
//! visible when `n·x < d` (`n` the boundary's normal toward the invisible side), and `n·x` is
//! the sum of two independent uniform variables on `[−a, a]` and `[−b, b]`, `a = s|cos θ|`,
//! `b = s|sin θ|`. So the visible fraction is their sum's distribution function,
//!
//! `F_θ(d) = [H(d + a + b) − H(d + a − b)] / 4ab`, with `H(x) = ∫ clamp(x, 0, 2a)`:
//! `H = 0` for `x < 0`, `x²/2` on `[0, 2a]`, `2a² + 2a(x − 2a)` beyond,
//!
//! and an RSL, free to take any rotation, sees the average over `θ ∈ [0, π/2)`:
//! `C(d, r) = (2/π)∫ F_θ(d) dθ`. It depends on `t = d/r` alone, is `½` at `t = 0` (the paper's
//! printed `F = (√2r + D)/√2r` gives 1 there), `0` for `t ≤ −1`, `1` for `t ≥ 1`, and
//! `C(−t) = 1 − C(t)`. It is tabulated once over `t` and interpolated linearly.

use std::sync::OnceLock;

/// Samples of the table over `t ∈ [−1, 1]`.
pub const SAMPLES: usize = 1025;

/// A square of zero size: visible where `d > 0`, half at the boundary itself.
fn step(d: f64) -> f64 {
    if d > 0.0 {
        1.0
    } else if d < 0.0 {
        0.0
    } else {
        0.5
    }
}

/// `F_θ(d)` for half-widths `a ≥ 0`, `b ≥ 0` of the two uniform variables.
pub fn cut_fraction(d: f64, a: f64, b: f64) -> f64 {
    let (a, b) = if a >= b { (a, b) } else { (b, a) };
    if a <= 0.0 {
        return step(d);
    }
    if b <= 1e-12 * a {
        return ((d + a) / (2.0 * a)).clamp(0.0, 1.0);
    }
    let h = |x: f64| {
        if x <= 0.0 {
            0.0
        } else if x <= 2.0 * a {
            0.5 * x * x
        } else {
            2.0 * a * a + 2.0 * a * (x - 2.0 * a)
        }
    };
    ((h(d + a + b) - h(d + a - b)) / (4.0 * a * b)).clamp(0.0, 1.0)
}

/// The rotation-averaged visible fraction at `t = d/r`, computed by Gauss–Legendre
/// quadrature over `θ` (64 points on each of 4 sub-intervals: `F_θ` has kinks in `θ`).
pub fn coverage_exact(t: f64) -> f64 {
    if t <= -1.0 {
        return 0.0;
    }
    if t >= 1.0 {
        return 1.0;
    }
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let (nodes, weights) = gauss_legendre_64();
    let parts = 4;
    let width = std::f64::consts::FRAC_PI_2 / parts as f64;
    let mut acc = 0.0;
    for p in 0..parts {
        let mid = (p as f64 + 0.5) * width;
        for (x, w) in nodes.iter().zip(weights) {
            let theta = mid + 0.5 * width * x;
            acc += w * 0.5 * width * cut_fraction(t, s * theta.cos().abs(), s * theta.sin().abs());
        }
    }
    acc / std::f64::consts::FRAC_PI_2
}

/// 64-point Gauss–Legendre nodes and weights on `[−1, 1]` (Newton on Legendre polynomials).
fn gauss_legendre_64() -> &'static (Vec<f64>, Vec<f64>) {
    static GL: OnceLock<(Vec<f64>, Vec<f64>)> = OnceLock::new();
    GL.get_or_init(|| {
        let n = 64;
        let mut xs = Vec::with_capacity(n);
        let mut ws = Vec::with_capacity(n);
        for i in 0..n {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            xs.push(x);
            ws.push(2.0 / ((1.0 - x * x) * dp * dp));
        }
        (xs, ws)
    })
}

/// The tabulated `C(t)` at `t_k = −1 + 2k/(SAMPLES − 1)`, which [`coverage`] interpolates
/// linearly (the GPU path uploads the same values).
pub fn table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| {
        (0..SAMPLES).map(|k| coverage_exact(-1.0 + 2.0 * k as f64 / (SAMPLES - 1) as f64) as f32).collect()
    })
}

/// The visible fraction of a rotatable square of half-diagonal `r` whose centre lies at
/// signed distance `d` (plane units, positive where visible) from a straight boundary.
/// A square of zero size is visible exactly where `d > 0`.
#[inline]
pub fn coverage(d: f32, r: f32) -> f32 {
    if r.is_nan() || r <= 0.0 {
        return step(f64::from(d)) as f32;
    }
    let t = d / r;
    // NaN distances count as invisible.
    if t.is_nan() || t <= -1.0 {
        return 0.0;
    }
    if t >= 1.0 {
        return 1.0;
    }
    let x = (t + 1.0) * 0.5 * (SAMPLES - 1) as f32;
    // 0 < x < SAMPLES − 1 here; a 32-bit conversion is one instruction.
    let i = (x as u32 as usize).min(SAMPLES - 2);
    let f = x - i as f32;
    let tab = table();
    tab[i] * (1.0 - f) + tab[i + 1] * f
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        let (x, w) = gauss_legendre_64();
        let sum: f64 = w.iter().sum();
        assert!((sum - 2.0).abs() < 1e-13);
        let x8: f64 = x.iter().zip(w).map(|(x, w)| w * x.powi(8)).sum();
        assert!((x8 - 2.0 / 9.0).abs() < 1e-13);
    }

    #[test]
    fn symmetric_half_at_zero_and_saturating() {
        assert!((coverage(0.0, 0.3) - 0.5).abs() < 1e-6);
        for t in [0.1f32, 0.37, 0.8] {
            assert!((coverage(t, 1.0) + coverage(-t, 1.0) - 1.0).abs() < 1e-6);
        }
        assert_eq!(coverage(1.0, 1.0), 1.0);
        assert_eq!(coverage(-2.0, 1.0), 0.0);
        // Monotone in d.
        let mut last = 0.0;
        for k in 0..=200 {
            let c = coverage(-1.0 + k as f32 / 100.0, 1.0);
            assert!(c >= last - 1e-7);
            last = c;
        }
        assert_eq!(coverage(0.1, 0.0), 1.0);
        assert!(coverage(f32::NAN, 1.0) == 0.0);
    }

    #[test]
    fn cut_fraction_matches_counting_for_one_rotation() {
        // A square of half-side 1 rotated by θ, cut at distance d: count grid points.
        for &theta in &[0.0f64, 0.3, std::f64::consts::FRAC_PI_4, 1.2] {
            for &d in &[-1.2f64, -0.5, 0.0, 0.3, 0.9, 1.3] {
                let m = 800;
                let mut visible = 0usize;
                for i in 0..m {
                    for j in 0..m {
                        let (u, v) =
                            (-1.0 + (i as f64 + 0.5) * 2.0 / m as f64, -1.0 + (j as f64 + 0.5) * 2.0 / m as f64);
                        // n·x with n at angle θ to the square's axes.
                        if u * theta.cos() + v * theta.sin() < d {
                            visible += 1;
                        }
                    }
                }
                let want = visible as f64 / (m * m) as f64;
                let got = cut_fraction(d, theta.cos().abs(), theta.sin().abs());
                // Counting error is about the boundary's length in cells: 2√2/800.
                assert!((got - want).abs() < 4e-3, "θ={theta} d={d}: {got} vs {want}");
            }
        }
    }
}

//! The Lambertian term in closed form: `∫ cos⁺θ dω` over a box of the hemisphere plane.
//!
//! In the equal-area hemisphere plane (docs/conventions.md) a point `p` with `|p| ≤ 1` is the
//! direction with `cos θ = 1 − |p|²`, and `dω = 2 dA`. A box `[x0, x1]×[y0, y1]` of the plane
//! therefore collects
//!
//! `C = 2 ∫∫_{box ∩ disk} (1 − x² − y²) dx dy`,
//!
//! the parts outside the unit disk (below the horizon) adding nothing. A Lambertian BRDF of
//! albedo `a` has `∫ ρ cos θ dω = a·C/π` over the box — the quantity a table's diffuse slice
//! would interpolate, here exact at no build cost.
//!
//! Boxes inside the disk use the polynomial `Δx·Δy·(1 − (x0² + x0x1 + x1²)/3 − (y0² + y0y1 +
//! y1²)/3)`, which has no cancellation however small the box (a sun). Boxes crossing the rim
//! use the quadrant integral `Q(a, b) = ∫_0^a ∫_0^b (1 − x² − y²)⁺ dy dx` at the four corners
//! (odd in each coordinate); with `c = min(a, √(1 − b²))`,
//!
//! `Q = b(c − c³/3) − b³c/3 + ⅔ (H(a) − H(c))`,  `H(x) = ∫_0^x (1 − t²)^{3/2} dt
//! = 3 asin(x)/8 + x√(1 − x²)(5 − 2x²)/8`.

use glam::Vec2;

/// `∫ cos⁺θ dω` over the box `[p − s, p + s]²` of the hemisphere plane (`s ≥ 0`).
pub fn box_cosine(p: Vec2, s: f32) -> f64 {
    let s = f64::from(s.max(0.0));
    let (x0, x1) = (f64::from(p.x) - s, f64::from(p.x) + s);
    let (y0, y1) = (f64::from(p.y) - s, f64::from(p.y) + s);
    rect_cosine(x0, x1, y0, y1)
}

/// `∫ cos⁺θ dω` over the rectangle `[x0, x1]×[y0, y1]` of the hemisphere plane (`x0 ≤ x1`,
/// `y0 ≤ y1`).
pub fn rect_cosine(x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    if !(x0 <= x1 && y0 <= y1) {
        return 0.0;
    }
    // The point of the box nearest the origin, and the farthest.
    let near = |a: f64, b: f64| {
        if a > 0.0 {
            a
        } else if b < 0.0 {
            -b
        } else {
            0.0
        }
    };
    let (nx, ny) = (near(x0, x1), near(y0, y1));
    if nx * nx + ny * ny >= 1.0 {
        return 0.0;
    }
    let (fx, fy) = (x0.abs().max(x1.abs()), y0.abs().max(y1.abs()));
    let half = if fx * fx + fy * fy <= 1.0 {
        (x1 - x0) * (y1 - y0) * (1.0 - (x0 * x0 + x0 * x1 + x1 * x1) / 3.0 - (y0 * y0 + y0 * y1 + y1 * y1) / 3.0)
    } else {
        signed_quadrant(x1, y1) - signed_quadrant(x0, y1) - signed_quadrant(x1, y0) + signed_quadrant(x0, y0)
    };
    2.0 * half.max(0.0)
}

/// `∫_0^x ∫_0^y (1 − u² − v²)⁺ dv du` with signs (odd in `x` and in `y`).
fn signed_quadrant(x: f64, y: f64) -> f64 {
    let q = quadrant(x.abs().min(1.0), y.abs().min(1.0));
    if (x < 0.0) != (y < 0.0) { -q } else { q }
}

/// `Q(a, b)` for `a, b ∈ [0, 1]` (module docs).
fn quadrant(a: f64, b: f64) -> f64 {
    let c = a.min(((1.0 - b) * (1.0 + b)).max(0.0).sqrt());
    // Where the rim does not cut the column range (c = a), H(a) − H(c) vanishes: most
    // corners of a box are inside the disk or beyond x = 1, and need no arctangent.
    let rim = if c < a { h(a) - h(c) } else { 0.0 };
    b * (c - c * c * c / 3.0) - b * b * b * c / 3.0 + 2.0 / 3.0 * rim
}

/// `∫_0^x (1 − t²)^{3/2} dt` for `x ∈ [0, 1]`, as `3 asin(x)/8 + x√(1 − x²)(5 − 2x²)/8` with
/// `√(1 − x²)` formed as `√((1 − x)(1 + x))` and asin as atan2, which keep their precision next
/// to the rim (the shader's f32 copy needs it; the terms' derivatives cancel there).
fn h(x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 3.0 * std::f64::consts::PI / 16.0;
    }
    let r = ((1.0 - x) * (1.0 + x)).max(0.0).sqrt();
    3.0 * x.atan2(r) / 8.0 + x * r * (5.0 - 2.0 * x * x) / 8.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// `2 ∫∫ (1 − x² − y²)⁺` over the rectangle by a midpoint rule on a fine grid.
    fn brute(x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
        let m = 1500;
        let (dx, dy) = ((x1 - x0) / m as f64, (y1 - y0) / m as f64);
        let mut sum = 0.0;
        for j in 0..m {
            let y = y0 + (j as f64 + 0.5) * dy;
            for i in 0..m {
                let x = x0 + (i as f64 + 0.5) * dx;
                sum += (1.0 - x * x - y * y).max(0.0);
            }
        }
        2.0 * sum * dx * dy
    }

    #[test]
    fn whole_plane_is_pi_and_quarters_are_equal() {
        assert!((rect_cosine(-1.0, 1.0, -1.0, 1.0) - PI).abs() < 1e-14);
        assert!((rect_cosine(-5.0, 5.0, -5.0, 5.0) - PI).abs() < 1e-14);
        assert!((rect_cosine(0.0, 1.0, 0.0, 1.0) - PI / 4.0).abs() < 1e-14);
        assert!((rect_cosine(-1.0, 0.0, 0.0, 1.0) - PI / 4.0).abs() < 1e-14);
        // The upper half: half the disk.
        assert!((rect_cosine(-2.0, 2.0, 0.0, 2.0) - PI / 2.0).abs() < 1e-14);
    }

    #[test]
    fn matches_brute_force_inside_across_and_outside_the_rim() {
        let boxes = [
            (-0.3, 0.2, 0.1, 0.4),   // inside
            (0.5, 1.2, -0.4, 0.3),   // across the rim
            (-1.3, -0.6, 0.5, 0.95), // across, one corner inside
            (0.7, 0.9, 0.7, 0.9),    // across, near the diagonal
            (-0.2, 0.1, 0.9, 1.4),   // across the top
            (1.01, 1.3, -0.1, 0.1),  // outside
        ];
        for (x0, x1, y0, y1) in boxes {
            let (got, want) = (rect_cosine(x0, x1, y0, y1), brute(x0, x1, y0, y1));
            // The midpoint rule errs by O(h²) inside and O(h^{3/2}) at the rim.
            assert!((got - want).abs() < 2e-6, "[{x0}, {x1}]×[{y0}, {y1}]: {got} against {want}");
        }
    }

    #[test]
    fn a_sun_sized_box_keeps_its_relative_precision() {
        // A box 10⁻⁴ across at θ = 60°: cos θ·area·2 to first order.
        let p = Vec2::new(0.5f32.sqrt(), 0.0);
        let s = 5e-5f32;
        let got = box_cosine(p, s);
        let cos = 1.0 - f64::from(p.x) * f64::from(p.x);
        let want = 2.0 * cos * (2.0 * f64::from(s)).powi(2);
        assert!((got / want - 1.0).abs() < 1e-6, "{got} against {want}");
    }

    #[test]
    fn the_rim_formula_agrees_with_the_polynomial_where_both_apply() {
        // A box whose far corner touches the rim from inside, and one just past it.
        let r = 0.5f64.sqrt();
        let inside = rect_cosine(0.2, r - 1e-9, 0.2, r - 1e-9);
        let across = rect_cosine(0.2, r + 1e-9, 0.2, r + 1e-9);
        assert!((inside - across).abs() < 1e-8, "{inside} against {across}");
        let q = 2.0
            * (signed_quadrant(0.6, 0.5) - signed_quadrant(0.1, 0.5) - signed_quadrant(0.6, -0.2)
                + signed_quadrant(0.1, -0.2));
        assert!((q - rect_cosine(0.1, 0.6, -0.2, 0.5)).abs() < 1e-14);
    }
}

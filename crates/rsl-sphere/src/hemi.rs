//! The equal-area hemisphere map of Xu et al. 2006 (§5) and the `N×N` table grid over it.
//!
//! For a unit direction `ω = (x, y, z)` in a local frame with the normal along +z,
//! `p = (x, y)/√(1 + z)`: Lambert's azimuthal equal-area projection. `|p|² = 1 − cos θ`,
//! so the upper hemisphere fills the unit disk, the lower hemisphere the ring
//! `1 < |p| ≤ √2`, and a region's plane area is half its solid angle.
//! The square `[−1, 1]²` lies inside the disk of radius `√2`, so every point of the grid
//! maps to a direction.

use glam::{Vec2, Vec3};

/// Largest radius of the map: the south pole (θ = π) becomes the circle `|p| = √2`.
pub const MAX_RADIUS: f32 = std::f32::consts::SQRT_2;

/// Hemisphere-plane point of a unit local direction (the normal is +z).
///
/// Stable everywhere: for the lower hemisphere it uses the equivalent
/// `(x, y)/|(x, y)| · √(1 − z)`, which avoids the cancellation in `1 + z` near the south
/// pole. The south pole itself maps to `(√2, 0)`.
#[inline]
pub fn hemi_from_dir(d: Vec3) -> Vec2 {
    let xy = Vec2::new(d.x, d.y);
    if d.z >= 0.0 {
        xy / (1.0 + d.z).sqrt()
    } else {
        let r = xy.length();
        if r > 0.0 { xy * ((1.0 - d.z).max(0.0).sqrt() / r) } else { Vec2::new(MAX_RADIUS, 0.0) }
    }
}

/// Unit local direction of a hemisphere-plane point (inverse of [`hemi_from_dir`]).
///
/// Near the south pole the inverse is ill-conditioned: `d|p|/dθ = cos(θ/2)/√2 → 0`, so an
/// error `ε` in `p` becomes a direction error of about `√2·ε / cos(θ/2)`. Tables only use the
/// ring `|p| ≤ √2` as far as the grid's corners, where `cos(θ/2) ≥ 0`; below-horizon cells
/// contribute nothing to shading anyway.
///
/// `z = 1 − |p|²` and `(x, y) = p·√(2 − |p|²)`. Points beyond `|p| = √2` are clamped to
/// that circle (the south pole).
#[inline]
pub fn dir_from_hemi(p: Vec2) -> Vec3 {
    let r2 = p.length_squared().min(2.0);
    let s = (2.0 - r2).max(0.0).sqrt();
    Vec3::new(p.x * s, p.y * s, 1.0 - r2).normalize_or(Vec3::NEG_Z)
}

/// Whether a grid cell lies above the horizon (inside the unit disk).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Horizon {
    /// The whole cell is inside the unit disk.
    Above,
    /// The unit circle crosses the cell.
    Crossing,
    /// The whole cell is outside the unit disk.
    Below,
}

/// The `N×N` grid over `[−1, 1]²` on which BRDF, visibility and distance tables live.
///
/// Cell `(i, j)` spans `x ∈ [−1 + i·h, −1 + (i+1)·h]`, `y ∈ [−1 + j·h, −1 + (j+1)·h]` with
/// `h = 2/N`; its flat index is `j·N + i`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct HemiGrid {
    n: usize,
}

impl HemiGrid {
    /// A grid of `n×n` cells; `n` must be at least 1.
    pub fn new(n: usize) -> Self {
        assert!(n >= 1, "a hemisphere grid needs at least one cell");
        Self { n }
    }

    /// Cells per side.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Total number of cells, `N²`.
    pub fn len(&self) -> usize {
        self.n * self.n
    }

    /// Always false: a grid has at least one cell.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Side length of a cell in the plane, `2/N`.
    pub fn cell_size(&self) -> f32 {
        2.0 / self.n as f32
    }

    /// Flat index of cell `(i, j)`.
    #[inline]
    pub fn index(&self, i: usize, j: usize) -> usize {
        j * self.n + i
    }

    /// The cell containing plane point `p`, or `None` outside `[−1, 1]²`. Points on the
    /// upper edge belong to the last cell.
    pub fn cell_of(&self, p: Vec2) -> Option<(usize, usize)> {
        let f = |c: f32| -> Option<usize> {
            if !(-1.0..=1.0).contains(&c) {
                return None;
            }
            Some((((c + 1.0) * 0.5 * self.n as f32) as usize).min(self.n - 1))
        };
        Some((f(p.x)?, f(p.y)?))
    }

    /// Plane rectangle `[x0, y0, x1, y1]` of a cell, in f64.
    pub fn cell_rect(&self, i: usize, j: usize) -> [f64; 4] {
        let h = 2.0 / self.n as f64;
        [-1.0 + i as f64 * h, -1.0 + j as f64 * h, -1.0 + (i + 1) as f64 * h, -1.0 + (j + 1) as f64 * h]
    }

    /// Plane point at the centre of a cell.
    pub fn cell_centre(&self, i: usize, j: usize) -> Vec2 {
        let h = 2.0 / self.n as f32;
        Vec2::new(-1.0 + (i as f32 + 0.5) * h, -1.0 + (j as f32 + 0.5) * h)
    }

    /// Local direction through the centre of a cell.
    pub fn cell_dir(&self, i: usize, j: usize) -> Vec3 {
        dir_from_hemi(self.cell_centre(i, j))
    }

    /// Solid angle of the whole cell (both hemispheres), `2·(2/N)²` steradians.
    pub fn cell_solid_angle(&self, _i: usize, _j: usize) -> f64 {
        let h = 2.0 / self.n as f64;
        2.0 * h * h
    }

    /// Exact solid angle of the part of the cell above the horizon (inside the unit disk):
    /// twice the area of the cell ∩ unit disk, in closed form.
    pub fn cell_solid_angle_above(&self, i: usize, j: usize) -> f64 {
        match self.horizon(i, j) {
            Horizon::Above => self.cell_solid_angle(i, j),
            Horizon::Below => 0.0,
            Horizon::Crossing => {
                let [x0, y0, x1, y1] = self.cell_rect(i, j);
                2.0 * disk_rect_area(x0, y0, x1, y1)
            }
        }
    }

    /// Where a cell lies relative to the horizon.
    pub fn horizon(&self, i: usize, j: usize) -> Horizon {
        let [x0, y0, x1, y1] = self.cell_rect(i, j);
        let near = |a: f64, b: f64| if a <= 0.0 && b >= 0.0 { 0.0 } else { a.abs().min(b.abs()) };
        let far = |a: f64, b: f64| a.abs().max(b.abs());
        let rmin2 = near(x0, x1).powi(2) + near(y0, y1).powi(2);
        let rmax2 = far(x0, x1).powi(2) + far(y0, y1).powi(2);
        if rmax2 <= 1.0 {
            Horizon::Above
        } else if rmin2 >= 1.0 {
            Horizon::Below
        } else {
            Horizon::Crossing
        }
    }
}

/// Area of `[0, x] × [0, y] ∩ unit disk` for `x, y ≥ 0`.
fn quadrant_area(x: f64, y: f64) -> f64 {
    let (x, y) = (x.min(1.0), y.min(1.0));
    // Up to X = a the disk's boundary is above Y = y.
    let a = (1.0 - y * y).max(0.0).sqrt();
    if a >= x {
        return x * y;
    }
    let prim = |t: f64| 0.5 * (t * (1.0 - t * t).max(0.0).sqrt() + t.asin());
    y * a + prim(x) - prim(a)
}

/// Exact area of the rectangle `[x0, x1] × [y0, y1]` intersected with the unit disk.
pub fn disk_rect_area(x0: f64, y0: f64, x1: f64, y1: f64) -> f64 {
    // Signed corner function: G(x, y) = area of the disk between the axes and (x, y).
    let g = |x: f64, y: f64| x.signum() * y.signum() * quadrant_area(x.abs(), y.abs());
    (g(x1, y1) - g(x0, y1) - g(x1, y0) + g(x0, y0)).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::approx::assert_close;
    use crate::sampling::{Pcg32, uniform_sphere};
    use std::f64::consts::PI;

    #[test]
    fn map_and_inverse_round_trip_on_both_hemispheres() {
        let mut rng = Pcg32::new(1);
        for _ in 0..100_000 {
            let d = uniform_sphere(rng.next_2d());
            let p = hemi_from_dir(d);
            assert!(p.length() <= MAX_RADIUS + 1e-6);
            let back = dir_from_hemi(p);
            // f32 rounding of p (≈1e-7) amplified by the map's conditioning √2/cos(θ/2).
            let cond = ((1.0 + d.z) / 2.0).max(0.0).sqrt().max(1e-3);
            assert!((back - d).length() < 2e-6 / cond + 1e-6, "{d:?} -> {p:?} -> {back:?}");
            // Equal-area radius: |p|² = 1 − cos θ.
            assert!((p.length_squared() - (1.0 - d.z)).abs() < 1e-5);
        }
        for i in 0..=200 {
            for j in 0..=200 {
                let p = Vec2::new(-1.0 + i as f32 / 100.0, -1.0 + j as f32 / 100.0);
                // The circle |p| = √2 (the grid's corners) is all one direction, the south
                // pole, so the map cannot be inverted there.
                if p.length_squared() > 1.99 {
                    continue;
                }
                let q = hemi_from_dir(dir_from_hemi(p));
                assert!((p - q).length() < 1e-4, "{p:?} -> {q:?}");
            }
        }
        assert_eq!(hemi_from_dir(Vec3::Z), Vec2::ZERO);
        assert_eq!(hemi_from_dir(Vec3::NEG_Z), Vec2::new(MAX_RADIUS, 0.0));
        assert!((hemi_from_dir(Vec3::X) - Vec2::X).length() < 1e-7);
        assert!((dir_from_hemi(Vec2::new(5.0, 0.0)) - Vec3::NEG_Z).length() < 1e-3);
    }

    #[test]
    fn cell_solid_angles_over_the_unit_disk_sum_to_2pi() {
        for n in [1, 2, 3, 7, 16, 32, 64, 128] {
            let g = HemiGrid::new(n);
            let mut above = 0.0;
            let mut whole = 0.0;
            for j in 0..n {
                for i in 0..n {
                    above += g.cell_solid_angle_above(i, j);
                    whole += g.cell_solid_angle(i, j);
                    let h = g.horizon(i, j);
                    let full = g.cell_solid_angle(i, j);
                    let part = g.cell_solid_angle_above(i, j);
                    match h {
                        Horizon::Above => assert_close("above cell", part, full, 1e-12, 1e-300),
                        Horizon::Below => assert_eq!(part, 0.0),
                        Horizon::Crossing => assert!(part >= 0.0 && part <= full),
                    }
                }
            }
            assert_close(&format!("N={n} disk"), above, 2.0 * PI, 1e-9, 0.0);
            assert_close(&format!("N={n} square"), whole, 8.0, 1e-12, 0.0);
        }
    }

    #[test]
    fn disk_rect_area_matches_brute_force() {
        let rects = [[-0.3, 0.2, 0.9, 0.95], [0.5, 0.5, 1.0, 1.0], [-1.0, -1.0, -0.2, 0.1], [0.0, 0.0, 2.0, 2.0]];
        for [x0, y0, x1, y1] in rects {
            let m = 2000;
            let mut inside = 0usize;
            for a in 0..m {
                for b in 0..m {
                    let x = x0 + (x1 - x0) * (a as f64 + 0.5) / m as f64;
                    let y = y0 + (y1 - y0) * (b as f64 + 0.5) / m as f64;
                    inside += usize::from(x * x + y * y <= 1.0);
                }
            }
            let brute = inside as f64 / (m * m) as f64 * (x1 - x0) * (y1 - y0);
            // Midpoint counting error is about perimeter·h ≈ 1e-3 of the area.
            assert_close("rect ∩ disk", disk_rect_area(x0, y0, x1, y1), brute, 2e-3, 1e-3);
        }
        assert_close("quarter", disk_rect_area(0.0, 0.0, 1.0, 1.0), PI / 4.0, 1e-14, 0.0);
    }

    #[test]
    fn cell_lookup_and_centres_agree() {
        let g = HemiGrid::new(32);
        for j in 0..32 {
            for i in 0..32 {
                assert_eq!(g.cell_of(g.cell_centre(i, j)), Some((i, j)));
            }
        }
        assert_eq!(g.cell_of(Vec2::new(1.0, 1.0)), Some((31, 31)));
        assert_eq!(g.cell_of(Vec2::new(-1.0, -1.0)), Some((0, 0)));
        assert_eq!(g.cell_of(Vec2::new(1.01, 0.0)), None);
        assert_eq!(g.cell_of(Vec2::new(f32::NAN, 0.0)), None);
        // The centre cell of an even grid touches the pole, a corner cell is below.
        assert_eq!(g.horizon(16, 16), Horizon::Above);
        assert_eq!(g.horizon(0, 0), Horizon::Below);
        assert_eq!(g.horizon(0, 16), Horizon::Crossing);
        assert!(g.cell_dir(16, 16).z > 0.99);
    }
}

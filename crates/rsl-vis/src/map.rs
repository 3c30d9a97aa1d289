//! Visibility maps on the hemisphere grid, their distance tables and summed-area tables.

use crate::coverage::coverage;
use crate::edt::signed_distance;
use crate::rays::Occluder;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use rsl_sphere::Frame;
use rsl_sphere::hemi::{HemiGrid, dir_from_hemi};

/// Visible fraction of each cell of the `N×N` hemisphere grid around a point (row-major,
/// `[j·N + i]`), and the `s×s` sub-samples per cell they came from. Directions below the
/// horizon count as invisible.
#[derive(Clone, Debug, PartialEq)]
pub struct VisibilityMap {
    n: usize,
    s: usize,
    visible: Vec<f32>,
    /// `(N·s)²` sub-samples, row-major on the fine grid.
    fine: Vec<bool>,
}

impl VisibilityMap {
    /// A map from a visibility predicate on local directions (normal +z), with `s×s`
    /// sub-samples per cell (cell-centred, equal plane area): each cell's value is the
    /// fraction of its samples above the horizon that are visible.
    pub fn from_fn(n: usize, s: usize, visible: impl Fn(Vec3) -> bool + Sync) -> Self {
        Self::from_fn_with_horizon(n, s, false, visible)
    }

    /// As [`VisibilityMap::from_fn`]; with `below_visible`, directions below the horizon count
    /// as visible (an occluder field: nothing behind the sample's hemisphere is blocked by
    /// the object it faces) and are evaluated by `visible` too when they fall in the grid.
    pub fn from_fn_with_horizon(
        n: usize,
        s: usize,
        below_visible: bool,
        visible: impl Fn(Vec3) -> bool + Sync,
    ) -> Self {
        let grid = HemiGrid::new(n);
        let s = s.max(1);
        let h = 2.0 / n as f32;
        let m = n * s;
        // Fine sub-samples, row by row in parallel; points below the horizon are invisible.
        // Large chunks: callers usually run many maps in parallel already.
        let fine: Vec<bool> = (0..m * m)
            .into_par_iter()
            .with_min_len(1024)
            .map(|k| {
                let p =
                    Vec2::new(-1.0 + (2 * (k % m) + 1) as f32 / m as f32, -1.0 + (2 * (k / m) + 1) as f32 / m as f32);
                if p.length_squared() < 1.0 { visible(dir_from_hemi(p)) } else { below_visible }
            })
            .collect();
        let mut cells = vec![0.0f32; n * n];
        for (j, row) in cells.chunks_mut(n).enumerate() {
            for (i, c) in row.iter_mut().enumerate() {
                let [x0, y0, ..] = grid.cell_rect(i, j);
                let (mut seen, mut total) = (0usize, 0usize);
                for b in 0..s {
                    for a in 0..s {
                        let p = Vec2::new(
                            x0 as f32 + h * (a as f32 + 0.5) / s as f32,
                            y0 as f32 + h * (b as f32 + 0.5) / s as f32,
                        );
                        if p.length_squared() >= 1.0 && !below_visible {
                            continue;
                        }
                        total += 1;
                        seen += usize::from(fine[(j * s + b) * m + i * s + a]);
                    }
                }
                *c = if total == 0 { 0.0 } else { seen as f32 / total as f32 };
            }
        }
        Self { n, s, visible: cells, fine }
    }

    /// The visibility map at `origin` in `frame` against `occluder`: shadow rays from the
    /// point lifted by `offset` along the normal (to avoid hitting its own surface), up to
    /// `tmax`.
    pub fn trace(occluder: &Occluder, origin: Vec3, frame: &Frame, offset: f32, tmax: f32, n: usize, s: usize) -> Self {
        let o = origin + frame.n * offset;
        Self::from_fn(n, s, |d| !occluder.occluded(o, frame.to_world(d), tmax))
    }

    /// Whether every sub-sample above the horizon is visible (nothing occludes this point).
    pub fn fully_visible(&self) -> bool {
        let m = self.n * self.s;
        self.fine.iter().enumerate().all(|(k, &v)| {
            let p = Vec2::new(-1.0 + (2 * (k % m) + 1) as f32 / m as f32, -1.0 + (2 * (k / m) + 1) as f32 / m as f32);
            v || p.length_squared() >= 1.0
        })
    }

    /// Cells per side.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Visible fractions, row-major.
    pub fn values(&self) -> &[f32] {
        &self.visible
    }

    /// The signed visibility distance table. The distance transform runs on the fine
    /// sub-sample grid (so the boundary is placed to within about a third of a sub-sample,
    /// not of a cell), and is then read at the cell centres.
    pub fn vdt(&self) -> Vdt {
        // Beyond the grid's diagonal no square needs a larger distance.
        let limit = 2.0 * std::f32::consts::SQRT_2;
        let (n, s) = (self.n, self.s);
        let m = n * s;
        let fine: Vec<f32> = self.fine.iter().map(|&v| if v { 1.0 } else { 0.0 }).collect();
        let fd = signed_distance(m, &fine, limit);
        // A cell centre lies at fine coordinate i·s + s/2: on a sample for odd s, between the
        // middle two for even s (average them).
        let taps: &[usize] = if s % 2 == 1 { &[0] } else { &[0, 1] };
        let first = |i: usize| i * s + s / 2 - if s % 2 == 1 { 0 } else { 1 };
        let mut d = vec![0.0f32; n * n];
        for j in 0..n {
            for i in 0..n {
                let mut acc = 0.0;
                for &b in taps {
                    for &a in taps {
                        acc += fd[(first(j) + b) * m + first(i) + a];
                    }
                }
                d[j * n + i] = acc / (taps.len() * taps.len()) as f32;
            }
        }
        Vdt { n, d }
    }

    /// Summed-area table of the visible fractions, for exact box averages.
    pub fn sat(&self) -> VisSat {
        let n = self.n;
        let mut sat = vec![0.0f64; (n + 1) * (n + 1)];
        for j in 0..n {
            let mut row = 0.0;
            for i in 0..n {
                row += f64::from(self.visible[j * n + i]);
                sat[(j + 1) * (n + 1) + i + 1] = sat[j * (n + 1) + i + 1] + row;
            }
        }
        VisSat { n, sat }
    }
}

/// A visibility distance table: per cell centre, the signed distance (plane units) to the
/// visibility boundary, positive where visible.
#[derive(Clone, Debug, PartialEq)]
pub struct Vdt {
    n: usize,
    d: Vec<f32>,
}

impl Vdt {
    /// Distances, row-major.
    pub fn values(&self) -> &[f32] {
        &self.d
    }

    /// The distance at plane point `p`, bilinear between cell centres (clamped at the edges).
    pub fn lookup(&self, p: Vec2) -> f32 {
        let n = self.n;
        let g = |c: f32| ((c + 1.0) * 0.5 * n as f32 - 0.5).clamp(0.0, (n - 1) as f32);
        let (x, y) = (g(p.x), g(p.y));
        let (i, j) = ((x as usize).min(n.saturating_sub(2)), (y as usize).min(n.saturating_sub(2)));
        if n == 1 {
            return self.d[0];
        }
        let (fx, fy) = (x - i as f32, y - j as f32);
        let at = |a: usize, b: usize| self.d[b * n + a];
        (at(i, j) * (1.0 - fx) + at(i + 1, j) * fx) * (1.0 - fy)
            + (at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx) * fy
    }

    /// The visible fraction of the rotatable square of half-diagonal `r` centred at `p`: one
    /// lookup and the coverage function.
    pub fn coverage(&self, p: Vec2, r: f32) -> f32 {
        coverage(self.lookup(p), r)
    }
}

/// The cell `(i, j)` below and left of plane point `p` among the centres of an `n×n` grid
/// (`n ≥ 2`, clamped at the edges), and `p`'s fractions `(fx, fy)` toward `(i + 1, j + 1)`.
#[inline(always)]
fn bilinear_corner(n: usize, p: Vec2) -> (usize, usize, f32, f32) {
    let g = |c: f32| ((c + 1.0) * 0.5 * n as f32 - 0.5).clamp(0.0, (n - 1) as f32);
    let (x, y) = (g(p.x), g(p.y));
    let (i, j) = ((x as usize).min(n - 2), (y as usize).min(n - 2));
    (i, j, x - i as f32, y - j as f32)
}

/// Bilinear interpolation at plane point `p` between the centres of an `n×n` grid's cells
/// (clamped at the edges), reading only the four cells it needs through `at(flat index)`.
#[inline(always)]
pub(crate) fn bilinear_cells(n: usize, p: Vec2, at: impl Fn(usize) -> f32) -> f32 {
    if n == 1 {
        return at(0);
    }
    let (i, j, fx, fy) = bilinear_corner(n, p);
    let v = |a: usize, b: usize| at(b * n + a);
    (v(i, j) * (1.0 - fx) + v(i + 1, j) * fx) * (1.0 - fy) + (v(i, j + 1) * (1.0 - fx) + v(i + 1, j + 1) * fx) * fy
}

/// The four cells and weights of [`bilinear_cells`] at `p` (an `n = 1` grid gives its one
/// cell with weight 1).
#[inline(always)]
pub(crate) fn bilinear_taps(n: usize, p: Vec2) -> ([usize; 4], [f32; 4]) {
    if n == 1 {
        return ([0; 4], [1.0, 0.0, 0.0, 0.0]);
    }
    let (i, j, fx, fy) = bilinear_corner(n, p);
    (
        [j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1],
        [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy],
    )
}

/// Summed-area table of a visibility map: the exact average over any axis-aligned box (cells
/// taken as uniform), four lookups.
#[derive(Clone, Debug, PartialEq)]
pub struct VisSat {
    n: usize,
    sat: Vec<f64>,
}

impl VisSat {
    fn prefix(&self, x: f32, y: f32) -> f64 {
        let n = self.n;
        let g = |c: f32| (f64::from(c) + 1.0) * 0.5 * n as f64;
        let (gx, gy) = (g(x).clamp(0.0, n as f64), g(y).clamp(0.0, n as f64));
        let (i, j) = ((gx as usize).min(n - 1), (gy as usize).min(n - 1));
        let (fx, fy) = (gx - i as f64, gy - j as f64);
        let at = |a: usize, b: usize| self.sat[b * (n + 1) + a];
        (at(i, j) * (1.0 - fx) + at(i + 1, j) * fx) * (1.0 - fy)
            + (at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx) * fy
    }

    /// The value of the cell containing `p` (clamped to the grid).
    fn cell_value(&self, p: Vec2) -> f32 {
        let n = self.n;
        let g = |c: f32| (((c + 1.0) * 0.5 * n as f32).max(0.0) as usize).min(n - 1);
        let (i, j) = (g(p.x), g(p.y));
        let at = |a: usize, b: usize| self.sat[b * (n + 1) + a];
        (at(i + 1, j + 1) - at(i, j + 1) - at(i + 1, j) + at(i, j)) as f32
    }

    /// The visible fraction of the square of half-diagonal `r` centred at `p` (the part outside
    /// the grid counts as invisible; a square of zero size takes its cell's value).
    pub fn coverage(&self, p: Vec2, r: f32) -> f32 {
        let s = r / std::f32::consts::SQRT_2;
        if s.is_nan() || s <= 0.0 {
            return self.cell_value(p);
        }
        let (x0, x1, y0, y1) = (p.x - s, p.x + s, p.y - s, p.y + s);
        let sum = self.prefix(x1, y1) - self.prefix(x0, y1) - self.prefix(x1, y0) + self.prefix(x0, y0);
        let cell = 2.0 / self.n as f64;
        (sum * cell * cell / (4.0 * f64::from(s) * f64::from(s))).clamp(0.0, 1.0) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sat_is_exact_for_cell_aligned_boxes() {
        // A map whose cells are constant (one sub-sample each): any box on cell boundaries
        // averages exactly the cells inside it.
        let n = 16;
        let mut rng = rsl_sphere::sampling::Pcg32::new(4);
        let vis: Vec<bool> = (0..n * n).map(|_| rng.next_f32() < 0.5).collect();
        let grid = HemiGrid::new(n);
        let map = VisibilityMap::from_fn(n, 1, |d| {
            let p = rsl_sphere::hemi::hemi_from_dir(d);
            let (i, j) = grid.cell_of(p).unwrap_or((0, 0));
            vis[j * n + i]
        });
        let sat = map.sat();
        let cell = 2.0 / n as f32;
        for (i0, j0, k) in [(5usize, 6usize, 2usize), (7, 7, 3), (6, 4, 4)] {
            let centre =
                Vec2::new(-1.0 + (i0 as f32 + k as f32 / 2.0) * cell, -1.0 + (j0 as f32 + k as f32 / 2.0) * cell);
            let want: f32 = (j0..j0 + k)
                .flat_map(|j| (i0..i0 + k).map(move |i| (i, j)))
                .map(|(i, j)| map.values()[j * n + i])
                .sum::<f32>()
                / (k * k) as f32;
            let got = sat.coverage(centre, k as f32 * cell / 2.0 * std::f32::consts::SQRT_2);
            assert!((got - want).abs() < 1e-5, "box at ({i0}, {j0}) × {k}: {got} vs {want}");
        }
    }
}

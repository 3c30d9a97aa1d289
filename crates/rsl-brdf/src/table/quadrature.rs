//! How a BRDF table's cells are integrated: a 2×2 Gauss–Legendre rule per cell, refined
//! recursively where a lobe narrower than the cell peaks (the module docs of [`super`]), and
//! the slices' summed-area tables.

use super::MAX_DEPTH;
use crate::model::Brdf;
use glam::{Vec2, Vec3};
use rsl_sphere::hemi::{HemiGrid, dir_from_hemi};
use std::sync::{Arc, Mutex};

/// The regular 2×2 Gauss–Legendre points of every cell (directions and which are above the
/// horizon), shared by all the view slices of a build.
pub(super) struct QuadraturePoints {
    dirs: Vec<[Vec3; 4]>,
    inside: Vec<[bool; 4]>,
    centres: Vec<Vec3>,
    /// Per cell: 1 / its solid angle above the horizon, or 0 for a cell wholly below it.
    inv_omega: Vec<f32>,
}

/// The 2×2 Gauss–Legendre points of the plane square `[x0, x0 + side] × [y0, y0 + side]`.
fn gauss_points(x0: f64, y0: f64, side: f64) -> [Vec2; 4] {
    let (lo, hi) = (0.5 - 0.5 / 3f64.sqrt(), 0.5 + 0.5 / 3f64.sqrt());
    [(lo, lo), (hi, lo), (lo, hi), (hi, hi)].map(|(a, b)| Vec2::new((x0 + a * side) as f32, (y0 + b * side) as f32))
}

/// The 2×2 Gauss–Legendre rule over a square of side `side` (exact for bicubic integrands,
/// the same four evaluations as a midpoint rule but fourth-order accurate): each point
/// carries a quarter of the square's solid angle `2·side²`; points below the horizon add
/// nothing.
fn gauss_sum(brdf: &Brdf, wo: Vec3, side: f64, points: impl Iterator<Item = (Vec3, bool)>) -> [f64; 3] {
    let weight = 0.5 * side * side;
    let mut sum = [0.0; 3];
    for (d, inside) in points {
        if inside {
            let v = brdf.eval_cos(d, wo);
            for c in 0..3 {
                sum[c] += f64::from(v[c]) * weight;
            }
        }
    }
    sum
}

impl QuadraturePoints {
    fn new(grid: &HemiGrid) -> Self {
        let n = grid.n();
        let h = 2.0 / n as f64;
        let mut dirs = Vec::with_capacity(n * n);
        let mut inside = Vec::with_capacity(n * n);
        let mut centres = Vec::with_capacity(n * n);
        let mut inv_omega = Vec::with_capacity(n * n);
        for j in 0..n {
            for i in 0..n {
                let omega = grid.cell_solid_angle_above(i, j);
                inv_omega.push(if omega > 0.0 { (1.0 / omega) as f32 } else { 0.0 });
                let [x0, y0, ..] = grid.cell_rect(i, j);
                centres.push(dir_from_hemi(Vec2::new((x0 + 0.5 * h) as f32, (y0 + 0.5 * h) as f32)));
                let pts = gauss_points(x0, y0, h);
                inside.push(pts.map(|p| p.length_squared() < 1.0));
                dirs.push(pts.map(dir_from_hemi));
            }
        }
        Self { dirs, inside, centres, inv_omega }
    }

    /// The points of an `N×N` grid, built once per `N` and kept (a few MB at N = 128; a
    /// material edit rebuilds its table at the same `N`).
    pub(super) fn of(grid: &HemiGrid) -> Arc<Self> {
        static BUILT: Mutex<Vec<(usize, Arc<QuadraturePoints>)>> = Mutex::new(Vec::new());
        let n = grid.n();
        let mut built = BUILT.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, p)) = built.iter().find(|(m, _)| *m == n) {
            return p.clone();
        }
        let p = Arc::new(Self::new(grid));
        // The few resolutions in use (auto picks powers of two from 32 to 128).
        if built.len() >= 4 {
            built.remove(0);
        }
        built.push((n, p.clone()));
        p
    }
}

/// One view slice's cell integrals (row-major `N×N`) and its largest cell density. With
/// `mirror_y` (isotropic BRDFs, view in the xz-plane) the slice is symmetric in y: only the
/// upper half of the rows is integrated and the rest copied.
fn slice(
    brdf: &Brdf,
    grid: &HemiGrid,
    points: &QuadraturePoints,
    wo: Vec3,
    mirror_y: bool,
    cells: &mut [[f64; 3]],
) -> Vec3 {
    let n = grid.n();
    let h = 2.0 / n as f64;
    let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
    let width = brdf.lobe_width().map(f64::from);
    cells.fill([0.0; 3]);
    let mut max_density = Vec3::ZERO;
    let first_row = if mirror_y { n / 2 } else { 0 };
    // Whole cells need refining only when wider than half the lobe; then only those whose
    // centre is within 3w + 2h of the peak (the test of `refine`, as a cosine).
    let near_cos =
        width.filter(|&w| 2.0 * h > 0.5 * w).map(|w| (3.0 * w + 2.0 * h).min(std::f64::consts::PI).cos() as f32);
    for j in first_row..n {
        for i in 0..n {
            let k = j * n + i;
            let inv_omega = points.inv_omega[k];
            if inv_omega == 0.0 {
                // Wholly below the horizon.
                continue;
            }
            let near = near_cos.is_some_and(|c| points.centres[k].dot(mirror) > c);
            let e = if near && refine(width, mirror, -1.0 + i as f64 * h, -1.0 + j as f64 * h, h, 0) {
                integrate(brdf, wo, mirror, width, -1.0 + i as f64 * h, -1.0 + j as f64 * h, h, 0)
            } else {
                gauss_sum(brdf, wo, h, points.dirs[k].iter().copied().zip(points.inside[k]))
            };
            max_density = max_density.max(Vec3::new(e[0] as f32, e[1] as f32, e[2] as f32) * inv_omega);
            cells[k] = e;
        }
    }
    if mirror_y {
        for j in 0..first_row {
            for i in 0..n {
                cells[j * n + i] = cells[(n - 1 - j) * n + i];
            }
        }
    }
    max_density
}

/// [`slice`]'s summed-area table ([`summed_area`]) and largest cell density, its cells in a
/// per-thread buffer reused across slices and builds.
pub(super) fn slice_sat(
    brdf: &Brdf,
    grid: &HemiGrid,
    points: &QuadraturePoints,
    wo: Vec3,
    mirror_y: bool,
) -> (Vec<[f64; 4]>, Vec3) {
    thread_local! {
        static CELLS: std::cell::RefCell<Vec<[f64; 3]>> = const { std::cell::RefCell::new(Vec::new()) };
    }
    let n = grid.n();
    CELLS.with_borrow_mut(|cells| {
        cells.resize(n * n, [0.0; 3]);
        let max_density = slice(brdf, grid, points, wo, mirror_y, cells);
        (summed_area(cells, n), max_density)
    })
}

/// Summed-area table of `N×N` cells: `(N+1)²` prefix sums, stored with replicated edges as
/// `(N+3)²` entries (see `BrdfTable::sat`): padded row (column) `a` holds prefix row (column)
/// `clamp(a − 1, 0, N)`, written directly.
fn summed_area(cells: &[[f64; 3]], n: usize) -> Vec<[f64; 4]> {
    let w = n + 3;
    // Padded rows 0 and 1 are prefix row 0 (zeros); row j + 2 is prefix row j + 1.
    let mut out = vec![[0.0f64; 4]; w * w];
    for j in 0..n {
        let (above, rest) = out.split_at_mut((j + 2) * w);
        let (prev, cur) = (&above[(j + 1) * w..], &mut rest[..w]);
        let mut row = [0.0f64; 3];
        for i in 0..n {
            let c = cells[j * n + i];
            row = [row[0] + c[0], row[1] + c[1], row[2] + c[2]];
            let p = prev[i + 2];
            cur[i + 2] = [p[0] + row[0], p[1] + row[1], p[2] + row[2], 0.0];
        }
        cur[n + 2] = cur[n + 1];
    }
    let (body, last) = out.split_at_mut((n + 2) * w);
    last.copy_from_slice(&body[(n + 1) * w..]);
    out
}

/// Whether the square `[x0, x0 + side] × [y0, y0 + side]` must be split: it is wider than the
/// lobe and within three lobe widths of the lobe's peak (the 2×2 Gauss–Legendre rule is
/// fourth-order, so sub-cells one lobe width across suffice).
fn refine(width: Option<f64>, mirror: Vec3, x0: f64, y0: f64, side: f64, depth: u32) -> bool {
    let Some(w) = width else { return false };
    // Angular size of the square is at most 2·side (the map's largest stretch).
    let angular = 2.0 * side;
    if depth >= MAX_DEPTH || angular <= w {
        return false;
    }
    let centre = dir_from_hemi(Vec2::new((x0 + 0.5 * side) as f32, (y0 + 0.5 * side) as f32));
    f64::from(centre.dot(mirror).clamp(-1.0, 1.0).acos()) < 3.0 * w + angular
}

/// Calls `f(direction, solid angle)` for the points of the adaptive rule over the plane
/// square `[x0, x0 + side] × [y0, y0 + side]` that lie inside the unit disk (the rule of
/// [`BrdfTable::build`], exposed for direct quadrature with a weight).
pub(crate) fn adaptive_points(
    width: Option<f64>,
    mirror: Vec3,
    x0: f64,
    y0: f64,
    side: f64,
    f: &mut dyn FnMut(Vec3, f64),
) {
    adaptive_points_at(width, mirror, x0, y0, side, 0, f)
}

fn adaptive_points_at(
    width: Option<f64>,
    mirror: Vec3,
    x0: f64,
    y0: f64,
    side: f64,
    depth: u32,
    f: &mut dyn FnMut(Vec3, f64),
) {
    if refine(width, mirror, x0, y0, side, depth) {
        let half = 0.5 * side;
        for (dx, dy) in [(0.0, 0.0), (half, 0.0), (0.0, half), (half, half)] {
            adaptive_points_at(width, mirror, x0 + dx, y0 + dy, half, depth + 1, f);
        }
        return;
    }
    let weight = 0.5 * side * side;
    for p in gauss_points(x0, y0, side) {
        if p.length_squared() < 1.0 {
            f(dir_from_hemi(p), weight);
        }
    }
}

/// `∫ ρ cos θ dω` over the plane square `[x0, x0 + side] × [y0, y0 + side]` ∩ unit disk.
#[allow(clippy::too_many_arguments)]
fn integrate(
    brdf: &Brdf,
    wo: Vec3,
    mirror: Vec3,
    width: Option<f64>,
    x0: f64,
    y0: f64,
    side: f64,
    depth: u32,
) -> [f64; 3] {
    if refine(width, mirror, x0, y0, side, depth) {
        let half = 0.5 * side;
        let mut sum = [0.0; 3];
        for (dx, dy) in [(0.0, 0.0), (half, 0.0), (0.0, half), (half, half)] {
            let part = integrate(brdf, wo, mirror, width, x0 + dx, y0 + dy, half, depth + 1);
            for c in 0..3 {
                sum[c] += part[c];
            }
        }
        return sum;
    }
    let pts = gauss_points(x0, y0, side);
    gauss_sum(brdf, wo, side, pts.iter().map(|&p| (dir_from_hemi(p), p.length_squared() < 1.0)))
}

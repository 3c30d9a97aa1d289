//! BRDF tables on the hemisphere grid and their summed-area tables (Xu et al. 2006, §4.2).
//!
//! For each tabulated view direction, cell `(i, j)` of the `N×N` grid holds
//! `∫_cell ρ(ω, v)·cos θ dω` over the part of the cell above the horizon (in steradians;
//! plane area is half the solid angle). The integral is computed by recursive adaptive
//! quadrature: a cell is split into quarters while its angular size exceeds the lobe width
//! and it lies within three lobe widths of the lobe's peak (the mirror direction), so
//! a lobe narrower than a cell keeps its energy; elsewhere a 2×2 Gauss–Legendre rule is used.
//!
//! View directions:
//! - Lambertian BRDFs: no slice at all. A Lambertian term (a Lambertian BRDF, or the diffuse
//!   term of an isotropic one) is view-independent and its box integral has a closed form
//!   ([`crate::cosine`]), exact and cheaper than any lookup.
//! - Isotropic BRDFs: `V` polar angles `θ_k = θ_max·(1 − (1 − k/(V−1))²)`, denser toward
//!   grazing (the spacing shrinks linearly to zero at `θ_max = acos(10⁻³) ≈ 89.94°`); the view
//!   is rotated to azimuth 0, which an RSL allows because its square may take any rotation.
//!   Views beyond `θ_max` use the last slice.
//! - Anisotropic BRDFs: `V×V` views at the nodes of a grid over the view's hemisphere-plane
//!   point `[−1, 1]²` (nodes outside the unit disk use the view on the disk's rim), bilinearly
//!   interpolated. The models are symmetric under x → −x and y → −y, so only a quarter of the
//!   views is tabulated and stored; the others are the same slices with the box mirrored.
//!
//! Summed-area tables are built and stored in f64 (the prefix sums of `N²` cell integrals
//! keep ~15 significant digits, so the four-lookup difference of a near-delta lobe's box is
//! exact to far below the table's own error; docs/conventions.md, Numerics). A box is evaluated through
//! the prefix function `F(x, y)`, the integral over `[−1, x]×[−1, y]`, known exactly at cell
//! corners and interpolated between them by Catmull–Rom splines (a bilinear `F`, i.e. a
//! density uniform per cell, errs by several 10⁻³ for boxes of two cells even for Lambert);
//! the parts of a box outside `[−1, 1]²` or below the horizon add nothing, and results are
//! clamped to `[0, max density × area]`, which bounds any spline overshoot.

use crate::model::Brdf;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use rsl_sphere::hemi::{HemiGrid, dir_from_hemi, hemi_from_dir};

mod quadrature;
pub(crate) use quadrature::adaptive_points;
use quadrature::{QuadraturePoints, slice_sat};

/// Largest polar view angle tabulated: `acos(10⁻³)`.
pub fn theta_max() -> f32 {
    (1e-3f32).acos()
}

/// The least cosine of a view's polar angle by which a BRDF whose value grows as `cos^−e` of
/// it near grazing ([`Brdf::view_amplitude_exponent`]: Ward) is scaled beyond the last
/// tabulated or fitted view (about 89.9994°): its amplitude stays finite at grazing.
pub const MIN_VIEW_COS: f32 = 1e-5;

/// `v ≥ 2` polar view angles `θ_k = θ_max·(1 − (1 − k/(v−1))²)`, denser toward grazing.
pub fn polar_views(v: usize, theta_max: f32) -> Vec<f32> {
    (0..v).map(|k| theta_max * (1.0 - (1.0 - k as f32 / (v - 1) as f32).powi(2))).collect()
}

/// Where the polar angle `theta` falls among [`polar_views`]`(v, theta_max)`: the lower view
/// `k ≤ v − 2` and the fraction `f ∈ [0, 1]` of the way to `k + 1` (angles beyond `θ_max`
/// take the last view).
pub fn polar_view_between(theta: f32, v: usize, theta_max: f32) -> (usize, f32) {
    // Invert θ = θ_max(1 − (1 − t)²): t = 1 − √(1 − θ/θ_max).
    let t = (1.0 - (1.0 - theta.min(theta_max) / theta_max).max(0.0).sqrt()) * (v - 1) as f32;
    let k = (t.floor() as usize).min(v - 2);
    (k, (t - k as f32).clamp(0.0, 1.0))
}

/// Deepest recursion of the adaptive cell quadrature (a cell split into up to 4⁸ parts).
const MAX_DEPTH: u32 = 8;

/// How views are sampled.
#[derive(Clone, Debug, PartialEq)]
pub enum Views {
    /// One view-independent slice.
    Single,
    /// Polar angles (radians), increasing.
    Isotropic(Vec<f32>),
    /// `v×v` nodes over the view's hemisphere-plane point in `[−1, 1]²`.
    Anisotropic(usize),
}

/// Resolutions of a table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Resolution {
    /// `N` of the `N×N` light grid.
    pub n: usize,
    /// View samples: `V` polar angles, or `V×V` for anisotropic BRDFs.
    pub views: usize,
}

impl Resolution {
    /// The paper's resolution: `N = 32`, `V = 32`.
    pub const PAPER: Resolution = Resolution { n: 32, views: 32 };

    /// Chooses `N` from the lobe width `w`, and `V = 16`: the power of two at least `48/w`,
    /// within `[32, 128]` (32 for Lambertian BRDFs). A cell spans at most `4/N` radians, so
    /// that is about twelve cells per lobe width, where square integrals of two cells and
    /// more are within 10⁻³ of direct integration at tabulated views (README: measured per
    /// model and `N`). Sixteen views suffice since lookups follow the lobe between them
    /// (32 changed no accuracy scene's error by more than 0.01 points; README).
    pub fn auto(brdf: &Brdf) -> Self {
        let n = match brdf.lobe_width() {
            None => 32,
            Some(w) => ((48.0 / w).ceil() as usize).next_power_of_two().clamp(32, 128),
        };
        Self { n, views: 16 }
    }
}

/// A BRDF tabulated per view, with summed-area tables.
#[derive(Clone, Debug)]
pub struct BrdfTable {
    brdf: Brdf,
    grid: HemiGrid,
    views: Views,
    /// Per view slice, the `(N+1)²` prefix sums (RGB, f64) with replicated edges, `(N+3)²`
    /// entries row-major: entry `(a, b)` is the sum of the cells with index `< clamp(a − 1,
    /// 0, N)` in x and `< clamp(b − 1, 0, N)` in y. A spline's four taps around grid index
    /// `i` are then always the four consecutive entries from `i`. The fourth lane is zero
    /// padding, so that a tap is one 4-wide vector operation.
    sat: Vec<Vec<[f64; 4]>>,
    /// The albedo of the Lambertian term integrated in closed form (a Lambertian BRDF's, or
    /// an isotropic BRDF's diffuse term, which then is not in the slices); zero for
    /// anisotropic BRDFs, whose slices hold the whole BRDF.
    diffuse: Vec3,
    /// Largest cell density (integral / cell solid angle), per channel, over all slices.
    max_density: Vec3,
}

/// The view-dependent part of a square query (see [`BrdfTable::view_lookup`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ViewLookup {
    /// The view is at or below the horizon: nothing is reflected.
    Below,
    /// A view-independent (Lambertian) table.
    Single,
    /// Rotation to azimuth 0 (`cos φ`, `sin φ`) and the two polar slices `slice`, `slice + 1`
    /// blended by `weights`, each read with the light turned by `turn` (`cos β`, `sin β` of a
    /// rotation about the y axis, `β = θ_v − θ_k`) so that the view's mirror direction lands
    /// on the slice's.
    Isotropic {
        /// `cos φ_v`.
        cos: f32,
        /// `sin φ_v`.
        sin: f32,
        /// Lower slice.
        slice: usize,
        /// Weights of the lower and upper slice: `1 − f` and `f` for a view a fraction `f` of
        /// the way between them, each scaled by `(cos θ_k / cos θ_v)^e`
        /// ([`Brdf::view_amplitude_exponent`]).
        weights: [f32; 2],
        /// `(cos β, sin β)` for the lower and the upper slice.
        turn: [Vec2; 2],
    },
    /// The view grid node below and left of the view, and the bilinear weights.
    Anisotropic {
        /// `(i, j)` of the node.
        node: [usize; 2],
        /// `(fx, fy)`.
        weight: [f32; 2],
    },
}

/// The result of a square query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SquareIntegral {
    /// `∫ ρ cos θ dω` over the square, RGB.
    pub integral: Vec3,
    /// Solid angle of the square, `4r²`.
    pub solid_angle: f32,
    /// `integral / solid_angle` (zero for an empty square).
    pub average: Vec3,
}

impl BrdfTable {
    /// Tabulates `brdf` (which must validate) at `res`. Lambertian BRDFs need no slice (their
    /// integral is in closed form), isotropic BRDFs get `res.views` polar slices of their
    /// specular part (the diffuse term, view-independent, is in closed form and must not
    /// follow the lobe between views), and anisotropic ones `views²` slices of the whole
    /// BRDF.
    pub fn build(brdf: &Brdf, res: Resolution) -> Result<Self, crate::model::ParamError> {
        brdf.validate()?;
        if res.n == 0 || res.views < 2 {
            return Err(crate::model::ParamError {
                model: brdf.name(),
                parameter: "resolution",
                problem: format!("needs N ≥ 1 and at least 2 view samples, got N = {}, V = {}", res.n, res.views),
            });
        }
        let grid = HemiGrid::new(res.n);
        let views = if brdf.is_lambertian() {
            Views::Single
        } else if brdf.is_anisotropic() {
            Views::Anisotropic(res.views)
        } else {
            let v = res.views;
            Views::Isotropic(polar_views(v, theta_max()))
        };
        let points = QuadraturePoints::of(&grid);
        let diffuse = match &views {
            Views::Anisotropic(_) => Vec3::ZERO,
            _ => brdf.diffuse(),
        };
        let slices: Vec<(Vec<[f64; 4]>, Vec3)> = match &views {
            Views::Single => Vec::new(),
            Views::Isotropic(thetas) => {
                let specular = brdf.specular_part();
                thetas
                    .par_iter()
                    .map(|&t| slice_sat(&specular, &grid, &points, Vec3::new(t.sin(), 0.0, t.cos()), true))
                    .collect()
            }
            Views::Anisotropic(v) => {
                // The anisotropic models here are symmetric under x → −x and y → −y (Ward
                // depends on h_x² and h_y²): the view at node (v−1−i, j) sees the cells of node
                // (i, j) mirrored in x, and likewise in y. Only the quarter i, j < ⌈v/2⌉ is
                // stored; queries mirror the box instead (see `square`).
                let half = v.div_ceil(2);
                (0..half * half)
                    .into_par_iter()
                    .map(|k| slice_sat(brdf, &grid, &points, anisotropic_view(*v, k % half, k / half), false))
                    .collect()
            }
        };
        // A square's specular and diffuse parts each stay within their own largest density
        // (the Lambertian term's is `a/π`, at the pole).
        let max_density = slices.iter().fold(Vec3::ZERO, |m, s| m.max(s.1)) + diffuse * std::f32::consts::FRAC_1_PI;
        let sat: Vec<Vec<[f64; 4]>> = slices.into_iter().map(|(sat, _)| sat).collect();
        Ok(Self { brdf: *brdf, grid, views, sat, diffuse, max_density })
    }

    /// The tabulated BRDF.
    pub fn brdf(&self) -> &Brdf {
        &self.brdf
    }

    /// The light grid.
    pub fn grid(&self) -> HemiGrid {
        self.grid
    }

    /// How views are sampled.
    pub fn views(&self) -> &Views {
        &self.views
    }

    /// Number of view slices stored: none (Lambertian), `V` (isotropic), or the quarter
    /// `⌈V/2⌉²` of the `V×V` anisotropic views that symmetry leaves distinct.
    pub fn slices(&self) -> usize {
        self.sat.len()
    }

    /// The albedo `a` of the Lambertian term that is integrated in closed form rather than
    /// tabulated (`∫ (a/π) cos θ dω` over each box, [`crate::cosine`]): a Lambertian BRDF's
    /// albedo, an isotropic BRDF's diffuse term (its slices then hold the specular part
    /// alone); zero for anisotropic BRDFs.
    pub fn analytic_diffuse(&self) -> Vec3 {
        self.diffuse
    }

    /// Bytes of the summed-area tables.
    pub fn bytes(&self) -> usize {
        self.sat.iter().map(|s| std::mem::size_of_val(s.as_slice())).sum::<usize>()
    }

    /// Largest cell density `∫ρcos / Ω` in any slice, per channel: no square's average can
    /// exceed it.
    pub fn max_density(&self) -> Vec3 {
        self.max_density
    }

    /// The summed-area table of view slice `k`: `(N+1)²` prefix sums, row-major, `[j·(N+1) + i]`
    /// the sum of the cells with index `< i` in x and `< j` in y (RGB and a zero lane).
    pub fn slice_sat(&self, k: usize) -> Vec<[f64; 4]> {
        let n = self.grid.n();
        let w = n + 3;
        (0..=n).flat_map(|j| (0..=n).map(move |i| (j + 1) * w + i + 1)).map(|e| self.sat[k][e]).collect()
    }

    /// Directional albedo of view slice `k`: the sum of all its cells, plus the closed-form
    /// term's albedo ([`BrdfTable::analytic_diffuse`]). A Lambertian table, which has no
    /// slice, answers its albedo for any `k`.
    pub fn slice_albedo(&self, k: usize) -> Vec3 {
        let n = self.grid.n();
        let total = self.sat.get(k).map_or(Vec3::ZERO, |sat| {
            let e = sat[(n + 1) * (n + 3) + n + 1];
            Vec3::new(e[0] as f32, e[1] as f32, e[2] as f32)
        });
        total + self.diffuse
    }

    /// `∫ ρ(ω, v) cos θ dω` over the axis-aligned square of half-diagonal `r` centred on the
    /// light direction `light` (unit, local frame: normal +z; for anisotropic BRDFs the tangent
    /// frame), for the view `view` (unit, same frame).
    ///
    /// For isotropic BRDFs both directions are first rotated about the normal so the view has
    /// azimuth 0 (the square keeps its orientation relative to that frame: RSLs may rotate).
    /// Views at or below the horizon reflect nothing. The same as
    /// `square_for(&view_lookup(view), light, r)`.
    pub fn square(&self, light: Vec3, r: f32, view: Vec3) -> SquareIntegral {
        self.square_for(&self.view_lookup(view), light, r)
    }

    /// Where `view` (unit, local frame) falls among the tabulated views: the part of a square
    /// query that depends on the view alone, computed once per vertex and reused for every
    /// light.
    pub fn view_lookup(&self, view: Vec3) -> ViewLookup {
        if view.z.is_nan() || view.z <= 0.0 {
            return ViewLookup::Below;
        }
        match &self.views {
            Views::Single => ViewLookup::Single,
            Views::Isotropic(thetas) => {
                let rxy = Vec2::new(view.x, view.y).length();
                let (cos, sin) = if rxy > 1e-12 { (view.x / rxy, view.y / rxy) } else { (1.0, 0.0) };
                let theta = view.z.clamp(-1.0, 1.0).acos().min(theta_max());
                let (k, f) = polar_view_between(theta, thetas.len(), theta_max());
                let turn = [k, k + 1].map(|k| {
                    let (sin, cos) = (theta - thetas[k]).sin_cos();
                    Vec2::new(cos, sin)
                });
                let e = self.brdf.view_amplitude_exponent();
                // Beyond the last view, its slice scaled on by the view's own cosine.
                let cos_view = if view.z < theta_max().cos() { view.z.max(MIN_VIEW_COS) } else { theta.cos() };
                let scale = |k: usize| if e == 0.0 { 1.0 } else { (thetas[k].cos() / cos_view).powf(e) };
                let weights = [(1.0 - f) * scale(k), f * scale(k + 1)];
                ViewLookup::Isotropic { cos, sin, slice: k, weights, turn }
            }
            Views::Anisotropic(v) => {
                let v = *v;
                let q = hemi_from_dir(view);
                let q = if q.length() > 1.0 { q / q.length() } else { q };
                let x = ((q.x + 1.0) * 0.5 * (v - 1) as f32).clamp(0.0, (v - 1) as f32);
                let y = ((q.y + 1.0) * 0.5 * (v - 1) as f32).clamp(0.0, (v - 1) as f32);
                let (i, j) = ((x.floor() as usize).min(v - 2), (y.floor() as usize).min(v - 2));
                ViewLookup::Anisotropic { node: [i, j], weight: [x - i as f32, y - j as f32] }
            }
        }
    }

    /// [`BrdfTable::square`] for a view already located by [`BrdfTable::view_lookup`].
    pub fn square_for(&self, view: &ViewLookup, light: Vec3, r: f32) -> SquareIntegral {
        let r = if r.is_finite() { r.max(0.0) } else { 0.0 };
        let solid_angle = 4.0 * r * r;
        let integral = self.integral_for(view, light, r);
        let average = if solid_angle > 0.0 { integral / solid_angle } else { Vec3::ZERO };
        SquareIntegral { integral, solid_angle, average }
    }

    /// The integral of [`BrdfTable::square_for`] alone (what shading multiplies), `∫ ρ cos θ
    /// dω` over the square, RGB.
    #[inline]
    pub fn integral_for(&self, view: &ViewLookup, light: Vec3, r: f32) -> Vec3 {
        self.integral_with(view, light, r, |k, w, p, s| self.box_blend(&[(k, w)], p, s))
    }

    /// [`BrdfTable::integral_for`] for a light far from the BRDF's lobe, where the lobe's tail
    /// is smooth over the square: each slice's density at the square's centre (its cells'
    /// integrals over their area, interpolated between the cells' centres) times the square's
    /// area, in place of the box's integral — nine summed-area entries a slice instead of the
    /// box's 64 spline taps. The closed-form Lambertian term is integrated as ever. The GPU
    /// reads the same cells (`square_for` in shaders/common/brdf.wgsl with `tail`).
    #[inline]
    pub fn tail_for(&self, view: &ViewLookup, light: Vec3, r: f32) -> Vec3 {
        self.integral_with(view, light, r, |k, w, p, s| self.density_box(k, w, p, s))
    }

    /// The square's integral with each slice `k` read, with weight `w`, over the box `[p − s,
    /// p + s]²` by `read`.
    #[inline(always)]
    fn integral_with(
        &self,
        view: &ViewLookup,
        light: Vec3,
        r: f32,
        read: impl Fn(usize, f32, Vec2, f32) -> Vec3,
    ) -> Vec3 {
        let r = if r.is_finite() { r.max(0.0) } else { 0.0 };
        if !light.is_finite() {
            return Vec3::ZERO;
        }
        let s = r / std::f32::consts::SQRT_2;
        let integral = match *view {
            ViewLookup::Below => return Vec3::ZERO,
            ViewLookup::Single => self.lambertian(hemi_from_dir(light), s),
            ViewLookup::Isotropic { cos: c, sin: sn, slice: k, weights, turn } => {
                // Rotate by −φ_v about z.
                let l = Vec3::new(c * light.x + sn * light.y, -sn * light.x + c * light.y, light.z);
                // Each slice is read where its lobe is: the light turned about y as the mirror
                // direction turns from the view's to the slice's (the lobe follows the view).
                let turned = |t: Vec2| Vec3::new(t.x * l.x + t.y * l.z, l.y, t.x * l.z - t.y * l.x);
                let mut sum = Vec3::ZERO;
                for (slice, w, t) in [(k, weights[0], turn[0]), (k + 1, weights[1], turn[1])] {
                    if w > 0.0 {
                        sum += read(slice, w, hemi_from_dir(turned(t)), s);
                    }
                }
                if self.diffuse != Vec3::ZERO {
                    sum += self.lambertian(hemi_from_dir(l), s);
                }
                sum
            }
            ViewLookup::Anisotropic { node: [i, j], weight: [fx, fy] } => {
                let Views::Anisotropic(v) = self.views else { return Vec3::ZERO };
                let p = hemi_from_dir(light);
                let half = v.div_ceil(2);
                // Node (a, b) is the stored node (min(a, v−1−a), min(b, v−1−b)) mirrored.
                let at = |a: usize, b: usize| {
                    let (qa, qb) = (a.min(v - 1 - a), b.min(v - 1 - b));
                    let q = Vec2::new(if qa != a { -p.x } else { p.x }, if qb != b { -p.y } else { p.y });
                    read(qb * half + qa, 1.0, q, s)
                };
                (at(i, j) * (1.0 - fx) + at(i + 1, j) * fx) * (1.0 - fy)
                    + (at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx) * fy
            }
        };
        self.clamp(integral, r)
    }

    /// `w ·` slice `k`'s density at `p` times the area of the box `[p − s, p + s]²`: the
    /// cells' integrals interpolated bilinearly between the centres of the 2×2 cells around
    /// `p`, divided by a cell's area. Beyond the grid there are no cells (nothing above the
    /// horizon): they count as zero.
    ///
    /// Along x, `(1 − f)·cell(i) + f·cell(i + 1)` is `−(1 − f)·S(i) + (1 − 2f)·S(i + 1) +
    /// f·S(i + 2)` in the prefix sums `S`, and likewise along y: nine summed-area entries,
    /// which the replicated edges hold for `i` from −1 (a cell before the first) to `N − 1`.
    fn density_box(&self, k: usize, w: f32, p: Vec2, s: f32) -> Vec3 {
        let n = self.grid.n();
        let width = n + 3;
        let sat = &self.sat[k];
        // Cell-centre coordinates (cell i's centre at i), shifted by one so that the first
        // index, from −1, is a padded column: clamped ≥ 0, so truncation floors.
        let at = |c: f32| {
            let g = (f64::from(c) + 1.0) * 0.5 * n as f64 + 0.5;
            let i = g.clamp(0.0, n as f64) as usize;
            let f = (g - i as f64).clamp(0.0, 1.0);
            (i, [f - 1.0, 1.0 - 2.0 * f, f])
        };
        let ((i, ux), (j, uy)) = (at(p.x), at(p.y));
        let mut out = [0.0f64; 4];
        for (b, wy) in uy.iter().enumerate() {
            // Prefix entry S(a, b) (the cells < a in x and < b in y) is padded entry
            // (a+1, b+1); here a = i − 1 + column.
            let row = &sat[(j + b) * width + i..][..3];
            let mut line = [0.0f64; 4];
            for (v, wx) in row.iter().zip(&ux) {
                for c in 0..4 {
                    line[c] += wx * v[c];
                }
            }
            for c in 0..4 {
                out[c] += wy * line[c];
            }
        }
        // The box's area over a cell's: (2s)² / (2/N)².
        let scale = f64::from(w) * (f64::from(s) * n as f64).powi(2);
        Vec3::new((out[0] * scale) as f32, (out[1] * scale) as f32, (out[2] * scale) as f32)
    }

    /// A square's integral, within what it can be: the spline can overshoot next to a
    /// near-delta lobe; the true value lies in [0, max density × area].
    #[inline]
    fn clamp(&self, integral: Vec3, r: f32) -> Vec3 {
        integral.clamp(Vec3::ZERO, self.max_density * (4.0 * r * r))
    }

    /// The closed-form Lambertian term's `∫ (a/π) cos θ dω` over the box `[p − s, p + s]²`.
    #[inline]
    fn lambertian(&self, p: Vec2, s: f32) -> Vec3 {
        self.diffuse * (crate::cosine::box_cosine(p, s) / std::f64::consts::PI) as f32
    }

    /// `Σ w·∫` over the box `[p − s, p + s]²` of the slices `(k, w)`: the box's corners are
    /// located once and their spline taps shared by every slice and channel.
    ///
    /// Each corner's `F(x, y)` is the prefix function interpolated between grid corners by
    /// Catmull–Rom splines in x and y (exact at corners; outside `[−1, 1]²` `F` is constant,
    /// which the replicated edges reproduce); the box is `F(x1, y1) − F(x0, y1) −
    /// F(x1, y0) + F(x0, y0)`, summed in f64.
    fn box_blend(&self, slices: &[(usize, f32)], p: Vec2, s: f32) -> Vec3 {
        let n = self.grid.n();
        #[cfg(target_arch = "x86_64")]
        if simd::available() {
            #[allow(unsafe_code)]
            // SAFETY: the processor has AVX2 and FMA (checked at run time just above).
            let out = unsafe { simd::box_blend(&self.sat, slices, p, s, n) };
            return Vec3::new(out[0] as f32, out[1] as f32, out[2] as f32);
        }
        self.box_blend_portable(slices, p, s)
    }

    /// [`BrdfTable::box_blend`] in portable code.
    fn box_blend_portable(&self, slices: &[(usize, f32)], p: Vec2, s: f32) -> Vec3 {
        let n = self.grid.n();
        let width = n + 3;
        // Taps of one coordinate: the first of 4 consecutive (padded) indices and their
        // spline weights.
        let taps = |c: f32| {
            let g = ((f64::from(c) + 1.0) * 0.5 * n as f64).clamp(0.0, n as f64);
            // g ≥ 0, so truncation is the floor.
            let i = (g as usize).min(n - 1);
            (i, catmull_rom(g - i as f64))
        };
        let (x0, x1) = (taps(p.x - s), taps(p.x + s));
        let (y0, y1) = (taps(p.y - s), taps(p.y + s));
        // Signed weights of the eight columns (x1's four, then x0's) and the eight rows.
        let wx = [x1.1[0], x1.1[1], x1.1[2], x1.1[3], -x0.1[0], -x0.1[1], -x0.1[2], -x0.1[3]];
        let wy = [y1.1[0], y1.1[1], y1.1[2], y1.1[3], -y0.1[0], -y0.1[1], -y0.1[2], -y0.1[3]];
        let rows: [usize; 8] = std::array::from_fn(|r| if r < 4 { y1.0 + r } else { y0.0 + r - 4 } * width);
        let taps = Taps { rows, wy, cols: [x1.0, x0.0], wx };
        let out = blend_taps(&self.sat, slices, &taps);
        Vec3::new(out[0] as f32, out[1] as f32, out[2] as f32)
    }
}

/// The 8×8 taps of a box on a padded summed-area table: eight rows (entry offsets) with
/// signed weights, and two runs of four consecutive columns with signed weights.
struct Taps {
    rows: [usize; 8],
    wy: [f64; 8],
    cols: [usize; 2],
    wx: [f64; 8],
}

/// `Σ_slices w · Σ_rows wy · Σ_cols wx · sat[row + col]` over RGB(+pad) lanes (the portable
/// path; `simd::box_blend` computes the same sums in the same order with fused
/// multiply-adds).
fn blend_taps(sat: &[Vec<[f64; 4]>], slices: &[(usize, f32)], taps: &Taps) -> [f64; 4] {
    let mut out = [0.0f64; 4];
    for &(k, w) in slices {
        let sat = &sat[k];
        // One partial sum per row: eight independent chains of additions.
        let mut lines = [[0.0f64; 4]; 8];
        for (line, &row) in lines.iter_mut().zip(&taps.rows) {
            for (run, &col) in taps.cols.iter().enumerate() {
                let quad = &sat[row + col..row + col + 4];
                for (v, wx) in quad.iter().zip(&taps.wx[run * 4..run * 4 + 4]) {
                    for c in 0..4 {
                        line[c] += wx * v[c];
                    }
                }
            }
        }
        let weighted: [[f64; 4]; 8] = std::array::from_fn(|r| lines[r].map(|x| x * taps.wy[r]));
        let acc = pairwise(weighted);
        let w = f64::from(w);
        for c in 0..4 {
            out[c] += w * acc[c];
        }
    }
    out
}

/// The sum of eight RGB(+pad) values, pairwise.
fn pairwise(v: [[f64; 4]; 8]) -> [f64; 4] {
    let pair = |a: [f64; 4], b: [f64; 4]| std::array::from_fn::<f64, 4, _>(|c| a[c] + b[c]);
    pair(pair(pair(v[0], v[4]), pair(v[2], v[6])), pair(pair(v[1], v[5]), pair(v[3], v[7])))
}

/// The box kernels in vector registers with fused multiply-adds: the four coordinates' spline
/// taps at once, then one register per row's partial sum (AVX2).
#[cfg(target_arch = "x86_64")]
mod simd {
    use super::Taps;
    use glam::Vec2;
    use std::arch::x86_64::*;

    /// Whether the AVX2/FMA kernels run ([`rsl_sphere::simd::level`]).
    #[inline]
    pub(super) fn available() -> bool {
        rsl_sphere::simd::level() >= rsl_sphere::simd::Level::Avx2
    }

    /// The spline taps of the box `[p − s, p + s]²` on a padded table of width `n + 3`, as
    /// `BrdfTable::box_blend_portable` forms them.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn taps(p: Vec2, s: f32, n: usize) -> Taps {
        let width = n + 3;
        // Lanes: x0, x1, y0, y1 (the box's edges), as `taps` in the portable path.
        let c = _mm256_cvtps_pd(_mm_setr_ps(p.x - s, p.x + s, p.y - s, p.y + s));
        let (one, half, zero) = (_mm256_set1_pd(1.0), _mm256_set1_pd(0.5), _mm256_setzero_pd());
        let nf = _mm256_set1_pd(n as f64);
        let g = _mm256_mul_pd(_mm256_mul_pd(_mm256_add_pd(c, one), half), nf);
        let g = _mm256_min_pd(_mm256_max_pd(g, zero), nf);
        let i = _mm256_min_pd(_mm256_floor_pd(g), _mm256_set1_pd((n - 1) as f64));
        let t = _mm256_sub_pd(g, i);
        let first: [i32; 4] = bytemuck::cast(_mm256_cvttpd_epi32(i));
        // Catmull–Rom weights of the taps at offsets −1, 0, 1, 2.
        let (t2, two) = (_mm256_mul_pd(t, t), _mm256_set1_pd(2.0));
        let t3 = _mm256_mul_pd(t2, t);
        let (three, four, five) = (_mm256_set1_pd(3.0), _mm256_set1_pd(4.0), _mm256_set1_pd(5.0));
        let w: [[f64; 4]; 4] = [
            bytemuck::cast(_mm256_mul_pd(half, _mm256_sub_pd(_mm256_sub_pd(_mm256_mul_pd(two, t2), t3), t))),
            bytemuck::cast(_mm256_mul_pd(
                half,
                _mm256_add_pd(_mm256_sub_pd(_mm256_mul_pd(three, t3), _mm256_mul_pd(five, t2)), two),
            )),
            bytemuck::cast(_mm256_mul_pd(
                half,
                _mm256_add_pd(_mm256_sub_pd(_mm256_mul_pd(four, t2), _mm256_mul_pd(three, t3)), t),
            )),
            bytemuck::cast(_mm256_mul_pd(half, _mm256_sub_pd(t3, t2))),
        ];
        let wx: [f64; 8] = std::array::from_fn(|d| if d < 4 { w[d][1] } else { -w[d - 4][0] });
        let wy: [f64; 8] = std::array::from_fn(|d| if d < 4 { w[d][3] } else { -w[d - 4][2] });
        let first = first.map(|f| f as usize);
        let rows: [usize; 8] = std::array::from_fn(|r| if r < 4 { first[3] + r } else { first[2] + r - 4 } * width);
        Taps { rows, wy, cols: [first[1], first[0]], wx }
    }

    /// `Σ_slices w ·` the box `[p − s, p + s]²` of each slice's padded `(n+3)²` table.
    #[target_feature(enable = "avx2,fma")]
    #[allow(unsafe_code)]
    pub(super) fn box_blend(sat: &[Vec<[f64; 4]>], slices: &[(usize, f32)], p: Vec2, s: f32, n: usize) -> [f64; 4] {
        let width = n + 3;
        let Taps { rows, wy, cols, wx } = taps(p, s, n);
        let wx = wx.map(|w| _mm256_set1_pd(w));
        let mut out = _mm256_setzero_pd();
        for &(k, weight) in slices {
            let sat = &sat[k][..];
            assert_eq!(sat.len(), width * width, "a padded table of (n+3)² entries");
            let mut lines = [_mm256_setzero_pd(); 8];
            for (line, &row) in lines.iter_mut().zip(&rows) {
                for (run, &col) in cols.iter().enumerate() {
                    for d in 0..4 {
                        // SAFETY: the first tap index is at most n − 1 in each coordinate, so
                        // row + col + d ≤ (n + 2)·(n + 3) + n + 2 < (n + 3)², the length
                        // asserted above.
                        let v: __m256d = bytemuck::cast(unsafe { *sat.get_unchecked(row + col + d) });
                        *line = _mm256_fmadd_pd(wx[run * 4 + d], v, *line);
                    }
                }
            }
            let weighted: [__m256d; 8] = std::array::from_fn(|r| _mm256_mul_pd(lines[r], _mm256_set1_pd(wy[r])));
            let pair = |a, b| _mm256_add_pd(a, b);
            let acc = pair(
                pair(pair(weighted[0], weighted[4]), pair(weighted[2], weighted[6])),
                pair(pair(weighted[1], weighted[5]), pair(weighted[3], weighted[7])),
            );
            out = _mm256_fmadd_pd(_mm256_set1_pd(f64::from(weight)), acc, out);
        }
        bytemuck::cast(out)
    }
}

/// Catmull–Rom weights of the points at offsets −1, 0, 1, 2 for a parameter `t ∈ [0, 1]`.
fn catmull_rom(t: f64) -> [f64; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [0.5 * (-t3 + 2.0 * t2 - t), 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0), 0.5 * (-3.0 * t3 + 4.0 * t2 + t), 0.5 * (t3 - t2)]
}

/// The view of anisotropic node `(i, j)` of a `v×v` grid over `[−1, 1]²` (clamped to the
/// unit disk, and kept just above the horizon).
fn anisotropic_view(v: usize, i: usize, j: usize) -> Vec3 {
    let q = Vec2::new(-1.0 + 2.0 * i as f32 / (v - 1) as f32, -1.0 + 2.0 * j as f32 / (v - 1) as f32);
    let max = theta_max();
    // |p|² = 1 − cos θ: the disk of θ ≤ θ_max has radius √(1 − cos θ_max).
    let rmax = (1.0 - max.cos()).sqrt();
    let q = if q.length() > rmax { q * (rmax / q.length()) } else { q };
    dir_from_hemi(q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rsl_sphere::sampling::Pcg32;

    #[test]
    fn every_box_path_gives_the_portable_sums() {
        let brdf = Brdf::Ggx { alpha: 0.08, specular: Vec3::new(0.9, 0.6, 0.3), diffuse: Vec3::splat(0.1) };
        let table = BrdfTable::build(&brdf, Resolution { n: 32, views: 16 }).unwrap();
        let mut rng = Pcg32::new(4);
        let mut checked = 0;
        for _ in 0..3000 {
            // Boxes from a fraction of a cell to wider than the grid, past its edges too.
            let p = Vec2::new(rng.next_f32() * 2.6 - 1.3, rng.next_f32() * 2.6 - 1.3);
            let s = 10f32.powf(-3.0 + 3.3 * rng.next_f32());
            let k = rng.next_u32() as usize % (table.slices() - 1);
            let f = rng.next_f32();
            let slices = [(k, 1.0 - f), (k + 1, f)];
            let want = table.box_blend_portable(&slices, p, s);
            let close = |got: Vec3| (got - want).abs().max_element() <= 1e-6 * want.abs().max_element() + 1e-10;
            assert!(
                close(table.box_blend(&slices, p, s)),
                "p = {p}, s = {s}: {} vs {want}",
                table.box_blend(&slices, p, s)
            );
            checked += 1;
        }
        assert_eq!(checked, 3000);
    }

    #[test]
    fn a_small_squares_tail_read_is_its_box_and_nothing_beyond_the_grid() {
        // A square under half a cell, inside the disk, on a rough lobe: the density at its
        // centre times its area is its box, up to how the two interpolate the cells (the
        // cells' densities bilinearly, the prefix sums by splines; measured: 1.5 % at worst).
        // What the tails cost the eye's sums is measured in rsl-engine's tests (≤ 0.03 %).
        let brdf = Brdf::Ggx { alpha: 0.5, specular: Vec3::new(0.9, 0.6, 0.3), diffuse: Vec3::ZERO };
        let table = BrdfTable::build(&brdf, Resolution { n: 32, views: 16 }).unwrap();
        let mut rng = Pcg32::new(5);
        let (mut worst, mut beyond) = (0.0f32, 0);
        for _ in 0..2000 {
            let view = dir_from_hemi(Vec2::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5));
            let lookup = table.view_lookup(view);
            let p = Vec2::new(1.6 * rng.next_f32() - 0.8, 1.6 * rng.next_f32() - 0.8);
            let r = 0.005 + 0.015 * rng.next_f32();
            let light = dir_from_hemi(p);
            if p.length() < 0.85 {
                let (a, b) = (table.integral_for(&lookup, light, r), table.tail_for(&lookup, light, r));
                worst = worst.max((a - b).abs().max_element() / a.max_element());
            }
            // Far below the horizon: beyond the grid, where no cell is (zero up to rounding).
            let below = Vec3::new(light.x, light.y, -light.z.max(0.5)).normalize();
            let nothing = table.tail_for(&lookup, below, r);
            assert!(nothing.max_element() <= 1e-12, "{below}: {nothing}");
            beyond += 1;
        }
        eprintln!("worst relative difference {worst:.2e}");
        assert!(worst < 0.02, "{worst}");
        assert_eq!(beyond, 2000);
    }
}

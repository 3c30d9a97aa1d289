//! The environment convolved with normalised vMF lobes at a ladder of concentrations
//! (Laurijssen & Dutré 2009; Green et al. 2006 §5): `P_κ(μ) = ∫ L(s) γ_{μ,κ}(s) ds`, the
//! lobe-weighted mean radiance around `μ`. Rendering a lobe of weight `α` is then one lookup,
//! `α·P_κ(μ)`.
//!
//! Level 0 is `κ = 0` (the map's mean radiance); levels 1… double `κ` from 1 to
//! [`PrefilterParams::kappa_max`]. Each level lives on its own `6×o×o` cube grid with
//! `o ≈ π√κ` (a texel at most half the lobe's width, up to
//! [`PrefilterParams::max_resolution`]) and is summed directly from a source cube grid at
//! least twice as fine (a power of two: the finest resampled from the map once, the coarser
//! ones by summing 2×2 texels): `P(μ_t) = Σ_u E_u γ(μ_t·d_u)`, `E_u` a
//! source texel's energy and `d_u` where its light lies (its luminance-weighted mean
//! direction, so a sun keeps its place), over the texels within the lobe's support
//! (`κ(1 − μ·d) ≤` [`PrefilterParams::cutoff`]). Sums are in f64 with the `e^{κ(μ·d − 1)}`
//! form, so a sun of 20,000 and `κ` of 10⁴ stay finite and exact to the cutoff.
//!
//! A lookup interpolates bilinearly within a level (across cube seams) and linearly between
//! levels in `log₂ κ` (in `κ` between levels 0 and 1). Rotating the environment rotates the
//! lookup direction; nothing is rebuilt.

use crate::vmf::peak_density;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use rsl_env::cube_env::CubeEnv;
use rsl_sphere::Frame;
use rsl_sphere::cube::{CubeGrid, face_axes};
use rsl_sphere::latlong::LatLongMap;
use std::collections::HashMap;
use std::f64::consts::PI;

/// How a [`Prefiltered`] environment is built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrefilterParams {
    /// The sharpest level's `κ` (rounded up to a power of two). Lobes sharper than this are
    /// looked up at it (blurred to its width).
    pub kappa_max: f32,
    /// Largest cube resolution `o` of a level (sources go to twice this).
    pub max_resolution: usize,
    /// Support of a lobe: source texels with `κ(1 − μ·d)` beyond this are left out (their
    /// weight is below `e^{−cutoff}` of the peak's).
    pub cutoff: f64,
}

impl Default for PrefilterParams {
    fn default() -> Self {
        Self { kappa_max: 4096.0, max_resolution: 128, cutoff: 10.0 }
    }
}

/// One level of the ladder.
#[derive(Clone, Debug)]
pub struct Level {
    /// Its concentration.
    pub kappa: f32,
    /// Its cube grid.
    pub grid: CubeGrid,
    /// `P_κ` at each texel's centre direction, RGB.
    pub values: Vec<Vec3>,
}

/// A prefiltered environment: [`Level`]s of increasing `κ`.
#[derive(Clone, Debug)]
pub struct Prefiltered {
    levels: Vec<Level>,
}

/// Points on a support's boundary.
const K: usize = 32;

/// `(cos φ, sin φ)` of the boundary points.
static RING: std::sync::LazyLock<[(f64, f64); K]> = std::sync::LazyLock::new(|| {
    std::array::from_fn(|k| {
        let (s, c) = (2.0 * PI * k as f64 / K as f64).sin_cos();
        (c, s)
    })
});

/// A lobe's support on one source grid: for each of the 6 faces, the texel ranges
/// `[i0, i1) × [j0, j1)` that may hold directions within `cos ≥ cos_min` of `mean`.
fn support(grid: &CubeGrid, mean: DVec3, cos_min: f64) -> [(usize, usize, usize, usize); 6] {
    let r = grid.r();
    if cos_min <= 0.5 {
        return [(0, r, 0, r); 6];
    }
    let sin_max = (1.0 - cos_min * cos_min).max(0.0).sqrt();
    let frame = Frame::from_normal(mean.as_vec3());
    let (t, b) = (frame.t.as_dvec3(), frame.b.as_dvec3());
    let boundary: [DVec3; K] = std::array::from_fn(|k| {
        let (c, s) = RING[k];
        mean * cos_min + (t * c + b * s) * sin_max
    });
    let mut out = [(0, 0, 0, 0); 6];
    let reach = cos_min.acos();
    for (face, range) in out.iter_mut().enumerate() {
        let (n, ua, va) = face_axes(face);
        // A face holds only directions within acos(1/√3) of its axis.
        let off = mean.dot(n).clamp(-1.0, 1.0).acos();
        if off - reach > (1.0 / 3f64.sqrt()).acos() + 1e-6 {
            continue;
        }
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        let mut grow = |u: f64, v: f64| {
            lo = [lo[0].min(u), lo[1].min(v)];
            hi = [hi[0].max(u), hi[1].max(v)];
        };
        let mut any = false;
        for d in boundary.iter().chain(std::iter::once(&mean)) {
            let z = d.dot(n);
            if z > 1e-9 {
                grow(d.dot(ua) / z, d.dot(va) / z);
                any = true;
            }
        }
        // Where the cone crosses the face's plane through the centre, its projection runs
        // off to infinity toward the crossing: open the box that way.
        for k in 0..K {
            let (a, c) = (boundary[k], boundary[(k + 1) % K]);
            if (a.dot(n) > 0.0) != (c.dot(n) > 0.0) {
                let x = a + (c - a) * (a.dot(n) / (a.dot(n) - c.dot(n)));
                let far = |c: f64| if c.abs() > 1e-12 { c.signum() * 1e9 } else { 0.0 };
                grow(far(x.dot(ua)), far(x.dot(va)));
                any = true;
            }
        }
        if !any {
            continue;
        }
        // The cone's boundary curves between the 32 samples: two texels of margin.
        let cell = |c: f64, up: bool| {
            let g = (c.clamp(-1.0, 1.0) + 1.0) * 0.5 * r as f64;
            let g = if up { g.ceil() + 2.0 } else { g.floor() - 2.0 };
            g.clamp(0.0, r as f64) as usize
        };
        *range = (cell(lo[0], false), cell(hi[0], true), cell(lo[1], false), cell(hi[1], true));
    }
    out
}

/// A source grid: per texel, its energy (RGB) and where its light lies.
struct Source {
    grid: CubeGrid,
    energy: Vec<[f64; 3]>,
    /// `Σ Y·d` over the texel's light (luminance-weighted directions) and `Σ Y`.
    moments: Vec<[f64; 4]>,
    /// Where each texel's light lies (its luminance-weighted mean direction, else its
    /// centre), x, y and z columns, and the energy's RGB columns in f32, for the sums.
    columns: [Vec<f32>; 6],
}

impl Source {
    fn new(grid: CubeGrid, energy: Vec<[f64; 3]>, moments: Vec<[f64; 4]>) -> Self {
        let mut columns: [Vec<f32>; 6] = std::array::from_fn(|_| Vec::with_capacity(grid.len()));
        for t in 0..grid.len() {
            let m = moments[t];
            let d = DVec3::new(m[0], m[1], m[2]);
            let d =
                if m[3] > 0.0 && d.length() > 0.0 { d.normalize().as_vec3() } else { grid.texel_dir(t).normalize() };
            let e = energy[t];
            for (c, v) in columns.iter_mut().zip([d.x, d.y, d.z, e[0] as f32, e[1] as f32, e[2] as f32]) {
                c.push(v);
            }
        }
        Self { grid, energy, moments, columns }
    }

    fn from_env(env: &CubeEnv) -> Self {
        let moments = env.moments.clone().unwrap_or_else(|| vec![[0.0; 4]; env.grid.len()]);
        Self::new(env.grid, env.energy.clone(), moments)
    }

    /// The grid of half the resolution, each texel the sum of its 2×2 children (a cube grid's
    /// texels nest exactly).
    fn halved(&self) -> Self {
        let r = self.grid.r() / 2;
        let grid = CubeGrid::new(r);
        let mut energy = vec![[0.0f64; 3]; grid.len()];
        let mut moments = vec![[0.0f64; 4]; grid.len()];
        for t in 0..self.grid.len() {
            let (f, i, j) = self.grid.coords(t);
            let p = grid.index(f, i / 2, j / 2);
            for (sum, e) in energy[p].iter_mut().zip(self.energy[t]) {
                *sum += e;
            }
            for (sum, m) in moments[p].iter_mut().zip(self.moments[t]) {
                *sum += m;
            }
        }
        Self::new(grid, energy, moments)
    }

    /// `Σ_u E_u γ_κ(μ·d_u)` over the support, with `1 − μ·d = |μ − d|²/2` (no cancellation
    /// next to the mean, where a sharp lobe's weight changes fastest).
    fn convolve(&self, mean: Vec3, kappa: f64, cutoff: f64) -> [f64; 3] {
        let cos_min = 1.0 - cutoff / kappa.max(1e-9);
        let peak = peak_density(kappa);
        let (half_k, limit) = ((0.5 * kappa) as f32, (2.0 * cutoff / kappa.max(1e-9)) as f32);
        let r = self.grid.r();
        // Runs of whole chunks of 8 texels: a run is widened within its row (texels outside
        // the support weigh nothing, and no other run reads them).
        let mut runs = Vec::with_capacity(64);
        for (face, (i0, i1, j0, j1)) in support(&self.grid, mean.as_dvec3(), cos_min).into_iter().enumerate() {
            if i1 <= i0 {
                continue;
            }
            let (a, b) = if r >= LANES {
                let width = (i1 - i0).div_ceil(LANES) * LANES;
                let b = (i0 + width).min(r);
                (b - width, b)
            } else {
                (i0, i1)
            };
            for j in j0..j1 {
                let row = self.grid.index(face, 0, j);
                runs.push((row + a, row + b));
            }
        }
        support_sum(&self.columns, &runs, mean, half_k, limit).map(|x| x * peak)
    }
}

/// Lanes of the sums.
const LANES: usize = 8;

/// `Σ e^{−(κ/2)|μ − d|²}·E` over runs of texels (columns x, y, z, r, g, b), texels with
/// `|μ − d|² > limit` left out: eight at a time (AVX2 where the processor has it, chosen at
/// run time; the same sums either way up to rounding), each lane summed in f32 and the lanes
/// in f64.
#[multiversion::multiversion(targets("x86_64+avx2+fma", "x86_64+sse4.1"))]
fn support_sum(cols: &[Vec<f32>; 6], runs: &[(usize, usize)], mean: Vec3, half_k: f32, limit: f32) -> [f64; 3] {
    use wide::f32x8;
    let (mx, my, mz) = (f32x8::splat(mean.x), f32x8::splat(mean.y), f32x8::splat(mean.z));
    let (nk, lim, zero) = (f32x8::splat(-half_k), f32x8::splat(limit), f32x8::splat(0.0));
    let floor = f32x8::splat(-EXP_FLOOR);
    let mut acc = [zero; 3];
    let mut tail = [0.0f64; 3];
    for &(a, b) in runs {
        let mut t = a;
        while t + LANES <= b {
            let lanes = |c: usize| f32x8::new(cols[c][t..t + LANES].try_into().expect("a whole chunk"));
            let (dx, dy, dz) = (lanes(0) - mx, lanes(1) - my, lanes(2) - mz);
            let q = dx * dx + dy * dy + dz * dz;
            let w = q.simd_le(lim).select(exp_support((nk * q).fast_max(floor)), zero);
            for (c, s) in acc.iter_mut().enumerate() {
                *s += w * lanes(3 + c);
            }
            t += LANES;
        }
        for (k, &x) in cols[0][t..b].iter().enumerate() {
            let at = |c: usize| cols[c][t + k];
            let q = (Vec3::new(x, at(1), at(2)) - mean).length_squared();
            if q <= limit {
                let w = f64::from((-half_k * q).exp());
                for (c, s) in tail.iter_mut().enumerate() {
                    *s += w * f64::from(at(3 + c));
                }
            }
        }
    }
    std::array::from_fn(|c| tail[c] + acc[c].to_array().iter().map(|&x| f64::from(x)).sum::<f64>())
}

/// Lowest exponent [`exp_support`] is asked for (a lobe's support ends well above it).
const EXP_FLOOR: f32 = 24.0;

/// `e^x` for `x ∈ [−24, 0]` as `(e^{x/32})^{32}`: Taylor to degree 8 on `[−0.75, 0]`, then
/// five squarings (relative error below 10⁻⁵; libm's exp, not inlined into vector code,
/// cost more than the rest of the sum).
#[inline(always)]
fn exp_support(x: wide::f32x8) -> wide::f32x8 {
    use wide::f32x8;
    let y = x * f32x8::splat(1.0 / 32.0);
    let mut p = f32x8::splat(1.0 / 40320.0);
    for c in [1.0 / 5040.0, 1.0 / 720.0, 1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0] {
        p = p.mul_add(y, f32x8::splat(c));
    }
    for _ in 0..5 {
        p *= p;
    }
    p
}

/// The resolution of the level of concentration `kappa`: a texel at most half the lobe's
/// width `1/√κ` (a face spans π/2), within `[4, max]` and even.
fn level_resolution(kappa: f64, max: usize) -> usize {
    let o = (PI * kappa.sqrt()).ceil() as usize;
    (o.clamp(4, max.max(4)) + 1) & !1
}

/// The source grid a level sums: the power of two at or above twice its resolution (texels
/// at most a quarter of the lobe's width), at most twice `max` rounded up likewise.
fn source_resolution(kappa: f64, max: usize) -> usize {
    (2 * level_resolution(kappa, max)).next_power_of_two().min((2 * max.max(4)).next_power_of_two())
}

impl Prefiltered {
    /// Prefilters `map` (which must hold finite, non-negative radiance).
    pub fn build(map: &LatLongMap, params: &PrefilterParams) -> Self {
        let top = params.kappa_max.max(1.0).log2().ceil() as i32;
        let kappas: Vec<f64> = (0..=top).map(|l| 2f64.powi(l)).collect();
        // Sources at powers of two: the finest resampled from the map, the others halved
        // from it (exact sums, so every source holds the map's energy).
        let sizes: Vec<usize> = kappas.iter().map(|&k| source_resolution(k, params.max_resolution)).collect();
        let finest = *sizes.iter().max().expect("at least one level");
        let mut sources: HashMap<usize, Source> = HashMap::new();
        let mut s = Source::from_env(&CubeEnv::from_latlong(map, finest));
        loop {
            let r = s.grid.r();
            let next = (r >= 8 && r.is_multiple_of(2)).then(|| s.halved());
            sources.insert(r, s);
            match next {
                Some(n) => s = n,
                None => break,
            }
        }
        // Level 0: the mean radiance.
        let total = sources[&finest].energy.iter().fold([0.0f64; 3], |a, e| [a[0] + e[0], a[1] + e[1], a[2] + e[2]]);
        let mean = DVec3::from(total) / (4.0 * PI);
        let mut levels = vec![Level { kappa: 0.0, grid: CubeGrid::new(1), values: vec![mean.as_vec3(); 6] }];
        for (&k, &size) in kappas.iter().zip(&sizes) {
            let source = &sources[&size];
            let grid = CubeGrid::new(level_resolution(k, params.max_resolution));
            let values = (0..grid.len())
                .into_par_iter()
                .map(|t| {
                    let v = source.convolve(grid.texel_dir(t).normalize(), k, params.cutoff);
                    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
                })
                .collect();
            levels.push(Level { kappa: k as f32, grid, values });
        }
        Self { levels }
    }

    /// The levels, `κ = 0` first.
    pub fn levels(&self) -> &[Level] {
        &self.levels
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.levels.iter().map(|l| std::mem::size_of_val(l.values.as_slice())).sum()
    }

    /// `P_κ(dir)`: the environment's mean radiance under a normalised vMF lobe of mean `dir`
    /// (unit, environment space) and concentration `kappa`.
    pub fn lookup(&self, dir: Vec3, kappa: f32) -> Vec3 {
        let kappa = if kappa.is_finite() { kappa.max(0.0) } else { 0.0 };
        let last = self.levels.len() - 1;
        let (a, f) = if kappa <= 1.0 {
            (0, kappa)
        } else {
            let t = kappa.log2() + 1.0;
            if t >= last as f32 {
                return bilinear(&self.levels[last], dir);
            }
            let a = t.floor() as usize;
            (a, t - a as f32)
        };
        let lo = bilinear(&self.levels[a], dir);
        if f <= 0.0 {
            return lo;
        }
        lo * (1.0 - f) + bilinear(&self.levels[a + 1], dir) * f
    }
}

/// Bilinear interpolation of a level between texel centres, across face seams.
fn bilinear(level: &Level, dir: Vec3) -> Vec3 {
    if level.grid.r() == 1 {
        return level.values[0];
    }
    let (texels, weights) = level.grid.bilinear(dir.as_dvec3());
    texels.iter().zip(weights).map(|(&t, w)| level.values[t] * w).sum()
}

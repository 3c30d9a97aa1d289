//! Fitting a region of the environment with a rotatable square light (Xu et al. 2006,
//! §4.1.1).
//!
//! A region `S` (a set of cube texels) is fitted in the equal-area plane centred on the
//! RSL's centre `c` (the hemisphere map with `c` as its pole, docs/conventions.md): the square of
//! half-diagonal `r` has plane area `2r²`, i.e. solid angle `4r²`, and its intensity is set
//! by exact energy preservation, `I = ∫_S L dω / 4r²`. The fitting error of eq. 7,
//!
//! `|S ∪ O_r| · E_θ[ ∫ (T − F_θ)² dω ]`,  θ ∈ {0, π/8, π/4, 3π/8},
//!
//! expands, with `A = ∫_S L²`, `E = ∫_S L` and `B(θ) = ∫_{S ∩ Q_θ} L`, into
//! `η²(θ) = A − 2·I·B(θ) + I²·4r²`, summed over the three colour channels (each with its own
//! `A`, `B` and `I`) with the weights [`CHANNEL_WEIGHTS`]: a region whose colours differ, a
//! blue sky over a green field at the same luminance, fits worse than a grey one, as it
//! renders worse. The RGB energy is carried exactly. Each texel enters as a small square of its own area in that plane (aligned
//! with the RSL's square), so `B` is a continuous function of `r` even for regions of one
//! texel. The centre is the region's luminance-weighted mean direction (its area-weighted
//! mean for black regions); `r` minimises the penalised error (see [`fit_region`]).

use glam::{DVec3, Vec3};
use rsl_sphere::frame::Frame;
use std::f64::consts::PI;

/// Weights of the red, green and blue channels' fitting errors. The paper does not say what
/// it fits; luminance alone lets regions straddle an edge of colour at equal luminance, and
/// the squares then render both sides in one grey (a rough ball under sunrise.exr, 6.49 %
/// per vertex at paper, 30 RSLs). Green, which carries most of the luminance, counts twice
/// as much as red and blue: of the weights tried on the accuracy scenes (docs/history.md), equal ones
/// gave that ball 3.24 % but the overcast bunny 3.16 % (2.64 % with luminance), these 3.84 %
/// and 2.67 %, and luminance's own weights (blue at 0.07) 4.05 % and 2.68 % but 5.56 % at 35
/// RSLs.
pub const CHANNEL_WEIGHTS: [f64; 3] = [0.5, 1.0, 0.5];

/// Rotations at which the square's fit is averaged (Xu et al. §4.1.1).
pub const ROTATIONS: [f64; 4] = [0.0, PI / 8.0, PI / 4.0, 3.0 * PI / 8.0];

/// `(cos θ, sin θ)` of [`ROTATIONS`] (checked against them in a test).
const ROTATION_COS_SIN: [(f32, f32); 4] = [
    (1.0, 0.0),
    (0.923_879_5, 0.382_683_43),
    (std::f32::consts::FRAC_1_SQRT_2, std::f32::consts::FRAC_1_SQRT_2),
    (0.382_683_43, 0.923_879_5),
];

/// Additive statistics of a region; merging two regions adds them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RegionStats {
    /// `∫ L dω` per RGB channel.
    pub energy: [f64; 3],
    /// `∫ Y dω` (luminance).
    pub lum_energy: f64,
    /// `∫ Y² dω`.
    pub lum_sq: f64,
    /// Solid angle.
    pub area: f64,
    /// `Σ Y_t Ω_t d_t`: luminance-weighted direction sum.
    pub dir_energy: DVec3,
    /// `Σ Ω_t d_t`: area-weighted direction sum.
    pub dir_area: DVec3,
    /// Number of texels.
    pub texels: u32,
    /// `∫ L_c² dω` per RGB channel.
    pub rgb_sq: [f64; 3],
}

impl RegionStats {
    /// Statistics of one texel of direction `d`, solid angle `omega` and energy `energy`.
    pub fn texel(d: Vec3, omega: f64, energy: [f64; 3]) -> Self {
        let y = crate::cube_env::luminance_f64(energy);
        let d = d.as_dvec3();
        Self {
            energy,
            lum_energy: y,
            lum_sq: if omega > 0.0 { y * y / omega } else { 0.0 },
            area: omega,
            dir_energy: d * y,
            dir_area: d * omega,
            texels: 1,
            rgb_sq: if omega > 0.0 { energy.map(|e| e * e / omega) } else { [0.0; 3] },
        }
    }

    /// The statistics of the union of two disjoint regions.
    pub fn merged(&self, o: &Self) -> Self {
        Self {
            energy: [self.energy[0] + o.energy[0], self.energy[1] + o.energy[1], self.energy[2] + o.energy[2]],
            lum_energy: self.lum_energy + o.lum_energy,
            lum_sq: self.lum_sq + o.lum_sq,
            area: self.area + o.area,
            dir_energy: self.dir_energy + o.dir_energy,
            dir_area: self.dir_area + o.dir_area,
            texels: self.texels + o.texels,
            rgb_sq: [0, 1, 2].map(|c| self.rgb_sq[c] + o.rgb_sq[c]),
        }
    }

    /// The RSL centre: luminance-weighted mean direction, else area-weighted, else +Y.
    pub fn centre(&self) -> Vec3 {
        let pick = |v: DVec3, scale: f64| (v.length() > 1e-9 * scale).then(|| v.normalize());
        pick(self.dir_energy, self.lum_energy).or_else(|| pick(self.dir_area, self.area)).unwrap_or(DVec3::Y).as_vec3()
    }

    /// The light-variance term of Xu et al. eq. 13 for this region, `|S|·σ_L`, with
    /// `σ_L² = (1/|S|)∫(Y − ū)²`: it equals `√(|S|·∫Y² − (∫Y)²)`.
    pub fn light_variance_term(&self) -> f64 {
        (self.area * self.lum_sq - self.lum_energy * self.lum_energy).max(0.0).sqrt()
    }
}

/// Per-texel data the fit reads: direction, solid angle and energy.
#[derive(Clone, Debug)]
pub struct TexelTable {
    /// Unit direction of each texel's centre.
    pub dir: Vec<Vec3>,
    /// Solid angle of each texel.
    pub omega: Vec<f64>,
    /// Luminance energy `Y·Ω` of each texel.
    pub lum_energy: Vec<f64>,
    /// Per texel, what a fit gathers, packed: direction x, y, z; half the side of its
    /// equal-area square in the fit plane `h = √(Ω/2)/2`; `1/(2h)`; the RGB energy over the
    /// square's area, `E_c/(2h)²`; solid angle.
    packed: Vec<[f32; 9]>,
}

impl TexelTable {
    /// The table of a cube grid and per-texel RGB energies.
    pub fn new(grid: &rsl_sphere::cube::CubeGrid, energy: &[[f64; 3]]) -> Self {
        let n = grid.len();
        assert_eq!(energy.len(), n, "one energy per texel");
        let lum_energy: Vec<f64> = energy.iter().map(|&e| crate::cube_env::luminance_f64(e)).collect();
        let omega: Vec<f64> = (0..n).map(|t| grid.texel_solid_angle(t)).collect();
        let dir: Vec<Vec3> = (0..n).map(|t| grid.texel_dir(t)).collect();
        let packed = (0..n)
            .map(|t| {
                let half = 0.5 * (omega[t] / 2.0).sqrt() as f32;
                let inv = 0.5 / half;
                let [r, g, b] = energy[t].map(|e| e as f32 * inv * inv);
                [dir[t].x, dir[t].y, dir[t].z, half, inv, r, g, b, omega[t] as f32]
            })
            .collect();
        Self { dir, omega, lum_energy, packed }
    }
}

/// The result of fitting one region.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    /// Unit centre direction.
    pub centre: Vec3,
    /// Half-diagonal in the equal-area plane (solid angle `4r²`).
    pub r: f64,
    /// `E_θ[η²(θ)]` summed over the RGB channels with [`CHANNEL_WEIGHTS`], radiance² · sr.
    pub error: f64,
    /// `|S ∪ O_r| · E_θ[η²(θ)]` (eq. 7), the merge criterion.
    pub penalised: f64,
}

/// The region's texels as the objective sees them, in the fit plane, struct-of-arrays and
/// padded to a multiple of [`LANES`] with empty texels (zero energy and area).
#[derive(Default)]
struct PlaneTexels {
    /// |u| and |v| in the square's frame, per rotation.
    u: [Vec<f32>; 4],
    v: [Vec<f32>; 4],
    /// Half the side of the texel's square in the plane.
    half: Vec<f32>,
    /// 1 / (2·half).
    inv_side: Vec<f32>,
    /// Distance of the centre from the plane's origin.
    rho: Vec<f32>,
    /// RGB energy over the texel's plane area, `E_c/(2h)²`.
    w: [Vec<f32>; 3],
    /// Gathered texel directions (environment space), x, y, z.
    d: [Vec<f32>; 3],
    /// Solid angle.
    omega: Vec<f32>,
}

/// Independent accumulators in the objective's loops: wide enough for the compiler to keep
/// them in vector registers, and a fixed summation order, so results are deterministic.
const LANES: usize = 8;

struct Objective<'a> {
    t: &'a PlaneTexels,
    stats: &'a RegionStats,
}

impl Objective<'_> {
    /// `(E_θ[η²], |S ∪ O_r|·E_θ[η²])` at half-diagonal `r`.
    ///
    /// A texel's square `[x − h, x + h] × [y − h, y + h]` (in the RSL square's frame, with
    /// `x, y ≥ 0` by symmetry) overlaps the RSL square `[−s, s]²` by the product of
    /// `max(0, min(x + h, s) − max(x − h, −s)) = max(0, min(2h, 2s, s + h − x))` and the same
    /// in `y`, divided by the texel's area `(2h)²`.
    fn eval(&self, r: f64) -> (f64, f64) {
        eval_objective(self.t, self.stats, r)
    }
}

/// The objective of [`Objective::eval`], compiled for AVX2 and SSE4.1 with run-time
/// dispatch. Lanes are independent and summed in a fixed order, so every path gives the
/// same bits.
#[multiversion::multiversion(targets("x86_64+avx2", "x86_64+sse4.1"))]
fn eval_objective(t: &PlaneTexels, st: &RegionStats, r: f64) -> (f64, f64) {
    use wide::f32x8;
    let lanes = |col: &[f32], c: usize| f32x8::new(col[c * LANES..(c + 1) * LANES].try_into().expect("whole chunk"));
    let n = t.omega.len();
    let s = (r / std::f64::consts::SQRT_2) as f32;
    let rf = f32x8::splat(r as f32);
    let s2 = f32x8::splat(2.0 * s);
    let sv = f32x8::splat(s);
    let disc_area = f32x8::splat(std::f32::consts::PI * (r as f32) * (r as f32));
    let (zero, one, two) = (f32x8::splat(0.0), f32x8::splat(1.0), f32x8::splat(2.0));
    let (mut b_acc, mut disc_acc) = ([zero; 3], zero);
    // Whole chunks of 8 (columns are padded): every chunk is straight vector code with no
    // scalar epilogue, which matters because most regions are small.
    for c in 0..n / LANES {
        let (half, inv) = (lanes(&t.half, c), lanes(&t.inv_side, c));
        let cap = (two * half).fast_min(s2);
        let sh = sv + half;
        let mut cover = zero;
        for k in 0..4 {
            let ox = cap.fast_min(sh - lanes(&t.u[k], c)).fast_max(zero);
            let oy = cap.fast_min(sh - lanes(&t.v[k], c)).fast_max(zero);
            cover += ox * oy;
        }
        for (acc, w) in b_acc.iter_mut().zip(&t.w) {
            *acc += cover * lanes(w, c);
        }
        // Part of the texel inside the disc O_r swept by the rotating square: the radial
        // overlap, capped by the disc's area relative to the texel's.
        let radial = ((rf - lanes(&t.rho, c) + half) * inv).fast_max(zero).fast_min(one);
        let disc = (disc_area * inv * inv).fast_min(one);
        disc_acc += lanes(&t.omega, c) * radial.fast_min(disc);
    }
    let inside_disc: f64 = disc_acc.to_array().iter().map(|&x| f64::from(x)).sum();
    let q = 4.0 * r * r;
    let eta2: f64 = (0..3)
        .map(|c| {
            let b = 0.25 * b_acc[c].to_array().iter().map(|&x| f64::from(x)).sum::<f64>();
            let i = st.energy[c] / q;
            CHANNEL_WEIGHTS[c] * (st.rgb_sq[c] - 2.0 * i * b + i * i * q).max(0.0)
        })
        .sum();
    let union = (st.area + 2.0 * PI * r * r - inside_disc).max(st.area);
    (eta2, union * eta2)
}

fn plane_texels(parts: &[&[u32]], centre: Vec3, table: &TexelTable, t: &mut PlaneTexels) {
    let frame = Frame::from_normal(centre);
    let n: usize = parts.iter().map(|p| p.len()).sum();
    let padded = n.div_ceil(LANES) * LANES;
    // Gather the texels' data; padding is far away (local direction −n, which maps to the
    // rim |p| = √2) with zero energy and area.
    t.half.resize(padded, 1.0);
    t.inv_side.resize(padded, 0.5);
    for col in t.w.iter_mut().chain([&mut t.omega]) {
        col.resize(padded, 0.0);
    }
    let mut d = std::mem::take(&mut t.d);
    for col in &mut d {
        col.resize(padded, 0.0);
    }
    {
        let [dx, dy, dz] = &mut d;
        let (dx, dy, dz) = (&mut dx[..n], &mut dy[..n], &mut dz[..n]);
        let [wr, wg, wb] = &mut t.w;
        let (half, inv, wr, wg, wb, omega) =
            (&mut t.half[..n], &mut t.inv_side[..n], &mut wr[..n], &mut wg[..n], &mut wb[..n], &mut t.omega[..n]);
        for (k, &i) in parts.iter().flat_map(|p| p.iter()).enumerate() {
            let [x, y, z, h, iv, r, g, b, o] = table.packed[i as usize];
            (dx[k], dy[k], dz[k]) = (x, y, z);
            (half[k], inv[k], wr[k], wg[k], wb[k], omega[k]) = (h, iv, r, g, b, o);
        }
    }
    t.half[n..].fill(1.0);
    t.inv_side[n..].fill(0.5);
    for col in t.w.iter_mut().chain([&mut t.omega]) {
        col[n..].fill(0.0);
    }
    for (col, c) in d.iter_mut().zip([-centre.x, -centre.y, -centre.z]) {
        col[n..].fill(c);
    }
    let [dx, dy, dz] = &d;
    project_columns(&frame, dx, dy, dz, t);
    t.d = d;
}

/// Local frame, equal-area map, radius and the four rotations, element-wise over columns
/// (the same formulas as [`rsl_sphere::hemi::hemi_from_dir`], written branch-free so they vectorise).
#[multiversion::multiversion(targets("x86_64+avx2", "x86_64+sse4.1"))]
fn project_columns(frame: &Frame, dx: &[f32], dy: &[f32], dz: &[f32], t: &mut PlaneTexels) {
    let n = dx.len();
    for col in t.u.iter_mut().chain(t.v.iter_mut()) {
        col.resize(n, 0.0);
    }
    t.rho.resize(n, 0.0);
    use wide::f32x8;
    let (ft, fb, fnn) = (frame.t, frame.b, frame.n);
    let lanes = |col: &[f32], c: usize| f32x8::new(col[c * LANES..(c + 1) * LANES].try_into().expect("whole chunk"));
    let splat = f32x8::splat;
    let (zero, one, tiny) = (splat(0.0), splat(1.0), splat(1e-30));
    let rot = ROTATION_COS_SIN;
    for c in 0..n / LANES {
        let (x, y, z) = (lanes(dx, c), lanes(dy, c), lanes(dz, c));
        let lx = x * splat(ft.x) + y * splat(ft.y) + z * splat(ft.z);
        let ly = x * splat(fb.x) + y * splat(fb.y) + z * splat(fb.z);
        let lz = x * splat(fnn.x) + y * splat(fnn.y) + z * splat(fnn.z);
        let rxy = (lx * lx + ly * ly).sqrt();
        // Upper hemisphere: 1/√(1 + z); lower: √(1 − z)/|(x, y)|, the stable equivalent.
        let up = one / (one + lz.fast_max(zero)).sqrt();
        let down = (one - lz).fast_max(zero).sqrt() / rxy.fast_max(tiny);
        let upper = lz.simd_ge(zero);
        let scale = upper.select(up, down);
        // The antipode (lower, on the axis) maps to the rim point (√2, 0).
        let rim = (!upper) & rxy.simd_le(tiny);
        let px = rim.select(splat(std::f32::consts::SQRT_2), lx * scale);
        let py = rim.select(zero, ly * scale);
        let range = c * LANES..(c + 1) * LANES;
        t.rho[range.clone()].copy_from_slice(&(px * px + py * py).sqrt().to_array());
        for (k, &(cs, sn)) in rot.iter().enumerate() {
            let (cs, sn) = (splat(cs), splat(sn));
            t.u[k][range.clone()].copy_from_slice(&(cs * px + sn * py).abs().to_array());
            t.v[k][range.clone()].copy_from_slice(&(cs * py - sn * px).abs().to_array());
        }
    }
}

/// The largest half-diagonal a fitted square may take: the square then just fits in its
/// centre's hemisphere plane (the unit disk, 4 sr). A larger square reaches past the disk,
/// where the plane holds no directions, and the energy given to that part is lost at every
/// vertex (one square fitted to a whole constant sky, `r` = 1.82, lit a ball's normals 32 %
/// too dark on average).
pub const MAX_HALF_DIAGONAL: f64 = 1.0;

thread_local! {
    /// Per-thread scratch for the plane texels, so fits do not allocate.
    static SCRATCH: std::cell::RefCell<PlaneTexels> = std::cell::RefCell::default();
}

/// Fits the region made of the texels in `parts` (disjoint lists) with statistics `stats`.
///
/// `r_hint` starts the search for `r` (for a merge, `√(r_a² + r_b²)` of the two parts is a
/// good start; any positive value works). The penalised error is bracketed by growing steps
/// from ±10% in `r` within `[r0/32, 4·r0]` (`r0 = √(|S|/4)`, the equal-area half-diagonal), then
/// refined by parabolic interpolation in `ln r` to the given precision.
pub fn fit_region(parts: &[&[u32]], stats: &RegionStats, table: &TexelTable, r_hint: f64, precision: Precision) -> Fit {
    let centre = stats.centre();
    let r0 = (stats.area / 4.0).sqrt();
    if stats.lum_energy <= 0.0 || r0 <= 0.0 {
        // Black: any square fits exactly; use the region's own solid angle.
        return Fit { centre, r: r0, error: 0.0, penalised: 0.0 };
    }
    if stats.texels == 1 {
        // One texel has uniform radiance: its own equal-area square (4r² = Ω) reproduces it
        // exactly, η² = 0 (the objective's minimum; `one_uniform_texel_…` checks this).
        return Fit { centre, r: r0, error: 0.0, penalised: 0.0 };
    }
    SCRATCH.with_borrow_mut(|texels| {
        plane_texels(parts, centre, table, texels);
        let obj = Objective { t: texels, stats };
        let hi = (4.0 * r0).min(MAX_HALF_DIAGONAL);
        let (r, (error, penalised)) = minimise_log(|r| obj.eval(r), (r0 / 32.0).min(hi), hi, r_hint, precision);
        Fit { centre, r, error, penalised }
    })
}

/// Minimises `f(r).1` over `[lo, hi]` starting near `start`: bracket by growing steps, then
/// parabolic steps in `ln r` (golden-section steps where a parabola is unusable).
fn minimise_log(
    f: impl Fn(f64) -> (f64, f64),
    lo: f64,
    hi: f64,
    start: f64,
    precision: Precision,
) -> (f64, (f64, f64)) {
    let (tolerance, mut step, refine_steps) = precision.search();
    let (tlo, thi) = (lo.ln(), hi.ln());
    let eval = |t: f64| (t, f(t.exp()));
    let start = if start.is_finite() && start > 0.0 { start.ln().clamp(tlo, thi) } else { 0.5 * (tlo + thi) };
    let mut b = eval(start);
    let mut a = eval((start - step).max(tlo));
    let mut c = eval((start + step).min(thi));
    // Walk downhill until the middle point is the lowest (or a bound is reached).
    for _ in 0..64 {
        if a.1.1 < b.1.1 && a.0 > tlo {
            step *= 2.0;
            (c, b) = (b, a);
            a = eval((b.0 - step).max(tlo));
        } else if c.1.1 < b.1.1 && c.0 < thi {
            step *= 2.0;
            (a, b) = (b, c);
            c = eval((b.0 + step).min(thi));
        } else {
            break;
        }
    }
    let mut best = [a, b, c].into_iter().min_by(|x, y| x.1.1.total_cmp(&y.1.1)).unwrap_or(b);
    if best.0 != b.0 {
        // Minimum on a bound of the range: nothing to refine.
        return (best.0.exp(), best.1);
    }
    const GOLD: f64 = 0.381_966_011_250_105;
    for _ in 0..refine_steps {
        if c.0 - a.0 < 2.0 * tolerance {
            break;
        }
        let (fa, fb, fc) = (a.1.1, b.1.1, c.1.1);
        let (p, q) = ((b.0 - a.0) * (fb - fc), (b.0 - c.0) * (fb - fa));
        let denom = 2.0 * (p - q);
        let mut x = b.0 - ((b.0 - a.0) * p - (b.0 - c.0) * q) / denom;
        if !x.is_finite() || x <= a.0 + tolerance || x >= c.0 - tolerance || (x - b.0).abs() < tolerance {
            // Golden-section step into the larger side.
            x = if c.0 - b.0 > b.0 - a.0 { b.0 + GOLD * (c.0 - b.0) } else { b.0 - GOLD * (b.0 - a.0) };
        }
        let y = eval(x);
        if y.1.1 < b.1.1 {
            if x > b.0 {
                a = b;
            } else {
                c = b;
            }
            b = y;
        } else if x > b.0 {
            c = y;
        } else {
            a = y;
        }
    }
    if b.1.1 < best.1.1 {
        best = b;
    }
    (best.0.exp(), best.1)
}

/// How precisely to locate the optimal `r`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// For ranking candidate merges: bracket from ±10% around the hint, then one parabolic
    /// step. The penalised error is smooth near its minimum, so the key is off by a few
    /// parts in a thousand at most.
    Rank,
    /// For the RSLs that are kept: bracket from ±3% around the hint (the ranking fit's
    /// radius), then refine to 0.5% in `r`.
    Final,
}

impl Precision {
    /// `(tolerance in ln r, initial half-bracket in ln r, refinement steps)`.
    fn search(self) -> (f64, f64, usize) {
        match self {
            Precision::Rank => (0.03, 0.1, 1),
            Precision::Final => (0.005, 0.03, 10),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rsl_sphere::cube::CubeGrid;

    fn table(grid: &CubeGrid, lum: impl Fn(usize) -> f64) -> TexelTable {
        let energy: Vec<[f64; 3]> = (0..grid.len()).map(|t| [lum(t) * grid.texel_solid_angle(t); 3]).collect();
        TexelTable::new(grid, &energy)
    }

    fn stats_of(tab: &TexelTable, texels: &[u32]) -> RegionStats {
        texels.iter().fold(RegionStats::default(), |acc, &t| {
            let t = t as usize;
            // Grey: equal RGB so luminance energy equals each channel's.
            let e = tab.lum_energy[t];
            acc.merged(&RegionStats::texel(tab.dir[t], tab.omega[t], [e, e, e]))
        })
    }

    #[test]
    fn one_uniform_texel_fits_its_own_area_with_no_error() {
        let grid = CubeGrid::new(16);
        let tab = table(&grid, |_| 3.0);
        let t = grid.index(4, 7, 9) as u32;
        let st = stats_of(&tab, &[t]);
        let f = fit_region(&[&[t]], &st, &tab, 1.0, Precision::Final);
        let omega = grid.texel_solid_angle(t as usize);
        // The shortcut agrees with minimising the objective itself.
        let mut texels = PlaneTexels::default();
        plane_texels(&[&[t]], st.centre(), &tab, &mut texels);
        let obj = Objective { t: &texels, stats: &st };
        let (r_min, (e_min, _)) = minimise_log(|r| obj.eval(r), f.r / 32.0, 4.0 * f.r, 1.0, Precision::Final);
        assert!((r_min / f.r - 1.0).abs() < 1e-2, "objective's minimum at r = {r_min}, shortcut r = {}", f.r);
        // At the shortcut's radius the objective itself is ~0 (f32 rounding of the texel's
        // overlap), and no worse than what the search found.
        let (e_at, _) = obj.eval(f.r);
        assert!(e_at <= 1e-5 * st.lum_sq && e_at <= e_min, "η² at shortcut {e_at}, searched {e_min}, A {}", st.lum_sq);
        // Golden-section precision on r (~1e-3 of the bracket) bounds the match.
        assert!(((4.0 * f.r * f.r) / omega - 1.0).abs() < 2e-2, "4r² = {} vs Ω = {omega}", 4.0 * f.r * f.r);
        assert!(f.error <= 1e-3 * st.lum_sq, "error {} vs A {}", f.error, st.lum_sq);
        assert!((f.centre - grid.texel_dir(t as usize)).length() < 1e-5);
    }

    #[test]
    fn uniform_patch_fits_an_equal_area_square_and_peaks_shrink_it() {
        let grid = CubeGrid::new(32);
        // A 6×6 patch on +Z.
        let patch: Vec<u32> = (13..19)
            .flat_map(|j| (13..19).map(move |i| (4, i, j)))
            .map(|(f, i, j)| grid.index(f, i, j) as u32)
            .collect();
        let flat = table(&grid, |_| 1.0);
        let st = stats_of(&flat, &patch);
        let f = fit_region(&[&patch], &st, &flat, 1.0, Precision::Final);
        let ratio = 4.0 * f.r * f.r / st.area;
        assert!((0.6..1.4).contains(&ratio), "square/region area {ratio}");
        // Brute force: the same penalised error is no better at nearby radii.
        let centre_t = grid.index(4, 15, 15);
        let peaked = table(&grid, |t| if t == centre_t { 500.0 } else { 1.0 });
        let sp = stats_of(&peaked, &patch);
        let g = fit_region(&[&patch], &sp, &peaked, f.r, Precision::Final);
        assert!(g.r < 0.6 * f.r, "a bright texel should pull the square in: {} vs {}", g.r, f.r);
        assert!(g.error.is_finite() && g.penalised.is_finite());
    }

    #[test]
    fn the_chosen_radius_beats_a_dense_scan() {
        let grid = CubeGrid::new(16);
        let region: Vec<u32> = (0..40).map(|k| grid.index(2, k % 8, k / 8) as u32).collect();
        let tab = table(&grid, |t| 1.0 + (t % 7) as f64);
        let st = stats_of(&tab, &region);
        let f = fit_region(&[&region], &st, &tab, 0.01, Precision::Final);
        // Re-evaluate the objective on a dense grid of r: no radius in [r0/16, 2r0] may be
        // more than 1% better than the chosen one.
        let mut texels = PlaneTexels::default();
        plane_texels(&[&region], st.centre(), &tab, &mut texels);
        let obj = Objective { t: &texels, stats: &st };
        let r0 = (st.area / 4.0).sqrt();
        let best = (0..2000)
            .map(|k| r0 / 16.0 * (32.0f64).powf(k as f64 / 1999.0))
            .map(|r| obj.eval(r).1)
            .fold(f64::INFINITY, f64::min);
        assert!(f.penalised <= best * 1.01, "fit {} vs dense scan {best}", f.penalised);
    }

    #[test]
    fn rotation_table_matches_the_angles() {
        for (&a, &(c, s)) in ROTATIONS.iter().zip(&ROTATION_COS_SIN) {
            assert!((f64::from(c) - a.cos()).abs() < 1e-7 && (f64::from(s) - a.sin()).abs() < 1e-7);
        }
    }

    #[test]
    fn black_regions_fit_exactly() {
        let grid = CubeGrid::new(8);
        let tab = table(&grid, |_| 0.0);
        let region: Vec<u32> = (0..10).collect();
        let st = stats_of(&tab, &region);
        let f = fit_region(&[&region], &st, &tab, 1.0, Precision::Final);
        assert_eq!((f.error, f.penalised), (0.0, 0.0));
        assert!(f.r > 0.0 && f.centre.is_finite());
    }
}

//! The occluder visibility distance field (Xu et al. 2006, §4.3.2 and §5.1): how an object
//! blocks light for points around it, so that it can move and rotate freely.
//!
//! Samples lie on `S` concentric spheres around the object's bounding-sphere centre, with
//! radii spaced geometrically from `0.4·R` to `6·R` (`r_s = 0.4R·15^{s/(S−1)}`: the cap an
//! object subtends changes fastest close to it), at the `6×M×M` texel centres of a cube
//! grid. Each sample holds the VDT over the hemisphere facing the centre, in the frame
//! `Frame::from_normal(−u)` fixed to its cube direction `u`; directions facing away from the
//! object count as visible. Each shell's cube faces are split 2×2 into 24 segments, each
//! compressed by PCA (one cluster; half-precision coefficients where that raises the
//! segment's RMS error by at most 1%), and built one segment at a time, so the uncompressed
//! field is never held in memory.
//!
//! A lookup at a point interpolates the distances of the 8 nearest samples (2 shells × 4 cube
//! neighbours, across face seams) trilinearly; beyond the outer shell nothing is occluded,
//! inside the inner one the inner shell is used.
//!
//! A flat convex object (a floor, a wall, a card) takes no samples: its field is the closed
//! form of [`crate::flat`], exact where the sampled field is at its worst.

use crate::coverage::coverage;
use crate::cpca::{Cpca, CpcaVector, hsum};
use crate::flat::{Flat, FlatLookup};
use crate::map::{VisibilityMap, bilinear_cells, bilinear_taps};
use crate::rays::{Occluder, VisError};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use rsl_sphere::Frame;
use rsl_sphere::cube::CubeGrid;
use rsl_sphere::hemi::hemi_from_dir;
use rsl_sphere::mesh::TriMesh;

/// A point located among an occluder field's samples ([`Ovdf::locate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OvdfPoint {
    /// The point itself (object space).
    x: Vec3,
    /// Inner of the two shells.
    shell: usize,
    /// Weight of the outer shell.
    shell_weight: f32,
    /// The four cube texels around the point's direction.
    texels: [usize; 4],
    /// Per texel: its segment within a shell (face·4 + quadrant) and its index there.
    places: [(u32, u32); 4],
    /// Bilinear weights of the texels.
    weights: [f32; 4],
}

/// Resolutions of an occluder field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OvdfParams {
    /// Concentric shells `S`.
    pub shells: usize,
    /// Cube resolution `M` per shell (even).
    pub m: usize,
    /// `N` of each sample's table.
    pub n: usize,
    /// `s×s` rays per cell.
    pub supersample: usize,
    /// PCA vectors per segment.
    pub vectors: usize,
}

impl OvdfParams {
    /// Fast: 8 shells × 6×8×8 samples, 16×16 tables, 4 vectors.
    pub const DRAFT: OvdfParams = OvdfParams { shells: 8, m: 8, n: 16, supersample: 2, vectors: 4 };
    /// Xu et al.: 16 shells × 6×32×32 samples, 32×32 tables, 8 vectors.
    pub const PAPER: OvdfParams = OvdfParams { shells: 16, m: 32, n: 32, supersample: 2, vectors: 8 };

    /// Checks that the resolutions can make a field: even M ≥ 2, S ≥ 2, N ≥ 2.
    pub fn check(&self) -> Result<(), VisError> {
        if self.m < 2 || !self.m.is_multiple_of(2) || self.shells < 2 || self.n < 2 {
            return Err(VisError::Params(format!(
                "occluder field resolution needs even M ≥ 2, S ≥ 2, N ≥ 2; got M = {}, S = {}, N = {}",
                self.m, self.shells, self.n
            )));
        }
        Ok(())
    }
}

/// Inner and outer shell radii in bounding radii.
pub const INNER: f32 = 0.4;
/// Outer shell radius in bounding radii.
pub const OUTER: f32 = 6.0;

/// Distance returned where the object occludes nothing (beyond any square's reach).
const FAR: f32 = 2.0 * std::f32::consts::SQRT_2;

/// An object's occluder field.
#[derive(Clone, Debug, PartialEq)]
pub struct Ovdf {
    centre: Vec3,
    radius: f32,
    params: OvdfParams,
    /// `shells × 24` segments.
    segments: Vec<Cpca>,
    /// Each cube texel's sample frame, `Frame::from_normal(−u)` (computed once: lookups read
    /// eight of them).
    frames: Vec<Frame>,
    /// The closed form of a flat convex object, which then has no segments or frames.
    flat: Option<Flat>,
    /// Whether every segment holds `n²` means and rows and `n ≥ 2`, so that the vector
    /// kernel may read them without bounds checks: true of every field built or read here
    /// (a field that is not takes the portable path).
    whole: bool,
    /// Bytes uncompressed, f32, f16; RMS distance error.
    pub raw_bytes: usize,
    /// Compressed bytes with f32 coefficients.
    pub bytes_f32: usize,
    /// Compressed bytes with f16 coefficients.
    pub bytes_f16: usize,
    /// RMS error of the reconstructed distances (plane units).
    pub rms_distance_error: f32,
    /// RMS error of the coverage of random squares (half-diagonal 0.02–0.2) from the
    /// reconstructed tables against the uncompressed ones.
    pub rms_coverage_error: f32,
}

impl Ovdf {
    /// Builds the field of `mesh` (object space).
    pub fn build(mesh: &TriMesh, params: &OvdfParams) -> Result<Self, VisError> {
        Self::build_with_progress(mesh, params, &|_, _| {})
    }

    /// [`Ovdf::build`], calling `progress(done, total)` after each of the `shells × 24`
    /// segments. A flat convex mesh takes the closed form ([`crate::flat`]) at once.
    pub fn build_with_progress(
        mesh: &TriMesh,
        params: &OvdfParams,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Self, VisError> {
        Self::build_as(mesh, params, progress, true)
    }

    /// The sampled field of any mesh, flat or not (for comparisons: [`Ovdf::build`] gives a
    /// flat convex mesh its closed form).
    pub fn build_sampled(
        mesh: &TriMesh,
        params: &OvdfParams,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Self, VisError> {
        Self::build_as(mesh, params, progress, false)
    }

    /// The field of `mesh`: the closed form where `closed_form` allows and the mesh is flat
    /// and convex, else sampled.
    fn build_as(
        mesh: &TriMesh,
        params: &OvdfParams,
        progress: &(dyn Fn(usize, usize) + Sync),
        closed_form: bool,
    ) -> Result<Self, VisError> {
        mesh.validate().map_err(|e| VisError::Mesh(e.to_string()))?;
        params.check()?;
        let (centre, radius) = mesh.bounding_sphere().unwrap_or_default();
        let radius = radius.max(f32::MIN_POSITIVE);
        if let Some(flat) = Flat::detect(mesh).filter(|_| closed_form) {
            progress(1, 1);
            return Self::from_flat(centre, radius, *params, flat).map_err(VisError::Params);
        }
        let occluder = Occluder::new(mesh)?;
        let grid = CubeGrid::new(params.m);
        let half = params.m / 2;
        let d = params.n * params.n;
        let mut segments = Vec::with_capacity(params.shells * 24);
        let (mut sq, mut count, mut raw_bytes) = (0.0f64, 0usize, 0usize);
        let (mut cov_sq, mut cov_count) = (0.0f64, 0usize);
        let mut rng = rsl_sphere::sampling::Pcg32::new(17);
        for s in 0..params.shells {
            let r = shell_radius(s, params.shells) * radius;
            for face in 0..6 {
                for (qx, qy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    // One segment: trace, compress, drop.
                    let samples: Vec<Vec<f32>> = (0..half * half)
                        .into_par_iter()
                        .map(|k| {
                            let (a, b) = (k % half, k / half);
                            let t = grid.index(face, qx * half + a, qy * half + b);
                            let u = grid.texel_dir(t);
                            let q = centre + u * r;
                            let frame = Frame::from_normal(-u);
                            // The object lies inside the cone of half-angle asin(R/r) around the
                            // sample's pole (its centre's direction): rays outside it cannot hit.
                            let cos_cone = if r > radius { (1.0 - (radius / r).powi(2)).sqrt() } else { -1.0 };
                            let map = VisibilityMap::from_fn_with_horizon(params.n, params.supersample, true, |l| {
                                l.z < cos_cone || !occluder.occluded(q, frame.to_world(l), r + 2.0 * radius)
                            });
                            map.vdt().values().to_vec()
                        })
                        .collect();
                    let raw: Vec<f32> = samples.concat();
                    progress(s * 24 + face * 4 + qy * 2 + qx + 1, params.shells * 24);
                    let pca = Cpca::fit(&raw, d, 1, params.vectors, 0, (s * 24 + face * 4 + qy * 2 + qx) as u64);
                    let mut rec = vec![0.0f32; d];
                    for v in 0..half * half {
                        pca.reconstruct_into(v, &mut rec);
                        sq += rec
                            .iter()
                            .zip(&raw[v * d..(v + 1) * d])
                            .map(|(a, b)| f64::from(a - b).powi(2))
                            .sum::<f64>();
                    }
                    // Coverage of a few random squares per segment, compressed vs raw.
                    for _ in 0..8 {
                        let v = rng.next_u32() as usize % (half * half);
                        let p = Vec2::new(rng.next_f32() * 1.6 - 0.8, rng.next_f32() * 1.6 - 0.8);
                        let rr = 0.02 + 0.18 * rng.next_f32();
                        let a = coverage(bilinear_cells(params.n, p, |k| raw[v * d + k]), rr);
                        let b = coverage(bilinear_cells(params.n, p, |k| pca.value(v, k)), rr);
                        cov_sq += f64::from(a - b).powi(2);
                        cov_count += 1;
                    }
                    count += raw.len();
                    raw_bytes += raw.len() * 4;
                    segments.push(pca);
                }
            }
        }
        let bytes_f32 = segments.iter().map(|c| c.bytes(4)).sum();
        let bytes_f16 = segments.iter().map(|c| c.bytes(2)).sum();
        let rms_distance_error = (sq / count.max(1) as f64).sqrt() as f32;
        let rms_coverage_error = (cov_sq / cov_count.max(1) as f64).sqrt() as f32;
        Self::from_parts(
            centre,
            radius,
            *params,
            segments,
            [raw_bytes, bytes_f32, bytes_f16],
            [rms_distance_error, rms_coverage_error],
        )
        .map_err(VisError::Params)
    }

    /// Bytes held as stored: every segment's PCA and the texel frames, or a flat object's
    /// outline.
    pub fn bytes(&self) -> usize {
        self.segments.iter().map(Cpca::stored_bytes).sum::<usize>()
            + std::mem::size_of_val(self.frames.as_slice())
            + self.flat.as_ref().map_or(0, |f| std::mem::size_of_val(f.corners()) + 16)
    }

    /// The closed form of a flat convex object, whose field has no segments.
    pub fn flat(&self) -> Option<&Flat> {
        self.flat.as_ref()
    }

    /// The field of a flat convex object: its closed form, built around the object's bounding
    /// sphere (`params` are kept to say what was asked for; no samples are taken).
    pub fn from_flat(centre: Vec3, radius: f32, params: OvdfParams, flat: Flat) -> Result<Self, String> {
        params.check().map_err(|e| e.to_string())?;
        if !(centre.is_finite() && radius.is_finite() && radius > 0.0) {
            return Err(format!(
                "bad bounding sphere (centre {centre}, radius {radius}): it must be finite with a positive radius"
            ));
        }
        Ok(Self {
            centre,
            radius,
            params,
            segments: Vec::new(),
            frames: Vec::new(),
            flat: Some(flat),
            whole: false,
            raw_bytes: 0,
            bytes_f32: 0,
            bytes_f16: 0,
            rms_distance_error: 0.0,
            rms_coverage_error: 0.0,
        })
    }

    /// Resolutions the field was built with.
    pub fn params(&self) -> &OvdfParams {
        &self.params
    }

    /// The PCA of each segment (`shells × 24`, shell-major, then face, then quadrant).
    pub fn segments(&self) -> &[Cpca] {
        &self.segments
    }

    /// Reassembles a field from its parts (as read from a file); checks their consistency.
    pub fn from_parts(
        centre: Vec3,
        radius: f32,
        params: OvdfParams,
        segments: Vec<Cpca>,
        bytes: [usize; 3],
        errors: [f32; 2],
    ) -> Result<Self, String> {
        let half = params.m / 2;
        params.check().map_err(|e| e.to_string())?;
        if segments.len() != params.shells * 24 {
            return Err(format!("{} segments for {} shells", segments.len(), params.shells));
        }
        if let Some(bad) = segments
            .iter()
            .position(|c| c.d != params.n * params.n || c.assignment.len() != half * half || c.clusters() != 1)
        {
            return Err(format!("segment {bad} does not match the resolutions"));
        }
        if !(centre.is_finite() && radius.is_finite() && radius > 0.0) {
            return Err(format!(
                "bad bounding sphere (centre {centre}, radius {radius}): it must be finite with a positive radius"
            ));
        }
        let ([raw_bytes, bytes_f32, bytes_f16], [rms_distance_error, rms_coverage_error]) = (bytes, errors);
        let grid = CubeGrid::new(params.m);
        let frames = (0..grid.len()).map(|t| Frame::from_normal(-grid.texel_dir(t))).collect();
        let d = params.n * params.n;
        let whole = params.n >= 2 && segments.iter().all(|c| c.vector(0).is_whole(d));
        Ok(Self {
            centre,
            radius,
            params,
            segments,
            frames,
            flat: None,
            whole,
            raw_bytes,
            bytes_f32,
            bytes_f16,
            rms_distance_error,
            rms_coverage_error,
        })
    }

    /// Bounding-sphere centre and radius the field is built around (object space).
    pub fn bounds(&self) -> (Vec3, f32) {
        (self.centre, self.radius)
    }

    /// Where `x` (object space) lies among the samples, or `None` beyond the outer shell
    /// (where nothing is occluded): computed once per point and reused for every direction.
    #[inline]
    pub fn locate(&self, x: Vec3) -> Option<OvdfPoint> {
        let v = x - self.centre;
        let r = v.length() / self.radius;
        if r >= OUTER {
            return None;
        }
        if self.flat.is_some() {
            return Some(OvdfPoint {
                x,
                shell: 0,
                shell_weight: 0.0,
                texels: [0; 4],
                places: [(0, 0); 4],
                weights: [0.0; 4],
            });
        }
        let shells = self.params.shells;
        let t = if r > INNER { (r / INNER).ln() / (OUTER / INNER).ln() * (shells - 1) as f32 } else { 0.0 };
        let s0 = (t.floor() as usize).min(shells - 2);
        let fs = (t - s0 as f32).clamp(0.0, 1.0);
        let m = self.params.m;
        let grid = CubeGrid::new(m);
        let u = if v.length_squared() > 0.0 { v.normalize() } else { Vec3::Y };
        let (texels, weights) = grid.bilinear(u.as_dvec3());
        let half = m / 2;
        // Each texel's place: its segment within a shell (face·4 + quadrant) and its index there.
        let places = texels.map(|t| {
            let (f, i, j) = grid.coords(t);
            let (qi, qj) = (usize::from(i >= half), usize::from(j >= half));
            ((f * 4 + qj * 2 + qi) as u32, ((j - qj * half) * half + i - qi * half) as u32)
        });
        Some(OvdfPoint { x, shell: s0, shell_weight: fs, texels, places, weights })
    }

    /// The signed distance at a located point for light from `dir` (object space):
    /// trilinear over its 8 samples.
    pub fn distance_at(&self, at: &OvdfPoint, dir: Vec3) -> f32 {
        self.prepare(at).distance(dir)
    }

    /// Everything the lookups at a located point read, gathered once: the four texels'
    /// sample frames, and each of the 8 samples' rows, coefficients and trilinear weight.
    #[inline]
    pub fn prepare(&self, at: &OvdfPoint) -> OvdfLookup<'_> {
        if let Some(flat) = &self.flat {
            return OvdfLookup(Lookup::Flat(flat.prepare(at.x)));
        }
        let w = at.shell_weight;
        let shells = if w <= 0.0 { 1 } else { 2 };
        let n = self.params.n;
        let mut axes = [[0.0f32; 4]; 9];
        for (t, &texel) in at.texels.iter().enumerate() {
            let f = &self.frames[texel];
            for (k, v) in [f.t, f.b, f.n].iter().enumerate() {
                axes[3 * k][t] = v.x;
                axes[3 * k + 1][t] = v.y;
                axes[3 * k + 2][t] = v.z;
            }
        }
        // The outer shell's samples repeat the inner ones (with zero weight) when unused.
        let outer = if shells == 2 { 1 } else { 0 };
        let (w_inner, w_outer) = if shells == 2 { (1.0 - w, w) } else { (1.0, 0.0) };
        let sample = |k: usize| {
            let t = k % 4;
            let (segment, index) = at.places[t];
            let (s, weight) = if k < 4 { (at.shell, w_inner) } else { (at.shell + outer, w_outer) };
            (self.segments[s * 24 + segment as usize].vector(index as usize), weight * at.weights[t])
        };
        let samples = [sample(0), sample(1), sample(2), sample(3), sample(4), sample(5), sample(6), sample(7)];
        OvdfLookup(Lookup::Sampled(SampledLookup { n, shells, axes, samples, whole: self.whole }))
    }

    /// The signed distance (visible > 0) to this object's shadow boundary for light from
    /// direction `dir` at point `x`, both in the object's space: trilinear over the 8
    /// nearest samples. Beyond the outer shell: far (nothing occluded).
    pub fn distance(&self, x: Vec3, dir: Vec3) -> f32 {
        match self.locate(x) {
            Some(at) => self.distance_at(&at, dir),
            None => FAR,
        }
    }

    /// The visible fraction of the square of half-diagonal `r` around `dir` at a located
    /// point.
    pub fn coverage_at(&self, at: &OvdfPoint, dir: Vec3, r: f32) -> f32 {
        coverage(self.distance_at(at, dir), r)
    }

    /// The visible fraction of the rotatable square of half-diagonal `r` around light
    /// direction `dir` at point `x` (object space).
    pub fn coverage(&self, x: Vec3, dir: Vec3, r: f32) -> f32 {
        coverage(self.distance(x, dir), r)
    }
}

/// A located point of an occluder field prepared for lookups in many directions
/// ([`Ovdf::prepare`]).
#[derive(Clone, Copy, Debug)]
pub struct OvdfLookup<'a>(Lookup<'a>);

// Both variants are a few hundred bytes and live in reused per-thread lists: boxing the
// larger would allocate per vertex and occluder.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
enum Lookup<'a> {
    Sampled(SampledLookup<'a>),
    Flat(FlatLookup),
}

/// A point prepared among a sampled field's samples.
#[derive(Clone, Copy, Debug)]
struct SampledLookup<'a> {
    n: usize,
    /// 1 when the point lies on the inner shell (its outer weight is zero), else 2.
    shells: usize,
    /// The four texels' sample frames, by component across the texels: `t.x, t.y, t.z, b.x,
    /// …, n.z`, each for texels 0–3.
    axes: [[f32; 4]; 9],
    /// Inner shell's four texels, then the outer shell's, each with its trilinear weight.
    samples: [(CpcaVector<'a>, f32); 8],
    /// The field's [`Ovdf`] `whole`: the vector kernel may read its samples without bounds
    /// checks.
    whole: bool,
}

impl OvdfLookup<'_> {
    /// The signed distance for light from `dir` (object space): trilinear over the 8
    /// samples (each texel's plane point and bilinear cells are shared by both shells), or a
    /// flat object's closed form.
    pub fn distance(&self, dir: Vec3) -> f32 {
        match &self.0 {
            Lookup::Sampled(s) => lookup_distance(s, dir),
            Lookup::Flat(f) => f.distance(dir),
        }
    }

    /// The visible fraction of the square of half-diagonal `r` around `dir`.
    #[inline]
    pub fn coverage(&self, dir: Vec3, r: f32) -> f32 {
        coverage(self.distance(dir), r)
    }
}

impl SampledLookup<'_> {
    /// Texel `t`'s local coordinates of `dir`.
    fn texel_local(&self, t: usize, d: Vec3) -> Vec3 {
        let a = &self.axes;
        let dot = |k: usize| d.x * a[k][t] + d.y * a[k + 1][t] + d.z * a[k + 2][t];
        Vec3::new(dot(0), dot(3), dot(6))
    }
}

/// [`OvdfLookup::distance`]: AVX2 and FMA where the processor has them.
fn lookup_distance(at: &SampledLookup<'_>, dir: Vec3) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if at.whole && crate::cpca::simd::available() {
        #[allow(unsafe_code)]
        // SAFETY: the processor has AVX2 and FMA (checked at run time just above).
        return unsafe { lookup_distance_avx2(at, dir) };
    }
    lookup_distance_portable(at, dir)
}

/// [`lookup_distance`] in portable code.
fn lookup_distance_portable(at: &SampledLookup<'_>, dir: Vec3) -> f32 {
    let mut acc = [0.0f32; 8];
    let mut mean = 0.0f32;
    for t in 0..4 {
        let (cells, w) = bilinear_taps(at.n, hemi_from_dir(at.texel_local(t, dir)));
        for shell in 0..at.shells {
            let (v, weight) = &at.samples[shell * 4 + t];
            mean += v.blend_into(&mut acc, cells, w.map(|x| x * weight));
        }
    }
    mean + hsum(acc)
}

/// [`lookup_distance`] in AVX2 and FMA: the four texels' plane points and bilinear taps
/// four at a time, then each sample's rows blended in vector registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn lookup_distance_avx2(at: &SampledLookup<'_>, dir: Vec3) -> f32 {
    use std::arch::x86_64::*;
    let a = &at.axes;
    let v = |k: usize| -> __m128 { bytemuck::cast(a[k]) };
    let (dx, dy, dz) = (_mm_set1_ps(dir.x), _mm_set1_ps(dir.y), _mm_set1_ps(dir.z));
    // Local coordinates per texel (Frame::to_local), then hemi_from_dir, four at once.
    let lx = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, v(0)), _mm_mul_ps(dy, v(1))), _mm_mul_ps(dz, v(2)));
    let ly = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, v(3)), _mm_mul_ps(dy, v(4))), _mm_mul_ps(dz, v(5)));
    let lz = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, v(6)), _mm_mul_ps(dy, v(7))), _mm_mul_ps(dz, v(8)));
    let (one, zero) = (_mm_set1_ps(1.0), _mm_setzero_ps());
    let upper = _mm_cmpge_ps(lz, zero);
    let s = _mm_sqrt_ps(_mm_add_ps(one, lz));
    let r = _mm_sqrt_ps(_mm_add_ps(_mm_mul_ps(lx, lx), _mm_mul_ps(ly, ly)));
    let f = _mm_div_ps(_mm_sqrt_ps(_mm_max_ps(_mm_sub_ps(one, lz), zero)), r);
    let off_pole = _mm_cmpgt_ps(r, zero);
    let lower_x = _mm_blendv_ps(_mm_set1_ps(rsl_sphere::hemi::MAX_RADIUS), _mm_mul_ps(lx, f), off_pole);
    let lower_y = _mm_blendv_ps(zero, _mm_mul_ps(ly, f), off_pole);
    let px = _mm_blendv_ps(lower_x, _mm_div_ps(lx, s), upper);
    let py = _mm_blendv_ps(lower_y, _mm_div_ps(ly, s), upper);
    // bilinear_taps: the cell below and left among the centres (NaN clamps to 0 here).
    let n = at.n;
    let (nf, top) = (_mm_set1_ps(n as f32), _mm_set1_ps((n - 1) as f32));
    let grid = |p: __m128| {
        let g = _mm_sub_ps(_mm_mul_ps(_mm_mul_ps(_mm_add_ps(p, one), _mm_set1_ps(0.5)), nf), _mm_set1_ps(0.5));
        let g = _mm_min_ps(_mm_max_ps(g, zero), top);
        let i = _mm_min_epi32(_mm_cvttps_epi32(g), _mm_set1_epi32(n as i32 - 2));
        (i, _mm_sub_ps(g, _mm_cvtepi32_ps(i)))
    };
    let ((ix, fx), (iy, fy)) = (grid(px), grid(py));
    let base: [i32; 4] = bytemuck::cast(_mm_add_epi32(_mm_mullo_epi32(iy, _mm_set1_epi32(n as i32)), ix));
    let (gx, gy) = (_mm_sub_ps(one, fx), _mm_sub_ps(one, fy));
    let weights: [[f32; 4]; 4] = [
        bytemuck::cast(_mm_mul_ps(gx, gy)),
        bytemuck::cast(_mm_mul_ps(fx, gy)),
        bytemuck::cast(_mm_mul_ps(gx, fy)),
        bytemuck::cast(_mm_mul_ps(fx, fy)),
    ];
    let mut acc = _mm256_setzero_ps();
    let mut mean = 0.0f32;
    for t in 0..4 {
        // Every index is below n²: i, j ≤ n − 2 after the clamps above.
        let b = base[t] as usize;
        let cells = [b, b + 1, b + n, b + n + 1];
        for shell in 0..at.shells {
            let (v, weight) = &at.samples[shell * 4 + t];
            let w = [weights[0][t] * weight, weights[1][t] * weight, weights[2][t] * weight, weights[3][t] * weight];
            // `at.whole` (checked by the caller) says every sample is whole for n².
            mean += crate::cpca::simd::blend!(v, acc, cells, w);
        }
    }
    mean + crate::cpca::simd::sum(acc)
}

/// Radius of shell `s` of `shells`, in bounding radii.
pub fn shell_radius(s: usize, shells: usize) -> f32 {
    INNER * (OUTER / INNER).powf(s as f32 / (shells - 1) as f32)
}

/// The plane point of `dir` in the frame of the sample facing the centre from direction `u`
/// (exposed for tests that build the same frame).
pub fn sample_plane_point(u: Vec3, dir: Vec3) -> Vec2 {
    hemi_from_dir(Frame::from_normal(-u).to_local(dir))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rsl_sphere::sampling::Pcg32;

    /// A field of random segments (no geometry): 3 shells of 6×4×4 samples with 8×8 tables,
    /// `k` vectors per segment.
    fn random_field(k: usize, seed: u64) -> Ovdf {
        let params = OvdfParams { shells: 3, m: 4, n: 8, supersample: 1, vectors: k };
        let mut rng = Pcg32::new(seed);
        let segments = (0..params.shells * 24)
            .map(|s| {
                let data: Vec<f32> = (0..4 * 64).map(|_| rng.next_f32() * 2.0 - 1.0).collect();
                Cpca::fit(&data, 64, 1, k, 0, s as u64)
            })
            .collect();
        Ovdf::from_parts(Vec3::new(0.1, -0.2, 0.3), 0.7, params, segments, [0; 3], [0.0; 2]).unwrap()
    }

    /// The distance at a located point written out independently: 8 samples, each
    /// reconstructed cell by cell (`Cpca::value`) and read bilinearly in its own frame.
    fn distance_by_cells(f: &Ovdf, at: &OvdfPoint, dir: Vec3) -> f32 {
        let n = f.params.n;
        let shell = |s: usize| -> f32 {
            (0..4)
                .map(|t| {
                    let (segment, index) = at.places[t];
                    let cpca = &f.segments[s * 24 + segment as usize];
                    let p = hemi_from_dir(f.frames[at.texels[t]].to_local(dir));
                    at.weights[t] * bilinear_cells(n, p, |c| cpca.value(index as usize, c))
                })
                .sum()
        };
        shell(at.shell) * (1.0 - at.shell_weight) + shell(at.shell + 1) * at.shell_weight
    }

    #[test]
    fn lookups_match_the_tables_cell_by_cell_on_every_path() {
        // k = 8 fills one lane; k = 5 pads one; k = 12 takes two.
        for (k, seed) in [(8, 1), (5, 2), (12, 3)] {
            let f = random_field(k, seed);
            let mut rng = Pcg32::new(seed + 10);
            let mut worst = 0.0f32;
            for _ in 0..400 {
                let u = rsl_sphere::sampling::uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                // Points across the shells (inside the inner one too), directions anywhere.
                let x = f.centre + u * f.radius * (0.2 + 6.0 * rng.next_f32());
                let dir = rsl_sphere::sampling::uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let Some(at) = f.locate(x) else { continue };
                let want = distance_by_cells(&f, &at, dir);
                let OvdfLookup(Lookup::Sampled(prepared)) = f.prepare(&at) else { panic!("a sampled field") };
                for got in [lookup_distance(&prepared, dir), lookup_distance_portable(&prepared, dir)] {
                    worst = worst.max((got - want).abs() / want.abs().max(1.0));
                }
            }
            assert!(worst < 2e-5, "k = {k}: worst difference {worst}");
        }
    }

    #[test]
    fn located_places_agree_with_the_grid_across_seams() {
        let f = random_field(4, 5);
        let grid = CubeGrid::new(f.params.m);
        let half = f.params.m / 2;
        let mut rng = Pcg32::new(9);
        for _ in 0..2000 {
            let u = rsl_sphere::sampling::uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let at = f.locate(f.centre + u * f.radius).unwrap();
            for (t, place) in at.texels.iter().zip(at.places) {
                let (face, i, j) = grid.coords(*t);
                let want = ((face * 4 + (j / half) * 2 + i / half) as u32, ((j % half) * half + i % half) as u32);
                assert_eq!(place, want);
            }
        }
    }
}

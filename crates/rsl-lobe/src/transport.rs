//! Transport lobes (Green et al. 2006, §3–5): per vertex and per view, the transport
//! `ρ(ω, v)·cos θ·V_self(ω)` as weighted vMF lobes, the views fixed in object space (a
//! geodesic sphere: 92 views at frequency 3, Green's count), so that an object rotates freely.
//!
//! **Fit.** Green fits the sampled transport of each view by nonlinear optimisation, with
//! terms that align corresponding lobes across views and vertices. Here each transport lobe
//! is one of the material's lobes ([`MaterialLobes`], fitted to `ρ·cos` per view by
//! Laurijssen's estimator) shadowed by the object itself and refitted, so lobe `k` of every
//! view and vertex comes from the same material lobe and corresponds by construction (the
//! role of Green's alignment terms). For a material lobe `α·γ_{μ,κ}` in the vertex's frame,
//! `S` stratified samples `ω_s` of `γ` above the shading horizon are weighted by the
//! visibility `h_s = V_self(ω_s) ∈ [0, 1]`, and:
//! - the weight is `α·Σh_s/S⁺` (the visible share of the lobe above the horizon, `S⁺` the
//!   samples there);
//! - the mean is turned by the rotation that takes the samples' unshadowed mean direction to
//!   their visibility-weighted one;
//! - `κ` is the one whose mean cosine deficit `g(κ) = E[1 − μ·ω] = 1 − coth κ + 1/κ` is
//!   `g(κ)` times the ratio of the weighted samples' deficit (about their mean) to the
//!   unshadowed samples' (Laurijssen's eq. 13 matches the same moment; the ratio cancels the
//!   samples' own error, and the horizon's cut).
//!
//! With `V_self = 1` every ratio is exactly 1 and the transport lobes are the material lobes.
//! A view below a vertex's horizon takes the lobes of the view just above the horizon at the
//! same azimuth. Green gives those views zero weight, which darkens every view within a
//! view spacing (0.3 rad at 92 views) of the horizon as it interpolates toward them; no view
//! below the horizon is drawn (the vertex faces away), so they serve interpolation alone. A
//! lobe wholly shadowed keeps its shape with zero weight.
//!
//! **Diffuse part.** The material's diffuse lobe (a cosine lobe about the normal) is shadowed
//! and refitted the same way, once per vertex (it does not depend on the view): a lobe about
//! the vertex's unoccluded direction, the "bent normal", with the visible share as weight.
//!
//! **Rendering.** [`TransportLobes::lobes_at`] interpolates the lobes of the three views
//! around the current one (barycentric weights on their geodesic triangle), lobe by lobe:
//! the weight and the mean (a normalised blend) linearly, `κ` weighted by each view's weight
//! too (the mean direction, not the radiance, as Green interpolates); one prefiltered lookup
//! per lobe follows. What is drawn ([`TransportLobes::lobes_following`]) scales the specular
//! lobes' weights by the material's own amplitude at the view over the same interpolation of
//! the unshadowed amplitudes: across the views only the visible share is interpolated, and
//! the amplitude, which changes fast near grazing, is the material's at the view. Each
//! view's lobes are those of the material's tabulated view nearest it,
//! turned to it ([`MaterialLobes::nearest_specular_lobes`]): lobe `k` is the same lobe at
//! every view near one tabulated view, and at views near the next a lobe of similar share.

use crate::material::{MaterialLobes, SPECULAR_LOBES, WeightedLobe};
use crate::vmf::Vmf;
use glam::{DVec3, Mat3, Quat, Vec2, Vec3};
use rayon::prelude::*;
use rsl_sphere::Frame;

/// The version of the fit ([`TransportLobes::fit`] and the material fit it starts from): a
/// cache of fitted lobes keys on it, and it changes whenever what a fit gives does.
pub const FIT_VERSION: u32 = 1;

/// The highest geodesic frequency [`TransportLobes::from_payload`] reads (2,562 views).
pub const MAX_FREQUENCY: u32 = 16;

/// Bytes of [`TransportLobes::to_payload`]'s header: frequency, lobes per view, vertices.
const PAYLOAD_HEADER: usize = 16;

/// Bytes of one lobe in [`TransportLobes::to_payload`]: weight, mean and `κ`, 7 × f32.
const LOBE_BYTES: usize = 28;

/// How transport lobes are fitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TransportParams {
    /// Geodesic frequency of the views: `10ν² + 2` views (3: 92).
    pub frequency: u32,
    /// Stratified samples per specular lobe (a square number is used: `⌈√S⌉²`).
    pub samples: usize,
    /// Stratified samples for the diffuse lobe.
    pub diffuse_samples: usize,
}

impl Default for TransportParams {
    fn default() -> Self {
        Self { frequency: 3, samples: 64, diffuse_samples: 256 }
    }
}

/// The views of a geodesic sphere of frequency `nu ≥ 1`: each face of an icosahedron split
/// into `ν²` triangles, the `10ν² + 2` distinct corners projected to the unit sphere.
pub fn geodesic_views(nu: u32) -> Vec<Vec3> {
    geodesic(nu).0
}

/// [`geodesic_views`] and the `20ν²` triangles between them (counter-clockwise seen from
/// outside).
pub fn geodesic(nu: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let nu = nu.max(1);
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let corners: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    const FACES: [[usize; 3]; 20] = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut views: Vec<DVec3> = Vec::new();
    let mut triangles = Vec::with_capacity(20 * (nu * nu) as usize);
    let n = f64::from(nu);
    for [a, b, c] in FACES {
        let (a, b, c) = (corners[a], corners[b], corners[c]);
        // The index of grid point (i, j) of this face, i + j ≤ ν.
        let mut index = vec![0u32; ((nu + 1) * (nu + 1)) as usize];
        for i in 0..=nu {
            for j in 0..=nu - i {
                let p = (a + (b - a) * (f64::from(i) / n) + (c - a) * (f64::from(j) / n)).normalize();
                // Points shared by faces come out equal to rounding; the closest distinct
                // views are ~0.3/ν radians apart.
                let k = match views.iter().position(|q| q.distance_squared(p) < 1e-12) {
                    Some(k) => k,
                    None => {
                        views.push(p);
                        views.len() - 1
                    }
                };
                index[(i * (nu + 1) + j) as usize] = k as u32;
            }
        }
        let at = |i: u32, j: u32| index[(i * (nu + 1) + j) as usize];
        for i in 0..nu {
            for j in 0..nu - i {
                triangles.push([at(i, j), at(i + 1, j), at(i, j + 1)]);
                if i + j + 1 < nu {
                    triangles.push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
        }
    }
    (views.into_iter().map(|v| v.as_vec3()).collect(), triangles)
}

/// Where a view falls among the geodesic views: the spherical triangle holding it.
#[derive(Clone, Debug)]
struct ViewLocator {
    triangles: Vec<[u32; 3]>,
    /// Per triangle, the inverse of the matrix of its corners (barycentric weights of a
    /// direction, up to scale).
    inverses: Vec<Mat3>,
    /// Per view, the triangles around it.
    around: Vec<Vec<u32>>,
}

impl ViewLocator {
    fn new(views: &[Vec3], triangles: Vec<[u32; 3]>) -> Self {
        let inverses = triangles
            .iter()
            .map(|t| Mat3::from_cols(views[t[0] as usize], views[t[1] as usize], views[t[2] as usize]).inverse())
            .collect();
        let mut around = vec![Vec::new(); views.len()];
        for (k, t) in triangles.iter().enumerate() {
            for &c in t {
                around[c as usize].push(k as u32);
            }
        }
        Self { triangles, inverses, around }
    }

    /// The weights of `view` on triangle `k`, normalised to sum 1, and the most negative of
    /// them before clamping (≥ 0 inside).
    fn weights(&self, k: usize, view: Vec3) -> (Vec3, f32) {
        let w = self.inverses[k] * view;
        let sum = w.element_sum();
        if sum <= 0.0 {
            return (Vec3::X, f32::NEG_INFINITY);
        }
        let w = w / sum;
        (w, w.min_element())
    }

    /// The triangle holding unit `view` and its barycentric weights: among the triangles
    /// around the nearest view first (where it lies but for rounding), else among all.
    fn locate(&self, nearest: usize, view: Vec3) -> ([u32; 3], Vec3) {
        let best = |ks: &mut dyn Iterator<Item = usize>| {
            ks.map(|k| (k, self.weights(k, view))).max_by(|a, b| a.1.1.total_cmp(&b.1.1)).expect("triangles")
        };
        let (mut k, (mut w, worst)) = best(&mut self.around[nearest].iter().map(|&k| k as usize));
        if worst < -1e-5 {
            (k, (w, _)) = best(&mut (0..self.triangles.len()));
        }
        let w = w.max(Vec3::ZERO);
        (self.triangles[k], w / w.element_sum())
    }
}

/// `g(κ) = E[1 − μ·ω]` for `ω` drawn from a vMF of concentration `κ`: `1 − coth κ + 1/κ`.
fn deficit(kappa: f64) -> f64 {
    if kappa < 1e-4 {
        1.0 - kappa / 3.0
    } else if kappa > 30.0 {
        // coth κ = 1 to within e^{−60}.
        1.0 / kappa
    } else {
        1.0 - 1.0 / kappa.tanh() + 1.0 / kappa
    }
}

/// The `κ` with `g(κ) = target` (`g` falls from 1 at `κ = 0`); within `[0, 10⁷]`.
fn kappa_of_deficit(target: f64) -> f64 {
    if target >= 1.0 {
        return 0.0;
    }
    if target <= 1e-7 {
        return 1e7;
    }
    if target < 1.0 / 30.0 {
        return 1.0 / target;
    }
    let (mut lo, mut hi) = (1e-4f64.ln(), 30f64.ln());
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if deficit(mid.exp()) > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)).exp()
}

/// `lobe` (in the local frame: normal +z) shadowed by `visible` (local directions, values in
/// `[0, 1]`) and refitted from `k×k` stratified samples (see the module's text).
fn shadowed(lobe: &WeightedLobe, k: usize, visible: &impl Fn(Vec3) -> f32) -> WeightedLobe {
    if lobe.weight == Vec3::ZERO {
        return *lobe;
    }
    let (mut above, mut seen) = (0usize, 0.0f64);
    let (mut m_all, mut m_seen) = (DVec3::ZERO, DVec3::ZERO);
    let mut samples: Vec<(DVec3, f64)> = Vec::with_capacity(k * k);
    for j in 0..k {
        for i in 0..k {
            // Stratified with a fixed jitter (the fit is deterministic).
            let jitter = |a: usize, b: usize| ((a * 7919 + b * 104_729) % 1000) as f32 / 1000.0;
            let u = Vec2::new((i as f32 + jitter(i, j)) / k as f32, (j as f32 + jitter(j, i)) / k as f32);
            let w = lobe.lobe.sample(u.x, u.y);
            if w.z <= 0.0 {
                continue;
            }
            let h = f64::from(visible(w).clamp(0.0, 1.0));
            let d = w.as_dvec3();
            above += 1;
            seen += h;
            m_all += d;
            m_seen += d * h;
            samples.push((d, h));
        }
    }
    if above == 0 || seen <= 0.0 {
        return WeightedLobe { weight: Vec3::ZERO, ..*lobe };
    }
    let (dir_all, dir_seen) = (m_all.normalize(), m_seen.normalize());
    let d_all = samples.iter().map(|(d, _)| 1.0 - d.dot(dir_all)).sum::<f64>() / above as f64;
    let d_seen = samples.iter().map(|(d, h)| h * (1.0 - d.dot(dir_seen))).sum::<f64>() / seen;
    let kappa = f64::from(lobe.lobe.kappa);
    let kappa = if d_all > 0.0 { kappa_of_deficit(deficit(kappa) * d_seen / d_all) } else { kappa };
    let turn = Quat::from_rotation_arc(dir_all.as_vec3(), dir_seen.as_vec3());
    WeightedLobe {
        weight: lobe.weight * (seen / above as f64) as f32,
        lobe: Vmf::new(turn * lobe.lobe.mean, kappa as f32),
    }
}

/// One object's transport lobes: per vertex and per view, the specular lobes; per vertex, the
/// diffuse lobe. Object space.
#[derive(Clone, Debug)]
pub struct TransportLobes {
    /// The geodesic frequency of the views ([`TransportParams::frequency`], at least 1).
    frequency: u32,
    views: Vec<Vec3>,
    locator: ViewLocator,
    /// Specular lobes per view (0 without a specular part, else [`SPECULAR_LOBES`]).
    per_view: usize,
    /// `[vertex][view][lobe]`, flattened.
    specular: Vec<WeightedLobe>,
    /// Per vertex, when the material has a diffuse term.
    diffuse: Vec<Option<WeightedLobe>>,
}

impl TransportLobes {
    /// Bytes one vertex takes at `params` (for a budget check before fitting).
    pub fn bytes_per_vertex(material: &MaterialLobes, params: &TransportParams) -> usize {
        let views = 10 * params.frequency.max(1) as usize * params.frequency.max(1) as usize + 2;
        let per_view = if material.brdf().is_lambertian() { 0 } else { SPECULAR_LOBES };
        (views * per_view + 1) * std::mem::size_of::<WeightedLobe>()
    }

    /// Fits the transport lobes of an object of `material` whose vertices have shading frames
    /// `frames` (object space), `visible(v, d)` the self-visibility of vertex `v` toward
    /// object-space direction `d` (in `[0, 1]`). `progress(done, total)` is called as
    /// vertices finish.
    pub fn fit(
        material: &MaterialLobes,
        frames: &[Frame],
        params: &TransportParams,
        visible: impl Fn(usize, Vec3) -> f32 + Sync,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Self {
        let frequency = params.frequency.max(1);
        let (views, triangles) = geodesic(frequency);
        let locator = ViewLocator::new(&views, triangles);
        let per_view = if material.brdf().is_lambertian() { 0 } else { SPECULAR_LOBES };
        let k = (params.samples as f64).sqrt().ceil().max(1.0) as usize;
        let kd = (params.diffuse_samples as f64).sqrt().ceil().max(1.0) as usize;
        let done = std::sync::atomic::AtomicUsize::new(0);
        let total = frames.len();
        let fitted: Vec<(Vec<WeightedLobe>, Option<WeightedLobe>)> = frames
            .par_iter()
            .enumerate()
            .map(|(v, frame)| {
                let vis = |d: Vec3| visible(v, frame.to_world(d));
                let mut spec = Vec::with_capacity(views.len() * per_view);
                for &view in &views {
                    if per_view == 0 {
                        break;
                    }
                    let local = frame.to_local(view);
                    // Below the horizon: the lobes of the view just above it, so that views
                    // near the horizon interpolate toward it instead of fading (no view below
                    // the horizon is drawn: the vertex faces away).
                    let lobes = material
                        .nearest_specular_lobes(shown_view(local))
                        .unwrap_or([WeightedLobe { weight: Vec3::ZERO, lobe: Vmf::new(Vec3::Z, 1.0) }; SPECULAR_LOBES]);
                    for lobe in lobes {
                        let fitted = shadowed(&lobe, k, &vis);
                        spec.push(WeightedLobe { weight: fitted.weight, lobe: frame_lobe(frame, fitted.lobe) });
                    }
                }
                let diffuse = material.diffuse_lobe().map(|d| {
                    let s = shadowed(&d, kd, &vis);
                    WeightedLobe { lobe: frame_lobe(frame, s.lobe), ..s }
                });
                let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                if n.is_multiple_of(1024) || n == total {
                    progress(n, total);
                }
                (spec, diffuse)
            })
            .collect();
        let mut specular = Vec::with_capacity(total * views.len() * per_view);
        let mut diffuse = Vec::with_capacity(total);
        for (s, d) in fitted {
            specular.extend(s);
            diffuse.push(d);
        }
        Self { frequency, views, locator, per_view, specular, diffuse }
    }

    /// The lobes as bytes, little-endian, for a cache file (which frames them with a checksum
    /// and the key they were fitted for): the frequency, the specular lobes per view, the
    /// vertex count, every vertex's specular lobes (`[vertex][view][lobe]`), one byte per
    /// vertex saying whether it has a diffuse lobe, then those diffuse lobes; a lobe is its
    /// weight (3 × f32), mean (3 × f32) and `κ`. [`TransportLobes::from_payload`] reads it
    /// back to the bit.
    pub fn to_payload(&self) -> Vec<u8> {
        let lobes = self.specular.len() + self.diffuse.iter().flatten().count();
        let mut out = Vec::with_capacity(PAYLOAD_HEADER + self.diffuse.len() + lobes * LOBE_BYTES);
        out.extend_from_slice(&self.frequency.to_le_bytes());
        out.extend_from_slice(&(self.per_view as u32).to_le_bytes());
        out.extend_from_slice(&(self.diffuse.len() as u64).to_le_bytes());
        let lobe = |out: &mut Vec<u8>, l: &WeightedLobe| {
            let (w, m) = (l.weight, l.lobe.mean);
            for x in [w.x, w.y, w.z, m.x, m.y, m.z, l.lobe.kappa] {
                out.extend_from_slice(&x.to_le_bytes());
            }
        };
        for l in &self.specular {
            lobe(&mut out, l);
        }
        out.extend(self.diffuse.iter().map(|d| u8::from(d.is_some())));
        for d in self.diffuse.iter().flatten() {
            lobe(&mut out, d);
        }
        out
    }

    /// Reads [`TransportLobes::to_payload`]'s bytes, checking every count against the
    /// length before anything is allocated, and every value (finite, `κ ≥ 0`). The views
    /// are the geodesic sphere of the stored frequency (at most [`MAX_FREQUENCY`]).
    pub fn from_payload(bytes: &[u8]) -> Result<Self, String> {
        if bytes.len() < PAYLOAD_HEADER {
            return Err(format!("{} bytes, shorter than the header ({PAYLOAD_HEADER})", bytes.len()));
        }
        let u32_at = |k: usize| u32::from_le_bytes(bytes[k..k + 4].try_into().expect("4 bytes"));
        let frequency = u32_at(0);
        if !(1..=MAX_FREQUENCY).contains(&frequency) {
            return Err(format!("frequency {frequency}, outside 1 to {MAX_FREQUENCY}"));
        }
        let per_view = u32_at(4) as usize;
        if per_view != 0 && per_view != SPECULAR_LOBES {
            return Err(format!("{per_view} specular lobes per view (0 or {SPECULAR_LOBES})"));
        }
        let vertices = u64::from_le_bytes(bytes[8..16].try_into().expect("8 bytes"));
        let views = 10 * frequency as u64 * frequency as u64 + 2;
        let too_long = || format!("{vertices} vertices do not fit in {} bytes", bytes.len());
        let specular = vertices.checked_mul(views * per_view as u64).ok_or_else(too_long)?;
        let flags_at = specular
            .checked_mul(LOBE_BYTES as u64)
            .and_then(|b| b.checked_add(PAYLOAD_HEADER as u64))
            .filter(|&b| b.saturating_add(vertices) <= bytes.len() as u64)
            .ok_or_else(too_long)? as usize;
        let (vertices, specular) = (vertices as usize, specular as usize);
        let flags = &bytes[flags_at..flags_at + vertices];
        if let Some(f) = flags.iter().find(|&&f| f > 1) {
            return Err(format!("a diffuse flag of {f} (0 or 1)"));
        }
        let diffuse_count = flags.iter().filter(|&&f| f == 1).count();
        let expected = flags_at + vertices + diffuse_count * LOBE_BYTES;
        if bytes.len() != expected {
            return Err(format!("{} bytes where the counts give {expected}", bytes.len()));
        }
        let lobe_at = |k: usize| -> Result<WeightedLobe, String> {
            let f = |i: usize| f32::from_le_bytes(bytes[k + 4 * i..k + 4 * i + 4].try_into().expect("4 bytes"));
            let l = WeightedLobe {
                weight: Vec3::new(f(0), f(1), f(2)),
                lobe: Vmf { mean: Vec3::new(f(3), f(4), f(5)), kappa: f(6) },
            };
            if l.weight.is_finite() && l.lobe.mean.is_finite() && l.lobe.kappa.is_finite() && l.lobe.kappa >= 0.0 {
                Ok(l)
            } else {
                Err(format!("a lobe with non-finite or negative values ({l:?})"))
            }
        };
        let specular = (0..specular).map(|j| lobe_at(PAYLOAD_HEADER + j * LOBE_BYTES)).collect::<Result<_, _>>()?;
        let mut next = flags_at + vertices;
        let diffuse = flags
            .iter()
            .map(|&f| {
                (f == 1)
                    .then(|| {
                        let l = lobe_at(next);
                        next += LOBE_BYTES;
                        l
                    })
                    .transpose()
            })
            .collect::<Result<_, _>>()?;
        let (views, triangles) = geodesic(frequency);
        let locator = ViewLocator::new(&views, triangles);
        Ok(Self { frequency, views, locator, per_view, specular, diffuse })
    }

    /// The specular lobes per view (0: the material has no specular part).
    pub fn specular_per_view(&self) -> usize {
        self.per_view
    }

    /// The views (object space).
    pub fn views(&self) -> &[Vec3] {
        &self.views
    }

    /// Vertices fitted.
    pub fn vertex_count(&self) -> usize {
        self.diffuse.len()
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.specular.as_slice()) + std::mem::size_of_val(self.diffuse.as_slice())
    }

    /// The specular lobes of vertex `v` at view number `j` (object space).
    pub fn at_view(&self, v: usize, j: usize) -> &[WeightedLobe] {
        let start = (v * self.views.len() + j) * self.per_view;
        &self.specular[start..start + self.per_view]
    }

    /// The diffuse lobe of vertex `v` (object space), if the material has a diffuse term.
    pub fn diffuse(&self, v: usize) -> Option<WeightedLobe> {
        self.diffuse[v]
    }

    /// The three views around unit object-space direction `view` (the geodesic triangle
    /// holding it), with its barycentric weights there (non-negative, summing to 1).
    pub fn nearest_views(&self, view: Vec3) -> [(usize, f32); 3] {
        let nearest = (0..self.views.len())
            .max_by(|&a, &b| self.views[a].dot(view).total_cmp(&self.views[b].dot(view)))
            .unwrap_or(0);
        let (t, w) = self.locator.locate(nearest, view);
        [(t[0] as usize, w.x), (t[1] as usize, w.y), (t[2] as usize, w.z)]
    }

    /// The lobes of vertex `v` for unit object-space view `view` into `out` (object space):
    /// each specular lobe interpolated across the three nearest views, then the diffuse lobe.
    pub fn lobes_at(&self, v: usize, view: Vec3, out: &mut Vec<WeightedLobe>) {
        let near = (self.per_view > 0).then(|| self.nearest_views(view));
        self.lobes_near(v, near.as_ref(), out);
    }

    /// [`TransportLobes::lobes_at`] for the three views `near` around the view (none for a
    /// material without specular lobes): the lobes into `out`, and how many of them are
    /// specular (the diffuse lobe, if any, follows them).
    fn lobes_near(&self, v: usize, near: Option<&[(usize, f32); 3]>, out: &mut Vec<WeightedLobe>) -> usize {
        out.clear();
        if let Some(near) = near {
            for k in 0..self.per_view {
                // The weight and the mean linearly (every view's lobe has a mean, weighted or
                // not: a reflection's direction is linear in the view); κ weighted by each
                // view's weight too, so that a lobe a view leaves empty (one lobe fitted
                // there, or wholly shadowed) lends its width to none.
                let (mut weight, mut mean, mut kappa, mut mass) = (Vec3::ZERO, Vec3::ZERO, 0.0f32, 0.0f32);
                for &(j, w) in near {
                    let l = self.at_view(v, j)[k];
                    let m = w * l.weight.element_sum();
                    weight += l.weight * w;
                    mean += l.lobe.mean * w;
                    kappa += l.lobe.kappa * m;
                    mass += m;
                }
                if mass > 0.0 {
                    let first = self.at_view(v, near[0].0)[k].lobe.mean;
                    out.push(WeightedLobe { weight, lobe: Vmf::new(mean.normalize_or(first), kappa / mass) });
                }
            }
        }
        let specular = out.len();
        out.extend(self.diffuse[v].filter(|d| d.weight != Vec3::ZERO));
        specular
    }

    /// [`TransportLobes::lobes_at`] with the specular lobes' weights scaled, per channel, by
    /// the material's unshadowed specular weight at the view itself
    /// ([`MaterialLobes::specular_weight`]) over the same interpolation of the unshadowed
    /// weights the three views were fitted from ([`MaterialLobes::nearest_specular_weight`]):
    /// what is interpolated across the views is then the lobes' visible share, and their
    /// amplitude follows the material at the view. Interpolating the amplitudes themselves
    /// errs where they change fast between views 0.3 rad apart — near grazing, where a view
    /// below the horizon lends the lobes of one just above it: in the white furnace a Ward
    /// α = 0.1 ball's vertices seen within 12° of their horizon came to 1.77× the truth, a
    /// Phong n = 1,000 ball's to 1.92×. `material` is the material the lobes were fitted
    /// from, `frame` vertex `v`'s frame in the fit (object space), `view` in object space.
    pub fn lobes_following(
        &self,
        material: &MaterialLobes,
        frame: &Frame,
        v: usize,
        view: Vec3,
        out: &mut Vec<WeightedLobe>,
    ) {
        if self.per_view == 0 {
            self.lobes_near(v, None, out);
            return;
        }
        let near = self.nearest_views(view);
        let specular = self.lobes_near(v, Some(&near), out);
        let fitted: Vec3 = near
            .iter()
            .map(|&(j, w)| material.nearest_specular_weight(shown_view(frame.to_local(self.views[j]))) * w)
            .sum();
        let want = material.specular_weight(frame.to_local(view));
        let scale = Vec3::select(fitted.cmpgt(Vec3::splat(1e-12)), want / fitted, Vec3::ONE);
        for l in &mut out[..specular] {
            l.weight *= scale;
        }
    }
}

/// The view whose material lobes a tabulated view (local frame) is fitted from: itself above
/// the horizon, below it the view just above the horizon at the same azimuth
/// ([`horizon_view`]).
fn shown_view(local: Vec3) -> Vec3 {
    if local.z > 0.0 { local } else { horizon_view(local) }
}

/// A view below the horizon brought just above it, at the same azimuth.
fn horizon_view(local: Vec3) -> Vec3 {
    let xy = Vec2::new(local.x, local.y).normalize_or(Vec2::X);
    Vec3::new(xy.x, xy.y, 0.0).lerp(Vec3::Z, 1e-3).normalize()
}

/// A lobe in `frame`'s local coordinates carried to the frame's space.
fn frame_lobe(frame: &Frame, l: Vmf) -> Vmf {
    Vmf::new(frame.to_world(l.mean), l.kappa)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geodesic_views_count_ten_nu_squared_plus_two_and_cover_the_sphere() {
        for nu in 1..=4 {
            let v = geodesic_views(nu);
            assert_eq!(v.len() as u32, 10 * nu * nu + 2, "frequency {nu}");
            let (_, t) = geodesic(nu);
            assert_eq!(t.len() as u32, 20 * nu * nu);
            assert!(v.iter().all(|d| (d.length() - 1.0).abs() < 1e-6));
        }
        // No direction is far from a view at frequency 3: the covering radius of the 92 views.
        let v = geodesic_views(3);
        let mut worst = 1.0f32;
        for i in 0..2000 {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 2000.0;
            let phi = i as f32 * 2.399_963;
            let d = Vec3::new((1.0 - z * z).sqrt() * phi.cos(), (1.0 - z * z).sqrt() * phi.sin(), z);
            worst = worst.min(v.iter().map(|q| q.dot(d)).fold(-1.0, f32::max));
        }
        assert!(worst.acos() < 0.25, "covering radius {} rad", worst.acos());
    }

    #[test]
    fn the_deficit_inverts() {
        for kappa in [1e-3, 0.5, 3.0666, 10.0, 29.0, 31.0, 200.0, 1e4, 1e6] {
            let back = kappa_of_deficit(deficit(kappa));
            assert!((back / kappa - 1.0).abs() < 1e-6, "{kappa} → {back}");
        }
    }

    #[test]
    fn the_deficit_is_the_mean_cosine_deficit_of_the_lobe() {
        // Brute force: E[1 − μ·ω] under γ by quadrature in cos θ.
        for kappa in [0.3f64, 3.0, 30.0, 300.0] {
            let n = 200_000;
            let (mut num, mut den) = (0.0, 0.0);
            for i in 0..n {
                let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                let w = crate::vmf::density_at(kappa, c);
                num += w * (1.0 - c);
                den += w;
            }
            assert!((num / den / deficit(kappa) - 1.0).abs() < 1e-3, "κ {kappa}");
        }
    }

    #[test]
    fn nearest_views_reproduce_a_view_from_its_triangle() {
        let (views, triangles) = geodesic(3);
        let locator = ViewLocator::new(&views, triangles);
        let t = TransportLobes { frequency: 3, views, locator, per_view: 0, specular: vec![], diffuse: vec![] };
        for i in 0..500 {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 500.0;
            let phi = i as f32 * 2.399_963;
            let d = Vec3::new((1.0 - z * z).sqrt() * phi.cos(), (1.0 - z * z).sqrt() * phi.sin(), z);
            let near = t.nearest_views(d);
            let sum: f32 = near.iter().map(|n| n.1).sum();
            assert!((sum - 1.0).abs() < 1e-5 && near.iter().all(|n| n.1 >= 0.0));
            let blend: Vec3 = near.iter().map(|&(j, w)| t.views[j] * w).sum();
            // Inside its triangle a view is its corners' blend exactly.
            assert!(blend.normalize().dot(d) > 1.0 - 1e-6, "{d}: {blend}");
        }
    }
}

//! Clustered principal component analysis (Sloan et al. 2003, "Clustered Principal Components
//! for Precomputed Radiance Transfer").
//!
//! `n` vectors of dimension `d` are split into clusters, each approximated by its mean plus
//! the span of its top `k` principal directions. The fit alternates between refitting every
//! cluster (mean and basis) and moving each vector to the cluster that reconstructs it best.
//! A cluster's basis comes from randomized subspace iteration (Halko et al. 2011) on the
//! centred data with `k + 8` columns and two power iterations: no `d×d` eigenproblem, and
//! data of rank ≤ k is captured exactly. Seeding and the choice of candidate clusters work
//! in a 16-dimensional global PCA space: each round compares the exact reconstruction error
//! of only the 4 clusters whose means are nearest there (and the current one).

use nalgebra::DMatrix;
use rayon::prelude::*;
use rsl_sphere::sampling::Pcg32;

/// A fitted CPCA model and the coefficients of every vector.
#[derive(Clone, Debug, PartialEq)]
pub struct Cpca {
    /// Dimension of the vectors.
    pub d: usize,
    /// Basis vectors per cluster.
    pub k: usize,
    /// Per cluster, its mean (`d` values).
    pub means: Vec<Vec<f32>>,
    /// Per cluster, `k` orthonormal basis vectors, row-major (`k·d` values).
    pub bases: Vec<Vec<f32>>,
    /// Cluster of each vector.
    pub assignment: Vec<u32>,
    /// `k` coefficients of each vector.
    pub coeffs: Vec<f32>,
    /// Whether the coefficients are half-precision values (stored as f16).
    pub f16: bool,
    /// Per cluster `c` and component `j`, the `k` basis values of that component in
    /// [`Lane`]s of eight (zero-padded), at `(c·d + j)·L` with `L = ⌈k/8⌉`: what a
    /// single-component lookup reads, each lane within one cache line. Derived from `bases`
    /// by [`Cpca::with_lookup`].
    pub(crate) rows: Vec<Lane>,
    /// Each vector's `k` coefficients in `L` lanes (zero-padded), derived from `coeffs`.
    pub(crate) coeff_lanes: Vec<Lane>,
}

/// Eight `f32` on a 32-byte boundary: one vector register, never split across cache lines.
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(32))]
pub(crate) struct Lane(pub(crate) [f32; 8]);

/// Lanes of eight that hold `k` values.
pub(crate) fn lanes_for(k: usize) -> usize {
    k.div_ceil(8)
}

/// One vector of a [`Cpca`] model, with everything a lookup of it reads gathered once: its
/// cluster's mean and basis rows and its coefficients.
#[derive(Clone, Copy, Debug)]
pub struct CpcaVector<'a> {
    /// The cluster's basis rows, `L` lanes per component.
    pub(crate) rows: &'a [Lane],
    /// The cluster's mean.
    pub(crate) mean: &'a [f32],
    /// The vector's coefficients, `L` lanes.
    pub(crate) coeffs: &'a [Lane],
}

impl CpcaVector<'_> {
    /// Lanes per component.
    fn lanes(&self) -> usize {
        self.coeffs.len()
    }

    /// Whether the vector has `d` means and `d` rows of its lanes (what lookups index).
    pub(crate) fn is_whole(&self, d: usize) -> bool {
        self.mean.len() == d && self.rows.len() == d * self.lanes()
    }

    /// Component `j`: mean plus coefficients × basis.
    pub fn value(&self, j: usize) -> f32 {
        let l = self.lanes();
        let mut acc = [0.0f32; 8];
        for (row, co) in self.rows[j * l..(j + 1) * l].iter().zip(self.coeffs) {
            for ((a, c), r) in acc.iter_mut().zip(&co.0).zip(&row.0) {
                *a += c * r;
            }
        }
        self.mean[j] + hsum(acc)
    }

    /// The vector read as an `n×n` table (`d = n²`) and interpolated bilinearly at plane
    /// point `p` between cell centres: the same as `map::bilinear_cells` over
    /// [`CpcaVector::value`], reconstructing only the four cells it needs (their rows
    /// blended, then one product with the coefficients).
    #[inline]
    pub fn bilinear(&self, n: usize, p: glam::Vec2) -> f32 {
        vector_bilinear(self, n, p)
    }

    /// Adds `Σ_c w_c·(coefficients ⊙ row_c)` to the lanes of `acc` and returns `Σ_c w_c·mean_c`:
    /// the bilinear blend of four cells, before its lanes are summed (the portable form of
    /// `simd::blend!`, which fuses the multiply-adds).
    #[inline(always)]
    pub(crate) fn blend_into(&self, acc: &mut [f32; 8], cells: [usize; 4], w: [f32; 4]) -> f32 {
        let l = self.lanes();
        let [r0, r1, r2, r3] = cells.map(|c| &self.rows[c * l..(c + 1) * l]);
        for t in 0..l {
            let (a, b, c, d, co) = (r0[t].0, r1[t].0, r2[t].0, r3[t].0, self.coeffs[t].0);
            let blended: [f32; 8] = std::array::from_fn(|e| w[0] * a[e] + w[1] * b[e] + w[2] * c[e] + w[3] * d[e]);
            *acc = std::array::from_fn(|e| acc[e] + co[e] * blended[e]);
        }
        w[0] * self.mean[cells[0]]
            + w[1] * self.mean[cells[1]]
            + w[2] * self.mean[cells[2]]
            + w[3] * self.mean[cells[3]]
    }
}

/// [`CpcaVector::bilinear`]: AVX2 and FMA where the processor has them.
fn vector_bilinear(v: &CpcaVector<'_>, n: usize, p: glam::Vec2) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if v.is_whole(n * n) && simd::available() {
        #[allow(unsafe_code)]
        // SAFETY: the processor has AVX2 and FMA (checked at run time just above).
        return unsafe { simd::vector_bilinear(v, n, p) };
    }
    vector_bilinear_portable(v, n, p)
}

/// [`CpcaVector::bilinear`] in portable code.
fn vector_bilinear_portable(v: &CpcaVector<'_>, n: usize, p: glam::Vec2) -> f32 {
    let (cells, w) = crate::map::bilinear_taps(n, p);
    let mut acc = [0.0f32; 8];
    let mean = v.blend_into(&mut acc, cells, w);
    mean + hsum(acc)
}

/// The lookups' kernels in AVX2 and FMA (eight lanes, fused multiply-adds), chosen at run
/// time by [`simd::available`]; the portable code beside each caller computes the same
/// blend.
#[cfg(target_arch = "x86_64")]
pub(crate) mod simd {
    use super::CpcaVector;
    use std::arch::x86_64::*;

    /// Whether the AVX2/FMA kernels run ([`rsl_sphere::simd::level`]).
    #[inline]
    pub(crate) fn available() -> bool {
        rsl_sphere::simd::level() >= rsl_sphere::simd::Level::Avx2
    }

    /// [`CpcaVector::blend_into`] in vector registers: `blend!(v, acc, cells, w)` adds
    /// `Σ_c w_c·(coefficients ⊙ row_c)` to `acc` (an `__m256`) and is `Σ_c w_c·mean_c`,
    /// reading without bounds checks. A macro, so that it is expanded inside each caller's
    /// `target_feature` function (which a call across functions with `#[inline]` does not
    /// guarantee).
    ///
    /// The caller must have checked that `v` is whole ([`CpcaVector::is_whole`]) for a
    /// `d` above every cell index.
    macro_rules! blend {
        ($v:expr, $acc:expr, $cells:expr, $w:expr) => {{
            let v: &crate::cpca::CpcaVector<'_> = $v;
            let cells: [usize; 4] = $cells;
            let w: [f32; 4] = $w;
            let l = v.coeffs.len();
            // SAFETY: the caller checked that `v` has `d` means and `d·l` rows with every
            // cell below `d`, and `lane < l`.
            #[allow(unsafe_code)]
            unsafe {
                let (w0, w1) = (_mm256_set1_ps(w[0]), _mm256_set1_ps(w[1]));
                let (w2, w3) = (_mm256_set1_ps(w[2]), _mm256_set1_ps(w[3]));
                for lane in 0..l {
                    let row = |c: usize| -> __m256 { bytemuck::cast(*v.rows.get_unchecked(c * l + lane)) };
                    let b = _mm256_mul_ps(w0, row(cells[0]));
                    let b = _mm256_fmadd_ps(w1, row(cells[1]), b);
                    let b = _mm256_fmadd_ps(w2, row(cells[2]), b);
                    let b = _mm256_fmadd_ps(w3, row(cells[3]), b);
                    $acc = _mm256_fmadd_ps(bytemuck::cast(*v.coeffs.get_unchecked(lane)), b, $acc);
                }
                w[0] * v.mean.get_unchecked(cells[0])
                    + w[1] * v.mean.get_unchecked(cells[1])
                    + w[2] * v.mean.get_unchecked(cells[2])
                    + w[3] * v.mean.get_unchecked(cells[3])
            }
        }};
    }
    pub(crate) use blend;

    /// The sum of the eight lanes.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    pub(crate) fn sum(acc: __m256) -> f32 {
        let lanes: [f32; 8] = bytemuck::cast(acc);
        super::hsum(lanes)
    }

    /// [`CpcaVector::bilinear`] of a whole vector (every cell of the taps is below `n²`).
    #[target_feature(enable = "avx2,fma")]
    pub(crate) fn vector_bilinear(v: &CpcaVector<'_>, n: usize, p: glam::Vec2) -> f32 {
        let (cells, w) = crate::map::bilinear_taps(n, p);
        let mut acc = _mm256_setzero_ps();
        let mean = blend!(v, acc, cells, w);
        mean + sum(acc)
    }
}

/// The sum of eight lanes, pairwise (fixed order).
#[inline(always)]
pub(crate) fn hsum(a: [f32; 8]) -> f32 {
    ((a[0] + a[4]) + (a[2] + a[6])) + ((a[1] + a[5]) + (a[3] + a[7]))
}

/// `Σ (x − m)·b` with eight independent partial sums (vectorisable, fixed order).
fn centred_dot(x: &[f32], m: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; 8];
    let (xc, mc, bc) = (x.chunks_exact(8), m.chunks_exact(8), b.chunks_exact(8));
    let (xr, mr, br) = (xc.remainder(), mc.remainder(), bc.remainder());
    for ((x, m), b) in xc.zip(mc).zip(bc) {
        for l in 0..8 {
            acc[l] += (x[l] - m[l]) * b[l];
        }
    }
    let tail: f32 = xr.iter().zip(mr).zip(br).map(|((x, m), b)| (x - m) * b).sum();
    acc.iter().sum::<f32>() + tail
}

/// `x − m`.
fn centred(x: &[f32], m: &[f32]) -> Vec<f32> {
    x.iter().zip(m).map(|(x, m)| x - m).collect()
}

/// Dimensions of the global PCA space used for seeding and shortlists.
const REDUCED_DIMS: usize = 16;
/// Clusters whose exact reconstruction error is compared per vector and round.
const SHORTLIST: usize = 4;

/// Every vector's coordinates in a small global PCA basis (randomized, like the clusters').
struct Reduced {
    dims: usize,
    mean: Vec<f32>,
    basis: Vec<f32>,
    coords: Vec<f32>,
}

impl Reduced {
    fn new(data: &[f32], d: usize, dims: usize, seed: u64) -> Self {
        let n = data.len() / d;
        let all: Vec<usize> = (0..n).collect();
        let row = |i: usize| &data[i * d..(i + 1) * d];
        let (mean, basis) = fit_cluster(&all, &row, d, dims, seed ^ 0x5eed);
        let mut r = Self { dims, mean, basis, coords: Vec::new() };
        r.coords = (0..n).into_par_iter().flat_map_iter(|i| r.project(row(i))).collect();
        r
    }

    fn project(&self, x: &[f32]) -> Vec<f32> {
        let d = self.mean.len();
        (0..self.dims)
            .map(|j| x.iter().zip(&self.mean).zip(&self.basis[j * d..(j + 1) * d]).map(|((x, m), b)| (x - m) * b).sum())
            .collect()
    }

    fn coords_of(&self, i: usize) -> &[f32] {
        &self.coords[i * self.dims..(i + 1) * self.dims]
    }
}

/// Oversampling columns of the randomized range finder.
const OVERSAMPLE: usize = 8;
/// Power iterations of the range finder.
const POWER: usize = 2;

impl Cpca {
    /// Fits `clusters` clusters of `k` vectors to the `n = data.len()/d` rows of `data`,
    /// with `iterations` rounds of reassignment. Deterministic for a given `seed`.
    pub fn fit(data: &[f32], d: usize, clusters: usize, k: usize, iterations: usize, seed: u64) -> Self {
        assert!(d > 0 && data.len().is_multiple_of(d), "data must hold whole vectors of dimension d");
        let n = data.len() / d;
        let clusters = clusters.clamp(1, n.max(1));
        let row = |i: usize| &data[i * d..(i + 1) * d];
        // A small global PCA basis: seeding and candidate shortlists work in its space.
        let reduced = Reduced::new(data, d, REDUCED_DIMS.min(d), seed);
        let mut assignment = seed_clusters(&reduced.coords, reduced.dims, clusters);
        let mut model = Self {
            d,
            k,
            means: Vec::new(),
            bases: Vec::new(),
            assignment: Vec::new(),
            coeffs: Vec::new(),
            f16: false,
            rows: Vec::new(),
            coeff_lanes: Vec::new(),
        };
        for it in 0..=iterations {
            // Refit every cluster.
            let members: Vec<Vec<usize>> = {
                let mut m = vec![Vec::new(); clusters];
                for (i, &c) in assignment.iter().enumerate() {
                    m[c as usize].push(i);
                }
                m
            };
            let fitted: Vec<(Vec<f32>, Vec<f32>)> = members
                .par_iter()
                .enumerate()
                .map(|(c, idx)| fit_cluster(idx, &row, d, k, seed.wrapping_add((it * clusters + c) as u64)))
                .collect();
            model.means = fitted.iter().map(|f| f.0.clone()).collect();
            model.bases = fitted.into_iter().map(|f| f.1).collect();
            if it == iterations {
                break;
            }
            // Reassign each vector to the cluster that reconstructs it best among the
            // SHORTLIST clusters whose means are nearest in the reduced space (all of them
            // when there are few).
            let reduced_means: Vec<Vec<f32>> = model.means.iter().map(|m| reduced.project(m)).collect();
            let new: Vec<u32> = (0..n)
                .into_par_iter()
                .map(|i| {
                    if clusters <= SHORTLIST {
                        return model.best_cluster(row(i), 0..clusters as u32).0;
                    }
                    let x = reduced.coords_of(i);
                    let mut near: Vec<(f32, u32)> = reduced_means
                        .iter()
                        .enumerate()
                        .map(|(c, m)| (x.iter().zip(m).map(|(a, b)| (a - b) * (a - b)).sum::<f32>(), c as u32))
                        .collect();
                    near.select_nth_unstable_by(SHORTLIST - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                    let mut cand: Vec<u32> = near[..SHORTLIST].iter().map(|x| x.1).collect();
                    // The current cluster always competes, so a vector never moves to a worse one.
                    cand.push(assignment[i]);
                    cand.sort_unstable();
                    cand.dedup();
                    model.best_cluster(row(i), cand.into_iter()).0
                })
                .collect();
            // Empty clusters restart from the worst-reconstructed vectors.
            let mut counts = vec![0usize; clusters];
            for &c in &new {
                counts[c as usize] += 1;
            }
            let changed = new != assignment;
            assignment = new;
            let empty: Vec<usize> = (0..clusters).filter(|&c| counts[c] == 0).collect();
            if !empty.is_empty() {
                let mut errs: Vec<(f64, usize)> =
                    (0..n).into_par_iter().map(|i| (model.error(row(i), assignment[i] as usize), i)).collect();
                errs.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
                for (c, (_, i)) in empty.iter().zip(errs) {
                    assignment[i] = *c as u32;
                }
            } else if !changed {
                break;
            }
        }
        model.coeffs =
            (0..n).into_par_iter().flat_map_iter(|i| model.project(row(i), assignment[i] as usize)).collect();
        model.assignment = assignment;
        model.with_lookup()
    }

    /// Builds the lane layouts that lookups read ([`Cpca::vector`]) from `bases` and
    /// `coeffs`.
    pub(crate) fn with_lookup(mut self) -> Self {
        let (d, k) = (self.d, self.k);
        let l = lanes_for(k);
        self.rows = vec![Lane::default(); self.clusters() * d * l];
        for (c, basis) in self.bases.iter().enumerate() {
            for j in 0..d {
                for t in 0..k {
                    self.rows[(c * d + j) * l + t / 8].0[t % 8] = basis[t * d + j];
                }
            }
        }
        self.with_coefficient_lanes()
    }

    /// Builds the coefficients' lanes from `coeffs` (the rows depend on the bases alone).
    fn with_coefficient_lanes(mut self) -> Self {
        let (k, l) = (self.k, lanes_for(self.k));
        self.coeff_lanes = vec![Lane::default(); self.assignment.len() * l];
        for (i, co) in self.coeffs.chunks_exact(k.max(1)).enumerate().take(self.assignment.len()) {
            for (t, &a) in co.iter().enumerate().take(k) {
                self.coeff_lanes[i * l + t / 8].0[t % 8] = a;
            }
        }
        self
    }

    /// Component-major rows as the GPU reads them: per cluster `c` and component `j`, at
    /// `(c·d + j)·(k + 1)`, the mean then the `k` basis values of that component.
    pub fn lookup_rows(&self) -> Vec<f32> {
        let (d, k) = (self.d, self.k);
        let mut out = Vec::with_capacity(self.clusters() * d * (k + 1));
        for (mean, basis) in self.means.iter().zip(&self.bases) {
            for j in 0..d {
                out.push(mean[j]);
                out.extend((0..k).map(|t| basis[t * d + j]));
            }
        }
        out
    }

    /// Vector `i` prepared for lookups.
    #[inline]
    pub fn vector(&self, i: usize) -> CpcaVector<'_> {
        let (d, l) = (self.d, lanes_for(self.k));
        let c = self.assignment[i] as usize;
        CpcaVector {
            rows: &self.rows[c * d * l..(c + 1) * d * l],
            mean: &self.means[c],
            coeffs: &self.coeff_lanes[i * l..(i + 1) * l],
        }
    }

    /// Number of clusters.
    pub fn clusters(&self) -> usize {
        self.means.len()
    }

    /// Coefficients of `x` in cluster `c`.
    fn project(&self, x: &[f32], c: usize) -> Vec<f32> {
        let (mean, basis) = (&self.means[c], &self.bases[c]);
        (0..self.k).map(|j| centred_dot(x, mean, &basis[j * self.d..(j + 1) * self.d])).collect()
    }

    /// Squared reconstruction error of `x` in cluster `c`: `‖x − μ‖² − Σ (bⱼ·(x − μ))²`.
    fn error(&self, x: &[f32], c: usize) -> f64 {
        let mean = &self.means[c];
        let total = f64::from(centred_dot(x, mean, &centred(x, mean)));
        let along: f64 = self.project(x, c).iter().map(|&a| f64::from(a * a)).sum();
        (total - along).max(0.0)
    }

    /// Vector `i` reconstructed into `out` (`d` values): mean plus coefficients × basis.
    pub fn reconstruct_into(&self, i: usize, out: &mut [f32]) {
        let c = self.assignment[i] as usize;
        out.copy_from_slice(&self.means[c]);
        for (t, &a) in self.coeffs[i * self.k..(i + 1) * self.k].iter().enumerate() {
            for (o, b) in out.iter_mut().zip(&self.bases[c][t * self.d..(t + 1) * self.d]) {
                *o += a * b;
            }
        }
    }

    /// The cluster among `candidates` reconstructing `x` best, and its squared error.
    fn best_cluster(&self, x: &[f32], candidates: impl Iterator<Item = u32>) -> (u32, f64) {
        candidates
            .map(|c| (c, self.error(x, c as usize)))
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
            .unwrap_or((0, 0.0))
    }

    /// Component `j` of vector `i`, reconstructed from its cluster.
    pub fn value(&self, i: usize, j: usize) -> f32 {
        self.vector(i).value(j)
    }

    /// Vector `i` read as an `n×n` table (`d = n²`) and interpolated bilinearly at plane
    /// point `p` between cell centres (see [`CpcaVector::bilinear`]).
    pub fn bilinear(&self, i: usize, n: usize, p: glam::Vec2) -> f32 {
        self.vector(i).bilinear(n, p)
    }

    /// Vector `i`, reconstructed.
    pub fn reconstruct(&self, i: usize) -> Vec<f32> {
        let mut out = vec![0.0; self.d];
        self.reconstruct_into(i, &mut out);
        out
    }

    /// The same model with its coefficients rounded to half precision (what f16 storage
    /// holds).
    pub fn with_f16_coefficients(&self) -> Self {
        Self {
            coeffs: self.coeffs.iter().map(|&c| half::f16::from_f32(c).to_f32()).collect(),
            f16: true,
            ..self.clone()
        }
        .with_coefficient_lanes()
    }

    /// Bytes as stored: f16 or f32 coefficients.
    pub fn stored_bytes(&self) -> usize {
        self.bytes(if self.f16 { 2 } else { 4 })
    }

    /// Squared reconstruction error summed over the rows of `raw` (this model's vectors).
    pub fn squared_error(&self, raw: &[f32]) -> f64 {
        let mut rec = vec![0.0f32; self.d];
        (0..self.assignment.len())
            .map(|v| {
                self.reconstruct_into(v, &mut rec);
                rec.iter().zip(&raw[v * self.d..(v + 1) * self.d]).map(|(a, b)| f64::from(a - b).powi(2)).sum::<f64>()
            })
            .sum()
    }

    /// Bytes stored: means, bases (f32), and per vector a cluster index (u16 up to 65,536
    /// clusters) and `k` coefficients of `coefficient_bytes` each.
    pub fn bytes(&self, coefficient_bytes: usize) -> usize {
        let n = self.assignment.len();
        let index = if self.clusters() <= 1 << 16 { 2 } else { 4 };
        self.clusters() * (self.k + 1) * self.d * 4 + n * (index + self.k * coefficient_bytes)
    }
}

/// Initial clusters by farthest-point seeding (on the vectors' reduced coordinates): the
/// first seed is the vector farthest from the mean, each next one the vector farthest from
/// all seeds so far; every vector then joins its nearest seed. Ties go to the lowest index,
/// so the result is deterministic.
fn seed_clusters(data: &[f32], d: usize, clusters: usize) -> Vec<u32> {
    let n = data.len() / d;
    let row = |i: usize| &data[i * d..(i + 1) * d];
    let dist2 = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| f64::from((x - y) * (x - y))).sum::<f64>();
    let mut mean = vec![0.0f32; d];
    for i in 0..n {
        for (m, &x) in mean.iter_mut().zip(row(i)) {
            *m += x / n as f32;
        }
    }
    let farthest = |dist: &[f64]| (0..n).max_by(|&a, &b| dist[a].total_cmp(&dist[b]).then(b.cmp(&a))).unwrap_or(0);
    let from_mean: Vec<f64> = (0..n).into_par_iter().map(|i| dist2(row(i), &mean)).collect();
    let mut seeds = vec![farthest(&from_mean)];
    let mut nearest: Vec<(f64, u32)> = (0..n).into_par_iter().map(|i| (dist2(row(i), row(seeds[0])), 0)).collect();
    while seeds.len() < clusters {
        let dist: Vec<f64> = nearest.iter().map(|x| x.0).collect();
        let next = farthest(&dist);
        if dist[next] <= 0.0 {
            break; // Fewer distinct vectors than clusters.
        }
        let c = seeds.len() as u32;
        seeds.push(next);
        let s = row(next);
        nearest.par_iter_mut().enumerate().for_each(|(i, best)| {
            let e = dist2(row(i), s);
            if e < best.0 {
                *best = (e, c);
            }
        });
    }
    nearest.into_iter().map(|x| x.1).collect()
}

/// Mean and top-`k` orthonormal basis (row-major `k·d`) of the rows `idx`. Missing directions
/// (fewer members than `k`, or rank-deficient data) are zero vectors.
fn fit_cluster<'a>(
    idx: &[usize],
    row: &(impl Fn(usize) -> &'a [f32] + Sync),
    d: usize,
    k: usize,
    seed: u64,
) -> (Vec<f32>, Vec<f32>) {
    let m = idx.len();
    let mut mean = vec![0.0f64; d];
    for &i in idx {
        for (a, &x) in mean.iter_mut().zip(row(i)) {
            *a += f64::from(x);
        }
    }
    if m > 0 {
        for a in &mut mean {
            *a /= m as f64;
        }
    }
    let mut basis = vec![0.0f32; k * d];
    if m == 0 || k == 0 {
        return (mean.iter().map(|&x| x as f32).collect(), basis);
    }
    let x = DMatrix::<f64>::from_fn(m, d, |r, c| f64::from(row(idx[r])[c]) - mean[c]);
    // Range of X (m×d) from the right: Y = X·Ω, refined by power iterations.
    let l = (k + OVERSAMPLE).min(m).min(d);
    let mut rng = Pcg32::new(seed);
    let omega = DMatrix::<f64>::from_fn(d, l, |_, _| f64::from(rng.next_f32()) * 2.0 - 1.0);
    let mut q = (&x * &omega).qr().q();
    for _ in 0..POWER {
        let z = (x.transpose() * &q).qr().q();
        q = (&x * z).qr().q();
    }
    // B = Qᵀ·X (l×d): its right singular vectors are X's principal directions.
    let b = q.transpose() * &x;
    let svd = b.svd(false, true);
    let Some(v_t) = svd.v_t else { return (mean.iter().map(|&x| x as f32).collect(), basis) };
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    let scale = svd.singular_values.iter().copied().fold(0.0f64, f64::max);
    for (j, &o) in order.iter().take(k).enumerate() {
        // Directions with no variance are left out (zero), so reconstruction stays exact.
        if svd.singular_values[o] <= 1e-9 * scale {
            continue;
        }
        for c in 0..d {
            basis[j * d + c] = v_t[(o, c)] as f32;
        }
    }
    (mean.iter().map(|&x| x as f32).collect(), basis)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` vectors from `groups` groups, each of the form μ_g + Σ_{j<rank} a_j·u_gj.
    fn synthetic(n: usize, d: usize, groups: usize, rank: usize, seed: u64) -> Vec<f32> {
        let mut rng = Pcg32::new(seed);
        let mut f = || rng.next_f32() * 2.0 - 1.0;
        let means: Vec<Vec<f32>> = (0..groups).map(|_| (0..d).map(|_| 5.0 * f()).collect()).collect();
        let dirs: Vec<Vec<Vec<f32>>> =
            (0..groups).map(|_| (0..rank).map(|_| (0..d).map(|_| f()).collect()).collect()).collect();
        let mut out = Vec::with_capacity(n * d);
        for i in 0..n {
            let g = i % groups;
            let a: Vec<f32> = (0..rank).map(|_| f()).collect();
            for c in 0..d {
                out.push(means[g][c] + (0..rank).map(|j| a[j] * dirs[g][j][c]).sum::<f32>());
            }
        }
        out
    }

    #[test]
    fn bilinear_lookups_match_reconstructed_tables_on_every_path() {
        // k = 8 fills one lane; k = 3 pads one; k = 17 takes three.
        for (k, seed) in [(8usize, 1u64), (3, 2), (17, 3)] {
            let (n, vectors) = (12, 60);
            let data = synthetic(vectors, n * n, 3, k.min(5), seed);
            let model = Cpca::fit(&data, n * n, 3, k, 2, seed);
            let mut rng = Pcg32::new(seed);
            let mut worst = 0.0f32;
            for _ in 0..2000 {
                let i = rng.next_u32() as usize % vectors;
                // Points inside and beyond the grid's cell centres (clamped there).
                let p = glam::Vec2::new(rng.next_f32() * 2.4 - 1.2, rng.next_f32() * 2.4 - 1.2);
                let table = model.reconstruct(i);
                let want = crate::map::bilinear_cells(n, p, |c| table[c]);
                let v = model.vector(i);
                for got in [vector_bilinear(&v, n, p), vector_bilinear_portable(&v, n, p), model.bilinear(i, n, p)] {
                    worst = worst.max((got - want).abs() / want.abs().max(1.0));
                }
            }
            assert!(worst < 1e-5, "k = {k}: worst difference {worst}");
        }
    }

    #[test]
    fn reconstructs_rank_k_clusters_exactly() {
        let (n, d, groups, rank) = (600, 256, 4, 3);
        let data = synthetic(n, d, groups, rank, 1);
        let model = Cpca::fit(&data, d, groups, rank, 8, 7);
        let mut worst = 0.0f32;
        for i in 0..n {
            let r = model.reconstruct(i);
            for (a, b) in r.iter().zip(&data[i * d..(i + 1) * d]) {
                worst = worst.max((a - b).abs());
            }
        }
        // f32 storage of values up to ~8: a few ulps.
        assert!(worst < 1e-4, "worst reconstruction error {worst}");
        // The interleaved groups are recovered: members of a cluster share i mod groups.
        for c in 0..groups {
            let g: std::collections::BTreeSet<usize> =
                (0..n).filter(|&i| model.assignment[i] as usize == c).map(|i| i % groups).collect();
            assert!(g.len() <= 1, "cluster {c} mixes groups {g:?}");
        }
    }

    #[test]
    fn fewer_vectors_than_k_and_constant_data_are_exact() {
        let d = 32;
        let data: Vec<f32> = (0..3 * d).map(|v| (v % 7) as f32).collect();
        let model = Cpca::fit(&data, d, 1, 8, 3, 1);
        for i in 0..3 {
            for (a, b) in model.reconstruct(i).iter().zip(&data[i * d..(i + 1) * d]) {
                assert!((a - b).abs() < 1e-4);
            }
        }
        let constant = vec![2.5f32; 10 * d];
        let m = Cpca::fit(&constant, d, 2, 4, 3, 1);
        assert!(m.reconstruct(9).iter().all(|&v| (v - 2.5).abs() < 1e-6));
        assert!(m.coeffs.iter().all(|c| c.is_finite()));
    }
}

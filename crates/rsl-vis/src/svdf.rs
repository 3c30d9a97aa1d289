//! The self-visibility distance field (Xu et al. 2006, §4.3.1 and §5.1): a VDT per vertex in
//! the vertex's own frame, compressed with clustered PCA.
//!
//! Vertex frames are `Frame::from_normal(normal)` (its tangent is a fixed, continuous function
//! of the normal), so shading code rebuilds the same frame. A convex object, where every
//! vertex sees its whole hemisphere, stores nothing: its distance is the analytic distance to
//! the horizon, `1 − |p|`.

use crate::coverage::coverage;
use crate::cpca::{Cpca, CpcaVector};
use crate::map::{VisibilityMap, bilinear_cells};
use crate::rays::{Occluder, VisError};
use glam::Vec2;
use rayon::prelude::*;
use rsl_sphere::Frame;
use rsl_sphere::mesh::TriMesh;
use rsl_sphere::sampling::Pcg32;

/// Resolutions of a self-visibility field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SvdfParams {
    /// `N` of the per-vertex `N×N` table.
    pub n: usize,
    /// `s×s` rays per cell.
    pub supersample: usize,
    /// CPCA clusters.
    pub clusters: usize,
    /// CPCA basis vectors per cluster.
    pub vectors: usize,
    /// CPCA reassignment rounds.
    pub iterations: usize,
}

impl SvdfParams {
    /// Fast, for tests and first looks: 16×16 tables, 2×2 rays per cell, 32 clusters × 4.
    pub const DRAFT: SvdfParams = SvdfParams { n: 16, supersample: 2, clusters: 32, vectors: 4, iterations: 4 };
    /// Xu et al.: 32×32 tables, 256 clusters × 8 vectors, and their budget of 1,024 rays per
    /// vertex: one ray per cell, so the boundary is placed to about a third of a cell.
    pub const PAPER: SvdfParams = SvdfParams { n: 32, supersample: 1, clusters: 256, vectors: 8, iterations: 3 };
    /// Finer boundaries: 32×32 tables with 2×2 rays per cell (4,096 rays per vertex).
    pub const HIGH: SvdfParams = SvdfParams { n: 32, supersample: 2, clusters: 256, vectors: 8, iterations: 4 };
}

/// How well a field is compressed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompressionReport {
    /// Vertices (or samples) in the field.
    pub vectors: usize,
    /// Bytes of the uncompressed tables (f32).
    pub raw_bytes: usize,
    /// Bytes compressed, f32 coefficients.
    pub bytes_f32: usize,
    /// Bytes compressed, f16 coefficients.
    pub bytes_f16: usize,
    /// RMS error of the reconstructed distances (plane units), f32 coefficients.
    pub rms_distance_error: f32,
    /// RMS error of the coverage of random squares (half-diagonal 0.02–0.2) from the
    /// reconstructed tables against the uncompressed ones, f32 coefficients.
    pub rms_coverage_error: f32,
    /// The same two with f16 coefficients.
    pub rms_distance_error_f16: f32,
    /// Coverage error with f16 coefficients.
    pub rms_coverage_error_f16: f32,
}

/// A self-visibility field.
// One per distinct mesh: the size of the convex variant does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Svdf {
    /// Every vertex sees its whole hemisphere: nothing is stored.
    Convex {
        /// Number of vertices.
        vertices: usize,
    },
    /// Compressed per-vertex tables.
    Field {
        /// `N` of the tables.
        n: usize,
        /// The compressed tables (one vector of `N²` distances per vertex).
        cpca: Cpca,
        /// Compression figures.
        report: CompressionReport,
    },
}

/// Whether every vertex lies behind (or on) every triangle's plane, i.e. the mesh is the
/// boundary of a convex body; `None` when the check would cost more than `budget` point–plane
/// tests.
fn convex(mesh: &TriMesh, tolerance: f32, budget: usize) -> Option<bool> {
    if mesh.triangle_count().saturating_mul(mesh.vertex_count()) > budget {
        return None;
    }
    Some(mesh.indices.par_chunks_exact(3).all(|t| {
        let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[t[k] as usize]);
        let n = (b - a).cross(c - a);
        let len = n.length();
        if len <= 0.0 {
            return true;
        }
        let n = n / len;
        mesh.positions.iter().all(|&p| (p - a).dot(n) <= tolerance)
    }))
}

impl Svdf {
    /// Bytes held as stored (CPCA means, bases and coefficients; nothing for a convex
    /// object).
    pub fn bytes(&self) -> usize {
        match self {
            Svdf::Convex { .. } => 0,
            Svdf::Field { cpca, .. } => cpca.stored_bytes(),
        }
    }

    /// Traces and compresses the self-visibility of every vertex of `mesh` (object space).
    pub fn build(mesh: &TriMesh, params: &SvdfParams) -> Result<Self, VisError> {
        Self::build_with_progress(mesh, params, &|_, _| {})
    }

    /// [`Svdf::build`], calling `progress(done, total)` as vertices are traced (every 256
    /// vertices at 16×16 tables, more often for finer ones; in any order).
    pub fn build_with_progress(
        mesh: &TriMesh,
        params: &SvdfParams,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Self, VisError> {
        mesh.validate().map_err(|e| VisError::Mesh(e.to_string()))?;
        let occluder = Occluder::new(mesh)?;
        let (_, radius) = mesh.bounding_sphere().unwrap_or_default();
        let nv = mesh.vertex_count();
        if convex(mesh, 1e-5 * radius, 400_000_000) == Some(true) {
            return Ok(Svdf::Convex { vertices: nv });
        }
        // Rays start just off the surface and need not go past the object.
        let (offset, tmax) = (1e-4 * radius.max(f32::MIN_POSITIVE), 4.0 * radius.max(f32::MIN_POSITIVE));
        let n = params.n;
        let traced = std::sync::atomic::AtomicUsize::new(0);
        // A report every 65,536 rays' worth of vertices (every 256 vertices at 16×16
        // tables, every vertex at 256×256), so that fine tables show progress within
        // seconds too.
        let rays = (n * n * params.supersample * params.supersample).max(1);
        let every = (65_536 / rays).clamp(1, 256);
        // The tables are written in place: the build holds them once (the size the engine
        // checks before building), not once per vertex and again flattened.
        let mut raw = vec![0.0f32; nv * n * n];
        let visible: Vec<bool> = raw
            .par_chunks_mut(n * n)
            .enumerate()
            .map(|(v, out)| {
                let done = traced.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                if done.is_multiple_of(every) || done == nv {
                    progress(done, nv);
                }
                let frame = Frame::from_normal(mesh.normals[v]);
                let map =
                    VisibilityMap::trace(&occluder, mesh.positions[v], &frame, offset, tmax, n, params.supersample);
                out.copy_from_slice(map.vdt().values());
                map.fully_visible()
            })
            .collect();
        if visible.iter().all(|&v| v) {
            return Ok(Svdf::Convex { vertices: nv });
        }
        let cpca = Cpca::fit(&raw, n * n, params.clusters, params.vectors, params.iterations, 1);
        let report = report(&raw, n, &cpca);
        // Half-precision coefficients where the error allows: within 1% of f32's.
        let cpca = if report.rms_distance_error_f16 <= 1.01 * report.rms_distance_error + 1e-6 {
            cpca.with_f16_coefficients()
        } else {
            cpca
        };
        Ok(Svdf::Field { n, cpca, report })
    }

    /// The compression report (none for a convex object).
    pub fn report(&self) -> Option<&CompressionReport> {
        match self {
            Svdf::Convex { .. } => None,
            Svdf::Field { report, .. } => Some(report),
        }
    }

    /// The signed distance to the self-visibility boundary at plane point `p` for `vertex`:
    /// bilinear over the four nearest cell centres, reconstructing only those four values.
    pub fn distance(&self, vertex: usize, p: Vec2) -> f32 {
        self.vertex(vertex).distance(p)
    }

    /// Vertex `vertex`'s field prepared for lookups in many directions.
    pub fn vertex(&self, vertex: usize) -> SvdfVertex<'_> {
        match self {
            Svdf::Convex { .. } => SvdfVertex::Convex,
            Svdf::Field { n, cpca, .. } => SvdfVertex::Field { n: *n, vector: cpca.vector(vertex) },
        }
    }

    /// The visible fraction of the rotatable square of half-diagonal `r` at `p` for `vertex`.
    pub fn coverage(&self, vertex: usize, p: Vec2, r: f32) -> f32 {
        coverage(self.distance(vertex, p), r)
    }

    /// [`SvdfVertex::coverage_above_horizon`] for `vertex`.
    pub fn coverage_above_horizon(&self, vertex: usize, p: Vec2, r: f32) -> f32 {
        above_horizon(self.coverage(vertex, p, r), p, r)
    }
}

/// A square's visible fraction `c` (horizon included) as a fraction of its part above the
/// horizon, `c / coverage(1 − |p|, r)` within [0, 1] (0 where none of it is above).
#[inline]
pub fn above_horizon(c: f32, p: Vec2, r: f32) -> f32 {
    let h = coverage(1.0 - p.length(), r);
    if h > 0.0 { (c / h).min(1.0) } else { 0.0 }
}

/// RMS errors of the distances and of random squares' coverage reconstructed by `cpca`,
/// against the uncompressed tables `raw`.
/// One vertex's self-visibility prepared for lookups ([`Svdf::vertex`]).
#[derive(Clone, Copy, Debug)]
pub enum SvdfVertex<'a> {
    /// A convex object: the horizon alone.
    Convex,
    /// A compressed table.
    Field {
        /// `N` of the table.
        n: usize,
        /// The vertex's vector of the CPCA model.
        vector: CpcaVector<'a>,
    },
}

impl SvdfVertex<'_> {
    /// The signed distance at plane point `p` (see [`Svdf::distance`]).
    #[inline]
    pub fn distance(&self, p: Vec2) -> f32 {
        match self {
            SvdfVertex::Convex => 1.0 - p.length(),
            SvdfVertex::Field { n, vector } => vector.bilinear(*n, p),
        }
    }

    /// The visible fraction of the square of half-diagonal `r` around plane point `p`.
    #[inline]
    pub fn coverage(&self, p: Vec2, r: f32) -> f32 {
        coverage(self.distance(p), r)
    }

    /// The visible fraction of the square's part above the vertex's horizon: what multiplies
    /// a BRDF integral that already leaves out the part below it (a product of the two
    /// fractions would count the horizon twice). A convex object's is 1 wherever any of the
    /// square is above the horizon.
    #[inline]
    pub fn coverage_above_horizon(&self, p: Vec2, r: f32) -> f32 {
        match self {
            // The horizon is the only boundary: its share of itself.
            SvdfVertex::Convex => f32::from(u8::from(coverage(1.0 - p.length(), r) > 0.0)),
            SvdfVertex::Field { .. } => above_horizon(self.coverage(p, r), p, r),
        }
    }
}

fn errors(raw: &[f32], n: usize, cpca: &Cpca) -> (f32, f32) {
    let d = n * n;
    let nv = raw.len() / d;
    let sq: f64 = (0..nv)
        .into_par_iter()
        .map_init(
            || vec![0.0f32; d],
            |rec, v| {
                cpca.reconstruct_into(v, rec);
                rec.iter().zip(&raw[v * d..(v + 1) * d]).map(|(a, b)| f64::from(a - b).powi(2)).sum::<f64>()
            },
        )
        .sum();
    let mut rng = Pcg32::new(3);
    let samples = 4000;
    let mut cov = 0.0f64;
    for _ in 0..samples {
        let v = (rng.next_u32() as usize) % nv.max(1);
        let p = Vec2::new(rng.next_f32() * 1.6 - 0.8, rng.next_f32() * 1.6 - 0.8);
        let r = 0.02 + 0.18 * rng.next_f32();
        let a = coverage(bilinear_cells(n, p, |k| raw[v * d + k]), r);
        let b = coverage(bilinear_cells(n, p, |k| cpca.value(v, k)), r);
        cov += f64::from(a - b).powi(2);
    }
    ((sq / raw.len().max(1) as f64).sqrt() as f32, (cov / samples as f64).sqrt() as f32)
}

fn report(raw: &[f32], n: usize, cpca: &Cpca) -> CompressionReport {
    let (rms_distance_error, rms_coverage_error) = errors(raw, n, cpca);
    let (rms_distance_error_f16, rms_coverage_error_f16) = errors(raw, n, &cpca.with_f16_coefficients());
    CompressionReport {
        vectors: raw.len() / (n * n),
        raw_bytes: raw.len() * 4,
        bytes_f32: cpca.bytes(4),
        bytes_f16: cpca.bytes(2),
        rms_distance_error,
        rms_coverage_error,
        rms_distance_error_f16,
        rms_coverage_error_f16,
    }
}

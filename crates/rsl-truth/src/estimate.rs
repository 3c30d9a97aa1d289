//! The Monte Carlo estimator of direct environment lighting with shadows:
//!
//! `L_o(x, v) = ∫ L(ω) ρ(ω, v) cos θ V(x, ω) dω`
//!
//! — exactly what the RSL path approximates: the environment (bilinear lat-long lookups,
//! as Mitsuba 3's `envmap`, or a constant) seen from `x` past every object at its current
//! transform, no interreflection. Each sample pairs one direction drawn from the
//! environment (luminance × texel solid angle, rsl-sphere) with one drawn from the BRDF
//! (rsl-brdf), weighted by the power heuristic (β = 2). Samples are stratified (Latin
//! hypercube per strategy), deterministic for a seed, and the estimate comes with its
//! standard error (the sample standard deviation of the per-sample sums over √spp, per
//! channel; stratification only makes it conservative).
//!
//! Shadow rays start `1e-4` scene radii off the surface along the shading normal. An object
//! with `casts_shadows = false` still shadows itself, not others, as in the RSL path.
//!
//! At a vertex, visibility is face-averaged: each direction's shadow-ray result is weighted
//! by the vertex's mask `h(ω) = Σ_f w_f [ω·n_f > 0]` over its incident faces
//! ([`rsl_sphere::faces`]), so that a vertex's value is the angle-weighted mean of what
//! each incident face sees there. At a pixel, the mask is the hit face's: `[ω·n_f > 0]`.

use glam::{DVec3, Quat, Vec2, Vec3, Vec3A};
use obvhs::{
    BvhBuildParams, cwbvh::CwBvh, cwbvh::builder::build_cwbvh_from_tris, ray::Ray, ray::RayHit, triangle::Triangle,
};
use rayon::prelude::*;
use rsl_brdf::Brdf;
use rsl_frame::{Pose, VertexFrames};
use rsl_scene::texture::{MetallicRoughnessTexture, ObjectTexture, textured};
use rsl_scene::{Camera, Transform};
use rsl_sphere::Frame;
use rsl_sphere::faces::IncidentFaces;
use rsl_sphere::latlong::LatLongMap;
use rsl_sphere::mesh::TriMesh;
use rsl_sphere::sampling::{EnvironmentSampler, Pcg32, luminance, uniform_sphere};
use std::sync::Arc;

/// The environment as a light source.
#[derive(Clone, Debug)]
pub enum EnvLight {
    /// A lat-long map (bilinear lookups) with its importance sampler, times `intensity`.
    Map {
        /// The radiance.
        map: Arc<LatLongMap>,
        /// Its sampler.
        sampler: Arc<EnvironmentSampler>,
        /// Scale.
        intensity: f32,
    },
    /// The same radiance everywhere.
    Constant(Vec3),
}

impl EnvLight {
    /// A map light. Its sampler follows each texel's largest 3×3-neighbour luminance, so
    /// that every direction where the bilinear lookup is non-zero can be sampled (a bright
    /// texel's light spreads into its neighbours' areas).
    pub fn map(map: Arc<LatLongMap>, intensity: f32) -> Self {
        let (w, h) = (map.width(), map.height());
        let mut dilated = Vec::with_capacity(w * h);
        for j in 0..h {
            for i in 0..w {
                let mut best = map.texel(i, j);
                for dj in [-1i64, 0, 1] {
                    let jj = j as i64 + dj;
                    if jj < 0 || jj >= h as i64 {
                        continue;
                    }
                    for di in [-1i64, 0, 1] {
                        let c = map.texel((i as i64 + di).rem_euclid(w as i64) as usize, jj as usize);
                        if luminance(c) > luminance(best) {
                            best = c;
                        }
                    }
                }
                dilated.push(best);
            }
        }
        let weights = LatLongMap::new(w, h, dilated).expect("same size as the map");
        let sampler = Arc::new(EnvironmentSampler::new(&weights));
        EnvLight::Map { map, sampler, intensity }
    }

    /// Radiance toward environment-space direction `d`.
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        match self {
            EnvLight::Map { map, intensity, .. } => map.lookup(d) * *intensity,
            EnvLight::Constant(c) => *c,
        }
    }

    fn sample(&self, u: Vec2) -> (Vec3, f32) {
        match self {
            EnvLight::Map { sampler, .. } => sampler.sample(u),
            EnvLight::Constant(_) => (uniform_sphere(u), 1.0 / (4.0 * std::f32::consts::PI)),
        }
    }

    fn pdf(&self, d: Vec3) -> f32 {
        match self {
            EnvLight::Map { sampler, .. } => sampler.pdf(d),
            EnvLight::Constant(_) => 1.0 / (4.0 * std::f32::consts::PI),
        }
    }
}

/// One object as the estimator sees it.
#[derive(Clone, Copy, Debug)]
pub struct TruthObject<'a> {
    /// The mesh in object space.
    pub mesh: &'a TriMesh,
    /// Its vertex frames (the same the RSL path uses).
    pub frames: &'a VertexFrames,
    /// The material.
    pub brdf: Brdf,
    /// The current transform.
    pub transform: Transform,
    /// Whether it shadows other objects.
    pub casts_shadows: bool,
    /// Its base-colour texture: the material's base colour times the texture's value at
    /// each point a pixel's sample meets, and times its mean over a vertex's surroundings at
    /// a vertex ([`ObjectTexture::vertex_means`]).
    pub texture: Option<&'a ObjectTexture>,
    /// Its metallic-roughness texture, evaluated the same way (where the methods draw its
    /// means).
    pub metallic_roughness: Option<&'a MetallicRoughnessTexture>,
}

/// Where on an object a BRDF is evaluated, for its texture.
#[derive(Clone, Copy, Debug)]
enum Place {
    /// A vertex: its texture averaged over its surroundings.
    Vertex(usize),
    /// A point between three vertices.
    Point([u32; 3], Vec3),
    /// Nowhere in particular: the material's own factors.
    Untextured,
}

/// An estimate and its standard error, per channel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    /// The mean.
    pub mean: Vec3,
    /// Its standard error.
    pub std_error: Vec3,
}

/// Samples gathered in independent replicates, each stratified on its own: the spread of the
/// replicates' means is an honest standard error for the stratified estimate. Sums in f64:
/// the square of a sample of a sun at 1e23 overflows f32 (the error was NaN).
struct Replicates {
    /// Samples in all, and per replicate.
    n: usize,
    per: usize,
    means: Vec<DVec3>,
    /// This replicate's sum; all samples' sum and sum of squares.
    current: DVec3,
    sum: DVec3,
    sum2: DVec3,
}

impl Replicates {
    /// `n` samples (at least 1) in 16, 8, 4 or 2 equal replicates, or one.
    fn new(n: usize) -> Self {
        let n = n.max(1);
        let count = [16, 8, 4, 2].into_iter().find(|&b| n >= b && n.is_multiple_of(b)).unwrap_or(1);
        Self {
            n,
            per: n / count,
            means: Vec::with_capacity(count),
            current: DVec3::ZERO,
            sum: DVec3::ZERO,
            sum2: DVec3::ZERO,
        }
    }

    fn count(&self) -> usize {
        self.n / self.per
    }

    fn add(&mut self, v: Vec3) {
        let v = v.as_dvec3();
        self.current += v;
        self.sum += v;
        self.sum2 += v * v;
    }

    /// Closes the replicate whose samples were added since the last.
    fn end_replicate(&mut self) {
        self.means.push(std::mem::take(&mut self.current) / self.per as f64);
    }

    /// The mean and its standard error: from the replicates' spread, or with one replicate
    /// from the samples' (conservative under stratification).
    fn estimate(&self) -> Estimate {
        let n = self.n as f64;
        let mean = self.sum / n;
        let std_error = if self.means.len() > 1 {
            let b = self.means.len() as f64;
            let var = self.means.iter().map(|m| (*m - mean) * (*m - mean)).sum::<DVec3>() / (b - 1.0);
            (var / b).sqrt()
        } else {
            let var = (self.sum2 / n - mean * mean).max(DVec3::ZERO) * (n / (n - 1.0).max(1.0));
            (var / n).sqrt()
        };
        Estimate { mean: mean.as_vec3(), std_error: std_error.as_vec3() }
    }
}

/// Counts of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TruthStats {
    /// Points estimated.
    pub points: u64,
    /// Shadow rays traced.
    pub shadow_rays: u64,
}

/// The scene at one time, in world space, with one BVH over every triangle.
pub struct TruthScene {
    positions: Vec<Vec<Vec3>>,
    frames: Vec<Vec<Frame>>,
    /// Per object, its vertices' incident faces in world space.
    faces: Vec<IncidentFaces>,
    indices: Vec<Vec<u32>>,
    brdfs: Vec<Brdf>,
    /// Per object: its texture and, per vertex, the texture's mean over its surroundings.
    textures: Vec<Option<(ObjectTexture, Arc<Vec<Vec3>>)>>,
    /// Per object: its metallic-roughness texture and its means about each vertex.
    metallic_roughness: Vec<Option<(MetallicRoughnessTexture, Arc<Vec<Vec3>>)>>,
    casts: Vec<bool>,
    bvh: CwBvh,
    tris: Vec<Triangle>,
    /// Per BVH triangle: object and triangle number.
    owners: Vec<(u32, u32)>,
    env: EnvLight,
    env_from_world: Quat,
    world_from_env: Quat,
    offset: f32,
    /// The BVH's triangles are world positions times this power of two
    /// (`rsl_sphere::mesh::ray_scale`); ray origins are scaled alike.
    scale: f32,
    /// Where a pixel's samples lie ([`TruthScene::with_pixel_filter`]).
    filter: PixelFilter,
    /// Bounces of light between surfaces ([`TruthScene::with_bounces`]); 0: direct light only.
    bounces: u32,
}

/// Where [`TruthScene::pixel`] takes a pixel's samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PixelFilter {
    /// Over its square, stratified: the pixel's value as rsl defines it (a box filter).
    #[default]
    Box,
    /// All at its centre: what an image drawn with one point per pixel (aliased) should be,
    /// for measuring shading apart from aliasing.
    Centre,
}

/// Where a ray met a surface ([`TruthScene::gather`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceHit {
    /// The object met.
    pub object: usize,
    /// Its triangle's corners (the object's vertex numbers).
    pub corners: [u32; 3],
    /// The corners' weights at the point met (barycentric, summing to 1).
    pub weights: Vec3,
    /// The triangle's unit normal, on the side of the shading normal.
    pub face: Vec3,
    /// The world point met.
    pub point: Vec3,
    /// The shading frame there (the corners' normals and tangents interpolated).
    pub frame: Frame,
    /// The unit direction back along the ray (toward where it came from).
    pub toward: Vec3,
}

/// Toward where [`TruthScene::gather`] reflects the light it gathers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GatherView {
    /// Toward this eye (world position).
    Eye(Vec3),
    /// Along each vertex's own shading normal (what a surface sends on to the others).
    Normals,
}

/// The seed of object `receiver`'s gathered directions ([`TruthScene::gather`]).
fn object_seed(seed: u64, receiver: usize) -> u64 {
    seed ^ ((receiver as u64) << 40)
}

/// `n` points of the unit square, stratified: one in each cell of a √n × √n grid where n is
/// a square, else a Latin hypercube.
fn stratified(n: usize, rng: &mut Pcg32) -> Vec<Vec2> {
    let side = (n as f64).sqrt().round() as usize;
    if side * side != n {
        return latin_hypercube(n, rng);
    }
    let cell = 1.0 / side as f32;
    (0..n)
        .map(|k| {
            let (i, j) = (k % side, k / side);
            let x = ((i as f32 + rng.next_f32()) * cell).min(1.0 - f32::EPSILON);
            let y = ((j as f32 + rng.next_f32()) * cell).min(1.0 - f32::EPSILON);
            Vec2::new(x, y)
        })
        .collect()
}

/// Which directions count at a point, besides the shadow ray.
#[derive(Clone, Copy, Debug)]
enum Mask {
    /// Every direction.
    None,
    /// The face-averaged mask of this vertex of the receiver.
    Vertex(usize),
    /// The directions in front of this face (world unit normal).
    Face(Vec3),
}

/// `n` points stratified in each coordinate (a Latin hypercube: one per row and column
/// stratum, in random pairings).
fn latin_hypercube(n: usize, rng: &mut Pcg32) -> Vec<Vec2> {
    let mut px: Vec<usize> = (0..n).collect();
    let mut py: Vec<usize> = (0..n).collect();
    for k in (1..n).rev() {
        px.swap(k, rng.next_u32() as usize % (k + 1));
        py.swap(k, rng.next_u32() as usize % (k + 1));
    }
    let cell = |s: usize, rng: &mut Pcg32| ((s as f32 + rng.next_f32()) / n as f32).min(1.0 - f32::EPSILON);
    (0..n).map(|k| Vec2::new(cell(px[k], rng), cell(py[k], rng))).collect()
}

/// Why a truth scene cannot be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TruthError {
    /// Nothing to estimate.
    #[error("the scene has no objects: there is nothing to estimate")]
    NoObjects,
    /// No sample per point.
    #[error("spp must be at least 1")]
    NoSamples,
    /// More samples per point than [`MAX_SPP`].
    #[error(
        "{0} samples per point is more than the limit of {MAX_SPP} (each point holds its samples' strata; the \
         estimate's noise falls as 1/√spp, so 4× the samples halve it)"
    )]
    TooManySamples(u32),
    /// Every triangle is degenerate.
    #[error("the scene has no triangle of non-zero area")]
    NoTriangles,
    /// An object placed beyond the coordinates the BVH can hold.
    #[error(
        "object {object} reaches {extent:e} scene units from the origin, beyond the limit of {limit:e} (its \
         bounding boxes would overflow)"
    )]
    TooLarge {
        /// Object number.
        object: usize,
        /// Its largest world coordinate.
        extent: f32,
        /// The limit, `rsl_sphere::mesh::MAX_COORDINATE`.
        limit: f32,
    },
}

/// The most samples per point (pixel or vertex) the estimator takes.
pub const MAX_SPP: u32 = 1 << 16;

/// The most bounces of light the estimator follows ([`TruthScene::with_bounces`]): the
/// quality knob's bound.
pub use rsl_scene::quality::MAX_BOUNCES;

/// One object of a [`TruthScene`] placed in the world ([`TruthScene::new`]).
struct PlacedObject {
    positions: Vec<Vec3>,
    frames: Vec<Frame>,
    faces: IncidentFaces,
    /// Its triangles to trace (world space, unscaled), each with its owner (object,
    /// triangle).
    tris: Vec<Triangle>,
    owners: Vec<(u32, u32)>,
}

impl PlacedObject {
    /// Object `i`, `o`, placed by its transform.
    fn new(i: usize, o: &TruthObject<'_>) -> Result<Self, TruthError> {
        let pose = Pose::new(&o.transform);
        let p: Vec<Vec3> = o.mesh.positions.par_iter().map(|&p| pose.position(p)).collect();
        let limit = rsl_sphere::mesh::MAX_COORDINATE;
        let extent = p.iter().map(|x| x.abs().max_element()).fold(0.0, f32::max);
        if extent.is_nan() || extent > limit {
            return Err(TruthError::TooLarge { object: i, extent, limit });
        }
        let frames: Vec<Frame> =
            (0..o.mesh.vertex_count()).into_par_iter().map(|v| pose.frame(o.frames.shading(v))).collect();
        // Coincident copies of a triangle within an object: one is kept (a BVH cannot split
        // them, and every ray would test them all); the first copy is the face hit.
        let (mut tris, mut owners) = (Vec::new(), Vec::new());
        let mut seen = std::collections::HashSet::new();
        for (t, tri) in o.mesh.indices.chunks_exact(3).enumerate() {
            let [a, b, c] = [0, 1, 2].map(|k| p[tri[k] as usize]);
            if (b - a).cross(c - a).length_squared() > 0.0
                && a.is_finite()
                && b.is_finite()
                && c.is_finite()
                && seen.insert(rsl_sphere::mesh::triangle_key(a, b, c))
            {
                tris.push(Triangle { v0: a.into(), v1: b.into(), v2: c.into() });
                owners.push((i as u32, t as u32));
            }
        }
        let normals: Vec<Vec3> = frames.iter().map(|f| f.n).collect();
        let faces = IncidentFaces::new(&p, &normals, &o.mesh.indices);
        Ok(Self { positions: p, frames, faces, tris, owners })
    }
}

impl TruthScene {
    /// Places every object and builds the BVH. `world_from_env` rotates the environment.
    pub fn new(objects: &[TruthObject<'_>], env: EnvLight, world_from_env: Quat) -> Result<Self, TruthError> {
        if objects.is_empty() {
            return Err(TruthError::NoObjects);
        }
        // Each object placed apart (in parallel): its world positions and frames, its
        // triangles, and its vertices' faces.
        let placed: Vec<Result<PlacedObject, TruthError>> =
            objects.par_iter().enumerate().map(|(i, o)| PlacedObject::new(i, o)).collect();
        let (mut positions, mut frames, mut faces) = (Vec::new(), Vec::new(), Vec::new());
        let (mut tris, mut owners) = (Vec::new(), Vec::new());
        for placed in placed {
            let placed = placed?;
            tris.extend(placed.tris);
            owners.extend(placed.owners);
            positions.push(placed.positions);
            frames.push(placed.frames);
            faces.push(placed.faces);
        }
        if tris.is_empty() {
            return Err(TruthError::NoTriangles);
        }
        let (lo, hi) =
            positions.iter().flatten().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), &p| (l.min(p), h.max(p)));
        let radius = 0.5 * (hi - lo).length();
        // Traced at a power-of-two scale (`rsl_sphere::mesh::ray_scale`), so that rays
        // resolve scenes of any size.
        let scale = rsl_sphere::mesh::ray_scale(radius, lo.abs().max(hi.abs()).max_element());
        tris.par_iter_mut().for_each(|t| *t = Triangle { v0: t.v0 * scale, v1: t.v1 * scale, v2: t.v2 * scale });
        let bvh = build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut std::time::Duration::default());
        Ok(Self {
            positions,
            frames,
            faces,
            indices: objects.iter().map(|o| o.mesh.indices.clone()).collect(),
            brdfs: objects.iter().map(|o| o.brdf).collect(),
            textures: objects.iter().map(|o| o.texture.map(|t| (t.clone(), t.vertex_means(o.mesh)))).collect(),
            metallic_roughness: objects
                .iter()
                .map(|o| o.metallic_roughness.map(|t| (t.clone(), t.map.vertex_means(o.mesh))))
                .collect(),
            casts: objects.iter().map(|o| o.casts_shadows).collect(),
            bvh,
            tris,
            owners,
            env,
            env_from_world: world_from_env.inverse(),
            world_from_env,
            offset: 1e-4 * radius.max(f32::MIN_POSITIVE),
            scale,
            filter: PixelFilter::Box,
            bounces: 0,
        })
    }

    /// Object `i`'s BRDF at `place`: its metallic-roughness texture's values there, and its
    /// base-colour texture's multiplying its base colour.
    fn brdf_at(&self, i: usize, place: Place) -> Brdf {
        let brdf = match (&self.metallic_roughness[i], place) {
            (None, _) | (_, Place::Untextured) => self.brdfs[i],
            (Some((t, means)), Place::Vertex(v)) => t.apply(&self.brdfs[i], means[v]),
            (Some((t, _)), Place::Point(corners, weights)) => {
                t.apply(&self.brdfs[i], t.map.at_corners(corners, weights))
            }
        };
        match (&self.textures[i], place) {
            (None, _) | (_, Place::Untextured) => brdf,
            (Some((_, means)), Place::Vertex(v)) => textured(&brdf, means[v]),
            (Some((t, _)), Place::Point(corners, weights)) => textured(&brdf, t.at_corners(corners, weights)),
        }
    }

    /// World positions of object `i`'s vertices.
    pub fn positions(&self, i: usize) -> &[Vec3] {
        &self.positions[i]
    }

    /// The world shading frame of vertex `v` of object `i`.
    pub fn frame(&self, i: usize, v: usize) -> &Frame {
        &self.frames[i][v]
    }

    /// Radiance of the environment toward world direction `d`.
    pub fn background(&self, d: Vec3) -> Vec3 {
        self.env.radiance(self.env_from_world * d)
    }

    /// Whether light from world direction `dir` reaches `x` on object `receiver`.
    fn visible(&self, receiver: usize, x: Vec3, dir: Vec3) -> bool {
        self.visible_past(x, dir, |owner| owner == receiver || self.casts[owner])
    }

    /// Whether light from world direction `dir` reaches `x` on object `receiver` past the
    /// triangles of the objects `blocks` accepts.
    fn visible_past(&self, x: Vec3, dir: Vec3, blocks: impl Fn(usize) -> bool) -> bool {
        let ray = Ray::new(Vec3A::from(x * self.scale), Vec3A::from(dir), 0.0, f32::INFINITY);
        self.bvh.ray_traverse_miss(ray, |ray, id| {
            let k = self.bvh.primitive_indices[id] as usize;
            if blocks(self.owners[k].0 as usize) { self.tris[k].intersect(ray) } else { f32::INFINITY }
        })
    }

    /// The estimate at `x` on object `receiver` with shading frame `frame`, seen from
    /// direction `view` (world, unit, toward the eye), with `spp` samples from `rng` (no
    /// face mask: every direction above the shading frame's horizon counts).
    pub fn estimate(
        &self,
        receiver: usize,
        x: Vec3,
        frame: &Frame,
        view: Vec3,
        spp: u32,
        rng: &mut Pcg32,
    ) -> (Estimate, u64) {
        self.estimate_masked(receiver, x, frame, view, spp, Mask::None, rng)
    }

    /// The face-averaged mask of vertex `vertex` of object `object` for world direction `dir`
    /// (`h(ω)`, see the module's documentation).
    pub fn mask(&self, object: usize, vertex: usize, dir: Vec3) -> f32 {
        self.faces[object].mask(vertex, dir)
    }

    /// [`TruthScene::estimate`] with every direction's visibility weighted by `mask`.
    #[allow(clippy::too_many_arguments)]
    fn estimate_masked(
        &self,
        receiver: usize,
        x: Vec3,
        frame: &Frame,
        view: Vec3,
        spp: u32,
        mask: Mask,
        rng: &mut Pcg32,
    ) -> (Estimate, u64) {
        let wo = frame.to_local(view);
        if wo.z <= 0.0 || spp == 0 {
            return (Estimate::default(), 0);
        }
        let origin = x + frame.n * self.offset;
        let brdf = match mask {
            Mask::Vertex(v) => self.brdf_at(receiver, Place::Vertex(v)),
            _ => self.brdf_at(receiver, Place::Untextured),
        };
        let mut samples = Replicates::new(spp as usize);
        let mut rays = 0u64;
        for _ in 0..samples.count() {
            let (ul, ub) = (latin_hypercube(samples.per, rng), latin_hypercube(samples.per, rng));
            for k in 0..samples.per {
                let lobe = rng.next_f32();
                let (y, r) =
                    self.sample(receiver, &brdf, origin, frame, wo, mask, [ul[k], ub[k]], lobe, self.bounces, rng);
                rays += r;
                samples.add(y);
            }
            samples.end_replicate();
        }
        (samples.estimate(), rays)
    }

    /// One sample of each strategy, MIS-weighted (power heuristic): the sum, and the shadow
    /// rays traced.
    /// With `bounces` left, a BRDF direction that meets a surface continues there, drawing
    /// its random numbers from `rng` (none drawn at 0 bounces).
    #[allow(clippy::too_many_arguments)]
    fn sample(
        &self,
        receiver: usize,
        brdf: &Brdf,
        origin: Vec3,
        frame: &Frame,
        wo: Vec3,
        mask: Mask,
        [ul, ub]: [Vec2; 2],
        lobe: f32,
        bounces: u32,
        rng: &mut Pcg32,
    ) -> (Vec3, u64) {
        let weight_of = |w: Vec3| match mask {
            Mask::None => 1.0,
            Mask::Vertex(v) => self.faces[receiver].mask(v, w),
            Mask::Face(n) => f32::from(u8::from(n.dot(w) > 0.0)),
        };
        // The direction's weight: its mask times whether the shadow ray gets through.
        let seen = |w: Vec3, rays: &mut u64| {
            let h = weight_of(w);
            if h <= 0.0 {
                return 0.0;
            }
            *rays += 1;
            if self.visible(receiver, origin, w) { h } else { 0.0 }
        };
        let mut y = Vec3::ZERO;
        let mut rays = 0;
        // Environment sample.
        let (d_env, pdf_l) = self.env.sample(ul);
        if pdf_l > 0.0 {
            let w = (self.world_from_env * d_env).normalize();
            let wi = frame.to_local(w);
            let f = brdf.eval_cos(wi, wo);
            if f != Vec3::ZERO {
                let h = seen(w, &mut rays);
                if h > 0.0 {
                    let pdf_b = brdf.pdf(wo, wi);
                    let weight = pdf_l * pdf_l / (pdf_l * pdf_l + pdf_b * pdf_b);
                    y += self.env.radiance(d_env) * f * (h * weight / pdf_l);
                }
            }
        }
        // BRDF sample.
        if let Some(wi) = brdf.sample(wo, ub, lobe)
            && wi.z > 0.0
        {
            let pdf_b = brdf.pdf(wo, wi);
            let f = brdf.eval_cos(wi, wo);
            if pdf_b > 0.0 && f != Vec3::ZERO {
                let w = frame.to_world(wi).normalize();
                let escaped = |h: f32| {
                    let d_env = self.env_from_world * w;
                    let pdf_l = self.env.pdf(d_env);
                    let weight = pdf_b * pdf_b / (pdf_l * pdf_l + pdf_b * pdf_b);
                    self.env.radiance(d_env) * f * (h * weight / pdf_b)
                };
                if bounces == 0 {
                    let h = seen(w, &mut rays);
                    if h > 0.0 {
                        y += escaped(h);
                    }
                } else {
                    let h = weight_of(w);
                    if h > 0.0 {
                        rays += 1;
                        match self.hit_surface(origin, w, |owner| owner == receiver || self.casts[owner]) {
                            None => y += escaped(h),
                            Some(hit) => {
                                let (j, p, hit_frame, face) = (hit.object, hit.point, hit.frame, hit.face);
                                let hit_brdf = self.brdf_at(j, Place::Point(hit.corners, hit.weights));
                                // The surface met sends its own light back along −w: the
                                // environment's sample there has its own MIS weight; this
                                // direction is the only strategy that finds the surface.
                                let back = -w;
                                let hit_frame = hit_frame.toward_view(back, face);
                                let wo_hit = hit_frame.to_local(back);
                                if wo_hit.z > 0.0 {
                                    let from = p + hit_frame.n * self.offset;
                                    let u = [rng.next_2d(), rng.next_2d()];
                                    let lobe_hit = rng.next_f32();
                                    let (l, r) = self.sample(
                                        j,
                                        &hit_brdf,
                                        from,
                                        &hit_frame,
                                        wo_hit,
                                        Mask::Face(face),
                                        u,
                                        lobe_hit,
                                        bounces - 1,
                                        rng,
                                    );
                                    rays += r;
                                    y += l * f * (h / pdf_b);
                                }
                            }
                        }
                    }
                }
            }
        }
        (y, rays)
    }

    /// Per object, per vertex: the estimate toward `eye` (whether or not the vertex is visible
    /// from it), deterministic for `seed`.
    pub fn vertices(&self, eye: Vec3, spp: u32, seed: u64) -> Result<(Vec<Vec<Estimate>>, TruthStats), TruthError> {
        self.vertices_with_progress(eye, spp, seed, &|_, _| {})
    }

    /// [`TruthScene::vertices`], calling `progress(done, total)` as vertices finish.
    pub fn vertices_with_progress(
        &self,
        eye: Vec3,
        spp: u32,
        seed: u64,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<(Vec<Vec<Estimate>>, TruthStats), TruthError> {
        let total: usize = self.positions.iter().map(Vec::len).sum();
        let done = std::sync::atomic::AtomicUsize::new(0);
        if spp == 0 {
            return Err(TruthError::NoSamples);
        }
        if spp > MAX_SPP {
            return Err(TruthError::TooManySamples(spp));
        }
        let mut stats = TruthStats::default();
        let mut out = Vec::with_capacity(self.positions.len());
        for i in 0..self.positions.len() {
            let est: Vec<(Estimate, u64)> = (0..self.positions[i].len())
                .into_par_iter()
                .map(|v| {
                    let mut rng =
                        Pcg32::new(seed ^ ((i as u64) << 40) ^ (v as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
                    let x = self.positions[i][v];
                    let view = (eye - x).normalize_or_zero();
                    let e = self.estimate_masked(i, x, &self.frames[i][v], view, spp, Mask::Vertex(v), &mut rng);
                    let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                    if d.is_multiple_of(256) || d == total {
                        progress(d, total);
                    }
                    e
                })
                .collect();
            stats.points += est.len() as u64;
            stats.shadow_rays += est.iter().map(|e| e.1).sum::<u64>();
            out.push(est.into_iter().map(|e| e.0).collect());
        }
        Ok((out, stats))
    }

    /// The closest surface along a ray among the triangles of the objects `blocks` accepts.
    fn hit_surface(&self, origin: Vec3, dir: Vec3, blocks: impl Fn(usize) -> bool) -> Option<SurfaceHit> {
        let ray = Ray::new(Vec3A::from(origin * self.scale), Vec3A::from(dir), 0.0, f32::INFINITY);
        let mut hit = RayHit::none();
        if !self.bvh.ray_traverse(ray, &mut hit, |ray, id| {
            let k = self.bvh.primitive_indices[id] as usize;
            if blocks(self.owners[k].0 as usize) { self.tris[k].intersect(ray) } else { f32::INFINITY }
        }) {
            return None;
        }
        let k = self.bvh.primitive_indices[hit.primitive_id as usize] as usize;
        let (i, t) = (self.owners[k].0 as usize, self.owners[k].1 as usize);
        let idx = &self.indices[i][3 * t..3 * t + 3];
        let p = origin + dir * (hit.t / self.scale);
        let [a, b, c] = [0, 1, 2].map(|m| self.positions[i][idx[m] as usize]);
        // Barycentric weights from sub-triangle areas.
        let n = (b - a).cross(c - a);
        let area = n.length_squared();
        let wb = (p - a).cross(c - a).dot(n) / area;
        let wc = (b - a).cross(p - a).dot(n) / area;
        let wa = 1.0 - wb - wc;
        let [fa, fb, fc] = [0, 1, 2].map(|m| self.frames[i][idx[m] as usize]);
        let normal = fa.n * wa + fb.n * wb + fc.n * wc;
        let tangent = fa.t * wa + fb.t * wb + fc.t * wc;
        let frame = Frame::from_normal_tangent(normal, tangent);
        let face = n.normalize_or_zero();
        Some(SurfaceHit {
            object: i,
            corners: [idx[0], idx[1], idx[2]],
            weights: Vec3::new(wa, wb, wc),
            face: if face.dot(frame.n) < 0.0 { -face } else { face },
            point: p,
            frame,
            toward: -dir,
        })
    }

    /// One bounce of light gathered at vertex `vertex` of object `receiver`: the light that
    /// the surfaces it sees (itself, and the objects that cast shadows) send toward it,
    /// reflected toward `view`, from `rays` directions drawn from its BRDF (stratified,
    /// deterministic for `seed` and the vertex). `source` gives what a surface sends back
    /// along a ray that meets it (toward `hit.toward`); a surface met from behind its face
    /// sends nothing, and directions that meet nothing bring nothing (the environment's
    /// light is the direct part's). Weighted by the vertex's face-averaged mask, as the
    /// estimate is.
    pub fn gather(
        &self,
        receiver: usize,
        vertex: usize,
        view: GatherView,
        rays: u32,
        seed: u64,
        source: &(dyn Fn(&SurfaceHit) -> Vec3 + Sync),
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        self.gather_with(receiver, vertex, (view, rays), (seed, [0.0; 3]), source, |_, f, pdf, (light, h)| {
            sum += light * f * (h / pdf);
        });
        sum / rays.max(1) as f32
    }

    /// [`TruthScene::gather`]'s directions at a vertex of a Lambertian receiver, kept as
    /// moments from which any nearby normal's light follows: `M = (1/N) Σ L·h·ω / (π·pdf)`
    /// (three vectors, one per world axis of `ω`), so that the light reflected about a unit
    /// normal `n` is `ρ ⊙ (M · n)` ([`TruthScene::reflect_moments`]), the vertex's own
    /// estimate where `n` is its normal. Each vertex shifts the object's stratified set by
    /// its own fixed offset (a Cranley–Patterson rotation, the same from frame to frame), so
    /// that neighbouring vertices' errors are independent and a mean of their moments brings
    /// them down. `None` where the vertex faces away from `view` or no ray is asked for.
    pub fn gather_moments(
        &self,
        receiver: usize,
        vertex: usize,
        view: GatherView,
        rays: u32,
        seed: u64,
        source: &(dyn Fn(&SurfaceHit) -> Vec3 + Sync),
    ) -> Option<[Vec3; 3]> {
        let mut at = Pcg32::new(object_seed(seed, receiver) ^ (vertex as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let shift = [at.next_f32(), at.next_f32(), at.next_f32()];
        let mut m = [Vec3::ZERO; 3];
        let gathered =
            self.gather_with(receiver, vertex, (view, rays), (seed, shift), source, |w, _, pdf, (light, h)| {
                let k = light * (h / (std::f32::consts::PI * pdf));
                m[0] += k * w.x;
                m[1] += k * w.y;
                m[2] += k * w.z;
            });
        gathered.then(|| m.map(|c| c / rays as f32))
    }

    /// The light vertex `vertex` of a Lambertian `receiver` reflects from gathered moments
    /// `m` (its own or a neighbour's, [`TruthScene::gather_moments`]): its albedo times `m`
    /// applied to its normal.
    pub fn reflect_moments(&self, receiver: usize, vertex: usize, m: &[Vec3; 3]) -> Vec3 {
        let n = self.frames[receiver][vertex].n;
        let albedo = self.brdf_at(receiver, Place::Vertex(vertex)).diffuse();
        albedo * (m[0] * n.x + m[1] * n.y + m[2] * n.z).max(Vec3::ZERO)
    }

    /// The gather's loop: `each(world direction, BRDF × cosine, pdf, (light met, mask))` for
    /// every direction that brings light; the stratified set moved by `shift` (the BRDF's
    /// two sample coordinates and its lobe choice, wrapped into [0, 1)). `false` where the
    /// vertex faces away from `view` or no ray is asked for.
    fn gather_with(
        &self,
        receiver: usize,
        vertex: usize,
        (view, rays): (GatherView, u32),
        (seed, shift): (u64, [f32; 3]),
        source: &(dyn Fn(&SurfaceHit) -> Vec3 + Sync),
        mut each: impl FnMut(Vec3, Vec3, f32, (Vec3, f32)),
    ) -> bool {
        let frame = &self.frames[receiver][vertex];
        let x = self.positions[receiver][vertex];
        let wo = match view {
            GatherView::Eye(eye) => frame.to_local((eye - x).normalize_or_zero()),
            GatherView::Normals => Vec3::Z,
        };
        if wo.z <= 0.0 || rays == 0 {
            return false;
        }
        let origin = x + frame.n * self.offset;
        let brdf = &self.brdf_at(receiver, Place::Vertex(vertex));
        // The same directions at every vertex of the object, in each vertex's own frame (moved
        // by the vertex's own shift where there is one): without, the gathered light varies
        // smoothly over a surface (its error a smooth bias, not noise from vertex to vertex).
        let mut rng = Pcg32::new(object_seed(seed, receiver));
        let wrap = |x: f32| {
            let y = x - x.floor();
            if y < 1.0 { y } else { 0.0 }
        };
        for u in stratified(rays as usize, &mut rng) {
            let u = Vec2::new(wrap(u.x + shift[0]), wrap(u.y + shift[1]));
            let lobe = wrap(rng.next_f32() + shift[2]);
            let Some(wi) = brdf.sample(wo, u, lobe) else { continue };
            let pdf = brdf.pdf(wo, wi);
            let f = brdf.eval_cos(wi, wo);
            if wi.z <= 0.0 || pdf.is_nan() || pdf <= 0.0 || f == Vec3::ZERO {
                continue;
            }
            let w = frame.to_world(wi).normalize();
            let h = self.faces[receiver].mask(vertex, w);
            if h <= 0.0 {
                continue;
            }
            let Some(mut hit) = self.hit_surface(origin, w, |owner| owner == receiver || self.casts[owner]) else {
                continue;
            };
            // The face met must face back along the ray (one-sided surfaces); a silhouette's
            // shading normal turned toward it, as the truth's is.
            if hit.face.dot(-w) <= 0.0 {
                continue;
            }
            hit.frame = hit.frame.toward_view(-w, hit.face);
            each(w, f, pdf, (source(&hit), h));
        }
        true
    }

    /// The same scene, its light followed through `bounces` bounces between surfaces (paths
    /// of up to `bounces + 1` segments from the point estimated; at most [`MAX_BOUNCES`]): a
    /// direction the BRDF samples that meets a surface (the object itself, or another that
    /// casts shadows) brings that surface's own estimate toward the point, one sample of
    /// each strategy there too. 0 (the default): the environment's light alone, each
    /// blocked direction black — every figure as before.
    pub fn with_bounces(mut self, bounces: u32) -> Self {
        self.bounces = bounces.min(MAX_BOUNCES);
        self
    }

    /// The same scene, its pixels sampled as `filter` says (the box filter by default).
    pub fn with_pixel_filter(mut self, filter: PixelFilter) -> Self {
        self.filter = filter;
        self
    }

    /// Pixel `(x, y)`'s value, the mean radiance over its square, from `spp` samples at
    /// stratified positions inside it (a Latin hypercube per replicate, as the BRDF's and the
    /// light's directions are; all at its centre under [`PixelFilter::Centre`]): each sample
    /// follows its own primary ray to the object it meets — one sample of each strategy
    /// there, as [`TruthScene::estimate`] — or to the environment. Returns the estimate (its
    /// standard error from independent replicates), whether an object covers the pixel's
    /// centre (as in the methods' images), and the shadow rays traced.
    pub fn pixel(&self, camera: &Camera, x: u32, y: u32, spp: u32, rng: &mut Pcg32) -> (Estimate, bool, u64) {
        let mut samples = Replicates::new(spp as usize);
        let per = samples.per;
        let mut rays = 0u64;
        for _ in 0..samples.count() {
            let at = latin_hypercube(per, rng);
            let (ul, ub) = (latin_hypercube(per, rng), latin_hypercube(per, rng));
            for k in 0..per {
                let at = match self.filter {
                    PixelFilter::Box => at[k],
                    PixelFilter::Centre => Vec2::splat(0.5),
                };
                let dir = rsl_frame::image_ray(camera, x as f32 + at.x, y as f32 + at.y);
                let value = match self.hit_surface(camera.eye, dir, |_| true) {
                    None => self.background(dir),
                    Some(hit) => {
                        let (i, p, frame, face) = (hit.object, hit.point, hit.frame, hit.face);
                        let brdf = self.brdf_at(i, Place::Point(hit.corners, hit.weights));
                        // A silhouette's normal turned toward the eye (docs/conventions.md).
                        let frame = frame.toward_view(-dir, face);
                        let wo = frame.to_local(-dir);
                        if wo.z <= 0.0 {
                            Vec3::ZERO
                        } else {
                            let origin = p + frame.n * self.offset;
                            let lobe = rng.next_f32();
                            let (v, r) = self.sample(
                                i,
                                &brdf,
                                origin,
                                &frame,
                                wo,
                                Mask::Face(face),
                                [ul[k], ub[k]],
                                lobe,
                                self.bounces,
                                rng,
                            );
                            rays += r;
                            v
                        }
                    }
                };
                samples.add(value);
            }
            samples.end_replicate();
        }
        let covered = self.hit_surface(camera.eye, rsl_frame::pixel_ray(camera, x, y), |_| true).is_some();
        (samples.estimate(), covered, rays)
    }

    /// Per pixel (row-major, row 0 at the top): the estimate of the pixel's value — the mean
    /// radiance over its square (a box filter), objects and environment alike
    /// ([`TruthScene::pixel`]) — and whether an object covers its centre.
    pub fn pixels(
        &self,
        camera: &Camera,
        spp: u32,
        seed: u64,
    ) -> Result<(Vec<Estimate>, Vec<bool>, TruthStats), TruthError> {
        self.pixels_with_progress(camera, spp, seed, &|_, _| {})
    }

    /// [`TruthScene::pixels`], calling `progress(done, total)` as pixels finish.
    pub fn pixels_with_progress(
        &self,
        camera: &Camera,
        spp: u32,
        seed: u64,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<(Vec<Estimate>, Vec<bool>, TruthStats), TruthError> {
        let total = (camera.width * camera.height) as usize;
        let done = std::sync::atomic::AtomicUsize::new(0);
        if spp == 0 {
            return Err(TruthError::NoSamples);
        }
        if spp > MAX_SPP {
            return Err(TruthError::TooManySamples(spp));
        }
        let (w, h) = (camera.width, camera.height);
        let px: Vec<(Estimate, bool, u64)> = (0..w * h)
            .into_par_iter()
            .map(|k| {
                let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                if d.is_multiple_of(4096) || d == total {
                    progress(d, total);
                }
                let mut rng = Pcg32::new(seed ^ u64::from(k).wrapping_mul(0x9e37_79b9_7f4a_7c15));
                self.pixel(camera, k % w, k / w, spp, &mut rng)
            })
            .collect();
        let stats =
            TruthStats { points: px.iter().filter(|p| p.1).count() as u64, shadow_rays: px.iter().map(|p| p.2).sum() };
        Ok((px.iter().map(|p| p.0).collect(), px.iter().map(|p| p.1).collect(), stats))
    }
}

/// Shadow rays for the RSL path's oracles, from the same points as the truth's (vertices
/// lifted `1e-4` scene radii along the shading normal). Objects that cast no shadows block
/// only themselves.
impl rsl_frame::Rays for TruthScene {
    fn visible(&self, object: usize, vertex: usize, dir: Vec3, blockers: rsl_frame::Blockers) -> bool {
        use rsl_frame::Blockers;
        let x = self.positions[object][vertex] + self.frames[object][vertex].n * self.offset;
        match blockers {
            Blockers::Own => self.visible_past(x, dir, |o| o == object),
            Blockers::Object(j) => j == object || !self.casts[j] || self.visible_past(x, dir, |o| o == j),
            Blockers::All { own, others } => {
                self.visible_past(x, dir, |o| if o == object { own } else { others && self.casts[o] })
            }
        }
    }

    fn mask(&self, object: usize, vertex: usize, dir: Vec3) -> f32 {
        self.faces[object].mask(vertex, dir)
    }
}

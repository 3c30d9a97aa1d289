//! Per-vertex shading with the multiple product approximation (Xu et al. 2006, eq. 5 and
//! fig. 8).
//!
//! For a vertex `x` with view `v` toward the eye, over the RSLs `⟨c_i, r_i, I_i⟩`:
//!
//! `B = Σ_i I_i · ∫_{square_i} ρ cos θ dω · cover_self(square_i) · Π_j cover_Oj(square_i)`
//!
//! which is `Σ E_i · avg_ρ · cover_self · Π cover_Oj` with the energy `E_i = I_i·4r_i²`.
//!
//! - The BRDF square lies in the vertex's shading frame in world space: the object-space
//!   frame (normal, and tangent for anisotropic materials) carried by the object's current
//!   rotation and scale (normals by `R·S⁻¹`, tangents by `R·S`).
//! - Self visibility is looked up in the vertex's object-space frame `Frame::from_normal(n)`
//!   (as the SVDF was built), with the light direction carried into object space by
//!   `S⁻¹·R⁻¹`: ray casting commutes with affine maps, so the direction is exact under any
//!   scale; the square's size is kept. `cover_self` is the visible fraction of the square's
//!   part above the vertex's horizon (the field's coverage divided by the horizon's alone):
//!   the BRDF integral already leaves out the part below, and multiplying by the field's
//!   coverage (which counts that part as hidden) would count the horizon twice — a square
//!   half below the horizon would get half its light. On a rough ball under a low sun this
//!   darkened grazing views by 20 % (measured: 8.6 % → 6.4 % per vertex, README).
//! - Occluder `j` is looked up in its own object space at its current transform: the point
//!   by `S⁻¹·R⁻¹·(x − t)`, the direction as above.
//! - Occluder culling: occluder `j` is skipped for RSL `i` when `x` lies beyond the field's
//!   outer shell (the field holds nothing there), or when the RSL's cone from `x` cannot meet
//!   `j`'s bounding sphere. The cone's half-angle is the angle from the centre to a corner of
//!   the square placed on the pole of the hemisphere map, `acos(1 − r²)`.
//!
//! [`shade_reference`] is the plain loop over vertices, RSLs and occluders through the
//! crates' public lookups; [`shade`] is the fast path (rayon over vertex blocks, the view's
//! table slices and each occluder's proximity found once per vertex, zero terms skipped).
//! They agree to float rounding.

use glam::{Mat3, Vec2, Vec3};
use rayon::prelude::*;
use rsl_brdf::{BrdfTable, ViewLookup};
use rsl_scene::Transform;
use rsl_sphere::Frame;
use rsl_sphere::hemi::hemi_from_dir;
use rsl_sphere::mesh::TriMesh;
use rsl_vis::ovdf::OUTER;
use rsl_vis::{FaceMask, Ovdf, OvdfLookup, Svdf};

/// A rotatable square light in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Unit centre direction (world space, toward the light).
    pub dir: Vec3,
    /// Half-diagonal of the square in the hemisphere plane (solid angle `4r²`).
    pub half_diagonal: f32,
    /// Uniform radiance (RGB).
    pub radiance: Vec3,
}

impl Light {
    /// Half-angle of the cone around `dir` that contains the square: the angle to a corner
    /// of the square centred on the pole of the hemisphere map, `acos(1 − r²)` (π once the
    /// square reaches past the equator of the map's plane).
    pub fn cone_half_angle(&self) -> f32 {
        let r2 = self.half_diagonal * self.half_diagonal;
        if r2.is_finite() { (1.0 - r2).clamp(-1.0, 1.0).acos() } else { std::f32::consts::PI }
    }
}

/// The per-vertex frames an object needs, computed once from its mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexFrames {
    /// `Frame::from_normal(n)` per vertex (object space): the frame of the self-visibility
    /// field.
    pub visibility: Vec<Frame>,
    /// Shading frames with the mesh's tangents (object space), for anisotropic BRDFs; `None`
    /// when the shading frame is the visibility frame.
    pub tangent: Option<Vec<Frame>>,
}

impl VertexFrames {
    /// The frames of `mesh`; `anisotropic` asks for tangent frames (from the mesh's tangents,
    /// or from a fixed axis when it has none).
    pub fn new(mesh: &TriMesh, anisotropic: bool) -> Self {
        let visibility = mesh.normals.iter().map(|&n| Frame::from_normal(n)).collect();
        let tangent = anisotropic.then(|| match &mesh.tangents {
            Some(t) => mesh.normals.iter().zip(t).map(|(&n, t)| Frame::from_normal_tangent(n, t.truncate())).collect(),
            None => {
                let mut m = mesh.clone();
                m.compute_tangents_from_axis();
                let t = m.tangents.unwrap_or_default();
                mesh.normals.iter().zip(t).map(|(&n, t)| Frame::from_normal_tangent(n, t.truncate())).collect()
            }
        });
        Self { visibility, tangent }
    }

    /// The object-space shading frame of vertex `v`.
    pub fn shading(&self, v: usize) -> &Frame {
        match &self.tangent {
            Some(t) => &t[v],
            None => &self.visibility[v],
        }
    }
}

/// One object as the shader sees it: its precomputed data and its current transform.
#[derive(Clone, Copy, Debug)]
pub struct ShadeObject<'a> {
    /// The mesh in object space.
    pub mesh: &'a TriMesh,
    /// Its vertex frames.
    pub frames: &'a VertexFrames,
    /// The material's table.
    pub table: &'a BrdfTable,
    /// Self-visibility (a convex object's field is analytic and stores nothing).
    pub svdf: &'a Svdf,
    /// The face-averaged vertex mask, part of self-visibility.
    pub mask: &'a FaceMask,
    /// The occluder field, or `None` for an object that casts no shadows.
    pub ovdf: Option<&'a Ovdf>,
    /// The current transform.
    pub transform: Transform,
}

/// Which terms of the product are evaluated (all of them by default); leaving some out
/// measures what they cost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Terms {
    /// Self-visibility (the SVDF).
    pub self_visibility: bool,
    /// Other objects' shadows (the OVDFs).
    pub occluders: bool,
}

impl Default for Terms {
    fn default() -> Self {
        Self { self_visibility: true, occluders: true }
    }
}

/// What a frame cost, in lookups.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Vertices shaded.
    pub vertices: u64,
    /// Vertices facing away from the eye (nothing reflected, nothing looked up).
    pub back_facing: u64,
    /// BRDF square lookups.
    pub brdf_lookups: u64,
    /// Self-visibility lookups.
    pub self_lookups: u64,
    /// Occluder-field lookups.
    pub occluder_lookups: u64,
    /// (vertex, RSL, occluder) triples skipped by culling.
    pub occluders_culled: u64,
}

impl FrameStats {
    /// The sum of two frames' (or parts of a frame's) counts.
    pub fn plus(mut self, o: Self) -> Self {
        self.vertices += o.vertices;
        self.back_facing += o.back_facing;
        self.brdf_lookups += o.brdf_lookups;
        self.self_lookups += o.self_lookups;
        self.occluder_lookups += o.occluder_lookups;
        self.occluders_culled += o.occluders_culled;
        self
    }
}

/// An object's transform in the forms shading needs. Every path that evaluates a vertex
/// (this crate's, the GPU's, the Monte Carlo truth's) places it with these.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Translation.
    pub translation: Vec3,
    /// `S⁻¹·R⁻¹`: world directions (and offsets) into object space.
    pub to_object: Mat3,
    /// `R·S⁻¹`: object normals to world.
    pub normal_to_world: Mat3,
    /// `R·S`: object tangents (and offsets) to world.
    pub linear_to_world: Mat3,
}

impl Pose {
    /// The pose of a transform `T·R·S`.
    pub fn new(t: &Transform) -> Self {
        let r = Mat3::from_quat(t.rotation);
        Self {
            translation: t.translation,
            to_object: Mat3::from_diagonal(t.scale.recip()) * r.transpose(),
            normal_to_world: r * Mat3::from_diagonal(t.scale.recip()),
            linear_to_world: r * Mat3::from_diagonal(t.scale),
        }
    }

    /// World position of an object-space point.
    pub fn position(&self, p: Vec3) -> Vec3 {
        self.translation + self.linear_to_world * p
    }

    /// Object-space position of a world point.
    pub fn point_to_object(&self, x: Vec3) -> Vec3 {
        self.to_object * (x - self.translation)
    }

    /// Unit object-space direction of a world direction (a light's centre, for the
    /// visibility fields).
    pub fn direction_to_object(&self, d: Vec3) -> Vec3 {
        (self.to_object * d).normalize_or_zero()
    }

    /// Unit world normal of an object-space normal.
    pub fn normal(&self, n: Vec3) -> Vec3 {
        (self.normal_to_world * n).normalize_or_zero()
    }

    /// The world-space shading frame of an object-space frame: its normal carried by
    /// `R·S⁻¹`, its tangent by `R·S` (then made orthogonal).
    pub fn frame(&self, f: &Frame) -> Frame {
        Frame::from_normal_tangent(self.normal_to_world * f.n, self.linear_to_world * f.t)
    }
}

/// The per-frame form of an object: its pose, and every light's direction in its object
/// space.
pub(crate) struct Placed<'a> {
    pub(crate) object: ShadeObject<'a>,
    pub(crate) pose: Pose,
    /// Light directions in object space (unit).
    pub(crate) light_dirs: Vec<Vec3>,
    /// Bounding sphere of the occluder field in world space, and its object-space form.
    bound: Option<OccluderBound>,
}

/// An occluder field's bounding sphere at an object's current transform: what culling and
/// the "beyond the outer shell" test read (every path that shades uses this one).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OccluderBound {
    /// Centre, world space.
    pub centre_world: Vec3,
    /// Radius, world space (scaled by the largest scale factor: a sphere that contains the
    /// scaled object).
    pub radius_world: f32,
    /// Centre, object space.
    pub centre_object: Vec3,
    /// Beyond this object-space distance from the centre the field holds nothing.
    pub reach_object: f32,
}

impl OccluderBound {
    /// The bound of `field` for an object at `transform` (whose pose is `pose`).
    pub fn new(field: &Ovdf, transform: &Transform, pose: &Pose) -> Self {
        let (c, radius) = field.bounds();
        Self {
            centre_world: pose.position(c),
            radius_world: radius * transform.scale.max_element(),
            centre_object: c,
            reach_object: OUTER * radius,
        }
    }
}

impl<'a> Placed<'a> {
    fn new(object: ShadeObject<'a>, lights: &[Light]) -> Self {
        let pose = Pose::new(&object.transform);
        let light_dirs = lights.iter().map(|l| pose.direction_to_object(l.dir)).collect();
        let bound = object.ovdf.map(|f| OccluderBound::new(f, &object.transform, &pose));
        Self { object, pose, light_dirs, bound }
    }

    fn point_to_object(&self, x: Vec3) -> Vec3 {
        self.pose.point_to_object(x)
    }

    pub(crate) fn position(&self, v: usize) -> Vec3 {
        self.pose.position(self.object.mesh.positions[v])
    }

    /// The world-space shading frame of vertex `v`.
    pub(crate) fn shading_frame(&self, v: usize) -> Frame {
        self.pose.frame(self.object.frames.shading(v))
    }
}

/// An occluder near a vertex: where the vertex lies in the occluder's space, and the sphere
/// test's inputs.
#[derive(Clone, Copy)]
pub(crate) struct Near {
    j: usize,
    x_object: Vec3,
    /// Unit direction from the vertex to the bounding-sphere centre (world).
    to_centre: Vec3,
    /// Angular radius `β` of the bounding sphere seen from the vertex, with its cosine and
    /// sine; `None` when the vertex is inside the sphere (nothing can be culled).
    angular_radius: Option<(f32, f32, f32)>,
}

/// A light's cone for culling: half-angle `α`, `cos α`, `sin α`.
#[derive(Clone, Copy)]
struct Cone(f32, f32, f32);

impl Cone {
    fn new(alpha: f32) -> Self {
        Self(alpha, alpha.cos(), alpha.sin())
    }
}

/// Whether the cone around `dir` misses the sphere of `near`: the angle γ between `dir` and
/// the sphere's centre exceeds `α + β`, i.e. `cos γ < cos(α + β)` while `α + β < π`.
fn culled(near: &Near, dir: Vec3, cone: Cone) -> bool {
    match near.angular_radius {
        None => false,
        Some((beta, cb, sb)) => {
            cone.0 + beta < std::f32::consts::PI && dir.dot(near.to_centre) < cone.1 * cb - cone.2 * sb
        }
    }
}

/// The occluder `j` as seen from the world point `x`, or `None` when `x` lies beyond its
/// field (which then occludes nothing).
fn near(placed: &Placed<'_>, j: usize, x: Vec3) -> Option<Near> {
    let b = placed.bound?;
    let x_object = placed.point_to_object(x);
    if (x_object - b.centre_object).length() >= b.reach_object {
        return None;
    }
    let offset = b.centre_world - x;
    let dist = offset.length();
    let angular_radius = (dist > b.radius_world).then(|| {
        // sin β = R/d and cos β = √(1 − sin²β), as the GPU computes them.
        let sb = (b.radius_world / dist).clamp(0.0, 1.0);
        (sb.asin(), (1.0 - sb * sb).max(0.0).sqrt(), sb)
    });
    let to_centre = if dist > 0.0 { offset / dist } else { Vec3::Y };
    Some(Near { j, x_object, to_centre, angular_radius })
}

/// Everything a frame needs: objects at their current transforms, lights, eye.
pub struct FrameSetup<'a> {
    pub(crate) placed: Vec<Placed<'a>>,
    pub(crate) lights: Vec<Light>,
    cones: Vec<Cone>,
    /// Per light, its [`rsl_vis::mask::reach`].
    reaches: Vec<(f32, f32)>,
    pub(crate) eye: Vec3,
    pub(crate) terms: Terms,
}

impl<'a> FrameSetup<'a> {
    /// Places the objects and carries every light into every object's space.
    pub fn new(objects: &[ShadeObject<'a>], lights: &[Light], eye: Vec3, terms: Terms) -> Self {
        Self {
            placed: objects.iter().map(|&o| Placed::new(o, lights)).collect(),
            lights: lights.to_vec(),
            cones: lights.iter().map(|l| Cone::new(l.cone_half_angle())).collect(),
            reaches: lights.iter().map(|l| rsl_vis::mask::reach(l.half_diagonal)).collect(),
            eye,
            terms,
        }
    }

    /// The parallel work items of a frame: `(object, block)` for every block of `size`
    /// vertices of every object.
    pub(crate) fn blocks(&self, size: usize) -> Vec<(usize, usize)> {
        self.placed
            .iter()
            .enumerate()
            .flat_map(|(i, p)| (0..p.object.mesh.vertex_count().div_ceil(size)).map(move |b| (i, b)))
            .collect()
    }

    /// World position of vertex `v` of object `i`.
    pub fn position(&self, i: usize, v: usize) -> Vec3 {
        self.placed[i].position(v)
    }

    /// World normal of vertex `v` of object `i`.
    pub fn normal(&self, i: usize, v: usize) -> Vec3 {
        let p = &self.placed[i];
        p.pose.normal(p.object.mesh.normals[v])
    }

    /// Radiance of vertex `v` of object `i` toward the eye, and its lookups (the fast path's
    /// inner loop).
    fn vertex(&self, i: usize, v: usize, nears: &mut Vec<(Near, Lazy<'a>)>, stats: &mut FrameStats) -> Vec3 {
        let p = &self.placed[i];
        let o = &p.object;
        stats.vertices += 1;
        let x = p.position(v);
        let frame = p.shading_frame(v);
        let view = frame.to_local((self.eye - x).normalize_or_zero());
        let lookup = o.table.view_lookup(view);
        if lookup == ViewLookup::Below {
            stats.back_facing += 1;
            return Vec3::ZERO;
        }
        nears.clear();
        if self.terms.occluders {
            // Where the vertex lies in a field is found the first time a light needs it:
            // culling often leaves an occluder nothing to look up.
            self.nears(i, x, nears);
        }
        let vis_frame = &o.frames.visibility[v];
        let self_vis = o.svdf.vertex(v);
        let mask = o.mask.vertex(v);
        let mut sum = Vec3::ZERO;
        for (l, light) in self.lights.iter().enumerate() {
            let r = light.half_diagonal;
            stats.brdf_lookups += 1;
            let brdf = o.table.integral_for(&lookup, frame.to_local(light.dir), r);
            if brdf == Vec3::ZERO {
                continue;
            }
            let mut cover = 1.0;
            if self.terms.self_visibility {
                stats.self_lookups += 1;
                let q = hemi_from_dir(vis_frame.to_local(p.light_dirs[l]));
                cover = self_vis.coverage_above_horizon(q, r);
                if cover > 0.0 {
                    cover *= mask.share_above_horizon_with(q, r, self.reaches[l]);
                }
            }
            cover = self.occluder_cover(nears, l, cover, stats);
            sum += light.radiance * brdf * cover;
        }
        sum
    }

    /// `cover` times the occluder fields' coverages of light `l` at a vertex whose occluders
    /// are `nears` (located on first use); nothing is looked up once it is zero.
    pub(crate) fn occluder_cover(
        &self,
        nears: &mut [(Near, Lazy<'a>)],
        l: usize,
        mut cover: f32,
        stats: &mut FrameStats,
    ) -> f32 {
        let light = &self.lights[l];
        for (n, at) in nears.iter_mut() {
            if cover <= 0.0 {
                break;
            }
            if culled(n, light.dir, self.cones[l]) {
                stats.occluders_culled += 1;
                continue;
            }
            let q = &self.placed[n.j];
            if let Lazy::Unknown = at {
                *at = match q.object.ovdf.and_then(|f| Some(f.prepare(&f.locate(n.x_object)?))) {
                    Some(prepared) => Lazy::Ready(prepared),
                    None => Lazy::Outside,
                };
            }
            if let Lazy::Ready(at) = at {
                stats.occluder_lookups += 1;
                cover *= at.coverage(q.light_dirs[l], light.half_diagonal);
            }
        }
        cover
    }

    /// The occluders near world point `x` on object `i` (every other object whose field
    /// reaches `x`), not yet located in their fields.
    pub(crate) fn nears(&self, i: usize, x: Vec3, out: &mut Vec<(Near, Lazy<'a>)>) {
        out.clear();
        out.extend(
            (0..self.placed.len())
                .filter(|&j| j != i)
                .filter_map(|j| Some((near(&self.placed[j], j, x)?, Lazy::Unknown))),
        );
    }
}

/// An occluder field's lookup at a vertex, prepared when first needed.
// Held in a reused per-thread list (a box each would allocate per vertex and occluder).
#[allow(clippy::large_enum_variant)]
pub(crate) enum Lazy<'a> {
    /// Not located yet.
    Unknown,
    /// Beyond the field: nothing occluded.
    Outside,
    /// Located and prepared.
    Ready(OvdfLookup<'a>),
}

/// Vertices per parallel work item of the fast path.
const BLOCK: usize = 256;

/// Shades every vertex of every object (the fast path): per object, per vertex, the radiance
/// toward the eye.
pub fn shade(setup: &FrameSetup<'_>) -> (Vec<Vec<Vec3>>, FrameStats) {
    let blocks = setup.blocks(BLOCK);
    let done: Vec<(usize, usize, Vec<Vec3>, FrameStats)> = blocks
        .par_iter()
        .map_init(Vec::new, |nears, &(i, b)| {
            let n = setup.placed[i].object.mesh.vertex_count();
            let mut stats = FrameStats::default();
            let out = (b * BLOCK..((b + 1) * BLOCK).min(n)).map(|v| setup.vertex(i, v, nears, &mut stats)).collect();
            (i, b, out, stats)
        })
        .collect();
    let mut result: Vec<Vec<Vec3>> =
        setup.placed.iter().map(|p| Vec::with_capacity(p.object.mesh.vertex_count())).collect();
    let mut stats = FrameStats::default();
    for (i, _, out, s) in done {
        result[i].extend(out);
        stats = stats.plus(s);
    }
    (result, stats)
}

/// The reference: the formula as written, one vertex, RSL and occluder at a time, through
/// the public lookups of rsl-brdf and rsl-vis, with nothing hoisted. It culls as the fast
/// path does (an occluder outside its field's reach, or whose bounding sphere the light's
/// cone misses, covers nothing), so the two agree on which lookups are made; the culling
/// of an occluder beyond its field is checked to change nothing in rsl-engine's tests.
pub fn shade_reference(setup: &FrameSetup<'_>) -> Vec<Vec<Vec3>> {
    let mut out = Vec::new();
    for (i, p) in setup.placed.iter().enumerate() {
        let o = &p.object;
        let mut radiance = Vec::with_capacity(o.mesh.vertex_count());
        for v in 0..o.mesh.vertex_count() {
            let x = p.position(v);
            let frame = p.shading_frame(v);
            let view = frame.to_local((setup.eye - x).normalize_or_zero());
            let vis_frame = Frame::from_normal(o.mesh.normals[v]);
            let mut sum = Vec3::ZERO;
            for (l, light) in setup.lights.iter().enumerate() {
                let r = light.half_diagonal;
                let brdf = o.table.square(frame.to_local(light.dir), r, view).integral;
                let mut cover = 1.0;
                if setup.terms.self_visibility {
                    let d = p.pose.direction_to_object(light.dir);
                    let q: Vec2 = hemi_from_dir(vis_frame.to_local(d));
                    cover = o.svdf.coverage_above_horizon(v, q, r) * o.mask.vertex(v).share_above_horizon(q, r);
                }
                if setup.terms.occluders {
                    for (j, q) in setup.placed.iter().enumerate() {
                        if j == i {
                            continue;
                        }
                        let Some(n) = near(q, j, x) else { continue };
                        if culled(&n, light.dir, setup.cones[l]) {
                            continue;
                        }
                        let d = q.pose.direction_to_object(light.dir);
                        cover *= q.object.ovdf.expect("near() needs a field").coverage(n.x_object, d, r);
                    }
                }
                sum += light.radiance * brdf * cover;
            }
            radiance.push(sum);
        }
        out.push(radiance);
    }
    out
}

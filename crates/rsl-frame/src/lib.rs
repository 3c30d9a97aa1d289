//! The frame-level types every way of shading a frame shares (the CPU shader rsl-shade, the
//! GPU passes of rsl-gpu, the truth of rsl-truth): lights in world space, vertex frames, the
//! objects a frame shades, which terms it evaluates, traced lights, lookup counts, object
//! poses and occluder bounds; the camera's rays and projection, the linear image; and the
//! shadow rays an oracle or the truth traces (`Rays`).

mod camera;
mod rays;

pub use camera::{Image, Projection, RasterMesh, image_point, image_ray, pixel_ray};
pub use rays::{Blockers, Rays};

use glam::{Mat3, Vec2, Vec3};
use rsl_brdf::BrdfTable;
use rsl_scene::Transform;
use rsl_sphere::Frame;
use rsl_sphere::mesh::TriMesh;
use rsl_vis::ovdf::OUTER;
use rsl_vis::rays::Occluder;
use rsl_vis::{FaceMask, Ovdf, Svdf};

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
    /// The object's triangles in a BVH (object space), for the shadow rays of traced lights
    /// (against itself when its self-visibility field is stored, against others when it
    /// casts shadows); `None` when no light is traced, or neither applies.
    pub occluder: Option<&'a Occluder>,
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

/// Which lights get traced shadows from other objects instead of occluder fields (module
/// docs): the `lights` of highest radiance (luminance per steradian), `rays` rays each per
/// vertex. Either at zero traces nothing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Traced {
    /// How many lights are traced.
    pub lights: usize,
    /// Rays per traced light per vertex.
    pub rays: usize,
}

impl Traced {
    /// Which of `lights` are traced: the `self.lights` of highest luminance (the earlier
    /// light on ties), as a flag per light.
    pub fn select(&self, lights: &[Light]) -> Vec<bool> {
        let mut flags = vec![false; lights.len()];
        if self.rays == 0 {
            return flags;
        }
        let luminance = |l: &Light| l.radiance.dot(Vec3::new(0.2126, 0.7152, 0.0722));
        let mut order: Vec<usize> = (0..lights.len()).collect();
        order.sort_by(|&a, &b| luminance(&lights[b]).total_cmp(&luminance(&lights[a])).then(a.cmp(&b)));
        for &l in order.iter().take(self.lights) {
            flags[l] = true;
        }
        flags
    }

    /// `rays` offsets in the square `[-1, 1]²`: the R2 sequence (Roberts 2018) started at
    /// the centre, so that one ray goes to the light's centre and more fill the square evenly.
    pub fn pattern(&self) -> Vec<Vec2> {
        // 1/φ₂ and 1/φ₂², φ₂ the plastic number.
        const A: Vec2 = Vec2::new(0.754_877_7, 0.569_840_3);
        (0..self.rays)
            .map(|k| {
                let u = (Vec2::splat(0.5) + A * k as f32).fract();
                2.0 * u - Vec2::ONE
            })
            .collect()
    }
}

/// Every vertex's traced covers (rsl-shade's `FrameSetup::traced_covers`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TracedCovers {
    /// Per light, its slot among the traced lights (`None`: not traced).
    pub slots: Vec<Option<u32>>,
    /// Traced lights.
    pub count: u32,
    /// `covers[g·count + k]`: the cover of traced light `k` at vertex `g` (all objects'
    /// vertices in order).
    pub covers: Vec<f32>,
    /// Rays traced.
    pub rays: u64,
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
    /// Shadow rays traced toward traced lights.
    pub traced_rays: u64,
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
        self.traced_rays += o.traced_rays;
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

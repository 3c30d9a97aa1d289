//! Each object placed for a frame (its lights carried into its space, its occluder bound),
//! the traced lights' rays, and the culling of occluders per light. The frame-level types
//! themselves are rsl-frame's (re-exported here).

pub use rsl_frame::{FrameStats, Light, OccluderBound, Pose, ShadeObject, Terms, Traced, TracedCovers, VertexFrames};

use glam::Vec3;
use rsl_sphere::Frame;

/// The traced lights of a frame (see [`Traced`]).
#[derive(Clone, Debug, Default)]
pub(crate) struct TracedSetup {
    /// Per light, whether it is traced.
    pub(crate) flags: Vec<bool>,
    /// Per traced light, the world directions of its rays.
    pub(crate) dirs: Vec<Vec<Vec3>>,
    /// Per light, its index in `dirs` when traced.
    pub(crate) index: Vec<usize>,
    /// How far rays start from a vertex, along its normal (world units).
    pub(crate) lift: f32,
}

/// The per-frame form of an object: its pose, and every light's direction in its object
/// space.
pub(crate) struct Placed<'a> {
    pub(crate) object: ShadeObject<'a>,
    pub(crate) pose: Pose,
    /// Light directions in object space (unit).
    pub(crate) light_dirs: Vec<Vec3>,
    /// Bounding sphere of the occluder field in world space, and its object-space form.
    pub(crate) bound: Option<OccluderBound>,
    /// Whether the object's BRDF is view-independent (Lambertian: one table for every view).
    pub(crate) lambertian: bool,
}

impl<'a> Placed<'a> {
    pub(crate) fn new(object: ShadeObject<'a>, lights: &[Light]) -> Self {
        let pose = Pose::new(&object.transform);
        let light_dirs = lights.iter().map(|l| pose.direction_to_object(l.dir)).collect();
        let bound = object.ovdf.map(|f| OccluderBound::new(f, &object.transform, &pose));
        let lambertian = object.table.view_lookup(Vec3::Z) == rsl_brdf::ViewLookup::Single;
        Self { object, pose, light_dirs, bound, lambertian }
    }

    pub(crate) fn point_to_object(&self, x: Vec3) -> Vec3 {
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
    pub(crate) j: usize,
    pub(crate) x_object: Vec3,
    /// Unit direction from the vertex to the bounding-sphere centre (world).
    pub(crate) to_centre: Vec3,
    /// Angular radius `β` of the bounding sphere seen from the vertex, with its cosine and
    /// sine; `None` when the vertex is inside the sphere (nothing can be culled).
    pub(crate) angular_radius: Option<(f32, f32, f32)>,
}

/// A light's cone for culling: half-angle `α`, `cos α`, `sin α`.
#[derive(Clone, Copy)]
pub(crate) struct Cone(pub(crate) f32, pub(crate) f32, pub(crate) f32);

impl Cone {
    pub(crate) fn new(alpha: f32) -> Self {
        Self(alpha, alpha.cos(), alpha.sin())
    }
}

/// Whether the cone around `dir` misses the sphere of `near`: the angle γ between `dir` and
/// the sphere's centre exceeds `α + β`, i.e. `cos γ < cos(α + β)` while `α + β < π`.
pub(crate) fn culled(near: &Near, dir: Vec3, cone: Cone) -> bool {
    match near.angular_radius {
        None => false,
        Some((beta, cb, sb)) => {
            cone.0 + beta < std::f32::consts::PI && dir.dot(near.to_centre) < cone.1 * cb - cone.2 * sb
        }
    }
}

/// Whether the cone of half-angle `cone` around unit `dir` from `x` misses the sphere
/// (`centre`, `radius`); never when `x` is inside it.
pub(crate) fn cone_misses_sphere(x: Vec3, dir: Vec3, cone: Cone, centre: Vec3, radius: f32) -> bool {
    let offset = centre - x;
    let dist = offset.length();
    if dist <= radius {
        return false;
    }
    let sb = (radius / dist).clamp(0.0, 1.0);
    let (beta, cb) = (sb.asin(), (1.0 - sb * sb).max(0.0).sqrt());
    cone.0 + beta < std::f32::consts::PI && dir.dot(offset / dist) < cone.1 * cb - cone.2 * sb
}

/// The occluder `j` as seen from the world point `x`, or `None` when `x` lies beyond its
/// field (which then occludes nothing).
pub(crate) fn near(placed: &Placed<'_>, j: usize, x: Vec3) -> Option<Near> {
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

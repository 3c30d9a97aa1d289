//! Unit directions and orthonormal local frames.
//!
//! A [`Frame`] has its normal along local +z, matching the hemisphere map's convention
//! (docs/conventions.md, Local frames): `to_local(n) = (0, 0, 1)`.

use glam::Vec3;

/// Normalises `v`, or returns `None` when its length is zero or not finite.
pub fn try_normalize(v: Vec3) -> Option<Vec3> {
    let len2 = v.length_squared();
    if len2.is_finite() && len2 > 0.0 { Some(v / len2.sqrt()) } else { None }
}

/// The least cosine between a pixel's shading normal and its view where its face sees the
/// eye ([`Frame::toward_view`]).
pub const MIN_VIEW_COS: f32 = 0.05;

/// A right-handed orthonormal basis: `t × b = n`. Local coordinates are `(t, b, n)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Tangent, local +x.
    pub t: Vec3,
    /// Bitangent, local +y.
    pub b: Vec3,
    /// Normal, local +z.
    pub n: Vec3,
}

impl Frame {
    /// A frame around a unit normal, continuous except where `n.z` changes sign
    /// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited"). Accurate to f32
    /// rounding for every unit `n`, including the poles; `n` is renormalised first, and a
    /// zero or non-finite `n` gives the frame around +Y (world up).
    pub fn from_normal(n: Vec3) -> Self {
        let n = try_normalize(n).unwrap_or(Vec3::Y);
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { t, b: bt, n }
    }

    /// A frame whose tangent is `tangent` made orthogonal to `n` (Gram–Schmidt). When the
    /// tangent is zero, not finite or parallel to `n`, falls back to [`Frame::from_normal`].
    pub fn from_normal_tangent(n: Vec3, tangent: Vec3) -> Self {
        let n = try_normalize(n).unwrap_or(Vec3::Y);
        let ortho = tangent - n * n.dot(tangent);
        // Below ~1e-4 of the tangent's length the projection is dominated by rounding.
        // NaN lengths fail the comparison too, and fall back.
        if ortho.length_squared().partial_cmp(&(1e-8 * tangent.length_squared())) != Some(std::cmp::Ordering::Greater) {
            return Self::from_normal(n);
        }
        match try_normalize(ortho) {
            Some(t) => Self { t, b: n.cross(t), n },
            None => Self::from_normal(n),
        }
    }

    /// This frame as a pixel's shading frame seen along unit `view` (toward the eye), on a
    /// face of unit normal `face` (on the shading normal's side). Where the face sees the eye
    /// but the interpolated normal leans away from it — the silhouette of a smooth-shaded
    /// mesh, which a one-sided BRDF would draw black — the normal is turned toward the view,
    /// in the plane of the two, just far enough that `n·view` = [`MIN_VIEW_COS`] (the
    /// tangent made orthogonal to it again). Unchanged where `n·view` is at least that, and
    /// where the face itself does not see the eye (a back face reflects nothing).
    pub fn toward_view(&self, view: Vec3, face: Vec3) -> Self {
        let c = self.n.dot(view);
        if c >= MIN_VIEW_COS || face.dot(view) <= 0.0 || c.is_nan() {
            return *self;
        }
        let Some(u) = try_normalize(self.n - c * view) else { return Self::from_normal_tangent(face, self.t) };
        let n = MIN_VIEW_COS * view + (1.0 - MIN_VIEW_COS * MIN_VIEW_COS).sqrt() * u;
        Self::from_normal_tangent(n, self.t)
    }

    /// Local coordinates of a world vector.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    /// World vector of local coordinates.
    #[inline]
    pub fn to_world(&self, l: Vec3) -> Vec3 {
        self.t * l.x + self.b * l.y + self.n * l.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Pcg32, uniform_sphere};

    fn check_orthonormal(f: &Frame) {
        for (a, b) in [(f.t, f.b), (f.t, f.n), (f.b, f.n)] {
            assert!(a.dot(b).abs() < 1e-5, "not orthogonal: {f:?}");
        }
        for v in [f.t, f.b, f.n] {
            assert!((v.length() - 1.0).abs() < 1e-5, "not unit: {f:?}");
        }
        assert!((f.t.cross(f.b) - f.n).length() < 1e-5, "left-handed: {f:?}");
    }

    #[test]
    fn frames_are_orthonormal_everywhere() {
        let mut rng = Pcg32::new(7);
        let mut normals = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        normals.push(Vec3::new(1e-9, 0.0, -1.0).normalize());
        normals.push(Vec3::new(0.0, 1e-7, -1.0).normalize());
        for _ in 0..10_000 {
            normals.push(uniform_sphere(rng.next_2d()));
        }
        for n in normals {
            let f = Frame::from_normal(n);
            check_orthonormal(&f);
            assert!((f.n - n).length() < 1e-6);
            let v = Vec3::new(0.3, -0.5, 0.8);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
            assert!((f.to_local(n) - Vec3::Z).length() < 1e-5);
        }
    }

    #[test]
    fn tangent_frames_keep_the_tangent_direction() {
        let f = Frame::from_normal_tangent(Vec3::Y, Vec3::new(1.0, 0.3, 0.0));
        check_orthonormal(&f);
        assert!((f.t - Vec3::X).length() < 1e-6);
        // A tangent parallel to the normal falls back to a valid frame.
        let g = Frame::from_normal_tangent(Vec3::Y, Vec3::Y * 2.0);
        check_orthonormal(&g);
        let z = Frame::from_normal_tangent(Vec3::ZERO, Vec3::ZERO);
        check_orthonormal(&z);
        assert_eq!(z.n, Vec3::Y);
    }

    #[test]
    fn a_silhouettes_normal_is_turned_toward_the_view_only_where_its_face_sees_the_eye() {
        let view = Vec3::Z;
        let away = Frame::from_normal_tangent(Vec3::new(1.0, 0.0, -0.2), Vec3::Y);
        let face = Vec3::new(1.0, 0.0, 0.1).normalize();
        let turned = away.toward_view(view, face);
        assert!((turned.n.dot(view) - MIN_VIEW_COS).abs() < 1e-6, "{:?}", turned.n);
        // In the plane of the normal and the view, on the normal's side; still orthonormal.
        assert!(turned.n.y.abs() < 1e-6 && turned.n.x > 0.99);
        assert!((turned.n.length() - 1.0).abs() < 1e-6 && turned.t.dot(turned.n).abs() < 1e-6);
        // A back face, and a normal already facing the eye, are left as they are.
        assert_eq!(away.toward_view(view, -face), away);
        let facing = Frame::from_normal(Vec3::new(0.3, 0.0, 1.0));
        assert_eq!(facing.toward_view(view, face), facing);
        // A normal straight away from the eye takes the face's.
        let opposite = Frame::from_normal(-Vec3::Z);
        assert!((opposite.toward_view(view, face).n - face).length() < 1e-6);
    }
}

//! Transforms and their motion over time.
//!
//! Scene time is in seconds. An object's transform at time `t` is built from its base
//! transform (`world_from_object = T·R·S`) and its motion:
//! - `spin` rotates the object about its own origin: `R(t) = R_spin(ω·t)·R`;
//! - `orbit` carries the translation around an axis through `centre`:
//!   `T(t) = centre + R_orbit(ω·t)·(T − centre)`;
//! - `keyframes` replace translation, rotation and scale with linear (slerp for rotations)
//!   interpolation between keys, held constant before the first and after the last key.
//!
//! `spin` and `orbit` combine; `keyframes` stand alone.

use glam::{Mat4, Quat, Vec3};

/// Rotation, translation and scale of an object; `matrix()` is `T·R·S`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Translation.
    pub translation: Vec3,
    /// Rotation.
    pub rotation: Quat,
    /// Per-axis scale (all components > 0).
    pub scale: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Self { translation: Vec3::ZERO, rotation: Quat::IDENTITY, scale: Vec3::ONE }
    }
}

impl Transform {
    /// `world_from_object = T·R·S`.
    pub fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

/// A constant-rate rotation about a unit axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spin {
    /// Unit axis (world space).
    pub axis: Vec3,
    /// Angular speed in radians per second.
    pub radians_per_second: f32,
}

impl Spin {
    /// The rotation after `t` seconds.
    pub fn at(&self, t: f32) -> Quat {
        Quat::from_axis_angle(self.axis, self.radians_per_second * t)
    }
}

/// An orbit of the translation around an axis through `centre`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// A point on the axis.
    pub centre: Vec3,
    /// The axis and speed.
    pub spin: Spin,
}

/// One key of a keyframed motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    /// Time in seconds.
    pub time: f32,
    /// The transform at that time.
    pub transform: Transform,
}

/// How an object moves.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Motion {
    /// Rotation about the object's origin.
    pub spin: Option<Spin>,
    /// Orbit of its position.
    pub orbit: Option<Orbit>,
    /// Keyframes, sorted by strictly increasing time; non-empty replaces spin and orbit.
    pub keyframes: Vec<Keyframe>,
}

impl Motion {
    /// Whether the object moves at all.
    pub fn is_static(&self) -> bool {
        self.spin.is_none() && self.orbit.is_none() && self.keyframes.is_empty()
    }

    /// The transform at time `t` given the base transform.
    pub fn at(&self, base: &Transform, t: f32) -> Transform {
        if !self.keyframes.is_empty() {
            return interpolate(&self.keyframes, t);
        }
        let mut out = *base;
        if let Some(s) = &self.spin {
            out.rotation = (s.at(t) * out.rotation).normalize();
        }
        if let Some(o) = &self.orbit {
            out.translation = o.centre + o.spin.at(t) * (out.translation - o.centre);
        }
        out
    }
}

fn interpolate(keys: &[Keyframe], t: f32) -> Transform {
    let first = &keys[0];
    let last = &keys[keys.len() - 1];
    if t <= first.time || keys.len() == 1 {
        return first.transform;
    }
    if t >= last.time {
        return last.transform;
    }
    let k = keys.partition_point(|k| k.time <= t);
    let (a, b) = (&keys[k - 1], &keys[k]);
    let s = (t - a.time) / (b.time - a.time);
    Transform {
        translation: a.transform.translation.lerp(b.transform.translation, s),
        rotation: a.transform.rotation.slerp(b.transform.rotation, s).normalize(),
        scale: a.transform.scale.lerp(b.transform.scale, s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::FRAC_PI_2;

    #[test]
    fn spin_and_orbit_follow_their_rates() {
        let base = Transform { translation: Vec3::new(2.0, 0.0, 0.0), ..Default::default() };
        let m = Motion {
            spin: Some(Spin { axis: Vec3::Y, radians_per_second: FRAC_PI_2 }),
            orbit: Some(Orbit { centre: Vec3::ZERO, spin: Spin { axis: Vec3::Y, radians_per_second: FRAC_PI_2 } }),
            keyframes: vec![],
        };
        let s = m.at(&base, 1.0);
        // A quarter turn about +Y takes +X to −Z.
        assert!((s.translation - Vec3::new(0.0, 0.0, -2.0)).length() < 1e-5);
        assert!((s.rotation * Vec3::X - Vec3::NEG_Z).length() < 1e-5);
        assert_eq!(m.at(&base, 0.0).translation, base.translation);
    }

    #[test]
    fn keyframes_interpolate_and_hold() {
        let key = |time: f32, x: f32, deg: f32| Keyframe {
            time,
            transform: Transform {
                translation: Vec3::new(x, 0.0, 0.0),
                rotation: Quat::from_rotation_y(deg.to_radians()),
                scale: Vec3::ONE,
            },
        };
        let m = Motion { keyframes: vec![key(1.0, 0.0, 0.0), key(3.0, 4.0, 90.0)], ..Default::default() };
        let base = Transform::default();
        assert_eq!(m.at(&base, 0.0).translation.x, 0.0);
        assert!((m.at(&base, 2.0).translation.x - 2.0).abs() < 1e-6);
        let r = m.at(&base, 2.0).rotation;
        assert!((r.angle_between(Quat::from_rotation_y(45f32.to_radians()))).abs() < 1e-5);
        assert_eq!(m.at(&base, 10.0).translation.x, 4.0);
    }

    #[test]
    fn matrix_is_translate_rotate_scale() {
        let t = Transform {
            translation: Vec3::new(1.0, 2.0, 3.0),
            rotation: Quat::from_rotation_z(FRAC_PI_2),
            scale: Vec3::splat(2.0),
        };
        // S first: X → 2X; then R: 2X → 2Y; then T.
        let p = t.matrix().transform_point3(Vec3::X);
        assert!((p - Vec3::new(1.0, 4.0, 3.0)).length() < 1e-5);
    }
}

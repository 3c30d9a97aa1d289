//! Spherical foundations shared by every rsl crate.
//!
//! # Conventions (binding for the whole workspace)
//!
//! - World space is right-handed with **+Y up**. Colours are linear RGB in `f32`.
//!   Angles are radians in code; degrees appear only in files and on the command line.
//! - Every integral over directions is in **steradians**; radiance in, radiance out.
//! - **Lat-long maps** follow Mitsuba 3: a direction `d` in environment space maps to
//!   `u = atan2(d.x, −d.z) / 2π` wrapped to `[0, 1)` and `v = acos(d.y) / π` (`v = 0` is
//!   the top row, +Y). Texel `(i, j)` of a `W×H` map has its centre at
//!   `u = (i + ½)/W`, `v = (j + ½)/H`; lookups are bilinear between centres, wrapping in `u`
//!   ([`latlong`]).
//! - **Hemisphere map** (Xu et al. 2006, §5): in a local frame with the normal along +z,
//!   `ω = (x, y, z) ↦ p = (x, y)/√(1 + z)`. This is Lambert's azimuthal equal-area map:
//!   `|p|² = 1 − cos θ`, the upper hemisphere fills the unit disk, the lower hemisphere the
//!   ring up to `|p| = √2`, and **plane area = solid angle / 2** ([`hemi`]).
//! - Tables live on an `N×N` grid over `[−1, 1]²` ([`hemi::HemiGrid`]); cells outside the unit
//!   disk are below the horizon.
//! - Cube grids are `6×R×R` with exact texel solid angles ([`cube::CubeGrid`]).
//! - Object transforms apply scale, then rotation, then translation
//!   (`world_from_object = T·R·S`).
//! - Errors are relative L2: `‖L − L_ref‖₂ / ‖L_ref‖₂`; times in milliseconds; sizes in bytes.

pub mod approx;
pub mod cube;
pub mod faces;
pub mod frame;
pub mod framed;
pub mod hemi;
pub mod io;
pub mod key;
pub mod latlong;
pub mod mesh;
pub mod sampling;
pub mod scratch;
pub mod simd;

pub use frame::Frame;
pub use glam;
pub use glam::{DVec2, DVec3, Mat3, Mat4, Quat, Vec2, Vec3, Vec4};

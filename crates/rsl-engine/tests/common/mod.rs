//! Helpers shared by the engine's test binaries: scenes built in code, materials, and the analytic cap a ball
//! casts on a plane under a constant environment.

// Each test binary uses its own subset.
#![allow(dead_code)]

use glam::Vec3;
use rsl_engine::method::Frame;
use rsl_engine::scene::Scene;
use rsl_scene::build::{ObjectBuilder, SceneBuilder};
use rsl_scene::{Brdf, Preset};
use std::path::PathBuf;

/// The repository's root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The scene `b` builds, as if its file were in data/scenes (so `../hdri/…` resolves).
pub fn scene(b: SceneBuilder) -> Scene {
    b.build(root().join("data/scenes/inline-test.toml")).expect("valid test scene")
}

/// Lambert with grey albedo `a`.
pub fn lambert(a: f32) -> Brdf {
    Brdf::Lambert { albedo: Vec3::splat(a) }
}

/// GGX of roughness `alpha` with grey specular `s` and diffuse `d`.
pub fn ggx(alpha: f32, s: f32, d: f32) -> Brdf {
    Brdf::Ggx { alpha, specular: Vec3::splat(s), diffuse: Vec3::splat(d) }
}

/// Beckmann of roughness `alpha` with grey specular `s` and diffuse `d`.
pub fn beckmann(alpha: f32, s: f32, d: f32) -> Brdf {
    Brdf::Beckmann { alpha, specular: Vec3::splat(s), diffuse: Vec3::splat(d) }
}

/// Whether vertex `v` of object `i` faces `eye` (by more than a grazing margin).
pub fn facing(f: &Frame, i: usize, v: usize, eye: Vec3) -> bool {
    f.normals[i][v].dot((eye - f.positions[i][v]).normalize()) > 0.05
}

/// Relative L2 of `a` against `b` (rsl-truth's one metric, in f64).
pub fn relative_l2(a: &[Vec3], b: &[Vec3]) -> f64 {
    rsl_truth::compare(a, b, None).expect("comparable radiance").relative_l2
}

/// `∫ ρ(ω, v) cos θ · h(ω) dω` over the hemisphere by a fine midpoint rule in (cos θ, φ), `h`
/// a weight on local directions.
pub fn directional_albedo(b: &rsl_brdf::Brdf, view: Vec3, h: &dyn Fn(Vec3) -> f32) -> Vec3 {
    let (nu, np) = (2000, 400);
    let mut sum = Vec3::ZERO;
    for i in 0..nu {
        let c = (i as f32 + 0.5) / nu as f32;
        let s = (1.0 - c * c).sqrt();
        for j in 0..np {
            let phi = 2.0 * std::f32::consts::PI * (j as f32 + 0.5) / np as f32;
            let d = Vec3::new(s * phi.cos(), s * phi.sin(), c);
            sum += b.eval(d, view) * (c * h(d));
        }
    }
    sum * (2.0 * std::f32::consts::PI / (nu * np) as f32)
}

/// A ball of radius 1 and `resolution` with `material` in a constant white environment of
/// `rsl_count` lights, at `preset` with `knobs` over it, seen from +Z.
pub fn furnace_ball(material: Brdf, preset: Preset, knobs: &[(&str, i64)], rsl_count: u32, resolution: u32) -> Scene {
    let b = knobs.iter().fold(SceneBuilder::new().preset(preset), |b, (k, v)| b.knob(k, *v));
    scene(
        b.constant(Vec3::ONE)
            .rsl_count(rsl_count)
            .camera(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO)
            .object(ObjectBuilder::sphere("ball", 1.0, resolution).material(material)),
    )
}

/// A plane under a ball, both Lambert, in a constant white environment: a plane point at
/// horizontal distance ρ from below the ball's centre (height h, radius R) sees the ball as
/// a cap of half-angle β = asin(R/d), d² = ρ² + h², at angle θ from its normal
/// (cos θ = h/d). Where the cap is wholly above the horizon (θ + β < π/2) it hides
/// (R/d)²·cos θ of the cosine-weighted hemisphere (the form factor of a sphere), so the
/// point reflects `albedo·L·(1 − (R/d)² cos θ)`.
pub fn cap_scene() -> Scene {
    cap_scene_with(1.0, |ball| ball)
}

/// [`cap_scene`] with every length (and the camera's place) times `s`, the ball as `ball`
/// makes it (its motion).
pub fn cap_scene_with(s: f32, ball: impl FnOnce(ObjectBuilder) -> ObjectBuilder) -> Scene {
    cap_scene_of(s, 384, ball)
}

/// [`cap_scene_with`] lit by `rsl_count` lights.
pub fn cap_scene_of(s: f32, rsl_count: u32, ball: impl FnOnce(ObjectBuilder) -> ObjectBuilder) -> Scene {
    scene(
        SceneBuilder::new()
            .preset(Preset::Draft)
            .knob("env_grid", 8)
            .knob("table_resolution", 32)
            .knob("ovdf_directions", 16)
            .constant(Vec3::ONE)
            .rsl_count(rsl_count)
            .camera(Vec3::new(0.0, 3.0 * s, 0.5 * s), Vec3::ZERO)
            .object(ObjectBuilder::plane("ground", 3.0 * s, 30).material(lambert(0.5)).no_shadows())
            .object(ball(
                ObjectBuilder::sphere("ball", 0.4 * s, 24)
                    .translation(Vec3::new(0.0, 0.8 * s, 0.0))
                    .material(lambert(0.5)),
            )),
    )
}

/// Suzanne (GGX α = 0.3, not convex: her self-visibility field is used) under the studio
/// map at draft, she and the map turned by `degrees` about one axis, seen from `eye`.
pub fn turned_suzanne(degrees: f32, eye: Vec3) -> Scene {
    let axis = Vec3::new(0.3, 1.0, 0.2);
    scene(
        SceneBuilder::new()
            .preset(Preset::Draft)
            .map("../hdri/studio.exr")
            .environment_rotation(axis, degrees)
            .camera(eye, Vec3::ZERO)
            .object(
                ObjectBuilder::mesh("suzanne", "../models/suzanne.glb")
                    .rotation(axis, degrees)
                    .material(ggx(0.3, 1.0, 0.3)),
            ),
    )
}

/// The radiance of a ground point `p` under a ball at `centre` of radius `r` (`None` where
/// the cap crosses the horizon).
pub fn cap_radiance(p: Vec3, centre: Vec3, r: f32) -> Option<f32> {
    let to = centre - p;
    let d = to.length();
    let (sin_b, cos_t) = (r / d, to.y / d);
    let (beta, theta) = (sin_b.asin(), cos_t.acos());
    (theta + beta < std::f32::consts::FRAC_PI_2 - 0.05).then_some(0.5 * (1.0 - sin_b * sin_b * cos_t))
}

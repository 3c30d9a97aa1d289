//! Helpers shared by the engine's test binaries: inline scenes, and the analytic cap a ball
//! casts on a plane under a constant environment.

// Each test binary uses its own subset.
#![allow(dead_code)]

use glam::Vec3;
use rsl_engine::method::Frame;
use rsl_engine::scene::Scene;
use std::path::PathBuf;

/// The repository's root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A scene written inline as if it were a file in data/scenes (so `../hdri/…` resolves).
pub fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text, &root().join("data/scenes/inline-test.toml")).expect("valid test scene")
}

/// Whether vertex `v` of object `i` faces `eye` (by more than a grazing margin).
pub fn facing(f: &Frame, i: usize, v: usize, eye: Vec3) -> bool {
    f.normals[i][v].dot((eye - f.positions[i][v]).normalize()) > 0.05
}

/// Relative L2 of `a` against `b` (rsl-truth's one metric, in f64).
pub fn relative_l2(a: &[Vec3], b: &[Vec3]) -> f64 {
    rsl_truth::compare(a, b, None).expect("comparable radiance").relative_l2
}

/// A ball of radius 1 and `resolution` with `material` in a constant white environment of
/// `rsl_count` lights, `quality` the lines of its `[quality]` table, seen from +Z.
pub fn furnace_ball(material: &str, quality: &str, rsl_count: u32, resolution: u32) -> Scene {
    scene(&format!(
        r#"
        [quality]
        {quality}
        [environment]
        constant = [1.0, 1.0, 1.0]
        rsl_count = {rsl_count}
        [camera]
        eye = [0.0, 0.0, 5.0]
        target = [0.0, 0.0, 0.0]
        [[objects]]
        name = "ball"
        primitive = {{ kind = "sphere", radius = 1.0, resolution = {resolution} }}
        material = {material}
        "#
    ))
}

/// A plane under a ball, both Lambert, in a constant white environment: a plane point at
/// horizontal distance ρ from below the ball's centre (height h, radius R) sees the ball as
/// a cap of half-angle β = asin(R/d), d² = ρ² + h², at angle θ from its normal
/// (cos θ = h/d). Where the cap is wholly above the horizon (θ + β < π/2) it hides
/// (R/d)²·cos θ of the cosine-weighted hemisphere (the form factor of a sphere), so the
/// point reflects `albedo·L·(1 − (R/d)² cos θ)`.
pub fn cap_scene(motion: &str) -> Scene {
    cap_scene_at(motion, 1.0)
}

/// [`cap_scene`] with every length (and the camera's place) times `s`.
pub fn cap_scene_at(motion: &str, s: f32) -> Scene {
    scene(&format!(
        r#"
        [quality]
        preset = "draft"
        env_grid = 8
        table_resolution = 32
        ovdf_directions = 16
        [environment]
        constant = [1.0, 1.0, 1.0]
        rsl_count = 384
        [camera]
        eye = [0.0, {eye_y:e}, {eye_z:e}]
        target = [0.0, 0.0, 0.0]
        [[objects]]
        name = "ground"
        primitive = {{ kind = "plane", size = {size:e}, resolution = 30 }}
        material = {{ model = "lambert", albedo = [0.5, 0.5, 0.5] }}
        casts_shadows = false
        [[objects]]
        name = "ball"
        primitive = {{ kind = "sphere", radius = {radius:e}, resolution = 24 }}
        translation = [0.0, {height:e}, 0.0]
        material = {{ model = "lambert", albedo = [0.5, 0.5, 0.5] }}
        {motion}
        "#,
        eye_y = 3.0 * s,
        eye_z = 0.5 * s,
        size = 3.0 * s,
        radius = 0.4 * s,
        height = 0.8 * s,
    ))
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

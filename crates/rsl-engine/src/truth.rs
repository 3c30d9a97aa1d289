//! The Monte Carlo truth of a scene at a time without an engine: rsl-truth's estimator on the
//! same vertices, shading frames and views as the RSL path (for tests and scripts; the
//! [`crate::method::Truth`] method shares the engine's prepared data instead).

use anyhow::Result;
use rsl_scene::{EnvironmentSource, Scene};
use rsl_shade::VertexFrames;
use rsl_truth::{EnvLight, TruthObject, TruthScene};
use std::sync::Arc;

/// Loads the scene's environment as a light.
pub fn env_light(scene: &Scene) -> Result<EnvLight> {
    let env = &scene.environment;
    Ok(match (crate::engine::load_map(&env.source)?, &env.source) {
        (Some(map), _) => EnvLight::map(Arc::new(map), env.intensity),
        (None, EnvironmentSource::Constant(c)) => EnvLight::Constant(*c * env.intensity),
        (None, _) => unreachable!("every source but a constant is a map"),
    })
}

/// The vertex frames of every object (as the engine builds them).
pub fn vertex_frames(scene: &Scene) -> Vec<VertexFrames> {
    scene.objects.iter().map(|o| VertexFrames::new(&o.mesh, o.material.is_anisotropic())).collect()
}

/// The truth scene at time `t`, following the light through the scene's `bounces`.
pub fn truth_scene(scene: &Scene, frames: &[VertexFrames], env: EnvLight, t: f32) -> Result<TruthScene> {
    let state = scene.at(t);
    let objects: Vec<TruthObject<'_>> = scene
        .objects
        .iter()
        .zip(frames)
        .zip(&state.objects)
        .map(|((o, f), &transform)| TruthObject {
            mesh: &o.mesh,
            frames: f,
            brdf: o.material,
            transform,
            casts_shadows: o.casts_shadows,
            texture: o.texture.as_ref(),
            metallic_roughness: o.metallic_roughness.as_ref(),
        })
        .collect();
    Ok(TruthScene::new(&objects, env, state.world_from_env)?.with_bounces(scene.quality.settings.bounces))
}

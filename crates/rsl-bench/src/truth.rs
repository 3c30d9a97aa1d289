//! The per-vertex truth of a scene at a time, computed once per (scene contents, time, spp,
//! seed) and kept in the cache folder, in the frame every cache file shares
//! ([`rsl_sphere::framed`]).

use anyhow::{Context, Result, bail};
use glam::Vec3;
use rsl_engine::cache::KeyHasher;
use rsl_engine::method::{Method, Request, Truth};
use rsl_engine::{Engine, Progress};
use rsl_scene::Scene;
use rsl_sphere::framed::{self, FrameError};
use std::path::Path;

/// Magic number of a cached truth file.
pub const MAGIC: [u8; 8] = *b"RSLTRUTH";
/// Version of the truth file format (3: vertices' visibility is face-averaged,
/// rsl_sphere::faces; 4: the shared frame, with the content key in the header).
pub const VERSION: u32 = 4;

/// Per object, per vertex: the mean radiance and its standard error.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexTruth {
    /// Means.
    pub mean: Vec<Vec<Vec3>>,
    /// Standard errors.
    pub std_error: Vec<Vec<Vec3>>,
    /// Samples per vertex.
    pub spp: u32,
    /// Seconds the estimation of the vertices took (kept in the cache file with them).
    pub seconds: f64,
}

impl VertexTruth {
    /// ‖standard error‖₂ / ‖mean‖₂ over objects `which` (all when `None`).
    pub fn noise(&self, which: Option<usize>) -> f64 {
        let (mut se, mut m) = (0.0f64, 0.0f64);
        for (i, (means, errors)) in self.mean.iter().zip(&self.std_error).enumerate() {
            if which.is_some_and(|w| w != i) {
                continue;
            }
            se += errors.iter().map(|e| f64::from(e.length_squared())).sum::<f64>();
            m += means.iter().map(|e| f64::from(e.length_squared())).sum::<f64>();
        }
        if m > 0.0 { (se / m).sqrt() } else { 0.0 }
    }
}

/// The key of the truth of `scene` (as `engine` prepared it) at `time`: the environment's
/// radiance, every object's mesh, material, pose and shadow flag, the eye, the sampling, and
/// the bounces of light it follows.
pub fn key(engine: &Engine, scene: &Scene, time: f32, spp: u32, seed: u64) -> u64 {
    let state = scene.at(time);
    let mut h = KeyHasher::default()
        .str("truth")
        .u64(u64::from(VERSION))
        .u64(engine.environment_key())
        .f32s(&[engine.intensity()])
        .f32s(&state.world_from_env.to_array())
        .f32s(&scene.camera.eye.to_array())
        .u64(u64::from(spp))
        .u64(seed)
        .f32s(&[time]);
    let bounces = scene.quality.settings.bounces;
    if bounces > 0 {
        // Keyed only when followed, so that the direct light's truths keep their keys.
        h = h.str("bounces").u64(u64::from(bounces));
    }
    for (i, o) in scene.objects.iter().enumerate() {
        let t = &state.objects[i];
        h = h
            .u64(engine.keys(i).mesh)
            .u64(engine.brdf(i).key())
            .f32s(&t.translation.to_array())
            .f32s(&t.rotation.to_array())
            .f32s(&t.scale.to_array())
            .u64(u64::from(o.casts_shadows));
        // Keyed only where there are textures, so that the other truths keep their keys.
        if let Some(texture) = &o.texture {
            h = h.str("base colour texture").u64(texture.key());
        }
        if let Some(mr) = &o.metallic_roughness {
            h = h.str("metallic-roughness texture").u64(mr.map.key()).f32s(&[mr.metallic, mr.roughness]);
        }
    }
    h.finish()
}

/// The truth from `dir` (if given and there), else estimated (and written there). Returns it
/// and whether it was read from the cache.
pub fn truth(
    engine: &Engine,
    scene: &Scene,
    time: f32,
    spp: u32,
    seed: u64,
    dir: Option<&Path>,
    progress: &Progress,
) -> Result<(VertexTruth, bool)> {
    let key = key(engine, scene, time, spp, seed);
    let file = dir.map(|d| d.join(format!("truth-{key:016x}.bin")));
    if let Some(f) = &file
        && let Ok(bytes) = rsl_sphere::io::read_bounded(f, rsl_sphere::io::MAX_DATA_BYTES)
    {
        match from_bytes(&bytes, key, spp) {
            Ok(t) if t.mean.iter().map(Vec::len).eq(engine_counts(engine)) => return Ok((t, true)),
            Ok(_) => tracing::warn!("{}: vertex counts differ from the scene; estimating again", f.display()),
            Err(e) => tracing::warn!("{}: {e}; estimating again", f.display()),
        }
    }
    let mut method = Truth::new(engine, spp, seed)?;
    method.progress = progress.clone();
    let start = std::time::Instant::now();
    let frame = method.render(engine, scene, &Request { time, image: false, vertices: true, exposure: None })?;
    let t = VertexTruth {
        mean: frame.radiance,
        std_error: frame.std_error.context("the truth gives standard errors")?,
        spp,
        seconds: start.elapsed().as_secs_f64(),
    };
    if let Some(f) = &file {
        if let Some(d) = f.parent() {
            std::fs::create_dir_all(d).with_context(|| format!("cannot create {}", d.display()))?;
        }
        rsl_engine::output::write_atomic(f, &to_bytes(&t, key))?;
    }
    Ok((t, false))
}

fn engine_counts(engine: &Engine) -> impl Iterator<Item = usize> + '_ {
    (0..engine.object_count()).map(|i| engine.mesh(i).vertex_count())
}

fn to_bytes(t: &VertexTruth, key: u64) -> Vec<u8> {
    let mut payload = Vec::new();
    payload.extend_from_slice(&t.spp.to_le_bytes());
    payload.extend_from_slice(&t.seconds.to_le_bytes());
    payload.extend_from_slice(&(t.mean.len() as u32).to_le_bytes());
    for (m, e) in t.mean.iter().zip(&t.std_error) {
        payload.extend_from_slice(&(m.len() as u32).to_le_bytes());
        for v in m.iter().chain(e) {
            for c in v.to_array() {
                payload.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    framed::frame(&MAGIC, VERSION, key, &payload)
}

/// Reads a cached truth file's bytes (built for content key `key`, at `spp` samples per
/// vertex), verifying everything.
pub fn from_bytes(b: &[u8], key: u64, spp: u32) -> Result<VertexTruth> {
    let payload = framed::unframe(&MAGIC, VERSION, key, b).map_err(|e| match e {
        FrameError::BadMagic => anyhow::anyhow!("not a truth file (bad magic number)"),
        e => anyhow::anyhow!("truth file: {e}"),
    })?;
    let mut at = 0usize;
    let mut next = |n: usize| -> Result<&[u8]> {
        let s = payload.get(at..at + n).context("truth file is malformed (too short)")?;
        at += n;
        Ok(s)
    };
    let u = |s: &[u8]| u32::from_le_bytes(s.try_into().expect("4 bytes"));
    if u(next(4)?) != spp {
        bail!("truth file holds another sample count");
    }
    let seconds = f64::from_le_bytes(next(8)?.try_into().expect("8 bytes"));
    if !(seconds.is_finite() && seconds >= 0.0) {
        bail!("truth file holds a bad estimation time");
    }
    let objects = u(next(4)?) as usize;
    let (mut mean, mut std_error) = (Vec::new(), Vec::new());
    for _ in 0..objects.min(payload.len()) {
        let n = u(next(4)?) as usize;
        let bytes = next(n.checked_mul(24).context("truth file is malformed")?)?;
        let vals: Vec<Vec3> = bytes
            .chunks_exact(12)
            .map(|c| {
                let f = |k: usize| f32::from_le_bytes(c[k..k + 4].try_into().expect("4 bytes"));
                Vec3::new(f(0), f(4), f(8))
            })
            .collect();
        if vals.iter().any(|v| !v.is_finite()) {
            bail!("truth file holds non-finite values");
        }
        mean.push(vals[..n].to_vec());
        std_error.push(vals[n..].to_vec());
    }
    if mean.len() != objects || at != payload.len() {
        bail!("truth file is malformed");
    }
    Ok(VertexTruth { mean, std_error, spp, seconds })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_files_round_trip_and_damage_is_detected() {
        let t = VertexTruth {
            mean: vec![vec![Vec3::new(1.0, 2.0, 3.0)], vec![Vec3::ONE, Vec3::ZERO]],
            std_error: vec![vec![Vec3::splat(0.1)], vec![Vec3::splat(0.2), Vec3::ZERO]],
            spp: 64,
            seconds: 2.5,
        };
        let b = to_bytes(&t, 7);
        assert_eq!(from_bytes(&b, 7, 64).unwrap(), t);
        assert!(from_bytes(&b, 7, 32).unwrap_err().to_string().contains("sample count"));
        let mut flipped = b.clone();
        flipped[40] ^= 1;
        assert!(from_bytes(&flipped, 7, 64).unwrap_err().to_string().contains("checksum"));
        assert!(from_bytes(&b[..b.len() - 1], 7, 64).is_err());
        assert!(from_bytes(&b, 8, 64).unwrap_err().to_string().contains("built for key"));
        assert!((t.noise(Some(0)) - (0.03f64 / 14.0).sqrt()).abs() < 1e-6);
    }

    /// A truth is keyed by the scene's textures: the same meshes and materials with and
    /// without a texture, or with another texel, are other truths.
    #[test]
    fn textures_are_part_of_a_truths_key() {
        let dir = rsl_sphere::scratch::Scratch::new("bench-texture-key");
        let path = rsl_scene::build::write_textured_sample(&dir).unwrap();
        let textured = Scene::load(&path).unwrap();
        let engine = Engine::new(&textured, rsl_engine::EngineOptions::default()).unwrap();
        let mut plain = textured.clone();
        plain.objects[0].texture = None;
        let mut other = textured.clone();
        let t = other.objects[0].texture.as_mut().unwrap();
        let mut image = (*t.texture).clone();
        image.texels[5][1] ^= 1;
        t.texture = std::sync::Arc::new(image);
        let keys = [&textured, &plain, &other].map(|s| key(&engine, s, 0.0, 64, 1));
        assert!(keys[0] != keys[1] && keys[0] != keys[2] && keys[1] != keys[2], "{keys:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

//! The hybrid of the lobe path and the RSL path (rsl-lobe; the variant (b)): per
//! vertex, the unshadowed glossy radiance from the material's vMF lobes over the prefiltered
//! environment, times the RSL path's visibility ratio `Σ_i E_i·B̄_i·V̄_i / Σ_i E_i·B̄_i` (the
//! ratio estimator of Heitz et al. 2018, with RSL visibility in place of rays), per channel.
//!
//! The lobes are meant to carry what a square light cannot, the environment's detail inside
//! a lobe narrower than the squares; the ratio carries the shadows, self and from other
//! objects, weighted as the RSL path weighs them. Measured (rsl-lobe README), one vMF lobe per
//! view does not reproduce a microfacet lobe well enough for that: on every accuracy scene
//! the plain RSL path is closer to the truth, so this is a comparison, not a default, and
//! there is no automatic choice between the two yet.
//!
//! Prepared once and kept: the environment prefiltered up to the sharpest lobe the scene's
//! materials need (`κ` rounded up to a power of two, at most 4096), and each material's lobes
//! (refitted when its parameters change).
//!
//! Images ([`Hybrid::per_pixel`], the default): each pixel of a glossy object looks its lobes
//! up for its own interpolated normal and view (one prefiltered lookup per lobe), times the
//! ratio interpolated from the vertices ([`rsl_shade::draw_pixels`]).

use crate::engine::{Engine, EnvRadiance, brdf_key};
use crate::method::{Frame, Method, Request, rasterise};
use crate::progress::Timings;
use anyhow::Result;
use glam::Vec3;
use rayon::prelude::*;
use rsl_brdf::Brdf;
use rsl_lobe::{FitParams, MaterialLobes, PrefilterParams, Prefiltered};
use rsl_scene::Scene;
use rsl_shade::{FrameStats, PixelMesh, Terms};
use rsl_sphere::Frame as LocalFrame;
use rsl_sphere::latlong::LatLongMap;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

/// The hybrid method, on every object with a specular lobe (Lambertian objects keep the RSL
/// path's value).
#[derive(Default)]
pub struct Hybrid {
    /// Draw glossy objects per pixel: each pixel's lobes from its own interpolated normal
    /// and view, times the visibility ratio interpolated from the vertices (else the
    /// vertices' radiance is interpolated).
    pub per_pixel: bool,
    env: Option<(u64, u32, Arc<Prefiltered>)>,
    materials: HashMap<u64, Arc<MaterialLobes>>,
}

impl Hybrid {
    /// A hybrid with nothing prepared yet (the environment and the lobes are made on the first
    /// frame and kept), drawing glossy objects per pixel.
    pub fn new() -> Self {
        Self { per_pixel: true, ..Self::default() }
    }

    /// The material lobes of `brdf` (fitted once per parameter set).
    fn lobes(&mut self, brdf: &Brdf) -> Result<Arc<MaterialLobes>> {
        let key = brdf_key(brdf);
        if let Some(l) = self.materials.get(&key) {
            return Ok(l.clone());
        }
        let l = Arc::new(MaterialLobes::fit(brdf, &FitParams::default()).map_err(anyhow::Error::msg)?);
        self.materials.insert(key, l.clone());
        Ok(l)
    }

    /// The environment prefiltered up to `kappa_max` (rebuilt when the map or the need changes).
    fn environment(&mut self, engine: &Engine, kappa_max: f32) -> Arc<Prefiltered> {
        let top = kappa_max.clamp(1.0, 4096.0).log2().ceil().exp2() as u32;
        let key = engine.environment_key();
        if let Some((k, t, p)) = &self.env
            && *k == key
            && *t >= top
        {
            return p.clone();
        }
        let map = match engine.environment() {
            EnvRadiance::Map(m) => m.clone(),
            EnvRadiance::Constant(c) => Arc::new(LatLongMap::from_fn(8, 4, |_| *c)),
        };
        let params = PrefilterParams { kappa_max: top as f32, ..Default::default() };
        let p = Arc::new(Prefiltered::build(&map, &params));
        self.env = Some((key, top, p.clone()));
        p
    }
}

impl Method for Hybrid {
    fn describe(&self) -> String {
        format!("vMF lobes × RSL visibility on the CPU ({} threads)", rayon::current_num_threads())
    }

    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        let mut timings = Timings::default();
        // Which objects, and their lobes.
        let start = Instant::now();
        let n = engine.object_count();
        let mut lobes: Vec<Option<Arc<MaterialLobes>>> = Vec::with_capacity(n);
        for i in 0..n {
            let brdf = *engine.brdf(i);
            // A Lambertian object has no glossy detail to add: the RSL path's value stands
            // (its Lambertian term is exact, where a cosine-fitted lobe is not).
            lobes.push(if brdf.is_lambertian() { None } else { Some(self.lobes(&brdf)?) });
        }
        let kappa_max =
            lobes.iter().flatten().flat_map(|l| l.lobes_per_view().map(|w| w.lobe.kappa)).fold(1.0f32, f32::max);
        let env = if lobes.iter().any(Option::is_some) { Some(self.environment(engine, kappa_max)) } else { None };
        timings.add("lobes", start.elapsed().as_secs_f64() * 1e3, None);

        let full = engine.shade_with(scene, request.time, Terms::default())?;
        let mut shade_ms = full.shade_ms;
        let mut radiance = full.radiance.clone();
        let mut stats: FrameStats = full.stats;
        // Per vertex of each glossy object: the visibility ratio, and its world shading frames.
        let mut ratios: Vec<Option<Vec<Vec3>>> = vec![None; n];
        if let Some(env) = &env {
            let bare = engine.shade_with(scene, request.time, Terms { self_visibility: false, occluders: false })?;
            shade_ms += bare.shade_ms;
            stats = stats.plus(bare.stats);
            let start = Instant::now();
            let env_from_world = full.state.world_from_env.inverse();
            let intensity = engine.intensity();
            let eye = scene.camera.eye;
            for (i, l) in lobes.iter().enumerate() {
                let Some(l) = l else { continue };
                let (pos, nor) = (&full.positions[i], &full.normals[i]);
                let (shadowed, unshadowed) = (&full.radiance[i], &bare.radiance[i]);
                let ratio: Vec<Vec3> = shadowed
                    .iter()
                    .zip(unshadowed)
                    .map(|(s, u)| {
                        Vec3::select(u.cmpgt(Vec3::ZERO), *s / u.max(Vec3::splat(f32::MIN_POSITIVE)), Vec3::ZERO)
                            .clamp(Vec3::ZERO, Vec3::ONE)
                    })
                    .collect();
                radiance[i] = (0..pos.len())
                    .into_par_iter()
                    .map(|v| {
                        let frame = LocalFrame::from_normal(nor[v]);
                        let view = (eye - pos[v]).normalize_or_zero();
                        l.radiance(env, &frame, view, |d| env_from_world * d) * intensity * ratio[v]
                    })
                    .collect();
                ratios[i] = Some(ratio);
            }
            shade_ms += start.elapsed().as_secs_f64() * 1e3;
        }
        timings.add("shade", shade_ms, None);
        let image = request.image.then(|| match (&env, self.per_pixel) {
            (Some(env), true) => timings.time("draw per pixel", || {
                let frames: Vec<Option<Vec<LocalFrame>>> = ratios
                    .iter()
                    .enumerate()
                    .map(|(i, r)| {
                        r.as_ref().map(|_| full.normals[i].iter().map(|&n| LocalFrame::from_normal(n)).collect())
                    })
                    .collect();
                let meshes: Vec<PixelMesh<'_>> = scene
                    .objects
                    .iter()
                    .enumerate()
                    .map(|(i, o)| PixelMesh {
                        positions: &full.positions[i],
                        indices: &o.mesh.indices,
                        frames: frames[i].as_deref(),
                        radiance: &radiance[i],
                    })
                    .collect();
                let env_from_world = full.state.world_from_env.inverse();
                let (intensity, eye) = (engine.intensity(), scene.camera.eye);
                rsl_shade::draw_pixels(
                    &scene.camera,
                    &meshes,
                    || (),
                    |p, _| {
                        let (Some(l), Some(ratio)) = (&lobes[p.object], &ratios[p.object]) else {
                            return Vec3::ZERO;
                        };
                        let view = (eye - p.position).normalize_or_zero();
                        let ratio = p.fragment.interpolate(meshes[p.object].indices, ratio);
                        l.radiance(env, &p.frame, view, |d| env_from_world * d) * intensity * ratio
                    },
                    |d| engine.background(&full.state, d),
                )
            }),
            _ => timings.time("draw", || rasterise(engine, scene, &full.state, &full.positions, &radiance)),
        });
        Ok(Frame {
            state: full.state,
            positions: full.positions,
            normals: full.normals,
            radiance,
            std_error: None,
            image,
            encoded: None,
            self_error: None,
            stats,
            shadow_rays: 0,
            timings,
        })
    }
}

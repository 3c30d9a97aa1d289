//! The Haar wavelet baseline (Ng et al. 2003) for a static scene: the environment on a
//! `6×R×R` cube, a non-linear approximation of it that keeps the `K` largest area-weighted
//! Haar coefficients, and per vertex the transport `ρ·cos·V` (shadow rays against every
//! object that casts shadows) in the same basis, kept only at the coefficients the lighting
//! can select. A frame of `K` terms is `K` products per vertex and channel.
//!
//! Area weighting: with texel solid angles `Ω_t`, the lighting `L_t·√Ω_t` and the transport
//! `T_t·√Ω_t` are transformed by the orthonormal Haar basis on each face, so by Parseval
//! `Σ_k L̂_k·T̂_k = Σ_t L_t·T_t·Ω_t`, the cube's quadrature of the lighting integral: with all
//! `6R²` terms the baseline is exactly that sum.

use crate::engine::{Engine, EnvRadiance};
use crate::method::{Frame, Method, Request};
use crate::progress::Timings;
use anyhow::{Result, bail};
use glam::Vec3;
use rsl_env::CubeEnv;
use rsl_scene::Scene;
use rsl_shade::Pose;
use rsl_sphere::cube::CubeGrid;
use rsl_sphere::mesh::TriMesh;
use rsl_vis::rays::Occluder;

/// In-place orthonormal 2D Haar transform (non-standard decomposition) of an `r×r` block
/// (`r` a power of two), row-major.
pub fn haar2d(x: &mut [Vec3], r: usize) {
    let s2 = std::f32::consts::FRAC_1_SQRT_2;
    let mut tmp = vec![Vec3::ZERO; r];
    let mut n = r;
    while n > 1 {
        let h = n / 2;
        for row in 0..n {
            for k in 0..h {
                let (a, b) = (x[row * r + 2 * k], x[row * r + 2 * k + 1]);
                tmp[k] = (a + b) * s2;
                tmp[h + k] = (a - b) * s2;
            }
            x[row * r..row * r + n].copy_from_slice(&tmp[..n]);
        }
        for col in 0..n {
            for k in 0..h {
                let (a, b) = (x[2 * k * r + col], x[(2 * k + 1) * r + col]);
                tmp[k] = (a + b) * s2;
                tmp[h + k] = (a - b) * s2;
            }
            for k in 0..n {
                x[k * r + col] = tmp[k];
            }
        }
        n = h;
    }
}

/// The inverse of [`haar2d`].
pub fn inverse_haar2d(x: &mut [Vec3], r: usize) {
    let s2 = std::f32::consts::FRAC_1_SQRT_2;
    let mut tmp = vec![Vec3::ZERO; r];
    let mut n = 2;
    while n <= r {
        let h = n / 2;
        for col in 0..n {
            for k in 0..h {
                let (a, d) = (x[k * r + col], x[(h + k) * r + col]);
                tmp[2 * k] = (a + d) * s2;
                tmp[2 * k + 1] = (a - d) * s2;
            }
            for k in 0..n {
                x[k * r + col] = tmp[k];
            }
        }
        for row in 0..n {
            for k in 0..h {
                let (a, d) = (x[row * r + k], x[row * r + h + k]);
                tmp[2 * k] = (a + d) * s2;
                tmp[2 * k + 1] = (a - d) * s2;
            }
            x[row * r..row * r + n].copy_from_slice(&tmp[..n]);
        }
        n *= 2;
    }
}

/// Area-weighted Haar coefficients of a per-texel quantity on `grid` (`v_t·√Ω_t`, each face
/// transformed on its own), indexed face-major like the grid's faces.
fn coefficients(grid: &CubeGrid, value: impl Fn(usize) -> Vec3) -> Vec<Vec3> {
    let r = grid.r();
    let mut out = vec![Vec3::ZERO; 6 * r * r];
    for face in 0..6 {
        let block = &mut out[face * r * r..(face + 1) * r * r];
        for i in 0..r {
            for j in 0..r {
                let t = grid.index(face, i, j);
                block[j * r + i] = value(t) * (grid.texel_solid_angle(t) as f32).sqrt();
            }
        }
        haar2d(block, r);
    }
    out
}

/// The baseline prepared for a scene at a time.
pub struct Wavelets {
    /// The lighting's coefficients in order of decreasing magnitude: (coefficient index,
    /// value).
    lighting: Vec<(usize, Vec3)>,
    /// Per object, per vertex: the transport's coefficients at `lighting`'s first `kept`
    /// indices, in that order.
    transport: Vec<Vec<Vec<Vec3>>>,
    /// How many terms were kept per vertex.
    kept: usize,
}

impl Wavelets {
    /// Prepares the baseline of `scene` (prepared by `engine`, any layers) at `time` with an
    /// `r×r` grid per cube face, for up to `max_terms` terms; `shadows: false` leaves the
    /// visibility out (the unshadowed transport).
    pub fn new(engine: &Engine, scene: &Scene, time: f32, r: usize, max_terms: usize, shadows: bool) -> Result<Self> {
        if !r.is_power_of_two() || r < 2 {
            bail!("the wavelet baseline needs a cube grid of a power of two (env_grid = {r})");
        }
        engine.check(scene)?;
        let grid = CubeGrid::new(r);
        let cube = match engine.environment() {
            EnvRadiance::Map(m) => CubeEnv::from_latlong(m, r),
            EnvRadiance::Constant(c) => CubeEnv::constant(r, *c),
        };
        let intensity = engine.intensity();
        let light = coefficients(&grid, |t| cube.radiance(t) * intensity);
        let mut lighting: Vec<(usize, Vec3)> = light.iter().copied().enumerate().collect();
        lighting.sort_by(|a, b| b.1.length_squared().total_cmp(&a.1.length_squared()).then(a.0.cmp(&b.0)));
        let kept = max_terms.min(lighting.len());
        let state = scene.at(time);
        // Occluders: every object that casts shadows, in world space at this time.
        let mut world = TriMesh::default();
        for (i, o) in scene.objects.iter().enumerate() {
            if o.casts_shadows {
                let mut m = (**engine.mesh(i)).clone();
                m.transform(&state.world_from_object(i));
                world.append(&m);
            }
        }
        let occluder = if shadows && !world.indices.is_empty() { Some(Occluder::new(&world)?) } else { None };
        let (lo, hi) = world
            .positions
            .iter()
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| (a.min(*p), b.max(*p)));
        let offset = 1e-4 * (hi - lo).length().max(1e-3);
        let directions: Vec<Vec3> = (0..grid.len()).map(|t| state.world_from_env * grid.texel_dir(t)).collect();
        let eye = scene.camera.eye;
        let transport = (0..engine.object_count())
            .map(|i| {
                let pose = Pose::new(&state.objects[i]);
                let mesh = engine.mesh(i);
                let frames = engine.frames(i);
                let brdf = *engine.brdf(i);
                use rayon::prelude::*;
                (0..mesh.vertex_count())
                    .into_par_iter()
                    .map(|v| {
                        let x = pose.position(mesh.positions[v]);
                        let n = pose.normal(mesh.normals[v]);
                        let frame = pose.frame(frames.shading(v));
                        let wo = frame.to_local((eye - x).normalize_or_zero());
                        if wo.z <= 0.0 {
                            return vec![Vec3::ZERO; kept];
                        }
                        let t_of = |t: usize| {
                            let d = directions[t];
                            if d.dot(n) <= 0.0 {
                                return Vec3::ZERO;
                            }
                            if let Some(occ) = &occluder
                                && occ.occluded(x + n * offset, d, f32::MAX)
                            {
                                return Vec3::ZERO;
                            }
                            brdf.eval_cos(frame.to_local(d), wo)
                        };
                        let c = coefficients(&grid, t_of);
                        lighting[..kept].iter().map(|(k, _)| c[*k]).collect()
                    })
                    .collect()
            })
            .collect();
        Ok(Self { lighting, transport, kept })
    }

    /// Bytes of the transport kept.
    pub fn bytes(&self) -> usize {
        self.transport.iter().flatten().map(|t| std::mem::size_of_val(t.as_slice())).sum::<usize>()
            + std::mem::size_of_val(self.lighting.as_slice())
    }

    /// Whether it was prepared for at least `terms` terms (or for every term there is).
    pub fn holds(&self, terms: usize) -> bool {
        self.kept >= terms.min(self.lighting.len())
    }

    /// The coefficient count of the whole cube (`6R²`): with that many terms the baseline
    /// is the cube's quadrature exactly.
    pub fn all_terms(&self) -> usize {
        self.lighting.len()
    }

    /// Per object, per vertex: radiance toward the eye from the `terms` largest lighting
    /// coefficients (at most the count prepared).
    pub fn radiance(&self, terms: usize) -> Vec<Vec<Vec3>> {
        let k = terms.min(self.kept);
        self.transport
            .iter()
            .map(|o| {
                o.iter().map(|t| t[..k].iter().zip(&self.lighting[..k]).map(|(a, (_, l))| *a * *l).sum()).collect()
            })
            .collect()
    }
}

/// The Haar wavelet baseline as a method: the transport is prepared for the scene as it is
/// at the frame's time (a static scene: prepared again when the time, the environment or
/// the scene changes) on the quality's environment grid, and each frame keeps the quality's
/// `wavelet_terms` largest lighting coefficients. Transport prepared for more terms serves
/// fewer (a sweep of term counts from the largest down prepares once).
pub struct WaveletMethod {
    progress: crate::progress::Progress,
    prepared: Option<(u64, Wavelets)>,
    /// Transports prepared so far ([`Method::built`]).
    built: u64,
}

/// Lighting terms the presets keep (quality knob `wavelet_terms`; Ng et al.'s figures use
/// 100–200).
pub const DEFAULT_TERMS: usize = 200;

impl WaveletMethod {
    /// The baseline, nothing prepared yet.
    pub fn new(_engine: &Engine, options: &crate::registry::MethodOptions) -> Result<Self> {
        Ok(Self { progress: options.progress.clone(), prepared: None, built: 0 })
    }
}

impl Method for WaveletMethod {
    fn describe(&self) -> String {
        "Haar wavelet baseline, the quality's wavelet_terms largest lighting terms (CPU)".into()
    }

    fn bytes(&self) -> usize {
        self.prepared.as_ref().map_or(0, |(_, w)| w.bytes())
    }

    fn built(&self) -> u64 {
        self.built
    }

    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        let r = scene.quality.settings.env_grid as usize;
        let terms = scene.quality.settings.wavelet_terms as usize;
        // What the transport depends on: the meshes, materials and shadow casters, each
        // object's world transform at this time, the eye, the environment and the grid.
        let state = scene.at(request.time);
        let mut h = crate::cache::KeyHasher::default()
            .str("wavelet method")
            .u64(engine.environment_key())
            .f32s(&state.world_from_env.to_array())
            .f32s(&scene.camera.eye.to_array())
            .u64(r as u64);
        for (i, o) in scene.objects.iter().enumerate() {
            h = h
                .u64(engine.keys(i).mesh)
                .u64(engine.brdf(i).key())
                .u64(u64::from(o.casts_shadows))
                .f32s(&state.world_from_object(i).to_cols_array());
        }
        let key = h.finish();
        let mut timings = Timings::default();
        if self.prepared.as_ref().is_none_or(|(k, w)| *k != key || !w.holds(terms)) {
            let task = format!("wavelet transport ({} vertices, 6×{r}² rays each)", scene.counts().0);
            let start = std::time::Instant::now();
            let w = self.progress.task(&task, |_| Wavelets::new(engine, scene, request.time, r, terms, true))?;
            timings.add("transport", start.elapsed().as_secs_f64() * 1e3, None);
            self.prepared = Some((key, w));
            self.built += 1;
        }
        let w = &self.prepared.as_ref().expect("prepared above").1;
        let radiance = timings.time("shade", || w.radiance(terms));
        Frame::of_vertices(engine, scene, state, radiance, request.image, timings)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_haar_transform_is_orthonormal_and_inverts() {
        let r = 8;
        let x: Vec<Vec3> = (0..r * r).map(|k| Vec3::new(k as f32, (k * k % 7) as f32, 1.0)).collect();
        let mut y = x.clone();
        haar2d(&mut y, r);
        let energy = |v: &[Vec3]| v.iter().map(|a| a.length_squared()).sum::<f32>();
        assert!((energy(&x) - energy(&y)).abs() <= 1e-4 * energy(&x), "Parseval");
        // A constant block has a single (scaling) coefficient.
        let mut c = vec![Vec3::ONE; r * r];
        haar2d(&mut c, r);
        assert!((c[0] - Vec3::splat(r as f32)).length() < 1e-4);
        assert!(c[1..].iter().all(|v| v.length() < 1e-4));
        inverse_haar2d(&mut y, r);
        assert!(x.iter().zip(&y).all(|(a, b)| (*a - *b).length() < 1e-3));
    }
}

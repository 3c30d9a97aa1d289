//! Interreflections for every method that draws the environment's direct light: the quality
//! knob `bounces` (0: none, each direction another surface blocks stays black).
//!
//! At each vertex, `bounce_rays` directions drawn from its BRDF (stratified, in the vertex's
//! own frame, fixed from frame to frame so that nothing flickers) are traced through every
//! object that casts shadows and the object itself ([`rsl_truth::TruthScene::gather`]). On a
//! glossy surface every vertex draws the same set, so that the gathered light toward the eye
//! varies smoothly over it (its error a smooth bias). On a Lambertian surface, whose gathered
//! light is the same toward every direction and varies slowly across it, each vertex shifts
//! the set by its own offset and keeps what its directions bring as moments, from which the
//! light about any nearby normal follows ([`rsl_truth::TruthScene::gather_moments`]); a
//! vertex's light is the mean over its ring ([`Rings`]) of what each ring vertex's moments
//! give its own normal: the vertices' errors, now independent, average down (about `1/√7`
//! on a regular mesh) while the normal's turn across the ring is followed exactly.
//!
//! A direction that meets a surface brings what that surface sends back, weighted by the
//! BRDF over its sampling density. What a
//! surface sends is its own RSL shading at the point met, as the per-pixel drawing shades a
//! point: the traced lights (a sun) with their shadows traced from there
//! ([`rsl_shade::FrameSetup::traced_cover_at`], one ray each), every other light's cover
//! interpolated from the surface's vertices (shaded along their normals,
//! [`rsl_shade::FrameSetup::along_normals`], so that none faces away); a Lambertian surface
//! sends the same toward every direction, a glossy one its RSL sum toward the receiver
//! ([`rsl_shade::FrameSetup::point_toward`]), in which a light whose square lies beyond
//! [`rsl_shade::TAIL_WIDTHS`] lobe widths of the mirror direction takes the BRDF at the
//! square's centre times its solid angle ([`rsl_shade::FrameSetup::midpoint_tails`]): the
//! lobe's tail is smooth over such a square, and each direction's light is one of many that
//! a vertex averages. For `bounces` above 1 the surfaces gather their own bounces first,
//! each along its normal (a glossy surface's earlier bounces taken as sending toward every
//! direction what they send along its normal), so the light of N bounces costs N gathers.
//!
//! The method draws the direct light as it always does; the gathered light is added to each
//! vertex's radiance and, in the image, interpolated across triangles (the CPU rasteriser,
//! antialiased as the image is) and added to every pixel. It turns and moves with the
//! objects: nothing is precomputed. Where the frame's drawing already found every light's
//! cover at an object's vertices (the RSL sum per pixel on the CPU, [`Frame::covers`]),
//! they are read rather than found again: a cover does not depend on the view. The direct
//! part is the method's own, so with `bounces = 0` every frame is exactly what the method
//! draws alone.

use crate::engine::Engine;
use crate::method::{Changes, Frame, Kept, Method, Preparation, Prepared, Request, Truth, rasterise_over};
use anyhow::{Result, bail};
use glam::Vec3;
use rayon::prelude::*;
use rsl_scene::{Scene, SceneState};
use rsl_shade::{Covers, Terms};
use rsl_truth::{EnvLight, GatherView, SurfaceHit};
use std::time::Instant;

/// The seed of the gathers' directions (one per bounce).
const SEED: u64 = 0x6f75_6e63_655f_7273;

thread_local! {
    /// Each thread's buffer of one point's covers, one per light ([`interreflections`]'s
    /// sources): a hit allocates nothing.
    static SCRATCH: std::cell::RefCell<Vec<f32>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// The light gathered at every vertex ([`interreflections`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Gathered {
    /// Per object, per vertex: the light of the bounces, toward the camera's eye.
    pub light: Vec<Vec<Vec3>>,
    /// Per object, per vertex: the world position.
    pub positions: Vec<Vec<Vec3>>,
}

/// The light of `bounces` bounces between the surfaces of `scene` at `state`, reflected
/// toward the camera's eye, at every vertex. Needs the engine's RSL layer (the sources are
/// its shading). `known`: per object, every light's cover at its vertices where the frame's
/// drawing already found them at `state` with every term ([`Frame::covers`]; `None`, or an
/// empty list, where not): those objects' covers are not found again.
pub fn interreflections(
    engine: &Engine,
    scene: &Scene,
    state: &SceneState,
    (bounces, rays): (u32, u32),
    known: &[Option<Covers>],
) -> Result<Gathered> {
    if !engine.layers().rsl {
        bail!(
            "interreflections (bounces = {bounces}) are gathered from the RSL path's shading, which this engine was \
             prepared without: use a method of the RSL path (rsl, pixel, hybrid, lobe, auto) or bounces = 0"
        );
    }
    let setup = engine.setup(scene, state, scene.camera.eye, Terms::default())?.along_normals().midpoint_tails();
    // What each surface sends from the point met, as the per-pixel drawing shades a point:
    // the traced lights (a sun) with their shadows traced from there where one's shadow
    // edge crosses the triangle met (its corners' covers differ), every other light's
    // cover interpolated from the surface's vertices; a Lambertian surface sends the same
    // toward every direction (where no traced shadow edge crosses, its vertices' radiance
    // along their normals, interpolated), a glossy one its RSL sum toward the receiver.
    let n = scene.objects.len();
    // A glossy surface's radiance along its normal is never read (it sends its RSL sum
    // toward each receiver): its covers alone are found.
    let lambertian: Vec<bool> = (0..n).map(|i| setup.view_independent(i)).collect();
    // A light's cover does not depend on the view: the covers the drawing found are the
    // ones found here, and of a Lambertian surface only its sums along the normals are read
    // again from them (`FrameSetup::sums_from_covers`).
    let known: Vec<Option<&Covers>> = (0..n).map(|i| known.get(i).and_then(Option::as_ref)).collect();
    let find: Vec<bool> = known.iter().map(Option::is_none).collect();
    let sum: Vec<bool> = (0..n).map(|i| find[i] && lambertian[i]).collect();
    let (mut along, mut found, _) = rsl_shade::shade_covers_for(&setup, &find, &sum);
    let mut untraced: Vec<Vec<Vec3>> =
        found.iter_mut().map(|c| c.as_mut().map_or_else(Vec::new, |c| std::mem::take(&mut c.untraced))).collect();
    for (i, c) in known.iter().enumerate() {
        if let (Some(c), true) = (c, lambertian[i]) {
            (along[i], untraced[i]) = setup.sums_from_covers(i, c);
        }
    }
    let covers: Vec<Option<&Covers>> = (0..n).map(|i| known[i].or(found[i].as_ref())).collect();
    let traced = setup.traced_lights();
    let lights = setup.light_count();
    let direct_at = |hit: &SurfaceHit| {
        let Some(c) = covers[hit.object] else { return Vec3::ZERO };
        let j = hit.object;
        let [a, b, d] = hit.corners.map(|k| k as usize * c.lights);
        let edge = |l: usize| c.values[a + l] != c.values[b + l] || c.values[a + l] != c.values[d + l];
        let crossed = traced.iter().any(|&l| edge(l));
        if lambertian[j] && !crossed {
            return at(&along, hit);
        }
        // Each thread's buffer of the lights' covers at the point, reused from hit to hit.
        SCRATCH.with_borrow_mut(|at| {
            at.clear();
            at.resize(lights, 0.0);
            let mut base = Vec3::ZERO;
            if lambertian[j] {
                let [a, b, d] = hit.corners.map(|k| untraced[j][k as usize]);
                base = a * hit.weights.x + b * hit.weights.y + d * hit.weights.z;
                for &l in &traced {
                    at[l] = c.values[hit.corners[0] as usize * c.lights + l].max(0.0);
                }
            } else {
                c.at_corners(hit.corners, hit.weights, at);
            }
            let mut rays = 0;
            for &l in traced.iter().filter(|&&l| edge(l)) {
                // One ray, the square's centre: each gathered direction draws its own.
                at[l] = setup.traced_cover_at(j, (hit.point, hit.frame.n, hit.face), l, 1, &mut rays);
            }
            let mut stats = rsl_shade::FrameStats::default();
            base + setup.point_toward(j, hit.toward, &hit.frame, at, &mut stats)
        })
    };
    // Only the geometry is traced: the environment is the direct part's.
    let truth = Truth::scene(engine, scene, state, EnvLight::Constant(Vec3::ZERO))?;
    // A Lambertian receiver's gathered light is the same toward every direction and varies
    // slowly over its surface: each vertex draws its own shift of the directions, and the
    // light is the mean over its ring of what each vertex's directions give its normal. A
    // glossy one's, toward the eye, can vary as fast as the reflections it shows: every
    // vertex draws the same directions.
    let rings: Vec<Option<Rings>> =
        (0..n).map(|i| lambertian[i].then(|| Rings::of(&engine.mesh(i).indices, &engine.mesh(i).normals))).collect();
    let gather = |view: GatherView, seed: u64, source: &(dyn Fn(&SurfaceHit) -> Vec3 + Sync)| -> Vec<Vec<Vec3>> {
        (0..n)
            .map(|i| {
                let vertices = truth.positions(i).len();
                let Some(rings) = &rings[i] else {
                    return (0..vertices)
                        .into_par_iter()
                        .map(|v| truth.gather(i, v, view, rays, seed, source))
                        .collect();
                };
                let moments: Vec<Option<[Vec3; 3]>> = (0..vertices)
                    .into_par_iter()
                    .map(|v| truth.gather_moments(i, v, view, rays, seed, source))
                    .collect();
                (0..vertices)
                    .into_par_iter()
                    .map(|v| rings.mean_at(v, &moments, |m| truth.reflect_moments(i, v, m)))
                    .collect()
            })
            .collect()
    };
    // The bounces before the last, gathered along each vertex's normal.
    let mut before: Option<Vec<Vec<Vec3>>> = None;
    for k in 1..bounces {
        let source = |hit: &SurfaceHit| direct_at(hit) + before.as_deref().map_or(Vec3::ZERO, |b| at(b, hit));
        before = Some(gather(GatherView::Normals, SEED ^ u64::from(k), &source));
    }
    let source = |hit: &SurfaceHit| direct_at(hit) + before.as_deref().map_or(Vec3::ZERO, |b| at(b, hit));
    let toward_eye = gather(GatherView::Eye(scene.camera.eye), SEED, &source);
    let positions = (0..n).map(|i| truth.positions(i).to_vec()).collect();
    Ok(Gathered { light: toward_eye, positions })
}

/// The power of the cosine between two normals that weighs a neighbour in a vertex's ring
/// ([`Rings::of`]).
const RING_SHARPNESS: i32 = 16;

/// Each vertex's ring: the vertices it shares a triangle with, and how much each counts
/// toward its mean ([`Rings::mean_at`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Rings {
    /// Vertex `v`'s neighbours are `neighbours[start[v]..start[v + 1]]`, each with its weight.
    start: Vec<u32>,
    neighbours: Vec<(u32, f32)>,
}

impl Rings {
    /// The rings of the mesh of triangles `indices` with vertex normals `normals`: each
    /// neighbour weighted by the cosine between its normal and the vertex's to the power
    /// [`RING_SHARPNESS`] (none where they are a right angle or more apart), so that a crease,
    /// or a curve sharper than its triangles, mixes little. On the interreflection scenes
    /// (`docs/bench/interreflections`, 64 directions) the square let the Lambert bunny's
    /// vertices err 3.64 % where the 16th power gives 2.92 % (2.76 % with one set of
    /// directions for all); flat walls are averaged either way.
    pub fn of(indices: &[u32], normals: &[Vec3]) -> Self {
        let n = normals.len();
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(indices.len() * 2);
        for t in indices.chunks_exact(3) {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                if a != b && (a as usize) < n && (b as usize) < n {
                    pairs.push((a, b));
                    pairs.push((b, a));
                }
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        let mut start = vec![0u32; n + 1];
        for &(a, _) in &pairs {
            start[a as usize + 1] += 1;
        }
        for v in 0..n {
            start[v + 1] += start[v];
        }
        let neighbours = pairs
            .iter()
            .map(|&(a, b)| {
                let c = normals[a as usize].normalize_or_zero().dot(normals[b as usize].normalize_or_zero());
                (b, c.max(0.0).powi(RING_SHARPNESS))
            })
            .collect();
        Self { start, neighbours }
    }

    /// Vertex `v`'s value as the mean over its ring of `value(m)` for each vertex's `items`
    /// (`v` weighing one, each neighbour its weight; those without an item left out, and
    /// nothing where `v` has none). Where each vertex's item errs independently of its
    /// neighbours' (shifted directions), the mean over a ring of `k` vertices errs about
    /// `1/√k` as much; what it blurs is what changes across one ring.
    pub fn mean_at<T>(&self, v: usize, items: &[Option<T>], value: impl Fn(&T) -> Vec3) -> Vec3 {
        let Some(Some(own)) = items.get(v) else { return Vec3::ZERO };
        let ring = self.start.get(v..v + 2).map_or(&[][..], |r| &self.neighbours[r[0] as usize..r[1] as usize]);
        let (sum, weight) = ring
            .iter()
            .filter(|(_, w)| *w > 0.0)
            .filter_map(|&(j, w)| items.get(j as usize)?.as_ref().map(|m| (value(m) * w, w)))
            .fold((value(own), 1.0), |(s, t), (x, w)| (s + x, t + w));
        sum / weight
    }
}

/// What `radiance` (per object, per vertex) holds at the point `hit` met, interpolated.
fn at(radiance: &[Vec<Vec3>], hit: &SurfaceHit) -> Vec3 {
    let r = &radiance[hit.object];
    let [a, b, c] = hit.corners.map(|k| r[k as usize]);
    a * hit.weights.x + b * hit.weights.y + c * hit.weights.z
}

/// A method with the scene's interreflections added ([`interreflections`]) whenever its
/// quality asks for bounces; with none, the method itself, frame for frame. The registry
/// builds every method that is not a Monte Carlo estimate (which follows the bounces by
/// itself) inside one.
pub struct Bounced {
    inner: Box<dyn Method>,
}

impl Bounced {
    /// `inner`, with interreflections where the scene's quality asks.
    pub fn new(inner: Box<dyn Method>) -> Self {
        Self { inner }
    }

    /// Whether `scene`'s quality asks for interreflections (bounces, and directions to
    /// gather them along).
    pub(crate) fn asked(scene: &Scene) -> bool {
        let q = scene.quality.settings;
        q.bounces > 0 && q.bounce_rays > 0
    }

    /// The request the inner method gets: the vertices' radiance too, since the gathered
    /// light is added to them.
    fn inner_request(scene: &Scene, request: &Request) -> Request {
        if Self::asked(scene) { Request { vertices: true, ..*request } } else { *request }
    }

    /// Adds the interreflections of the frame's scene to `frame`.
    fn add_bounces(engine: &Engine, scene: &Scene, frame: &mut Frame) -> Result<()> {
        // The drawing's covers are read here, and not kept in the frame.
        let known = std::mem::take(&mut frame.covers);
        if !Self::asked(scene) {
            return Ok(());
        }
        let q = scene.quality.settings;
        let start = Instant::now();
        let Gathered { light: indirect, positions } =
            interreflections(engine, scene, &frame.state, (q.bounces, q.bounce_rays), &known)?;
        if frame.has_vertices() {
            for (r, g) in frame.radiance.iter_mut().zip(&indirect) {
                for (r, g) in r.iter_mut().zip(g) {
                    *r += *g;
                }
            }
        }
        if let Some(image) = &mut frame.image {
            let gathered = rasterise_over(engine, scene, &positions, &indirect, |_| Vec3::ZERO);
            for (p, g) in image.pixels.iter_mut().zip(&gathered.pixels) {
                *p += *g;
            }
            // The device's encoding is of the direct light alone.
            frame.encoded = None;
        }
        frame.timings.add("interreflections", start.elapsed().as_secs_f64() * 1e3, None);
        Ok(())
    }
}

impl Method for Bounced {
    fn describe(&self) -> String {
        self.inner.describe()
    }

    fn bytes(&self) -> usize {
        self.inner.bytes()
    }

    fn built(&self) -> u64 {
        self.inner.built()
    }

    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        let mut frame = self.inner.render(engine, scene, &Self::inner_request(scene, request))?;
        Self::add_bounces(engine, scene, &mut frame)?;
        Ok(frame)
    }

    fn preparation(&mut self, engine: &Engine, scene: &Scene) -> Result<Option<Preparation>> {
        self.inner.preparation(engine, scene)
    }

    fn install(&mut self, prepared: Prepared) {
        self.inner.install(prepared);
    }

    /// The inner method's frame for what changed; the interreflections gathered whole
    /// (another object's move changes what every surface receives).
    fn render_changed(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        request: &Request,
        changes: &Changes,
        kept: &mut Kept,
    ) -> Result<Frame> {
        let mut frame =
            self.inner.render_changed(engine, scene, &Self::inner_request(scene, request), changes, kept)?;
        Self::add_bounces(engine, scene, &mut frame)?;
        Ok(frame)
    }

    fn explain(&mut self, engine: &Engine, scene: &Scene) -> Result<Vec<String>> {
        let mut lines = self.inner.explain(engine, scene)?;
        let q = scene.quality.settings;
        if q.bounces > 0 && q.bounce_rays > 0 {
            let what = if q.bounces == 1 { "1 bounce".to_string() } else { format!("{} bounces", q.bounces) };
            for l in &mut lines {
                l.push_str(&format!(
                    "; interreflections: {what} gathered from {} directions per vertex, interpolated",
                    q.bounce_rays
                ));
            }
        }
        Ok(lines)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_vertex_is_averaged_with_its_ring_weighted_by_its_normals_agreement() {
        // A square of two triangles (0-1-2, 0-2-3), then a fifth vertex on a triangle 1-4-2
        // whose normal is tilted so that it and its neighbours weigh a quarter to each other.
        let indices = [0, 1, 2, 0, 2, 3, 1, 4, 2];
        let up = Vec3::Z;
        let c = 0.25f32.powf(1.0 / RING_SHARPNESS as f32);
        let tilted = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
        let normals = [up, up, up, up, tilted];
        let rings = Rings::of(&indices, &normals);
        let values = [1.0, 2.0, 3.0, 4.0, 10.0].map(Vec3::splat);
        let items: Vec<Option<Vec3>> = values.iter().copied().map(Some).collect();
        let mean: Vec<Vec3> = (0..5).map(|v| rings.mean_at(v, &items, |x| *x)).collect();
        let expect = [
            // 0: itself, 1, 2, 3.
            (1.0 + 2.0 + 3.0 + 4.0) / 4.0,
            // 1: itself, 0, 2, and 4 at a quarter.
            (2.0 + 1.0 + 3.0 + 0.25 * 10.0) / 3.25,
            // 2: itself, 0, 1, 3, and 4 at a quarter.
            (3.0 + 1.0 + 2.0 + 4.0 + 0.25 * 10.0) / 4.25,
            // 3: itself, 0, 2.
            (4.0 + 1.0 + 3.0) / 3.0,
            // 4: itself, and 1 and 2 at a quarter.
            (10.0 + 0.25 * 2.0 + 0.25 * 3.0) / 1.5,
        ];
        for (v, (m, e)) in mean.iter().zip(expect).enumerate() {
            assert!((m.x - e).abs() < 1e-5 && m.x == m.z, "vertex {v}: {m} against {e}");
        }
        // A crease of a right angle or more does not mix; a lone vertex keeps its value.
        let rings = Rings::of(&[0, 1, 2], &[up, Vec3::X, -up, up]);
        let items = [1.0, 2.0, 3.0, 7.0].map(|x| Some(Vec3::splat(x)));
        let mean: Vec<Vec3> = (0..4).map(|v| rings.mean_at(v, &items, |x| *x)).collect();
        assert_eq!(mean, [1.0, 2.0, 3.0, 7.0].map(Vec3::splat));
        // A vertex without an item has nothing; a neighbour without one is left out.
        let rings = Rings::of(&[0, 1, 2], &[up, up, up]);
        let items = [Some(Vec3::ONE), None, Some(Vec3::splat(3.0))];
        assert_eq!(rings.mean_at(1, &items, |x| *x), Vec3::ZERO);
        assert_eq!(rings.mean_at(0, &items, |x| *x), Vec3::splat(2.0));
    }
}

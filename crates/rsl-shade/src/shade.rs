//! Per-vertex shading with the multiple product approximation (Xu et al. 2006, eq. 5 and
//! fig. 8).
//!
//! For a vertex `x` with view `v` toward the eye, over the RSLs `⟨c_i, r_i, I_i⟩`:
//!
//! `B = Σ_i I_i · ∫_{square_i} ρ cos θ dω · cover_self(square_i) · Π_j cover_Oj(square_i)`
//!
//! which is `Σ E_i · avg_ρ · cover_self · Π cover_Oj` with the energy `E_i = I_i·4r_i²`.
//!
//! - The BRDF square lies in the vertex's shading frame in world space: the object-space
//!   frame (normal, and tangent for anisotropic materials) carried by the object's current
//!   rotation and scale (normals by `R·S⁻¹`, tangents by `R·S`).
//! - Self visibility is looked up in the vertex's object-space frame `Frame::from_normal(n)`
//!   (as the SVDF was built), with the light direction carried into object space by
//!   `S⁻¹·R⁻¹`: ray casting commutes with affine maps, so the direction is exact under any
//!   scale; the square's size is kept. `cover_self` is the visible fraction of the square's
//!   part above the vertex's horizon (the field's coverage divided by the horizon's alone):
//!   the BRDF integral already leaves out the part below, and multiplying by the field's
//!   coverage (which counts that part as hidden) would count the horizon twice — a square
//!   half below the horizon would get half its light. On a rough ball under a low sun this
//!   darkened grazing views by 20 % (measured: 8.6 % → 6.4 % per vertex, docs/history.md).
//! - Occluder `j` is looked up in its own object space at its current transform: the point
//!   by `S⁻¹·R⁻¹·(x − t)`, the direction as above.
//! - Occluder culling: occluder `j` is skipped for RSL `i` when `x` lies beyond the field's
//!   outer shell (the field holds nothing there), or when the RSL's cone from `x` cannot meet
//!   `j`'s bounding sphere. The cone's half-angle is the angle from the centre to a corner of
//!   the square placed on the pole of the hemisphere map, `acos(1 − r²)`.
//!
//! [`shade_reference`] is the plain loop over vertices, RSLs and occluders through the
//! crates' public lookups; [`shade`] is the fast path (rayon over vertex blocks, the view's
//! table slices and each occluder's proximity found once per vertex, zero terms skipped).
//! They agree to float rounding.
//!
//! **Traced lights** ([`Traced`], [`FrameSetup::with_traced`]): for the few lights of highest
//! radiance — a sun, a studio lamp: the sharp shadows — the visibility fields can be replaced
//! per frame by shadow rays against the triangles (BVHs, each in its object's space at its
//! current transform). Each traced light gets `K` rays per vertex spread over its square (a
//! 2D low-discrepancy set, the first at the centre), from the vertex lifted along its normal
//! by `1e-4` of the scene's radius as the truth's rays are. The light's whole cover comes
//! from the rays: among those above the horizon of the vertex's visibility frame, each
//! weighted by the vertex's face-averaged mask, the share that neither the object itself
//! (when it can hide part of itself) nor any other object blocks — a joint visibility, not
//! a product of averages.

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use rsl_brdf::ViewLookup;
use rsl_sphere::Frame;
use rsl_sphere::hemi::dir_from_hemi;
use rsl_sphere::hemi::hemi_from_dir;
use rsl_vis::mask::VertexMask;
use rsl_vis::svdf::SvdfVertex;
use rsl_vis::{OvdfLookup, Svdf};

pub(crate) use crate::frame::{Cone, Near, Placed, TracedSetup, cone_misses_sphere, culled, near};
pub use crate::frame::{
    FrameStats, Light, OccluderBound, Pose, ShadeObject, Terms, Traced, TracedCovers, VertexFrames,
};

/// Everything a frame needs: objects at their current transforms, lights, eye.
pub struct FrameSetup<'a> {
    pub(crate) placed: Vec<Placed<'a>>,
    pub(crate) lights: Vec<Light>,
    cones: Vec<Cone>,
    /// Per light, its [`rsl_vis::mask::reach`].
    reaches: Vec<(f32, f32)>,
    pub(crate) eye: Vec3,
    pub(crate) terms: Terms,
    traced: TracedSetup,
}

impl<'a> FrameSetup<'a> {
    /// Places the objects and carries every light into every object's space.
    pub fn new(objects: &[ShadeObject<'a>], lights: &[Light], eye: Vec3, terms: Terms) -> Self {
        Self {
            placed: objects.iter().map(|&o| Placed::new(o, lights)).collect(),
            lights: lights.to_vec(),
            cones: lights.iter().map(|l| Cone::new(l.cone_half_angle())).collect(),
            reaches: lights.iter().map(|l| rsl_vis::mask::reach(l.half_diagonal)).collect(),
            eye,
            terms,
            traced: TracedSetup { flags: vec![false; lights.len()], ..TracedSetup::default() },
        }
    }

    /// Traces the shadows that other objects cast from the lights `traced` selects, instead
    /// of reading the occluder fields (module docs; replaces an earlier choice, and
    /// `Traced::default()` traces nothing). Objects without a BVH
    /// ([`ShadeObject::occluder`]) cast no traced shadows.
    ///
    /// Each light's rays are laid out in its square's plane oriented as in the environment
    /// (`world_from_env` carries it), so that turning the scene and the environment together
    /// turns the rays with them.
    pub fn with_traced(mut self, traced: Traced, world_from_env: glam::Quat) -> Self {
        let flags = traced.select(&self.lights);
        if !flags.contains(&true) {
            self.traced = TracedSetup { flags, ..TracedSetup::default() };
            return self;
        }
        let pattern = traced.pattern();
        let mut index = vec![usize::MAX; flags.len()];
        let mut dirs = Vec::new();
        for (l, _) in flags.iter().enumerate().filter(|(_, f)| **f) {
            let light = &self.lights[l];
            let env = Frame::from_normal((world_from_env.inverse() * light.dir).normalize_or_zero());
            let frame = Frame::from_normal_tangent(light.dir, world_from_env * env.t);
            let s = light.half_diagonal / std::f32::consts::SQRT_2;
            index[l] = dirs.len();
            dirs.push(pattern.iter().map(|u| frame.to_world(dir_from_hemi(*u * s)).normalize_or_zero()).collect());
        }
        // The truth's lift: 1e-4 of half the diagonal of the scene's bounding box.
        let (lo, hi) = self
            .placed
            .iter()
            .flat_map(|p| (0..p.object.mesh.vertex_count()).map(|v| p.position(v)))
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), x| (l.min(x), h.max(x)));
        let radius = if lo.x <= hi.x { 0.5 * (hi - lo).length() } else { 0.0 };
        self.traced = TracedSetup { flags, dirs, index, lift: 1e-4 * radius.max(f32::MIN_POSITIVE) };
        self
    }

    /// Whether any light is traced (its rays were laid out: O(1), for per-pixel callers).
    pub fn traces_any(&self) -> bool {
        !self.traced.dirs.is_empty()
    }

    /// Whether light `l` is traced.
    pub fn is_traced(&self, l: usize) -> bool {
        self.traced.flags.get(l).copied().unwrap_or(false)
    }

    /// The lights that are traced, in light order.
    pub fn traced_lights(&self) -> Vec<usize> {
        (0..self.lights.len()).filter(|&l| self.is_traced(l)).collect()
    }

    /// Traced light `l`'s cover at vertex `v` of object `i` under the frame's terms: with
    /// self-visibility, the mask-weighted fraction of its rays above the vertex's horizon that
    /// neither the object itself nor (with occluders) any other object blocks; without it,
    /// the fraction of all its rays no other object blocks. `rays` counts the rays traced.
    pub fn traced_cover(&self, i: usize, v: usize, l: usize, rays: &mut u64) -> f32 {
        self.traced_cover_with(i, v, l, self.terms.self_visibility, self.terms.occluders, rays)
    }

    /// [`FrameSetup::traced_cover`] with the terms given.
    pub(crate) fn traced_cover_with(
        &self,
        i: usize,
        v: usize,
        l: usize,
        own: bool,
        others: bool,
        rays: &mut u64,
    ) -> f32 {
        let p = &self.placed[i];
        let x = p.position(v) + p.pose.normal(p.object.mesh.normals[v]).normalize_or_zero() * self.traced.lift;
        let vis_frame = &p.object.frames.visibility[v];
        let mask = p.object.mask.vertex(v);
        let dirs = &self.traced.dirs[self.traced.index[l]];
        // Among the directions above the horizon of the vertex's visibility frame, each
        // weighted by its face-averaged mask (what the field's cover means).
        let above = |d: Vec3| {
            let local = vis_frame.to_local(p.pose.direction_to_object(d));
            (local.z > 0.0).then(|| mask.at(local))
        };
        self.traced_from(i, x, l, dirs, (own, others), above, rays)
    }

    /// Traced light `l`'s cover at a point of object `i` that is not a vertex (a pixel's):
    /// world position `x`, interpolated shading normal `n`, and the unit normal `face` of the
    /// face it lies on (on `n`'s side); the first `max_rays` of the light's rays, among those above the
    /// shading normal's horizon the share that the face sees and no object blocks (the
    /// truth's pixels mask with the hit face likewise).
    pub fn traced_cover_at(
        &self,
        i: usize,
        (x, n, face): (Vec3, Vec3, Vec3),
        l: usize,
        max_rays: usize,
        rays: &mut u64,
    ) -> f32 {
        let dirs = &self.traced.dirs[self.traced.index[l]];
        let dirs = &dirs[..dirs.len().min(max_rays.max(1))];
        let above = |d: Vec3| (n.dot(d) > 0.0).then(|| if face.dot(d) > 0.0 { 1.0 } else { 0.0 });
        let terms = (self.terms.self_visibility, self.terms.occluders);
        self.traced_from(i, x + n.normalize_or_zero() * self.traced.lift, l, dirs, terms, above, rays)
    }

    /// The traced cover from world point `x` (lifted off object `i`'s surface) along `dirs`:
    /// over the directions `above` counts (with their weights), the weighted share that the
    /// object itself (with `own`, when it can hide part of itself) and the others (with
    /// `others`) leave unblocked; without `own`, every direction counts with weight one.
    #[allow(clippy::too_many_arguments)]
    fn traced_from(
        &self,
        i: usize,
        x: Vec3,
        l: usize,
        dirs: &[Vec3],
        (own, others): (bool, bool),
        above: impl Fn(Vec3) -> Option<f32>,
        rays: &mut u64,
    ) -> f32 {
        if !own && !others {
            return 1.0;
        }
        let p = &self.placed[i];
        let cone = self.cones[l];
        // The other objects the light's cone from `x` can meet, with `x` in their spaces.
        let mut casters: [(usize, Vec3); 8] = [(0, Vec3::ZERO); 8];
        let mut more: Vec<(usize, Vec3)> = Vec::new();
        let mut count = 0;
        if others {
            for (j, q) in self.placed.iter().enumerate() {
                let (Some(_), Some(b)) = (q.object.occluder, q.bound) else { continue };
                if j == i || cone_misses_sphere(x, self.lights[l].dir, cone, b.centre_world, b.radius_world) {
                    continue;
                }
                let at = (j, q.point_to_object(x));
                if count < casters.len() {
                    casters[count] = at;
                } else {
                    more.push(at);
                }
                count += 1;
            }
        }
        // The object itself: only one that can hide part of itself (a stored field).
        let itself = if own && matches!(p.object.svdf, Svdf::Field { .. }) { p.object.occluder } else { None };
        if count == 0 && itself.is_none() && !own {
            return 1.0;
        }
        let x_own = p.point_to_object(x);
        let casters = casters[..count.min(8)].iter().chain(&more);
        let blocked_by = |j: usize, xo: Vec3, d: Vec3, rays: &mut u64| {
            *rays += 1;
            let q = &self.placed[j];
            let dir = q.pose.direction_to_object(d);
            let length = dir.length();
            length > 0.0 && q.object.occluder.is_some_and(|o| o.occluded(xo, dir / length, f32::INFINITY))
        };
        let (mut seen, mut counted) = (0.0f32, 0usize);
        for &d in dirs {
            let mut weight = 1.0;
            if own {
                let Some(w) = above(d) else { continue };
                counted += 1;
                weight = w;
                if weight <= 0.0 {
                    continue;
                }
                if let Some(o) = itself {
                    *rays += 1;
                    let dir = p.pose.direction_to_object(d);
                    if o.occluded(x_own, dir, f32::INFINITY) {
                        continue;
                    }
                }
            } else {
                counted += 1;
            }
            if casters.clone().any(|&(j, xo)| blocked_by(j, xo, d, rays)) {
                continue;
            }
            seen += weight;
        }
        if counted == 0 { 0.0 } else { seen / counted as f32 }
    }

    /// Every vertex's [`FrameSetup::traced_cover`] of every traced light, for a shader that
    /// cannot trace rays itself (the GPU's).
    pub fn traced_covers(&self) -> TracedCovers {
        let traced = self.traced_lights();
        let mut slots = vec![None; self.lights.len()];
        for (k, &l) in traced.iter().enumerate() {
            slots[l] = Some(k as u32);
        }
        let count = traced.len();
        if count == 0 {
            return TracedCovers { slots, count: 0, covers: Vec::new(), rays: 0 };
        }
        let blocks = self.blocks(BLOCK);
        let done: Vec<(Vec<f32>, u64)> = blocks
            .par_iter()
            .map(|&(i, b)| {
                let p = &self.placed[i];
                let n = p.object.mesh.vertex_count();
                let mut rays = 0;
                let mut out = Vec::with_capacity(BLOCK * count);
                for v in b * BLOCK..((b + 1) * BLOCK).min(n) {
                    for &l in &traced {
                        out.push(self.traced_cover(i, v, l, &mut rays));
                    }
                }
                (out, rays)
            })
            .collect();
        let rays = done.iter().map(|d| d.1).sum();
        TracedCovers { slots, count: count as u32, covers: done.into_iter().flat_map(|d| d.0).collect(), rays }
    }

    /// `cover` times what the other objects leave of light `l` at vertex `v` of object `i`
    /// (world point `x`): traced rays for a traced light, else the occluder fields at `nears`.
    pub(crate) fn others_cover(
        &self,
        nears: &mut [(Near, Lazy<'a>)],
        i: usize,
        v: usize,
        l: usize,
        cover: f32,
        stats: &mut FrameStats,
    ) -> f32 {
        if self.is_traced(l) {
            if cover <= 0.0 {
                return cover;
            }
            cover * self.traced_cover_with(i, v, l, false, true, &mut stats.traced_rays)
        } else {
            self.occluder_cover(nears, l, cover, stats)
        }
    }

    /// The parallel work items of a frame: `(object, block)` for every block of `size`
    /// vertices of every object.
    pub(crate) fn blocks(&self, size: usize) -> Vec<(usize, usize)> {
        self.placed
            .iter()
            .enumerate()
            .flat_map(|(i, p)| (0..p.object.mesh.vertex_count().div_ceil(size)).map(move |b| (i, b)))
            .collect()
    }

    /// A sphere around object `i`'s vertices in world space (their box's centre, and the
    /// farthest vertex from it).
    pub fn world_sphere(&self, i: usize) -> (Vec3, f32) {
        let p = &self.placed[i];
        let n = p.object.mesh.vertex_count();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for v in 0..n {
            let x = p.position(v);
            lo = lo.min(x);
            hi = hi.max(x);
        }
        let c = 0.5 * (lo + hi);
        let r = (0..n).map(|v| (p.position(v) - c).length()).fold(0.0f32, f32::max);
        (c, r)
    }

    /// Whether object `j` can shadow any vertex of object `i` in this frame (conservative:
    /// `true` may cast no shadow, `false` casts none). Without a field `j` shadows nothing;
    /// through its field only within the field's reach; through a traced light's rays
    /// wherever the light's cone from `i`'s bounding sphere meets `j`'s. A front end that
    /// moved `j` reshades `j` and the objects this names at the old and the new pose.
    pub fn may_shadow(&self, j: usize, i: usize) -> bool {
        if i == j {
            return false;
        }
        let Some(b) = self.placed[j].bound else { return false };
        let (c, r) = self.world_sphere(i);
        let reach = b.reach_object * self.placed[j].object.transform.scale.max_element();
        if (c - b.centre_world).length() - r < reach {
            return true;
        }
        if self.terms.occluders && self.placed[j].object.occluder.is_some() {
            for (l, light) in self.lights.iter().enumerate() {
                if !self.is_traced(l) {
                    continue;
                }
                let alpha = self.cones[l].0;
                if alpha >= std::f32::consts::FRAC_PI_2 {
                    return true;
                }
                let w = b.centre_world - c;
                let t = w.dot(light.dir);
                let slack = r + b.radius_world;
                if t < -slack {
                    continue;
                }
                let q = (w - t * light.dir).length();
                // The cone widens by tan α per unit along the light, from anywhere in i's sphere.
                if q <= slack + t.max(0.0) * alpha.tan() + 1e-4 * slack {
                    return true;
                }
            }
        }
        false
    }

    /// World position of vertex `v` of object `i`.
    pub fn position(&self, i: usize, v: usize) -> Vec3 {
        self.placed[i].position(v)
    }

    /// The number of lights.
    pub fn light_count(&self) -> usize {
        self.lights.len()
    }

    /// World shading frame of vertex `v` of object `i` (its normal, and its tangent for an
    /// anisotropic material, at the object's current transform).
    pub fn shading_frame(&self, i: usize, v: usize) -> Frame {
        self.placed[i].shading_frame(v)
    }

    /// World normal of vertex `v` of object `i`.
    pub fn normal(&self, i: usize, v: usize) -> Vec3 {
        let p = &self.placed[i];
        p.pose.normal(p.object.mesh.normals[v])
    }

    /// Radiance of vertex `v` of object `i` toward the eye, and its lookups (the fast path's
    /// inner loop).
    fn vertex(
        &self,
        i: usize,
        v: usize,
        nears: &mut Vec<(Near, Lazy<'a>)>,
        stats: &mut FrameStats,
        untraced: &mut Vec3,
    ) -> Vec3 {
        let p = &self.placed[i];
        let o = &p.object;
        stats.vertices += 1;
        let x = p.position(v);
        let frame = p.shading_frame(v);
        let view = frame.to_local((self.eye - x).normalize_or_zero());
        let lookup = o.table.view_lookup(view);
        if lookup == ViewLookup::Below {
            stats.back_facing += 1;
            return Vec3::ZERO;
        }
        nears.clear();
        if self.terms.occluders {
            // Where the vertex lies in a field is found the first time a light needs it:
            // culling often leaves an occluder nothing to look up.
            self.nears(i, x, nears);
        }
        let vis_frame = &o.frames.visibility[v];
        let self_vis = o.svdf.vertex(v);
        let mask = o.mask.vertex(v);
        let mut sum = Vec3::ZERO;
        for (l, light) in self.lights.iter().enumerate() {
            let r = light.half_diagonal;
            stats.brdf_lookups += 1;
            let brdf = o.table.integral_for(&lookup, frame.to_local(light.dir), r);
            if brdf == Vec3::ZERO {
                continue;
            }
            let traced = self.is_traced(l);
            let cover = if traced {
                self.traced_cover(i, v, l, &mut stats.traced_rays)
            } else {
                let q = hemi_from_dir(vis_frame.to_local(p.light_dirs[l]));
                self.fields_cover(nears, (i, v, l), q, (&self_vis, &mask), stats)
            };
            let term = light.radiance * brdf * cover;
            sum += term;
            if !traced {
                *untraced += term;
            }
        }
        sum
    }

    /// Light `l`'s cover at vertex `v` of object `i` from the visibility fields (a light that
    /// is not traced): self-visibility at hemisphere point `q` of the vertex's visibility
    /// frame (with its face mask), times the occluder fields at `nears`, as the terms ask.
    fn fields_cover(
        &self,
        nears: &mut [(Near, Lazy<'a>)],
        (i, v, l): (usize, usize, usize),
        q: Vec2,
        (self_vis, mask): (&SvdfVertex<'_>, &VertexMask<'_>),
        stats: &mut FrameStats,
    ) -> f32 {
        let r = self.lights[l].half_diagonal;
        let mut cover = 1.0;
        if self.terms.self_visibility {
            stats.self_lookups += 1;
            cover = self_vis.coverage_above_horizon(q, r);
            if cover > 0.0 {
                cover *= mask.share_above_horizon_with(q, r, self.reaches[l]);
            }
        }
        if self.terms.occluders {
            cover = self.others_cover(nears, i, v, l, cover, stats);
        }
        cover
    }

    /// Every light's cover at vertex `v` of object `i` into `out` (one per light; what
    /// multiplies the light's BRDF integral there, [`crate::pixel::UNDEFINED`] for a light
    /// wholly below the vertex's horizon), and the vertex's radiance toward the eye. Unlike
    /// [`FrameSetup::vertex`] every light above the horizon gets its cover, whatever the
    /// vertex's BRDF does with it: points near the vertex (a pixel's) have other normals
    /// and views.
    pub(crate) fn vertex_covers(
        &self,
        i: usize,
        v: usize,
        nears: &mut Vec<(Near, Lazy<'a>)>,
        stats: &mut FrameStats,
        out: &mut [f32],
        untraced: &mut Vec3,
    ) -> Vec3 {
        let p = &self.placed[i];
        let o = &p.object;
        stats.vertices += 1;
        let x = p.position(v);
        let frame = p.shading_frame(v);
        let lookup = o.table.view_lookup(frame.to_local((self.eye - x).normalize_or_zero()));
        nears.clear();
        if self.terms.occluders {
            self.nears(i, x, nears);
        }
        let vis_frame = &o.frames.visibility[v];
        let self_vis = o.svdf.vertex(v);
        let mask = o.mask.vertex(v);
        let mut sum = Vec3::ZERO;
        for (l, light) in self.lights.iter().enumerate() {
            let r = light.half_diagonal;
            // Wholly below the horizon: no part of the square in the hemisphere plane's disk.
            let q = hemi_from_dir(vis_frame.to_local(p.light_dirs[l]));
            if rsl_vis::coverage::coverage(1.0 - q.length(), r) <= 0.0 {
                out[l] = crate::pixel::UNDEFINED;
                continue;
            }
            let cover = if self.is_traced(l) {
                self.traced_cover(i, v, l, &mut stats.traced_rays)
            } else {
                self.fields_cover(nears, (i, v, l), q, (&self_vis, &mask), stats)
            };
            out[l] = cover;
            if lookup != ViewLookup::Below && cover > 0.0 {
                stats.brdf_lookups += 1;
                let term = light.radiance * o.table.integral_for(&lookup, frame.to_local(light.dir), r) * cover;
                sum += term;
                if !self.is_traced(l) {
                    *untraced += term;
                }
            }
        }
        sum
    }

    /// Whether object `i`'s BRDF is view-independent (Lambertian: one table for every view).
    pub fn view_independent(&self, i: usize) -> bool {
        self.placed[i].object.table.view_lookup(Vec3::Z) == ViewLookup::Single
    }

    /// Radiance toward the eye from world point `x` of object `i` with world shading frame
    /// `frame`, each light weighted by its cover `covers[l]` (the RSL sum at a point that
    /// is not a vertex: a pixel's).
    pub fn point(&self, i: usize, x: Vec3, frame: &Frame, covers: &[f32], stats: &mut FrameStats) -> Vec3 {
        let o = &self.placed[i].object;
        let lookup = o.table.view_lookup(frame.to_local((self.eye - x).normalize_or_zero()));
        if lookup == ViewLookup::Below {
            return Vec3::ZERO;
        }
        let mut sum = Vec3::ZERO;
        for (light, &cover) in self.lights.iter().zip(covers) {
            if cover > 0.0 {
                stats.brdf_lookups += 1;
                sum += light.radiance
                    * o.table.integral_for(&lookup, frame.to_local(light.dir), light.half_diagonal)
                    * cover;
            }
        }
        sum
    }

    /// `cover` times the occluder fields' coverages of light `l` at a vertex whose occluders
    /// are `nears` (located on first use); nothing is looked up once it is zero.
    pub(crate) fn occluder_cover(
        &self,
        nears: &mut [(Near, Lazy<'a>)],
        l: usize,
        mut cover: f32,
        stats: &mut FrameStats,
    ) -> f32 {
        let light = &self.lights[l];
        for (n, at) in nears.iter_mut() {
            if cover <= 0.0 {
                break;
            }
            if culled(n, light.dir, self.cones[l]) {
                stats.occluders_culled += 1;
                continue;
            }
            if let Some(at) = self.located(n, at) {
                stats.occluder_lookups += 1;
                cover *= at.coverage(self.placed[n.j].light_dirs[l], light.half_diagonal);
            }
        }
        cover
    }

    /// Occluder `n`'s field prepared at the vertex (located on first use), or `None` where
    /// the vertex is beyond it.
    fn located<'s>(&self, n: &Near, at: &'s mut Lazy<'a>) -> Option<&'s OvdfLookup<'a>> {
        if let Lazy::Unknown = at {
            let field = self.placed[n.j].object.ovdf;
            *at = match field.and_then(|f| Some(f.prepare(&f.locate(n.x_object)?))) {
                Some(prepared) => Lazy::Ready(prepared),
                None => Lazy::Outside,
            };
        }
        match at {
            Lazy::Ready(at) => Some(at),
            _ => None,
        }
    }

    /// The covers at vertex `v` of object `i` of square lights toward world directions
    /// `squares[k].0` with half-diagonals `squares[k].1` (solid angle `4r²`), into `out`: the
    /// self-visibility field's coverage above the horizon times the face mask's share, times
    /// every other object's occluder field, as the terms ask — the fields only, nothing
    /// traced. The lobe path's own shadows (`rsl_engine::lobe`, `method = "lobe"`) read it
    /// with one square per lobe, matched to the lobe's width.
    pub fn square_covers(&self, i: usize, v: usize, squares: &[(Vec3, f32)], out: &mut [f32], stats: &mut FrameStats) {
        let p = &self.placed[i];
        let o = &p.object;
        let mut nears = Vec::new();
        if self.terms.occluders {
            self.nears(i, p.position(v), &mut nears);
        }
        for (&(dir, r), cover) in squares.iter().zip(out.iter_mut()) {
            *cover = 1.0;
            if self.terms.self_visibility {
                let q = hemi_from_dir(o.frames.visibility[v].to_local(p.pose.direction_to_object(dir)));
                stats.self_lookups += 1;
                *cover = o.svdf.vertex(v).coverage_above_horizon(q, r);
                if *cover > 0.0 {
                    *cover *= o.mask.vertex(v).share_above_horizon_with(q, r, rsl_vis::mask::reach(r));
                }
            }
            for (n, at) in nears.iter_mut() {
                if *cover <= 0.0 {
                    break;
                }
                if let Some(at) = self.located(n, at) {
                    stats.occluder_lookups += 1;
                    *cover *= at.coverage(self.placed[n.j].pose.direction_to_object(dir), r);
                }
            }
        }
    }

    /// The occluders near world point `x` on object `i` (every other object whose field
    /// reaches `x`), not yet located in their fields.
    pub(crate) fn nears(&self, i: usize, x: Vec3, out: &mut Vec<(Near, Lazy<'a>)>) {
        out.clear();
        out.extend(
            (0..self.placed.len())
                .filter(|&j| j != i)
                .filter_map(|j| Some((near(&self.placed[j], j, x)?, Lazy::Unknown))),
        );
    }
}

/// An occluder field's lookup at a vertex, prepared when first needed.
// Held in a reused per-thread list (a box each would allocate per vertex and occluder).
#[allow(clippy::large_enum_variant)]
pub(crate) enum Lazy<'a> {
    /// Not located yet.
    Unknown,
    /// Beyond the field: nothing occluded.
    Outside,
    /// Located and prepared.
    Ready(OvdfLookup<'a>),
}

/// Vertices per parallel work item of the fast path.
pub(crate) const BLOCK: usize = 256;

/// Shades every vertex of every object (the fast path): per object, per vertex, the radiance
/// toward the eye.
pub fn shade(setup: &FrameSetup<'_>) -> (Vec<Vec<Vec3>>, FrameStats) {
    shade_objects(setup, &vec![true; setup.placed.len()])
}

/// [`shade`] for the objects `which` selects (one flag per object); the others come back
/// empty. An object's radiance depends on the others only through their shadows, so a
/// front end that changed one object's material reshades that object alone.
pub fn shade_objects(setup: &FrameSetup<'_>, which: &[bool]) -> (Vec<Vec<Vec3>>, FrameStats) {
    let (radiance, _, stats) = shade_objects_untraced(setup, which);
    (radiance, stats)
}

/// One block of vertices shaded: object, per vertex the radiance and its untraced lights'
/// part, costs.
type UntracedBlock = (usize, Vec<(Vec3, Vec3)>, FrameStats);

/// [`shade_objects`], and per vertex the radiance of the lights that are not traced (the
/// rest of the sum: the traced lights' shadows are what varies fastest across a triangle).
pub fn shade_objects_untraced(setup: &FrameSetup<'_>, which: &[bool]) -> (Vec<Vec<Vec3>>, Vec<Vec<Vec3>>, FrameStats) {
    let mut blocks = setup.blocks(BLOCK);
    blocks.retain(|&(i, _)| which.get(i).copied().unwrap_or(false));
    let done: Vec<UntracedBlock> = blocks
        .par_iter()
        .map_init(Vec::new, |nears, &(i, b)| {
            let n = setup.placed[i].object.mesh.vertex_count();
            let mut stats = FrameStats::default();
            let out = (b * BLOCK..((b + 1) * BLOCK).min(n))
                .map(|v| {
                    let mut untraced = Vec3::ZERO;
                    (setup.vertex(i, v, nears, &mut stats, &mut untraced), untraced)
                })
                .collect();
            (i, out, stats)
        })
        .collect();
    let with_capacity = || -> Vec<Vec<Vec3>> {
        setup.placed.iter().map(|p| Vec::with_capacity(p.object.mesh.vertex_count())).collect()
    };
    let (mut radiance, mut untraced) = (with_capacity(), with_capacity());
    let mut stats = FrameStats::default();
    // Blocks come back in order (rayon's collect keeps it).
    for (i, out, s) in done {
        radiance[i].extend(out.iter().map(|o| o.0));
        untraced[i].extend(out.iter().map(|o| o.1));
        stats = stats.plus(s);
    }
    (radiance, untraced, stats)
}

/// The reference: the formula as written, one vertex, RSL and occluder at a time, through
/// the public lookups of rsl-brdf and rsl-vis, with nothing hoisted. It culls as the fast
/// path does (an occluder outside its field's reach, or whose bounding sphere the light's
/// cone misses, covers nothing), so the two agree on which lookups are made; the culling
/// of an occluder beyond its field is checked to change nothing in rsl-engine's tests.
pub fn shade_reference(setup: &FrameSetup<'_>) -> Vec<Vec<Vec3>> {
    let mut out = Vec::new();
    for (i, p) in setup.placed.iter().enumerate() {
        let o = &p.object;
        let mut radiance = Vec::with_capacity(o.mesh.vertex_count());
        for v in 0..o.mesh.vertex_count() {
            let x = p.position(v);
            let frame = p.shading_frame(v);
            let view = frame.to_local((setup.eye - x).normalize_or_zero());
            let vis_frame = Frame::from_normal(o.mesh.normals[v]);
            let mut sum = Vec3::ZERO;
            for (l, light) in setup.lights.iter().enumerate() {
                let r = light.half_diagonal;
                let brdf = o.table.square(frame.to_local(light.dir), r, view).integral;
                if setup.is_traced(l) {
                    sum += light.radiance * brdf * setup.traced_cover(i, v, l, &mut 0);
                    continue;
                }
                let mut cover = 1.0;
                if setup.terms.self_visibility {
                    let d = p.pose.direction_to_object(light.dir);
                    let q: Vec2 = hemi_from_dir(vis_frame.to_local(d));
                    cover = o.svdf.coverage_above_horizon(v, q, r) * o.mask.vertex(v).share_above_horizon(q, r);
                }
                if setup.terms.occluders {
                    for (j, q) in setup.placed.iter().enumerate() {
                        if j == i {
                            continue;
                        }
                        let Some(n) = near(q, j, x) else { continue };
                        if culled(&n, light.dir, setup.cones[l]) {
                            continue;
                        }
                        let d = q.pose.direction_to_object(light.dir);
                        cover *= q.object.ovdf.expect("near() needs a field").coverage(n.x_object, d, r);
                    }
                }
                sum += light.radiance * brdf * cover;
            }
            radiance.push(sum);
        }
        out.push(radiance);
    }
    out
}

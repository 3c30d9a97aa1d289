//! **Traced lights** ([`crate::Traced`], [`FrameSetup::with_traced`]): for the few lights of highest
//! radiance — a sun, a studio lamp: the sharp shadows — the visibility fields can be replaced
//! per frame by shadow rays against the triangles (BVHs, each in its object's space at its
//! current transform). Each traced light gets `K` rays per vertex spread over its square (a
//! 2D low-discrepancy set, the first at the centre), from the vertex lifted along its normal
//! by `1e-4` of the scene's radius as the truth's rays are. The light's whole cover comes
//! from the rays: among those above the horizon of the vertex's visibility frame, each
//! weighted by the vertex's face-averaged mask, the share that neither the object itself
//! (when it can hide part of itself) nor any other object blocks — a joint visibility, not
//! a product of averages.

use crate::frame::{TracedSetup, cone_misses_sphere};
use crate::shade::{BLOCK, FrameSetup, Traced, TracedCovers};
use glam::Vec3;
use rsl_sphere::Frame;
use rsl_sphere::hemi::dir_from_hemi;
use rsl_vis::Svdf;

impl<'a> FrameSetup<'a> {
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

    /// Traced light `l`'s ray directions (world; its square's pattern, the centre first),
    /// none for a light that is not traced.
    pub fn traced_rays(&self, l: usize) -> &[Vec3] {
        if self.is_traced(l) { &self.traced.dirs[self.traced.index[l]] } else { &[] }
    }

    /// How far traced rays start off the surface, along its normal (world units).
    pub fn traced_lift(&self) -> f32 {
        self.traced.lift
    }

    /// Light `l` as the frame has it (world direction, square, radiance with the
    /// environment's intensity).
    pub fn light(&self, l: usize) -> &rsl_frame::Light {
        &self.lights[l]
    }

    /// The lights that are traced, in light order.
    pub fn traced_lights(&self) -> Vec<usize> {
        (0..self.lights.len()).filter(|&l| self.is_traced(l)).collect()
    }

    /// Traced light `l`'s cover at vertex `v` of object `i` under the frame's terms: with
    /// self-visibility, the mask-weighted (without [`FrameSetup::without_face_mask`]) fraction of its rays above the vertex's horizon that
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
        self.traced_at_vertex(i, v, l, (own, others), false, rays)[0]
    }

    /// Traced light `l`'s cover at vertex `v` of object `i` under the frame's terms, with and
    /// without the vertex's face mask (`[masked, unmasked]`: [`FrameSetup::traced_cover`] of
    /// this setup and of [`FrameSetup::without_face_mask`]'s) from the same rays.
    pub(crate) fn traced_cover_both(&self, i: usize, v: usize, l: usize, rays: &mut u64) -> [f32; 2] {
        self.traced_at_vertex(i, v, l, (self.terms.self_visibility, self.terms.occluders), true, rays)
    }

    /// [`FrameSetup::traced_cover_with`], and with `both` the share of the same rays without
    /// the face mask beside it.
    fn traced_at_vertex(
        &self,
        i: usize,
        v: usize,
        l: usize,
        terms: (bool, bool),
        both: bool,
        rays: &mut u64,
    ) -> [f32; 2] {
        let p = &self.placed[i];
        let x = p.position(v) + p.pose.normal(p.object.mesh.normals[v]).normalize_or_zero() * self.traced.lift;
        let vis_frame = &p.object.frames.visibility[v];
        let mask = p.object.mask.vertex(v);
        let dirs = &self.traced.dirs[self.traced.index[l]];
        // Among the directions above the horizon of the vertex's visibility frame, each
        // weighted by its face-averaged mask (what the field's cover means).
        let above = |d: Vec3| {
            let local = vis_frame.to_local(p.pose.direction_to_object(d));
            (local.z > 0.0).then(|| if self.face_mask { mask.at(local) } else { 1.0 })
        };
        self.traced_from_both(i, x, l, dirs, terms, above, both, rays)
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
        terms: (bool, bool),
        above: impl Fn(Vec3) -> Option<f32>,
        rays: &mut u64,
    ) -> f32 {
        self.traced_from_both(i, x, l, dirs, terms, above, false, rays)[0]
    }

    /// [`FrameSetup::traced_from`]'s share, and with `both` beside it the share of the same
    /// directions unweighted (every direction `above` counts with weight one; the rays that
    /// a zero weight would spare are traced too).
    #[allow(clippy::too_many_arguments)]
    fn traced_from_both(
        &self,
        i: usize,
        x: Vec3,
        l: usize,
        dirs: &[Vec3],
        (own, others): (bool, bool),
        above: impl Fn(Vec3) -> Option<f32>,
        both: bool,
        rays: &mut u64,
    ) -> [f32; 2] {
        if !own && !others {
            return [1.0; 2];
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
            return [1.0; 2];
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
        let (mut seen, mut seen_all, mut counted) = (0.0f32, 0.0f32, 0usize);
        for &d in dirs {
            let mut weight = 1.0;
            if own {
                let Some(w) = above(d) else { continue };
                counted += 1;
                weight = w;
                if weight <= 0.0 && !both {
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
            seen_all += 1.0;
        }
        if counted == 0 { [0.0; 2] } else { [seen / counted as f32, seen_all / counted as f32] }
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
        let (blocks, rays) = self.par_blocks(
            None,
            BLOCK,
            |a, b| a + b,
            |_, rays, i, vertices| {
                let mut out = Vec::with_capacity(vertices.len() * count);
                for v in vertices {
                    out.extend(traced.iter().map(|&l| self.traced_cover(i, v, l, rays)));
                }
                out
            },
        );
        TracedCovers { slots, count: count as u32, covers: blocks.into_iter().flat_map(|b| b.1).collect(), rays }
    }
}

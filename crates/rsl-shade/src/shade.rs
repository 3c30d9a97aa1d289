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
//! The parts: the frame's setup and geometry here; the RSL sum and its parallel driver in
//! [`crate::sum`]; the covers from the visibility fields in `crate::covers`; the traced
//! lights' rays in `crate::traced`; the reference in `crate::reference`.
//!
use glam::Vec3;
use rsl_brdf::ViewLookup;
use rsl_sphere::Frame;

pub(crate) use crate::covers::Lazy;
pub(crate) use crate::frame::{Cone, Placed, TracedSetup};
pub use crate::frame::{
    FrameStats, Light, OccluderBound, Pose, ShadeObject, Terms, Traced, TracedCovers, VertexFrames,
};
pub use crate::reference::shade_reference;

/// Everything a frame needs: objects at their current transforms, lights, eye.
pub struct FrameSetup<'a> {
    pub(crate) placed: Vec<Placed<'a>>,
    pub(crate) lights: Vec<Light>,
    pub(crate) cones: Vec<Cone>,
    /// Per light, its [`rsl_vis::mask::reach`].
    pub(crate) reaches: Vec<(f32, f32)>,
    pub(crate) eye: Vec3,
    /// Each vertex seen along its own shading normal rather than from the eye
    /// ([`FrameSetup::along_normals`]).
    pub(crate) along_normals: bool,
    /// Per object, per light: the cosine between the light and a point's mirror direction
    /// below which the light is in the lobe's tail ([`tail_cosines`]); empty for a
    /// Lambertian object.
    pub(crate) tails: Vec<Vec<f32>>,
    /// Whether a tail's integral is the BRDF at the square's centre
    /// ([`FrameSetup::midpoint_tails`]) rather than the table's density there.
    pub(crate) exact_tails: bool,
    /// Whether a cut square at a Lambertian point is averaged over its sub-squares
    /// ([`FrameSetup::occluder_cover`]).
    pub(crate) cut_squares: bool,
    /// Whether the object's own part of a cover is weighted by the vertex's face mask
    /// ([`FrameSetup::without_face_mask`]).
    pub(crate) face_mask: bool,
    pub(crate) terms: Terms,
    pub(crate) traced: TracedSetup,
}

impl<'a> FrameSetup<'a> {
    /// The terms the frame is set up for.
    pub fn terms(&self) -> Terms {
        self.terms
    }

    /// The eye the frame is seen from.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }

    /// Places the objects and carries every light into every object's space.
    pub fn new(objects: &[ShadeObject<'a>], lights: &[Light], eye: Vec3, terms: Terms) -> Self {
        Self {
            placed: objects.iter().map(|&o| Placed::new(o, lights)).collect(),
            lights: lights.to_vec(),
            cones: lights.iter().map(|l| Cone::new(l.cone_half_angle())).collect(),
            reaches: lights.iter().map(|l| rsl_vis::mask::reach(l.half_diagonal)).collect(),
            eye,
            along_normals: false,
            tails: objects.iter().map(|o| tail_cosines(o.table.brdf(), lights)).collect(),
            exact_tails: false,
            cut_squares: true,
            face_mask: true,
            terms,
            traced: TracedSetup { flags: vec![false; lights.len()], ..TracedSetup::default() },
        }
    }

    /// The same frame with every vertex seen along its own shading normal instead of from
    /// the eye: each vertex's radiance toward its normal, which for a Lambertian surface is
    /// its radiance in every direction above it (no vertex faces away). What a surface sends
    /// to the others ([`shade`] of this setup is the first bounce's source).
    pub fn along_normals(mut self) -> Self {
        self.along_normals = true;
        self
    }

    /// The same frame with the object's own part of every cover left without the vertex's
    /// face mask: the self-visibility field above the vertex's horizon alone (and a traced
    /// light's rays above it unweighted). For a drawing that weighs a vertex's directions by
    /// the mask at a finer scale than a square (the hybrid's lobes, `rsl_engine::lobe`), whose
    /// RSL sums' ratio must not take it again ([`shade_objects_masked_and_not`] gives both).
    pub fn without_face_mask(mut self) -> Self {
        self.face_mask = false;
        self
    }

    /// The same frame with the BRDF integral of a light in a glossy point's lobe tail
    /// ([`tail_cosines`]) taken at the square's centre from the BRDF itself, times its solid
    /// angle `4r²`, instead of from the table's density there. For sums averaged with many
    /// others (what a glossy surface sends in the interreflections' gathering), which need
    /// not match the GPU's image.
    pub fn midpoint_tails(mut self) -> Self {
        self.exact_tails = true;
        self
    }

    /// The same frame with every square's BRDF integral read from its box in the table, the
    /// lobes' tails included ([`tail_cosines`]): what the midpoint rule stands in for, to
    /// measure what it costs.
    pub fn without_tails(mut self) -> Self {
        self.tails = Vec::new();
        self
    }

    /// The same frame with every occluder's coverage of a square taken whole, also where it
    /// cuts the square at a Lambertian point ([`FrameSetup::occluder_cover`]): what the
    /// sub-squares replace, to measure what they gain.
    pub fn without_cut_squares(mut self) -> Self {
        self.cut_squares = false;
        self
    }

    /// Whether light `l`, in direction `dir`, lies in the lobe's tail at a point of object `i`
    /// seen from `view` (both in the point's shading frame): its cosine with the view's
    /// mirror direction below the one [`tail_cosines`] gives it.
    #[inline]
    pub fn in_tail(&self, i: usize, view: Vec3, dir: Vec3, l: usize) -> bool {
        let mirror = Vec3::new(-view.x, -view.y, view.z);
        self.tails.get(i).and_then(|t| t.get(l)).is_some_and(|&c| dir.dot(mirror) < c)
    }

    /// Whether the lobe's tails take the midpoint rule at a point of object `i` seen from
    /// `view` with shading frame `frame`: where some light is near the lobe (not in its tail,
    /// [`FrameSetup::in_tail`]), whose box is read. Where every light is in the tail — the
    /// mirror direction in a gap between squares — the sum is all tails, and the midpoint
    /// rule, which misses a steep tail's near edge (a Beckmann lobe's falls off like a
    /// Gaussian), would make it vanish: every box is read there.
    pub fn tails_at(&self, i: usize, view: Vec3, frame: &Frame) -> bool {
        // Without a rule to take them by, the tails read their boxes anyway.
        let rule = self.exact_tails || density_tails(self.placed[i].object.table.brdf());
        rule && !self.tails.get(i).is_none_or(Vec::is_empty)
            && (0..self.lights.len()).any(|l| !self.in_tail(i, view, frame.to_local(self.lights[l].dir), l))
    }

    /// Light `l`'s BRDF integral at a point of object `i` whose view (local frame) the
    /// table's `lookup` located: with `tails` ([`FrameSetup::tails_at`]), a light in the
    /// lobe's tail by the midpoint rule ([`tail_cosines`]; the table's density, or with
    /// [`FrameSetup::midpoint_tails`] the BRDF, at the square's centre); any other by its
    /// box in the table.
    #[inline]
    pub(crate) fn light_integral(
        &self,
        i: usize,
        (lookup, view, tails): (&ViewLookup, Vec3, bool),
        dir: Vec3,
        l: usize,
    ) -> Vec3 {
        let table = &self.placed[i].object.table;
        let r = self.lights[l].half_diagonal;
        if !(tails && self.in_tail(i, view, dir, l)) {
            return table.integral_for(lookup, dir, r);
        }
        if self.exact_tails {
            table.brdf().eval_cos(dir, view) * (4.0 * r * r)
        } else if density_tails(table.brdf()) {
            table.tail_for(lookup, dir, r)
        } else {
            table.integral_for(lookup, dir, r)
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

    /// Object `i`'s vertices' world positions.
    pub fn positions(&self, i: usize) -> Vec<Vec3> {
        (0..self.placed[i].object.mesh.vertex_count()).map(|v| self.position(i, v)).collect()
    }

    /// Object `i`'s vertices' world normals.
    pub fn normals(&self, i: usize) -> Vec<Vec3> {
        (0..self.placed[i].object.mesh.vertex_count()).map(|v| self.normal(i, v)).collect()
    }

    /// Whether object `i`'s BRDF is view-independent (Lambertian: one table for every view).
    pub fn view_independent(&self, i: usize) -> bool {
        self.placed[i].lambertian
    }

    /// The frame in which a point of object `i` with world shading frame `frame` weighs its
    /// cut squares ([`FrameSetup::occluder_cover`]): its own for a Lambertian object, none
    /// for any other.
    #[inline]
    pub(crate) fn receiver<'f>(&self, i: usize, frame: &'f Frame) -> Option<&'f Frame> {
        (self.cut_squares && self.placed[i].lambertian).then_some(frame)
    }
}

/// Lobe widths ([`rsl_brdf::Brdf::lobe_width`], about one standard deviation) beyond which
/// a square's BRDF integral is its centre's density times its solid angle
/// ([`tail_cosines`]).
pub const TAIL_WIDTHS: f32 = 3.0;

/// Per light, the cosine between the light and a point's mirror direction (local frame)
/// below which its square lies wholly beyond [`TAIL_WIDTHS`] lobe widths of it, in the
/// lobe's tail; none for a Lambertian BRDF. There the square's integral may be taken by the
/// midpoint rule: the BRDF at its centre in the interreflections' gathering
/// ([`FrameSetup::midpoint_tails`]), the table's density there in what the eye sees where
/// the tail follows a power law ([`drawn_tail_cosines`]).
pub fn tail_cosines(brdf: &rsl_brdf::Brdf, lights: &[Light]) -> Vec<f32> {
    match brdf.lobe_width() {
        None => Vec::new(),
        Some(w) => {
            lights.iter().map(|l| (TAIL_WIDTHS * w + l.cone_half_angle()).min(std::f32::consts::PI).cos()).collect()
        }
    }
}

/// Whether the sums the eye sees take a tail's integral as the table's density at the
/// square's centre times its area ([`rsl_brdf::BrdfTable::tail_for`]: nine summed-area
/// entries a slice instead of a box's 64 spline taps): for a power-law tail (GGX, glTF;
/// GGX's density falls like θ⁻⁴), which varies slowly across a square beyond three lobe
/// widths. A Gaussian-like tail (Beckmann, Cook–Torrance, Ward, the cosine powers) falls by
/// orders of magnitude across it, its integral is its near edge's, which the centre
/// misses: with the rule, a Beckmann α = 0.05 ball's vertices whose every light was in the
/// tail went black in the white furnace (3.5 → 11.5 % per vertex). Those read every box.
pub fn density_tails(brdf: &rsl_brdf::Brdf) -> bool {
    matches!(brdf, rsl_brdf::Brdf::Ggx { .. } | rsl_brdf::Brdf::Gltf { .. })
}

/// [`tail_cosines`] as the eye's sums use them ([`density_tails`]; none where every box is
/// read): what the GPU takes, so that its images match the CPU's.
pub fn drawn_tail_cosines(brdf: &rsl_brdf::Brdf, lights: &[Light]) -> Vec<f32> {
    if density_tails(brdf) { tail_cosines(brdf, lights) } else { Vec::new() }
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
    let (blocks, stats) = setup.par_blocks(Some(which), BLOCK, FrameStats::plus, |nears, stats, i, vertices| {
        vertices.map(|v| setup.vertex(i, v, nears, stats).radiance).collect::<Vec<_>>()
    });
    (setup.per_object(blocks), stats)
}

/// [`shade_objects`], and per vertex the radiance of the lights that are not traced (the
/// rest of the sum: the traced lights' shadows are what varies fastest across a triangle).
pub fn shade_objects_untraced(setup: &FrameSetup<'_>, which: &[bool]) -> (Vec<Vec<Vec3>>, Vec<Vec<Vec3>>, FrameStats) {
    let (blocks, stats) = setup.par_blocks(Some(which), BLOCK, FrameStats::plus, |nears, stats, i, vertices| {
        vertices.map(|v| setup.vertex(i, v, nears, stats)).collect::<Vec<_>>()
    });
    let sums = setup.per_object(blocks);
    let part = |f: fn(&crate::sum::Sum) -> Vec3| sums.iter().map(|s| s.iter().map(f).collect()).collect();
    (part(|s| s.radiance), part(|s| s.untraced), stats)
}

/// Per-vertex sums of the objects `which` selects, each with its own part of the covers taken
/// with the vertex's face mask and without it, in one pass ([`FrameSetup::without_face_mask`]).
pub struct MaskedSums {
    /// [`shade_objects_untraced`]'s radiance.
    pub radiance: Vec<Vec<Vec3>>,
    /// [`shade_objects_untraced`]'s part from the lights that are not traced.
    pub untraced: Vec<Vec<Vec3>>,
    /// The radiance without the face mask.
    pub unmasked: Vec<Vec<Vec3>>,
    /// What the pass cost.
    pub stats: FrameStats,
}

/// [`shade_objects_untraced`] and the radiance without the face mask beside it, from one pass
/// over the vertices ([`MaskedSums`]).
pub fn shade_objects_masked_and_not(setup: &FrameSetup<'_>, which: &[bool]) -> MaskedSums {
    let (blocks, stats) = setup.par_blocks(Some(which), BLOCK, FrameStats::plus, |nears, stats, i, vertices| {
        vertices.map(|v| setup.vertex_both(i, v, nears, stats)).collect::<Vec<_>>()
    });
    let sums = setup.per_object(blocks);
    let part = |f: fn(&(crate::sum::Sum, Vec3)) -> Vec3| sums.iter().map(|s| s.iter().map(f).collect()).collect();
    MaskedSums { radiance: part(|s| s.0.radiance), untraced: part(|s| s.0.untraced), unmasked: part(|s| s.1), stats }
}

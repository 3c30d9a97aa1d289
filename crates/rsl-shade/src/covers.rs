//! A light's cover at a vertex from the visibility fields: the self-visibility field above
//! the vertex's horizon times its face mask's share, times every other object's occluder
//! field (located at the vertex on first use, culled by the light's cone), or the traced
//! rays for a traced light's shadows from other objects.
//!
//! **Cut squares at a Lambertian point.** A field gives the visible fraction of a whole
//! square from one signed distance at its centre, as if the shadow's edge were straight
//! across it, and the sum multiplies that fraction by the square's cosine-weighted integral
//! as if visibility and cosine were unrelated. Both fail where an occluder cuts a square of
//! the 30-light set (some 37° across): a ball's round shadow, a floor's corner, a wall that
//! hides the part of the square near the horizon, where the cosine is small. Where some
//! occluder leaves a light's square partly visible at a Lambertian point (whose BRDF is the
//! cosine alone), the occluders' part of the cover is instead the cosine-weighted mean over
//! [`CUT_SPLIT`]² sub-squares of the light's box in the point's hemisphere plane (the box
//! the Lambertian term integrates) of every occluder's coverage of each sub-square:
//! `Σ_k C(box_k)·Π_j c_j(k) / Σ_k C(box_k)`, with `C` the closed-form cosine integral
//! ([`rsl_brdf::cosine::box_cosine`]). Unoccluded, it is 1; fully hidden, 0; the other
//! objects' part only (the object's own stays the whole square's), and only for the
//! occluder fields (a traced light's rays already sample its square).

use crate::frame::{Near, culled, near};
use crate::shade::{FrameSetup, FrameStats};
use glam::{Vec2, Vec3};
use rsl_sphere::Frame;
use rsl_sphere::hemi::{dir_from_hemi, hemi_from_dir};
use rsl_vis::OvdfLookup;
use rsl_vis::mask::VertexMask;
use rsl_vis::svdf::SvdfVertex;

/// Sub-squares per side of a light's box over which a Lambertian point's cover is averaged
/// where an occluder cuts the square (module docs).
pub const CUT_SPLIT: usize = 3;

impl<'a> FrameSetup<'a> {
    /// `cover` times what the other objects leave of light `l` at vertex `v` of object `i`
    /// (world point `x`): traced rays for a traced light, else the occluder fields at `nears`
    /// (cut squares weighed in the `receiver` frame, [`FrameSetup::occluder_cover`]).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn others_cover(
        &self,
        nears: &mut [(Near, Lazy<'a>)],
        i: usize,
        v: usize,
        l: usize,
        cover: f32,
        receiver: Option<&Frame>,
        stats: &mut FrameStats,
    ) -> f32 {
        if self.is_traced(l) {
            if cover <= 0.0 {
                return cover;
            }
            cover * self.traced_cover_with(i, v, l, false, true, &mut stats.traced_rays)
        } else {
            self.occluder_cover(nears, l, cover, receiver, stats)
        }
    }

    /// Light `l`'s cover at vertex `v` of object `i` from the visibility fields (a light that
    /// is not traced): self-visibility at hemisphere point `q` of the vertex's visibility
    /// frame (with its face mask), times the occluder fields at `nears` (cut squares weighed
    /// in the `receiver` frame, [`FrameSetup::occluder_cover`]), as the terms ask — as `(the
    /// object's own part, the whole cover)`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn fields_cover(
        &self,
        nears: &mut [(Near, Lazy<'a>)],
        (i, v, l): (usize, usize, usize),
        q: Vec2,
        (self_vis, mask): (&SvdfVertex<'_>, &VertexMask<'_>),
        receiver: Option<&Frame>,
        stats: &mut FrameStats,
    ) -> (f32, f32) {
        let r = self.lights[l].half_diagonal;
        let mut own = 1.0;
        if self.terms.self_visibility {
            stats.self_lookups += 1;
            own = self_cover((self_vis, self.face_mask.then_some(mask)), q, r, self.reaches[l]);
        }
        let cover = if self.terms.occluders { self.others_cover(nears, i, v, l, own, receiver, stats) } else { own };
        (own, cover)
    }

    /// `cover` times the occluder fields' coverages of light `l` at a point whose occluders
    /// are `nears` (located on first use); nothing is looked up once it is zero. With a
    /// `receiver` frame (a Lambertian point's shading frame, [`FrameSetup::receiver`]), a
    /// square that some occluder cuts takes the occluders' cosine-weighted mean over its
    /// sub-squares instead of the product of their whole-square coverages (module docs).
    pub(crate) fn occluder_cover(
        &self,
        nears: &mut [(Near, Lazy<'a>)],
        l: usize,
        own: f32,
        receiver: Option<&Frame>,
        stats: &mut FrameStats,
    ) -> f32 {
        let light = &self.lights[l];
        let mut cover = own;
        // Bit k: occluder k (the last bit: any from 63 on) leaves part of the square.
        let mut cut = 0u64;
        for (k, (n, at)) in nears.iter_mut().enumerate() {
            if cover <= 0.0 {
                break;
            }
            if culled(n, light.dir, self.cones[l]) {
                stats.occluders_culled += 1;
                continue;
            }
            if let Some(at) = self.located(n, at) {
                stats.occluder_lookups += 1;
                let c = at.coverage(self.placed[n.j].light_dirs[l], light.half_diagonal);
                if c < 1.0 {
                    cut |= 1 << k.min(63);
                }
                cover *= c;
            }
        }
        match receiver {
            Some(frame) if cut != 0 && cover > 0.0 => {
                own * self.cut_share(nears, cut, l, frame, stats).unwrap_or(cover / own)
            }
            _ => cover,
        }
    }

    /// The cosine-weighted mean, over the [`CUT_SPLIT`]² sub-squares of light `l`'s box in
    /// the hemisphere plane of `frame`, of the product of the coverages of each by the
    /// occluders that cut the square (`cut`'s bits, as [`FrameSetup::occluder_cover`] sets
    /// them; the others leave all of it): what the occluders leave of a cut square at a
    /// Lambertian point (module docs). `None` where no part of the box is above the horizon.
    fn cut_share(
        &self,
        nears: &[(Near, Lazy<'a>)],
        cut: u64,
        l: usize,
        frame: &Frame,
        stats: &mut FrameStats,
    ) -> Option<f32> {
        let light = &self.lights[l];
        let p = hemi_from_dir(frame.to_local(light.dir));
        let (s, r) = (light.half_diagonal / std::f32::consts::SQRT_2, light.half_diagonal / CUT_SPLIT as f32);
        let h = s / CUT_SPLIT as f32;
        let (mut seen, mut total) = (0.0f64, 0.0f64);
        for a in 0..CUT_SPLIT {
            for b in 0..CUT_SPLIT {
                let c = p + Vec2::new((2 * a + 1) as f32 * h - s, (2 * b + 1) as f32 * h - s);
                let weight = rsl_brdf::cosine::box_cosine(c, h);
                if weight <= 0.0 {
                    continue;
                }
                let dir = frame.to_world(dir_from_hemi(c));
                let mut vis = 1.0;
                for (k, (n, at)) in nears.iter().enumerate() {
                    if vis <= 0.0 {
                        break;
                    }
                    if cut & (1 << k.min(63)) == 0 {
                        continue;
                    }
                    if let Lazy::Ready(at) = at
                        && !culled(n, light.dir, self.cones[l])
                        // The last bit stands for every occluder from it on: those that cut.
                        && (k < 63 || at.coverage(self.placed[n.j].light_dirs[l], light.half_diagonal) < 1.0)
                    {
                        stats.occluder_lookups += 1;
                        vis *= at.coverage(self.placed[n.j].pose.direction_to_object(dir), r);
                    }
                }
                seen += weight * f64::from(vis);
                total += weight;
            }
        }
        (total > 0.0).then(|| (seen / total) as f32)
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
        self.nears(i, p.position(v), &mut nears);
        for (&(dir, r), cover) in squares.iter().zip(out.iter_mut()) {
            *cover = 1.0;
            if self.terms.self_visibility {
                let q = hemi_from_dir(o.frames.visibility[v].to_local(p.pose.direction_to_object(dir)));
                stats.self_lookups += 1;
                let mask = o.mask.vertex(v);
                *cover =
                    self_cover((&o.svdf.vertex(v), self.face_mask.then_some(&mask)), q, r, rsl_vis::mask::reach(r));
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
    /// reaches `x`), not yet located in their fields, into `out`; none when the terms leave
    /// occluders out.
    pub(crate) fn nears(&self, i: usize, x: Vec3, out: &mut Vec<(Near, Lazy<'a>)>) {
        out.clear();
        if !self.terms.occluders {
            return;
        }
        out.extend(
            (0..self.placed.len())
                .filter(|&j| j != i)
                .filter_map(|j| Some((near(&self.placed[j], j, x)?, Lazy::Unknown))),
        );
    }
}

/// What an object leaves of a square of half-diagonal `r` centred at hemisphere point `q` of
/// a vertex's visibility frame: its self-visibility field's coverage above the horizon (the
/// BRDF's integral already leaves out the part below), times the share of it the vertex's
/// faces see (`reach`: [`rsl_vis::mask::reach`] of `r`) where a `mask` is given.
pub(crate) fn self_cover(
    (own, mask): (&SvdfVertex<'_>, Option<&VertexMask<'_>>),
    q: Vec2,
    r: f32,
    reach: (f32, f32),
) -> f32 {
    let cover = own.coverage_above_horizon(q, r);
    match mask {
        Some(mask) if cover > 0.0 => cover * mask.share_above_horizon_with(q, r, reach),
        _ => cover,
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

//! The RSL sum, written once: `Σ_l I_l · ∫_{square_l} ρ cos θ dω · cover_l` (Xu et al. 2006,
//! eq. 5), the one loop over lights behind every shader of this crate, with its factors
//! plugged in:
//!
//! - **the BRDF's integral** over each square: the object's table at the point's view
//!   ([`FrameSetup::vertex`], [`FrameSetup::point`]), or integrated exactly by the BRDF
//!   oracle ([`crate::oracle`]; the product oracle integrates the BRDF and the visibility
//!   together and covers nothing);
//! - **each light's cover**: the visibility fields at a vertex ([`FrameSetup::fields_cover`]),
//!   rays for the traced lights (`crate::traced`), covers interpolated to a pixel
//!   ([`crate::pixel`]), or the oracles' rays;
//! - **what is kept** besides the radiance: the part of the lights that are not traced, and
//!   every light's cover.
//!
//! [`FrameSetup::par_blocks`] is the one parallel driver over blocks of vertices.
//! [`crate::shade::shade_reference`] keeps the formula written out with nothing shared, as
//! the independent answer these are tested against.

use crate::frame::{Near, Placed};
use crate::pixel::UNDEFINED;
use crate::shade::{FrameSetup, FrameStats, Lazy};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use rsl_brdf::ViewLookup;
use rsl_sphere::Frame;
use rsl_sphere::hemi::hemi_from_dir;
use rsl_vis::mask::VertexMask;
use rsl_vis::svdf::SvdfVertex;
use std::ops::Range;

/// Which factor of a light's term is found first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Order {
    /// The BRDF's integral first; a light it gives nothing is not covered (shading a vertex:
    /// covers are the costly factor).
    BrdfFirst,
    /// Every light's cover first (kept, for a point near the vertex with another normal and
    /// view), then the integral where the cover is positive.
    CoverFirst,
}

/// A sum's radiance, and the part of it from the lights that are not traced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Sum {
    pub(crate) radiance: Vec3,
    pub(crate) untraced: Vec3,
}

/// A thread's list of the occluders near a vertex, reused from vertex to vertex.
pub(crate) type Nears<'a> = Vec<(Near, Lazy<'a>)>;

/// A vertex as the sum sees it: its object, world position, world shading frame and the
/// table's lookup for its view.
pub(crate) struct AtVertex<'s, 'a> {
    pub(crate) placed: &'s Placed<'a>,
    pub(crate) x: Vec3,
    pub(crate) frame: Frame,
    pub(crate) view: Vec3,
    pub(crate) lookup: ViewLookup,
}

/// A vertex's visibility data: its visibility frame, self-visibility field and face mask.
pub(crate) struct VertexFields<'s> {
    pub(crate) frame: &'s Frame,
    pub(crate) own: SvdfVertex<'s>,
    pub(crate) mask: VertexMask<'s>,
}

impl<'a> FrameSetup<'a> {
    /// The RSL sum over the frame's lights: `brdf(ctx, l)` and `cover(ctx, l)` give light
    /// `l`'s factors (`ctx` is what both change: costs, scratch), found in `order`; with
    /// `keep`, every light's cover is written there ([`Order::CoverFirst`] only).
    // Inlined into each shader, so that `order` and the closures fold away.
    #[inline(always)]
    pub(crate) fn rsl_sum<C>(
        &self,
        ctx: &mut C,
        order: Order,
        brdf: impl Fn(&mut C, usize) -> Vec3,
        cover: impl Fn(&mut C, usize) -> f32,
        mut keep: Option<&mut [f32]>,
    ) -> Sum {
        debug_assert!(keep.is_none() || order == Order::CoverFirst);
        let mut sum = Sum::default();
        for (l, light) in self.lights.iter().enumerate() {
            let (b, c) = match order {
                Order::BrdfFirst => {
                    let b = brdf(ctx, l);
                    if b == Vec3::ZERO {
                        continue;
                    }
                    (b, cover(ctx, l))
                }
                Order::CoverFirst => {
                    let c = cover(ctx, l);
                    if let Some(k) = keep.as_deref_mut() {
                        k[l] = c;
                    }
                    if c <= 0.0 {
                        continue;
                    }
                    (brdf(ctx, l), c)
                }
            };
            let term = light.radiance * b * c;
            sum.radiance += term;
            if !self.is_traced(l) {
                sum.untraced += term;
            }
        }
        sum
    }

    /// Vertex `v` of object `i`: where it is, its shading frame, and its view's lookup.
    pub(crate) fn at_vertex(&self, i: usize, v: usize) -> AtVertex<'_, 'a> {
        let placed = &self.placed[i];
        let x = placed.position(v);
        let frame = placed.shading_frame(v);
        let view = if self.along_normals { Vec3::Z } else { frame.to_local((self.eye - x).normalize_or_zero()) };
        AtVertex { placed, x, frame, view, lookup: placed.object.table.view_lookup(view) }
    }

    /// Light `l`'s BRDF integral at vertex `at` of object `i`, read toward its view in its
    /// shading frame (`tails`: the lights far from the lobe by the midpoint rule).
    #[inline]
    pub(crate) fn integral_at(&self, i: usize, at: &AtVertex<'_, 'a>, tails: bool, l: usize) -> Vec3 {
        self.light_integral(i, (&at.lookup, at.view, tails), at.frame.to_local(self.lights[l].dir), l)
    }

    /// Vertex `v` of object `i`'s visibility data.
    pub(crate) fn vertex_fields(&self, i: usize, v: usize) -> VertexFields<'_> {
        let o = &self.placed[i].object;
        VertexFields { frame: &o.frames.visibility[v], own: o.svdf.vertex(v), mask: o.mask.vertex(v) }
    }

    /// Light `l`'s point on the hemisphere map of a vertex's visibility frame.
    pub(crate) fn light_on_hemi(&self, i: usize, fields: &VertexFields<'_>, l: usize) -> Vec2 {
        hemi_from_dir(fields.frame.to_local(self.placed[i].light_dirs[l]))
    }

    /// Light `l`'s cover at vertex `v` of object `i`: traced rays for a traced light, else
    /// the fields (`fields`, and the occluders `nears`) as the terms ask.
    fn vertex_cover(
        &self,
        (nears, stats): &mut (&mut Nears<'a>, &mut FrameStats),
        (i, v, l): (usize, usize, usize),
        (fields, frame): (&VertexFields<'_>, &Frame),
    ) -> f32 {
        if self.is_traced(l) {
            self.traced_cover(i, v, l, &mut stats.traced_rays)
        } else {
            let q = self.light_on_hemi(i, fields, l);
            self.fields_cover(nears, (i, v, l), q, (&fields.own, &fields.mask), self.receiver(i, frame), stats).1
        }
    }

    /// The RSL sum at vertex `v` of object `i` toward the eye (the fast path's inner loop):
    /// nothing for a vertex that faces away, and no cover for a light its BRDF gives nothing.
    pub(crate) fn vertex(&self, i: usize, v: usize, nears: &mut Nears<'a>, stats: &mut FrameStats) -> Sum {
        stats.vertices += 1;
        let at = self.at_vertex(i, v);
        if at.lookup == ViewLookup::Below {
            stats.back_facing += 1;
            return Sum::default();
        }
        self.nears(i, at.x, nears);
        let fields = self.vertex_fields(i, v);
        let tails = self.tails_at(i, at.view, &at.frame);
        let brdf = |(_, stats): &mut (&mut Nears<'a>, &mut FrameStats), l: usize| {
            stats.brdf_lookups += 1;
            self.integral_at(i, &at, tails, l)
        };
        let cover = |ctx: &mut (&mut Nears<'a>, &mut FrameStats), l: usize| {
            self.vertex_cover(ctx, (i, v, l), (&fields, &at.frame))
        };
        self.rsl_sum(&mut (nears, stats), Order::BrdfFirst, brdf, cover, None)
    }

    /// [`FrameSetup::vertex`] with the object's own part of each cover taken with the
    /// vertex's face mask and without it ([`FrameSetup::without_face_mask`]), in one pass:
    /// the sum as [`FrameSetup::vertex`] gives it, and the radiance without the mask. Each
    /// light's BRDF integral, field lookups and rays serve both.
    pub(crate) fn vertex_both(&self, i: usize, v: usize, nears: &mut Nears<'a>, stats: &mut FrameStats) -> (Sum, Vec3) {
        stats.vertices += 1;
        let at = self.at_vertex(i, v);
        if at.lookup == ViewLookup::Below {
            stats.back_facing += 1;
            return (Sum::default(), Vec3::ZERO);
        }
        self.nears(i, at.x, nears);
        let fields = self.vertex_fields(i, v);
        let tails = self.tails_at(i, at.view, &at.frame);
        let receiver = self.receiver(i, &at.frame);
        // Each light's integral is kept in the context for its covers, which add the
        // unmasked term beside the masked one the sum takes.
        type Ctx<'c, 'a> = (&'c mut Nears<'a>, &'c mut FrameStats, Vec3, Vec3);
        let brdf = |ctx: &mut Ctx<'_, 'a>, l: usize| {
            ctx.1.brdf_lookups += 1;
            ctx.2 = self.integral_at(i, &at, tails, l);
            ctx.2
        };
        let cover = |(nears, stats, b, open): &mut Ctx<'_, 'a>, l: usize| {
            let [masked, unmasked] = if self.is_traced(l) {
                self.traced_cover_both(i, v, l, &mut stats.traced_rays)
            } else {
                let (q, r) = (self.light_on_hemi(i, &fields, l), self.lights[l].half_diagonal);
                let (mut own, mut share) = (1.0, 1.0);
                if self.terms.self_visibility {
                    stats.self_lookups += 1;
                    own = fields.own.coverage_above_horizon(q, r);
                    if own > 0.0 {
                        share = fields.mask.share_above_horizon_with(q, r, self.reaches[l]);
                    }
                }
                // What the others leave is the same factor under either own part.
                let others = if self.terms.occluders && own > 0.0 {
                    self.others_cover(nears, i, v, l, 1.0, receiver, stats)
                } else {
                    1.0
                };
                [own * share * others, own * others]
            };
            *open += self.lights[l].radiance * *b * unmasked;
            masked
        };
        let mut ctx = (nears, stats, Vec3::ZERO, Vec3::ZERO);
        let sum = self.rsl_sum(&mut ctx, Order::BrdfFirst, brdf, cover, None);
        (sum, ctx.3)
    }

    /// [`FrameSetup::vertex`], keeping every light's cover in `out` (one per light; what
    /// multiplies the light's BRDF integral there, [`UNDEFINED`] for a light wholly below
    /// the vertex's horizon) and, in `own`, the part of it that the object itself leaves
    /// (the self-visibility field and face mask; the rest is the occluder fields' product;
    /// 1 for a traced light, whose rays give its whole cover): every light above the horizon
    /// gets its cover, whatever the vertex's BRDF and view do with it, since points near the
    /// vertex (a pixel's) have other normals and views. Without `radiance` no BRDF integral
    /// is read: the covers alone, and a zero sum.
    pub(crate) fn vertex_covers(
        &self,
        i: usize,
        v: usize,
        nears: &mut Nears<'a>,
        stats: &mut FrameStats,
        (out, own): (&mut [f32], &mut [f32]),
        radiance: bool,
    ) -> Sum {
        stats.vertices += 1;
        let at = self.at_vertex(i, v);
        self.nears(i, at.x, nears);
        let fields = self.vertex_fields(i, v);
        let tails = radiance && self.tails_at(i, at.view, &at.frame);
        type Ctx<'c, 'a> = (&'c mut Nears<'a>, &'c mut FrameStats, &'c mut [f32]);
        let brdf = |(_, stats, _): &mut Ctx<'_, 'a>, l: usize| {
            if !radiance || at.lookup == ViewLookup::Below {
                return Vec3::ZERO;
            }
            stats.brdf_lookups += 1;
            self.integral_at(i, &at, tails, l)
        };
        let cover = |(nears, stats, own): &mut Ctx<'_, 'a>, l: usize| {
            own[l] = 1.0;
            // Wholly below the horizon: no part of the square in the hemisphere plane's disk.
            let q = self.light_on_hemi(i, &fields, l);
            let r = self.lights[l].half_diagonal;
            if rsl_vis::coverage::coverage(1.0 - q.length(), r) <= 0.0 {
                return UNDEFINED;
            }
            if self.is_traced(l) {
                return self.traced_cover(i, v, l, &mut stats.traced_rays);
            }
            let cover;
            let receiver = self.receiver(i, &at.frame);
            (own[l], cover) = self.fields_cover(nears, (i, v, l), q, (&fields.own, &fields.mask), receiver, stats);
            cover
        };
        self.rsl_sum(&mut (nears, stats, own), Order::CoverFirst, brdf, cover, Some(out))
    }

    /// Radiance toward the eye from world point `x` of object `i` with world shading frame
    /// `frame`, each light weighted by its cover `covers[l]` (the RSL sum at a point that
    /// is not a vertex: a pixel's).
    pub fn point(&self, i: usize, x: Vec3, frame: &Frame, covers: &[f32], stats: &mut FrameStats) -> Vec3 {
        self.point_toward(i, (self.eye - x).normalize_or_zero(), frame, covers, stats)
    }

    /// [`FrameSetup::point`] toward world direction `view` (unit) instead of the eye: what a
    /// point of object `i` sends toward another surface (in a frame set up with
    /// [`FrameSetup::midpoint_tails`], the lights far from the lobe by the midpoint rule).
    pub fn point_toward(&self, i: usize, view: Vec3, frame: &Frame, covers: &[f32], stats: &mut FrameStats) -> Vec3 {
        let local_view = frame.to_local(view);
        let lookup = self.placed[i].object.table.view_lookup(local_view);
        if lookup == ViewLookup::Below {
            return Vec3::ZERO;
        }
        let tails = self.tails_at(i, local_view, frame);
        let brdf = |stats: &mut &mut FrameStats, l: usize| {
            stats.brdf_lookups += 1;
            self.light_integral(i, (&lookup, local_view, tails), frame.to_local(self.lights[l].dir), l)
        };
        let cover = |_: &mut &mut FrameStats, l: usize| covers.get(l).copied().unwrap_or(0.0);
        self.rsl_sum(&mut &mut *stats, Order::CoverFirst, brdf, cover, None).radiance
    }

    /// The one parallel driver: `each(nears, stats, i, vertices)` for every block of `size`
    /// vertices of the objects `which` selects (one flag per object; all with `None`), on
    /// rayon's threads, with a list of nearby occluders reused per thread. The blocks'
    /// results come back in order, object by object and vertex by vertex, with their costs
    /// summed by `plus`.
    pub(crate) fn par_blocks<R: Send, S: Default + Send>(
        &self,
        which: Option<&[bool]>,
        size: usize,
        plus: impl Fn(S, S) -> S,
        each: impl Fn(&mut Nears<'a>, &mut S, usize, Range<usize>) -> R + Sync + Send,
    ) -> (Vec<(usize, R)>, S) {
        let mut blocks = self.blocks(size);
        if let Some(which) = which {
            blocks.retain(|&(i, _)| which.get(i).copied().unwrap_or(false));
        }
        let done: Vec<(usize, R, S)> = blocks
            .par_iter()
            .map_init(Vec::new, |nears, &(i, b)| {
                let n = self.placed[i].object.mesh.vertex_count();
                let mut stats = S::default();
                let r = each(nears, &mut stats, i, b * size..((b + 1) * size).min(n));
                (i, r, stats)
            })
            .collect();
        let mut stats = S::default();
        // rayon's collect keeps the blocks' order.
        let results = done
            .into_iter()
            .map(|(i, r, s)| {
                stats = plus(std::mem::take(&mut stats), s);
                (i, r)
            })
            .collect();
        (results, stats)
    }

    /// Blocks' per-vertex results gathered per object (empty for the objects no block came
    /// from).
    pub(crate) fn per_object<T>(&self, blocks: impl IntoIterator<Item = (usize, Vec<T>)>) -> Vec<Vec<T>> {
        let mut out: Vec<Vec<T>> = self.placed.iter().map(|_| Vec::new()).collect();
        for (i, values) in blocks {
            out[i].extend(values);
        }
        out
    }
}

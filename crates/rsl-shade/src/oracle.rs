//! Oracles: the RSL path with some of its approximations replaced by their exact values, so
//! that the error each one costs against the truth can be measured (an error budget).
//!
//! Per vertex and RSL `i` the path computes `I_i · B_i · C_self,i · Π_j C_j,i` (see
//! [`crate::shade`]). Each oracle swaps one factor for what it approximates:
//!
//! - **brdf**: `B_i` by direct quadrature over the same square ([`rsl_brdf::square_exact`])
//!   instead of the table (no table resolution, view interpolation or spline);
//! - **self**: `C_self,i` as the visible fraction of the square's part above the vertex's
//!   horizon in its visibility frame, by shadow rays against the object itself weighted by
//!   the vertex's face-averaged mask ([`Rays::mask`]), instead of the SVDF's (whose coverage,
//!   horizon included, is divided by the horizon's alone);
//! - **occluders**: each `C_j,i` as the fraction of the square, centred on the light, that
//!   object `j` leaves visible, by shadow rays against `j` alone, instead of the OVDF (and
//!   without its reach or culling);
//! - **product**: the whole term as `I_i·∫_square ρ cos θ · V dω`, one quadrature with a
//!   shadow ray per point against every object that shadows the vertex (weighted by the
//!   vertex's mask where self-visibility is on) — the product approximation itself (a product
//!   of averages) is gone, and with it the other three;
//! - **light** is applied where the lights are made, not here: one RSL per texel of the
//!   environment grid instead of the fitted set ([`Oracles::light`]).
//!
//! Visible fractions average over the square's rotation, as the coverage function does:
//! `K×K` jittered points, each in a square turned by its own stratified angle. With every
//! oracle on, what remains is the environment grid's resampling and the squares' shape
//! within a texel.

use crate::covers::self_cover;
use crate::shade::{FrameSetup, FrameStats};
use crate::sum::{Nears, Order};
use glam::{Vec2, Vec3};
use rsl_brdf::{ViewLookup, square_exact, square_exact_at};
pub use rsl_frame::{Blockers, Rays};
use rsl_sphere::Frame;
use rsl_sphere::hemi::dir_from_hemi;
use rsl_sphere::sampling::Pcg32;
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Which approximations are replaced by their exact values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Oracles {
    /// One RSL per environment texel (applied by whoever makes the lights).
    pub light: bool,
    /// BRDF square integrals by quadrature.
    pub brdf: bool,
    /// Self-visibility by rays.
    pub self_visibility: bool,
    /// Occluder visibility by rays.
    pub occluders: bool,
    /// The whole product by quadrature with rays.
    pub product: bool,
}

/// A list of oracle names that cannot be read.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("unknown oracle `{0}`; known: light, brdf, self, occluders, product, all, none")]
pub struct UnknownOracle(pub String);

impl Oracles {
    /// Every oracle: the truth up to the environment grid.
    pub const ALL: Oracles = Oracles { light: true, brdf: true, self_visibility: true, occluders: true, product: true };

    /// Each oracle alone, by name, in the order of an error budget.
    pub fn each() -> [(&'static str, Oracles); 5] {
        let none = Oracles::default();
        [
            ("light", Oracles { light: true, ..none }),
            ("brdf", Oracles { brdf: true, ..none }),
            ("self", Oracles { self_visibility: true, ..none }),
            ("occluders", Oracles { occluders: true, ..none }),
            ("product", Oracles { product: true, ..none }),
        ]
    }

    /// Whether any oracle is on.
    pub fn any(&self) -> bool {
        *self != Oracles::default()
    }

    /// Whether the shader itself has anything to replace (everything but the light).
    pub fn shading(&self) -> bool {
        self.brdf || self.self_visibility || self.occluders || self.product
    }

    /// Parses a comma-separated list (`brdf,occluders`, `all`, `none`).
    pub fn parse(list: &str) -> Result<Self, UnknownOracle> {
        let mut o = Oracles::default();
        for name in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            match name {
                "light" => o.light = true,
                "brdf" => o.brdf = true,
                "self" => o.self_visibility = true,
                "occluders" => o.occluders = true,
                "product" => o.product = true,
                "all" => o = Oracles::ALL,
                "none" => o = Oracles::default(),
                _ => return Err(UnknownOracle(name.to_string())),
            }
        }
        Ok(o)
    }

    /// The names of the oracles that are on, comma-separated (`none` for none).
    pub fn names(&self) -> String {
        let on = [
            (self.light, "light"),
            (self.brdf, "brdf"),
            (self.self_visibility, "self"),
            (self.occluders, "occluders"),
            (self.product, "product"),
        ];
        let names: Vec<_> = on.iter().filter(|(b, _)| *b).map(|(_, n)| *n).collect();
        if names.is_empty() { "none".into() } else { names.join(",") }
    }
}

/// How finely the oracles integrate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OracleParams {
    /// `K` of the `K×K` rays per visible fraction.
    pub samples: usize,
    /// Widest base sub-square of the product quadrature (plane units; each point is a ray).
    pub product_base: f32,
    /// Seed of the jitter.
    pub seed: u64,
}

impl Default for OracleParams {
    fn default() -> Self {
        Self { samples: 12, product_base: 2.0 / 32.0, seed: 0x5eed }
    }
}

/// What an oracle frame cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OracleStats {
    /// The lookups made where no oracle replaced them.
    pub lookups: FrameStats,
    /// Shadow rays traced.
    pub rays: u64,
}

impl OracleStats {
    /// The sum of two parts' costs.
    pub fn plus(self, o: Self) -> Self {
        Self { lookups: self.lookups.plus(o.lookups), rays: self.rays + o.rays }
    }
}

/// Vertices per parallel work item.
const BLOCK: usize = 64;

/// Shades every vertex with the oracles `oracles` (light aside: the setup's lights are used
/// as they are), tracing shadow rays with `rays`; `report(done, total)` follows the vertices.
pub fn shade_oracle(
    setup: &FrameSetup<'_>,
    oracles: Oracles,
    params: &OracleParams,
    rays: &dyn Rays,
    report: &(dyn Fn(usize, usize) + Sync),
) -> (Vec<Vec<Vec3>>, OracleStats) {
    // The objects that cast shadows (have occluder fields), found once.
    let casters: Vec<usize> = (0..setup.placed.len()).filter(|&j| setup.placed[j].object.ovdf.is_some()).collect();
    let total: usize = setup.placed.iter().map(|p| p.object.mesh.vertex_count()).sum();
    let done = AtomicUsize::new(0);
    let (blocks, stats) = setup.par_blocks(None, BLOCK, OracleStats::plus, |nears, stats, i, vertices| {
        let count = vertices.len();
        let out: Vec<Vec3> =
            vertices.map(|v| vertex(setup, oracles, params, rays, &casters, (i, v), nears, stats)).collect();
        report(done.fetch_add(count, Ordering::Relaxed) + count, total);
        out
    });
    (setup.per_object(blocks), stats)
}

/// Rotates `p` by `angle`.
fn rotate(p: Vec2, angle: f32) -> Vec2 {
    let (s, c) = angle.sin_cos();
    Vec2::new(c * p.x - s * p.y, s * p.x + c * p.y)
}

/// `K×K` offsets within a square of half-side 1, jittered per stratum, each turned by its own
/// angle in `[0, π/2)` (angles stratified too, in a random pairing).
fn rotated_points(k: usize, rng: &mut Pcg32) -> Vec<Vec2> {
    let n = k * k;
    let mut order: Vec<usize> = (0..n).collect();
    for a in (1..n).rev() {
        order.swap(a, rng.next_u32() as usize % (a + 1));
    }
    (0..n)
        .map(|m| {
            let (i, j) = (m % k, m / k);
            let u = Vec2::new(
                2.0 * (i as f32 + rng.next_f32()) / k as f32 - 1.0,
                2.0 * (j as f32 + rng.next_f32()) / k as f32 - 1.0,
            );
            let angle = std::f32::consts::FRAC_PI_2 * (order[m] as f32 + rng.next_f32()) / n as f32;
            rotate(u, angle)
        })
        .collect()
}

/// The RSL sum at vertex `v` of object `i` with the oracles' factors in place of the
/// approximations they replace.
#[allow(clippy::too_many_arguments)]
fn vertex<'a>(
    setup: &FrameSetup<'a>,
    oracles: Oracles,
    params: &OracleParams,
    rays: &dyn Rays,
    casters: &[usize],
    (i, v): (usize, usize),
    nears: &mut Nears<'a>,
    stats: &mut OracleStats,
) -> Vec3 {
    stats.lookups.vertices += 1;
    let at = setup.at_vertex(i, v);
    if at.lookup == ViewLookup::Below {
        stats.lookups.back_facing += 1;
        return Vec3::ZERO;
    }
    let (p, o, frame, view) = (at.placed, &at.placed.object, at.frame, at.view);
    let terms = setup.terms;
    let brdf = o.table.brdf();
    if oracles.occluders || oracles.product {
        nears.clear();
    } else {
        setup.nears(i, at.x, nears);
    }
    let traced = Cell::new(0u64);
    let trace = |dir: Vec3, by: Blockers| {
        traced.set(traced.get() + 1);
        rays.visible(i, v, dir, by)
    };
    let fields = setup.vertex_fields(i, v);
    // The BRDF's integral over light `l`'s square: the product oracle's whole term (the
    // BRDF times the rays' visibility, covered by nothing else), the BRDF oracle's
    // quadrature, or the table.
    let tails = setup.tails_at(i, view, &frame);
    let integral = |(_, stats): &mut (&mut Nears<'a>, &mut OracleStats), l: usize| {
        let light = &setup.lights[l];
        let (local, r) = (frame.to_local(light.dir), light.half_diagonal);
        if oracles.product {
            let by = Blockers::All { own: terms.self_visibility, others: terms.occluders };
            let w = |d: Vec3| {
                let d = frame.to_world(d);
                let h = if terms.self_visibility { rays.mask(i, v, d) } else { 1.0 };
                if h > 0.0 && trace(d, by) { h } else { 0.0 }
            };
            square_exact_at(brdf, local, r, view, params.product_base, &w)
        } else if oracles.brdf {
            square_exact(brdf, local, r, view, &|_| 1.0)
        } else {
            stats.lookups.brdf_lookups += 1;
            setup.light_integral(i, (&at.lookup, view, tails), local, l)
        }
    };
    let cover = |(nears, stats): &mut (&mut Nears<'a>, &mut OracleStats), l: usize| {
        if oracles.product {
            return 1.0;
        }
        let light = &setup.lights[l];
        let r = light.half_diagonal;
        let s = r / std::f32::consts::SQRT_2;
        let mut rng = Pcg32::with_stream(params.seed ^ ((i as u64) << 40 | v as u64), l as u64);
        let mut cover = 1.0;
        if terms.self_visibility {
            let c = setup.light_on_hemi(i, &fields, l);
            cover = if oracles.self_visibility {
                // The fraction of the square's points above the horizon that the object
                // leaves visible (the BRDF integral already leaves out the rest).
                let pts = rotated_points(params.samples, &mut rng);
                let above: Vec<Vec2> = pts.iter().map(|u| c + *u * s).filter(|q| q.length_squared() < 1.0).collect();
                let seen: f32 = above
                    .iter()
                    .map(|q| {
                        let d = (p.pose.linear_to_world * fields.frame.to_world(dir_from_hemi(*q))).normalize_or_zero();
                        let h = rays.mask(i, v, d);
                        if h > 0.0 && trace(d, Blockers::Own) { h } else { 0.0 }
                    })
                    .sum();
                if above.is_empty() { 0.0 } else { seen / above.len() as f32 }
            } else {
                stats.lookups.self_lookups += 1;
                self_cover((&fields.own, setup.face_mask.then_some(&fields.mask)), c, r, rsl_vis::mask::reach(r))
            };
        }
        if terms.occluders && cover > 0.0 {
            if oracles.occluders {
                let f = Frame::from_normal(light.dir);
                for &j in casters.iter().filter(|&&j| j != i) {
                    if cover <= 0.0 {
                        break;
                    }
                    let pts = rotated_points(params.samples, &mut rng);
                    let seen =
                        pts.iter().filter(|u| trace(f.to_world(dir_from_hemi(**u * s)), Blockers::Object(j))).count();
                    cover *= seen as f32 / pts.len() as f32;
                }
            } else {
                cover = setup.others_cover(nears, i, v, l, cover, setup.receiver(i, &frame), &mut stats.lookups);
            }
        }
        cover
    };
    let sum = setup.rsl_sum(&mut (nears, &mut *stats), Order::BrdfFirst, integral, cover, None);
    stats.rays += traced.get();
    sum.radiance
}

//! The RSL sum per pixel: sharp highlights across a triangle.
//!
//! Per-vertex radiance interpolated across a triangle cannot draw a highlight smaller than
//! the triangle, nor put one between vertices: on a glossy bunny of 2.8k vertices the
//! interpolated image is several times further from the truth than its vertices are. Here
//! the factors that vary slowly over a surface — each light's cover, what the object itself
//! and the others leave of it — are computed per vertex and interpolated, and the factor that
//! varies fast — the BRDF's integral over each square, for the point's own normal and view —
//! is evaluated per pixel:
//!
//! `L(pixel) = Σ_i E_i · avg_ρ(square_i; n_p, v_p) · Σ_k w_k · cover_i(vertex_k)`
//!
//! with `n_p` the interpolated shading frame (as the truth's pixels use), `v_p` the direction
//! from the pixel's surface point to the eye, and `w_k` the fragment's perspective-correct
//! barycentric weights. A light wholly below a corner's horizon has no cover there
//! ([`UNDEFINED`]); the others' weights are renormalised, so that a light grazing a
//! silhouette is not darkened by a corner that cannot see it at all.
//!
//! Covers vary slowly except where another object's shadow edge crosses a triangle: there
//! the corners' covers differ, and interpolating them draws the edge along the triangle's
//! sides (a staircase of whole triangles on a coarse floor). For a light whose covers
//! spread over such a triangle by enough to matter to the point ([`occluders_at_point`]:
//! more than [`COVER_SPREAD`], and moving more than [`REFINE_SHARE`] of its irradiance),
//! the other objects' occluder fields are read at the point itself, as at a vertex, and
//! multiply the object's own part interpolated from the corners.

use crate::antialias;
use crate::raster::{Fragment, Image, RasterMesh, fragments, image_ray, pixel_ray, sample_fragments};
use crate::shade::{BLOCK, FrameSetup, FrameStats};
use crate::sum::{Order, Sum};
use glam::Vec3;
use rayon::prelude::*;
use rsl_brdf::ViewLookup;
use rsl_scene::Camera;
use rsl_sphere::Frame;

/// The cover of a light wholly below a vertex's horizon (no value: the vertex cannot see
/// any of it).
pub const UNDEFINED: f32 = -1.0;

/// Every light's cover at every vertex of one object (vertex-major).
#[derive(Clone, Debug, PartialEq)]
pub struct Covers {
    /// Lights per vertex.
    pub lights: usize,
    /// `values[v * lights + l]`: light `l`'s cover at vertex `v`, in [0, 1] or [`UNDEFINED`].
    pub values: Vec<f32>,
    /// `own[v * lights + l]`: the part of `values[v * lights + l]` the object itself leaves
    /// (its self-visibility and face mask; the rest is the other objects' occluder fields),
    /// 1 for a traced light.
    pub own: Vec<f32>,
    /// Per vertex, the radiance of the lights that are not traced.
    pub untraced: Vec<Vec3>,
    /// Per triangle, where its lights whose covers spread over its corners
    /// ([`Covers::find_spreads`]) start in [`Covers::spread`] (and, one on, end). Empty where
    /// they were not found: each point then finds its triangle's.
    pub spread_start: Vec<u32>,
    /// The lights of [`Covers::spread_start`], each `(light, spread)`.
    pub spread: Vec<(u32, f32)>,
}

impl Covers {
    /// The covers at `fragment` of a mesh with triangles `indices`, into `out` (one per
    /// light): each light's weighted mean over the triangle's corners that define it (the
    /// weights renormalised over those), 0 where none does.
    pub fn at(&self, indices: &[u32], fragment: &Fragment, out: &mut [f32]) {
        let t = 3 * fragment.triangle as usize;
        self.at_corners([0, 1, 2].map(|k| indices[t + k]), fragment.weights, out);
    }

    /// The lights that are not traced (`traced(l)` false) whose other objects' part of the
    /// cover (the cover over the object's own part, [`Covers::own`]) spreads over the
    /// corners `corners` by more than [`COVER_SPREAD`], each with that spread, into `out`: a
    /// corner that cannot see the light, or that the object hides it from itself, says
    /// nothing of it.
    pub fn spread_over(&self, corners: [u32; 3], traced: impl Fn(usize) -> bool, out: &mut Vec<(u32, f32)>) {
        let base = corners.map(|c| c as usize * self.lights);
        for l in (0..self.lights).filter(|&l| !traced(l)) {
            let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
            for b in base {
                let (c, o) = (self.values[b + l], self.own[b + l]);
                if c != UNDEFINED && o > 0.0 {
                    lo = lo.min(c / o);
                    hi = hi.max(c / o);
                }
            }
            if hi - lo > COVER_SPREAD {
                out.push((l as u32, hi - lo));
            }
        }
    }

    /// Finds every triangle's spread lights ([`Covers::spread_over`]) once, for the points
    /// of the triangles to read ([`occluders_at_point`]) rather than each find them again.
    pub fn find_spreads(&mut self, indices: &[u32], traced: impl Fn(usize) -> bool + Sync) {
        self.spread_start.clear();
        self.spread.clear();
        if self.own.len() != self.values.len() {
            return;
        }
        let per: Vec<Vec<(u32, f32)>> = indices
            .par_chunks_exact(3)
            .map(|t| {
                let mut out = Vec::new();
                self.spread_over([t[0], t[1], t[2]], &traced, &mut out);
                out
            })
            .collect();
        self.spread_start.reserve(per.len() + 1);
        self.spread_start.push(0);
        for lights in per {
            self.spread.extend(lights);
            self.spread_start.push(self.spread.len() as u32);
        }
    }

    /// [`Covers::at`] the point of weights `weights` of the triangle of vertices `corners`.
    pub fn at_corners(&self, corners: [u32; 3], weights: Vec3, out: &mut [f32]) {
        let corners = corners.map(|c| c as usize * self.lights);
        let w = weights.to_array();
        for (l, o) in out.iter_mut().enumerate().take(self.lights) {
            let (mut sum, mut weight) = (0.0, 0.0);
            for k in 0..3 {
                let c = self.values[corners[k] + l];
                if c != UNDEFINED {
                    sum += w[k] * c;
                    weight += w[k];
                }
            }
            *o = if weight > 0.0 { (sum / weight).clamp(0.0, 1.0) } else { 0.0 };
        }
    }
}

/// Shades the objects `which` selects at their vertices, keeping every light's cover there:
/// per object, the vertices' radiance (as [`crate::shade`] gives it, to float rounding) and
/// the covers (`None` for the objects not selected, whose radiance comes back empty).
pub fn shade_covers(setup: &FrameSetup<'_>, which: &[bool]) -> (Vec<Vec<Vec3>>, Vec<Option<Covers>>, FrameStats) {
    shade_covers_for(setup, which, which)
}

/// [`shade_covers`], with the vertices' radiance (and [`Covers::untraced`]) summed only for
/// the objects `radiance` selects: the others' covers alone are found, and their radiance
/// comes back zero (no BRDF integral is read for them).
pub fn shade_covers_for(
    setup: &FrameSetup<'_>,
    which: &[bool],
    radiance: &[bool],
) -> (Vec<Vec<Vec3>>, Vec<Option<Covers>>, FrameStats) {
    let lights = setup.lights.len();
    let (blocks, stats) = setup.par_blocks(Some(which), BLOCK, FrameStats::plus, |nears, stats, i, vertices| {
        let wanted = radiance.get(i).copied().unwrap_or(false);
        let mut covers = vec![0.0; vertices.len() * lights];
        let mut own = vec![1.0; vertices.len() * lights];
        let sums: Vec<Sum> = vertices
            .zip(covers.chunks_exact_mut(lights.max(1)).zip(own.chunks_exact_mut(lights.max(1))))
            .map(|(v, out)| setup.vertex_covers(i, v, nears, stats, out, wanted))
            .collect();
        (sums, (covers, own))
    });
    let mut covers: Vec<Option<Covers>> = (0..setup.placed.len())
        .map(|i| {
            which.get(i).copied().unwrap_or(false).then(|| Covers {
                lights,
                values: Vec::new(),
                own: Vec::new(),
                untraced: Vec::new(),
                spread_start: Vec::new(),
                spread: Vec::new(),
            })
        })
        .collect();
    let mut radiance: Vec<Vec<Vec3>> = vec![Vec::new(); setup.placed.len()];
    for (i, (sums, (values, own))) in blocks {
        radiance[i].extend(sums.iter().map(|s| s.radiance));
        if let Some(c) = &mut covers[i] {
            c.values.extend(values);
            c.own.extend(own);
            c.untraced.extend(sums.iter().map(|s| s.untraced));
        }
    }
    if setup.terms.occluders && setup.placed.len() > 1 {
        for (i, c) in covers.iter_mut().enumerate() {
            if let Some(c) = c {
                c.find_spreads(&setup.placed[i].object.mesh.indices, |l| setup.is_traced(l));
            }
        }
    }
    (radiance, covers, stats)
}

impl FrameSetup<'_> {
    /// The vertices' sums of object `i` (radiance, and [`Covers::untraced`]) from `covers`
    /// already found at them by [`shade_covers`] in a frame set up for the same scene state
    /// and terms, read toward this frame's views (along the normals with
    /// [`FrameSetup::along_normals`]): a light's cover does not depend on the view, so this
    /// is what [`shade_covers_for`] sums for the object, to the bit, without finding a cover
    /// again — only the BRDF's integrals are read.
    pub fn sums_from_covers(&self, i: usize, covers: &Covers) -> (Vec<Vec3>, Vec<Vec3>) {
        let (lights, n) = (self.lights.len(), self.placed[i].object.mesh.vertex_count());
        debug_assert_eq!((covers.lights, covers.values.len()), (lights, n * lights), "another frame's covers");
        if lights == 0 || covers.lights != lights || covers.values.len() != n * lights {
            return (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        }
        covers
            .values
            .par_chunks_exact(lights)
            .enumerate()
            .map(|(v, row)| {
                let at = self.at_vertex(i, v);
                let tails = self.tails_at(i, at.view, &at.frame);
                let brdf = |_: &mut (), l: usize| {
                    if at.lookup == ViewLookup::Below {
                        return Vec3::ZERO;
                    }
                    self.integral_at(i, &at, tails, l)
                };
                let s = self.rsl_sum(&mut (), Order::CoverFirst, brdf, |_, l| row[l], None);
                (s.radiance, s.untraced)
            })
            .unzip()
    }
}

/// One object as [`draw_pixels`] sees it: world-space vertices, and either its world
/// shading frames (its pixels are shaded one by one) or none (its radiance is interpolated).
#[derive(Clone, Copy, Debug)]
pub struct PixelMesh<'a> {
    /// World positions per vertex.
    pub positions: &'a [Vec3],
    /// Triangle vertex indices.
    pub indices: &'a [u32],
    /// World shading frames per vertex, for an object shaded per pixel.
    pub frames: Option<&'a [Frame]>,
    /// Radiance per vertex, interpolated for an object without frames.
    pub radiance: &'a [Vec3],
}

/// The surface point a pixel's centre sees on an object shaded per pixel.
#[derive(Clone, Copy, Debug)]
pub struct PixelPoint<'f> {
    /// The object.
    pub object: usize,
    /// World position.
    pub position: Vec3,
    /// The interpolated shading frame (normal and tangent interpolated, then
    /// orthonormalised, as the truth's pixels do).
    pub frame: Frame,
    /// Where on which triangle.
    pub fragment: &'f Fragment,
}

/// The point fragment `f` shows of `mesh` (object `f.mesh`) to the eye at `eye`, its
/// shading frame interpolated from the corners' frames and, on a silhouette, turned toward
/// the eye ([`Frame::toward_view`]); `None` for a mesh without frames (its vertices are
/// interpolated).
pub fn pixel_point<'f>(mesh: &PixelMesh<'_>, f: &'f Fragment, eye: Vec3) -> Option<PixelPoint<'f>> {
    let fr = mesh.frames?;
    let t = 3 * f.triangle as usize;
    let corner = |k: usize| &fr[mesh.indices[t + k] as usize];
    let wts = f.weights;
    let n = corner(0).n * wts.x + corner(1).n * wts.y + corner(2).n * wts.z;
    let tan = corner(0).t * wts.x + corner(1).t * wts.y + corner(2).t * wts.z;
    let frame = Frame::from_normal_tangent(n, tan);
    let position = f.interpolate(mesh.indices, mesh.positions);
    // A silhouette's normal turned toward the eye where the face sees it (as the truth's).
    let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[mesh.indices[t + k] as usize]);
    let face = (b - a).cross(c - a).normalize_or_zero();
    let face = if face.dot(frame.n) < 0.0 { -face } else { face };
    Some(PixelPoint {
        object: f.mesh as usize,
        position,
        frame: frame.toward_view((eye - position).normalize_or_zero(), face),
        fragment: f,
    })
}

/// Draws `meshes` through `camera`: each pixel of an object with frames gets
/// `shade(point, scratch)` (`scratch` one per worker, from `init`), each pixel of the others
/// its vertices' radiance interpolated, and the rest `background(direction)`. With `aa` > 1
/// (a square number), the pixels that one sample at the centre does not resolve are the
/// mean of more samples over their square, in the rounds of [`crate::antialias::rounds`]: 4,
/// then more where those span a wide range, and with `aa` beyond 16 more again where a
/// glint's range remains ([`crate::antialias`]).
pub fn draw_pixels<S>(
    camera: &Camera,
    meshes: &[PixelMesh<'_>],
    aa: u32,
    init: impl Fn() -> S + Sync + Send,
    shade: impl Fn(&PixelPoint<'_>, &mut S) -> Vec3 + Sync + Send,
    background: impl Fn(Vec3) -> Vec3 + Sync,
) -> Image {
    let geometry: Vec<(&[Vec3], &[u32])> = meshes.iter().map(|m| (m.positions, m.indices)).collect();
    let frags = fragments(camera, &geometry);
    let w = camera.width as usize;
    // One sample: what `f` shows, or the background along `ray`.
    let sample = |f: Option<&Fragment>, ray: &dyn Fn() -> Vec3, scratch: &mut S| -> Vec3 {
        let Some(f) = f else {
            return background(ray());
        };
        let m = &meshes[f.mesh as usize];
        match pixel_point(m, f, camera.eye) {
            Some(point) => shade(&point, scratch),
            None => f.interpolate(m.indices, m.radiance),
        }
    };
    let mut pixels: Vec<Vec3> = frags
        .par_iter()
        .enumerate()
        .map_init(&init, |scratch, (k, f)| {
            sample(f.as_ref(), &|| pixel_ray(camera, (k % w) as u32, (k / w) as u32), scratch)
        })
        .collect();
    if aa > 1 {
        let depth: Vec<f32> = frags
            .par_iter()
            .map(|f| {
                f.map_or(f32::INFINITY, |f| {
                    let m = &meshes[f.mesh as usize];
                    f.interpolate(m.indices, m.positions).distance(camera.eye)
                })
            })
            .collect();
        let edges = antialias::edge_pixels(w, camera.height as usize, &frags, &depth, &pixels);
        // Each pixel of `which` sampled at `offsets`: the samples' sum, least and greatest
        // luminance.
        // A few million samples' fragments at a time, whatever the image's size.
        let sampled = |which: &[usize], offsets: &[[f32; 2]]| -> Vec<(Vec3, f32, f32)> {
            let per_chunk = (antialias::SAMPLES_AT_ONCE / offsets.len()).max(1);
            let mut out = Vec::with_capacity(which.len());
            for chunk in which.chunks(per_chunk) {
                let at = sample_fragments(camera, &geometry, chunk, offsets);
                out.par_extend(chunk.par_iter().zip(at.par_chunks(offsets.len())).map_init(
                    &init,
                    |scratch, (&k, samples)| {
                        let (x, y) = ((k % w) as f32, (k / w) as f32);
                        let start = (Vec3::ZERO, f32::INFINITY, 0.0f32);
                        samples.iter().zip(offsets).fold(start, |(sum, lo, hi), (f, o)| {
                            let c = sample(f.as_ref(), &|| image_ray(camera, x + o[0], y + o[1]), scratch);
                            let l = antialias::luminance(c).max(0.0);
                            (sum + c, lo.min(l), hi.max(l))
                        })
                    },
                ));
            }
            out
        };
        // The pixels of the round (each round's a subset of the one before's), with their
        // samples' sum, least and greatest luminance so far.
        let mut taking: Vec<(usize, Vec3, f32, f32)> =
            edges.iter().map(|&k| (k, Vec3::ZERO, f32::INFINITY, 0.0)).collect();
        let mut taken = 0;
        let mut mean = None;
        for (round, count) in antialias::rounds(aa).into_iter().enumerate() {
            if round > 0 {
                // The image's mean after the first round (as the GPU's).
                let mean = *mean.get_or_insert_with(|| antialias::mean_luminance(&pixels));
                let pick = if round == 1 { antialias::sample_again } else { antialias::sample_glint };
                taking.retain(|&(_, _, lo, hi)| pick(lo, hi, mean));
            }
            if taking.is_empty() {
                break;
            }
            let offsets = antialias::sample_offsets(count);
            let which: Vec<usize> = taking.iter().map(|t| t.0).collect();
            for (t, (sum, lo, hi)) in taking.iter_mut().zip(sampled(&which, &offsets)) {
                *t = (t.0, t.1 + sum, t.2.min(lo), t.3.max(hi));
            }
            taken += offsets.len();
            for &(k, sum, _, _) in &taking {
                pixels[k] = sum / taken as f32;
            }
        }
    }
    Image { width: camera.width, height: camera.height, covered: frags.iter().map(Option::is_some).collect(), pixels }
}

/// [`crate::rasterise`] antialiased with `aa` samples per pixel where one is not enough
/// (`aa` ≤ 1: the rasteriser itself).
pub fn rasterise_antialiased(
    camera: &Camera,
    meshes: &[RasterMesh<'_>],
    aa: u32,
    background: impl Fn(Vec3) -> Vec3 + Sync,
) -> Image {
    if aa <= 1 {
        return crate::rasterise(camera, meshes, background);
    }
    let meshes: Vec<PixelMesh<'_>> = meshes
        .iter()
        .map(|m| PixelMesh { positions: m.positions, indices: m.indices, frames: None, radiance: m.radiance })
        .collect();
    // Without frames every object's vertices are interpolated: `shade` is never called.
    draw_pixels(camera, &meshes, aa, || (), |_, _| Vec3::ZERO, background)
}

/// The image of the frame through `camera`: the pixels of objects with covers
/// ([`shade_covers`]) shaded per pixel, those of the others interpolated from `radiance`
/// (per object, per vertex), and `background(direction)` where no object is; with the BRDF
/// lookups the per-pixel sums made; antialiased with `aa` samples per pixel where one is not
/// enough.
pub fn shade_image(
    setup: &FrameSetup<'_>,
    camera: &Camera,
    covers: &[Option<Covers>],
    radiance: &[Vec<Vec3>],
    aa: u32,
    background: impl Fn(Vec3) -> Vec3 + Sync,
) -> (Image, FrameStats) {
    let positions: Vec<Vec<Vec3>> = (0..setup.placed.len()).map(|i| setup.positions(i)).collect();
    let frames: Vec<Option<Vec<Frame>>> = setup
        .placed
        .iter()
        .zip(covers)
        .map(|(p, c)| c.as_ref().map(|_| (0..p.object.mesh.vertex_count()).map(|v| p.shading_frame(v)).collect()))
        .collect();
    let meshes: Vec<PixelMesh<'_>> = (0..setup.placed.len())
        .map(|i| PixelMesh {
            positions: &positions[i],
            indices: &setup.placed[i].object.mesh.indices,
            frames: frames[i].as_deref(),
            radiance: &radiance[i],
        })
        .collect();
    let lookups = std::sync::atomic::AtomicU64::new(0);
    let rays = std::sync::atomic::AtomicU64::new(0);
    let lights = setup.lights.len();
    let image = draw_pixels(
        camera,
        &meshes,
        aa,
        || vec![0.0f32; lights],
        |p, buf| {
            let c = covers[p.object].as_ref().expect("objects with frames have covers");
            let mut stats = FrameStats::default();
            let l = point_radiance(setup, c, &meshes[p.object], p, buf, &mut stats);
            lookups.fetch_add(stats.brdf_lookups, std::sync::atomic::Ordering::Relaxed);
            rays.fetch_add(stats.traced_rays, std::sync::atomic::Ordering::Relaxed);
            l
        },
        background,
    );
    let stats =
        FrameStats { brdf_lookups: lookups.into_inner(), traced_rays: rays.into_inner(), ..FrameStats::default() };
    (image, stats)
}

/// Rays per traced light at a pixel (the first of the light's pattern, its centre first):
/// enough to place a sun's shadow edge within the pixel, a quarter of a vertex's rays at
/// the presets.
pub const PIXEL_RAYS: usize = 4;

/// The spread of a light's covers over a triangle's corners above which its cover at a
/// pixel of the triangle is found at the pixel itself ([`occluders_at_point`]) rather than
/// interpolated: where another object's shadow edge crosses the triangle, interpolating
/// its corners draws the edge as the triangle's outline (a staircase on a coarse floor).
pub const COVER_SPREAD: f32 = 0.02;

/// The share of a point's irradiance below which a light's spread of covers is left
/// interpolated ([`occluders_at_point`]). On the default scene (320×240, `aa = 16`, against
/// the truth at 1,024 samples per pixel) the floor's pixels came to 4.66 % interpolated,
/// 2.98 % at 0.01, 2.98 % at 0.03 and 3.23 % at 0.1; 0.03 found a third fewer covers per
/// pixel than 0.01.
pub const REFINE_SHARE: f32 = 0.03;

/// Whether an object is drawn per pixel by the RSL sum: a glossy one always (its highlights
/// are sharper than its triangles), a Lambertian one when some light is traced (its sharp
/// shadows are traced per pixel) or when other objects' fields can shadow it (their shadow
/// edges are found per pixel where they cross its triangles, [`COVER_SPREAD`]); a lone
/// Lambertian object's radiance varies no faster than its covers, and interpolating its
/// vertices gives the same image.
pub fn drawn_per_pixel(setup: &FrameSetup<'_>, glossy: bool) -> bool {
    glossy || setup.traces_any() || (setup.terms.occluders && setup.placed.len() > 1)
}

/// The RSL sum at `point` of an object with `covers` drawn as `mesh` (world positions): each
/// light's cover interpolated from the vertices, except a traced light's, which is traced
/// from the point itself ([`PIXEL_RAYS`] rays, masked with the face the point lies on), and
/// a light whose covers differ across the point's triangle, whose occluder fields are read
/// at the point ([`occluders_at_point`]).
pub fn point_radiance(
    setup: &FrameSetup<'_>,
    covers: &Covers,
    mesh: &PixelMesh<'_>,
    point: &PixelPoint<'_>,
    buf: &mut [f32],
    stats: &mut FrameStats,
) -> Vec3 {
    let refined = occluders_at_point(setup, covers, mesh, point, stats);
    if setup.view_independent(point.object) {
        // A Lambertian object's untraced lights vary no faster than their covers: their
        // radiance is interpolated from the vertices, and only the lights traced or found
        // at the point are summed here (the latter as the change from their interpolation).
        let mut radiance = point.fragment.interpolate(mesh.indices, &covers.untraced);
        if !refined.is_empty() {
            // Those lights' terms with the covers found at the point, less their terms with
            // the covers interpolated.
            let mut sum_with = |cover: fn(&(usize, f32, f32)) -> f32| {
                buf.fill(0.0);
                refined.iter().for_each(|r| buf[r.0] = cover(r));
                setup.point(point.object, point.position, &point.frame, buf, stats)
            };
            radiance += sum_with(|r| r.2);
            radiance -= sum_with(|r| r.1);
        }
        if setup.traces_any() {
            buf.fill(0.0);
            trace_at(setup, mesh, point, buf, stats);
            radiance += setup.point(point.object, point.position, &point.frame, buf, stats);
        }
        return radiance;
    }
    covers.at(mesh.indices, point.fragment, buf);
    refined.iter().for_each(|r| buf[r.0] = r.2);
    trace_at(setup, mesh, point, buf, stats);
    setup.point(point.object, point.position, &point.frame, buf, stats)
}

/// The lights that are not traced whose covers spread over more than [`COVER_SPREAD`]
/// across `point`'s triangle, each as `(light, interpolated cover, cover at the point)`:
/// at the point, the object's own part interpolated ([`Covers::own`]) times the other
/// objects' occluder fields read there, as at a vertex.
pub fn occluders_at_point(
    setup: &FrameSetup<'_>,
    covers: &Covers,
    mesh: &PixelMesh<'_>,
    point: &PixelPoint<'_>,
    stats: &mut FrameStats,
) -> Vec<(usize, f32, f32)> {
    let mut refined = Vec::new();
    // Alone, or without occluders, an object's covers are its own part alone.
    if !setup.terms.occluders || setup.placed.len() < 2 || covers.own.len() != covers.values.len() {
        return refined;
    }
    let t = point.fragment.triangle as usize;
    let w = point.fragment.weights.to_array();
    // Each corner's cover and own part.
    let base = [0, 1, 2].map(|k| mesh.indices[3 * t + k] as usize * covers.lights);
    let corners = |l: usize| {
        base.map(|b| {
            let c = covers.values[b + l];
            (c != UNDEFINED).then_some((c, covers.own[b + l]))
        })
    };
    // First the lights whose other objects' part spreads over the corners, found once per
    // triangle where the covers kept them: most points have none.
    let mut found = Vec::new();
    let spread: &[(u32, f32)] = match covers.spread_start.get(t..t + 2) {
        Some(&[a, b]) => &covers.spread[a as usize..b as usize],
        _ => {
            let corners = [0, 1, 2].map(|k| mesh.indices[3 * t + k]);
            covers.spread_over(corners, |l| setup.is_traced(l), &mut found);
            &found
        }
    };
    if spread.is_empty() {
        return refined;
    }
    // Each light's share of the point's irradiance, roughly (its radiance's luminance times
    // its solid angle and cosine), and their sum under the interpolated covers: a light
    // whose spread of covers cannot move the point's irradiance by [`REFINE_SHARE`] of
    // that sum is interpolated.
    let n = point.frame.n;
    let share = |l: usize| {
        let light = &setup.lights[l];
        let r = light.half_diagonal;
        crate::antialias::luminance(light.radiance).max(0.0) * 4.0 * r * r * (n.dot(light.dir) + r).max(0.0)
    };
    let mut total = 0.0;
    for l in 0..covers.lights {
        let (sum, weight) = (0..3)
            .filter_map(|k| corners(l)[k].map(|(c, _)| (w[k] * c, w[k])))
            .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
        if weight > 0.0 {
            total += share(l) * sum / weight;
        }
    }
    let least = total * REFINE_SHARE;
    let mut nears = None;
    for &(l, width) in spread {
        let l = l as usize;
        if width * share(l) <= least {
            continue;
        }
        // The corners' weighted means over those that define the light, as `Covers::at`.
        let (mut value, mut own, mut weight) = (0.0, 0.0, 0.0);
        for (k, c) in corners(l).iter().enumerate() {
            if let Some((c, o)) = c {
                value += w[k] * c;
                own += w[k] * o;
                weight += w[k];
            }
        }
        if weight <= 0.0 {
            continue;
        }
        let nears = nears.get_or_insert_with(|| {
            let mut n = Vec::new();
            setup.nears(point.object, point.position, &mut n);
            n
        });
        let receiver = setup.receiver(point.object, &point.frame);
        let here = setup.occluder_cover(nears, l, (own / weight).clamp(0.0, 1.0), receiver, stats);
        refined.push((l, (value / weight).clamp(0.0, 1.0), here));
    }
    refined
}

/// The traced lights alone at `point` of an object with `covers` drawn as `mesh`: their
/// radiance with their shadows traced from the point ([`PIXEL_RAYS`] rays each), and
/// without shadows. With the other lights' radiance interpolated from the vertices
/// (`covers.untraced`), the first is what [`point_radiance`] draws for a Lambertian object.
pub fn traced_at_point(
    setup: &FrameSetup<'_>,
    mesh: &PixelMesh<'_>,
    point: &PixelPoint<'_>,
    buf: &mut [f32],
    stats: &mut FrameStats,
) -> (Vec3, Vec3) {
    if !setup.traces_any() {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    buf.iter_mut().for_each(|c| *c = 0.0);
    trace_at(setup, mesh, point, buf, stats);
    let shadowed = setup.point(point.object, point.position, &point.frame, buf, stats);
    for (l, c) in buf.iter_mut().enumerate() {
        *c = if setup.is_traced(l) { 1.0 } else { 0.0 };
    }
    (shadowed, setup.point(point.object, point.position, &point.frame, buf, stats))
}

/// The traced lights' covers at `point`, into `buf`.
fn trace_at(
    setup: &FrameSetup<'_>,
    mesh: &PixelMesh<'_>,
    point: &PixelPoint<'_>,
    buf: &mut [f32],
    stats: &mut FrameStats,
) {
    if setup.traces_any() {
        let t = 3 * point.fragment.triangle as usize;
        let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[mesh.indices[t + k] as usize]);
        let n = point.frame.n;
        let face = (b - a).cross(c - a).normalize_or_zero();
        let face = if face.dot(n) < 0.0 { -face } else { face };
        for (l, cover) in buf.iter_mut().enumerate() {
            if setup.is_traced(l) {
                *cover = setup.traced_cover_at(
                    point.object,
                    (point.position, n, face),
                    l,
                    PIXEL_RAYS,
                    &mut stats.traced_rays,
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangles_spread_lights_are_found_once_as_each_point_finds_them() {
        // Three lights over two triangles (0-1-2, 1-3-2); light 2 is traced.
        // Light 0: the other objects' part (cover / own) is 1, 0.5, 1, 1 at the vertices.
        // Light 1: the cover changes with the object's own part alone (ratio 1 everywhere),
        // except at vertex 3, which cannot see it.
        // Light 2: spreads, but is traced (its rays find its shadows).
        let values = vec![
            1.0, 0.8, 1.0, //
            0.25, 0.4, 0.2, //
            0.9, 0.2, 1.0, //
            0.6, UNDEFINED, 0.7,
        ];
        let own = vec![
            1.0, 0.8, 1.0, //
            0.5, 0.4, 1.0, //
            0.9, 0.2, 1.0, //
            0.6, 1.0, 1.0,
        ];
        let mut covers =
            Covers { lights: 3, values, own, untraced: Vec::new(), spread_start: Vec::new(), spread: Vec::new() };
        let indices = [0, 1, 2, 1, 3, 2];
        let traced = |l: usize| l == 2;
        covers.find_spreads(&indices, traced);
        assert_eq!(covers.spread_start, [0, 1, 2]);
        // Triangle 0: light 0's ratio spans 0.5..1; triangle 1 likewise (vertex 1's 0.5).
        assert_eq!(covers.spread, [(0, 0.5), (0, 0.5)]);
        for (t, corners) in indices.chunks(3).enumerate() {
            let mut each = Vec::new();
            covers.spread_over([corners[0], corners[1], corners[2]], traced, &mut each);
            let (a, b) = (covers.spread_start[t] as usize, covers.spread_start[t + 1] as usize);
            assert_eq!(each, covers.spread[a..b]);
        }
        // Without the object's own part kept, nothing is found.
        covers.own.clear();
        covers.find_spreads(&indices, traced);
        assert!(covers.spread_start.is_empty() && covers.spread.is_empty());
    }

    #[test]
    fn covers_interpolate_over_the_corners_that_see_a_light() {
        // Two lights, a triangle 0-1-2; light 1 is below vertex 2's horizon.
        let covers = Covers {
            lights: 2,
            values: vec![1.0, 0.2, 0.5, 0.6, 0.0, UNDEFINED],
            own: Vec::new(),
            untraced: Vec::new(),
            spread_start: Vec::new(),
            spread: Vec::new(),
        };
        let f = Fragment { mesh: 0, triangle: 0, weights: Vec3::new(0.5, 0.25, 0.25) };
        let mut out = [0.0; 2];
        covers.at(&[0, 1, 2], &f, &mut out);
        assert!((out[0] - (0.5 + 0.125)).abs() < 1e-6, "{out:?}");
        // Renormalised over vertices 0 and 1: (0.5·0.2 + 0.25·0.6) / 0.75.
        assert!((out[1] - (0.1 + 0.15) / 0.75).abs() < 1e-6, "{out:?}");
        // No corner sees it: nothing.
        let covers = Covers {
            lights: 1,
            values: vec![UNDEFINED; 3],
            own: Vec::new(),
            untraced: Vec::new(),
            spread_start: Vec::new(),
            spread: Vec::new(),
        };
        let mut one = [0.5];
        covers.at(&[0, 1, 2], &f, &mut one);
        assert_eq!(one, [0.0]);
    }
}

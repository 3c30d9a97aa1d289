//! The per-object compositor. Each object of a frame is drawn by the drawing assigned to it
//! (an [`ObjectDrawing`]: the RSL path at the vertices, the RSL sum per pixel, the lobes);
//! [`compose`] sets the frame up once, asks each drawing for its objects' radiance at the
//! vertices and, where it draws per pixel, for a [`PixelShader`], and assembles the frame
//! and its image: rasterised from the vertices, drawn per pixel on the CPU with each pixel
//! shaded by its object's shader, or drawn on the GPU when every shader can be
//! ([`PixelShader::gpu_lobes`]). The per-object methods (`hybrid`, `lobe`, `auto`:
//! [`crate::lobe::Composite`]) are only rules that assign objects to drawings.

use crate::engine::Engine;
use crate::method::{Frame, Request, rasterise};
use crate::progress::Timings;
use anyhow::Result;
use glam::Vec3;
use rsl_brdf::Brdf;
use rsl_lobe::{MaterialLobes, Prefiltered};
use rsl_scene::{Scene, SceneState};
use rsl_shade::{Covers, FrameSetup, FrameStats, Image, PixelMesh, PixelPoint, Terms};
use rsl_sphere::Frame as LocalFrame;
use std::time::Instant;

/// What the drawings of a frame share: the scene at the frame's time, set up once.
pub struct FrameContext<'f> {
    /// The prepared scene.
    pub engine: &'f Engine,
    /// The scene.
    pub scene: &'f Scene,
    /// What the frame is asked for.
    pub request: &'f Request,
    /// The scene at the frame's time.
    pub state: &'f SceneState,
    /// The frame set up with every term.
    pub setup: &'f FrameSetup<'f>,
    /// Whether the image is drawn per pixel (else every object's vertices are interpolated).
    pub per_pixel: bool,
    /// Whether the image is drawn on the GPU, the RSL sum per pixel included: its objects'
    /// covers are shaded there, not on the CPU ([`Part::on_gpu`]).
    pub gpu: bool,
    /// Per object, its vertices' world positions.
    pub positions: &'f [Vec<Vec3>],
    /// Per object, its vertices' world normals.
    pub normals: &'f [Vec<Vec3>],
}

impl FrameContext<'_> {
    /// The eye.
    pub fn eye(&self) -> Vec3 {
        self.scene.camera.eye
    }

    /// Whether the frame's image will be drawn per pixel.
    pub fn image_per_pixel(&self) -> bool {
        self.request.image && self.per_pixel
    }
}

/// What a drawing made of one object: its radiance at the vertices and, when its pixels are
/// shaded one by one, how.
pub struct Part<'f> {
    /// Per vertex, the radiance toward the eye.
    pub radiance: Vec<Vec3>,
    /// The shader of its pixels (`None`: its vertices are interpolated).
    pub pixels: Option<Box<dyn PixelShader + 'f>>,
    /// Drawn by the GPU's RSL sum per pixel, its vertices shaded there too (radiance empty
    /// until the GPU's vertices are read back).
    pub on_gpu: bool,
}

impl<'f> Part<'f> {
    /// An object drawn from its vertices alone.
    pub fn vertices(radiance: Vec<Vec3>) -> Self {
        Self { radiance, pixels: None, on_gpu: false }
    }

    /// An object whose pixels `shader` shades.
    pub fn per_pixel(radiance: Vec<Vec3>, shader: Box<dyn PixelShader + 'f>) -> Self {
        Self { radiance, pixels: Some(shader), on_gpu: false }
    }

    /// An object the GPU shades and draws by the RSL sum per pixel.
    pub fn on_gpu() -> Self {
        Self { radiance: Vec::new(), pixels: None, on_gpu: true }
    }
}

/// How one object's pixels are shaded.
pub trait PixelShader: Sync {
    /// The world shading frame at each vertex; a pixel's is interpolated from its triangle's
    /// corners.
    fn frames(&self) -> Vec<LocalFrame>;

    /// The radiance at `point` of the object drawn as `mesh` (`buf`: one float per light, a
    /// worker's scratch).
    fn shade(&self, mesh: &PixelMesh<'_>, point: &PixelPoint<'_>, buf: &mut [f32]) -> Vec3;

    /// The object's lobes and the values its pixels interpolate (the visibility ratio),
    /// when the GPU's lobe pass can draw it.
    fn gpu_lobes(&self) -> Option<GpuLobe<'_>> {
        None
    }

    /// The covers found at the object's vertices, when its pixels read them (the RSL sum
    /// per pixel): kept in the frame for the interreflections ([`Frame::covers`]).
    fn into_covers(self: Box<Self>) -> Option<Covers> {
        None
    }
}

/// A boxed [`PixelShader`] living as long as the frame's data.
type Shader<'f> = Box<dyn PixelShader + 'f>;

/// An object the GPU's lobe pass draws with its lobes.
pub struct GpuLobe<'a> {
    /// The material's lobes.
    pub material: &'a MaterialLobes,
    /// Per vertex, what the pixels interpolate and multiply the lobes by.
    pub values: &'a [Vec3],
    /// The prefiltered environment the lobes look up, with its key and top κ.
    pub env: (&'a Prefiltered, (u64, u32)),
}

/// An object as the GPU draws it: with its lobes, by the RSL sum per pixel, or its
/// vertices' `values` interpolated.
pub struct GpuObject<'a> {
    /// Its lobes, if it is drawn with them.
    pub lobes: Option<GpuLobe<'a>>,
    /// Per vertex, what its pixels interpolate (with lobes, what multiplies them).
    pub values: &'a [Vec3],
    /// Shaded and drawn by the GPU's RSL sum per pixel ([`Part::on_gpu`]).
    pub rsl_pixels: bool,
}

/// A way to draw objects: the part of a frame of the objects assigned to it. A per-object
/// method of the registry has one ([`crate::Registration::drawing`]); scene files assign
/// objects to it by the method's name.
pub trait ObjectDrawing: Send {
    /// How it draws an object of `brdf`, in words (`rsl render --explain`).
    fn describe(&self, brdf: &Brdf) -> String;

    /// Readies what drawing the objects `which` selects (one flag per object) needs (lobes
    /// fitted, an environment prefiltered); timed apart from the shading.
    fn prepare(&mut self, _engine: &Engine, _which: &[bool], _timings: &mut Timings) -> Result<()> {
        Ok(())
    }

    /// Whether the GPU's draw pass can draw its objects (their parts interpolate vertices,
    /// give lobes, or are [`Part::on_gpu`] when the frame is drawn on the GPU).
    fn on_gpu(&self) -> bool {
        false
    }

    /// The parts of the objects `which` selects (`None` for the others), with their costs
    /// added to `stats`.
    fn shade<'f>(
        &mut self,
        ctx: &FrameContext<'f>,
        which: &[bool],
        stats: &mut FrameStats,
    ) -> Result<Vec<Option<Part<'f>>>>;
}

/// The image drawn on the GPU, for a method that has it (the per-object methods on a GPU:
/// [`crate::lobe::Composite::on_gpu`]).
pub trait GpuImage {
    /// Draws the frame's objects: the image, and the vertices' radiance of the objects
    /// shaded on the GPU ([`GpuObject::rsl_pixels`]; `None` for the others).
    fn draw(
        &mut self,
        ctx: &FrameContext<'_>,
        objects: &[GpuObject<'_>],
        positions: &[Vec<Vec3>],
        normals: &[Vec<Vec3>],
        timings: &mut Timings,
    ) -> Result<(Image, Vec<Option<Vec<Vec3>>>)>;
}

/// A frame with object `i` drawn by `drawings[assigned[i]]`; with `per_pixel` false, the
/// image interpolates every object's vertices; with `gpu`, the image is drawn there when
/// every drawing assigned an object can draw there ([`ObjectDrawing::on_gpu`]), the RSL sum
/// per pixel shaded there too.
pub fn compose(
    (engine, scene, request): (&Engine, &Scene, &Request),
    assigned: &[usize],
    drawings: &mut [&mut dyn ObjectDrawing],
    per_pixel: bool,
    gpu: Option<&mut dyn GpuImage>,
) -> Result<Frame> {
    let n = engine.object_count();
    anyhow::ensure!(assigned.len() == n, "{} drawing choices for {n} objects", assigned.len());
    let mut timings = Timings::default();
    let which = |d: usize| -> Vec<bool> { assigned.iter().map(|&a| a == d).collect() };
    for (d, drawing) in drawings.iter_mut().enumerate() {
        let which = which(d);
        if which.contains(&true) {
            drawing.prepare(engine, &which, &mut timings)?;
        }
    }

    let start = Instant::now();
    let state = scene.at(request.time);
    let setup = engine.setup(scene, &state, scene.camera.eye, Terms::default())?;
    let positions: Vec<Vec<Vec3>> = (0..n).map(|i| setup.positions(i)).collect();
    let normals: Vec<Vec<Vec3>> = (0..n).map(|i| setup.normals(i)).collect();
    let on_gpu = gpu.is_some()
        && request.image
        && per_pixel
        && drawings.iter().enumerate().all(|(d, drawing)| drawing.on_gpu() || !which(d).contains(&true));
    let ctx = FrameContext {
        engine,
        scene,
        request,
        state: &state,
        setup: &setup,
        per_pixel,
        gpu: on_gpu,
        positions: &positions,
        normals: &normals,
    };
    let mut stats = FrameStats::default();
    let mut parts: Vec<Option<Part<'_>>> = (0..n).map(|_| None).collect();
    for (d, drawing) in drawings.iter_mut().enumerate() {
        let which = which(d);
        if !which.contains(&true) {
            continue;
        }
        for (i, part) in drawing.shade(&ctx, &which, &mut stats)?.into_iter().enumerate() {
            if which[i] {
                parts[i] = part;
            }
        }
    }
    let rsl_pixels: Vec<bool> = parts.iter().map(|p| p.as_ref().is_some_and(|p| p.on_gpu)).collect();
    let (mut radiance, shaders): (Vec<Vec<Vec3>>, Vec<Option<Shader<'_>>>) = parts
        .into_iter()
        .enumerate()
        .map(|(i, p)| {
            p.map(|p| (p.radiance, p.pixels))
                .ok_or_else(|| anyhow::anyhow!("object {i} was assigned no drawing that drew it"))
        })
        .collect::<Result<Vec<_>>>()?
        .into_iter()
        .unzip();
    timings.add("shade", start.elapsed().as_secs_f64() * 1e3, None);

    let per_pixel = per_pixel && (shaders.iter().any(Option::is_some) || rsl_pixels.contains(&true));
    let objects: Option<Vec<GpuObject<'_>>> = shaders
        .iter()
        .zip(&radiance)
        .zip(&rsl_pixels)
        .map(|((s, r), &rsl_pixels)| match s {
            None => Some(GpuObject { lobes: None, values: r, rsl_pixels }),
            Some(s) => s.gpu_lobes().map(|l| GpuObject { values: l.values, lobes: Some(l), rsl_pixels: false }),
        })
        .collect();
    let mut gpu_radiance = Vec::new();
    let image = match (gpu, objects) {
        (Some(gpu), Some(objects)) if request.image && per_pixel => {
            let (image, radiance) = gpu.draw(&ctx, &objects, &positions, &normals, &mut timings)?;
            gpu_radiance = radiance;
            Some(image)
        }
        _ if rsl_pixels.contains(&true) => anyhow::bail!("objects shaded on the GPU, and the image not drawn there"),
        _ if !request.image => None,
        _ if !per_pixel => Some(timings.time("draw", || rasterise(engine, scene, &state, &positions, &radiance))),
        _ => Some(timings.time("draw per pixel", || draw_per_pixel(&ctx, &shaders, &radiance))),
    };
    let covers = shaders.into_iter().map(|s| s.and_then(PixelShader::into_covers)).collect();
    for (i, r) in gpu_radiance.into_iter().enumerate() {
        if let Some(r) = r {
            radiance[i] = r;
        }
    }
    Ok(Frame {
        state,
        positions,
        normals,
        radiance,
        std_error: None,
        image,
        pixel_std_error: None,
        encoded: None,
        self_error: None,
        stats,
        shadow_rays: 0,
        timings,
        covers,
    })
}

/// The image on the CPU: each pixel of an object with a shader shaded by it, the others'
/// vertices interpolated.
fn draw_per_pixel(ctx: &FrameContext<'_>, shaders: &[Option<Shader<'_>>], radiance: &[Vec<Vec3>]) -> Image {
    let frames: Vec<Option<Vec<LocalFrame>>> = shaders.iter().map(|s| s.as_ref().map(|s| s.frames())).collect();
    let meshes: Vec<PixelMesh<'_>> = ctx
        .scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| PixelMesh {
            positions: &ctx.positions[i],
            indices: &o.mesh.indices,
            frames: frames[i].as_deref(),
            radiance: &radiance[i],
        })
        .collect();
    let lights = ctx.setup.light_count();
    rsl_shade::draw_pixels(
        &ctx.scene.camera,
        &meshes,
        ctx.engine.antialias(),
        || vec![0.0f32; lights],
        |p, buf| match &shaders[p.object] {
            Some(s) => s.shade(&meshes[p.object], p, buf),
            None => Vec3::ZERO,
        },
        |d| ctx.engine.background(ctx.state, d),
    )
}

/// The RSL path at the vertices, interpolated (method `rsl`).
#[derive(Clone, Copy, Debug, Default)]
pub struct VertexDrawing;

impl ObjectDrawing for VertexDrawing {
    fn describe(&self, _: &Brdf) -> String {
        "RSL at the vertices, interpolated".into()
    }

    fn on_gpu(&self) -> bool {
        true
    }

    fn shade<'f>(
        &mut self,
        ctx: &FrameContext<'f>,
        which: &[bool],
        stats: &mut FrameStats,
    ) -> Result<Vec<Option<Part<'f>>>> {
        let (radiance, s) = rsl_shade::shade_objects(ctx.setup, which);
        *stats = stats.plus(s);
        Ok(radiance.into_iter().enumerate().map(|(i, r)| which[i].then(|| Part::vertices(r))).collect())
    }
}

/// The RSL sum per pixel (method `pixel`, [`rsl_shade::pixel`]): every light's cover kept at
/// the vertices and interpolated, the BRDF's integrals for each pixel's own normal and view;
/// a Lambertian object only where shadows make it worthwhile (traced lights, other objects:
/// [`rsl_shade::drawn_per_pixel`]), else from its vertices.
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelDrawing;

/// A pixel shader of [`PixelDrawing`].
struct CoverShader<'f> {
    setup: &'f FrameSetup<'f>,
    object: usize,
    covers: Covers,
}

impl PixelShader for CoverShader<'_> {
    fn frames(&self) -> Vec<LocalFrame> {
        // The RSL sum reads its tables in the vertices' shading frames.
        let n = self.covers.values.len() / self.covers.lights.max(1);
        (0..n).map(|v| self.setup.shading_frame(self.object, v)).collect()
    }

    fn shade(&self, mesh: &PixelMesh<'_>, point: &PixelPoint<'_>, buf: &mut [f32]) -> Vec3 {
        rsl_shade::point_radiance(self.setup, &self.covers, mesh, point, buf, &mut FrameStats::default())
    }

    fn into_covers(self: Box<Self>) -> Option<Covers> {
        Some(self.covers)
    }
}

impl ObjectDrawing for PixelDrawing {
    fn describe(&self, brdf: &Brdf) -> String {
        if brdf.is_lambertian() { "RSL at the vertices, interpolated" } else { "the RSL sum per pixel" }.into()
    }

    fn on_gpu(&self) -> bool {
        true
    }

    fn shade<'f>(
        &mut self,
        ctx: &FrameContext<'f>,
        which: &[bool],
        stats: &mut FrameStats,
    ) -> Result<Vec<Option<Part<'f>>>> {
        if ctx.gpu {
            // The GPU shades the objects drawn per pixel, covers and all; the others here.
            let n = which.len();
            let per_pixel: Vec<bool> = (0..n)
                .map(|i| which[i] && rsl_shade::drawn_per_pixel(ctx.setup, !ctx.engine.brdf(i).is_lambertian()))
                .collect();
            let plain: Vec<bool> = (0..n).map(|i| which[i] && !per_pixel[i]).collect();
            let (radiance, s) = rsl_shade::shade_objects(ctx.setup, &plain);
            *stats = stats.plus(s);
            return Ok(radiance
                .into_iter()
                .enumerate()
                .map(|(i, r)| which[i].then(|| if per_pixel[i] { Part::on_gpu() } else { Part::vertices(r) }))
                .collect());
        }
        let (radiance, covers, s) = shade_for_pixels(ctx.engine, ctx.setup, which)?;
        *stats = stats.plus(s);
        Ok(radiance
            .into_iter()
            .zip(covers)
            .enumerate()
            .map(|(i, (radiance, covers))| {
                which[i].then(|| match covers {
                    None => Part::vertices(radiance),
                    Some(covers) => {
                        Part::per_pixel(radiance, Box::new(CoverShader { setup: ctx.setup, object: i, covers }))
                    }
                })
            })
            .collect())
    }
}

/// Per object, the vertices' radiance and the covers kept; the frame's counts.
type ShadedForPixels = (Vec<Vec<Vec3>>, Vec<Option<Covers>>, FrameStats);

/// The objects `which` selects shaded for the RSL sum per pixel: those drawn per pixel
/// ([`rsl_shade::drawn_per_pixel`]) with every light's cover kept at their vertices
/// (`Some`), the others from their vertices alone (`None`); every selected object's
/// radiance at its vertices.
pub(crate) fn shade_for_pixels(engine: &Engine, setup: &FrameSetup<'_>, which: &[bool]) -> Result<ShadedForPixels> {
    let n = which.len();
    let per_pixel: Vec<bool> =
        (0..n).map(|i| which[i] && rsl_shade::drawn_per_pixel(setup, !engine.brdf(i).is_lambertian())).collect();
    let plain: Vec<bool> = (0..n).map(|i| which[i] && !per_pixel[i]).collect();
    crate::lobe::check_covers_size(engine, setup, &per_pixel)?;
    let (mut radiance, covers, stats) = rsl_shade::shade_covers(setup, &per_pixel);
    let (plain_radiance, plain_stats) = rsl_shade::shade_objects(setup, &plain);
    for (i, r) in plain_radiance.into_iter().enumerate() {
        if plain[i] {
            radiance[i] = r;
        }
    }
    Ok((radiance, covers, stats.plus(plain_stats)))
}

/// Per pixel of `scene`'s camera at time `t`, the object its centre sees (by index), as the
/// drawings per pixel rasterise it: the split of an image's pixels by object.
pub fn object_pixels(scene: &Scene, t: f32) -> Vec<Option<usize>> {
    let positions = world_positions(scene, &scene.at(t));
    let geometry: Vec<(&[Vec3], &[u32])> =
        scene.objects.iter().zip(&positions).map(|(o, p)| (p.as_slice(), o.mesh.indices.as_slice())).collect();
    rsl_shade::fragments(&scene.camera, &geometry).iter().map(|f| f.map(|f| f.mesh as usize)).collect()
}

/// Per object of `scene` at `state`, its vertices' world positions.
pub fn world_positions(scene: &Scene, state: &SceneState) -> Vec<Vec<Vec3>> {
    scene
        .objects
        .iter()
        .zip(&state.objects)
        .map(|(o, tr)| {
            let m = tr.matrix();
            o.mesh.positions.iter().map(|&p| m.transform_point3(p)).collect()
        })
        .collect()
}

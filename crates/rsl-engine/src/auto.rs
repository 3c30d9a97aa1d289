//! The per-object methods (`hybrid`, `lobe`, `auto`): rules that assign each object to a
//! drawing, the frame assembled by the compositor ([`crate::compose`]). `auto` draws each
//! object as its scene `method` asks, and for `method = "auto"` a glossy object with the
//! lobes or the RSL sum per pixel ([`Composite::auto_choice`]).

use crate::compose::{GpuImage, ObjectDrawing, PixelDrawing, VertexDrawing, compose};
use crate::engine::Engine;
use crate::lobe::{EnvironmentJob, GpuLobes, LobeDrawing, PreparedEnvironment};
use crate::method::{Frame, Method, Preparation, Prepared, Request};
use crate::registry::MethodId;
use anyhow::Result;
use rsl_brdf::Brdf;
use rsl_gpu::GpuContext;
use rsl_scene::{ObjectMethod, Scene};
use std::sync::Arc;

/// The per-object methods: each object drawn by the drawing a rule assigns it — the RSL path
/// at the vertices, the RSL sum per pixel, the hybrid's lobes or the lobe path's — and the
/// frame assembled by [`compose`]. The rules: `hybrid` and `lobe` draw every glossy object
/// with their lobes; `auto` ([`Composite::auto`]) draws each object as its scene `method`
/// asks, choosing for `method = "auto"` ([`Composite::auto_choice`]).
pub struct Composite {
    /// Draw per pixel: each pixel of a glossy object shaded for its own interpolated normal
    /// and view (else the vertices' radiance is interpolated).
    pub per_pixel: bool,
    rule: Rule,
    vertex: VertexDrawing,
    pixel: PixelDrawing,
    hybrid: LobeDrawing,
    lobe: LobeDrawing,
    /// The drawings of per-object methods a program registered, built when an object first
    /// asks for one.
    others: Vec<(MethodId, Box<dyn ObjectDrawing>)>,
    gpu: Option<GpuLobes>,
}

/// Which objects a [`Composite`] draws how.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Rule {
    /// Glossy objects with the hybrid's lobes.
    Hybrid,
    /// Glossy objects with the lobe path's transport lobes.
    Lobe,
    /// As each object's scene `method` asks.
    PerObject,
}

impl Composite {
    fn with_rule(rule: Rule) -> Self {
        Self {
            per_pixel: true,
            rule,
            vertex: VertexDrawing,
            pixel: PixelDrawing,
            hybrid: LobeDrawing::new(false),
            lobe: LobeDrawing::new(true),
            others: Vec::new(),
            gpu: None,
        }
    }

    /// The hybrid (`--method hybrid`, variant (b)) with nothing prepared yet (the
    /// environment and the lobes are made on the first frame and kept), drawing glossy
    /// objects per pixel.
    pub fn hybrid() -> Self {
        Self::with_rule(Rule::Hybrid)
    }

    /// The lobe path with its own shadows (`--method lobe`, variant (a)): transport lobes,
    /// each shadowed by the other objects' fields over a square of its width, drawn per pixel.
    pub fn lobe() -> Self {
        Self::with_rule(Rule::Lobe)
    }

    /// Each object drawn as its scene `method` asks (`--method auto`), on the CPU.
    pub fn auto() -> Self {
        Self::with_rule(Rule::PerObject)
    }

    /// A hybrid whose images are drawn per pixel on the GPU of `ctx` (the fragment shader
    /// `shaders/draw/lobes.wgsl`); the vertices' RSL shading, the visibility ratio, stays on
    /// the CPU. Objects drawn with the RSL sum per pixel are shaded and drawn on the GPU
    /// (`shaders/draw/pixels.wgsl`), in the same pass.
    pub fn on_gpu(ctx: Arc<GpuContext>) -> Result<Self> {
        Ok(Self { gpu: Some(GpuLobes::new(ctx)?), ..Self::hybrid() })
    }

    /// `auto` ([`Composite::auto`]) with its images drawn on the GPU of `ctx`, as
    /// [`Composite::on_gpu`] draws them.
    pub fn auto_on_gpu(ctx: Arc<GpuContext>) -> Result<Self> {
        Ok(Self { rule: Rule::PerObject, ..Self::on_gpu(ctx)? })
    }

    /// This method with the transport lobes fitted as if the object did not shadow itself
    /// (`V_self = 1`), to measure what its own shadows are worth.
    pub fn without_self_shadows(mut self) -> Self {
        for d in [&mut self.hybrid, &mut self.lobe] {
            d.set_no_self_shadows();
        }
        self
    }

    /// This method with the visibility ratio of images drawn on the CPU interpolated from the
    /// vertices, as the GPU draw pass has it (to compare the two). Less accurate: a traced
    /// light's shadow edge across a triangle, and a light a corner cannot see, are smeared
    /// (a Suzanne under a low sun: 11.0 % per covered pixel against 4.2 % with the ratio at
    /// each pixel).
    pub fn with_vertex_ratios(mut self) -> Self {
        self.hybrid.set_vertex_ratios();
        self.lobe.set_vertex_ratios();
        self
    }

    /// How many objects' transport lobes are held (those the last frame drew).
    pub fn transport_held(&self) -> usize {
        self.lobe.transport_held()
    }

    /// This hybrid drawing glossy objects with the lobe path's transport lobes
    /// ([`Composite::lobe`]) when `fields`.
    pub fn with_fields(self, fields: bool) -> Self {
        Self { rule: if fields { Rule::Lobe } else { Rule::Hybrid }, ..self }
    }

    /// The GPU's adapter, in words, when the images are drawn there.
    pub fn gpu_adapter(&self) -> Option<String> {
        self.gpu.as_ref().map(GpuLobes::adapter)
    }

    /// Whether each object is drawn as its scene asks (`auto`).
    pub(crate) fn is_per_object(&self) -> bool {
        self.rule == Rule::PerObject
    }

    /// The width (radians) of object `i`'s sharpest single-lobe fit.
    pub(crate) fn sharpest_lobe(&mut self, engine: &Engine, i: usize) -> Result<f32> {
        let kappa = self.hybrid.lobes(engine.brdf(i))?.single_kappa_max();
        Ok(1.0 / kappa.max(1e-6).sqrt())
    }

    /// The drawing whose preparation runs ahead of frames: the lobe path's for `lobe`, else
    /// the hybrid's.
    fn prepared_drawing(&mut self) -> &mut LobeDrawing {
        if self.rule == Rule::Lobe { &mut self.lobe } else { &mut self.hybrid }
    }

    /// [`LobeDrawing::environment_job`] of the lobes this method prepares ahead.
    pub fn environment_job(&mut self, engine: &Engine) -> Result<Option<EnvironmentJob>> {
        self.prepared_drawing().environment_job(engine)
    }

    /// Takes what an [`EnvironmentJob`] made.
    pub fn install(&mut self, p: PreparedEnvironment) {
        self.hybrid.install(p.clone());
        self.lobe.install(p);
    }

    /// Which per-object method draws each of `engine`'s objects.
    fn drawn(&mut self, engine: &Engine, scene: &Scene) -> Result<Vec<MethodId>> {
        let method = match self.rule {
            Rule::Hybrid => ObjectMethod::HYBRID,
            Rule::Lobe => ObjectMethod::LOBE,
            Rule::PerObject => {
                let mut drawn = Vec::with_capacity(scene.objects.len());
                for (i, o) in scene.objects.iter().enumerate() {
                    drawn.push(match o.method {
                        ObjectMethod::AUTO => self.auto_choice(engine, i)?,
                        m => drawn_by(m, engine.brdf(i))?,
                    });
                }
                return Ok(drawn);
            }
        };
        (0..engine.object_count()).map(|i| drawn_by(method, engine.brdf(i))).collect()
    }

    /// The drawing of per-object method `id` (built from the registry on first use).
    fn drawing(&mut self, id: MethodId) -> Result<&mut dyn ObjectDrawing> {
        Ok(match id {
            MethodId::RSL => &mut self.vertex,
            MethodId::PIXEL => &mut self.pixel,
            MethodId::HYBRID => &mut self.hybrid,
            MethodId::LOBE => &mut self.lobe,
            _ => {
                if !self.others.iter().any(|(o, _)| *o == id) {
                    let make = id
                        .registration()
                        .drawing
                        .ok_or_else(|| anyhow::anyhow!("method `{id}` cannot draw single objects"))?;
                    self.others.push((id, make()));
                }
                let (_, d) = self.others.iter_mut().find(|(o, _)| *o == id).expect("built just above");
                d.as_mut()
            }
        })
    }

    /// A frame with each object drawn by the per-object method `drawn` names (one per
    /// object); with `per_pixel` false, the image interpolates every object's vertices.
    pub fn render_drawn(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        request: &Request,
        drawn: &[MethodId],
        per_pixel: bool,
    ) -> Result<Frame> {
        for &id in drawn {
            self.drawing(id)?;
        }
        let built_in = [MethodId::RSL, MethodId::PIXEL, MethodId::HYBRID, MethodId::LOBE];
        let ids: Vec<MethodId> = built_in.into_iter().chain(self.others.iter().map(|o| o.0)).collect();
        let assigned: Vec<usize> =
            drawn.iter().map(|id| ids.iter().position(|d| d == id).expect("every drawing built above")).collect();
        let mut drawings: Vec<&mut dyn ObjectDrawing> =
            vec![&mut self.vertex, &mut self.pixel, &mut self.hybrid, &mut self.lobe];
        drawings.extend(self.others.iter_mut().map(|(_, d)| d.as_mut() as &mut dyn ObjectDrawing));
        let gpu = self.gpu.as_mut().map(|g| g as &mut dyn GpuImage);
        compose((engine, scene, request), &assigned, &mut drawings, per_pixel, gpu)
    }
}

/// Why an anisotropic object is drawn with the RSL sum per pixel by the lobe methods.
pub(crate) const ANISOTROPIC: &str =
    "anisotropic: the lobes fit isotropic BRDFs only, so the RSL sum per pixel draws it";

/// Why a Lambertian object is drawn from its vertices (`rsl render --explain`).
pub(crate) const LAMBERTIAN: &str = "Lambertian: its radiance varies no faster than its visibility and its BRDF \
     term is exact (per pixel only where a traced light's shadow falls or another object's shadow edge crosses \
     its triangles)";

/// The per-object method that draws an object of `brdf` whose scene asks for `method`:
/// `auto` draws a glossy object per pixel ([`Composite::auto_choice`] may take the lobes);
/// the built-in methods never give a Lambertian object lobes (the RSL path's Lambertian term
/// is exact where a cosine-fitted lobe is not) and draw it per pixel only where that changes
/// something, for the shadows of traced lights and of other objects
/// ([`rsl_shade::drawn_per_pixel`]); an
/// anisotropic object, which the lobes cannot fit, gets the RSL sum per pixel; a method a
/// program registered draws whatever it is given.
pub fn drawn_by(method: ObjectMethod, brdf: &Brdf) -> Result<MethodId> {
    if !method.is_built_in() {
        let id: MethodId = method.name().parse().map_err(anyhow::Error::msg)?;
        anyhow::ensure!(id.registration().drawing.is_some(), "method `{id}` cannot draw single objects");
        return Ok(id);
    }
    if brdf.is_lambertian() {
        return Ok(if method == ObjectMethod::RSL { MethodId::RSL } else { MethodId::PIXEL });
    }
    if brdf.is_anisotropic() && (method == ObjectMethod::HYBRID || method == ObjectMethod::LOBE) {
        return Ok(MethodId::PIXEL);
    }
    Ok(match method {
        ObjectMethod::RSL => MethodId::RSL,
        ObjectMethod::HYBRID => MethodId::HYBRID,
        ObjectMethod::LOBE => MethodId::LOBE,
        _ => MethodId::PIXEL,
    })
}

impl Method for Composite {
    fn describe(&self) -> String {
        let threads = rayon::current_num_threads();
        let what = match self.rule {
            Rule::Hybrid => "vMF lobes × RSL visibility",
            Rule::Lobe => "vMF lobes shadowed by the fields",
            Rule::PerObject => "each object's own method",
        };
        match self.gpu_adapter() {
            Some(a) => format!(
                "{what}: the lobes' vertices on the CPU ({threads} threads), the RSL sum's vertices and the pixels on {a}"
            ),
            None => format!("{what} on the CPU ({threads} threads)"),
        }
    }

    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        engine.check(scene)?;
        let drawn = self.drawn(engine, scene)?;
        let per_pixel = self.per_pixel;
        self.render_drawn(engine, scene, request, &drawn, per_pixel)
    }

    fn explain(&mut self, engine: &Engine, scene: &Scene) -> Result<Vec<String>> {
        engine.check(scene)?;
        let drawn = self.drawn(engine, scene)?;
        let mut lines = Vec::with_capacity(scene.objects.len());
        for (i, o) in scene.objects.iter().enumerate() {
            let brdf = engine.brdf(i);
            let why = self.why(engine, i, o.method)?;
            let how = self.drawing(drawn[i])?.describe(brdf);
            lines.push(format!("{}: {how} ({}) — {why}", o.name, drawn[i]));
        }
        Ok(lines)
    }

    fn preparation(&mut self, engine: &Engine) -> Result<Option<Preparation>> {
        Ok(self.environment_job(engine)?.map(|job| Preparation::new(move || Box::new(job.run()) as Prepared)))
    }

    fn install(&mut self, prepared: Prepared) {
        if let Ok(p) = prepared.downcast::<PreparedEnvironment>() {
            Composite::install(self, *p);
        }
    }
}

impl Composite {
    /// What `auto` draws object `i` with: a glossy object gets the lobes when its sharpest
    /// single-lobe fit is [`LOBE_RATIO`] times narrower than the squares that carry the light
    /// ([`typical_square`]), where the RSL sum per pixel would show the squares' outlines
    /// and gaps, and else the RSL sum per pixel.
    pub fn auto_choice(&mut self, engine: &Engine, i: usize) -> Result<MethodId> {
        let brdf = engine.brdf(i);
        if brdf.is_lambertian() || brdf.is_anisotropic() {
            return drawn_by(ObjectMethod::AUTO, brdf);
        }
        let width = self.sharpest_lobe(engine, i)?;
        Ok(if width * LOBE_RATIO < typical_square(engine.rsls()) { MethodId::HYBRID } else { MethodId::PIXEL })
    }

    /// Why object `i`, whose scene asks for `method`, is drawn as this method draws it
    /// (`rsl render --explain`).
    pub(crate) fn why(&mut self, engine: &Engine, i: usize, method: ObjectMethod) -> Result<String> {
        let brdf = engine.brdf(i);
        let per_object = self.is_per_object();
        Ok(if brdf.is_lambertian() {
            LAMBERTIAN.to_string()
        } else if brdf.is_anisotropic() && !(per_object && method == ObjectMethod::RSL) {
            ANISOTROPIC.to_string()
        } else if !per_object {
            "glossy: the method's lobes".to_string()
        } else if method == ObjectMethod::AUTO {
            let square = typical_square(engine.rsls());
            let width = self.sharpest_lobe(engine, i)?;
            let ratio = square / width;
            format!(
                "auto: the typical square ({square:.4} rad) is {ratio:.1}× its sharpest lobe ({width:.4} rad); \
                 auto takes the lobes from {LOBE_RATIO}×"
            )
        } else {
            format!("the scene asks for method {method}")
        })
    }
}

/// How much narrower than the typical square a lobe must be for `auto` to draw it with the
/// lobes rather than the RSL sum.
pub const LOBE_RATIO: f32 = 8.0;

/// The energy-weighted mean half-diagonal of `rsls` (in the equal-area plane; about the
/// half-width of a square in radians): how large the squares that carry most of the light
/// are. A sun or a studio's lamps make it small, a uniform sky large.
pub fn typical_square(rsls: &[rsl_env::Rsl]) -> f32 {
    let (mut sum, mut energy) = (0.0f64, 0.0f64);
    for r in rsls {
        let e = f64::from(rsl_sphere::sampling::luminance(r.intensity).max(0.0) * r.solid_angle());
        sum += e * f64::from(r.half_diagonal);
        energy += e;
    }
    if energy > 0.0 { (sum / energy) as f32 } else { 0.0 }
}

//! `auto`: each object drawn as its scene `method` asks, and for `method = "auto"` the rule
//! that picks the lobes or the RSL sum per pixel for a glossy object
//! ([`PerObject::auto_choice`]).

use crate::engine::Engine;
use crate::lobe::{ANISOTROPIC, Drawn, Hybrid, LAMBERTIAN};
use crate::method::{Frame, Method, Preparation, Prepared, Request};
use anyhow::Result;
use rsl_scene::{ObjectMethod, Scene};

/// Each object drawn as its scene `method` asks ([`Drawn::of`]; `auto`:
/// [`PerObject::auto_choice`]), on the CPU.
#[derive(Default)]
pub struct PerObject {
    hybrid: Hybrid,
}

impl PerObject {
    /// The hybrid it draws its lobe objects with (to give it a prefiltered environment).
    pub fn hybrid_mut(&mut self) -> &mut Hybrid {
        &mut self.hybrid
    }
}

impl PerObject {
    /// Nothing prepared yet (lobes and the prefiltered environment are made when an object
    /// first needs them, and kept).
    pub fn new() -> Self {
        Self::default()
    }
}

impl PerObject {
    /// What `auto` draws object `i` with: a glossy object gets the lobes when its sharpest
    /// single-lobe fit is [`LOBE_RATIO`] times narrower than the squares that carry the light
    /// ([`typical_square`]), where the RSL sum per pixel would show the squares' outlines
    /// and gaps, and else the RSL sum per pixel.
    pub fn auto_choice(&mut self, engine: &Engine, i: usize) -> Result<Drawn> {
        let brdf = engine.brdf(i);
        if brdf.is_lambertian() || brdf.is_anisotropic() {
            return Ok(Drawn::of(ObjectMethod::Auto, brdf));
        }
        let kappa = self.hybrid.lobes(brdf)?.single_kappa_max();
        let width = 1.0 / kappa.max(1e-6).sqrt();
        Ok(if width * LOBE_RATIO < typical_square(engine.rsls()) { Drawn::Lobes } else { Drawn::Pixel })
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

impl Method for PerObject {
    fn describe(&self) -> String {
        format!("each object's own method on the CPU ({} threads)", rayon::current_num_threads())
    }

    fn render(&mut self, engine: &Engine, scene: &Scene, request: &Request) -> Result<Frame> {
        engine.check(scene)?;
        let mut drawn = Vec::with_capacity(scene.objects.len());
        for (i, o) in scene.objects.iter().enumerate() {
            drawn.push(match o.method {
                ObjectMethod::Auto => self.auto_choice(engine, i)?,
                m => Drawn::of(m, engine.brdf(i)),
            });
        }
        self.hybrid.render_drawn(engine, scene, request, &drawn, true)
    }

    fn preparation(&mut self, engine: &Engine) -> Result<Option<Preparation>> {
        self.hybrid.preparation(engine)
    }

    fn explain(&mut self, engine: &Engine, scene: &Scene) -> Result<Vec<String>> {
        engine.check(scene)?;
        let square = typical_square(engine.rsls());
        let mut lines = Vec::with_capacity(scene.objects.len());
        for (i, o) in scene.objects.iter().enumerate() {
            let brdf = engine.brdf(i);
            let drawn = match o.method {
                ObjectMethod::Auto => self.auto_choice(engine, i)?,
                m => Drawn::of(m, brdf),
            };
            let how = drawn.describe(brdf);
            let why = if brdf.is_lambertian() {
                LAMBERTIAN.to_string()
            } else if brdf.is_anisotropic() && o.method != ObjectMethod::Rsl {
                ANISOTROPIC.to_string()
            } else if o.method == ObjectMethod::Auto {
                let width = 1.0 / self.hybrid.lobes(brdf)?.single_kappa_max().max(1e-6).sqrt();
                let ratio = square / width;
                format!(
                    "auto: the typical square ({square:.4} rad) is {ratio:.1}× its sharpest lobe ({width:.4} rad); \
                     auto takes the lobes from {LOBE_RATIO}×"
                )
            } else {
                format!("the scene asks for method {:?}", o.method)
            };
            lines.push(format!("{}: {how} — {why}", o.name));
        }
        Ok(lines)
    }

    fn install(&mut self, prepared: Prepared) {
        Method::install(&mut self.hybrid, prepared);
    }
}

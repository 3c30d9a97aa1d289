//! The progressive truth on its own thread, and the error readout against it.

use super::*;

impl Viewer {
    /// Turns the progressive truth (and the error readout against it) on or off.
    pub fn set_truth(&mut self, on: bool) {
        self.truth_on = on;
        if !on {
            self.truth = None;
            self.readout = None;
            self.show_truth = false;
        }
    }

    /// Shows the truth's image instead of the RSL image (while the truth runs).
    pub fn set_show_truth(&mut self, on: bool) {
        self.show_truth = on && self.truth_on;
        self.texture_stale = true;
        if let Some(t) = &mut self.truth {
            // The next poll redraws the truth's image from what it has.
            t.seen = 0;
        }
    }

    /// The bounces of light between surfaces (the scene's quality knob `bounces`, at most
    /// `rsl_truth::MAX_BOUNCES`): the drawings gather them at the vertices
    /// (`rsl_engine::bounce`), drawn again at once, and the truth starts over following as
    /// many. While there are bounces the vertices are shaded on the CPU (the GPU's shading
    /// pass draws the direct light alone).
    pub fn set_bounces(&mut self, bounces: u32) {
        let bounces = bounces.min(rsl_truth::MAX_BOUNCES);
        if bounces != self.scene.quality.settings.bounces {
            self.scene.quality.settings.bounces = bounces;
            self.force_pixels = !self.vertices_only();
            self.pixels_pending = None;
            self.mark_all();
            if self.truth_on {
                self.restart_truth();
            }
        }
    }

    /// The RSL image against the truth so far (`None` before the truth's first pass).
    pub fn error_readout(&self) -> Option<ErrorReadout> {
        self.readout
    }

    /// A copy of the truth so far (`None` when it is off).
    pub fn truth_image(&self) -> Option<TruthImage> {
        let t = self.truth.as_ref()?;
        Some(t.image.lock().map(|i| i.clone()).unwrap_or_else(|e| e.into_inner().clone()))
    }

    /// Starts the truth over for the scene as it is now.
    pub(crate) fn restart_truth(&mut self) {
        self.truth = None;
        self.readout = None;
        self.truth_rgba = None;
        let Some(engine) = &self.engine else { return };
        let state = self.scene.at(self.time);
        let env = rsl_engine::method::env_light(engine);
        let ts = match rsl_engine::Truth::scene(engine, &self.scene, &state, env) {
            Ok(ts) => ts,
            Err(e) => {
                self.error = Some(format!("truth: {e:#}"));
                return;
            }
        };
        let camera = self.scene.camera;
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let image = Arc::new(Mutex::new(TruthImage::default()));
        let (stop2, image2) = (stop.clone(), image.clone());
        let handle = std::thread::Builder::new()
            .name("rsl-view truth".into())
            .spawn(move || {
                let mut pass = 0u64;
                while !stop2.load(std::sync::atomic::Ordering::Relaxed) && pass < u64::from(MAX_TRUTH_PASSES) {
                    pass += 1;
                    match ts.pixels(&camera, TRUTH_PASS_SPP, pass) {
                        Ok((est, covered, _)) => {
                            if stop2.load(std::sync::atomic::Ordering::Relaxed) {
                                break;
                            }
                            image2.lock().unwrap_or_else(|e| e.into_inner()).add(&est, covered);
                        }
                        Err(e) => {
                            image2.lock().unwrap_or_else(|e| e.into_inner()).error = Some(e.to_string());
                            break;
                        }
                    }
                }
            })
            .expect("the operating system refused a thread");
        self.truth = Some(TruthRun { stop, image, handle: Some(handle), seen: 0 });
    }

    /// Takes in the truth's new passes: the readout, and the view when it shows the truth.
    pub(crate) fn poll_truth(&mut self, ctx: &egui::Context) {
        if !self.truth_on || self.engine.is_none() {
            return;
        }
        if self.truth.is_none() {
            self.restart_truth();
        }
        let Some(t) = &mut self.truth else { return };
        ctx.request_repaint_after(std::time::Duration::from_millis(200));
        let img = t.image.lock().map(|i| i.clone()).unwrap_or_else(|e| e.into_inner().clone());
        if let Some(e) = &img.error {
            self.error = Some(format!("truth: {e}"));
        }
        if img.passes == t.seen {
            return;
        }
        t.seen = img.passes;
        if self.on_gpu && self.linear.is_none() {
            // The view lives on the GPU: read it back once for the readout.
            let r = self.read_back();
            self.report(r);
        }
        if let Some(rsl) = &self.linear {
            let mask: Vec<bool> = rsl.covered.iter().zip(&img.covered).map(|(a, b)| *a && *b).collect();
            if let Ok(m) = rsl_truth::metrics::compare(&rsl.pixels, &img.mean, Some(&mask)) {
                self.readout = Some(ErrorReadout {
                    relative_l2: m.relative_l2,
                    truth_noise: img.noise(),
                    passes: img.passes,
                    spp: img.passes * TRUTH_PASS_SPP,
                });
            }
        }
        if self.show_truth {
            let exposure = self.exposure.unwrap_or(1.0);
            let pixels = img.mean.par_iter().map(|&c| colour(c, exposure)).collect();
            let c = &self.scene.camera;
            self.truth_rgba = Some(ColorImage::new([c.width as usize, c.height as usize], pixels));
            self.texture_stale = true;
        }
    }
}

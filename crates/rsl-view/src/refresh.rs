//! Drawing: the drawing chosen from the registry, drawn through the render session
//! ([`rsl_engine::Session`]): its vertices interpolated while edits come, its own frame once
//! the view rests, each with only what changed drawn again.

use super::*;

impl Viewer {
    /// Draws glossy objects per pixel (each pixel's own normal and view in the RSL sum, the
    /// visibility interpolated from the vertices, traced lights traced per pixel;
    /// `rsl_engine::CpuRslPixels` renders the same image) whenever the view rests
    /// ([`Viewer::settle_pixels`]), or interpolates every object's vertex radiance always.
    pub fn set_per_pixel(&mut self, on: bool) {
        self.set_drawing(if on { per_pixel_drawing() } else { MethodId::RSL });
    }

    /// How the view is drawn once it rests (a method of the registry); drawn that way at
    /// once.
    pub fn set_drawing(&mut self, drawing: MethodId) {
        if self.drawing != drawing {
            self.drawing = drawing;
            self.pixels_ms = None;
            self.force_pixels = !self.vertices_only();
            self.pixels_pending = None;
            self.mark_all();
        }
    }

    /// Sets the samples per pixel of the drawings per pixel where one is not enough (the
    /// `aa` quality knob; nothing is prepared again); drawn that way at once.
    pub fn set_antialias(&mut self, aa: u32) -> Result<()> {
        if aa == self.scene.quality.settings.aa {
            return Ok(());
        }
        if let Some(engine) = &mut self.engine {
            engine.set_antialias(aa)?;
        }
        self.scene.quality.settings.aa = aa;
        self.force_pixels = !self.vertices_only();
        self.pixels_pending = None;
        self.mark_all();
        Ok(())
    }

    /// How the view is drawn once it rests.
    pub fn drawing(&self) -> MethodId {
        self.drawing
    }

    /// Whether the drawing is the vertices interpolated, always (nothing to settle).
    pub(crate) fn vertices_only(&self) -> bool {
        self.drawing.capabilities().image == ImageKind::Vertices
    }

    /// What the view is drawn with while edits come: the drawing itself when it
    /// interpolates vertices, else the RSL path's vertices (drawn per pixel once the view
    /// rests).
    pub(crate) fn preview(&self) -> MethodId {
        if self.vertices_only() { self.drawing } else { MethodId::RSL }
    }

    /// Draws edits (a slider, a drag, the camera) per pixel too while the drawing's last
    /// frame per pixel took at most `ms` ([`LIVE_BUDGET_MS`] by default; infinite: always,
    /// 0: never).
    pub fn set_live_budget(&mut self, ms: f64) {
        self.live_budget_ms = ms.max(0.0);
    }

    /// Whether edits are drawn per pixel now: the drawing draws per pixel and its last
    /// frame kept within the budget ([`Viewer::set_live_budget`]).
    pub fn live_pixels(&self) -> bool {
        !self.vertices_only() && self.pixels_ms.is_some_and(|ms| ms <= self.live_budget_ms)
    }

    /// Drawing per pixel can cost hundreds of milliseconds a frame on 2 cores: where it
    /// does not keep up ([`Viewer::live_pixels`]), frames are interpolated while edits come
    /// (a slider, a drag, the camera), and the view is drawn per pixel again once it has
    /// rested for [`PREVIEW_REST`] (or at once with `now`); `true` when that was started.
    pub fn settle_pixels(&mut self, now: bool) -> bool {
        match self.pixels_pending {
            Some(t) if now || t.elapsed() >= PREVIEW_REST => {
                self.pixels_pending = None;
                self.force_pixels = true;
                self.mark_all();
                true
            }
            _ => false,
        }
    }

    /// Whether glossy objects are drawn with the RSL sum per pixel.
    pub fn per_pixel(&self) -> bool {
        self.drawing.capabilities().incremental == Incremental::PixelCovers
    }

    /// Whether the drawing is prepared ([`rsl_engine::Method::preparation`]): if not, the
    /// session starts its preparation on a worker thread (once) and `false` comes back.
    pub(crate) fn drawing_ready(&mut self) -> Result<bool> {
        let Some(engine) = &self.engine else { return Ok(true) };
        self.session.ready(engine, &self.scene, self.drawing)
    }

    /// Waits for the drawing's preparation on the worker thread, if any (tests and the
    /// headless screenshot); the next refresh draws with it.
    pub fn wait_drawing(&mut self) {
        if self.session.is_preparing() {
            if let Err(e) = self.session.wait_preparation() {
                self.error = Some(format!("{e:#}"));
            }
            self.mark_all();
        }
    }

    /// Whether the drawing's preparation (the lobes' prefiltered environment) runs on the
    /// worker thread.
    pub fn is_prefiltering(&self) -> bool {
        self.session.is_preparing()
    }

    /// [`Viewer::refresh`] once the view rests: the frame of the drawing's method, as `rsl
    /// render --method` draws it, with what changed since its last frame drawn again.
    pub(crate) fn refresh_drawing(&mut self, start: Instant) -> Result<bool> {
        let Some(engine) = self.engine.as_mut() else { return Ok(false) };
        let began = Instant::now();
        let request = rsl_engine::Request { time: self.time, image: true, vertices: true, exposure: None };
        // Base-colour textures mixed in (the interpolated preview draws the factors alone).
        let rendered = rsl_engine::textured::render(&mut self.session, engine, &self.scene, self.drawing, &request)?;
        // A method that draws whole frames draws every object again.
        let whole = self.drawing.capabilities().incremental == Incremental::Frames;
        let frame = rendered.frame;
        for (i, (p, r)) in frame.positions.into_iter().zip(frame.radiance).enumerate() {
            if whole || rendered.changes.objects.get(i).copied().unwrap_or(true) {
                self.counters.vertices_shaded += r.len() as u64;
                self.counters.objects_shaded += 1;
            }
            self.positions[i] = p;
            self.radiance[i] = r;
        }
        self.counters.shaded_frames += 1;
        self.counters.rasterised += 1;
        self.redraw = false;
        let stages = &frame.timings.stages;
        let raster_ms: f64 = stages.iter().filter(|s| s.is_image()).map(|s| s.wall_ms).sum();
        let shade_ms: f64 = stages.iter().filter(|s| !s.is_image()).map(|s| s.wall_ms).sum();
        let image = frame.image.ok_or_else(|| anyhow::anyhow!("the method drew no image"))?;
        self.show_whole(image, start, shade_ms, raster_ms);
        self.counters.pixel_frames += 1;
        self.pixels_ms = Some(began.elapsed().as_secs_f64() * 1e3);
        self.pixels_pending = None;
        Ok(true)
    }

    /// Shows a whole image drawn per pixel: tonemapped and uploaded.
    pub(crate) fn show_whole(&mut self, image: rsl_shade::Image, start: Instant, shade_ms: f64, raster_ms: f64) {
        let t2 = Instant::now();
        let exposure = *self.exposure.get_or_insert_with(|| exposure_for(&image));
        let pixels: Vec<Color32> = image.pixels.par_iter().map(|&c| colour(c, exposure)).collect();
        // The next interpolated frame starts afresh (its background may be stale).
        self.background = None;
        self.show(image, pixels, [start, t2], shade_ms, raster_ms);
    }

    /// Shades what changed and rasterises a new image; `false` when nothing changed (no
    /// shading, no rasterising).
    pub fn refresh(&mut self) -> Result<bool> {
        let Some(engine) = &self.engine else { return Ok(false) };
        let preview = self.preview();
        // What changed since the frame shown: drawn by the drawing itself while it keeps up,
        // else by the preview.
        let live = self.live_pixels();
        let shown = if live { self.drawing } else { preview };
        let mut found = self.session.changes(engine, &self.scene, shown, self.time)?;
        let mut changes = found.clone();
        if !changes.any() && !self.redraw {
            return Ok(false);
        }
        let start = self.edit_started.take().unwrap_or_else(Instant::now);
        if !self.vertices_only() {
            // Per pixel when asked, or while the drawing keeps up with the edits.
            if (self.force_pixels || live) && !self.drawing_ready()? {
                // Drawn from the vertices until the worker has prepared the drawing
                // (`force_pixels` stays: the frame after it draws per pixel).
            } else if std::mem::take(&mut self.force_pixels) || live {
                return self.refresh_drawing(start);
            }
        }
        let Some(engine) = &self.engine else { return Ok(false) };
        if shown != preview {
            // Drawn from the vertices after all (the drawing is being prepared): what changed
            // since the preview's last frame.
            found = self.session.changes(engine, &self.scene, preview, self.time)?;
            changes = found.clone();
        }
        // Drawn again whole (a new drawing or device), whatever changed in the scene; with
        // bounces, whatever changes one object's light changes what the others gather.
        if std::mem::take(&mut self.redraw) || self.scene.quality.settings.bounces > 0 {
            changes.moved = true;
        }
        // Only radiance changed (material edits): the image is redrawn where those objects
        // are, over the last one.
        let still = !changes.moved;
        let partial = still && self.linear.is_some();
        let t0 = Instant::now();
        // The GPU's shading pass draws the direct light alone: with bounces the vertices are
        // shaded through the session, which gathers them.
        let bounces = self.scene.quality.settings.bounces;
        let gpu_frame = match self.wgpu.as_mut().filter(|w| w.shades && bounces == 0) {
            Some(w) => match w.shade(engine, &self.scene, self.time) {
                Ok(frame) => Some(frame),
                Err(e) => {
                    self.error =
                        Some(format!("shading with wgpu: {e:#}; the view is shaded and drawn on the CPU from now on"));
                    self.wgpu = None;
                    self.on_gpu = false;
                    None
                }
            },
            None => None,
        };
        let shaded_on_gpu = gpu_frame.is_some();
        let (state, positions, radiance) = match gpu_frame {
            // rsl-gpu's shading pass (a hardware adapter) shades every vertex.
            Some(frame) => {
                self.session.drawn_elsewhere(engine, &self.scene, preview, self.time)?;
                changes = rsl_engine::Changes::all(self.scene.objects.len());
                (frame.state, frame.positions, frame.radiance)
            }
            None => {
                let request = rsl_engine::Request { time: self.time, image: false, vertices: true, exposure: None };
                let frame = self.session.render_changes(engine, &self.scene, preview, &request, found)?.frame;
                (frame.state, frame.positions, frame.radiance)
            }
        };
        let changed = changes.objects.clone();
        let shade_ms = t0.elapsed().as_secs_f64() * 1e3;
        for (i, (p, r)) in positions.into_iter().zip(radiance).enumerate() {
            if changed[i] {
                self.counters.vertices_shaded += r.len() as u64;
                self.counters.objects_shaded += 1;
            }
            self.positions[i] = p;
            self.radiance[i] = r;
        }
        self.counters.shaded_frames += 1;
        let meshes: Vec<rsl_shade::RasterMesh<'_>> = self
            .scene
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| rsl_shade::RasterMesh {
                positions: &self.positions[i],
                indices: &o.mesh.indices,
                radiance: &self.radiance[i],
            })
            .collect();
        if let Some(w) = self.wgpu.as_mut() {
            let drawn = if shaded_on_gpu {
                w.draw_shaded(engine, &self.scene, self.time, &mut self.exposure)
            } else {
                // Only radiance changed since the image shown, drawn with wgpu too: the changed
                // objects are drawn again over it.
                let redraw = (still && self.on_gpu).then_some(&changed[..]);
                w.draw(engine, &state, &self.scene.camera, &meshes, redraw, &mut self.exposure)
            };
            match drawn {
                Ok(drawn) => {
                    self.counters.rasterised += 1;
                    self.linear = drawn.linear;
                    self.rgba = None;
                    self.clay = false;
                    self.on_gpu = true;
                    self.record(start, shade_ms, drawn.draw_ms, drawn.tonemap_ms, true);
                    if !self.vertices_only() {
                        self.pixels_pending = Some(Instant::now());
                    }
                    return Ok(true);
                }
                Err(e) => {
                    // The window's device failed (lost, or out of memory): the CPU draws
                    // from now on, starting with this frame.
                    self.error = Some(format!("drawing with wgpu: {e:#}; the view is drawn on the CPU from now on"));
                    self.wgpu = None;
                    self.on_gpu = false;
                    self.linear = None;
                }
            }
        }
        let partial = partial && self.linear.is_some();
        let t1 = Instant::now();
        // The environment behind the objects is looked up (and tonemapped) again only when
        // the camera or the environment's orientation changed.
        let key = (self.scene.camera, state.world_from_env, engine.environment_key());
        let fresh = self.background.as_ref().is_none_or(|b| b.key != key);
        if fresh {
            let pixels = rsl_shade::background_image(&self.scene.camera, |d| engine.background(&state, d));
            self.background = Some(Background { key, pixels, encoded: Vec::new(), exposure: f32::NAN });
        }
        let bg = self.background.as_mut().expect("set above");
        let previous = if partial && !fresh { self.linear.take() } else { None };
        let image = match previous.clone() {
            Some(mut image) => {
                rsl_shade::rasterise_changed(&self.scene.camera, &meshes, &changed, &bg.pixels, &mut image);
                image
            }
            None => rsl_shade::rasterise_over(&self.scene.camera, &meshes, &bg.pixels),
        };
        self.counters.rasterised += 1;
        let raster_ms = t1.elapsed().as_secs_f64() * 1e3;
        let t2 = Instant::now();
        let exposure = *self.exposure.get_or_insert_with(|| exposure_for(&image));
        if bg.exposure != exposure {
            bg.encoded = bg.pixels.iter().map(|&c| colour(c, exposure)).collect();
            bg.exposure = exposure;
        }
        let pixels: Vec<Color32> = match (&previous, &self.rgba) {
            // Pixels whose radiance did not change keep their colour.
            (Some(prev), Some(rgba)) if rgba.pixels.len() == image.pixels.len() => image
                .pixels
                .par_iter()
                .zip(&prev.pixels)
                .zip(&rgba.pixels)
                .map(|((&c, &p), &old)| if c == p { old } else { colour(c, exposure) })
                .collect(),
            _ => image
                .pixels
                .par_iter()
                .zip(&image.covered)
                .zip(&bg.encoded)
                .map(|((&c, &covered), &b)| if covered { colour(c, exposure) } else { b })
                .collect(),
        };
        self.show(image, pixels, [start, t2], shade_ms, raster_ms);
        if !self.vertices_only() {
            // Per pixel again once the view has rested PREVIEW_REST after this frame (and,
            // while the worker prefilters, a check that often).
            self.pixels_pending = Some(Instant::now());
        }
        Ok(true)
    }

    /// Shows a new image (`pixels` its tonemapped colours), restarts the truth, and records
    /// the frame's cost: the edit began at `start`, the upload at `upload`.
    pub(crate) fn show(
        &mut self,
        image: rsl_shade::Image,
        pixels: Vec<Color32>,
        [start, upload]: [Instant; 2],
        shade_ms: f64,
        raster_ms: f64,
    ) {
        self.clay = false;
        self.rgba = Some(ColorImage::new([image.width as usize, image.height as usize], pixels));
        self.linear = Some(image);
        self.texture_stale = true;
        self.on_gpu = false;
        let upload_ms = upload.elapsed().as_secs_f64() * 1e3;
        self.record(start, shade_ms, raster_ms, upload_ms, false);
    }

    /// Records a new image's cost (the edit began at `start`) and restarts the truth.
    pub(crate) fn record(&mut self, start: Instant, shade_ms: f64, raster_ms: f64, upload_ms: f64, on_gpu: bool) {
        if self.truth_on {
            // The scene changed: the truth starts over.
            self.restart_truth();
        }
        let cost = FrameCost {
            sync_ms: std::mem::take(&mut self.pending_sync_ms),
            shade_ms,
            raster_ms,
            upload_ms,
            total_ms: start.elapsed().as_secs_f64() * 1e3,
            on_gpu,
        };
        if self.history.len() == HISTORY {
            self.history.pop_front();
        }
        self.history.push_back(cost);
    }
}

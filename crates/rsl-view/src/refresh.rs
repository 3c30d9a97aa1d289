//! Drawing: the drawing chosen from the registry, and the refresh of what changed (vertices, per
//! pixel, or whole frames of the drawing's method).

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
            self.force_pixels = !self.vertices_only();
            self.pixels_pending = None;
            self.covers.iter_mut().for_each(|c| *c = None);
            self.mark_all();
        }
    }

    /// How the view is drawn once it rests.
    pub fn drawing(&self) -> MethodId {
        self.drawing
    }

    /// Whether the drawing is the vertices interpolated, always (nothing to settle).
    pub(crate) fn vertices_only(&self) -> bool {
        self.drawing.capabilities().incremental == Incremental::Vertices
    }

    /// Drawing per pixel costs hundreds of milliseconds a frame on 2 cores: while edits come
    /// (a slider, a drag, the camera), frames are interpolated, and the view is drawn per
    /// pixel again once it has rested for [`PREVIEW_REST`] (or at once with `now`); `true`
    /// when that was started.
    pub fn settle_pixels(&mut self, now: bool) -> bool {
        match self.pixels_pending {
            Some(t) if now || t.elapsed() >= PREVIEW_REST => {
                self.pixels_pending = None;
                self.force_pixels = true;
                // Every object again, with its covers (interpolated frames did not keep them).
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

    /// Whether the drawing is prepared ([`rsl_engine::Method::preparation`]): if not, its
    /// preparation is started on a worker thread (once) and `false` comes back; a finished
    /// worker's result is given to its method.
    pub(crate) fn drawing_ready(&mut self) -> Result<bool> {
        if self.lobe_job.as_ref().is_some_and(|(_, h)| !h.is_finished()) {
            return Ok(false);
        }
        if let Some((id, h)) = self.lobe_job.take() {
            let p = h.join().map_err(|_| anyhow!("preparing the drawing {id} failed"))?;
            if let Some((_, m)) = self.methods.iter_mut().find(|(m, _)| *m == id) {
                m.install(p);
            }
        }
        if self.drawing.capabilities().incremental != Incremental::Frames {
            return Ok(true);
        }
        let id = self.drawing;
        let at = self.method()?;
        let Some(engine) = &self.engine else { return Ok(true) };
        match self.methods[at].1.preparation(engine)? {
            None => Ok(true),
            Some(job) => {
                let handle = std::thread::Builder::new()
                    .name("rsl-view prepare".into())
                    .spawn(move || job.run())
                    .context("starting the preparation thread")?;
                self.lobe_job = Some((id, handle));
                Ok(false)
            }
        }
    }

    /// Where the drawing's method is in `methods` (built from the registry, on the CPU, when
    /// first asked for).
    pub(crate) fn method(&mut self) -> Result<usize> {
        let id = self.drawing;
        let at = match self.methods.iter().position(|(m, _)| *m == id) {
            Some(at) => at,
            None => {
                let engine = self.engine.as_ref().ok_or_else(|| anyhow!("the scene is not prepared yet"))?;
                let options = rsl_engine::MethodOptions { device: rsl_engine::Device::Cpu, ..Default::default() };
                self.methods.push((id, id.create(engine, &options)?));
                self.methods.len() - 1
            }
        };
        Ok(at)
    }

    /// Waits for the environment being prefiltered for the lobes, if any (tests and the
    /// headless screenshot); the next refresh draws with them.
    pub fn wait_lobes(&mut self) {
        if let Some((_, h)) = &self.lobe_job {
            while !h.is_finished() {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
            self.mark_all();
        }
    }

    /// Whether the lobes' environment is being prefiltered on the worker thread.
    pub fn is_prefiltering(&self) -> bool {
        self.lobe_job.is_some()
    }

    /// [`Viewer::refresh`] through one of the lobe methods (or `auto`): the whole frame by
    /// the engine's method, as `rsl render --method` draws it.
    pub(crate) fn refresh_method(&mut self, start: Instant) -> Result<bool> {
        if self.engine.is_none() {
            return Ok(false);
        }
        let at = self.method()?;
        let Some(engine) = &self.engine else { return Ok(false) };
        let request = rsl_engine::Request { time: self.time, image: true, vertices: true, exposure: None };
        let frame = self.methods[at].1.render(engine, &self.scene, &request)?;
        let n = self.scene.objects.len();
        for (i, (p, r)) in frame.positions.into_iter().zip(frame.radiance).enumerate().take(n) {
            self.counters.vertices_shaded += r.len() as u64;
            self.counters.objects_shaded += 1;
            self.positions[i] = p;
            self.radiance[i] = r;
        }
        self.counters.shaded_frames += 1;
        self.counters.rasterised += 1;
        self.dirty.iter_mut().for_each(|d| *d = false);
        self.moved = false;
        let stages = &frame.timings.stages;
        let raster_ms: f64 = stages.iter().filter(|s| s.name.starts_with("draw")).map(|s| s.wall_ms).sum();
        let shade_ms: f64 = stages.iter().filter(|s| !s.name.starts_with("draw")).map(|s| s.wall_ms).sum();
        let image = frame.image.ok_or_else(|| anyhow::anyhow!("the method drew no image"))?;
        self.show_whole(image, start, shade_ms, raster_ms);
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

    /// [`Viewer::refresh`] per pixel: the dirty objects shaded at their vertices (glossy ones
    /// keeping every light's cover), then the whole image drawn.
    pub(crate) fn refresh_per_pixel(&mut self, start: Instant) -> Result<bool> {
        let Some(engine) = &self.engine else { return Ok(false) };
        let t0 = Instant::now();
        let state = self.scene.at(self.time);
        let setup = engine.setup(&self.scene, &state, self.scene.camera.eye, rsl_shade::Terms::default())?;
        let n = self.scene.objects.len();
        let per_pixel: Vec<bool> =
            (0..n).map(|i| rsl_shade::drawn_per_pixel(&setup, !engine.brdf(i).is_lambertian())).collect();
        let with_covers: Vec<bool> = (0..n).map(|i| self.dirty[i] && per_pixel[i]).collect();
        let plain: Vec<bool> = (0..n).map(|i| self.dirty[i] && !per_pixel[i]).collect();
        let (mut radiance, covers, _) = rsl_shade::shade_covers(&setup, &with_covers);
        let (plain_radiance, _) = rsl_shade::shade_objects(&setup, &plain);
        for (i, (c, r)) in covers.into_iter().zip(plain_radiance).enumerate() {
            if !self.dirty[i] {
                continue;
            }
            if plain[i] {
                radiance[i] = r;
            }
            self.counters.vertices_shaded += radiance[i].len() as u64;
            self.counters.objects_shaded += 1;
            self.positions[i] = (0..radiance[i].len()).map(|v| setup.position(i, v)).collect();
            self.radiance[i] = std::mem::take(&mut radiance[i]);
            self.covers[i] = c;
        }
        self.counters.shaded_frames += 1;
        self.dirty.iter_mut().for_each(|d| *d = false);
        self.moved = false;
        let shade_ms = t0.elapsed().as_secs_f64() * 1e3;
        let t1 = Instant::now();
        let (image, _) = rsl_shade::shade_image(&setup, &self.scene.camera, &self.covers, &self.radiance, |d| {
            engine.background(&state, d)
        });
        self.counters.rasterised += 1;
        let raster_ms = t1.elapsed().as_secs_f64() * 1e3;
        self.show_whole(image, start, shade_ms, raster_ms);
        Ok(true)
    }

    /// Shades what changed and rasterises a new image; `false` when nothing changed (no
    /// shading, no rasterising).
    pub fn refresh(&mut self) -> Result<bool> {
        if self.engine.is_none() || !self.dirty.iter().any(|&d| d) {
            return Ok(false);
        }
        let start = self.edit_started.take().unwrap_or_else(Instant::now);
        if !self.vertices_only() {
            if self.force_pixels && !self.drawing_ready()? {
                // Drawn from the vertices until the worker has prefiltered the environment
                // (`force_pixels` stays: the frame after it draws per pixel).
            } else if std::mem::take(&mut self.force_pixels) {
                return match self.drawing.capabilities().incremental {
                    Incremental::PixelCovers => self.refresh_per_pixel(start),
                    _ => self.refresh_method(start),
                };
            }
        }
        let Some(engine) = &self.engine else { return Ok(false) };
        // rsl-gpu's shading pass (a hardware adapter) shades every vertex.
        if self.wgpu.as_ref().is_some_and(|w| w.shades) {
            self.dirty.iter_mut().for_each(|d| *d = true);
        }
        let all = self.dirty.iter().all(|&d| d);
        // Only radiance changed (material edits): the image is redrawn where those objects
        // are, over the last one.
        let changed = self.dirty.clone();
        let still = !std::mem::take(&mut self.moved);
        let partial = still && self.linear.is_some();
        let t0 = Instant::now();
        let gpu_frame = match self.wgpu.as_mut().filter(|w| w.shades) {
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
        let frame = match gpu_frame {
            Some(frame) => frame,
            None if all => engine.shade(&self.scene, self.time)?,
            None => engine.shade_objects(&self.scene, self.time, &self.dirty)?,
        };
        let shade_ms = t0.elapsed().as_secs_f64() * 1e3;
        let state = frame.state.clone();
        for (i, (p, r)) in frame.positions.into_iter().zip(frame.radiance).enumerate() {
            if self.dirty[i] {
                self.counters.vertices_shaded += r.len() as u64;
                self.counters.objects_shaded += 1;
                self.positions[i] = p;
                self.radiance[i] = r;
            }
        }
        self.counters.shaded_frames += 1;
        self.dirty.iter_mut().for_each(|d| *d = false);
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

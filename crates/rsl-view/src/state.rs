//! The viewer's construction, its preparation on a worker thread, and what it shows.

use super::*;

impl Viewer {
    /// A viewer of the scene file `path`; starts preparing it on a worker thread.
    pub fn open(path: &Path, options: ViewerOptions) -> Result<Self> {
        let scene = Scene::load(path).with_context(|| format!("cannot open {}", path.display()))?;
        Ok(Self::new(scene, options))
    }

    /// A viewer of `scene`; starts preparing it on a worker thread.
    pub fn new(scene: Scene, options: ViewerOptions) -> Self {
        let mut scene = scene;
        let preset = options.quality.unwrap_or(scene.quality.preset);
        if preset != scene.quality.preset {
            scene.quality = Quality::from_preset(preset);
        }
        let n = scene.objects.len();
        let stem = scene.path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        let mut v = Self {
            orbit: Orbit::of(scene.camera.eye, scene.camera.target),
            env_base: scene.environment.rotation,
            rsl_count: scene.environment.rsl_count as usize,
            scene,
            options,
            engine: None,
            worker: None,
            error: None,
            time: 0.0,
            playing: false,
            last_tick: None,
            selected: 0,
            env_degrees: 0.0,
            preset,
            session: Session::new(rsl_engine::MethodOptions { device: rsl_engine::Device::Cpu, ..Default::default() }),
            redraw: true,
            positions: vec![Vec::new(); n],
            radiance: vec![Vec::new(); n],
            exposure: None,
            rgba: None,
            background: None,
            texture: None,
            pending_sync_ms: 0.0,
            edit_started: None,
            counters: Counters::default(),
            history: VecDeque::with_capacity(HISTORY),
            last_material_edit: None,
            previewing: None,
            save_path: format!("{stem}-edited.toml"),
            image_path: format!("{stem}-view.png"),
            notice: None,
            truth_on: false,
            show_truth: false,
            truth: None,
            linear: None,
            truth_rgba: None,
            texture_stale: false,
            clay: false,
            thumbnail: None,
            readout: None,
            drawing: MethodId::default_on(rsl_engine::Device::Cpu),
            force_pixels: false,
            pixels_pending: None,
            live_budget_ms: LIVE_BUDGET_MS,
            pixels_ms: None,
            gizmo_drag: None,
            view_area: None,
            wgpu: None,
            on_gpu: false,
        };
        v.prepare();
        v
    }

    /// Starts preparing the engine for the scene at the current preset on a worker thread
    /// (the UI keeps drawing the last frame meanwhile).
    pub(crate) fn prepare(&mut self) {
        let progress = Arc::new(Mutex::new(("starting".to_string(), 0.0f32)));
        let report = progress.clone();
        let mut scene = self.scene.clone();
        scene.environment.rsl_count = self.rsl_count as u32;
        let options = EngineOptions {
            cache_dir: self.options.cache_dir.clone(),
            quality: Some(self.preset),
            progress: Progress::new(move |e| {
                let mut p = report.lock().unwrap_or_else(|e| e.into_inner());
                match *e {
                    Event::Started { task } => *p = (task.to_string(), 0.0),
                    Event::Advanced { task, done, total } => {
                        *p = (task.to_string(), if total > 0 { done as f32 / total as f32 } else { 0.0 })
                    }
                    Event::Finished { task } => *p = (task.to_string(), 1.0),
                }
            }),
            ..Default::default()
        };
        let handle = std::thread::Builder::new()
            .name("rsl-view prepare".into())
            .spawn(move || Engine::new(&scene, options))
            .expect("the operating system refused a thread");
        self.worker = Some(Worker { handle, progress });
    }

    /// Whether the engine is being prepared on the worker thread.
    pub fn is_preparing(&self) -> bool {
        self.worker.is_some()
    }

    /// Waits for the worker thread (tests and the headless screenshot).
    pub fn wait_prepared(&mut self) -> Result<()> {
        if let Some(w) = self.worker.take() {
            self.finish(w);
        }
        match &self.error {
            Some(e) => Err(anyhow!("{e}")),
            None => Ok(()),
        }
    }

    pub(crate) fn poll_worker(&mut self) {
        if self.worker.as_ref().is_some_and(|w| w.handle.is_finished())
            && let Some(w) = self.worker.take()
        {
            self.finish(w);
        }
    }

    pub(crate) fn finish(&mut self, w: Worker) {
        match w.handle.join() {
            Ok(Ok(engine)) => {
                self.rsl_count = engine.rsl_count();
                self.engine = Some(engine);
                self.error = None;
                self.counters.prepared += 1;
                // A new engine: every method draws its next frame whole.
                self.session.forget_frames();
                self.mark_all();
            }
            Ok(Err(e)) => self.error = Some(format!("{e:#}")),
            Err(_) => self.error = Some("the preparation thread panicked".into()),
        }
    }

    /// The edited scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The prepared engine (`None` while preparing).
    pub fn engine(&self) -> Option<&Engine> {
        self.engine.as_ref()
    }

    /// What the viewer has done so far.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// The costs of the most recent reshaded frames, oldest first.
    pub fn history(&self) -> impl Iterator<Item = &FrameCost> {
        self.history.iter()
    }

    /// The last error (a failed preparation or edit), if any.
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    /// The last image shown, as RGBA pixels (`None` before the first frame; when the view is
    /// drawn with wgpu, `None` until [`Viewer::read_back`]).
    pub fn image(&self) -> Option<&ColorImage> {
        self.rgba.as_ref()
    }

    /// Whether the image shown is the clay preview ([`Viewer::show_clay`]): the scene's
    /// objects, unlit by the environment, while the first engine is prepared.
    pub fn showing_clay(&self) -> bool {
        self.clay
    }

    /// What is ready first, while the first engine is prepared (the fields of a large mesh
    /// take minutes): the objects as clay — grey, brighter where they face the eye, no
    /// environment, no shadows — through the scene's camera, so that the user sees the scene
    /// and its framing at once. The first shaded frame replaces it.
    pub fn show_clay(&mut self) {
        let state = self.scene.at(self.time);
        let positions = rsl_engine::compose::world_positions(&self.scene, &state);
        let eye = self.scene.camera.eye;
        let radiance: Vec<Vec<Vec3>> = self
            .scene
            .objects
            .iter()
            .zip(&state.objects)
            .zip(&positions)
            .map(|((o, t), p)| {
                let normal_matrix = t.matrix().inverse().transpose();
                o.mesh
                    .normals
                    .iter()
                    .zip(p)
                    .map(|(n, x)| {
                        let n = normal_matrix.transform_vector3(*n).normalize_or_zero();
                        Vec3::splat(0.1 + 0.7 * n.dot((eye - *x).normalize_or_zero()).max(0.0))
                    })
                    .collect()
            })
            .collect();
        let meshes: Vec<rsl_shade::RasterMesh<'_>> = self
            .scene
            .objects
            .iter()
            .zip(&positions)
            .zip(&radiance)
            .map(|((o, p), r)| rsl_shade::RasterMesh { positions: p, indices: &o.mesh.indices, radiance: r })
            .collect();
        let image = rsl_shade::rasterise(&self.scene.camera, &meshes, |_| Vec3::splat(0.02));
        let pixels: Vec<Color32> = image.pixels.iter().map(|&c| colour(c, 1.0)).collect();
        self.rgba = Some(ColorImage::new([image.width as usize, image.height as usize], pixels));
        self.texture_stale = true;
        self.clay = true;
    }

    /// Draws the view with wgpu on `state`'s device (a window's, or the headless
    /// renderer's), shared with rsl-gpu: from the next frame on, the CPU shades the vertices
    /// and rsl-gpu's draw pass rasterises and tonemaps them into a texture egui samples.
    /// Images drawn per pixel by the CPU methods are still uploaded. An error (a device
    /// rsl-gpu cannot use) leaves the view drawn on the CPU.
    pub fn attach_wgpu(&mut self, state: &eframe::egui_wgpu::RenderState) -> Result<()> {
        let view = wgpu_view::WgpuView::new(state)?;
        let hardware = view.shades;
        self.wgpu = Some(view);
        // On a hardware adapter the drawings per pixel run there too.
        self.set_pixels_on_gpu(hardware)?;
        self.linear = None;
        self.background = None;
        self.mark_all();
        Ok(())
    }

    /// Draws the drawings per pixel on the attached device (by default on a hardware adapter
    /// once [`Viewer::attach_wgpu`] has attached one: the methods' GPU passes, the image read
    /// back and shown) or on the CPU; an error before [`Viewer::attach_wgpu`].
    pub fn set_pixels_on_gpu(&mut self, on: bool) -> Result<()> {
        let gpu = match on {
            true => Some(self.wgpu.as_ref().context("the view is not drawn with wgpu")?.context()),
            false => None,
        };
        if self.pixels_on_gpu() != on {
            let device = if on { rsl_engine::Device::Auto } else { rsl_engine::Device::Cpu };
            self.session = Session::new(rsl_engine::MethodOptions { device, gpu, ..Default::default() });
            self.pixels_ms = None;
            self.force_pixels = !self.vertices_only();
            self.mark_all();
        }
        Ok(())
    }

    /// Whether the drawings per pixel run on the attached device ([`Viewer::set_pixels_on_gpu`]).
    pub fn pixels_on_gpu(&self) -> bool {
        self.session.options().gpu.is_some()
    }

    /// Whether rsl-gpu's shading pass shades the vertices (by default on a hardware adapter
    /// once [`Viewer::attach_wgpu`] has attached one), or the CPU path does.
    pub fn shading_on_gpu(&self) -> bool {
        self.wgpu.as_ref().is_some_and(|w| w.shades)
    }

    /// Shades on the GPU (every vertex of every changed frame, by rsl-gpu's shading pass on
    /// the attached device) or on the CPU (only what changed); an error before
    /// [`Viewer::attach_wgpu`].
    pub fn set_shading_on_gpu(&mut self, on: bool) -> Result<()> {
        let w = self.wgpu.as_mut().context("the view is not drawn with wgpu")?;
        if w.shades != on {
            w.shades = on;
            self.mark_all();
        }
        Ok(())
    }

    /// The adapter the view is drawn with, in words, when it is drawn with wgpu.
    pub fn wgpu_adapter(&self) -> Option<&str> {
        self.wgpu.as_ref().map(|w| w.adapter())
    }

    /// Whether the image shown was drawn with wgpu (and lives on the GPU).
    pub fn shown_on_gpu(&self) -> bool {
        self.on_gpu
    }

    /// Reads the view drawn with wgpu back into [`Viewer::image`] and
    /// [`Viewer::linear_image`] (nothing to do when the CPU drew it, or it was read already).
    pub fn read_back(&mut self) -> Result<()> {
        let Some(w) = self.wgpu.as_ref().filter(|_| self.on_gpu) else { return Ok(()) };
        if self.linear.is_none() {
            self.linear = Some(w.read_linear(&self.scene.camera)?);
        }
        if self.rgba.is_none() {
            self.rgba = Some(w.read_display()?);
        }
        Ok(())
    }

    /// The RSL image last drawn, linear radiance (`None` before the first frame; when the
    /// view is drawn with wgpu, see [`Viewer::read_back`]).
    pub fn linear_image(&self) -> Option<&rsl_shade::Image> {
        self.linear.as_ref()
    }

    /// Per object, per vertex: the radiance last shaded.
    pub fn radiance(&self) -> &[Vec<Vec3>] {
        &self.radiance
    }

    /// The RSL count in use.
    pub fn rsl_count(&self) -> usize {
        self.rsl_count
    }

    /// The environment's extra rotation about +Y, degrees.
    pub fn environment_degrees(&self) -> f32 {
        self.env_degrees
    }

    /// Draws the next refresh whole, even if the scene did not change (what changed in it
    /// the session finds by itself).
    pub(crate) fn mark_all(&mut self) {
        self.redraw = true;
    }
}

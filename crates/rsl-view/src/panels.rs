//! The UI: the controls, the object and material panels, the timings, and the view.

use super::*;

impl Viewer {
    /// Draws one frame of the whole UI into `ui` (the eframe app and the headless
    /// screenshot both call it).
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        self.counters.frames += 1;
        self.poll_worker();
        if self.playing {
            let now = Instant::now();
            let dt = self.last_tick.map_or(0.0, |t| now.duration_since(t).as_secs_f32());
            self.last_tick = Some(now);
            self.set_time(self.time + dt);
            ui.ctx().request_repaint();
        } else {
            self.last_tick = None;
        }
        if self.worker.is_some() {
            ui.ctx().request_repaint_after(std::time::Duration::from_millis(100));
        }
        egui::Panel::left("controls").resizable(true).min_size(260.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.controls(ui));
        });
        egui::Panel::bottom("timings").show(ui, |ui| self.timings(ui));
        egui::CentralPanel::default().show(ui, |ui| self.view(ui));
    }

    pub(crate) fn report(&mut self, r: Result<()>) {
        if let Err(e) = r {
            self.error = Some(format!("{e:#}"));
        }
    }

    pub(crate) fn controls(&mut self, ui: &mut egui::Ui) {
        ui.heading("rsl view");
        if let Some(w) = &self.worker {
            let (task, f) = w.progress.lock().map(|p| p.clone()).unwrap_or_default();
            ui.label("preparing");
            ui.add(egui::ProgressBar::new(f).text(task).show_percentage());
        }
        if let Some(e) = &self.error {
            ui.colored_label(Color32::from_rgb(230, 90, 80), e.as_str());
        }
        ui.separator();
        // Quality preset (prepared again on the worker thread).
        let mut preset = self.preset;
        egui::ComboBox::from_label("quality").selected_text(preset.name()).show_ui(ui, |ui| {
            for p in Preset::ALL {
                ui.selectable_value(&mut preset, p, p.name());
            }
        });
        self.set_preset(preset);
        // RSL count: instant (the merge tree holds every count).
        if let Some(engine) = &self.engine {
            let max = engine.texel_count().min(300);
            let mut n = self.rsl_count;
            ui.add(egui::Slider::new(&mut n, 1..=max).text("RSLs"));
            let r = self.set_rsl_count(n);
            self.report(r);
        }
        let mut deg = self.env_degrees;
        ui.add(egui::Slider::new(&mut deg, -180.0..=180.0).text("environment °"));
        self.set_environment_degrees(deg);
        self.environment_thumbnail(ui);
        let mut drawing = self.drawing;
        egui::ComboBox::from_label("drawing")
            .selected_text(label(drawing))
            .show_ui(ui, |ui| {
                for d in drawings() {
                    ui.selectable_value(&mut drawing, d, label(d)).on_hover_text(d.summary());
                }
            })
            .response
            .on_hover_text(
                "How glossy objects are drawn once the view rests (per pixel: sharp highlights, slower); \
                 edits in between are drawn from the vertices",
            );
        self.set_drawing(drawing);
        let mut aa = self.scene.quality.settings.aa;
        let aa_label = |n: u32| if n == 1 { "off".to_owned() } else { format!("up to {n} samples") };
        egui::ComboBox::from_label("antialiasing")
            .selected_text(aa_label(aa))
            .show_ui(ui, |ui| {
                for n in [1, 4, 16, 64] {
                    ui.selectable_value(&mut aa, n, aa_label(n));
                }
            })
            .response
            .on_hover_text(
                "Samples per pixel where one at the centre is not enough (silhouettes, shadow edges, \
                 highlights), averaged: the drawings per pixel, on the CPU and the GPU alike",
            );
        let r = self.set_antialias(aa);
        self.report(r);
        if let Some(adapter) = self.wgpu_adapter().map(str::to_owned) {
            let mut on = self.shading_on_gpu();
            ui.checkbox(&mut on, "shade on the GPU").on_hover_text(format!(
                "The view is drawn with wgpu on {adapter}. Checked, rsl-gpu shades every vertex of each \
                 changed frame; unchecked, the CPU shades what changed (the default on a software adapter)"
            ));
            if on != self.shading_on_gpu() {
                let r = self.set_shading_on_gpu(on);
                self.report(r);
            }
        }
        let mut truth = self.truth_on;
        ui.checkbox(&mut truth, "progressive truth (error readout)");
        if truth != self.truth_on {
            self.set_truth(truth);
        }
        let mut bounces = self.scene.quality.settings.bounces;
        let bounce_label = |n: u32| match n {
            0 => "direct light only".to_owned(),
            1 => "1 bounce".to_owned(),
            n => format!("{n} bounces"),
        };
        egui::ComboBox::from_label("light")
            .selected_text(bounce_label(bounces))
            .show_ui(ui, |ui| {
                for n in [0, 1, 2] {
                    ui.selectable_value(&mut bounces, n, bounce_label(n));
                }
            })
            .response
            .on_hover_text(
                "Bounces of light between surfaces (the quality knob `bounces`): the drawings gather them at \
                 the vertices, and the truth follows as many",
            );
        self.set_bounces(bounces);
        if self.truth_on {
            let mut show = self.show_truth;
            ui.horizontal(|ui| {
                ui.radio_value(&mut show, false, "show RSL");
                ui.radio_value(&mut show, true, "show truth");
            });
            if show != self.show_truth {
                self.set_show_truth(show);
            }
            match self.readout {
                Some(r) => ui.label(format!(
                    "RSL vs truth: {:.2} % per covered pixel (truth noise {:.2} %, {} spp)",
                    100.0 * r.relative_l2,
                    100.0 * r.truth_noise,
                    r.spp
                )),
                None => ui.label("truth: first pass…"),
            };
        }
        ui.horizontal(|ui| {
            let label = if self.playing { "pause" } else { "play" };
            if ui.button(label).clicked() {
                self.playing = !self.playing;
            }
            let mut t = self.time;
            ui.add(egui::Slider::new(&mut t, 0.0..=10.0).text("time s"));
            self.set_time(t);
        });
        ui.separator();
        ui.horizontal(|ui| {
            let button = ui.button("save scene");
            ui.text_edit_singleline(&mut self.save_path).labelled_by(button.id);
            if button.clicked() {
                let r = self.save(Path::new(&self.save_path));
                self.notice = r.as_ref().ok().map(|_| format!("saved {}", self.save_path));
                self.report(r);
            }
        });
        ui.horizontal(|ui| {
            let button = ui.button("screenshot");
            ui.text_edit_singleline(&mut self.image_path).labelled_by(button.id);
            if button.clicked() {
                let path = PathBuf::from(&self.image_path);
                let r = self.save_image(&path);
                self.notice = r.as_ref().ok().map(|_| format!("wrote {}", self.image_path));
                self.report(r);
            }
        });
        if let Some(n) = &self.notice {
            ui.label(n.as_str());
        }
        ui.separator();
        ui.label("objects");
        for (i, o) in self.scene.objects.iter().enumerate() {
            ui.selectable_value(&mut self.selected, i, o.name.as_str());
        }
        self.object_controls(ui);
    }

    /// The environment (in its own orientation) with the RSLs in use outlined, like Xu et
    /// al.'s figure 6; redrawn when the RSL count changes.
    pub(crate) fn environment_thumbnail(&mut self, ui: &mut egui::Ui) {
        let Some(engine) = &self.engine else { return };
        let (w, h) = (256usize, 128usize);
        let key = (engine.environment_key(), engine.rsl_count());
        if self.thumbnail.as_ref().is_none_or(|t| t.0 != key) {
            let mut rgb = match engine.environment() {
                rsl_engine::engine::EnvRadiance::Map(m) => rsl_engine::env::visualise::thumbnail(m, w, h),
                rsl_engine::engine::EnvRadiance::Constant(c) => {
                    let px = rsl_engine::env::visualise::tonemap(*c, 0.18 / c.max_element().max(1e-6));
                    px.repeat(w * h)
                }
            };
            rsl_engine::env::visualise::outline_squares(&mut rgb, w, h, engine.rsls(), [255, 40, 40]);
            let img = ColorImage::from_rgb([w, h], &rgb);
            let tex = ui.ctx().load_texture("rsl-view-environment", img, TextureOptions::LINEAR);
            self.thumbnail = Some((key, tex));
        }
        if let Some((_, tex)) = &self.thumbnail {
            ui.add(
                egui::Image::new((tex.id(), egui::vec2(w as f32, h as f32))).alt_text("the RSLs over the environment"),
            );
        }
    }

    /// The selected object's index.
    pub fn selected(&self) -> usize {
        self.selected
    }

    /// Selects object `i` (as clicking it in the list or the view does).
    pub fn select(&mut self, i: usize) {
        if i < self.scene.objects.len() {
            self.selected = i;
        }
    }

    pub(crate) fn object_controls(&mut self, ui: &mut egui::Ui) {
        let i = self.selected;
        let Some(o) = self.scene.objects.get(i) else { return };
        ui.separator();
        ui.label(format!("{}: position", o.name));
        let mut p = o.transform.translation;
        ui.horizontal(|ui| {
            ui.add(egui::DragValue::new(&mut p.x).speed(0.01).prefix("x "));
            ui.add(egui::DragValue::new(&mut p.y).speed(0.01).prefix("y "));
            ui.add(egui::DragValue::new(&mut p.z).speed(0.01).prefix("z "));
        });
        let r = self.set_translation(i, p);
        self.report(r);
        let (axis, angle) = self.scene.objects[i].transform.rotation.to_axis_angle();
        let mut yaw = (angle * axis.y.signum()).to_degrees();
        ui.add(egui::Slider::new(&mut yaw, -180.0..=180.0).text("turn °"));
        if (yaw - (angle * axis.y.signum()).to_degrees()).abs() > 1e-4 {
            let r = self.set_yaw(i, yaw);
            self.report(r);
        }
        ui.label("material");
        let mut m = self.scene.objects[i].material;
        material_controls(ui, &mut m);
        let r = self.set_material(i, m);
        self.report(r);
    }

    pub(crate) fn timings(&mut self, ui: &mut egui::Ui) {
        let c = self.counters;
        match self.history.back() {
            Some(f) => ui.label(format!(
                "last reshade {:.1} ms: sync {:.1}, shade {:.1}, {} {:.1}, {} {:.1} · shaded frames {} of {}, objects {}",
                f.total_ms,
                f.sync_ms,
                f.shade_ms,
                if f.on_gpu { "draw (wgpu)" } else { "raster" },
                f.raster_ms,
                if f.on_gpu { "tonemap" } else { "upload" },
                f.upload_ms,
                c.shaded_frames,
                c.frames,
                c.objects_shaded
            )),
            None => ui.label("no frame yet"),
        };
        // A bar per recent reshaded frame: shade (blue) under raster (orange), 50 ms high.
        let (rect, _) = ui.allocate_exact_size(egui::vec2(ui.available_width(), 40.0), egui::Sense::hover());
        let painter = ui.painter_at(rect);
        let w = rect.width() / HISTORY as f32;
        let scale = rect.height() / 50.0;
        for (k, f) in self.history.iter().enumerate() {
            let x = rect.left() + k as f32 * w;
            let shade = (f.shade_ms + f.sync_ms) as f32 * scale;
            let raster = (f.raster_ms + f.upload_ms) as f32 * scale;
            let y0 = rect.bottom();
            painter.rect_filled(
                egui::Rect::from_min_max(egui::pos2(x, y0 - shade), egui::pos2(x + w * 0.8, y0)),
                0.0,
                Color32::from_rgb(90, 140, 230),
            );
            painter.rect_filled(
                egui::Rect::from_min_max(egui::pos2(x, y0 - shade - raster), egui::pos2(x + w * 0.8, y0 - shade)),
                0.0,
                Color32::from_rgb(230, 150, 60),
            );
        }
        let y33 = rect.bottom() - 33.0 * scale;
        painter.hline(rect.x_range(), y33, egui::Stroke::new(1.0, Color32::GRAY));
    }

    pub(crate) fn view(&mut self, ui: &mut egui::Ui) {
        if self.previewing.is_some() {
            ui.ctx().request_repaint_after(PREVIEW_REST);
            let r = self.settle(false).map(|_| ());
            self.report(r);
        }
        if self.pixels_pending.is_some() && self.previewing.is_none() {
            ui.ctx().request_repaint_after(PREVIEW_REST);
            self.settle_pixels(false);
        }
        let r = self.refresh().map(|_| ());
        self.report(r);
        // Nothing drawn yet and the engine still being prepared: the scene as clay first.
        if self.engine.is_none() && self.worker.is_some() && self.rgba.is_none() {
            self.show_clay();
        }
        self.poll_truth(ui.ctx());
        let truth_shown = self.show_truth && self.truth_rgba.is_some();
        let shown = if truth_shown { &self.truth_rgba } else { &self.rgba };
        if self.texture_stale
            && let Some(img) = shown
        {
            match &mut self.texture {
                Some(t) if t.size() == img.size => t.set(img.clone(), TextureOptions::LINEAR),
                _ => self.texture = Some(ui.ctx().load_texture("rsl-view", img.clone(), TextureOptions::LINEAR)),
            }
            self.texture_stale = false;
        }
        // The image drawn with wgpu is shown in place; the CPU's images are uploaded.
        let native = self.wgpu.as_ref().filter(|_| self.on_gpu && !truth_shown).and_then(|w| w.texture());
        let Some((id, size)) = native.or_else(|| self.texture.as_ref().map(|t| (t.id(), t.size()))) else {
            ui.centered_and_justified(|ui| ui.label("preparing the scene…"));
            return;
        };
        let avail = ui.available_size();
        let [w, h] = size.map(|s| s as f32);
        let s = (avail.x / w).min(avail.y / h).max(0.05);
        let response = ui.add(egui::Image::new((id, egui::vec2(w * s, h * s))).sense(egui::Sense::click_and_drag()));
        let to_pixel = |p: egui::Pos2| {
            let r = response.rect;
            ((p.x - r.left()) / s, (p.y - r.top()) / s)
        };
        if response.clicked()
            && let Some(p) = response.interact_pointer_pos()
        {
            let (x, y) = to_pixel(p);
            if let Some(i) = self.pick(x, y) {
                self.selected = i;
            }
        }
        self.view_area = Some((response.rect, s));
        if response.drag_started() {
            // Where the button went down (the drag starts once the pointer has moved).
            let origin = ui.input(|i| i.pointer.press_origin()).or(response.interact_pointer_pos());
            self.gizmo_drag = origin.and_then(|p| {
                let (x, y) = to_pixel(p);
                self.gizmo_hit(x, y)
            });
        }
        if response.drag_stopped() {
            self.gizmo_drag = None;
        }
        if let Some(g) = self.gizmo() {
            // The gizmo over the view: move arrows in the axes' usual colours, the turn ring.
            let painter = ui.painter_at(response.rect);
            let at = |(x, y): (f32, f32)| response.rect.min + egui::vec2(x * s, y * s);
            let ring: Vec<egui::Pos2> = g.ring.iter().map(|&p| at(p)).collect();
            let held = |part: GizmoPart| self.gizmo_drag == Some(part);
            let width = |part: GizmoPart| if held(part) { 3.5 } else { 2.0 };
            painter.add(egui::Shape::closed_line(
                ring,
                egui::Stroke::new(width(GizmoPart::Ring), Color32::from_rgb(230, 200, 60)),
            ));
            let colours =
                [Color32::from_rgb(230, 70, 70), Color32::from_rgb(80, 200, 80), Color32::from_rgb(80, 130, 240)];
            for (k, tip) in g.tips.iter().enumerate() {
                let (from, to) = (at(g.centre), at(*tip));
                painter.arrow(from, to - from, egui::Stroke::new(width(GizmoPart::Axis(k)), colours[k]));
            }
        }
        if response.dragged() {
            let d = response.drag_delta();
            if let (Some(part), Some(p)) = (self.gizmo_drag, response.interact_pointer_pos()) {
                let (x, y) = to_pixel(p);
                self.drag_gizmo(part, (x - d.x / s, y - d.y / s), (x, y));
            } else if ui.input(|i| i.modifiers.shift) {
                // Shift-drag moves the selected object on the ground plane, along the
                // camera's right and forward directions, by the distance the pointer covers
                // at the object's depth.
                self.drag_selected(d.x / s, d.y / s);
            } else {
                self.orbit_by(d.x * 0.01, d.y * 0.01, 1.0);
            }
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.orbit_by(0.0, 0.0, (-scroll * 0.002).exp());
            }
        }
    }
}

/// Sliders for a material's parameters (the model stays; its numbers change).
pub(crate) fn material_controls(ui: &mut egui::Ui, m: &mut Brdf) {
    fn rgb(ui: &mut egui::Ui, label: &str, c: &mut glam::Vec3) {
        ui.horizontal(|ui| {
            ui.label(label);
            ui.color_edit_button_rgb(c.as_mut());
        });
    }
    match m {
        Brdf::Lambert { albedo } => rgb(ui, "albedo", albedo),
        Brdf::Phong { exponent, specular, diffuse } | Brdf::BlinnPhong { exponent, specular, diffuse } => {
            ui.add(egui::Slider::new(exponent, 1.0..=2000.0).logarithmic(true).text("exponent"));
            rgb(ui, "specular", specular);
            rgb(ui, "diffuse", diffuse);
        }
        Brdf::CookTorrance { alpha, specular, diffuse }
        | Brdf::Ggx { alpha, specular, diffuse }
        | Brdf::Beckmann { alpha, specular, diffuse } => {
            ui.add(egui::Slider::new(alpha, 0.02..=1.0).logarithmic(true).text("alpha"));
            rgb(ui, "specular", specular);
            rgb(ui, "diffuse", diffuse);
        }
        Brdf::Gltf { base_color, metallic, roughness } => {
            rgb(ui, "base colour", base_color);
            ui.add(egui::Slider::new(metallic, 0.0..=1.0).text("metallic"));
            ui.add(egui::Slider::new(roughness, 0.14..=1.0).text("roughness"));
        }
        _ => {
            ui.label("(this model's parameters are edited in the scene file)");
        }
    }
}

//! Edits: materials (with preview tables while a slider moves), transforms, the environment, the
//! RSL count, the preset, time and the camera; saving the scene and the image.

use super::*;

impl Viewer {
    /// Sets object `i`'s material: one BRDF table is built (milliseconds) and that object
    /// alone is reshaded. While a slider moves (edits of the same object less than
    /// [`PREVIEW_REST`] apart) the table is a preview at `rsl_engine::engine::PREVIEW_RESOLUTION`;
    /// the real table is built when the slider rests ([`Viewer::settle`]).
    pub fn set_material(&mut self, i: usize, material: Brdf) -> Result<()> {
        let o = self.scene.objects.get_mut(i).context("no such object")?;
        if o.material == material {
            return Ok(());
        }
        self.edit_started.get_or_insert_with(Instant::now);
        o.material = material;
        let now = Instant::now();
        let dragging = self.last_material_edit.is_some_and(|(j, t)| j == i && now.duration_since(t) < PREVIEW_REST);
        if let Some(engine) = &mut self.engine {
            let start = Instant::now();
            engine.sync_previewing(&self.scene, dragging.then_some(i))?;
            self.pending_sync_ms += start.elapsed().as_secs_f64() * 1e3;
        }
        self.previewing = if dragging { Some(i) } else { None };
        // Edits are apart by the time between them, not counting this one's own work (a
        // real table built here on a busy machine is no rest of the slider).
        self.last_material_edit = Some((i, Instant::now()));
        Ok(())
    }

    /// Builds the real table of an object shown with a preview table once its slider has
    /// rested for [`PREVIEW_REST`] (or at once with `now`); `true` when it did.
    pub fn settle(&mut self, now: bool) -> Result<bool> {
        if self.previewing.is_none() {
            return Ok(false);
        }
        let rested = self.last_material_edit.is_none_or(|(_, t)| t.elapsed() >= PREVIEW_REST);
        if !(now || rested) {
            return Ok(false);
        }
        self.previewing = None;
        if let Some(engine) = &mut self.engine {
            self.edit_started.get_or_insert_with(Instant::now);
            let start = Instant::now();
            engine.sync(&self.scene)?;
            self.pending_sync_ms += start.elapsed().as_secs_f64() * 1e3;
        }
        Ok(true)
    }

    /// Whether an object is shown with a preview table (a slider is moving).
    pub fn is_previewing(&self) -> bool {
        self.previewing.is_some()
    }

    /// Replaces object `j`'s base transform: the session reshades `j` and every object it
    /// can shadow at the old or the new pose ([`rsl_engine::Session::changes`]); the rest keep
    /// their radiance.
    pub(crate) fn move_object(&mut self, j: usize, transform: rsl_engine::scene::Transform) {
        if self.scene.objects[j].transform == transform {
            return;
        }
        self.edit_started.get_or_insert_with(Instant::now);
        self.scene.objects[j].transform = transform;
    }

    /// Moves object `i` to `translation` (its base transform, before motion): it is
    /// reshaded with the objects its shadow can reach.
    pub fn set_translation(&mut self, i: usize, translation: Vec3) -> Result<()> {
        let o = self.scene.objects.get(i).context("no such object")?;
        if !translation.is_finite() {
            return Err(anyhow!("object {}: translation must be finite", o.name));
        }
        let t = rsl_engine::scene::Transform { translation, ..o.transform };
        self.move_object(i, t);
        Ok(())
    }

    /// Sets object `i`'s rotation about +Y, degrees (replacing its base rotation).
    pub fn set_yaw(&mut self, i: usize, degrees: f32) -> Result<()> {
        let o = self.scene.objects.get(i).context("no such object")?;
        if !degrees.is_finite() {
            return Err(anyhow!("object {}: the turn must be finite", o.name));
        }
        let t = rsl_engine::scene::Transform { rotation: yaw_rotation(degrees), ..o.transform };
        self.move_object(i, t);
        Ok(())
    }

    /// Turns the environment by `degrees` about +Y after its own rotation: nothing is
    /// rebuilt (the lights rotate), every object is reshaded.
    pub fn set_environment_degrees(&mut self, degrees: f32) {
        if degrees != self.env_degrees {
            self.edit_started.get_or_insert_with(Instant::now);
            self.env_degrees = degrees;
            self.scene.environment.rotation = (yaw_rotation(degrees) * self.env_base).normalize();
        }
    }

    /// Sets the RSL count: the merge tree already holds every count, so nothing is
    /// recomputed (the engine's cache counters do not move); every object is reshaded.
    pub fn set_rsl_count(&mut self, n: usize) -> Result<()> {
        if n == self.rsl_count {
            return Ok(());
        }
        if let Some(engine) = &mut self.engine {
            self.edit_started.get_or_insert_with(Instant::now);
            let start = Instant::now();
            engine.set_rsl_count(n)?;
            self.pending_sync_ms += start.elapsed().as_secs_f64() * 1e3;
        }
        self.rsl_count = n;
        self.scene.environment.rsl_count = n as u32;
        Ok(())
    }

    /// Switches the quality preset: the engine is prepared again on the worker thread.
    pub fn set_preset(&mut self, preset: Preset) {
        if preset != self.preset && self.worker.is_none() {
            self.preset = preset;
            self.scene.quality = Quality::from_preset(preset);
            self.prepare();
        }
    }

    /// Saves the edited scene as a scene file that `rsl render` reproduces (atomically:
    /// nothing half-written is left).
    pub fn save(&self, path: &Path) -> Result<()> {
        let text = self.scene.to_toml(path).with_context(|| format!("cannot write the scene as {}", path.display()))?;
        rsl_engine::output::write_atomic(path, text.as_bytes())
    }

    /// Writes the image shown as a PNG (the 3D view alone, at the camera's resolution).
    pub fn save_image(&mut self, path: &Path) -> Result<()> {
        self.read_back()?;
        let img = self.rgba.as_ref().context("no image has been drawn yet")?;
        let rgb: Vec<u8> = img.pixels.iter().flat_map(|c| [c.r(), c.g(), c.b()]).collect();
        rsl_engine::output::write_png(path, img.size[0] as u32, img.size[1] as u32, rgb)
    }

    /// Sets the scene time (seconds).
    pub fn set_time(&mut self, t: f32) {
        if t != self.time && t.is_finite() {
            self.edit_started.get_or_insert_with(Instant::now);
            self.time = t;
        }
    }

    /// Orbits the camera by `dx`, `dy` radians and scales its distance by `zoom`.
    pub(crate) fn orbit_by(&mut self, dx: f32, dy: f32, zoom: f32) {
        self.edit_started.get_or_insert_with(Instant::now);
        self.orbit.yaw -= dx;
        self.orbit.pitch = (self.orbit.pitch + dy).clamp(-1.5, 1.5);
        self.orbit.distance = (self.orbit.distance * zoom).clamp(1e-2, 1e4);
        self.scene.camera.eye = self.orbit.eye();
    }
}

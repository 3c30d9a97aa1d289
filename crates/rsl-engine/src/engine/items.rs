//! How the engine builds or finds each prepared item: in its memory store, in the disk
//! cache, or built (BRDF tables, face masks, BVHs, the visibility fields).

use super::*;

impl Engine {
    /// The BRDF table of `brdf` at `res`; `warn`: say when the lobe is narrower than a cell
    /// (not for a preview).
    pub(super) fn table(
        &mut self,
        name: &str,
        brdf: &Brdf,
        res: Resolution,
        warn: bool,
    ) -> Result<(Arc<BrdfTable>, u64)> {
        let key = KeyHasher::default()
            .str("table")
            .u64(brdf.key())
            .u64(res.n as u64)
            .u64(res.views as u64)
            .u64(CACHE_VERSION)
            .finish();
        self.store.pin_more([key]);
        if let Some(t) = self.store.get::<BrdfTable>(key) {
            self.stats.memory_hits += 1;
            return Ok((t, key));
        }
        self.stats.misses += 1;
        let slices = if brdf.is_lambertian() {
            0
        } else if brdf.is_anisotropic() {
            // V×V views, a quarter of them stored.
            (res.views * res.views).div_ceil(4)
        } else {
            res.views
        };
        let bytes = slices as u64 * ((res.n as u64 + 1).pow(2) * 16);
        check_size(
            &format!("object {name}: the BRDF table at N = {}, {} view samples", res.n, res.views),
            "brdf_resolution or view_samples",
            bytes,
        )?;
        // A cell of the table spans at most 4/N radians: a lobe narrower than one is blurred
        // to the cell (its highlights spread, its peak lowered), whatever else is done.
        if let Some(width) = brdf.lobe_width()
            && warn
            && width < 4.0 / res.n as f32
        {
            tracing::warn!(
                "object {name}: its {} lobe ({width:.2e} rad wide) is narrower than one cell of its {n}×{n} BRDF \
                 table ({:.2e} rad): its highlights are blurred to the table's resolution (raise brdf_resolution, \
                 or compare against --method truth)",
                brdf.name(),
                4.0 / res.n as f32,
                n = res.n
            );
        }
        let start = Instant::now();
        let t = Arc::new(BrdfTable::build(brdf, res).with_context(|| format!("object {name}: material"))?);
        self.timings.add(stage::TABLES, start.elapsed().as_secs_f64() * 1e3, None);
        self.store.insert(key, t.clone(), t.bytes());
        Ok((t, key))
    }

    /// A mesh's face-averaged vertex mask: built in milliseconds, kept in memory, never on disk.
    pub(super) fn face_mask(&mut self, mesh: &TriMesh, mesh_key: u64) -> Arc<FaceMask> {
        let key = KeyHasher::default().str("face mask").u64(mesh_key).finish();
        let mask = match self.store.get::<FaceMask>(key) {
            Some(m) => m,
            None => {
                let m = Arc::new(FaceMask::build(mesh));
                self.store.insert(key, m.clone(), m.bytes());
                m
            }
        };
        self.store.pin_more([key]);
        mask
    }

    /// A mesh's triangles in a BVH for traced shadows: built in milliseconds, kept in memory,
    /// never on disk.
    pub(super) fn bvh(&mut self, name: &str, mesh: &TriMesh, mesh_key: u64) -> Result<Arc<Occluder>> {
        let key = KeyHasher::default().str("bvh").u64(mesh_key).finish();
        let bvh = match self.store.get::<Occluder>(key) {
            Some(b) => b,
            None => {
                let b = Arc::new(Occluder::new(mesh).with_context(|| format!("object {name}: shadow-ray BVH"))?);
                self.store.insert(key, b.clone(), b.bytes());
                b
            }
        };
        self.store.pin_more([key]);
        Ok(bvh)
    }

    pub(super) fn svdf(&mut self, name: &str, mesh: &TriMesh, mesh_key: u64) -> Result<(Arc<Svdf>, u64)> {
        let p = svdf_params(self.preset, &self.settings);
        let key = field_key("svdf", mesh_key, &[p.n, p.supersample, p.clusters, p.vectors, p.iterations]);
        let vertices = mesh.vertex_count();
        let io = FieldIo {
            prefix: "svdf",
            load: rsl_vis::store::load_svdf,
            save: rsl_vis::store::save_svdf,
            check: &|f: &Svdf| {
                (field_vertices(f) == vertices).then_some(()).ok_or("vertex count differs from the mesh")
            },
            // The size is checked only where the field must be built.
            build: &|report| {
                check_size(
                    &format!("object {name}: the self-visibility field ({vertices} vertices × {}² tables)", p.n),
                    "visibility_resolution",
                    vertices as u64 * (p.n as u64).pow(2) * 4,
                )?;
                Svdf::build_with_progress(mesh, &p, report)
                    .with_context(|| format!("object {name}: self-visibility field"))
            },
            bytes: Svdf::bytes,
            stage: stage::SVDF,
            message: format!("self-visibility of {name} ({vertices} vertices, {}×{} per vertex)", p.n, p.n),
        };
        self.cached(key, io).map(|f| (f, key))
    }

    pub(super) fn ovdf(&mut self, name: &str, mesh: &TriMesh, mesh_key: u64) -> Result<(Arc<Ovdf>, u64)> {
        let p = ovdf_params(&self.settings);
        p.check().context("quality settings")?;
        let key = field_key("ovdf", mesh_key, &[p.shells, p.m, p.n, p.supersample, p.vectors]);
        let io = FieldIo {
            prefix: "ovdf",
            load: rsl_vis::store::load_ovdf,
            save: rsl_vis::store::save_ovdf,
            check: &|f: &Ovdf| (f.params() == &p).then_some(()).ok_or("resolution differs"),
            // The size is checked only where the field must be built. A flat convex occluder
            // is its closed form (a few corners), never the tables: its size does not depend
            // on the field's knobs (two planes were refused for 12.9 GB).
            build: &|report| {
                let flat = rsl_vis::flat::Flat::detect(mesh).is_some();
                check_size(
                    &format!(
                        "object {name}: the occluder field ({} shells × 6×{}² directions × {}² tables)",
                        p.shells, p.m, p.n
                    ),
                    "ovdf_shells, ovdf_directions or visibility_resolution",
                    if flat { 0 } else { (p.shells * 6 * p.m * p.m) as u64 * (p.n as u64).pow(2) * 4 },
                )?;
                Ovdf::build_with_progress(mesh, &p, report).with_context(|| format!("object {name}: occluder field"))
            },
            bytes: Ovdf::bytes,
            stage: stage::OVDF,
            message: format!("occluder field of {name} ({} shells × 6×{}×{} samples)", p.shells, p.m, p.m),
        };
        self.cached(key, io).map(|f| (f, key))
    }

    /// A field from memory, else from disk (checked; a bad file is rejected), else built (and
    /// written to disk).
    pub(super) fn cached<T: Send + Sync + 'static>(&mut self, key: u64, io: FieldIo<'_, T>) -> Result<Arc<T>> {
        self.store.pin_more([key]);
        if let Some(f) = self.store.get::<T>(key) {
            self.stats.memory_hits += 1;
            return Ok(f);
        }
        let file = self.options.cache_dir.as_ref().map(|d| d.join(format!("{}-{key:016x}.bin", io.prefix)));
        if let Some(path) = &file
            && path.exists()
        {
            match (io.load)(path, key)
                .map_err(|e| e.to_string())
                .and_then(|f| (io.check)(&f).map(|()| f).map_err(String::from))
            {
                Ok(f) => {
                    cache::used(path);
                    self.stats.disk_hits += 1;
                    let f = Arc::new(f);
                    self.store.insert(key, f.clone(), (io.bytes)(&f));
                    return Ok(f);
                }
                Err(why) => reject(&mut self.stats, path, &why),
            }
        }
        self.stats.misses += 1;
        let start = Instant::now();
        let f = self.options.progress.task(&io.message, |report| (io.build)(report))?;
        self.timings.add(io.stage, start.elapsed().as_secs_f64() * 1e3, None);
        if let Some(path) = &file {
            match std::fs::create_dir_all(path.parent().unwrap_or(path))
                .map_err(|e| e.to_string())
                .and_then(|()| (io.save)(&f, key, path).map_err(|e| e.to_string()))
            {
                Ok(()) => cache::stored(path, self.cache_limit()),
                Err(e) => tracing::warn!("cannot cache {}: {e}", io.message),
            }
        }
        let f = Arc::new(f);
        self.store.insert(key, f.clone(), (io.bytes)(&f));
        Ok(f)
    }
}

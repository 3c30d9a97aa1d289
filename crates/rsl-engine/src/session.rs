//! A render session: the methods a front end draws with, what changed since each one's
//! last frame, their preparation on a worker thread, and incremental rendering for any
//! method ([`Method::render_changed`]).
//!
//! A front end edits its [`Scene`] and keeps its [`Engine`] in step ([`Engine::sync`]), and
//! asks the session for frames. The session finds what changed by content, against the
//! frame each method last drew: the eye, the environment (its map, rotation, intensity and
//! light count), the traced lights, and every object's material, shadow and pose. A material
//! edit changes that object alone; a moved object changes itself and every object its shadow
//! can reach at its old or its new pose ([`Engine::shadowed_by_any`]); anything else (a new
//! mesh or occluder field included) changes every object. Nothing is
//! told to the session and nothing is branched on by method: each method reuses what it
//! kept for the objects that did not change, or draws the whole frame.

use crate::engine::{Engine, ObjectKeys};
use crate::method::{Changes, Frame, Kept, Method, Prepared, Request};
use crate::registry::{MethodId, MethodOptions};
use anyhow::{Context, Result, anyhow};
use rsl_scene::{Camera, Scene, SceneState};
use rsl_shade::Traced;
use std::thread::JoinHandle;

/// What a frame was drawn from: compared with the scene now to find what changed.
#[derive(Clone, Debug, PartialEq)]
struct Seen {
    camera: Camera,
    state: SceneState,
    /// The environment's content key, its intensity's bits, the light count.
    environment: (u64, u32, usize),
    /// Which lights are traced, and with how many rays.
    traced: Traced,
    /// Per object: its prepared data's keys, its BRDF's key, whether it casts shadows.
    objects: Vec<(ObjectKeys, u64, bool)>,
}

impl Seen {
    fn of(engine: &Engine, scene: &Scene, time: f32) -> Self {
        Seen {
            camera: scene.camera,
            state: scene.at(time),
            environment: (engine.environment_key(), engine.intensity().to_bits(), engine.rsl_count()),
            traced: engine.traced(),
            objects: (0..engine.object_count())
                .map(|i| (engine.keys(i), engine.brdf(i).key(), scene.objects[i].casts_shadows))
                .collect(),
        }
    }
}

/// One method of the session, with what it keeps between frames.
struct Slot {
    id: MethodId,
    method: Box<dyn Method>,
    kept: Kept,
    seen: Option<Seen>,
}

/// A frame from [`Session::render`], and what changed since the method's frame before it.
pub struct Rendered {
    /// The frame.
    pub frame: Frame,
    /// What the method drew again.
    pub changes: Changes,
}

/// Methods built from the registry when first asked for and kept with what they prepared
/// and what they keep between frames; see the module docs.
pub struct Session {
    options: MethodOptions,
    slots: Vec<Slot>,
    job: Option<(MethodId, JoinHandle<Prepared>)>,
}

impl Session {
    /// A session building its methods with `options`.
    pub fn new(options: MethodOptions) -> Self {
        Self { options, slots: Vec::new(), job: None }
    }

    /// What the session builds its methods with.
    pub fn options(&self) -> &MethodOptions {
        &self.options
    }

    /// Where method `id` is in `slots`, built from the registry the first time.
    fn slot(&mut self, engine: &Engine, id: MethodId) -> Result<usize> {
        if let Some(at) = self.slots.iter().position(|s| s.id == id) {
            return Ok(at);
        }
        let method = id.create(engine, &self.options)?;
        self.slots.push(Slot { id, method, kept: None, seen: None });
        Ok(self.slots.len() - 1)
    }

    /// Holds `method` under `id` in place of the registry's (a method the front end built
    /// itself, such as the command line's RSL path with oracles); it draws its next frame
    /// whole.
    pub fn insert(&mut self, id: MethodId, method: Box<dyn Method>) {
        self.slots.retain(|s| s.id != id);
        self.slots.push(Slot { id, method, kept: None, seen: None });
    }

    /// Method `id` as this session holds it (built when first asked for).
    pub fn method(&mut self, engine: &Engine, id: MethodId) -> Result<&mut dyn Method> {
        let at = self.slot(engine, id)?;
        Ok(self.slots[at].method.as_mut())
    }

    /// What changed in `scene` at `time` since method `id` last drew (everything when it
    /// has not drawn yet).
    pub fn changes(&self, engine: &Engine, scene: &Scene, id: MethodId, time: f32) -> Result<Changes> {
        engine.check(scene)?;
        let n = scene.objects.len();
        let Some(before) = self.slots.iter().find(|s| s.id == id).and_then(|s| s.seen.as_ref()) else {
            return Ok(Changes::all(n));
        };
        let now = Seen::of(engine, scene, time);
        let everything = before.camera.eye != now.camera.eye
            || before.environment != now.environment
            || before.traced != now.traced
            || before.state.world_from_env != now.state.world_from_env
            || before.objects.len() != n
            // What an object's shadow is made of (whether it casts one, its mesh, its
            // occluder field) changes what the others receive.
            || before.objects.iter().zip(&now.objects).any(|(b, a)| b.2 != a.2 || b.0.mesh != a.0.mesh || b.0.ovdf != a.0.ovdf);
        if everything {
            return Ok(Changes::all(n));
        }
        let movers: Vec<bool> = (0..n).map(|j| before.state.objects[j] != now.state.objects[j]).collect();
        let mut changes = Changes {
            objects: (0..n).map(|j| movers[j] || before.objects[j] != now.objects[j]).collect(),
            moved: before.camera != now.camera || movers.contains(&true),
        };
        if movers.contains(&true) && !changes.is_all() {
            // The movers' shadows, where they were and where they are.
            let was = engine.shadowed_by_any(scene, &before.state, &movers)?;
            let is = engine.shadowed_by_any(scene, &now.state, &movers)?;
            for (i, c) in changes.objects.iter_mut().enumerate() {
                *c |= was[i] || is[i];
            }
        }
        Ok(changes)
    }

    /// The frame of method `id` for `request`: only what changed since its last frame is
    /// drawn again, as far as the method can reuse what it kept.
    pub fn render(&mut self, engine: &Engine, scene: &Scene, id: MethodId, request: &Request) -> Result<Rendered> {
        let changes = self.changes(engine, scene, id, request.time)?;
        self.render_changes(engine, scene, id, request, changes)
    }

    /// [`Session::render`] with what changed already found ([`Session::changes`] for this
    /// scene, method and time, since which nothing was drawn), for a front end that looked
    /// before deciding to draw.
    pub fn render_changes(
        &mut self,
        engine: &Engine,
        scene: &Scene,
        id: MethodId,
        request: &Request,
        changes: Changes,
    ) -> Result<Rendered> {
        let at = self.slot(engine, id)?;
        let slot = &mut self.slots[at];
        // A method installed since the changes were found has drawn nothing yet.
        let changes = if slot.seen.is_some() { changes } else { Changes::all(scene.objects.len()) };
        let frame = match slot.method.render_changed(engine, scene, request, &changes, &mut slot.kept) {
            Ok(frame) => frame,
            Err(e) => {
                // Nothing half-kept: the next frame starts afresh.
                slot.kept = None;
                slot.seen = None;
                return Err(e);
            }
        };
        slot.seen = Some(Seen::of(engine, scene, request.time));
        Ok(Rendered { frame, changes })
    }

    /// Records that the front end drew `scene` at `time` for method `id` by its own means
    /// (a device of its own): what the method kept is dropped, and what changes next is
    /// counted from here.
    pub fn drawn_elsewhere(&mut self, engine: &Engine, scene: &Scene, id: MethodId, time: f32) -> Result<()> {
        engine.check(scene)?;
        let at = self.slot(engine, id)?;
        let slot = &mut self.slots[at];
        slot.kept = None;
        slot.seen = Some(Seen::of(engine, scene, time));
        Ok(())
    }

    /// Forgets every method's last frame (after the engine was replaced): each draws its
    /// next frame whole.
    pub fn forget_frames(&mut self) {
        for s in &mut self.slots {
            s.kept = None;
            s.seen = None;
        }
    }

    /// Whether method `id` is prepared for `engine`'s scene ([`Method::preparation`]): if
    /// not, its preparation is started on a worker thread (once) and `false` comes back; a
    /// finished preparation is given to its method first.
    pub fn ready(&mut self, engine: &Engine, scene: &Scene, id: MethodId) -> Result<bool> {
        if self.job.as_ref().is_some_and(|(_, h)| !h.is_finished()) {
            return Ok(false);
        }
        self.install_finished()?;
        let at = self.slot(engine, id)?;
        match self.slots[at].method.preparation(engine, scene)? {
            None => Ok(true),
            Some(job) => {
                let handle = std::thread::Builder::new()
                    .name(format!("rsl prepare {id}"))
                    .spawn(move || job.run())
                    .context("starting the preparation thread")?;
                self.job = Some((id, handle));
                Ok(false)
            }
        }
    }

    /// Gives a finished preparation to its method.
    fn install_finished(&mut self) -> Result<()> {
        if let Some((id, h)) = self.job.take() {
            let prepared = h.join().map_err(|_| anyhow!("preparing {id} failed"))?;
            if let Some(s) = self.slots.iter_mut().find(|s| s.id == id) {
                s.method.install(prepared);
            }
        }
        Ok(())
    }

    /// Whether a method's preparation runs on the worker thread.
    pub fn is_preparing(&self) -> bool {
        self.job.is_some()
    }

    /// Waits for the preparation running on the worker thread, if any, and gives it to its
    /// method.
    pub fn wait_preparation(&mut self) -> Result<()> {
        self.install_finished()
    }
}

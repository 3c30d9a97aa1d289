//! Progress and timings: the one way long work reports itself, and the one shape of "what
//! each stage cost".
//!
//! Libraries never draw on the terminal: a front end passes a [`Progress`] callback (the
//! command line draws bars with it, the viewer a widget) and reads [`Timings`] afterwards.

use std::sync::Arc;

/// One report of a long task.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event<'a> {
    /// A task started; `total` units are expected (0: not known yet).
    Started {
        /// What is being done, in words ("occluder field of bunny (8 shells × 6×8×8 samples)").
        task: &'a str,
    },
    /// `done` of `total` units are finished.
    Advanced {
        /// The task.
        task: &'a str,
        /// Units finished.
        done: usize,
        /// Units in all.
        total: usize,
    },
    /// The task ended (successfully or not).
    Finished {
        /// The task.
        task: &'a str,
    },
}

/// A progress callback, shared between threads (builds report from rayon workers). The
/// default reports nowhere.
#[derive(Clone, Default)]
pub struct Progress(Option<Arc<Callback>>);

/// What a [`Progress`] calls.
type Callback = dyn Fn(&Event<'_>) + Send + Sync;

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() { "Progress(callback)" } else { "Progress(none)" })
    }
}

impl Progress {
    /// Reports to `f`.
    pub fn new(f: impl Fn(&Event<'_>) + Send + Sync + 'static) -> Self {
        Self(Some(Arc::new(f)))
    }

    /// Reports nowhere.
    pub fn none() -> Self {
        Self(None)
    }

    /// Reports `event`.
    pub fn report(&self, event: &Event<'_>) {
        if let Some(f) = &self.0 {
            f(event);
        }
    }

    /// Runs `work` as the task `task`, giving it a `(done, total)` callback; reports the
    /// start and the end (also when `work` fails).
    pub fn task<T>(&self, task: &str, work: impl FnOnce(&(dyn Fn(usize, usize) + Sync)) -> T) -> T {
        self.report(&Event::Started { task });
        let advance = |done: usize, total: usize| self.report(&Event::Advanced { task, done, total });
        let out = work(&advance);
        self.report(&Event::Finished { task });
        out
    }
}

/// The time one stage took.
#[derive(Clone, Debug, PartialEq)]
pub struct Stage {
    /// The stage ("environment", "shade", "draw", …).
    pub name: &'static str,
    /// Wall time, ms.
    pub wall_ms: f64,
    /// Device time from GPU timestamps, ms, where the adapter has them.
    pub gpu_ms: Option<f64>,
}

impl Stage {
    /// The best measure of the stage's cost: GPU time where known, else wall time.
    pub fn ms(&self) -> f64 {
        self.gpu_ms.unwrap_or(self.wall_ms)
    }

    /// Whether the stage makes the image from what shading left ("draw…", "antialias…",
    /// "image readback"), as against shading.
    pub fn is_image(&self) -> bool {
        self.name.starts_with("draw") || self.name.starts_with("antialias") || self.name == "image readback"
    }

    /// Whether the stage prepares what the frames after it reuse rather than drawing this
    /// frame: "lobes" (the prefiltered environment), "transport" (the transport lobes, the
    /// wavelet baseline's transport) and "choose" (`auto`'s choice of each object's drawing,
    /// measured against the truth once and cached).
    pub fn is_preparation(&self) -> bool {
        matches!(self.name, "lobes" | "transport" | "choose")
    }
}

/// What each stage of some work cost, in the order the stages ran. Adding to a stage that is
/// already there accumulates.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Timings {
    /// The stages.
    pub stages: Vec<Stage>,
}

impl Timings {
    /// Adds `wall_ms` (and GPU time, where known) to stage `name`.
    pub fn add(&mut self, name: &'static str, wall_ms: f64, gpu_ms: Option<f64>) {
        match self.stages.iter_mut().find(|s| s.name == name) {
            Some(s) => {
                s.wall_ms += wall_ms;
                s.gpu_ms = match (s.gpu_ms, gpu_ms) {
                    (Some(a), Some(b)) => Some(a + b),
                    (a, b) => a.or(b),
                };
            }
            None => self.stages.push(Stage { name, wall_ms, gpu_ms }),
        }
    }

    /// Times `work` as stage `name` (wall time).
    pub fn time<T>(&mut self, name: &'static str, work: impl FnOnce() -> T) -> T {
        let start = std::time::Instant::now();
        let out = work();
        self.add(name, start.elapsed().as_secs_f64() * 1e3, None);
        out
    }

    /// The cost of stage `name` ([`Stage::ms`]), 0 when it did not run.
    pub fn ms(&self, name: &str) -> f64 {
        self.stages.iter().find(|s| s.name == name).map_or(0.0, Stage::ms)
    }

    /// The stage `name`, if it ran.
    pub fn get(&self, name: &str) -> Option<&Stage> {
        self.stages.iter().find(|s| s.name == name)
    }

    /// Wall time of the stages that prepare rather than draw ([`Stage::is_preparation`]), ms.
    pub fn preparation_ms(&self) -> f64 {
        self.stages.iter().filter(|s| s.is_preparation()).map(|s| s.wall_ms).sum()
    }

    /// One line: `shade 12.3 ms (GPU), draw 4.5 ms`.
    pub fn describe(&self) -> String {
        self.stages
            .iter()
            .map(|s| match s.gpu_ms {
                Some(g) => format!("{} {g:.3} ms (GPU; {:.1} ms wall)", s.name, s.wall_ms),
                None => format!("{} {:.1} ms", s.name, s.wall_ms),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[test]
    fn tasks_report_start_progress_and_end() {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let s = seen.clone();
        let p = Progress::new(move |e| {
            s.lock().unwrap().push(match *e {
                Event::Started { task } => format!("start {task}"),
                Event::Advanced { task, done, total } => format!("{task} {done}/{total}"),
                Event::Finished { task } => format!("end {task}"),
            })
        });
        let v = p.task("build", |advance| {
            advance(1, 2);
            advance(2, 2);
            7
        });
        assert_eq!(v, 7);
        assert_eq!(*seen.lock().unwrap(), ["start build", "build 1/2", "build 2/2", "end build"]);
        // The silent default runs the work all the same.
        assert_eq!(
            Progress::none().task("x", |a| {
                a(0, 1);
                3
            }),
            3
        );
    }

    #[test]
    fn timings_accumulate_per_stage_in_order() {
        let mut t = Timings::default();
        t.add("shade", 2.0, None);
        t.add("draw", 1.0, Some(0.5));
        t.add("shade", 3.0, None);
        t.add("draw", 1.0, Some(0.25));
        assert_eq!(t.stages.iter().map(|s| s.name).collect::<Vec<_>>(), ["shade", "draw"]);
        assert_eq!(t.ms("shade"), 5.0);
        assert_eq!(t.ms("draw"), 0.75, "GPU time is preferred where known");
        assert_eq!(t.get("draw").unwrap().wall_ms, 2.0);
        assert_eq!(t.ms("absent"), 0.0);
        assert_eq!(t.preparation_ms(), 0.0, "shading and drawing prepare nothing");
        t.add("lobes", 40.0, Some(1.0));
        t.add("choose", 2.5, None);
        assert_eq!(t.preparation_ms(), 42.5, "wall time of the preparing stages alone");
    }
}

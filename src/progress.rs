//! Progress on standard error for the library's [`Progress`] reports: on a terminal a bar per
//! task with a percentage and a time estimate; otherwise (a log, a pipe, CI) a line when a
//! task has run for 2 s and then one every 10 s, and one when it ends.

use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use rsl_engine::{Event, Progress};
use std::collections::HashMap;
use std::sync::Mutex;

/// Whether `--quiet` asked for errors only: no status lines, no progress.
static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Sets `--quiet` for the process.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, std::sync::atomic::Ordering::Relaxed);
}

/// Whether `--quiet` is set.
pub fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
}

/// Prints a status line on standard error unless `--quiet` is set.
#[macro_export]
macro_rules! status {
    ($($arg:tt)*) => {
        if !$crate::progress::quiet() {
            eprintln!($($arg)*);
        }
    };
}

/// A [`Progress`] that draws one bar per running task on standard error (nested tasks,
/// such as a field build inside a bench, stack below the outer one); none under `--quiet`.
pub fn bars() -> Progress {
    if quiet() {
        return Progress::none();
    }
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return lines(std::time::Duration::from_secs(2), std::time::Duration::from_secs(10));
    }
    let running: Mutex<HashMap<String, ProgressBar>> = Mutex::new(HashMap::new());
    let multi = MultiProgress::new();
    Progress::new(move |e| {
        let Ok(mut running) = running.lock() else { return };
        match *e {
            Event::Started { task } => {
                let bar = multi.add(ProgressBar::new(0).with_message(task.to_string()));
                bar.set_style(
                    ProgressStyle::with_template("{msg} {wide_bar} {percent:>3}% [{elapsed} / ~{duration}]")
                        .expect("valid template"),
                );
                bar.enable_steady_tick(std::time::Duration::from_millis(250));
                running.insert(task.to_string(), bar);
            }
            Event::Advanced { task, done, total } => {
                if let Some(bar) = running.get(task) {
                    bar.set_length(total as u64);
                    bar.set_position(done as u64);
                }
            }
            Event::Finished { task } => {
                if let Some(bar) = running.remove(task) {
                    bar.finish_and_clear();
                    multi.remove(&bar);
                }
            }
        }
    })
}

/// A [`Progress`] that writes plain lines on standard error: the first once a task has run
/// for `first`, then one every `every`, and a last line when a task that printed one ends. A
/// task that reports no fraction done (an environment decomposed in one piece) is said to be
/// running all the same, by a thread that looks at the running tasks.
pub fn lines(first: std::time::Duration, every: std::time::Duration) -> Progress {
    lines_to(first, every, |line| eprintln!("{line}"))
}

/// A running task, for [`lines_to`]: when it started, when a line was last printed, whether it
/// reported a fraction done.
struct Running {
    start: std::time::Instant,
    last: Option<std::time::Instant>,
    advanced: bool,
}

impl Running {
    fn due(&self, first: std::time::Duration, every: std::time::Duration) -> bool {
        match self.last {
            None => self.start.elapsed() >= first,
            Some(t) => t.elapsed() >= every,
        }
    }
}

/// [`lines`] into `out`.
pub fn lines_to(
    first: std::time::Duration,
    every: std::time::Duration,
    out: impl Fn(String) + Send + Sync + 'static,
) -> Progress {
    use std::sync::Arc;
    use std::time::{Duration, Instant};
    let out = Arc::new(out);
    let running: Arc<Mutex<HashMap<String, Running>>> = Arc::new(Mutex::new(HashMap::new()));
    // The watcher ends with the last clone of the Progress (it holds the tasks weakly).
    let (weak, say) = (Arc::downgrade(&running), out.clone());
    let tick = first.min(every).clamp(Duration::from_millis(50), Duration::from_secs(1));
    std::thread::spawn(move || {
        loop {
            std::thread::sleep(tick);
            let Some(running) = weak.upgrade() else { return };
            let Ok(mut running) = running.lock() else { return };
            for (task, r) in running.iter_mut().filter(|(_, r)| !r.advanced) {
                if r.due(first, every) {
                    say(format!("{task}: running, {:.0} s so far", r.start.elapsed().as_secs_f64()));
                    r.last = Some(Instant::now());
                }
            }
        }
    });
    Progress::new(move |e| {
        let Ok(mut running) = running.lock() else { return };
        match *e {
            Event::Started { task } => {
                running.insert(task.to_string(), Running { start: Instant::now(), last: None, advanced: false });
            }
            Event::Advanced { task, done, total } => {
                if let Some(r) = running.get_mut(task) {
                    r.advanced = true;
                    if r.due(first, every) && total > 0 {
                        let pct = 100.0 * done as f64 / total as f64;
                        out(format!(
                            "{task}: {pct:.0}% ({done}/{total}) after {:.0} s",
                            r.start.elapsed().as_secs_f64()
                        ));
                        r.last = Some(Instant::now());
                    }
                }
            }
            Event::Finished { task } => {
                if let Some(Running { start, last: Some(_), .. }) = running.remove(task) {
                    out(format!("{task}: done in {:.1} s", start.elapsed().as_secs_f64()));
                }
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::time::Duration;

    #[test]
    fn without_a_terminal_long_tasks_print_lines_and_short_ones_nothing() {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let sink = seen.clone();
        let p = lines_to(Duration::ZERO, Duration::ZERO, move |l| sink.lock().unwrap().push(l));
        p.task("building a field", |advance| {
            advance(1, 4);
            advance(4, 4);
        });
        let got = seen.lock().unwrap().clone();
        assert_eq!(got.len(), 3, "{got:?}");
        assert!(got[0].starts_with("building a field: 25% (1/4)"), "{got:?}");
        assert!(got[2].starts_with("building a field: done in"), "{got:?}");
        // A task shorter than `first` says nothing.
        let quiet = Arc::new(Mutex::new(Vec::new()));
        let sink = quiet.clone();
        let p = lines_to(Duration::from_secs(3600), Duration::ZERO, move |l| sink.lock().unwrap().push(l));
        p.task("quick", |advance| advance(1, 1));
        assert!(quiet.lock().unwrap().is_empty());
        // A long task that reports no fraction is said to be running, and done.
        let seen = Arc::new(Mutex::new(Vec::new()));
        let sink = seen.clone();
        let p = lines_to(Duration::from_millis(100), Duration::from_secs(3600), move |l| sink.lock().unwrap().push(l));
        p.task("decomposing", |_| std::thread::sleep(Duration::from_millis(600)));
        let got = seen.lock().unwrap().clone();
        assert_eq!(got.len(), 2, "{got:?}");
        assert!(got[0].starts_with("decomposing: running") && got[1].starts_with("decomposing: done in"), "{got:?}");
    }
}

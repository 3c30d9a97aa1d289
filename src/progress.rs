//! Progress bars on standard error for the library's [`Progress`] reports: a percentage and
//! a time estimate per task, hidden when standard error is not a terminal.

use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use rsl_engine::{Event, Progress};
use std::collections::HashMap;
use std::sync::Mutex;

/// A [`Progress`] that draws one bar per running task on standard error (nested tasks,
/// such as a field build inside a bench, stack below the outer one).
pub fn bars() -> Progress {
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

//! Scratch folders for tests and examples, under the system's temp folder, that do not pile
//! up: a test run's caches and outputs can reach hundreds of megabytes, and left behind by
//! every run they fill the disk.
//!
//! A folder is `rsl-<name>-<process id>`. [`Scratch`] is one test's, emptied when made and
//! removed with its contents when dropped (also when the test panics); [`run_dir`] is one
//! that a process's tests share (a disk cache one test fills and the next reads), which the
//! process leaves behind. Either, when made, first removes the folders of the same name that
//! processes no longer running left ([`remove_stale`]: a run killed before its drops ran, or
//! the shared folder of a run that ended), so at most one run's worth of each name remains.

use std::path::{Path, PathBuf};

/// The folder `rsl-<name>-<pid>` in the temp folder.
fn folder(name: &str, pid: u32) -> PathBuf {
    std::env::temp_dir().join(format!("rsl-{name}-{pid}"))
}

/// Whether process `pid` is running. Only where the system answers cheaply (Linux's `/proc`):
/// elsewhere every process counts as running, and nothing is removed as stale.
fn running(pid: u32) -> bool {
    let proc = Path::new("/proc");
    !proc.is_dir() || proc.join(pid.to_string()).exists()
}

/// Removes the folders `rsl-<name>-<pid>` in the temp folder whose process is not running
/// (not this one's): how many were removed. A folder another user owns, or one that cannot
/// be read, is left.
pub fn remove_stale(name: &str) -> usize {
    let prefix = format!("rsl-{name}-");
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else { return 0 };
    let mine = std::process::id();
    entries
        .flatten()
        .filter(|e| {
            let file = e.file_name();
            let pid = file.to_str().and_then(|f| f.strip_prefix(&prefix)).and_then(|p| p.parse::<u32>().ok());
            pid.is_some_and(|p| p != mine && !running(p))
        })
        .filter(|e| std::fs::remove_dir_all(e.path()).is_ok())
        .count()
}

/// The folder `rsl-<name>-<this process>` in the temp folder, created (kept if there): one the
/// process's tests share. Stale folders of the name go first ([`remove_stale`]).
///
/// # Panics
/// When the folder cannot be created (these are for tests).
pub fn run_dir(name: &str) -> PathBuf {
    remove_stale(name);
    let d = folder(name, std::process::id());
    std::fs::create_dir_all(&d).unwrap_or_else(|e| panic!("cannot create {}: {e}", d.display()));
    d
}

/// One test's folder, `rsl-<name>-<this process>` in the temp folder: emptied and created
/// when made, removed with its contents when dropped. It dereferences to its path.
#[derive(Debug)]
pub struct Scratch(PathBuf);

impl Scratch {
    /// The folder for `name` (unique among the process's tests that run at once), made
    /// empty. Stale folders of the name go first ([`remove_stale`]).
    ///
    /// # Panics
    /// When the folder cannot be created (these are for tests).
    pub fn new(name: &str) -> Self {
        let _ = std::fs::remove_dir_all(folder(name, std::process::id()));
        Scratch(run_dir(name))
    }
}

impl std::ops::Deref for Scratch {
    type Target = Path;

    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<std::ffi::OsStr> for Scratch {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.as_os_str()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scratch_folder_goes_with_its_guard_and_stale_ones_of_its_name_with_the_next() {
        let path = {
            let s = Scratch::new("scratch-test");
            std::fs::write(s.join("a.txt"), "x").unwrap();
            assert!(s.join("a.txt").exists());
            s.to_path_buf()
        };
        assert!(!path.exists(), "removed with its guard");
        // A folder of the name left by a process that is not running (no pid reaches
        // u32::MAX − 1 on Linux), and one of another name, and this process's shared one.
        let stale = folder("scratch-test", u32::MAX - 1);
        let other = folder("scratch-test-other", u32::MAX - 1);
        for d in [&stale, &other] {
            std::fs::create_dir_all(d.join("inside")).unwrap();
        }
        let shared = run_dir("scratch-test");
        std::fs::write(shared.join("kept"), "x").unwrap();
        if Path::new("/proc").is_dir() {
            assert!(!stale.exists(), "a stale folder of the name is removed");
        }
        assert!(other.exists(), "another name's is left");
        // The shared folder is kept as it is when asked for again.
        assert_eq!(run_dir("scratch-test"), shared);
        assert!(shared.join("kept").exists());
        for d in [&stale, &other, &shared] {
            let _ = std::fs::remove_dir_all(d);
        }
        assert_eq!(remove_stale("scratch-test-none"), 0);
    }
}

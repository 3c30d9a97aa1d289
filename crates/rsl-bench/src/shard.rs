//! Sharding: one bench's work split over independent processes — the elements of a job
//! array on a scheduler (Slurm's `--array`, a Kubernetes Indexed Job) — that share one
//! output folder. Shard `K/N` measures every `N`th (scene, configuration, time), starting at
//! the `K`th, and writes its rows into files of its own (`results-shard-K-of-N.csv`,
//! `budget-shard-K-of-N.csv`), under a lock of its own; the next bench into the folder
//! without `--shard` (or `rsl bench --merge`) joins them into `results.csv` and
//! `budget.csv`. Every row carries its truth's key, so a joined row is reused only where it
//! was measured against the truth the scene needs now.

use crate::Row;
use crate::budget::BudgetRow;
use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};

/// Most shards of one bench.
pub const MAX_SHARDS: u32 = 100_000;

/// One slice of a bench: shard `index` of `count`, counted from 0 as job-array indices are
/// (`SLURM_ARRAY_TASK_ID`, `JOB_COMPLETION_INDEX`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// Which slice, in `0..count`.
    pub index: u32,
    /// How many slices.
    pub count: u32,
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `K/N`, with `K` in `0..N`.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("`{s}` is not a shard K/N (K from 0 to N − 1, as job-array indices count)");
        let (k, n) = s.trim().split_once('/').ok_or_else(bad)?;
        let (index, count): (u32, u32) = (k.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
        if count == 0 || count > MAX_SHARDS {
            return Err(format!("`{s}`: the number of shards must be in 1..={MAX_SHARDS}"));
        }
        if index >= count {
            return Err(format!("`{s}`: shard {index} of {count} does not exist (they count from 0 to {})", count - 1));
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl Shard {
    /// Whether this shard measures the `item`th piece of work.
    pub fn takes(&self, item: usize) -> bool {
        item % self.count as usize == self.index as usize
    }

    /// What its file names carry: `shard-K-of-N`.
    fn tag(&self) -> String {
        format!("shard-{}-of-{}", self.index, self.count)
    }

    /// The shard whose tag `name` carries between `prefix` and `suffix`, if any.
    fn from_name(name: &str, prefix: &str, suffix: &str) -> Option<Shard> {
        let tag = name.strip_prefix(prefix)?.strip_suffix(suffix)?.strip_prefix("shard-")?;
        let (k, n) = tag.split_once("-of-")?;
        format!("{k}/{n}").parse().ok()
    }
}

/// `results.csv`, or a shard's results file, in `out`.
pub fn results_file(out: &Path, shard: Option<Shard>) -> PathBuf {
    out.join(shard.map_or("results.csv".into(), |s| format!("results-{}.csv", s.tag())))
}

/// `budget.csv`, or a shard's budget file, in `out`.
pub fn budget_file(out: &Path, shard: Option<Shard>) -> PathBuf {
    out.join(shard.map_or("budget.csv".into(), |s| format!("budget-{}.csv", s.tag())))
}

/// The lock file a bench (or a shard of one) holds in `out` while it runs.
pub fn lock_file(out: &Path, shard: Option<Shard>) -> PathBuf {
    out.join(shard.map_or(crate::LOCK_FILE.into(), |s| format!("bench-{}.lock", s.tag())))
}

/// What [`merge`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Merged {
    /// The shards whose files were joined (and then removed).
    pub joined: Vec<Shard>,
    /// The shards still running (their lock held): left for a later run.
    pub running: Vec<Shard>,
}

/// Whether the shard holding `lock` is still running: its lock file exists and another
/// process holds its lock.
fn running(lock: &Path) -> Result<bool> {
    let file = match std::fs::File::open(lock) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(false),
        Err(e) => return Err(e).with_context(|| format!("cannot open {}", lock.display())),
    };
    match file.try_lock_shared() {
        Ok(()) => Ok(false),
        Err(std::fs::TryLockError::WouldBlock) => Ok(true),
        Err(std::fs::TryLockError::Error(e)) => Err(e).with_context(|| format!("cannot lock {}", lock.display())),
    }
}

/// Joins the rows of every finished shard in `out` into `rows` and `budget` (a shard's row
/// replaces one of the same scene, configuration and time — and oracle — measured before),
/// writes `results.csv` and `budget.csv`, and then removes the joined shards' files. The
/// caller holds `out`'s own lock.
pub fn merge(out: &Path, rows: &mut Vec<Row>, budget: &mut Vec<BudgetRow>) -> Result<Merged> {
    let mut merged = Merged::default();
    let entries = match std::fs::read_dir(out) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(merged),
        Err(e) => return Err(e).with_context(|| format!("cannot read the folder {}", out.display())),
    };
    let mut shards: Vec<Shard> = entries
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            Shard::from_name(&name, "results-", ".csv").or_else(|| Shard::from_name(&name, "budget-", ".csv"))
        })
        .collect();
    shards.sort_by_key(|s| (s.count, s.index));
    shards.dedup();
    for shard in shards {
        if running(&lock_file(out, Some(shard)))? {
            merged.running.push(shard);
            continue;
        }
        for row in crate::report::read_rows(&results_file(out, Some(shard)))? {
            rows.retain(|r| !(r.scene == row.scene && r.config == row.config && r.time == row.time));
            rows.push(row);
        }
        for row in crate::budget::read_rows(&budget_file(out, Some(shard)))? {
            budget.retain(|r| {
                !(r.scene == row.scene && r.config == row.config && r.time == row.time && r.oracle == row.oracle)
            });
            budget.push(row);
        }
        merged.joined.push(shard);
    }
    if merged.joined.is_empty() {
        return Ok(merged);
    }
    // Written before any shard file is removed: a merge cut short loses nothing.
    crate::report::write_rows(&results_file(out, None), rows)?;
    crate::budget::write_rows(&budget_file(out, None), budget)?;
    for &shard in &merged.joined {
        let results = results_file(out, Some(shard));
        for file in [crate::report::objects_path(&results), results, budget_file(out, Some(shard))] {
            match std::fs::remove_file(&file) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(e).with_context(|| format!("cannot remove {} (joined)", file.display())),
            }
        }
    }
    Ok(merged)
}

/// Refuses a shard of `count` where shards of another count have files in `out`: their
/// slices would not fit together.
pub fn check_count(out: &Path, shard: Shard) -> Result<()> {
    let Ok(entries) = std::fs::read_dir(out) else { return Ok(()) };
    for e in entries.filter_map(|e| e.ok()) {
        let name = e.file_name().to_string_lossy().into_owned();
        if let Some(other) = Shard::from_name(&name, "results-", ".csv")
            && other.count != shard.count
        {
            bail!(
                "{}: holds rows of shard {other}, of another split than {shard}; join them first \
                 (rsl bench --merge), or give another --out",
                out.display()
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shard_is_k_of_n_counted_from_0_and_its_files_name_it() {
        let s: Shard = "2/5".parse().unwrap();
        assert_eq!(s, Shard { index: 2, count: 5 });
        assert_eq!(s.to_string(), "2/5");
        assert!(s.takes(2) && s.takes(7) && !s.takes(3) && !s.takes(5));
        for bad in ["5/5", "1/0", "a/2", "2", "-1/3", "1/100001"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        let out = Path::new("o");
        assert_eq!(results_file(out, Some(s)), out.join("results-shard-2-of-5.csv"));
        assert_eq!(results_file(out, None), out.join("results.csv"));
        assert_eq!(Shard::from_name("results-shard-2-of-5.csv", "results-", ".csv"), Some(s));
        assert_eq!(Shard::from_name("budget-shard-2-of-5.csv", "results-", ".csv"), None);
        assert_eq!(Shard::from_name("results-shard-5-of-5.csv", "results-", ".csv"), None);
        // Every item is some shard's, and one shard's only.
        let shards: Vec<Shard> = (0..3).map(|k| Shard { index: k, count: 3 }).collect();
        for item in 0..20 {
            assert_eq!(shards.iter().filter(|s| s.takes(item)).count(), 1);
        }
    }
}

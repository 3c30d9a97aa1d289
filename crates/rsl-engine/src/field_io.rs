//! The engine's visibility-field files: their content keys, how one kind of field is read,
//! checked, built and written ([`FieldIo`]), rejected cache files, and the bytes prepared
//! data holds.

use crate::cache::{CacheStats, KeyHasher};
use crate::engine::CACHE_VERSION;
use anyhow::Result;
use rsl_env::Rsl;
use rsl_shade::VertexFrames;
use rsl_vis::Svdf;
use rsl_vis::store::FieldFileError;
use std::path::Path;

pub(crate) fn rsl_bytes(s: &[Rsl]) -> usize {
    std::mem::size_of_val(s)
}

pub(crate) fn frames_bytes(f: &VertexFrames) -> usize {
    std::mem::size_of_val(f.visibility.as_slice())
        + f.tangent.as_ref().map_or(0, |t| std::mem::size_of_val(t.as_slice()))
}

/// Counts a rejected cache file, says why, and removes it.
pub(crate) fn reject(stats: &mut CacheStats, file: &Path, why: &str) {
    stats.rejected += 1;
    tracing::warn!("cache file {} rejected ({why}); recomputing", file.display());
    let _ = std::fs::remove_file(file);
}

/// The key of a visibility field of a mesh at some parameters.
pub(crate) fn field_key(kind: &str, mesh_key: u64, params: &[usize]) -> u64 {
    params
        .iter()
        .fold(
            KeyHasher::default().str(kind).u64(mesh_key).u64(CACHE_VERSION).u64(rsl_vis::store::VERSION.into()),
            |h, &p| h.u64(p as u64),
        )
        .finish()
}

/// A progress callback: `(done, total)`.
pub(crate) type Report<'p> = dyn Fn(usize, usize) + Sync + 'p;

/// How to read, check, build, measure and write one kind of visibility field.
pub(crate) struct FieldIo<'a, T> {
    /// File name prefix (`<prefix>-<key>.bin`).
    pub(crate) prefix: &'static str,
    pub(crate) load: fn(&Path, u64) -> Result<T, FieldFileError>,
    pub(crate) save: fn(&T, u64, &Path) -> Result<(), FieldFileError>,
    /// Whether a loaded field fits what is asked for (and why not).
    pub(crate) check: &'a dyn Fn(&T) -> Result<(), &'static str>,
    /// Builds the field, reporting `(done, total)`.
    pub(crate) build: &'a dyn Fn(&Report<'_>) -> Result<T>,
    /// Bytes the field holds.
    pub(crate) bytes: fn(&T) -> usize,
    /// The timing stage its builds count in.
    pub(crate) stage: &'static str,
    /// What the progress report says while building.
    pub(crate) message: String,
}

pub(crate) fn field_vertices(f: &Svdf) -> usize {
    match f {
        Svdf::Convex { vertices } => *vertices,
        Svdf::Field { cpca, .. } => cpca.assignment.len(),
    }
}

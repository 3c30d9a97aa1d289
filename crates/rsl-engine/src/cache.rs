//! The disk side of the precomputation cache, and the content keys every cached item is
//! found by: a hash of its inputs, its parameters and a format version (never an address or
//! debug text). In memory, prepared data lives in the engine's [`crate::store::Store`].
//!
//! On disk, visibility fields use rsl-vis's checksummed format (`svdf-<key>.bin`,
//! `ovdf-<key>.bin`) and RSL sets this module's (`rsl-<key>.bin`): magic, version, payload
//! length, FNV-1a 64 checksum, the content key the data was built for, little-endian
//! payload. A stale, truncated or corrupt file, or one built for another key (copied over
//! another's name), is reported, removed and recomputed, never used. Files are written
//! atomically.
//!
//! Transport lobes (the lobe path's, `tlobe-<key>.bin`) are framed the same way around
//! [`rsl_lobe::TransportLobes::to_payload`]'s bytes: their fit takes seconds per thousand
//! vertices (about 22 s per 10,000 on 2 cores), reading them back milliseconds.
//!
//! BRDF tables are held in memory only: they build in milliseconds (rsl-brdf's README),
//! about as fast as reading their summed-area tables back from disk.
//!
//! The folder is bounded ([`trim`]): once rsl's files in it take more than the limit
//! (`$RSL_CACHE_MAX_MB`, else [`DEFAULT_MAX_MB`]), the least recently used are removed
//! after each write, never one this process has read or written, and never a file rsl
//! did not name. A file read from the cache counts as used now (its modification time is
//! set to the time it was read, where the folder is writable).

use glam::Vec3;
use rsl_env::Rsl;
use rsl_sphere::framed::{self, FrameError};
use std::path::{Path, PathBuf};

/// Environment variable naming the cache folder.
pub const CACHE_ENV: &str = "RSL_CACHE_DIR";

/// The default cache folder: `$RSL_CACHE_DIR`, else `$XDG_CACHE_HOME/rsl`, else
/// `$HOME/.cache/rsl`; `None` when none of them is set.
pub fn default_dir() -> Option<PathBuf> {
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    var(CACHE_ENV)
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("rsl")))
        .or_else(|| var("HOME").map(|d| d.join(".cache").join("rsl")))
}

/// Environment variable bounding the cache folder, in megabytes (0: no limit).
pub const MAX_ENV: &str = "RSL_CACHE_MAX_MB";

/// The cache folder's bound without [`MAX_ENV`]: 4 GiB (the default scene's files at every
/// preset, with the lobe path's transport lobes, take about 200 MB).
pub const DEFAULT_MAX_MB: u64 = 4096;

/// The cache folder's bound in bytes from [`MAX_ENV`] (megabytes of 2²⁰ bytes, fractions
/// allowed; `u64::MAX` for 0: no limit), else [`DEFAULT_MAX_MB`]; an error naming the
/// variable where it is not a number of megabytes.
pub fn max_bytes_from_env() -> anyhow::Result<u64> {
    match std::env::var(MAX_ENV) {
        Err(std::env::VarError::NotPresent) => Ok(DEFAULT_MAX_MB << 20),
        Ok(v) if v.trim().is_empty() => Ok(DEFAULT_MAX_MB << 20),
        Ok(v) => match v.trim().parse::<f64>() {
            Ok(0.0) => Ok(u64::MAX),
            // `as` saturates: a bound past 2⁶⁴ bytes is no bound.
            Ok(mb) if mb.is_finite() && mb > 0.0 => Ok((mb * f64::from(1u32 << 20)) as u64),
            _ => anyhow::bail!("{MAX_ENV}: expected the megabytes the cache folder may take (0: no limit), got `{v}`"),
        },
        Err(e) => anyhow::bail!("{MAX_ENV}: {e}"),
    }
}

/// The cache files this process has read or written: [`trim`] never removes them.
static USED: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Records that `path`, a cache file, was just read (or written): it counts as used now
/// (its modification time set to now, where the file is writable) and [`trim`] keeps it.
pub fn used(path: &Path) {
    if let Ok(f) = std::fs::File::options().append(true).open(path) {
        let _ = f.set_modified(std::time::SystemTime::now());
    }
    hold(path);
}

/// Adds `path` to the files [`trim`] keeps.
fn hold(path: &Path) {
    let mut held = USED.lock().unwrap_or_else(|e| e.into_inner());
    if !held.iter().any(|p| p == path) {
        held.push(path.to_path_buf());
    }
}

/// Whether `name` is one of rsl's cache files: `<kind>-<16 hex digits>.bin` for the kinds
/// it writes (`rsl`, `svdf`, `ovdf`, `tlobe`, `auto`).
pub fn is_cache_file(name: &str) -> bool {
    let Some(stem) = name.strip_suffix(".bin") else { return false };
    let Some((kind, key)) = stem.split_once('-') else { return false };
    ["rsl", "svdf", "ovdf", "tlobe", "auto"].contains(&kind)
        && key.len() == 16
        && key.bytes().all(|b| b.is_ascii_hexdigit())
}

/// Bytes in the megabytes of [`MAX_ENV`] (2²⁰ bytes).
pub fn mb(bytes: u64) -> f64 {
    bytes as f64 / f64::from(1u32 << 20)
}

/// How many of rsl's files cache folder `dir` holds, and their bytes.
pub fn usage(dir: &Path) -> std::io::Result<(usize, u64)> {
    let files = rsl_files(dir)?;
    Ok((files.len(), files.iter().map(|f| f.2).sum()))
}

/// rsl's files in cache folder `dir` ([`is_cache_file`]; plain files only), each with its
/// modification time and length.
fn rsl_files(dir: &Path) -> std::io::Result<Vec<(std::time::SystemTime, PathBuf, u64)>> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        if entry.file_name().to_str().is_some_and(is_cache_file)
            && let Ok(meta) = entry.metadata()
            && meta.is_file()
        {
            files.push((meta.modified().unwrap_or(std::time::UNIX_EPOCH), entry.path(), meta.len()));
        }
    }
    Ok(files)
}

/// What [`trim`] found and did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Trimmed {
    /// Files removed.
    pub removed: usize,
    /// Their bytes.
    pub removed_bytes: u64,
    /// Bytes of rsl's files left in the folder.
    pub left_bytes: u64,
}

/// Removes rsl's least recently used files from cache folder `dir` (oldest modification
/// first) until those left take at most `max` bytes; the files this process used
/// ([`used`]) are kept whatever their age, and no other file in the folder is touched.
pub fn trim(dir: &Path, max: u64) -> std::io::Result<Trimmed> {
    let mut files = rsl_files(dir)?;
    let total = files.iter().map(|f| f.2).sum();
    let mut out = Trimmed { left_bytes: total, ..Trimmed::default() };
    if total <= max {
        return Ok(out);
    }
    files.sort();
    let held = USED.lock().unwrap_or_else(|e| e.into_inner()).clone();
    for (_, path, len) in files {
        if out.left_bytes <= max {
            break;
        }
        if held.iter().any(|p| p == &path) {
            continue;
        }
        if std::fs::remove_file(&path).is_ok() {
            out.removed += 1;
            out.removed_bytes += len;
            out.left_bytes -= len;
        }
    }
    Ok(out)
}

/// Whether [`stored`] said that the files in use exceed the bound (said once a process).
static OVER: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Records that `path` was just written into the cache (kept by [`trim`], as [`used`]; its
/// modification time is already now) and keeps its folder
/// within `max` bytes ([`trim`]), saying what was removed, or that the files in use alone
/// exceed the bound.
pub fn stored(path: &Path, max: u64) {
    hold(path);
    let Some(dir) = path.parent() else { return };
    match trim(dir, max) {
        Ok(t) if t.removed > 0 => tracing::warn!(
            "cache {}: removed the {} least recently used file(s) ({:.1} MB) to stay within {} MB (${MAX_ENV})",
            dir.display(),
            t.removed,
            mb(t.removed_bytes),
            max >> 20
        ),
        Ok(t) if t.left_bytes > max && !OVER.swap(true, std::sync::atomic::Ordering::Relaxed) => tracing::warn!(
            "cache {}: the files this run uses take {:.1} MB, more than its {} MB bound (${MAX_ENV}); kept",
            dir.display(),
            mb(t.left_bytes),
            max >> 20
        ),
        Ok(_) => {}
        Err(e) => tracing::warn!("cache {}: cannot list it to bound its size: {e}", dir.display()),
    }
}

/// How lookups went since the engine started (tables, fields, light sets).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CacheStats {
    /// Found in memory.
    pub memory_hits: u64,
    /// Read from disk.
    pub disk_hits: u64,
    /// Not found: computed.
    pub misses: u64,
    /// Disk files rejected (stale, truncated, corrupt) and recomputed.
    pub rejected: u64,
}

impl CacheStats {
    /// Memory and disk hits.
    pub fn hits(&self) -> u64 {
        self.memory_hits + self.disk_hits
    }
}

pub use rsl_sphere::key::KeyHasher;

/// The content key of a mesh: its positions, normals, tangents and triangles, bit for bit.
pub fn mesh_key(mesh: &rsl_sphere::mesh::TriMesh) -> u64 {
    let bits = |v: &[glam::Vec3]| v.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<u32>>();
    let mut h = KeyHasher::default().str("mesh").words(&bits(&mesh.positions)).words(&bits(&mesh.normals));
    if let Some(t) = &mesh.tangents {
        h = h.str("tangents").words(&t.iter().flat_map(|t| t.to_array().map(f32::to_bits)).collect::<Vec<u32>>());
    }
    h.words(&mesh.indices).finish()
}

/// Magic number of an RSL-set file.
pub const RSL_MAGIC: [u8; 8] = *b"RSLLIGHT";
/// Version of the RSL-set file format.
pub const RSL_VERSION: u32 = 3;
/// Serialises an RSL set (environment space, before intensity) built for content key `key`,
/// in the frame every cache file shares ([`rsl_sphere::framed`]).
pub fn rsls_to_bytes(rsls: &[Rsl], key: u64) -> Vec<u8> {
    let mut payload = Vec::with_capacity(4 + rsls.len() * 28);
    payload.extend_from_slice(&(rsls.len() as u32).to_le_bytes());
    for r in rsls {
        for v in [r.centre.x, r.centre.y, r.centre.z, r.half_diagonal, r.intensity.x, r.intensity.y, r.intensity.z] {
            payload.extend_from_slice(&v.to_le_bytes());
        }
    }
    framed::frame(&RSL_MAGIC, RSL_VERSION, key, &payload)
}

/// Reads an RSL set written by [`rsls_to_bytes`] for `key`, verifying everything.
pub fn rsls_from_bytes(b: &[u8], key: u64) -> Result<Vec<Rsl>, String> {
    let payload = framed::unframe(&RSL_MAGIC, RSL_VERSION, key, b).map_err(|e| match e {
        FrameError::BadMagic => "not an rsl light set (bad magic number)".to_string(),
        e => format!("light set file: {e}"),
    })?;
    if payload.len() < 4 {
        return Err(format!("light set file is malformed: {} payload bytes, no light count", payload.len()));
    }
    let count = u32::from_le_bytes(payload[..4].try_into().expect("4 bytes")) as usize;
    if payload.len() as u64 != 4 + count as u64 * 28 {
        return Err(format!("light set file is malformed: {count} lights in {} bytes", payload.len()));
    }
    let f = |k: usize| f32::from_le_bytes(payload[k..k + 4].try_into().expect("4 bytes"));
    let rsls: Vec<Rsl> = (0..count)
        .map(|i| {
            let o = 4 + i * 28;
            Rsl {
                centre: Vec3::new(f(o), f(o + 4), f(o + 8)),
                half_diagonal: f(o + 12),
                intensity: Vec3::new(f(o + 16), f(o + 20), f(o + 24)),
            }
        })
        .collect();
    if rsls.iter().any(|r| !r.centre.is_finite() || !r.half_diagonal.is_finite() || !r.intensity.is_finite()) {
        return Err("light set file is malformed: non-finite values".into());
    }
    Ok(rsls)
}

/// Magic number of a transport-lobe file.
pub const TRANSPORT_MAGIC: [u8; 8] = *b"RSLTLOBE";
/// Version of the transport-lobe file format, and of what the engine fits them against (the
/// self-visibility: rays from each vertex lifted along its normal, times the face mask).
pub const TRANSPORT_VERSION: u32 = 1;

/// Serialises one object's transport lobes fitted for content key `key`.
pub fn transport_to_bytes(t: &rsl_lobe::TransportLobes, key: u64) -> Vec<u8> {
    framed::frame(&TRANSPORT_MAGIC, TRANSPORT_VERSION, key, &t.to_payload())
}

/// Reads transport lobes written by [`transport_to_bytes`] for `key`, verifying everything.
pub fn transport_from_bytes(b: &[u8], key: u64) -> Result<rsl_lobe::TransportLobes, String> {
    let payload = framed::unframe(&TRANSPORT_MAGIC, TRANSPORT_VERSION, key, b).map_err(|e| match e {
        FrameError::BadMagic => "not an rsl transport-lobe file (bad magic number)".to_string(),
        e => format!("transport-lobe file: {e}"),
    })?;
    rsl_lobe::TransportLobes::from_payload(payload).map_err(|e| format!("transport-lobe file is malformed: {e}"))
}

/// Writes `bytes` atomically into the cache (temporary file, then rename), creating the
/// cache folder if needed.
pub fn write(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)
            .map_err(|e| anyhow::anyhow!("cannot create cache folder {}: {e}", dir.display()))?;
    }
    crate::output::write_atomic(path, bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn light_sets_round_trip_and_damage_is_detected() {
        let rsls = vec![
            Rsl { centre: Vec3::Y, half_diagonal: 0.1, intensity: Vec3::new(1.0, 2.0, 3.0) },
            Rsl { centre: Vec3::X, half_diagonal: 0.5, intensity: Vec3::splat(20_000.0) },
        ];
        let b = rsls_to_bytes(&rsls, 42);
        assert_eq!(rsls_from_bytes(&b, 42).unwrap(), rsls);
        assert!(rsls_from_bytes(&b, 43).unwrap_err().contains("built for key"));
        let mut flipped = b.clone();
        flipped[44] ^= 1;
        assert!(rsls_from_bytes(&flipped, 42).unwrap_err().contains("checksum"));
        assert!(rsls_from_bytes(&b[..b.len() - 3], 42).unwrap_err().contains("truncated"));
        assert!(rsls_from_bytes(&b[..20], 42).unwrap_err().contains("truncated"));
        let mut foreign = b.clone();
        foreign[0] = b'X';
        assert!(rsls_from_bytes(&foreign, 42).unwrap_err().contains("magic"));
        let mut future = b;
        future[8] = 9;
        assert!(rsls_from_bytes(&future, 42).unwrap_err().contains("version"));
        // A well-formed header over an empty payload (its checksum right) is an error, not a
        // panic, so the engine rejects and removes the file.
        let empty = framed::frame(&RSL_MAGIC, RSL_VERSION, 42, &[]);
        assert!(rsls_from_bytes(&empty, 42).unwrap_err().contains("no light count"));
    }

    /// The bound removes rsl's files oldest first until the rest fit, keeps the ones this
    /// process used whatever their age, and touches nothing it did not name; a file read
    /// counts as used now.
    #[test]
    fn trimming_removes_the_least_recently_used_files_alone() {
        let dir = std::env::temp_dir().join(format!("rsl-trim-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let epoch = std::time::UNIX_EPOCH;
        let put = |name: &str, bytes: usize, age_s: u64| {
            let p = dir.join(name);
            std::fs::write(&p, vec![7u8; bytes]).unwrap();
            let f = std::fs::File::options().append(true).open(&p).unwrap();
            f.set_modified(epoch + std::time::Duration::from_secs(1_000_000 - age_s)).unwrap();
            p
        };
        let oldest = put("svdf-00000000000000a1.bin", 400, 50);
        let older = put("ovdf-00000000000000a2.bin", 300, 40);
        let kept_old = put("tlobe-00000000000000a3.bin", 500, 60);
        let newer = put("rsl-00000000000000a4.bin", 200, 10);
        let read_now = put("auto-00000000000000a5.bin", 100, 90);
        // Not rsl's: another kind, a key of another length, another extension.
        let foreign =
            [put("notes.txt", 5000, 99), put("svdf-xyz.bin", 5000, 99), put("mesh-00000000000000a6.bin", 5000, 99)];
        used(&kept_old);
        used(&read_now);
        assert!(read_now.metadata().unwrap().modified().unwrap() > epoch + std::time::Duration::from_secs(1_000_000));
        // 1,500 bytes of rsl's files against a bound of 900: the oldest two not used go.
        let t = trim(&dir, 900).unwrap();
        assert_eq!(t, Trimmed { removed: 2, removed_bytes: 700, left_bytes: 800 });
        assert!(!oldest.exists() && !older.exists());
        assert!(kept_old.exists() && newer.exists() && read_now.exists());
        assert!(foreign.iter().all(|f| f.exists()), "a file rsl did not name was removed");
        // Within the bound nothing goes; below what is in use, only what is not.
        assert_eq!(trim(&dir, 800).unwrap().removed, 0);
        let t = trim(&dir, 100).unwrap();
        assert_eq!((t.removed, t.left_bytes), (1, 600), "{t:?}");
        assert!(!newer.exists() && kept_old.exists() && read_now.exists());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn cache_file_names_are_rsls_own() {
        assert!(is_cache_file("tlobe-5b354dbbdda3371a.bin"));
        assert!(is_cache_file("rsl-ee88869d63d1867c.bin"));
        for name in [
            "tlobe-5b354dbbdda3371a.bin.tmp",
            "svdf-5b354dbbdda3371.bin",
            "svdf-5b354dbbdda3371g.bin",
            "x-5b354dbbdda3371a.bin",
            "svdf5b354dbbdda3371a.bin",
        ] {
            assert!(!is_cache_file(name), "{name}");
        }
    }

    #[test]
    fn keys_see_every_part() {
        let a = KeyHasher::default().str("ab").str("c").finish();
        let b = KeyHasher::default().str("a").str("bc").finish();
        assert_ne!(a, b);
        assert_ne!(KeyHasher::default().f32s(&[0.0]).finish(), KeyHasher::default().f32s(&[-0.0]).finish());
        let w = |v: &[u32]| KeyHasher::default().words(v).finish();
        assert_ne!(w(&[1, 2]), w(&[2, 1]));
        assert_ne!(w(&[0]), w(&[0, 0]), "lengths count");
        assert_ne!(w(&[1 << 31]), w(&[1 << 30]), "high bits count");
    }
}

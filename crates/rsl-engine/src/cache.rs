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

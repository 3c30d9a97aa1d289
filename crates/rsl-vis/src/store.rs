//! The on-disk form of visibility fields (SVDF and OVDF) (docs/conventions.md,
//! Precomputation cache), in the frame every cache file shares ([`rsl_sphere::framed`]): a
//! magic number, a format version, the payload's length, an FNV-1a 64 checksum and the
//! content key the field was built for, then the little-endian payload. A wrong magic, an unknown version, a short file, a checksum mismatch or another
//! key (a file copied over another's name) is an error, never a half-read or foreign field.
//! Files are read only when regular and within [`rsl_sphere::io::MAX_DATA_BYTES`]. Saving
//! writes a temporary file and renames it.

use crate::cpca::Cpca;
use crate::svdf::{CompressionReport, Svdf};
use std::path::Path;

/// File magic of a self-visibility field.
pub const SVDF_MAGIC: [u8; 8] = *b"RSLSVDF\0";
/// File magic of an occluder field.
pub const OVDF_MAGIC: [u8; 8] = *b"RSLOVDF\0";
/// Current format version.
pub const VERSION: u32 = 3;

/// Why a field file was rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FieldFileError {
    /// Not a field file of this kind.
    #[error("not an rsl visibility field (bad magic number)")]
    BadMagic,
    /// Written by another format version.
    #[error("field format version {found}, this build reads version {VERSION}")]
    Version {
        /// Version in the file.
        found: u32,
    },
    /// Shorter (or longer) than its header says.
    #[error("field file is truncated or padded: {got} bytes, expected {expected}")]
    Length {
        /// Bytes expected.
        expected: u64,
        /// Bytes present.
        got: u64,
    },
    /// The payload does not match its checksum.
    #[error("field file is corrupt (checksum mismatch)")]
    Checksum,
    /// Built for another content key.
    #[error("field file was built for key {found:016x}, not {expected:016x} (copied over another's name?)")]
    Key {
        /// The key asked for.
        expected: u64,
        /// The key in the file.
        found: u64,
    },
    /// The payload is internally inconsistent.
    #[error("field file is malformed: {0}")]
    Malformed(String),
    /// Reading or writing failed.
    #[error("{0}")]
    Io(String),
}

use rsl_sphere::framed::FrameError;
pub use rsl_sphere::framed::fnv1a64;

impl From<FrameError> for FieldFileError {
    fn from(e: FrameError) -> Self {
        match e {
            FrameError::BadMagic => FieldFileError::BadMagic,
            FrameError::Version { found, .. } => FieldFileError::Version { found },
            FrameError::Length { expected, got } => FieldFileError::Length { expected, got },
            FrameError::Checksum => FieldFileError::Checksum,
            FrameError::Key { expected, found } => FieldFileError::Key { expected, found },
        }
    }
}

struct Writer(Vec<u8>);

impl Writer {
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32s(&mut self, v: &[f32]) {
        for x in v {
            self.0.extend_from_slice(&x.to_le_bytes());
        }
    }
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], FieldFileError> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.b.len())
            .ok_or_else(|| FieldFileError::Malformed("payload ends early".into()))?;
        let s = &self.b[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn u32(&mut self) -> Result<u32, FieldFileError> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }
    fn f32s(&mut self, n: usize) -> Result<Vec<f32>, FieldFileError> {
        let bytes = self.take(n.checked_mul(4).ok_or_else(|| FieldFileError::Malformed("size overflow".into()))?)?;
        Ok(bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes"))).collect())
    }
}

/// Serialises a field built for content key `key`.
pub fn svdf_to_bytes(f: &Svdf, key: u64) -> Vec<u8> {
    let mut w = Writer(Vec::new());
    match f {
        Svdf::Convex { vertices } => {
            w.u32(0);
            w.u32(*vertices as u32);
        }
        Svdf::Field { n, cpca, report } => {
            w.u32(1);
            w.u32(*n as u32);
            write_cpca(&mut w, cpca);
            for v in [report.vectors, report.raw_bytes, report.bytes_f32, report.bytes_f16] {
                w.u32(v as u32);
            }
            w.f32s(&[
                report.rms_distance_error,
                report.rms_coverage_error,
                report.rms_distance_error_f16,
                report.rms_coverage_error_f16,
            ]);
        }
    }
    frame(&SVDF_MAGIC, key, w.0)
}

/// The framed file ([`rsl_sphere::framed`]) of a field's payload.
fn frame(magic: &[u8; 8], key: u64, payload: Vec<u8>) -> Vec<u8> {
    rsl_sphere::framed::frame(magic, VERSION, key, &payload)
}

/// Checks the header, checksum and key; returns the payload.
fn unframe<'a>(magic: &[u8; 8], key: u64, b: &'a [u8]) -> Result<&'a [u8], FieldFileError> {
    Ok(rsl_sphere::framed::unframe(magic, VERSION, key, b)?)
}

fn write_cpca(w: &mut Writer, c: &Cpca) {
    for v in [c.d, c.k, c.clusters(), c.assignment.len()] {
        w.u32(v as u32);
    }
    for m in &c.means {
        w.f32s(m);
    }
    for b in &c.bases {
        w.f32s(b);
    }
    for &a in &c.assignment {
        w.u32(a);
    }
    w.u32(u32::from(c.f16));
    if c.f16 {
        for &x in &c.coeffs {
            w.0.extend_from_slice(&half::f16::from_f32(x).to_bits().to_le_bytes());
        }
    } else {
        w.f32s(&c.coeffs);
    }
}

fn read_cpca(r: &mut Reader) -> Result<Cpca, FieldFileError> {
    let [d, k, clusters, vectors] = [r.u32()?, r.u32()?, r.u32()?, r.u32()?].map(|v| v as usize);
    if d == 0 || clusters == 0 {
        return Err(FieldFileError::Malformed(format!("vectors of {d} in {clusters} clusters")));
    }
    let means = (0..clusters).map(|_| r.f32s(d)).collect::<Result<Vec<_>, _>>()?;
    let bases = (0..clusters).map(|_| r.f32s(k * d)).collect::<Result<Vec<_>, _>>()?;
    let assignment = (0..vectors).map(|_| r.u32()).collect::<Result<Vec<_>, _>>()?;
    if let Some(&bad) = assignment.iter().find(|&&a| a as usize >= clusters) {
        return Err(FieldFileError::Malformed(format!("vector assigned to cluster {bad} of {clusters}")));
    }
    let f16 = match r.u32()? {
        0 => false,
        1 => true,
        other => return Err(FieldFileError::Malformed(format!("coefficient precision flag {other}"))),
    };
    let coeffs = if f16 {
        let bytes = r.take(
            vectors
                .checked_mul(k)
                .and_then(|v| v.checked_mul(2))
                .ok_or_else(|| FieldFileError::Malformed("size overflow".into()))?,
        )?;
        bytes.chunks_exact(2).map(|b| half::f16::from_bits(u16::from_le_bytes([b[0], b[1]])).to_f32()).collect()
    } else {
        r.f32s(vectors * k)?
    };
    Ok(Cpca { d, k, means, bases, assignment, coeffs, f16, rows: Vec::new(), coeff_lanes: Vec::new() }.with_lookup())
}

/// Serialises an occluder field.
pub fn ovdf_to_bytes(f: &crate::ovdf::Ovdf, key: u64) -> Vec<u8> {
    let mut w = Writer(Vec::new());
    let (c, r) = f.bounds();
    w.f32s(&[c.x, c.y, c.z, r]);
    let p = f.params();
    for v in [p.shells, p.m, p.n, p.supersample, p.vectors] {
        w.u32(v as u32);
    }
    for v in [f.raw_bytes, f.bytes_f32, f.bytes_f16] {
        w.u32(v as u32);
    }
    w.f32s(&[f.rms_distance_error, f.rms_coverage_error]);
    // A flat object's outline (0 corners for a sampled field), then the segments.
    let corners = f.flat().map_or(&[][..], |flat| flat.corners());
    w.u32(corners.len() as u32);
    if let Some(flat) = f.flat() {
        let n = flat.normal();
        w.f32s(&[n.x, n.y, n.z, flat.offset()]);
        for c in corners {
            w.f32s(&[c.x, c.y, c.z]);
        }
    }
    for s in f.segments() {
        write_cpca(&mut w, s);
    }
    frame(&OVDF_MAGIC, key, w.0)
}

/// Parses an occluder field, checking header, checksum and consistency.
pub fn ovdf_from_bytes(b: &[u8], key: u64) -> Result<crate::ovdf::Ovdf, FieldFileError> {
    let payload = unframe(&OVDF_MAGIC, key, b)?;
    let mut r = Reader { b: payload, at: 0 };
    let cr = r.f32s(4)?;
    let [shells, m, n, supersample, vectors] = [r.u32()?, r.u32()?, r.u32()?, r.u32()?, r.u32()?].map(|v| v as usize);
    let bytes = [r.u32()?, r.u32()?, r.u32()?].map(|v| v as usize);
    let errors: [f32; 2] = r.f32s(2)?.try_into().expect("two figures");
    if shells == 0 || shells > 4096 {
        return Err(FieldFileError::Malformed(format!("{shells} shells")));
    }
    let corners = r.u32()? as usize;
    if corners > crate::flat::MAX_CORNERS {
        return Err(FieldFileError::Malformed(format!("a flat outline of {corners} corners")));
    }
    let params = crate::ovdf::OvdfParams { shells, m, n, supersample, vectors };
    let centre = glam::Vec3::new(cr[0], cr[1], cr[2]);
    let v3 = |v: Vec<f32>| glam::Vec3::new(v[0], v[1], v[2]);
    let field = if corners > 0 {
        let plane = r.f32s(4)?;
        let outline = (0..corners).map(|_| r.f32s(3).map(v3)).collect::<Result<Vec<_>, _>>()?;
        crate::flat::Flat::from_parts(v3(plane.clone()), plane[3], outline)
            .and_then(|flat| crate::ovdf::Ovdf::from_flat(centre, cr[3], params, flat))
    } else {
        let segments = (0..shells * 24).map(|_| read_cpca(&mut r)).collect::<Result<Vec<_>, _>>()?;
        crate::ovdf::Ovdf::from_parts(centre, cr[3], params, segments, bytes, errors)
    };
    if r.at != payload.len() {
        return Err(FieldFileError::Malformed(format!("{} bytes after the field", payload.len() - r.at)));
    }
    field.map_err(FieldFileError::Malformed)
}

/// Parses a field, checking magic, version, length, checksum and consistency.
pub fn svdf_from_bytes(b: &[u8], key: u64) -> Result<Svdf, FieldFileError> {
    let payload = unframe(&SVDF_MAGIC, key, b)?;
    let mut r = Reader { b: payload, at: 0 };
    let field = match r.u32()? {
        0 => Svdf::Convex { vertices: r.u32()? as usize },
        1 => {
            let n = r.u32()? as usize;
            let cpca = read_cpca(&mut r)?;
            if cpca.d != n * n || n < 2 {
                return Err(FieldFileError::Malformed(format!("table {n}×{n} with vectors of {}", cpca.d)));
            }
            let [rv, raw, b32, b16] = [r.u32()?, r.u32()?, r.u32()?, r.u32()?].map(|v| v as usize);
            let e = r.f32s(4)?;
            let report = CompressionReport {
                vectors: rv,
                raw_bytes: raw,
                bytes_f32: b32,
                bytes_f16: b16,
                rms_distance_error: e[0],
                rms_coverage_error: e[1],
                rms_distance_error_f16: e[2],
                rms_coverage_error_f16: e[3],
            };
            Svdf::Field { n, cpca, report }
        }
        kind => return Err(FieldFileError::Malformed(format!("unknown field kind {kind}"))),
    };
    if r.at != payload.len() {
        return Err(FieldFileError::Malformed(format!("{} bytes after the field", payload.len() - r.at)));
    }
    Ok(field)
}

/// Writes a field built for `key` atomically (temporary file, then rename).
pub fn save_svdf(f: &Svdf, key: u64, path: &Path) -> Result<(), FieldFileError> {
    save_bytes(&svdf_to_bytes(f, key), path)
}

/// Writes an occluder field built for `key` atomically.
pub fn save_ovdf(f: &crate::ovdf::Ovdf, key: u64, path: &Path) -> Result<(), FieldFileError> {
    save_bytes(&ovdf_to_bytes(f, key), path)
}

/// Reads a field file's bytes: a regular file within the size limit.
fn read(path: &Path) -> Result<Vec<u8>, FieldFileError> {
    rsl_sphere::io::read_bounded(path, rsl_sphere::io::MAX_DATA_BYTES)
        .map_err(|e| FieldFileError::Io(format!("{}: {e}", path.display())))
}

/// Reads and verifies an occluder field file built for `key`.
pub fn load_ovdf(path: &Path, key: u64) -> Result<crate::ovdf::Ovdf, FieldFileError> {
    ovdf_from_bytes(&read(path)?, key)
}

fn save_bytes(bytes: &[u8], path: &Path) -> Result<(), FieldFileError> {
    rsl_sphere::io::write_atomic(path, bytes).map_err(|e| FieldFileError::Io(format!("{}: {e}", path.display())))
}

/// Reads and verifies a field file built for `key`.
pub fn load_svdf(path: &Path, key: u64) -> Result<Svdf, FieldFileError> {
    svdf_from_bytes(&read(path)?, key)
}

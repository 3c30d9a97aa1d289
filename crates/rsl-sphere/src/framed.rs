//! The one binary frame of every cache file (visibility fields, light sets, the bench's
//! truth; docs/conventions.md, Precomputation cache): an 8-byte magic number naming the
//! kind, a `u32` format version, the payload's length (`u64`), its FNV-1a 64 checksum, and
//! the content key it was built for, all little-endian, then the payload. A wrong magic,
//! another version, a short or padded file, a checksum mismatch or another key (a file
//! copied over another's name) is an error, never a half-read or foreign payload.

/// Bytes before the payload: magic, version, length, checksum, key.
pub const HEADER: usize = 8 + 4 + 8 + 8 + 8;

/// FNV-1a, 64 bits.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3))
}

/// Why a framed file was rejected (its kind is the caller's to name).
#[derive(Clone, Debug, thiserror::Error, PartialEq, Eq)]
pub enum FrameError {
    /// Not a file of this kind.
    #[error("bad magic number")]
    BadMagic,
    /// Written by another format version.
    #[error("format version {found}, this build reads version {expected}")]
    Version {
        /// Version in the file.
        found: u32,
        /// Version this build reads.
        expected: u32,
    },
    /// Shorter or longer than its header says.
    #[error("truncated or padded: {got} bytes, expected {expected}")]
    Length {
        /// Bytes expected.
        expected: u64,
        /// Bytes present.
        got: u64,
    },
    /// The payload does not match its checksum.
    #[error("corrupt (checksum mismatch)")]
    Checksum,
    /// Built for another content key.
    #[error("built for key {found:016x}, not {expected:016x} (copied over another's name?)")]
    Key {
        /// The key asked for.
        expected: u64,
        /// The key in the file.
        found: u64,
    },
}

/// `payload` framed as a file of kind `magic`, format `version`, built for `key`.
pub fn frame(magic: &[u8; 8], version: u32, key: u64, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER + payload.len());
    out.extend_from_slice(magic);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&fnv1a64(payload).to_le_bytes());
    out.extend_from_slice(&key.to_le_bytes());
    out.extend_from_slice(payload);
    out
}

/// The payload of `bytes`, once its magic, version, length, checksum and key are checked.
pub fn unframe<'a>(magic: &[u8; 8], version: u32, key: u64, bytes: &'a [u8]) -> Result<&'a [u8], FrameError> {
    if bytes.len() < 8 || &bytes[..8] != magic {
        return Err(FrameError::BadMagic);
    }
    if bytes.len() < HEADER {
        return Err(FrameError::Length { expected: HEADER as u64, got: bytes.len() as u64 });
    }
    let word = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"));
    let found = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if found != version {
        return Err(FrameError::Version { found, expected: version });
    }
    let expected = (HEADER as u64).saturating_add(word(12));
    if bytes.len() as u64 != expected {
        return Err(FrameError::Length { expected, got: bytes.len() as u64 });
    }
    let payload = &bytes[HEADER..];
    if fnv1a64(payload) != word(20) {
        return Err(FrameError::Checksum);
    }
    if word(28) != key {
        return Err(FrameError::Key { expected: key, found: word(28) });
    }
    Ok(payload)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAGIC: [u8; 8] = *b"RSLTEST\0";

    #[test]
    fn a_frame_round_trips_and_every_damage_is_named() {
        let b = frame(&MAGIC, 2, 42, b"payload");
        assert_eq!(b.len(), HEADER + 7);
        assert_eq!(unframe(&MAGIC, 2, 42, &b), Ok(&b"payload"[..]));
        assert_eq!(unframe(b"RSLOTHER", 2, 42, &b), Err(FrameError::BadMagic));
        assert_eq!(unframe(&MAGIC, 3, 42, &b), Err(FrameError::Version { found: 2, expected: 3 }));
        assert_eq!(unframe(&MAGIC, 2, 43, &b), Err(FrameError::Key { expected: 43, found: 42 }));
        assert_eq!(
            unframe(&MAGIC, 2, 42, &b[..b.len() - 1]),
            Err(FrameError::Length { expected: (HEADER + 7) as u64, got: (HEADER + 6) as u64 })
        );
        assert!(matches!(unframe(&MAGIC, 2, 42, &b[..20]), Err(FrameError::Length { .. })));
        for at in HEADER..b.len() {
            let mut bad = b.clone();
            bad[at] ^= 0x10;
            assert_eq!(unframe(&MAGIC, 2, 42, &bad), Err(FrameError::Checksum), "byte {at}");
        }
        // The FNV-1a 64 of "a" (its published test vector).
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
    }
}

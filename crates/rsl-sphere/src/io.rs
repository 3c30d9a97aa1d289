//! Reading input files with bounds: regular files only (a device, FIFO or socket would
//! block or never end), no larger than a stated limit, read in one go.

use std::io::Read;
use std::path::{Path, PathBuf};

/// The largest scene file read, bytes.
pub const MAX_SCENE_BYTES: u64 = 16 << 20;
/// The largest mesh, image or cache file read, bytes.
pub const MAX_DATA_BYTES: u64 = 4 << 30;

/// Why a file could not be read.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ReadError {
    /// Nothing at the path.
    #[error("file not found")]
    NotFound,
    /// A folder where a file was expected.
    #[error("is a folder, not a file")]
    Folder,
    /// A device, FIFO or socket.
    #[error("is not a regular file (a device, FIFO or socket cannot be read as input)")]
    NotRegular,
    /// Larger than the limit.
    #[error("is {size} bytes, more than the limit of {limit} bytes")]
    TooLarge {
        /// Bytes in the file (at least).
        size: u64,
        /// The limit.
        limit: u64,
    },
    /// Any other failure, as the system says it (a symbolic-link loop, permissions).
    #[error("{0}")]
    Io(String),
}

/// Checks that `path` names a regular file (following symbolic links) of at most `limit`
/// bytes, and returns its size.
pub fn check_regular(path: &Path, limit: u64) -> Result<u64, ReadError> {
    let meta = std::fs::metadata(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => ReadError::NotFound,
        _ => ReadError::Io(e.to_string()),
    })?;
    if meta.is_dir() {
        return Err(ReadError::Folder);
    }
    if !meta.is_file() {
        return Err(ReadError::NotRegular);
    }
    if meta.len() > limit {
        return Err(ReadError::TooLarge { size: meta.len(), limit });
    }
    Ok(meta.len())
}

/// Reads a regular file of at most `limit` bytes (one that grows past it while being read is
/// an error too).
pub fn read_bounded(path: &Path, limit: u64) -> Result<Vec<u8>, ReadError> {
    let size = check_regular(path, limit)?;
    let file = std::fs::File::open(path).map_err(|e| ReadError::Io(e.to_string()))?;
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(limit.saturating_add(1)).read_to_end(&mut bytes).map_err(|e| ReadError::Io(e.to_string()))?;
    if bytes.len() as u64 > limit {
        return Err(ReadError::TooLarge { size: bytes.len() as u64, limit });
    }
    Ok(bytes)
}

/// [`read_bounded`] as UTF-8 text.
pub fn read_text_bounded(path: &Path, limit: u64) -> Result<String, ReadError> {
    String::from_utf8(read_bounded(path, limit)?).map_err(|e| ReadError::Io(format!("not UTF-8 text: {e}")))
}

/// The temporary file [`write_atomic`] writes `path` through: hidden, beside it (so the
/// rename stays on one file system), named by this process (so two writers never share one).
pub fn temporary(path: &Path) -> std::io::Result<PathBuf> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().ok_or_else(|| std::io::Error::other("not a file path"))?;
    Ok(dir.join(format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id())))
}

/// Writes `bytes` to `path` whole or not at all: into [`temporary`], then renamed over it. On
/// any error the temporary file is removed and `path` is untouched.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = temporary(path)?;
    let result = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_regular_files_within_the_limit_are_read() {
        let dir = crate::scratch::Scratch::new("io");
        let f = dir.join("ten");
        std::fs::write(&f, b"0123456789").unwrap();
        assert_eq!(read_bounded(&f, 10).unwrap(), b"0123456789");
        assert_eq!(read_bounded(&f, 9), Err(ReadError::TooLarge { size: 10, limit: 9 }));
        assert_eq!(read_bounded(&dir, 10), Err(ReadError::Folder));
        assert_eq!(read_bounded(&dir.join("none"), 10), Err(ReadError::NotFound));
        #[cfg(unix)]
        {
            assert_eq!(read_bounded(Path::new("/dev/zero"), 10), Err(ReadError::NotRegular));
            let a = dir.join("loop-a");
            let b = dir.join("loop-b");
            let _ = std::os::unix::fs::symlink(&b, &a);
            let _ = std::os::unix::fs::symlink(&a, &b);
            let e = read_bounded(&a, 10).unwrap_err();
            assert!(matches!(e, ReadError::Io(ref m) if m.contains("symbolic links")), "{e}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_atomic_write_replaces_the_file_whole_and_a_failed_one_leaves_it_and_no_temporary() {
        let dir = crate::scratch::Scratch::new("sphere-atomic");
        let f = dir.join("a.txt");
        write_atomic(&f, b"old").unwrap();
        write_atomic(&f, b"new").unwrap();
        assert_eq!(std::fs::read(&f).unwrap(), b"new");
        // A folder where the temporary file goes: the write fails, the file is untouched.
        std::fs::create_dir_all(temporary(&f).unwrap()).unwrap();
        assert!(write_atomic(&f, b"lost").is_err());
        assert_eq!(std::fs::read(&f).unwrap(), b"new");
        std::fs::remove_dir_all(temporary(&f).unwrap()).unwrap();
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, ["a.txt"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

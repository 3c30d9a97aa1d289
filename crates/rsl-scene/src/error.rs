//! Scene errors that say which file, where in it, which field, and what is wrong.

use std::fmt;
use std::path::{Path, PathBuf};

/// An error in a scene file or in a file it refers to.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    /// The scene file (or the mesh file, for mesh errors).
    pub file: PathBuf,
    /// 1-based line and column, where the TOML parser knows them.
    pub location: Option<(usize, usize)>,
    /// The field, as a path like `objects[1] "bunny".rotation.axis`.
    pub field: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl SceneError {
    /// An error about a field of `file`.
    pub fn field(file: &Path, field: impl Into<String>, message: impl Into<String>) -> Self {
        Self { file: file.to_path_buf(), location: None, field: Some(field.into()), message: message.into() }
    }

    /// An error about `file` as a whole.
    pub fn file(file: &Path, message: impl Into<String>) -> Self {
        Self { file: file.to_path_buf(), location: None, field: None, message: message.into() }
    }

    /// A TOML error, located by the byte span the parser reports.
    pub fn toml(file: &Path, source: &str, err: &toml::de::Error) -> Self {
        let location = err.span().map(|s| line_col(source, s.start));
        Self { file: file.to_path_buf(), location, field: None, message: err.message().trim().to_string() }
    }
}

/// 1-based line and column (in characters) of a byte offset.
fn line_col(source: &str, offset: usize) -> (usize, usize) {
    let before = &source[..offset.min(source.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some((l, c)) = self.location {
            write!(f, ":{l}:{c}")?;
        }
        write!(f, ": ")?;
        if let Some(field) = &self.field {
            write!(f, "{field}: ")?;
        }
        write!(f, "{}", self.message)
    }
}

impl std::error::Error for SceneError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column_are_one_based() {
        assert_eq!(line_col("ab\ncd", 0), (1, 1));
        assert_eq!(line_col("ab\ncd", 4), (2, 2));
        assert_eq!(line_col("é\nx", 3), (2, 1));
    }
}

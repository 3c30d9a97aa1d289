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
        let field = err.span().and_then(|s| field_at(source, s.start));
        Self { file: file.to_path_buf(), location, field, message: err.message().trim().to_string() }
    }
}

/// The TOML path of the value at byte `offset` (`objects[1].primitive.radius`), from the
/// table header above it and the keys before it on its line; `None` where it cannot be told
/// (a value spread over several lines, a syntax error before any key).
fn field_at(source: &str, offset: usize) -> Option<String> {
    let offset = offset.min(source.len());
    let line_start = source[..offset].rfind('\n').map_or(0, |k| k + 1);
    // The table: the last header line above, with an index for arrays of tables.
    let mut table: Vec<String> = Vec::new();
    let mut counts: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    for line in source[..line_start].lines() {
        let t = line.trim();
        if let Some(name) = t.strip_prefix("[[").and_then(|r| r.split("]]").next()) {
            let name = name.trim().to_string();
            let n = counts.entry(name.clone()).or_insert(0);
            table = vec![format!("{name}[{}]", *n)];
            *n += 1;
        } else if let Some(name) = t.strip_prefix('[').and_then(|r| r.split(']').next()) {
            table = vec![name.trim().to_string()];
        }
    }
    // The keys on the line: each `key =` whose value encloses the offset (inline tables).
    let before = &source[line_start..offset];
    let mut keys: Vec<String> = Vec::new();
    let mut depth_keys: Vec<usize> = Vec::new();
    let mut word = String::new();
    let mut last_key: Option<String> = None;
    let mut in_string = false;
    for c in before.chars() {
        if in_string {
            in_string = c != '"';
            continue;
        }
        match c {
            '"' => in_string = true,
            '=' => {
                last_key = Some(word.trim().to_string()).filter(|w| !w.is_empty());
                word.clear();
            }
            '{' => {
                if let Some(k) = last_key.take() {
                    keys.push(k);
                    depth_keys.push(keys.len());
                }
                word.clear();
            }
            '}' => {
                if let Some(n) = depth_keys.pop() {
                    keys.truncate(n - 1);
                }
                word.clear();
            }
            ',' => word.clear(),
            _ => word.push(c),
        }
    }
    let key = last_key?;
    keys.push(key);
    let path: Vec<String> = table.into_iter().chain(keys).collect();
    Some(path.join("."))
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
    fn a_type_error_names_its_toml_path() {
        let text = "quality = \"draft\"\n[environment]\nrsl_count = \"thirty\"\n[[objects]]\nname = \"a\"\n\
                    [[objects]]\nname = \"b\"\nprimitive = { kind = \"sphere\", radius = \"big\" }\n";
        let at = |needle: &str| field_at(text, text.find(needle).unwrap());
        assert_eq!(at("\"thirty\"").as_deref(), Some("environment.rsl_count"));
        assert_eq!(at("\"big\"").as_deref(), Some("objects[1].primitive.radius"));
        assert_eq!(at("\"draft\"").as_deref(), Some("quality"));
        let e = toml::from_str::<toml::Table>("x = [1, 2,").unwrap_err();
        let _ = SceneError::toml(Path::new("s.toml"), "x = [1, 2,", &e);
    }

    #[test]
    fn line_and_column_are_one_based() {
        assert_eq!(line_col("ab\ncd", 0), (1, 1));
        assert_eq!(line_col("ab\ncd", 4), (2, 2));
        assert_eq!(line_col("é\nx", 3), (2, 1));
    }
}

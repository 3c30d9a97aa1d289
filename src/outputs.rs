//! The one check of a command's output files before any work: each can be written (its
//! folder exists, nothing is in the way), no two name the same file, and none names one of
//! the command's inputs (rsl never writes over what it reads).

use anyhow::{Result, bail};
use std::path::{Path, PathBuf};

/// A command's outputs, each with the option that names it, checked against its inputs.
#[derive(Default)]
pub struct Outputs<'a> {
    outputs: Vec<(&'a Path, String)>,
    inputs: Vec<(&'a Path, String)>,
}

impl<'a> Outputs<'a> {
    /// No outputs, no inputs.
    pub fn new() -> Self {
        Self::default()
    }

    /// An output file, named by `what` in errors (`--out`, "the animation's GIF").
    pub fn output(mut self, path: &'a Path, what: impl Into<String>) -> Self {
        self.outputs.push((path, what.into()));
        self
    }

    /// An input file, described by `what` in errors ("the scene's environment map").
    pub fn input(mut self, path: &'a Path, what: impl Into<String>) -> Self {
        self.inputs.push((path, what.into()));
        self
    }

    /// A scene's files as inputs: the scene file, its environment map and its meshes.
    pub fn scene(mut self, scene: &'a rsl_engine::scene::Scene) -> Self {
        for (k, path) in scene.input_files().into_iter().enumerate() {
            let what = match k {
                0 => "the scene file".to_string(),
                _ => format!("a file the scene {} reads", scene.path.display()),
            };
            self.inputs.push((path, what));
        }
        self
    }

    /// Fails with the option and the file at fault unless every output can be written, no
    /// two outputs are one file, and no output is an input.
    pub fn check(&self) -> Result<()> {
        for (path, what) in &self.outputs {
            crate::render::check_writable(path, what)?;
        }
        let outputs: Vec<PathBuf> = self.outputs.iter().map(|(p, _)| identity(p)).collect();
        let inputs: Vec<PathBuf> = self.inputs.iter().map(|(p, _)| identity(p)).collect();
        for (k, ((path, what), me)) in self.outputs.iter().zip(&outputs).enumerate() {
            if let Some(j) = outputs[..k].iter().position(|o| o == me) {
                bail!("{} and {what} both name {}: one would overwrite the other", self.outputs[j].1, path.display());
            }
            if let Some(j) = inputs.iter().position(|i| i == me) {
                bail!("{what} {} is {}: rsl does not write over its inputs", path.display(), self.inputs[j].1);
            }
        }
        Ok(())
    }
}

/// The file a path names, as far as it can be told without creating it: the canonical path
/// of an existing file, else the canonical folder joined with the file's name.
fn identity(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    match (dir.canonicalize(), path.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => path.to_path_buf(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_over_an_input_or_another_output_is_refused_by_name() {
        let dir = std::env::temp_dir().join(format!("rsl-outputs-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let map = dir.join("map.exr");
        std::fs::write(&map, b"input").unwrap();
        // The same file by another spelling.
        let again = dir.join("sub/../map.exr");
        let err = Outputs::new().input(&map, "the map").output(&again, "--json").check().unwrap_err();
        assert!(format!("{err:#}").contains("--json") && format!("{err:#}").contains("is the map"), "{err:#}");
        let (a, b) = (dir.join("f.png"), dir.join("./f.png"));
        let err = Outputs::new().output(&a, "--png").output(&b, "--json").check().unwrap_err();
        assert!(format!("{err:#}").contains("--png and --json both name"), "{err:#}");
        Outputs::new()
            .input(&map, "the map")
            .output(&a, "--png")
            .output(&dir.join("f.json"), "--json")
            .check()
            .unwrap();
        assert_eq!(std::fs::read(&map).unwrap(), b"input");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

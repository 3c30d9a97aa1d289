//! The shader registry: the only way WGSL is loaded, by the runtime and by the tests alike.
//!
//! A shader is its stage file with the `shaders/common/` files it uses prepended, in order;
//! [`Shader::source`] gives that composed text.

/// One registered shader.
#[derive(Clone, Copy, Debug)]
pub struct Shader {
    /// Registry name, also the pipeline label.
    pub name: &'static str,
    /// The stage file, relative to `shaders/`.
    pub path: &'static str,
    /// `(path, text)` of the common files it uses, in order.
    pub common: &'static [(&'static str, &'static str)],
    /// The stage file's text.
    pub text: &'static str,
    /// The compute entry point.
    pub entry_point: &'static str,
}

impl Shader {
    /// The composed WGSL: common files, then the stage file.
    pub fn source(&self) -> String {
        let mut s = String::new();
        for (path, text) in self.common {
            s.push_str(&format!("// ---- shaders/{path}\n{text}\n"));
        }
        s.push_str(&format!("// ---- shaders/{}\n{}", self.path, self.text));
        s
    }
}

const HEMI: (&str, &str) = ("common/hemi.wgsl", include_str!("../../../shaders/common/hemi.wgsl"));

/// GPU smoke test: the hemisphere map and its inverse over an array of directions.
pub const HEMI_MAP: Shader = Shader {
    name: "smoke/hemi_map",
    path: "smoke/hemi_map.wgsl",
    common: &[HEMI],
    text: include_str!("../../../shaders/smoke/hemi_map.wgsl"),
    entry_point: "main",
};

/// Every registered shader.
pub const ALL: &[Shader] = &[HEMI_MAP];

/// Looks a shader up by name.
pub fn by_name(name: &str) -> Option<&'static Shader> {
    ALL.iter().find(|s| s.name == name)
}

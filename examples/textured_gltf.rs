//! Writes a textured glTF scene (`textured.glb`: a checker floor and a textured metal cube,
//! with a camera; `rsl_scene::build::write_textured_sample`) into a folder, to open with
//! `rsl render` or `rsl view`:
//!
//! ```text
//! cargo run --release --example textured_gltf -- out/
//! rsl render out/textured.glb --out textured.png
//! ```

use anyhow::{Context, Result};

fn main() -> Result<()> {
    let dir = std::env::args().nth(1).unwrap_or_else(|| ".".into());
    let dir = std::path::Path::new(&dir);
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let path =
        rsl_scene::build::write_textured_sample(dir).with_context(|| format!("cannot write into {}", dir.display()))?;
    println!("{}", path.display());
    Ok(())
}

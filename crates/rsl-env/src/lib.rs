//! Environment maps and their decomposition into rotatable square lights (Xu et al. 2006,
//! §4.1).
//!
//! - [`load`]: lat-long OpenEXR and Radiance `.hdr` maps, validated.
//! - [`cube_env`]: resampling onto a `6×R×R` cube grid that integrates texel footprints.
//! - [`fit`]: fitting one region with an RSL ⟨c, r, I⟩ (§4.1.1, eq. 7).
//! - [`decompose`]: bottom-up merging into a merge tree with every region count (§4.1.2).
//! - [`visualise`]: the paper's figure 6 as a PNG: map, region borders, fitted squares.
//!
//! Units (docs/conventions.md, Rotatable square lights): an RSL's square has solid angle `4r²`, and `I·4r² = ∫_S L dω` per
//! channel exactly.

pub mod cube_env;
pub mod decompose;
pub mod fit;
pub mod load;
pub mod visualise;

pub use cube_env::CubeEnv;
pub use decompose::{Decomposition, LevelError, Rsl, RslInfo};
pub use load::{BUNDLED_NAMES, EnvError, LoadedMap, decode_latlong, load_bundled, load_latlong};

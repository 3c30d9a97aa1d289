//! The Gaussian / von Mises-Fisher lobe path (Green et al. 2006; Laurijssen & Dutré 2009).
//!
//! Built so far: vMF lobes ([`vmf`]), the prefiltered environment they are rendered with
//! ([`prefilter`]), material lobes fitted per view ([`material`]) and both as flat tables for
//! a GPU draw pass ([`packed`]). The hybrid with RSL visibility is `rsl_engine::lobe`.
//! Transport lobes (Green's method) and occluder fields over lobes are not built.

pub mod material;
pub mod packed;
pub mod prefilter;
pub mod vmf;

pub use material::{FitParams, MaterialLobes, WeightedLobe};
pub use packed::{PackedEnvironment, PackedLevel, PackedLobe, PackedMaterial};
pub use prefilter::{PrefilterParams, Prefiltered};
pub use vmf::Vmf;

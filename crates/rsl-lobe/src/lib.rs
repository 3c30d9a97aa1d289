//! The Gaussian / von Mises-Fisher lobe path (Green et al. 2006; Laurijssen & Dutré 2009).
//!
//! Built so far: vMF lobes ([`vmf`]), the prefiltered environment they are rendered with
//! ([`prefilter`]) and material lobes fitted per view ([`material`]). Transport lobes, shadows,
//! the hybrid with RSL visibility and the engine's `lobe` method are not built yet.

pub mod material;
pub mod prefilter;
pub mod vmf;

pub use material::{FitParams, MaterialLobes, WeightedLobe};
pub use prefilter::{PrefilterParams, Prefiltered};
pub use vmf::Vmf;

//! The Gaussian / von Mises-Fisher lobe path (Green et al. 2006; Laurijssen & Dutré 2009).
//!
//! vMF lobes ([`vmf`]), the prefiltered environment they are rendered with ([`prefilter`]),
//! material lobes fitted per view ([`material`]), transport lobes per vertex and view with
//! the object's own shadows (Green's method, [`transport`]), and the environment and
//! material lobes as flat tables for a GPU draw pass ([`packed`]). The methods that render
//! with them (the hybrid with RSL visibility, and the lobes shadowed by the fields) are
//! `rsl_engine::lobe`.

pub mod material;
pub mod packed;
pub mod prefilter;
pub mod transport;
pub mod vmf;

pub use material::{FitParams, MaterialLobes, SPECULAR_LOBES, SpecularLobes, WeightedLobe, view_amplitude};
pub use packed::{PackedEnvironment, PackedLevel, PackedLobe, PackedMaterial};
pub use prefilter::{PrefilterParams, Prefiltered};
pub use transport::{TransportLobes, TransportParams};
pub use vmf::Vmf;

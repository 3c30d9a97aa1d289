//! Visibility (Xu et al. 2006, §4.3): shadow rays on a BVH, visibility maps on the hemisphere
//! grid, visibility distance tables (VDT) by an exact Euclidean distance transform, the
//! coverage of a rotatable square from one VDT lookup, and summed-area-table visibility.
//!
//! The self-visibility field (SVDF, [`svdf`]) is compressed with clustered PCA ([`cpca`]).
//! The occluder field (OVDF, [`ovdf`]) is compressed with PCA per segment.
//!
//! `unsafe` is confined to the lookups' vector kernels (AVX2/FMA, detected at run time):
//! calling them, and reading CPCA rows without bounds checks after a per-vector check that
//! every cell index the bilinear taps can form is in range. Field lookups are a large part
//! of a frame's time.

pub mod coverage;
pub mod cpca;
pub mod edt;
pub mod flat;
pub mod map;
pub mod mask;
pub mod ovdf;
pub mod rays;
pub mod store;
pub mod svdf;

pub use coverage::coverage;
pub use flat::Flat;
pub use map::{Vdt, VisibilityMap};
pub use mask::{FaceMask, VertexMask};
pub use ovdf::{Ovdf, OvdfLookup, OvdfParams, OvdfPoint};
pub use rays::{Occluder, VisError};
pub use svdf::{CompressionReport, Svdf, SvdfParams, SvdfVertex};

//! BRDF models, their tables on the hemisphere grid and summed-area tables (Xu et al. 2006,
//! §4.2).
//!
//! BRDF data lives apart from objects: swapping a material or dragging its parameters only
//! rebuilds its table ([`BrdfTable::build`]). The tabulated quantity is `ρ·cos θ` (docs/conventions.md, BRDF tables);
//! a square's integral is returned with its average over the square and its solid angle.
//!
//! `unsafe` is confined to `table`'s vector kernels (AVX2/FMA, detected at run
//! time): calling them, and reading the padded summed-area tables without bounds checks,
//! where every index is below the table's length by construction and the length is
//! asserted per call. Square lookups are most of a frame's time.

pub mod cosine;
pub mod exact;
pub mod model;
pub mod sample;
pub mod table;

pub use exact::{square_exact, square_exact_at};
pub use model::{Brdf, ParamError};
pub use table::{BrdfTable, Resolution, SquareIntegral, ViewLookup, Views};

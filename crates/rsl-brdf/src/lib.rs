//! BRDF models, tables on the hemisphere grid and summed-area tables (Xu et al. 2006, §4.2).
//!
//! Not built yet: this crate is filled by the BRDF work.

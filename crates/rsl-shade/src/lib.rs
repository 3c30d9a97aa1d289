//! CPU frame shading (the multiple product approximation, Xu et al. 2006 eq. 5) and the CPU
//! rasteriser.
//!
//! Not built yet: this crate is filled by the CPU shading work.

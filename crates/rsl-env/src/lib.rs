//! Environment maps and their decomposition into rotatable square lights (Xu et al. 2006, §4.1).
//!
//! Not built yet: this crate is filled by the environment-decomposition work.

//! The Gaussian / von Mises-Fisher lobe comparison path (Green et al. 2006; Laurijssen &
//! Dutré 2009).
//!
//! Not built yet.

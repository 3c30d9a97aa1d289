//! Visibility maps, visibility distance tables, SVDF and OVDF (Xu et al. 2006, §4.3, §5.1).
//!
//! Not built yet: this crate is filled by the visibility work.

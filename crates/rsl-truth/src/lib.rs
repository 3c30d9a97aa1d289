//! Monte Carlo ground truth and error metrics.
//!
//! Not built yet: this crate is filled by the ground-truth work.

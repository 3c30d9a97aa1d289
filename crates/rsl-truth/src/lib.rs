//! Monte Carlo ground truth for every frame, and error metrics.
//!
//! [`estimate`] estimates exactly the quantity the RSL path approximates — direct lighting
//! from the environment with shadows from every object at its current transform, no
//! interreflection — per vertex (the RSL path's vertices, shading frames and views) and
//! per pixel, with multiple importance sampling of the environment and the BRDF and a
//! standard error per estimate. [`metrics`] compares results (relative L2, RMSE, max,
//! PSNR) and draws error heatmaps.

pub mod estimate;
pub mod metrics;

pub use estimate::{
    EnvLight, Estimate, GatherView, MAX_BOUNCES, MAX_SPP, PixelFilter, SurfaceHit, TruthError, TruthObject, TruthScene,
    TruthStats,
};
pub use metrics::{CompareError, Metrics, compare};

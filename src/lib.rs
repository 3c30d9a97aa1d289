//! rsl: all-frequency environment lighting of dynamic scenes with rotatable square lights
//! and the multiple product approximation (Xu et al. 2006).
//!
//! The root package holds the engine (scene → prepared data → frame) and the `rsl`
//! command-line tool; the stages live in the `rsl-*` crates (see ARCHITECTURE.md).

pub mod cache;
pub mod cli;
pub mod compare;
pub mod decompose;
pub mod engine;
pub mod gpu;
pub mod output;
pub mod ply;
pub mod render;
pub mod truth;

pub use engine::{Engine, EngineOptions, ShadedFrame};
pub use gpu::GpuRenderer;
pub use rsl_env as env;
pub use rsl_scene as scene;
pub use rsl_sphere as sphere;

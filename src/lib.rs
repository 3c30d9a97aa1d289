//! rsl: all-frequency environment lighting of dynamic scenes with rotatable square lights
//! and the multiple product approximation (Xu et al. 2006).
//!
//! The root package is the `rsl` command line only: argument parsing, progress bars and
//! printing over `rsl-engine`, which holds the engine, the methods and the outputs (see
//! ARCHITECTURE.md); and the entry points fuzzing drives ([`fuzzing`]).

pub mod bench;
pub mod cli;
pub mod compare;
pub mod decompose;
pub mod fuzzing;
pub mod outputs;
pub mod progress;
pub mod render;
pub mod view;

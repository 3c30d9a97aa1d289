//! rsl-engine: scene → prepared scene → frames, as a library under every front end (the
//! `rsl` command line, the viewer, the benchmark).
//!
//! - [`Engine`] prepares a scene in two layers of content-keyed data (method-neutral, and
//!   per method), from a memory store with a byte budget and a checksummed disk cache.
//! - [`Method`] is the one renderer interface: [`CpuRsl`], [`GpuRsl`] and [`Truth`] each turn
//!   the prepared scene and a [`Request`] into a [`Frame`]; [`registry`] names every method
//!   and builds it.
//! - [`bounce`] adds interreflections (the quality knob `bounces`) to every method that is
//!   not a Monte Carlo estimate.
//! - [`Session`] draws frames of any method with only what changed since its last frame
//!   drawn again, and runs methods' preparation on a worker thread (the viewer's loop).
//! - [`Progress`] and [`Timings`] are the one way long work reports itself and what stages
//!   cost; nothing here draws on the terminal.
//! - [`output`] writes result files atomically, [`ply`] the per-vertex export.

mod auto;
pub mod bounce;
pub mod cache;
pub mod compose;
pub mod engine;
mod field_io;
pub mod gpu;
pub mod lobe;
pub mod method;
pub mod options;
pub mod output;
pub mod ply;
pub mod progress;
pub mod registry;
pub mod session;
pub mod store;
pub mod textured;
pub mod truth;
pub mod wavelet;

pub use engine::{Engine, EngineOptions, Layers, ShadedFrame};
pub use gpu::GpuRenderer;
pub use method::{Changes, CpuRsl, CpuRslPixels, Frame, GpuRsl, Method, Request, Truth};
pub use progress::{Event, Progress, Timings};
pub use registry::{Capabilities, Device, ErrorModel, Incremental, MethodId, MethodOptions, Registration};
pub use rsl_env as env;
pub use rsl_scene as scene;
pub use rsl_sphere as sphere;
pub use session::{Rendered, Session};

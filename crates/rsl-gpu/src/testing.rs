//! The one entry point GPU tests use to get a device.
//!
//! Without an adapter a test prints `skipped: no adapter` and returns early; under
//! `RSL_REQUIRE_GPU=1` (as in CI) it fails instead, so GPU tests can never be skipped
//! silently.

use crate::GpuContext;
use std::io::Write;

/// Whether `RSL_REQUIRE_GPU=1` is set.
pub fn gpu_required() -> bool {
    std::env::var("RSL_REQUIRE_GPU").is_ok_and(|v| v.trim() == "1")
}

/// A GPU context for test `test`, or `None` (after printing why) when there is no adapter.
/// Panics when there is none and [`gpu_required`] is true. The message goes straight to
/// stderr so the test harness's capture does not hide it.
pub fn context_or_skip(test: &str) -> Option<GpuContext> {
    match GpuContext::new() {
        Ok(ctx) => {
            let _ = writeln!(std::io::stderr(), "{test}: adapter {}", ctx.describe());
            Some(ctx)
        }
        Err(e) if gpu_required() => panic!("{test}: RSL_REQUIRE_GPU=1 but no GPU device: {e}"),
        Err(e) => {
            let _ = writeln!(std::io::stderr(), "{test}: skipped: no adapter ({e})");
            None
        }
    }
}

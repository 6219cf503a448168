//! GPU test support: get a [`GpuContext`] or skip loudly.
//!
//! Without an adapter a GPU test prints one `SKIPPED (no GPU adapter): ...` line and passes,
//! unless `DIFFSIL_REQUIRE_GPU=1` (CI sets it), in which case it fails. The adapter comes from
//! `DIFFSIL_ADAPTER` / `WGPU_BACKEND` (see `GpuOptions::from_env`); on a machine with Mesa's
//! lavapipe, `WGPU_BACKEND=vulkan` selects it.

#![allow(dead_code)]

use std::io::Write as _;
use std::sync::Once;

use diffsil::gpu::{GpuContext, GpuOptions};
use diffsil::Error;

static LOG_ADAPTER: Once = Once::new();

/// Whether `DIFFSIL_REQUIRE_GPU=1`: GPU tests must not skip.
pub fn gpu_required() -> bool {
    std::env::var("DIFFSIL_REQUIRE_GPU").is_ok_and(|v| v.trim() == "1")
}

/// A fresh GPU context for the test `test_name`, or `None` (after one loud stderr line) when
/// there is no adapter. Panics when there is no adapter and `DIFFSIL_REQUIRE_GPU=1`, and when an
/// adapter exists but opening a device on it fails (a broken setup is not a reason to skip).
pub fn gpu_or_skip(test_name: &str) -> Option<GpuContext> {
    match GpuContext::new(&GpuOptions::from_env()) {
        Ok(ctx) => {
            LOG_ADAPTER.call_once(|| loud(&format!("GPU tests run on: {}", ctx.adapter())));
            Some(ctx)
        }
        Err(error @ Error::NoAdapter(_)) => {
            if gpu_required() {
                panic!("{test_name}: DIFFSIL_REQUIRE_GPU=1 but there is no usable GPU adapter: {error}");
            }
            loud(&format!("SKIPPED (no GPU adapter): {test_name} — set DIFFSIL_REQUIRE_GPU=1 to make this fail"));
            None
        }
        Err(error) => panic!("{test_name}: a GPU adapter exists but could not be opened: {error}"),
    }
}

/// Writes one line straight to the process's stderr: unlike `eprintln!`, this is not captured by
/// the test harness, so it shows in a plain `cargo test` run.
fn loud(line: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

//! The GPU backend: WGSL compute stages on any adapter wgpu supports.
//!
//! Use it through [`crate::Renderer::with_backend`] with [`crate::Backend::Gpu`] (or
//! [`crate::Backend::Auto`]); the same `render` / `backward` calls then run the stages of
//! [`stages`] (one WGSL file per CPU stage, all views of a frame in one dispatch each, one
//! submission per forward and one per backward; `Renderer::squared_error_step` runs forward,
//! loss and backward in one submission). Screen-space input gives images bit-identical
//! to the CPU backend's and gradients equal to ~1e-7 relative (`tests/gpu/vs_cpu.rs`).
//!
//! This module holds the plumbing the stages share, one concern per file:
//! - `adapter.rs`: adapter selection ([`GpuOptions`], [`AdapterChoice`], `DIFFSIL_ADAPTER`,
//!   `WGPU_BACKEND`) and [`AdapterReport`]; `context.rs`: [`GpuContext`], the device (kept for
//!   the next context when its context is dropped, not destroyed), error scopes, pipelines,
//!   submission and 1D dispatches; `alloc.rs`: buffer creation;
//!   `readback.rs`: [`Readback`] and staging reads.
//! - The shaders: every file under `shaders/` is validated by naga when the crate is built and
//!   embedded in it ([`SHADERS`]); `//!include` directives are resolved by [`shader`], the same
//!   code at build and run time. [`WORKGROUP_SIZES`] reflects each entry point's workgroup size
//!   and [`BINDINGS`] the buffers it binds.
//! - The engine: [`stages`] (the stage table), `pipelines.rs`, `buffers.rs` (topology and frame
//!   buffers, sizing), [`bindings`] (bind groups by reflected variable name), `record.rs`
//!   (passes, dispatches and the recording of a submission), `forward.rs`, `backward.rs`,
//!   `backend.rs` (the backend's state) and `engine.rs` (the `Engine` interface).
//!
//! Every wgpu error becomes [`crate::Error::Gpu`]; a missing adapter is
//! [`crate::Error::NoAdapter`]; a device limit that is too small is [`crate::Error::GpuLimit`].
//!
//! ## Exactness
//! - Coverage is bit-exact: vertices are snapped with the CPU's f32 arithmetic reproduced in
//!   integers (`shaders/shared/exact.wgsl`, immune to the FMA fusion WGSL cannot forbid), edge
//!   functions are exact integers (32-bit when a triangle's box spans at most 2^14 units, else
//!   64-bit emulated on `vec2<u32>`, `shaders/shared/int64.wgsl`).
//! - Face orientations and candidate edges are the signs the CPU's f64 cross products have,
//!   reproduced exactly (software f64 rounding of the few operations involved).
//! - `edge_grad` runs in float-float arithmetic (`shaders/shared/ff.wgsl`, ~44 bits) where the
//!   CPU uses f64, so long edges keep their per-pixel accuracy.
//! - Nothing uses float atomics: every float result is written by one invocation and summed in
//!   a fixed order, so runs are bit-identical. Where the lanes of a workgroup gather a pixel's
//!   occlusion intervals in whatever order they find them (`edge_grad`), they sort them before
//!   the one lane that merges them sums the gaps.
//!
//! ## llvmpipe (lavapipe)
//! Mesa's software rasterizer ends all loops of a shader invocation after 65,535 iterations in
//! total, silently. The stages keep their invocations short (tiles sized from the triangle
//! density, large triangles listed per view, long edges cut into parts of 4 to 16 pixels) and
//! count their iterations; a frame that would still exceed the limit there (thousands of
//! triangles in one pixel) is an [`crate::Error::GpuLimit`] on llvmpipe, never a wrong result.
//! Hardware GPUs have no such limit.
//!
//! ## 1D dispatches beyond 65,535 workgroups
//! A dimension of a dispatch holds at most `max_compute_workgroups_per_dimension` (65,535 by
//! default) workgroups. [`GpuContext::dispatch_1d`] launches `n` workgroups as the grid
//! [`workgroup_grid`] returns, and the shader recovers its linear index with
//! `linear_invocation_index` from `shaders/shared/dispatch.wgsl` (row-major:
//! `workgroup_id.x + workgroup_id.y * num_workgroups.x`), bounds-checking it against its
//! element count because the grid may have a few workgroups too many.

mod adapter;
mod alloc;
mod backend;
mod backward;
pub mod bindings;
mod buffers;
mod context;
mod engine;
mod forward;
mod pipelines;
mod profile;
mod readback;
mod record;
pub mod shader;
pub mod stages;

pub use adapter::{hardware_gpu_available, AdapterChoice, AdapterReport, GpuOptions, SOFTWARE_ADAPTER_MAX_SAMPLES};
#[doc(hidden)]
pub use context::dispatch_1d_with_limit;
pub use context::GpuContext;
pub(crate) use engine::GpuEngine;
pub(crate) use profile::StageTimer;
pub use profile::StageTiming;
pub use readback::Readback;

use crate::{Error, Result};

mod embedded {
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

pub use embedded::{BINDINGS, SHADERS, WORKGROUP_SIZES};

/// The text of the embedded shader `name` (a path under `shaders/`, e.g. `"smoke.wgsl"`) with its
/// `//!include` directives resolved: exactly what [`GpuContext::compute_pipeline`] compiles.
pub fn shader_source(name: &str) -> Result<String> {
    shader::resolve(SHADERS, name).map(|r| r.source).map_err(|e| Error::Gpu(e.to_string()))
}

/// The `@workgroup_size` of compute entry point `entry_point` in shader `shader`, as reflected at
/// build time; `None` if there is no such entry point or its size is an override expression.
pub fn workgroup_size(shader: &str, entry_point: &str) -> Option<[u32; 3]> {
    WORKGROUP_SIZES.iter().find(|(s, e, _)| *s == shader && *e == entry_point).map(|(_, _, size)| *size)
}

/// The grid `[x, y, 1]` that launches at least `workgroups` workgroups with no dimension above
/// `max_per_dimension`: `y = ceil(workgroups / max_per_dimension)`, `x = ceil(workgroups / y)`,
/// so `x * y - workgroups < y` workgroups are surplus (the shader bounds-checks them away).
/// `[0, 1, 1]` for no work. [`Error::GpuLimit`] when even `y` would exceed the limit.
pub fn workgroup_grid(workgroups: u32, max_per_dimension: u32) -> Result<[u32; 3]> {
    if workgroups == 0 {
        return Ok([0, 1, 1]);
    }
    let limit_error = || Error::GpuLimit {
        limit: "max_compute_workgroups_per_dimension",
        needed: u64::from(workgroups),
        max: u64::from(max_per_dimension) * u64::from(max_per_dimension),
    };
    if max_per_dimension == 0 {
        return Err(limit_error());
    }
    let y = workgroups.div_ceil(max_per_dimension);
    if y > max_per_dimension {
        return Err(limit_error());
    }
    Ok([workgroups.div_ceil(y), y, 1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_covers_work_within_limits() {
        assert_eq!(workgroup_grid(0, 65_535).unwrap(), [0, 1, 1]);
        assert_eq!(workgroup_grid(1, 65_535).unwrap(), [1, 1, 1]);
        assert_eq!(workgroup_grid(65_535, 65_535).unwrap(), [65_535, 1, 1]);
        assert_eq!(workgroup_grid(65_536, 65_535).unwrap(), [32_768, 2, 1]);
        assert_eq!(workgroup_grid(3_125, 1_000).unwrap(), [782, 4, 1]);
        for (n, max) in [(1u32, 1u32), (7, 3), (90_000, 300), (89_999, 300), (65_535 * 65_535, 65_535)] {
            let [x, y, z] = workgroup_grid(n, max).unwrap();
            assert!(x <= max && y <= max && z == 1, "{n} {max}");
            let total = u64::from(x) * u64::from(y);
            assert!(total >= u64::from(n) && total - u64::from(n) < u64::from(y), "{n} {max}");
        }
        assert!(matches!(workgroup_grid(5, 2), Err(Error::GpuLimit { .. })));
        assert!(matches!(workgroup_grid(1, 0), Err(Error::GpuLimit { .. })));
    }

    #[test]
    fn embedded_shaders_resolve() {
        assert!(SHADERS.iter().any(|(name, _)| *name == "smoke.wgsl"));
        assert!(SHADERS.iter().any(|(name, _)| *name == "shared/dispatch.wgsl"));
        for (name, _) in SHADERS {
            let source = shader_source(name).unwrap();
            assert!(!source.lines().any(|l| l.trim_start().starts_with("//!include ")), "{name}");
        }
        assert!(shader_source("smoke.wgsl").unwrap().contains("fn linear_invocation_index"));
        assert_eq!(workgroup_size("smoke.wgsl", "main"), Some([64, 1, 1]));
        assert_eq!(workgroup_size("smoke.wgsl", "nope"), None);
        assert!(matches!(shader_source("nope.wgsl"), Err(Error::GpuLimit { .. }) | Err(Error::Gpu(_))));
    }
}

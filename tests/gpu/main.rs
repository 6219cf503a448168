//! The WGSL engine on wgpu (feature `gpu`): adapters and options, the shaders on every naga
//! backend, the WGSL twins' layouts and exact arithmetic, GPU against CPU, bad input on the GPU,
//! `squared_error_step` on the GPU, and the GPU golden hashes. `cargo test --test gpu`; on a
//! machine without an adapter set `DIFFSIL_REQUIRE_GPU=1` to make the tests fail instead of skip.

#[path = "../common/mod.rs"]
mod common;

mod backend;
mod bad_input;
mod batch;
mod clip;
#[path = "../cpu/clip_scenes.rs"]
mod clip_scenes;
mod coincident;
mod exact;
mod golden;
mod layout;
mod params;
mod shader_backends;
mod smoke;
mod step;
mod vs_cpu;

//! The CPU engine and everything around it that needs neither the `gpu` nor the `pose` feature:
//! forward and backward renders, gradients against finite differences and closed forms, the
//! exact-area oracle, losses, bad input, OBJ/PNG files, `squared_error_step`, and the CPU golden
//! hashes. `cargo test --test cpu`; the real meshes with `-- --include-ignored`.

#[path = "../common/mod.rs"]
mod common;

mod bad_input;
mod batch;
mod camera;
mod clip;
mod clip_scenes;
mod closed_form;
mod coincident;
mod forward;
mod golden;
mod gradients;
mod io;
mod loss;
mod oracle;
mod real_meshes;
mod step;

//! The examples' command lines and functions, one test binary: each module includes its example's
//! source with `#[path]` and calls its functions on small inputs.

// Each included example declares `mod common;` (examples/common), so this binary holds a copy
// per example; they never meet.
#![allow(clippy::duplicate_mod)]

#[path = "../common/mod.rs"]
mod common;

mod fit_object_pose;
mod fit_pose;
mod fit_pose_user_data;
mod gradient_maps;
mod render;

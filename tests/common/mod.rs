//! Helpers shared by the integration test binaries (`tests/cpu`, `tests/gpu`, `tests/pose`): each
//! `main.rs` declares `#[path = "../common/mod.rs"] mod common;`, and not every binary uses every
//! helper.

#![allow(dead_code)]

pub mod batch;
pub mod fd;
pub mod files;
pub mod fuzz;
pub mod golden;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod rng;
pub mod scenes;
pub mod step;

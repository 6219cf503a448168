//! Helpers shared by integration tests: `mod common;` in a test file.

pub mod fd;
pub mod gpu;
pub mod scenes;

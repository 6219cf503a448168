//! Skinning, the built-in figure, the self-intersection penalty, pose fitting and glTF/GLB files
//! (feature `pose`), and the pose fit's golden hash. `cargo test --test pose`; the Khronos sample
//! models with `DIFFSIL_ASSETS=... cargo test --test pose -- --include-ignored`.

#[path = "../common/mod.rs"]
mod common;

mod body;
mod figure;
mod fit;
mod gltf_io;
mod golden;
mod self_intersection;
mod skin;

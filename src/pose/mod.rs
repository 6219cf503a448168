//! From pose parameters to vertices and back, and fitting them to silhouettes (the paper's §4):
//! linear-blend skinning of glTF-style skeletons ([`skin`]), a built-in articulated figure
//! ([`figure`]), the self-intersection penalty ([`self_intersection`]) and the pose fit ([`fit`]).
//!
//! Needs the `pose` feature (on by default).

pub mod figure;
pub mod fit;
pub mod self_intersection;
pub mod skin;

//! From pose parameters to vertices and back, and fitting them to silhouettes (the paper's §4):
//! linear-blend skinning of glTF-style skeletons ([`skin`]), a built-in articulated figure
//! ([`figure`]), a real human body with shape targets ([`makehuman_body`]), the self-intersection
//! penalty ([`self_intersection`]) and the pose fit ([`fit`]).
//!
//! Needs the `pose` feature (on by default).

mod body;
pub mod figure;
pub mod fit;
pub mod self_intersection;
pub mod skin;

pub use body::{makehuman_body, MAKEHUMAN_BODY_GLB};

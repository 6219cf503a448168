//! Skinned meshes: a joint hierarchy, linear-blend skinning, and its analytic backward to the pose.
//!
//! The pose is a vector of parameters ([`Pose`]): per-joint axis–angle rotation offsets applied on
//! top of each joint's rest rotation, a global orientation (axis–angle) and a root translation.
//! Joint world transforms follow the hierarchy (parents before children):
//!
//! ```text
//! local_j  = T(t_j) · R(q_j) · R(θ_j) · S(s_j)              rest TRS with the offset θ_j inserted
//! G_root   = T(translation) · R(orientation) · P_root · local_root
//! G_j      = G_parent(j) · local_j
//! v_i      = Σ_k w_ik · G_{j_ik} · IBM_{j_ik} · v̂_i         (at most 4 influences per vertex)
//! ```
//!
//! where `P_root` is the world transform of the root joint's non-joint ancestors (glTF: the
//! transform of the node holding the skinned mesh is ignored, per the spec).

mod backward;
mod lbs;
mod morph;
mod pose;
mod rodrigues;
mod skeleton;
mod skinned;

pub use lbs::SkinCache;
pub use morph::MorphTargets;
pub use pose::Pose;
pub use rodrigues::{rodrigues, rodrigues_derivative, rodrigues_derivative_f64, rodrigues_f64};
pub use skeleton::{JointRest, Skeleton};
pub use skinned::{SkinnedMesh, WEIGHT_SUM_TOLERANCE};

//! Skinned meshes: a joint hierarchy, linear-blend skinning with shape, its analytic backward to
//! the pose and the shape, morph targets, and skeletal animation clips.
//!
//! The pose is a vector of parameters ([`Pose`]): per-joint axis–angle rotation offsets applied on
//! top of each joint's rest rotation, optional per-joint translation offsets `τ_j` added to the
//! rest translation, optional per-joint scale factors `σ_j` multiplying the rest scale, a global
//! orientation (axis–angle) and a root translation. The shape is a
//! vector `β` of morph-target coefficients ([`MorphTargets`]). Joint world transforms follow the
//! hierarchy (parents before children):
//!
//! ```text
//! local_j  = T(t_j + τ_j + s_j(β)) · R(q_j) · R(θ_j) · S(s_j ⊙ σ_j)   rest TRS, offsets inserted
//! G_root   = T(translation) · R(orientation) · P_root · local_root
//! G_j      = G_parent(j) · local_j
//! v_i      = Σ_k w_ik · G_{j_ik} · IBM_{j_ik} · T(−Δp_{j_ik}(β)) · (v̂_i + Σ_b β_b Δ_bi)
//! ```
//!
//! where `P_root` is the world transform of the root joint's non-joint ancestors (glTF: the
//! transform of the node holding the skinned mesh is ignored, per the spec), `Δp_j(β) = Σ_b β_b
//! o_bj` moves joint `j`'s rest world position when the mesh has joint offsets `o` (zero
//! otherwise), and `s_j(β)` is the local translation change that realises it (see
//! [`SkinnedMesh::skin_shaped_with_cache`]). With `β = 0`, no `τ` and no `σ` this is plain LBS.

mod animation;
mod backward;
mod json;
mod lbs;
mod morph;
mod pose;
mod rodrigues;
mod skeleton;
mod skinned;

pub use animation::{AnimatedNode, Animation, Channel, Interpolation, Property};
pub use json::POSE_JSON_FORMAT;
pub use lbs::SkinCache;
pub use morph::MorphTargets;
pub use pose::Pose;
pub use rodrigues::{rodrigues, rodrigues_derivative, rodrigues_derivative_f64, rodrigues_f64};
pub use skeleton::{JointRest, Skeleton};
pub use skinned::{SkinnedMesh, WEIGHT_SUM_TOLERANCE};

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

use glam::{Mat4, Quat, Vec3};

use crate::Mesh;

/// The rest transform of one joint relative to its parent, as glTF stores it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointRest {
    /// Translation.
    pub translation: Vec3,
    /// Rotation.
    pub rotation: Quat,
    /// Scale.
    pub scale: Vec3,
}

/// A joint hierarchy with its rest pose and inverse bind matrices.
#[derive(Clone, Debug, PartialEq)]
pub struct Skeleton {
    /// Joint names (may be empty strings).
    pub names: Vec<String>,
    /// Parent of each joint, `None` for a root. Parents come before their children.
    pub parents: Vec<Option<usize>>,
    /// Rest transform of each joint relative to its parent.
    pub rest: Vec<JointRest>,
    /// World transform of each root joint's non-joint ancestors (identity when none); ignored
    /// for joints with a parent.
    pub root_parent: Vec<Mat4>,
    /// Inverse bind matrix of each joint.
    pub inverse_bind: Vec<Mat4>,
}

/// A mesh bound to a skeleton: bind-pose vertices, up to four joint influences per vertex.
#[derive(Clone, Debug)]
pub struct SkinnedMesh {
    /// Bind-pose mesh (welded: silhouettes need one vertex per position).
    pub mesh: Mesh,
    /// The skeleton.
    pub skeleton: Skeleton,
    /// Joint indices of each vertex's influences.
    pub joints: Vec<[u16; 4]>,
    /// Weights of each vertex's influences (sum to 1).
    pub weights: Vec<[f32; 4]>,
}

/// Pose parameters: what the fitting optimises.
#[derive(Clone, Debug, PartialEq)]
pub struct Pose {
    /// Axis–angle rotation offset per joint (radians), applied after the rest rotation.
    pub joint_rotations: Vec<Vec3>,
    /// Global orientation, axis–angle (radians), about the world origin.
    pub orientation: Vec3,
    /// Root translation, world units.
    pub translation: Vec3,
}

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

use glam::{DMat3, DMat4, DVec3, DVec4, Mat3, Mat4, Quat, Vec3};
use rayon::prelude::*;

use crate::{Error, Mesh, Result};

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

/// How far a vertex's weights may sum from 1 before [`SkinnedMesh::new`] rejects them.
pub const WEIGHT_SUM_TOLERANCE: f32 = 1e-3;

/// How far a rest rotation's quaternion norm may be from 1 before [`Skeleton::validate`] rejects it.
const QUAT_NORM_TOLERANCE: f64 = 1e-2;

/// Vertices per block of the backward's per-joint sums. Blocks are summed in a fixed order, so
/// gradients do not depend on the number of threads.
const BLOCK: usize = 4096;

/// Below this many vertices the forward runs on one thread (rayon's overhead would dominate).
const PARALLEL_MIN_VERTICES: usize = 16_384;

impl JointRest {
    /// The identity transform: no translation, no rotation, unit scale.
    pub const IDENTITY: JointRest = JointRest { translation: Vec3::ZERO, rotation: Quat::IDENTITY, scale: Vec3::ONE };

    /// The rest transform as a matrix, `T(t) · R(q) · S(s)` (the quaternion is normalised first).
    pub fn to_mat4(&self) -> Mat4 {
        let (a, b) = self.factors();
        (a * b).as_mat4()
    }

    /// The two constant factors around the pose rotation, in f64: `A = T(t)·R(q)` and `B = S(s)`.
    fn factors(&self) -> (DMat4, DMat4) {
        let q = self.rotation.as_dquat().normalize();
        let a = DMat4::from_rotation_translation(q, self.translation.as_dvec3());
        (a, DMat4::from_scale(self.scale.as_dvec3()))
    }
}

impl Default for JointRest {
    fn default() -> Self {
        JointRest::IDENTITY
    }
}

impl Skeleton {
    /// Number of joints (the length of `parents`; every other per-joint vector must match it).
    pub fn joint_count(&self) -> usize {
        self.parents.len()
    }

    /// Checks the skeleton: at least one joint, every per-joint vector as long as `parents`, each
    /// parent index before its child, finite rest transforms with unit rotations (within 1e-2; they
    /// are normalised when used), finite root-parent and inverse bind matrices.
    pub fn validate(&self) -> Result<()> {
        let n = self.joint_count();
        if n == 0 {
            return Err(Error::InvalidSettings("the skeleton has no joints; a skin needs at least one".into()));
        }
        let lengths: [(&'static str, usize); 4] = [
            ("skeleton joint names (one per parent entry)", self.names.len()),
            ("skeleton rest transforms (one per joint)", self.rest.len()),
            ("skeleton root-parent matrices (one per joint)", self.root_parent.len()),
            ("skeleton inverse bind matrices (one per joint)", self.inverse_bind.len()),
        ];
        for (what, got) in lengths {
            if got != n {
                return Err(Error::LengthMismatch { what, expected: n, got });
            }
        }
        for (j, parent) in self.parents.iter().enumerate() {
            if let Some(p) = *parent {
                if p >= j {
                    return Err(Error::InvalidSettings(format!(
                        "skeleton: joint {j} has parent {p}, which does not come before it; order the joints \
                         so that every parent precedes its children"
                    )));
                }
            }
        }
        for (j, rest) in self.rest.iter().enumerate() {
            let finite = rest.translation.is_finite() && rest.rotation.is_finite() && rest.scale.is_finite();
            if !finite {
                return Err(Error::InvalidSettings(format!(
                    "skeleton: joint {j} has a non-finite rest transform {rest:?}; every value must be finite"
                )));
            }
            let norm = rest.rotation.as_dquat().length();
            if (norm - 1.0).abs() > QUAT_NORM_TOLERANCE {
                return Err(Error::InvalidSettings(format!(
                    "skeleton: joint {j} has a rest rotation quaternion of norm {norm}; it must be a unit quaternion"
                )));
            }
        }
        for (j, m) in self.root_parent.iter().enumerate() {
            if self.parents[j].is_none() && !m.is_finite() {
                return Err(Error::InvalidSettings(format!(
                    "skeleton: root joint {j} has a non-finite root-parent matrix; every value must be finite"
                )));
            }
        }
        for (j, m) in self.inverse_bind.iter().enumerate() {
            if !m.is_finite() {
                return Err(Error::InvalidSettings(format!(
                    "skeleton: joint {j} has a non-finite inverse bind matrix; every value must be finite"
                )));
            }
        }
        Ok(())
    }

    /// World transforms `G_j` of the joints at the rest pose (no offsets, no global orientation or
    /// translation). Their inverses are the inverse bind matrices under the glTF convention.
    pub fn rest_world_transforms(&self) -> Result<Vec<Mat4>> {
        self.validate()?;
        let joints = JointState::new(self, &Pose::rest(self.joint_count()));
        Ok(joints.global.iter().map(DMat4::as_mat4).collect())
    }

    /// Sets every inverse bind matrix to the inverse of the joint's rest world transform (the glTF
    /// convention: the bind pose is the rest pose), so that [`Pose::rest`] reproduces the mesh.
    pub fn set_inverse_bind_to_rest(&mut self) -> Result<()> {
        // Validate with placeholder IBMs if they are missing, then compute them.
        if self.inverse_bind.len() != self.joint_count() {
            self.inverse_bind = vec![Mat4::IDENTITY; self.joint_count()];
        }
        self.validate()?;
        let joints = JointState::new(self, &Pose::rest(self.joint_count()));
        let invertible = |g: &DMat4| g.determinant().abs() > f64::MIN_POSITIVE;
        let inverse: Vec<Mat4> = joints.global.iter().map(|g| g.inverse().as_mat4()).collect();
        let singular = joints.global.iter().zip(&inverse).position(|(g, m)| !invertible(g) || !m.is_finite());
        if let Some(j) = singular {
            return Err(Error::InvalidSettings(format!(
                "skeleton: the rest world transform of joint {j} is singular (a zero scale?) and has no inverse"
            )));
        }
        self.inverse_bind = inverse;
        Ok(())
    }
}

impl Pose {
    /// The rest pose of a skeleton with `joint_count` joints: all offsets, the orientation and the
    /// translation zero.
    pub fn rest(joint_count: usize) -> Pose {
        Pose { joint_rotations: vec![Vec3::ZERO; joint_count], orientation: Vec3::ZERO, translation: Vec3::ZERO }
    }

    /// Number of scalar parameters of a pose for `joint_count` joints: `3·joint_count + 6`.
    pub fn parameter_count(joint_count: usize) -> usize {
        3 * joint_count + 6
    }

    /// Number of joints this pose is for.
    pub fn joint_count(&self) -> usize {
        self.joint_rotations.len()
    }

    /// The pose as a flat vector (what an optimiser such as [`crate::optim::Adam`] updates):
    ///
    /// ```text
    /// [θ_0.x, θ_0.y, θ_0.z, θ_1.x, …, θ_{J−1}.z, orientation.x, .y, .z, translation.x, .y, .z]
    /// ```
    ///
    /// `3·J + 6` values. A gradient returned as a [`Pose`] flattens the same way.
    pub fn to_params(&self) -> Vec<f32> {
        let mut params = Vec::with_capacity(Pose::parameter_count(self.joint_count()));
        for r in &self.joint_rotations {
            params.extend_from_slice(&r.to_array());
        }
        params.extend_from_slice(&self.orientation.to_array());
        params.extend_from_slice(&self.translation.to_array());
        params
    }

    /// The inverse of [`Pose::to_params`]. Errors when `params` does not hold `3·joint_count + 6`
    /// values or holds a non-finite one.
    pub fn from_params(params: &[f32], joint_count: usize) -> Result<Pose> {
        let expected = Pose::parameter_count(joint_count);
        if params.len() != expected {
            return Err(Error::LengthMismatch {
                what: "pose parameters (3 per joint + 6)",
                expected,
                got: params.len(),
            });
        }
        if let Some(i) = params.iter().position(|v| !v.is_finite()) {
            return Err(Error::InvalidSettings(format!(
                "pose parameter {i} is {}; every pose parameter must be a finite number",
                params[i]
            )));
        }
        let v = |i: usize| Vec3::new(params[i], params[i + 1], params[i + 2]);
        Ok(Pose {
            joint_rotations: (0..joint_count).map(|j| v(3 * j)).collect(),
            orientation: v(3 * joint_count),
            translation: v(3 * joint_count + 3),
        })
    }

    /// Checks that the pose has one rotation per joint and only finite values.
    pub fn validate(&self, joint_count: usize) -> Result<()> {
        if self.joint_rotations.len() != joint_count {
            return Err(Error::LengthMismatch {
                what: "pose joint rotations (one per skeleton joint)",
                expected: joint_count,
                got: self.joint_rotations.len(),
            });
        }
        if let Some(j) = self.joint_rotations.iter().position(|r| !r.is_finite()) {
            return Err(Error::InvalidSettings(format!(
                "pose: the rotation of joint {j} is {:?}; every pose parameter must be a finite number",
                self.joint_rotations[j]
            )));
        }
        if !self.orientation.is_finite() {
            return Err(Error::InvalidSettings(format!(
                "pose: the orientation is {:?}; every pose parameter must be a finite number",
                self.orientation
            )));
        }
        if !self.translation.is_finite() {
            return Err(Error::InvalidSettings(format!(
                "pose: the translation is {:?}; every pose parameter must be a finite number",
                self.translation
            )));
        }
        Ok(())
    }
}

/// The skew-symmetric (cross-product) matrix of `v`: `skew(v)·x = v × x`.
fn skew(v: DVec3) -> DMat3 {
    DMat3::from_cols(DVec3::new(0.0, v.z, -v.y), DVec3::new(-v.z, 0.0, v.x), DVec3::new(v.y, -v.x, 0.0))
}

/// Below this angle the Rodrigues coefficients come from their Taylor series (the closed forms
/// cancel catastrophically near zero).
const SERIES_BELOW: f64 = 0.05;

/// Coefficients of `R = I + a·K + b·K²` (`K = skew(θ)`, `t = |θ|`): `a = sin t / t`,
/// `b = (1 − cos t)/t²`, and their derivatives divided by `t`: `a' = (da/dt)/t`, `b' = (db/dt)/t`.
fn rodrigues_coefficients(t2: f64) -> (f64, f64, f64, f64) {
    let t = t2.sqrt();
    if t < SERIES_BELOW {
        let t4 = t2 * t2;
        let t6 = t4 * t2;
        let a = 1.0 - t2 / 6.0 + t4 / 120.0 - t6 / 5040.0;
        let b = 0.5 - t2 / 24.0 + t4 / 720.0 - t6 / 40320.0;
        let da = -1.0 / 3.0 + t2 / 30.0 - t4 / 840.0 + t6 / 45360.0;
        let db = -1.0 / 12.0 + t2 / 180.0 - t4 / 6720.0 + t6 / 453600.0;
        (a, b, da, db)
    } else {
        let (s, c) = t.sin_cos();
        let a = s / t;
        let b = (1.0 - c) / t2;
        let da = (t * c - s) / (t2 * t);
        let db = (t * s - 2.0 * (1.0 - c)) / (t2 * t2);
        (a, b, da, db)
    }
}

/// Rodrigues' formula in f64: the rotation by `|θ|` radians about `θ/|θ|` (right-handed, as glam's
/// `from_axis_angle`), `R = I + sin t/t · K + (1 − cos t)/t² · K²` with `K = skew(θ)`. Exact at 0.
pub fn rodrigues_f64(axis_angle: DVec3) -> DMat3 {
    let (a, b, _, _) = rodrigues_coefficients(axis_angle.length_squared());
    let k = skew(axis_angle);
    DMat3::IDENTITY + k * a + (k * k) * b
}

/// The partial derivatives `∂R/∂θ_x, ∂R/∂θ_y, ∂R/∂θ_z` of [`rodrigues_f64`]. Smooth through zero,
/// where they are the generators `skew(e_x), skew(e_y), skew(e_z)`.
///
/// `∂R/∂θ_k = a·E_k + b·(E_k·K + K·E_k) + θ_k·(a'·K + b'·K²)` with `E_k = skew(e_k)`.
pub fn rodrigues_derivative_f64(axis_angle: DVec3) -> [DMat3; 3] {
    let (a, b, da, db) = rodrigues_coefficients(axis_angle.length_squared());
    let k = skew(axis_angle);
    let k2 = k * k;
    let theta = axis_angle.to_array();
    let generators = [DVec3::X, DVec3::Y, DVec3::Z].map(skew);
    std::array::from_fn(|i| {
        let e = generators[i];
        e * a + (e * k + k * e) * b + (k * da + k2 * db) * theta[i]
    })
}

/// Rodrigues' formula: the rotation matrix of an axis–angle vector (angle = its length, radians).
/// Computed in f64; exact (the identity) at zero and accurate for tiny angles.
pub fn rodrigues(axis_angle: Vec3) -> Mat3 {
    rodrigues_f64(axis_angle.as_dvec3()).as_mat3()
}

/// The partial derivatives `[∂R/∂θ_x, ∂R/∂θ_y, ∂R/∂θ_z]` of [`rodrigues`]; no NaN anywhere, and
/// at zero they are the skew-symmetric generators.
pub fn rodrigues_derivative(axis_angle: Vec3) -> [Mat3; 3] {
    rodrigues_derivative_f64(axis_angle.as_dvec3()).map(|m| m.as_mat3())
}

/// Frobenius inner product of two 3×3 matrices.
fn frobenius(a: &DMat3, b: &DMat3) -> f64 {
    a.x_axis.dot(b.x_axis) + a.y_axis.dot(b.y_axis) + a.z_axis.dot(b.z_axis)
}

/// The joint hierarchy evaluated at a pose, in f64. Assumes a validated skeleton and pose.
#[derive(Clone, Debug)]
struct JointState {
    /// `W = T(translation) · R(orientation)`.
    world: DMat4,
    /// Per joint, `A_j = T(t_j)·R(q_j)`.
    rest_a: Vec<DMat4>,
    /// Per joint, `B_j = S(s_j)`.
    rest_b: Vec<DMat4>,
    /// Per joint, `local_j = A_j · R(θ_j) · B_j`.
    local: Vec<DMat4>,
    /// Per joint, `G_j`.
    global: Vec<DMat4>,
}

impl JointState {
    fn new(skeleton: &Skeleton, pose: &Pose) -> JointState {
        let n = skeleton.joint_count();
        let world = DMat4::from_translation(pose.translation.as_dvec3())
            * DMat4::from_mat3(rodrigues_f64(pose.orientation.as_dvec3()));
        let mut state = JointState {
            world,
            rest_a: Vec::with_capacity(n),
            rest_b: Vec::with_capacity(n),
            local: Vec::with_capacity(n),
            global: Vec::with_capacity(n),
        };
        for j in 0..n {
            let (a, b) = skeleton.rest[j].factors();
            let local = a * DMat4::from_mat3(rodrigues_f64(pose.joint_rotations[j].as_dvec3())) * b;
            let global = match skeleton.parents[j] {
                Some(p) => state.global[p] * local,
                None => world * skeleton.root_parent[j].as_dmat4() * local,
            };
            state.rest_a.push(a);
            state.rest_b.push(b);
            state.local.push(local);
            state.global.push(global);
        }
        state
    }
}

/// What [`SkinnedMesh::backward`] needs from a forward pass ([`SkinnedMesh::skin_with_cache`]).
#[derive(Clone, Debug)]
pub struct SkinCache {
    pose: Pose,
    vertex_count: usize,
    joints: JointState,
}

impl SkinCache {
    /// The pose the forward pass was evaluated at.
    pub fn pose(&self) -> &Pose {
        &self.pose
    }

    /// Number of vertices of the skinned mesh.
    pub fn vertex_count(&self) -> usize {
        self.vertex_count
    }

    /// The joint world transforms `G_j` at that pose.
    pub fn joint_transforms(&self) -> Vec<Mat4> {
        self.joints.global.iter().map(DMat4::as_mat4).collect()
    }
}

impl SkinnedMesh {
    /// Binds a mesh to a skeleton, checking everything: a valid skeleton ([`Skeleton::validate`]),
    /// one `joints` and one `weights` entry per mesh vertex, joint indices below the joint count,
    /// weights finite, non-negative and summing to 1 within [`WEIGHT_SUM_TOLERANCE`]. The weights
    /// are renormalised to sum to 1 exactly (to f32 precision).
    pub fn new(mesh: Mesh, skeleton: Skeleton, joints: Vec<[u16; 4]>, weights: Vec<[f32; 4]>) -> Result<SkinnedMesh> {
        skeleton.validate()?;
        let mut skinned = SkinnedMesh { mesh, skeleton, joints, weights };
        skinned.check_bindings()?;
        for (i, w) in skinned.weights.iter_mut().enumerate() {
            if let Some(k) = w.iter().position(|x| !x.is_finite() || *x < 0.0) {
                return Err(Error::InvalidSettings(format!(
                    "skin: vertex {i} has weight {} for influence {k}; weights must be finite and non-negative",
                    w[k]
                )));
            }
            let sum: f64 = w.iter().map(|&x| x as f64).sum();
            if (sum - 1.0).abs() > WEIGHT_SUM_TOLERANCE as f64 {
                return Err(Error::InvalidSettings(format!(
                    "skin: the weights of vertex {i} sum to {sum} ({w:?}); they must sum to 1 (within {})",
                    WEIGHT_SUM_TOLERANCE
                )));
            }
            for x in w.iter_mut() {
                *x = (*x as f64 / sum) as f32;
            }
        }
        Ok(skinned)
    }

    /// Number of joints of the skeleton.
    pub fn joint_count(&self) -> usize {
        self.skeleton.joint_count()
    }

    /// Number of vertices of the mesh.
    pub fn vertex_count(&self) -> usize {
        self.mesh.positions().len()
    }

    /// Number of pose parameters, `3·joint_count + 6` (see [`Pose::to_params`]).
    pub fn parameter_count(&self) -> usize {
        Pose::parameter_count(self.joint_count())
    }

    /// Per-vertex binding tables as long as the mesh, joint indices in range.
    fn check_bindings(&self) -> Result<()> {
        let n = self.vertex_count();
        if self.joints.len() != n {
            return Err(Error::LengthMismatch {
                what: "skin joint indices (one [u16; 4] per vertex)",
                expected: n,
                got: self.joints.len(),
            });
        }
        if self.weights.len() != n {
            return Err(Error::LengthMismatch {
                what: "skin weights (one [f32; 4] per vertex)",
                expected: n,
                got: self.weights.len(),
            });
        }
        let joint_count = self.joint_count();
        for (i, js) in self.joints.iter().enumerate() {
            if let Some(k) = js.iter().position(|&j| j as usize >= joint_count) {
                return Err(Error::InvalidSettings(format!(
                    "skin: vertex {i} influence {k} uses joint {}, but the skeleton has only {joint_count} joints",
                    js[k]
                )));
            }
        }
        Ok(())
    }

    /// Validates the skeleton, the bindings (the fields are public) and the pose.
    fn check(&self, pose: &Pose) -> Result<()> {
        self.skeleton.validate()?;
        self.check_bindings()?;
        pose.validate(self.joint_count())
    }

    /// The joint world transforms `G_j` at `pose` (see the module docs).
    pub fn joint_transforms(&self, pose: &Pose) -> Result<Vec<Mat4>> {
        self.check(pose)?;
        Ok(JointState::new(&self.skeleton, pose).global.iter().map(DMat4::as_mat4).collect())
    }

    /// The posed vertices `v_i = Σ_k w_ik · G_{j_ik} · IBM_{j_ik} · v̂_i`.
    pub fn skin(&self, pose: &Pose) -> Result<Vec<Vec3>> {
        Ok(self.skin_with_cache(pose)?.0)
    }

    /// The posed mesh: [`SkinnedMesh::skin`] on the bind mesh's (shared) topology.
    pub fn posed_mesh(&self, pose: &Pose) -> Result<Mesh> {
        Mesh::with_topology(self.skin(pose)?, self.mesh.topology().clone())
    }

    /// [`SkinnedMesh::skin`], also returning what [`SkinnedMesh::backward`] needs.
    pub fn skin_with_cache(&self, pose: &Pose) -> Result<(Vec<Vec3>, SkinCache)> {
        self.check(pose)?;
        let joints = JointState::new(&self.skeleton, pose);
        // M_j = G_j · IBM_j, composed in f64, applied in f32.
        let skinning: Vec<Mat4> = joints
            .global
            .iter()
            .zip(&self.skeleton.inverse_bind)
            .map(|(g, ibm)| (*g * ibm.as_dmat4()).as_mat4())
            .collect();
        let bind = self.mesh.positions();
        let skin_vertex = |((p, js), ws): ((&Vec3, &[u16; 4]), &[f32; 4])| -> Vec3 {
            let mut out = Vec3::ZERO;
            for k in 0..4 {
                if ws[k] != 0.0 {
                    out += ws[k] * skinning[js[k] as usize].transform_point3(*p);
                }
            }
            out
        };
        let positions: Vec<Vec3> = if bind.len() >= PARALLEL_MIN_VERTICES {
            bind.par_iter().zip(&self.joints).zip(&self.weights).with_min_len(BLOCK).map(skin_vertex).collect()
        } else {
            bind.iter().zip(&self.joints).zip(&self.weights).map(skin_vertex).collect()
        };
        let cache = SkinCache { pose: pose.clone(), vertex_count: bind.len(), joints };
        Ok((positions, cache))
    }

    /// The gradient of a loss with respect to the pose, given its gradient `d_vertices` with
    /// respect to the posed vertices of the forward pass that produced `cache`. The returned
    /// [`Pose`] holds `∂L/∂θ_j`, `∂L/∂orientation` and `∂L/∂translation`; flatten it with
    /// [`Pose::to_params`] for an optimiser.
    ///
    /// Chain: `∂L/∂M_j = Σ_i w_ij (∂L/∂v_i)·[v̂_i, 1]ᵀ` (summed in f64, in fixed-size blocks of
    /// vertices added in a fixed order, so the result is deterministic), `∂L/∂G_j = ∂L/∂M_j ·
    /// IBM_jᵀ`, then through the hierarchy children before parents and through Rodrigues' formula.
    pub fn backward(&self, cache: &SkinCache, d_vertices: &[Vec3]) -> Result<Pose> {
        let n = self.vertex_count();
        let joint_count = self.joint_count();
        if cache.vertex_count != n || cache.pose.joint_count() != joint_count {
            return Err(Error::InvalidSettings(format!(
                "skin backward: the cache is for {} vertices and {} joints, but this mesh has {n} vertices and \
                 {joint_count} joints; pass the cache of this mesh's forward pass",
                cache.vertex_count,
                cache.pose.joint_count()
            )));
        }
        if d_vertices.len() != n {
            return Err(Error::LengthMismatch { what: "vertex gradients", expected: n, got: d_vertices.len() });
        }
        if let Some(i) = d_vertices.iter().position(|g| !g.is_finite()) {
            return Err(Error::InvalidSettings(format!(
                "skin backward: the gradient of vertex {i} is {:?}; gradients must be finite",
                d_vertices[i]
            )));
        }
        self.check_bindings()?;

        // ∂L/∂M_j, rows 0..3 of the 4×4 (the bottom row does not reach the vertices), row-major.
        let d_m = self.accumulate_joint_gradients(d_vertices);

        let state = &cache.joints;
        let mut d_global: Vec<DMat4> = d_m
            .iter()
            .zip(&self.skeleton.inverse_bind)
            .map(|(r, ibm)| {
                let col = |c: usize| DVec4::new(r[c], r[4 + c], r[8 + c], 0.0);
                DMat4::from_cols(col(0), col(1), col(2), col(3)) * ibm.as_dmat4().transpose()
            })
            .collect();
        let mut d_world = DMat4::ZERO;
        let mut d_rotations = vec![Vec3::ZERO; joint_count];
        for j in (0..joint_count).rev() {
            let dg = d_global[j];
            let d_local = match self.skeleton.parents[j] {
                Some(p) => {
                    d_global[p] += dg * state.local[j].transpose();
                    state.global[p].transpose() * dg
                }
                None => {
                    let root_parent = self.skeleton.root_parent[j].as_dmat4();
                    d_world += dg * (root_parent * state.local[j]).transpose();
                    (state.world * root_parent).transpose() * dg
                }
            };
            let d_r = DMat3::from_mat4(state.rest_a[j].transpose() * d_local * state.rest_b[j].transpose());
            let d_rodrigues = rodrigues_derivative_f64(cache.pose.joint_rotations[j].as_dvec3());
            d_rotations[j] = DVec3::from_array(d_rodrigues.map(|m| frobenius(&d_r, &m))).as_vec3();
        }
        let d_orientation = rodrigues_derivative_f64(cache.pose.orientation.as_dvec3())
            .map(|m| frobenius(&DMat3::from_mat4(d_world), &m));
        Ok(Pose {
            joint_rotations: d_rotations,
            orientation: DVec3::from_array(d_orientation).as_vec3(),
            translation: d_world.w_axis.truncate().as_vec3(),
        })
    }

    /// `Σ_i w_ij (∂L/∂v_i)·[v̂_i, 1]ᵀ` per joint (3×4, row-major), in f64. Blocks of [`BLOCK`]
    /// vertices are summed (in parallel when there are several) and then added in block order.
    fn accumulate_joint_gradients(&self, d_vertices: &[Vec3]) -> Vec<[f64; 12]> {
        let joint_count = self.joint_count();
        let bind = self.mesh.positions();
        let block_sum = |start: usize| -> Vec<[f64; 12]> {
            let end = (start + BLOCK).min(bind.len());
            let mut acc = vec![[0.0f64; 12]; joint_count];
            for i in start..end {
                let g = d_vertices[i].as_dvec3();
                let v = bind[i].as_dvec3().extend(1.0).to_array();
                let (js, ws) = (&self.joints[i], &self.weights[i]);
                for k in 0..4 {
                    let w = ws[k] as f64;
                    if w == 0.0 {
                        continue;
                    }
                    let wg = (g * w).to_array();
                    let a = &mut acc[js[k] as usize];
                    for r in 0..3 {
                        for c in 0..4 {
                            a[4 * r + c] += wg[r] * v[c];
                        }
                    }
                }
            }
            acc
        };
        let starts: Vec<usize> = (0..bind.len()).step_by(BLOCK).collect();
        let blocks: Vec<Vec<[f64; 12]>> = if starts.len() > 1 {
            starts.par_iter().map(|&s| block_sum(s)).collect()
        } else {
            starts.iter().map(|&s| block_sum(s)).collect()
        };
        let mut total = vec![[0.0f64; 12]; joint_count];
        for block in &blocks {
            for (t, b) in total.iter_mut().zip(block) {
                for (x, y) in t.iter_mut().zip(b) {
                    *x += y;
                }
            }
        }
        total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_and_closed_form_coefficients_agree_near_the_switch() {
        for t in [0.01, 0.03, 0.049, 0.051, 0.07, 0.1] {
            let t2: f64 = t * t;
            let (s, c) = t.sin_cos();
            let closed = [s / t, (1.0 - c) / t2, (t * c - s) / (t2 * t), (t * s - 2.0 * (1.0 - c)) / (t2 * t2)];
            let k = t2 * t2 * t2 * t2; // size of the first omitted series term
            let series = {
                let (t4, t6) = (t2 * t2, t2 * t2 * t2);
                [
                    1.0 - t2 / 6.0 + t4 / 120.0 - t6 / 5040.0,
                    0.5 - t2 / 24.0 + t4 / 720.0 - t6 / 40320.0,
                    -1.0 / 3.0 + t2 / 30.0 - t4 / 840.0 + t6 / 45360.0,
                    -1.0 / 12.0 + t2 / 180.0 - t4 / 6720.0 + t6 / 453600.0,
                ]
            };
            let ours = rodrigues_coefficients(t2);
            let ours = [ours.0, ours.1, ours.2, ours.3];
            for i in 0..4 {
                // Closed forms lose about eps/t⁴ to cancellation; the series omits O(t⁸).
                let tol = 1e-16 / (t2 * t2) + k;
                assert!((series[i] - closed[i]).abs() < tol, "coefficient {i} at t = {t}");
                assert!((ours[i] - closed[i]).abs() < tol, "coefficient {i} at t = {t}");
            }
        }
    }

    #[test]
    fn joint_rest_matrix_is_trs() {
        let rest = JointRest {
            translation: Vec3::new(1.0, -2.0, 0.5),
            rotation: Quat::from_rotation_y(0.7),
            scale: Vec3::new(2.0, 1.0, 0.5),
        };
        let expected = Mat4::from_scale_rotation_translation(rest.scale, rest.rotation, rest.translation);
        assert!(rest.to_mat4().abs_diff_eq(expected, 1e-6));
        assert_eq!(JointRest::default().to_mat4(), Mat4::IDENTITY);
    }
}

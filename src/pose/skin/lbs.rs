//! Linear-blend skinning: the joint hierarchy evaluated at a pose and shape, and the forward from
//! pose and shape to posed vertices (the backward is in `backward.rs`).

use glam::{DMat4, DVec3, Mat4, Vec3};
use rayon::prelude::*;

use super::morph::ShapeBasis;
use super::rodrigues::rodrigues_f64;
use super::{Pose, Skeleton, SkinnedMesh};
use crate::{Mesh, Result};

/// Vertices per block of the per-vertex loops (and of the backward's per-joint sums). Blocks are
/// summed in a fixed order, so gradients do not depend on the number of threads.
pub(super) const BLOCK: usize = 4096;

/// Below this many vertices the forward runs on one thread (rayon's overhead would dominate).
const PARALLEL_MIN_VERTICES: usize = 16_384;

/// The joint hierarchy evaluated at a pose, in f64. Assumes a validated skeleton and pose.
#[derive(Clone, Debug)]
pub(super) struct JointState {
    /// `W = T(translation) · R(orientation)`.
    pub(super) world: DMat4,
    /// Per joint, `A_j = T(t_j + τ_j + s_j(β))·R(q_j)`.
    pub(super) rest_a: Vec<DMat4>,
    /// Per joint, `B_j = S(s_j ⊙ σ_j)` (`σ_j` the pose's scale factor, ones when it has none).
    pub(super) rest_b: Vec<DMat4>,
    /// Per joint, `local_j = A_j · R(θ_j) · B_j`.
    pub(super) local: Vec<DMat4>,
    /// Per joint, `G_j`.
    pub(super) global: Vec<DMat4>,
}

impl JointState {
    /// The hierarchy at `pose`, with each joint's rest translation also moved by `shift[j]` (the
    /// shape's local translation change; empty for none).
    pub(super) fn new(skeleton: &Skeleton, pose: &Pose, shift: &[DVec3]) -> JointState {
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
            let (mut a, mut b) = skeleton.rest[j].factors();
            let scale = pose.joint_scale(j);
            if scale != Vec3::ONE {
                b = DMat4::from_scale(skeleton.rest[j].scale.as_dvec3() * scale.as_dvec3());
            }
            let moved = pose.joint_translation(j).as_dvec3() + shift.get(j).copied().unwrap_or(DVec3::ZERO);
            if moved != DVec3::ZERO {
                a = DMat4::from_translation(moved) * a;
            }
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

/// What [`SkinnedMesh::backward`] needs from a forward pass ([`SkinnedMesh::skin_with_cache`] or
/// [`SkinnedMesh::skin_shaped_with_cache`]).
#[derive(Clone, Debug)]
pub struct SkinCache {
    pub(super) pose: Pose,
    pub(super) betas: Vec<f32>,
    pub(super) vertex_count: usize,
    pub(super) joints: JointState,
    /// The shaped bind vertices `v̂ + Σ β_k Δ_k`; `None` when they are the bind mesh's.
    pub(super) shaped: Option<Vec<Vec3>>,
    /// Per joint, the shaped inverse bind matrix `IBM_j · T(−Σ β_k o_kj)`.
    pub(super) inverse_bind: Vec<DMat4>,
    /// Per joint, the skinning matrix `M_j = G_j · IBM'_j`, as applied (f32).
    pub(super) skinning: Vec<Mat4>,
    /// The joint-offset basis, when the mesh has joint offsets.
    pub(super) basis: Option<ShapeBasis>,
}

impl SkinCache {
    /// The pose the forward pass was evaluated at.
    pub fn pose(&self) -> &Pose {
        &self.pose
    }

    /// The shape coefficients it was evaluated at (empty: all zero).
    pub fn betas(&self) -> &[f32] {
        &self.betas
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
    /// The joint world transforms `G_j` at `pose` (see the module docs).
    pub fn joint_transforms(&self, pose: &Pose) -> Result<Vec<Mat4>> {
        self.joint_transforms_shaped(pose, &[])
    }

    /// The joint world transforms `G_j` at `pose` and shape `betas` (the joints of the shaped
    /// skeleton; see [`SkinnedMesh::skin_shaped`]).
    pub fn joint_transforms_shaped(&self, pose: &Pose, betas: &[f32]) -> Result<Vec<Mat4>> {
        Ok(self.skin_shaped_with_cache(pose, betas)?.1.joint_transforms())
    }

    /// The posed vertices `v_i = Σ_k w_ik · G_{j_ik} · IBM_{j_ik} · v̂_i`.
    pub fn skin(&self, pose: &Pose) -> Result<Vec<Vec3>> {
        Ok(self.skin_with_cache(pose)?.0)
    }

    /// The posed vertices of the shaped body: linear-blend skinning of `v̂_i + Σ_k β_k Δ_ki` by the
    /// shaped skeleton (see [`SkinnedMesh::skin_shaped_with_cache`]). `betas` holds one
    /// coefficient per morph target, or is empty for the unshaped body.
    pub fn skin_shaped(&self, pose: &Pose, betas: &[f32]) -> Result<Vec<Vec3>> {
        Ok(self.skin_shaped_with_cache(pose, betas)?.0)
    }

    /// The posed mesh: [`SkinnedMesh::skin`] on the bind mesh's (shared) topology.
    pub fn posed_mesh(&self, pose: &Pose) -> Result<Mesh> {
        self.posed_mesh_shaped(pose, &[])
    }

    /// The posed, shaped mesh: [`SkinnedMesh::skin_shaped`] on the bind mesh's topology.
    pub fn posed_mesh_shaped(&self, pose: &Pose, betas: &[f32]) -> Result<Mesh> {
        Mesh::with_topology(self.skin_shaped(pose, betas)?, self.mesh.topology().clone())
    }

    /// [`SkinnedMesh::skin`], also returning what [`SkinnedMesh::backward`] needs.
    pub fn skin_with_cache(&self, pose: &Pose) -> Result<(Vec<Vec3>, SkinCache)> {
        self.skin_shaped_with_cache(pose, &[])
    }

    /// [`SkinnedMesh::skin_shaped`], also returning what [`SkinnedMesh::backward_with_shape`]
    /// needs.
    ///
    /// With `o_kj` the joint offsets of [`MorphTargets::joint_offsets`](super::MorphTargets) and
    /// `Δp_j = Σ_k β_k o_kj`, the shaped skeleton keeps every rest rotation and scale and moves
    /// each joint's rest world position by `Δp_j`: its local rest translation becomes
    /// `t_j + L_p⁻¹ (Δp_j − Δp_parent)` (`L_p` the linear part of the parent's rest world
    /// transform) and its inverse bind matrix `IBM_j · T(−Δp_j)`, so that the rest pose of the
    /// shaped skeleton reproduces the shaped bind mesh. Without joint offsets `Δp = 0`: the
    /// joints stay put and only the surface changes. Errors for a bad pose, `betas` neither empty
    /// nor one finite value per target, or inconsistent morph tables.
    pub fn skin_shaped_with_cache(&self, pose: &Pose, betas: &[f32]) -> Result<(Vec<Vec3>, SkinCache)> {
        self.check(pose)?;
        self.check_shape(betas)?;
        let n = self.joint_count();
        let basis = match &self.morphs.joint_offsets {
            Some(offsets) if !self.morphs.is_empty() => {
                let rest = JointState::new(&self.skeleton, &Pose::rest(n), &[]);
                Some(ShapeBasis::new(&self.skeleton, offsets, &rest.global)?)
            }
            _ => None,
        };
        let shaped_joints = basis.as_ref().filter(|_| betas.iter().any(|&b| b != 0.0));
        let (local_shift, world_shift) = match shaped_joints {
            Some(basis) => {
                (ShapeBasis::combine(&basis.local, betas, n), Some(ShapeBasis::combine(&basis.world, betas, n)))
            }
            None => (Vec::new(), None),
        };
        let joints = JointState::new(&self.skeleton, pose, &local_shift);
        let inverse_bind: Vec<DMat4> = match &world_shift {
            Some(shift) => self
                .skeleton
                .inverse_bind
                .iter()
                .zip(shift)
                .map(|(m, d)| m.as_dmat4() * DMat4::from_translation(-*d))
                .collect(),
            None => self.skeleton.inverse_bind.iter().map(Mat4::as_dmat4).collect(),
        };
        // M_j = G_j · IBM'_j, composed in f64, applied in f32.
        let skinning: Vec<Mat4> =
            joints.global.iter().zip(&inverse_bind).map(|(g, ibm)| (*g * *ibm).as_mat4()).collect();
        let shaped = self.shaped_bind(betas);
        let bind = shaped.as_deref().unwrap_or(self.mesh.positions());
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
        let cache = SkinCache {
            pose: pose.clone(),
            betas: betas.to_vec(),
            vertex_count: bind.len(),
            joints,
            shaped,
            inverse_bind,
            skinning,
            basis,
        };
        Ok((positions, cache))
    }

    /// The shaped bind vertices `v̂_i + Σ_k β_k Δ_ki`, or `None` when every `β_k` is zero.
    fn shaped_bind(&self, betas: &[f32]) -> Option<Vec<Vec3>> {
        if betas.iter().all(|&b| b == 0.0) {
            return None;
        }
        let mut positions = self.mesh.positions().to_vec();
        for (deltas, &b) in self.morphs.deltas.iter().zip(betas) {
            if b != 0.0 {
                for (p, d) in positions.iter_mut().zip(deltas) {
                    *p += b * *d;
                }
            }
        }
        Some(positions)
    }
}

//! Linear-blend skinning: the joint hierarchy evaluated at a pose, the forward from pose to posed
//! vertices and its analytic backward from vertex gradients to the pose.

use glam::{DMat3, DMat4, DVec3, DVec4, Mat4, Vec3};
use rayon::prelude::*;

use super::rodrigues::{rodrigues_derivative_f64, rodrigues_f64};
use super::{Pose, Skeleton, SkinnedMesh};
use crate::{Error, Mesh, Result};

/// Vertices per block of the backward's per-joint sums. Blocks are summed in a fixed order, so
/// gradients do not depend on the number of threads.
const BLOCK: usize = 4096;

/// Below this many vertices the forward runs on one thread (rayon's overhead would dominate).
const PARALLEL_MIN_VERTICES: usize = 16_384;

/// Frobenius inner product of two 3×3 matrices.
fn frobenius(a: &DMat3, b: &DMat3) -> f64 {
    a.x_axis.dot(b.x_axis) + a.y_axis.dot(b.y_axis) + a.z_axis.dot(b.z_axis)
}

/// The joint hierarchy evaluated at a pose, in f64. Assumes a validated skeleton and pose.
#[derive(Clone, Debug)]
pub(super) struct JointState {
    /// `W = T(translation) · R(orientation)`.
    world: DMat4,
    /// Per joint, `A_j = T(t_j)·R(q_j)`.
    rest_a: Vec<DMat4>,
    /// Per joint, `B_j = S(s_j)`.
    rest_b: Vec<DMat4>,
    /// Per joint, `local_j = A_j · R(θ_j) · B_j`.
    local: Vec<DMat4>,
    /// Per joint, `G_j`.
    pub(super) global: Vec<DMat4>,
}

impl JointState {
    pub(super) fn new(skeleton: &Skeleton, pose: &Pose) -> JointState {
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

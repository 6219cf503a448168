//! The analytic backward of linear-blend skinning: from vertex gradients to the pose (joint
//! rotations, translations and scale factors, global orientation and translation) and to the
//! shape `β`.

use glam::{DMat3, DMat4, DVec3, DVec4, Vec3};
use rayon::prelude::*;

use super::lbs::{SkinCache, BLOCK};
use super::rodrigues::{rodrigues_derivative_f64, rodrigues_f64};
use super::{Pose, SkinnedMesh};
use crate::{Error, Result};

/// Frobenius inner product of two 3×3 matrices.
fn frobenius(a: &DMat3, b: &DMat3) -> f64 {
    a.x_axis.dot(b.x_axis) + a.y_axis.dot(b.y_axis) + a.z_axis.dot(b.z_axis)
}

/// Per-block sums over the vertices, added in block order (deterministic for any thread count).
fn blocked_sum<T: Send>(
    vertex_count: usize,
    zero: impl Fn() -> T + Sync,
    block_sum: impl Fn(usize, usize) -> T + Sync,
    add: impl Fn(&mut T, &T),
) -> T {
    let starts: Vec<usize> = (0..vertex_count).step_by(BLOCK).collect();
    let run = |&s: &usize| block_sum(s, (s + BLOCK).min(vertex_count));
    let blocks: Vec<T> =
        if starts.len() > 1 { starts.par_iter().map(run).collect() } else { starts.iter().map(run).collect() };
    let mut total = zero();
    for block in &blocks {
        add(&mut total, block);
    }
    total
}

impl SkinnedMesh {
    /// The gradient of a loss with respect to the pose, given its gradient `d_vertices` with
    /// respect to the posed vertices of the forward pass that produced `cache`. The returned
    /// [`Pose`] holds `∂L/∂θ_j`, `∂L/∂orientation`, `∂L/∂translation` and, when the pose of the
    /// forward pass has joint translations, `∂L/∂τ_j`, and when it has joint scale factors,
    /// `∂L/∂σ_j`; flatten it with [`Pose::to_params`] for an optimiser.
    /// [`SkinnedMesh::backward_with_shape`] also gives `∂L/∂β`.
    ///
    /// Chain: `∂L/∂M_j = Σ_i w_ij (∂L/∂v_i)·[v̂_i, 1]ᵀ` (summed in f64, in fixed-size blocks of
    /// vertices added in a fixed order, so the result is deterministic), `∂L/∂G_j = ∂L/∂M_j ·
    /// IBM_jᵀ`, then through the hierarchy children before parents and through Rodrigues' formula.
    pub fn backward(&self, cache: &SkinCache, d_vertices: &[Vec3]) -> Result<Pose> {
        Ok(self.backward_with_shape(cache, d_vertices)?.0)
    }

    /// [`SkinnedMesh::backward`] and the gradient with respect to the shape coefficients `β`, one
    /// value per morph target (also when the forward pass had no `β`, i.e. all zero). Three terms
    /// add up in `∂L/∂β_k`: through the vertex deltas, `Σ_i (Σ_j w_ij L(M_j))ᵀ ∂L/∂v_i · Δ_ki`
    /// (`L` the linear part); through the shaped inverse bind matrices `IBM_j · T(−Δp_j)`; and
    /// through the joints' shaped local rest translations (the last two only with joint offsets).
    pub fn backward_with_shape(&self, cache: &SkinCache, d_vertices: &[Vec3]) -> Result<(Pose, Vec<f32>)> {
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
        self.check_shape(&cache.betas)?;

        // ∂L/∂M_j, rows 0..3 of the 4×4 (the bottom row does not reach the vertices), row-major.
        let bind = cache.shaped.as_deref().unwrap_or(self.mesh.positions());
        let d_m = self.accumulate_joint_gradients(bind, d_vertices);
        let d_m: Vec<DMat4> = d_m
            .iter()
            .map(|r| {
                let col = |c: usize| DVec4::new(r[c], r[4 + c], r[8 + c], 0.0);
                DMat4::from_cols(col(0), col(1), col(2), col(3))
            })
            .collect();

        let state = &cache.joints;
        let mut d_global: Vec<DMat4> =
            d_m.iter().zip(&cache.inverse_bind).map(|(d, ibm)| *d * ibm.transpose()).collect();
        let mut d_world = DMat4::ZERO;
        let mut d_rotations = vec![Vec3::ZERO; joint_count];
        let mut d_local_translation = vec![DVec3::ZERO; joint_count];
        let with_scales = cache.pose.has_joint_scales();
        let mut d_scales = vec![Vec3::ZERO; if with_scales { joint_count } else { 0 }];
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
            // local = T(t)·X with X free of translation, so ∂L/∂t is ∂L/∂local's last column.
            d_local_translation[j] = d_local.w_axis.truncate();
            let d_r = DMat3::from_mat4(state.rest_a[j].transpose() * d_local * state.rest_b[j].transpose());
            let theta = cache.pose.joint_rotations[j].as_dvec3();
            let d_rodrigues = rodrigues_derivative_f64(theta);
            d_rotations[j] = DVec3::from_array(d_rodrigues.map(|m| frobenius(&d_r, &m))).as_vec3();
            if with_scales {
                // local = (A·R(θ))·S(s ⊙ σ): ∂L/∂S = (A·R(θ))ᵀ ∂L/∂local, ∂L/∂σ_c = s_c·(∂L/∂S)_cc.
                let ar = state.rest_a[j] * DMat4::from_mat3(rodrigues_f64(theta));
                let d_s = ar.transpose() * d_local;
                let s = self.skeleton.rest[j].scale.as_dvec3();
                d_scales[j] = (DVec3::new(d_s.x_axis.x, d_s.y_axis.y, d_s.z_axis.z) * s).as_vec3();
            }
        }
        let d_orientation = rodrigues_derivative_f64(cache.pose.orientation.as_dvec3())
            .map(|m| frobenius(&DMat3::from_mat4(d_world), &m));
        let pose = Pose {
            joint_rotations: d_rotations,
            joint_translations: if cache.pose.has_joint_translations() {
                d_local_translation.iter().map(|t| t.as_vec3()).collect()
            } else {
                Vec::new()
            },
            joint_scales: d_scales,
            orientation: DVec3::from_array(d_orientation).as_vec3(),
            translation: d_world.w_axis.truncate().as_vec3(),
        };

        let mut d_betas = self.vertex_delta_gradients(cache, d_vertices);
        if let Some(basis) = &cache.basis {
            for j in 0..joint_count {
                // M_j = (G_j·IBM_j)·T(−Δp_j): ∂L/∂Δp_j = −[(G_j·IBM_j)ᵀ ∂L/∂M_j]'s last column.
                let g_ibm = state.global[j] * self.skeleton.inverse_bind[j].as_dmat4();
                let d_offset = -(g_ibm.transpose() * d_m[j]).w_axis.truncate();
                for (k, d) in d_betas.iter_mut().enumerate() {
                    *d += d_offset.dot(basis.world[k][j]) + d_local_translation[j].dot(basis.local[k][j]);
                }
            }
        }
        Ok((pose, d_betas.iter().map(|&d| d as f32).collect()))
    }

    /// `Σ_i (Σ_j w_ij L(M_j))ᵀ ∂L/∂v_i · Δ_ki` per target `k`, in f64.
    fn vertex_delta_gradients(&self, cache: &SkinCache, d_vertices: &[Vec3]) -> Vec<f64> {
        let count = self.morphs.count();
        if count == 0 {
            return Vec::new();
        }
        let linear: Vec<DMat3> = cache.skinning.iter().map(|m| DMat3::from_mat4(m.as_dmat4())).collect();
        blocked_sum(
            d_vertices.len(),
            || vec![0.0f64; count],
            |start, end| {
                let mut acc = vec![0.0f64; count];
                for i in start..end {
                    // A zero gradient adds exact zeros: skip it (at 64² only the silhouette's
                    // vertices have a gradient).
                    if d_vertices[i] == Vec3::ZERO {
                        continue;
                    }
                    let (js, ws) = (&self.joints[i], &self.weights[i]);
                    let mut a = DMat3::ZERO;
                    for k in 0..4 {
                        if ws[k] != 0.0 {
                            a += linear[js[k] as usize] * ws[k] as f64;
                        }
                    }
                    let u = a.transpose() * d_vertices[i].as_dvec3();
                    for (s, deltas) in acc.iter_mut().zip(&self.morphs.deltas) {
                        *s += u.dot(deltas[i].as_dvec3());
                    }
                }
                acc
            },
            |total, block| total.iter_mut().zip(block).for_each(|(t, b)| *t += b),
        )
    }

    /// `Σ_i w_ij (∂L/∂v_i)·[v̂_i, 1]ᵀ` per joint (3×4, row-major), in f64, with `v̂` the (shaped)
    /// bind vertices. Blocks of [`BLOCK`] vertices are summed (in parallel when there are several)
    /// and then added in block order.
    fn accumulate_joint_gradients(&self, bind: &[Vec3], d_vertices: &[Vec3]) -> Vec<[f64; 12]> {
        let joint_count = self.joint_count();
        blocked_sum(
            bind.len(),
            || vec![[0.0f64; 12]; joint_count],
            |start, end| {
                let mut acc = vec![[0.0f64; 12]; joint_count];
                for i in start..end {
                    // A zero gradient adds exact zeros (`x + 0 = x`, and `+0 + ±0 = +0`): skip it.
                    if d_vertices[i] == Vec3::ZERO {
                        continue;
                    }
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
            },
            |total, block| {
                for (t, b) in total.iter_mut().zip(block) {
                    for (x, y) in t.iter_mut().zip(b) {
                        *x += y;
                    }
                }
            },
        )
    }
}

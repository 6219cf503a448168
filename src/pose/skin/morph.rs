//! Morph targets (blend shapes): per-vertex position deltas, optional per-joint offsets, and the
//! shaped rest skeleton they give for shape coefficients `β`.

use glam::{DMat3, DVec3, Vec3};

use super::Skeleton;
use crate::{Error, Result};

/// The index of the first non-finite vector of `values`, if any. The skinning forward and
/// backward validate the morph tables on every call (their fields are public), so the common
/// case, all finite, is one branch-free pass over the bits (an exponent of all ones is an
/// infinity or a NaN) that the compiler vectorises; only a hit looks for the index.
fn first_non_finite(values: &[Vec3]) -> Option<usize> {
    const EXPONENT: u32 = 0x7f80_0000;
    let bits: &[u32] = bytemuck::cast_slice(values);
    // `(b & EXPONENT) + 2^23` has its top bit set exactly for an all-ones exponent (an infinity
    // or a NaN); or-ing them needs only SSE2's integer ops.
    let any = bits.iter().fold(0u32, |acc, &b| acc | (b & EXPONENT).wrapping_add(0x0080_0000));
    if any & 0x8000_0000 != 0 {
        values.iter().position(|v| !v.is_finite())
    } else {
        None
    }
}

/// The morph targets of a skinned mesh: a linear shape space around the bind mesh.
///
/// For shape coefficients `β` (one per target) the shaped bind mesh is `v̂_i + Σ_k β_k Δ_ki` and,
/// when [`MorphTargets::joint_offsets`] is present, the shaped rest skeleton has every joint's rest
/// world position moved by `Σ_k β_k · o_kj` (rotations and scales unchanged). Without joint
/// offsets the joints stay where they are and only the surface changes shape. See
/// [`SkinnedMesh::skin_shaped`](super::SkinnedMesh::skin_shaped) for how both enter skinning.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MorphTargets {
    /// Name of each target (glTF: `mesh.extras.targetNames`; `target_k` when the file has none).
    pub names: Vec<String>,
    /// Position deltas `Δ_k`, one list per target with one delta per bind-mesh vertex.
    pub deltas: Vec<Vec<Vec3>>,
    /// Joint offsets `o_k`, one list per target with one world-space displacement of the joint's
    /// rest position per skeleton joint (per unit weight), or `None` when the joints do not
    /// follow the shape (glTF: `skins[0].extras.morphJointOffsets`, an extension of the MakeHuman
    /// body files; plain glTF morph targets never move joints).
    pub joint_offsets: Option<Vec<Vec<Vec3>>>,
}

impl MorphTargets {
    /// Number of targets (the length `β` must have).
    pub fn count(&self) -> usize {
        self.deltas.len()
    }

    /// Whether there are no targets.
    pub fn is_empty(&self) -> bool {
        self.deltas.is_empty()
    }

    /// Checks the tables against a mesh of `vertex_count` vertices and a skeleton of
    /// `joint_count` joints: one name per target, one delta per vertex, one offset per joint,
    /// finite values.
    pub fn validate(&self, vertex_count: usize, joint_count: usize) -> Result<()> {
        let count = self.count();
        if self.names.len() != count {
            return Err(Error::LengthMismatch {
                what: "morph target names (one per target)",
                expected: count,
                got: self.names.len(),
            });
        }
        for (k, deltas) in self.deltas.iter().enumerate() {
            if deltas.len() != vertex_count {
                return Err(Error::LengthMismatch {
                    what: "morph target deltas (one per mesh vertex)",
                    expected: vertex_count,
                    got: deltas.len(),
                });
            }
            if let Some(i) = first_non_finite(deltas) {
                return Err(Error::InvalidSettings(format!(
                    "morph target {k} (`{}`): the delta of vertex {i} is {:?}; deltas must be finite",
                    self.names[k], deltas[i]
                )));
            }
        }
        if let Some(offsets) = &self.joint_offsets {
            if offsets.len() != count {
                return Err(Error::LengthMismatch {
                    what: "morph joint offsets (one list per target)",
                    expected: count,
                    got: offsets.len(),
                });
            }
            for (k, list) in offsets.iter().enumerate() {
                if list.len() != joint_count {
                    return Err(Error::LengthMismatch {
                        what: "morph joint offsets (one per skeleton joint)",
                        expected: joint_count,
                        got: list.len(),
                    });
                }
                if let Some(j) = list.iter().position(|o| !o.is_finite()) {
                    return Err(Error::InvalidSettings(format!(
                        "morph target {k} (`{}`): the offset of joint {j} is {:?}; offsets must be finite",
                        self.names[k], list[j]
                    )));
                }
            }
        }
        Ok(())
    }

    /// Checks shape coefficients: empty (all zero) or one finite value per target.
    pub fn check_betas(&self, betas: &[f32]) -> Result<()> {
        if !betas.is_empty() && betas.len() != self.count() {
            return Err(Error::LengthMismatch {
                what: "shape coefficients β (one per morph target, or none)",
                expected: self.count(),
                got: betas.len(),
            });
        }
        if let Some(k) = betas.iter().position(|b| !b.is_finite()) {
            return Err(Error::InvalidSettings(format!(
                "shape coefficient β_{k} is {}; every shape coefficient must be a finite number",
                betas[k]
            )));
        }
        Ok(())
    }
}

/// The shape-dependent part of the rest skeleton, linear in `β`.
#[derive(Clone, Debug)]
pub(super) struct ShapeBasis {
    /// Per target, per joint: the world rest-position offset `o_kj` (f64).
    pub(super) world: Vec<Vec<DVec3>>,
    /// Per target, per joint: the local rest-translation change `d_kj = L_p⁻¹ (o_kj − o_kp)` that
    /// moves the joint by `o_kj` in the world (`L_p` the linear part of the parent's rest world
    /// transform, of the root-parent matrix for a root, and `o_kp = 0` for a root).
    pub(super) local: Vec<Vec<DVec3>>,
}

impl ShapeBasis {
    /// The basis for a validated skeleton and validated joint offsets.
    pub(super) fn new(skeleton: &Skeleton, offsets: &[Vec<Vec3>], rest_global: &[glam::DMat4]) -> Result<ShapeBasis> {
        let n = skeleton.joint_count();
        let mut inverse_linear = Vec::with_capacity(n);
        for j in 0..n {
            let parent = match skeleton.parents[j] {
                Some(p) => rest_global[p],
                None => skeleton.root_parent[j].as_dmat4(),
            };
            let linear = DMat3::from_mat4(parent);
            let det = linear.determinant();
            if !det.is_finite() || det.abs() < 1e-12 {
                return Err(Error::InvalidSettings(format!(
                    "morph joint offsets: the rest frame of joint {j}'s parent is singular (a zero scale?), so \
                     the joint cannot follow the shape"
                )));
            }
            inverse_linear.push(linear.inverse());
        }
        let world: Vec<Vec<DVec3>> = offsets.iter().map(|o| o.iter().map(|v| v.as_dvec3()).collect()).collect();
        let local = world
            .iter()
            .map(|o| {
                (0..n)
                    .map(|j| {
                        let relative = match skeleton.parents[j] {
                            Some(p) => o[j] - o[p],
                            None => o[j],
                        };
                        inverse_linear[j] * relative
                    })
                    .collect()
            })
            .collect();
        Ok(ShapeBasis { world, local })
    }

    /// `Σ_k β_k · table_kj` for every joint.
    pub(super) fn combine(table: &[Vec<DVec3>], betas: &[f32], joint_count: usize) -> Vec<DVec3> {
        let mut out = vec![DVec3::ZERO; joint_count];
        for (list, &b) in table.iter().zip(betas) {
            if b != 0.0 {
                for (o, v) in out.iter_mut().zip(list) {
                    *o += *v * b as f64;
                }
            }
        }
        out
    }
}

//! The skinned mesh: a bind-pose mesh bound to a skeleton by up to four weighted joints per
//! vertex, and the checks of those bindings.

use super::{MorphTargets, Pose, Skeleton};
use crate::{Error, Mesh, Result};

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
    /// Morph targets (shape space; empty when the mesh has none).
    pub morphs: MorphTargets,
}

/// How far a vertex's weights may sum from 1 before [`SkinnedMesh::new`] rejects them.
pub const WEIGHT_SUM_TOLERANCE: f32 = 1e-3;

impl SkinnedMesh {
    /// Binds a mesh to a skeleton, checking everything: a valid skeleton ([`Skeleton::validate`]),
    /// one `joints` and one `weights` entry per mesh vertex, joint indices below the joint count,
    /// weights finite, non-negative and summing to 1 within [`WEIGHT_SUM_TOLERANCE`]. The weights
    /// are renormalised to sum to 1 exactly (to f32 precision).
    pub fn new(mesh: Mesh, skeleton: Skeleton, joints: Vec<[u16; 4]>, weights: Vec<[f32; 4]>) -> Result<SkinnedMesh> {
        skeleton.validate()?;
        let mut skinned = SkinnedMesh { mesh, skeleton, joints, weights, morphs: MorphTargets::default() };
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

    /// This mesh with morph targets (replacing any it had), after checking them against the mesh
    /// and the skeleton ([`MorphTargets::validate`]).
    pub fn with_morph_targets(mut self, morphs: MorphTargets) -> Result<SkinnedMesh> {
        morphs.validate(self.vertex_count(), self.joint_count())?;
        self.morphs = morphs;
        Ok(self)
    }

    /// Number of shape coefficients `β` (morph targets).
    pub fn shape_count(&self) -> usize {
        self.morphs.count()
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
    pub(super) fn check_bindings(&self) -> Result<()> {
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

    /// Validates the morph tables (the fields are public) and the shape coefficients.
    pub(super) fn check_shape(&self, betas: &[f32]) -> Result<()> {
        self.morphs.validate(self.vertex_count(), self.joint_count())?;
        self.morphs.check_betas(betas)
    }

    /// Validates the skeleton, the bindings (the fields are public) and the pose.
    pub(super) fn check(&self, pose: &Pose) -> Result<()> {
        self.skeleton.validate()?;
        self.check_bindings()?;
        pose.validate(self.joint_count())
    }
}

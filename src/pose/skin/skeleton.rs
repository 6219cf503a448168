//! The joint hierarchy: rest transforms relative to the parents, root-parent and inverse bind
//! matrices, and their validation.

use glam::{DMat4, Mat4, Quat, Vec3};

use super::lbs::JointState;
use super::Pose;
use crate::{Error, Result};

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
    /// Joint names (may be empty strings; glTF: the joint node's name).
    pub names: Vec<String>,
    /// The glTF node index of each joint, or empty when the skeleton does not come from a file
    /// (then any length other than 0 or one per joint is an error).
    pub nodes: Vec<usize>,
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

/// How far a rest rotation's quaternion norm may be from 1 before [`Skeleton::validate`] rejects it.
const QUAT_NORM_TOLERANCE: f64 = 1e-2;

impl JointRest {
    /// The identity transform: no translation, no rotation, unit scale.
    pub const IDENTITY: JointRest = JointRest { translation: Vec3::ZERO, rotation: Quat::IDENTITY, scale: Vec3::ONE };

    /// The rest transform as a matrix, `T(t) · R(q) · S(s)` (the quaternion is normalised first).
    pub fn to_mat4(&self) -> Mat4 {
        let (a, b) = self.factors();
        (a * b).as_mat4()
    }

    /// The two constant factors around the pose rotation, in f64: `A = T(t)·R(q)` and `B = S(s)`.
    pub(super) fn factors(&self) -> (DMat4, DMat4) {
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
        if !self.nodes.is_empty() && self.nodes.len() != n {
            return Err(Error::LengthMismatch {
                what: "skeleton joint node indices (none, or one per joint)",
                expected: n,
                got: self.nodes.len(),
            });
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
        let joints = JointState::new(self, &Pose::rest(self.joint_count()), &[]);
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
        let joints = JointState::new(self, &Pose::rest(self.joint_count()), &[]);
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

#[cfg(test)]
mod tests {
    use super::*;

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

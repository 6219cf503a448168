//! Pose parameters: per-joint rotation offsets, a global orientation and a root translation, and
//! their flat vector form.

use glam::Vec3;

use crate::{Error, Result};

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

    /// Checks that the pose has one rotation per joint, only finite values, and a translation
    /// within ±1e18 per component (beyond it the skinned positions overflow f32).
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
        if let Some(v) = super::skeleton::too_large(&self.translation.to_array()) {
            let max = super::skeleton::MAX_TRANSFORM_MAGNITUDE;
            return Err(Error::InvalidSettings(format!(
                "pose: the translation has a component {v:e}, beyond ±{max:e}; keep the model within that range \
                 (lower the learning rate if a fit drove it there)"
            )));
        }
        Ok(())
    }
}

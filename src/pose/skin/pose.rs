//! Pose parameters: per-joint rotation offsets, optional per-joint translation offsets and scale
//! factors, a global orientation and a root translation, and their flat vector form.

use glam::Vec3;

use crate::{Error, Result};

/// Pose parameters: what the fitting optimises.
#[derive(Clone, Debug, PartialEq)]
pub struct Pose {
    /// Axis–angle rotation offset per joint (radians), applied after the rest rotation.
    pub joint_rotations: Vec<Vec3>,
    /// Translation offset per joint, added to the joint's rest translation (in its parent's
    /// frame, world units), as glTF animations move joints; **empty** means all zero (the usual
    /// case: bones keep their lengths). Either empty or one per joint.
    pub joint_translations: Vec<Vec3>,
    /// Scale factor per joint, multiplying the joint's rest scale component by component (its
    /// local transform's `S(s_j)` becomes `S(s_j ⊙ σ_j)`), as glTF animations' scale channels
    /// scale joints; **empty** means all ones (the usual case). Either empty or one per joint.
    pub joint_scales: Vec<Vec3>,
    /// Global orientation, axis–angle (radians), about the world origin.
    pub orientation: Vec3,
    /// Root translation, world units.
    pub translation: Vec3,
}

impl Pose {
    /// The rest pose of a skeleton with `joint_count` joints: all offsets, the orientation and the
    /// translation zero, no joint translations.
    pub fn rest(joint_count: usize) -> Pose {
        Pose {
            joint_rotations: vec![Vec3::ZERO; joint_count],
            joint_translations: Vec::new(),
            joint_scales: Vec::new(),
            orientation: Vec3::ZERO,
            translation: Vec3::ZERO,
        }
    }

    /// This pose with explicit joint translations (zeros when it had none), so that
    /// [`Pose::to_params`] and the gradients of
    /// [`SkinnedMesh::backward`](super::SkinnedMesh::backward) include them.
    pub fn with_joint_translations(mut self) -> Pose {
        if self.joint_translations.is_empty() {
            self.joint_translations = vec![Vec3::ZERO; self.joint_count()];
        }
        self
    }

    /// Whether the pose carries joint translations (see [`Pose::joint_translations`]).
    pub fn has_joint_translations(&self) -> bool {
        !self.joint_translations.is_empty()
    }

    /// The translation offset of joint `j` (zero when the pose has none).
    pub fn joint_translation(&self, j: usize) -> Vec3 {
        self.joint_translations.get(j).copied().unwrap_or(Vec3::ZERO)
    }

    /// This pose with explicit joint scale factors (ones when it had none), so that
    /// [`Pose::to_params`] and the gradients of
    /// [`SkinnedMesh::backward`](super::SkinnedMesh::backward) include them.
    pub fn with_joint_scales(mut self) -> Pose {
        if self.joint_scales.is_empty() {
            self.joint_scales = vec![Vec3::ONE; self.joint_count()];
        }
        self
    }

    /// Whether the pose carries joint scale factors (see [`Pose::joint_scales`]).
    pub fn has_joint_scales(&self) -> bool {
        !self.joint_scales.is_empty()
    }

    /// The scale factor of joint `j` (ones when the pose has none).
    pub fn joint_scale(&self, j: usize) -> Vec3 {
        self.joint_scales.get(j).copied().unwrap_or(Vec3::ONE)
    }

    /// Number of scalar parameters of a pose for `joint_count` joints without joint translations:
    /// `3·joint_count + 6`.
    pub fn parameter_count(joint_count: usize) -> usize {
        3 * joint_count + 6
    }

    /// Number of scalar parameters of a pose for `joint_count` joints with joint translations:
    /// `6·joint_count + 6`.
    pub fn parameter_count_with_translations(joint_count: usize) -> usize {
        6 * joint_count + 6
    }

    /// Number of scalar parameters of a pose for `joint_count` joints with joint scale factors
    /// (and so joint translations, see [`Pose::to_params`]): `9·joint_count + 6`.
    pub fn parameter_count_with_scales(joint_count: usize) -> usize {
        9 * joint_count + 6
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
    /// `3·J + 6` values, followed, only when the pose has joint translations or scales, by
    /// `[τ_0.x, τ_0.y, τ_0.z, …, τ_{J−1}.z]` (zeros for a pose with scales but no translations;
    /// `6·J + 6` in all), and then, only when it has joint scales, by `[σ_0.x, …, σ_{J−1}.z]`
    /// (`9·J + 6` in all). The first `3·J + 6` values mean the same in every layout. A gradient
    /// returned as a [`Pose`] flattens the same way (it carries joint translations and scales
    /// exactly when the pose it was taken at does, so its layout is that pose's).
    pub fn to_params(&self) -> Vec<f32> {
        let mut params = Vec::with_capacity(Pose::parameter_count_with_scales(self.joint_count()));
        for r in &self.joint_rotations {
            params.extend_from_slice(&r.to_array());
        }
        params.extend_from_slice(&self.orientation.to_array());
        params.extend_from_slice(&self.translation.to_array());
        if self.has_joint_translations() || self.has_joint_scales() {
            for j in 0..self.joint_count() {
                params.extend_from_slice(&self.joint_translation(j).to_array());
            }
        }
        for s in &self.joint_scales {
            params.extend_from_slice(&s.to_array());
        }
        params
    }

    /// The inverse of [`Pose::to_params`]: `3·joint_count + 6` values give a pose without joint
    /// translations or scales, `6·joint_count + 6` one with joint translations, `9·joint_count +
    /// 6` one with joint translations and scales (a pose with scales and no translations comes
    /// back with zero translations: the same transforms). Errors for any other length or a
    /// non-finite value.
    pub fn from_params(params: &[f32], joint_count: usize) -> Result<Pose> {
        let expected = Pose::parameter_count(joint_count);
        let with_translations = Pose::parameter_count_with_translations(joint_count);
        let with_scales = Pose::parameter_count_with_scales(joint_count);
        if ![expected, with_translations, with_scales].contains(&params.len()) {
            return Err(Error::LengthMismatch {
                what: "pose parameters (3 per joint + 6, 6 per joint + 6 with joint translations, or 9 per joint + 6 \
                       with joint translations and scales)",
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
            joint_translations: if params.len() >= with_translations {
                (0..joint_count).map(|j| v(3 * joint_count + 6 + 3 * j)).collect()
            } else {
                Vec::new()
            },
            joint_scales: if params.len() == with_scales {
                (0..joint_count).map(|j| v(6 * joint_count + 6 + 3 * j)).collect()
            } else {
                Vec::new()
            },
            orientation: v(3 * joint_count),
            translation: v(3 * joint_count + 3),
        })
    }

    /// Checks that the pose has one rotation per joint, no or one translation and no or one scale
    /// factor per joint, only finite values, and translations and scale factors within ±1e18 per
    /// component (beyond it the skinned positions overflow f32).
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
        check_per_joint(
            &self.joint_translations,
            joint_count,
            "pose joint translations (none, or one per skeleton joint)",
            "translation",
        )?;
        check_per_joint(
            &self.joint_scales,
            joint_count,
            "pose joint scales (none, or one per skeleton joint)",
            "scale factor",
        )?;
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

/// Checks an optional per-joint list of a pose (`what`: its name in a length error; `name`: a
/// value's, "translation" or "scale factor"): empty or one per joint, finite, and within
/// ±[`MAX_TRANSFORM_MAGNITUDE`](super::skeleton::MAX_TRANSFORM_MAGNITUDE) per component.
fn check_per_joint(list: &[Vec3], joint_count: usize, what: &'static str, name: &str) -> Result<()> {
    if !list.is_empty() && list.len() != joint_count {
        return Err(Error::LengthMismatch { what, expected: joint_count, got: list.len() });
    }
    if let Some(j) = list.iter().position(|v| !v.is_finite()) {
        return Err(Error::InvalidSettings(format!(
            "pose: the {name} of joint {j} is {:?}; every pose parameter must be a finite number",
            list[j]
        )));
    }
    if let Some((j, v)) =
        list.iter().enumerate().find_map(|(j, t)| Some((j, super::skeleton::too_large(&t.to_array())?)))
    {
        let max = super::skeleton::MAX_TRANSFORM_MAGNITUDE;
        return Err(Error::InvalidSettings(format!(
            "pose: the {name} of joint {j} has a component {v:e}, beyond ±{max:e}; keep the model within that range \
             (lower the learning rate if a fit drove it there)"
        )));
    }
    Ok(())
}

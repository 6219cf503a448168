//! The priors of a [`PoseFit`]'s energy: the pose prior `μ·E_prior` and the shape prior
//! `ν·E_shape`, their weights and gradients. A child of `descent.rs`, in its own file.

use super::PoseFit;
use crate::{Error, Result};

impl PoseFit {
    /// Weight `μ` of the pose prior: the energy gains `μ·E_prior` with
    /// `E_prior = (1/J) Σ_j |θ_j|²`, the mean squared rotation offset (radians²) of the `J`
    /// joints; global orientation and translation are free. 0 (none) unless set; the method's
    /// value is [`PoseFit::POSE_PRIOR`]. Errors on a negative or non-finite weight.
    ///
    /// This is a zero-mean Gaussian prior on the offsets (the energy is then a negative log
    /// posterior): silhouettes barely see a limb's twist about its own axis, which a joint and its
    /// child can also trade between them, so without a prior those directions drift wherever
    /// the noise of the descent takes them. The prior keeps them near the rest pose unless the
    /// silhouettes say otherwise, and hands a rotation of the whole body from the root joint to the
    /// global orientation, which it does not penalise.
    pub fn set_pose_prior(&mut self, weight: f32) -> Result<()> {
        check_prior_weight("pose", weight)?;
        self.pose_prior = weight;
        Ok(())
    }

    /// The weight `μ` ([`PoseFit::set_pose_prior`]).
    pub fn pose_prior(&self) -> f32 {
        self.pose_prior
    }

    /// The pose prior's weight in force: `μ` times the current stage's
    /// [`Stage::prior_scale`](super::Stage::prior_scale) during [`PoseFit::run`], `μ` outside it.
    pub(super) fn pose_prior_weight(&self) -> f32 {
        self.pose_prior * self.prior_scale
    }

    /// Sets the multiple of `μ` in force ([`PoseFit::run`] sets it per stage, and back to 1 at
    /// its end).
    pub(in crate::pose::fit) fn set_prior_scale(&mut self, scale: f32) {
        self.prior_scale = scale;
    }

    /// Weight `ν` of the shape prior: the energy gains `ν·E_shape` with
    /// `E_shape = (1/K) Σ_k β_k²` over the `K` morph targets, a zero-mean Gaussian prior on the
    /// shape (morph targets are authored so that ±1 is an extreme body). 0 unless set; the
    /// method's value is [`PoseFit::SHAPE_PRIOR`]. Errors on a negative or non-finite weight.
    pub fn set_shape_prior(&mut self, weight: f32) -> Result<()> {
        check_prior_weight("shape", weight)?;
        self.shape_prior = weight;
        Ok(())
    }

    /// `E_shape` at the current shape.
    pub(super) fn shape_energy(&self) -> f64 {
        let betas = self.shape();
        betas.iter().map(|&b| f64::from(b) * f64::from(b)).sum::<f64>() / betas.len().max(1) as f64
    }

    /// `E_prior` at the current pose.
    pub(super) fn prior_energy(&self) -> f64 {
        let joints = self.model.joint_count();
        let offsets = &self.params[..3 * joints];
        offsets.iter().map(|&t| f64::from(t) * f64::from(t)).sum::<f64>() / joints.max(1) as f64
    }

    /// Adds `μ·∂E_prior/∂θ = 2μ θ / J` to the joint offsets' entries of `grads`.
    pub(super) fn add_prior_gradient(&self, grads: &mut [f32]) {
        let weight = self.pose_prior_weight();
        if weight > 0.0 {
            let joints = self.model.joint_count();
            let scale = 2.0 * weight / joints as f32;
            for (g, &t) in grads.iter_mut().zip(&self.params[..3 * joints]) {
                *g += scale * t;
            }
        }
    }
}

/// Errors ([`Error::InvalidSettings`]) on a negative or non-finite weight of the `which`
/// ("pose" or "shape") prior ([`PoseFit::set_pose_prior`], [`PoseFit::set_shape_prior`],
/// [`FitOptions::validate`](super::FitOptions::validate)).
pub(in crate::pose::fit) fn check_prior_weight(which: &str, weight: f32) -> Result<()> {
    if weight.is_finite() && weight >= 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidSettings(format!("need a non-negative {which} prior weight, got {weight}")))
    }
}

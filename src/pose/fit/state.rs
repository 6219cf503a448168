//! [`FitState`]: a [`PoseFit`]'s optimiser state, taken out and put back, so that one fit can
//! follow several hypotheses (`hypotheses.rs`) or swap candidates (`swap.rs`).

use super::PoseFit;
use crate::optim::Adam;
use crate::pose::self_intersection::SelfIntersection;
use crate::pose::skin::Pose;
use crate::{Error, Result};

/// The optimiser's state: the pose parameters, Adam's moments, the nuisances and the last
/// self-intersection check. [`PoseFit::state`] and
/// [`PoseFit::set_state`] move it in and out, so that one fit can follow several hypotheses.
#[derive(Clone, Debug)]
pub struct FitState {
    pub(in crate::pose::fit) params: Vec<f32>,
    pub(in crate::pose::fit) adam: Adam,
    pub(in crate::pose::fit) inflation: f32,
    pub(in crate::pose::fit) inflation_adam: Adam,
    pub(in crate::pose::fit) outline: f32,
    pub(in crate::pose::fit) outline_adam: Adam,
    /// The last self-intersection check and the steps since (reused between checks): part of
    /// the state so that hypotheses stepped in lock-step each keep their own.
    pub(in crate::pose::fit) intersection: Option<(SelfIntersection, u32)>,
}

impl PoseFit {
    /// The optimiser's state (pose parameters and Adam's moments).
    pub fn state(&self) -> FitState {
        FitState {
            params: self.params.clone(),
            adam: self.adam.clone(),
            inflation: self.inflation,
            inflation_adam: self.inflation_adam.clone(),
            outline: self.outline,
            outline_adam: self.outline_adam.clone(),
            intersection: self.intersection.clone(),
        }
    }

    /// Restores a state taken by [`PoseFit::state`] from this fit.
    pub fn set_state(&mut self, state: FitState) -> Result<()> {
        if state.params.len() != self.params.len() {
            return Err(Error::LengthMismatch {
                what: "fit state parameters",
                expected: self.params.len(),
                got: state.params.len(),
            });
        }
        self.params = state.params;
        self.adam = state.adam;
        self.inflation = state.inflation;
        self.inflation_adam = state.inflation_adam;
        self.outline = state.outline;
        self.outline_adam = state.outline_adam;
        self.intersection = state.intersection;
        Ok(())
    }

    /// The shape [`PoseFit::restart`] goes back to set to `shape` (of the model's length: a
    /// fit's own shape); the one it replaces.
    pub(in crate::pose::fit) fn replace_initial_shape(&mut self, shape: Vec<f32>) -> Vec<f32> {
        debug_assert_eq!(shape.len(), self.initial_shape.len());
        std::mem::replace(&mut self.initial_shape, shape)
    }

    /// Moves to `pose`, the initial shape and no inflation, and forgets Adam's moments (a fresh start from
    /// there). Errors when `pose` does not fit the skeleton or carries joint translations where
    /// the fit's initial pose did not (or the other way round).
    pub fn restart(&mut self, pose: &Pose) -> Result<()> {
        pose.validate(self.model.joint_count())?;
        let mut params = pose.to_params();
        if params.len() != self.pose_len {
            return Err(Error::LengthMismatch {
                what: "restart pose parameters",
                expected: self.pose_len,
                got: params.len(),
            });
        }
        params.extend_from_slice(&self.initial_shape);
        self.params = params;
        self.adam = Adam::new(self.adam.learning_rate);
        self.inflation = 0.0;
        self.inflation_adam = Adam::new(self.inflation_adam.learning_rate);
        self.outline = 0.0;
        self.outline_adam = Adam::new(self.outline_adam.learning_rate);
        self.intersection = None;
        Ok(())
    }
}

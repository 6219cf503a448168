//! [`FitOptions::plan`]: the schedule and the starting poses a set of [`FitOptions`] gives for a
//! model.

use super::{limb_swing_hypotheses, turned_about_vertical, FitOptions, Schedule, Stage};
use crate::pose::skin::{Pose, SkinnedMesh};
use crate::Result;

impl FitOptions {
    /// The schedule and the starting poses [`fit`](super::fit) uses for `model`.
    ///
    /// With `fit_pose` and a blur, the starting poses are [`limb_swing_hypotheses`] applied on
    /// top of the initial pose (its joint offsets added to each), and the schedule is
    /// [`Schedule::coarse_to_fine`] with the blur scaled to `coarse_blur`, the blurred
    /// stages' prior scale set to `coarse_prior_scale` and the unblurred stage's outline settle
    /// and learning-rate ramp to `outline_settle` and `warmup`. Without blur: one unblurred
    /// stage from the initial pose, which keeps the outline and has no ramp. Without
    /// `fit_pose`, the initial pose alone. With [`FitOptions::facings`], all of that for the
    /// initial pose turned by each facing ([`turned_about_vertical`]), facing by facing (the
    /// starting poses of facing `k` are the `k`-th run of equal length), with the hypothesis
    /// steps a single facing's starting poses would have.
    pub fn plan(&self, model: &SkinnedMesh) -> Result<(Schedule, Vec<Pose>)> {
        self.validate()?;
        let initial = self.initial.clone().unwrap_or_else(|| Pose::rest(model.joint_count()));
        initial.validate(model.joint_count())?;
        if self.coarse_blur == 0.0 {
            let stages = vec![Stage::new(0.0, self.steps)];
            return Ok((Schedule { hypothesis_steps: 0, stages, convergence: self.convergence }, vec![initial]));
        }
        let swings =
            if self.fit_pose { limb_swing_hypotheses(model, self.leg_stride, self.arm_swing)? } else { Vec::new() };
        let per_facing = swings.len().max(1);
        let facings: &[f32] = if self.facings.is_empty() { &[0.0] } else { &self.facings };
        let mut hypotheses = Vec::with_capacity(facings.len() * per_facing);
        for &facing in facings {
            let turned = turned_about_vertical(model, &initial, facing)?;
            if swings.is_empty() {
                hypotheses.push(turned);
                continue;
            }
            for h in &swings {
                let joint_rotations =
                    h.joint_rotations.iter().zip(&turned.joint_rotations).map(|(a, b)| *a + *b).collect();
                hypotheses.push(Pose { joint_rotations, ..turned.clone() });
            }
        }
        // Each facing's starting poses take the steps a fit from one facing would give them.
        let mut schedule = Schedule::coarse_to_fine(self.steps, per_facing);
        let scale = self.coarse_blur / Schedule::COARSE_BLUR;
        for stage in &mut schedule.stages {
            stage.blur *= scale;
            if stage.blur > 0.0 {
                stage.prior_scale = self.coarse_prior_scale;
            } else {
                stage.outline_settle = self.outline_settle;
                stage.warmup = self.warmup;
            }
        }
        schedule.convergence = self.convergence;
        Ok((schedule, hypotheses))
    }
}

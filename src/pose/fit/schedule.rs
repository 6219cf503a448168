//! The coarse-to-fine, multi-hypothesis schedule and [`PoseFit::run`], which follows it.

use super::{PoseFit, StepReport};
use crate::pose::skin::Pose;
use crate::Result;

/// One stage of a [`Schedule`]: this many steps with the silhouettes blurred by a Gaussian of
/// standard deviation `blur` × the image height.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stage {
    /// Standard deviation of the blur, as a fraction of the image height (0: no blur).
    pub blur: f32,
    /// Adam steps.
    pub steps: u32,
}

/// A coarse-to-fine, multi-hypothesis schedule for [`PoseFit::run`]: every hypothesis runs
/// `hypothesis_steps` steps with the blur of the first stage, the one with the lowest energy is
/// kept, and it runs every stage in turn.
#[derive(Clone, Debug, PartialEq)]
pub struct Schedule {
    /// Steps each hypothesis gets before one is chosen.
    pub hypothesis_steps: u32,
    /// The stages the chosen hypothesis runs, coarse to fine.
    pub stages: Vec<Stage>,
}

impl Schedule {
    /// Blur of the coarsest stage: 6% of the image height (3.8 pixels at 64², 1.9 at 32²).
    pub const COARSE_BLUR: f32 = 0.06;

    /// The default schedule: `total_steps` Adam steps in all, shared by `hypotheses` starting
    /// poses. Each hypothesis gets a tenth of the steps at blur [`Schedule::COARSE_BLUR`]
    /// (fewer if there are more than five, so that half the steps are left); the chosen one
    /// continues with a twentieth of the steps at the same blur, a twelfth at half that blur,
    /// and the rest unblurred. For 300 steps and 3 hypotheses: 3 × 30, then 15, 25 and 170.
    /// Every resolution and supersampling gets the same schedule.
    pub fn coarse_to_fine(total_steps: u32, hypotheses: usize) -> Schedule {
        let hypotheses = hypotheses.max(1) as u32;
        let hypothesis_steps = (total_steps / 10).min(total_steps / (2 * hypotheses));
        let coarse = total_steps / 20;
        let middle = total_steps / 12;
        let fine = total_steps.saturating_sub(hypotheses * hypothesis_steps + coarse + middle);
        Schedule {
            hypothesis_steps,
            stages: vec![
                Stage { blur: Self::COARSE_BLUR, steps: coarse },
                Stage { blur: Self::COARSE_BLUR / 2.0, steps: middle },
                Stage { blur: 0.0, steps: fine },
            ],
        }
    }

    /// Steps [`PoseFit::run`] takes with this schedule and `hypotheses` starting poses.
    pub fn total_steps(&self, hypotheses: usize) -> u32 {
        hypotheses.max(1) as u32 * self.hypothesis_steps + self.stages.iter().map(|s| s.steps).sum::<u32>()
    }
}

/// Where [`PoseFit::run`] is, passed to its callback after every step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Steps taken so far, all hypotheses included (1 after the first).
    pub step: u32,
    /// The hypothesis being run, while they are tried; `None` once one has been chosen.
    pub hypothesis: Option<usize>,
    /// The blur of this step (fraction of the image height).
    pub blur: f32,
    /// The step's energies.
    pub report: StepReport,
}

/// What [`PoseFit::run`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct RunReport {
    /// Adam steps taken, all hypotheses included.
    pub steps: u32,
    /// Energy `E` (unblurred, [`PoseFit::energy`]) of each hypothesis after its steps.
    pub hypothesis_energies: Vec<f64>,
    /// The hypothesis that was kept.
    pub chosen: usize,
    /// Energy at the final pose (unblurred).
    pub energy: f64,
}

impl PoseFit {
    /// Runs a whole fit: each of `hypotheses` (starting poses; the current pose when empty) for
    /// `schedule.hypothesis_steps` steps at the first stage's blur, each from a fresh Adam, then
    /// the one with the lowest energy ([`PoseFit::energy`]) through every stage of `schedule`,
    /// keeping its Adam state. Calls `on_step` after every step. Ends unblurred, at the chosen
    /// hypothesis's final pose. Errors (and stops) on the first step that errors.
    pub fn run(
        &mut self,
        schedule: &Schedule,
        hypotheses: &[Pose],
        mut on_step: impl FnMut(&PoseFit, &Progress),
    ) -> Result<RunReport> {
        let first_blur = schedule.stages.first().map_or(0.0, |s| s.blur);
        let mut step = 0;
        let mut states = Vec::new();
        let mut energies = Vec::new();
        let current = self.pose();
        let starts = if hypotheses.is_empty() { std::slice::from_ref(&current) } else { hypotheses };
        for (k, start) in starts.iter().enumerate() {
            self.restart(start)?;
            self.set_blur(first_blur)?;
            for _ in 0..schedule.hypothesis_steps {
                let report = self.step()?;
                step += 1;
                on_step(self, &Progress { step, hypothesis: Some(k), blur: self.blur(), report });
            }
            energies.push(self.energy()?);
            states.push(self.state());
        }
        let chosen = energies
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map(|(k, _)| k)
            .expect("at least one hypothesis");
        self.set_state(states.swap_remove(chosen))?;
        for stage in &schedule.stages {
            self.set_blur(stage.blur)?;
            for _ in 0..stage.steps {
                let report = self.step()?;
                step += 1;
                on_step(self, &Progress { step, hypothesis: None, blur: self.blur(), report });
            }
        }
        self.set_blur(0.0)?;
        let energy = self.energy()?;
        Ok(RunReport { steps: step, hypothesis_energies: energies, chosen, energy })
    }
}

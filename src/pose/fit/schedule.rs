//! The coarse-to-fine, multi-hypothesis schedule and [`PoseFit::run`], which follows it, with
//! its convergence rule and cancellation.

use std::ops::ControlFlow;

use super::{PoseFit, StepReport};
use crate::pose::skin::Pose;
use crate::{Error, Result};

/// One stage of a [`Schedule`]: this many steps with the silhouettes blurred by a Gaussian of
/// standard deviation `blur` × the image height, the pose prior's weight `μ` multiplied by
/// `prior_scale`, and the outline nuisance dropped at its start when it has settled below
/// `outline_settle`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stage {
    /// Standard deviation of the blur, as a fraction of the image height (0: no blur).
    pub blur: f32,
    /// Adam steps.
    pub steps: u32,
    /// The pose prior's weight during the stage, as a multiple of the fit's `μ`
    /// ([`PoseFit::set_pose_prior`]), finite and ≥ 0; 1 keeps `μ`.
    pub prior_scale: f32,
    /// At the start of the stage, a fitted outline nuisance ([`PoseFit::outline`]) with `|a|`
    /// below this is dropped: `a` is set to 0 and no longer fitted (its rate set to 0,
    /// [`PoseFit::set_outline_rate`]) for the rest of the run and after it. Finite and ≥ 0; 0
    /// keeps the outline as it is. See [`FitOptions::outline_settle`](super::FitOptions::outline_settle)
    /// for why and what it costs.
    pub outline_settle: f32,
    /// Steps over which Adam's learning rate ramps up at the start of the stage: step `k` of
    /// the first `warmup` (from 1) takes `k / (warmup + 1)` times the fit's rate
    /// ([`PoseFit::learning_rate`]), the later ones the rate itself; 0: no ramp.
    ///
    /// Where the blur ends, the sharp silhouettes' gradients are larger than the blurred ones
    /// whose squares Adam's second moments remember, so in the first unblurred steps every
    /// parameter moves up to two or three times the learning rate at once: a fit of the
    /// built-in figure goes from about 14 to about 30 mm per vertex in its first unblurred step
    /// (seeds 31–40) and takes tens of steps to come back. Ramped over 10 steps, the error
    /// stays where the blurred stages left it (13.9 → 14.0 mm on seed 31). See
    /// [`FitOptions::warmup`](super::FitOptions::warmup) for what it does to whole fits.
    pub warmup: u32,
}

impl Stage {
    /// `steps` steps at `blur`, with the fit's own pose prior weight (`prior_scale` 1), the
    /// outline kept (`outline_settle` 0) and no learning-rate ramp (`warmup` 0).
    pub fn new(blur: f32, steps: u32) -> Stage {
        Stage { blur, steps, prior_scale: 1.0, outline_settle: 0.0, warmup: 0 }
    }
}

/// A coarse-to-fine, multi-hypothesis schedule for [`PoseFit::run`]: every hypothesis runs
/// `hypothesis_steps` steps with the blur and prior scale of the first stage, the one with the
/// lowest energy is kept, and it runs every stage in turn.
#[derive(Clone, Debug, PartialEq)]
pub struct Schedule {
    /// Steps each hypothesis gets before one is chosen.
    pub hypothesis_steps: u32,
    /// The stages the chosen hypothesis runs, coarse to fine.
    pub stages: Vec<Stage>,
    /// When the last stage may end early; `None`: it runs all its steps.
    pub convergence: Option<Convergence>,
}

/// The early-stopping rule of [`PoseFit::run`]: the last stage ends after a step where the mean
/// step energy ([`StepReport::energy`]) of its last `window` steps is not below `(1 − tolerance)`
/// times the mean of the `window` steps before them. Only the last stage stops early (the
/// earlier ones are short and blurred), and never before `2·window` of its steps. Comparing
/// means rather than single steps lets the rule ignore Adam's step-to-step noise and the
/// transient where the blur changes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Convergence {
    /// Steps per window, ≥ 1.
    pub window: u32,
    /// Relative decrease of the windows' mean energy below which the fit has converged, ≥ 0.
    pub tolerance: f64,
}

impl Default for Convergence {
    /// Windows of 25 steps, 0.5%.
    fn default() -> Self {
        Convergence { window: 25, tolerance: 0.005 }
    }
}

impl Convergence {
    /// Whether the stage's step energies so far (`energies`, oldest first) meet the rule.
    pub fn met(&self, energies: &[f64]) -> bool {
        let w = self.window.max(1) as usize;
        if energies.len() < 2 * w {
            return false;
        }
        let n = energies.len();
        let mean = |s: &[f64]| s.iter().sum::<f64>() / s.len() as f64;
        let (before, last) = (mean(&energies[n - 2 * w..n - w]), mean(&energies[n - w..]));
        last >= (1.0 - self.tolerance) * before
    }
}

/// Why [`PoseFit::run`] ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// Every step of the schedule was taken.
    Finished,
    /// The last stage met the [`Convergence`] rule.
    Converged,
    /// The callback returned [`ControlFlow::Break`].
    Cancelled,
}

impl Schedule {
    /// Blur of the coarsest stage: 6% of the image height (3.8 pixels at 64², 1.9 at 32²).
    pub const COARSE_BLUR: f32 = 0.06;

    /// The pose prior's weight in the blurred stages, as a multiple of the fit's `μ`: 10.
    ///
    /// While the silhouettes are blurred they cannot place a limb's twist or tell which way
    /// the body faces within a few tens of degrees, and a weak prior lets the joints take up
    /// rotations that belong to the whole body (a walking figure fitted from its T-pose ended
    /// turned 90° with its legs striding sideways). A prior ten times stronger keeps the joints
    /// near the rest pose while the global orientation and the large limb motions settle; the
    /// unblurred stage then fits the details with `μ` itself, as SMPLify anneals its prior.
    pub const COARSE_PRIOR_SCALE: f32 = 10.0;

    /// The default schedule: `total_steps` Adam steps in all, shared by `hypotheses` starting
    /// poses. Each hypothesis gets a tenth of the steps at blur [`Schedule::COARSE_BLUR`]
    /// (fewer if there are more than five, so that half the steps are left); the chosen one
    /// continues with a twentieth of the steps at the same blur, a twelfth at half that blur,
    /// and the rest unblurred. For 300 steps and 3 hypotheses: 3 × 30, then 15, 25 and 170.
    /// The blurred stages weigh the pose prior [`Schedule::COARSE_PRIOR_SCALE`] times more.
    /// Every resolution and supersampling gets the same schedule.
    pub fn coarse_to_fine(total_steps: u32, hypotheses: usize) -> Schedule {
        let hypotheses = hypotheses.max(1) as u32;
        let hypothesis_steps = (total_steps / 10).min(total_steps / (2 * hypotheses));
        let coarse = total_steps / 20;
        let middle = total_steps / 12;
        let fine = total_steps.saturating_sub(hypotheses * hypothesis_steps + coarse + middle);
        Schedule {
            convergence: None,
            hypothesis_steps,
            stages: vec![
                Stage { prior_scale: Self::COARSE_PRIOR_SCALE, ..Stage::new(Self::COARSE_BLUR, coarse) },
                Stage { prior_scale: Self::COARSE_PRIOR_SCALE, ..Stage::new(Self::COARSE_BLUR / 2.0, middle) },
                Stage::new(0.0, fine),
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
    /// Why the run ended.
    pub stop: Stop,
}

impl PoseFit {
    /// Runs a whole fit: each of `hypotheses` (starting poses; the current pose when empty) for
    /// `schedule.hypothesis_steps` steps at the first stage's blur and prior scale, each from a
    /// fresh Adam, then the one with the lowest energy ([`PoseFit::energy`], with that prior
    /// scale) through every stage of `schedule`, keeping its Adam state; the last stage ends
    /// early when `schedule.convergence` says so. Calls `on_step` after every step:
    /// [`ControlFlow::Break`] cancels the run, which then ends where it is (the hypothesis
    /// being tried counts as the chosen one). Ends unblurred, with the pose prior's weight back
    /// at `μ`. A stage's [`Stage::outline_settle`] may drop the outline nuisance as the stage
    /// begins, and its [`Stage::warmup`] ramps the learning rate over its first steps (the
    /// fit's rate is back after each). Errors (and stops) on the first step that errors, or before the first step on a
    /// stage whose `prior_scale` or `outline_settle` is negative or not finite.
    pub fn run(
        &mut self,
        schedule: &Schedule,
        hypotheses: &[Pose],
        on_step: impl FnMut(&PoseFit, &Progress) -> ControlFlow<()>,
    ) -> Result<RunReport> {
        for stage in &schedule.stages {
            check_prior_scale(stage.prior_scale)?;
        }
        for stage in &schedule.stages {
            check_outline_settle(stage.outline_settle)?;
        }
        let result = self.run_schedule(schedule, hypotheses, on_step);
        if result.is_err() {
            // A step failed mid-stage: later steps the caller takes weigh the prior by μ.
            self.set_prior_scale(1.0);
        }
        result
    }

    /// [`PoseFit::run`] after its checks.
    fn run_schedule(
        &mut self,
        schedule: &Schedule,
        hypotheses: &[Pose],
        mut on_step: impl FnMut(&PoseFit, &Progress) -> ControlFlow<()>,
    ) -> Result<RunReport> {
        let first_blur = schedule.stages.first().map_or(0.0, |s| s.blur);
        self.set_prior_scale(schedule.stages.first().map_or(1.0, |s| s.prior_scale));
        let mut step = 0;
        let mut states = Vec::new();
        let mut hypothesis_energies = Vec::new();
        let current = self.pose();
        let starts = if hypotheses.is_empty() { std::slice::from_ref(&current) } else { hypotheses };
        // The hypotheses run in lock-step, one render batch per step; the steps are reported
        // hypothesis after hypothesis, the fit at each step's state, as if they had run in turn.
        for (k, hypothesis) in
            self.run_hypotheses(starts, first_blur, schedule.hypothesis_steps)?.into_iter().enumerate()
        {
            for (report, state) in hypothesis.steps {
                self.set_state(state)?;
                step += 1;
                if on_step(self, &Progress { step, hypothesis: Some(k), blur: self.blur(), report }).is_break() {
                    return self.end(step, hypothesis_energies, k, Stop::Cancelled);
                }
            }
            hypothesis_energies.push(hypothesis.energy);
            states.push(hypothesis.state);
        }
        let chosen = hypothesis_energies
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map(|(k, _)| k)
            .expect("at least one hypothesis");
        self.set_state(states.swap_remove(chosen))?;
        let last = schedule.stages.len().saturating_sub(1);
        for (s, stage) in schedule.stages.iter().enumerate() {
            self.set_blur(stage.blur)?;
            self.set_prior_scale(stage.prior_scale);
            if self.outline_rate() > 0.0 && self.outline().abs() < stage.outline_settle {
                self.set_outline(0.0)?;
                self.set_outline_rate(0.0)?;
            }
            let rule = if s == last { schedule.convergence } else { None };
            let mut energies = Vec::new();
            let rate = self.learning_rate();
            for k in 0..stage.steps {
                let report = if k < stage.warmup {
                    self.set_learning_rate(rate * (k + 1) as f32 / stage.warmup.saturating_add(1) as f32)?;
                    let report = self.step();
                    self.set_learning_rate(rate)?;
                    report?
                } else {
                    self.step()?
                };
                step += 1;
                if on_step(self, &Progress { step, hypothesis: None, blur: self.blur(), report }).is_break() {
                    return self.end(step, hypothesis_energies, chosen, Stop::Cancelled);
                }
                if let Some(rule) = rule {
                    energies.push(report.energy);
                    if rule.met(&energies) {
                        return self.end(step, hypothesis_energies, chosen, Stop::Converged);
                    }
                }
            }
        }
        self.end(step, hypothesis_energies, chosen, Stop::Finished)
    }

    /// Ends a run: no blur, the prior at `μ`, the final energy, the report.
    fn end(&mut self, steps: u32, hypothesis_energies: Vec<f64>, chosen: usize, stop: Stop) -> Result<RunReport> {
        self.set_blur(0.0)?;
        self.set_prior_scale(1.0);
        let energy = self.energy()?;
        Ok(RunReport { steps, hypothesis_energies, chosen, energy, stop })
    }
}

/// Errors ([`Error::InvalidSettings`]) on a negative or non-finite [`Stage::prior_scale`]
/// ([`PoseFit::run`], [`FitOptions::validate`](super::FitOptions::validate)).
pub(in crate::pose::fit) fn check_prior_scale(scale: f32) -> Result<()> {
    if scale.is_finite() && scale >= 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidSettings(format!("need a non-negative prior scale, got {scale}")))
    }
}

/// Errors ([`Error::InvalidSettings`]) on a negative or non-finite [`Stage::outline_settle`]
/// ([`PoseFit::run`], [`FitOptions::validate`](super::FitOptions::validate)).
pub(in crate::pose::fit) fn check_outline_settle(settle: f32) -> Result<()> {
    if settle.is_finite() && settle >= 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidSettings(format!("need a finite, non-negative outline settle, got {settle}")))
    }
}

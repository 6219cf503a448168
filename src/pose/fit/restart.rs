//! What [`fit`](super::fit) does last where its result still misses a piece of the targets
//! ([`misfit_blocks`]) or its targets look thinned (the outline nuisance near −1): the whole
//! method once more from other starting poses (the arms swung forward and back,
//! [`FitOptions::restart_arm_swing`]; for thinned targets each family of
//! [`FitOptions::thinned_restarts`], then a run from the lowest end alone without the coarsest
//! stage, [`FitOptions::thinned_final_run`]), and the fit ends at the lowest energy.

use std::ops::ControlFlow;

use super::pass::run_pass;
use super::{FitOptions, FitState, PassReport, PoseFit, Progress, Schedule};
use crate::pose::skin::Pose;
use crate::{Error, Image, Result};

/// Per view, the 2×2 blocks of pixels where `renders` and `targets` differ by more than half a
/// pixel's coverage, all four the same way (all more covered in the render, or all less): a
/// piece of the body at least two pixels wide in the wrong place. A fit that matches its masks
/// up to a boundary offset of a pixel, or up to scattered flipped pixels, has none: a boundary
/// offset is one pixel wide and a flipped pixel alone. A pixel that is NaN in either image
/// counts as matching; an empty image has no block. Errors where the counts differ
/// ([`Error::LengthMismatch`]) or the sizes ([`Error::SizeMismatch`]).
pub fn misfit_blocks(renders: &[Image], targets: &[Image]) -> Result<Vec<u32>> {
    if renders.len() != targets.len() {
        return Err(Error::LengthMismatch { what: "misfit renders", expected: targets.len(), got: renders.len() });
    }
    renders
        .iter()
        .zip(targets)
        .map(|(render, target)| {
            render.expect_size("misfit render", target.width(), target.height())?;
            let w = render.width() as usize;
            if w == 0 {
                return Ok(0);
            }
            // -1, 0 or 1: how the pixel differs, where by more than half its coverage.
            let sign: Vec<i8> = render
                .data()
                .iter()
                .zip(target.data())
                .map(|(r, t)| {
                    let d = r - t;
                    i8::from(d > 0.5) - i8::from(d < -0.5)
                })
                .collect();
            let mut blocks = 0;
            for (upper, lower) in sign.chunks_exact(w).zip(sign.chunks_exact(w).skip(1)) {
                for x in 1..w {
                    let s = upper[x];
                    if s != 0 && upper[x - 1] == s && lower[x - 1] == s && lower[x] == s {
                        blocks += 1;
                    }
                }
            }
            Ok(blocks)
        })
        .collect()
}

/// How a restart runs the method again: its family of starting poses
/// ([`limb_swing_hypotheses`](super::limb_swing_hypotheses): the legs' stride and the arms'
/// swing, in radians, both finite and ≥ 0) and whether its coarsest steps render the coarse
/// proxy as the first pass's do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestartFamily {
    /// Leg stride of the extra starting poses ([`FitOptions::leg_stride`]).
    pub leg_stride: f32,
    /// Arm swing of the extra starting poses ([`FitOptions::arm_swing`]).
    pub arm_swing: f32,
    /// Whether the steps at the coarsest blur render the coarse proxy of
    /// [`FitOptions::coarse_proxy`] (where that is not 0); false: the whole mesh, as a fit with
    /// `coarse_proxy` 0 would.
    pub coarse_proxy: bool,
}

impl RestartFamily {
    /// The family with this leg stride and arm swing, on the fit's coarse proxy.
    pub const fn swing(leg_stride: f32, arm_swing: f32) -> RestartFamily {
        RestartFamily { leg_stride, arm_swing, coarse_proxy: true }
    }

    /// Errors ([`Error::InvalidSettings`]) where either angle is not finite or is negative.
    pub fn validate(&self) -> Result<()> {
        if [self.leg_stride, self.arm_swing].iter().all(|a| a.is_finite() && *a >= 0.0) {
            Ok(())
        } else {
            Err(Error::InvalidSettings(format!(
                "a restart's leg stride and arm swing must be finite and ≥ 0, got {} and {}",
                self.leg_stride, self.arm_swing
            )))
        }
    }
}

/// Where a restart of [`fit`](super::fit) starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RestartStart {
    /// The whole method from a family's starting poses.
    Family(RestartFamily),
    /// The lowest end so far (the first pass's or a family's pose and shape) alone, without the
    /// coarsest stage ([`FitOptions::thinned_final_run`]).
    LowestEnd,
}

/// What [`fit`](super::fit) found where its first pass (the first run, its swap test and the
/// runs from the crossed legs) ended, and the restarts where they ran.
#[derive(Clone, Debug, PartialEq)]
pub struct RestartReport {
    /// [`misfit_blocks`] of the first pass's result, per view: the restart from the arms swung
    /// ([`FitOptions::restart_arm_swing`]) runs where any is not 0.
    pub misfit_blocks: Vec<u32>,
    /// Whether the first pass found its targets thinned: its outline nuisance
    /// ([`PoseFit::outline`]) at or below [`FitOptions::thinned_below`]. The restarts of
    /// [`FitOptions::thinned_restarts`] then run, whatever the misfit blocks.
    pub thinned: bool,
    /// The energy ([`PoseFit::energy`]) where the first pass ended.
    pub first_energy: f64,
    /// The restarts that ran, in order (for thinned targets the families', then the run from
    /// the lowest end); empty where none did: no misfit block and targets not thinned, or every
    /// restart's starting poses were the first run's (a fit without blur has only the initial
    /// pose, and no stage after the coarsest for the run from the lowest end) or an earlier
    /// restart's.
    pub runs: Vec<RestartRun>,
    /// Which of `runs` the fit ends at: the lowest energy, where strictly below `first_energy`
    /// (an earlier run where two end at the same); `None`: the first pass's result.
    pub kept: Option<usize>,
}

/// The method run again, from other starting poses or from the lowest end so far.
#[derive(Clone, Debug, PartialEq)]
pub struct RestartRun {
    /// Where it started.
    pub start: RestartStart,
    /// The pass: its run (its steps follow the first pass's and the earlier restarts' in the
    /// callback's [`Progress`]), swap test and crossed legs.
    pub pass: PassReport,
    /// The energy where it ended; `None` when its own run was cancelled ([`PassReport::ended`]:
    /// a cancelled run from its crossed legs leaves it at the lowest of its other runs).
    pub energy: Option<f64>,
}

impl RestartReport {
    /// Adam steps of all the restarts.
    pub fn steps(&self) -> u32 {
        self.runs.iter().map(|r| r.pass.steps()).sum()
    }

    /// Whether one of the restarts was cancelled ([`PassReport::cancelled`](super::PassReport::cancelled)).
    pub fn cancelled(&self) -> bool {
        self.runs.iter().any(|r| r.pass.cancelled())
    }
}

/// The restarts of [`fit`](super::fit) after a first pass from `first_starts` of `first_steps`
/// steps (the outline's rate at the start `outline_rate`): where the targets look thinned
/// ([`FitOptions::thinned_below`]), the method again from each family of
/// [`FitOptions::thinned_restarts`]; otherwise, where the fit misses a piece of its targets,
/// from the arms swung by [`FitOptions::restart_arm_swing`]. A family whose starting poses are
/// the first run's or an earlier restart's, on the same mesh (the coarse proxy or not), is
/// skipped. For thinned targets a run from the lowest end so far follows the families
/// ([`FitOptions::thinned_final_run`]). The fit is left at the lowest end, and a cancelled
/// restart ends the restarts.
pub(super) fn restarts_after_first_pass(
    fit: &mut PoseFit,
    options: &FitOptions,
    first_starts: &[Pose],
    first_steps: u32,
    outline_rate: f32,
    on_step: &mut impl FnMut(&PoseFit, &Progress) -> ControlFlow<()>,
) -> Result<RestartReport> {
    let (first_energy, renders) = fit.energy_and_renders()?;
    let misfit_blocks = misfit_blocks(&fit.outlined(&renders), fit.targets())?;
    let thinned = fit.outline_setting().is_some_and(|a| a <= options.thinned_below);
    let families = if thinned && !options.thinned_restarts.is_empty() {
        options.thinned_restarts.clone()
    } else if misfit_blocks.iter().any(|&b| b > 0) && options.restart_arm_swing > 0.0 {
        vec![RestartFamily::swing(options.leg_stride, options.restart_arm_swing)]
    } else {
        Vec::new()
    };
    let mut outcome = RestartReport { misfit_blocks, thinned, first_energy, runs: Vec::new(), kept: None };
    let (first, first_outline_rate) = (fit.state(), fit.outline_rate());
    // The starting poses run so far, each with whether its coarsest steps rendered the proxy
    // (never without blur).
    let proxy_set = options.coarse_proxy > 0.0 && options.coarse_blur > 0.0;
    let mut tried = vec![(first_starts.to_vec(), proxy_set)];
    // The lowest end so far among the restarts: its energy, its state and outline rate.
    let mut lowest: Option<(f64, FitState, f32)> = None;
    let mut steps = first_steps;
    let mut cancelled = false;
    for family in families {
        let restarted = FitOptions {
            leg_stride: family.leg_stride,
            arm_swing: family.arm_swing,
            coarse_proxy: if family.coarse_proxy { options.coarse_proxy } else { 0.0 },
            ..options.clone()
        };
        let (schedule, starts) = restarted.plan(fit.model())?;
        let with_proxy = proxy_set && family.coarse_proxy;
        if tried.iter().any(|(s, p)| *s == starts && *p == with_proxy) {
            // The same starting poses on the same mesh would end where that run did.
            continue;
        }
        tried.push((starts.clone(), with_proxy));
        let plan = RestartPlan { start: RestartStart::Family(family), schedule, starts, with_proxy, shape: None };
        let run = restart_run(fit, &restarted, plan, outline_rate, steps, on_step)?;
        steps += run.pass.steps();
        cancelled = run.pass.cancelled();
        record(&mut outcome, &mut lowest, fit, run);
        if cancelled {
            break;
        }
    }
    if thinned && options.thinned_final_run && !cancelled {
        let state = lowest.as_ref().map_or_else(|| first.clone(), |l| l.1.clone());
        if let Some(plan) = lowest_end_plan(fit, options, state)? {
            let run = restart_run(fit, options, plan, outline_rate, steps, on_step)?;
            record(&mut outcome, &mut lowest, fit, run);
        }
    }
    if !outcome.runs.is_empty() {
        let (state, rate) = match lowest {
            Some((_, state, rate)) => (state, rate),
            None => (first, first_outline_rate),
        };
        fit.set_state(state)?;
        fit.set_outline_rate(rate)?;
    }
    Ok(outcome)
}

/// A restart to run: where it starts, its schedule and starting poses, and whether its coarsest
/// steps render the coarse proxy (where the fit has one).
struct RestartPlan {
    start: RestartStart,
    schedule: Schedule,
    starts: Vec<Pose>,
    with_proxy: bool,
    /// The shape `β` its starting poses (and the runs from its crossed legs) start with, where
    /// not the fit's initial shape.
    shape: Option<Vec<f32>>,
}

/// The plan of [`FitOptions::thinned_final_run`]: from the pose and shape of `lowest` (the
/// lowest end so far, which the fit is moved to) alone, the schedule of `options` without its
/// coarsest stage (so without the coarse proxy); `None` where the schedule has one stage only
/// (a fit without blur).
fn lowest_end_plan(fit: &mut PoseFit, options: &FitOptions, lowest: FitState) -> Result<Option<RestartPlan>> {
    let (schedule, _) = options.plan(fit.model())?;
    let stages: Vec<_> = schedule.stages.iter().skip(1).cloned().collect();
    if stages.is_empty() {
        return Ok(None);
    }
    fit.set_state(lowest)?;
    let schedule = Schedule { hypothesis_steps: 0, stages, ..schedule };
    let shape = Some(fit.shape().to_vec());
    Ok(Some(RestartPlan {
        start: RestartStart::LowestEnd,
        schedule,
        starts: vec![fit.pose()],
        with_proxy: true,
        shape,
    }))
}

/// Runs `plan` as one pass of `options` (the outline's rate first set back to `outline_rate`
/// where it is fitted; a plan off the proxy with the fit's coarse proxy set aside, put back
/// after; a plan's own starting shape in place of the fit's initial one meanwhile), its steps
/// following `offset` in the callback's [`Progress`]: the run and its energy where it was not
/// cancelled.
fn restart_run(
    fit: &mut PoseFit,
    options: &FitOptions,
    plan: RestartPlan,
    outline_rate: f32,
    offset: u32,
    on_step: &mut impl FnMut(&PoseFit, &Progress) -> ControlFlow<()>,
) -> Result<RestartRun> {
    if options.fit_outline {
        fit.set_outline_rate(outline_rate)?;
    }
    let mut callback =
        |fit: &PoseFit, progress: &Progress| on_step(fit, &Progress { step: offset + progress.step, ..*progress });
    let taken = (!plan.with_proxy).then(|| fit.take_coarse_proxy());
    let initial_shape = plan.shape.map(|shape| fit.replace_initial_shape(shape));
    let pass = run_pass(fit, options, &plan.schedule, &plan.starts, outline_rate, &mut callback);
    if let Some(shape) = initial_shape {
        fit.replace_initial_shape(shape);
    }
    if let Some(proxy) = taken {
        fit.put_coarse_proxy(proxy);
    }
    let pass = pass?;
    let energy = if pass.ended() { Some(fit.energy()?) } else { None };
    Ok(RestartRun { start: plan.start, pass, energy })
}

/// Appends `run` (just ended: the fit is at its end) to `outcome`, and where it ends below the
/// lowest end so far (`lowest`, else the first pass's energy) makes it the lowest and the one
/// kept.
fn record(outcome: &mut RestartReport, lowest: &mut Option<(f64, FitState, f32)>, fit: &PoseFit, run: RestartRun) {
    if let Some(e) = run.energy {
        if e < lowest.as_ref().map_or(outcome.first_energy, |l| l.0) {
            *lowest = Some((e, fit.state(), fit.outline_rate()));
            outcome.kept = Some(outcome.runs.len());
        }
    }
    outcome.runs.push(run);
}

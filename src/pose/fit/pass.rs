//! One pass of the method, as [`fit`](super::fit) runs it first and each restart runs it again:
//! a run from some starting poses, its swap test, and the runs from the crossed legs.

use std::ops::ControlFlow;

use super::crossed_runs::runs_from_crossed_legs;
use super::{CrossedLegsReport, FitOptions, PoseFit, Progress, RunReport, Schedule, Stop, SwapReport};
use crate::pose::skin::Pose;
use crate::Result;

/// What one pass of the method did ([`Fitted::first`](super::Fitted::first), each
/// [`FacingRun`](super::FacingRun) and [`RestartRun`](super::RestartRun)): the run, its swap
/// test and the runs from its crossed legs.
#[derive(Clone, Debug, PartialEq)]
pub struct PassReport {
    /// The run's report: steps, the hypotheses' energies, the energy where its descent ended
    /// (before the swap test) and why it stopped. Its steps follow the earlier passes' in the
    /// callback's [`Progress`].
    pub report: RunReport,
    /// The limb swap test after the run ([`FitOptions::swap_steps`]); `None` when it did not run.
    pub swap: Option<SwapReport>,
    /// The crossed legs ([`FitOptions::crossed_legs_within`]): their refinement, the runs from
    /// them, and where the pass ends; `None` when the crossed pose was not looked at (switched
    /// off, a skeleton without a pair of legs, a cancelled run).
    pub crossed_legs: Option<CrossedLegsReport>,
}

impl PassReport {
    /// Whether the run, or one of the runs from its crossed legs, was cancelled (the fit then
    /// ran no later pass and no polish).
    pub fn cancelled(&self) -> bool {
        self.report.stop == Stop::Cancelled
            || self.crossed_legs.as_ref().is_some_and(|c| c.runs.iter().any(|r| r.report.stop == Stop::Cancelled))
    }

    /// Whether the pass's end is a fitted state whose energy means something: its own run was
    /// not cancelled. (Where a run from its crossed legs was, the pass ended at the lowest of its
    /// other runs, as every pass ends.) What [`FacingRun::energy`](super::FacingRun::energy)
    /// and [`RestartRun::energy`](super::RestartRun::energy) follow.
    pub fn ended(&self) -> bool {
        self.report.stop != Stop::Cancelled
    }

    /// Adam steps of the pass, the runs from its crossed legs included (the swap test's and the
    /// crossed pose's short refinements are not counted).
    pub fn steps(&self) -> u32 {
        self.report.steps + self.crossed_legs.as_ref().map_or(0, |c| c.steps())
    }
}

/// One pass from `starts` (the outline's rate at the start `outline_rate`): the run and its
/// swap test ([`run_and_swap`]), then, unless the run was cancelled, the runs from the crossed
/// legs ([`FitOptions::crossed_legs_within`]; not for a pose-less fit).
pub(super) fn run_pass(
    fit: &mut PoseFit,
    options: &FitOptions,
    schedule: &Schedule,
    starts: &[Pose],
    outline_rate: f32,
    on_step: &mut impl FnMut(&PoseFit, &Progress) -> ControlFlow<()>,
) -> Result<PassReport> {
    let (report, swap) = run_and_swap(fit, options, schedule, starts, &mut *on_step)?;
    let crossed_legs = if options.fit_pose && options.crossed_legs_within > 0.0 && report.stop != Stop::Cancelled {
        runs_from_crossed_legs(fit, options, schedule, report.steps, outline_rate, on_step)?
    } else {
        None
    };
    Ok(PassReport { report, swap, crossed_legs })
}

/// One run of `schedule` from `starts`, then the swap test ([`FitOptions::swap_steps`]) unless
/// the run was cancelled.
pub(super) fn run_and_swap(
    fit: &mut PoseFit,
    options: &FitOptions,
    schedule: &Schedule,
    starts: &[Pose],
    on_step: &mut impl FnMut(&PoseFit, &Progress) -> ControlFlow<()>,
) -> Result<(RunReport, Option<SwapReport>)> {
    let report = fit.run(schedule, starts, &mut *on_step)?;
    let swap = if options.swap_steps > 0 && options.fit_pose && report.stop != Stop::Cancelled {
        Some(fit.swap_limbs(&options.swap_test())?)
    } else {
        None
    };
    Ok((report, swap))
}

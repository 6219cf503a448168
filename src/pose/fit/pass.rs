//! One pass of the method, as [`fit`](super::fit) runs it first and each restart runs it again:
//! a run from some starting poses, its swap test, and the runs from the crossed legs.

use std::ops::ControlFlow;

use super::crossed_runs::runs_from_crossed_legs;
use super::{CrossedLegsReport, FitOptions, PoseFit, Progress, RunReport, Schedule, Stop, SwapReport};
use crate::pose::skin::Pose;
use crate::Result;

/// What one pass did: the run, its swap test and the runs from its crossed legs.
pub(super) struct Pass {
    /// The run's report.
    pub(super) report: RunReport,
    /// Its swap test; `None` when it did not run.
    pub(super) swap: Option<SwapReport>,
    /// Its crossed legs and the runs from them; `None` when not looked at.
    pub(super) crossed_legs: Option<CrossedLegsReport>,
}

impl Pass {
    /// Whether the run, or one of the runs from its crossed legs, was cancelled
    /// ([`pass_cancelled`]).
    pub(super) fn cancelled(&self) -> bool {
        pass_cancelled(&self.report, self.crossed_legs.as_ref())
    }

    /// Adam steps of the pass, the runs from its crossed legs included.
    pub(super) fn steps(&self) -> u32 {
        self.report.steps + self.crossed_legs.as_ref().map_or(0, |c| c.steps())
    }
}

/// Whether a pass (the first, or a restart's) with this run's `report` and these
/// `crossed_legs` was cancelled: the run, or one of the runs from its crossed legs.
pub(super) fn pass_cancelled(report: &RunReport, crossed_legs: Option<&CrossedLegsReport>) -> bool {
    report.stop == Stop::Cancelled
        || crossed_legs.is_some_and(|c| c.runs.iter().any(|r| r.report.stop == Stop::Cancelled))
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
) -> Result<Pass> {
    let (report, swap) = run_and_swap(fit, options, schedule, starts, &mut *on_step)?;
    let crossed_legs = if options.fit_pose && options.crossed_legs_within > 0.0 && report.stop != Stop::Cancelled {
        runs_from_crossed_legs(fit, options, schedule, report.steps, outline_rate, on_step)?
    } else {
        None
    };
    Ok(Pass { report, swap, crossed_legs })
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

//! What [`fit`](super::fit) does last where its result still misses a piece of the targets
//! ([`misfit_blocks`]): the whole method once more from other starting poses (the arms swung
//! forward and back, [`FitOptions::restart_arm_swing`]), and the fit ends at the lower energy.

use std::ops::ControlFlow;

use super::crossed_runs::runs_from_crossed_legs;
use super::method::run_and_swap;
use super::{CrossedLegsReport, FitOptions, PoseFit, Progress, RunReport, Stop, SwapReport};
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

/// What [`fit`](super::fit) found where its first pass (the first run, its swap test and the
/// runs from the crossed legs) ended, and the restart where it ran.
#[derive(Clone, Debug, PartialEq)]
pub struct RestartReport {
    /// [`misfit_blocks`] of the first pass's result, per view: the restart runs where any is
    /// not 0.
    pub misfit_blocks: Vec<u32>,
    /// The energy ([`PoseFit::energy`]) where the first pass ended.
    pub first_energy: f64,
    /// The restart; `None` where it did not run: no misfit block, or its starting poses would
    /// be the first run's (a fit without blur has only the initial pose; a first run whose
    /// arms were swung by as much already).
    pub run: Option<RestartRun>,
    /// Whether the fit ends at the restart's result (its energy strictly below `first_energy`).
    pub kept: bool,
}

/// The method run again from the arms swung ([`FitOptions::restart_arm_swing`]).
#[derive(Clone, Debug, PartialEq)]
pub struct RestartRun {
    /// The run's report; its steps follow the first pass's in the callback's [`Progress`].
    pub report: RunReport,
    /// Its swap test; `None` when it did not run.
    pub swap: Option<SwapReport>,
    /// Its crossed legs and the runs from them; `None` when not looked at.
    pub crossed_legs: Option<CrossedLegsReport>,
    /// The energy where it ended; `None` when it was cancelled.
    pub energy: Option<f64>,
}

impl RestartRun {
    /// Adam steps of the restart, the runs from its crossed legs included.
    pub fn steps(&self) -> u32 {
        self.report.steps + self.crossed_legs.as_ref().map_or(0, |c| c.steps())
    }
}

/// The restart of [`fit`](super::fit) after a first pass from `first_starts` of `first_steps`
/// steps (the outline's rate at the start `outline_rate`): where the fit misses a piece of its
/// targets, the method again from its starting poses with the arms swung by
/// [`FitOptions::restart_arm_swing`] (where those differ from `first_starts`), and the fit left
/// at the lower end.
pub(super) fn restart_where_misfit(
    fit: &mut PoseFit,
    options: &FitOptions,
    first_starts: &[Pose],
    first_steps: u32,
    outline_rate: f32,
    on_step: &mut impl FnMut(&PoseFit, &Progress) -> ControlFlow<()>,
) -> Result<RestartReport> {
    let (first_energy, renders) = fit.energy_and_renders()?;
    let misfit_blocks = misfit_blocks(&fit.outlined(&renders), fit.targets())?;
    let mut outcome = RestartReport { misfit_blocks, first_energy, run: None, kept: false };
    if outcome.misfit_blocks.iter().all(|&b| b == 0) {
        return Ok(outcome);
    }
    let swung = FitOptions { arm_swing: options.restart_arm_swing, ..options.clone() };
    let (schedule, starts) = swung.plan(fit.model())?;
    if starts == first_starts {
        // Nothing else to try (no blur, so no starting poses; or the first run's arms swung
        // already): the restart would end where the first pass did.
        return Ok(outcome);
    }
    let (first, first_outline_rate) = (fit.state(), fit.outline_rate());
    if options.fit_outline {
        fit.set_outline_rate(outline_rate)?;
    }
    let mut callback =
        |fit: &PoseFit, progress: &Progress| on_step(fit, &Progress { step: first_steps + progress.step, ..*progress });
    let (report, swap) = run_and_swap(fit, &swung, &schedule, &starts, &mut callback)?;
    let crossed_legs = if swung.crossed_legs_within > 0.0 && report.stop != Stop::Cancelled {
        runs_from_crossed_legs(fit, &swung, &schedule, report.steps, outline_rate, &mut callback)?
    } else {
        None
    };
    let energy = if report.stop == Stop::Cancelled { None } else { Some(fit.energy()?) };
    outcome.kept = energy.is_some_and(|e| e < first_energy);
    if !outcome.kept {
        fit.set_state(first)?;
        fit.set_outline_rate(first_outline_rate)?;
    }
    outcome.run = Some(RestartRun { report, swap, crossed_legs, energy });
    Ok(outcome)
}

//! What [`fit`](super::fit) does after its first run with the legs crossed over
//! ([`crossed_legs`]): where that pose is close to the fit, it is refined a few steps, two more
//! runs start from it, and the fit ends at the lowest of them all.

use std::ops::ControlFlow;

use super::descent::changed_pixels;
use super::method::run_and_swap;
use super::{crossed_legs, FitOptions, PoseFit, Progress, RunReport, Schedule, Stop, SwapReport};
use crate::Result;

/// Where [`fit`](super::fit) ends once it has looked at the legs crossed over
/// ([`CrossedLegsReport::end`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CrossedLegsEnd {
    /// Where the first run and its swap test ended.
    FirstRun,
    /// At the crossed pose refined [`FitOptions::swap_steps`] unblurred steps from the first
    /// run's end ([`CrossedLegsReport::refined_energy`]).
    Refined,
    /// Where the second run (from starting poses about the crossed one) and its swap test ended.
    SecondRun,
    /// Where the third run (from the crossed pose alone) and its swap test ended.
    ThirdRun,
}

/// What [`fit`](super::fit) did with the legs crossed over ([`crossed_legs`]): the crossed pose
/// refined a few steps, the second and third runs from it, and which the fit kept.
#[derive(Clone, Debug, PartialEq)]
pub struct CrossedLegsReport {
    /// The energy ([`PoseFit::energy`]) where the first run and its swap test ended.
    pub fitted_energy: f64,
    /// The crossed pose's energy as it is (Adam and the nuisances fresh, as a run starts).
    pub start_energy: f64,
    /// The crossed pose's energy after [`FitOptions::swap_steps`] unblurred steps from where the
    /// first run ended (its Adam moments and nuisances), as the swap test refines its
    /// candidates; refined where the second run runs, before it. `None` when `swap_steps` is 0
    /// or the second run does not run.
    pub refined_energy: Option<f64>,
    /// The crossed pose's squared error against the targets over the pixels where its renders
    /// differ from the fitted pose's, over the fitted pose's there (both rendered with the fit's
    /// outline); infinite when the fit is exact there or nothing differs. What
    /// [`FitOptions::crossed_legs_within`] bounds.
    pub changed_ratio: f64,
    /// The crossed pose's squared error minus the fitted pose's over the same pixels, per
    /// pixel (a mean in [−1, 1]); infinite when nothing differs. What
    /// [`FitOptions::crossed_legs_excess`] bounds.
    pub changed_excess: f64,
    /// The second run's report: the first run's schedule from starting poses about the crossed
    /// one. `None` when it did not run (`changed_ratio` above
    /// [`FitOptions::crossed_legs_within`], and above [`FitOptions::crossed_legs_loose_within`]
    /// or `changed_excess` above [`FitOptions::crossed_legs_excess`]). Its steps follow the
    /// first run's in the [`Progress`] passed to the callback.
    pub report: Option<RunReport>,
    /// The second run's swap test; `None` when it did not run.
    pub swap: Option<SwapReport>,
    /// The energy where the second run and its swap test ended; `None` when it did not run or
    /// was cancelled.
    pub energy: Option<f64>,
    /// The third run's report: the same stages from the crossed pose alone (no starting poses
    /// tried about it, which now and then lead back to the legs the first run ended with).
    /// It runs after a second run that was not cancelled and had more than one starting pose
    /// (with one, the second run is that run already); its steps follow the second run's.
    pub third_report: Option<RunReport>,
    /// The third run's swap test; `None` when it did not run.
    pub third_swap: Option<SwapReport>,
    /// The energy where the third run and its swap test ended; `None` when it did not run or
    /// was cancelled.
    pub third_energy: Option<f64>,
    /// Where the fit ends: the lowest of `fitted_energy`, `refined_energy`, `energy` and
    /// `third_energy`, the earlier of equal ones in that order.
    pub end: CrossedLegsEnd,
}

impl CrossedLegsReport {
    /// Adam steps of the second and third runs (those the callback saw after the first run's).
    pub fn steps(&self) -> u32 {
        [&self.report, &self.third_report].into_iter().flatten().map(|r| r.steps).sum()
    }
}

/// The part of [`fit`](super::fit) after the first run (`first_steps` steps, its outline rate
/// at the start `outline_rate`): the crossed legs looked at, refined and run from where they
/// are close, and the fit left at the lowest end. `None` when the skeleton has no crossed legs.
pub(super) fn runs_from_crossed_legs(
    fit: &mut PoseFit,
    options: &FitOptions,
    schedule: &Schedule,
    first_steps: u32,
    outline_rate: f32,
    on_step: &mut impl FnMut(&PoseFit, &Progress) -> ControlFlow<()>,
) -> Result<Option<CrossedLegsReport>> {
    let Some(crossed) = crossed_legs(fit.model(), &fit.pose())? else { return Ok(None) };
    let (first, first_outline_rate, outline) = (fit.state(), fit.outline_rate(), fit.outline());
    // One render of each pose serves its energy and the ratio: the fitted pose's under its
    // outline, the crossed one's energy as a run starts (no outline) and its renders under the
    // fit's outline.
    let (fitted_energy, fitted_renders) = fit.energy_and_renders()?;
    let fitted_images = fit.outlined(&fitted_renders);
    fit.restart(&crossed)?;
    let (start_energy, crossed_renders) = fit.energy_and_renders()?;
    fit.set_outline(outline)?;
    let changed = changed_pixels(&fit.outlined(&crossed_renders), &fitted_images, fit.targets());
    let mut outcome = CrossedLegsReport {
        fitted_energy,
        start_energy,
        refined_energy: None,
        changed_ratio: changed.ratio,
        changed_excess: changed.excess,
        report: None,
        swap: None,
        energy: None,
        third_report: None,
        third_swap: None,
        third_energy: None,
        end: CrossedLegsEnd::FirstRun,
    };
    let close = changed.ratio <= options.crossed_legs_within
        || (options.crossed_legs_excess > 0.0
            && changed.ratio <= options.crossed_legs_loose_within
            && changed.excess <= options.crossed_legs_excess);
    if !close {
        fit.set_state(first)?;
        fit.set_outline_rate(first_outline_rate)?;
        return Ok(Some(outcome));
    }
    let mut refined = None;
    if options.swap_steps > 0 {
        // The crossed pose refined as a swap candidate is, from the fitted state: now and then
        // lower than the runs (the built-in figure's seed 433: 64.9 → 8.4 mm, its second run
        // ending higher than the first). The runs below restart from their own starting poses.
        let h = fit.refine_pose(first.clone(), &crossed, options.swap_steps)?;
        outcome.refined_energy = Some(h.energy);
        refined = Some(h.state);
    }
    // The second run as the first: the same schedule, its starting poses about the crossed one
    // (a stage's outline settle may have switched the outline off in the first), its steps
    // numbered on from the first run's.
    let (_, starts) = FitOptions { initial: Some(crossed.clone()), ..options.clone() }.plan(fit.model())?;
    if options.fit_outline {
        fit.set_outline_rate(outline_rate)?;
    }
    let mut offset = first_steps;
    let (second, second_swap) = run_and_swap(fit, options, schedule, &starts, &mut |fit, progress| {
        on_step(fit, &Progress { step: offset + progress.step, ..*progress })
    })?;
    offset += second.steps;
    let second_done = second.stop != Stop::Cancelled;
    // With one starting pose (no blurred stages, or no limb swings) the second run already is
    // a run from the crossed pose alone.
    let third_differs = starts.len() > 1;
    (outcome.report, outcome.swap) = (Some(second), second_swap);
    let mut second_end = None;
    if second_done {
        outcome.energy = Some(fit.energy()?);
        second_end = Some((fit.state(), fit.outline_rate()));
    }
    if second_done && third_differs {
        // The third run: the same stages from the crossed pose alone. The second run's starting
        // poses are tried under the coarsest blur, where one of them now and then slides back to
        // the legs the first run ended with; from the crossed pose alone the legs stay crossed
        // over, and the energy tells which run to keep (`docs/pose-fit-evaluation.md`).
        let alone = Schedule { hypothesis_steps: 0, ..schedule.clone() };
        if options.fit_outline {
            fit.set_outline_rate(outline_rate)?;
        }
        let (third, third_swap) = run_and_swap(fit, options, &alone, &[crossed], &mut |fit, progress| {
            on_step(fit, &Progress { step: offset + progress.step, ..*progress })
        })?;
        if third.stop != Stop::Cancelled {
            outcome.third_energy = Some(fit.energy()?);
        }
        (outcome.third_report, outcome.third_swap) = (Some(third), third_swap);
    }
    let mut lowest = fitted_energy;
    for (end, energy) in [
        (CrossedLegsEnd::Refined, outcome.refined_energy),
        (CrossedLegsEnd::SecondRun, outcome.energy),
        (CrossedLegsEnd::ThirdRun, outcome.third_energy),
    ] {
        if let Some(energy) = energy.filter(|&e| e < lowest) {
            (outcome.end, lowest) = (end, energy);
        }
    }
    let (state, rate) = match outcome.end {
        CrossedLegsEnd::FirstRun => (Some(first), first_outline_rate),
        CrossedLegsEnd::Refined => (refined, first_outline_rate),
        CrossedLegsEnd::SecondRun => {
            let (state, rate) = second_end.expect("the second run ended");
            (Some(state), rate)
        }
        // Where the third run ended (a cancelled one never ends lowest: its energy is `None`).
        CrossedLegsEnd::ThirdRun => (None, fit.outline_rate()),
    };
    if let Some(state) = state {
        fit.set_state(state)?;
        fit.set_outline_rate(rate)?;
    }
    Ok(Some(outcome))
}

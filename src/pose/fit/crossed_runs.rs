//! What [`fit`](super::fit) does after its first run with the legs crossed over
//! ([`crossed_legs`]): where that pose is close to the fit, it is refined a few steps, up to three
//! more runs start from it ([`CrossedRunStart`]), and the fit ends at the lowest of them all.

use std::ops::ControlFlow;

use super::descent::changed_pixels;
use super::pass::run_and_swap;
use super::{crossed_legs, FitOptions, PoseFit, Progress, RunReport, Schedule, Stop, SwapReport};
use crate::Result;

/// How one of the runs from the crossed legs ([`CrossedRun`]) starts. Each runs every stage it
/// has and the swap test; their steps follow each other in this order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CrossedRunStart {
    /// The second run: the first run's schedule from starting poses about the crossed pose, as
    /// the first run's about its own start.
    AboutCrossed,
    /// The third run: the same stages from the crossed pose alone (no starting poses tried about
    /// it, which now and then lead back, under the coarsest blur, to the legs the first run
    /// ended with). It runs only where the second run had more than one starting pose (with
    /// one, the second run is this run already).
    CrossedAlone,
    /// The fourth run: the second run's starting poses with the coarsest stage left out (its
    /// starting poses tried under the next stage's blur). The coarsest blur now and then undoes
    /// the crossing from every start, the crossed pose's alone included, and then the second and
    /// third runs end above the first: the fourth runs only there (neither ended below the first
    /// run's end or the refined crossed pose), where the schedule has more than one stage and
    /// [`FitOptions::fourth_run_below`] is not 0, and is kept only where it ends at most
    /// [`FitOptions::fourth_run_below`] times the lowest of the other ends.
    AboutCrossedWithoutCoarsest,
}

/// One run from the crossed legs: how it started, its report, its swap test and where it ended.
#[derive(Clone, Debug, PartialEq)]
pub struct CrossedRun {
    /// How the run started.
    pub start: CrossedRunStart,
    /// The run's report; its steps follow the runs' before it in the [`Progress`] passed to the
    /// callback.
    pub report: RunReport,
    /// The run's swap test; `None` when it did not run (switched off, or the run cancelled).
    pub swap: Option<SwapReport>,
    /// The energy ([`PoseFit::energy`]) where the run and its swap test ended; `None` when the
    /// run was cancelled.
    pub energy: Option<f64>,
}

/// Where [`fit`](super::fit) ends once it has looked at the legs crossed over
/// ([`CrossedLegsReport::end`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CrossedLegsEnd {
    /// Where the first run and its swap test ended.
    FirstRun,
    /// At the crossed pose refined [`FitOptions::swap_steps`] unblurred steps from the first
    /// run's end ([`CrossedLegsReport::refined_energy`]).
    Refined,
    /// Where the run from the crossed legs that started this way ended
    /// ([`CrossedLegsReport::runs`]).
    Run(CrossedRunStart),
}

/// What [`fit`](super::fit) did with the legs crossed over ([`crossed_legs`]): the crossed pose
/// refined a few steps, the runs from it, and where the fit ended.
#[derive(Clone, Debug, PartialEq)]
pub struct CrossedLegsReport {
    /// The energy ([`PoseFit::energy`]) where the first run and its swap test ended.
    pub fitted_energy: f64,
    /// The crossed pose's energy as it is (Adam and the nuisances fresh, as a run starts).
    pub start_energy: f64,
    /// The crossed pose's energy after [`FitOptions::swap_steps`] unblurred steps from where the
    /// first run ended (its Adam moments and nuisances), as the swap test refines its
    /// candidates; refined where the runs run, before them. `None` when `swap_steps` is 0 or
    /// the runs do not run.
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
    /// The runs from the crossed legs, in the order they ran ([`CrossedRunStart`]: the second,
    /// third and fourth run); empty when they did not run (`changed_ratio` above
    /// [`FitOptions::crossed_legs_within`], and above [`FitOptions::crossed_legs_loose_within`]
    /// or `changed_excess` above [`FitOptions::crossed_legs_excess`]). A cancelled run is the
    /// last.
    pub runs: Vec<CrossedRun>,
    /// Where the fit ends: the lowest of `fitted_energy`, `refined_energy` and the runs'
    /// energies, the earlier of equal ones in that order, the fourth run's only where it is at
    /// most [`FitOptions::fourth_run_below`] times the lowest of the others.
    pub end: CrossedLegsEnd,
}

impl CrossedLegsReport {
    /// Adam steps of the runs from the crossed legs (those the callback saw after the first
    /// run's).
    pub fn steps(&self) -> u32 {
        self.runs.iter().map(|r| r.report.steps).sum()
    }

    /// The run that started this way, where it ran.
    pub fn run(&self, start: CrossedRunStart) -> Option<&CrossedRun> {
        self.runs.iter().find(|r| r.start == start)
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
        runs: Vec::new(),
        end: CrossedLegsEnd::FirstRun,
    };
    let close = changed.ratio <= options.crossed_legs_within
        || (options.crossed_legs_excess > 0.0
            && changed.ratio <= options.crossed_legs_loose_within
            && changed.excess <= options.crossed_legs_excess);
    let mut lowest = (fitted_energy, first, first_outline_rate);
    if !close {
        fit.set_state(lowest.1)?;
        fit.set_outline_rate(first_outline_rate)?;
        return Ok(Some(outcome));
    }
    if options.swap_steps > 0 {
        // The crossed pose refined as a swap candidate is, from the fitted state: now and then
        // lower than the runs (the built-in figure's seed 433: 64.9 → 8.4 mm, its second run
        // ending higher than the first). The runs below restart from their own starting poses.
        let h = fit.refine_pose(lowest.1.clone(), &crossed, options.swap_steps)?;
        outcome.refined_energy = Some(h.energy);
        if h.energy < lowest.0 {
            (outcome.end, lowest) = (CrossedLegsEnd::Refined, (h.energy, h.state, first_outline_rate));
        }
    }
    // The second run's starting poses are those the first run's method puts about the crossed
    // one (a stage's outline settle may have switched the outline off in the first run).
    let (_, about) = FitOptions { initial: Some(crossed.clone()), ..options.clone() }.plan(fit.model())?;
    let without_coarsest = Schedule { stages: schedule.stages.iter().skip(1).cloned().collect(), ..schedule.clone() };
    let mut plan = vec![(CrossedRunStart::AboutCrossed, schedule.clone(), about.clone())];
    if about.len() > 1 {
        // From the crossed pose alone the legs stay crossed over where a starting pose about it
        // slides back under the coarsest blur; the energy tells which run to keep
        // (`docs/pose-fit-evaluation.md`).
        let alone = Schedule { hypothesis_steps: 0, ..schedule.clone() };
        plan.push((CrossedRunStart::CrossedAlone, alone, vec![crossed]));
    }
    if options.fourth_run_below > 0.0 && !without_coarsest.stages.is_empty() {
        // Without the coarsest stage, where the blur now and then undoes the crossing whatever
        // the start (the built-in figure's seed 116: 78.6 → 4.2 mm); kept only well below the
        // others (`FitOptions::fourth_run_below`).
        plan.push((CrossedRunStart::AboutCrossedWithoutCoarsest, without_coarsest, about));
    }
    let mut offset = first_steps;
    for (start, schedule, starts) in plan {
        if start == CrossedRunStart::AboutCrossedWithoutCoarsest && matches!(outcome.end, CrossedLegsEnd::Run(_)) {
            // A run from the crossed legs already ended below the first run (and the refined
            // pose): the crossing held through the coarsest blur there, so the fourth run, for
            // where it did not, is left out.
            break;
        }
        if options.fit_outline {
            fit.set_outline_rate(outline_rate)?;
        }
        let (report, swap) = run_and_swap(fit, options, &schedule, &starts, &mut |fit, progress| {
            on_step(fit, &Progress { step: offset + progress.step, ..*progress })
        })?;
        offset += report.steps;
        let cancelled = report.stop == Stop::Cancelled;
        let energy = if cancelled { None } else { Some(fit.energy()?) };
        outcome.runs.push(CrossedRun { start, report, swap, energy });
        if cancelled {
            break;
        }
        let bound = match start {
            CrossedRunStart::AboutCrossedWithoutCoarsest => options.fourth_run_below * lowest.0,
            _ => lowest.0,
        };
        if let Some(energy) = energy.filter(|&e| e < lowest.0 && e <= bound) {
            (outcome.end, lowest) = (CrossedLegsEnd::Run(start), (energy, fit.state(), fit.outline_rate()));
        }
    }
    let (_, state, rate) = lowest;
    fit.set_state(state)?;
    fit.set_outline_rate(rate)?;
    Ok(Some(outcome))
}

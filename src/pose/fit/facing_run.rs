//! The pass from the runner-up facing ([`FitOptions::facing_within`]): where a second facing
//! fits about as well as the chosen one after the hypothesis phase, the first pass runs again
//! from it, and the lower end is kept.

use std::ops::ControlFlow;

use super::pass::run_pass;
use super::{FitOptions, PassReport, PoseFit, Progress, Schedule};
use crate::pose::skin::Pose;
use crate::Result;

/// What the pass from the runner-up facing did ([`FitOptions::facing_within`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FacingRun {
    /// The runner-up facing, in radians (one of [`FitOptions::facings`]).
    pub facing: f32,
    /// Its lowest energy after the hypothesis phase over the chosen facing's (≥ 1).
    pub ratio: f64,
    /// The energy ([`PoseFit::energy`]) where the first pass ended.
    pub first_energy: f64,
    /// The pass: its run (the hypothesis phase over the runner-up facing's starting poses), swap
    /// test and crossed legs.
    pub pass: PassReport,
    /// The energy where the pass ended; `None` when its own run was cancelled
    /// ([`PassReport::ended`]: a cancelled run from its crossed legs leaves the pass at the lowest
    /// of its other runs, which is compared with the first pass's as any end is).
    pub energy: Option<f64>,
    /// Whether the fit goes on from this pass's end (it ended below the first pass's) rather
    /// than from the first pass's.
    pub kept: bool,
}

/// The facing (index into `facings` of them, `energies` one per starting pose, facing after
/// facing) whose lowest energy is the second lowest among the facings, with its ratio to the
/// lowest facing's, where that ratio is at most `within`; `None` for fewer than two facings,
/// energies that do not divide among them, or no facing that near.
pub(super) fn runner_up(energies: &[f64], facings: usize, within: f64) -> Option<(usize, f64)> {
    if facings < 2 || energies.is_empty() || !energies.len().is_multiple_of(facings) {
        return None;
    }
    let per_facing = energies.len() / facings;
    let lowest: Vec<f64> =
        energies.chunks(per_facing).map(|c| c.iter().copied().fold(f64::INFINITY, f64::min)).collect();
    let mut order: Vec<usize> = (0..facings).collect();
    order.sort_by(|a, b| lowest[*a].total_cmp(&lowest[*b]));
    let (best, second) = (lowest[order[0]], lowest[order[1]]);
    let ratio = if best > 0.0 { second / best } else { f64::INFINITY };
    (ratio <= within).then_some((order[1], ratio))
}

/// Runs the first pass again from the runner-up facing's `starts` (its `facing` and `ratio`
/// from [`runner_up`]), its steps reported after `offset`, and keeps the lower end: the fit is
/// left at this pass's end where it ended below the first pass's (where the fit was on
/// entry), else put back there.
pub(super) fn run_from_runner_up(
    fit: &mut PoseFit,
    options: &FitOptions,
    schedule: &Schedule,
    (starts, facing, ratio): (&[Pose], f32, f64),
    outline_rate: f32,
    offset: u32,
    on_step: &mut impl FnMut(&PoseFit, &Progress) -> ControlFlow<()>,
) -> Result<FacingRun> {
    let first_energy = fit.energy()?;
    let (first, first_outline_rate) = (fit.state(), fit.outline_rate());
    if options.fit_outline {
        fit.set_outline_rate(outline_rate)?;
    }
    let mut callback =
        |fit: &PoseFit, progress: &Progress| on_step(fit, &Progress { step: offset + progress.step, ..*progress });
    let pass = run_pass(fit, options, schedule, starts, outline_rate, &mut callback)?;
    let energy = if pass.ended() { Some(fit.energy()?) } else { None };
    let kept = energy.is_some_and(|e| e < first_energy);
    if !kept {
        fit.set_state(first)?;
        fit.set_outline_rate(first_outline_rate)?;
    }
    Ok(FacingRun { facing, ratio, first_energy, pass, energy, kept })
}

#[cfg(test)]
mod tests {
    use super::runner_up;

    #[test]
    fn the_runner_up_is_the_second_lowest_facing_within_the_bound() {
        // Two facings of three starting poses: lowest 1.0 (facing 1) and 1.2 (facing 0).
        let energies = [1.5, 1.2, 2.0, 1.0, 3.0, 1.1];
        assert_eq!(runner_up(&energies, 2, 1.25), Some((0, 1.2)));
        assert_eq!(runner_up(&energies, 2, 1.1), None);
        // Four facings of one: the second lowest, not the next one.
        assert_eq!(runner_up(&[4.0, 1.0, 3.0, 1.1], 4, 1.25).map(|r| r.0), Some(3));
        // One facing, energies that do not divide, none: no runner-up; a zero lowest: none.
        assert_eq!(runner_up(&energies, 1, 10.0), None);
        assert_eq!(runner_up(&energies[..5], 2, 10.0), None);
        assert_eq!(runner_up(&[], 2, 10.0), None);
        assert_eq!(runner_up(&[0.0, 0.5], 2, 10.0), None);
        // Off below 1.
        assert_eq!(runner_up(&[1.0, 1.0], 2, 0.0), None);
    }
}

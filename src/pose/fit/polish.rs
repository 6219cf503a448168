//! The polish that ends [`fit`](super::fit): a few unblurred steps at a falling learning rate
//! ([`PoseFit::polish`], [`FitOptions::polish_steps`](super::FitOptions::polish_steps)).
//!
//! At a constant rate Adam does not settle in a minimum: its steps do not shrink with the
//! gradient (each is divided by the gradient's running size), so near a minimum they stay a
//! good fraction of the rate and a fit stops wherever the last step left it,
//! up to a rate's worth of rotation off in every joint. Steps at a quarter and then a tenth of
//! the rate bring it down into the minimum it is in; they do not move it to another one.

use std::ops::ControlFlow;

use super::{PoseFit, Progress};
use crate::Result;

/// The learning rate of the polish's first half, as a multiple of the fit's rate.
pub const POLISH_FIRST_RATE: f32 = 0.25;

/// The learning rate of the polish's second half, as a multiple of the fit's rate.
pub const POLISH_SECOND_RATE: f32 = 0.1;

/// What [`PoseFit::polish`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PolishReport {
    /// Steps taken.
    pub steps: u32,
    /// The energy ([`PoseFit::energy`]) where the polish started.
    pub energy_before: f64,
    /// The energy where its steps ended.
    pub energy_after: f64,
    /// Whether the fit ends where the steps did (they ended lower); otherwise it is back where
    /// the polish started, bit for bit.
    pub kept: bool,
    /// Whether the callback cancelled the steps.
    pub cancelled: bool,
}

impl PoseFit {
    /// Polishes the current state: `steps` unblurred steps, the first half (rounded down) at
    /// [`POLISH_FIRST_RATE`] times the fit's learning rate ([`PoseFit::learning_rate`], the
    /// pose's and shape's) and the rest at [`POLISH_SECOND_RATE`] times it, with the fit's pose
    /// prior, nuisances (at their own rates, unchanged) and self-intersection check as any step.
    /// The fit then ends where the steps ended if its energy ([`PoseFit::energy`]) is lower
    /// there than where they started, and otherwise goes back to its state
    /// before them ([`PoseFit::set_state`]), bit for bit. The learning rate is the fit's again
    /// after, and the blur 0. `on_step` sees the fit after every step, numbered from 1, with no
    /// hypothesis and blur 0; [`ControlFlow::Break`] ends the steps there (the same comparison
    /// follows). Errors (and stops) on the first step that errors, the state then where that step
    /// left it.
    pub fn polish(
        &mut self,
        steps: u32,
        mut on_step: impl FnMut(&PoseFit, &Progress) -> ControlFlow<()>,
    ) -> Result<PolishReport> {
        self.set_blur(0.0)?;
        let energy_before = self.energy()?;
        let before = self.state();
        let rate = self.learning_rate();
        let mut taken = 0;
        let mut cancelled = false;
        let stepped = (|| -> Result<()> {
            for k in 0..steps {
                let factor = if k < steps / 2 { POLISH_FIRST_RATE } else { POLISH_SECOND_RATE };
                self.set_learning_rate(rate * factor)?;
                let report = self.step()?;
                taken += 1;
                let progress = Progress { step: taken, hypothesis: None, blur: 0.0, report };
                if on_step(self, &progress).is_break() {
                    cancelled = true;
                    break;
                }
            }
            Ok(())
        })();
        self.set_learning_rate(rate)?;
        stepped?;
        let energy_after = self.energy()?;
        let kept = energy_after < energy_before;
        if !kept {
            self.set_state(before)?;
        }
        Ok(PolishReport { steps: taken, energy_before, energy_after, kept, cancelled })
    }
}

//! [`fit`]: the recommended fitting method as one call, with documented defaults.

use std::ops::ControlFlow;

use super::facing_run::{run_from_runner_up, runner_up, FacingRun};
use super::pass::run_pass;
use super::polish::PolishReport;
use super::restart::{restarts_after_first_pass, RestartReport};
use super::{FitOptions, FitSettings, Free, PassReport, PoseFit, Progress};
use crate::pose::skin::SkinnedMesh;
use crate::{Camera, Image, Renderer, Result};

/// A finished [`fit`]: the fit (its pose, vertices, renders) and what the runs did.
#[derive(Debug)]
pub struct Fitted {
    /// The fit at its final pose; [`PoseFit::pose`] is the result.
    pub fit: PoseFit,
    /// The facing the fit kept, in radians: the one of [`FitOptions::facings`] whose starting
    /// poses ended the hypothesis phase lowest, or the runner-up where the pass from it ended
    /// lower ([`Fitted::facing_run`]); 0 without facings.
    pub facing: f32,
    /// The first pass: its run from the starting poses of every facing (steps, the hypotheses'
    /// energies, the energy where its descent ended and why it stopped), its limb swap test and
    /// its crossed legs.
    pub first: PassReport,
    /// The misfit and thinned-target checks after the crossed legs and the restarts where they
    /// ran ([`FitOptions::restart_arm_swing`], [`FitOptions::thinned_restarts`],
    /// [`FitOptions::thinned_final_run`]); `None` when not looked at (all three switched off, a
    /// pose-less fit, a cancelled run).
    pub restart: Option<RestartReport>,
    /// The pass from the runner-up facing ([`FitOptions::facing_within`]); `None` where it did
    /// not run (one facing, none within the bound, a cancelled first pass).
    pub facing_run: Option<FacingRun>,
    /// The polish that ends the fit ([`FitOptions::polish_steps`], [`PoseFit::polish`]); `None`
    /// when it did not run (0 steps, a cancelled run).
    pub polish: Option<PolishReport>,
}

impl Fitted {
    /// The Adam steps of the fit's descents: the first run's, the runs from the crossed legs,
    /// the pass from the runner-up facing, the restarts' and the polish's (the swap test's and the crossed pose's short refinements
    /// are not counted).
    pub fn steps(&self) -> u32 {
        self.first.steps()
            + self.facing_run.as_ref().map_or(0, |f| f.pass.steps())
            + self.restart.as_ref().map_or(0, |r| r.steps())
            + self.polish.as_ref().map_or(0, |p| p.steps)
    }
}

/// Fits `model`'s pose (and shape, with `fit_shape`) to the `targets` (one silhouette per
/// camera, values in [0, 1]) by the recommended method: `E = E_sl + λ·E_spt + μ·E_prior +
/// ν·E_shape` minimised with Adam, coarse to fine, from several starting poses, each part
/// switchable and every setting in `options` (`FitOptions::default()` is the method's; its
/// ranges are checked first, [`FitOptions::validate`]). `on_step` sees the fit and its [`Progress`] after
/// every step; returning [`ControlFlow::Break`] cancels the fit (e.g. from an `AtomicBool` a
/// user interface sets), which then ends at its current pose with
/// [`Stop::Cancelled`](super::Stop::Cancelled). When the legs crossed over match the targets
/// nearly as well as the first run's result ([`FitOptions::crossed_legs_within`]), they are
/// refined a few steps ([`FitOptions::swap_steps`]) and up to three more runs start from them
/// (with starting poses about them, from them alone, and, where neither of those ends below the
/// first run, with the starting poses about them without the coarsest stage); the lowest end is
/// kept. With several [`FitOptions::facings`], where a second facing ended the first steps
/// nearly as low as the chosen one ([`FitOptions::facing_within`]), all of that runs again from
/// that facing and the lower end is kept ([`Fitted::facing_run`]). Last, where the result still
/// misses a piece of a target at least two pixels wide
/// ([`misfit_blocks`](super::misfit_blocks)), all of that runs once more from the arms swung
/// ([`FitOptions::restart_arm_swing`]), and where the targets look thinner than the body (the
/// outline nuisance at or below [`FitOptions::thinned_below`]) once from each family of
/// [`FitOptions::thinned_restarts`] instead, then once from the lowest end alone without the
/// coarsest stage ([`FitOptions::thinned_final_run`]); the lowest end is kept. Those runs' steps
/// follow the first run's in the callback's [`Progress`], and cancelling one ends the fit at the
/// lowest of the others. Then, unless a run was cancelled, the polish
/// ([`FitOptions::polish_steps`]): a few unblurred steps at a falling learning rate, kept where
/// they end lower. With [`FitOptions::steps`] 0 none of it takes a step: the fit ends at the
/// starting pose of lowest energy.
///
/// The method was tuned on targets where the body is 50–70 pixels tall; masks at a camera's
/// own resolution are best downsampled to that first, with their cameras:
/// [`downsample_factor`](super::downsample_factor) with [`FIT_SUBJECT_HEIGHT`](super::FIT_SUBJECT_HEIGHT),
/// [`Image::downsampled`](crate::Image::downsampled), [`Camera::downsampled`](crate::Camera::downsampled)
/// (what that saves and gains: [`downsample_factor`](super::downsample_factor)), after cropping
/// masks where the body is small in them to windows that frame it as it was framed there
/// ([`subject_windows`](super::subject_windows)); [`FitFrame`](super::FitFrame) does both in
/// one call. A calibrated
/// rig's world has its own origin and up: start the fit where
/// [`start_from_masks`](super::start_from_masks) puts the model ([`FitOptions::initial`]), with
/// [`FitOptions::facings`] where the subject may face any way.
///
/// ```
/// use std::ops::ControlFlow;
/// use diffsil::pose::fit::{fit, framing_cameras, FitOptions};
/// use diffsil::pose::figure::builtin_figure;
/// use diffsil::{RenderSettings, Renderer};
///
/// let model = builtin_figure();
/// let cameras = framing_cameras(&model.mesh, 2, 16);
/// let mut renderer = Renderer::new(RenderSettings::default())?;
/// let targets = renderer.render(&model.mesh, &cameras)?.images().to_vec();
/// let options = FitOptions { steps: 12, ..FitOptions::default() };
/// let fitted = fit(model, cameras, targets, renderer, &options, |_, _| ControlFlow::Continue(()))?;
/// assert!(fitted.first.report.steps <= 12);
/// # Ok::<(), diffsil::Error>(())
/// ```
pub fn fit(
    model: SkinnedMesh,
    cameras: Vec<Camera>,
    targets: Vec<Image>,
    renderer: Renderer,
    options: &FitOptions,
    on_step: impl FnMut(&PoseFit, &Progress) -> ControlFlow<()>,
) -> Result<Fitted> {
    // `plan` checks the options first (`FitOptions::validate`).
    let (schedule, hypotheses) = options.plan(&model)?;
    // Without steps there is no run to refine: the fit ends at the starting pose of lowest
    // energy, and nothing that follows a run (swap test, crossed legs, runner-up facing,
    // restarts, polish) takes a step.
    let without_steps;
    let options = if options.steps > 0 {
        options
    } else {
        without_steps = FitOptions {
            swap_steps: 0,
            crossed_legs_within: 0.0,
            facing_within: 0.0,
            restart_arm_swing: 0.0,
            thinned_restarts: Vec::new(),
            thinned_final_run: false,
            polish_steps: 0,
            ..options.clone()
        };
        &without_steps
    };
    let height = model.mesh.bounds().map(|(lo, hi)| hi.y - lo.y).filter(|h| *h > 0.0).unwrap_or(1.0);
    let settings = FitSettings {
        initial: hypotheses.first().cloned(),
        learning_rate: options.learning_rate,
        lambda: options.lambda,
        initial_shape: options.initial_shape.clone(),
    };
    let mut fit = PoseFit::new(model, cameras, targets, renderer, settings)?;
    if options.coarse_proxy > 0.0 {
        // The starting poses and the first stage run at its blur (0 without blur: no proxy).
        let coarsest = schedule.stages.first().map_or(0.0, |s| s.blur);
        fit.set_coarse_proxy(Some(options.coarse_proxy * height), coarsest)?;
    }
    fit.set_pose_prior(options.pose_prior)?;
    fit.set_intersection_interval(options.intersection_interval)?;
    fit.set_shape_prior(options.shape_prior)?;
    fit.set_free(Free { joints: options.fit_pose, global: options.fit_global, shape: options.fit_shape });
    if options.fit_inflation {
        fit.set_inflation_rate(options.inflation_rate * height)?;
    }
    if options.fit_outline {
        fit.set_outline_rate(options.outline_rate)?;
    }
    let outline_rate = fit.outline_rate();
    let mut on_step = on_step;
    // Where several facings are tried, the hypothesis phase picks one; everything after it (the
    // runs from the crossed legs, the restarts) starts from that facing alone.
    let one_facing = FitOptions { facings: Vec::new(), ..options.clone() };
    let first = run_pass(&mut fit, &one_facing, &schedule, &hypotheses, outline_rate, &mut on_step)?;
    let per_facing = hypotheses.len() / options.facings.len().max(1);
    let starts_of = |k: usize| &hypotheses[k * per_facing..(k + 1) * per_facing];
    let faced = |k: usize| FitOptions { initial: starts_of(k).first().cloned(), ..one_facing.clone() };
    let mut chosen = first.report.chosen / per_facing.max(1);
    // A second facing about as near after the phase: its own pass, the lower end kept.
    let runner_up = runner_up(&first.report.hypothesis_energies, options.facings.len(), options.facing_within);
    let facing_run = match runner_up {
        Some((k, ratio)) if !first.cancelled() => {
            let runner = (starts_of(k), options.facings[k], ratio);
            let run =
                run_from_runner_up(&mut fit, &faced(k), &schedule, runner, outline_rate, first.steps(), &mut on_step)?;
            if run.kept {
                chosen = k;
            }
            Some(run)
        }
        _ => None,
    };
    let facing = options.facings.get(chosen).copied().unwrap_or(0.0);
    let before_restarts = first.steps() + facing_run.as_ref().map_or(0, |f| f.pass.steps());
    let restarts = options.restart_arm_swing > 0.0 || !options.thinned_restarts.is_empty() || options.thinned_final_run;
    let cancelled = first.cancelled() || facing_run.as_ref().is_some_and(|f| f.pass.cancelled());
    let restart = if options.fit_pose && restarts && !cancelled {
        let (faced, starts) = (faced(chosen), starts_of(chosen));
        Some(restarts_after_first_pass(&mut fit, &faced, starts, before_restarts, outline_rate, &mut on_step)?)
    } else {
        None
    };
    let cancelled = cancelled || restart.as_ref().is_some_and(RestartReport::cancelled);
    let polish = if options.polish_steps > 0 && !cancelled {
        let offset = before_restarts + restart.as_ref().map_or(0, |r| r.steps());
        let report = fit.polish(options.polish_steps, |fit, progress| {
            on_step(fit, &Progress { step: offset + progress.step, ..*progress })
        })?;
        Some(report)
    } else {
        None
    };
    Ok(Fitted { fit, facing, first, facing_run, restart, polish })
}

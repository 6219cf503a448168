//! [`FitOptions`]: every setting of [`fit`](super::fit), its default (the recommended method) and
//! its checks ([`FitOptions::validate`]). The schedule and starting poses the options give for a
//! model ([`FitOptions::plan`]) are in `plan.rs`.

use super::descent::{check_blur, check_intersection_interval, check_prior_weight, check_rate_and_lambda};
use super::restart::RestartFamily;
use super::schedule::{check_outline_settle, check_prior_scale};
use super::{Convergence, PoseFit, Schedule, SwapScreen, SwapTest};
use crate::pose::skin::Pose;
use crate::{Error, Result};

/// What [`fit`](super::fit) does; `FitOptions::default()` is the recommended method (see the
/// [module documentation](super) for why each part is there).
#[derive(Clone, Debug, PartialEq)]
pub struct FitOptions {
    /// Adam steps in all, every starting pose included, when the fit does not converge earlier
    /// (each facing of [`FitOptions::facings`] after the first adds its starting poses' steps;
    /// the runs after the first, [`fit`](super::fit), add theirs). Default 300. With 0 the fit
    /// takes no step at all: it ends at the starting pose of lowest energy, and the swap test,
    /// the crossed legs, the runner-up facing's pass, the restarts and the polish do not run.
    pub steps: u32,
    /// Adam's learning rate, > 0. Default 0.02.
    pub learning_rate: f32,
    /// Self-intersection weight `λ`, ≥ 0. Default 1e-7 ([`FitSettings::lambda`](super::FitSettings::lambda)).
    pub lambda: f32,
    /// Steps between self-intersection checks, ≥ 1 ([`PoseFit::set_intersection_interval`]; the
    /// steps in between reuse the last check's gradient). Default
    /// [`FitOptions::INTERSECTION_INTERVAL`].
    pub intersection_interval: u32,
    /// Pose prior weight `μ`, ≥ 0, of the unblurred stage and the swap test. Default
    /// [`PoseFit::POSE_PRIOR`].
    pub pose_prior: f32,
    /// The pose prior's weight in the blurred stages (the starting poses' included), as a
    /// multiple of `pose_prior`, finite and ≥ 0 ([`Stage::prior_scale`](super::Stage::prior_scale)). Default
    /// [`Schedule::COARSE_PRIOR_SCALE`].
    pub coarse_prior_scale: f32,
    /// Leg stride of the extra starting poses, radians (0: none). Default 0.3
    /// ([`limb_swing_hypotheses`](super::limb_swing_hypotheses)).
    pub leg_stride: f32,
    /// Arm swing of the extra starting poses, radians (0: none). Default 0
    /// ([`limb_swing_hypotheses`](super::limb_swing_hypotheses)).
    pub arm_swing: f32,
    /// Blur of the coarsest stage, fraction of the image height; 0 fits without blur (and
    /// without hypotheses, which are compared on blurred silhouettes). Default
    /// [`Schedule::COARSE_BLUR`].
    pub coarse_blur: f32,
    /// Early stop of the last stage; `None` runs every step. Default
    /// [`Convergence::default`] (the last 25 steps' mean energy not 0.5% below the 25 before).
    pub convergence: Option<Convergence>,
    /// Fit the joints' rotation offsets. Default true.
    pub fit_pose: bool,
    /// Fit the global orientation and the root translation. Default true.
    pub fit_global: bool,
    /// Fit the shape coefficients `β` (models with morph targets). Default false: a pose-only
    /// fit keeps the initial shape.
    pub fit_shape: bool,
    /// Shape prior weight `ν`, ≥ 0 ([`PoseFit::set_shape_prior`]). Default
    /// [`PoseFit::SHAPE_PRIOR`].
    pub shape_prior: f32,
    /// The shape to start from, one `β` per morph target; empty for all zero. Default empty.
    pub initial_shape: Vec<f32>,
    /// The pose to start from (and to keep where a part is not fitted); `None`: the rest pose.
    /// Default `None`.
    pub initial: Option<Pose>,
    /// Facings to try, in radians: the initial pose turned by each about its vertical (the
    /// model's +y as its orientation holds it) through its centre ([`turned_about_vertical`](super::turned_about_vertical)),
    /// every starting pose with each, all in one hypothesis phase; the lowest energy after it
    /// decides the facing, which the rest of the fit (the later stages, the runs from the
    /// crossed legs, the restarts) keeps ([`Fitted::facing`](super::Fitted::facing)). For targets whose subject may face any way:
    /// the descent turns a body only part of the way, and one facing away from the initial pose
    /// ends fitted back to front. Empty: the initial pose's facing alone. Needs the
    /// hypothesis phase (`coarse_blur` > 0). Where a second facing comes close after the
    /// phase, its own pass runs too ([`FitOptions::facing_within`]). Default empty;
    /// [`FitOptions::ANY_FACING`] tries four.
    pub facings: Vec<f32>,
    /// With several [`FitOptions::facings`]: where another facing's lowest energy after the
    /// hypothesis phase is within this factor of the chosen facing's, the first pass (the
    /// run, its swap test, the runs from the crossed legs) runs again from that facing's
    /// starting poses, and the lower end is kept ([`FacingRun`](super::FacingRun)), before the
    /// restarts. Finite and ≥ 0; below 1 (0) never. Default [`FitOptions::FACING_WITHIN`].
    ///
    /// A subject turned about halfway between two of the facings tried fits either of them
    /// about equally well in the blurred first steps, and the descent from the wrong one turns
    /// the body only part of the way; the ends of the two whole passes differ far more than
    /// the phase's energies.
    pub facing_within: f64,
    /// Fit an inflation `d` beside the pose: the silhouettes compared are those of the vertices
    /// moved by `d` along their normals ([`PoseFit::inflation`]), so that masks uniformly too
    /// fat or too thin do not twist the pose. The fitted pose and vertices exclude `d`. Default
    /// false: the outline nuisance ([`FitOptions::fit_outline`]) copes with eroded masks too;
    /// for masks a pixel off at a resolution they are downsampled from, see
    /// [`FitOptions::for_downsampled`] (which the `fit_pose` example uses wherever it
    /// downsamples).
    pub fit_inflation: bool,
    /// Step size of `d` as a fraction of the model's rest height (its extent along y) per Adam
    /// step, > 0 ([`PoseFit::set_inflation_rate`]). Default [`FitOptions::INFLATION_RATE`].
    pub inflation_rate: f32,
    /// Fit an outline nuisance `a` beside the pose ([`PoseFit::outline`]): each rendered
    /// silhouette is grown or shrunk by up to one pixel (a grey-scale dilation or erosion blended
    /// in by `|a|`) before it is compared, so that masks up to one pixel too fat or too thin,
    /// thin limbs erased included, do not twist the pose. Default
    /// [`FitOptions::FIT_OUTLINE`].
    pub fit_outline: bool,
    /// Step size of `a` per Adam step, > 0 ([`PoseFit::set_outline_rate`]). Default
    /// [`FitOptions::OUTLINE_RATE`].
    pub outline_rate: f32,
    /// When the blurred stages end with the outline `|a|` below this, the unblurred stage drops
    /// it (`a` = 0, no longer fitted; [`Stage::outline_settle`](super::Stage::outline_settle)), finite and ≥ 0; 0 keeps it;
    /// a fit without blur always keeps it. Default 0.
    ///
    /// Masks a pixel too fat or too thin take `a` to ±1 within the blurred stages, exact ones
    /// leave it within a few hundredths of 0 (0.03 at most over MakeHuman seeds 1–10 and
    /// built-in seeds 31–40). An outline that small changes the comparison by a hundredth of a
    /// pixel's coverage, but a render outlined by any `a ≠ 0` differs from its target along
    /// every contour, so the renderer's backward visits every contour segment. With 0.1 a
    /// MakeHuman fit of exact masks takes 0.8 times the time, and dilated and eroded masks fit
    /// as before; but the fits of exact masks end elsewhere within their spread, and on the
    /// built-in figure two of seeds 31–80 no longer recover from the jump of the first
    /// unblurred step ([`Stage::warmup`](super::Stage::warmup)) and end 6 to 10 mm worse (p90 6.9 → 12.1 mm; the
    /// table is in `docs/pose-fit-evaluation.md`), so the default keeps the outline.
    pub outline_settle: f32,
    /// Steps over which the unblurred stage that follows the blurred ones ramps up the learning
    /// rate ([`Stage::warmup`](super::Stage::warmup), which says why; 0: none; a fit without blur has no ramp).
    /// Default 0.
    ///
    /// With 10, and `outline_settle` 0.1, fits stop earlier (about 250 steps instead of 280)
    /// and take about 0.7 times the CPU time; the built-in figure's tails shrink (seeds 31–80:
    /// p90 6.9 → 6.5 mm, worst 26.5 → 20.2 mm; 81–130: p90 16.6 → 11.9 mm) but most medians
    /// grow, by up to 1.1 mm (CesiumMan's walk 4.0 → 5.0 mm, the MakeHuman body's seeds 1–30
    /// 3.5 → 4.3 mm), so neither is the default yet (the table is in
    /// `docs/pose-fit-evaluation.md`).
    pub warmup: u32,
    /// Steps of the limb swap test after the descent ([`PoseFit::swap_limbs`]: each limb
    /// mirrored front to back (an arm near the body's plane also swung forward and back), each
    /// forearm turned about its upper arm, the legs exchanged, each candidate and the pose
    /// refined this many steps, a candidate kept only where the energy ends lower); 0: no swap
    /// test (and no refinement of the crossed legs, [`FitOptions::crossed_legs_within`]). Only
    /// with `fit_pose`, and not after a cancelled run. Default [`FitOptions::SWAP_STEPS`].
    pub swap_steps: u32,
    /// Cell of the coarse proxy that the steps at the coarsest blur (the starting poses' and the
    /// first stage's, blur `coarse_blur`) render, as a fraction of the model's rest height (its
    /// extent along y), finite and ≥ 0; 0: every step renders the whole mesh
    /// ([`PoseFit::set_coarse_proxy`]). Default [`FitOptions::COARSE_PROXY`].
    pub coarse_proxy: f32,
    /// Which swap candidates take the refinement steps, by their energy as they are
    /// ([`SwapScreen`]; [`SwapScreen::ALL`] refines every one). Default
    /// [`SwapScreen::default`]: the lowest and any within three times the pose's energy.
    pub swap_screen: SwapScreen,
    /// When the pose with the legs moved onto each other's places
    /// ([`crossed_legs`](super::crossed_legs), taken on the fitted pose after the swap test)
    /// matches the targets at most this many times worse than the fitted pose where their
    /// renders differ (the squared error over the pixels whose value differs between the two,
    /// each rendered with the fit's outline, the candidate's over the fit's;
    /// [`CrossedLegsReport::changed_ratio`](super::CrossedLegsReport::changed_ratio)), or as the looser rule of
    /// [`FitOptions::crossed_legs_loose_within`] allows, the fit refines it
    /// [`FitOptions::swap_steps`] steps as the swap test refines a candidate, runs up to three more
    /// times from it (the stages and the swap test: a second run from starting poses about it, as
    /// the first run, a third from it alone, and, where neither of those ends below the first, a
    /// fourth from the starting poses about it without the coarsest stage;
    /// [`CrossedRunStart`](super::CrossedRunStart)) and keeps whichever ends with the lowest
    /// energy ([`PoseFit::energy`]; [`CrossedLegsReport::end`](super::CrossedLegsReport::end));
    /// 0: never (neither rule). Only with `fit_pose`, and not after a cancelled run. Default
    /// [`FitOptions::CROSSED_LEGS_WITHIN`].
    ///
    /// The descent leaves crossed or close legs in each other's places now and then (the
    /// built-in figure: 4 of seeds 81–130). Refining the candidate a few steps, as the swap test
    /// does, is seldom enough: the pelvis and the spine have settled around the wrong legs, so it
    /// takes the blurred stages again. But the second run's starting poses, tried under the
    /// coarsest blur, now and then lead back to the legs the first run ended with; the third run
    /// keeps the legs crossed over, and the energy chooses (the built-in figure's seeds
    /// 31–1060: failures 10 → 6, see `docs/pose-fit-evaluation.md`). Now and then the coarsest
    /// blur undoes the crossing from the crossed pose alone as well, which the fourth run,
    /// without that stage, keeps ([`FitOptions::fourth_run_below`]). Over the built-in figure's
    /// seeds 31–230 the ratio was 1.7–5.1 in ten of the eleven fits where a second run ends
    /// lower (58.7 in the eleventh, 12.8 mm off), 3.1 in one where it does not, and above 5.4 in
    /// the 188 others. The ratio of the whole energies separates them as well on exact masks,
    /// but not on noisy ones: with 2% of the pixels flipped every pose's energy holds the same
    /// large floor, every ratio is near 1, and every fit would run twice.
    pub crossed_legs_within: f64,
    /// A looser bound on the same ratio, finite and ≥ 0: the second run runs as well when the
    /// ratio is at most this and the crossed pose's squared error exceeds the fitted pose's by
    /// at most [`FitOptions::crossed_legs_excess`] per changed pixel
    /// ([`CrossedLegsReport::changed_excess`](super::CrossedLegsReport::changed_excess)). Default
    /// [`FitOptions::CROSSED_LEGS_LOOSE_WITHIN`].
    ///
    /// Noise among the changed pixels adds to both sides of the ratio and pulls it towards 1, so
    /// on noisy masks a ratio of 6 or 10 is common in good fits (2% of the pixels flipped: 30
    /// of the built-in figure's seeds 31–70 lie between 5 and 15), while on exact masks fits
    /// with the legs in each other's places reach ratios of 5.4–13 too. The excess per pixel
    /// is not pulled that way. With both rules the built-in figure's exact masks run a second
    /// run in 34 of seeds 31–380 instead of 22, and 7 of the 12 more end lower and closer to the
    /// truth (p90 11.2 → 9.4 mm); its flipped masks in 11 of seeds 31–70 instead of 7, and the
    /// MakeHuman body's fits in none more (their excess is 0.12 or more).
    pub crossed_legs_loose_within: f64,
    /// The largest excess per changed pixel
    /// ([`CrossedLegsReport::changed_excess`](super::CrossedLegsReport::changed_excess)) with
    /// which a ratio up to [`FitOptions::crossed_legs_loose_within`] runs the second run, finite and
    /// ≥ 0; 0: only [`FitOptions::crossed_legs_within`] decides. Default
    /// [`FitOptions::CROSSED_LEGS_EXCESS`].
    pub crossed_legs_excess: f64,
    /// The fourth run from the crossed legs (their starting poses without the coarsest stage,
    /// [`CrossedRunStart::AboutCrossedWithoutCoarsest`](super::CrossedRunStart)) runs after the
    /// other runs from them where neither the second nor the third ended below the first run's
    /// end (or the refined crossed pose), and is kept only where its energy ends at most this
    /// many times the lowest of those ends, in [0, 1]; 0: no fourth run. Default
    /// [`FitOptions::FOURTH_RUN_BELOW`].
    ///
    /// Without the coarsest blur, which settles the body as a whole, a run can end a little
    /// lower than the others with the legs' order still wrong: where the silhouettes leave it
    /// nearly ambiguous (legs close together in a stride, seen from mirror-image views) a
    /// slightly lower energy does not single out the truth. Where the coarsest blur undid the
    /// crossing in every other run, the fourth ends far lower. Over the 219 fits of about 2,600
    /// where the runs from the crossed legs run, run in all of them and kept wherever it ended
    /// lowest, it ended 0.09–0.33 times the others in the five fits it took from 10–79 mm to
    /// 4–19 mm (the built-in figure's seeds 116, 166, 242, 1006 and eroded 50), but also
    /// 0.75–0.91 times in the three it made worse by 10–33 mm (CesiumMan's walk at t = 0.375 s,
    /// 27.0 → 59.5 mm; the built-in figure's 837 and 864); see `docs/pose-fit-evaluation.md`.
    ///
    /// Where the second or the third run ends lower, the crossing held through the coarsest
    /// blur there; skipping the fourth run there keeps its cost to about a third of the fits
    /// where the runs run (66 of 216 on the sets measured) and gives up two fits it made closer
    /// (the built-in figure's 1006, 18.1 → 4.8 mm; RiggedFigure's 45, 2.9 → 1.6 mm).
    pub fourth_run_below: f64,
    /// Head turns in the swap test ([`head_turns`](super::head_turns): the head and neck turned
    /// ±30° and ±60° about the neck's line), each kept only where its energy ends at most this
    /// many times the pose's own after the same steps (and below every other candidate's), in
    /// [0, 1]; 0: not tried. Default 0.
    ///
    /// A model with a big head that is not round (CesiumMan's box of a head) can end a fit with
    /// the head turned 20–80° from the truth, the rest of the body right: the outline changes
    /// slowly under the turn. With 0.85, CesiumMan's random poses (the example's seeds 1–300)
    /// fail 5 times instead of 12 (held out, seeds 101–300: 3 instead of 7). But the turns move
    /// other fits too: over 360 fits of the MakeHuman body, the built-in figure (exact, dilated,
    /// eroded and flipped masks) and RiggedFigure, it changed 19, 16 of them 0.1–4.1 mm further
    /// from the truth (a turned head that matched the masks a little better lay further off)
    /// and none across the 2% line; so it is off by default (the measurements are in
    /// `docs/pose-fit-evaluation.md`).
    pub head_turn_below: f64,
    /// Arm swing (radians) of the starting poses of the restart ([`limb_swing_hypotheses`](super::limb_swing_hypotheses)),
    /// finite and ≥ 0; 0: no restart. Where the fit's result (after the first run, its swap
    /// test and the runs from the crossed legs) still misses a piece of a target at least two
    /// pixels wide ([`misfit_blocks`](super::misfit_blocks) not all 0), [`fit`](super::fit) runs the whole
    /// method once more from the initial pose with the arms also swung forward and back by this
    /// much, and ends at whichever of the two ends with the lower energy
    /// ([`Fitted::restart`](super::Fitted::restart)); where the targets look thinned, [`FitOptions::thinned_restarts`]
    /// run instead. Default [`FitOptions::RESTART_ARM_SWING`].
    ///
    /// The failures left after the first pass are descent failures (the true pose's energy a
    /// tenth of the fit's end or less), and another family of starting poses reaches the true
    /// pose's basin in most of them; a fit that matches its masks up to a pixel's offset of the
    /// outline, or up to scattered flipped pixels, has no misfit block and takes no restart. It
    /// restarted none of the MakeHuman body's seeds 1–60, 3 of the built-in figure's seeds
    /// 31–80 and 15 of CesiumMan's 48 walk keys (whose 3 failures it mended); a restarted fit
    /// takes about twice the time (`docs/pose-fit-evaluation.md`).
    pub restart_arm_swing: f32,
    /// The outline nuisance ([`PoseFit::outline`], fitted with [`FitOptions::fit_outline`]) at
    /// or below which the first pass's targets count as thinned, so that
    /// [`FitOptions::thinned_restarts`] run; finite. Default [`FitOptions::THINNED_BELOW`]:
    /// masks eroded by a pixel end the first pass at −0.96 to −1, exact and flipped ones at
    /// −0.03 to +0.04, dilated ones at +0.99 or above (`docs/pose-fit-evaluation.md`).
    pub thinned_below: f32,
    /// The families the whole method runs again from, one after the other, where the targets
    /// look thinned ([`FitOptions::thinned_below`]): each its starting poses, and with or
    /// without the coarse proxy ([`RestartFamily`]); the fit ends at the lowest energy
    /// ([`Fitted::restart`](super::Fitted::restart)); empty: none. Default
    /// [`FitOptions::THINNED_RESTARTS`].
    ///
    /// Masks thinner than the body (a pixel eroded) leave the forearms, and now and then a
    /// shin, a faint line one pixel wide: a limb that misses its line changes the energy little,
    /// so the descent ends with it elsewhere (the true pose's energy still lower), without a
    /// misfit block that would restart it. Which start reaches the true pose's basin varies
    /// from fit to fit, so several families are tried and the energy picks. On masks eroded by
    /// a pixel the first three families took the MakeHuman body's failures from 25 to 13 in 60
    /// fits and the built-in figure's from 23 to 4 in 120 (one fit became a failure); the fourth,
    /// off the proxy, from 13 to 8 and from 4 to 3 (none became one). A thinned fit runs the
    /// method five times (six with [`FitOptions::thinned_final_run`]), four to five times as
    /// long as one that is not; no fit on exact, dilated or flipped masks counted as thinned
    /// (`docs/pose-fit-evaluation.md`).
    pub thinned_restarts: Vec<RestartFamily>,
    /// Where the targets look thinned ([`FitOptions::thinned_below`]), one more run after the
    /// families of [`FitOptions::thinned_restarts`]: from the lowest end so far alone (the
    /// first pass's or a family's pose and shape; Adam and the outline started afresh as a
    /// restart does), the stages without the coarsest one (so without the coarse proxy), then
    /// its swap test and crossed legs as any pass; the fit ends there where it ends lower
    /// ([`RestartStart::LowestEnd`](super::RestartStart::LowestEnd)). Not for a fit without
    /// blur (one stage). Default [`FitOptions::THINNED_FINAL_RUN`].
    ///
    /// Every start of the families ends with the thinned limbs a little off their faint lines
    /// (the true pose's energy lower still); the middle blur, from the lowest of those ends
    /// and with the whole mesh, settles them closer in some fits. On masks eroded by a pixel it
    /// changed 26 of the built-in figure's 120 fits (seeds 31–150: median 11.6 → 9.8 mm,
    /// failures 3 → 2) and 8 of the MakeHuman body's 60 (seeds 1–60: 12.0 → 11.4 mm, failures
    /// 8 → 8), 30 of them closer to the truth and 4 further (by 0.4–7.3 mm); it costs one more
    /// run (a thinned fit runs the method six times). Fits of masks that do not look thinned
    /// never run it (`docs/pose-fit-evaluation.md`).
    pub thinned_final_run: bool,
    /// Steps of the polish that ends the fit, after every run and restart
    /// ([`PoseFit::polish`]): unblurred, the first half at a quarter of `learning_rate` and the
    /// rest at a tenth, kept where the energy ends lower. 0: none. Default
    /// [`FitOptions::POLISH_STEPS`].
    ///
    /// At its constant rate Adam ends a fit wherever its last step left it, up to about a
    /// step's rotation off in every joint; the polish settles it in the minimum it is in. On
    /// the MakeHuman body's seeds 1–20 (clean masks) it took the median from 3.8 to 2.8 mm and
    /// the worst from 17.8 to 4.7 mm, for about 15% more steps; it does not move a fit out of
    /// a wrong minimum (`docs/pose-fit-evaluation.md`).
    pub polish_steps: u32,
}

impl Default for FitOptions {
    fn default() -> Self {
        // The swap test's defaults are `SwapTest`'s, held here field by field.
        let swap = SwapTest::default();
        FitOptions {
            steps: 300,
            learning_rate: 0.02,
            lambda: 1e-7,
            intersection_interval: FitOptions::INTERSECTION_INTERVAL,
            pose_prior: PoseFit::POSE_PRIOR,
            coarse_prior_scale: Schedule::COARSE_PRIOR_SCALE,
            leg_stride: 0.3,
            arm_swing: 0.0,
            coarse_blur: Schedule::COARSE_BLUR,
            convergence: Some(Convergence::default()),
            fit_pose: true,
            fit_global: true,
            fit_shape: false,
            shape_prior: PoseFit::SHAPE_PRIOR,
            initial_shape: Vec::new(),
            initial: None,
            facings: Vec::new(),
            facing_within: FitOptions::FACING_WITHIN,
            fit_inflation: FIT_INFLATION_DEFAULT,
            inflation_rate: FitOptions::INFLATION_RATE,
            fit_outline: FitOptions::FIT_OUTLINE,
            outline_rate: FitOptions::OUTLINE_RATE,
            outline_settle: 0.0,
            warmup: 0,
            swap_steps: swap.steps,
            swap_screen: swap.screen,
            coarse_proxy: FitOptions::COARSE_PROXY,
            crossed_legs_within: FitOptions::CROSSED_LEGS_WITHIN,
            crossed_legs_loose_within: FitOptions::CROSSED_LEGS_LOOSE_WITHIN,
            crossed_legs_excess: FitOptions::CROSSED_LEGS_EXCESS,
            fourth_run_below: FitOptions::FOURTH_RUN_BELOW,
            head_turn_below: swap.head_turn_below,
            restart_arm_swing: FitOptions::RESTART_ARM_SWING,
            thinned_below: FitOptions::THINNED_BELOW,
            thinned_restarts: FitOptions::THINNED_RESTARTS.to_vec(),
            thinned_final_run: FitOptions::THINNED_FINAL_RUN,
            polish_steps: FitOptions::POLISH_STEPS,
        }
    }
}

/// Whether `FitOptions::default()` fits the inflation.
const FIT_INFLATION_DEFAULT: bool = false;

impl FitOptions {
    /// Four facings a quarter turn apart, the initial pose's first ([`FitOptions::facings`]).
    /// The MakeHuman body in random poses turned 0°, 45°, …, 315° about the vertical (seeds 1–6
    /// each, 640×480 masks of four OpenCV cameras at random, downsampled to 64 pixels of
    /// height): from the initial facing alone 20 of the 48 fits ended back to front (316–521 mm
    /// off), with these four none (median 3.1 mm, worst 5.2 mm) at about 1.5 times the time of
    /// a fit. Where the body was turned by one of the four, the phase's lowest energy was at
    /// its own facing in all 16 fits looked at, 1.5–2.4 times below the lowest of the facings
    /// that end back to front. Less clear-cut on a model with less front and back: the
    /// built-in figure turned 180° at 32², 120 steps, was not told apart (the phase's lowest
    /// energy 0.0162 from its front, 0.0167 turned); at 64², 300 steps, it was (0.0161 turned,
    /// 0.0220 at the nearest other facing). (Those 640×480 masks came from a program outside
    /// the repository. On the `fit_pose` example's own, `--as-user-data`, with the outline
    /// nuisance: from the front alone 24 of 48 failed, with these four 1 of 48, which
    /// [`FitOptions::facing_within`]'s pass mends.)
    pub const ANY_FACING: [f32; 4] =
        [0.0, std::f32::consts::FRAC_PI_2, std::f32::consts::PI, 3.0 * std::f32::consts::FRAC_PI_2];

    /// Default of [`FitOptions::facing_within`]: 1.25. The MakeHuman body in random poses,
    /// hard 640 × 480 masks of irregular four-camera rigs fitted from the masks and cameras
    /// alone (the `fit_pose` example's `--as-user-data`, the outline nuisance on), seeds 1–6,
    /// the body turned 0°, 45°, …, 315°: with the four [`FitOptions::ANY_FACING`] alone one of the 48 ended 71.6 mm off
    /// (turned 135°, seed 4: the phase's lowest energies at 90° and 180° within 0.2% of each
    /// other, 90° kept; from 180° the fit ends 3.9 mm off). With this bound the runner-up's
    /// pass ran in 11 of the 48 (steps per fit 582 → 637) and was kept in 5, and none failed
    /// (median 2.7, worst 4.8 mm). Seeds 7–12 turned by 22.5° + k·45° and by 45°, 135°, 225°,
    /// 315° (held out): no failure with it or without it, 21% more steps per fit with it. The
    /// built-in figure's front and back end the phase within 4% of each other at 32² and 40².
    pub const FACING_WITHIN: f64 = 1.25;

    /// Default step size of the inflation, as a fraction of the model's rest height per step.
    pub const INFLATION_RATE: f32 = 1e-3;

    /// Whether `FitOptions::default()` fits the outline nuisance.
    pub const FIT_OUTLINE: bool = true;

    /// Default step size of the outline nuisance `a` (which spans [−1, 1]) per Adam step.
    pub const OUTLINE_RATE: f32 = 0.06;

    /// Default cell of the coarse proxy ([`FitOptions::coarse_proxy`]): 2% of the model's
    /// height, about a pixel at 64² with the framing cameras (the 7,000-vertex MakeHuman body
    /// keeps 1,553 vertices and 3,203 of its 13,996 triangles).
    pub const COARSE_PROXY: f32 = 0.02;

    /// Default arm swing of the restart ([`FitOptions::restart_arm_swing`]), radians.
    pub const RESTART_ARM_SWING: f32 = 0.4;

    /// Default bound of the outline nuisance below which the targets count as thinned
    /// ([`FitOptions::thinned_below`]).
    pub const THINNED_BELOW: f32 = -0.5;

    /// Default restarts where the targets look thinned ([`FitOptions::thinned_restarts`]): the
    /// arms swung by 0.4 rad (the misfit restart's), the legs' stride widened from 0.3 to 0.5
    /// rad, the arms swung by 0.7 rad, and the arms swung by 0.4 rad again with the whole mesh
    /// at the coarsest blur instead of the coarse proxy (whose clustered outline is not the
    /// mesh's: a fit of eroded masks started at the true pose stays there only without it).
    pub const THINNED_RESTARTS: [RestartFamily; 4] = [
        RestartFamily::swing(0.3, 0.4),
        RestartFamily::swing(0.5, 0.0),
        RestartFamily::swing(0.3, 0.7),
        RestartFamily { leg_stride: 0.3, arm_swing: 0.4, coarse_proxy: false },
    ];

    /// Whether `FitOptions::default()` runs once more from the lowest end where the targets
    /// look thinned ([`FitOptions::thinned_final_run`]).
    pub const THINNED_FINAL_RUN: bool = true;

    /// Default steps of the polish that ends a fit ([`FitOptions::polish_steps`]).
    pub const POLISH_STEPS: u32 = 40;

    /// Default steps of the limb swap test ([`FitOptions::swap_steps`]).
    pub const SWAP_STEPS: u32 = 10;

    /// Default steps between self-intersection checks.
    pub const INTERSECTION_INTERVAL: u32 = 4;

    /// Default bound of the second run from the crossed legs
    /// ([`FitOptions::crossed_legs_within`]), set on the built-in figure's seeds 31–230.
    pub const CROSSED_LEGS_WITHIN: f64 = 5.0;

    /// Default looser bound of the same ratio ([`FitOptions::crossed_legs_loose_within`]), set
    /// on the built-in figure's seeds 31–380.
    pub const CROSSED_LEGS_LOOSE_WITHIN: f64 = 15.0;

    /// Default largest excess per changed pixel with the looser bound
    /// ([`FitOptions::crossed_legs_excess`]), set on the built-in figure's seeds 31–380.
    pub const CROSSED_LEGS_EXCESS: f64 = 0.1;

    /// Default bound of the fourth run from the crossed legs ([`FitOptions::fourth_run_below`]):
    /// kept where it ends at most half the lowest of the other ends.
    pub const FOURTH_RUN_BELOW: f64 = 0.5;

    /// These options for targets downsampled by `factor` for the fit
    /// ([`downsample_factor`](super::downsample_factor)): from a factor of 2 up, the surface
    /// offset ([`FitOptions::fit_inflation`]) fitted in place of the outline nuisance
    /// ([`FitOptions::fit_outline`]); `self` as it is for a factor of 1. A mask a pixel too fat
    /// or too thin at its own resolution is a fraction of a pixel off at the fit's: an offset of
    /// the surface, which the inflation models, and not a pixel's erosion, which the outline
    /// does (it is there for masks at the fit's own scale, where an eroded pixel takes a thin
    /// limb away). The MakeHuman body in random poses at 480² (the example's irregular rigs,
    /// fitted at 80² or 96²), seeds 1–10, median / p90 / worst mm: masks eroded by a pixel
    /// 7.2 / 8.0 / 8.6 with the outline, 4.0 / 4.4 / 4.5 with the inflation; dilated 5.0 / 6.9
    /// / 8.5 and 3.3 / 3.6 / 4.2; exact 2.8 / 3.7 / 4.2 and 3.0 / 3.6 / 4.1; 2% flipped 3.3 /
    /// 4.1 / 4.7 and 3.5 / 4.0 / 4.7. Both on did worse on the dilated masks (p90 13.6 mm).
    /// Hard 640 × 480 masks fitted from the masks and cameras alone (the example's
    /// `--as-user-data`, seeds 1–30): eroded 7.0 / 8.7 / 9.8 → 4.0 / 4.5 / 8.3, dilated 5.0 /
    /// 6.8 / 8.8 → 3.1 / 4.0 / 5.9; the body turned 0°–315° (48 fits, the four facings tried)
    /// 2.7 / 4.1 / 4.8 → 2.8 / 4.3 / 4.4, and in worlds whose up is ±z or 40° from +y all 18
    /// within 4.4 mm. The `fit_pose` example's choice for downsampled masks; not
    /// [`FitOptions::default`], which cannot know the factor. (Before the runner-up facing's
    /// pass, [`FitOptions::facing_within`], the offset chose a wrong facing in 1 of 48 fits on
    /// other 640 × 480 rigs, 311 mm off, and that was not looked at again.)
    pub fn for_downsampled(self, factor: u32) -> FitOptions {
        if factor < 2 {
            return self;
        }
        FitOptions { fit_inflation: true, fit_outline: false, ..self }
    }

    /// The swap test [`fit`](super::fit) runs after each run ([`PoseFit::swap_limbs`]): `swap_steps`,
    /// `swap_screen` and `head_turn_below`.
    pub fn swap_test(&self) -> SwapTest {
        SwapTest { steps: self.swap_steps, screen: self.swap_screen, head_turn_below: self.head_turn_below }
    }

    /// Errors ([`Error::InvalidSettings`]) where a setting is outside the range its field's
    /// documentation gives (the same checks [`PoseFit`]'s setters make), before any model is
    /// loaded. What needs the model is checked where it is known: `initial_shape`'s length
    /// ([`PoseFit::new`]) and `initial`'s joint count ([`FitOptions::plan`]).
    /// [`fit`](super::fit) and [`FitOptions::plan`] call it first.
    pub fn validate(&self) -> Result<()> {
        check_rate_and_lambda(self.learning_rate, self.lambda)?;
        check_intersection_interval(self.intersection_interval)?;
        check_prior_weight("shape", self.shape_prior)?;
        check_prior_weight("pose", self.pose_prior)?;
        if !(self.coarse_proxy.is_finite() && self.coarse_proxy >= 0.0) {
            return Err(Error::InvalidSettings(format!(
                "coarse proxy cell {}: use a fraction of the model's height ≥ 0",
                self.coarse_proxy
            )));
        }
        check_blur("coarse blur", self.coarse_blur)?;
        check_prior_scale(self.coarse_prior_scale)?;
        check_outline_settle(self.outline_settle)?;
        if !(self.leg_stride.is_finite() && self.arm_swing.is_finite()) {
            return Err(Error::InvalidSettings("the leg stride and arm swing must be finite".into()));
        }
        if self.fit_inflation && !(self.inflation_rate.is_finite() && self.inflation_rate > 0.0) {
            return Err(Error::InvalidSettings(format!("need a positive inflation rate, got {}", self.inflation_rate)));
        }
        if self.fit_outline && !(self.outline_rate.is_finite() && self.outline_rate > 0.0) {
            return Err(Error::InvalidSettings(format!("need a positive outline rate, got {}", self.outline_rate)));
        }
        for (what, bound) in [
            ("bound", self.crossed_legs_within),
            ("looser bound", self.crossed_legs_loose_within),
            ("excess bound", self.crossed_legs_excess),
        ] {
            if !(bound.is_finite() && bound >= 0.0) {
                return Err(Error::InvalidSettings(format!(
                    "the crossed legs' {what} must be finite and ≥ 0, got {bound}"
                )));
            }
        }
        if !(0.0..=1.0).contains(&self.fourth_run_below) {
            return Err(Error::InvalidSettings(format!(
                "the fourth run's bound must be in [0, 1], got {}",
                self.fourth_run_below
            )));
        }
        self.swap_test().validate()?;
        if !(self.restart_arm_swing.is_finite() && self.restart_arm_swing >= 0.0) {
            return Err(Error::InvalidSettings(format!(
                "the restart's arm swing must be finite and ≥ 0, got {}",
                self.restart_arm_swing
            )));
        }
        if !self.thinned_below.is_finite() {
            return Err(Error::InvalidSettings(format!(
                "the thinned targets' outline bound must be finite, got {}",
                self.thinned_below
            )));
        }
        for family in &self.thinned_restarts {
            family.validate()?;
        }
        if let Some(bad) = self.facings.iter().find(|f| !f.is_finite()) {
            return Err(Error::InvalidSettings(format!("a facing must be a finite number of radians, got {bad}")));
        }
        if !(self.facing_within.is_finite() && self.facing_within >= 0.0) {
            return Err(Error::InvalidSettings(format!(
                "the facings' bound must be finite and ≥ 0, got {}",
                self.facing_within
            )));
        }
        if !self.facings.is_empty() && self.coarse_blur == 0.0 {
            return Err(Error::InvalidSettings(
                "facings are told apart in the hypothesis phase, which needs a coarse blur > 0".into(),
            ));
        }
        Ok(())
    }
}

//! Pose fitting to multi-view silhouettes (paper §4): `E = E_sl + λ·E_spt`, minimised over the
//! pose (and, for a model with morph targets, the shape) with Adam.
//!
//! **One call:** [`fit`] runs the recommended method below on the user's model, cameras and
//! target masks, with every setting in [`FitOptions`] (`FitOptions::default()` is the method's):
//! it reports each step to a callback, which can cancel the fit
//! (`std::ops::ControlFlow::Break`), stops early once the energy stops falling ([`Convergence`]),
//! and fits the joints, the global transform and the shape each only when switched on
//! (`fit_pose`, `fit_global`, `fit_shape`; the others keep their initial values exactly).
//! [`PoseFit`] is the step-by-step machinery underneath, for other schedules.
//!
//! One [`PoseFit::step`] skins the model at the current pose, renders every view, takes the
//! squared silhouette error against the targets (`E_sl`, paper Eq. 18), adds `λ` times the
//! self-intersection surrogate (`E_spt`, see [`crate::pose::self_intersection`]), and back-propagates
//! through the renderer, the cameras and the skinning to the pose parameters.
//!
//! # The fitting method ([`PoseFit::run`])
//!
//! Plain descent from the rest pose stalls in local minima on a large share of random poses
//! (16 of seeds 1–30 end more than 20 mm off for the built-in figure at 64², F = 4, 300 steps;
//! the errors are bimodal: 2.5–7 mm, or 22–71 mm). The stalled fits are not ambiguities the
//! silhouettes cannot decide: their silhouette error stays 6–50 times that of the converged
//! ones. Their per-joint errors
//! show whole limbs in the wrong place (a wrist or an ankle 30–45 cm off), of two kinds:
//!
//! - **No overlap, no gradient.** A limb whose silhouette does not overlap its target in a view
//!   feels nothing there: the squared error is flat until the two touch. An arm that should reach
//!   forward, fitted alongside (and hidden behind) the torso in the side views, stays there.
//! - **Which leg is in front.** The four views are pairwise mirror images (0°/180°, 90°/270°),
//!   and in a side view the nearer leg hides the other, so only the nearer leg's contour gets a
//!   gradient. From the symmetric rest pose, the descent decides which leg goes forward (or
//!   crosses in front) on faint cues (perspective, foot shape), and often decides wrong: the
//!   fitted legs then hold each other's depths, and they cannot pass through each other to swap.
//!
//! Once those are avoided, what is left of the error is mostly twist: a limb's rotation about
//! its own axis, which silhouettes barely see and which a joint and its child can trade between
//! them (10–30° on the thighs and arms of otherwise converged fits).
//!
//! The method answers all three, with the same settings for every resolution and supersampling:
//!
//! 1. **Coarse to fine.** `E_sl` compares the rendered and target silhouettes blurred by the
//!    same Gaussian ([`loss::blurred_squared_error`](crate::loss::blurred_squared_error)), whose
//!    standard deviation is a fraction of the image height (so every resolution sees the same
//!    blurred picture), shrinking in stages to no blur ([`Schedule`]). Blurred silhouettes
//!    attract from farther away.
//! 2. **Multiple hypotheses.** The fit starts from several initial poses ([`stride_hypotheses`]:
//!    the rest pose, and the legs in a small stride one way and the other), runs each for the
//!    same few steps of the coarsest stage, and keeps the one with the lowest energy `E`
//!    (unblurred), which then runs the remaining stages. This is the classic way to treat a
//!    discrete ambiguity that descent cannot cross: start on each side of it and let the
//!    objective choose.
//! 3. **A pose prior.** `E` gains `μ·E_prior`, `E_prior` the mean squared joint offset
//!    ([`PoseFit::set_pose_prior`], μ = [`PoseFit::POSE_PRIOR`]): a zero-mean Gaussian prior,
//!    as the random poses are drawn around the rest pose. It holds the directions the silhouettes
//!    do not see (twist) near rest instead of letting Adam's noise move them. Like the blur it is
//!    annealed ([`Stage::prior_scale`]): [`Schedule::COARSE_PRIOR_SCALE`] times stronger while
//!    the silhouettes are blurred, so that the joints do not take up a turn of the whole body
//!    before the global orientation has settled, then `μ` for the details.
//! 4. **Mean, not sum.** `E_sl` is the mean over all pixels of all views, so its scale, and so
//!    the meaning of `λ` and `μ`, does not depend on the resolution or the number of views
//!    (Adam's steps do not depend on the scale of the loss, but the balance of the terms does).
//!
//! 5. **Shape** (optional, [`FitOptions::fit_shape`]): the shape coefficients `β` of the model's
//!    morph targets join the parameters, with a zero-mean Gaussian prior `ν·(1/K) Σ_k β_k²`
//!    ([`PoseFit::set_shape_prior`], ν = [`PoseFit::SHAPE_PRIOR`]).
//! 6. **Outline** ([`FitOptions::fit_outline`], on by default): one scalar `a` in [−1, 1],
//!    fitted by its own Adam beside the pose ([`PoseFit::set_outline_rate`], step
//!    [`FitOptions::OUTLINE_RATE`]), grows (`a > 0`) or shrinks (`a < 0`) every rendered
//!    silhouette by up to one pixel before it is compared: `|a|` of the 3×3 grey-scale dilation or
//!    erosion is blended into the render ([`PoseFit::outline`]). Masks up to one pixel too fat or
//!    too thin (common in real segmentations) are then explained by `a` instead of a twisted pose,
//!    and, unlike a surface offset, an eroded render loses the limbs thinner than two pixels
//!    just as an eroded mask does, so the fit need not hide them. Seeds 31–40 of the built-in
//!    figure at 64², F = 4 (raised ring), against the surface offset `d` below measured the same
//!    hour: eroded masks 21.7 mm median (3 of 10 above 2% of the height) instead of 41.0 mm
//!    (8 of 10); dilated 6.5 mm; clean 5.2 mm (worst 9.2) instead of 5.7 mm (worst 31.0).
//!    The older nuisance, an **inflation** `d` ([`FitOptions::fit_inflation`], off by default),
//!    moves every rendered vertex along its area-weighted normal, `v_i + d·n_i` (normals held
//!    constant within a step, so `∂E/∂d = Σ_i ∂E_sl/∂v_i · n_i`); it explains dilated masks
//!    (9.6 mm instead of 48 mm) but not eroded ones (a surface moved inward cannot make a
//!    forearm vanish), and with both on, `d` takes the offset first. The fitted pose and
//!    vertices exclude both. Cost: a render outlined by any `a` ≠ 0 disagrees with a clean
//!    target along every contour, so the renderer's backward visits every contour segment; on
//!    the MakeHuman body a fit took about 1.4 times the CPU time with the outline as without.
//!    Exact masks leave `a` within a few hundredths of 0 when the blur ends and masks a pixel
//!    off take it near ±1; [`FitOptions::outline_settle`] (off by default) drops an outline
//!    settled below it for the unblurred stage, 0.8 times the time of a MakeHuman fit, at a
//!    cost on the built-in figure's tail (see there).
//! 7. **Early stop:** the last (unblurred) stage ends when the mean energy of its last 25 steps
//!    is less than 0.5% below that of the 25 before ([`Convergence`]); means over windows, not
//!    single steps, so that Adam's noise and the jump where the blur changes do not end it.
//!
//! 8. **Self-intersection every 4th step** ([`FitOptions::intersection_interval`]): the
//!    check (BVH refit and self-traversal of the whole mesh) was about a quarter of a step's
//!    CPU time on the 7,000-vertex MakeHuman body; the steps between reuse the last check's
//!    gradient ([`PoseFit::set_intersection_interval`]). That body's seeds 1–10 end where they
//!    did (median 4.0 mm, the same 2 failures), at 0.76 times the CPU time per fit.
//!
//! 9. **Swap test** ([`PoseFit::swap_limbs`], [`FitOptions::swap_steps`], after the descent):
//!    the mistakes descent cannot undo are tried as discrete candidates on the final pose
//!    ([`limb_swaps`]): each leg and each arm mirrored front to back in the body's coronal plane
//!    (its joints' rotations reflected, `T → M T M`), both legs mirrored, and the legs
//!    exchanged; an arm within 15° of the coronal plane, which nearly mirrors onto itself, is
//!    also swung 40° forward and 40° back (an arm fitted alongside the torso where the target's
//!    reaches forward is hidden in the side views and gets no gradient to come out); and each
//!    forearm is turned about its upper arm's line by a quarter, a half and three quarters of a
//!    turn (an elbow bent the wrong way round, the forearm behind the torso in a side view:
//!    over 300 fits of the built-in figure it mended four, seeds 112, 166, 220 and 242, 23.4 →
//!    7.3, 16.1 → 12.9, 17.6 → 10.8 and 13.9 → 10.5 mm, moved three others by 0.1 mm or less,
//!    and changed no fit of the other models). The twelve to sixteen candidates are screened
//!    by their energy as they are (one render batch with the pose's, [`SwapScreen`]): the
//!    lowest and any within three times the pose's energy take 10 unblurred steps beside the
//!    pose, in one batch per step, and a candidate replaces the pose only where its energy then
//!    ends lower. A state's steps do not depend on the others in its batch, so the screen
//!    changes a fit only where it leaves out the candidate the full test would keep: over 386
//!    fits of four models and four kinds of mask the screen of the three lowest never did,
//!    and the lowest alone with the ratio ends the evaluation of `docs/pose-fit-evaluation.md`
//!    (352 fits) as the three did (both before the forearm turns; with them, 149 of 150 fits
//!    of the built-in figure end as with every candidate refined). Two lowest alone, tried
//!    earlier with the energies taken one by one, lost two swaps and saved nothing. On request
//!    ([`FitOptions::head_turn_below`], off by default) four head turns join them
//!    ([`head_turns`]: the neck's subtree turned ±30° and ±60° about its line), kept only where
//!    they end well below the pose: they mend most of CesiumMan's failures (a big, boxy head
//!    left turned) but move a few fits of other models slightly further off.
//!
//! 10. **A coarse proxy at the coarsest blur** ([`FitOptions::coarse_proxy`],
//!     [`PoseFit::set_coarse_proxy`]): the starting poses and the first stage compare
//!     silhouettes blurred by 6% of the image height, where detail below a pixel hardly moves
//!     the energy, yet a step's cost grows with the mesh (the blurred `∂L/∂I` is non-zero almost
//!     everywhere, so every contour segment is scanned). Those steps render, and check for
//!     self-intersection, a vertex subset of the mesh instead: its rest-pose vertices clustered
//!     on a grid of 2% of the model's height by cell and dominant joint (two limbs that touch in
//!     the rest pose never merge), one vertex kept per cluster, the triangles between three kept
//!     vertices. The kept vertices are the mesh's own, so skinning, shape and their gradients
//!     are unchanged; the other vertices get no silhouette gradient in those steps. The
//!     7,000-vertex MakeHuman body keeps 1,553 vertices and 3,203 of its 13,996 triangles, and
//!     a fit takes about 0.85 times the time; the errors stay those of the whole mesh within the
//!     spread between seeds (see `docs/pose-fit-evaluation.md`). The milder blur of the second
//!     stage renders the whole mesh: with the proxy there too, the built-in figure's seeds 31–80
//!     ended with a p90 of 15.4 mm instead of 6.9.
//!
//! 11. **A second run from the crossed legs** ([`FitOptions::crossed_legs_within`], after the
//!     swap test): where the legs cross or stand close, the descent sometimes ends with them in
//!     each other's places (left knee and foot where the right ones belong, and the other way
//!     round), which no mirror or exchange of the swap test undoes: the pelvis and spine have
//!     settled around the wrong legs. [`crossed_legs`] points each leg's bones at the other
//!     leg's joints; when that pose matches the targets at most five times worse than the
//!     fitted pose where their renders differ (the squared error over the changed pixels only,
//!     so that noise in the masks elsewhere does not decide), or at most 15 times worse with a
//!     squared error at most 0.1 higher per changed pixel
//!     ([`FitOptions::crossed_legs_loose_within`], [`FitOptions::crossed_legs_excess`]), the
//!     fit refines it a few steps as the swap test refines a candidate, runs the method again from
//!     it up to three times ([`CrossedRunStart`]: from starting poses about it, as the first run;
//!     from it alone, since the starting poses now and then lead back to the legs the first run
//!     ended with; and, where neither of those ended below the first run, from the starting poses
//!     without the coarsest stage, whose blur now and then undoes the crossing from any start) and
//!     keeps whichever ends with the lowest energy ([`CrossedLegsEnd`]). On the built-in
//!     figure's seeds 31–230 the second run ran in 10 of the 200 fits and took the failures
//!     (more than 2% of the height off) from 8 to 1, and on seeds 231–330, which played no part
//!     in choosing the first bound, from 9 to 1 (11 second runs);
//!     the looser rule, set on seeds 31–380, improved 7 more of those fits (over 31–380: p90
//!     11.2 → 9.4 mm, failures 3 → 2), 1 of the fresh seeds 381–480 and RiggedFigure's two
//!     failures of seeds 1–20; the MakeHuman body's fits seldom meet either bound. The
//!     refinement ended lowest in one fit of about a thousand (the built-in figure's seed 433,
//!     64.9 → 8.4 mm, where the second run ends higher than the first); the third run then
//!     took the built-in figure's failures over seeds 31–1060 from 10 to 6, and the fourth,
//!     kept only where it ends at most half as high as the others
//!     ([`FitOptions::fourth_run_below`]), from 6 to 5 (seed 116, 78.6 → 4.2 mm; see
//!     `docs/pose-fit-evaluation.md`).
//!
//! 12. **A restart where a piece is missed** ([`FitOptions::restart_arm_swing`], last): the
//!     failures left are descent failures (the true pose's energy a tenth of the fit's end or
//!     less), and they show as a piece of the body at least two pixels wide in the wrong place:
//!     2×2 blocks of pixels where the render and the target differ by more than half a pixel's
//!     coverage, the same way ([`misfit_blocks`]): over 288 fits looked at, with exact, dilated,
//!     eroded or flipped masks, the 22 with one were 5.7–102 mm off, none closer (an outline a
//!     pixel off is one pixel wide, a flipped pixel stands alone). Where a view has one, the
//!     whole method runs again from the initial pose with the arms also swung forward and back
//!     by 0.4 rad, and the lower end is kept ([`RestartReport`]). It ran in about 2% of the
//!     body's fits, 5% of the figure's and a third of CesiumMan's walk keys; it took the walk's 48
//!     keys from 3 failures to none and the built-in figure's p90 on every row of 50 to 100 seeds
//!     in 31–560 to 9.4 mm or less; on irregular camera rigs the figure's failures from 5 to 1 in
//!     200; of the 68 fits of about 2,000 where it was kept, 60 ended closer to the truth and one
//!     turned into a failure (`docs/pose-fit-evaluation.md`).
//!
//! 13. **Restarts where the masks look thinned** ([`FitOptions::thinned_restarts`], in place of
//!     the restart above): masks eroded by a pixel leave the forearms a faint line one pixel
//!     wide, which the descent often misses without a misfit block; the fitted outline
//!     nuisance tells such masks (−0.96 to −1 where eroded, above −0.05 otherwise), and where
//!     it ends at or below [`FitOptions::thinned_below`] the whole method runs again from four
//!     families ([`RestartFamily`]: three of starting poses, and one of them without the coarse
//!     proxy) and the lowest energy is kept. On eroded masks the body's failures went from 25
//!     to 8 in 60 and the figure's from 23 to 3 in 120, at four to five times the time of such
//!     a fit. Then one more run starts from the lowest end alone, without the coarsest stage
//!     ([`FitOptions::thinned_final_run`]): the middle blur, on the whole mesh, settles the
//!     faint limbs closer to their lines in some fits (eroded medians: the figure 11.6 → 9.8
//!     mm, failures 3 → 2 of 120; the body 12.0 → 11.4 mm, 8 of 60 still).
//!
//! 14. **The polish** ([`FitOptions::polish_steps`], [`PoseFit::polish`], last of all): 40
//!     unblurred steps, 20 at a quarter of the learning rate and 20 at a tenth, kept where the
//!     energy ends lower. Adam's steps do not shrink with the gradient (each is divided by the
//!     gradient's running size), so near a minimum they stay a good fraction of the rate: at a
//!     constant rate every run stops up to a step's rotation off in each joint, which at a hand
//!     is millimetres; the smaller steps settle it in the minimum it is in. On the MakeHuman
//!     body's seeds 1–20 (clean masks) the median went from 3.8 to 2.8 mm and the worst from
//!     17.8 to 4.7 mm (seed 15, which ends at a mirrored arm from the swap test after its ten
//!     refinement steps: 17.8 → 4.3 mm, its energy 2.1e-3 → 3.5e-4), for 40 more steps on
//!     about 280; it mends no wrong minimum, so the rows' failures stay.
//!
//! 15. **Facing** ([`FitOptions::facings`], off by default): the descent turns a body about the
//!     vertical only part of the way (from 90° off it often ends right, from 180° it ends back
//!     to front: the silhouettes of a body and of its back are nearly mirror images, and the
//!     limbs bend to fit them). Where the subject may face any way, the starting poses are
//!     tried turned to each facing ([`FitOptions::ANY_FACING`]: four, a quarter turn apart) in
//!     the same hypothesis phase, and the lowest energy after it decides the facing; the
//!     phase's steps are then four times as many. A subject turned about halfway between two
//!     facings fits both about equally well after the phase, and the wrong one ends a limb or
//!     the trunk turned part of the way: where the second-lowest facing is within
//!     [`FitOptions::facing_within`] of the lowest, the first pass runs from it as well and
//!     the lower end is kept ([`FacingRun`]). On hard 640 × 480 masks of irregular rigs, the
//!     body turned by 0°, 45°, …, 315° (seeds 1–6 each, the outline nuisance on): one of 48
//!     ended 71.6 mm off without it, none with it.
//!
//! Costs: a blurred step costs about a third more than a sharp one (see
//! [`PoseFit::set_blur`]), so the default 300 steps (130 blurred) take about 1.06 times as long
//! as 300 plain steps. With them, seeds 1–30 at 64², F = 4 end at a median of 4.6 mm, one of
//! them more than 20 mm off (a leg-order ambiguity no start resolved). What is left of a step is
//! mostly the renderer's forward and backward (about 70% of the CPU time on the MakeHuman body
//! at 64², F = 4, 4 views).

mod cameras;
mod crossed_runs;
mod descent;
mod facing_run;
mod inflation;
mod method;
mod options;
mod outline;
mod pass;
mod placement;
mod plan;
mod polish;
mod poses;
mod resolution;
mod restart;
mod schedule;
mod start;

pub use cameras::{framing_cameras, framing_orbit, framing_ring, orbit_cameras, ring_orbits, RAISED_ELEVATION_DEG};
pub use crossed_runs::{CrossedLegsEnd, CrossedLegsReport, CrossedRun, CrossedRunStart};
pub use descent::{
    crossed_legs, head_turns, limb_swaps, FitSettings, FitState, Free, LimbSwap, PoseFit, StepReport, SwapCandidate,
    SwapReport, SwapScreen, SwapTest,
};
pub use facing_run::FacingRun;
pub use inflation::vertex_normals;
pub use method::{fit, Fitted};
pub use options::FitOptions;
pub use pass::PassReport;
pub use placement::triangulate_masks;
pub use polish::{PolishReport, POLISH_FIRST_RATE, POLISH_SECOND_RATE};
pub use poses::{limb_swing_hypotheses, per_vertex_error, random_pose, stride_hypotheses, turned_about_vertical};
pub use resolution::{
    downsample_factor, subject_height, subject_windows, FitFrame, FIT_SUBJECT_HEIGHT, SUBJECT_WINDOW_SCALE,
};
pub use restart::{misfit_blocks, RestartFamily, RestartReport, RestartRun, RestartStart};
pub use schedule::{Convergence, Progress, RunReport, Schedule, Stage, Stop};
pub use start::{cameras_up, start_from_masks, upright, world_up, MaskStart};

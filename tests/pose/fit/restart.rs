//! The restarts of `fit::fit` (`FitOptions::restart_arm_swing`, `FitOptions::thinned_restarts`):
//! `misfit_blocks` counts the 2×2 blocks a fit misses, the restart runs only where there is one,
//! runs the method again from the arms swung, and the fit ends at the lower energy; where the
//! targets look thinned (the fitted outline near −1), the method runs again from each family of
//! starting poses, then once from the lowest end without the coarsest stage, and the fit ends at
//! the lowest. A restart counts as cancelled where its run or a run from its crossed legs was.
//!
//! The polish that ends a fit (`FitOptions::polish_steps`) is off here: these tests compare where
//! the runs end with where the fit ends (`polish.rs` tests the polish after them).

use std::ops::ControlFlow;

use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::{
    fit, framing_cameras, misfit_blocks, random_pose, CrossedLegsEnd, CrossedLegsReport, CrossedRun, CrossedRunStart,
    FitOptions, PassReport, PoseFit, RestartFamily, RestartReport, RestartRun, RestartStart, RunReport, Schedule, Stop,
};
use diffsil::pose::skin::{MorphTargets, SkinnedMesh};
use diffsil::{Camera, Error, Image, RenderSettings, Renderer};

use super::call::{go_on, renderer};

/// A 6×5 image of zeros with `ones` (row, column) set to `value`.
fn image(ones: &[(usize, usize)], value: f32) -> Image {
    let mut data = vec![0.0; 30];
    for &(r, c) in ones {
        data[r * 6 + c] = value;
    }
    Image::from_vec(6, 5, data).unwrap()
}

#[test]
fn misfit_blocks_are_two_by_two_pixels_off_by_more_than_half_the_same_way() {
    let zero = image(&[], 0.0);
    let count = |render: &Image| misfit_blocks(std::slice::from_ref(render), std::slice::from_ref(&zero)).unwrap()[0];
    let square = [(1, 1), (1, 2), (2, 1), (2, 2)];
    assert_eq!(count(&image(&square, 1.0)), 1, "a 2×2 square more covered");
    assert_eq!(count(&image(&square, -1.0)), 1, "a 2×2 square less covered");
    assert_eq!(count(&image(&square, 0.51)), 1);
    assert_eq!(count(&image(&square, 0.5)), 0, "off by exactly half: not counted");
    let three: Vec<(usize, usize)> = (1..4).flat_map(|r| (1..4).map(move |c| (r, c))).collect();
    assert_eq!(count(&image(&three, 1.0)), 4, "a 3×3 square holds four blocks");
    let line: Vec<(usize, usize)> = (0..6).map(|c| (2, c)).collect();
    assert_eq!(count(&image(&line, 1.0)), 0, "a one-pixel line (an outline offset)");
    let scattered = [(0, 0), (1, 2), (2, 4), (3, 1), (4, 5)];
    assert_eq!(count(&image(&scattered, 1.0)), 0, "scattered pixels (flipped ones)");
    let mut mixed = image(&square, 1.0);
    mixed.data_mut()[2 * 6 + 2] = -1.0;
    assert_eq!(count(&mixed), 0, "a block off both ways");
    // NaN matches, and an empty image has no block.
    let mut nan = image(&square, 1.0);
    nan.data_mut()[6 + 1] = f32::NAN;
    assert_eq!(count(&nan), 0);
    for (w, h) in [(0, 0), (0, 5), (6, 0)] {
        let empty = Image::from_vec(w, h, Vec::new()).unwrap();
        assert_eq!(misfit_blocks(std::slice::from_ref(&empty), std::slice::from_ref(&empty)).unwrap(), vec![0]);
    }
    // Per view, and only against targets of the same number and size.
    let views = misfit_blocks(&[image(&square, 1.0), zero.clone()], &[zero.clone(), zero.clone()]).unwrap();
    assert_eq!(views, vec![1, 0]);
    assert!(matches!(
        misfit_blocks(std::slice::from_ref(&zero), &[zero.clone(), zero.clone()]),
        Err(Error::LengthMismatch { .. })
    ));
    let other = Image::from_vec(5, 6, vec![0.0; 30]).unwrap();
    assert!(matches!(misfit_blocks(&[other], &[zero]), Err(Error::SizeMismatch { .. })));
}

/// The built-in figure in the random pose of seed 3, 4 views at 48².
fn scene() -> (SkinnedMesh, Vec<Camera>, Vec<Image>) {
    let model = builtin_figure();
    let truth = random_pose(&random_pose_limits(&model.skeleton), 30f32.to_radians(), 3);
    let cameras = framing_cameras(&model.mesh, 4, 48);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let targets = renderer.render(&model.posed_mesh(&truth).unwrap(), &cameras).unwrap().images().to_vec();
    (model, cameras, targets)
}

/// Options whose first pass ends far from the targets (too few steps to get there), so that the
/// restart runs.
fn short() -> FitOptions {
    FitOptions { steps: 12, crossed_legs_within: 0.0, polish_steps: 0, ..FitOptions::default() }
}

/// The energy of `fit` at its pose now.
fn energy(fit: &mut PoseFit) -> f64 {
    fit.energy().unwrap()
}

#[test]
fn a_fit_that_misses_a_piece_restarts_from_the_arms_swung_and_ends_at_the_lower_energy() {
    let (model, cameras, targets) = scene();
    let mut last_step = 0;
    let mut fitted = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &short(), |_, p| {
        assert_eq!(p.step, last_step + 1, "the restart's steps follow the first pass's");
        last_step = p.step;
        ControlFlow::Continue(())
    })
    .unwrap();
    let restart = fitted.restart.clone().expect("looked at");
    assert!(restart.misfit_blocks.iter().any(|&b| b > 0), "{restart:?}");
    assert!(!restart.thinned, "exact masks: {restart:?}");
    assert_eq!(restart.runs.len(), 1, "the arms swung alone: {restart:?}");
    let run = &restart.runs[0];
    assert_eq!(run.start, RestartStart::Family(RestartFamily::swing(0.3, FitOptions::RESTART_ARM_SWING)));
    assert_eq!(fitted.first.report.steps + run.pass.steps(), last_step);
    let end = run.energy.expect("not cancelled");
    assert_eq!(restart.kept, (end < restart.first_energy).then_some(0));
    assert_eq!(energy(&mut fitted.fit), end.min(restart.first_energy), "at the lower end");
    // The restart is the method from the arms swung: the same end as a fit asked for that.
    let swung = FitOptions { arm_swing: FitOptions::RESTART_ARM_SWING, restart_arm_swing: 0.0, ..short() };
    let mut alone = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &swung, go_on).unwrap();
    assert_eq!(energy(&mut alone.fit), end);
    assert_eq!(alone.first.report.steps, run.pass.report.steps);
    // Without it, the first pass is the fit, and the same as with it up to there.
    let off = FitOptions { restart_arm_swing: 0.0, thinned_restarts: Vec::new(), thinned_final_run: false, ..short() };
    let mut first = fit(model, cameras, targets, renderer(), &off, go_on).unwrap();
    assert!(first.restart.is_none());
    assert_eq!(energy(&mut first.fit), restart.first_energy);
}

#[test]
fn a_fit_that_matches_its_masks_takes_no_restart() {
    // Started at the truth, nothing is missed: the check runs, the restart does not, and the
    // fit ends where it would without the restart.
    let (model, cameras, targets) = scene();
    let truth = random_pose(&random_pose_limits(&model.skeleton), 30f32.to_radians(), 3);
    let options =
        FitOptions { steps: 24, initial: Some(truth), coarse_proxy: 0.0, polish_steps: 0, ..FitOptions::default() };
    let fitted = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &options, go_on).unwrap();
    let restart = fitted.restart.expect("looked at");
    assert_eq!(restart.misfit_blocks, vec![0; 4]);
    assert!(!restart.thinned);
    assert!(restart.runs.is_empty() && restart.kept.is_none());
    let off = FitOptions { restart_arm_swing: 0.0, thinned_restarts: Vec::new(), ..options };
    let without = fit(model, cameras, targets, renderer(), &off, go_on).unwrap();
    assert_eq!(fitted.fit.pose(), without.fit.pose());
}

#[test]
fn a_cancelled_restart_leaves_the_first_pass_and_a_bad_swing_is_an_error_before_any_step() {
    let (model, cameras, targets) = scene();
    let mut first_steps = None;
    let mut fitted = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &short(), |_, p| {
        // Cancel at the restart.s eighth step or later (the first pass takes `short().steps` at
        // most).
        if p.step == 20 {
            first_steps = Some(p.step);
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .unwrap();
    assert_eq!(first_steps, Some(20));
    let restart = fitted.restart.clone().expect("looked at");
    assert_eq!(restart.runs.len(), 1, "it ran until cancelled");
    let run = &restart.runs[0];
    assert_eq!(run.pass.report.stop, Stop::Cancelled);
    assert_eq!((run.energy, restart.kept), (None, None));
    assert_eq!(energy(&mut fitted.fit), restart.first_energy, "back at the first pass's end");
    // With the polish on, a fit cancelled in its restart is not polished after.
    let polished = FitOptions { polish_steps: 6, ..short() };
    let cancelled = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &polished, |_, p| {
        if p.step == 20 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .unwrap();
    assert!(cancelled.restart.expect("looked at").cancelled());
    assert_eq!(cancelled.polish, None);
    for bad in [f32::NAN, -0.1, f32::INFINITY] {
        let options = FitOptions { restart_arm_swing: bad, ..short() };
        let result = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &options, |_, _| {
            panic!("a step before the restart's swing was checked")
        });
        assert!(matches!(result, Err(Error::InvalidSettings(_))), "{bad}: {result:?}");
    }
}

#[test]
fn no_restart_where_its_starting_poses_would_be_the_first_runs() {
    // Without blur the method starts from the initial pose alone, and a first run whose arms
    // were swung by as much already started where the restart would: it would end the same.
    let (model, cameras, targets) = scene();
    // (Three steps: too few to come near the targets from any start.)
    let no_blur = FitOptions { coarse_blur: 0.0, steps: 3, ..short() };
    let swung = FitOptions { arm_swing: FitOptions::RESTART_ARM_SWING, steps: 3, ..short() };
    for options in [no_blur, swung] {
        let mut steps = 0;
        let fitted = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &options, |_, p| {
            steps = p.step;
            ControlFlow::Continue(())
        })
        .unwrap();
        let restart = fitted.restart.expect("looked at");
        assert!(restart.misfit_blocks.iter().any(|&b| b > 0), "a misfit: {restart:?}");
        assert!(restart.runs.is_empty() && restart.kept.is_none(), "{restart:?}");
        assert_eq!(steps, fitted.first.report.steps, "no step after the first run");
    }
}

/// `targets` eroded by a pixel: each pixel the minimum of its 3×3 neighbourhood (outside the
/// image counts as background), as masks thinner than the body.
fn eroded(targets: &[Image]) -> Vec<Image> {
    targets
        .iter()
        .map(|t| {
            let (w, h) = (t.width() as i64, t.height() as i64);
            let mut out = t.clone();
            for i in 0..h {
                for j in 0..w {
                    let mut v = 1.0f32;
                    for (di, dj) in (-1..=1).flat_map(|di| (-1..=1).map(move |dj| (di, dj))) {
                        let (r, c) = (i + di, j + dj);
                        let inside = r >= 0 && c >= 0 && r < h && c < w;
                        v = v.min(if inside { t.get(r as u32, c as u32) } else { 0.0 });
                    }
                    out.data_mut()[(i * w + j) as usize] = v;
                }
            }
            out
        })
        .collect()
}

/// Options whose first pass ends with the outline fitted near −1 on eroded targets.
fn thinned_options() -> FitOptions {
    FitOptions { steps: 30, crossed_legs_within: 0.0, polish_steps: 0, ..FitOptions::default() }
}

#[test]
fn thinned_targets_restart_from_each_family_and_the_fit_ends_at_the_lowest() {
    let (model, cameras, targets) = scene();
    let targets = eroded(&targets);
    let mut last_step = 0;
    let options = thinned_options();
    let mut fitted = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &options, |_, p| {
        assert_eq!(p.step, last_step + 1, "each restart's steps follow the ones before");
        last_step = p.step;
        ControlFlow::Continue(())
    })
    .unwrap();
    let restart = fitted.restart.clone().expect("looked at");
    assert!(restart.thinned, "eroded targets: outline {} ({restart:?})", fitted.fit.outline());
    let starts: Vec<RestartStart> = restart.runs.iter().map(|r| r.start).collect();
    let mut expected: Vec<RestartStart> = FitOptions::THINNED_RESTARTS.map(RestartStart::Family).to_vec();
    expected.push(RestartStart::LowestEnd);
    assert_eq!(starts, expected, "every family in order, then the run from the lowest end");
    let families = FitOptions::THINNED_RESTARTS;
    assert_eq!(fitted.first.report.steps + restart.steps(), last_step);
    let energies: Vec<f64> = restart.runs.iter().map(|r| r.energy.expect("not cancelled")).collect();
    let lowest = energies.iter().copied().fold(restart.first_energy, f64::min);
    assert_eq!(energy(&mut fitted.fit), lowest, "at the lowest end: {energies:?}, first {}", restart.first_energy);
    let kept = energies.iter().position(|&e| e == lowest).filter(|_| lowest < restart.first_energy);
    assert_eq!(restart.kept, kept);
    // Each restart is the method from its family: the same end as a fit asked for that.
    for (run, family) in restart.runs.iter().zip(FitOptions::THINNED_RESTARTS) {
        let alone = FitOptions {
            leg_stride: family.leg_stride,
            arm_swing: family.arm_swing,
            coarse_proxy: if family.coarse_proxy { options.coarse_proxy } else { 0.0 },
            restart_arm_swing: 0.0,
            thinned_restarts: Vec::new(),
            thinned_final_run: false,
            ..options.clone()
        };
        let mut alone = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &alone, go_on).unwrap();
        assert_eq!(Some(energy(&mut alone.fit)), run.energy, "{family:?}");
    }
    // Without them, the misfit restart alone (where there is a block), from the same first pass.
    let off = FitOptions { thinned_restarts: Vec::new(), thinned_final_run: false, ..options.clone() };
    let without = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &off, go_on).unwrap();
    let without = without.restart.expect("looked at");
    assert_eq!(without.first_energy, restart.first_energy);
    assert!(without.runs.len() <= 1, "{without:?}");
    // A family that repeats the first run's starting poses or an earlier family's on the same
    // mesh is skipped; the first run's starting poses without the coarse proxy are not.
    let first_run = RestartFamily::swing(options.leg_stride, options.arm_swing);
    let first_run_whole = RestartFamily { coarse_proxy: false, ..first_run };
    let repeated = vec![first_run, first_run_whole, families[1], families[1]];
    let twice = FitOptions { thinned_restarts: repeated, ..options.clone() };
    let once = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &twice, go_on).unwrap();
    let once = once.restart.expect("looked at");
    let once_starts: Vec<RestartStart> = once.runs.iter().map(|r| r.start).collect();
    let want = [first_run_whole, families[1]].map(RestartStart::Family);
    assert_eq!(once_starts, [&want[..], &[RestartStart::LowestEnd]].concat());
    // The proxy is back after the family off it: the next family ends as it did above.
    assert_eq!(once.runs[1].energy, restart.runs[1].energy);
    // Without a coarse proxy in the options, a family off the proxy is the same run as on it.
    let no_proxy = FitOptions {
        coarse_proxy: 0.0,
        thinned_below: 1.0,
        thinned_restarts: vec![first_run_whole],
        ..options.clone()
    };
    let none = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &no_proxy, go_on).unwrap();
    let none = none.restart.expect("looked at");
    let only_last = none.runs.len() == 1 && none.runs[0].start == RestartStart::LowestEnd;
    assert!(none.thinned && only_last, "the first run's again, skipped: {none:?}");
    // Nor without blur, whose steps never render the proxy (and whose only start is the initial
    // pose, whatever the swing).
    let unblurred = FitOptions {
        coarse_blur: 0.0,
        thinned_below: 1.0,
        thinned_restarts: vec![RestartFamily { arm_swing: 0.4, ..first_run_whole }],
        ..options.clone()
    };
    let none = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &unblurred, go_on).unwrap();
    let none = none.restart.expect("looked at");
    // (Nor the run from the lowest end: a schedule of one stage has no stage after the coarsest.)
    assert!(none.thinned && none.runs.is_empty(), "{none:?}");
}

#[test]
fn the_thinned_bound_decides_and_bad_families_are_errors_before_any_step() {
    let (model, cameras, exact) = scene();
    // Exact targets count as thinned when the bound is above the fitted outline ...
    let options = FitOptions { thinned_below: 1.0, restart_arm_swing: 0.0, ..thinned_options() };
    let fitted = fit(model.clone(), cameras.clone(), exact.clone(), renderer(), &options, go_on).unwrap();
    let restart = fitted.restart.expect("looked at");
    assert!(restart.thinned && restart.runs.len() == FitOptions::THINNED_RESTARTS.len() + 1, "{restart:?}");
    // ... and eroded ones do not when it is below −1.
    let options = FitOptions { thinned_below: -1.5, restart_arm_swing: 0.0, ..thinned_options() };
    let fitted = fit(model.clone(), cameras.clone(), eroded(&exact), renderer(), &options, go_on).unwrap();
    let restart = fitted.restart.expect("looked at");
    assert!(!restart.thinned && restart.runs.is_empty(), "{restart:?}");
    // Without the outline fitted, nothing counts as thinned.
    let options = FitOptions { thinned_below: 1.0, restart_arm_swing: 0.0, fit_outline: false, ..thinned_options() };
    let fitted = fit(model.clone(), cameras.clone(), eroded(&exact), renderer(), &options, go_on).unwrap();
    assert!(!fitted.restart.expect("looked at").thinned);
    let bad_families = [
        RestartFamily::swing(f32::NAN, 0.4),
        RestartFamily::swing(0.3, -0.1),
        RestartFamily { leg_stride: f32::INFINITY, arm_swing: 0.0, coarse_proxy: false },
    ];
    let bad_options = bad_families
        .into_iter()
        .map(|family| FitOptions { thinned_restarts: vec![family], ..short() })
        .chain([f32::NAN, f32::NEG_INFINITY].map(|bound| FitOptions { thinned_below: bound, ..short() }));
    for options in bad_options {
        let result = fit(model.clone(), cameras.clone(), exact.clone(), renderer(), &options, |_, _| {
            panic!("a step before the thinned restarts were checked")
        });
        assert!(matches!(result, Err(Error::InvalidSettings(_))), "{result:?}");
    }
}

#[test]
fn the_last_thinned_run_starts_alone_from_the_lowest_end_without_the_coarsest_stage() {
    let (model, cameras, targets) = scene();
    let targets = eroded(&targets);
    // 45 steps and the arms swung 0.7: a family that ends below the first pass here, so that
    // the lowest end is not the first pass's.
    let options = FitOptions { steps: 45, thinned_restarts: vec![RestartFamily::swing(0.3, 0.7)], ..thinned_options() };
    let fitted = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &options, go_on).unwrap();
    let first_steps = fitted.first.report.steps;
    let with = fitted.restart.expect("looked at");
    let last = with.runs.last().expect("restarts ran");
    assert_eq!(last.start, RestartStart::LowestEnd);
    // Switched off: the same families, the same ends, and nothing after them.
    let off = FitOptions { thinned_final_run: false, ..options.clone() };
    let mut without = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &off, go_on).unwrap();
    let families = without.restart.clone().expect("looked at");
    assert_eq!(families.runs.len() + 1, with.runs.len());
    assert_eq!(families.kept, Some(0), "the family ends lowest: {families:?}");
    for (a, b) in families.runs.iter().zip(&with.runs) {
        assert_eq!((a.start, a.energy), (b.start, b.energy));
    }
    // The run is the schedule without its coarsest stage from the lowest end's pose alone (the
    // fit without it ends there), then the swap test: the same end, bit for bit.
    let (schedule, _) = options.plan(without.fit.model()).unwrap();
    let later = Schedule { hypothesis_steps: 0, stages: schedule.stages[1..].to_vec(), ..schedule };
    let from = without.fit.pose();
    without.fit.set_outline_rate(options.outline_rate).unwrap();
    let report = without.fit.run(&later, &[from], go_on).unwrap();
    without.fit.swap_limbs(&options.swap_test()).unwrap();
    assert_eq!(report.steps, last.pass.report.steps);
    assert_eq!(Some(energy(&mut without.fit)), last.energy);
    // Kept only where it ends below every other end.
    let lowest_before = families.runs.iter().filter_map(|r| r.energy).fold(families.first_energy, f64::min);
    let kept_last = last.energy.is_some_and(|e| e < lowest_before);
    assert_eq!(with.kept == Some(with.runs.len() - 1), kept_last, "{with:?}");
    // A family cancelled: the fit ends at the lowest of the others, without the last run.
    let cancel_at = first_steps + 3;
    let cancelled = fit(model, cameras, targets, renderer(), &options, |_, p| {
        if p.step == cancel_at {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .unwrap();
    let cancelled = cancelled.restart.expect("looked at");
    assert_eq!(cancelled.runs.len(), 1, "{cancelled:?}");
    assert_eq!((cancelled.runs[0].pass.report.stop, cancelled.kept), (Stop::Cancelled, None));
}

#[test]
fn the_last_thinned_run_of_a_shape_fit_starts_from_the_lowest_ends_shape() {
    let (model, cameras, targets) = scene();
    let targets = eroded(&targets);
    // Two shapes for the figure: wider or narrower about its vertical axis, and taller or
    // shorter. The truth has neither (β = 0); the fit starts from a wrong shape and moves it,
    // so the lowest end's β is away from the initial one.
    let positions = model.mesh.positions().to_vec();
    let morphs = MorphTargets {
        names: vec!["width".into(), "height".into()],
        deltas: vec![
            positions.iter().map(|p| glam::Vec3::new(p.x, 0.0, p.z)).collect(),
            positions.iter().map(|p| glam::Vec3::new(0.0, 0.2 * p.y, 0.0)).collect(),
        ],
        joint_offsets: None,
    };
    let model = model.with_morph_targets(morphs).unwrap();
    let options = FitOptions {
        steps: 45,
        fit_shape: true,
        initial_shape: vec![0.4, -0.4],
        thinned_restarts: vec![RestartFamily::swing(0.3, 0.7)],
        ..thinned_options()
    };
    let mut shapes: Vec<Vec<f32>> = Vec::new();
    let fitted = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &options, |fit, p| {
        assert_eq!(p.step as usize, shapes.len() + 1);
        shapes.push(fit.shape().to_vec());
        ControlFlow::Continue(())
    })
    .unwrap();
    let with = fitted.restart.expect("looked at");
    let (last, before) = with.runs.split_last().expect("restarts ran");
    assert_eq!(last.start, RestartStart::LowestEnd, "{with:?}");
    // The lowest end before the last run: where the fit without the last run ends.
    let off = FitOptions { thinned_final_run: false, ..options.clone() };
    let without = fit(model, cameras, targets, renderer(), &off, go_on).unwrap();
    let lowest = without.fit.shape().to_vec();
    let moved = lowest.iter().zip(&options.initial_shape).fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
    assert!(moved > 0.1, "the lowest end's shape must be away from the initial one here: {lowest:?}");
    // The last run's first step is one Adam step (at most the learning rate per coefficient)
    // from the lowest end's shape, not from the initial shape.
    let first = fitted.first.report.steps + before.iter().map(|r| r.pass.steps()).sum::<u32>();
    let shape = &shapes[first as usize];
    let off_by = shape.iter().zip(&lowest).fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        off_by <= options.learning_rate * 1.001,
        "the last run's first step {shape:?} is not one step from the lowest end's shape {lowest:?}"
    );
}

#[test]
fn a_restart_counts_as_cancelled_where_a_run_from_its_crossed_legs_was() {
    let report = |stop| RunReport { steps: 3, hypothesis_energies: vec![1.0], chosen: 0, energy: 1.0, stop };
    let crossed = |stop| CrossedLegsReport {
        fitted_energy: 1.0,
        start_energy: 2.0,
        refined_energy: None,
        changed_ratio: 1.0,
        changed_excess: 0.0,
        runs: vec![CrossedRun { start: CrossedRunStart::AboutCrossed, report: report(stop), swap: None, energy: None }],
        end: CrossedLegsEnd::FirstRun,
    };
    let restart = |stop, crossed_legs| RestartRun {
        start: RestartStart::Family(RestartFamily::swing(0.3, 0.4)),
        pass: PassReport { report: report(stop), swap: None, crossed_legs },
        energy: Some(1.0),
    };
    let cases = [
        (restart(Stop::Finished, None), false),
        (restart(Stop::Converged, Some(crossed(Stop::Finished))), false),
        (restart(Stop::Cancelled, None), true),
        // The restart's own run ended (it has an energy), a run from its crossed legs did not.
        (restart(Stop::Finished, Some(crossed(Stop::Cancelled))), true),
    ];
    for (run, cancelled) in cases {
        assert_eq!(run.pass.cancelled(), cancelled, "{run:?}");
        let first = restart(Stop::Finished, None);
        let report = RestartReport {
            misfit_blocks: vec![0],
            thinned: true,
            first_energy: 1.0,
            runs: vec![first, run],
            kept: None,
        };
        assert_eq!(report.cancelled(), cancelled);
    }
}

//! The outline nuisance `a` of a pose fit: at the true pose, targets eroded or dilated by one
//! pixel are matched exactly by `a = −1` or `+1`; `∂E/∂a` against a finite difference; a stage
//! drops an outline settled below its `outline_settle`; bad values are errors.

use std::ops::ControlFlow;

use super::{assert_stage_rejected_before_any_step, planned};
use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::{framing_cameras, random_pose, FitOptions, FitSettings, PoseFit, Schedule, Stage};
use diffsil::{Error, Image, RenderSettings, Renderer};

/// `image` with each pixel replaced by `pick` over its 3×3 neighbourhood (outside: 0).
fn morph(image: &Image, pick: fn(f32, f32) -> f32, start: f32) -> Image {
    let (w, h) = (image.width() as i64, image.height() as i64);
    let data = (0..h)
        .flat_map(|r| (0..w).map(move |c| (r, c)))
        .map(|(r, c)| {
            let mut v = start;
            for dr in -1..=1 {
                for dc in -1..=1 {
                    let (rr, cc) = (r + dr, c + dc);
                    let x = if rr < 0 || cc < 0 || rr >= h || cc >= w { 0.0 } else { image.get(rr as u32, cc as u32) };
                    v = pick(v, x);
                }
            }
            v
        })
        .collect();
    Image::from_vec(image.width(), image.height(), data).unwrap()
}

/// A fit at the built-in figure's seed-5 pose (2 views at 24², F = 4, λ = 0) toward that pose's
/// silhouettes transformed by `spoil`.
fn fit_at_truth(spoil: impl Fn(&Image) -> Image) -> PoseFit {
    let model = builtin_figure();
    let truth = random_pose(&random_pose_limits(&model.skeleton), 30f32.to_radians(), 5);
    let cameras = framing_cameras(&model.mesh, 2, 24);
    let mut renderer = Renderer::new(RenderSettings { supersample: 4, ..RenderSettings::default() }).unwrap();
    let clean = renderer.render(&model.posed_mesh(&truth).unwrap(), &cameras).unwrap().images().to_vec();
    let targets = clean.iter().map(spoil).collect();
    let settings = FitSettings { initial: Some(truth), lambda: 0.0, ..FitSettings::default() };
    PoseFit::new(model, cameras, targets, renderer, settings).unwrap()
}

#[test]
fn a_whole_outline_matches_masks_eroded_or_dilated_by_one_pixel() {
    for (pick, start, a) in [(f32::min as fn(f32, f32) -> f32, 1.0, -1.0), (f32::max, 0.0, 1.0)] {
        let mut fit = fit_at_truth(|t| morph(t, pick, start));
        let spoiled = fit.energy().unwrap();
        assert!(spoiled > 1e-3, "a one-pixel change should cost: {spoiled}");
        fit.set_outline(a).unwrap();
        assert!(fit.energy().unwrap() < 1e-12, "a = {a}: {}", fit.energy().unwrap());
        fit.set_outline(a / 2.0).unwrap();
        let half = fit.energy().unwrap();
        assert!(half > 1e-6 && half < spoiled, "a = {}: {half} (none: {spoiled})", a / 2.0);
    }
}

#[test]
fn the_outline_gradient_matches_a_finite_difference_and_bad_values_are_errors() {
    let mut fit = fit_at_truth(|t| morph(t, f32::min, 1.0));
    for a in [-0.7f32, -0.3, 0.4] {
        fit.set_outline(a).unwrap();
        let analytic = fit.outline_gradient().unwrap();
        let h = 1e-2;
        fit.set_outline(a + h).unwrap();
        let plus = fit.energy().unwrap();
        fit.set_outline(a - h).unwrap();
        let minus = fit.energy().unwrap();
        let numeric = (plus - minus) / (2.0 * f64::from(h));
        assert!((analytic - numeric).abs() < 1e-3 * numeric.abs(), "a = {a}: {analytic} vs {numeric}");
        // Toward the erosion the energy falls.
        assert!(analytic > 0.0, "a = {a}: {analytic}");
    }
    for bad in [1.5f32, -1.01, f32::NAN] {
        assert!(matches!(fit.set_outline(bad), Err(Error::InvalidSettings(_))), "{bad}");
    }
    assert!(matches!(fit.set_outline_rate(-0.1), Err(Error::InvalidSettings(_))));
    assert_eq!(fit.outline_rate(), 0.0);
}

/// Runs a blurred stage of three steps (which fits `a` from 0) then an unblurred one of two with
/// `settle`, from the true pose toward its silhouettes dilated by one pixel; returns the fit and
/// the outline after each step.
fn settle_run(settle: f32) -> (PoseFit, Vec<f32>) {
    let mut fit = fit_at_truth(|t| morph(t, f32::max, 0.0));
    fit.set_outline_rate(0.06).unwrap();
    let schedule = Schedule {
        hypothesis_steps: 0,
        stages: vec![Stage::new(Schedule::COARSE_BLUR, 3), Stage { outline_settle: settle, ..Stage::new(0.0, 2) }],
        convergence: None,
    };
    let mut outlines = Vec::new();
    fit.run(&schedule, &[], |fit, _| {
        outlines.push(fit.outline());
        ControlFlow::Continue(())
    })
    .unwrap();
    (fit, outlines)
}

#[test]
fn a_stage_drops_an_outline_settled_below_its_value_and_keeps_a_larger_one() {
    // The blurred steps grow `a` toward the dilated targets.
    let (kept, outlines) = settle_run(0.0);
    let grown = outlines[2];
    assert!(grown > 0.05 && grown < 1.0, "after the blurred stage: {outlines:?}");
    assert!(outlines[3] != 0.0 && outlines[4] != 0.0, "{outlines:?}");
    assert_eq!(kept.outline_rate(), 0.06);
    // Below the settle value: dropped as the stage begins, and not fitted again.
    let (mut dropped, outlines) = settle_run(grown * 1.01);
    assert_eq!(&outlines[3..], [0.0, 0.0], "{outlines:?}");
    assert_eq!((dropped.outline(), dropped.outline_rate()), (0.0, 0.0));
    dropped.step().unwrap();
    assert_eq!(dropped.outline(), 0.0);
    // Above it: kept and fitted.
    let (above, outlines) = settle_run(grown * 0.99);
    assert!(outlines[3] != 0.0 && outlines[4] != 0.0, "{outlines:?}");
    assert_eq!(above.outline_rate(), 0.06);
}

#[test]
fn bad_outline_settles_are_errors_before_any_step_and_the_options_put_it_on_the_unblurred_stage() {
    for bad in [-0.1f32, f32::NAN, f32::INFINITY] {
        let mut fit = fit_at_truth(|t| t.clone());
        let stage = Stage { outline_settle: bad, ..Stage::new(0.0, 1) };
        assert_stage_rejected_before_any_step(&mut fit, stage, &format!("outline settle {bad}"));
        let plan = FitOptions { outline_settle: bad, ..FitOptions::default() }.plan(&builtin_figure());
        assert!(matches!(plan, Err(Error::InvalidSettings(_))), "{bad}: {plan:?}");
    }
    let settles = |options: &FitOptions| planned(options, |s| s.outline_settle);
    let defaults = FitOptions::default();
    assert_eq!(settles(&defaults), [0.0, 0.0, 0.0]);
    let settled = FitOptions { outline_settle: 0.1, ..defaults.clone() };
    assert_eq!(settles(&settled), [0.0, 0.0, 0.1]);
    // Without blur the outline starts at 0 and is kept.
    assert_eq!(settles(&FitOptions { coarse_blur: 0.0, ..settled }), [0.0]);
    let schedule = Schedule::coarse_to_fine(300, 3);
    assert!(schedule.stages.iter().all(|s| s.outline_settle == 0.0));
}

#[test]
fn downsampled_targets_fit_the_surface_offset_in_place_of_the_outline() {
    let options = FitOptions::default();
    assert_eq!(options.clone().for_downsampled(1), options, "a factor of 1 keeps the options");
    for factor in [2, 5] {
        let downsampled = options.clone().for_downsampled(factor);
        assert!(downsampled.fit_inflation && !downsampled.fit_outline, "factor {factor}");
        assert_eq!(FitOptions { fit_inflation: false, fit_outline: true, ..downsampled }, options);
    }
}

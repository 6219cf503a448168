//! The limb swap test (`PoseFit::swap_limbs`, `limb_swaps`): a mirrored limb is the reflection
//! of the limb in the body's coronal plane and mirroring twice gives the pose back; a fit whose
//! arm or leg sits on the wrong side ends on the right one; screening refines the candidates
//! lowest as they are, to the bits of the full test; a swap that raises the energy is not kept;
//! `fit::fit` runs the test after its descent only when asked.

use diffsil::pose::figure::builtin_figure;
use diffsil::pose::fit::{
    fit, framing_ring, limb_swaps, limb_swing_hypotheses, per_vertex_error, FitOptions, FitSettings, LimbSwap, PoseFit,
    SwapScreen, SwapTest, RAISED_ELEVATION_DEG,
};
use diffsil::pose::skin::{Pose, SkinnedMesh};
use diffsil::{Camera, Image, Mat3, RenderSettings, Renderer, Vec3};

/// The built-in figure with the legs in a stride and the arms swung (one forward, one back)
/// (also used by `head_turns.rs`).
pub(super) fn striding() -> (SkinnedMesh, Pose) {
    let model = builtin_figure();
    let poses = limb_swing_hypotheses(&model, 0.5, 0.6).unwrap();
    // Rest, then (legs +, arms −), (legs +, arms +), ...: the second one.
    let mut pose = poses[1].clone();
    pose.orientation = Vec3::new(0.0, 0.3, 0.0);
    (model, pose)
}

/// The candidate of `kind` among `limb_swaps(model, pose)`.
fn candidate(model: &SkinnedMesh, pose: &Pose, kind: LimbSwap) -> Pose {
    limb_swaps(model, pose).unwrap().into_iter().find(|(k, _)| *k == kind).expect("candidate present").1
}

/// The limbs' first joints, from the candidates' kinds: legs then arms.
fn limbs(model: &SkinnedMesh, pose: &Pose) -> Vec<usize> {
    limb_swaps(model, pose)
        .unwrap()
        .into_iter()
        .filter_map(|(k, _)| match k {
            LimbSwap::Mirror(j) => Some(j),
            _ => None,
        })
        .collect()
}

/// 4 views on the raised ring at `resolution`², the silhouettes of `truth` (also used by
/// `crossed_legs.rs`).
pub(super) fn views(model: &SkinnedMesh, truth: &Pose, resolution: u32) -> (Vec<Camera>, Vec<Image>) {
    let rest = model.posed_mesh(&Pose::rest(model.joint_count())).unwrap();
    let cameras = framing_ring(&rest, 4, resolution, RAISED_ELEVATION_DEG.to_radians());
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let targets = renderer.render(&model.posed_mesh(truth).unwrap(), &cameras).unwrap().images().to_vec();
    (cameras, targets)
}

/// A fit of `targets` from `start` with the default pose prior (also used by `head_turns.rs`).
pub(super) fn fit_from(model: &SkinnedMesh, start: &Pose, cameras: Vec<Camera>, targets: Vec<Image>) -> PoseFit {
    let renderer = Renderer::new(RenderSettings::default()).unwrap();
    let settings = FitSettings { initial: Some(start.clone()), ..FitSettings::default() };
    let mut fit = PoseFit::new(model.clone(), cameras, targets, renderer, settings).unwrap();
    fit.set_pose_prior(PoseFit::POSE_PRIOR).unwrap();
    fit
}

#[test]
fn there_are_candidates_for_each_limb_and_the_legs() {
    let (model, pose) = striding();
    let kinds: Vec<LimbSwap> = limb_swaps(&model, &pose).unwrap().into_iter().map(|(k, _)| k).collect();
    assert_eq!(limbs(&model, &pose).len(), 4, "{kinds:?}");
    assert!(kinds.contains(&LimbSwap::MirrorLegs) && kinds.contains(&LimbSwap::ExchangeLegs), "{kinds:?}");
}

#[test]
fn a_mirrored_limb_is_the_limb_reflected_in_the_coronal_plane_and_twice_is_the_pose() {
    let (model, pose) = striding();
    let world = model.joint_transforms(&pose).unwrap();
    let at = |g: &[glam::Mat4], j: usize| g[j].w_axis.truncate();
    let [left_leg, right_leg, ..] = limbs(&model, &pose)[..] else { panic!("no legs") };
    // The body's forward axis: across the hips and up the body, turned by the orientation.
    let [.., left_arm, right_arm] = limbs(&model, &pose)[..] else { panic!("no arms") };
    let mid = |a: usize, b: usize| 0.5 * (at(&world, a) + at(&world, b));
    let lateral = at(&world, left_leg) - at(&world, right_leg);
    let forward = lateral.cross(mid(left_arm, right_arm) - mid(left_leg, right_leg)).normalize();
    let mirrored = candidate(&model, &pose, LimbSwap::Mirror(left_leg));
    let after = model.joint_transforms(&mirrored).unwrap();
    let children: Vec<usize> =
        (0..model.joint_count()).filter(|&c| model.skeleton.parents[c] == Some(left_leg)).collect();
    let knee = children[0];
    let before_offset = at(&world, knee) - at(&world, left_leg);
    let after_offset = at(&after, knee) - at(&after, left_leg);
    assert!(before_offset.dot(forward).abs() > 0.05 * before_offset.length(), "the leg swings: {before_offset}");
    // Each joint of the limb moved by M·T·M (M the reflection in the coronal plane) where it
    // moved by T: T = Q·Q⁰ᵀ, Q its world rotation at the pose, Q⁰ at rest.
    let reflect = |v: Vec3| v - 2.0 * v.dot(forward) * forward;
    let m = Mat3::from_cols(reflect(Vec3::X), reflect(Vec3::Y), reflect(Vec3::Z));
    let rest = model.joint_transforms(&Pose::rest(model.joint_count())).unwrap();
    let rotation = |g: &glam::Mat4| Mat3::from_mat4(*g);
    for j in [left_leg, knee] {
        let moved = rotation(&world[j]) * rotation(&rest[j]).transpose();
        let expected = m * moved * m;
        let got = rotation(&after[j]) * rotation(&rest[j]).transpose();
        assert!(got.abs_diff_eq(expected, 1e-4), "joint {j}: {got} vs {expected}");
    }
    // So the knee swings to the other side, nearly its reflection (the thigh's rest bone is
    // nearly in the coronal plane).
    let reflected = reflect(before_offset);
    assert!(after_offset.dot(forward) * before_offset.dot(forward) < 0.0);
    assert!((after_offset - reflected).length() < 0.05 * before_offset.length(), "{after_offset} vs {reflected}");
    // The other leg and the arms did not move.
    for j in [right_leg, limbs(&model, &pose)[2]] {
        assert!((at(&after, j) - at(&world, j)).length() < 1e-6);
        assert_eq!(mirrored.joint_rotations[j], pose.joint_rotations[j]);
    }
    // Twice is the pose (the same vertices).
    let twice = candidate(&model, &mirrored, LimbSwap::Mirror(left_leg));
    let error = per_vertex_error(&model.skin(&twice).unwrap(), &model.skin(&pose).unwrap());
    assert!(error < 1e-4, "mirrored twice is {error} m off");
    // Exchanging the legs twice too; once, the legs trade places front to back.
    let exchanged = candidate(&model, &pose, LimbSwap::ExchangeLegs);
    let twice = candidate(&model, &exchanged, LimbSwap::ExchangeLegs);
    assert!(per_vertex_error(&model.skin(&twice).unwrap(), &model.skin(&pose).unwrap()) < 1e-4);
    let swapped = model.joint_transforms(&exchanged).unwrap();
    let foot_forward = |g: &[glam::Mat4], leg: usize| {
        let knee = (0..model.joint_count()).find(|&c| model.skeleton.parents[c] == Some(leg)).unwrap();
        (at(g, knee) - at(g, leg)).dot(forward)
    };
    let (l, r) = (foot_forward(&world, left_leg), foot_forward(&world, right_leg));
    let (l2, r2) = (foot_forward(&swapped, left_leg), foot_forward(&swapped, right_leg));
    assert!(l * r < 0.0, "a stride: {l} {r}");
    // (Nearly: each leg keeps its own rest bone, and the legs' rest bones are not exactly mirror
    // images in the sagittal plane through the hips' midpoint.)
    let tolerance = 0.05 * (l.abs() + r.abs());
    assert!((l2 - r).abs() < tolerance && (r2 - l).abs() < tolerance, "exchanged {l2} {r2}, was {l} {r}");
}

#[test]
fn a_fit_with_a_limb_on_the_wrong_side_ends_on_the_right_side() {
    let (model, truth) = striding();
    let [_, _, arm, _] = limbs(&model, &truth)[..] else { panic!("no arms") };
    let (cameras, targets) = views(&model, &truth, 48);
    let wrong = candidate(&model, &truth, LimbSwap::Mirror(arm));
    let truth_vertices = model.skin(&truth).unwrap();
    let start_error = per_vertex_error(&model.skin(&wrong).unwrap(), &truth_vertices);
    // Compared as they are, and after 4 refinement steps of the pose and every candidate.
    for steps in [0, 4] {
        let mut fit = fit_from(&model, &wrong, cameras.clone(), targets.clone());
        // A fresh Adam's first steps move every parameter by the learning rate (a fit's own
        // Adam has settled by the end of its descent): small steps here.
        fit.set_learning_rate(0.002).unwrap();
        let report = fit.swap_limbs(&SwapTest { steps, screen: SwapScreen::ALL, ..SwapTest::default() }).unwrap();
        assert_eq!(report.kept, Some(LimbSwap::Mirror(arm)), "{report:?}");
        let error = per_vertex_error(&fit.vertices().unwrap(), &truth_vertices);
        assert!(error < 0.2 * start_error, "{steps} steps: {start_error} m → {error} m");
        let kept = report.candidates.iter().find(|c| c.kind == LimbSwap::Mirror(arm)).unwrap().energy.unwrap();
        assert!(kept < report.energy, "{report:?}");
        assert!((fit.energy().unwrap() - kept).abs() <= 1e-9 * kept.max(1e-12), "{report:?}");
    }
}

#[test]
fn screening_refines_the_lowest_candidates_to_the_same_bits_as_the_full_test() {
    let (model, truth) = striding();
    let [_, _, arm, _] = limbs(&model, &truth)[..] else { panic!("no arms") };
    let (cameras, targets) = views(&model, &truth, 32);
    let wrong = candidate(&model, &truth, LimbSwap::Mirror(arm));
    let run = |screen: SwapScreen| {
        let mut fit = fit_from(&model, &wrong, cameras.clone(), targets.clone());
        fit.set_learning_rate(0.002).unwrap();
        let report = fit.swap_limbs(&SwapTest { steps: 3, screen, ..SwapTest::default() }).unwrap();
        (report, fit.pose())
    };
    let (full, full_pose) = run(SwapScreen::ALL);
    assert!(full.candidates.iter().all(|c| c.start_energy.is_none() && c.energy.is_some()), "{full:?}");
    assert_eq!(full.start_energy, None);
    let (screened, screened_pose) = run(SwapScreen { lowest: 2, within: 0.0 });
    // Every candidate's energy as it is; the two lowest refined.
    let start = |c: &diffsil::pose::fit::SwapCandidate| c.start_energy.expect("screened");
    let mut order: Vec<usize> = (0..screened.candidates.len()).collect();
    order.sort_by(|&a, &b| start(&screened.candidates[a]).total_cmp(&start(&screened.candidates[b])));
    for (rank, &k) in order.iter().enumerate() {
        let (c, f) = (&screened.candidates[k], &full.candidates[k]);
        assert_eq!(c.kind, f.kind);
        if rank < 2 {
            // The same steps as in the full test, whatever ran beside them.
            assert_eq!(c.energy, f.energy, "{screened:?}");
        } else {
            assert_eq!(c.energy, None, "{screened:?}");
        }
    }
    assert_eq!(screened.energy, full.energy);
    assert_eq!(screened.kept, Some(LimbSwap::Mirror(arm)), "{screened:?}");
    assert_eq!((screened.kept, screened_pose), (full.kept, full_pose));
    // None refined: the pose takes its steps alone and stays.
    let (none, _) = run(SwapScreen { lowest: 0, within: 0.0 });
    assert!(none.candidates.iter().all(|c| c.start_energy.is_some() && c.energy.is_none()), "{none:?}");
    assert_eq!((none.kept, none.energy), (None, full.energy));
    // By the ratio to the pose's energy as it is: those within it, here every one.
    let pose_start = screened.start_energy.expect("screened");
    let highest = screened.candidates.iter().map(start).fold(0.0, f64::max);
    let (ratio, _) = run(SwapScreen { lowest: 0, within: highest / pose_start });
    assert_eq!(
        ratio.candidates.iter().map(|c| c.energy).collect::<Vec<_>>(),
        full.candidates.iter().map(|c| c.energy).collect::<Vec<_>>()
    );
    // Only those within it.
    let middle = start(&screened.candidates[order[order.len() / 2]]);
    let within = middle / pose_start;
    let (half, _) = run(SwapScreen { lowest: 0, within });
    for c in &half.candidates {
        assert_eq!(c.energy.is_some(), start(c) <= within * pose_start, "{half:?}");
    }
    assert!(half.candidates.iter().any(|c| c.energy.is_none()), "{half:?}");
    let mut swap_test = fit_from(&model, &wrong, cameras.clone(), targets.clone());
    for within in [f64::NAN, -1.0] {
        let screen = SwapScreen { lowest: 2, within };
        assert!(swap_test.swap_limbs(&SwapTest { steps: 3, screen, ..SwapTest::default() }).is_err(), "{within}");
    }
    // The library call checks the screen before it takes a step.
    for within in [f64::NAN, -1.0] {
        let options = FitOptions { swap_screen: SwapScreen { lowest: 2, within }, ..FitOptions::default() };
        let result = fit(model.clone(), cameras.clone(), targets.clone(), super::call::renderer(), &options, |_, _| {
            panic!("a step before the swap screen was checked")
        });
        assert!(matches!(result, Err(diffsil::Error::InvalidSettings(_))), "{within}: {result:?}");
    }
}

#[test]
fn the_default_swap_test_is_the_one_the_default_fit_runs() {
    assert_eq!(FitOptions::default().swap_test(), SwapTest::default());
    let options =
        FitOptions { swap_steps: 3, head_turn_below: 0.5, swap_screen: SwapScreen::ALL, ..FitOptions::default() };
    assert_eq!(options.swap_test(), SwapTest { steps: 3, screen: SwapScreen::ALL, head_turn_below: 0.5 });
}

#[test]
fn a_swap_that_raises_the_energy_is_not_kept() {
    let (model, truth) = striding();
    let (cameras, targets) = views(&model, &truth, 48);
    for steps in [0, 3] {
        let mut fit = fit_from(&model, &truth, cameras.clone(), targets.clone());
        fit.set_learning_rate(0.002).unwrap();
        let report = fit.swap_limbs(&SwapTest { steps, screen: SwapScreen::ALL, ..SwapTest::default() }).unwrap();
        assert_eq!(report.kept, None, "{report:?}");
        // Six, and three turns of each forearm (the arms are straight: their turns hardly move
        // the hands, but they still end above the truth).
        assert_eq!(report.candidates.len(), 6 + 6);
        assert!(report.candidates.iter().all(|c| c.energy.unwrap() > report.energy), "{report:?}");
        if steps == 0 {
            let error = per_vertex_error(&fit.vertices().unwrap(), &model.skin(&truth).unwrap());
            assert!(error < 1e-6, "stayed at the truth: {error} m");
        }
    }
}

#[test]
fn the_library_call_runs_the_swap_test_when_asked() {
    let (model, truth) = striding();
    let (cameras, targets) = views(&model, &truth, 24);
    let renderer = || Renderer::new(RenderSettings::default()).unwrap();
    let options = FitOptions { steps: 40, swap_steps: 2, ..FitOptions::default() };
    let with = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &options, |_, _| {
        std::ops::ControlFlow::Continue(())
    })
    .unwrap();
    let swap = with.first.swap.expect("the swap test ran");
    // Six, a forward and a back swing for each arm left near the body's plane, and three turns
    // of each forearm.
    let swings = swap.candidates.iter().filter(|c| matches!(c.kind, LimbSwap::Swing(..))).count();
    let twists = swap.candidates.iter().filter(|c| matches!(c.kind, LimbSwap::Twist(..))).count();
    assert_eq!((swap.candidates.len(), twists), (6 + swings + 6, 6), "{swap:?}");
    assert!(swings % 2 == 0 && swings <= 4, "{swap:?}");
    let options = FitOptions { swap_steps: 0, ..options };
    let without =
        fit(model, cameras, targets, renderer(), &options, |_, _| std::ops::ControlFlow::Continue(())).unwrap();
    assert!(without.first.swap.is_none());
}

/// The joints that `limb_swaps`'s candidates at `pose` name, where `joint` picks one from a
/// candidate's kind, each once (in the candidates' order).
fn named(model: &SkinnedMesh, pose: &Pose, joint: fn(LimbSwap) -> Option<usize>) -> Vec<usize> {
    let mut joints: Vec<usize> = limb_swaps(model, pose).unwrap().into_iter().filter_map(|(k, _)| joint(k)).collect();
    joints.dedup();
    joints
}

/// `root` and every joint below it, in joint order.
pub(super) fn subtree(model: &SkinnedMesh, root: usize) -> Vec<usize> {
    (0..model.joint_count())
        .filter(|&j| {
            let mut k = Some(j);
            while let Some(x) = k {
                if x == root {
                    return true;
                }
                k = model.skeleton.parents[x];
            }
            false
        })
        .collect()
}

/// The arms' first joints that `limb_swaps` swings at `pose` (arms near the coronal plane).
fn swung(model: &SkinnedMesh, pose: &Pose) -> Vec<usize> {
    named(model, pose, |k| match k {
        LimbSwap::Swing(j, _) => Some(j),
        _ => None,
    })
}

#[test]
fn an_arm_in_the_coronal_plane_is_also_swung_forward_and_back() {
    let model = builtin_figure();
    let mut pose = Pose::rest(model.joint_count());
    pose.orientation = Vec3::new(0.0, 0.3, 0.0);
    let kinds: Vec<LimbSwap> = limb_swaps(&model, &pose).unwrap().into_iter().map(|(k, _)| k).collect();
    // At rest both arms hang in the coronal plane: two swings each besides the mirror (and
    // three turns of each forearm).
    let arms = swung(&model, &pose);
    assert_eq!(arms.len(), 2, "{kinds:?}");
    assert_eq!(kinds.len(), 4 + 4 + 2 + 6, "{kinds:?}");
    for &arm in &arms {
        assert!(kinds.contains(&LimbSwap::Mirror(arm)), "{kinds:?}");
    }
    // Swung 22° (the striding pose), they are mirrored only.
    let (model_striding, striding_pose) = striding();
    assert!(swung(&model_striding, &striding_pose).is_empty());
    let world = model.joint_transforms(&pose).unwrap();
    let at = |g: &[glam::Mat4], j: usize| g[j].w_axis.truncate();
    let legs = limbs(&model, &pose);
    let lateral = at(&world, legs[0]) - at(&world, legs[1]);
    let mid = |g: &[glam::Mat4], a: usize, b: usize| 0.5 * (at(g, a) + at(g, b));
    let forward = lateral.cross(mid(&world, arms[0], arms[1]) - mid(&world, legs[0], legs[1])).normalize();
    let arm = arms[0];
    // The arm's far end: its joint farthest from the shoulder.
    let below = subtree(&model, arm);
    let tip = *below
        .iter()
        .max_by(|&&a, &&b| {
            let d = |j: usize| (at(&world, j) - at(&world, arm)).length();
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    let before = at(&world, tip) - at(&world, arm);
    for (forward_swing, sign) in [(true, 1.0f32), (false, -1.0)] {
        let after_pose = candidate(&model, &pose, LimbSwap::Swing(arm, forward_swing));
        let after = model.joint_transforms(&after_pose).unwrap();
        let offset = at(&after, tip) - at(&after, arm);
        // Turned rigidly by 40° about an axis through the shoulder, its far end forward (or
        // back).
        assert!((offset.length() - before.length()).abs() < 1e-4 * before.length());
        let angle = (offset.dot(before) / (offset.length() * before.length())).clamp(-1.0, 1.0).acos();
        assert!((angle - 0.7).abs() < 1e-3, "turned by {angle} rad");
        assert!(sign * offset.dot(forward) > 0.5 * before.length(), "{forward_swing}: {offset} vs forward {forward}");
        // In the plane of the arm and the forward axis.
        let normal = before.cross(forward).normalize();
        assert!(offset.dot(normal).abs() < 1e-3 * before.length(), "{offset} off the swing's plane");
        // Nothing else moved.
        for j in (0..model.joint_count()).filter(|j| !below.contains(j)) {
            assert!((at(&after, j) - at(&world, j)).length() < 1e-5, "joint {j} moved");
        }
    }
}

#[test]
fn a_fit_with_an_arm_left_in_the_body_plane_swings_it_forward() {
    let model = builtin_figure();
    let start = Pose::rest(model.joint_count());
    let [arm, _] = swung(&model, &start)[..] else { panic!("no arms swung") };
    let truth = candidate(&model, &start, LimbSwap::Swing(arm, true));
    let (cameras, targets) = views(&model, &truth, 48);
    let truth_vertices = model.skin(&truth).unwrap();
    let start_error = per_vertex_error(&model.skin(&start).unwrap(), &truth_vertices);
    let mut fit = fit_from(&model, &start, cameras, targets);
    fit.set_learning_rate(0.002).unwrap();
    let report = fit.swap_limbs(&SwapTest { steps: 4, screen: SwapScreen::ALL, ..SwapTest::default() }).unwrap();
    assert_eq!(report.kept, Some(LimbSwap::Swing(arm, true)), "{report:?}");
    let error = per_vertex_error(&fit.vertices().unwrap(), &truth_vertices);
    assert!(error < 0.2 * start_error, "{start_error} m → {error} m");
}

/// The elbows that `limb_swaps` turns forearms at, at `pose`.
fn elbows(model: &SkinnedMesh, pose: &Pose) -> Vec<usize> {
    named(model, pose, |k| match k {
        LimbSwap::Twist(j, _) => Some(j),
        _ => None,
    })
}

/// The built-in figure at rest with each elbow bent 1.2 rad (69°) about its joint's x axis.
fn bent_elbows() -> (SkinnedMesh, Pose, Vec<usize>) {
    let model = builtin_figure();
    let mut pose = Pose::rest(model.joint_count());
    let elbows = elbows(&model, &pose);
    for &elbow in &elbows {
        pose.joint_rotations[elbow] = Vec3::new(1.2, 0.0, 0.0);
    }
    (model, pose, elbows)
}

#[test]
fn a_forearm_is_turned_about_its_upper_arm_by_quarter_turns() {
    let (model, pose, elbows) = bent_elbows();
    assert_eq!(elbows.len(), 2, "one elbow per arm");
    let parents = &model.skeleton.parents;
    let world = model.joint_transforms(&pose).unwrap();
    let at = |g: &[glam::Mat4], j: usize| g[j].w_axis.truncate();
    for &elbow in &elbows {
        let shoulder = parents[elbow].expect("an elbow has a parent");
        let below = subtree(&model, elbow);
        let wrist = *below.iter().find(|&&j| parents[j] == Some(elbow)).expect("a forearm");
        let axis = (at(&world, elbow) - at(&world, shoulder)).normalize();
        let offset = at(&world, wrist) - at(&world, elbow);
        let across = offset - offset.dot(axis) * axis;
        assert!(across.length() > 0.5 * offset.length(), "the elbow is bent: {offset}");
        for quarter in 1..=3u8 {
            let turned = candidate(&model, &pose, LimbSwap::Twist(elbow, quarter));
            let after = model.joint_transforms(&turned).unwrap();
            let moved = at(&after, wrist) - at(&after, elbow);
            // The same distance from the elbow and along the upper arm; round the upper arm's
            // line by the quarter turns.
            assert!((moved.length() - offset.length()).abs() < 1e-4 * offset.length());
            assert!((moved.dot(axis) - offset.dot(axis)).abs() < 1e-4 * offset.length());
            let moved_across = moved - moved.dot(axis) * axis;
            let angle = across.cross(moved_across).dot(axis).atan2(across.dot(moved_across));
            let expected = f32::from(quarter) * std::f32::consts::FRAC_PI_2;
            let diff = (angle - expected).rem_euclid(std::f32::consts::TAU);
            assert!(diff.min(std::f32::consts::TAU - diff) < 1e-3, "quarter {quarter}: turned {angle} rad");
            // Nothing above the elbow moved.
            for j in (0..model.joint_count()).filter(|j| !below.contains(j) || *j == elbow) {
                assert!((at(&after, j) - at(&world, j)).length() < 1e-5, "joint {j} moved");
            }
        }
    }
}

#[test]
fn a_fit_with_a_forearm_bent_the_wrong_way_turns_it_back() {
    let (model, start, elbows) = bent_elbows();
    let elbow = elbows[0];
    let truth = candidate(&model, &start, LimbSwap::Twist(elbow, 2));
    let (cameras, targets) = views(&model, &truth, 48);
    let truth_vertices = model.skin(&truth).unwrap();
    let start_error = per_vertex_error(&model.skin(&start).unwrap(), &truth_vertices);
    let mut fit = fit_from(&model, &start, cameras, targets);
    fit.set_learning_rate(0.002).unwrap();
    let report = fit.swap_limbs(&SwapTest { steps: 4, screen: SwapScreen::default(), ..SwapTest::default() }).unwrap();
    assert_eq!(report.kept, Some(LimbSwap::Twist(elbow, 2)), "{report:?}");
    let error = per_vertex_error(&fit.vertices().unwrap(), &truth_vertices);
    assert!(error < 0.2 * start_error, "{start_error} m → {error} m");
}

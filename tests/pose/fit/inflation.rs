//! The inflation nuisance `d` of a pose fit: vertex normals, `∂E/∂d` against a finite
//! difference, and a fit to dilated / eroded masks that explains them by `d` of the right sign.

use std::ops::ControlFlow;

use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::{fit, framing_cameras, random_pose, vertex_normals, FitOptions, FitSettings, PoseFit};
use diffsil::{Error, Image, RenderSettings, Renderer, Vec3};

#[test]
fn vertex_normals_are_unit_area_weighted_and_outward() {
    // A tetrahedron with outward-facing triangles: the corner at the origin has the three
    // axis-aligned faces of equal area, so its normal is −(1,1,1)/√3.
    let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    let triangles = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    let n = vertex_normals(&positions, &triangles);
    assert!((n[0] + Vec3::ONE / 3f32.sqrt()).length() < 1e-6, "{:?}", n[0]);
    // Vertex 1 (at x): faces −z and −y of area 1/2 and the slanted face (1,1,1)/√3 of area √3/2:
    // (0,−1/2,−1/2) + (1/2,1/2,1/2) = (1/2, 0, 0).
    assert!((n[1] - Vec3::X).length() < 1e-6, "{:?}", n[1]);
    assert!(n.iter().all(|v| (v.length() - 1.0).abs() < 1e-6));
    // A vertex on no triangle gets zero.
    assert_eq!(vertex_normals(&[Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z], &[[0, 1, 2]])[3], Vec3::ZERO);
}

/// A fit of the built-in figure's seed-5 pose from the rest pose, 4 views at 24², λ = 0, with
/// `supersample` samples per pixel side.
fn fit_of_seed_5(supersample: u32) -> PoseFit {
    let model = builtin_figure();
    let truth = random_pose(&random_pose_limits(&model.skeleton), 30f32.to_radians(), 5);
    let cameras = framing_cameras(&model.mesh, 4, 24);
    let mut renderer = Renderer::new(RenderSettings { supersample, ..RenderSettings::default() }).unwrap();
    let targets = renderer.render(&model.posed_mesh(&truth).unwrap(), &cameras).unwrap().images().to_vec();
    let settings = FitSettings { lambda: 0.0, ..FitSettings::default() };
    PoseFit::new(model, cameras, targets, renderer, settings).unwrap()
}

#[test]
fn the_inflation_gradient_matches_a_finite_difference() {
    // Dense supersampling makes the rendered coverage close to the exact area, whose derivative
    // the backward computes; what is left (16² samples per pixel, a 2 mm step at 24²) is within
    // 10%.
    let mut fit = fit_of_seed_5(16);
    for d in [0.0f32, 0.02, -0.015] {
        fit.set_inflation(d).unwrap();
        let analytic = fit.inflation_gradient().unwrap();
        let h = 2e-3;
        fit.set_inflation(d + h).unwrap();
        let plus = fit.energy().unwrap();
        fit.set_inflation(d - h).unwrap();
        let minus = fit.energy().unwrap();
        let numeric = (plus - minus) / (2.0 * f64::from(h));
        assert!(
            (analytic - numeric).abs() < 0.1 * numeric.abs(),
            "d = {d}: ∂E/∂d analytic {analytic} vs finite difference {numeric}"
        );
    }
    assert!(matches!(fit.set_inflation(f32::NAN), Err(Error::InvalidSettings(_))));
    assert!(matches!(fit.set_inflation_rate(-1.0), Err(Error::InvalidSettings(_))));
}

#[test]
fn without_a_rate_the_inflation_stays_put_and_the_vertices_exclude_it() {
    let mut fit = fit_of_seed_5(4);
    let vertices = fit.vertices().unwrap();
    fit.set_inflation(0.01).unwrap();
    assert_eq!(fit.vertices().unwrap(), vertices, "reported vertices exclude d");
    fit.step().unwrap();
    assert_eq!(fit.inflation(), 0.01);
    fit.set_inflation_rate(0.002).unwrap();
    fit.step().unwrap();
    assert!((fit.inflation() - 0.01).abs() > 1e-3, "a fitted d moves by about its rate");
    // A restart starts again without inflation.
    fit.restart(&fit.pose()).unwrap();
    assert_eq!(fit.inflation(), 0.0);
}

/// `image` with each pixel replaced by the max (`grow`) or min of its 3×3 neighbourhood,
/// outside counting as background.
fn morph(image: &Image, grow: bool) -> Image {
    let (w, h) = (image.width() as i64, image.height() as i64);
    let mut out = image.clone();
    for i in 0..h {
        for j in 0..w {
            let mut v: f32 = if grow { 0.0 } else { 1.0 };
            for (di, dj) in (-1..=1).flat_map(|a| (-1..=1).map(move |b| (a, b))) {
                let (r, c) = (i + di, j + dj);
                let x = if r < 0 || c < 0 || r >= h || c >= w { 0.0 } else { image.get(r as u32, c as u32) };
                v = if grow { v.max(x) } else { v.min(x) };
            }
            out.data_mut()[(i * w + j) as usize] = v;
        }
    }
    out
}

#[test]
fn a_fit_to_dilated_masks_inflates_and_to_eroded_ones_deflates() {
    let model = builtin_figure();
    let truth = random_pose(&random_pose_limits(&model.skeleton), 30f32.to_radians(), 3);
    let cameras = framing_cameras(&model.mesh, 4, 24);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let clean = renderer.render(&model.posed_mesh(&truth).unwrap(), &cameras).unwrap().images().to_vec();
    // The descent alone: at 24² after 80 steps the swap test may keep a limb swap whose
    // refinement trades some of the offset for the pose (d for dilated masks then ends near 0).
    let options = FitOptions { steps: 80, fit_inflation: true, swap_steps: 0, ..FitOptions::default() };
    let mut ds = Vec::new();
    for grow in [true, false] {
        let targets: Vec<Image> = clean.iter().map(|t| morph(t, grow)).collect();
        let renderer = Renderer::new(RenderSettings::default()).unwrap();
        let fitted =
            fit(model.clone(), cameras.clone(), targets, renderer, &options, |_, _| ControlFlow::Continue(())).unwrap();
        ds.push(fitted.fit.inflation());
    }
    assert!(ds[0] > 0.0 && ds[1] < 0.0, "d for dilated, eroded masks: {ds:?}");
    let off = FitOptions { fit_inflation: false, ..options };
    let fitted = fit(model, cameras, clean, renderer, &off, |_, _| ControlFlow::Continue(())).unwrap();
    assert_eq!(fitted.fit.inflation(), 0.0);
}

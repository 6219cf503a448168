//! The coarse proxy of the blurred steps (`PoseFit::set_coarse_proxy`, `FitOptions::coarse_proxy`):
//! unblurred steps and steps blurred less than its least blur never see it, the others render
//! it and land near the whole mesh's step, and bad cells and blurs are errors.

use std::ops::ControlFlow;

use diffsil::pose::fit::{fit, framing_cameras, FitOptions, Schedule};
use diffsil::{Error, RenderSettings, Renderer};

use super::{fit_from_rest, scene};

/// The figure's extent along y.
fn height(fit: &diffsil::pose::fit::PoseFit) -> f32 {
    let vertices = fit.vertices().unwrap();
    let ys = vertices.iter().map(|p| p.y);
    ys.clone().fold(f32::NEG_INFINITY, f32::max) - ys.fold(f32::INFINITY, f32::min)
}

#[test]
fn unblurred_steps_ignore_the_proxy() {
    let (mut whole, _, _) = fit_from_rest(32, 5);
    let (mut proxied, _, _) = fit_from_rest(32, 5);
    let cell = 0.05 * height(&proxied);
    proxied.set_coarse_proxy(Some(cell), 0.0).unwrap();
    for _ in 0..3 {
        assert_eq!(whole.step().unwrap(), proxied.step().unwrap());
    }
    assert_eq!(whole.pose(), proxied.pose());
    assert_eq!(whole.energy().unwrap(), proxied.energy().unwrap());
}

#[test]
fn blurred_steps_render_the_proxy_and_land_near_the_whole_mesh() {
    let (mut whole, _, _) = fit_from_rest(32, 5);
    let (mut proxied, _, _) = fit_from_rest(32, 5);
    let cell = 0.03 * height(&proxied);
    let (vertices, triangles) = proxied.set_coarse_proxy(Some(cell), 0.0).unwrap();
    assert!(vertices > 0 && triangles > 0);
    for fit in [&mut whole, &mut proxied] {
        fit.set_blur(Schedule::COARSE_BLUR).unwrap();
    }
    let start = whole.pose().to_params();
    let (a, b) = (whole.step().unwrap(), proxied.step().unwrap());
    // The proxy's blurred silhouettes are within 10% of the whole mesh's energy (6% here).
    let relative = (a.silhouette - b.silhouette).abs() / a.silhouette;
    assert!(relative > 0.0 && relative < 0.1, "E_sl {} against {} ({relative:.3})", a.silhouette, b.silhouette);
    let (pa, pb) = (whole.pose().to_params(), proxied.pose().to_params());
    assert_ne!(pa, pb);
    // The first Adam step moves every free parameter by about the learning rate, in the
    // direction of its gradient's sign: the proxy's gradient has the same sign almost everywhere.
    let moved = |p: &[f32]| p.iter().zip(&start).map(|(x, s)| (x - s).signum()).collect::<Vec<f32>>();
    let (da, db) = (moved(&pa), moved(&pb));
    let agree = da.iter().zip(&db).filter(|(x, y)| x == y).count();
    assert!(agree as f64 >= 0.8 * da.len() as f64, "{agree} of {} steps agree in sign", da.len());
    // Unset: the blurred step is the whole mesh's again.
    let (mut again, _, _) = fit_from_rest(32, 5);
    again.set_coarse_proxy(Some(cell), 0.0).unwrap();
    assert_eq!(again.set_coarse_proxy(None, 0.0).unwrap(), (0, 0));
    again.set_blur(Schedule::COARSE_BLUR).unwrap();
    assert_eq!(again.step().unwrap(), a);
}

#[test]
fn blurs_below_the_least_blur_render_the_whole_mesh() {
    let (mut whole, _, _) = fit_from_rest(32, 5);
    let (mut proxied, _, _) = fit_from_rest(32, 5);
    let cell = 0.03 * height(&proxied);
    proxied.set_coarse_proxy(Some(cell), Schedule::COARSE_BLUR).unwrap();
    for fit in [&mut whole, &mut proxied] {
        fit.set_blur(Schedule::COARSE_BLUR / 2.0).unwrap();
    }
    assert_eq!(whole.step().unwrap(), proxied.step().unwrap());
    for fit in [&mut whole, &mut proxied] {
        fit.set_blur(Schedule::COARSE_BLUR).unwrap();
    }
    assert_ne!(whole.step().unwrap(), proxied.step().unwrap());
}

#[test]
fn bad_proxy_cells_are_errors() {
    let (mut fit_, _, _) = fit_from_rest(16, 5);
    for cell in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert!(matches!(fit_.set_coarse_proxy(Some(cell), 0.0), Err(Error::InvalidSettings(_))), "{cell}");
    }
    for min_blur in [-0.01, f32::NAN, f32::INFINITY] {
        assert!(matches!(fit_.set_coarse_proxy(Some(0.1), min_blur), Err(Error::InvalidSettings(_))), "{min_blur}");
    }
    let (model, _, targets, _) = scene(16, 5);
    let cameras = framing_cameras(&model.mesh, 4, 16);
    for coarse_proxy in [-0.1, f32::NAN] {
        let options = FitOptions { coarse_proxy, steps: 4, ..FitOptions::default() };
        let renderer = Renderer::new(RenderSettings::default()).unwrap();
        let result =
            fit(model.clone(), cameras.clone(), targets.clone(), renderer, &options, |_, _| ControlFlow::Continue(()));
        assert!(matches!(result, Err(Error::InvalidSettings(_))), "{coarse_proxy}");
    }
}

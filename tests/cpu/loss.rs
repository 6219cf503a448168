//! Tests of `diffsil::loss`: values on hand examples, gradients against finite differences.

use diffsil::loss::{
    blurred_squared_error, soft_iou, soft_iou_views, squared_error, squared_error_views, GaussianBlur, LossOutput,
};
use diffsil::{Error, Image, Result};

fn img(w: u32, h: u32, data: &[f32]) -> Image {
    Image::from_vec(w, h, data.to_vec()).unwrap()
}

/// Deterministic pseudo-random values in [0, 1].
fn values(n: usize, seed: u32) -> Vec<f32> {
    let mut s = seed.wrapping_mul(2654435761).wrapping_add(12345);
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            (s % 10_000) as f32 / 9_999.0
        })
        .collect()
}

#[test]
fn squared_error_hand_example() {
    let i = img(2, 2, &[0.0, 1.0, 0.5, 0.25]);
    let t = img(2, 2, &[1.0, 1.0, 0.0, 0.75]);
    let out = squared_error(&i, &t).unwrap();
    assert!((out.value - (1.0 + 0.0 + 0.25 + 0.25)).abs() < 1e-12);
    assert_eq!(out.grad.data(), &[-2.0, 0.0, 1.0, -1.0]);
    assert_eq!((out.grad.width(), out.grad.height()), (2, 2));
}

#[test]
fn soft_iou_hand_example() {
    // Hard masks: I = {0, 1}, T = {1, 2} (pixel indices) → IoU = 1/3.
    let i = img(3, 1, &[1.0, 1.0, 0.0]);
    let t = img(3, 1, &[0.0, 1.0, 1.0]);
    let out = soft_iou(&i, &t).unwrap();
    assert!((out.value - 2.0 / 3.0).abs() < 1e-12);
    // A = 1, U = 3: ∂L/∂I_k = −(T_k·3 − (1 − T_k)) / 9.
    let expected = [1.0 / 9.0, -3.0 / 9.0, -3.0 / 9.0];
    for (g, e) in out.grad.data().iter().zip(expected) {
        assert!((*g as f64 - e).abs() < 1e-7, "{g} vs {e}");
    }
    // Perfect match → 0; disjoint → 1.
    assert!(soft_iou(&t, &t).unwrap().value.abs() < 1e-12);
    let d = soft_iou(&img(2, 1, &[1.0, 0.0]), &img(2, 1, &[0.0, 1.0])).unwrap();
    assert!((d.value - 1.0).abs() < 1e-12);
}

/// Checks `loss`'s gradient against central differences in f64 at every pixel.
fn check_gradient(loss: fn(&Image, &Image) -> Result<LossOutput>, w: u32, h: u32, seed: u32) {
    let base = values((w * h) as usize, seed);
    let target = img(w, h, &values((w * h) as usize, seed + 99));
    let out = loss(&img(w, h, &base), &target).unwrap();
    // Step sizes exactly representable in f32 so the perturbation is exact.
    let eps = 1.0 / 1024.0;
    for k in 0..base.len() {
        let mut plus = base.clone();
        plus[k] += eps;
        let mut minus = base.clone();
        minus[k] -= eps;
        let lp = loss(&img(w, h, &plus), &target).unwrap().value;
        let lm = loss(&img(w, h, &minus), &target).unwrap().value;
        let actual_step = (plus[k] as f64 - minus[k] as f64) / 2.0;
        let fd = (lp - lm) / (2.0 * actual_step);
        let g = out.grad.data()[k] as f64;
        assert!((fd - g).abs() <= 1e-5 * (1.0 + g.abs()), "pixel {k}: analytic {g}, finite difference {fd}");
    }
}

#[test]
fn squared_error_gradient_matches_finite_differences() {
    check_gradient(squared_error, 5, 4, 1);
    check_gradient(squared_error, 1, 1, 2);
}

#[test]
fn soft_iou_gradient_matches_finite_differences() {
    check_gradient(soft_iou, 5, 4, 3);
    check_gradient(soft_iou, 3, 7, 4);
    check_gradient(soft_iou, 1, 1, 5);
}

#[test]
fn size_mismatch_is_error() {
    let i = Image::filled(4, 3, 0.5);
    let t = Image::filled(3, 4, 0.5);
    for r in [squared_error(&i, &t), soft_iou(&i, &t)] {
        match r {
            Err(Error::SizeMismatch { what, expected_width, expected_height, width, height }) => {
                assert_eq!((what, expected_width, expected_height, width, height), ("target", 4, 3, 3, 4));
            }
            other => panic!("expected SizeMismatch, got {other:?}"),
        }
    }
}

#[test]
fn soft_iou_all_zero_is_finite() {
    let z = Image::filled(4, 4, 0.0);
    let out = soft_iou(&z, &z).unwrap();
    assert_eq!(out.value, 0.0);
    assert!(out.grad.data().iter().all(|&g| g == 0.0));
    // Empty render against a non-empty target: loss 1, finite gradient pulling pixels up.
    let t = img(2, 1, &[1.0, 0.0]);
    let out = soft_iou(&Image::filled(2, 1, 0.0), &t).unwrap();
    assert_eq!(out.value, 1.0);
    assert!(out.grad.data().iter().all(|g| g.is_finite()));
    assert!(out.grad.data()[0] < 0.0);
    // A 0×0 image is fine too.
    let e = Image::filled(0, 0, 0.0);
    assert_eq!(soft_iou(&e, &e).unwrap().value, 0.0);
    assert_eq!(squared_error(&e, &e).unwrap().value, 0.0);
}

#[test]
fn non_finite_inputs_are_errors() {
    let good = Image::filled(2, 2, 0.5);
    let bad = img(2, 2, &[0.0, 0.0, f32::NAN, 0.0]);
    for r in [squared_error(&bad, &good), squared_error(&good, &bad), soft_iou(&bad, &good), soft_iou(&good, &bad)] {
        match r {
            Err(Error::InvalidSettings(msg)) => assert!(msg.contains("row 1, column 0"), "{msg}"),
            other => panic!("expected InvalidSettings, got {other:?}"),
        }
    }
    // Past the first few hundred values (the check runs in chunks): an infinity at row 21.
    let good = Image::filled(32, 32, 0.5);
    let mut data = vec![0.5; 32 * 32];
    data[21 * 32 + 7] = f32::NEG_INFINITY;
    let bad = img(32, 32, &data);
    for r in [squared_error(&bad, &good), squared_error(&good, &bad)] {
        match r {
            Err(Error::InvalidSettings(msg)) => assert!(msg.contains("row 21, column 7"), "{msg}"),
            other => panic!("expected InvalidSettings, got {other:?}"),
        }
    }
}

#[test]
fn multi_view_helpers() {
    let images = [img(2, 1, &[1.0, 0.0]), img(1, 2, &[0.5, 0.5])];
    let targets = [img(2, 1, &[1.0, 1.0]), img(1, 2, &[0.0, 1.0])];
    let (total, grads) = squared_error_views(&images, &targets).unwrap();
    let single: Vec<_> = images.iter().zip(&targets).map(|(i, t)| squared_error(i, t).unwrap()).collect();
    assert!((total - (single[0].value + single[1].value)).abs() < 1e-12);
    assert_eq!(grads.len(), 2);
    assert_eq!(grads[0], single[0].grad);
    assert_eq!(grads[1], single[1].grad);

    let (mean, grads) = soft_iou_views(&images, &targets).unwrap();
    let single: Vec<_> = images.iter().zip(&targets).map(|(i, t)| soft_iou(i, t).unwrap()).collect();
    assert!((mean - (single[0].value + single[1].value) / 2.0).abs() < 1e-12);
    for (g, s) in grads.iter().zip(&single) {
        assert_eq!((g.width(), g.height()), (s.grad.width(), s.grad.height()));
        for (a, b) in g.data().iter().zip(s.grad.data()) {
            assert!((a - b / 2.0).abs() < 1e-7);
        }
    }

    match squared_error_views(&images, &targets[..1]) {
        Err(Error::ViewCountMismatch { what, views, got }) => assert_eq!((what, views, got), ("targets", 2, 1)),
        other => panic!("expected ViewCountMismatch, got {other:?}"),
    }
    assert!(matches!(soft_iou_views(&images[..1], &targets), Err(Error::ViewCountMismatch { .. })));
    // A size mismatch in one view is reported.
    assert!(matches!(
        squared_error_views(&images, &[targets[0].clone(), targets[0].clone()]),
        Err(Error::SizeMismatch { .. })
    ));
    assert_eq!(soft_iou_views(&[], &[]).unwrap(), (0.0, vec![]));
}

#[test]
fn gaussian_blur_is_normalised_symmetric_and_self_adjoint() {
    // σ = 0 is the identity.
    let x = img(9, 7, &values(63, 11));
    assert_eq!(GaussianBlur::new(0.0).unwrap().apply(&x), x);
    let blur = GaussianBlur::new(1.5).unwrap();
    assert_eq!(blur.sigma(), 1.5);
    // A point far from the borders keeps its mass and spreads symmetrically.
    let mut point = vec![0.0f32; 21 * 21];
    point[10 * 21 + 10] = 1.0;
    let spread = blur.apply(&img(21, 21, &point));
    let mass: f64 = spread.data().iter().map(|&v| v as f64).sum();
    assert!((mass - 1.0).abs() < 1e-5, "{mass}");
    assert!((spread.get(10, 7) - spread.get(10, 13)).abs() < 1e-7);
    assert!((spread.get(7, 10) - spread.get(10, 7)).abs() < 1e-7);
    assert!(spread.get(10, 10) > spread.get(10, 11) && spread.get(10, 11) > spread.get(10, 12));
    // ⟨G x, y⟩ = ⟨x, G y⟩ (zero padding keeps the filter symmetric at the borders too).
    let y = img(9, 7, &values(63, 12));
    let dot = |a: &Image, b: &Image| a.data().iter().zip(b.data()).map(|(&p, &q)| p as f64 * q as f64).sum::<f64>();
    let (gx, gy) = (blur.apply(&x), blur.apply(&y));
    assert!((dot(&gx, &y) - dot(&x, &gy)).abs() < 1e-5, "{} vs {}", dot(&gx, &y), dot(&x, &gy));
    // Degenerate sizes and bad σ.
    assert_eq!(blur.apply(&Image::filled(0, 0, 0.0)).data().len(), 0);
    assert_eq!(blur.apply(&Image::filled(1, 1, 2.0)).data().len(), 1);
    for bad in [-1.0, f32::NAN, f32::INFINITY, 5000.0] {
        assert!(matches!(GaussianBlur::new(bad), Err(Error::InvalidSettings(_))), "σ = {bad}");
    }
}

fn blurred_by_1_3(image: &Image, target: &Image) -> Result<LossOutput> {
    let blur = GaussianBlur::new(1.3).unwrap();
    blurred_squared_error(image, &blur.apply(target), &blur)
}

#[test]
fn blurred_squared_error_gradient_matches_finite_differences() {
    let (w, h) = (6, 5);
    let base = values(w * h, 21);
    let target = img(w as u32, h as u32, &values(w * h, 22));
    let out = blurred_by_1_3(&img(w as u32, h as u32, &base), &target).unwrap();
    // The loss is quadratic in the image, so central differences are exact up to rounding:
    // a large step keeps the f32 rounding of the blurred images small against it.
    let eps = 1.0 / 16.0;
    for k in 0..base.len() {
        let (mut plus, mut minus) = (base.clone(), base.clone());
        plus[k] += eps;
        minus[k] -= eps;
        let lp = blurred_by_1_3(&img(w as u32, h as u32, &plus), &target).unwrap().value;
        let lm = blurred_by_1_3(&img(w as u32, h as u32, &minus), &target).unwrap().value;
        let fd = (lp - lm) / (2.0 * eps as f64);
        let g = out.grad.data()[k] as f64;
        assert!((fd - g).abs() <= 1e-4 * (1.0 + g.abs()), "pixel {k}: analytic {g}, finite difference {fd}");
    }
    // No blur: the plain squared error.
    let i = img(w as u32, h as u32, &base);
    assert_eq!(
        blurred_squared_error(&i, &target, &GaussianBlur::identity()).unwrap(),
        squared_error(&i, &target).unwrap()
    );
    // Sizes must match.
    assert!(matches!(
        blurred_squared_error(&Image::filled(3, 2, 0.0), &Image::filled(2, 3, 0.0), &GaussianBlur::identity()),
        Err(Error::SizeMismatch { .. })
    ));
}

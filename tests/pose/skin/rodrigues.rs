//! Rodrigues' formula and its derivative against glam and finite differences.

use super::*;

fn rodrigues_samples() -> Vec<DVec3> {
    let mut rng = SplitMix64::new(7);
    let mut samples = vec![DVec3::ZERO];
    for angle in [
        1e-20,
        1e-12,
        1e-8,
        1e-5,
        1e-3,
        0.02,
        0.0499999,
        0.05,
        0.0500001,
        0.3,
        1.0,
        3.0,
        std::f64::consts::PI,
        6.0,
        10.0,
    ] {
        samples.push(rng.unit_dvec3() * angle);
    }
    for _ in 0..100 {
        samples.push(rng.unit_dvec3() * rng.range_f64(0.0, 7.0));
    }
    samples
}

#[test]
fn rodrigues_is_orthonormal() {
    for v in rodrigues_samples() {
        let r = rodrigues(v.as_vec3());
        assert!(r.is_finite(), "{v}");
        let rtr = (r.transpose() * r).as_dmat3();
        assert!(max_abs3(&rtr, &DMat3::IDENTITY) < 1e-6, "RᵀR at {v}: {rtr}");
        assert!((r.determinant() - 1.0).abs() < 1e-6, "det at {v}");
        let r64 = rodrigues_f64(v);
        assert!(max_abs3(&(r64.transpose() * r64), &DMat3::IDENTITY) < 1e-14, "f64 RᵀR at {v}");
        assert!((r64.determinant() - 1.0).abs() < 1e-14, "f64 det at {v}");
    }
    assert_eq!(rodrigues(Vec3::ZERO), Mat3::IDENTITY);
    assert_eq!(rodrigues_f64(DVec3::ZERO), DMat3::IDENTITY);
}

#[test]
fn rodrigues_matches_glam() {
    for v in rodrigues_samples() {
        let t = v.length();
        if t == 0.0 {
            continue;
        }
        let ours = rodrigues(v.as_vec3()).as_dmat3();
        let glam32 = Mat3::from_axis_angle((v / t).as_vec3(), t as f32).as_dmat3();
        assert!(max_abs3(&ours, &glam32) < 2e-6, "f32 at {v}: {ours} vs {glam32}");
        let glam64 = DMat3::from_axis_angle(v / t, t);
        assert!(max_abs3(&rodrigues_f64(v), &glam64) < 1e-13, "f64 at {v}");
    }
    // And the direction: a quarter turn about z takes x to y.
    let r = rodrigues(Vec3::new(0.0, 0.0, std::f32::consts::FRAC_PI_2));
    assert!((r * Vec3::X - Vec3::Y).length() < 1e-6);
}

#[test]
fn rodrigues_derivative_matches_finite_differences() {
    let h = 1e-6;
    for v in rodrigues_samples() {
        let analytic = rodrigues_derivative_f64(v);
        for (k, axis) in [DVec3::X, DVec3::Y, DVec3::Z].into_iter().enumerate() {
            let fd = (rodrigues_f64(v + axis * h) - rodrigues_f64(v - axis * h)) * (0.5 / h);
            let err = max_abs3(&analytic[k], &fd);
            assert!(err < 1e-8, "∂R/∂θ_{k} at {v} (|θ| = {}): error {err}\n{}\nvs\n{fd}", v.length(), analytic[k]);
        }
        let d32 = rodrigues_derivative(v.as_vec3());
        for k in 0..3 {
            assert!(d32[k].is_finite());
            assert!(max_abs3(&d32[k].as_dmat3(), &analytic[k]) < 1e-6);
        }
    }
}

#[test]
fn rodrigues_derivative_at_zero_is_the_generators() {
    let generators = [DVec3::X, DVec3::Y, DVec3::Z].map(skew);
    assert_eq!(rodrigues_derivative_f64(DVec3::ZERO), generators);
    assert_eq!(rodrigues_derivative(Vec3::ZERO), generators.map(|m| m.as_mat3()));
    // Continuous across the switch from the series to the closed form.
    let dir = DVec3::new(0.3, -0.5, 0.8).normalize();
    let below = rodrigues_derivative_f64(dir * (0.05 - 1e-12));
    let above = rodrigues_derivative_f64(dir * (0.05 + 1e-12));
    for k in 0..3 {
        assert!(max_abs3(&below[k], &above[k]) < 1e-11, "jump at the series threshold");
    }
}

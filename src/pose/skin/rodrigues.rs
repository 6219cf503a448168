//! Rodrigues' formula: the rotation matrix of an axis–angle vector and its derivatives, smooth
//! through zero.

use glam::{DMat3, DVec3, Mat3, Vec3};

/// The skew-symmetric (cross-product) matrix of `v`: `skew(v)·x = v × x`.
fn skew(v: DVec3) -> DMat3 {
    DMat3::from_cols(DVec3::new(0.0, v.z, -v.y), DVec3::new(-v.z, 0.0, v.x), DVec3::new(v.y, -v.x, 0.0))
}

/// Below this angle the Rodrigues coefficients come from their Taylor series (the closed forms
/// cancel catastrophically near zero).
const SERIES_BELOW: f64 = 0.05;

/// Coefficients of `R = I + a·K + b·K²` (`K = skew(θ)`, `t = |θ|`): `a = sin t / t`,
/// `b = (1 − cos t)/t²`, and their derivatives divided by `t`: `a' = (da/dt)/t`, `b' = (db/dt)/t`.
fn rodrigues_coefficients(t2: f64) -> (f64, f64, f64, f64) {
    let t = t2.sqrt();
    if t < SERIES_BELOW {
        let t4 = t2 * t2;
        let t6 = t4 * t2;
        let a = 1.0 - t2 / 6.0 + t4 / 120.0 - t6 / 5040.0;
        let b = 0.5 - t2 / 24.0 + t4 / 720.0 - t6 / 40320.0;
        let da = -1.0 / 3.0 + t2 / 30.0 - t4 / 840.0 + t6 / 45360.0;
        let db = -1.0 / 12.0 + t2 / 180.0 - t4 / 6720.0 + t6 / 453600.0;
        (a, b, da, db)
    } else {
        let (s, c) = t.sin_cos();
        let a = s / t;
        let b = (1.0 - c) / t2;
        let da = (t * c - s) / (t2 * t);
        let db = (t * s - 2.0 * (1.0 - c)) / (t2 * t2);
        (a, b, da, db)
    }
}

/// Rodrigues' formula in f64: the rotation by `|θ|` radians about `θ/|θ|` (right-handed, as glam's
/// `from_axis_angle`), `R = I + sin t/t · K + (1 − cos t)/t² · K²` with `K = skew(θ)`. Exact at 0.
pub fn rodrigues_f64(axis_angle: DVec3) -> DMat3 {
    let (a, b, _, _) = rodrigues_coefficients(axis_angle.length_squared());
    let k = skew(axis_angle);
    DMat3::IDENTITY + k * a + (k * k) * b
}

/// The partial derivatives `∂R/∂θ_x, ∂R/∂θ_y, ∂R/∂θ_z` of [`rodrigues_f64`]. Smooth through zero,
/// where they are the generators `skew(e_x), skew(e_y), skew(e_z)`.
///
/// `∂R/∂θ_k = a·E_k + b·(E_k·K + K·E_k) + θ_k·(a'·K + b'·K²)` with `E_k = skew(e_k)`.
pub fn rodrigues_derivative_f64(axis_angle: DVec3) -> [DMat3; 3] {
    let (a, b, da, db) = rodrigues_coefficients(axis_angle.length_squared());
    let k = skew(axis_angle);
    let k2 = k * k;
    let theta = axis_angle.to_array();
    let generators = [DVec3::X, DVec3::Y, DVec3::Z].map(skew);
    std::array::from_fn(|i| {
        let e = generators[i];
        e * a + (e * k + k * e) * b + (k * da + k2 * db) * theta[i]
    })
}

/// Rodrigues' formula: the rotation matrix of an axis–angle vector (angle = its length, radians).
/// Computed in f64; exact (the identity) at zero and accurate for tiny angles.
pub fn rodrigues(axis_angle: Vec3) -> Mat3 {
    rodrigues_f64(axis_angle.as_dvec3()).as_mat3()
}

/// The partial derivatives `[∂R/∂θ_x, ∂R/∂θ_y, ∂R/∂θ_z]` of [`rodrigues`]; no NaN anywhere, and
/// at zero they are the skew-symmetric generators.
pub fn rodrigues_derivative(axis_angle: Vec3) -> [Mat3; 3] {
    rodrigues_derivative_f64(axis_angle.as_dvec3()).map(|m| m.as_mat3())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_and_closed_form_coefficients_agree_near_the_switch() {
        for t in [0.01, 0.03, 0.049, 0.051, 0.07, 0.1] {
            let t2: f64 = t * t;
            let (s, c) = t.sin_cos();
            let closed = [s / t, (1.0 - c) / t2, (t * c - s) / (t2 * t), (t * s - 2.0 * (1.0 - c)) / (t2 * t2)];
            let k = t2 * t2 * t2 * t2; // size of the first omitted series term
            let series = {
                let (t4, t6) = (t2 * t2, t2 * t2 * t2);
                [
                    1.0 - t2 / 6.0 + t4 / 120.0 - t6 / 5040.0,
                    0.5 - t2 / 24.0 + t4 / 720.0 - t6 / 40320.0,
                    -1.0 / 3.0 + t2 / 30.0 - t4 / 840.0 + t6 / 45360.0,
                    -1.0 / 12.0 + t2 / 180.0 - t4 / 6720.0 + t6 / 453600.0,
                ]
            };
            let ours = rodrigues_coefficients(t2);
            let ours = [ours.0, ours.1, ours.2, ours.3];
            for i in 0..4 {
                // Closed forms lose about eps/t⁴ to cancellation; the series omits O(t⁸).
                let tol = 1e-16 / (t2 * t2) + k;
                assert!((series[i] - closed[i]).abs() < tol, "coefficient {i} at t = {t}");
                assert!((ours[i] - closed[i]).abs() < tol, "coefficient {i} at t = {t}");
            }
        }
    }
}

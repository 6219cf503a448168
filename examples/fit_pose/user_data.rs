//! The user's own data: calibrated cameras from a JSON file (OpenCV model) and one PNG mask per
//! camera, checked against each other, and how well a silhouette agrees with its mask.
//!
//! `cameras.json` is a list with one object per camera, in the order of the masks:
//!
//! ```text
//! [{"width": 640, "height": 480,
//!   "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],
//!   "R": [[r00, r01, r02], [r10, r11, r12], [r20, r21, r22]],
//!   "t": [tx, ty, tz],
//!   "near": 0.01, "far": 1000}, ...]
//! ```
//!
//! `K`, `R` (world → camera rotation, rows) and `t` as OpenCV's `calibrateCamera`/`solvePnP` give
//! them (pixel centres at integer coordinates; camera x right, y down, z forward), passed to
//! `diffsil::Camera::from_opencv`; `near` and `far` are optional (default 0.01 and 1000, in the
//! units of `t`). Lens distortion is not modelled: coefficients under `dist`, `distCoeffs`,
//! `dist_coeffs`, `D` or `distortion` must be zeros (undistort the masks first, e.g. with
//! OpenCV's `undistort`, and give the `K` they were undistorted to).

use std::path::{Path, PathBuf};

use diffsil::io::{load_png_target, TargetMode};
use diffsil::{Camera, Image};
use serde_json::Value;

/// Names calibration files give lens distortion coefficients under: accepted when all zero,
/// otherwise an error that says to undistort the masks first.
const DISTORTION_KEYS: [&str; 5] = ["dist", "distCoeffs", "dist_coeffs", "D", "distortion"];

/// Three numbers from `value` (a list of 3), if it is one.
fn vector3(value: &Value) -> Option<[f32; 3]> {
    let row = value.as_array().filter(|r| r.len() == 3)?;
    let mut out = [0.0; 3];
    for (x, out_x) in row.iter().zip(&mut out) {
        *out_x = x.as_f64()? as f32;
    }
    Some(out)
}

/// A 3 × 3 matrix (a list of 3 rows of 3 numbers) from `value`; `what` names it in errors.
fn matrix(value: Option<&Value>, what: &str) -> Result<[[f32; 3]; 3], String> {
    let value = value.ok_or_else(|| format!("missing \"{what}\""))?;
    let rows = value.as_array().filter(|r| r.len() == 3);
    match rows.map(|r| [vector3(&r[0]), vector3(&r[1]), vector3(&r[2])]) {
        Some([Some(a), Some(b), Some(c)]) => Ok([a, b, c]),
        _ => Err(format!("\"{what}\" must be 3 rows of 3 numbers, got {value}")),
    }
}

/// A positive pixel count from `value`.
fn pixels(value: Option<&Value>, what: &str) -> Result<u32, String> {
    let value = value.ok_or_else(|| format!("missing \"{what}\""))?;
    value
        .as_u64()
        .and_then(|v| u32::try_from(v).ok())
        .filter(|v| *v > 0)
        .ok_or_else(|| format!("\"{what}\" must be a positive whole number of pixels, got {value}"))
}

/// One camera of the list.
fn camera(value: &Value) -> Result<Camera, String> {
    let object = value.as_object().ok_or_else(|| format!("each camera must be an object, got {value}"))?;
    for (key, value) in object {
        if DISTORTION_KEYS.contains(&key.as_str()) {
            // Zero coefficients are no distortion; others would move the mask's pixels.
            let zeros = value.as_array().is_some_and(|v| v.iter().all(|x| x.as_f64() == Some(0.0)));
            if zeros {
                continue;
            }
            return Err(format!(
                "lens distortion (\"{key}\": {value}) is not modelled: undistort the masks first (e.g. OpenCV's \
                 undistort) and give the K they were undistorted to"
            ));
        }
        if !["width", "height", "K", "R", "t", "near", "far"].contains(&key.as_str()) {
            return Err(format!("unknown key \"{key}\" (keys: width, height, K, R, t, near, far)"));
        }
    }
    let (width, height) = (pixels(object.get("width"), "width")?, pixels(object.get("height"), "height")?);
    let k = matrix(object.get("K"), "K")?;
    let r = matrix(object.get("R"), "R")?;
    let t = object.get("t").ok_or("missing \"t\"")?;
    let t = vector3(t).ok_or_else(|| format!("\"t\" must be 3 numbers, got {t}"))?;
    let mut camera = Camera::from_opencv(k, r, t, width, height).map_err(|e| e.to_string())?;
    for (key, field) in [("near", &mut camera.near), ("far", &mut camera.far)] {
        if let Some(value) = object.get(key) {
            *field = value.as_f64().ok_or_else(|| format!("\"{key}\" must be a number, got {value}"))? as f32;
        }
    }
    camera.validate().map_err(|e| e.to_string())?;
    Ok(camera)
}

/// The cameras of the JSON file at `path`; errors name the file and the camera.
pub fn load_cameras(path: &Path) -> Result<Vec<Camera>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let json: Value = serde_json::from_str(&text).map_err(|e| format!("{}: not valid JSON: {e}", path.display()))?;
    let list = json.as_array().ok_or_else(|| {
        format!(
            "{}: expected a JSON list of cameras [{{\"width\", \"height\", \"K\", \"R\", \"t\"}}, ...]",
            path.display()
        )
    })?;
    if list.is_empty() {
        return Err(format!("{}: the list of cameras is empty", path.display()));
    }
    list.iter()
        .enumerate()
        .map(|(i, value)| camera(value).map_err(|e| format!("{}: camera {i}: {e}", path.display())))
        .collect()
}

/// `cameras` as the JSON `load_cameras` reads (`K` in OpenCV's pixel convention, `R` and `t`
/// world → camera in OpenCV's axes, `near`, `far`); errors for an orthographic camera, which
/// that format cannot hold.
pub fn cameras_json(cameras: &[Camera]) -> Result<String, String> {
    let list = cameras
        .iter()
        .enumerate()
        .map(|(k, camera)| {
            if matches!(camera.projection, diffsil::Projection::Orthographic { .. }) {
                return Err(format!("camera {k} is orthographic: cameras.json holds pinhole cameras only"));
            }
            let [fx, fy, cx, cy] = camera.intrinsics();
            let e = camera.opencv_extrinsics();
            let r = e.rotation.transpose().to_cols_array_2d();
            Ok(serde_json::json!({
                "width": camera.width, "height": camera.height,
                "K": [[fx, 0.0, cx - 0.5], [0.0, fy, cy - 0.5], [0.0, 0.0, 1.0]],
                "R": r, "t": e.translation.to_array(),
                "near": camera.near, "far": camera.far,
            }))
        })
        .collect::<Result<Vec<_>, String>>()?;
    serde_json::to_string_pretty(&list).map_err(|e| e.to_string())
}

/// The masks at `paths`, one per camera and of its size; `threshold` hardens them (see
/// `TargetMode`), otherwise a pixel's value in [0, 1] is its coverage. Masks that are all empty
/// (no subject in any view) are refused: a fit would only move the body out of sight; so are
/// masks that are all covered (no outline in any view: nothing to fit either).
pub fn load_targets(paths: &[PathBuf], cameras: &[Camera], threshold: Option<f32>) -> Result<Vec<Image>, String> {
    if paths.len() != cameras.len() {
        return Err(format!(
            "{} masks for {} cameras: --targets needs one mask per camera of --cameras, in the same order",
            paths.len(),
            cameras.len()
        ));
    }
    let mode = threshold.map_or(TargetMode::Coverage, TargetMode::Threshold);
    paths
        .iter()
        .zip(cameras)
        .enumerate()
        .map(|(i, (path, camera))| {
            let image = load_png_target(path, mode).map_err(|e| format!("{}: {e}", path.display()))?;
            if (image.width(), image.height()) != (camera.width, camera.height) {
                return Err(format!(
                    "{}: the mask is {}×{} but camera {i} renders {}×{} (width × height)",
                    path.display(),
                    image.width(),
                    image.height(),
                    camera.width,
                    camera.height
                ));
            }
            Ok(image)
        })
        .collect::<Result<Vec<_>, String>>()
        .and_then(|masks| {
            if masks.iter().all(|m| m.data().iter().all(|v| *v == 0.0)) {
                let below = threshold.map_or(String::new(), |t| format!(" once hardened at --threshold {t}"));
                return Err(format!(
                    "every mask is empty{below}: no view shows the subject, so there is nothing to fit (the \
                     subject must be the bright pixels)"
                ));
            }
            if masks.iter().all(|m| m.data().iter().all(|v| *v == 1.0)) {
                let below = threshold.map_or(String::new(), |t| format!(" once hardened at --threshold {t}"));
                return Err(format!(
                    "every mask is covered everywhere{below}: no view shows an outline of the subject, so there \
                     is nothing to fit (are the masks inverted? The subject must be the bright pixels)"
                ));
            }
            Ok(masks)
        })
}

/// Whether more than half of `mask`'s border pixels are covered (above 0.5): a subject seldom
/// touches most of the image's edge, a mask drawn the wrong way round (the subject dark on a
/// bright background) does.
pub fn looks_inverted(mask: &Image) -> bool {
    let (w, h) = (mask.width(), mask.height());
    let border =
        (0..h).flat_map(|i| (0..w).map(move |j| (i, j))).filter(|&(i, j)| i == 0 || j == 0 || i + 1 == h || j + 1 == w);
    let (mut covered, mut all) = (0usize, 0usize);
    for (i, j) in border {
        covered += usize::from(mask.get(i, j) > 0.5);
        all += 1;
    }
    2 * covered > all
}

/// The mean IoU of per-view [`agreement`]s (0 for none).
pub fn mean_iou(agreements: &[(f64, f64)]) -> f64 {
    agreements.iter().map(|a| a.0).sum::<f64>() / agreements.len().max(1) as f64
}

/// How a rendered silhouette agrees with its target: the IoU of the two masks thresholded at
/// 0.5 (1 when both are empty) and the mean squared difference over the pixels (E_sl of one
/// view, unblurred).
pub fn agreement(rendered: &Image, target: &Image) -> (f64, f64) {
    let (mut both, mut either, mut squared) = (0usize, 0usize, 0.0f64);
    for (r, t) in rendered.data().iter().zip(target.data()) {
        let (a, b) = (*r > 0.5, *t > 0.5);
        both += usize::from(a && b);
        either += usize::from(a || b);
        squared += f64::from(r - t).powi(2);
    }
    let iou = if either == 0 { 1.0 } else { both as f64 / either as f64 };
    (iou, squared / target.data().len().max(1) as f64)
}

//! The fit to the user's own masks and cameras (`--targets`, `--cameras`): from the model's rest
//! pose placed where the masks put the body (turned by `--facing DEG`, or tried at four facings), at a resolution where the subject is about `--fit-height` pixels tall (masks and cameras
//! downsampled together), with no ground truth, reported as each view's silhouette IoU and energy
//! before and after at the masks' own resolution; and the writer of a fit's result (`--save`).

use std::path::Path;

use diffsil::pose::fit::{cameras_up, subject_height, triangulate_masks, turned_about_vertical, PoseFit};
use diffsil::pose::skin::{Pose, SkinnedMesh};
use diffsil::{Camera, Image, Mesh, RenderSettings, Renderer, Vec3};

use super::options::{Facing, Up};
use super::{at_fit_height, fit_with_progress, sheet, user_data, Options};

/// Writes the fitted posed mesh (`fitted.glb`, `fitted.obj`) and pose and shape
/// (`fitted_pose.json`) to `out`.
pub fn save_fit(model: &SkinnedMesh, fit: &PoseFit, out: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let posed = model.posed_mesh_shaped(&fit.pose(), fit.shape())?;
    diffsil::io::gltf::save_mesh_glb(&posed, out.join("fitted.glb"))?;
    diffsil::io::save_obj(out.join("fitted.obj"), &posed)?;
    std::fs::write(out.join("fitted_pose.json"), fit.pose().to_json(fit.shape()))?;
    println!("wrote fitted.glb, fitted.obj and fitted_pose.json to {}", out.display());
    Ok(())
}

/// What a fit to the user's masks measured: per view, the silhouette IoU and energy
/// ([`user_data::agreement`]) at the start (the rest pose, placed) and at the end, at the masks' own
/// resolution.
pub struct DataOutcome {
    /// The factor the masks and cameras were downsampled by for the fit (`--fit-height`).
    pub factor: u32,
    /// Width and height of the first view's images in the fit.
    pub fit_size: (u32, u32),
    /// How tall the masks' subject looks where they place it, over the model's height (the
    /// placement's units check; `None` with `--no-placement` or when no point is found).
    pub height_ratio: Option<f32>,
    /// Per view (IoU, E_sl) of the start (the rest pose, placed and turned).
    pub before: Vec<(f64, f64)>,
    /// Per view (IoU, E_sl) of the fitted pose.
    pub after: Vec<(f64, f64)>,
    /// The facing the fit kept, in degrees from the model's front (`--facing auto`'s choice,
    /// else 0: a given `--facing` turns the start instead).
    pub facing: f32,
    /// The fit's final energy E (unblurred, all terms, [`PoseFit::energy`]).
    pub energy: f64,
    /// Adam steps taken.
    pub steps: u32,
    /// Wall-clock seconds of the fit.
    pub seconds: f64,
}

/// `rest` moved (its root translation) to where the masks place the body: where the rays through
/// the masks' centres of coverage meet ([`triangulate_masks`]), corrected once so that the
/// model's own silhouettes there triangulate to the same point (a silhouette's centre is not the
/// body's centre, and the bias is about the same for the model as for the subject); printed,
/// with a warning where the masks' subject looks more than twice as tall or as short as the model
/// there (cameras in other units than the model's), and that height over the model's (`None`
/// without a perspective view of the subject). `rest` itself when the point is not determined.
fn placed_start(
    model: &SkinnedMesh,
    renderer: &mut Renderer,
    cameras: &[Camera],
    masks: &[Image],
    rest: Pose,
) -> Result<(Pose, Option<f32>), Box<dyn std::error::Error>> {
    let Some(point) = triangulate_masks(cameras, masks)? else {
        println!("placement: the masks' centres do not fix a point (fewer than two views see the subject); starting at the rest pose");
        return Ok((rest, None));
    };
    let (lo, hi) = bounds(&model.skin(&rest)?);
    let centre = (lo + hi) * 0.5;
    let mut start = Pose { translation: rest.translation + (point - centre), ..rest.clone() };
    let there = Mesh::with_topology(model.skin(&start)?, model.mesh.topology().clone())?;
    if let Some(seen) = triangulate_masks(cameras, renderer.render(&there, cameras)?.images())? {
        start.translation += point - seen;
    }
    println!(
        "placement: the model moved by {:.3} from its rest position, to where the masks' centres meet ({point:.3})",
        start.translation - rest.translation
    );
    // The subject's height in world units as each perspective view sees it at that depth.
    let mut heights: Vec<f32> = cameras
        .iter()
        .zip(masks)
        .filter_map(|(camera, mask)| {
            let p = camera.params();
            let depth = -(glam::Vec4::from(p.row2).dot(point.extend(1.0)));
            (p.perspective == 1 && depth > 0.0 && subject_height(mask) > 0)
                .then(|| subject_height(mask) as f32 * depth / p.scale[1])
        })
        .collect();
    heights.sort_by(f32::total_cmp);
    let model_height = (hi - lo).max_element();
    let seen = heights.get(heights.len() / 2).copied();
    if let Some(seen) = seen.filter(|seen| !(0.5..=2.0).contains(&(seen / model_height))) {
        println!(
            "warning: the masks' subject looks about {seen:.3} tall where the model is {model_height:.3}: are the \
             cameras' t in the model's units?"
        );
    }
    Ok((start, seen.map(|seen| seen / model_height)))
}

/// The world's up for `--up` (`Up::Auto`: the cameras' mean up, snapped to the nearest axis
/// within 30°; +y without a common up), printed where it is not +y.
fn world_up(cameras: &[Camera], up: Up) -> Vec3 {
    match up {
        Up::Axis(axis) => axis,
        Up::Auto => {
            let Some(mean) = cameras_up(cameras) else {
                println!("up: the cameras have no common up; the model stays upright along +y");
                return Vec3::Y;
            };
            let axes = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];
            let nearest = axes.into_iter().max_by(|a, b| a.dot(mean).total_cmp(&b.dot(mean))).unwrap_or(Vec3::Y);
            let snapped = if nearest.dot(mean) >= 30f32.to_radians().cos() { nearest } else { mean };
            if snapped != Vec3::Y {
                println!("up: the cameras' mean up is {mean:.3}; the model is stood along {snapped:.3}");
            }
            snapped
        }
    }
}

/// The rest pose of `model` (upright along +y) stood along `up`: its global orientation the
/// shortest turn from +y to `up`; for `up` −y, the half turn about +x (y and z flipped, as from
/// a world with y up to one with y down such as an OpenCV camera's frame).
fn upright(model: &SkinnedMesh, up: Vec3) -> Pose {
    let mut rest = Pose::rest(model.joint_count());
    let up = up.normalize();
    if up.dot(Vec3::Y) < -0.9999 {
        rest.orientation = Vec3::new(std::f32::consts::PI, 0.0, 0.0);
    } else if up != Vec3::Y {
        rest.orientation = glam::Quat::from_rotation_arc(Vec3::Y, up).to_scaled_axis();
    }
    rest
}

/// The bounding box of `points`.
fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    points.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
}

/// Fits `model` to the user's `--targets` seen by `--cameras`; writes the pictures and, with
/// `--save`, the fitted mesh and pose to `--out`.
pub fn fit_user_data(model: &SkinnedMesh, o: &Options) -> Result<DataOutcome, Box<dyn std::error::Error>> {
    let path = o.cameras.as_ref().ok_or("--targets needs --cameras")?;
    let cameras = user_data::load_cameras(path)?;
    let targets = user_data::load_targets(&o.targets, &cameras, o.threshold)?;
    if o.shape && model.shape_count() == 0 {
        return Err("--shape needs a model with morph targets".into());
    }
    let settings = RenderSettings { supersample: o.supersample, ..RenderSettings::default() };
    let mut renderer = Renderer::with_backend(settings, o.backend.backend())?;
    // The fit runs where the subject is about `--fit-height` pixels tall; the report and the
    // pictures are at the masks' own resolution.
    let (factor, fit_cameras, fit_targets) = at_fit_height(&cameras, &targets, o.fit_height)?;
    let tallest = fit_targets.iter().map(subject_height).max().unwrap_or(0);
    let (w, h) = (fit_cameras[0].width, fit_cameras[0].height);
    println!("fitting at {w}x{h} (the masks downsampled {factor}x; the subject {tallest} pixels tall at most)");
    let up = world_up(&cameras, o.up);
    let rest = upright(model, up);
    // The fit starts with the model moved to where the masks' centres of coverage meet.
    let (start, height_ratio) =
        if o.no_placement { (rest, None) } else { placed_start(model, &mut renderer, &cameras, &targets, rest)? };
    let start = match o.facing {
        Facing::Degrees(degrees) => turned_about_vertical(model, &start, degrees.to_radians())?,
        Facing::Auto => start,
    };
    let start_mesh = Mesh::with_topology(model.skin(&start)?, model.mesh.topology().clone())?;
    let before = renderer.render(&start_mesh, &cameras)?.images().to_vec();
    let fit_renderer = Renderer::with_backend(settings, o.backend.backend())?;
    let o = &Options { initial: Some(start), ..o.clone() };
    let (fitted, seconds) =
        fit_with_progress(model, o, (fit_cameras, fit_targets, fit_renderer), false, |_, progress, _| {
            Some(format!("blur {:.3}  E_sl {:.2e}", progress.blur, progress.report.silhouette))
        })?;
    let facing = fitted.facing.to_degrees();
    if o.facing == Facing::Auto {
        println!("facing: {facing:.0}° from the model's front fitted best after the starting poses' steps");
    }
    let (mut fit, run) = (fitted.fit, fitted.report);
    let (fitted_inflation, fitted_outline) = (fit.inflation(), fit.outline());
    println!("stopped: {:?} after {} steps", run.stop, run.steps);
    println!("nuisances: inflation d = {fitted_inflation:.4} (model units), outline a = {fitted_outline:.3}");
    let posed = model.posed_mesh_shaped(&fit.pose(), fit.shape())?;
    let after = renderer.render(&posed, &cameras)?.images().to_vec();
    let mut outcome = DataOutcome {
        factor,
        fit_size: (w, h),
        height_ratio,
        before: Vec::new(),
        after: Vec::new(),
        facing,
        energy: fit.energy()?,
        steps: run.steps,
        seconds,
    };
    for (view, target) in targets.iter().enumerate() {
        outcome.before.push(user_data::agreement(&before[view], target));
        outcome.after.push(user_data::agreement(&after[view], target));
        let ((iou0, e0), (iou1, e1)) = (outcome.before[view], outcome.after[view]);
        println!("view {view} ({}): IoU {iou0:.3} -> {iou1:.3}, E_sl {e0:.2e} -> {e1:.2e}", o.targets[view].display());
    }
    sheet::save_comparison_sheets(&o.out, &targets, &before, &after)?;
    if o.save {
        save_fit(model, &fit, &o.out)?;
    }
    Ok(outcome)
}

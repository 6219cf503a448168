//! The fit to the user's own masks and cameras (`--targets`, `--cameras`): from the model's rest
//! pose stood along the cameras' up and placed where the masks put the body
//! (`diffsil::pose::fit::start_from_masks`), turned by `--facing DEG` or tried at four facings,
//! at a resolution where the subject is about `--fit-height` pixels tall (masks and cameras
//! downsampled together), with no ground truth, reported as each view's silhouette IoU and
//! energy before and after at the masks' own resolution; and the writer of a fit's result
//! (`--save`).

use std::path::Path;

use diffsil::pose::fit::{
    cameras_up, per_vertex_error, start_from_masks, subject_height, turned_about_vertical, upright, world_up,
    MaskStart, PoseFit,
};
use diffsil::pose::skin::{Pose, SkinnedMesh};
use diffsil::{Camera, Image, Mesh, Renderer, Vec3};

use super::options::{Facing, Up};
use super::{at_fit_height, fit_with_progress, renderer_for, sheet, user_data, Options};

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
    /// The fitted nuisances: the surface offset `d` (model units, `--inflation`) and the outline
    /// `a` (`--outline`); 0 where not fitted.
    pub nuisances: (f32, f32),
    /// The fit's final energy E (unblurred, all terms, [`PoseFit::energy`]).
    pub energy: f64,
    /// The per-vertex error against `--truth`, in the model's units; `None` without it.
    pub error_m: Option<f64>,
    /// Adam steps taken.
    pub steps: u32,
    /// Wall-clock seconds of the fit.
    pub seconds: f64,
}

/// The start of the fit ([`start_from_masks`], or with `--no-placement` the rest pose stood along
/// the up where the model was built), printed, with a warning where the masks' subject looks
/// more than twice as tall or as short as the model (cameras in other units than the model's).
fn start(
    model: &SkinnedMesh,
    renderer: &mut Renderer,
    cameras: &[Camera],
    masks: &[Image],
    o: &Options,
) -> Result<MaskStart, Box<dyn std::error::Error>> {
    let up = match o.up {
        Up::Auto => None,
        Up::Axis(axis) => Some(axis),
    };
    let start = if o.no_placement {
        let up = up.unwrap_or_else(|| world_up(cameras));
        MaskStart { pose: upright(model.joint_count(), up)?, up, point: None, height_ratio: None }
    } else {
        start_from_masks(model, cameras, masks, renderer, up)?
    };
    if o.up == Up::Auto && start.up != Vec3::Y {
        let mean = cameras_up(cameras).unwrap_or(Vec3::Y);
        println!("up: the cameras' mean up is {mean:.3}; the model is stood along {:.3}", start.up);
    }
    match start.point {
        Some(point) => println!(
            "placement: the model moved by {:.3} from its rest position, to where the masks' centres meet ({point:.3})",
            start.pose.translation
        ),
        None if !o.no_placement => println!(
            "placement: the masks' centres do not fix a point (fewer than two views see the subject); starting at the rest pose"
        ),
        None => {}
    }
    if let Some(ratio) = start.height_ratio.filter(|r| !(0.5..=2.0).contains(r)) {
        println!(
            "warning: the masks' subject looks about {ratio:.3} times as tall as the model: are the cameras' t in the \
             model's units?"
        );
    }
    Ok(start)
}

/// The per-vertex error of `fit` against the ground truth in the pose and shape JSON at `path`.
fn truth_error(model: &SkinnedMesh, fit: &PoseFit, path: &Path) -> Result<f64, Box<dyn std::error::Error>> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("--truth {}: {e}", path.display()))?;
    let (pose, shape) = Pose::from_json(&text).map_err(|e| format!("--truth {}: {e}", path.display()))?;
    let truth = model.skin_shaped(&pose, &shape).map_err(|e| format!("--truth {}: {e}", path.display()))?;
    Ok(per_vertex_error(&fit.vertices()?, &truth))
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
    let mut renderer = renderer_for(o)?;
    // The fit runs where the subject is about `--fit-height` pixels tall; the report and the
    // pictures are at the masks' own resolution.
    let (factor, fit_cameras, fit_targets) = at_fit_height(&cameras, &targets, o.fit_height)?;
    let tallest = fit_targets.iter().map(subject_height).max().unwrap_or(0);
    let (w, h) = (fit_cameras[0].width, fit_cameras[0].height);
    println!("fitting at {w}x{h} (the masks downsampled {factor}x; the subject {tallest} pixels tall at most)");
    let start = start(model, &mut renderer, &cameras, &targets, o)?;
    let height_ratio = start.height_ratio;
    let start = start.pose;
    let start = match o.facing() {
        Facing::Degrees(degrees) => turned_about_vertical(model, &start, degrees.to_radians())?,
        Facing::Auto => start,
    };
    let start_mesh = Mesh::with_topology(model.skin(&start)?, model.mesh.topology().clone())?;
    let before = renderer.render(&start_mesh, &cameras)?.images().to_vec();
    let fit_renderer = renderer_for(o)?;
    let o = &Options { initial: Some(start), ..o.clone() };
    let (fitted, seconds) =
        fit_with_progress(model, o, (fit_cameras, fit_targets, fit_renderer), false, |_, progress, _| {
            Some(format!("blur {:.3}  E_sl {:.2e}", progress.blur, progress.report.silhouette))
        })?;
    let facing = fitted.facing.to_degrees();
    if o.facing() == Facing::Auto {
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
        nuisances: (fitted_inflation, fitted_outline),
        energy: fit.energy()?,
        error_m: match &o.truth_file {
            Some(path) => Some(truth_error(model, &fit, path)?),
            None => None,
        },
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

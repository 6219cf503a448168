//! The fit to the user's own masks and cameras (`--targets`, `--cameras`): from the model's rest
//! pose, at a resolution where the subject is about `--fit-height` pixels tall (masks and cameras
//! downsampled together), with no ground truth, reported as each view's silhouette IoU and energy
//! before and after at the masks' own resolution; and the writer of a fit's result (`--save`).

use std::path::Path;

use diffsil::pose::fit::{downsample_factor, subject_height, PoseFit};
use diffsil::pose::skin::{Pose, SkinnedMesh};
use diffsil::{Mesh, RenderSettings, Renderer};

use super::{fit_with_progress, sheet, user_data, Options};

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
/// ([`user_data::agreement`]) at the start (rest pose) and at the end, at the masks' own
/// resolution.
pub struct DataOutcome {
    /// The factor the masks and cameras were downsampled by for the fit (`--fit-height`).
    pub factor: u32,
    /// Width and height of the first view's images in the fit.
    pub fit_size: (u32, u32),
    /// Per view (IoU, E_sl) of the rest pose.
    pub before: Vec<(f64, f64)>,
    /// Per view (IoU, E_sl) of the fitted pose.
    pub after: Vec<(f64, f64)>,
    /// The fit's final energy E (unblurred, all terms).
    pub energy: f64,
    /// Adam steps taken.
    pub steps: u32,
    /// Wall-clock seconds of the fit.
    pub seconds: f64,
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
    let factor = downsample_factor(&targets, o.fit_height);
    let fit_targets = targets.iter().map(|t| t.downsampled(factor)).collect::<Result<Vec<_>, _>>()?;
    let fit_cameras = cameras.iter().map(|c| c.downsampled(factor)).collect::<Result<Vec<_>, _>>()?;
    let tallest = fit_targets.iter().map(subject_height).max().unwrap_or(0);
    let (w, h) = (fit_cameras[0].width, fit_cameras[0].height);
    println!("fitting at {w}x{h} (the masks downsampled {factor}x; the subject {tallest} pixels tall at most)");
    let rest_mesh = Mesh::with_topology(model.skin(&Pose::rest(model.joint_count()))?, model.mesh.topology().clone())?;
    let before = renderer.render(&rest_mesh, &cameras)?.images().to_vec();
    let fit_renderer = Renderer::with_backend(settings, o.backend.backend())?;
    let (fitted, seconds) =
        fit_with_progress(model, o, (fit_cameras, fit_targets, fit_renderer), false, |_, progress, _| {
            Some(format!("blur {:.3}  E_sl {:.2e}", progress.blur, progress.report.silhouette))
        })?;
    let (fit, run) = (fitted.fit, fitted.report);
    let (fitted_inflation, fitted_outline) = (fit.inflation(), fit.outline());
    println!("stopped: {:?} after {} steps", run.stop, run.steps);
    println!("nuisances: inflation d = {fitted_inflation:.4} (model units), outline a = {fitted_outline:.3}");
    let posed = model.posed_mesh_shaped(&fit.pose(), fit.shape())?;
    let after = renderer.render(&posed, &cameras)?.images().to_vec();
    let mut outcome = DataOutcome {
        factor,
        fit_size: (w, h),
        before: Vec::new(),
        after: Vec::new(),
        energy: run.energy,
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

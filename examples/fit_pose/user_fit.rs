//! The fit to the user's own masks and cameras (`--targets`, `--cameras`): from the model's rest
//! pose, with no ground truth, reported as each view's silhouette IoU and energy before and after;
//! and the writer of a fit's result (`--save`).

use std::path::Path;

use diffsil::pose::fit::PoseFit;
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
/// ([`user_data::agreement`]) at the start (rest pose) and at the end.
pub struct DataOutcome {
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
    let rest_mesh = Mesh::with_topology(model.skin(&Pose::rest(model.joint_count()))?, model.mesh.topology().clone())?;
    let before = renderer.render(&rest_mesh, &cameras)?.images().to_vec();
    let (fitted, seconds) =
        fit_with_progress(model, o, (cameras, targets.clone(), renderer), false, |_, progress, _| {
            Some(format!("blur {:.3}  E_sl {:.2e}", progress.blur, progress.report.silhouette))
        })?;
    let (mut fit, run) = (fitted.fit, fitted.report);
    let (fitted_inflation, fitted_outline) = (fit.inflation(), fit.outline());
    println!("stopped: {:?} after {} steps", run.stop, run.steps);
    println!("nuisances: inflation d = {fitted_inflation:.4} (model units), outline a = {fitted_outline:.3}");
    let after = fit.render()?;
    let mut outcome =
        DataOutcome { before: Vec::new(), after: Vec::new(), energy: run.energy, steps: run.steps, seconds };
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

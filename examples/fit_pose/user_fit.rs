//! The fit to the user's own masks and cameras (`--targets`, `--cameras`): from the model's rest
//! pose stood along the cameras' up and placed where the masks put the body
//! (`diffsil::pose::fit::start_from_masks`), turned by `--facing DEG` or tried at four facings,
//! in windows about the subject where it is small in the masks, at a resolution where it is
//! about `--fit-height` pixels tall (masks and cameras cropped and downsampled together,
//! `FitFrame`), reported as each view's silhouette IoU and energy before and after at
//! the masks' own resolution and, where a ground truth is known (`--truth`, `--as-user-data`),
//! the per-vertex error; and the writer of a fit's result (`--save`).

use std::path::Path;

use diffsil::pose::fit::{
    cameras_up, per_vertex_error, start_from_masks, subject_height, turned_about_vertical, upright, world_up, FitFrame,
    Fitted, MaskStart, PoseFit,
};
use diffsil::pose::skin::{Pose, SkinnedMesh};
use diffsil::{Camera, Image, Mesh, Renderer, Vec3};

use super::options::{Facing, Up};
use super::{
    describe, downsampled_nuisances, fit_frame, fit_with_progress, renderer_for, report, sheet, sizes, user_data,
    Options,
};

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
    /// Whether the fit saw windows about the subject (`FitFrame::windows`; `--no-crop`).
    pub cropped: bool,
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
    /// The fitted nuisances: the surface offset `d` (model units) and the outline `a` (0 where
    /// not fitted: `FitOptions::for_downsampled` fits `d` for masks downsampled for the fit, `a`
    /// for masks fitted as they are, unless `--inflation` or `--outline` say otherwise).
    pub nuisances: (f32, f32),
    /// The fit's final energy E (unblurred, all terms, [`PoseFit::energy`]).
    pub energy: f64,
    /// The per-vertex error against the ground truth (`--truth`, or the example's own with
    /// `--as-user-data`), in the model's units; `None` without one.
    pub error_m: Option<f64>,
    /// Adam steps taken (`Fitted::steps`: the runs from the crossed legs, the runner-up facing's
    /// pass, the restarts and the polish included).
    pub steps: u32,
    /// Wall-clock seconds of the fit.
    pub seconds: f64,
}

/// Masks and cameras as the user gives them: the cameras, one mask per camera at its size, a
/// name per view for the report, and the ground truth's vertices where one is known.
pub struct UserData {
    /// The cameras, calibrated.
    pub cameras: Vec<Camera>,
    /// One mask per camera, at its size.
    pub targets: Vec<Image>,
    /// A name per view (the mask's file) for the report.
    pub names: Vec<String>,
    /// The ground truth's posed vertices, when known.
    pub truth: Option<Vec<Vec3>>,
}

/// The start of the fit ([`start_from_masks`], or with `--no-placement` the rest pose stood along
/// the up where the model was built), printed unless `quiet`, with a warning where the masks'
/// subject looks more than twice as tall or as short as the model (cameras in other units than
/// the model's).
fn start(
    model: &SkinnedMesh,
    renderer: &mut Renderer,
    (cameras, masks): (&[Camera], &[Image]),
    o: &Options,
    quiet: bool,
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
    if quiet {
        return Ok(start);
    }
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

/// The vertices of `model` in the ground truth's pose and shape, read from the JSON at `path`
/// (`--truth`).
fn truth_vertices(model: &SkinnedMesh, path: &Path) -> Result<Vec<Vec3>, Box<dyn std::error::Error>> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("--truth {}: {e}", path.display()))?;
    let (pose, shape) = Pose::from_json(&text).map_err(|e| format!("--truth {}: {e}", path.display()))?;
    Ok(model.skin_shaped(&pose, &shape).map_err(|e| format!("--truth {}: {e}", path.display()))?)
}

/// Fits `model` to the user's `--targets` seen by `--cameras` (with `--truth`, reporting the
/// error against it); writes the pictures and, with `--save`, the fitted mesh and pose to
/// `--out`.
pub fn fit_user_data(model: &SkinnedMesh, o: &Options) -> Result<DataOutcome, Box<dyn std::error::Error>> {
    let path = o.cameras.as_ref().ok_or("--targets needs --cameras")?;
    let cameras = user_data::load_cameras(path)?;
    let targets = user_data::load_targets(&o.targets, &cameras, o.threshold)?;
    let truth = match &o.truth_file {
        Some(path) => Some(truth_vertices(model, path)?),
        None => None,
    };
    let names = o.targets.iter().map(|p| p.display().to_string()).collect();
    Ok(fit_masks(model, o, UserData { cameras, targets, names, truth }, false)?.0)
}

/// Fits `model` to `data`'s masks from their cameras alone, printing the start, the choices and
/// each view's agreement and writing the pictures (and with `--save` the fit) to `--out` unless
/// `quiet`; returns what it measured and the library's fit.
pub fn fit_masks(
    model: &SkinnedMesh,
    o: &Options,
    data: UserData,
    quiet: bool,
) -> Result<(DataOutcome, Fitted), Box<dyn std::error::Error>> {
    let UserData { cameras, targets, names, truth } = data;
    if o.shape && model.shape_count() == 0 {
        return Err("--shape needs a model with morph targets".into());
    }
    let say = |line: String| {
        if !quiet {
            println!("{line}");
        }
    };
    for (name, mask) in names.iter().zip(&targets) {
        if user_data::looks_inverted(mask) {
            say(format!(
                "warning: {name}: most of the mask's border is covered: is it inverted? The subject must be the \
                 bright pixels."
            ));
        }
    }
    let mut renderer = renderer_for(o)?;
    // The fit runs in windows about a small subject, where it is about `--fit-height` pixels
    // tall; the report and the pictures are at the masks' own resolution.
    let frame = fit_frame(&cameras, &targets, o)?;
    let tallest = frame.masks.iter().map(subject_height).max().unwrap_or(0);
    let (w, h) = (frame.cameras[0].width, frame.cameras[0].height);
    let how = describe(&frame).unwrap_or_else(|| "as they are".to_string());
    say(format!("fitting at {} (the masks {how}; the subject {tallest} pixels tall at most)", sizes(&frame)));
    let FitFrame { windows, factor, cameras: fit_cameras, masks: fit_targets } = frame;
    let start = start(model, &mut renderer, (&cameras, &targets), o, quiet)?;
    let height_ratio = start.height_ratio;
    let start = start.pose;
    let start = match o.facing() {
        Facing::Degrees(degrees) => turned_about_vertical(model, &start, degrees.to_radians())?,
        Facing::Auto => start,
    };
    let start_mesh = Mesh::with_topology(model.skin(&start)?, model.mesh.topology().clone())?;
    let before = renderer.render(&start_mesh, &cameras)?.images().to_vec();
    let fit_renderer = renderer_for(o)?;
    let o = &Options { initial: Some(start), ..downsampled_nuisances(o, factor) };
    let (mut fitted, seconds) =
        fit_with_progress(model, o, (fit_cameras, fit_targets, fit_renderer), quiet, |_, progress, _| {
            Some(format!("blur {:.3}  E_sl {:.2e}", progress.blur, progress.report.silhouette))
        })?;
    let facing = fitted.facing.to_degrees();
    if o.facing() == Facing::Auto {
        let how = match &fitted.facing_run {
            Some(run) if run.kept => "ended lower than the facing that fitted best after the starting poses' steps",
            Some(_) => "fitted best after the starting poses' steps and ended lower than the runner-up",
            None => "fitted best after the starting poses' steps",
        };
        say(format!("facing: {facing:.0}° from the model's front {how}"));
    }
    if !quiet {
        report::print_fitted(&fitted);
    }
    let fit = &mut fitted.fit;
    let (fitted_inflation, fitted_outline) = (fit.inflation(), fit.outline());
    say(format!("stopped: {:?} after {} steps", fitted.first.report.stop, fitted.first.report.steps));
    say(format!("nuisances: inflation d = {fitted_inflation:.4} (model units), outline a = {fitted_outline:.3}"));
    let posed = model.posed_mesh_shaped(&fit.pose(), fit.shape())?;
    let after = renderer.render(&posed, &cameras)?.images().to_vec();
    let mut outcome = DataOutcome {
        cropped: windows.is_some(),
        factor,
        fit_size: (w, h),
        height_ratio,
        before: Vec::new(),
        after: Vec::new(),
        facing,
        nuisances: (fitted_inflation, fitted_outline),
        energy: fit.energy()?,
        error_m: match &truth {
            Some(truth) => Some(per_vertex_error(&fit.vertices()?, truth)),
            None => None,
        },
        steps: fitted.steps(),
        seconds,
    };
    for (view, target) in targets.iter().enumerate() {
        outcome.before.push(user_data::agreement(&before[view], target));
        outcome.after.push(user_data::agreement(&after[view], target));
        let ((iou0, e0), (iou1, e1)) = (outcome.before[view], outcome.after[view]);
        say(format!("view {view} ({}): IoU {iou0:.3} -> {iou1:.3}, E_sl {e0:.2e} -> {e1:.2e}", names[view]));
    }
    if !quiet {
        sheet::save_comparison_sheets(&o.out, &targets, &before, &after)?;
        if o.save {
            save_fit(model, &fitted.fit, &o.out)?;
        }
    }
    Ok((outcome, fitted))
}

//! Fits a skinned mesh's pose to multi-view silhouettes by gradient descent (paper §4), with the
//! library's one-call method `diffsil::pose::fit::fit`.
//!
//! ```text
//! cargo run --release --example fit_pose                          # the MakeHuman body, seed 1
//! cargo run --release --example fit_pose -- --shape               # and a random shape, fitted too
//! cargo run --release --example fit_pose -- --model ../shared/assets/RiggedFigure.glb
//! cargo run --release --example fit_pose -- --seeds 1-30          # median, p90, worst, failures
//! cargo run --release --example fit_pose -- --figure --seeds 31-50 --mask-noise dilate
//! cargo run --release --example fit_pose -- --ablation 10         # paper Table 2 over 10 seeds
//! cargo run --release --example fit_pose -- --targets a.png,b.png --cameras cameras.json --save
//! cargo run --release --example fit_pose -- --seed 3 --turn 180 --export d   # as --targets data
//! cargo run --release --example fit_pose -- --seeds 1-6 --views irregular --resolution 640x480 \
//!     --threshold 0.5 --turn 135 --as-user-data                  # the same, fitted over seeds
//! ```
//!
//! A random plausible ground-truth pose is drawn from the seed (joint limits from the joints'
//! names, `diffsil::pose::figure::random_pose_limits`: limbs 0.5 rad, spine, collars, neck and
//! head 0.25, root, fingers and toes 0, so no digit flails), its silhouettes rendered from
//! `--view-count` cameras on a level or raised ring (`--views`), optionally spoiled
//! (`--mask-noise`), and the pose fitted by `fit` with `FitOptions::default()` except where an
//! option says otherwise. `--plain` fits from the rest pose without blur, prior, starting poses
//! or early stop instead (the paper's plain descent). Pictures go to `--out`: per view,
//! target | fitted | difference, before (top) and after (bottom). The last line is
//! machine-readable.
//!
//! With `--targets` and `--cameras` the masks and cameras are the user's own (see `user_data.rs`
//! for the JSON format): the model is fitted to them from its rest pose moved to where the masks
//! place the body (`--no-placement`: where it was built), stood along the cameras' up (`--up`),
//! tried at four facings (`--facing DEG`: turned by that much instead), in windows about the
//! subject where it is small in the masks (`--no-crop`: the whole masks), at a resolution
//! where the body is about `--fit-height` pixels tall, with no ground truth (unless `--truth`
//! gives one), so the report is each view's silhouette IoU and energy before and after.
//! `--export DIR` writes the example's own targets, cameras and truth in those formats instead
//! of fitting them; `--as-user-data` fits them as that path would, in one process (with
//! `--resolution WxH` a camera's image size, `--threshold` hard masks, `--world-up` and
//! `--world-offset` a calibration's world).

mod evaluate;
mod masks;
mod options;
mod report;
mod rig;
mod sheet;
mod user_data;
mod user_fit;

use std::ops::ControlFlow;
use std::time::Instant;

use clap::Parser;
use diffsil::pose::figure::random_pose_limits;
use diffsil::pose::fit::{
    fit, per_vertex_error, random_pose, turned_about_vertical, upright, CrossedLegsEnd, FitFrame, FitOptions, Fitted,
    LimbSwap, PoseFit, Progress, Stop,
};
use diffsil::pose::skin::{Pose, SkinnedMesh};
use diffsil::{Camera, Image, Mesh, RenderSettings, Renderer};

#[path = "../common/mod.rs"]
mod common;
use evaluate::{ablation, evaluate, motion_frames};
pub use options::{fit_options, load_model, Facing, Options};
pub use user_fit::fit_user_data;
use user_fit::{fit_masks, save_fit, UserData};

/// What one fit of the example's own targets measured.
pub struct Outcome {
    /// The per-vertex error against the ground truth, in the model's units.
    pub error_m: f64,
    /// The mean over the views of the fitted silhouette's IoU with its target (both at 0.5).
    pub mean_iou: f64,
    /// Largest extent of the model's rest pose (its height for a standing body).
    pub height_m: f64,
    /// Wall-clock seconds of the fit.
    pub seconds: f64,
    /// The renderer's backend.
    pub backend: String,
    /// Adam steps ([`Fitted::steps`]).
    pub steps: u32,
    /// Why the first run stopped.
    pub stop: Stop,
    /// The swap the swap test kept, if any.
    pub swap: Option<LimbSwap>,
    /// Whether the runs from the legs crossed over ran (`FitOptions::crossed_legs_within`),
    /// and where the fit ends; `None` when the crossed pose was not looked at.
    pub crossed: Option<(bool, CrossedLegsEnd)>,
    /// Whether the restart ran and, if so, whether the fit ends at it (`FitOptions::restart_arm_swing`).
    pub restart: Option<bool>,
    /// Whether the fit found its targets thinned (`FitOptions::thinned_below`).
    pub thinned: bool,
    /// Whether the pass from the runner-up facing ran (`FitOptions::facing_within`) and, if so,
    /// whether the fit ends from it.
    pub facing_run: Option<bool>,
}

impl Outcome {
    /// What `fitted` did, with its per-vertex error `error_m`, its silhouettes' mean IoU
    /// `mean_iou`, the model's height `height_m` and the fit's wall `seconds`.
    fn of(fitted: &Fitted, (error_m, mean_iou): (f64, f64), height_m: f64, seconds: f64) -> Outcome {
        let restart = fitted.restart.as_ref().filter(|r| !r.runs.is_empty());
        Outcome {
            error_m,
            mean_iou,
            height_m,
            seconds,
            backend: fitted.fit.renderer().backend_name(),
            steps: fitted.steps(),
            stop: fitted.first.report.stop,
            swap: fitted.first.swap.as_ref().and_then(|s| s.kept),
            crossed: fitted.first.crossed_legs.as_ref().map(|c| (!c.runs.is_empty(), c.end)),
            restart: restart.map(|r| r.kept.is_some()),
            thinned: fitted.restart.as_ref().is_some_and(|r| r.thinned),
            facing_run: fitted.facing_run.as_ref().map(|f| f.kept),
        }
    }
}

/// The largest extent of `mesh`'s bounding box (a standing body's height).
fn largest_extent(mesh: &Mesh) -> f64 {
    mesh.bounds().map_or(0.0, |(lo, hi)| f64::from((hi - lo).max_element()))
}

/// Where a fit of `masks` seen by `cameras` works under `o`: windows about a small subject
/// (unless `--no-crop`), downsampled for `--fit-height` (`FitFrame::new`).
fn fit_frame(cameras: &[Camera], masks: &[Image], o: &Options) -> diffsil::Result<FitFrame> {
    FitFrame::new(cameras, masks, o.fit_height, !o.no_crop)
}

/// The sizes `frame`'s views are fitted at, for a progress line: "80x80", or each view's where
/// they differ ("73x73, 96x96, …").
fn sizes(frame: &FitFrame) -> String {
    let sizes: Vec<String> = frame.cameras.iter().map(|c| format!("{}x{}", c.width, c.height)).collect();
    if sizes.iter().all(|s| *s == sizes[0]) {
        sizes[0].clone()
    } else {
        sizes.join(", ")
    }
}

/// How `frame` differs from the masks, for a progress line: e.g. "cropped to the subject,
/// downsampled 5x"; `None` where it does not.
fn describe(frame: &FitFrame) -> Option<String> {
    let mut parts = Vec::new();
    if frame.windows.is_some() {
        parts.push("cropped to the subject".to_string());
    }
    if frame.factor > 1 {
        parts.push(format!("downsampled {}x", frame.factor));
    }
    (!parts.is_empty()).then(|| parts.join(", "))
}

/// A renderer with `--supersample` on `--backend`.
fn renderer_for(o: &Options) -> diffsil::Result<Renderer> {
    Renderer::with_backend(
        RenderSettings { supersample: o.supersample, ..RenderSettings::default() },
        o.backend.backend(),
    )
}

/// The example's own targets for `o`: the ground truth (its pose, shape and vertices), the
/// rest pose's mesh the cameras frame, the cameras of `--views`, their masks (with
/// `--mask-noise`) and a description of an irregular rig.
struct OwnTargets {
    truth: Pose,
    betas: Vec<f32>,
    truth_vertices: Vec<diffsil::Vec3>,
    rest_mesh: Mesh,
    cameras: Vec<Camera>,
    targets: Vec<Image>,
    rig: String,
}

/// Draws `o`'s ground truth (`--seed`, `--shape`, turned by `--turn`) and renders its targets
/// (hardened by `--threshold`, spoiled by `--mask-noise`).
fn own_targets(
    model: &SkinnedMesh,
    o: &Options,
    renderer: &mut Renderer,
) -> Result<OwnTargets, Box<dyn std::error::Error>> {
    let limits = random_pose_limits(&model.skeleton);
    let truth = o.truth.clone().unwrap_or_else(|| random_pose(&limits, 30f32.to_radians(), o.seed));
    let truth = turned_about_vertical(model, &truth, o.turn.to_radians())?;
    let betas: Vec<f32> = if o.shape {
        if model.shape_count() == 0 {
            return Err("--shape needs a model with morph targets".into());
        }
        let mut rng = diffsil::random::SplitMix64::new(o.seed ^ 0x5EED_5A9E);
        (0..model.shape_count()).map(|_| rng.range(-0.3, 0.3)).collect()
    } else {
        Vec::new()
    };
    let truth_vertices = model.skin_shaped(&truth, &betas)?;
    // Frame the skinned rest pose: a glTF bind-pose mesh may sit in another space (e.g. Z-up).
    let rest_mesh = Mesh::with_topology(model.skin(&Pose::rest(model.joint_count()))?, model.mesh.topology().clone())?;
    let rig_seed = o.rig_seed.unwrap_or(o.seed);
    let (cameras, rig) = rig::cameras(o.views, &rest_mesh, o.view_count, o.resolution, rig_seed);
    let truth_mesh = Mesh::with_topology(truth_vertices.clone(), model.mesh.topology().clone())?;
    let mut clean = renderer.render(&truth_mesh, &cameras)?.images().to_vec();
    if let Some(threshold) = o.threshold {
        clean = clean.into_iter().map(|t| t.thresholded(threshold)).collect();
    }
    let targets = clean
        .iter()
        .enumerate()
        .map(|(v, t)| masks::apply(o.mask_noise, t, o.flip_fraction, o.seed * 1000 + v as u64))
        .collect();
    Ok(OwnTargets { truth, betas, truth_vertices, rest_mesh, cameras, targets, rig })
}

/// `o` for targets downsampled by `factor`: where `--inflation` and `--outline` are not given,
/// the library's nuisances for such targets (`FitOptions::for_downsampled`: from a factor of 2
/// the surface offset in place of the outline).
pub fn downsampled_nuisances(o: &Options, factor: u32) -> Options {
    let chosen = FitOptions::default().for_downsampled(factor);
    Options {
        inflation: o.inflation.or(Some(chosen.fit_inflation)),
        outline: o.outline.or(Some(chosen.fit_outline)),
        ..o.clone()
    }
}

/// Moves `own`'s cameras and truth into the world of `--world-up` and `--world-offset`
/// (`X' = Q X + offset`, the cameras seeing there what they saw), where given.
fn in_given_world(model: &SkinnedMesh, mut own: OwnTargets, o: &Options) -> diffsil::Result<OwnTargets> {
    if o.world_up.is_none() && o.world_offset.is_none() {
        return Ok(own);
    }
    let q =
        glam::Quat::from_scaled_axis(upright(model.joint_count(), o.world_up.unwrap_or(diffsil::Vec3::Y))?.orientation);
    let offset = o.world_offset.unwrap_or(diffsil::Vec3::ZERO);
    for camera in &mut own.cameras {
        *camera = camera.in_world(glam::Mat3::from_quat(q), offset);
    }
    let orientation = (q * glam::Quat::from_scaled_axis(own.truth.orientation)).to_scaled_axis();
    own.truth = Pose { orientation, translation: q * own.truth.translation + offset, ..own.truth };
    own.truth_vertices = model.skin_shaped(&own.truth, &own.betas)?;
    Ok(own)
}

/// Fits one seed's own targets (with `--as-user-data` from its masks and cameras alone);
/// writes pictures when `pictures` is set and prints the fit's course unless `quiet`.
pub fn fit_seed(
    model: &SkinnedMesh,
    o: &Options,
    pictures: bool,
    quiet: bool,
) -> Result<Outcome, Box<dyn std::error::Error>> {
    let mut renderer = renderer_for(o)?;
    let own = in_given_world(model, own_targets(model, o, &mut renderer)?, o)?;
    if !quiet {
        print!("{}", own.rig);
    }
    if o.as_user_data {
        // The masks and cameras alone, as `--targets` would see them (pictures unless quiet).
        let height_m = largest_extent(&own.rest_mesh);
        let names = (0..own.targets.len()).map(|k| format!("camera {k}")).collect();
        let data = UserData { cameras: own.cameras, targets: own.targets, names, truth: Some(own.truth_vertices) };
        let (outcome, fitted) = fit_masks(model, o, data, quiet || !pictures)?;
        let error_m = outcome.error_m.ok_or("the fit reported no error against the truth")?;
        let mean_iou = user_data::mean_iou(&outcome.after);
        return Ok(Outcome::of(&fitted, (error_m, mean_iou), height_m, outcome.seconds));
    }
    let OwnTargets { truth_vertices, rest_mesh, cameras, targets, .. } = own;
    // A given `--facing` starts the model turned (`auto` tries four facings: `fit_options`).
    let turned = match o.facing() {
        Facing::Degrees(d) if d != 0.0 => {
            let initial = o.initial.clone().unwrap_or_else(|| Pose::rest(model.joint_count()));
            Some(Options { initial: Some(turned_about_vertical(model, &initial, d.to_radians())?), ..o.clone() })
        }
        _ => None,
    };
    let o = turned.as_ref().unwrap_or(o);
    // Where the subject is small in its masks the fit sees a window about it, and where it is
    // taller than `--fit-height` the masks downsampled.
    let frame = fit_frame(&cameras, &targets, o)?;
    if let (Some(how), false) = (describe(&frame), quiet) {
        println!("fitting at {} (the targets {how})", sizes(&frame));
    }
    let FitFrame { factor, cameras, masks: targets, .. } = frame;
    let o = &downsampled_nuisances(o, factor);
    let before = if pictures { Some(renderer.render(&rest_mesh, &cameras)?.images().to_vec()) } else { None };

    let (mut fitted, seconds) =
        fit_with_progress(model, o, (cameras, targets.clone(), renderer), quiet, |fit, progress, plan| {
            if quiet || (progress.step % 10 != 0 && progress.step != plan.total) {
                return None;
            }
            let error = fit.vertices().map_or(f64::NAN, |v| per_vertex_error(&v, &truth_vertices) * 1000.0);
            let stage = match progress.hypothesis {
                Some(k) => format!("start {}/{}", k + 1, plan.hypotheses),
                None => format!("blur {:.3}", progress.blur),
            };
            Some(format!(
                "{stage}  E_sl {:.2e}  E_spt {:.4}  error {error:.1} mm",
                progress.report.silhouette, progress.report.self_intersection
            ))
        })?;
    if !quiet {
        report::print_fitted(&fitted);
    }
    let (fit, run) = (&mut fitted.fit, &fitted.first.report);
    let (fitted_inflation, fitted_outline) = (fit.inflation(), fit.outline());
    if !quiet {
        if run.hypothesis_energies.len() > 1 {
            let energies: Vec<String> = run.hypothesis_energies.iter().map(|e| format!("{e:.3e}")).collect();
            println!("starting poses' energies: {} (kept {})", energies.join(", "), run.chosen + 1);
        }
        println!("stopped: {:?} after {} steps", run.stop, run.steps);
        println!("nuisances: inflation d = {fitted_inflation:.4} (model units), outline a = {fitted_outline:.3}");
    }
    let error_m = per_vertex_error(&fit.vertices()?, &truth_vertices);
    let after = fit.render()?;
    let agreements: Vec<(f64, f64)> = after.iter().zip(&targets).map(|(a, t)| user_data::agreement(a, t)).collect();
    if !quiet {
        let views: Vec<String> = agreements.iter().map(|(iou, _)| format!("{iou:.3}")).collect();
        println!("silhouette IoU per view: {}", views.join(", "));
    }
    let height_m = largest_extent(&rest_mesh);
    let mean_iou = user_data::mean_iou(&agreements);
    if !quiet && error_m > 0.02 * height_m && mean_iou >= 0.95 {
        println!(
            "note: the silhouettes match (mean IoU {mean_iou:.3}) while the vertices are {:.1} mm off: what differs \
             does not show in these views (e.g. a limb turned about its own axis)",
            error_m * 1000.0
        );
    }
    if let Some(before) = before {
        sheet::save_comparison_sheets(&o.out, &targets, &before, &after)?;
        if o.save {
            save_fit(model, fit, &o.out)?;
        }
    }
    Ok(Outcome::of(&fitted, (error_m, mean_iou), height_m, seconds))
}

/// Runs the command line; a failure is reported on stderr with exit status 1.
fn main() {
    let o = Options::parse();
    if let Err(e) = run(&o) {
        eprintln!("fit_pose: {e}");
        std::process::exit(1);
    }
}

/// What `main` does for the options `o`.
pub fn run(o: &Options) -> Result<(), Box<dyn std::error::Error>> {
    let (model, name) = load_model(o)?;
    if let Some(seeds) = o.ablation {
        return ablation(&model, &name, o, seeds);
    }
    if let Some(clip) = &o.motion {
        let poses = motion_frames(o, clip)?;
        if let Some(k) = o.frame {
            let (time, pose) =
                poses.get(k).cloned().ok_or_else(|| format!("--frame {k}: the clip gives {} frames", poses.len()))?;
            println!("{name}: clip {clip}, frame {k} (t = {time:.3} s)");
            let outcome = fit_seed(&model, &Options { truth: Some(pose), ..o.clone() }, true, false)?;
            println!(
                "final: per_vertex_error_mm={:.2} mean_iou={:.3} iterations={} seconds={:.3}",
                outcome.error_m * 1000.0,
                outcome.mean_iou,
                outcome.steps,
                outcome.seconds
            );
            return Ok(());
        }
        let what = format!("clip {clip}, {} frames", poses.len());
        let cases = poses
            .into_iter()
            .enumerate()
            .map(|(k, (time, pose))| {
                (
                    format!("frame {k} (t = {time:.3} s)"),
                    Options { seed: k as u64, truth: Some(pose), rig_seed: Some(o.seed), ..o.clone() },
                )
            })
            .collect();
        return evaluate(&model, &name, o, &what, cases);
    }
    if let Some(dir) = &o.export {
        return export(&model, o, dir);
    }
    if !o.targets.is_empty() {
        let outcome = fit_user_data(&model, o)?;
        println!(
            "final: mean_iou_before={:.3} mean_iou_after={:.3} energy={:.3e} iterations={} seconds={:.3}{} model={name}",
            user_data::mean_iou(&outcome.before),
            user_data::mean_iou(&outcome.after),
            outcome.energy,
            outcome.steps,
            outcome.seconds,
            outcome.error_m.map_or(String::new(), |e| format!(" per_vertex_error_mm={:.2}", e * 1000.0))
        );
        return Ok(());
    }
    if let Some((first, last)) = o.seeds {
        let cases = (first..=last).map(|seed| (format!("seed {seed}"), Options { seed, ..o.clone() })).collect();
        return evaluate(&model, &name, o, &format!("seeds {first}–{last}"), cases);
    }
    println!(
        "{name}: {} vertices, {} triangles, {} joints; {} {:?} views at {}, F = {}, seed {}",
        model.vertex_count(),
        model.mesh.triangles().len(),
        model.joint_count(),
        o.view_count,
        o.views,
        o.resolution_text(),
        o.supersample,
        o.seed
    );
    let outcome = fit_seed(&model, o, true, false)?;
    println!(
        "final: per_vertex_error_mm={:.2} mean_iou={:.3} iterations={} seconds={:.3} backend={} model={name}",
        outcome.error_m * 1000.0,
        outcome.mean_iou,
        outcome.steps,
        outcome.seconds,
        outcome.backend.replace(' ', "_")
    );
    Ok(())
}

/// `--export DIR`: writes the example's own targets for `o` (`mask0.png`, …), their cameras
/// (`cameras.json`, the format `--cameras` reads) and the ground truth (`truth.json`, the format
/// of `--save`'s `fitted_pose.json`) to `dir`, for a fit with `--targets`, `--cameras` and
/// `--truth`.
fn export(model: &SkinnedMesh, o: &Options, dir: &std::path::Path) -> Result<(), Box<dyn std::error::Error>> {
    let mut renderer = renderer_for(o)?;
    let own = in_given_world(model, own_targets(model, o, &mut renderer)?, o)?;
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut masks = Vec::new();
    for (k, target) in own.targets.iter().enumerate() {
        let path = dir.join(format!("mask{k}.png"));
        diffsil::io::save_png(target, &path)?;
        masks.push(path.display().to_string());
    }
    let cameras = user_data::cameras_json(&own.cameras)?;
    std::fs::write(dir.join("cameras.json"), cameras).map_err(|e| format!("{}: {e}", dir.display()))?;
    std::fs::write(dir.join("truth.json"), own.truth.to_json(&own.betas))
        .map_err(|e| format!("{}: {e}", dir.display()))?;
    println!(
        "wrote {} masks, cameras.json and truth.json to {}; fit them with\n  fit_pose --targets {} --cameras {} --truth {}",
        masks.len(),
        dir.display(),
        masks.join(","),
        dir.join("cameras.json").display(),
        dir.join("truth.json").display()
    );
    Ok(())
}

/// The size of a fit's plan, for progress messages: its steps in all and its starting poses.
struct Plan {
    total: u32,
    hypotheses: usize,
}

/// Runs the library's fit (`fit_options(o)`) of `model` to the targets seen by the cameras, with
/// a progress bar over the plan's steps (hidden when `quiet`) whose message `describe` gives (or
/// leaves as it was, `None`), stopping at `--time-limit`; returns the fit and its wall seconds.
fn fit_with_progress(
    model: &SkinnedMesh,
    o: &Options,
    (cameras, targets, renderer): (Vec<Camera>, Vec<Image>, Renderer),
    quiet: bool,
    mut describe: impl FnMut(&PoseFit, &Progress, &Plan) -> Option<String>,
) -> diffsil::Result<(Fitted, f64)> {
    let options = fit_options(o);
    let (schedule, hypotheses) = options.plan(model)?;
    let plan = Plan { total: schedule.total_steps(hypotheses.len()), hypotheses: hypotheses.len() };
    let bar = if quiet { indicatif::ProgressBar::hidden() } else { indicatif::ProgressBar::new(plan.total as u64) };
    bar.set_style(indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}").expect("valid template"));
    let start = Instant::now();
    let fitted = fit(model.clone(), cameras, targets, renderer, &options, |fit, progress| {
        if let Some(message) = describe(fit, progress, &plan) {
            bar.set_message(message);
        }
        bar.inc(1);
        within_time_limit(o.time_limit, start)
    })?;
    let seconds = start.elapsed().as_secs_f64();
    bar.finish();
    Ok((fitted, seconds))
}

/// `--time-limit`: `Break` (cancel the fit) once more than `limit` seconds have passed since
/// `start`, `Continue` otherwise or without a limit.
fn within_time_limit(limit: Option<f64>, start: Instant) -> ControlFlow<()> {
    match limit {
        Some(limit) if start.elapsed().as_secs_f64() > limit => ControlFlow::Break(()),
        _ => ControlFlow::Continue(()),
    }
}

//! Fits a skinned mesh's pose to multi-view silhouettes by gradient descent (paper §4).
//!
//! ```text
//! cargo run --release --example fit_pose                     # built-in figure, seed 1
//! cargo run --release --example fit_pose -- --model ../shared/assets/RiggedFigure.glb
//! cargo run --release --example fit_pose -- --ablation 10    # paper Table 2 over 10 seeds
//! ```
//!
//! A random plausible ground-truth pose is drawn from the seed, its silhouettes rendered from
//! `--views` cameras around the model, and the pose fitted with
//! `E = E_sl + λ·E_spt + μ·E_prior` and Adam, by the method of `diffsil::pose::fit` (`PoseFit::run`):
//! three starting poses (rest, and the legs in a stride each way) tried for a few steps on
//! blurred silhouettes, the lowest-energy one kept and refined coarse to fine, the blur shrinking
//! to none, with a zero-mean prior on the joint offsets. `--plain` fits from the rest pose without
//! blur or prior instead (the paper's plain descent). Pictures go to `--out`: per view,
//! target | fitted | difference, before (top) and after (bottom). The last line is
//! machine-readable.

use std::path::PathBuf;
use std::time::Instant;

use clap::Parser;
use diffsil::io::gltf::{load_gltf, Model};
use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::{
    framing_cameras, per_vertex_error, random_pose, stride_hypotheses, FitSettings, PoseFit, Schedule, Stage,
};
use diffsil::pose::skin::{Pose, SkinnedMesh};
use diffsil::{Image, RenderSettings, Renderer};

mod common;
use common::{finite, median, BackendName};

/// Command-line options (`fit_pose --help`).
#[derive(Clone, Debug, Parser)]
#[command(
    name = "fit_pose",
    about = "Fit a skinned mesh's pose to multi-view silhouettes",
    after_help = "\
Method (diffsil::pose::fit, PoseFit::run): E = E_sl + λ·E_spt + μ·E_prior, where E_sl is the mean
squared error over all pixels of all views between the rendered and target silhouettes, both
blurred by the same Gaussian, and E_prior = mean_j |θ_j|² a zero-mean prior on the joint offsets.
Each of the three starting poses runs 1/10 of the steps with a blur of 6% of the image height;
the one with the lowest unblurred energy E continues: 1/20 of the steps at 6%, 1/12 at 3%, the
rest (170 of 300) unblurred. Same method and settings at every resolution and F."
)]
struct Options {
    /// Skinned .gltf/.glb [default: the built-in figure]
    #[arg(long, value_name = "PATH")]
    model: Option<PathBuf>,
    /// Number of cameras around the model, azimuths evenly spaced, at least 1
    #[arg(long, value_name = "N", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..))]
    views: u32,
    /// Image side in pixels
    #[arg(long, value_name = "N", default_value_t = 64)]
    resolution: u32,
    /// Samples per pixel side, 1 = no anti-aliasing
    #[arg(long, value_name = "F", default_value_t = 4)]
    supersample: u32,
    /// Adam steps in all, every starting pose included
    #[arg(long, value_name = "N", default_value_t = 300)]
    iterations: u32,
    /// Adam learning rate
    #[arg(long, value_name = "X", default_value = "0.02", value_parser = finite)]
    lr: f32,
    /// Self-intersection weight λ; E_sl is a mean over pixels
    #[arg(long, value_name = "X", default_value = "1e-7", value_parser = finite)]
    lambda: f32,
    /// Leg stride (radians) of the two extra starting poses; 0: rest pose only
    #[arg(long, value_name = "X", default_value = "0.3", value_parser = finite)]
    stride: f32,
    /// Weight μ of the pose prior μ·mean_j |θ_j|² [default: PoseFit::POSE_PRIOR = 1e-3]
    #[arg(long, value_name = "X", default_value_t = PoseFit::POSE_PRIOR, hide_default_value = true, value_parser = finite)]
    prior: f32,
    /// Plain descent: rest pose only, no blur, no prior (the paper's method)
    #[arg(long)]
    plain: bool,
    /// Seed of the ground-truth pose
    #[arg(long, value_name = "N", default_value_t = 1)]
    seed: u64,
    /// Which engine renders
    #[arg(long, value_name = "NAME", value_enum, default_value_t = BackendName::Cpu)]
    backend: BackendName,
    /// Where the PNGs go
    #[arg(long, value_name = "DIR", default_value = "fit_pose_out")]
    out: PathBuf,
    /// Run N seeds for {32², 64²} × {F = 1, F = 4} and print the median errors
    #[arg(long, value_name = "N")]
    ablation: Option<u32>,
}

fn load_model(o: &Options) -> Result<(SkinnedMesh, String), Box<dyn std::error::Error>> {
    match &o.model {
        None => Ok((builtin_figure(), "builtin-figure".into())),
        Some(path) => match load_gltf(path)? {
            Model::Skinned(model) => {
                Ok((model, path.file_stem().map_or("model".into(), |s| s.to_string_lossy().into_owned())))
            }
            Model::Static(_) => {
                Err(format!("{}: the model has no skin, so it has no pose to fit", path.display()).into())
            }
        },
    }
}

/// What one fit measured.
struct Outcome {
    error_m: f64,
    seconds: f64,
    backend: String,
    steps: u32,
}

/// Fits one seed; writes pictures when `pictures` is set.
fn fit(model: &SkinnedMesh, o: &Options, pictures: bool, quiet: bool) -> Result<Outcome, Box<dyn std::error::Error>> {
    let limits = random_pose_limits(&model.skeleton);
    let truth = random_pose(&limits, 30f32.to_radians(), o.seed);
    let truth_vertices = model.skin(&truth)?;
    // Frame the skinned rest pose: a glTF bind-pose mesh may sit in another space (e.g. Z-up).
    let rest_mesh =
        diffsil::Mesh::with_topology(model.skin(&Pose::rest(model.joint_count()))?, model.mesh.topology().clone())?;
    let cameras = framing_cameras(&rest_mesh, o.views, o.resolution);
    let settings = RenderSettings { supersample: o.supersample, ..RenderSettings::default() };
    let mut renderer = Renderer::with_backend(settings, o.backend.backend())?;
    let truth_mesh = diffsil::Mesh::with_topology(truth_vertices.clone(), model.mesh.topology().clone())?;
    let targets = renderer.render(&truth_mesh, &cameras)?.images().to_vec();

    let rest = Pose::rest(model.joint_count());
    let mut fit = PoseFit::new(
        model.clone(),
        cameras,
        targets.clone(),
        renderer,
        FitSettings { initial: Some(rest.clone()), learning_rate: o.lr, lambda: o.lambda },
    )?;
    let backend = fit.renderer().backend_name();
    let before = if pictures { Some(fit.render()?) } else { None };
    fit.set_pose_prior(if o.plain { 0.0 } else { o.prior })?;
    let (schedule, hypotheses) = if o.plain {
        (Schedule { hypothesis_steps: 0, stages: vec![Stage { blur: 0.0, steps: o.iterations }] }, vec![rest])
    } else {
        let hypotheses = if o.stride > 0.0 { stride_hypotheses(model, o.stride)? } else { vec![rest] };
        let schedule = Schedule::coarse_to_fine(o.iterations, hypotheses.len());
        (schedule, hypotheses)
    };

    let total = schedule.total_steps(hypotheses.len());
    let bar = if quiet { indicatif::ProgressBar::hidden() } else { indicatif::ProgressBar::new(total as u64) };
    bar.set_style(indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}").expect("valid template"));
    let start = Instant::now();
    let run = fit.run(&schedule, &hypotheses, |fit, progress| {
        if !quiet && (progress.step % 10 == 0 || progress.step == total) {
            let error = fit.vertices().map_or(f64::NAN, |v| per_vertex_error(&v, &truth_vertices) * 1000.0);
            let stage = match progress.hypothesis {
                Some(k) => format!("start {}/{}", k + 1, hypotheses.len()),
                None => format!("blur {:.3}", progress.blur),
            };
            bar.set_message(format!(
                "{stage}  E_sl {:.2e}  E_spt {:.4}  error {error:.1} mm",
                progress.report.silhouette, progress.report.self_intersection
            ));
        }
        bar.inc(1);
    })?;
    let seconds = start.elapsed().as_secs_f64();
    bar.finish();
    if !quiet && run.hypothesis_energies.len() > 1 {
        let energies: Vec<String> = run.hypothesis_energies.iter().map(|e| format!("{e:.3e}")).collect();
        println!("starting poses' energies: {} (kept {})", energies.join(", "), run.chosen + 1);
    }
    let error_m = per_vertex_error(&fit.vertices()?, &truth_vertices);

    if let Some(before) = before {
        let after = fit.render()?;
        std::fs::create_dir_all(&o.out)?;
        for (view, target) in targets.iter().enumerate() {
            let path = o.out.join(format!("view{view}.png"));
            comparison_sheet(target, &before[view], &after[view]).save(&path)?;
        }
        println!(
            "wrote {} pictures to {} (rows: before, after; columns: target, fitted, difference)",
            targets.len(),
            o.out.display()
        );
    }
    Ok(Outcome { error_m, seconds, backend, steps: run.steps })
}

/// A picture a person can read: rows before/after, columns target | fitted | difference
/// (red: target only, cyan: fitted only, white: both), each pixel drawn 4×4.
fn comparison_sheet(target: &Image, before: &Image, after: &Image) -> image::RgbImage {
    let (w, h) = (target.width(), target.height());
    let zoom = 4;
    let gap = 4;
    let mut sheet = image::RgbImage::from_pixel(3 * w * zoom + 2 * gap, 2 * h * zoom + gap, image::Rgb([60, 60, 60]));
    for (row, fitted) in [before, after].into_iter().enumerate() {
        for i in 0..h {
            for j in 0..w {
                let t = target.get(i, j).clamp(0.0, 1.0);
                let f = fitted.get(i, j).clamp(0.0, 1.0);
                let gray = |v: f32| image::Rgb([(v * 255.0) as u8; 3]);
                let diff = image::Rgb([(t * 255.0) as u8, (f * 255.0) as u8, (f * 255.0) as u8]);
                for (col, color) in [gray(t), gray(f), diff].into_iter().enumerate() {
                    for di in 0..zoom {
                        for dj in 0..zoom {
                            let x = col as u32 * (w * zoom + gap) + j * zoom + dj;
                            let y = row as u32 * (h * zoom + gap) + i * zoom + di;
                            sheet.put_pixel(x, y, color);
                        }
                    }
                }
            }
        }
    }
    sheet
}

fn ablation(model: &SkinnedMesh, name: &str, o: &Options, seeds: u32) -> Result<(), Box<dyn std::error::Error>> {
    let method = if o.plain { "plain descent" } else { "coarse to fine, multiple starts" };
    println!(
        "median per-vertex error (mm) over {seeds} seeds, {name}, {} views, {} iterations, {method}",
        o.views, o.iterations
    );
    println!("| resolution | F = 1 (no AA) | F = 4 |");
    println!("|---|---|---|");
    let mut details = Vec::new();
    for resolution in [32, 64] {
        let mut cells = Vec::new();
        for supersample in [1, 4] {
            let mut errors = Vec::new();
            let mut seconds = Vec::new();
            for seed in 1..=seeds as u64 {
                let run = Options { resolution, supersample, seed, ..o.clone() };
                let outcome = fit(model, &run, false, true)?;
                errors.push(outcome.error_m * 1000.0);
                seconds.push(outcome.seconds);
            }
            let per_seed: Vec<String> = errors.iter().map(|e| format!("{e:.1}")).collect();
            details.push(format!(
                "{resolution}², F = {supersample}: seeds 1–{seeds}: {} mm; {:.2}–{:.2} s per fit",
                per_seed.join(", "),
                seconds.iter().copied().fold(f64::INFINITY, f64::min),
                seconds.iter().copied().fold(0.0, f64::max)
            ));
            cells.push(format!("{:.1}", median(errors)));
        }
        println!("| {resolution}² | {} | {} |", cells[0], cells[1]);
    }
    for line in details {
        println!("{line}");
    }
    Ok(())
}

fn main() {
    let o = Options::parse();
    if let Err(e) = run(&o) {
        eprintln!("fit_pose: {e}");
        std::process::exit(1);
    }
}

fn run(o: &Options) -> Result<(), Box<dyn std::error::Error>> {
    let (model, name) = load_model(o)?;
    if let Some(seeds) = o.ablation {
        return ablation(&model, &name, o, seeds);
    }
    println!(
        "{name}: {} vertices, {} triangles, {} joints; {} views at {}², F = {}, seed {}",
        model.vertex_count(),
        model.mesh.triangles().len(),
        model.joint_count(),
        o.views,
        o.resolution,
        o.supersample,
        o.seed
    );
    let outcome = fit(&model, o, true, false)?;
    println!(
        "final: per_vertex_error_mm={:.2} iterations={} seconds={:.3} backend={} model={name}",
        outcome.error_m * 1000.0,
        outcome.steps,
        outcome.seconds,
        outcome.backend.replace(' ', "_")
    );
    Ok(())
}

//! The example's command line (`Options`, parsed by clap), the model it names (`load_model`) and
//! the library's `FitOptions` it asks for (`fit_options`).

use std::path::PathBuf;

use clap::Parser;
use diffsil::io::gltf::{load_gltf, Model};
use diffsil::pose::figure::builtin_figure;
use diffsil::pose::fit::{Convergence, FitOptions, PoseFit, Schedule, SwapScreen};
use diffsil::pose::makehuman_body;
use diffsil::pose::skin::{Pose, SkinnedMesh};
use diffsil::Vec3;

use super::common::{finite, size, BackendName};
use super::evaluate::seed_range;
use super::masks::MaskNoise;
use super::rig::Layout;

/// Command-line options (`fit_pose --help`).
#[derive(Clone, Debug, Parser)]
#[command(
    name = "fit_pose",
    about = "Fit a skinned mesh's pose to multi-view silhouettes",
    after_help = "\
Method (diffsil::pose::fit::fit, FitOptions::default()): E = E_sl + λ·E_spt + μ·E_prior, where
E_sl is the mean squared error over all pixels of all views between the rendered and target
silhouettes, both blurred by the same Gaussian, and E_prior = mean_j |θ_j|² a zero-mean prior on
the joint offsets, μ = 2e-3 unblurred and 10 times that while blurred. Each of the three
starting poses (rest, legs striding each way) runs 1/10 of the steps with a blur of 6% of the
image height, on a coarse proxy of the mesh (its vertices clustered on a grid of 2% of the
model's height, --coarse-proxy); the one with the lowest unblurred energy E continues: 1/20 of
the steps at 6% (on the proxy too),
1/12 at 3%, the rest (170 of 300) unblurred, ending early once the mean energy of the last 25
steps is less than 0.5% below that of the 25 before. An outline nuisance a (--outline) grows or
shrinks every render by up to one pixel before it is compared, so that masks a pixel too fat or
too thin do not twist the pose (--outline-settle X drops it for the unblurred steps when the
blurred ones end with |a| below X; --warmup K ramps the learning rate up over the first K
unblurred steps; both off by default). Then the swap test: each leg and arm mirrored front to
back, each forearm turned about its upper arm, both legs mirrored and the legs exchanged; the
lowest in energy as it is, and any within 3 times the pose's energy, refined 10 steps beside
the pose and kept where the energy ends lower (--swap-steps, --swap-refined, --swap-within;
--head-turns adds turns of the head, off by default).
Same method and settings at every resolution and F."
)]
#[command(group(clap::ArgGroup::new("masks_alone").args(["targets", "as_user_data"])))]
#[command(group(clap::ArgGroup::new("moved_world").args(["export", "as_user_data"])))]
pub struct Options {
    /// Skinned .gltf/.glb [default: the built-in MakeHuman body, 7,000 vertices, 31 joints, 10
    /// shape targets]
    #[arg(long, value_name = "PATH")]
    pub model: Option<PathBuf>,
    /// Fit the built-in procedural figure (3,864 vertices, 24 joints) instead of the MakeHuman body
    #[arg(long, conflicts_with = "model")]
    pub figure: bool,
    /// Where the cameras sit around the model (raised: seeds 31–80 of the built-in figure end
    /// with no fit above 2% of the height, level: one at 57 mm; irregular: drawn from the seed,
    /// one rig for all the frames of `--motion`)
    #[arg(long, value_name = "LAYOUT", value_enum, default_value_t = Layout::Raised)]
    pub views: Layout,
    /// Number of cameras, azimuths evenly spaced (moved at random with irregular), at least 1
    #[arg(long, value_name = "N", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..))]
    pub view_count: u32,
    /// Image size in pixels of the example's own targets, N (square) or WxH (e.g. 640x480, a
    /// camera's; the cameras' vertical field of view frames the body either way)
    #[arg(long, value_name = "N|WxH", default_value = "64", value_parser = size)]
    pub resolution: (u32, u32),
    /// Samples per pixel side, 1 = no anti-aliasing
    #[arg(long, value_name = "F", default_value_t = 4)]
    pub supersample: u32,
    /// What is done to the target masks
    #[arg(long, value_name = "KIND", value_enum, default_value_t = MaskNoise::None)]
    pub mask_noise: MaskNoise,
    /// Fraction of pixels `--mask-noise flip` flips
    #[arg(long, value_name = "X", default_value_t = 0.02)]
    pub flip_fraction: f64,
    /// Adam steps in all, every starting pose included (fewer when the fit converges)
    #[arg(long, value_name = "N", default_value_t = 300)]
    pub iterations: u32,
    /// Adam learning rate
    #[arg(long, value_name = "X", default_value = "0.02", value_parser = finite)]
    pub lr: f32,
    /// Self-intersection weight λ; E_sl is a mean over pixels
    #[arg(long, value_name = "X", default_value = "1e-7", value_parser = finite)]
    pub lambda: f32,
    /// Steps between self-intersection checks (the steps between reuse the last check's
    /// gradient) [default: FitOptions::INTERSECTION_INTERVAL]
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(1..))]
    pub intersection_interval: Option<u32>,
    /// Leg stride (radians) of the extra starting poses; 0: none
    #[arg(long, value_name = "X", default_value = "0.3", value_parser = finite)]
    pub stride: f32,
    /// Steps of the limb swap test after the descent (limbs mirrored front to back, legs
    /// exchanged, kept where the energy ends lower); 0: none [default: FitOptions::SWAP_STEPS]
    #[arg(long, value_name = "K")]
    pub swap_steps: Option<u32>,
    /// Swap candidates refined: this many of the lowest in energy as they are (a number at
    /// least the candidates' refines all, unscreened) [default: SwapScreen::default, 1]
    #[arg(long, value_name = "K")]
    pub swap_refined: Option<usize>,
    /// Swap candidates refined besides: any whose energy as it is is at most X times the
    /// pose's [default: SwapScreen::default, 3]
    #[arg(long, value_name = "X", value_parser = finite)]
    pub swap_within: Option<f32>,
    /// Runs from the legs moved onto each other's places (refined, a second, third and fourth
    /// run) when that pose matches the masks at most X times worse than the fitted pose where
    /// their renders differ; the lowest end is kept; 0: never [default:
    /// FitOptions::CROSSED_LEGS_WITHIN, 5]
    #[arg(long, value_name = "X", value_parser = finite)]
    pub crossed_legs: Option<f32>,
    /// The second run also when that ratio is at most X and the crossed pose's squared error
    /// exceeds the fitted pose's by at most --crossed-legs-excess per changed pixel [default:
    /// FitOptions::CROSSED_LEGS_LOOSE_WITHIN, 15]
    #[arg(long, value_name = "X", value_parser = finite)]
    pub crossed_legs_loose: Option<f32>,
    /// The largest excess per changed pixel for --crossed-legs-loose; 0: that rule off
    /// [default: FitOptions::CROSSED_LEGS_EXCESS, 0.1]
    #[arg(long, value_name = "X", value_parser = finite)]
    pub crossed_legs_excess: Option<f32>,
    /// The fourth run from the crossed legs (without the coarsest stage) kept only where it ends
    /// at most X times the other ends' lowest energy; 0: none [default:
    /// FitOptions::FOURTH_RUN_BELOW, 0.5]
    #[arg(long, value_name = "X", value_parser = finite)]
    pub fourth_run_below: Option<f32>,
    /// Head turns (±30°, ±60° about the neck) in the swap test, each kept only where it ends at
    /// most X times the pose's energy (0.85 for a big, boxy head like CesiumMan's); 0: none
    /// [default: FitOptions::head_turn_below, 0]
    #[arg(long, value_name = "X", value_parser = finite)]
    pub head_turns: Option<f32>,
    /// Arm swing (radians) of the restart where the fit misses a piece of a target at least two
    /// pixels wide; 0: no restart [default: FitOptions::RESTART_ARM_SWING, 0.4]
    #[arg(long, value_name = "X", value_parser = finite)]
    pub restart_arm_swing: Option<f32>,
    /// No restarts where the targets look thinned (FitOptions::thinned_restarts: the fit's
    /// outline nuisance at or below −0.5, masks eroded by a pixel)
    #[arg(long)]
    pub no_thinned_restarts: bool,
    /// No last run from the lowest end where the targets look thinned
    /// (FitOptions::thinned_final_run)
    #[arg(long)]
    pub no_thinned_final_run: bool,
    /// Steps of the polish that ends the fit (unblurred, at a quarter and then a tenth of the
    /// learning rate, kept where the energy ends lower); 0: none [default:
    /// FitOptions::POLISH_STEPS, 40]
    #[arg(long, value_name = "N")]
    pub polish_steps: Option<u32>,
    /// Cell of the coarse proxy the steps at the coarsest blur render (the mesh's vertices
    /// clustered, one kept per cell and dominant joint), as a fraction of the model's height; 0:
    /// the whole mesh [default: FitOptions::COARSE_PROXY = 0.02]
    #[arg(long, value_name = "X", value_parser = finite)]
    pub coarse_proxy: Option<f32>,
    /// Arm swing (radians) of the extra starting poses; 0: none
    #[arg(long, value_name = "X", default_value = "0", value_parser = finite)]
    pub arm_swing: f32,
    /// Weight μ of the pose prior μ·mean_j |θ_j|² in the unblurred stage [default: PoseFit::POSE_PRIOR = 2e-3]
    #[arg(long, value_name = "X", default_value_t = PoseFit::POSE_PRIOR, hide_default_value = true, value_parser = finite)]
    pub prior: f32,
    /// The pose prior's weight in the blurred stages, as a multiple of μ (1: μ throughout)
    /// [default: Schedule::COARSE_PRIOR_SCALE = 10]
    #[arg(long, value_name = "X", default_value_t = Schedule::COARSE_PRIOR_SCALE, hide_default_value = true, value_parser = finite)]
    pub coarse_prior_scale: f32,
    /// Run every step: no early stop on convergence
    #[arg(long)]
    pub no_early_stop: bool,
    /// Cancel a fit after this many seconds (it keeps the pose it reached)
    #[arg(long, value_name = "S")]
    pub time_limit: Option<f64>,
    /// Keep the global orientation and translation at the start's (the rest pose's)
    #[arg(long)]
    pub no_global: bool,
    /// Random shape too: β_k uniform in ±0.3 per morph target as ground truth, fitted jointly
    /// with the pose (needs a model with morph targets)
    #[arg(long)]
    pub shape: bool,
    /// Fit an inflation of the body along its normals beside the pose (FitOptions::fit_inflation):
    /// on, off, or the library's choice (on where the masks are downsampled for the fit, in
    /// place of the outline: FitOptions::for_downsampled)
    #[arg(long, value_name = "ON", value_parser = clap::value_parser!(bool))]
    pub inflation: Option<bool>,
    /// Step of the inflation per Adam step, fraction of the model's height
    #[arg(long, value_name = "X", default_value_t = FitOptions::INFLATION_RATE, value_parser = finite)]
    pub inflation_rate: f32,
    /// Fit an outline nuisance beside the pose (FitOptions::fit_outline): the renders grown or
    /// shrunk by up to one pixel before they are compared; on, off, or the library's choice (on
    /// where the masks are fitted as they are)
    #[arg(long, value_name = "ON", value_parser = clap::value_parser!(bool))]
    pub outline: Option<bool>,
    /// Step of the outline nuisance per Adam step (it spans [−1, 1])
    #[arg(long, value_name = "X", default_value_t = FitOptions::OUTLINE_RATE, value_parser = finite)]
    pub outline_rate: f32,
    /// The unblurred steps drop the outline nuisance (a = 0, no longer fitted) when the blurred
    /// ones end with |a| below this, e.g. 0.1 (0.8 times the time with exact masks); 0 keeps
    /// it (FitOptions::outline_settle)
    #[arg(long, value_name = "X", default_value_t = 0.0, value_parser = finite)]
    pub outline_settle: f32,
    /// Steps over which the unblurred stage ramps up the learning rate, e.g. 10; 0: none
    /// (FitOptions::warmup)
    #[arg(long, value_name = "K", default_value_t = 0)]
    pub warmup: u32,
    /// Plain descent: rest pose only, no blur, no prior, no early stop (the paper's method)
    #[arg(long)]
    pub plain: bool,
    /// Seed of the ground-truth pose (and of `--views irregular`'s rig; with `--motion`, of the
    /// rig alone)
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// Evaluate over a range of seeds, e.g. 31-80: per-seed errors, median, p90, worst,
    /// failures (above 2% of the body height) and seconds per fit
    #[arg(long, value_name = "A-B", value_parser = seed_range)]
    pub seeds: Option<(u64, u64)>,
    /// Which engine renders
    #[arg(long, value_name = "NAME", value_enum, default_value_t = BackendName::Cpu)]
    pub backend: BackendName,
    /// Where the PNGs go
    #[arg(long, value_name = "DIR", default_value = "fit_pose_out")]
    pub out: PathBuf,
    /// Also write the fitted posed mesh (`fitted.glb`, `fitted.obj`) and the fitted pose and
    /// shape (`fitted_pose.json`) to `--out`
    #[arg(long)]
    pub save: bool,
    /// Run N seeds for {32², 64²} × {F = 1, F = 4} and print the median errors
    #[arg(long, value_name = "N")]
    pub ablation: Option<u32>,
    /// Ground truths from a glTF animation of `--model` (its name or index) instead of random
    /// poses: one fit per frame, evaluated like `--seeds`
    #[arg(long, value_name = "CLIP")]
    pub motion: Option<String>,
    /// Frames of `--motion`: every k-th key of the clip's most detailed channel, k chosen to give
    /// this many
    #[arg(long, value_name = "N", default_value_t = 12)]
    pub frames: usize,
    /// Fit only this frame of `--motion` (0-based, of the `--frames`), verbose, with pictures
    #[arg(long, value_name = "K", requires = "motion")]
    pub frame: Option<usize>,
    /// Your own masks, one PNG per camera of `--cameras` in the same order, comma-separated
    /// (white = the body); fits `--model` to them instead of to a random pose's silhouettes
    /// (`--resolution`, `--views`, `--view-count` and `--seed` then do not apply)
    #[arg(long, value_name = "A.png,B.png,...", value_delimiter = ',', num_args = 1.., requires = "cameras",
          conflicts_with_all = ["seeds", "ablation", "motion"])]
    pub targets: Vec<PathBuf>,
    /// Your calibrated cameras for `--targets`: a JSON list of OpenCV cameras
    /// {"width", "height", "K": [[fx,0,cx],[0,fy,cy],[0,0,1]], "R": 3×3 rows, "t": [x,y,z]}
    /// (world → camera; optional "near", "far")
    #[arg(long, value_name = "PATH", requires = "targets")]
    pub cameras: Option<PathBuf>,
    /// Harden `--targets` (or the example's own targets, before `--mask-noise`, as a
    /// segmentation's masks are): 1 where a pixel's value is above X, else 0 [default: keep
    /// values in [0, 1] as coverage]
    #[arg(long, value_name = "X", value_parser = finite)]
    pub threshold: Option<f32>,
    /// Fit where the subject (the tallest rows of white in any target mask) is at least this
    /// many pixels tall: masks and cameras downsampled by the largest whole factor that keeps it
    /// so, e.g. `--targets` at a camera's resolution or `--resolution 480` (at 64² the body is
    /// about 54 pixels tall: nothing changes); 0: at the masks' own resolution [default:
    /// FIT_SUBJECT_HEIGHT = 64]
    #[arg(long, value_name = "PX", default_value_t = diffsil::pose::fit::FIT_SUBJECT_HEIGHT)]
    pub fit_height: u32,
    /// Fit the whole masks even where the subject is small in them [default: a window about the
    /// subject in each mask, `diffsil::pose::fit::subject_windows`, where it fits in every mask
    /// and leaves out at least a quarter of one's width and height]
    #[arg(long)]
    pub no_crop: bool,
    /// Start `--targets` (or `--as-user-data`) from the model's rest pose where it was built,
    /// instead of moved to where the masks' centres of coverage meet
    /// (`diffsil::pose::fit::triangulate_masks`)
    #[arg(long, requires = "masks_alone")]
    pub no_placement: bool,
    /// Which way the subject faces, about its vertical (the model's up, stood along `--up`):
    /// `auto` tries the model's front and three quarter turns from it and keeps the facing whose
    /// starting poses fit best after the first steps (`FitOptions::ANY_FACING`); a number of
    /// degrees starts the model turned by that much through its centre and keeps it (the fit
    /// turns a body by itself only part of the way: one facing away from the model's front
    /// ends fitted back to front). `--plain` has no starting poses' steps: `auto` is 0 there
    /// [default: auto with `--targets` and `--as-user-data`, 0 for the example's own targets]
    #[arg(long, value_name = "auto|DEG", value_parser = facing)]
    pub facing: Option<Facing>,
    /// With `--facing auto`: where the second-best facing's energy after the first steps is
    /// within X times the best one's, the first pass runs from it as well and the lower end is
    /// kept (`FitOptions::facing_within`); 0: never [default: FitOptions::FACING_WITHIN, 1.25]
    #[arg(long, value_name = "X", value_parser = finite)]
    pub facing_within: Option<f32>,
    /// Turn the example's own ground truth by this many degrees about its vertical (e.g. 180:
    /// facing away from the model's front)
    #[arg(long, value_name = "DEG", default_value_t = 0.0, value_parser = finite, conflicts_with = "targets")]
    pub turn: f32,
    /// Write the example's own targets (`mask0.png`, …), their cameras (`cameras.json`, as
    /// `--cameras` reads them) and the ground truth (`truth.json`) to this folder instead of
    /// fitting them, for a fit with `--targets`, `--cameras` and `--truth`
    #[arg(long, value_name = "DIR", conflicts_with_all = ["targets", "seeds", "motion", "ablation"])]
    pub export: Option<PathBuf>,
    /// `--export` (or `--as-user-data`) in a world whose up is this axis (`+x`, `-x`, `+y`,
    /// `-y`, `+z`, `-z`) or direction (`X,Y,Z`), as a calibration's world may be: the cameras
    /// and the truth turned by the shortest turn from +y to it (for -y the half turn about x)
    #[arg(long, value_name = "AXIS|X,Y,Z", value_parser = direction, requires = "moved_world", allow_hyphen_values = true)]
    pub world_up: Option<Vec3>,
    /// `--export` (or `--as-user-data`) in a world whose origin is this far from the model's
    /// (`X,Y,Z` in the model's units), as a calibration's origin is wherever its target lay
    #[arg(long, value_name = "X,Y,Z", value_parser = vector, requires = "moved_world", allow_hyphen_values = true)]
    pub world_offset: Option<Vec3>,
    /// Fit the example's own targets as `--targets` data are fitted: from the masks and cameras
    /// alone (the placement, the up and the facing found from them, the masks downsampled to
    /// `--fit-height`), reporting the error against the truth; with `--world-up` and
    /// `--world-offset` in a world turned and moved (what `--export` then `--targets` do, in
    /// one process and over `--seeds`)
    #[arg(long, conflicts_with_all = ["targets", "export"])]
    pub as_user_data: bool,
    /// The ground truth of `--targets` (a pose and shape JSON as `--save` and `--export` write
    /// them): the fit then reports its per-vertex error
    #[arg(long = "truth", value_name = "FILE", requires = "targets")]
    pub truth_file: Option<PathBuf>,
    /// The world's up in `--cameras`' world (or `--as-user-data`'s), along which the model (upright along +y) is stood:
    /// `auto` takes the cameras' mean up (`diffsil::pose::fit::world_up`), the nearest axis
    /// where within 30° of one, e.g. +z for a calibration whose target lay on the floor; or one
    /// of `+x`, `-x`, `+y`, `-y`, `+z`, `-z`
    #[arg(long, value_name = "auto|AXIS", default_value = "auto", value_parser = up, requires = "masks_alone")]
    pub up: Up,
    /// The pose a fit starts from, when not the rest pose (set by the placement of `--targets`).
    #[arg(skip)]
    pub initial: Option<Pose>,
    /// The ground-truth pose, when not drawn from the seed (set by `--motion`).
    #[arg(skip)]
    pub truth: Option<Pose>,
    /// The seed of `--views irregular`'s rig when not `seed` (`--motion`: one rig for the clip).
    #[arg(skip)]
    pub rig_seed: Option<u64>,
}

impl Options {
    /// `--resolution` as the reports print it: `64²`, or `640x480`.
    pub fn resolution_text(&self) -> String {
        match self.resolution {
            (w, h) if w == h => format!("{w}²"),
            (w, h) => format!("{w}x{h}"),
        }
    }

    /// `--facing`, or its default: `auto` for `--targets` and `--as-user-data`, the model's
    /// front (0) for the example's own targets.
    pub fn facing(&self) -> Facing {
        self.facing.unwrap_or(if self.masks_alone() { Facing::Auto } else { Facing::Degrees(0.0) })
    }

    /// Whether the fit sees masks and cameras alone: `--targets`, or `--as-user-data`.
    pub fn masks_alone(&self) -> bool {
        !self.targets.is_empty() || self.as_user_data
    }
}

/// `--facing`: tried from the masks, or given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Facing {
    /// The four facings of `FitOptions::ANY_FACING`, the best kept.
    Auto,
    /// The model turned by this many degrees.
    Degrees(f32),
}

/// Parses `--facing`: `auto` or a finite number of degrees.
fn facing(value: &str) -> Result<Facing, String> {
    if value == "auto" {
        Ok(Facing::Auto)
    } else {
        finite(value).map(Facing::Degrees).map_err(|e| format!("{e} (or `auto`)"))
    }
}

/// `--up`: read from the cameras, or given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Up {
    /// The cameras' mean up, snapped to the nearest axis within 30°.
    Auto,
    /// This unit axis.
    Axis(Vec3),
}

/// Parses `--up`: `auto` or a signed axis.
fn up(value: &str) -> Result<Up, String> {
    if value == "auto" {
        return Ok(Up::Auto);
    }
    axis(value).map(Up::Axis).map_err(|_| format!("`{value}`: use auto, +x, -x, +y, -y, +z or -z"))
}

/// Parses a signed axis: `+x`, `-x`, `+y`, `-y`, `+z`, `-z` (the sign of + optional).
fn axis(value: &str) -> Result<Vec3, String> {
    match value {
        "+x" | "x" => Ok(Vec3::X),
        "-x" => Ok(Vec3::NEG_X),
        "+y" | "y" => Ok(Vec3::Y),
        "-y" => Ok(Vec3::NEG_Y),
        "+z" | "z" => Ok(Vec3::Z),
        "-z" => Ok(Vec3::NEG_Z),
        _ => Err(format!("`{value}`: use +x, -x, +y, -y, +z or -z")),
    }
}

/// Parses a direction: a signed axis ([`axis`]) or `X,Y,Z`, not zero.
fn direction(value: &str) -> Result<Vec3, String> {
    axis(value).or_else(|_| match vector(value) {
        Ok(v) if v.length() > 1e-6 => Ok(v.normalize()),
        _ => Err(format!("`{value}`: use +x, -x, +y, -y, +z, -z or a direction X,Y,Z other than 0,0,0")),
    })
}

/// Parses `X,Y,Z`: three finite numbers.
fn vector(value: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = value.split(',').collect();
    match parts.as_slice() {
        [x, y, z] => Ok(Vec3::new(finite(x)?, finite(y)?, finite(z)?)),
        _ => Err(format!("`{value}`: give three numbers, X,Y,Z")),
    }
}

/// The model `o` names: `--model`'s glTF (which must have a skin), the built-in figure with
/// `--figure`, else the MakeHuman body shipped in the crate; with its name for the report.
pub fn load_model(o: &Options) -> Result<(SkinnedMesh, String), Box<dyn std::error::Error>> {
    match &o.model {
        None if o.figure => Ok((builtin_figure(), "builtin-figure".into())),
        None => Ok((makehuman_body()?, "makehuman-body-7k".into())),
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

/// The fitting method's options for these command-line options.
pub fn fit_options(o: &Options) -> FitOptions {
    let defaults = FitOptions::default();
    if o.plain {
        return FitOptions {
            steps: o.iterations,
            learning_rate: o.lr,
            lambda: o.lambda,
            intersection_interval: o.intersection_interval.unwrap_or(1),
            pose_prior: 0.0,
            coarse_blur: 0.0,
            convergence: None,
            fit_global: !o.no_global,
            swap_steps: 0,
            crossed_legs_within: 0.0,
            restart_arm_swing: 0.0,
            thinned_restarts: Vec::new(),
            thinned_final_run: false,
            polish_steps: 0,
            initial: o.initial.clone(),
            ..defaults
        };
    }
    FitOptions {
        steps: o.iterations,
        learning_rate: o.lr,
        lambda: o.lambda,
        intersection_interval: o.intersection_interval.unwrap_or(defaults.intersection_interval),
        pose_prior: o.prior,
        coarse_prior_scale: o.coarse_prior_scale,
        leg_stride: o.stride,
        arm_swing: o.arm_swing,
        convergence: if o.no_early_stop { None } else { Some(Convergence::default()) },
        fit_global: !o.no_global,
        fit_shape: o.shape,
        fit_inflation: o.inflation.unwrap_or(defaults.fit_inflation),
        inflation_rate: o.inflation_rate,
        fit_outline: o.outline.unwrap_or(defaults.fit_outline),
        outline_rate: o.outline_rate,
        outline_settle: o.outline_settle,
        warmup: o.warmup,
        swap_steps: o.swap_steps.unwrap_or(defaults.swap_steps),
        coarse_proxy: o.coarse_proxy.unwrap_or(defaults.coarse_proxy),
        swap_screen: SwapScreen {
            lowest: o.swap_refined.unwrap_or(defaults.swap_screen.lowest),
            within: o.swap_within.map_or(defaults.swap_screen.within, f64::from),
        },
        crossed_legs_within: o.crossed_legs.map_or(defaults.crossed_legs_within, f64::from),
        facing_within: o.facing_within.map_or(defaults.facing_within, f64::from),
        crossed_legs_loose_within: o.crossed_legs_loose.map_or(defaults.crossed_legs_loose_within, f64::from),
        crossed_legs_excess: o.crossed_legs_excess.map_or(defaults.crossed_legs_excess, f64::from),
        fourth_run_below: o.fourth_run_below.map_or(defaults.fourth_run_below, f64::from),
        head_turn_below: o.head_turns.map_or(defaults.head_turn_below, f64::from),
        restart_arm_swing: o.restart_arm_swing.unwrap_or(defaults.restart_arm_swing),
        thinned_restarts: if o.no_thinned_restarts { Vec::new() } else { defaults.thinned_restarts.clone() },
        thinned_final_run: defaults.thinned_final_run && !o.no_thinned_final_run,
        polish_steps: o.polish_steps.unwrap_or(defaults.polish_steps),
        initial: o.initial.clone(),
        // `--facing auto` (the default with `--targets`: the user's subject may face any way)
        // tries four facings; a given facing turns the start instead (`fit_seed`, `user_fit.rs`).
        facings: if o.facing() == Facing::Auto { FitOptions::ANY_FACING.to_vec() } else { Vec::new() },
        ..defaults
    }
}

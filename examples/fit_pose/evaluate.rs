//! The example's evaluation over seeds and frames (`--seeds`, `--motion` and its ground-truth
//! frames) and the paper's Table 2 (`--ablation`): errors, their median, p90 and worst,
//! failures, wall and CPU time.

use diffsil::pose::fit::{CrossedLegsEnd, CrossedRunStart};
use diffsil::pose::skin::{Pose, SkinnedMesh};

use super::common::median;
use super::{fit_seed, load_model, Options};

/// CPU time this process has used (user + system), seconds; `None` where `/proc` is missing.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which is in parentheses and may hold spaces).
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    // Linux reports these in USER_HZ, 100 on every mainstream configuration.
    Some(ticks / 100.0)
}

/// The value below which `q` of the sorted `v` lie (nearest rank); NaN when empty.
fn quantile(v: &[f64], q: f64) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return f64::NAN;
    }
    let rank = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len());
    v[rank - 1]
}

/// Fits every case (a label and its options) and prints each error and the summary.
pub fn evaluate(
    model: &SkinnedMesh,
    name: &str,
    o: &Options,
    what: &str,
    cases: Vec<(String, Options)>,
) -> Result<(), Box<dyn std::error::Error>> {
    println!(
        "{name}: {what}, {} {:?} views at {}, F = {}, masks {:?}{}, {}{}",
        o.view_count,
        o.views,
        o.resolution_text(),
        o.supersample,
        o.mask_noise,
        o.threshold.map_or(String::new(), |t| format!(" (hardened at {t})")),
        if o.plain { "plain descent" } else { "fit::fit" },
        if o.as_user_data { " from the masks and cameras alone (--as-user-data)" } else { "" }
    );
    let (mut errors, mut seconds, mut steps, mut second_runs, mut restarts) = (Vec::new(), 0.0, 0u64, 0, 0);
    let (mut thinned, mut facing_runs) = (0, 0);
    let mut height = 0.0;
    let cpu_before = cpu_seconds();
    for (label, case) in cases {
        let outcome = fit_seed(model, &case, false, true)?;
        println!(
            "{label}: {:.1} mm, {} steps ({:?}), {:.2} s{}{}{}{}{}",
            outcome.error_m * 1000.0,
            outcome.steps,
            outcome.stop,
            outcome.seconds,
            outcome.swap.map_or(String::new(), |s| format!(", swapped {s:?}")),
            match outcome.crossed {
                Some((true, CrossedLegsEnd::FirstRun)) => ", runs from the legs crossed over: not kept",
                Some((_, CrossedLegsEnd::Refined)) => ", the legs crossed over refined: kept",
                Some((_, CrossedLegsEnd::Run(CrossedRunStart::AboutCrossed))) => {
                    ", second run from the legs crossed over: kept"
                }
                Some((_, CrossedLegsEnd::Run(CrossedRunStart::CrossedAlone))) => {
                    ", third run (from the legs crossed over alone): kept"
                }
                Some((_, CrossedLegsEnd::Run(CrossedRunStart::AboutCrossedWithoutCoarsest))) => {
                    ", fourth run (from the legs crossed over, without the coarsest stage): kept"
                }
                Some((false, CrossedLegsEnd::FirstRun)) | None => "",
            },
            match outcome.facing_run {
                Some(true) => ", runner-up facing: kept",
                Some(false) => ", runner-up facing: not kept",
                None => "",
            },
            match outcome.restart {
                Some(true) => ", restart: kept",
                Some(false) => ", restart: not kept",
                None => "",
            },
            if outcome.thinned { " (targets thinned)" } else { "" }
        );
        errors.push(outcome.error_m * 1000.0);
        seconds += outcome.seconds;
        steps += u64::from(outcome.steps);
        second_runs += usize::from(matches!(outcome.crossed, Some((true, _))));
        restarts += usize::from(outcome.restart.is_some());
        thinned += usize::from(outcome.thinned);
        facing_runs += usize::from(outcome.facing_run.is_some());
        height = outcome.height_m;
    }
    let fits = errors.len() as f64;
    let cpu = match (cpu_before, cpu_seconds()) {
        (Some(a), Some(b)) => format!("{:.2}", (b - a) / fits),
        _ => "n/a".into(),
    };
    let limit_mm = 0.02 * height * 1000.0;
    let failures = errors.iter().filter(|e| **e > limit_mm).count();
    println!(
        "summary: median={:.1}mm p90={:.1}mm worst={:.1}mm failures={failures}/{} (above {limit_mm:.0} mm = 2% of \
         {:.2} m) wall_s_per_fit={:.2} cpu_s_per_fit={cpu} steps_per_fit={:.0} second_runs={second_runs} \
         restarts={restarts} thinned={thinned} facing_runs={facing_runs}",
        median(errors.clone()),
        quantile(&errors, 0.9),
        errors.iter().copied().fold(0.0, f64::max),
        errors.len(),
        height,
        seconds / fits,
        steps as f64 / fits
    );
    Ok(())
}

/// The paper's Table 2 over `seeds` seeds: the median error at 32² and 64², with and without
/// anti-aliasing (F = 4 and 1).
pub fn ablation(model: &SkinnedMesh, name: &str, o: &Options, seeds: u32) -> Result<(), Box<dyn std::error::Error>> {
    let method = if o.plain { "plain descent" } else { "fit::fit" };
    println!(
        "median per-vertex error (mm) over {seeds} seeds, {name}, {} {:?} views, {} iterations, {method}",
        o.view_count, o.views, o.iterations
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
                let run = Options { resolution: (resolution, resolution), supersample, seed, ..o.clone() };
                let outcome = fit_seed(model, &run, false, true)?;
                errors.push(outcome.error_m * 1000.0);
                seconds.push(outcome.seconds);
            }
            let per_seed: Vec<String> = errors.iter().map(|e| format!("{e:.1}")).collect();
            details.push(format!(
                "{resolution}², F = {supersample}: seeds 1–{seeds}: {} mm; p90 {:.1}, worst {:.1}; {:.2}–{:.2} s per fit",
                per_seed.join(", "),
                quantile(&errors, 0.9),
                errors.iter().copied().fold(0.0, f64::max),
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

/// The `--frames` poses of `--motion` and their times: every k-th key time of the clip's channel
/// with the most keys.
pub fn motion_frames(o: &Options, clip: &str) -> Result<Vec<(f32, Pose)>, Box<dyn std::error::Error>> {
    let path = o.model.as_ref().ok_or("--motion needs --model (a glTF with animations)")?;
    let (model, _) = load_model(o)?;
    let clips = diffsil::io::gltf::load_animations(path)?;
    let animation = clips
        .iter()
        .find(|a| a.name == clip)
        .or_else(|| clip.parse::<usize>().ok().and_then(|k| clips.get(k)))
        .ok_or_else(|| {
            let names: Vec<&str> = clips.iter().map(|a| a.name.as_str()).collect();
            format!("{}: no clip {clip:?} (clips: {names:?}, or an index)", path.display())
        })?;
    let times = &animation.channels.iter().max_by_key(|c| c.times.len()).ok_or("the clip has no channels")?.times;
    let step = (times.len() / o.frames.max(1)).max(1);
    let mut frames = Vec::new();
    for &time in times.iter().step_by(step).take(o.frames) {
        frames.push((time, animation.sample(&model.skeleton, time)?));
    }
    Ok(frames)
}

/// `A-B` (inclusive, A ≤ B) or a single seed.
pub fn seed_range(value: &str) -> Result<(u64, u64), String> {
    let parse = |s: &str| s.trim().parse::<u64>().map_err(|e| format!("{e}"));
    let (a, b) = match value.split_once('-') {
        Some((a, b)) => (parse(a)?, parse(b)?),
        None => (parse(value)?, parse(value)?),
    };
    if a <= b {
        Ok((a, b))
    } else {
        Err("use A-B with A ≤ B".into())
    }
}

//! The seeded fuzzing of issue 13, shared by `tests/pose/fuzz.rs` (every loader, and random
//! extreme scenes on the CPU engine) and `tests/gpu/bad_input.rs` (a few scenes on the GPU).
//!
//! - [`run_cases`] runs numbered cases on a worker thread, each under [`CASE_DEADLINE`]: a panic
//!   is caught and recorded with its case number, a case past the deadline fails the test at
//!   once (a hang), and a case's `Err` is a violated property (e.g. a NaN in an `Ok` result).
//! - [`mutate`] applies 1–4 random edits (bit flips, interesting bytes and 32-bit words,
//!   truncation, deleted or duplicated ranges, extreme numbers in text, dictionary words such as
//!   `../` or `/dev/zero`) to a seed file, driven by `SplitMix64` (reproducible per case).
//! - [`Scene`] is a random scene of extreme but mostly finite values (coordinates near 0,
//!   1e-38, 1e18, 3e38, `f32::MAX`; resolutions from 1 to 16384; F from 0 to 17; pixel values
//!   and `∂L/∂I` up to 3e38), and [`Scene::check`] runs it through render, backward, the fused
//!   step, both losses and Adam, requiring an error or finite values.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant};

use diffsil::optim::Adam;
use diffsil::{loss, Camera, Image, Mesh, RenderSettings, Renderer, ScreenView, Targets, Topology, Vec2, Vec3};

use super::rng::{Draws, SplitMix64};

/// The longest one case may take before the run counts it as a hang.
pub const CASE_DEADLINE: Duration = Duration::from_secs(5);

/// `name` from the environment as a count, else `default` (the CI budget).
pub fn env_count(name: &str, default: usize) -> usize {
    match std::env::var(name) {
        Ok(v) => v.parse().unwrap_or_else(|_| panic!("{name}={v} is not a count")),
        Err(_) => default,
    }
}

/// The seed of a fuzz run: `DIFFSIL_FUZZ_SEED`, else 13.
pub fn fuzz_seed() -> u64 {
    env_count("DIFFSIL_FUZZ_SEED", 13) as u64
}

/// What a run saw.
#[derive(Debug, Default)]
pub struct Summary {
    /// Cases run.
    pub cases: usize,
    /// Cases whose call returned `Ok`.
    pub ok: usize,
    /// Longest case.
    pub slowest: Duration,
    /// Total time.
    pub elapsed: Duration,
}

/// One case's outcome: `Ok(true)` when the loader or renderer accepted the input, `Ok(false)`
/// when it returned a (good) error, `Err` for a violated property.
pub type Outcome = Result<bool, String>;

/// Runs cases `0..count` of `case` on one worker thread, each within [`CASE_DEADLINE`], and fails
/// the test on a hang, on any panic, or on any violated property (listing the first ten with
/// their case numbers). Returns what the run saw.
pub fn run_cases(name: &str, count: usize, case: impl Fn(usize) -> Outcome + Send + 'static) -> Summary {
    let (tx, rx) = mpsc::channel();
    let start = Instant::now();
    let worker = std::thread::Builder::new()
        .name(format!("fuzz {name}"))
        .spawn(move || {
            for i in 0..count {
                let t = Instant::now();
                let outcome = catch_unwind(AssertUnwindSafe(|| case(i))).unwrap_or_else(|payload| {
                    let text = payload
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_default();
                    Err(format!("panicked: {text}"))
                });
                if tx.send((i, outcome, t.elapsed())).is_err() {
                    return;
                }
            }
        })
        .unwrap();
    let mut summary = Summary::default();
    let mut failures = Vec::new();
    for expected in 0..count {
        match rx.recv_timeout(CASE_DEADLINE) {
            Ok((i, outcome, took)) => {
                assert_eq!(i, expected);
                summary.cases += 1;
                summary.slowest = summary.slowest.max(took);
                match outcome {
                    Ok(accepted) => summary.ok += usize::from(accepted),
                    Err(e) => failures.push(format!("case {i}: {e}")),
                }
            }
            Err(_) => panic!("{name}: case {expected} did not finish within {CASE_DEADLINE:?} (a hang)"),
        }
    }
    worker.join().unwrap();
    summary.elapsed = start.elapsed();
    println!(
        "{name}: {} cases, {} accepted, {} failures, slowest {:?}, total {:?}",
        summary.cases,
        summary.ok,
        failures.len(),
        summary.slowest,
        summary.elapsed
    );
    assert!(
        failures.is_empty(),
        "{name}: {} failures:\n{}",
        failures.len(),
        failures[..failures.len().min(10)].join("\n")
    );
    summary
}

/// Numbers that break parsers and arithmetic, as text.
const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "-1",
    "1e38",
    "-3e38",
    "3.4028235e38",
    "1e-40",
    "1e-38",
    "4294967295",
    "4294967296",
    "99999999999",
    "-9223372036854775808",
    "nan",
    "inf",
    "-inf",
    "1e309",
    "2147483648",
    "65535",
    "65536",
    "256",
];
/// Words worth splicing into text formats.
const WORDS: &[&str] = &[
    "../",
    "%2e%2e/",
    "/dev/zero",
    "/etc/passwd",
    "../sentinel.bin",
    "f 1 2 99\n",
    "v 1e38 1e38 1e38\n",
    "f -9 -8 -7\n",
    "{",
    "}",
    "[",
    "]",
    ",",
    ":",
    "\"",
    "null",
    "true",
    "\"uri\":\"../sentinel.bin\"",
    "\\u0000",
    "data:,",
];

/// The seed file with 1–4 random edits.
pub fn mutate(rng: &mut SplitMix64, seed: &[u8]) -> Vec<u8> {
    let mut data = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        let len = data.len();
        match rng.below(9) {
            0 if len > 0 => {
                let at = rng.below(len);
                data[at] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let at = rng.below(len);
                data[at] = [0u8, 1, 0x7f, 0x80, 0xff, b'-', b'9', b'.', b'e', b'"', b'/'][rng.below(11)];
            }
            2 => data.truncate(rng.below(len + 1)),
            3 if len > 0 => {
                let at = rng.below(len);
                let end = (at + 1 + rng.below(16)).min(len);
                data.drain(at..end);
            }
            4 if len > 0 => {
                let at = rng.below(len);
                let end = (at + 1 + rng.below(64)).min(len);
                let copy = data[at..end].to_vec();
                let to = rng.below(len + 1);
                data.splice(to..to, copy);
            }
            5 if len >= 4 => {
                let at = rng.below(len - 3);
                let word = [0u32, 1, 0x7fff_ffff, 0x8000_0000, u32::MAX, 0x1_0000, len as u32, 12, 20][rng.below(9)];
                data[at..at + 4].copy_from_slice(&word.to_le_bytes());
            }
            6 => {
                // Replace a number in the text (the first digit run after a random point).
                let from = rng.below(len + 1);
                if let Some(start) = data[from..].iter().position(u8::is_ascii_digit).map(|p| p + from) {
                    let end =
                        data[start..].iter().position(|b| !b.is_ascii_digit() && *b != b'.').map_or(len, |p| p + start);
                    let number = NUMBERS[rng.below(NUMBERS.len())].as_bytes().to_vec();
                    data.splice(start..end, number);
                }
            }
            7 => {
                let to = rng.below(len + 1);
                data.splice(to..to, WORDS[rng.below(WORDS.len())].bytes());
            }
            _ => {
                // Repeat the file's second half (counts and lengths no longer match).
                let half = data[len / 2..].to_vec();
                data.extend(half);
            }
        }
    }
    data
}

/// A value from the extremes: mostly moderate, often at the edges of f32, rarely NaN or ∞.
pub fn extreme(rng: &mut SplitMix64) -> f32 {
    let sign = if rng.below(2) == 0 { 1.0 } else { -1.0 };
    sign * match rng.below(24) {
        0 => 0.0,
        1 => 1e-38,
        2 => 1e-45,
        3 => 1e18,
        4 => 3e38,
        5 => f32::MAX,
        6 => 1e6,
        7 => 2e19,
        8 if rng.below(4) == 0 => f32::NAN,
        9 if rng.below(4) == 0 => f32::INFINITY,
        _ => rng.signed_f32() * 3.0,
    }
}

/// A random scene of extreme values, for [`Scene::check`].
#[derive(Clone, Debug)]
pub struct Scene {
    pub settings: RenderSettings,
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    pub cameras: Vec<Camera>,
    pub screen: Vec<Vec<Vec2>>,
    pub d_value: f32,
    pub target_value: f32,
    pub learning_rate: f32,
}

impl Scene {
    /// Scene `case` of the run seeded with `seed`.
    pub fn random(seed: u64, case: usize) -> Scene {
        let rng = &mut SplitMix64::new(seed ^ (case as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let coordinate = |rng: &mut SplitMix64| if rng.below(3) == 0 { extreme(rng) } else { rng.signed_f32() };
        let vertices = 3 + rng.below(6);
        let positions: Vec<Vec3> =
            (0..vertices).map(|_| Vec3::new(coordinate(rng), coordinate(rng), coordinate(rng))).collect();
        let triangles = (0..1 + rng.below(6))
            .map(|_| {
                // Now and then an index past the vertices.
                let index = |rng: &mut SplitMix64| {
                    let extra = usize::from(rng.below(40) == 0);
                    rng.below(vertices + extra) as u32
                };
                [index(rng), index(rng), index(rng)]
            })
            .collect();
        let supersample = [1, 2, 3, 4, 4, 4, 5, 8, 16, 0, 17][rng.below(11)];
        let pixel = |rng: &mut SplitMix64, typical: f32| if rng.below(4) == 0 { extreme(rng) } else { typical };
        let settings = RenderSettings { supersample, inside: pixel(rng, 1.0), outside: pixel(rng, 0.0) };
        let size = |rng: &mut SplitMix64| match rng.below(40) {
            0 => 0,
            1 => 16385,
            _ => 1 + rng.below(40) as u32,
        };
        let cameras: Vec<Camera> = (0..1 + rng.below(3))
            .map(|_| {
                let (mut w, mut h) = (size(rng), size(rng));
                if rng.below(40) == 0 {
                    // Beyond the memory budget at F = 16; small enough to render otherwise.
                    (w, h) = if supersample == 16 { (16384, 16384) } else { (16384, 2) };
                }
                let eye = Vec3::new(coordinate(rng), coordinate(rng), 3.0 + coordinate(rng));
                let target = Vec3::new(coordinate(rng), coordinate(rng), coordinate(rng));
                let mut camera = if rng.below(3) == 0 {
                    Camera::orthographic(eye, target, 2.0 + coordinate(rng), w, h)
                } else {
                    Camera::perspective(eye, target, 0.9 + 0.3 * coordinate(rng), w, h)
                };
                if rng.below(6) == 0 {
                    camera.up = Vec3::new(coordinate(rng), extreme(rng), coordinate(rng));
                }
                if rng.below(8) == 0 {
                    camera.near = extreme(rng).abs();
                }
                camera
            })
            .collect();
        let screen = cameras
            .iter()
            .map(|c| {
                let (w, h) = (c.width as f32, c.height as f32);
                (0..vertices)
                    .map(|_| {
                        if rng.below(4) == 0 {
                            Vec2::new(extreme(rng), extreme(rng))
                        } else {
                            Vec2::new((rng.signed_f32() * 0.7 + 0.5) * w, (rng.signed_f32() * 0.7 + 0.5) * h)
                        }
                    })
                    .collect()
            })
            .collect();
        Scene {
            settings,
            positions,
            triangles,
            cameras,
            screen,
            d_value: pixel(rng, 1.0),
            target_value: pixel(rng, 1.0),
            learning_rate: if rng.below(3) == 0 { extreme(rng) } else { 0.01 },
        }
    }

    /// Runs the scene through render (3D and screen space), backward, the fused step, both losses
    /// and an Adam step on `renderer` (whose settings must be `self.settings`): `Ok(true)` if the
    /// render was accepted, `Ok(false)` if it was refused with an error, `Err` for a non-finite
    /// value in an `Ok` result.
    pub fn check(&self, renderer: &mut Renderer) -> Outcome {
        let finite = |what: &str, values: &[f32]| match values.iter().position(|v| !v.is_finite()) {
            Some(p) => Err(format!("{what}: non-finite value {} at {p} in an Ok result ({self:?})", values[p])),
            None => Ok(()),
        };
        let Ok(mesh) = Mesh::new(self.positions.clone(), self.triangles.clone()) else {
            return Ok(false);
        };
        let mut accepted = false;
        if let Ok(frame) = renderer.render(&mesh, &self.cameras) {
            accepted = true;
            for image in frame.images() {
                finite("render", image.data())?;
            }
            let d: Vec<Image> =
                frame.images().iter().map(|i| Image::filled(i.width(), i.height(), self.d_value)).collect();
            if let Ok(g) = renderer.backward(&frame, &d) {
                finite("backward", &g.iter().flat_map(|v| v.to_array()).collect::<Vec<_>>())?;
            }
            let targets: Vec<Image> =
                frame.images().iter().map(|i| Image::filled(i.width(), i.height(), self.target_value)).collect();
            for (image, target) in frame.images().iter().zip(&targets) {
                for l in [loss::squared_error(image, target), loss::soft_iou(image, target)].into_iter().flatten() {
                    finite("loss gradient", l.grad.data())?;
                    if !l.value.is_finite() {
                        return Err(format!("loss: value {} in an Ok result ({self:?})", l.value));
                    }
                }
            }
            if let Ok(targets) = Targets::new(targets) {
                if let Ok(step) = renderer.squared_error_step(&mesh, &self.cameras, &targets) {
                    if !step.loss.is_finite() {
                        return Err(format!("step: loss {} in an Ok result ({self:?})", step.loss));
                    }
                    let flat: Vec<f32> = step.gradient.iter().flat_map(|v| v.to_array()).collect();
                    finite("step gradient", &flat)?;
                    let mut params: Vec<f32> = mesh.positions().iter().flat_map(|v| v.to_array()).collect();
                    if Adam::new(self.learning_rate).step(&mut params, &flat).is_ok() {
                        finite("Adam", &params)?;
                    }
                }
            }
        }
        let topology: Arc<Topology> = mesh.topology().clone();
        let views: Vec<ScreenView> = self
            .cameras
            .iter()
            .zip(&self.screen)
            .map(|(c, v)| ScreenView { vertices: v.clone(), width: c.width, height: c.height })
            .collect();
        if let Ok(frame) = renderer.render_screen(&topology, &views) {
            accepted = true;
            for image in frame.images() {
                finite("render_screen", image.data())?;
            }
            let d: Vec<Image> =
                frame.images().iter().map(|i| Image::filled(i.width(), i.height(), self.d_value)).collect();
            if let Ok(g) = renderer.backward_screen(&frame, &d) {
                for view in g {
                    finite("backward_screen", &view.iter().flat_map(|v| v.to_array()).collect::<Vec<_>>())?;
                }
            }
        }
        Ok(accepted)
    }
}

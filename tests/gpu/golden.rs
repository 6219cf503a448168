//! Golden hashes: the bits of images, gradients, losses and fitted poses on the test scenes,
//! recorded before the redesign (#10) and compared after it. Any change to the arithmetic of a
//! stage changes a hash. `DIFFSIL_GOLDEN_PRINT=1` prints the table instead of comparing.
//!
//! Here: GPU half (the CPU half is in `tests/cpu`); the shared machinery is `common::golden`.
//!
//! The GPU hashes were recorded on lavapipe (a software adapter), and are compared bit for bit on
//! software adapters. A hardware driver may fuse `a * b + c` into one multiply-add (WGSL allows
//! it; NVIDIA's Vulkan driver does), which changes the last bits of the float-float arithmetic in
//! `edge_grad`: there the images must still match bit for bit, and the gradients must equal the
//! CPU's within [`GRADIENT_TOL`] relative to their norm (each run on one device still repeats bit
//! for bit: `vs_cpu::gpu_runs_are_bit_identical`).

use crate::common::golden::{compare, hash_of, hashes, outputs};
use diffsil::{RenderSettings, Renderer};

/// The bound on `‖g_gpu − g_cpu‖ / max(‖g_cpu‖, 1e-3)` for a gradient output on a hardware
/// adapter (the bound `vs_cpu` uses).
const GRADIENT_TOL: f64 = 1e-5;

/// Recorded on `3df6b1c` (before the redesign), lavapipe.
const GPU: &[(&str, u64)] = &[
    ("2d/triangle/image", 0x6d2a3cb0bec75e7c),
    ("2d/triangle/grad", 0xf585302090c7bef5),
    ("2d/quad/image", 0x7aa6961ef6a1d2c5),
    ("2d/quad/grad", 0xd0bf1a356ac01b04),
    ("2d/icosphere/image", 0x970508d48e4e4355),
    ("2d/icosphere/grad", 0x8451c8676f9dbc3c),
    ("2d/torus_fold/image", 0xae134a9efd72140b),
    ("2d/torus_fold/grad", 0x6d0cad1e11cb1b2c),
    ("2d/blob/image", 0xbf0bff82a99058e2),
    ("2d/blob/grad", 0x06eb1f0fcf0d1f88),
    ("2d/two_spheres/image", 0x1332a69c33e716e5),
    ("2d/two_spheres/grad", 0x265a29c9a7ef4065),
    ("2d/open_patch/image", 0x6df6c16c89b8806c),
    ("2d/open_patch/grad", 0x81d439f5c0a9648a),
    ("2d/hemisphere/image", 0xd429bd884c0e5715),
    ("2d/hemisphere/grad", 0x6adae721efd8371f),
    ("2d/square_on_grid/image", 0xef49de3008475365),
    ("2d/square_on_grid/grad", 0x4e6c9385bde1c9aa),
    ("2d/diamond_on_grid/image", 0x0b8dd7afbd68d305),
    ("2d/diamond_on_grid/grad", 0x01d7c2cd7564563d),
    ("2d/flat_grid/image", 0x31114f4199676f7c),
    ("2d/flat_grid/grad", 0x3fc8fa6ee381cf83),
    ("3d/icosphere/images", 0x8f5beda9bbbeb8ef),
    ("3d/icosphere/grad", 0x2672da79aed80cf5),
    ("3d/icosphere/step_grad", 0xda8b04564eff7d58),
    ("3d/torus_fold/images", 0xb5a564e355d4d142),
    ("3d/torus_fold/grad", 0xe41498eaa500083a),
    ("3d/torus_fold/step_grad", 0x5431a6887eaad63e),
    ("3d/blob/images", 0x1ab7601794ddab5f),
    ("3d/blob/grad", 0x2f4e25eeac311a35),
    ("3d/blob/step_grad", 0x4780c2e9ec15c50d),
    ("3d/two_spheres/images", 0x3e0cf1f35626c6d2),
    ("3d/two_spheres/grad", 0x40025225967a3374),
    ("3d/two_spheres/step_grad", 0x499d83c59c039e6f),
    ("3d/open_patch/images", 0xbdfe5d6f63516c75),
    ("3d/open_patch/grad", 0xdc7e28419dbc894c),
    ("3d/open_patch/step_grad", 0x6b4d66bcd00b96e4),
    ("3d/hemisphere/images", 0x73ca929a39528781),
    ("3d/hemisphere/grad", 0x4f9b482c159fa117),
    ("3d/hemisphere/step_grad", 0x21bcc24b20d3c0e8),
];
#[test]
fn gpu_outputs_match_the_golden_hashes() {
    let Some(ctx) = crate::common::gpu::gpu_or_skip("gpu_outputs_match_the_golden_hashes") else { return };
    let software = ctx.adapter().device_type == wgpu::DeviceType::Cpu;
    let mut renderer = Renderer::with_gpu_context(RenderSettings::default(), ctx).unwrap();
    if software || std::env::var("DIFFSIL_GOLDEN_PRINT").is_ok() {
        compare("GPU", &hashes(&mut renderer), GPU);
        return;
    }
    let got = outputs(&mut renderer);
    assert_eq!(got.len(), GPU.len(), "GPU: number of golden outputs");
    let cpu = outputs(&mut Renderer::new(RenderSettings::default()).unwrap());
    let (mut worst, mut differing) = (0.0f64, 0);
    for (((name, words), (want_name, want)), (_, cpu_words)) in got.iter().zip(GPU).zip(&cpu) {
        assert_eq!(name, want_name);
        if !name.ends_with("grad") {
            assert_eq!(hash_of(words), *want, "GPU: {name} changed bits (images must match on every adapter)");
            continue;
        }
        differing += usize::from(hash_of(words) != *want);
        assert_eq!(words.len(), cpu_words.len(), "{name}");
        assert!(words.iter().all(|w| w.is_finite()), "{name}: non-finite GPU gradient");
        let diff: f64 = words.iter().zip(cpu_words).map(|(g, c)| (f64::from(*g) - f64::from(*c)).powi(2)).sum();
        let norm: f64 = cpu_words.iter().map(|c| f64::from(*c).powi(2)).sum();
        let relative = diff.sqrt() / norm.sqrt().max(1e-3);
        assert!(relative <= GRADIENT_TOL, "GPU: {name}: relative difference to the CPU {relative:.3e}");
        worst = worst.max(relative);
    }
    println!(
        "hardware adapter: images bit for bit; {differing} of the gradient outputs differ in bits from the \
         lavapipe record, the largest relative difference to the CPU is {worst:.3e}"
    );
}

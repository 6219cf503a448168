//! The integer emulations the GPU stages rely on for bit-exactness, checked on the GPU against
//! Rust on random and extreme values:
//! - `shaders/shared/int64.wgsl`: 64-bit two's complement on `vec2<u32>` (products of i32,
//!   add/sub/neg, comparisons, shifts);
//! - `shaders/shared/exact.wgsl`: `snap` (the CPU's `(x·units + 0.5).floor()` in f32, immune to
//!   fused multiply-add) and `orient_f64_sign` (the sign of the CPU's f64 cross product of f32
//!   points, with every f64 rounding reproduced).
//!
//! Run on lavapipe with `WGPU_BACKEND=vulkan DIFFSIL_REQUIRE_GPU=1 cargo test --test gpu exact::`.

use crate::common::gpu::gpu_or_skip;
use crate::common::rng::{Draws, SplitMix64};
use diffsil::gpu::{GpuContext, Readback};
use diffsil::mirror::RasterParams;

const SHADER: &str = r#"
//!include shared/exact.wgsl
//!include shared/ff.wgsl

@group(0) @binding(1) var<storage, read> input: array<u32>;
@group(0) @binding(2) var<storage, read_write> output: array<u32>;

fn w64(k: u32) -> vec2<u32> {
    return vec2<u32>(input[k], input[k + 1u]);
}

fn put(k: u32, v: vec2<u32>) {
    output[k] = v.x;
    output[k + 1u] = v.y;
}

// Per case: a, b (i32) -> a·b (2 words).
@compute @workgroup_size(64)
fn mul(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 64u * 1024u;
    if 2u * i + 1u >= arrayLength(&input) { return; }
    put(2u * i, i64_mul_i32(bitcast<i32>(input[2u * i]), bitcast<i32>(input[2u * i + 1u])));
}

// Per case: a, b (i64, 4 words) -> add, sub, neg a, shr a by (b.lo % 64), shl a by (b.lo % 64),
// then flags lt, le, sign(a), bit_length(a), (12 words).
@compute @workgroup_size(64)
fn ops(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 64u * 1024u;
    if 4u * i + 3u >= arrayLength(&input) { return; }
    let a = w64(4u * i);
    let b = w64(4u * i + 2u);
    let s = b.x % 64u;
    let o = 12u * i;
    put(o, i64_add(a, b));
    put(o + 2u, i64_sub(a, b));
    put(o + 4u, i64_neg(a));
    put(o + 6u, i64_shr(a, s));
    put(o + 8u, i64_shl(a, s));
    output[o + 10u] = select(0u, 1u, i64_lt(a, b)) | select(0u, 2u, i64_le(a, b)) | select(0u, 4u, u64_lt(a, b));
    output[o + 11u] = bitcast<u32>(i64_sign(a) + 1) | (u64_bit_length(a) << 8u);
}

// Per case: x (f32 bits), units -> snap(x, units).
@compute @workgroup_size(64)
fn snap_case(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 64u * 1024u;
    if 2u * i + 1u >= arrayLength(&input) { return; }
    output[i] = bitcast<u32>(snap(bitcast<f32>(input[2u * i]), input[2u * i + 1u]));
}

// Per case: x, y (float-float, 4 words) -> x + y, x - y, x · y, x / y, two_prod(x.hi, y.hi),
// flags (x < y, x <= y) (11 words).
@compute @workgroup_size(64)
fn ff_ops(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 64u * 1024u;
    if 4u * i + 3u >= arrayLength(&input) { return; }
    let x = bitcast<vec2<f32>>(w64(4u * i));
    let y = bitcast<vec2<f32>>(w64(4u * i + 2u));
    let o = 11u * i;
    put(o, bitcast<vec2<u32>>(ff_add(x, y)));
    put(o + 2u, bitcast<vec2<u32>>(ff_sub(x, y)));
    put(o + 4u, bitcast<vec2<u32>>(ff_mul(x, y)));
    put(o + 6u, bitcast<vec2<u32>>(ff_div(x, y)));
    put(o + 8u, bitcast<vec2<u32>>(two_prod(x.x, y.x)));
    output[o + 10u] = select(0u, 1u, ff_lt(x, y)) | select(0u, 2u, ff_le(x, y));
}

// Per case: a, b (f32 bits) -> div_rn(a, b).
@compute @workgroup_size(64)
fn div_case(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 64u * 1024u;
    if 2u * i + 1u >= arrayLength(&input) { return; }
    output[i] = bitcast<u32>(div_rn(bitcast<f32>(input[2u * i]), bitcast<f32>(input[2u * i + 1u])));
}

// Per case: a, b, w (f32 bits, 6 words) -> orient_f64_sign + 1.
@compute @workgroup_size(64)
fn orient(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 64u * 1024u;
    if 6u * i + 5u >= arrayLength(&input) { return; }
    let k = 6u * i;
    output[i] = bitcast<u32>(1 + orient_f64_sign(w64(k), w64(k + 2u), w64(k + 4u)));
}
"#;

/// Runs entry point `entry` over `cases` cases of `input`, returning `out_per_case · cases` words.
fn run(ctx: &GpuContext, entry: &str, input: &[u32], cases: usize, out_per_case: usize) -> Vec<u32> {
    let pipeline = ctx.compute_pipeline_from_wgsl("gpu_exact test", SHADER, entry).unwrap();
    let input_buffer = ctx.storage_buffer_init("input", input).unwrap();
    let output = ctx.storage_buffer("output", (cases * out_per_case * 4) as u64).unwrap();
    // The frame uniform only provides `no_fuse`'s opaque zero to the float-float functions.
    let frame: Box<diffsil::mirror::FrameUniform> = bytemuck::zeroed_box();
    let uniform = ctx.uniform_buffer_init("frame", &*frame).unwrap();
    let entries: Vec<(u32, &wgpu::Buffer)> = if entry == "ff_ops" {
        vec![(0, &uniform), (1, &input_buffer), (2, &output)]
    } else {
        vec![(1, &input_buffer), (2, &output)]
    };
    let bind = ctx.bind_entries("exact", &pipeline, 0, &entries).unwrap();
    let mut encoder = ctx.encoder("exact");
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes: None });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        let groups = cases.div_ceil(64) as u32;
        // x covers 1024 groups (65,536 cases) per row of the grid.
        pass.dispatch_workgroups(groups.min(1024), groups.div_ceil(1024), 1);
    }
    Readback::new("exact readback").submit_and_read(ctx, encoder, &output, cases * out_per_case).unwrap()
}

/// Random i32 with a random magnitude class (small, large, extreme).
fn i32_any(rng: &mut SplitMix64) -> i32 {
    let r = rng.next_u64();
    match r % 6 {
        0 => [0, 1, -1, i32::MAX, i32::MIN, i32::MIN + 1, 65_535, 65_536, -65_536][(r >> 8) as usize % 9],
        1 => (r >> 32) as i32 >> 16,
        _ => (r >> 32) as i32,
    }
}

fn i64_any(rng: &mut SplitMix64) -> i64 {
    let r = rng.next_u64();
    match r % 5 {
        0 => [0, 1, -1, i64::MAX, i64::MIN, 1 << 32, -(1 << 32), u32::MAX as i64][(r >> 8) as usize % 8],
        1 => rng.next_u64() as i64 >> 33,
        _ => rng.next_u64() as i64,
    }
}

fn words(v: i64) -> [u32; 2] {
    [v as u64 as u32, (v as u64 >> 32) as u32]
}

#[test]
fn int64_products_match_rust() {
    let Some(ctx) = gpu_or_skip("int64_products_match_rust") else { return };
    let mut rng = SplitMix64::new(1);
    let cases: Vec<(i32, i32)> = (0..200_000).map(|_| (i32_any(&mut rng), i32_any(&mut rng))).collect();
    let input: Vec<u32> = cases.iter().flat_map(|&(a, b)| [a as u32, b as u32]).collect();
    let out = run(&ctx, "mul", &input, cases.len(), 2);
    for (k, &(a, b)) in cases.iter().enumerate() {
        let got = out[2 * k] as u64 | (out[2 * k + 1] as u64) << 32;
        assert_eq!(got as i64, a as i64 * b as i64, "{a} * {b}");
    }
}

#[test]
fn int64_arithmetic_and_comparisons_match_rust() {
    let Some(ctx) = gpu_or_skip("int64_arithmetic_and_comparisons_match_rust") else { return };
    let mut rng = SplitMix64::new(2);
    let mut cases: Vec<(i64, i64)> = (0..100_000).map(|_| (i64_any(&mut rng), i64_any(&mut rng))).collect();
    cases.extend((0..64).map(|s| (i64::MIN >> s, s)));
    cases.extend((0..64).map(|s| (-1 - (1i64 << (s % 63)), s)));
    let input: Vec<u32> = cases.iter().flat_map(|&(a, b)| [words(a), words(b)].concat()).collect();
    let out = run(&ctx, "ops", &input, cases.len(), 12);
    for (k, &(a, b)) in cases.iter().enumerate() {
        let o = &out[12 * k..12 * k + 12];
        let get = |i: usize| (o[i] as u64 | (o[i + 1] as u64) << 32) as i64;
        let s = b as u64 as u32 % 64;
        assert_eq!(get(0), a.wrapping_add(b), "{a} + {b}");
        assert_eq!(get(2), a.wrapping_sub(b), "{a} - {b}");
        assert_eq!(get(4), a.wrapping_neg(), "-{a}");
        assert_eq!(get(6), a >> s, "{a} >> {s}");
        assert_eq!(get(8), a.wrapping_shl(s), "{a} << {s}");
        let flags = (a < b) as u32 | ((a <= b) as u32) << 1 | (((a as u64) < (b as u64)) as u32) << 2;
        assert_eq!(o[10], flags, "compare {a} {b}");
        assert_eq!(o[11] & 0xff, (a.signum() + 1) as u32, "sign {a}");
        assert_eq!(o[11] >> 8, 64 - (a as u64).leading_zeros(), "bit length {a}");
    }
}

#[test]
fn snap_matches_the_cpu_bit_for_bit() {
    let Some(ctx) = gpu_or_skip("snap_matches_the_cpu_bit_for_bit") else { return };
    let mut rng = SplitMix64::new(3);
    let mut cases: Vec<(f32, u32)> = Vec::new();
    for f in 1..=16u32 {
        let units = RasterParams::new(1, 1, f, 1.0, 0.0).unwrap().units;
        for _ in 0..4000 {
            let r = rng.next_u64();
            let x = match r % 7 {
                // Anywhere in the coordinate range, with random magnitude.
                0 => ((rng.unit() * 2.0 - 1.0) * diffsil::COORD_LIMIT as f64) as f32,
                1 => ((rng.unit() * 2.0 - 1.0) * 2f64.powi((r >> 8) as i32 % 22 - 12)) as f32,
                // Exactly on half units (ties of the rounding), and their neighbours.
                2 | 3 => {
                    let k = (rng.next_u64() % (1 << 22)) as i64 - (1 << 21);
                    let x = ((k as f64 + 0.5) / units as f64) as f32;
                    match r % 3 {
                        0 => x,
                        1 => f32::from_bits(x.to_bits() + 1),
                        _ => f32::from_bits(x.to_bits().saturating_sub(1)),
                    }
                }
                // Large values where f32 addition of 0.5 rounds.
                4 => f32::from_bits(0x4B00_0000 + (rng.next_u64() % (1 << 24)) as u32) / units as f32,
                5 => -(f32::from_bits(0x4A80_0000 + (rng.next_u64() % (1 << 24)) as u32)) / units as f32,
                _ => [0.0, -0.0, 1e-30, -1e-30, 0.5, -0.5, 1.0 / units as f32, f32::MIN_POSITIVE, 1e-45]
                    [r as usize / 7 % 9],
            };
            cases.push((x, units));
        }
    }
    let input: Vec<u32> = cases.iter().flat_map(|&(x, u)| [x.to_bits(), u]).collect();
    let out = run(&ctx, "snap_case", &input, cases.len(), 1);
    for (k, &(x, units)) in cases.iter().enumerate() {
        let params = RasterParams { units, ..RasterParams::new(1, 1, 1, 1.0, 0.0).unwrap() };
        assert_eq!(out[k] as i32, params.snap(x), "snap({x:e} = {:#x}, units {units})", x.to_bits());
    }
}

#[test]
fn division_is_correctly_rounded() {
    let Some(ctx) = gpu_or_skip("division_is_correctly_rounded") else { return };
    let mut rng = SplitMix64::new(6);
    let mut cases: Vec<(f32, f32)> = Vec::new();
    for k in 0..200_000 {
        let value = |rng: &mut SplitMix64| ((rng.unit() - 0.5) * 2f64.powi((rng.next_u64() % 60) as i32 - 30)) as f32;
        let (a, b) = match k % 5 {
            // Quotients near a rounding tie: a = q·b for a q with a 25th bit.
            0 => {
                let b = value(&mut rng);
                let q = f32::from_bits((rng.next_u64() as u32 & 0x007f_ffff) | 0x3f80_0000);
                (q * b, b)
            }
            1 => (value(&mut rng), [1.0, -3.0, 0.1, 7.0, 1e-3][k / 5 % 5]),
            2 => (
                f32::from_bits(rng.next_u64() as u32 & 0x7eff_ffff),
                f32::from_bits(rng.next_u64() as u32 & 0x7eff_ffff),
            ),
            _ => (value(&mut rng), value(&mut rng)),
        };
        if b != 0.0 {
            cases.push((a, b));
        }
    }
    let input: Vec<u32> = cases.iter().flat_map(|&(a, b)| [a.to_bits(), b.to_bits()]).collect();
    let out = run(&ctx, "div_case", &input, cases.len(), 1);
    let mut checked = 0;
    for (k, &(a, b)) in cases.iter().enumerate() {
        let q = a / b;
        // Quotients outside the normal range fall back to the device's division.
        if q == 0.0 || !q.is_normal() {
            continue;
        }
        assert_eq!(f32::from_bits(out[k]).to_bits(), q.to_bits(), "{a:e} / {b:e}");
        checked += 1;
    }
    assert!(checked > 150_000, "{checked}");
}

/// A float-float pair (hi, lo) nearest to `x`.
fn ff_of(x: f64) -> [f32; 2] {
    let hi = x as f32;
    [hi, (x - hi as f64) as f32]
}

fn ff_value(words: &[u32]) -> f64 {
    f32::from_bits(words[0]) as f64 + f32::from_bits(words[1]) as f64
}

#[test]
fn float_float_arithmetic_is_accurate() {
    let Some(ctx) = gpu_or_skip("float_float_arithmetic_is_accurate") else { return };
    let mut rng = SplitMix64::new(5);
    let mut cases: Vec<([f32; 2], [f32; 2])> = Vec::new();
    for k in 0..50_000 {
        let mag = |rng: &mut SplitMix64| 2f64.powi((rng.next_u64() % 40) as i32 - 20) * (rng.unit() - 0.5);
        let x = mag(&mut rng);
        let y = match k % 4 {
            0 => x * (1.0 + 1e-6 * (rng.unit() - 0.5)), // cancellation
            1 => -x * (1.0 + 1e-9 * rng.unit()),
            _ => mag(&mut rng),
        };
        let (x, y) = (ff_of(x), ff_of(if y == 0.0 { 1.0 } else { y }));
        cases.push((x, y));
    }
    // The first 1000 again, swapped: ff_mul must be symmetric bit for bit.
    let swapped: Vec<([f32; 2], [f32; 2])> = cases[..1000].iter().map(|&(x, y)| (y, x)).collect();
    cases.extend(swapped);
    let input: Vec<u32> = cases.iter().flat_map(|(x, y)| [x[0], x[1], y[0], y[1]].map(f32::to_bits)).collect();
    let out = run(&ctx, "ff_ops", &input, cases.len(), 11);
    let ulp = 2f64.powi(-43);
    for (k, (x, y)) in cases.iter().enumerate() {
        let o = &out[11 * k..11 * k + 11];
        let (xv, yv) = (x[0] as f64 + x[1] as f64, y[0] as f64 + y[1] as f64);
        let check = |what: &str, got: f64, exact: f64, scale: f64| {
            assert!((got - exact).abs() <= ulp * scale, "{what}: {x:?} {y:?}: got {got:e}, f64 {exact:e}");
        };
        check("add", ff_value(&o[0..2]), xv + yv, xv.abs() + yv.abs());
        check("sub", ff_value(&o[2..4]), xv - yv, xv.abs() + yv.abs());
        check("mul", ff_value(&o[4..6]), xv * yv, (xv * yv).abs());
        check("div", ff_value(&o[6..8]), xv / yv, (xv / yv).abs());
        // two_prod is exact.
        assert_eq!(ff_value(&o[8..10]), x[0] as f64 * y[0] as f64, "two_prod {x:?} {y:?}");
        assert_eq!(o[10], (xv < yv) as u32 | ((xv <= yv) as u32) << 1, "compare {x:?} {y:?}");
    }
    let n = cases.len() - 1000;
    for k in 0..1000 {
        assert_eq!(
            &out[11 * k + 4..11 * k + 6],
            &out[11 * (n + k) + 4..11 * (n + k) + 6],
            "ff_mul symmetry {:?}",
            cases[k]
        );
    }
}

/// The CPU's expression (src/cpu/edges.rs).
fn cpu_orient(a: [f32; 2], b: [f32; 2], w: [f32; 2]) -> i32 {
    let (a, b, w) = (a.map(f64::from), b.map(f64::from), w.map(f64::from));
    let cross = (b[0] - a[0]) * (w[1] - a[1]) - (b[1] - a[1]) * (w[0] - a[0]);
    if cross > 0.0 {
        1
    } else if cross < 0.0 {
        -1
    } else {
        0
    }
}

#[test]
fn orient_matches_the_cpu_f64_sign() {
    let Some(ctx) = gpu_or_skip("orient_matches_the_cpu_f64_sign") else { return };
    let mut rng = SplitMix64::new(4);
    let mut cases: Vec<[[f32; 2]; 3]> = Vec::new();
    let coord = |rng: &mut SplitMix64| -> f32 {
        let r = rng.next_u64();
        match r % 5 {
            0 => ((rng.unit() - 0.5) * 2048.0) as f32,
            1 => ((rng.unit() - 0.5) * 2f64.powi((r >> 8) as i32 % 60 - 40)) as f32,
            2 => ((rng.next_u64() % 64) as f32) * 0.5 - 8.0,
            3 => ((rng.unit() - 0.5) * 2.0 * diffsil::COORD_LIMIT as f64) as f32,
            _ => [0.0, -0.0, 1e-40, -3e-39, 1.0, 1024.0][r as usize / 5 % 6],
        }
    };
    for _ in 0..60_000 {
        let p = [
            [coord(&mut rng), coord(&mut rng)],
            [coord(&mut rng), coord(&mut rng)],
            [coord(&mut rng), coord(&mut rng)],
        ];
        cases.push(p);
        // Nearly collinear: w on the line a→b (rounded), then nudged by an ulp or not.
        let t = rng.unit() as f32 * 3.0 - 1.0;
        let [a, b, _] = p;
        let mut w = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
        match rng.next_u64() % 3 {
            0 => w[0] = f32::from_bits(w[0].to_bits() ^ 1),
            1 => w[1] = f32::from_bits(w[1].to_bits() ^ 1),
            _ => {}
        }
        cases.push([a, b, w]);
        // Exactly collinear scaled copies, and the lead's sliver faces: tiny offsets off a long edge.
        let s = coord(&mut rng);
        cases.push([[s, s], [2.0 * s, 2.0 * s], [-s, -s]]);
        cases.push([a, b, [(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5 + 1e-6]]);
    }
    let input: Vec<u32> = cases.iter().flat_map(|p| p.iter().flat_map(|v| v.map(f32::to_bits))).collect();
    let out = run(&ctx, "orient", &input, cases.len(), 1);
    let mut zeros = 0;
    for (k, [a, b, w]) in cases.iter().enumerate() {
        let expected = cpu_orient(*a, *b, *w);
        zeros += (expected == 0) as usize;
        assert_eq!(out[k] as i32 - 1, expected, "orient({a:?}, {b:?}, {w:?})");
    }
    assert!(zeros > 1000, "the cases should include exact zeros, got {zeros}");
}

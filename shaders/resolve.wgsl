// `resolve` — twin of `cpu::resolve::resolve` (src/cpu/resolve.rs): sample masks → pixel values.
//
// Reads:  `frame`, `masks` (words_per_pixel words per pixel, all views).
// Writes: `image[p]` for every pixel p of every view: exactly `outside` with no sample covered,
//         exactly `inside` with all covered, else `outside + (inside − outside) · (covered / F²)`
//         clamped to [min, max] of the two, with the CPU's rounding (products kept out of FMA
//         fusion).
// Dispatch: 1D over total_pixels invocations (64 per workgroup).

//!include shared/frame.wgsl
//!include shared/dispatch.wgsl

@group(0) @binding(1) var<storage, read> masks: array<u32>;
@group(0) @binding(2) var<storage, read_write> image: array<f32>;

// Entry point (one invocation per pixel): reads `masks`; writes `image`.
@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    let p = linear_invocation_index(workgroup_id, num_workgroups, local_index, 64u);
    if p >= frame.params.total_pixels {
        return;
    }
    let r = frame.views[view_of_pixel(p)].raster;
    var count = 0u;
    for (var w = 0u; w < r.words_per_pixel; w++) {
        count += countOneBits(masks[p * r.words_per_pixel + w]);
    }
    var value = r.outside;
    if count == r.supersample * r.supersample {
        value = r.inside;
    } else if count != 0u {
        let coverage = no_fuse(f32(count) * r.inv_samples);
        let mixed = r.outside + no_fuse((r.inside - r.outside) * coverage);
        value = clamp(mixed, min(r.outside, r.inside), max(r.outside, r.inside));
    }
    image[p] = value;
}

// `loss` — twin of `loss::squared_error` (src/loss.rs) for `Renderer::squared_error_step`: the
// squared error of every view's image against its target, and its gradient, without the images
// leaving the GPU.
//
// Reads:  `frame`, `image` (all views, from `resolve`), `target_image` (concatenated like the images).
// Writes: `d_image[p] = 2 · (image[p] − target[p])` for every pixel p of every view (the same f32
//         bits as the CPU's `(2 · (f64(i) − f64(t))) as f32`: one rounding of an exact value), and
//         `tile_losses[tile] = Σ (image − target)²` over the tile's pixels (f32, summed in a fixed
//         tree order: deterministic). The host adds each view's tiles in order, in f64.
// Dispatch: one workgroup of 256 invocations per tile of all views (`total_tiles` workgroups,
//         tiled into a 2D grid beyond 65,535); invocation `lid < tile_size²` takes one pixel.

//!include shared/frame.wgsl
//!include shared/dispatch.wgsl

@group(0) @binding(1) var<storage, read> image: array<f32>;
@group(0) @binding(2) var<storage, read> target_image: array<f32>;
@group(0) @binding(3) var<storage, read_write> d_image: array<f32>;
@group(0) @binding(4) var<storage, read_write> tile_losses: array<f32>;

var<workgroup> sums: array<f32, 256>;

// Entry point (one workgroup per tile): reads `image`, `target_image`; writes `d_image` for the
// tile's pixels and the tile's squared error to `tile_losses`.
@compute @workgroup_size(256)
fn main(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let g = linear_workgroup_index(workgroup_id, num_workgroups);
    if g >= frame.params.total_tiles {
        return;
    }
    let view = view_of_tile(g);
    let vw = frame.views[view];
    let r = vw.raster;
    let t = r.tile_size;
    let local_tile = g - vw.tile_offset;
    let px = (local_tile % r.tiles_x) * t + lid % t;
    let py = (local_tile / r.tiles_x) * t + lid / t;
    var squared = 0.0;
    if lid < t * t && px < r.width && py < r.height {
        let p = vw.pixel_offset + py * r.width + px;
        let d = image[p] - target_image[p];
        d_image[p] = 2.0 * d;
        squared = no_fuse(d * d);
    }
    sums[lid] = squared;
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride /= 2u) {
        if lid < stride {
            sums[lid] += sums[lid + stride];
        }
        workgroupBarrier();
    }
    if lid == 0u {
        tile_losses[g] = sums[0];
    }
}

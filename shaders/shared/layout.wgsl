// The structs and constants the WGSL stages share with Rust. Each struct is the twin of the
// `#[repr(C)]` struct of the same name in src/mirror.rs, each constant of the Rust constant of the
// same name there. The build checks them: build/shaders.rs reflects this file with naga and
// src/mirror.rs asserts at compile time that every struct has the same size and member offsets
// (members by name) and every constant the same value, so a mismatch fails the build.
// (`tests/gpu/layout.rs` also round-trips every field through the GPU.)
//
//   ScreenVertex   16 bytes
//   RasterParams   48 bytes
//   EdgeGrad       16 bytes
//   ViewParams     96 bytes
//   GpuView        64 bytes
//   FrameParams    64 bytes
//   FrameUniform   64 + MAX_VIEWS·64 bytes (uniform)

// A projected vertex: pixel coordinates (x right, y down) and whether it may be used.
struct ScreenVertex {
    position: vec2<f32>,
    valid: u32,
    pad: u32,
}

// Per-view raster constants (see `RasterParams` in src/mirror.rs). On the GPU `tile_size` is a
// power of two from 1 to 16 (`stages::gpu_tile_size`).
struct RasterParams {
    width: u32,
    height: u32,
    supersample: u32,
    units: u32,
    half_step: u32,
    words_per_pixel: u32,
    tile_size: u32,
    tiles_x: u32,
    tiles_y: u32,
    inside: f32,
    outside: f32,
    inv_samples: f32,
}

// The gradient slot of one edge [a, b]: dL/da and dL/db in pixel coordinates.
struct EdgeGrad {
    a: vec2<f32>,
    b: vec2<f32>,
}

// Per-view camera constants (see `ViewParams` in src/mirror.rs).
struct ViewParams {
    row0: vec4<f32>,
    row1: vec4<f32>,
    row2: vec4<f32>,
    // Principal point (cx, cy), pixels.
    centre: vec2<f32>,
    // Pixels per unit of (c.x/d, c.y/d) (perspective) or (c.x, c.y) (orthographic): (sx, sy).
    scale: vec2<f32>,
    perspective: u32,
    near: f32,
    far: f32,
    width: u32,
    height: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

// One view of a multi-view frame: its raster constants and where its data starts in the
// concatenated per-view buffers (pixels of all views back to back, tiles likewise).
struct GpuView {
    raster: RasterParams,
    // First pixel of this view in the concatenated images (and, times words_per_pixel, masks).
    pixel_offset: u32,
    // First tile of this view in the concatenated tile arrays.
    tile_offset: u32,
    // First vertex of this view's instance in the concatenated `positions` of a batch (0 for one
    // mesh; see project.wgsl).
    vertex_offset: u32,
    pad1: u32,
}

// Sizes of the whole frame.
struct FrameParams {
    view_count: u32,
    vertex_count: u32,
    triangle_count: u32,
    edge_count: u32,
    // Tiles of all views together.
    total_tiles: u32,
    // Pixels of all views together.
    total_pixels: u32,
    // Capacity of the bin list (entries).
    bin_capacity: u32,
    // Index of the first list entry in the `bins` buffer (= total_tiles + 1: the CSR offsets come
    // first).
    bin_list_offset: u32,
    // Index of the first face orientation in the `classes` buffer (= view_count · edge_count: the
    // edge sides come first).
    orient_offset: u32,
    // Always 0; the shaders cannot know it, which keeps compilers from fusing a product into a
    // following addition (see `no_fuse` in shared/frame.wgsl).
    zero: u32,
    // Index of the first large-triangle list in the `bins` buffer (view v's list starts at
    // large_offset + v · triangle_count; see shared/tiles.wgsl).
    large_offset: u32,
    // The most parts a candidate edge can have in `edge_grad` (shared/parts.wgsl): the largest
    // floor(image side / part_length(tile_size)) + 1 of the views. The frame's own count is
    // `status[STATUS_PARTS]`.
    parts: u32,
    // Loop iterations one SIMD batch of invocations may run before the stage stops and reports
    // it: 60,000 on llvmpipe (which silently ends loops after 65,535), 0 (no limit) elsewhere.
    loop_budget: u32,
    // Capacity of `edge_grad`'s partials buffer (entries), for the fused step's indirect dispatch.
    partial_capacity: u32,
    // The device's max_compute_workgroups_per_dimension.
    max_workgroups: u32,
    pad2: u32,
}

// A clipped vertex's snapped coordinates (both of them).
const INVALID_SNAPPED: i32 = -2147483647 - 1;

// Views per GPU frame (the size of the uniform array of views).
const MAX_VIEWS: u32 = 256u;

// Largest |pixel coordinate| of a valid projected vertex (`project`); farther vertices are clipped.
const COORD_LIMIT: f32 = 1048576.0;

// Largest GPU tile side in pixels: `coverage` has 256 invocations per tile.
const MAX_GPU_TILE_SIZE: u32 = 16u;

// Pixels per part of an edge in `edge_grad` (`part_length` in shared/parts.wgsl):
// PART_LENGTH_PER_TILE_SIDE · tile_size, clamped to [PART_LENGTH_MIN, PART_LENGTH_MAX].
const PART_LENGTH_PER_TILE_SIDE: u32 = 4u;
const PART_LENGTH_MIN: u32 = 4u;
const PART_LENGTH_MAX: u32 = 16u;

// Work items (candidate edge × part) per workgroup of `edge_grad.wgsl`'s `main`.
const EDGE_GRAD_ITEMS_PER_WORKGROUP: u32 = 2u;

// The frame uniform (binding 0 of every stage): sizes and all views.
struct FrameUniform {
    params: FrameParams,
    views: array<GpuView, MAX_VIEWS>,
}

// Layout of the `status` buffer (u32 counters, atomic where several invocations write; read back
// with the image or the gradients; see `STATUS_*` in src/mirror.rs):
//   [0]                 bin entries needed (written by `scan`)
//   [1]                 1 when the bin count overflowed u32 (written by `scan`)
//   [2]                 candidate edges of all views (`edges`: the length of the candidate list)
//   [3]                 most loop iterations one invocation of `coverage` or `edge_grad` ran
//   [4]                 1 when a fused step skipped `edge_grad` (partials buffer too small)
//   [5]                 parts per candidate edge: the most any candidate has (`edges`, atomic max)
//   [6 + 5·v + 0]       culled triangles of view v (`bin_count`)
//   [6 + 5·v + 1]       candidate edges of view v (`edges`)
//   [6 + 5·v + 2]       segments of view v (`edge_grad`)
//   [6 + 5·v + 3]       visible segments of view v (`edge_grad`)
//   [6 + 5·v + 4]       large triangles of view v (`bin_count`: the length of its large list)
const STATUS_NEEDED: u32 = 0u;
const STATUS_OVERFLOW: u32 = 1u;
const STATUS_CANDIDATE_TOTAL: u32 = 2u;
const STATUS_MAX_ITERATIONS: u32 = 3u;
const STATUS_PARTIALS_SHORT: u32 = 4u;
const STATUS_PARTS: u32 = 5u;
const STATUS_VIEW_BASE: u32 = 6u;
const STATUS_VIEW_STRIDE: u32 = 5u;
const STATUS_CULLED: u32 = 0u;
const STATUS_CANDIDATES: u32 = 1u;
const STATUS_SEGMENTS: u32 = 2u;
const STATUS_VISIBLE: u32 = 3u;
const STATUS_LARGE: u32 = 4u;

fn status_index(view: u32, counter: u32) -> u32 {
    return STATUS_VIEW_BASE + STATUS_VIEW_STRIDE * view + counter;
}

//! The shader mirror: every `#[repr(C)]` twin of a WGSL struct and every constant the Rust side
//! shares with the WGSL stages, in one place.
//!
//! The WGSL side is `shaders/shared/layout.wgsl`; every struct and `const` there has a twin here
//! **of the same name** (struct members too, padding included). The CPU stages use the same
//! structs, so both engines read and write one layout.
//!
//! ## Checked at build time
//!
//! With the `gpu` feature, `build/shaders.rs` reflects `layout.wgsl` with naga and writes
//! `$OUT_DIR/mirror_checks.rs`, included at the end of this module: one compile-time `assert!`
//! per WGSL struct (`size_of` of the Rust struct equals naga's size), per struct member
//! (`offset_of!` of the Rust member of the same name equals naga's offset) and per WGSL constant
//! (the Rust constant of the same name, converted with `as f64`, equals the WGSL value). So a
//! mismatch fails `cargo build`; for instance, with `MAX_VIEWS` changed to 255 here only:
//!
//! ```text
//! error[E0080]: evaluation panicked: the value of constant `MAX_VIEWS` differs between
//!               src/mirror.rs and shaders/shared/layout.wgsl (WGSL: 256)
//!   --> …/out/mirror_checks.rs
//! ```
//!
//! and a Rust member renamed or missing is an `offset_of!` error naming it (`no field `pad0` on
//! type `GpuView``). A struct or constant added to `layout.wgsl` needs its twin here (else the
//! build fails: "cannot find … in `mirror`"); Rust-only items (methods, [`MAX_SUPERSAMPLE`],
//! [`INVALID_SNAPPED_VERTEX`], the llvmpipe limits) are not checked. The status layout and the
//! llvmpipe limits are `pub(crate)`: they are the engine's plumbing, not API. Without the `gpu` feature
//! nothing is checked (nor needed: no shader runs).

use crate::{Error, Result};

/// Largest |pixel coordinate| a projected vertex may have; farther vertices are treated like
/// vertices behind the camera (their triangles are culled). Keeps fixed-point coverage exact in
/// 32-bit integers on the GPU.
pub const COORD_LIMIT: f32 = 1_048_576.0;

/// A projected vertex: pixel coordinates and whether it may be used (see [`ViewParams`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ScreenVertex {
    /// Pixel coordinates (x right, y down); zero when not valid.
    pub position: [f32; 2],
    /// 1 when the vertex is in front of the camera and within the coordinate limit, else 0.
    pub valid: u32,
    /// Padding to 16 bytes.
    pub pad: u32,
}

/// Per-view raster constants (`RasterParams` in `shaders/shared/layout.wgsl`).
///
/// Coverage runs on a fixed-point grid of `units` per pixel. Sample column `sx` of the image sits
/// at `(2·sx + 1)·half_step` units (likewise rows), i.e. sample `a` of pixel column `j` at
/// `j + (a + ½)/F` pixels. Vertices are snapped with `round(x·units)`; edge functions are exact
/// integers, so CPU and GPU agree bit for bit.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RasterParams {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Samples per pixel side (F).
    pub supersample: u32,
    /// Fixed-point units per pixel (`2·F·half_step`).
    pub units: u32,
    /// Half the distance between samples, in units.
    pub half_step: u32,
    /// 32-bit mask words per pixel (`ceil(F²/32)`).
    pub words_per_pixel: u32,
    /// Tile side, pixels (a power of two).
    pub tile_size: u32,
    /// Tiles per row.
    pub tiles_x: u32,
    /// Tile rows.
    pub tiles_y: u32,
    /// Value of a covered pixel (p1).
    pub inside: f32,
    /// Value of an uncovered pixel (p0).
    pub outside: f32,
    /// `1 / F²`.
    pub inv_samples: f32,
}

/// Each snapped coordinate of a clipped vertex (never a real coordinate: snapped coordinates are
/// within ±2^29).
pub const INVALID_SNAPPED: i32 = i32::MIN;

/// The snapped position of a clipped vertex: [`INVALID_SNAPPED`] twice.
pub const INVALID_SNAPPED_VERTEX: [i32; 2] = [INVALID_SNAPPED, INVALID_SNAPPED];

/// Largest supported supersampling factor.
pub const MAX_SUPERSAMPLE: u32 = 16;

impl RasterParams {
    /// Raster constants for a `width × height` image with `supersample`² samples per pixel.
    /// The tile size is chosen later by the `bin` stage; here it is 1.
    pub fn new(width: u32, height: u32, supersample: u32, inside: f32, outside: f32) -> Result<RasterParams> {
        use crate::scene::camera::MAX_RESOLUTION;
        if width == 0 || height == 0 || width > MAX_RESOLUTION || height > MAX_RESOLUTION {
            return Err(Error::InvalidResolution { width, height, max: MAX_RESOLUTION });
        }
        if supersample == 0 || supersample > MAX_SUPERSAMPLE {
            return Err(Error::InvalidSupersample(supersample));
        }
        if !(inside.is_finite() && outside.is_finite()) {
            return Err(Error::InvalidSettings(format!(
                "pixel values must be finite, got inside {inside} outside {outside}"
            )));
        }
        let half_step = 128u32.div_ceil(supersample);
        let samples = supersample * supersample;
        let mut params = RasterParams {
            width,
            height,
            supersample,
            units: 2 * supersample * half_step,
            half_step,
            words_per_pixel: samples.div_ceil(32),
            tile_size: 1,
            tiles_x: width,
            tiles_y: height,
            inside,
            outside,
            inv_samples: 1.0 / samples as f32,
        };
        params.set_tile_size(1);
        Ok(params)
    }

    /// Sets the tile side (a power of two) and the tile counts.
    pub fn set_tile_size(&mut self, tile_size: u32) {
        self.tile_size = tile_size;
        self.tiles_x = self.width.div_ceil(tile_size);
        self.tiles_y = self.height.div_ceil(tile_size);
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Number of tiles.
    pub fn tile_count(&self) -> usize {
        self.tiles_x as usize * self.tiles_y as usize
    }

    /// Snaps a pixel coordinate to the fixed-point grid: `floor(x·units + 0.5)` in f32, the same
    /// arithmetic as WGSL's `snap` (exact for |x| < [`COORD_LIMIT`]).
    #[inline]
    pub fn snap(&self, x: f32) -> i32 {
        let y = x * self.units as f32 + 0.5;
        let t = y as i32; // truncation toward zero, then down for negative non-integers
        t - (y < t as f32) as i32
    }

    /// Snaps a screen vertex; clipped vertices become [`INVALID_SNAPPED_VERTEX`].
    #[inline]
    pub fn snap_vertex(&self, v: &ScreenVertex) -> [i32; 2] {
        if v.valid == 0 {
            INVALID_SNAPPED_VERTEX
        } else {
            [self.snap(v.position[0]), self.snap(v.position[1])]
        }
    }
}

/// The gradient slot of one edge `[a, b]`: `∂L/∂a` and `∂L/∂b` in pixel coordinates.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct EdgeGrad {
    /// Gradient with respect to the edge's first vertex.
    pub a: [f32; 2],
    /// Gradient with respect to the edge's second vertex.
    pub b: [f32; 2],
}

/// Per-view projection constants (`ViewParams` in `shaders/shared/layout.wgsl`).
///
/// Camera space `c = R·p + t` with rows `row0..row2 = [R | t]` (x right, y up, z backward);
/// depth `d = −c.z`. Perspective: `x = cx + sx·c.x/d`, `y = cy − sy·c.y/d`; orthographic:
/// `x = cx + sx·c.x`, `y = cy − sy·c.y`, with `(cx, cy) = centre` and `(sx, sy) = scale`
/// (different for non-square pixels).
/// A point is valid when `near < d < far` and its pixel coordinates are within
/// ±[`COORD_LIMIT`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ViewParams {
    /// First row of `[R | t]`.
    pub row0: [f32; 4],
    /// Second row of `[R | t]`.
    pub row1: [f32; 4],
    /// Third row of `[R | t]`.
    pub row2: [f32; 4],
    /// Principal point `(cx, cy)` in pixels (the image centre unless the camera says otherwise).
    pub centre: [f32; 2],
    /// Pixels per unit of `(c.x/d, c.y/d)` (perspective: the focal lengths `fx, fy`) or of
    /// `(c.x, c.y)` (orthographic).
    pub scale: [f32; 2],
    /// 1 for perspective, 0 for orthographic.
    pub perspective: u32,
    /// Near clipping depth.
    pub near: f32,
    /// Far clipping depth.
    pub far: f32,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Padding to the 16-byte alignment of the WGSL struct; zero.
    pub pad0: u32,
    /// Padding; zero.
    pub pad1: u32,
    /// Padding; zero.
    pub pad2: u32,
}

/// Largest GPU tile side in pixels: `coverage` has 256 invocations per tile.
pub const MAX_GPU_TILE_SIZE: u32 = 16;

/// Part length per tile side: see [`part_length`].
pub const PART_LENGTH_PER_TILE_SIDE: u32 = 4;
/// Shortest part: see [`part_length`].
pub const PART_LENGTH_MIN: u32 = 4;
/// Longest part: see [`part_length`].
pub const PART_LENGTH_MAX: u32 = 16;

/// Pixels per part of an edge along its major axis in `edge_grad` for a view with tiles of
/// `tile_size` pixels: 4 · tile_size, from 4 to 16 (the same formula as `part_length` in
/// `shaders/shared/parts.wgsl`, from the same constants, where the parts of an edge are counted
/// from its own first pixel line). Dense meshes (small tiles) get short parts, so that no
/// workgroup walks many pixels with long occluder lists.
pub fn part_length(tile_size: u32) -> u32 {
    (PART_LENGTH_PER_TILE_SIDE * tile_size).clamp(PART_LENGTH_MIN, PART_LENGTH_MAX)
}

/// Work items (candidate edge × part) per workgroup of `edge_grad.wgsl`'s `main` (its `ITEMS`),
/// whose 64 lanes take the items one after another and split each pixel's occluder scan.
pub const EDGE_GRAD_ITEMS_PER_WORKGROUP: u32 = 2;

/// Views per GPU frame: the size of the uniform array of views.
pub const MAX_VIEWS: usize = 256;

/// One view of a multi-view GPU frame (`GpuView` in `shaders/shared/layout.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuView {
    /// Raster constants, with the GPU's `tile_size` (`gpu::stages::gpu_tile_size`).
    pub raster: RasterParams,
    /// First pixel of this view in the concatenated images (masks: times `words_per_pixel`).
    pub pixel_offset: u32,
    /// First tile of this view in the concatenated tile arrays.
    pub tile_offset: u32,
    /// First vertex of this view's instance in the concatenated `positions` of a batch (0 for
    /// one mesh): `project` reads vertex `v` of the view at `positions[vertex_offset + v]`.
    pub vertex_offset: u32,
    /// Padding to 64 bytes.
    pub pad1: u32,
}

/// Sizes of a GPU frame (`FrameParams` in `shaders/shared/layout.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FrameParams {
    /// Number of views.
    pub view_count: u32,
    /// Vertices of the topology.
    pub vertex_count: u32,
    /// Triangles of the topology.
    pub triangle_count: u32,
    /// Edges of the topology.
    pub edge_count: u32,
    /// Tiles of all views.
    pub total_tiles: u32,
    /// Pixels of all views.
    pub total_pixels: u32,
    /// Capacity of the bin lists, entries.
    pub bin_capacity: u32,
    /// Index of the first list entry in the bins buffer (`total_tiles + 1`).
    pub bin_list_offset: u32,
    /// Index of the first face orientation in the classes buffer (`view_count · edge_count`).
    pub orient_offset: u32,
    /// Always 0 (an opaque zero that keeps shader compilers from fusing multiply-adds).
    pub zero: u32,
    /// Index of the first large-triangle list in the bins buffer (view `v`'s starts at
    /// `large_offset + v · triangle_count`).
    pub large_offset: u32,
    /// The most parts a candidate edge can have in `edge_grad`: the largest
    /// `floor(image side / part_length) + 1` of the views ([`part_length`]). The frame's own count
    /// is the status counter `STATUS_PARTS`.
    pub parts: u32,
    /// Loop iterations one SIMD batch of invocations may run before `coverage` / `edge_grad` stop
    /// and report it: `LLVMPIPE_LOOP_BUDGET` (60,000) on llvmpipe, 0 (no limit) elsewhere.
    pub loop_budget: u32,
    /// Capacity of the `edge_grad` partials buffer, entries: a fused step whose candidates ×
    /// parts exceed it skips `edge_grad` and flags the status counter `STATUS_PARTIALS_SHORT`.
    pub partial_capacity: u32,
    /// The device's `max_compute_workgroups_per_dimension`, for the indirect dispatch grid.
    pub max_workgroups: u32,
    /// Padding to 64 bytes.
    pub pad2: u32,
}

/// The frame uniform, binding 0 of every stage (`FrameUniform` in `shaders/shared/layout.wgsl`).
/// Only the first `64 + 64 · view_count` bytes are uploaded.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FrameUniform {
    /// Sizes.
    pub params: FrameParams,
    /// Per-view constants; entries past `view_count` are unused.
    pub views: [GpuView; MAX_VIEWS],
}

// Layout of the `status` buffer (u32 counters; see `shaders/shared/layout.wgsl`). The values are
// `usize` (they index the counters read back); the build checks them against the WGSL `u32`s.

/// Status counter: bin entries the frame needs.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_NEEDED: usize = 0;
/// Status counter: 1 when the bin entry count overflowed u32.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_OVERFLOW: usize = 1;
/// Status counter: candidate edges of all views (the length of the candidate list).
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_CANDIDATE_TOTAL: usize = 2;
/// Status counter: most loop iterations one invocation of `coverage` or `edge_grad` ran.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_MAX_ITERATIONS: usize = 3;
/// Status counter: 1 when a fused step skipped `edge_grad` because the partials buffer was too
/// small.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_PARTIALS_SHORT: usize = 4;
/// Status counter: parts per candidate edge in `edge_grad`, the most any candidate has (at most
/// [`FrameParams::parts`]).
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_PARTS: usize = 5;
/// First per-view status counter; view `v` has [`STATUS_VIEW_STRIDE`] from
/// `STATUS_VIEW_BASE + STATUS_VIEW_STRIDE·v` ([`status_index`]).
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_VIEW_BASE: usize = 6;
/// Status counters per view.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_VIEW_STRIDE: usize = 5;
/// Per-view status counter: culled triangles (forward).
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_CULLED: usize = 0;
/// Per-view status counter: candidate edges (forward).
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_CANDIDATES: usize = 1;
/// Per-view status counter: segments (backward).
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_SEGMENTS: usize = 2;
/// Per-view status counter: visible segments (backward).
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_VISIBLE: usize = 3;
/// Per-view status counter: large triangles (forward).
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const STATUS_LARGE: usize = 4;

/// Words in the status buffer for `views` views.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) fn status_len(views: usize) -> usize {
    STATUS_VIEW_BASE + STATUS_VIEW_STRIDE * views
}

/// Index of per-view counter `counter` of view `view` (`status_index` in WGSL).
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) fn status_index(view: usize, counter: usize) -> usize {
    STATUS_VIEW_BASE + STATUS_VIEW_STRIDE * view + counter
}

/// Loop iterations one shader invocation may run on Mesa's llvmpipe/lavapipe, which silently ends
/// every loop of an invocation after 65,535 iterations in total (gallivm's loop limiter). The
/// stages keep far below it (large triangles are listed per view instead of per tile, long edges
/// are split into parts) and report their largest count, so that a scene beyond it is an
/// [`crate::Error::GpuLimit`] there instead of a wrong result.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const LLVMPIPE_LOOP_LIMIT: u32 = 65_535;

/// Where the stages stop on llvmpipe: below [`LLVMPIPE_LOOP_LIMIT`] by a margin for the few loops
/// they do not count.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(crate) const LLVMPIPE_LOOP_BUDGET: u32 = 60_000;

#[cfg(feature = "gpu")]
include!(concat!(env!("OUT_DIR"), "/mirror_checks.rs"));

//! Buffer structs and frame layout of the WGSL stages (`shaders/*.wgsl`), twins of the structs in
//! `shaders/shared/layout.wgsl` (`tests/gpu_layout.rs` round-trips every field through the GPU).
//!
//! ## The stages
//!
//! | stage (shader)                         | CPU twin                      | one invocation per          |
//! |----------------------------------------|-------------------------------|-----------------------------|
//! | `project.wgsl` (`main` for 3D input, `snap_vertices` for screen input) | `cpu::project::project_and_snap` | view × vertex |
//! | `bin_count.wgsl`, `scan.wgsl`, `bin_fill.wgsl` | `cpu::bin::bin`; `bin_count` also `cpu::edges::face_orientations` | view × triangle (scan: one workgroup) |
//! | `coverage.wgsl`                        | `cpu::coverage::coverage`     | pixel; one workgroup per tile |
//! | `resolve.wgsl`                         | `cpu::resolve::resolve`       | pixel                       |
//! | `edges.wgsl`                           | `cpu::edges::edges`           | view × edge                 |
//! | `edge_grad.wgsl`                       | `cpu::edge_grad::edge_grad`   | candidate edge × part; 64 lanes share 2 |
//! | `gather.wgsl`                          | `cpu::gather::gather`         | view × vertex               |
//!
//! All views of a frame go through each stage in one dispatch: per-view buffers are concatenated
//! (screen vertices `view · V + v`, edge slots `view · E + e`, pixels and tiles at the offsets of
//! [`GpuView`]), and the frame uniform ([`FrameUniform`]) holds every view's constants.
//!
//! ## Tile size
//!
//! The GPU bins into square tiles of [`gpu_tile_size`] pixels per side, a power of two from 1 to
//! [`MAX_GPU_TILE_SIZE`] picked per view from the triangle density, so that a tile holds a few
//! dozen triangles at any resolution (a 16² image of a 70k-triangle mesh gets 1-pixel tiles, the
//! same mesh at 1024² 8-pixel tiles). `coverage` runs one workgroup of 256 invocations per tile,
//! `256 / tile_size²` lanes per pixel. Results do not depend on the tile size: coverage tests
//! every sample against every triangle whose (conservative) box touches the sample's tile, and
//! ORs the bits; visibility in `edge_grad` intersects the segment with every triangle listed in
//! the pixel's tile, and any triangle that can cover a point of the pixel is listed in every tile
//! that contains the pixel. So GPU and CPU agree bit for bit on coverage, and the same triangles
//! occlude the same segments, whatever tile sizes either picks.

use crate::layout::RasterParams;

/// Largest GPU tile side in pixels: `coverage` has 256 invocations per tile.
pub const MAX_GPU_TILE_SIZE: u32 = 16;

/// Pixels per part of an edge along its major axis in `edge_grad` for a view with tiles of
/// `tile_size` pixels: 4 · tile_size, from 4 to 16 (keep in sync with `part_length` in
/// `shaders/shared/parts.wgsl`, where the parts of an edge are counted from its own first pixel
/// line). Dense meshes (small tiles) get short parts, so that no workgroup walks many pixels with
/// long occluder lists.
pub fn part_length(tile_size: u32) -> u32 {
    (4 * tile_size).clamp(4, 16)
}

/// Work items (candidate edge × part) per workgroup of `edge_grad.wgsl`'s `main`, whose 64 lanes
/// take the items one after another and split each pixel's occluder scan (keep in sync with
/// `ITEMS` there).
pub const EDGE_GRAD_ITEMS_PER_WORKGROUP: u32 = 2;

/// Tiles per view above which [`gpu_tile_size`] takes larger tiles (the `scan` stage is one
/// workgroup).
const MAX_TILES_PER_VIEW: u64 = 1 << 18;

/// The GPU tile side for a view of `width` × `height` pixels of a mesh of `triangles` triangles:
/// the power of two nearest to `sqrt(4 · width · height / triangles)`, from 1 to
/// [`MAX_GPU_TILE_SIZE`], so a tile holds about 8 triangles' worth of area when the mesh fills the
/// view (a few dozen where it is dense), and at most 2^18 tiles per view.
pub fn gpu_tile_size(triangles: usize, width: u32, height: u32) -> u32 {
    let area = width as f64 * height as f64;
    let ideal = (4.0 * area / triangles.max(1) as f64).sqrt();
    let mut size = if ideal <= 1.0 { 1 } else { 1u32 << (ideal.log2().round() as u32).min(4) };
    while size < MAX_GPU_TILE_SIZE && width.div_ceil(size) as u64 * height.div_ceil(size) as u64 > MAX_TILES_PER_VIEW {
        size *= 2;
    }
    size.clamp(1, MAX_GPU_TILE_SIZE)
}

/// Views per GPU frame: the size of the uniform array of views (keep in sync with `MAX_VIEWS`).
pub const MAX_VIEWS: usize = 256;

/// One view of a multi-view GPU frame (keep in sync with `GpuView` in `shaders/shared/layout.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuView {
    /// Raster constants, with the GPU's `tile_size` ([`gpu_tile_size`]).
    pub raster: RasterParams,
    /// First pixel of this view in the concatenated images (masks: times `words_per_pixel`).
    pub pixel_offset: u32,
    /// First tile of this view in the concatenated tile arrays.
    pub tile_offset: u32,
    /// Padding to 64 bytes.
    pub pad: [u32; 2],
}

/// Sizes of a GPU frame (keep in sync with `FrameParams` in `shaders/shared/layout.wgsl`).
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
    /// is [`status::PARTS`].
    pub parts: u32,
    /// Loop iterations one SIMD batch of invocations may run before `coverage` / `edge_grad` stop
    /// and report it: [`LLVMPIPE_LOOP_BUDGET`] on llvmpipe, 0 (no limit) elsewhere.
    pub loop_budget: u32,
    /// Capacity of the `edge_grad` partials buffer, entries: a fused step whose candidates ×
    /// parts exceed it skips `edge_grad` and flags [`status::PARTIALS_SHORT`].
    pub partial_capacity: u32,
    /// The device's `max_compute_workgroups_per_dimension`, for the indirect dispatch grid.
    pub max_workgroups: u32,
    /// Padding to 64 bytes.
    pub pad: [u32; 1],
}

/// The frame uniform, binding 0 of every stage (keep in sync with `Frame` in
/// `shaders/shared/layout.wgsl`). Only the first `64 + 64 · view_count` bytes are uploaded.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FrameUniform {
    /// Sizes.
    pub params: FrameParams,
    /// Per-view constants; entries past `view_count` are unused.
    pub views: [GpuView; MAX_VIEWS],
}

/// Layout of the `status` buffer (u32 counters; see `shaders/shared/layout.wgsl`).
pub mod status {
    /// Bin entries the frame needs.
    pub const NEEDED: usize = 0;
    /// 1 when the bin entry count overflowed u32.
    pub const OVERFLOW: usize = 1;
    /// Candidate edges of all views (the length of the candidate list).
    pub const CANDIDATE_TOTAL: usize = 2;
    /// Most loop iterations one invocation of `coverage` or `edge_grad` ran.
    pub const MAX_ITERATIONS: usize = 3;
    /// 1 when a fused step skipped `edge_grad` because the partials buffer was too small.
    pub const PARTIALS_SHORT: usize = 4;
    /// Parts per candidate edge in `edge_grad`: the most any candidate has (at most
    /// [`FrameParams::parts`](super::FrameParams::parts)).
    pub const PARTS: usize = 5;
    /// First per-view counter; view `v` has [`VIEW_STRIDE`] from `VIEW_BASE + VIEW_STRIDE·v`.
    pub const VIEW_BASE: usize = 6;
    /// Counters per view.
    pub const VIEW_STRIDE: usize = 5;
    /// Culled triangles (forward).
    pub const CULLED: usize = 0;
    /// Candidate edges (forward).
    pub const CANDIDATES: usize = 1;
    /// Segments (backward).
    pub const SEGMENTS: usize = 2;
    /// Visible segments (backward).
    pub const VISIBLE: usize = 3;
    /// Large triangles (forward).
    pub const LARGE: usize = 4;

    /// Words in the status buffer for `views` views.
    pub fn len(views: usize) -> usize {
        VIEW_BASE + VIEW_STRIDE * views
    }

    /// Index of counter `counter` of view `view`.
    pub fn index(view: usize, counter: usize) -> usize {
        VIEW_BASE + VIEW_STRIDE * view + counter
    }
}

/// Loop iterations one shader invocation may run on Mesa's llvmpipe/lavapipe, which silently ends
/// every loop of an invocation after 65,535 iterations in total (gallivm's loop limiter). The
/// stages keep far below it (large triangles are listed per view instead of per tile, long edges
/// are split into parts) and report their largest count, so that a scene beyond it is an
/// [`crate::Error::GpuLimit`] there instead of a wrong result.
pub const LLVMPIPE_LOOP_LIMIT: u32 = 65_535;

/// Where the stages stop on llvmpipe: below [`LLVMPIPE_LOOP_LIMIT`] by a margin for the few loops
/// they do not count.
pub const LLVMPIPE_LOOP_BUDGET: u32 = 60_000;

/// Where each view's data lies in the concatenated buffers of a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameLayout {
    /// Per view, with offsets.
    pub views: Vec<GpuView>,
    /// Pixels of all views.
    pub total_pixels: u64,
    /// Tiles of all views.
    pub total_tiles: u64,
}

impl FrameLayout {
    /// Lays out views with these raster parameters for a mesh of `triangles` triangles (their
    /// tile size is set to [`gpu_tile_size`]).
    pub fn new(params: &[RasterParams], triangles: usize) -> FrameLayout {
        let mut views = Vec::with_capacity(params.len());
        let (mut pixels, mut tiles) = (0u64, 0u64);
        for p in params {
            let mut raster = *p;
            raster.set_tile_size(gpu_tile_size(triangles, p.width, p.height));
            views.push(GpuView {
                raster,
                pixel_offset: pixels.min(u32::MAX as u64) as u32,
                tile_offset: tiles.min(u32::MAX as u64) as u32,
                pad: [0; 2],
            });
            pixels += raster.pixel_count() as u64;
            tiles += raster.tile_count() as u64;
        }
        FrameLayout { views, total_pixels: pixels, total_tiles: tiles }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_match_the_wgsl_layout() {
        assert_eq!(std::mem::size_of::<RasterParams>(), 48);
        assert_eq!(std::mem::size_of::<GpuView>(), 64);
        assert_eq!(std::mem::size_of::<FrameParams>(), 64);
        assert_eq!(std::mem::size_of::<FrameUniform>(), 64 + 64 * MAX_VIEWS);
        assert_eq!(std::mem::size_of::<crate::layout::ScreenVertex>(), 16);
        assert_eq!(std::mem::size_of::<crate::layout::EdgeGrad>(), 16);
        assert_eq!(std::mem::size_of::<crate::ViewParams>(), 80);
    }

    #[test]
    fn layout_concatenates_views() {
        let a = RasterParams::new(20, 18, 4, 1.0, 0.0).unwrap();
        let b = RasterParams::new(33, 1, 2, 1.0, 0.0).unwrap();
        let layout = FrameLayout::new(&[a, b], 1);
        assert_eq!(layout.views[0].raster.tile_size, 16);
        assert_eq!(layout.views[0].raster.tiles_x, 2);
        assert_eq!(layout.views[0].raster.tiles_y, 2);
        assert_eq!(layout.views[1].pixel_offset, 360);
        assert_eq!(layout.views[1].tile_offset, 4);
        assert_eq!(layout.total_pixels, 393);
        assert_eq!(layout.total_tiles, 7);
        let dense = FrameLayout::new(&[a, b], 10_000);
        assert_eq!(dense.views[0].raster.tile_size, 1);
        assert_eq!(dense.views[1].tile_offset, 360);
        assert_eq!(dense.total_tiles, 393);
    }

    #[test]
    fn tile_size_follows_triangle_density() {
        assert_eq!(gpu_tile_size(69_451, 16, 16), 1);
        assert_eq!(gpu_tile_size(69_451, 64, 64), 1);
        assert_eq!(gpu_tile_size(69_451, 256, 256), 2);
        assert_eq!(gpu_tile_size(69_451, 1024, 1024), 8);
        assert_eq!(gpu_tile_size(2, 1024, 1024), 16);
        assert_eq!(gpu_tile_size(0, 7, 3), 8);
        // Huge images of dense meshes keep at most 2^18 tiles per view.
        assert_eq!(gpu_tile_size(100_000_000, 4096, 4096), 8);
    }
}

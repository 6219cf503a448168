//! The stage table of the GPU engine and the frame layout of the WGSL stages (`shaders/*.wgsl`);
//! the buffer structs are in [`crate::mirror`], twins of `shaders/shared/layout.wgsl`.
//!
//! ## The stages
//!
//! `STAGES` is the stage table: name, shader, entry point and how the stage dispatches. The
//! buffers a stage binds are not listed in Rust: `build/shaders.rs` reflects them from the entry
//! point ([`BINDINGS`](super::BINDINGS), with whether it reads or writes each) and the engine binds
//! them by WGSL variable name (`gpu::bindings`). For reference, in submission order (buffers by
//! WGSL name; every stage also reads the frame uniform `frame`):
//!
//! | stage | CPU twin | shader (entry point) | reads | writes | one work item per |
//! |-------|----------|----------------------|-------|--------|-------------------|
//! | `project` | `project_and_snap`, `src/cpu/project.rs` | `project.wgsl` (`main`) | `cameras`, `positions` | `screen`, `snapped` | view × vertex |
//! | `snap` (screen input) | `snap`, `src/cpu/project.rs` | `project.wgsl` (`snap_vertices`) | `screen` | `snapped` | view × vertex |
//! | `bin_count` | `bin`, `src/cpu/bin.rs`; `face_orientations`, `src/cpu/edges.rs` | `bin_count.wgsl` | `screen`, `snapped`, `triangles`, `counts`, `status` | `counts`, `status`, `bins`, `classes`, `occluders` | view × triangle |
//! | `scan` | `bin`, `src/cpu/bin.rs` | `scan.wgsl` | `counts` | `bins`, `status` | frame (one workgroup) |
//! | `bin_fill` | `bin`, `src/cpu/bin.rs` | `bin_fill.wgsl` | `screen`, `snapped`, `triangles`, `counts`, `bins`, `classes` | `counts`, `bins`, `occluders` | view × triangle |
//! | `coverage` | `coverage`, `src/cpu/coverage/` | `coverage.wgsl` | `snapped`, `triangles`, `bins`, `status` | `masks`, `status` | tile (a workgroup) |
//! | `resolve` | `resolve`, `src/cpu/resolve.rs` | `resolve.wgsl` | `masks` | `image` | pixel |
//! | `edges` | `edges`, `src/cpu/edges.rs` | `edges.wgsl` | `screen`, `triangles`, `edges`, `edge_faces`, `classes`, `status` | `classes`, `status` | view × edge |
//! | `loss` (step) | `squared_error`, `src/loss.rs` | `loss.wgsl` | `image`, `target_image` | `d_image`, `tile_losses` | tile (a workgroup) |
//! | `edge_grad_args` (fused step) | — | `edge_grad.wgsl` (`args`) | `status` | `status`, `dispatch_args` | frame (one invocation) |
//! | `edge_grad` | `edge_grad`, `src/cpu/edge_grad.rs` | `edge_grad.wgsl` (`main`) | `screen`, `occluders`, `edges`, `bins`, `classes`, `d_image`, `status`, `edge_faces` | `partials`, `status` | candidate edge × part; 64 lanes share 2 |
//! | `edge_sum` | `edge_grad` (its sum over an edge), `src/cpu/edge_grad.rs` | `edge_sum.wgsl` | `screen`, `edges`, `classes`, `partials`, `status` | `slots` | view × edge |
//! | `gather` | `gather`, `src/cpu/gather.rs` | `gather.wgsl` | `edges`, `vertex_edges`, `slots` | `grads` | view × vertex |
//!
//! Uploaded by the host: `frame`, `screen` or `positions` and `cameras`, `d_image` (backward),
//! `target_image` (step), and the topology (`triangles`, `edges`, `edge_faces`, `vertex_edges`);
//! cleared by the encoder: `counts` and `status` (forward), the backward's `status` counters. The
//! engine records each submission this way (`record.rs`), and a test checks that every buffer a
//! stage reads was uploaded, cleared or written by an earlier stage.
//!
//! All views of a frame go through each stage in one dispatch: per-view buffers are concatenated
//! (screen vertices `view · V + v`, edge slots `view · E + e`, pixels and tiles at the offsets of
//! [`GpuView`]), and the frame uniform ([`FrameUniform`](crate::mirror::FrameUniform)) holds every view's constants.
//! A batch (`Renderer::render_batch`) is one frame whose views are every view of every instance:
//! "view" in the table is then instance × view, and `positions` holds the instances' vertices
//! back to back, `project` reading view `k`'s from [`GpuView::vertex_offset`].
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

use crate::mirror::{GpuView, RasterParams, EDGE_GRAD_ITEMS_PER_WORKGROUP, MAX_GPU_TILE_SIZE};

/// A stage of the GPU engine: one compute entry point (see [`STAGES`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stage {
    Project,
    Snap,
    BinCount,
    Scan,
    BinFill,
    Coverage,
    Resolve,
    Edges,
    Loss,
    EdgeGradArgs,
    EdgeGrad,
    EdgeSum,
    Gather,
}

/// How a stage's work items become workgroups (its `@workgroup_size` is reflected at build time,
/// [`super::WORKGROUP_SIZES`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Grid {
    /// One work item per invocation: `ceil(items / workgroup size)` workgroups.
    PerInvocation,
    /// One work item per workgroup (the workgroup's invocations share it).
    PerWorkgroup,
    /// This many work items per workgroup.
    ItemsPerWorkgroup(u32),
}

/// One entry of the stage table.
#[derive(Clone, Copy, Debug)]
pub(crate) struct StageInfo {
    /// The stage.
    pub stage: Stage,
    /// Its name in timings, labels and recordings.
    pub name: &'static str,
    /// Its shader, a path under `shaders/`.
    pub shader: &'static str,
    /// Its entry point in the shader.
    pub entry_point: &'static str,
    /// How it dispatches.
    pub grid: Grid,
}

/// The stage table, in [`Stage`] order. The buffers a stage binds are the variables its entry point
/// uses, reflected at build time ([`super::BINDINGS`]) and looked up by name (`gpu::bindings`).
pub(crate) const STAGES: [StageInfo; 13] = [
    StageInfo {
        stage: Stage::Project,
        name: "project",
        shader: "project.wgsl",
        entry_point: "main",
        grid: Grid::PerInvocation,
    },
    StageInfo {
        stage: Stage::Snap,
        name: "snap",
        shader: "project.wgsl",
        entry_point: "snap_vertices",
        grid: Grid::PerInvocation,
    },
    StageInfo {
        stage: Stage::BinCount,
        name: "bin_count",
        shader: "bin_count.wgsl",
        entry_point: "main",
        grid: Grid::PerInvocation,
    },
    StageInfo { stage: Stage::Scan, name: "scan", shader: "scan.wgsl", entry_point: "main", grid: Grid::PerWorkgroup },
    StageInfo {
        stage: Stage::BinFill,
        name: "bin_fill",
        shader: "bin_fill.wgsl",
        entry_point: "main",
        grid: Grid::PerInvocation,
    },
    StageInfo {
        stage: Stage::Coverage,
        name: "coverage",
        shader: "coverage.wgsl",
        entry_point: "main",
        grid: Grid::PerWorkgroup,
    },
    StageInfo {
        stage: Stage::Resolve,
        name: "resolve",
        shader: "resolve.wgsl",
        entry_point: "main",
        grid: Grid::PerInvocation,
    },
    StageInfo {
        stage: Stage::Edges,
        name: "edges",
        shader: "edges.wgsl",
        entry_point: "main",
        grid: Grid::PerInvocation,
    },
    StageInfo { stage: Stage::Loss, name: "loss", shader: "loss.wgsl", entry_point: "main", grid: Grid::PerWorkgroup },
    StageInfo {
        stage: Stage::EdgeGradArgs,
        name: "edge_grad_args",
        shader: "edge_grad.wgsl",
        entry_point: "args",
        grid: Grid::PerWorkgroup,
    },
    StageInfo {
        stage: Stage::EdgeGrad,
        name: "edge_grad",
        shader: "edge_grad.wgsl",
        entry_point: "main",
        grid: Grid::ItemsPerWorkgroup(EDGE_GRAD_ITEMS_PER_WORKGROUP),
    },
    StageInfo {
        stage: Stage::EdgeSum,
        name: "edge_sum",
        shader: "edge_sum.wgsl",
        entry_point: "main",
        grid: Grid::PerInvocation,
    },
    StageInfo {
        stage: Stage::Gather,
        name: "gather",
        shader: "gather.wgsl",
        entry_point: "main",
        grid: Grid::PerInvocation,
    },
];

impl Stage {
    /// Every stage, in table order.
    pub const ALL: [Stage; 13] = {
        let mut all = [Stage::Project; 13];
        let mut i = 0;
        while i < STAGES.len() {
            all[i] = STAGES[i].stage;
            i += 1;
        }
        all
    };

    /// The stage's entry of [`STAGES`].
    pub fn info(self) -> &'static StageInfo {
        &STAGES[self as usize]
    }
}

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
                vertex_offset: 0,
                pad1: 0,
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
    use crate::mirror::{FrameParams, FrameUniform, MAX_VIEWS};

    #[test]
    fn sizes_match_the_wgsl_layout() {
        assert_eq!(std::mem::size_of::<RasterParams>(), 48);
        assert_eq!(std::mem::size_of::<GpuView>(), 64);
        assert_eq!(std::mem::size_of::<FrameParams>(), 64);
        assert_eq!(std::mem::size_of::<FrameUniform>(), 64 + 64 * MAX_VIEWS);
        assert_eq!(std::mem::size_of::<crate::mirror::ScreenVertex>(), 16);
        assert_eq!(std::mem::size_of::<crate::mirror::EdgeGrad>(), 16);
        assert_eq!(std::mem::size_of::<crate::ViewParams>(), 96);
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

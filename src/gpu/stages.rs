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

use crate::mirror::{GpuView, RasterParams, MAX_GPU_TILE_SIZE};

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
                pad0: 0,
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

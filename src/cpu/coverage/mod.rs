//! `coverage` — CPU twin of `shaders/coverage.wgsl`: triangles → F×F sample masks per pixel.
//!
//! The WGSL stage draws every triangle; the CPU fills the same masks from the view's contour
//! ([`contour`]): its work follows the silhouette, not the mesh. [`draw_triangles`], the CPU
//! drawing every triangle, is the reference it is tested against.
//!
//! A sample is covered when it lies inside any triangle, whatever the winding. Edge functions are
//! exact integers on the fixed-point grid of [`RasterParams`]; a sample exactly on an edge counts
//! for the triangle whose edge is a *top* or *left* edge (screen y down), so a sample on an edge
//! shared by two triangles is counted once and never dropped. Bit `b·F + a` of pixel (i, j)'s mask
//! (word `k / 32`, bit `k % 32`) is sample (a, b): column a, row b.

mod back_face;
mod bands;
pub mod contour;
mod setup;
mod triangle;

use crate::mirror::RasterParams;

pub use back_face::BackFaceSkip;
use bands::{draw_direct, draw_in_bands, DIRECT_WORDS};
pub use contour::{coverage, ContourScratch};
use setup::SetupPass;
pub use setup::TriangleSummary;
pub use triangle::SnappedTriangle;

/// The masks of [`coverage`] by drawing every triangle, as the WGSL stage does (the forward no
/// longer runs it; it is the reference the contour fill is tested against). Reads the snapped
/// vertices and triangles of one view; writes `masks` (`pixel_count · words_per_pixel` words)
/// and, on the way, every triangle's snapped bounding box into `boxes` (as [`coverage`] does).
/// With `skip`, leaves out the negative triangles it allows (see [`BackFaceSkip`]; the masks are
/// the same).
///
/// The CPU works in two passes. A pass over the triangles (parallel, in chunks) sets up those
/// that can cover a sample. It takes them in blocks of eight: the box, extent and sample box (the
/// sample positions inside the snapped bounding box) of a block's triangles are computed lane by
/// lane in loops the compiler vectorises, and only the triangles with no clipped vertex and a
/// non-empty sample box within the image go on, one by one, to the set-up, where a zero snapped
/// area or a skippable back face still leaves them out before any edge setup (at 16²–64² most of
/// a dense mesh's triangles cover no sample centre and stop at the block). For a small image each
/// task draws its set-up triangles at once into a mask of the whole image and the masks are OR-ed;
/// a larger image is split into horizontal bands, one task each, that draw the set-up triangles
/// overlapping them (the WGSL stage works per tile from the
/// `bin` stage's lists instead; the masks are the same because coverage is an OR over
/// triangles). Boxes of one sample are tested directly, small triangles sample by sample with
/// incremental edge functions, large ones row by row with exact spans; all evaluate
/// [`SnappedTriangle::covers`] exactly.
pub fn draw_triangles(
    params: &RasterParams,
    snapped: &[[i32; 2]],
    triangles: &[[u32; 3]],
    skip: Option<&BackFaceSkip>,
    boxes: &mut [[i32; 4]],
    masks: &mut [u32],
) -> TriangleSummary {
    let f = params.supersample as i64;
    let h = params.half_step as i64;
    let pass = SetupPass {
        h,
        last: [params.width as i64 * f - 1, params.height as i64 * f - 1],
        limit: params.width.max(params.height) as i64 * params.units as i64,
        skip,
    };
    if masks.len() <= DIRECT_WORDS {
        draw_direct(params, &pass, snapped, triangles, boxes, masks)
    } else {
        draw_in_bands(params, &pass, snapped, triangles, boxes, masks)
    }
}

/// The tests' random source: xorshift64 with uniform numbers in `[0, 1)` from the top 53 bits (as
/// `f32`, cast the result: the same value as dividing in `f32`).
#[cfg(test)]
fn xorshift(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

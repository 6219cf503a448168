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
pub use contour::{coverage, coverage_and_edges, ContourScratch, EdgesStage};
use setup::SetupPass;
pub use setup::TriangleSummary;
pub use triangle::SnappedTriangle;

/// The masks of [`coverage`] by drawing every triangle, as the WGSL stage does (the forward no
/// longer runs it; it is the reference the contour fill is tested against). Reads the snapped
/// vertices and triangles of one view; writes `masks` (`pixel_count · words_per_pixel` words)
/// and, on the way, every triangle's snapped bounding box into `boxes` (as
/// [`bin::snapped_boxes`](crate::cpu::bin::snapped_boxes) gives them).
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

/// The tests' damaged closed meshes: `kind` 0 keeps `triangles`, 1 punches holes (drops about
/// 5% of the faces), 2 flips about 3% of them, 3 keeps the first half (an open patch).
#[cfg(test)]
pub(crate) fn damage(triangles: &mut Vec<[u32; 3]>, kind: usize, rand: &mut impl FnMut() -> f64) {
    match kind {
        0 => {}
        1 => triangles.retain(|_| rand() > 0.05),
        2 => triangles.iter_mut().filter(|_| rand() < 0.03).for_each(|t| t.swap(1, 2)),
        _ => triangles.truncate(triangles.len() / 2),
    }
}

/// The tests' placements of a mesh on a `w × h` image at `F = f`: a random linear map of
/// `positions` (a projection, possibly folded; `scale` times the image size), plus up to ±0.3
/// pixel of noise unless `exact`, rounded to a grid of 1/(2F) pixel so that samples land on
/// edges and vertices.
#[cfg(test)]
fn folded_placement(
    positions: &[glam::Vec3],
    (w, h, f): (u32, u32, u32),
    scale: f64,
    exact: bool,
    rand: &mut impl FnMut() -> f64,
) -> Vec<crate::mirror::ScreenVertex> {
    let m = [rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand(), rand()];
    let grid = 2.0 * f as f64;
    let noise = if exact { 0.0 } else { 0.6 };
    positions
        .iter()
        .map(|p| {
            let (x, y) = (p.x as f64, p.y as f64 + m[5] * p.z as f64);
            let sx = w as f64 * (0.5 + scale * (m[0] * x + m[1] * y)) + noise * (rand() - 0.5);
            let sy = h as f64 * (0.5 + scale * (m[2] * x + m[3] * y)) + noise * (rand() - 0.5);
            let q = |c: f64| ((c * grid).round() / grid) as f32;
            crate::mirror::ScreenVertex { position: [q(sx), q(sy)], valid: 1, pad: 0 }
        })
        .collect()
}

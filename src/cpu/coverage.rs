//! `coverage` — CPU twin of `shaders/coverage.wgsl`: triangles → F×F sample masks per pixel.
//!
//! A sample is covered when it lies inside any triangle, whatever the winding. Edge functions are
//! exact integers on the fixed-point grid of [`RasterParams`]; a sample exactly on an edge counts
//! for the triangle whose edge is a *top* or *left* edge (screen y down), so a sample on an edge
//! shared by two triangles is counted once and never dropped. Bit `b·F + a` of pixel (i, j)'s mask
//! (word `k / 32`, bit `k % 32`) is sample (a, b): column a, row b.

use rayon::prelude::*;

use super::bin::Bins;
use crate::layout::{RasterParams, ScreenVertex};

/// A triangle snapped to the fixed-point grid, counter-clockwise in the edge-function sense
/// (positive area), with its top-left biases. `None` for culled or zero-area triangles.
#[derive(Clone, Copy, Debug)]
pub struct SnappedTriangle {
    /// Vertices in fixed-point units.
    pub v: [[i64; 2]; 3],
    /// 1 for top/left edges (a sample exactly on them is inside), else 0. Edge k runs v[k] → v[k+1].
    pub bias: [i64; 3],
}

impl SnappedTriangle {
    /// Snaps triangle `tri`; `None` when a vertex is clipped or the snapped area is zero.
    pub fn new(params: &RasterParams, screen: &[ScreenVertex], tri: [u32; 3]) -> Option<SnappedTriangle> {
        let s = tri.map(|i| screen[i as usize]);
        if s.iter().any(|s| s.valid == 0) {
            return None;
        }
        let mut v = s.map(|s| [params.snap(s.position[0]) as i64, params.snap(s.position[1]) as i64]);
        let area2 = (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[1][1] - v[0][1]) * (v[2][0] - v[0][0]);
        if area2 == 0 {
            return None;
        }
        if area2 < 0 {
            v.swap(1, 2);
        }
        let bias = [0, 1, 2].map(|k| {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            // Interior is where E > 0; with y down that makes dy < 0 a left edge, dy = 0 & dx > 0 a top edge.
            (dy < 0 || (dy == 0 && dx > 0)) as i64
        });
        Some(SnappedTriangle { v, bias })
    }

    /// Edge function of edge k at point `p` (units): positive inside.
    pub fn edge_function(&self, k: usize, p: [i64; 2]) -> i64 {
        let (a, b) = (self.v[k], self.v[(k + 1) % 3]);
        (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    }

    /// Whether the sample at `p` (units) is covered.
    pub fn covers(&self, p: [i64; 2]) -> bool {
        (0..3).all(|k| self.edge_function(k, p) + self.bias[k] > 0)
    }

    /// Covered sample columns `[lo, hi]` in sample row `sy` (within `[col_lo, col_hi]`): the exact
    /// solution of the three edge inequalities for integer sample columns. Same result as testing
    /// [`SnappedTriangle::covers`] at every sample, which is what WGSL does.
    pub fn row_span(&self, params: &RasterParams, sy: i64, col_lo: i64, col_hi: i64) -> Option<(i64, i64)> {
        let h = params.half_step as i64;
        let py = (2 * sy + 1) * h;
        let (mut lo, mut hi) = (col_lo, col_hi);
        for k in 0..3 {
            let (a, b) = (self.v[k], self.v[(k + 1) % 3]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            // E(sx) + bias = c0 + c1·sx with px = (2·sx + 1)·h.
            let c1 = -dy * 2 * h;
            let c0 = dx * (py - a[1]) - dy * (h - a[0]) + self.bias[k];
            if c1 == 0 {
                if c0 <= 0 {
                    return None;
                }
            } else if c1 > 0 {
                lo = lo.max((-c0).div_euclid(c1) + 1); // c0 + c1·sx > 0  ⇔  sx > −c0/c1
            } else {
                hi = hi.min((c0 - 1).div_euclid(-c1)); // ⇔  sx < c0/(−c1)  ⇔  sx ≤ ⌊(c0 − 1)/(−c1)⌋
            }
        }
        (lo <= hi).then_some((lo, hi))
    }
}

/// Writes every pixel's sample mask. Reads the screen vertices, triangles and tile bins of one
/// view; writes `masks` (`pixel_count · words_per_pixel` words, zeroed here first).
pub fn coverage(
    params: &RasterParams,
    screen: &[ScreenVertex],
    triangles: &[[u32; 3]],
    bins: &Bins,
    masks: &mut [u32],
) {
    let f = params.supersample as i64;
    let wpp = params.words_per_pixel as usize;
    let row_words = params.width as usize * wpp;
    let tile = params.tile_size as i64;
    masks.par_chunks_mut(row_words * params.tile_size as usize).enumerate().for_each(|(ty, rows)| {
        rows.fill(0);
        let pixel_row0 = ty as i64 * tile;
        let sample_rows = (pixel_row0 * f, (pixel_row0 + tile).min(params.height as i64) * f - 1);
        for tx in 0..params.tiles_x as i64 {
            let sample_cols = (tx * tile * f, ((tx + 1) * tile).min(params.width as i64) * f - 1);
            for &t in bins.tile((ty as i64 * params.tiles_x as i64 + tx) as usize) {
                let Some(tri) = SnappedTriangle::new(params, screen, triangles[t as usize]) else { continue };
                let h = params.half_step as i64;
                let ymin = tri.v.iter().map(|v| v[1]).min().unwrap();
                let ymax = tri.v.iter().map(|v| v[1]).max().unwrap();
                // Sample rows whose y = (2·sy + 1)·h lies in [ymin, ymax].
                let sy0 = sample_rows.0.max((ymin - h + 2 * h - 1).div_euclid(2 * h));
                let sy1 = sample_rows.1.min((ymax - h).div_euclid(2 * h));
                for sy in sy0..=sy1 {
                    let Some((c0, c1)) = tri.row_span(params, sy, sample_cols.0, sample_cols.1) else { continue };
                    let local_row = (sy / f - pixel_row0) as usize;
                    let b = (sy % f) as u32;
                    for sx in c0..=c1 {
                        let bit = b * params.supersample + (sx % f) as u32;
                        let word = local_row * row_words + (sx / f) as usize * wpp + (bit / 32) as usize;
                        rows[word] |= 1 << (bit % 32);
                    }
                }
            }
        }
    });
}

//! The per-triangle pass: culling, sample boxes and top-left biases of the triangles that can
//! cover a sample, and what it counts on the way.

use super::back_face::BackFaceSkip;
use super::bands::Band;
use super::triangle::{area2, is_top_left, SnappedTriangle};
use crate::cpu::bin::CULLED_BOX;
use crate::mirror::{RasterParams, INVALID_SNAPPED_VERTEX};

/// What the per-triangle pass of [`coverage`](super::coverage) counts on the way (for the tile size of the `bin`
/// stage, [`bin::tile_size`](crate::cpu::bin::tile_size), and the render statistics).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TriangleSummary {
    /// Triangles with a clipped vertex (not drawn).
    pub culled: u32,
    /// Sum over the other triangles of their snapped extent, `max(width, height)` in units,
    /// capped at the image's larger side.
    pub extent_sum: u64,
    /// Number of those triangles.
    pub counted: u64,
}

impl std::ops::Add for TriangleSummary {
    type Output = TriangleSummary;
    fn add(self, o: TriangleSummary) -> TriangleSummary {
        TriangleSummary {
            culled: self.culled + o.culled,
            extent_sum: self.extent_sum + o.extent_sum,
            counted: self.counted + o.counted,
        }
    }
}

/// A triangle that covers at least one sample position of its box: vertices in positive order,
/// top-left biases as bits, and its sample box within the image.
#[derive(Clone, Copy, Debug)]
pub(super) struct Setup {
    v: [[i32; 2]; 3],
    bias: u8,
    cols: [i32; 2],
    rows: [i32; 2],
}

impl Setup {
    /// Draws the triangle's samples in sample rows `rows` (within its own) into `band`.
    #[inline(always)]
    pub(super) fn draw(&self, params: &RasterParams, rows: (i64, i64), band: &mut Band<'_>) {
        let h = params.half_step as i64;
        let tri = self.triangle();
        let cols = (self.cols[0] as i64, self.cols[1] as i64);
        let rows = ((self.rows[0] as i64).max(rows.0), (self.rows[1] as i64).min(rows.1));
        if cols.0 == cols.1 && rows.0 == rows.1 {
            if tri.covers([(2 * cols.0 + 1) * h, (2 * rows.0 + 1) * h]) {
                band.set_span(rows.0, cols);
            }
        } else if cols.1 - cols.0 < 8 {
            tri.raster_samples(params, cols, rows, band);
        } else {
            tri.raster_rows(params, cols, rows, band);
        }
    }

    fn triangle(&self) -> SnappedTriangle {
        SnappedTriangle {
            v: self.v.map(|p| [p[0] as i64, p[1] as i64]),
            bias: [0, 1, 2].map(|k| (self.bias >> k & 1) as i64),
        }
    }
}

/// `⌊n / d⌋` for a fixed `d > 0`: a shift or a division, so that the per-triangle pass is
/// compiled once for each, without a branch per division.
pub(super) trait FloorDiv: Copy {
    fn of(self, n: i64) -> i64;
}

/// Division by `2^k`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Shift(u32);

impl Shift {
    /// `Shift` for `d` when it is a power of two.
    #[inline]
    pub(super) fn of(d: i64) -> Option<Shift> {
        (d as u64).is_power_of_two().then(|| Shift(d.trailing_zeros()))
    }
}

impl FloorDiv for Shift {
    #[inline(always)]
    fn of(self, n: i64) -> i64 {
        n >> self.0
    }
}

/// Division by any positive number.
#[derive(Clone, Copy, Debug)]
pub(super) struct Divide(pub(super) i64);

impl FloorDiv for Divide {
    #[inline(always)]
    fn of(self, n: i64) -> i64 {
        n.div_euclid(self.0)
    }
}

/// The per-triangle pass of [`coverage`], its constants unpacked.
pub(super) struct SetupPass<'a> {
    /// Half the sample step, units.
    pub(super) h: i64,
    /// Last sample column and row of the image.
    pub(super) last: [i64; 2],
    /// Cap on a triangle's extent (the image's larger side, units).
    pub(super) limit: i64,
    pub(super) skip: Option<&'a BackFaceSkip>,
}

impl SetupPass<'_> {
    /// Sets up the triangles of `chunk` that can cover a sample and hands each to `sink` with its
    /// first and last sample rows; counts the triangles and writes each one's snapped bounding box
    /// into `boxes` (same length as `chunk`; [`CULLED_BOX`] for a culled one). `step` divides by
    /// the sample step.
    #[inline(always)]
    pub(super) fn run(
        &self,
        step: impl FloorDiv,
        snapped: &[[i32; 2]],
        chunk: &[[u32; 3]],
        boxes: &mut [[i32; 4]],
        mut sink: impl FnMut(&Setup, i64, i64),
    ) -> TriangleSummary {
        let h = self.h;
        let mut summary = TriangleSummary::default();
        for (tri, out) in chunk.iter().zip(boxes) {
            let v = tri.map(|i| snapped[i as usize]);
            // A clipped vertex is INVALID_SNAPPED_VERTEX; valid coordinates are within ±2^29.
            if v[0][0] == INVALID_SNAPPED_VERTEX[0]
                || v[1][0] == INVALID_SNAPPED_VERTEX[0]
                || v[2][0] == INVALID_SNAPPED_VERTEX[0]
            {
                summary.culled += 1;
                *out = CULLED_BOX;
                continue;
            }
            let b = [
                v[0][0].min(v[1][0]).min(v[2][0]),
                v[0][1].min(v[1][1]).min(v[2][1]),
                v[0][0].max(v[1][0]).max(v[2][0]),
                v[0][1].max(v[1][1]).max(v[2][1]),
            ];
            *out = b;
            summary.extent_sum += ((b[2] as i64 - b[0] as i64).max(b[3] as i64 - b[1] as i64)).min(self.limit) as u64;
            summary.counted += 1;
            // Sample c sits at (2c + 1)·h: the first at or after lo, the last at or before hi.
            let c0 = step.of(b[0] as i64 + h - 1).max(0);
            let c1 = step.of(b[2] as i64 - h).min(self.last[0]);
            let r0 = step.of(b[1] as i64 + h - 1).max(0);
            let r1 = step.of(b[3] as i64 - h).min(self.last[1]);
            if c0 > c1 || r0 > r1 {
                continue;
            }
            let w = v.map(|p| [p[0] as i64, p[1] as i64]);
            let area2 = area2(&w);
            if area2 == 0 || (area2 < 0 && self.skip.is_some_and(|s| s.skips(b))) {
                continue;
            }
            let (v, w) = if area2 < 0 { ([v[0], v[2], v[1]], [w[0], w[2], w[1]]) } else { (v, w) };
            let mut bias = 0u8;
            for k in 0..3 {
                bias |= (is_top_left(w[k], w[(k + 1) % 3]) as u8) << k;
            }
            sink(&Setup { v, bias, cols: [c0 as i32, c1 as i32], rows: [r0 as i32, r1 as i32] }, r0, r1);
        }
        summary
    }
}

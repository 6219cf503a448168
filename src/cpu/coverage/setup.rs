//! The per-triangle pass: culling, sample boxes and top-left biases of the triangles that can
//! cover a sample, and what it counts on the way.

use super::back_face::BackFaceSkip;
use super::bands::Band;
use super::triangle::{area2, is_top_left, SnappedTriangle};
use crate::cpu::bin::CULLED_BOX;
use crate::mirror::{RasterParams, INVALID_SNAPPED};

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
    /// The same on 32-bit integers (the lanes of the per-triangle pass).
    fn of32(self, n: i32) -> i32;
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
    #[inline(always)]
    fn of32(self, n: i32) -> i32 {
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
    #[inline(always)]
    fn of32(self, n: i32) -> i32 {
        // The sample step is at most 2·128 units.
        n.div_euclid(self.0 as i32)
    }
}

/// The per-triangle pass of [`draw_triangles`](super::draw_triangles), its constants unpacked.
pub(super) struct SetupPass<'a> {
    /// Half the sample step, units.
    pub(super) h: i64,
    /// Last sample column and row of the image.
    pub(super) last: [i64; 2],
    /// Cap on a triangle's extent (the image's larger side, units).
    pub(super) limit: i64,
    pub(super) skip: Option<&'a BackFaceSkip>,
}

/// Triangles per block of the per-triangle pass: the box and sample-box arithmetic of a block
/// runs lane by lane in loops the compiler vectorises, and only the triangles whose sample box is
/// non-empty go on to the (scalar) set-up.
pub(super) const BLOCK: usize = 8;

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
        let mut summary = TriangleSummary::default();
        let mut tris = chunk.chunks_exact(BLOCK);
        let mut outs = boxes.chunks_exact_mut(BLOCK);
        for (tris, outs) in (&mut tris).zip(&mut outs) {
            let tris: &[[u32; 3]; BLOCK] = tris.try_into().expect("a whole block");
            self.block(step, snapped, tris, outs, &mut summary, &mut sink);
        }
        let (rest, rest_boxes) = (tris.remainder(), outs.into_remainder());
        if let Some(&last) = rest.last() {
            // A short block: the missing lanes repeat the last triangle, and only `rest.len()`
            // lanes are written and counted.
            let mut padded = [last; BLOCK];
            padded[..rest.len()].copy_from_slice(rest);
            self.block(step, snapped, &padded, rest_boxes, &mut summary, &mut sink);
        }
        summary
    }

    /// [`SetupPass::run`] for one block of [`BLOCK`] triangles, of which the first `outs.len()`
    /// are real.
    #[inline(always)]
    fn block(
        &self,
        step: impl FloorDiv,
        snapped: &[[i32; 2]],
        tris: &[[u32; 3]; BLOCK],
        outs: &mut [[i32; 4]],
        summary: &mut TriangleSummary,
        sink: &mut impl FnMut(&Setup, i64, i64),
    ) {
        // Gather the vertices, lane by lane.
        let (mut x, mut y) = ([[0i32; BLOCK]; 3], [[0i32; BLOCK]; 3]);
        for (l, t) in tris.iter().enumerate() {
            for k in 0..3 {
                let p = snapped[t[k] as usize];
                (x[k][l], y[k][l]) = (p[0], p[1]);
            }
        }
        // Boxes, extents and sample boxes of all lanes. A clipped vertex is INVALID_SNAPPED_VERTEX;
        // valid coordinates are within ±2^29, so their differences and the sample-box bounds fit
        // in i32 (a clipped lane's may wrap: it is masked out).
        let h = self.h as i32;
        let (last_col, last_row, limit) = (self.last[0] as i32, self.last[1] as i32, self.limit as i32);
        let (mut lo_x, mut lo_y, mut hi_x, mut hi_y) = ([0i32; BLOCK], [0i32; BLOCK], [0i32; BLOCK], [0i32; BLOCK]);
        let (mut culled, mut extent, mut hit) = ([0i32; BLOCK], [0i32; BLOCK], [0i32; BLOCK]);
        let mut sample_box = [[0i32; 4]; BLOCK];
        for l in 0..BLOCK {
            let invalid = (x[0][l] == INVALID_SNAPPED) | (x[1][l] == INVALID_SNAPPED) | (x[2][l] == INVALID_SNAPPED);
            let b = [
                x[0][l].min(x[1][l]).min(x[2][l]),
                y[0][l].min(y[1][l]).min(y[2][l]),
                x[0][l].max(x[1][l]).max(x[2][l]),
                y[0][l].max(y[1][l]).max(y[2][l]),
            ];
            let e = b[2].wrapping_sub(b[0]).max(b[3].wrapping_sub(b[1])).min(limit);
            // Sample c sits at (2c + 1)·h: the first at or after lo, the last at or before hi.
            let c0 = step.of32(b[0].wrapping_add(h - 1)).max(0);
            let c1 = step.of32(b[2].wrapping_sub(h)).min(last_col);
            let r0 = step.of32(b[1].wrapping_add(h - 1)).max(0);
            let r1 = step.of32(b[3].wrapping_sub(h)).min(last_row);
            let valid = !invalid as i32;
            // CULLED_BOX for a clipped lane, branch-free: valid is 0 or 1, so −valid is 0 or −1.
            lo_x[l] = (b[0] & -valid) | (CULLED_BOX[0] & (valid - 1));
            lo_y[l] = (b[1] & -valid) | (CULLED_BOX[1] & (valid - 1));
            hi_x[l] = (b[2] & -valid) | (CULLED_BOX[2] & (valid - 1));
            hi_y[l] = (b[3] & -valid) | (CULLED_BOX[3] & (valid - 1));
            culled[l] = 1 - valid;
            extent[l] = e & -valid;
            hit[l] = valid & (c0 <= c1) as i32 & (r0 <= r1) as i32;
            sample_box[l] = [c0, c1, r0, r1];
        }
        let n = outs.len();
        for (l, out) in outs.iter_mut().enumerate() {
            *out = [lo_x[l], lo_y[l], hi_x[l], hi_y[l]];
        }
        let culled: i32 = culled[..n].iter().sum();
        summary.culled += culled as u32;
        summary.counted += (n as i32 - culled) as u64;
        summary.extent_sum += extent[..n].iter().sum::<i32>() as u64;
        let mut hits = hit[..n].iter().enumerate().fold(0u32, |m, (l, &h)| m | (h as u32) << l);
        while hits != 0 {
            let l = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            let b = [lo_x[l], lo_y[l], hi_x[l], hi_y[l]];
            self.set_up([0, 1, 2].map(|k| [x[k][l], y[k][l]]), b, sample_box[l], sink);
        }
    }

    /// The set-up of a triangle whose sample box `[c0, c1, r0, r1]` (first and last sample column
    /// and row) is not empty (vertices `v`, box `b`): hands it to `sink` unless its snapped area is
    /// zero or it is a skippable back face.
    #[inline(always)]
    fn set_up(&self, v: [[i32; 2]; 3], b: [i32; 4], sample_box: [i32; 4], sink: &mut impl FnMut(&Setup, i64, i64)) {
        let [c0, c1, r0, r1] = sample_box;
        let w = v.map(|p| [p[0] as i64, p[1] as i64]);
        let area2 = area2(&w);
        if area2 == 0 || (area2 < 0 && self.skip.is_some_and(|s| s.skips(b))) {
            return;
        }
        let (v, w) = if area2 < 0 { ([v[0], v[2], v[1]], [w[0], w[2], w[1]]) } else { (v, w) };
        let mut bias = 0u8;
        for k in 0..3 {
            bias |= (is_top_left(w[k], w[(k + 1) % 3]) as u8) << k;
        }
        sink(&Setup { v, bias, cols: [c0, c1], rows: [r0, r1] }, r0 as i64, r1 as i64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::coverage::{draw_triangles, xorshift};
    use crate::mirror::{ScreenVertex, COORD_LIMIT};

    /// Coverage of `n` random triangles (small and large, some off the image, some with a clipped
    /// vertex, some with vertices at the coordinate limit) against the per-sample predicate, the
    /// boxes against `bin::snapped_boxes` and the summary against its definition, for every
    /// length of the last, short block and for lengths spanning several tasks.
    #[test]
    fn blocks_of_every_length_match_the_per_sample_predicate() {
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
        let mut rand = move || next() as f32;
        let mut lengths: Vec<usize> = (0..=2 * BLOCK + 1).collect();
        lengths.extend([40 * BLOCK + 3, 20_000]);
        let (mut culled_any, mut drawn_any) = (false, false);
        for (case, &n) in lengths.iter().enumerate() {
            let (f, w, h) = [(4, 13, 9), (3, 10, 12), (1, 17, 5), (5, 8, 8)][case % 4];
            let params = RasterParams::new(w, h, f, 1.0, 0.0).unwrap();
            let mut screen = Vec::new();
            for k in 0..n {
                let c = [rand() * (w as f32 + 6.0) - 3.0, rand() * (h as f32 + 6.0) - 3.0];
                let size = [0.3, 1.5, 6.0][k % 3];
                for j in 0..3 {
                    let mut p = [c[0] + (rand() - 0.5) * size, c[1] + (rand() - 0.5) * size];
                    if k % 11 == 5 && j == 1 {
                        p[0] = (COORD_LIMIT - 1.0) * if k % 2 == 0 { 1.0 } else { -1.0 };
                    }
                    let valid = (k % 13 != 7 || j != 2) as u32;
                    screen.push(ScreenVertex { position: p, valid, pad: 0 });
                }
            }
            let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
            let triangles: Vec<[u32; 3]> = (0..n as u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
            let words = params.pixel_count() * params.words_per_pixel as usize;
            let (mut masks, mut boxes) = (vec![u32::MAX; words], vec![[1; 4]; n]);
            let summary = draw_triangles(&params, &snapped, &triangles, None, &mut boxes, &mut masks);
            assert_eq!(boxes, crate::cpu::bin::snapped_boxes(&snapped, &triangles), "n = {n}");
            let mut expected = TriangleSummary::default();
            let limit = w.max(h) as i64 * params.units as i64;
            for b in &boxes {
                if *b == CULLED_BOX {
                    expected.culled += 1;
                } else {
                    expected.counted += 1;
                    expected.extent_sum += ((b[2] - b[0]) as i64).max((b[3] - b[1]) as i64).min(limit) as u64;
                }
            }
            assert_eq!(summary, expected, "n = {n}");
            let hs = params.half_step as i64;
            let fs = f as i64;
            for py in 0..h as i64 * fs {
                for px in 0..w as i64 * fs {
                    let p = [(2 * px + 1) * hs, (2 * py + 1) * hs];
                    let covered =
                        triangles.iter().any(|&t| SnappedTriangle::new(&snapped, t).is_some_and(|t| t.covers(p)));
                    let (pixel, bit) = ((py / fs) * w as i64 + px / fs, (py % fs) * fs + px % fs);
                    let word = masks[pixel as usize * params.words_per_pixel as usize + bit as usize / 32];
                    assert_eq!(word >> (bit % 32) & 1 == 1, covered, "n = {n}, sample ({px}, {py})");
                    drawn_any |= covered;
                }
            }
            culled_any |= summary.culled > 0;
        }
        assert!(culled_any && drawn_any);
    }
}

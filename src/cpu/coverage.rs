//! `coverage` — CPU twin of `shaders/coverage.wgsl`: triangles → F×F sample masks per pixel.
//!
//! A sample is covered when it lies inside any triangle, whatever the winding. Edge functions are
//! exact integers on the fixed-point grid of [`RasterParams`]; a sample exactly on an edge counts
//! for the triangle whose edge is a *top* or *left* edge (screen y down), so a sample on an edge
//! shared by two triangles is counted once and never dropped. Bit `b·F + a` of pixel (i, j)'s mask
//! (word `k / 32`, bit `k % 32`) is sample (a, b): column a, row b.

use rayon::prelude::*;

use crate::mirror::{RasterParams, INVALID_SNAPPED_VERTEX};
use crate::scene::mesh::Topology;

/// A triangle snapped to the fixed-point grid, counter-clockwise in the edge-function sense
/// (positive area), with its top-left biases. `None` for culled or zero-area triangles.
#[derive(Clone, Copy, Debug)]
pub struct SnappedTriangle {
    /// Vertices in fixed-point units.
    pub v: [[i64; 2]; 3],
    /// 1 for top/left edges (a sample exactly on them is inside), else 0. Edge k runs `v[k] → v[k + 1]`.
    pub bias: [i64; 3],
}

impl SnappedTriangle {
    /// The snapped triangle `tri`; `None` when a vertex is clipped or the snapped area is zero.
    pub fn new(snapped: &[[i32; 2]], tri: [u32; 3]) -> Option<SnappedTriangle> {
        let s = tri.map(|i| snapped[i as usize]);
        if s.contains(&INVALID_SNAPPED_VERTEX) {
            return None;
        }
        let mut v = s.map(|p| [p[0] as i64, p[1] as i64]);
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
}

/// Boxes (fixed-point units, `[xmin, ymin, xmax, ymax]`, closed) that hold the oriented boundary
/// of a mesh in one view: outside them, the triangles of negative snapped area cover no sample
/// that the triangles of positive area do not, so [`coverage`] may skip them there.
///
/// Why this is exact. For a triangle of snapped area `A ≠ 0`, the top-left rule's indicator equals
/// `sign(A)` times a sum over its directed edges `a → b`, in the mesh's vertex order, of the
/// half-open crossing count `χ(a → b, p)`: `+1` when `a.y ≤ p.y < b.y` and `p` lies strictly left
/// of the edge, `−1` when `b.y ≤ p.y < a.y` and likewise, else 0 (so `χ(b → a) = −χ(a → b)`;
/// `tl_rule_is_a_crossing_count` checks the identity exhaustively on a small grid). Summed over
/// all triangles, `N₊(p) − N₋(p)` (the numbers of positive and negative triangles covering sample
/// `p`) is `Σ χ` over the directed edges, in which an edge run both ways cancels: what is left is
/// the winding number `B(p)` of the mesh's oriented boundary ([`Topology::boundary_components`]),
/// zero outside each component's bounding box. Where `B(p) = 0`, `N₋(p) > 0` implies `N₊(p) > 0`:
/// a sample covered by a negative triangle is covered by a positive one. So a negative triangle
/// whose box meets no boundary box can be left out, and the union of the rest is the same, bit for
/// bit. A closed, consistently oriented mesh (no boundary) needs no box: about half of its
/// triangles (the back faces, whichever way the camera looks) are skipped. The identity needs
/// every triangle in the sum, so there is no skip when a vertex is clipped.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BackFaceSkip {
    /// The boxes; merged into at most [`BackFaceSkip::MAX_BOXES`].
    pub boxes: Vec<[i32; 4]>,
    /// Their bounding box (empty when there is none), tested first.
    pub union: [i32; 4],
}

impl BackFaceSkip {
    /// Most boxes kept (components beyond are merged into the last boxes, which stays exact:
    /// a box that holds a component's box may replace it).
    pub const MAX_BOXES: usize = 8;

    /// The skip for `topology` seen with these snapped vertices, or `None` (no skip) when a
    /// vertex is clipped.
    pub fn new(topology: &Topology, snapped: &[[i32; 2]]) -> Option<BackFaceSkip> {
        if snapped.contains(&INVALID_SNAPPED_VERTEX) {
            return None;
        }
        let components = topology.boundary_components();
        let count = components.len();
        let kept = count.min(Self::MAX_BOXES);
        let mut boxes = vec![[i32::MAX, i32::MAX, i32::MIN, i32::MIN]; kept];
        for (k, component) in components.enumerate() {
            let b = &mut boxes[k * kept / count];
            for &v in component {
                let p = snapped[v as usize];
                *b = [b[0].min(p[0]), b[1].min(p[1]), b[2].max(p[0]), b[3].max(p[1])];
            }
        }
        let union = boxes.iter().fold([i32::MAX, i32::MAX, i32::MIN, i32::MIN], |u, b| {
            [u[0].min(b[0]), u[1].min(b[1]), u[2].max(b[2]), u[3].max(b[3])]
        });
        Some(BackFaceSkip { boxes, union })
    }

    /// Whether a negative triangle with this (closed) box may be skipped.
    #[inline]
    fn skips(&self, b: [i32; 4]) -> bool {
        let misses = |q: &[i32; 4]| b[0] > q[2] || b[2] < q[0] || b[1] > q[3] || b[3] < q[1];
        misses(&self.union) || self.boxes.iter().all(misses)
    }
}

/// What the per-triangle pass of [`coverage`] counts on the way (for the tile size of the `bin`
/// stage, [`bin::tile_size`](super::bin::tile_size), and the render statistics).
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
struct Setup {
    v: [[i32; 2]; 3],
    bias: u8,
    cols: [i32; 2],
    rows: [i32; 2],
}

impl Setup {
    /// Draws the triangle's samples in sample rows `rows` (within its own) into `band`.
    #[inline(always)]
    fn draw(&self, params: &RasterParams, rows: (i64, i64), band: &mut Band<'_>) {
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
trait FloorDiv: Copy {
    fn of(self, n: i64) -> i64;
}

/// Division by `2^k`.
#[derive(Clone, Copy, Debug)]
struct Shift(u32);

impl Shift {
    /// `Shift` for `d` when it is a power of two.
    fn of(d: i64) -> Option<Shift> {
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
struct Divide(i64);

impl FloorDiv for Divide {
    #[inline(always)]
    fn of(self, n: i64) -> i64 {
        n.div_euclid(self.0)
    }
}

/// The per-triangle pass of [`coverage`], its constants unpacked.
struct SetupPass<'a> {
    /// Half the sample step, units.
    h: i64,
    /// Last sample column and row of the image.
    last: [i64; 2],
    /// Cap on a triangle's extent (the image's larger side, units).
    limit: i64,
    skip: Option<&'a BackFaceSkip>,
}

impl SetupPass<'_> {
    /// Sets up the triangles of `chunk` that can cover a sample and hands each to `sink` with its
    /// first and last sample rows; counts the triangles. `step` divides by the sample step.
    #[inline(always)]
    fn run(
        &self,
        step: impl FloorDiv,
        snapped: &[[i32; 2]],
        chunk: &[[u32; 3]],
        mut sink: impl FnMut(&Setup, i64, i64),
    ) -> TriangleSummary {
        let h = self.h;
        let mut summary = TriangleSummary::default();
        for tri in chunk {
            let v = tri.map(|i| snapped[i as usize]);
            // A clipped vertex is INVALID_SNAPPED_VERTEX; valid coordinates are within ±2^29.
            if v[0][0] == INVALID_SNAPPED_VERTEX[0]
                || v[1][0] == INVALID_SNAPPED_VERTEX[0]
                || v[2][0] == INVALID_SNAPPED_VERTEX[0]
            {
                summary.culled += 1;
                continue;
            }
            let b = [
                v[0][0].min(v[1][0]).min(v[2][0]),
                v[0][1].min(v[1][1]).min(v[2][1]),
                v[0][0].max(v[1][0]).max(v[2][0]),
                v[0][1].max(v[1][1]).max(v[2][1]),
            ];
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
            let area2 = (w[1][0] - w[0][0]) * (w[2][1] - w[0][1]) - (w[1][1] - w[0][1]) * (w[2][0] - w[0][0]);
            if area2 == 0 || (area2 < 0 && self.skip.is_some_and(|s| s.skips(b))) {
                continue;
            }
            let (v, w) = if area2 < 0 { ([v[0], v[2], v[1]], [w[0], w[2], w[1]]) } else { (v, w) };
            let mut bias = 0u8;
            for k in 0..3 {
                let (a, b) = (w[k], w[(k + 1) % 3]);
                let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                // Interior is where E > 0; with y down that makes dy < 0 a left edge, dy = 0 & dx > 0 a top edge.
                bias |= ((dy < 0 || (dy == 0 && dx > 0)) as u8) << k;
            }
            sink(&Setup { v, bias, cols: [c0 as i32, c1 as i32], rows: [r0 as i32, r1 as i32] }, r0, r1);
        }
        summary
    }
}

/// Triangles per parallel task of the per-triangle pass.
const TRIANGLES_PER_TASK: usize = 4096;

/// Writes every pixel's sample mask. Reads the snapped vertices and triangles of one view;
/// writes `masks` (`pixel_count · words_per_pixel` words). With `skip`, leaves out the negative
/// triangles it allows (see [`BackFaceSkip`]; the masks are the same).
///
/// The CPU works in two passes. A pass over the triangles (parallel, in chunks) sets up those
/// that can cover a sample: a clipped vertex, a sample box (the sample positions inside the
/// snapped bounding box) that is empty or off-image, a zero snapped area or a skippable back face
/// leave a triangle out before any edge setup. The image is split into horizontal bands, one
/// task each, that draw the set-up triangles overlapping them (the WGSL stage works per tile from
/// the `bin` stage's lists instead; the masks are the same because coverage is an OR over
/// triangles). Boxes of one sample are tested directly, small triangles sample by sample with
/// incremental edge functions, large ones row by row with exact spans; all evaluate
/// [`SnappedTriangle::covers`] exactly.
pub fn coverage(
    params: &RasterParams,
    snapped: &[[i32; 2]],
    triangles: &[[u32; 3]],
    skip: Option<&BackFaceSkip>,
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
        draw_direct(params, &pass, snapped, triangles, masks)
    } else {
        draw_in_bands(params, &pass, snapped, triangles, masks)
    }
}

/// [`coverage`] for a small image: each task draws its triangles at once into a mask of the whole
/// image, and the masks are OR-ed (the same bits in any order).
fn draw_direct(
    params: &RasterParams,
    pass: &SetupPass<'_>,
    snapped: &[[i32; 2]],
    triangles: &[[u32; 3]],
    masks: &mut [u32],
) -> TriangleSummary {
    let f = params.supersample as i64;
    let step = 2 * pass.h;
    {
        let (drawn, summary) = triangles
            .par_chunks(TRIANGLES_PER_TASK)
            .fold(
                || (vec![0u32; masks.len()], TriangleSummary::default()),
                |(mut mask, summary), chunk| {
                    let mut band = Band::new(params, &mut mask, 0);
                    let full = (0, params.height as i64 * f - 1);
                    let draw = |setup: &Setup, _: i64, _: i64| setup.draw(params, full, &mut band);
                    let chunk_summary = match Shift::of(step) {
                        Some(s) => pass.run(s, snapped, chunk, draw),
                        None => pass.run(Divide(step), snapped, chunk, draw),
                    };
                    (mask, summary + chunk_summary)
                },
            )
            .reduce_with(|(mut a, sa), (b, sb)| {
                a.iter_mut().zip(&b).for_each(|(x, y)| *x |= y);
                (a, sa + sb)
            })
            .unwrap_or_else(|| (vec![0; masks.len()], TriangleSummary::default()));
        masks.copy_from_slice(&drawn);
        summary
    }
}

/// [`coverage`] for a larger image: the set-up triangles go to per-band lists, then each band
/// (one task) draws its own, its mask rows staying in cache.
fn draw_in_bands(
    params: &RasterParams,
    pass: &SetupPass<'_>,
    snapped: &[[i32; 2]],
    triangles: &[[u32; 3]],
    masks: &mut [u32],
) -> TriangleSummary {
    let f = params.supersample as i64;
    let row_words = params.width as usize * params.words_per_pixel as usize;
    let step = 2 * pass.h;
    let band_rows = band_height(params.height, triangles.len());
    let bands = params.height.div_ceil(band_rows) as usize;
    let band_of = band_rows as i64 * f;
    let tasks: Vec<(Vec<Vec<Setup>>, TriangleSummary)> = triangles
        .par_chunks(TRIANGLES_PER_TASK)
        .map(|chunk| {
            let mut lists = vec![Vec::new(); bands];
            let summary = match (Shift::of(step), Shift::of(band_of)) {
                (Some(s), Some(b)) => pass.run(s, snapped, chunk, |setup, r0, r1| push(&mut lists, b, setup, r0, r1)),
                (Some(s), None) => {
                    pass.run(s, snapped, chunk, |setup, r0, r1| push(&mut lists, Divide(band_of), setup, r0, r1))
                }
                (None, Some(b)) => {
                    pass.run(Divide(step), snapped, chunk, |setup, r0, r1| push(&mut lists, b, setup, r0, r1))
                }
                (None, None) => pass.run(Divide(step), snapped, chunk, |setup, r0, r1| {
                    push(&mut lists, Divide(band_of), setup, r0, r1)
                }),
            };
            (lists, summary)
        })
        .collect();
    masks.par_chunks_mut(row_words * band_rows as usize).enumerate().for_each(|(band_index, rows)| {
        rows.fill(0);
        let pixel_row0 = band_index as i64 * band_rows as i64;
        let band_sample_rows = (pixel_row0 * f, (pixel_row0 + band_rows as i64).min(params.height as i64) * f - 1);
        let mut band = Band::new(params, rows, pixel_row0);
        for setup in tasks.iter().flat_map(|t| &t.0[band_index]) {
            setup.draw(params, band_sample_rows, &mut band);
        }
    });
    tasks.iter().fold(TriangleSummary::default(), |a, t| a + t.1)
}

/// Mask words up to which [`coverage`] draws each task's triangles into a mask of the whole image
/// (64² pixels at F ≤ 5) rather than sorting them into bands first.
const DIRECT_WORDS: usize = 64 * 64;

/// Appends `setup` to the lists of the bands its sample rows `r0..=r1` overlap.
#[inline(always)]
fn push(lists: &mut [Vec<Setup>], band_of: impl FloorDiv, setup: &Setup, r0: i64, r1: i64) {
    for list in &mut lists[band_of.of(r0) as usize..=band_of.of(r1) as usize] {
        list.push(*setup);
    }
}

/// Pixel rows per band: enough bands to keep both cores busy and the per-band mask block in
/// cache, few enough that a triangle rarely spans two.
fn band_height(height: u32, triangles: usize) -> u32 {
    let bands = if triangles < 64 { 4 } else { 16 };
    height.div_ceil(bands).max(1)
}

/// The mask rows of one band, written by one thread.
struct Band<'a> {
    params: &'a RasterParams,
    rows: &'a mut [u32],
    row_words: usize,
    wpp: usize,
    pixel_row0: i64,
}

impl<'a> Band<'a> {
    /// The band whose first pixel row is `pixel_row0`, its mask rows `rows`.
    fn new(params: &'a RasterParams, rows: &'a mut [u32], pixel_row0: i64) -> Band<'a> {
        let wpp = params.words_per_pixel as usize;
        Band { params, rows, row_words: params.width as usize * wpp, wpp, pixel_row0 }
    }

    /// Sets samples `span.0..=span.1` of sample row `sy`, a pixel's worth of bits at a time.
    #[inline]
    fn set_span(&mut self, sy: i64, span: (i64, i64)) {
        let f = self.params.supersample;
        let (sy, first, last) = (sy as u32, span.0 as u32, span.1 as u32);
        let (sy_pixel, first_pixel, last_pixel) =
            if f == 4 { (sy >> 2, first >> 2, last >> 2) } else { (sy / f, first / f, last / f) };
        let row = (sy_pixel - self.pixel_row0 as u32) as usize * self.row_words;
        let bit_row = (sy - sy_pixel * f) * f;
        let (a_first, a_last) = (first - first_pixel * f, last - last_pixel * f);
        if self.wpp == 1 {
            // One word per pixel (F ≤ 5): the pixels strictly inside the span get a whole row of
            // F bits, the two ends their part of it.
            let row_bits = bit_range(bit_row, bit_row + f - 1);
            let words = &mut self.rows[row + first_pixel as usize..=row + last_pixel as usize];
            if let [only] = words {
                *only |= bit_range(bit_row + a_first, bit_row + a_last);
            } else if let [head, middle @ .., tail] = words {
                *head |= bit_range(bit_row + a_first, bit_row + f - 1);
                middle.iter_mut().for_each(|w| *w |= row_bits);
                *tail |= bit_range(bit_row, bit_row + a_last);
            }
            return;
        }
        let mut pixel = first_pixel;
        let mut a0 = a_first;
        while pixel <= last_pixel {
            let a1 = if pixel == last_pixel { a_last } else { f - 1 };
            let (lo, hi) = (bit_row + a0, bit_row + a1);
            let base = row + pixel as usize * self.wpp;
            if hi / 32 == lo / 32 {
                self.rows[base + (lo / 32) as usize] |= bit_range(lo % 32, hi % 32);
            } else {
                for bit in lo..=hi {
                    self.rows[base + (bit / 32) as usize] |= 1 << (bit % 32);
                }
            }
            pixel += 1;
            a0 = 0;
        }
    }
}

/// Which side of a row span an edge bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Bound {
    Lower,
    Upper,
    RowTest,
}

/// `(⌊n / m⌋, n mod m)` for `m > 0`, exactly: an f64 estimate corrected with integer arithmetic
/// (much cheaper than a 64-bit integer division).
fn floor_div(n: i64, m: i64) -> (i64, i64) {
    // Truncation (not `floor`, a library call without SSE4.1): the loops correct any estimate.
    let mut q = (n as f64 / m as f64) as i64;
    let mut r = n - q * m;
    while r < 0 {
        q -= 1;
        r += m;
    }
    while r >= m {
        q += 1;
        r -= m;
    }
    (q, r)
}

/// Bits `lo..=hi` of a word.
fn bit_range(lo: u32, hi: u32) -> u32 {
    (u32::MAX >> (31 - hi)) & (u32::MAX << lo)
}

impl SnappedTriangle {
    /// Covers rows `rows` (sample rows, within columns `cols`) by exact spans, each edge's bound
    /// stepped from row to row with an incremental floor division (a few divisions per triangle,
    /// none per row). Same samples as testing [`SnappedTriangle::covers`] at each one.
    fn raster_rows(&self, params: &RasterParams, cols: (i64, i64), rows: (i64, i64), band: &mut Band<'_>) {
        let h = params.half_step as i64;
        let py0 = (2 * rows.0 + 1) * h;
        // Per edge: the bound is q (+1 for a lower bound), q/r an exact running floor division by m.
        let (mut q, mut r, mut m, mut dq, mut dr) = ([0i64; 3], [0i64; 3], [0i64; 3], [0i64; 3], [0i64; 3]);
        let mut kind = [Bound::Lower; 3];
        for k in 0..3 {
            let (a, b) = (self.v[k], self.v[(k + 1) % 3]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let c1 = -dy * 2 * h;
            let c0 = dx * (py0 - a[1]) - dy * (h - a[0]) + self.bias[k];
            let dc0 = dx * 2 * h; // change of c0 per sample row
            let (n, dn) = if c1 == 0 {
                kind[k] = Bound::RowTest; // parallel to the rows: the row passes while c0 > 0
                q[k] = c0;
                dq[k] = dc0;
                continue;
            } else if c1 > 0 {
                kind[k] = Bound::Lower; // sx ≥ ⌊−c0/c1⌋ + 1
                m[k] = c1;
                (-c0, -dc0)
            } else {
                kind[k] = Bound::Upper; // sx ≤ ⌊(c0 − 1)/(−c1)⌋
                m[k] = -c1;
                (c0 - 1, dc0)
            };
            (q[k], r[k]) = floor_div(n, m[k]);
            (dq[k], dr[k]) = floor_div(dn, m[k]);
        }
        for sy in rows.0..=rows.1 {
            let (mut lo, mut hi, mut pass) = (cols.0, cols.1, true);
            for k in 0..3 {
                match kind[k] {
                    Bound::Lower => lo = lo.max(q[k] + 1),
                    Bound::Upper => hi = hi.min(q[k]),
                    Bound::RowTest => pass &= q[k] > 0,
                }
            }
            if pass && lo <= hi {
                band.set_span(sy, (lo, hi));
            }
            for k in 0..3 {
                q[k] += dq[k];
                r[k] += dr[k];
                if m[k] != 0 && r[k] >= m[k] {
                    r[k] -= m[k];
                    q[k] += 1;
                }
            }
        }
    }

    /// Tests every sample of the box with incremental edge functions.
    fn raster_samples(&self, params: &RasterParams, cols: (i64, i64), rows: (i64, i64), band: &mut Band<'_>) {
        let h = params.half_step as i64;
        let f = params.supersample as i64;
        let p0 = [(2 * cols.0 + 1) * h, (2 * rows.0 + 1) * h];
        let mut row_e = [0, 1, 2].map(|k| self.edge_function(k, p0) + self.bias[k]);
        let step_x = [0, 1, 2].map(|k| -(self.v[(k + 1) % 3][1] - self.v[k][1]) * 2 * h);
        let step_y = [0, 1, 2].map(|k| (self.v[(k + 1) % 3][0] - self.v[k][0]) * 2 * h);
        // Walk pixel by pixel and row by row (no division per sample or row).
        let (first_pixel, first_a) = ((cols.0 / f) as usize, (cols.0 % f) as u32);
        let (mut pixel_row, mut b) = ((rows.0 / f - band.pixel_row0) as usize, (rows.0 % f) as u32);
        for _ in rows.0..=rows.1 {
            let mut e = row_e;
            let row = pixel_row * band.row_words;
            let bit_row = b * f as u32;
            let (mut pixel, mut a) = (first_pixel, first_a);
            for _ in cols.0..=cols.1 {
                if e[0] > 0 && e[1] > 0 && e[2] > 0 {
                    let bit = bit_row + a;
                    band.rows[row + pixel * band.wpp + (bit / 32) as usize] |= 1 << (bit % 32);
                }
                for k in 0..3 {
                    e[k] += step_x[k];
                }
                a += 1;
                if a == f as u32 {
                    a = 0;
                    pixel += 1;
                }
            }
            for k in 0..3 {
                row_e[k] += step_y[k];
            }
            b += 1;
            if b == f as u32 {
                b = 0;
                pixel_row += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mirror::ScreenVertex;

    #[test]
    fn floor_div_is_exact() {
        for (n, m) in
            [(7i64, 2i64), (-7, 2), (0, 5), (-1, 5), (1 << 61, 3), (-(1 << 61) + 7, 1 << 40), (123456789012345, 97)]
        {
            assert_eq!(floor_div(n, m), (n.div_euclid(m), n.rem_euclid(m)), "{n} / {m}");
        }
    }

    /// The fast paths set exactly the samples the reference predicate `covers` accepts.
    #[test]
    fn fast_paths_match_the_per_sample_predicate() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rand = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f32 / (1u64 << 53) as f32
        };
        for f in [1, 3, 4, 6] {
            let mut params = RasterParams::new(24, 20, f, 1.0, 0.0).unwrap();
            params.set_tile_size(8);
            for _ in 0..60 {
                // Mix small and large triangles, some on exact sample/pixel positions.
                let scale = if rand() < 0.5 { 4.0 } else { 40.0 };
                let screen: Vec<ScreenVertex> = (0..3)
                    .map(|_| {
                        let mut p = [rand() * scale - 4.0 + rand() * 16.0, rand() * scale - 4.0 + rand() * 12.0];
                        if rand() < 0.3 {
                            p = p.map(|c| (c * 2.0).round() / 2.0);
                        }
                        ScreenVertex { position: p, valid: 1, pad: 0 }
                    })
                    .collect();
                let tris = [[0u32, 1, 2]];
                let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
                let mut masks = vec![0u32; params.pixel_count() * params.words_per_pixel as usize];
                coverage(&params, &snapped, &tris, None, &mut masks);
                let tri = SnappedTriangle::new(&snapped, tris[0]);
                let h = params.half_step as i64;
                for sy in 0..(params.height * f) as i64 {
                    for sx in 0..(params.width * f) as i64 {
                        let expected = tri.is_some_and(|t| t.covers([(2 * sx + 1) * h, (2 * sy + 1) * h]));
                        let pixel = (sy / f as i64) as usize * params.width as usize + (sx / f as i64) as usize;
                        let bit = (sy % f as i64) as usize * f as usize + (sx % f as i64) as usize;
                        let word = masks[pixel * params.words_per_pixel as usize + bit / 32];
                        assert_eq!(word >> (bit % 32) & 1 == 1, expected, "F={f} sample ({sx},{sy}) {screen:?}");
                    }
                }
            }
        }
    }

    /// `χ(a → b, p)` of [`BackFaceSkip`]: the half-open crossing count of a ray from `p` towards +x.
    fn crossing(a: [i64; 2], b: [i64; 2], p: [i64; 2]) -> i64 {
        // E(p) for the edge a → b (positive to the left of a downward edge, y down).
        let e = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        if a[1] <= p[1] && p[1] < b[1] && e > 0 {
            1
        } else if b[1] <= p[1] && p[1] < a[1] && e < 0 {
            -1
        } else {
            0
        }
    }

    /// The lemma behind [`BackFaceSkip`], on every triangle of a 4×4 grid (all vertex orders,
    /// degenerate ones included) and every point around it: the top-left rule's indicator times
    /// the sign of the area is the sum of the crossing counts of the edges in the given order.
    #[test]
    fn tl_rule_is_a_crossing_count() {
        let grid: Vec<[i32; 2]> = (0..16).map(|k| [k % 4 * 2, k / 4 * 2]).collect();
        for a in 0..16u32 {
            for b in 0..16u32 {
                for c in 0..16u32 {
                    let tri = [a, b, c];
                    let v = tri.map(|i| grid[i as usize]).map(|p| [p[0] as i64, p[1] as i64]);
                    let area2 = (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[1][1] - v[0][1]) * (v[2][0] - v[0][0]);
                    let snapped = SnappedTriangle::new(&grid, tri);
                    for py in -1..9 {
                        for px in -1..9 {
                            let p = [px, py];
                            let tl = snapped.is_some_and(|t| t.covers(p)) as i64 * area2.signum();
                            let chi: i64 = (0..3).map(|k| crossing(v[k], v[(k + 1) % 3], p)).sum();
                            assert_eq!(tl, chi, "{v:?} at {p:?}");
                        }
                    }
                }
            }
        }
    }

    /// Coverage with [`BackFaceSkip`] equals coverage without it, on closed meshes, meshes with
    /// holes and flipped faces, under random 2D placements of the vertices (wild overlaps,
    /// camera-independent) with many exact ties on sample positions.
    #[test]
    fn back_face_skip_changes_no_sample() {
        let mut seed = 0x0123_4567_89ab_cdefu64;
        let mut rand = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let sphere = crate::scene::shapes::icosphere(2);
        let closed = sphere.triangles().to_vec();
        let mut skipped_some = false;
        for case in 0..120 {
            let mut triangles = closed.clone();
            match case % 4 {
                0 => {}
                1 => triangles.retain(|_| rand() > 0.05), // holes
                2 => triangles.iter_mut().filter(|_| rand() < 0.03).for_each(|t| t.swap(1, 2)), // flipped faces
                _ => triangles.truncate(triangles.len() / 2), // a hemisphere-like patch
            }
            let f = [1, 3, 4, 5][case % 4];
            let (w, h) = (23 + case as u32 % 9, 17 + case as u32 % 5);
            let mut params = RasterParams::new(w, h, f, 1.0, 0.0).unwrap();
            params.set_tile_size(4);
            let topology = Topology::new(sphere.positions().len(), triangles.clone()).unwrap();
            // A random linear map of the sphere (a projection, possibly folded) plus noise,
            // rounded to a grid of 1/(2F) pixel so samples land on edges and vertices.
            let m = [rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand(), rand()];
            let grid = 2.0 * f as f64;
            let screen: Vec<ScreenVertex> = sphere
                .positions()
                .iter()
                .map(|p| {
                    let (x, y) = (p.x as f64, p.y as f64 + m[5] * p.z as f64);
                    let noise = if case % 3 == 0 { 0.0 } else { 0.6 };
                    let sx = w as f64 * (0.5 + 0.45 * (m[0] * x + m[1] * y)) + noise * (rand() - 0.5);
                    let sy = h as f64 * (0.5 + 0.45 * (m[2] * x + m[3] * y)) + noise * (rand() - 0.5);
                    let q = |c: f64| ((c * grid).round() / grid) as f32;
                    ScreenVertex { position: [q(sx), q(sy)], valid: 1, pad: 0 }
                })
                .collect();
            let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
            let skip = BackFaceSkip::new(&topology, &snapped).unwrap();
            assert_eq!(skip.boxes.is_empty(), case % 4 == 0, "case {case}");
            let words = params.pixel_count() * params.words_per_pixel as usize;
            let (mut all, mut culled) = (vec![0u32; words], vec![0u32; words]);
            let a = coverage(&params, &snapped, &triangles, None, &mut all);
            let b = coverage(&params, &snapped, &triangles, Some(&skip), &mut culled);
            assert_eq!(a, b, "case {case}");
            assert_eq!(all, culled, "case {case}: skipping back faces changed the masks");
            // The skip has teeth: dropping every negative triangle changes the open cases.
            let positive: Vec<[u32; 3]> = triangles
                .iter()
                .copied()
                .filter(|&t| {
                    let v = t.map(|i| snapped[i as usize]).map(|p| [p[0] as i64, p[1] as i64]);
                    (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[1][1] - v[0][1]) * (v[2][0] - v[0][0]) > 0
                })
                .collect();
            let mut front = vec![0u32; words];
            coverage(&params, &snapped, &positive, None, &mut front);
            if case % 4 == 0 {
                assert_eq!(front, all, "case {case}: a closed mesh's positive triangles cover it all");
            } else {
                skipped_some |= front != all;
            }
        }
        assert!(skipped_some, "no open case needed its negative triangles: the test has no teeth");
    }

    /// The two ways of drawing (whole-image masks per task, or bands) give the same masks.
    #[test]
    fn direct_and_banded_drawing_agree() {
        let mut seed = 0x3c6e_f372_fe94_f82bu64;
        let mut rand = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f32 / (1u64 << 53) as f32
        };
        for (f, w, h) in [(4, 64, 64), (3, 50, 37), (1, 31, 90), (6, 20, 20)] {
            let params = RasterParams::new(w, h, f, 1.0, 0.0).unwrap();
            // Triangles of all sizes (mostly small) around random centres, some off the image.
            let mut screen = Vec::new();
            for k in 0..1500 {
                let c = [rand() * (w as f32 + 8.0) - 4.0, rand() * (h as f32 + 8.0) - 4.0];
                let size = if k % 10 == 0 { 12.0 } else { 1.5 };
                for _ in 0..3 {
                    let p = [c[0] + (rand() - 0.5) * size, c[1] + (rand() - 0.5) * size];
                    screen.push(ScreenVertex { position: p, valid: 1, pad: 0 });
                }
            }
            let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
            let triangles: Vec<[u32; 3]> = (0..1500).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
            let pass = SetupPass { h: params.half_step as i64, last: [0; 2], limit: 0, skip: None };
            let pass = SetupPass {
                last: [w as i64 * f as i64 - 1, h as i64 * f as i64 - 1],
                limit: w.max(h) as i64 * params.units as i64,
                ..pass
            };
            let words = params.pixel_count() * params.words_per_pixel as usize;
            let (mut a, mut b) = (vec![0u32; words], vec![0u32; words]);
            let sa = draw_direct(&params, &pass, &snapped, &triangles, &mut a);
            let sb = draw_in_bands(&params, &pass, &snapped, &triangles, &mut b);
            assert_eq!((sa, &a), (sb, &b), "F={f} {w}x{h}");
            assert!(a.iter().any(|&m| m != 0) && a.contains(&0));
        }
    }

    /// A clipped vertex turns the skip off (the identity needs every triangle).
    #[test]
    fn no_back_face_skip_with_a_clipped_vertex() {
        let sphere = crate::scene::shapes::icosphere(1);
        let mut snapped = vec![[5, 5]; sphere.positions().len()];
        assert!(BackFaceSkip::new(sphere.topology(), &snapped).is_some());
        snapped[3] = INVALID_SNAPPED_VERTEX;
        assert!(BackFaceSkip::new(sphere.topology(), &snapped).is_none());
    }
}

//! Drawing the set-up triangles: into a mask of the whole image per task (small images) or into
//! per-band lists, each band drawn by one task with its mask rows in cache.

use rayon::prelude::*;

use super::setup::{Divide, FloorDiv, Setup, SetupPass, Shift};
use super::TriangleSummary;
use crate::mirror::RasterParams;

/// Triangles per parallel task of the per-triangle pass.
const TRIANGLES_PER_TASK: usize = 8192;

/// [`draw_triangles`](super::draw_triangles) for a small image: each task draws its triangles
/// at once into a mask of the whole image, and the masks are OR-ed (the same bits in any order).
pub(super) fn draw_direct(
    params: &RasterParams,
    pass: &SetupPass<'_>,
    snapped: &[[i32; 2]],
    triangles: &[[u32; 3]],
    boxes: &mut [[i32; 4]],
    masks: &mut [u32],
) -> TriangleSummary {
    let f = params.supersample as i64;
    let step = 2 * pass.h;
    let full = (0, params.height as i64 * f - 1);
    let draw_chunk = |mask: &mut [u32], chunk: &[[u32; 3]], boxes: &mut [[i32; 4]]| {
        let mut band = Band::new(params, mask, 0);
        let draw = |setup: &Setup, _: i64, _: i64| setup.draw(params, full, &mut band);
        match Shift::of(step) {
            Some(s) => pass.run(s, snapped, chunk, boxes, draw),
            None => pass.run(Divide(step), snapped, chunk, boxes, draw),
        }
    };
    masks.fill(0);
    if triangles.len() <= TRIANGLES_PER_TASK {
        // One task: straight into the masks.
        return draw_chunk(masks, triangles, boxes);
    }
    let (drawn, summary) = triangles
        .par_chunks(TRIANGLES_PER_TASK)
        .zip(boxes.par_chunks_mut(TRIANGLES_PER_TASK))
        .fold(
            || (vec![0u32; masks.len()], TriangleSummary::default()),
            |(mut mask, summary), (chunk, boxes)| {
                let chunk_summary = draw_chunk(&mut mask, chunk, boxes);
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

/// [`draw_triangles`](super::draw_triangles) for a larger image: the set-up triangles go to
/// per-band lists, then each band (one task) draws its own, its mask rows staying in cache.
pub(super) fn draw_in_bands(
    params: &RasterParams,
    pass: &SetupPass<'_>,
    snapped: &[[i32; 2]],
    triangles: &[[u32; 3]],
    boxes: &mut [[i32; 4]],
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
        .zip(boxes.par_chunks_mut(TRIANGLES_PER_TASK))
        .map(|(chunk, boxes)| {
            let mut lists = vec![Vec::new(); bands];
            let summary = match (Shift::of(step), Shift::of(band_of)) {
                (Some(s), Some(b)) => {
                    pass.run(s, snapped, chunk, boxes, |setup, r0, r1| push(&mut lists, b, setup, r0, r1))
                }
                (Some(s), None) => {
                    pass.run(s, snapped, chunk, boxes, |setup, r0, r1| push(&mut lists, Divide(band_of), setup, r0, r1))
                }
                (None, Some(b)) => {
                    pass.run(Divide(step), snapped, chunk, boxes, |setup, r0, r1| push(&mut lists, b, setup, r0, r1))
                }
                (None, None) => pass.run(Divide(step), snapped, chunk, boxes, |setup, r0, r1| {
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

/// Mask words up to which [`draw_triangles`](super::draw_triangles) draws each task's triangles
/// into a mask of the whole image (64² pixels at F ≤ 5) rather than sorting them into bands
/// first.
pub(super) const DIRECT_WORDS: usize = 64 * 64;

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
pub(super) struct Band<'a> {
    pub(super) params: &'a RasterParams,
    pub(super) rows: &'a mut [u32],
    pub(super) row_words: usize,
    pub(super) wpp: usize,
    pub(super) pixel_row0: i64,
}

impl<'a> Band<'a> {
    /// The band whose first pixel row is `pixel_row0`, its mask rows `rows`.
    pub(super) fn new(params: &'a RasterParams, rows: &'a mut [u32], pixel_row0: i64) -> Band<'a> {
        let wpp = params.words_per_pixel as usize;
        Band { params, rows, row_words: params.width as usize * wpp, wpp, pixel_row0 }
    }

    /// Sets samples `span.0..=span.1` of sample row `sy`, a pixel's worth of bits at a time.
    #[inline]
    pub(super) fn set_span(&mut self, sy: i64, span: (i64, i64)) {
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

/// Bits `lo..=hi` of a word.
fn bit_range(lo: u32, hi: u32) -> u32 {
    (u32::MAX >> (31 - hi)) & (u32::MAX << lo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::coverage::xorshift;
    use crate::mirror::ScreenVertex;

    /// The two ways of drawing (whole-image masks per task, or bands) give the same masks.
    #[test]
    fn direct_and_banded_drawing_agree() {
        let mut next = xorshift(0x3c6e_f372_fe94_f82b);
        let mut rand = move || next() as f32;
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
            let (mut boxes_a, mut boxes_b) = (vec![[0; 4]; triangles.len()], vec![[0; 4]; triangles.len()]);
            let sa = draw_direct(&params, &pass, &snapped, &triangles, &mut boxes_a, &mut a);
            let sb = draw_in_bands(&params, &pass, &snapped, &triangles, &mut boxes_b, &mut b);
            assert_eq!((sa, &a), (sb, &b), "F={f} {w}x{h}");
            assert_eq!(boxes_a, crate::cpu::bin::snapped_boxes(&snapped, &triangles));
            assert_eq!(boxes_a, boxes_b);
            assert!(a.iter().any(|&m| m != 0) && a.contains(&0));
        }
    }
}

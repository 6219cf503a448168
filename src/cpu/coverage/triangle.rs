//! One snapped triangle: its edge functions with the top-left rule, and the fast paths that set
//! its samples in a band (sample by sample, or row by row with exact spans).

use super::bands::Band;
use crate::mirror::{RasterParams, INVALID_SNAPPED_VERTEX};

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
    #[inline]
    pub fn new(snapped: &[[i32; 2]], tri: [u32; 3]) -> Option<SnappedTriangle> {
        let s = tri.map(|i| snapped[i as usize]);
        if s.contains(&INVALID_SNAPPED_VERTEX) {
            return None;
        }
        let mut v = s.map(|p| [p[0] as i64, p[1] as i64]);
        let area2 = area2(&v);
        if area2 == 0 {
            return None;
        }
        if area2 < 0 {
            v.swap(1, 2);
        }
        let bias = [0, 1, 2].map(|k| is_top_left(v[k], v[(k + 1) % 3]) as i64);
        Some(SnappedTriangle { v, bias })
    }

    /// Edge function of edge k at point `p` (units): positive inside.
    #[inline]
    pub fn edge_function(&self, k: usize, p: [i64; 2]) -> i64 {
        let (a, b) = (self.v[k], self.v[(k + 1) % 3]);
        (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    }

    /// Whether the sample at `p` (units) is covered.
    #[inline]
    pub fn covers(&self, p: [i64; 2]) -> bool {
        (0..3).all(|k| self.edge_function(k, p) + self.bias[k] > 0)
    }
}

/// Twice the signed area of a snapped triangle (units²), positive when its edge functions are
/// positive inside.
#[inline(always)]
pub(super) fn area2(v: &[[i64; 2]; 3]) -> i64 {
    (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[1][1] - v[0][1]) * (v[2][0] - v[0][0])
}

/// Whether edge `a → b` of a triangle of positive area is a top or left edge: a sample exactly on
/// it is inside.
#[inline(always)]
pub(super) fn is_top_left(a: [i64; 2], b: [i64; 2]) -> bool {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    // Interior is where E > 0; with y down that makes dy < 0 a left edge, dy = 0 & dx > 0 a top edge.
    dy < 0 || (dy == 0 && dx > 0)
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
pub(super) fn floor_div(n: i64, m: i64) -> (i64, i64) {
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

impl SnappedTriangle {
    /// Covers rows `rows` (sample rows, within columns `cols`) by exact spans, each edge's bound
    /// stepped from row to row with an incremental floor division (a few divisions per triangle,
    /// none per row). Same samples as testing [`SnappedTriangle::covers`] at each one.
    #[inline]
    pub(super) fn raster_rows(&self, params: &RasterParams, cols: (i64, i64), rows: (i64, i64), band: &mut Band<'_>) {
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
    #[inline]
    pub(super) fn raster_samples(
        &self,
        params: &RasterParams,
        cols: (i64, i64),
        rows: (i64, i64),
        band: &mut Band<'_>,
    ) {
        let h = params.half_step as i64;
        let f = params.supersample as i64;
        let p0 = [(2 * cols.0 + 1) * h, (2 * rows.0 + 1) * h];
        let mut row_e = [0, 1, 2].map(|k| self.edge_function(k, p0) + self.bias[k]);
        let step_x = [0, 1, 2].map(|k| -(self.v[(k + 1) % 3][1] - self.v[k][1]) * 2 * h);
        let step_y = [0, 1, 2].map(|k| (self.v[(k + 1) % 3][0] - self.v[k][0]) * 2 * h);
        // Walk pixel by pixel and row by row (no division per sample or row).
        // Sample columns and rows are within the image (non-negative, below 2^32): 32-bit
        // divisions, much cheaper than 64-bit ones.
        let (c0, r0, fu) = (cols.0 as u32, rows.0 as u32, f as u32);
        let (first_pixel, first_a) = ((c0 / fu) as usize, c0 % fu);
        let (mut pixel_row, mut b) = ((r0 / fu) as usize - band.pixel_row0 as usize, r0 % fu);
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
    use crate::cpu::coverage::{draw_triangles, xorshift};
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
        let mut next = xorshift(0x2545_f491_4f6c_dd1d);
        let mut rand = move || next() as f32;
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
                draw_triangles(&params, &snapped, &tris, None, &mut vec![[0; 4]; tris.len()], &mut masks);
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
}

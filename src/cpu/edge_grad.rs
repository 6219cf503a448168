//! `edge_grad` — CPU twin of `shaders/edge_grad.wgsl`: per candidate edge, the analytic derivative
//! of the loss with respect to its two endpoints, over the pixels it crosses, visible parts only.
//!
//! For each candidate edge the stage walks the pixels the segment crosses (a scanline DDA: the
//! rows it spans, then the columns within each row), clips the segment to each pixel with
//! Liang–Barsky, removes the parts whose outside is covered by another triangle (exact intervals
//! along the segment, from the triangles binned in the pixel's tile), and applies the closed form
//! of DESIGN.md §2 ([`crate::closed_form`]). Each edge writes only its own slot: no atomics, and
//! the result does not depend on the thread count.

use glam::DVec2;
use rayon::prelude::*;

use super::bin::Bins;
use crate::closed_form::{clip_parameter, segment_weights};
use crate::layout::{EdgeGrad, RasterParams, ScreenVertex};
use crate::mesh::Topology;

/// Counts of (edge, pixel) segments the backward looked at.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SegmentStats {
    /// Segments of candidate edges in pixels with a non-zero incoming gradient.
    pub segments: u64,
    /// Those with a visible (unoccluded) part.
    pub visible_segments: u64,
}

impl std::ops::Add for SegmentStats {
    type Output = SegmentStats;
    fn add(self, o: SegmentStats) -> SegmentStats {
        SegmentStats {
            segments: self.segments + o.segments,
            visible_segments: self.visible_segments + o.visible_segments,
        }
    }
}

fn position(screen: &[ScreenVertex], v: u32) -> DVec2 {
    let p = screen[v as usize].position;
    DVec2::new(p[0] as f64, p[1] as f64)
}

/// Parameter intervals of `[sa, sb]` on `va + s·d` whose outside (`+ε·outward`) is inside triangle
/// `q`, appended to `out`. Exact for shared vertices and coincident edges (the products vanish
/// exactly), so a face adjacent to the edge never occludes it.
fn occluded_interval(q: [DVec2; 3], va: DVec2, vb: DVec2, outward: DVec2, sa: f64, sb: f64) -> Option<(f64, f64)> {
    let cross = |u: DVec2, v: DVec2| u.x * v.y - u.y * v.x;
    let area2 = cross(q[1] - q[0], q[2] - q[0]);
    if area2 == 0.0 {
        return None;
    }
    let o = area2.signum();
    let (mut lo, mut hi) = (sa, sb);
    for k in 0..3 {
        let (qa, qb) = (q[k], q[(k + 1) % 3]);
        let h = |p: DVec2| o * cross(qb - qa, p - qa);
        let alpha = h(va);
        let beta = h(vb) - alpha;
        if beta == 0.0 {
            let inward = o * DVec2::new(-(qb.y - qa.y), qb.x - qa.x);
            if alpha < 0.0 || (alpha == 0.0 && inward.dot(outward) <= 0.0) {
                return None;
            }
        } else if beta > 0.0 {
            lo = lo.max(-alpha / beta);
        } else {
            hi = hi.min(-alpha / beta);
        }
        if hi <= lo {
            return None;
        }
    }
    Some((lo, hi))
}

/// The gradient slot of one candidate edge. `inside` is the edge's side from the `edges` stage.
#[allow(clippy::too_many_arguments)]
pub fn edge_gradient(
    params: &RasterParams,
    screen: &[ScreenVertex],
    triangles: &[[u32; 3]],
    bins: &Bins,
    d_image: &[f32],
    edge: [u32; 2],
    inside: i32,
    scratch: &mut Vec<(f64, f64)>,
) -> (EdgeGrad, SegmentStats) {
    let mut stats = SegmentStats::default();
    let (va, vb) = (position(screen, edge[0]), position(screen, edge[1]));
    let d = vb - va;
    if inside == 0 || d == DVec2::ZERO {
        return (EdgeGrad::default(), stats);
    }
    // Outward normal times the edge length: the flux direction of DESIGN.md §2.
    let outward = inside as f64 * DVec2::new(d.y, -d.x);
    let (w, h) = (params.width as f64, params.height as f64);
    let mut s = (0.0, 1.0);
    if !(clip_parameter(va.x, d.x, 0.0, w, &mut s) && clip_parameter(va.y, d.y, 0.0, h, &mut s)) {
        return (EdgeGrad::default(), stats);
    }
    let scale = (params.inside - params.outside) as f64;
    let (mut wa, mut wb) = (0.0f64, 0.0f64);
    let y_at = |t: f64| va.y + t * d.y;
    let (ylo, yhi) = (y_at(s.0).min(y_at(s.1)), y_at(s.0).max(y_at(s.1)));
    let rows = (ylo.ceil() as i64 - 1).max(0)..=(yhi.floor() as i64).min(params.height as i64 - 1);
    for i in rows {
        let mut r = s;
        if !clip_parameter(va.y, d.y, i as f64, i as f64 + 1.0, &mut r) {
            continue;
        }
        let x_at = |t: f64| va.x + t * d.x;
        let (xlo, xhi) = (x_at(r.0).min(x_at(r.1)), x_at(r.0).max(x_at(r.1)));
        let cols = (xlo.ceil() as i64 - 1).max(0)..=(xhi.floor() as i64).min(params.width as i64 - 1);
        for j in cols {
            let mut c = r;
            if !clip_parameter(va.x, d.x, j as f64, j as f64 + 1.0, &mut c) || c.1 <= c.0 {
                continue;
            }
            // A segment lying on a pixel border belongs half to each side (the mean of the two
            // one-sided derivatives, which is what central differences measure).
            let on_border = (d.y == 0.0 && (va.y == i as f64 || va.y == i as f64 + 1.0))
                || (d.x == 0.0 && (va.x == j as f64 || va.x == j as f64 + 1.0));
            let g = d_image[i as usize * params.width as usize + j as usize] as f64
                * scale
                * if on_border { 0.5 } else { 1.0 };
            if g == 0.0 {
                continue;
            }
            stats.segments += 1;
            let tile = (i as u32 / params.tile_size) * params.tiles_x + j as u32 / params.tile_size;
            let (bb_lo, bb_hi) = (va + c.0 * d, va + c.1 * d);
            let (bb_lo, bb_hi) = (bb_lo.min(bb_hi), bb_lo.max(bb_hi));
            scratch.clear();
            for (t, b) in bins.tile(tile as usize) {
                if b[0] as f64 > bb_hi.x || b[1] as f64 > bb_hi.y || (b[2] as f64) < bb_lo.x || (b[3] as f64) < bb_lo.y
                {
                    continue;
                }
                let q = triangles[t as usize].map(|v| position(screen, v));
                if let Some(iv) = occluded_interval(q, va, vb, outward, c.0, c.1) {
                    scratch.push(iv);
                }
            }
            scratch.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
            let (mut visible_a, mut visible_b, mut cursor) = (0.0, 0.0, c.0);
            for &(lo, hi) in scratch.iter().chain(std::iter::once(&(c.1, c.1))) {
                if lo > cursor {
                    let [ka, kb] = segment_weights(cursor, lo);
                    visible_a += ka;
                    visible_b += kb;
                }
                cursor = cursor.max(hi);
            }
            if visible_a != 0.0 || visible_b != 0.0 {
                stats.visible_segments += 1;
            }
            wa += g * visible_a;
            wb += g * visible_b;
        }
    }
    let (ga, gb) = (outward * wa, outward * wb);
    (EdgeGrad { a: [ga.x as f32, ga.y as f32], b: [gb.x as f32, gb.y as f32] }, stats)
}

/// Runs [`edge_gradient`] for every candidate edge. Reads screen vertices, triangles, bins, edge
/// sides and `∂L/∂I`; writes one [`EdgeGrad`] slot per edge (zero for non-candidates).
#[allow(clippy::too_many_arguments)]
pub fn edge_grad(
    params: &RasterParams,
    screen: &[ScreenVertex],
    topology: &Topology,
    sides: &[i32],
    bins: &Bins,
    d_image: &[f32],
    slots: &mut [EdgeGrad],
) -> SegmentStats {
    let edges = topology.edges();
    slots
        .par_iter_mut()
        .with_min_len(256)
        .enumerate()
        .map_init(Vec::new, |scratch, (e, slot)| {
            let (grad, stats) = if sides[e] == 0 {
                (EdgeGrad::default(), SegmentStats::default())
            } else {
                edge_gradient(params, screen, topology.triangles(), bins, d_image, edges[e], sides[e], scratch)
            };
            *slot = grad;
            stats
        })
        .reduce(SegmentStats::default, |a, b| a + b)
}

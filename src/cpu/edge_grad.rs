//! `edge_grad` — CPU twin of `shaders/edge_grad.wgsl`: per candidate edge, the analytic derivative
//! of the loss with respect to its two endpoints, over the pixels it crosses, visible parts only.
//!
//! For each candidate edge the stage walks the pixels the segment crosses (a scanline DDA: the
//! rows it spans, then the columns within each row), clips the segment to each pixel with
//! Liang–Barsky, removes the parts whose outside is covered by a triangle (exact intervals along
//! the segment; the CPU finds them from the view's contour, [`contour`], the WGSL stage from the
//! triangles binned near the segment), and applies the closed form of ARCHITECTURE.md, *The
//! method* ([`crate::reference::closed_form`]). Each edge writes only its own slot: no atomics,
//! and the result does not depend on the thread count.

use glam::DVec2;
use rayon::prelude::*;

use crate::engine::BackwardStats;
use crate::mirror::{EdgeGrad, RasterParams, ScreenVertex};
use crate::reference::closed_form::clip_parameter;
use crate::scene::mesh::Topology;
use contour::{ContourBands, EdgeContour};

fn position(screen: &[ScreenVertex], v: u32) -> DVec2 {
    let p = screen[v as usize].position;
    DVec2::new(p[0] as f64, p[1] as f64)
}

/// `x.floor()`, inline: on x86-64's baseline (no SSE4.1) `f64::floor` and `f64::ceil` are calls
/// into libm, about 1% of a pose fit's time from the walk of this stage (and the bands of
/// [`contour`]).
/// Exact (equal to `f64::floor`, up to the sign of a zero) for every `x`: below 2⁵² in magnitude through the
/// integer conversion, otherwise (already an integer, or not finite) through `f64::floor`.
#[inline]
fn floor(x: f64) -> f64 {
    if x.abs() < 4_503_599_627_370_496.0 {
        // Branch-free: whether the truncation rounded up is as often yes as no.
        let t = x as i64 as f64;
        t - (t > x) as u8 as f64
    } else {
        x.floor()
    }
}

/// `x.ceil()`, inline and exact, as [`floor`].
#[inline]
fn ceil(x: f64) -> f64 {
    -floor(-x)
}

/// The rank of candidate edge `e` among coincident edges: the lowest index of its faces with a
/// non-zero orientation (the faces that cover its inside; the topology lists an edge's faces in
/// increasing order, and a candidate has at least one). A stretch of `e` that lies on an edge of a
/// triangle `t < rank` on the same side is left to that triangle's edge; `e`'s own faces never
/// rank before it. Of two coincident edges `e1`, `e2` exactly one ranks first, and its lowest
/// covering face takes the stretch from the other.
fn coincident_rank(orientation: &[i8], topology: &Topology, e: u32) -> u32 {
    let faces = topology.edge_faces(e as usize);
    faces.iter().copied().find(|&f| orientation[f as usize] != 0).unwrap_or(u32::MAX)
}

/// One piece of a candidate edge: its part in one pixel with a non-zero incoming gradient.
#[derive(Clone, Copy, Debug)]
struct Segment {
    /// Parameter interval of the edge inside the pixel.
    s: (f64, f64),
    /// `∂L/∂I` of the pixel times `p1 − p0` (halved for a segment on a pixel border).
    g: f64,
}

/// The edge's endpoints, and whether it can contribute: a candidate (`inside != 0`) of non-zero
/// length.
fn edge_geometry(screen: &[ScreenVertex], edge: [u32; 2], inside: i32) -> Option<(DVec2, DVec2, DVec2)> {
    let (va, vb) = (position(screen, edge[0]), position(screen, edge[1]));
    let d = vb - va;
    if inside == 0 || d == DVec2::ZERO {
        return None;
    }
    // Outward normal times the edge length: the flux direction of ARCHITECTURE.md, *The method*.
    Some((va, vb, inside as f64 * DVec2::new(d.y, -d.x)))
}

/// Appends the segments of `va → vb` in the pixels it crosses with a non-zero `∂L/∂I`, in walk
/// order: the rows it spans, then the columns within each row, each clipped by Liang–Barsky.
fn edge_segments(params: &RasterParams, d_image: &[f32], va: DVec2, vb: DVec2, out: &mut Vec<Segment>) {
    let (w, h) = (params.width as f64, params.height as f64);
    let scale = (params.inside - params.outside) as f64;
    // Most candidates lie inside one pixel, off its borders: then the walk below finds one
    // segment, the whole edge (every clip leaves `(0, 1)`: the ends are strictly inside, and a
    // parameter whose exact value lies beyond 0 or 1 does not round inside), and it is found here.
    let (lo, hi) = (va.min(vb), va.max(vb));
    let (i, j) = (floor(lo.y), floor(lo.x));
    if lo.y > i && lo.x > j && hi.y < i + 1.0 && hi.x < j + 1.0 && i >= 0.0 && j >= 0.0 && i < h && j < w {
        let g = d_image[i as usize * params.width as usize + j as usize] as f64 * scale;
        if g != 0.0 {
            out.push(Segment { s: (0.0, 1.0), g });
        }
        return;
    }
    walk_segments(params, d_image, va, vb, out);
}

/// [`edge_segments`] by the walk: the rows the edge spans, then the columns within each row.
fn walk_segments(params: &RasterParams, d_image: &[f32], va: DVec2, vb: DVec2, out: &mut Vec<Segment>) {
    let d = vb - va;
    let (w, h) = (params.width as f64, params.height as f64);
    let scale = (params.inside - params.outside) as f64;
    let mut s = (0.0, 1.0);
    if !(clip_parameter(va.x, d.x, 0.0, w, &mut s) && clip_parameter(va.y, d.y, 0.0, h, &mut s)) {
        return;
    }
    let y_at = |t: f64| va.y + t * d.y;
    let (ylo, yhi) = (y_at(s.0).min(y_at(s.1)), y_at(s.0).max(y_at(s.1)));
    let rows = (ceil(ylo) as i64 - 1).max(0)..=(floor(yhi) as i64).min(params.height as i64 - 1);
    for i in rows {
        let mut r = s;
        if !clip_parameter(va.y, d.y, i as f64, i as f64 + 1.0, &mut r) {
            continue;
        }
        let x_at = |t: f64| va.x + t * d.x;
        let (xlo, xhi) = (x_at(r.0).min(x_at(r.1)), x_at(r.0).max(x_at(r.1)));
        let cols = (ceil(xlo) as i64 - 1).max(0)..=(floor(xhi) as i64).min(params.width as i64 - 1);
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
            out.push(Segment { s: c, g });
        }
    }
}

/// Sums the visible weights of an edge's segments (in walk order) into its slot.
fn accumulate(contour: &mut EdgeContour, outward: DVec2, segments: &[Segment]) -> (EdgeGrad, BackwardStats) {
    let mut stats = BackwardStats::default();
    let (mut wa, mut wb) = (0.0f64, 0.0f64);
    for segment in segments {
        stats.segments += 1;
        let (visible_a, visible_b) = contour.visible_weights(segment.s);
        if visible_a != 0.0 || visible_b != 0.0 {
            stats.visible_segments += 1;
        }
        wa += segment.g * visible_a;
        wb += segment.g * visible_b;
    }
    let (ga, gb) = (outward * wa, outward * wb);
    (EdgeGrad { a: [ga.x as f32, ga.y as f32], b: [gb.x as f32, gb.y as f32] }, stats)
}

/// Candidate edges per parallel task.
const EDGES_PER_TASK: usize = 64;

/// One task's buffers.
#[derive(Clone, Debug, Default)]
struct TaskScratch {
    /// The current edge's segments.
    segments: Vec<Segment>,
    /// The current edge's contour crossings.
    contour: EdgeContour,
}

/// The buffers of [`edge_grad`], kept from call to call (one per view in flight).
#[derive(Clone, Debug, Default)]
pub struct EdgeGradScratch {
    /// The view's contour edges by bands.
    bands: ContourBands,
    /// Each candidate's slot and statistics.
    results: Vec<(EdgeGrad, BackwardStats)>,
    /// Each task's buffers.
    tasks: Vec<TaskScratch>,
}

/// The gradient slot of every candidate edge: walks the pixels it crosses, keeps the visible
/// parts of its segments and applies the closed form. Where `∂L/∂I` is zero nothing is looked
/// up; a candidate with segments finds its visible parts from the view's contour
/// ([`contour::ContourBands`]: the sums of covering triangles just outside its start, and its crossings
/// with the contour edges near it) rather than from the triangles near it, which the WGSL stage
/// scans. The covered points are the same, so are the visible intervals (their end points come
/// from the crossing edge's line instead of a triangle's, which can move them by a rounding of
/// the last bit, far below the `f32` slots' precision).
///
/// Reads screen vertices, the face orientations (one per triangle, as
/// [`face_orientations`](super::edges::face_orientations) writes them), the candidates
/// `(edge, side)` of the `edges` stage and `∂L/∂I`; writes one [`EdgeGrad`] per candidate into
/// `slots` (same order). Each edge writes only its own slot: the result does not depend on the
/// thread count. `scratch` holds the buffers from call to call: a loop of backward passes
/// allocates only where a buffer must grow.
#[allow(clippy::too_many_arguments)]
pub fn edge_grad(
    params: &RasterParams,
    screen: &[ScreenVertex],
    orientation: &[i8],
    topology: &Topology,
    candidates: &[(u32, i32)],
    d_image: &[f32],
    slots: &mut Vec<EdgeGrad>,
    scratch: &mut EdgeGradScratch,
) -> BackwardStats {
    let EdgeGradScratch { bands, results, tasks: task_scratch } = scratch;
    let edges = topology.edges();
    bands.build(screen, orientation, topology, candidates, params.height);
    let bands = &*bands;
    let tasks = candidates.len().div_ceil(EDGES_PER_TASK);
    if task_scratch.len() < tasks {
        task_scratch.resize_with(tasks, Default::default);
    }
    results.clear();
    results.resize(candidates.len(), (EdgeGrad::default(), BackwardStats::default()));
    results
        .par_chunks_mut(EDGES_PER_TASK)
        .zip(candidates.par_chunks(EDGES_PER_TASK))
        .zip(&mut task_scratch[..tasks])
        .for_each(|((out, chunk), TaskScratch { segments, contour })| {
            for (result, &(e, side)) in out.iter_mut().zip(chunk) {
                let Some(geometry) = edge_geometry(screen, edges[e as usize], side) else { continue };
                segments.clear();
                edge_segments(params, d_image, geometry.0, geometry.1, segments);
                if segments.is_empty() {
                    continue;
                }
                let rank = coincident_rank(orientation, topology, e);
                bands.trace(screen, orientation, topology, e, geometry, rank, contour);
                *result = accumulate(contour, geometry.2, segments);
            }
        });
    slots.clear();
    slots.extend(results.iter().map(|r| r.0));
    results.iter().fold(BackwardStats::default(), |a, r| a + r.1)
}

pub mod contour;
#[cfg(test)]
mod tests;
